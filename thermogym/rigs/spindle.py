"""Spindle run-in rig with two multiplexed RTD modules (paper 001): its own true plant.

The rig stands in for the externally driven spindle of
``001_6d13a2cd04f5de5e.txt`` (Fig. 3b/c): a shaft in two angular-contact
bearing pairs (rear A, B; front C, D), an inner housing (the bearing sleeve)
pressed into a cast-iron outer housing, a belt pulley at the rear and the
nose at the front. Its plant, :class:`SpindlePlant`, is built from geometry,
materials, bearing friction and heat-transfer correlations; it imports
nothing from :mod:`thermogym.models` (the package's 14-node RC network,
:class:`thermogym.models.spindle.SpindleModel`, and the N4SID models of the
paper are approximations of it). Recordings carry the model's signal names.

Design (the rig's own estimates)
--------------------------------
Shaft Ø85/25 mm × 0.60 m (11 kJ/K), bearing sleeve Ø180/125 mm × 0.52 m
(25 kJ/K), cast-iron outer housing Ø260/180 mm × 0.62 m (57 kJ/K), an
aluminium pulley (Ø150 × 50 mm, 1.8 kJ/K). Bearings: rear pair d_m 80 mm,
front pair d_m 90 mm (70-series proportions, D − d = 0.44 d_m), light preload
200 N, grease-lubricated (the run-in of paper 001 is a grease run-in) with an
ISO VG 22 base oil. Friction per bearing by the SKF model (SKF, *Rolling
bearings*, PUB BU/P1 17000, 2018, "The SKF model for calculating the
frictional moment"; also General Catalogue 6000, 2005) for a single-row
angular contact ball bearing under the axial preload ``F_a`` (no radial
load)::

    M = φ_ish φ_rs G_rr (ν n)^0.6 + G_sl μ_sl,   P = M ω
    G_rr = R1 d_m^1.97 (R2 F_a)^0.54,   G_sl = S1 d_m^0.26 S2 F_a^(4/3)
    φ_ish = 1 / (1 + 1.84e-9 (n d_m)^1.28 ν^0.64)            (inlet shear heating)
    φ_rs = exp(−K_rs ν n (d + D) sqrt(K_z / (2 (D − d))))    (replenishment/starvation)
    μ_sl = φ_bl 0.15 + (1 − φ_bl) 0.05,  φ_bl = exp(−2.6e-8 (n ν)^1.4 d_m)

with R1 = 5.03e-7, R2 = 1.97, S1 = 1.30e-2, S2 = 0.68 (single-row angular
contact ball bearings), K_z = 4.4, K_rs = 6e-8 (grease and oil-air), ν the
base oil's viscosity at the rings' mean temperature, the preload
``F_a = F_0 + k_th (T_inner ring − T_outer ring)``. The four bearings make 140 W
at 6000 rpm and 40 °C with these catalogue constants (no fitted factor). At
n·d_m ≈ 5·10⁵ mm/min a grease-lubricated bearing runs starved and the inlet
heats the film: the rolling moment grows little with speed and viscosity, and
the heat grows about as n (n^1.3 from 4000 to 5000 rpm, n^0.9 from 7000 to
8000 at 40 °C). (An earlier version of this rig used Palmgren's
``M_0 = 10⁻⁷ f_0 (ν n)^(2/3) d_m³``, a law for flooded bearings at moderate
speeds: its heat grows as n^(5/3) and falls 1.8 %/K with the oil's
viscosity, and it needed f_0 = 0.26, an eighth of the catalogue's value for
grease, to give a plausible heat.) Belt hysteresis: 1.5 W per 1000 rpm into
the pulley. The slowest time constant is about 3.5 h, so a run at 4000-8000
rpm settles (1 °C in 3 h) within the day and cools by the evening, as in the
paper's Table 4 protocol.

What the rig has that the identified model lacks
------------------------------------------------
Each entry: physical source; size; switch (``SpindlePlant(off=[name])`` or
``get_rig("spindle", off=[name])``; every item is on by default). The rows are
:data:`EXTRAS`.

``friction_power_law``
    The SKF frictional moment (rolling, reduced by inlet shear heating and
    starvation; sliding) at the actual speed: the heat grows about as n^1.0
    (89 W at 4000 rpm, 140 at 6000, 181 at 8000, at 40 °C), with a slope
    falling from n^1.3 to n^0.9 over the range. Switch ``friction_power_law``
    (off: the moment at 6000 rpm at every speed, heat exactly ∝ n, as the
    model).
``thermal_preload``
    The inner ring runs warmer than the outer ring and the fixed-position
    preload grows, ``k_th`` = 40 N/K per bearing (radial expansion
    α d ΔT = 0.9 µm/K against ~45 N/µm contact stiffness): through
    ``G_rr ∝ F_a^0.54`` the rolling friction rises 10 % per kelvin of ring
    difference (1-1.5 K at 6000 rpm: +11 % heat). Switch ``thermal_preload``.
``lubricant_viscosity``
    The base oil's viscosity at the rings' temperature, ASTM D341 (Walther)
    through the ISO VG 22 oil's 22 mm²/s at 40 °C and 4.3 at 100 °C (49 at
    22 °C, 11 at 60 °C). In the SKF law the rolling moment depends on it as
    ``ν^0.6 φ_ish φ_rs``: −0.7 %/K at 4000 rpm and 40 °C, +0.3 %/K at 8000
    (starvation), nil at 22 °C and 6000 rpm. Switch ``lubricant_viscosity``
    (off: ν at 40 °C).
``rotating_convection``
    The rotating parts in the air: the nose a rotating cylinder,
    ``Nu = 0.133 Re_ω^(2/3) Pr^(1/3)`` (Kays & Bjorklund; Bossmanns & Tu, ref.
    [3] of paper 001), 160 W/(m² K) at 6000 rpm against 6 still (2.6 W/K); the
    pulley its rim outside the belt's 180° wrap (the same correlation) and its
    two faces as rotating disks, ``Nu_R = 0.36 Re^(1/2)`` (Cobb & Saunders
    1956): 3.7 W/K at 6000 rpm against 0.2 still; and the 1 mm gap between the
    rotating and the stationary spacer sleeves, where Taylor vortices raise
    the conduction ×2.6-3.6 at 4000-8000 rpm (Becker & Kaye 1962:
    ``Ta = ω² r_m δ³/ν²`` = 3.7·10⁴-1.5·10⁵, above the 1700 of Taylor's
    instability). All smooth in the speed; they switch when the spindle
    stops because its speed does. Switch ``rotating_convection``.
``distributed_nodes``
    The shaft (30 segments), the sleeve and the outer housing (10 each) are
    conducting bodies, each bearing has an inner and an outer ring joined by
    the rolling contact: 60 nodes (the model: 14). Switch ``distributed_nodes``
    (off: 3 shaft and 2 + 2 housing segments); ``n_shaft=``, ``n_housing=``.
``heat_partition``
    Friction heat shared by the inner and outer ring (50 %). Switch
    ``heat_partition`` (off: all into the outer ring).
``sensor_mounting``
    RTD probes lag their mounting points: spring-loaded against the outer
    rings τ = 40 s, inner housing 60 s, adhesive pads on the outer housing
    120 s (× the specimen's ``rtd_tau``). Switch ``sensor_mounting``.
specimen spread
    Bearing friction +200/−70 % (000 appendix, rolling contacts), preload
    ±20 %, belt loss +200/−70 %, air exchange +30/−20 %, rolling-contact
    conductance +100/−40 %, capacities ±10 %, probe lags ×0.5-2
    (:data:`SPREAD`, log-uniform). Switch ``SpindleRig.with_specimen("nominal")``.

Concealed effects (``effect_defaults``; written here, never borrowed from the
model's augmentations or the diagnosis, never named in recordings):

* ``input_nonlinearity`` — the balls' centrifugal force loads the outer
  raceway: the SKF model's centrifugal term ``F_g = k_c (n / 1000 rpm)²`` in
  ``G_rr`` and ``G_sl``, k_c = 5 N (12.7 mm balls at d_m 90 mm: ~50 N per
  ball at 8000 rpm, 320 N in all), so the friction grows faster than n.
* ``input_dependent_heat_transfer`` — the drive motor's shaft fan blows along
  the outer housing at 1.5 m/s at 6000 rpm (∝ speed): laminar flat-plate
  convection (Incropera eq 7.30) mixed with free convection: the housing's air
  exchange (radiation included) 1.35× at 6000 rpm, 1.45× at 8000.
* ``nonlinear_heat_transfer`` — free convection and radiation at the actual
  temperatures instead of their 10 K linearisation.
* ``time_varying_parameter`` — grease churning: after a night at rest the
  grease has flowed back into the rolling path and the rolling friction is
  60 % higher; it channels out with a 1.5 h time constant while running and
  flows back with 8 h at rest.
* ``unmeasured_disturbance`` — a 2 K, 5 h machine-hall air-conditioning cycle
  around the spindle that the ambient RTD does not see.
* ``sensor_offset`` — 1 K on the front outer-housing RTD (3.9 Ω contact
  resistance in its connector; PT1000: 3.85 Ω/K).
* ``sensor_lag`` — that RTD in a magnetic holder: τ = 600 s.
* ``sensor_drift`` — the inner-housing RTD drifting 0.15 K/h (moisture in
  its cable gland).
* ``transport_delay`` — the speed log of the motor controller runs 10 min
  behind the sensor modules' clock.
* ``missing_dynamics`` — a 60 kJ/K headstock casting bolted to the front of
  the outer housing (4 W/K, 1 W/K to the air).

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
speed is logged by the motor controller at 1 Hz. The room temperature follows
a daily cycle (Fig. 5) with a slow random wander; each run starts at 08:00.

The rig's spindle is one specimen drawn from :data:`SPREAD` with seed
:data:`SPECIMEN_SEED`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, ClassVar

import numpy as np

from thermogym.rigs._plant_base import MachineRig
from thermogym.rigs._spindle_plant import (
    _UNITS,
    EXTRAS,
    PHYSICS,
    SPREAD,
    TEMPERATURES,
    SpindlePlant,
)
from thermogym.rigs.base import Protocol, RigRun
from thermogym.rigs.sensors import Sensor

__all__ = [
    "CONVERSION_HZ",
    "EXTRAS",
    "MODULES",
    "PHYSICS",
    "SPECIMEN_SEED",
    "SPREAD",
    "TEMPERATURES",
    "SpindlePlant",
    "SpindleRig",
    "ambient_profile",
]

#: Channels of each TSWTM module, in multiplexer order.
MODULES: tuple[tuple[str, ...], ...] = (TEMPERATURES[:5], (*TEMPERATURES[5:], "T_amb"))
CONVERSION_HZ = 4.17
_ROLES = {"speed": "input", "T_amb": "disturbance", **{k: "output" for k in TEMPERATURES}}

#: Seed of the rig's own specimen (the spindle of the run-in system).
SPECIMEN_SEED = 0
_SIM_DT = 10.0  # s, grid of the protocols' simulations


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
    # moving average over k samples (edge-padded), by cumulative sums: O(N)
    c = np.concatenate([[0.0], np.cumsum(np.pad(walk, (k // 2, k - 1 - k // 2), mode="edge"))])
    walk = (c[k:] - c[:-k]) / k
    return mean + rng.uniform(-1.0, 1.0) + daily + walk - walk[0]


class SpindleRig(MachineRig[SpindlePlant]):
    """Virtual spindle run-in system (paper 001, Fig. 3b) around :class:`SpindlePlant`.

    Parameters
    ----------
    effects : sequence of str or EffectSpec
        Concealed effects (``NAME[:k=v,...]``, see the module docstring).
    off : iterable of str
        Rows of the plant's table (:data:`EXTRAS`) to switch off.
    """

    name = "spindle"
    plant_cls = SpindlePlant
    specimen_seed = SPECIMEN_SEED
    recorded = (*TEMPERATURES, "T_amb")
    sensors: ClassVar[dict[str, Sensor]] = {
        k: Sensor(
            noise=0.02,
            resolution=0.001,
            colored=0.01,
            colored_tau=3600.0,
            source="PT1000 class A, AD7794 (001 Table 2: ±0.05 K at 25 °C); reference drift",
        )
        for k in (*TEMPERATURES, "T_amb")
    }
    supported_effects = (
        *SpindlePlant.supported_effects,
        "sensor_offset",
        "sensor_lag",
        "sensor_drift",
    )
    effect_defaults: ClassVar[dict[str, dict[str, Any]]] = {
        **SpindlePlant.effect_defaults,
        "sensor_offset": {"signal": "T_front_outer_housing", "offset": 1.0},
        "sensor_lag": {"signal": "T_front_outer_housing", "tau": 600.0},
        "sensor_drift": {"signal": "T_inner_housing", "rate": 0.15},
    }

    def days(
        self,
        experiment_ids: Sequence[str],
        speeds: Sequence[float],
        rng: np.random.Generator,
        *,
        duration_h: float = 24.0,
        max_run_h: float = 20.0,
        window_h: float = 3.0,
        settle_K: float = 1.0,
        raw: bool = True,
        metas: Sequence[dict[str, Any]] | None = None,
    ) -> list[RigRun]:
        """Run-in days at constant speeds [rpm], simulated as one batch: heat, settle, cool."""
        dt = 1.0
        n = int(duration_h * 3600 / dt)
        t = dt * np.arange(n, dtype=np.float64)
        amb = np.array([ambient_profile(t, rng) for _ in speeds])
        # the plant runs on a 10 s grid (its fastest probe lags 20 s or more; the speed
        # steps fall on the grid) and is interpolated onto the 1 s grid of the recordings
        sub = int(_SIM_DT / dt)
        ts = t[::sub]
        U = np.zeros((len(speeds), ts.size, 2))
        U[:, :, 0] = np.asarray(speeds, dtype=float)[:, None]
        U[:, :, 1] = amb[:, ::sub]
        plant = self.plant()
        spec = self.specimen.take(np.zeros(len(speeds), dtype=np.int64))
        y = plant.simulate(U, _SIM_DT, spec).outputs
        rise = y - U[:, :, 1:2]
        w = int(window_h * 3600 / _SIM_DT)
        stops = []
        for b in range(len(speeds)):
            change = np.abs(rise[b, w:] - rise[b, :-w]).max(axis=1)
            settled = np.nonzero(change < settle_K)[0]
            k_stop = settled[0] + w if settled.size else ts.size
            stops.append(int(min(k_stop * sub, max_run_h * 3600 / dt, n)))
            U[b, stops[-1] // sub :, 0] = 0.0
        y = plant.simulate(U, _SIM_DT, spec).outputs
        out = {
            k: np.array([np.interp(t, ts, y[b, :, i]) for b in range(len(speeds))])
            for i, k in enumerate(TEMPERATURES)
        }
        speed_log = np.zeros((len(speeds), n))
        for b, s in enumerate(speeds):
            speed_log[b, : stops[b] - stops[b] % sub] = float(s)
        runs = []
        for b, (eid, speed) in enumerate(zip(experiment_ids, speeds, strict=True)):
            meta = {"speed_rpm": float(speed), "stop_s": float((stops[b] - stops[b] % sub) * dt)}
            meta |= dict(metas[b]) if metas else {}
            vals = {k: out[k][b] for k in TEMPERATURES}
            truth = vals | {"T_amb": amb[b], "speed": speed_log[b].copy()}
            if not raw:
                cols = {
                    "speed": speed_log[b].copy(),
                    **self.measure({"T_amb": amb[b]}, rng, t),
                    **self.measure(vals, rng, t),
                }
                runs.append(RigRun(eid, t, cols, dict(_UNITS), dict(_ROLES), meta, truth))
            else:
                runs.append(
                    self._raw(eid, t, speed_log[b], {**vals, "T_amb": amb[b]}, rng, meta, truth)
                )
        return runs

    def day(
        self,
        experiment_id: str,
        speed: float,
        rng: np.random.Generator,
        *,
        raw: bool = True,
        meta: dict[str, Any] | None = None,
        **options: Any,
    ) -> RigRun:
        """One run-in day at constant ``speed`` [rpm] (see :meth:`days`)."""
        return self.days([experiment_id], [speed], rng, raw=raw, metas=[meta or {}], **options)[0]

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
                meas = self.sensor(name).measure(true, rng, tk[sel])
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
    pairs = [(float(s), int(f)) for s in speeds for f in folds]
    return rig.days(
        [f"spindle-{int(s)}rpm-fold{f}" for s, f in pairs],
        [s for s, _ in pairs],
        rng,
        raw=raw,
        duration_h=duration_h,
        metas=[{"fold": f} for _, f in pairs],
    )


def _validation(
    rig: SpindleRig,
    rng: np.random.Generator,
    *,
    speeds=(4500, 5300, 7800),
    raw: bool = True,
    duration_h: float = 24.0,
) -> list[RigRun]:
    return rig.days(
        [f"spindle-{int(s)}rpm-validation" for s in speeds],
        [float(s) for s in speeds],
        rng,
        raw=raw,
        duration_h=duration_h,
    )


SpindleRig.protocols = {
    "run-in": Protocol("run-in", "Table 4: a day at 4000-8000 rpm, two folds each", _run_in),
    "validation": Protocol("validation", "section 3.2: days at 4500, 5300, 7800 rpm", _validation),
}
