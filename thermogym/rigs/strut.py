"""Actuator-strut test rig (paper 000, section 4).

Protocols
---------
``steps``
    From a thermal steady state, the strut is moved periodically at a constant
    feed rate of 20, 25 or 30 m/min for 170, 125 and 80 min (the paper: "between
    80 and 170 minutes"), sampled every 140.9, 148.7 and 158.3 s (the sampling
    periods of section 4). As in the paper, the drive had not fully cooled down
    before the 25 m/min run (it starts 3 K above the air).

Concealed effects (``effect_defaults``, physically plausible magnitudes):
forced convection that triples the moving parts' air conductance at 20 m/min
(β = 2: at 0.33 m/s the convective coefficient of a moving steel surface is
2-3 × its free-convection value), so the steady temperatures barely grow with
the feed rate as the paper observed; a 10-minute offset between the feed-rate
log and the temperature logger (transport delay); a 20 kJ/K machine-frame
bracket bolted to the bearing housing (missing dynamics: ~45 kg of steel,
2 W/K contact); natural convection h ∝ ΔT^(1/3) (γ = 2); a 1.5 K draught or
air-conditioning cycle of 2 h the air sensor does not see; a thermocouple
in the nut flange lagging 300 s; a 1 K offset; losses growing 5 %/h.

Sensors: thermocouples σ = 0.05 K, resolution 0.01 K; the elongation by a
laser interferometer, σ = 0.5 µm (the paper notes it is costly to measure; the
rig provides it as ground truth for compensation studies).
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from thermogym.models.strut import STRUT_OUTPUTS
from thermogym.rigs._legacy import ModelRig
from thermogym.rigs.base import Protocol, RigRun
from thermogym.rigs.sensors import SensorSpec

__all__ = ["STEP_TESTS", "StrutRig"]

#: feed rate [m/min] -> (duration [min], sampling period [s]) (paper 000 section 4)
STEP_TESTS: dict[float, tuple[float, float]] = {
    20.0: (170.0, 140.9),
    25.0: (125.0, 148.7),
    30.0: (80.0, 158.3),
}
_UNITS = {"feed_rate": "m/min", "T_air": "°C", "dL_um": "µm", **{k: "°C" for k in STRUT_OUTPUTS}}
_ROLES = {
    "feed_rate": "input",
    "T_air": "disturbance",
    "dL_um": "output",
    **{k: "output" for k in STRUT_OUTPUTS},
}


class StrutRig(ModelRig):
    """Virtual actuator-strut test stand (paper 000, Fig. 4)."""

    name = "strut"
    model_name = "strut"
    sensors: ClassVar[dict[str, SensorSpec]] = {
        **{k: SensorSpec(0.05, 0.01) for k in (*STRUT_OUTPUTS, "T_air")},
        "dL_um": SensorSpec(0.5, 0.1),
    }
    supported_effects = (
        "input_dependent_heat_transfer",
        "input_nonlinearity",
        "nonlinear_heat_transfer",
        "transport_delay",
        "time_varying_parameter",
        "unmeasured_disturbance",
        "sensor_offset",
        "sensor_lag",
        "sensor_drift",
        "missing_dynamics",
    )
    effect_defaults: ClassVar[dict[str, dict[str, Any]]] = {
        "input_dependent_heat_transfer": {"beta_u": 2.0},
        "input_nonlinearity": {"alpha_u": 0.45},
        "nonlinear_heat_transfer": {"gamma_nl": 2.0},
        "transport_delay": {"signal": "feed_rate", "delay": 600.0},
        "time_varying_parameter": {"q_drift": 0.05},
        "unmeasured_disturbance": {"signal": "T_air", "amplitude": 1.5, "period": 7200.0},
        "sensor_offset": {"signal": "T_nut", "offset": 1.0},
        "sensor_lag": {"signal": "T_nut", "tau": 300.0},
        "sensor_drift": {"signal": "T_spindle", "rate": 0.3},
        "missing_dynamics": {"node": "bearing_housing", "C": 20000.0, "G": 2.0, "g_air": 0.5},
    }

    def step_test(
        self,
        feed_rate: float,
        rng: np.random.Generator,
        *,
        duration_min: float,
        period_s: float,
        T_air: float = 21.0,
        drive_warm_K: float = 0.0,
    ) -> RigRun:
        """One step test from a thermal steady state at ``feed_rate`` [m/min]."""
        n = round(duration_min * 60.0 / period_s) + 1
        t = period_s * np.arange(n)
        air = T_air + 0.3 * np.sin(2 * np.pi * t / (6 * 3600.0) + rng.uniform(0, 2 * np.pi))
        u = np.column_stack([np.full(n, float(feed_rate)), air])
        u[0, 0] = 0.0  # the first sample is taken at rest, the movement starts right after
        model, _ = self.plant()
        x0 = np.full(len(model.state_names), air[0])
        if drive_warm_K:
            # not fully cooled: the drive and its flange are still warm
            for node, f in (("drive", 1.0), ("motor_flange", 0.6)):
                x0[model.state_names.index(node)] += f * drive_warm_K
        out, _ = self.simulate_true(u, period_s, x0=x0, rng=rng)
        names = [*STRUT_OUTPUTS, "dL_um"]
        cols = {
            "feed_rate": u[:, 0].copy(),
            **self.measure({"T_air": air}, rng),
            **self.measure({k: out[k] for k in names}, rng),
        }
        meta = {
            "feed_rate_m_min": float(feed_rate),
            "period_s": period_s,
            "duration_min": duration_min,
        }
        return RigRun(
            f"strut-step-{feed_rate:g}",
            t,
            cols,
            dict(_UNITS),
            dict(_ROLES),
            meta,
            truth={k: out[k] for k in names},
        )


def _steps(
    rig: StrutRig, rng: np.random.Generator, *, feed_rates=(20.0, 25.0, 30.0), T_air: float = 21.0
) -> list[RigRun]:
    runs = []
    for v in feed_rates:
        duration, period = STEP_TESTS.get(float(v), (120.0, 150.0))
        runs.append(
            rig.step_test(
                float(v),
                rng,
                duration_min=duration,
                period_s=period,
                T_air=T_air,
                drive_warm_K=3.0 if float(v) == 25.0 else 0.0,
            )
        )
    return runs


StrutRig.protocols = {
    "steps": Protocol("steps", "feed-rate steps at 20, 25, 30 m/min (80-170 min)", _steps),
}
