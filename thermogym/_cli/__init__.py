"""Sub-commands of the ``thermogym`` command line (one module each)."""
