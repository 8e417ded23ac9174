"""thermogym: identified thermal and electrothermal plants as Gymnasium environments."""

__version__ = "0.1.0"
