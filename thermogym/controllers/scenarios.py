"""Named, versioned benchmark scenarios.

A scenario fixes the episode conditions of one or more environments (the
keyword arguments of ``gymnasium.make``), so that two benchmark runs with
the same scenario key (``name@version``) and seed run the same episodes.
Changing what a scenario means makes a new version; old versions stay
available so that published tables can be reproduced.

===================  =======================  ================================================
scenario             environments                 conditions
===================  =======================  ================================================
``default``          every environment        the environment's defaults
``winter-week``      AXT211Room               7 days from Monday 15 January (synthetic weather
                                              drawn per seed), 24 V
``shoulder-season``  AXT211Room               7 days from Monday 9 April (mild, sunny)
``setpoint-steps``   AXT211Valve              4 h, a random stroke level in 0.5-4 mm every
                                              20 min
``supply-19V``       AXT211Valve, AXT211Room  as setpoint-steps / winter-week at 19 V, the low
                                              end of the AXT211's 19-29 V (paper 002, sec. I)
``ambient-50C``      AXT211Valve              setpoint-steps at 50 °C ambient, the high end of
                                              0-50 °C (paper 002, section I)
``actuator-spread``  AXT211Valve, AXT211Room  setpoint-steps / winter-week on the virtual rig
                                              with one actuator specimen per seed, drawn from
                                              the manufacturing spread of paper 002 Fig. 8
                                              (:func:`thermogym.rigs.axt211.specimen_spread`)
===================  =======================  ================================================
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from thermogym.errors import ConfigError, UnknownNameError

__all__ = ["SCENARIOS", "Scenario", "get_scenario", "scenarios_for"]


@dataclass(frozen=True)
class Scenario:
    """Episode conditions of a benchmark.

    Attributes
    ----------
    name : str
        Scenario name.
    version : int
        Version; a changed meaning makes a new version.
    description : str
        One line.
    env_kwargs : mapping
        ``{environment name: keyword arguments}``; ``"*"`` applies to every
        environment.
    plant : str, optional
        ``"rig"`` forces the virtual rig (whatever plant the benchmark asks for).
    specimen_per_seed : bool
        On the rig, draw one actuator specimen per seed (``specimen_seed = seed``).
    """

    name: str
    version: int
    description: str
    env_kwargs: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    plant: str | None = None
    specimen_per_seed: bool = False

    @property
    def key(self) -> str:
        """``name@version``."""
        return f"{self.name}@{self.version}"

    def applies_to(self, env_name: str) -> bool:
        """Whether the scenario is defined for environment ``env_name``."""
        return "*" in self.env_kwargs or env_name in self.env_kwargs

    def kwargs(self, env_name: str, seed: int, plant: str = "model") -> dict[str, Any]:
        """Keyword arguments of ``gymnasium.make`` for an episode.

        Parameters
        ----------
        env_name : str
            Environment name (``"AXT211Room"``).
        seed : int
            Episode seed (selects the specimen with ``specimen_per_seed``).
        plant : {"model", "rig"}
            Plant asked for (overridden by :attr:`plant`).

        Raises
        ------
        ConfigError
            The scenario is not defined for the environment.
        """
        if not self.applies_to(env_name):
            raise ConfigError(
                f"scenario {self.key!r} is not defined for {env_name}; it is for "
                f"{sorted(self.env_kwargs)}"
            )
        out = dict(self.env_kwargs.get("*", {}))
        out.update(self.env_kwargs.get(env_name, {}))
        p = self.plant or plant
        if p not in ("model", "rig"):
            raise ConfigError(f"plant is {p!r}; expected 'model' or 'rig'")
        if p == "rig":
            out["plant"] = "rig"
            if self.specimen_per_seed:
                out["specimen_seed"] = int(seed)
        return out

    def plant_for(self, plant: str) -> str:
        """The plant an episode of this scenario runs on."""
        return self.plant or plant


_WINTER = {"start_day": 14, "episode_days": 7.0}  # Monday 15 January (day 0 is a Monday)
_SHOULDER = {"start_day": 98, "episode_days": 7.0}  # Monday 9 April
_STEPS = {
    "episode_s": 4 * 3600.0,
    "setpoint": "random",
    "setpoint_range": (0.5, 4.0),
    "setpoint_hold_s": 1200.0,
}

_LIST = [
    Scenario("default", 1, "the environment's defaults", {"*": {}}),
    Scenario(
        "winter-week", 1, "a January week, synthetic weather per seed", {"AXT211Room": _WINTER}
    ),
    Scenario("shoulder-season", 1, "an April week (mild, sunny)", {"AXT211Room": _SHOULDER}),
    Scenario(
        "setpoint-steps",
        1,
        "4 h of random stroke set-points (0.5-4 mm, 20 min each)",
        {"AXT211Valve": _STEPS},
    ),
    Scenario(
        "supply-19V",
        1,
        "actuator supply at 19 V (low end of 19-29 V)",
        {"AXT211Valve": {**_STEPS, "supply_V": 19.0}, "AXT211Room": {**_WINTER, "supply_V": 19.0}},
    ),
    Scenario(
        "ambient-50C",
        1,
        "actuator ambient at 50 °C (high end of 0-50 °C)",
        {"AXT211Valve": {**_STEPS, "ambient_C": 50.0}},
    ),
    Scenario(
        "actuator-spread",
        1,
        "virtual rig, one actuator specimen per seed (paper 002 Fig. 8 spread)",
        {"AXT211Valve": _STEPS, "AXT211Room": _WINTER},
        plant="rig",
        specimen_per_seed=True,
    ),
]
#: Scenarios by key (``name@version``) and by name (its latest version).
SCENARIOS: dict[str, Scenario] = {}
for _s in _LIST:
    SCENARIOS[_s.key] = _s
for _s in sorted(_LIST, key=lambda s: s.version):
    SCENARIOS[_s.name] = _s


def get_scenario(name: str | Scenario) -> Scenario:
    """A scenario by ``name`` (latest version) or ``name@version``.

    Examples
    --------
    >>> s = get_scenario("winter-week")
    >>> s.key, s.kwargs("AXT211Room", seed=0)["start_day"]
    ('winter-week@1', 14)
    >>> get_scenario("actuator-spread").kwargs("AXT211Valve", seed=3)["specimen_seed"]
    3
    """
    if isinstance(name, Scenario):
        return name
    try:
        return SCENARIOS[name]
    except KeyError:
        names = sorted({s.name for s in SCENARIOS.values()})
        raise UnknownNameError(f"no scenario {name!r}; scenarios are {names}") from None


def scenarios_for(env_name: str) -> list[str]:
    """Names of the scenarios defined for an environment (``default`` first)."""
    seen: list[str] = []
    for s in _LIST:
        if s.applies_to(env_name) and s.name not in seen:
            seen.append(s.name)
    return seen
