"""AXT211 test rig: climate chamber, LVDT, thermocouples, power meter (paper 002, section IV).

Protocols
---------
``steps``
    Power on for 30 min, off for 60 min, at supply voltages 19, 24, 29 V and
    chamber temperatures 0, 25, 50 °C (the valid ranges of section I).
``pwm``
    The input of section VIII: step 0 → 1 for 1 h, then PWM with 50 % duty at
    high frequency for 2 h, medium for 1.5 h, low for 1.5 h. The paper does not
    give the frequencies; periods of 10 s, 2 min and 20 min are used here (the
    low one is the "on-off operation" the manufacturer recommends).
``spread``
    The ``pwm`` input applied to 15 actuators from three production dates
    (section VIII, Fig. 8), each with its own parameters drawn from the
    manufacturing spread below.
``staircase``
    Closed-loop control of the wax temperature through set-points 52 → 70 °C in
    2 °C steps every 30 min, then back down (section VI-C, Fig. 3): shows the
    stroke gain and the backlash.

Sensors: LVDT stroke σ = 5 µm; thermocouples σ = 0.1 K; power σ = 10 mW,
resistance σ = 0.5 Ω (from voltage and current); supply σ = 20 mV. Sampling 1 s.

Concealed effects (``effect_defaults``; magnitudes chosen to be physically
plausible): a play of 0.25 mm in the rod coupling (5.5 % of the 4.5 mm
stroke; the paper's Fig. 3 shows visible hysteresis); 500 J of latent heat
melting around 57 °C (about 2.5 g of paraffin at ~200 J/g); a 15 Ω source
resistance (an undersized 24 V transformer shared by several actuators plus
the cable); natural convection of the housing with h ∝ ΔT^0.25 (laminar);
a thermocouple lagging 45 s behind the cartridge; a 1.5 K thermocouple offset
(type K class 2 allows ±2.5 K).

Manufacturing spread (chosen here to give the spread the paper describes:
large at high and medium PWM frequency, small for on-off operation): start
temperature T_P0 ± 1 K, gain coefficients ± 8 %, cartridge capacity ± 5 %,
mechanical lag ± 15 %, backlash 0.05-0.2 mm; production dates shift T_P0 by up
to ± 0.7 K.
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from thermogym.rigs._legacy import ModelRig
from thermogym.rigs.base import Protocol, RigRun
from thermogym.rigs.sensors import SensorSpec

__all__ = ["AXT211Rig", "pwm_profile"]

_RECORDED_OUT = ("P_PTC", "R_PTC", "T_P", "T_G", "x_V")
_UNITS = {
    "u": "1",
    "k_U": "V",
    "T_U": "°C",
    "P_PTC": "W",
    "R_PTC": "Ohm",
    "T_P": "°C",
    "T_G": "°C",
    "x_V": "mm",
    "x_P": "mm",
}
_ROLES = {
    "u": "input",
    "k_U": "disturbance",
    "T_U": "disturbance",
    **{k: "output" for k in _RECORDED_OUT},
}


def pwm_profile(t: np.ndarray, period: float, duty: float = 0.5) -> np.ndarray:
    """On/off signal with the given period [s] and duty cycle, starting on.

    Examples
    --------
    >>> pwm_profile(np.arange(6.0), period=4.0).tolist()
    [1.0, 1.0, 0.0, 0.0, 1.0, 1.0]
    """
    return ((np.mod(t, period) / period) < duty).astype(float)


class AXT211Rig(ModelRig):
    """Virtual AXT211 test bench (paper 002)."""

    name = "axt211"
    model_name = "axt211"
    sensors: ClassVar[dict[str, SensorSpec]] = {
        "P_PTC": SensorSpec(0.01, 0.001),
        "R_PTC": SensorSpec(0.5, 0.01),
        "T_P": SensorSpec(0.1, 0.01),
        "T_G": SensorSpec(0.1, 0.01),
        "x_V": SensorSpec(0.005, 0.001),
        "k_U": SensorSpec(0.02, 0.01),
        "T_U": SensorSpec(0.1, 0.01),
    }
    supported_effects = (
        "backlash",
        "phase_change",
        "supply_variation",
        "nonlinear_heat_transfer",
        "sensor_lag",
        "sensor_offset",
        "sensor_drift",
        "unmeasured_disturbance",
        "time_varying_parameter",
        "transport_delay",
    )
    # Concealed-effect magnitudes (physically plausible, see the module docstring).
    effect_defaults: ClassVar[dict[str, dict[str, Any]]] = {
        "backlash": {"c_backlash": 0.25},
        "phase_change": {"L_melt": 500.0, "T_melt": 57.0, "w_melt": 2.0},
        "supply_variation": {"R_source": 15.0},
        "nonlinear_heat_transfer": {"n_conv": 0.25},
        "sensor_lag": {"signal": "T_P", "tau": 45.0},
        "sensor_offset": {"signal": "T_P", "offset": 1.5},
        "sensor_drift": {"signal": "T_P", "rate": 0.5},
        "unmeasured_disturbance": {"signal": "T_U", "amplitude": 3.0, "period": 3600.0},
        "time_varying_parameter": {"name": "lambda_GU", "rate": 0.1},
        "transport_delay": {"signal": "u", "delay": 20.0},
    }

    def record(
        self,
        experiment_id: str,
        u: np.ndarray,
        dt: float,
        rng: np.random.Generator,
        meta: dict[str, Any],
    ) -> RigRun:
        """Simulate an open-loop input ``u`` (T, 3) and return the measured run."""
        out, _ = self.simulate_true(u, dt, rng=rng)
        t = dt * np.arange(u.shape[0])
        measured = self.measure({k: out[k] for k in _RECORDED_OUT}, rng)
        exo = self.measure({"k_U": u[:, 1], "T_U": u[:, 2]}, rng)
        cols = {"u": u[:, 0].copy(), **exo, **measured}
        return RigRun(
            experiment_id,
            t,
            cols,
            dict(_UNITS),
            dict(_ROLES),
            dict(meta),
            truth={k: v for k, v in out.items()},
        )


def _steps(
    rig: AXT211Rig,
    rng: np.random.Generator,
    *,
    voltages=(19.0, 24.0, 29.0),
    ambients=(0.0, 25.0, 50.0),
    on_s: float = 1800.0,
    off_s: float = 3600.0,
    dt: float = 1.0,
) -> list[RigRun]:
    runs = []
    for kU in voltages:
        for TU in ambients:
            n_on, n = int(on_s / dt), int((on_s + off_s) / dt)
            u = np.zeros((n, 3))
            u[:n_on, 0] = 1.0
            u[:, 1] = kU
            u[:, 2] = TU
            runs.append(
                rig.record(
                    f"axt211-step-{kU:g}V-{TU:g}C",
                    u,
                    dt,
                    rng,
                    {"supply_V": kU, "ambient_C": TU, "on_s": on_s},
                )
            )
    return runs


def _pwm_input(dt: float, periods: tuple[float, float, float], kU: float, TU: float) -> np.ndarray:
    t = dt * np.arange(int(6 * 3600 / dt))
    u = np.zeros((t.size, 3))
    h = t / 3600.0
    u[:, 0] = np.where(h <= 1, 1.0, 0.0)
    for (a, b), period in zip(((1, 3), (3, 4.5), (4.5, 6.0)), periods, strict=True):
        sel = (h > a) & (h <= b)
        u[sel, 0] = pwm_profile(t[sel] - a * 3600.0, period)
    u[:, 1] = kU
    u[:, 2] = TU
    return u


def _pwm(
    rig: AXT211Rig,
    rng: np.random.Generator,
    *,
    periods=(10.0, 120.0, 1200.0),
    supply_V: float = 24.0,
    ambient_C: float = 25.0,
    dt: float = 1.0,
) -> list[RigRun]:
    u = _pwm_input(dt, tuple(periods), supply_V, ambient_C)
    return [
        rig.record(
            "axt211-pwm",
            u,
            dt,
            rng,
            {"periods_s": list(periods), "duty": 0.5, "supply_V": supply_V, "ambient_C": ambient_C},
        )
    ]


def specimen_spread(
    rng: np.random.Generator, n: int = 15, dates: int = 3
) -> list[dict[str, float]]:
    """Parameter overrides of ``n`` actuators from ``dates`` production dates.

    Nominal values are multiplied (or shifted) by draws that reproduce the
    spread described in paper 002 section VIII (see the module docstring).
    """
    from thermogym.models.axt211 import AXT211

    nom = dict(zip(AXT211().param_names, AXT211().nominal, strict=True))
    date_shift = rng.uniform(-0.7, 0.7, dates)
    out = []
    for i in range(n):
        g = 1.0 + 0.08 * rng.standard_normal()
        out.append(
            {
                "T_P0": nom["T_P0"] + date_shift[i % dates] + rng.normal(0.0, 1.0),
                "kP_b": nom["kP_b"] * g,
                "kP_c": nom["kP_c"] * g,
                "C_P": nom["C_P"] * (1.0 + 0.05 * rng.standard_normal()),
                "tau_P": nom["tau_P"] * (1.0 + 0.15 * rng.standard_normal()),
                "c_backlash": float(rng.uniform(0.05, 0.2)),
            }
        )
    return out


def _spread(
    rig: AXT211Rig,
    rng: np.random.Generator,
    *,
    n: int = 15,
    periods=(10.0, 120.0, 1200.0),
    dt: float = 1.0,
) -> list[RigRun]:
    u = _pwm_input(dt, tuple(periods), 24.0, 25.0)
    runs = []
    for i, spec in enumerate(specimen_spread(rng, n)):
        runs.append(
            rig.with_specimen(spec).record(  # type: ignore[attr-defined]
                f"axt211-spread-{i + 1:02d}",
                u,
                dt,
                rng,
                {"specimen": i + 1, "production_date": i % 3 + 1, "periods_s": list(periods)},
            )
        )
    return runs


def _staircase(
    rig: AXT211Rig,
    rng: np.random.Generator,
    *,
    low: float = 52.0,
    high: float = 70.0,
    step: float = 2.0,
    hold_s: float = 1800.0,
    supply_V: float = 24.0,
    ambient_C: float = 25.0,
    dt: float = 1.0,
) -> list[RigRun]:
    up = np.arange(low, high + 1e-9, step)
    levels = np.concatenate([up, up[-2::-1]])
    n_hold = int(hold_s / dt)
    sp = np.repeat(levels, n_hold)
    n = sp.size
    model, overrides = rig.plant()
    th = model.theta(overrides)
    x = model.initial_state(th, np.array([[0.0, supply_V, ambient_C]]))
    ys = np.empty((n, len(model.output_names)))
    u = np.zeros((n, 3))
    u[:, 1] = supply_V
    u[:, 2] = ambient_C
    # PI on the measured wax temperature; the output is the heating-power fraction,
    # turned into u by u = sqrt(fraction) because P ∝ u² (15).
    kp, ti, integ = 0.15, 300.0, 0.0
    iT = model.output_names.index("T_P")
    for k in range(n):
        T_meas = model._output(x, u[k : k + 1], th)[0, iT]
        e = sp[k] - (T_meas + rig.sensors["T_P"].noise * rng.standard_normal())
        raw = kp * e + integ
        frac = min(max(raw, 0.0), 1.0)
        if raw == frac:  # anti-windup: integrate only while unsaturated
            integ += kp * dt / ti * e
        u[k, 0] = np.sqrt(frac)
        # the outputs of sample k (the PTC power included) with the input applied at k
        ys[k] = model._output(x, u[k : k + 1], th)[0]
        x = model._step(x, u[k : k + 1], th, dt)
    out = {name: ys[:, i] for i, name in enumerate(model.output_names)}
    t = dt * np.arange(n)
    measured = rig.measure({k: out[k] for k in _RECORDED_OUT}, rng)
    exo = rig.measure({"k_U": u[:, 1], "T_U": u[:, 2]}, rng)
    cols = {"u": u[:, 0], **exo, **measured, "T_P_setpoint": sp.astype(float)}
    units = {**_UNITS, "T_P_setpoint": "°C"}
    roles = {**_ROLES, "T_P_setpoint": "disturbance"}
    meta = {
        "levels_C": levels.tolist(),
        "hold_s": hold_s,
        "supply_V": supply_V,
        "ambient_C": ambient_C,
    }
    return [RigRun("axt211-staircase", t, cols, units, roles, meta, truth=out)]


AXT211Rig.protocols = {
    "steps": Protocol("steps", "power on/off steps at 19-29 V and 0-50 °C", _steps),
    "pwm": Protocol("pwm", "step then PWM at high, medium and low frequency (50 % duty)", _pwm),
    "spread": Protocol("spread", "the PWM input on 15 actuators of 3 production dates", _spread),
    "staircase": Protocol(
        "staircase", "closed-loop wax temperature staircase 52-70-52 °C", _staircase
    ),
}
