"""thermogym: identified thermal and electrothermal plants as Gymnasium environments.

``import thermogym`` registers the environments (``thermogym/TCLab-v0``, ...)
with Gymnasium, as gym-electric-motor and Sinergym do, so that
``gymnasium.make("thermogym/...")`` works after the package's own import.
Registration names entry points only (strings): an environment's module loads
when it is made. The table of IDs lives here, at the bottom of the package, so
that registering needs no other part of it (:mod:`thermogym.envs` documents
the environments and registers the same table).
"""

from gymnasium.envs.registration import register as _register
from gymnasium.envs.registration import registry as _registry

__version__ = "0.1.0"

#: Registered environment ID -> (module under thermogym.envs, class, vector class).
ENVIRONMENTS: dict[str, tuple[str, str, str]] = {
    "thermogym/AXT211Valve-v0": ("axt211_valve", "AXT211ValveEnv", "AXT211ValveVectorEnv"),
    "thermogym/AXT211Room-v0": ("axt211_room", "AXT211RoomEnv", "AXT211RoomVectorEnv"),
    "thermogym/SpindleThermal-v0": ("spindle", "SpindleThermalEnv", "SpindleThermalVectorEnv"),
    "thermogym/StrutThermal-v0": ("strut", "StrutThermalEnv", "StrutThermalVectorEnv"),
    "thermogym/TCLab-v0": ("tclab", "TCLabEnv", "TCLabVectorEnv"),
    "thermogym/IdentifiedPlant-v0": ("identified", "make_env", "make_vector_env"),
}


def register_environments() -> None:
    """Register every ID of :data:`ENVIRONMENTS` with Gymnasium (idempotent)."""
    for env_id, (module, single, vector) in ENVIRONMENTS.items():
        if env_id not in _registry:
            _register(
                id=env_id,
                entry_point=f"thermogym.envs.{module}:{single}",
                vector_entry_point=f"thermogym.envs.{module}:{vector}",
            )


register_environments()
