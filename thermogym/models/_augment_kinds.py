"""The augmentations of :class:`~thermogym.models.augmented.AugmentedModel`, one class each.

Each augmentation is an effect of the vocabulary in one physically allowed
*form*, written around a base model it cannot see inside. It acts on one of
four sides:

``input``
    transforms an exogenous column before the base model (dead time, static
    maps, play, a modulated supply, a disturbance added to a port, a lag);
``loop``
    adds a heat-flow term to a *port* (the ambient temperature input, or the
    heat input) computed from the base model's output: an extra conductance
    that grows with the temperature difference, with an input, with time, a
    heat capacity coupled to the output node, latent heat. The whole
    trajectory is found by waveform relaxation (module
    :mod:`thermogym.models.augmented`); stepping feeds the term back sample by
    sample;
``plant``
    transforms the base output (static, legacy forms; a parallel path);
``sensor``
    transforms what the sensor reads (lag, offset, drift, dead time).

The augmentation classes are in four modules, one a side:
:mod:`~thermogym.models._augment_input`, :mod:`~thermogym.models._augment_loop`,
:mod:`~thermogym.models._augment_plant` and :mod:`~thermogym.models._augment_sensor`,
on the common ground of :mod:`~thermogym.models._augment_base` (parameters,
per-recording courses). This module indexes them: :data:`KINDS`, :func:`kind_of`.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from thermogym.errors import ConfigError
from thermogym.models._augment_base import LOCAL, _Aug
from thermogym.models._augment_input import (
    _Delay,
    _Disturbance,
    _DisturbanceForm,
    _InputLag,
    _InputMap,
    _InputPlay,
    _Supply,
)
from thermogym.models._augment_loop import (
    _ExtraNode,
    _ForcedLoss,
    _Latent,
    _NonlinearLoss,
    _VaryingLoss,
)
from thermogym.models._augment_plant import (
    RESIDUAL_TERMS,
    _OutputPlay,
    _ParallelPath,
    _ResidualODE,
    _Saturating,
    _StaticDrift,
    _StaticForced,
)
from thermogym.models._augment_sensor import (
    _Lag,
    _Offset,
    _OutputDelay,
    _SensorDrift,
    _SensorWander,
)

__all__ = ["AUGMENTATIONS", "KINDS", "LOCAL", "RESIDUAL_TERMS", "kind_of"]

#: Augmentation effects in application order, with their side (legacy forms).
AUGMENTATIONS: dict[str, str] = {
    "transport_delay": "input",
    "unmeasured_disturbance": "input",
    "input_nonlinearity": "input",
    "backlash": "plant",
    "supply_variation": "input",
    "missing_dynamics": "plant",
    "residual_ode": "plant",
    "input_dependent_heat_transfer": "plant",
    "nonlinear_heat_transfer": "plant",
    "time_varying_parameter": "plant",
    "phase_change": "loop",
    "sensor_lag": "sensor",
    "sensor_offset": "sensor",
    "sensor_drift": "sensor",
}


#: (effect, form) → class; form ``""`` is the effect's legacy (or only) form.
KINDS: dict[tuple[str, str], type[_Aug]] = {
    ("transport_delay", ""): _Delay,
    ("transport_delay", "input"): _Delay,
    ("transport_delay", "output"): _OutputDelay,
    ("unmeasured_disturbance", ""): _Disturbance,
    ("unmeasured_disturbance", "periodic"): _DisturbanceForm,
    ("unmeasured_disturbance", "steps"): _DisturbanceForm,
    ("unmeasured_disturbance", "smooth"): _DisturbanceForm,
    ("unmeasured_disturbance", "events"): _DisturbanceForm,
    ("supply_variation", "steps"): _Supply,
    ("supply_variation", "smooth"): _Supply,
    ("supply_variation", "ramp"): _Supply,
    ("supply_variation", ""): _Supply,
    ("input_nonlinearity", ""): _InputMap,
    ("input_nonlinearity", "power"): _InputMap,
    ("input_nonlinearity", "saturation"): _InputMap,
    ("input_nonlinearity", "limit"): _InputMap,
    ("input_nonlinearity", "dead_zone"): _InputMap,
    ("input_nonlinearity", "piecewise_linear"): _InputMap,
    ("backlash", ""): _OutputPlay,
    ("backlash", "output"): _OutputPlay,
    ("backlash", "input"): _InputPlay,
    ("missing_dynamics", ""): _ParallelPath,
    ("missing_dynamics", "parallel"): _ParallelPath,
    ("missing_dynamics", "input_lag"): _InputLag,
    ("missing_dynamics", "extra_node"): _ExtraNode,
    ("residual_ode", ""): _ResidualODE,
    ("input_dependent_heat_transfer", ""): _StaticForced,
    ("input_dependent_heat_transfer", "power"): _ForcedLoss,
    ("nonlinear_heat_transfer", ""): _Saturating,
    ("nonlinear_heat_transfer", "radiation"): _NonlinearLoss,
    ("nonlinear_heat_transfer", "convection"): _NonlinearLoss,
    ("time_varying_parameter", ""): _StaticDrift,
    ("time_varying_parameter", "ramp"): _VaryingLoss,
    ("time_varying_parameter", "step"): _VaryingLoss,
    ("time_varying_parameter", "random_walk"): _VaryingLoss,
    ("phase_change", ""): _Latent,
    ("phase_change", "latent_heat"): _Latent,
    ("sensor_lag", ""): _Lag,
    ("sensor_offset", ""): _Offset,
    ("sensor_drift", ""): _SensorDrift,
    ("sensor_drift", "wander"): _SensorWander,
}


def kind_of(spec: Mapping[str, Any]) -> type[_Aug]:
    """The augmentation class of a spec ``{"effect": ..., "form": ...}``.

    Raises
    ------
    ConfigError
        Unknown effect or form (the message lists what exists).
    """
    effect = str(spec.get("effect"))
    form = str(spec.get("form", ""))
    kind = KINDS.get((effect, form))
    if kind is None:
        forms = sorted({f for e, f in KINDS if e == effect and f})
        if not forms and (effect, "") not in KINDS:
            raise ConfigError(
                f"augmentation effect {effect!r}; augmentations are "
                f"{sorted({e for e, _ in KINDS})} (effects a plant includes itself go into "
                "base_config)"
            )
        raise ConfigError(f"{effect} form {form!r}; its forms are {forms}")
    return kind
