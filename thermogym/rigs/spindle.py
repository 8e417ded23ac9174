"""Spindle run-in rig with two multiplexed RTD modules (paper 001, sections 2.1-2.3).

Protocols
---------
``run-in``
    Table 4: one run a day at 4000, 5000, 6000, 7000 and 8000 rpm, two folds
    each. The spindle runs at constant speed until its temperatures change by
    less than 1 °C over 3 consecutive hours (judged on the rise above ambient,
    so that the daily swing of the room does not mask the spindle's own
    settling), is then stopped, and cools until the day (24 h) is over.
``validation``
    Section 3.2: the same protocol at 4500, 5300 and 7800 rpm.

Sensors (section 2.1): two TSWTM modules, each an AD7794 converting one
channel at a time at 4.17 Hz through a multiplexer. Module 1 reads bearings A,
B, C, D and the inner housing; module 2 the rear and front outer housing and
the ambient. Channel samples are therefore asynchronous (NaN in the other
columns of a row) and uneven (clock drift and jitter); RTD noise 0.02 K
(accuracy ±0.05 K at 25 °C, Table 2), resolution 1 mK. A few outliers (device
glitches and open-circuit readings) and short Bluetooth drop-outs are included,
as the paper's data-preparation stage expects (section 2.3.1). The spindle
speed is logged by the motor controller at 1 Hz.

The room temperature follows a daily cycle (Fig. 5) with a slow random
wander; each run starts at 08:00.

Concealed effects (``effect_defaults``, physically plausible magnitudes):
bearing friction power growing as speed^1.6 (Palmgren: friction torque ∝
(ν n)^(2/3), so P ∝ n^(5/3)); rotating parts' air conductance growing 2.5×
at 6000 rpm (forced convection); a 2 K, 5 h machine-hall air-conditioning
cycle the ambient sensor does not see; a 1 K offset of the front outer-housing
RTD (0.4 Ω of uncompensated 2-wire lead resistance); that RTD in a magnetic
holder lagging 600 s; a 60 kJ/K headstock casting bolted to the front outer
housing (missing dynamics); a 10-minute offset between the speed log and the
sensor module's clock.
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from thermogym.models.spindle import SPINDLE_OUTPUTS
from thermogym.rigs._legacy import ModelRig
from thermogym.rigs.base import Protocol, RigRun
from thermogym.rigs.sensors import SensorSpec

__all__ = ["MODULES", "SpindleRig", "ambient_profile"]

#: Channels of each TSWTM module, in multiplexer order.
MODULES: tuple[tuple[str, ...], ...] = (
    (
        "T_rear_bearing_A",
        "T_rear_bearing_B",
        "T_front_bearing_C",
        "T_front_bearing_D",
        "T_inner_housing",
    ),
    ("T_rear_outer_housing", "T_front_outer_housing", "T_amb"),
)
CONVERSION_HZ = 4.17
_UNITS = {"speed": "rpm", "T_amb": "°C", **{k: "°C" for k in SPINDLE_OUTPUTS}}
_ROLES = {"speed": "input", "T_amb": "disturbance", **{k: "output" for k in SPINDLE_OUTPUTS}}


def ambient_profile(
    t: np.ndarray,
    rng: np.random.Generator,
    *,
    start_clock_h: float = 8.0,
    mean: float = 24.0,
    swing: float = 1.5,
) -> np.ndarray:
    """Room temperature over a day: a daily cycle peaking mid-afternoon plus a slow wander.

    Parameters
    ----------
    t : ndarray
        Time since the start of the run [s] (uniform grid).
    rng : Generator
    start_clock_h : float
        Clock time of ``t = 0`` [h].
    mean, swing : float
        Daily mean and amplitude [°C].
    """
    clock = start_clock_h + t / 3600.0
    daily = swing * np.sin(2 * np.pi * (clock - 9.0) / 24.0)
    # slow wander: random walk smoothed over ~1 h
    step = rng.standard_normal(t.size) * 0.004
    walk = np.cumsum(step)
    k = max(1, int(3600.0 / max(t[1] - t[0], 1e-9)) if t.size > 1 else 1)
    kernel = np.ones(k) / k
    walk = np.convolve(np.pad(walk, (k // 2, k - 1 - k // 2), mode="edge"), kernel, "valid")
    return mean + rng.uniform(-1.0, 1.0) + daily + walk - walk[0]


class SpindleRig(ModelRig):
    """Virtual spindle run-in system (paper 001, Fig. 3b)."""

    name = "spindle"
    model_name = "spindle"
    sensors: ClassVar[dict[str, SensorSpec]] = {
        k: SensorSpec(0.02, 0.001) for k in (*SPINDLE_OUTPUTS, "T_amb")
    }
    supported_effects = (
        "input_nonlinearity",
        "input_dependent_heat_transfer",
        "nonlinear_heat_transfer",
        "time_varying_parameter",
        "unmeasured_disturbance",
        "sensor_offset",
        "sensor_lag",
        "sensor_drift",
        "transport_delay",
        "missing_dynamics",
    )
    effect_defaults: ClassVar[dict[str, dict[str, Any]]] = {
        "input_nonlinearity": {"alpha_u": 1.6},
        "input_dependent_heat_transfer": {"beta_u": 1.5},
        "nonlinear_heat_transfer": {"gamma_nl": 2.0},
        "time_varying_parameter": {"q_drift": 0.04},
        "unmeasured_disturbance": {"signal": "T_amb", "amplitude": 2.0, "period": 5 * 3600.0},
        "sensor_offset": {"signal": "T_front_outer_housing", "offset": 1.0},
        "sensor_lag": {"signal": "T_front_outer_housing", "tau": 600.0},
        "sensor_drift": {"signal": "T_inner_housing", "rate": 0.15},
        "transport_delay": {"signal": "speed", "delay": 600.0},
        "missing_dynamics": {"node": "outer_front", "C": 60000.0, "G": 4.0, "g_air": 1.0},
    }

    def day(
        self,
        experiment_id: str,
        speed: float,
        rng: np.random.Generator,
        *,
        duration_h: float = 24.0,
        max_run_h: float = 20.0,
        window_h: float = 3.0,
        settle_K: float = 1.0,
        raw: bool = True,
        meta: dict[str, Any] | None = None,
    ) -> RigRun:
        """One run-in day at constant ``speed`` [rpm]: heat until settled, then cool."""
        dt = 1.0
        n = int(duration_h * 3600 / dt)
        t = dt * np.arange(n)
        T_amb = ambient_profile(t, rng)
        u = np.column_stack([np.full(n, float(speed)), T_amb])
        out, _ = self.simulate_true(u, dt, rng=rng)
        rise = np.column_stack([out[k] for k in SPINDLE_OUTPUTS]) - T_amb[:, None]
        w = int(window_h * 3600 / dt)
        change = np.abs(rise[w:] - rise[:-w]).max(axis=1)
        settled = np.nonzero(change < settle_K)[0]
        k_stop = int(min(settled[0] + w if settled.size else n, max_run_h * 3600 / dt))
        u[k_stop:, 0] = 0.0
        out, _ = self.simulate_true(u, dt, rng=rng)
        meta = {"speed_rpm": float(speed), "stop_s": float(k_stop * dt), **(meta or {})}
        truth = {k: out[k] for k in SPINDLE_OUTPUTS} | {"T_amb": T_amb, "speed": u[:, 0]}
        if not raw:
            cols = {
                "speed": u[:, 0].copy(),
                **self.measure({"T_amb": T_amb}, rng),
                **self.measure({k: out[k] for k in SPINDLE_OUTPUTS}, rng),
            }
            return RigRun(experiment_id, t, cols, dict(_UNITS), dict(_ROLES), meta, truth)
        return self._raw(experiment_id, t, u[:, 0], {**out, "T_amb": T_amb}, rng, meta, truth)

    def _raw(
        self,
        experiment_id: str,
        t: np.ndarray,
        speed: np.ndarray,
        values: dict[str, np.ndarray],
        rng: np.random.Generator,
        meta: dict[str, Any],
        truth: dict[str, np.ndarray],
    ) -> RigRun:
        """Asynchronous multiplexed sampling with outliers and drop-outs."""
        t_end = t[-1]
        times, chans, vals = [], [], []
        channels = [c for module in MODULES for c in module]
        for module in MODULES:
            period = (1.0 / CONVERSION_HZ) * (1.0 + rng.normal(0.0, 2e-4))  # clock tolerance
            k = np.arange(int(t_end / period))
            tk = rng.uniform(0.0, period) + k * period + rng.normal(0.0, 0.002, k.size)
            tk = np.clip(tk, 0.0, t_end)
            ch = k % len(module)
            keep = np.ones(k.size, dtype=bool)
            for _ in range(rng.integers(2, 5)):  # Bluetooth drop-outs of 5-40 s
                a = rng.uniform(0.05, 0.95) * t_end
                keep &= ~((tk >= a) & (tk < a + rng.uniform(5.0, 40.0)))
            tk, ch = tk[keep], ch[keep]
            for j, name in enumerate(module):
                sel = ch == j
                true = np.interp(tk[sel], t, values[name])
                meas = self.sensors[name].measure(true, rng)
                times.append(tk[sel])
                chans.append(np.full(sel.sum(), channels.index(name)))
                vals.append(meas)
        tt, cc, vv = np.concatenate(times), np.concatenate(chans), np.concatenate(vals)
        # outliers: glitches of +15..60 K and open-circuit readings at the range limits
        n_out = int(rng.integers(4, 10))
        idx = rng.choice(tt.size, n_out, replace=False)
        glitch = rng.uniform(15.0, 60.0, n_out)
        vv[idx] = np.where(
            rng.random(n_out) < 0.7, vv[idx] + glitch, rng.choice([-50.0, 300.0], n_out)
        )
        # the speed log of the motor controller, 1 Hz
        tt = np.concatenate([tt, t])
        cc = np.concatenate([cc, np.full(t.size, len(channels))])
        vv = np.concatenate([vv, speed])
        tt = np.round(tt, 3)
        order = np.lexsort((cc, tt))
        tt, cc, vv = tt[order], cc[order], vv[order]
        ut, row = np.unique(tt, return_inverse=True)
        names = [*channels, "speed"]
        cols = {name: np.full(ut.size, np.nan) for name in names}
        for j, name in enumerate(names):
            sel = cc == j
            cols[name][row[sel]] = vv[sel]
        meta = {**meta, "sampling": "asynchronous: 2 multiplexed 4.17 Hz RTD modules, speed 1 Hz"}
        return RigRun(experiment_id, ut, cols, dict(_UNITS), dict(_ROLES), meta, truth)


def _run_in(
    rig: SpindleRig,
    rng: np.random.Generator,
    *,
    speeds=(4000, 5000, 6000, 7000, 8000),
    folds=(1, 2),
    raw: bool = True,
    duration_h: float = 24.0,
) -> list[RigRun]:
    runs = []
    for speed in speeds:
        for fold in folds:
            runs.append(
                rig.day(
                    f"spindle-{int(speed)}rpm-fold{fold}",
                    float(speed),
                    rng,
                    raw=raw,
                    duration_h=duration_h,
                    meta={"fold": int(fold)},
                )
            )
    return runs


def _validation(
    rig: SpindleRig,
    rng: np.random.Generator,
    *,
    speeds=(4500, 5300, 7800),
    raw: bool = True,
    duration_h: float = 24.0,
) -> list[RigRun]:
    return [
        rig.day(f"spindle-{int(s)}rpm-validation", float(s), rng, raw=raw, duration_h=duration_h)
        for s in speeds
    ]


SpindleRig.protocols = {
    "run-in": Protocol("run-in", "Table 4: a day at 4000-8000 rpm, two folds each", _run_in),
    "validation": Protocol("validation", "section 3.2: days at 4500, 5300, 7800 rpm", _validation),
}
