"""The effect vocabulary: stable names for what a model can be missing.

Shared by the virtual rigs (which can carry effects), the diagnosis (which
names them) and the benchmark suites (which score the names). DESIGN.md fixes
the rule: the vocabulary is extended, never renamed.

Examples
--------
>>> "parameter_error" in EFFECT_NAMES
True
>>> EFFECT_NAMES[0]
'none'
"""

from __future__ import annotations

__all__ = ["EFFECT_DESCRIPTIONS", "EFFECT_NAMES", "PHYSICS_EFFECTS"]

#: One line per effect: what it means physically.
EFFECT_DESCRIPTIONS: dict[str, str] = {
    "none": "the model explains the recordings within their noise",
    "parameter_error": "the model's own parameters are off; no physics is missing",
    "transport_delay": "an input reaches the plant after a dead time",
    "sensor_lag": "a sensor responds to its signal through a first-order lag",
    "sensor_offset": "a sensor reads a constant offset",
    "sensor_drift": "a sensor's reading drifts slowly with time",
    "unmeasured_disturbance": "an exogenous heat flow or temperature is not recorded",
    "input_nonlinearity": "an input acts on the plant through a static nonlinear map",
    "input_dependent_heat_transfer": "a heat-transfer coefficient changes with an input",
    "nonlinear_heat_transfer": "heat transfer is not linear in temperature difference",
    "backlash": "a mechanical transmission has play",
    "phase_change": "a material melts or solidifies, storing latent heat",
    "supply_variation": "the supply (voltage, flow) differs from its recorded value",
    "missing_dynamics": "a state (heat capacity, node) the model lacks",
    "time_varying_parameter": "a parameter of the plant changes during the recording",
}

#: The vocabulary of DESIGN.md, in its order (stable names; extend, never rename).
EFFECT_NAMES: tuple[str, ...] = tuple(EFFECT_DESCRIPTIONS)

#: The names that mean physics missing from the model (all but none and parameter_error).
PHYSICS_EFFECTS: tuple[str, ...] = tuple(
    n for n in EFFECT_NAMES if n not in ("none", "parameter_error")
)
