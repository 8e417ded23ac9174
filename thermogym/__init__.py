"""thermogym: identified thermal and electrothermal plants as Gymnasium environments.

``import thermogym`` registers the environments (``thermogym/TCLab-v0``, ...)
with Gymnasium, as gym-electric-motor and Sinergym do, so that
``gymnasium.make("thermogym/...")`` works after the package's own import.
Registration names entry points only; an environment's module loads when it
is made.
"""

__version__ = "0.1.0"

import thermogym.envs as _envs  # noqa: E402  (registers the environment IDs)

del _envs
