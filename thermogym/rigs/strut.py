"""Actuator-strut test rig (paper 000, section 4): a true plant written independently of the model.

The rig stands in for the ball-screw actuator strut of
``000_24627a5308ee07db.txt`` (Fig. 4). Its plant, :class:`StrutPlant`, is a
thermal model of the strut built from its geometry, materials, friction
torques and heat-transfer correlations. It imports nothing from
:mod:`thermogym.models`: the identified model (the 19-node RC network of
section 4.2, :class:`thermogym.models.strut.StrutModel`) is one engineer's
approximation of this plant, not a copy of it. Recordings carry the model's
signal names and units.

Design of the strut (the rig's own estimates)
---------------------------------------------
A ~3 kW servo motor drives a 40 mm ball screw (lead 20 mm, 1.5 m) through a
toothed belt (1:1). The screw is held by a preloaded angular-contact bearing
pair in a steel bearing housing at its rear end and is free at its front end.
The nut sits in a carriage at the rear end of a steel push tube (Ø110/90 mm,
1.2 m) that slides through a guide bushing at the front of the stand; the
strut's length is the distance from the fixed bearing to the front of the push
tube, so it lengthens by (eq 5) ``ΔL = α [∫ ΔT_screw dx (bearing → nut) +
∫ ΔT_tube ds]`` with ``ΔT = T − 20 °C`` (ISO 1 reference temperature). For
the step tests the axis moves periodically over a 0.6 m stroke at constant
feed rate ``v`` [m/min]; the screw turns at ``n = v / lead`` (1000 rpm at
20 m/min). The period of a stroke (seconds) is far below every thermal time
constant, so every moving contact (nut on the screw, screw inside the push
tube, push tube in the guide bushing) is averaged over the stroke.

The screw runs enclosed, as 000 section 4 describes the strut ("the tube moves
around the spindle"): ahead of the nut inside the push tube (Ø90 mm bore),
behind it inside a round bellows (Ø90/110 mm, coated fabric) between the
bearing housing and the carriage, the usual protection of a machine-tool ball
screw against chips and contact. Its heat reaches the air across the air of
that annulus (conduction, free convection and radiation at rest; Taylor
vortices while it turns) and then through the push tube or the bellows. The
paper's own estimate of the screw's air exchange is free convection and
radiation, its uncertainty stated "+30/−20 % without forced convection"
(appendix): a screw turning in the open air at 1000-1500 rpm would exchange
6-8× its still-air value (Kays & Bjorklund's rotating cylinder), outside that
bound. (An earlier version of this rig had such an open stand; see
``benchmarks/results/rigs/strut_spindle.md``.)

Heat sources (linear in ``v`` like the paper's estimate ``Q_i = k_i v``, eq 13,
except where the table says otherwise): motor 40 W at 20 m/min (75 % copper,
25 % iron and bearings), belt 6 W, screw-bearing pair 14 W (friction torque
0.13 N m), nut 29 W (preload drag torque 0.28 N m), guide bushing 7 W
(sliding friction 20 N). Heat capacities from masses (steel 3.61 MJ/(m³ K)),
conductances from ``k A / L`` (steel 45 W/(m K)) and the joints, air
exchange from the correlations of :mod:`thermogym.rigs._convection`.

What the rig has that the identified model lacks
------------------------------------------------
Every item can be switched off (``StrutPlant(off=[name])`` or
``get_rig("strut", off=[name])``) for tests; the concealed effects below are
off unless a rig is built with them. Each entry: physical source; size;
switch. The rows are :data:`EXTRAS`.

``conduction_1d``
    The heat equation along the screw and the push tube (000 section 4, eq 6)
    by finite volumes; 60 + 60 segments (the model: 5 screw and 3 tube nodes).
    Switch ``conduction_1d`` (off: 5 and 3 segments); ``n_screw=``, ``n_tube=``.
``forced_convection``
    The screw turning in its annulus (push tube ahead of the nut, bellows
    behind it): Taylor-Couette convection, ``Nu = 0.409 Ta^0.241``
    (Becker & Kaye 1962, the air-gap correlation of electrical machines;
    ``Ta = ω² r_m δ³/ν²`` = 2.2·10⁷ at 1000 rpm), its excess over conduction
    mixed (n = 3) with the annulus' free convection (Raithby & Hollands,
    Incropera eq 9.58); the push tube moving along itself, laminar flat plate
    ``Nu = 0.664 Re^(1/2) Pr^(1/3)`` over the stroke, where its boundary layer
    restarts (Incropera eq 7.30), mixed with free convection (n = 3). The
    annulus conducts 0.65 W/(m K) at rest (conduction 0.20 × 2.19 free
    convection, radiation 0.20), 2.65 at 20 m/min (×4.1), 3.18 at 30 (×4.9);
    the screw's exchange with the air through the bellows grows 2.7× (20
    m/min), the tube's outside +6 % (20 m/min), +10 % (30). Switch
    ``forced_convection`` (off: the annulus and the tube at rest).
``copper_resistance``
    The copper loss follows the winding resistance, α_Cu = 3.93e-3 1/K
    (IEC 60028): +0.39 % of the 30 W copper loss per kelvin of winding rise.
    Switch ``copper_resistance``.
``winding_node``
    The winding is its own heat capacity behind the stator (1.2 kJ/K,
    R_th 0.12 K/W to the housing). Switch ``winding_node`` (off: the copper
    loss heats the housing node).
``heat_partition``
    Friction heat is shared by the contact partners (Blok's partition, equal
    for equal materials): 50 % of the bearing, nut and bushing heat enters the
    screw or the tube. Switch ``heat_partition`` (off: all into the nut,
    bearing and bushing nodes, as the model assumes).
``stroke_contacts``
    Nut ↔ screw, screw ↔ push tube (across the annulus), tube ↔ bushing
    contacts and the screw's length under the bellows averaged over the 0.6 m
    stroke. Switch
    ``stroke_contacts`` (off: every contact at the stroke's mean position).
``thermocouple_lag``
    Sheathed thermocouples in blind holes with paste, τ = 30 s (× the
    specimen's ``tc_tau``). Switch ``thermocouple_lag``.
specimen spread
    The uncertainty of the physical estimates that 000's appendix states:
    losses +200/−70 %, air conductances +30/−20 %, rolling contacts
    +100/−40 %; capacities ±10 %; thermocouple mounting ×0.5-2 (:data:`SPREAD`,
    log-uniform). Switch: ``StrutRig.with_specimen("nominal")``.

Free convection (Churchill & Chu) and radiation are linearised at a 10 K
rise in the base rig, as an engineer's estimate would be; their exact
temperature dependence is the concealed ``nonlinear_heat_transfer``.

Concealed effects (``effect_defaults``; written in this module, never
borrowed from the model's augmentations or the diagnosis; nothing in the
recordings or their metadata names them):

* ``input_dependent_heat_transfer`` — a self-ventilated drive motor (IC 411):
  its shaft fan blows along the housing at 3 m/s at 1000 rpm (``air_speed``,
  ``at_rpm``; ∝ motor speed, belt 1:1), laminar flat-plate convection over
  the 0.3 m housing (Incropera eq 7.30) mixed with free convection: the drive
  and flange exchange 2.0× more heat with the air at 20 m/min, 2.3× at 30.
* ``input_nonlinearity`` — viscous (speed-dependent) friction of the bearing
  pair and the nut by Palmgren, ``M_0 = 10⁻⁷ f_0 (ν n)^(2/3) d_m³``
  (grease base oil 100 mm²/s; bearings f_0 = 2 each, d_m 55 mm; nut f_0 = 4,
  d_m 40 mm): 21 W at 1000 rpm, growing as n^(5/3) (``f0_scale`` = 1).
* ``nonlinear_heat_transfer`` — free convection and radiation evaluated at the
  actual temperatures instead of the 10 K linearisation.
* ``time_varying_parameter`` — the grease of the nut and of the bearing pair is
  pushed out of the raceways: their friction grows with travel, 4 % per km
  (``per_km``).
* ``transport_delay`` — the feed-rate log runs 10 min behind the temperature
  logger (``delay`` = 600 s).
* ``unmeasured_disturbance`` — a 1.5 K, 2 h air-conditioning cycle around the
  strut that the air sensor does not see.
* ``sensor_offset`` / ``sensor_drift`` — a 1 K cold-junction error on the nut
  thermocouple; the screw thermocouple's amplifier drifting 0.3 K/h.
* ``sensor_lag`` — the nut thermocouple clamped without paste: τ = 300 s.
* ``missing_dynamics`` — a 20 kJ/K frame bracket (~45 kg of steel) bolted to
  the bearing housing (2 W/K, 0.5 W/K to the air).

Protocols
---------
``steps``
    From a thermal steady state, the strut is moved periodically at a constant
    feed rate of 20, 25 or 30 m/min for 170, 125 and 80 min (the paper:
    "between 80 and 170 minutes"), sampled every 140.9, 148.7 and 158.3 s (the
    sampling periods of section 4). As in the paper, the drive had not fully
    cooled down before the 25 m/min run (it starts 3 K above the air).

Sensors: thermocouples σ = 0.05 K white + 0.03 K coloured (cold-junction wander,
30 min), resolution 0.01 K, a 1 K spike about every 50 h (the servo drive's
PWM) and a lost conversion about every 20 h, held for about 5 min by the
logger; the elongation by a
laser interferometer, σ = 0.5 µm (the paper notes it is costly to measure; the
rig provides it as ground truth for compensation studies).

The rig's strut is one specimen drawn from :data:`SPREAD` with seed
:data:`SPECIMEN_SEED` (the paper's strut is one unknown specimen too);
:meth:`StrutRig.with_specimen` chooses another or the nominal one.
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from thermogym.rigs._plant_base import MachineRig
from thermogym.rigs._strut_plant import (
    _UNITS,
    EXTRAS,
    OUTPUTS,
    PHYSICS,
    SPREAD,
    TEMPERATURES,
    StrutPlant,
)
from thermogym.rigs.base import Protocol, RigRun
from thermogym.rigs.sensors import Sensor

__all__ = [
    "EXTRAS",
    "OUTPUTS",
    "PHYSICS",
    "SPECIMEN_SEED",
    "SPREAD",
    "STEP_TESTS",
    "TEMPERATURES",
    "StrutPlant",
    "StrutRig",
]

#: feed rate [m/min] -> (duration [min], sampling period [s]) (paper 000 section 4)
STEP_TESTS: dict[float, tuple[float, float]] = {
    20.0: (170.0, 140.9),
    25.0: (125.0, 148.7),
    30.0: (80.0, 158.3),
}
_ROLES = {
    "feed_rate": "input",
    "T_air": "disturbance",
    "dL_um": "output",
    **{k: "output" for k in TEMPERATURES},
}

#: Seed of the rig's own specimen (the strut of the test stand).
SPECIMEN_SEED = 0


class StrutRig(MachineRig[StrutPlant]):
    """Virtual actuator-strut test stand (paper 000, Fig. 4) around :class:`StrutPlant`.

    Parameters
    ----------
    effects : sequence of str or EffectSpec
        Concealed effects (``NAME[:k=v,...]``, see the module docstring).
    off : iterable of str
        Rows of the plant's table (:data:`EXTRAS`) to switch off.
    """

    name = "strut"
    plant_cls = StrutPlant
    specimen_seed = SPECIMEN_SEED
    recorded = OUTPUTS
    not_model = "the rig is not the model: it has no ratio parameters"
    sensors: ClassVar[dict[str, Sensor]] = {
        **{
            k: Sensor(
                noise=0.05,
                resolution=0.01,
                colored=0.03,
                colored_tau=1800.0,
                spike_rate=0.02,
                spike_size=1.0,
                dropout_rate=0.05,
                dropout_s=300.0,
                dropout="hold",
                source="type K thermocouples, 16-bit logger: white noise, cold-junction "
                "wander, rare spikes from the servo drive's PWM, a conversion lost now "
                "and then (the logger repeats its register)",
            )
            for k in TEMPERATURES
        },
        "T_air": Sensor(
            noise=0.05,
            resolution=0.01,
            colored=0.03,
            colored_tau=1800.0,
            lag=60.0,
            source="air thermocouple in a radiation shield",
        ),
        "dL_um": Sensor(
            noise=0.5,
            resolution=0.1,
            colored=0.3,
            colored_tau=600.0,
            source="laser interferometer; wander of the air's refractive index",
        ),
    }
    supported_effects = (
        *StrutPlant.supported_effects,
        "sensor_offset",
        "sensor_lag",
        "sensor_drift",
    )
    effect_defaults: ClassVar[dict[str, dict[str, Any]]] = {
        **StrutPlant.effect_defaults,
        "sensor_offset": {"signal": "T_nut", "offset": 1.0},
        "sensor_lag": {"signal": "T_nut", "tau": 300.0},
        "sensor_drift": {"signal": "T_spindle", "rate": 0.3},
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
        t = period_s * np.arange(n, dtype=np.float64)
        air = T_air + 0.3 * np.sin(2 * np.pi * t / (6 * 3600.0) + rng.uniform(0, 2 * np.pi))
        u = np.column_stack([np.full(n, float(feed_rate)), air])
        u[0, 0] = 0.0  # the first sample is taken at rest, the movement starts right after
        plant, spec = self.plant(), self.specimen
        x0 = plant.initial_state(spec, u[0], drive_warm_K=drive_warm_K)
        run = plant.simulate(u, period_s, spec, x0=x0)
        vals = {k: run.outputs[0, :, i] for i, k in enumerate(OUTPUTS)}
        cols = {
            "feed_rate": u[:, 0].copy(),
            **self.measure({"T_air": air}, rng, t),
            **self.measure(vals, rng, t),
        }
        meta = {
            "feed_rate_m_min": float(feed_rate),
            "period_s": period_s,
            "duration_min": duration_min,
        }
        truth = {**vals, "T_air": air, **{k: v[0] for k, v in run.hidden.items()}}
        return RigRun(f"strut-step-{feed_rate:g}", t, cols, dict(_UNITS), dict(_ROLES), meta, truth)


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
