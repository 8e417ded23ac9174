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

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import numba as nb
import numpy as np
from numpy.typing import NDArray

from thermogym._checks import integer
from thermogym._jitcache import cache_depends_on
from thermogym.errors import ConfigError, ShapeError, UnknownNameError
from thermogym.rigs import _convection
from thermogym.rigs._convection import (
    g_annulus_conduction,
    g_annulus_radiation,
    h_free_cylinder,
    h_mixed,
    h_moving_surface,
    h_radiation,
    k_ratio_free_annulus,
    k_ratio_rotating_annulus,
)
from thermogym.rigs._machine import Links, ratio_parameters, segment_weights
from thermogym.rigs.base import (
    EffectSpec,
    ExtraPhysics,
    PlantRun,
    Protocol,
    Rig,
    RigRun,
    Specimens,
    TruePlant,
)
from thermogym.rigs.sensors import Sensor

__all__ = [
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
#: The seven thermocouples of the test stand (recorded with the model's signal names).
TEMPERATURES: tuple[str, ...] = (
    "T_drive",
    "T_belt_housing",
    "T_bearing",
    "T_nut",
    "T_spindle",
    "T_tube_front",
    "T_tube_rear",
)
OUTPUTS: tuple[str, ...] = (*TEMPERATURES, "dL_um")
_UNITS = {"feed_rate": "m/min", "T_air": "°C", "dL_um": "µm", **{k: "°C" for k in TEMPERATURES}}
_ROLES = {
    "feed_rate": "input",
    "T_air": "disturbance",
    "dL_um": "output",
    **{k: "output" for k in TEMPERATURES},
}

#: The rig's table: what it has that the identified model lacks (switch: ``off=[name]``).
EXTRAS: tuple[ExtraPhysics, ...] = (
    ExtraPhysics(
        "conduction_1d",
        "heat conduction along the screw and the push tube, 60 finite volumes each",
        "000 section 4, eq (6): the heat equation; the model lumps the screw in 5, the "
        "tube in 3 nodes",
        "60 + 60 segments of 25 and 20 mm",
        "5 screw and 3 tube segments (the model's resolution)",
    ),
    ExtraPhysics(
        "forced_convection",
        "convection of the screw turning in its enclosed annulus (push tube, bellows) and of "
        "the push tube moving through the air",
        "annulus with a rotating inner cylinder Nu = 0.409 Ta^0.241 (Becker & Kaye 1962; "
        "Staton et al. 2005), free convection in the annulus (Raithby & Hollands, Incropera "
        "eq 9.58); flat plate over the stroke Nu = 0.664 Re^(1/2) Pr^(1/3) (Incropera eq 7.30); "
        "mixed with free convection, n = 3 (Incropera eq 9.64)",
        "annulus 0.65 W/(m K) at rest, ×4.1 at 20 m/min, ×4.9 at 30; the screw's exchange "
        "with the air through the bellows ×2.7 at 20 m/min; the tube's outside +6 %, +10 %",
        "the annulus and the tube at rest (conduction, free convection, radiation)",
    ),
    ExtraPhysics(
        "copper_resistance",
        "the copper loss of the motor follows the winding resistance",
        "α_Cu = 3.93e-3 1/K, annealed copper at 20 °C (IEC 60028)",
        "+0.39 % of the 30 W copper loss (at 20 m/min) per kelvin of winding rise",
        "copper loss at its 20 °C value",
    ),
    ExtraPhysics(
        "winding_node",
        "the winding is a heat capacity of its own behind the stator",
        "servo motor datasheets: winding-housing R_th ≈ 0.12 K/W for ~3 kW",
        "1.2 kJ/K, 8 W/K to the housing",
        "the copper loss heats the housing node (one node of both capacities)",
    ),
    ExtraPhysics(
        "heat_partition",
        "friction heat is shared by the two contact partners",
        "Blok's heat partition, equal shares for equal materials (steel on steel)",
        "50 % of the bearing, nut and bushing heat enters the screw or the tube",
        "all of it into the nut, bearing and bushing nodes (as the model assumes)",
    ),
    ExtraPhysics(
        "stroke_contacts",
        "contacts of moving parts averaged over the stroke",
        "periodic motion over 0.6 m at constant speed: the stroke period (seconds) is far "
        "below every thermal time constant",
        "nut ↔ screw over 0.7 m, screw ↔ push tube across the annulus, tube ↔ bushing, the "
        "screw's length under the bellows",
        "every contact at the stroke's mean position",
    ),
    ExtraPhysics(
        "thermocouple_lag",
        "thermocouple junctions lag their mounting points",
        "sheathed thermocouples in blind holes with paste",
        "τ = 30 s (× the specimen's tc_tau, 0.5-2)",
        "the readings are the node temperatures",
    ),
)
#: Switch names of :data:`EXTRAS`.
PHYSICS: tuple[str, ...] = tuple(e.name for e in EXTRAS)

#: Specimen spread: factor -> (low, high, what it multiplies); drawn log-uniformly.
SPREAD: dict[str, tuple[float, float, str]] = {
    "loss_motor": (0.3, 3.0, "motor losses (000 appendix: +200/−70 % for electric units)"),
    "loss_bearing": (0.3, 3.0, "bearing pair and guide bushing friction (+200/−70 %)"),
    "loss_nut": (0.3, 3.0, "ball-screw nut friction (+200/−70 % for rolling contacts)"),
    "g_air_screw": (0.8, 1.3, "screw → air exchange (+30/−20 %, 000 appendix)"),
    "g_air_tube": (0.8, 1.3, "push tube → air exchange (+30/−20 %)"),
    "g_air_other": (0.8, 1.3, "housings, motor → air exchange (+30/−20 %)"),
    "g_contact": (0.6, 2.0, "rolling-contact conductances (+100/−40 %, 000 appendix)"),
    "capacity": (0.9, 1.1, "heat capacities (masses × specific heat, ±10 %)"),
    "tc_tau": (0.5, 2.0, "thermocouple time constants (mounting)"),
}
#: Seed of the rig's own specimen (the strut of the test stand).
SPECIMEN_SEED = 0

# ------------------------------------------------------------ geometry, materials
_RHO_C_STEEL = 7850.0 * 460.0  # J/(m³ K)
_K_STEEL = 45.0  # W/(m K)
_ALPHA_STEEL = 11.5e-6  # 1/K
_ALPHA_CU = 3.93e-3  # 1/K, annealed copper at 20 °C (IEC 60028)
_LEAD = 0.020  # m per screw revolution; n [rpm] = v [m/min] / lead
_D_SCREW, _L_SCREW = 0.040, 1.5
_D_TUBE, _D_TUBE_IN, _L_TUBE = 0.110, 0.090, 1.2
_STROKE = (0.45, 1.05)  # nut centre on the screw [m from the rear end]
_L_NUT = 0.10
_BEARING = (0.05, 0.11)  # bearing pair on the screw
_PULLEY = (0.0, 0.04)
_BUSHING_X = 1.55  # guide bushing, fixed, on the screw axis
_TUBE_REAR_OFFSET = -0.05  # push tube rear end relative to the nut centre
_DT_DESIGN = 10.0  # K: rise at which free convection and radiation are linearised
_T_REF = 20.0  # °C: reference temperature of the strut length (ISO 1)
_TC_TAU = 30.0  # s: thermocouple in a blind hole with paste
_N_REF = 1000.0  # rpm: reference speed of the viscous friction
_V_REF = 20.0  # m/min
_L_MOTOR = 0.3  # m, motor housing length along the fan's air stream

# lumped nodes
_LUMPED = (
    "winding",
    "drive",
    "motor_flange",
    "pulley_motor",
    "belt_housing",
    "pulley_spindle",
    "bearing_housing",
    "bearing",
    "nut",
    "carriage",
    "bushing",
    "bracket",
)
_IX = {k: i for i, k in enumerate(_LUMPED)}
_NL = len(_LUMPED)
#: capacity [J/K]
_CAP = {
    "winding": 1200.0,
    "drive": 7000.0,
    "motor_flange": 1500.0,
    "pulley_motor": 400.0,
    "belt_housing": 3000.0,
    "pulley_spindle": 500.0,
    "bearing_housing": 4000.0,
    "bearing": 320.0,
    "nut": 1000.0,
    "carriage": 3700.0,
    "bushing": 500.0,
}
#: air exchange of the lumped nodes: area [m²], characteristic diameter [m], emissivity
_AIR = {
    "drive": (0.25, 0.15, 0.9),
    "motor_flange": (0.04, 0.15, 0.9),
    "belt_housing": (0.15, 0.20, 0.2),
    "bearing_housing": (0.12, 0.15, 0.9),
    "nut": (0.02, 0.08, 0.3),
    "carriage": (0.05, 0.11, 0.3),
    "bushing": (0.04, 0.15, 0.9),
}
_EPS_TUBE = 0.8  # painted push tube
_EPS_SCREW, _EPS_TUBE_IN = 0.3, 0.5  # ground screw; the tube's drawn, oxidised bore
#: the bellows over the screw between the bearing housing and the carriage
_COVER_D, _EPS_COVER = 0.11, 0.9  # m (outer), coated fabric
_HOUSING_FACE = 0.12  # m: the screw leaves the bearing housing
_R_SCREW, _R_BORE = 0.5 * _D_SCREW, 0.5 * _D_TUBE_IN  # the annulus around the screw
#: joints between lumped nodes [W/K] and whether they are rolling contacts
_JOINTS = (
    ("winding", "drive", 8.0),
    ("drive", "motor_flange", 5.0),
    ("drive", "pulley_motor", 1.0),
    ("motor_flange", "belt_housing", 3.0),
    ("pulley_motor", "belt_housing", 0.4),
    ("pulley_spindle", "belt_housing", 0.4),
    ("belt_housing", "bearing_housing", 4.0),
    ("bearing", "bearing_housing", 8.0),
    ("nut", "carriage", 6.0),
)
#: heat sources at 20 m/min [W]
_Q_COPPER, _Q_IRON, _Q_BELT = 30.0, 10.0, 6.0
_M_BEARING, _M_NUT, _F_BUSHING = 0.13, 0.28, 20.0  # N m, N m, N
_G_PULLEY_SCREW = 3.0  # W/K, clamping hub
_G_BALLS_BEARING, _G_BALLS_NUT = 2.0, 3.0  # W/K, rolling contacts
_G_CARRIAGE_TUBE = 10.0  # W/K, bolted
_G_BUSHING_TUBE = 1.5  # W/K, sliding contact
#: the annulus around the screw (inside the push tube or the bellows) at rest [W/(m K)]:
#: conduction × free convection (Raithby & Hollands at the design rise) + radiation
_G_ANN_COND = g_annulus_conduction(_R_SCREW, _R_BORE)
_KR_FREE = float(k_ratio_free_annulus(_DT_DESIGN, _R_SCREW, _R_BORE))
_G_ANN_RAD = g_annulus_radiation(_R_SCREW, _R_BORE, _EPS_SCREW, _EPS_TUBE_IN)
_G_ANN_STILL = _KR_FREE * _G_ANN_COND + _G_ANN_RAD
_N_HI = 3000.0  # rpm (60 m/min): speed of the integrator's rate bound
_PALMGREN = (2 * 2.0, 55.0, 4.0, 40.0, 100.0)  # f0 bearings (×2), d_m, f0 nut, d_m, ν [mm²/s]


def _palmgren_watts(f0: float, dm_mm: float, n_rpm: float, nu: float) -> float:
    """Viscous friction power of Palmgren's M_0 at ``n_rpm`` [W] (M_0 in N mm)."""
    m0 = 1e-7 * f0 * (nu * n_rpm) ** (2.0 / 3.0) * dm_mm**3 if nu * n_rpm >= 2000 else 0.0
    return m0 * 1e-3 * n_rpm * 2 * math.pi / 60.0


@nb.njit(cache=True, inline="always")
def _g_annulus(n_rpm, forced, r_i, r_o, kr_free, g_cond, g_rad):  # pragma: no cover - numba
    # the annulus around the screw per metre [W/(m K)]: its free and its rotating (Taylor-
    # Couette) convection combined as Churchill's n = 3 on their excess over conduction,
    # plus radiation
    kr = kr_free
    if forced and n_rpm > 0.0:
        a = kr_free - 1.0
        b = k_ratio_rotating_annulus(n_rpm, r_i, r_o) - 1.0
        kr = 1.0 + (a * a * a + b * b * b) ** (1.0 / 3.0)
    return kr * g_cond + g_rad


def _g_annulus_np(n_rpm: float, forced: bool) -> float:
    """The annulus around the screw per metre at ``n_rpm`` [W/(m K)] (see the kernel)."""
    return float(_g_annulus(n_rpm, forced, _R_SCREW, _R_BORE, _KR_FREE, _G_ANN_COND, _G_ANN_RAD))


def _stroke_positions(stroke_contacts: bool) -> NDArray[np.float64]:
    # the nut moves at constant speed over the stroke: positions uniform in time
    if not stroke_contacts:
        return np.array([0.5 * (_STROKE[0] + _STROKE[1])])
    return np.linspace(_STROKE[0], _STROKE[1], 61)


@dataclass(frozen=True)
class _Arrays:
    """Kernel arrays of a batch of specimens."""

    C: NDArray[np.float64]  # (B, nn)
    ei: NDArray[np.int64]
    ej: NDArray[np.int64]
    eg: NDArray[np.float64]  # (B, E)
    eann: NDArray[np.int64]  # (E,) 1: across the annulus around the screw (grows with speed)
    A: NDArray[np.float64]  # (B, nn) exposed area × factor; screw: length under the bellows
    A2: NDArray[np.float64]  # (B, nn) screw segments: bellows' outer area × factor
    D: NDArray[np.float64]  # (nn,)
    eps: NDArray[np.float64]
    hnat: NDArray[np.float64]  # (nn,) linearised free convection
    hrad: NDArray[np.float64]  # (nn,) linearised radiation
    ftype: NDArray[np.int64]  # (nn,) 0 none, 1 screw under the bellows, 2 push tube
    xf: NDArray[np.float64]  # (nn,) fan air speed per motor rpm [m/s per rpm]
    qlin: NDArray[np.float64]  # (B, nn) W per m/min
    qcu: NDArray[np.float64]
    qwear: NDArray[np.float64]
    qvisc: NDArray[np.float64]  # (B, nn) W at the reference speed
    tca: NDArray[np.int64]
    tcb: NDArray[np.int64]
    tcw: NDArray[np.float64]
    tctau: NDArray[np.float64]  # (B, 7)
    wL: NDArray[np.float64]  # (nn,) elongation path lengths [m]
    rho: NDArray[np.float64]  # (B,) bound of the fastest rate [1/s]


class StrutPlant(TruePlant):
    """The strut's true plant: a batch of specimens, stepped in compiled code.

    Parameters
    ----------
    off : iterable of str
        Rows of :attr:`extras` to switch off.
    effects : sequence of str or EffectSpec
        Concealed effects of the plant (:attr:`supported_effects`, settings over
        :attr:`effect_defaults`).
    n_screw, n_tube : int
        Finite-volume segments of the screw and of the push tube (``conduction_1d``
        off: 5 and 3, the model's resolution).

    Notes
    -----
    State (:attr:`state_names`): the temperatures of the lumped nodes, the screw
    and tube segments [°C], the seven thermocouple junctions [°C] and the
    travelled distance [km]. Inputs ``u = [feed_rate (m/min), T_air (°C)]``
    are held over each sample. Integration: classical RK4 with fixed
    sub-steps from a bound of the fastest rate of the batch (Gershgorin), so
    that ``h ρ ≤ 1``.

    Examples
    --------
    >>> import numpy as np
    >>> p = StrutPlant()
    >>> u = np.column_stack([np.full(40, 20.0), np.full(40, 21.0)])
    >>> run = p.simulate(u, 140.9, p.nominal(2))
    >>> run.outputs.shape
    (2, 40, 8)
    >>> bool(run.output("T_nut")[0, -1] > run.output("T_nut")[0, 0] + 2.0)  # the nut warms
    True
    """

    name = "strut"
    input_names = ("feed_rate", "T_air")
    output_names = OUTPUTS
    hidden_names = ("T_winding", "T_screw_mean", "T_screw_max", "T_tube_mean", "travel_km")
    units: ClassVar[dict[str, str]] = {
        **_UNITS,
        "T_winding": "°C",
        "T_screw_mean": "°C",
        "T_screw_max": "°C",
        "T_tube_mean": "°C",
        "travel_km": "km",
    }
    max_step = 20.0
    parameters = ratio_parameters(SPREAD, "the rig's physical estimate (module docstring)")
    extras = EXTRAS
    supported_effects = (
        "input_dependent_heat_transfer",
        "input_nonlinearity",
        "nonlinear_heat_transfer",
        "time_varying_parameter",
        "transport_delay",
        "unmeasured_disturbance",
        "missing_dynamics",
    )
    effect_defaults: ClassVar[dict[str, dict[str, Any]]] = {
        "input_dependent_heat_transfer": {"air_speed": 3.0, "at_rpm": 1000.0},
        "input_nonlinearity": {"f0_scale": 1.0},
        "nonlinear_heat_transfer": {},
        "time_varying_parameter": {"per_km": 0.04},
        "transport_delay": {"signal": "feed_rate", "delay": 600.0},
        "unmeasured_disturbance": {"signal": "T_air", "amplitude": 1.5, "period": 7200.0},
        "missing_dynamics": {"C": 20000.0, "G": 2.0, "g_air": 0.5},
    }

    def __init__(
        self,
        *,
        off: Iterable[str] = (),
        effects: Sequence[str | EffectSpec] = (),
        n_screw: int = 60,
        n_tube: int = 60,
    ) -> None:
        super().__init__(off=off, effects=effects)
        self.physics = dict(self.switches)
        self.concealed = {e.name: self.effect(e.name) or {} for e in self.effects}
        if self.physics["conduction_1d"]:
            self.n_screw = integer("n_screw", n_screw, lo=1)
            self.n_tube = integer("n_tube", n_tube, lo=1)
        else:
            self.n_screw, self.n_tube = 5, 3
        self.n_nodes = _NL + self.n_screw + self.n_tube
        self.state_names = (  # type: ignore[misc]
            *(f"T_{k}" for k in _LUMPED),
            *(f"T_screw_{i}" for i in range(self.n_screw)),
            *(f"T_tube_{i}" for i in range(self.n_tube)),
            *(f"TC_{k}" for k in TEMPERATURES),
            "travel_km",
        )
        self.n_states = len(self.state_names)
        self._cache: dict[int, tuple[Any, _Arrays]] = {}

    # --------------------------------------------------------------- the network
    def arrays(self, specimens: Specimens) -> _Arrays:
        """Kernel arrays for a batch of specimens (cached per Specimens object)."""
        hit = self._cache.get(id(specimens))
        if hit is not None and hit[0] is specimens:
            return hit[1]
        missing = [k for k in SPREAD if k not in specimens]
        if missing:
            raise UnknownNameError(
                f"strut specimens lack {missing}; they need {list(SPREAD)} (StrutPlant.nominal)"
            )
        arr = self._build({k: specimens[k] for k in SPREAD})
        if len(self._cache) > 8:
            self._cache.clear()
        self._cache[id(specimens)] = (specimens, arr)
        return arr

    def _build(self, sp: dict[str, NDArray[np.float64]]) -> _Arrays:
        ph, cc = self.physics, self.concealed
        Ns, Nt, NL = self.n_screw, self.n_tube, _NL
        nn = self.n_nodes
        B = sp["loss_motor"].size
        S0, T0 = NL, NL + Ns  # first screw and tube node
        xs_e = np.linspace(0.0, _L_SCREW, Ns + 1)
        ts_e = np.linspace(0.0, _L_TUBE, Nt + 1)
        dxs, dxt = _L_SCREW / Ns, _L_TUBE / Nt
        xs_c = 0.5 * (xs_e[:-1] + xs_e[1:])
        a_screw = math.pi / 4 * _D_SCREW**2
        a_tube = math.pi / 4 * (_D_TUBE**2 - _D_TUBE_IN**2)
        # capacities
        C = np.ones((B, nn))
        for k, c in _CAP.items():
            C[:, _IX[k]] = c
        C[:, S0:T0] = _RHO_C_STEEL * a_screw * dxs
        C[:, T0:] = _RHO_C_STEEL * a_tube * dxt
        md = cc.get("missing_dynamics")
        if md is not None:
            C[:, _IX["bracket"]] = float(md.get("C", 20000.0))
        if not ph["winding_node"]:
            # the winding shares the housing's temperature: one node of both capacities
            C[:, _IX["drive"]] += C[:, _IX["winding"]]
        C *= sp["capacity"][:, None]
        # conductances
        L = Links(B)
        for a, b, g in _JOINTS:
            if a == "winding" and not ph["winding_node"]:
                continue
            L.add(_IX[a], _IX[b], g)
        for i in range(Ns - 1):
            L.add(S0 + i, S0 + i + 1, _K_STEEL * a_screw / dxs)
        for i in range(Nt - 1):
            L.add(T0 + i, T0 + i + 1, _K_STEEL * a_tube / dxt)
        L.spread(_IX["pulley_spindle"], S0, segment_weights(xs_e, *_PULLEY), _G_PULLEY_SCREW)
        w_bear = segment_weights(xs_e, *_BEARING)
        L.spread(_IX["bearing"], S0, w_bear, _G_BALLS_BEARING * sp["g_contact"])
        if md is not None:
            L.add(_IX["bracket"], _IX["bearing_housing"], float(md.get("G", 2.0)))
        # stroke-averaged contacts: nut on the screw, screw inside the push tube, tube in
        # the bushing; the carriage rides with the tube's rear end
        pos = _stroke_positions(ph["stroke_contacts"])
        w_nut = np.zeros(Ns)
        covered = np.zeros(Ns)  # length of each screw segment under the bellows [m]
        g_st = np.zeros((Ns, Nt))
        w_bush = np.zeros(Nt)
        for xn in pos:
            w_nut += segment_weights(xs_e, xn - _L_NUT / 2, xn + _L_NUT / 2)
            rear = xn + _TUBE_REAR_OFFSET
            ins = np.clip((xs_e[1:] - np.maximum(xs_e[:-1], xn + _L_NUT / 2)) / dxs, 0.0, 1.0)
            lo, hi = np.maximum(xs_e[:-1], _HOUSING_FACE), np.minimum(xs_e[1:], xn - _L_NUT / 2)
            covered += np.maximum(hi - lo, 0.0)
            j = np.clip(((xs_c - rear) / dxt).astype(int), 0, Nt - 1)
            for m in np.flatnonzero(ins > 0).tolist():
                g_st[m, j[m]] += _G_ANN_STILL * dxs * ins[m]
            w_bush += segment_weights(ts_e, _BUSHING_X - rear - 0.02, _BUSHING_X - rear + 0.02)
        w_nut /= len(pos)
        covered /= len(pos)
        g_st /= len(pos)
        w_bush /= len(pos)
        L.spread(_IX["nut"], S0, w_nut, _G_BALLS_NUT * sp["g_contact"])
        annulus = set()
        for i, j in zip(*np.nonzero(g_st), strict=True):
            L.add(S0 + int(i), T0 + int(j), g_st[i, j] * sp["g_air_screw"])
            annulus.add((S0 + int(i), T0 + int(j)))
        L.spread(_IX["carriage"], T0, segment_weights(ts_e, 0.0, 0.06), _G_CARRIAGE_TUBE)
        L.spread(_IX["bushing"], T0, w_bush, _G_BUSHING_TUBE)
        ei, ej, eg = L.arrays()
        eann = np.array(
            [int((a, b) in annulus) for a, b in zip(ei.tolist(), ej.tolist(), strict=True)],
            dtype=np.int64,
        )
        # air exchange
        A = np.zeros((B, nn))
        A2 = np.zeros((B, nn))
        D = np.ones(nn)
        eps = np.zeros(nn)
        ftype = np.zeros(nn, dtype=np.int64)
        xf = np.zeros(nn)
        for k, (area, d, e) in _AIR.items():
            A[:, _IX[k]] = area * sp["g_air_other"]
            D[_IX[k]], eps[_IX[k]] = d, e
        if md is not None:
            A[:, _IX["bracket"]] = float(md.get("g_air", 0.5)) / 10.0  # ~10 W/(m² K)
            D[_IX["bracket"]], eps[_IX["bracket"]] = 0.2, 0.9
        # the screw behind the nut: the annulus to the bellows in series with the bellows'
        # free convection and radiation (D, eps of these nodes are the bellows')
        A[:, S0:T0] = covered[None] * sp["g_air_screw"][:, None]
        A2[:, S0:T0] = (math.pi * _COVER_D * covered)[None] * sp["g_air_other"][:, None]
        D[S0:T0], eps[S0:T0] = _COVER_D, _EPS_COVER
        ftype[S0:T0] = 1
        A[:, T0:] = math.pi * _D_TUBE * dxt * sp["g_air_tube"][:, None]
        D[T0:], eps[T0:] = _D_TUBE, _EPS_TUBE
        if ph["forced_convection"]:
            ftype[T0:] = 2
        # the drive motor's shaft fan (concealed input-dependent heat transfer)
        fan = cc.get("input_dependent_heat_transfer")
        if fan is not None:
            per_rpm = float(fan.get("air_speed", 3.0)) / float(fan.get("at_rpm", 1000.0))
            xf[_IX["drive"]] = xf[_IX["motor_flange"]] = per_rpm
        hnat = np.array([h_free_cylinder(_DT_DESIGN, d) for d in D])
        hrad = np.array([h_radiation(25.0 + _DT_DESIGN / 2, 25.0 - _DT_DESIGN / 2, e) for e in eps])
        # heat sources
        part = 0.5 if ph["heat_partition"] else 0.0
        w_rpm = 2 * math.pi / 60.0 / _LEAD  # rad/s per m/min
        qlin = np.zeros((B, nn))
        qcu = np.zeros((B, nn))
        qwear = np.zeros((B, nn))
        qvisc = np.zeros((B, nn))
        lm, lb, ln = sp["loss_motor"], sp["loss_bearing"], sp["loss_nut"]
        cu_node = _IX["winding"] if ph["winding_node"] else _IX["drive"]
        qcu[:, cu_node] = _Q_COPPER / _V_REF * lm
        qlin[:, _IX["drive"]] += _Q_IRON / _V_REF * lm
        qlin[:, _IX["pulley_motor"]] += 0.5 * _Q_BELT / _V_REF
        qlin[:, _IX["pulley_spindle"]] += 0.5 * _Q_BELT / _V_REF
        kb = _M_BEARING * w_rpm * lb  # qwear: rolling contacts whose grease wears
        qwear[:, _IX["bearing"]] += (1 - part) * kb
        qwear[:, S0:T0] += part * kb[:, None] * w_bear[None]
        kn = _M_NUT * w_rpm * ln
        qwear[:, _IX["nut"]] += (1 - part) * kn
        qwear[:, S0:T0] += part * kn[:, None] * w_nut[None]
        kf = _F_BUSHING / 60.0 * lb
        qlin[:, _IX["bushing"]] += (1 - part) * kf
        qlin[:, T0:] += part * kf[:, None] * w_bush[None]
        vc = cc.get("input_nonlinearity")
        if vc is not None:
            f0b, dmb, f0n, dmn, nu = _PALMGREN
            s = float(vc.get("f0_scale", 1.0))
            pb = s * _palmgren_watts(f0b, dmb, _N_REF, nu) * lb
            pn = s * _palmgren_watts(f0n, dmn, _N_REF, nu) * ln
            qvisc[:, _IX["bearing"]] += (1 - part) * pb
            qvisc[:, S0:T0] += part * pb[:, None] * w_bear[None]
            qvisc[:, _IX["nut"]] += (1 - part) * pn
            qvisc[:, S0:T0] += part * pn[:, None] * w_nut[None]
        # thermocouples: (node a, node b, weight of b)
        tca = np.zeros(7, dtype=np.int64)
        tcb = np.zeros(7, dtype=np.int64)
        tcw = np.zeros(7)
        for c, node in enumerate(("drive", "belt_housing", "bearing", "nut")):
            tca[c] = tcb[c] = _IX[node]

        def at(x: float, first: int, n: int, length: float, c: int) -> None:
            f = np.clip(x / length * n - 0.5, 0.0, n - 1.0)
            i = min(int(f), n - 2) if n > 1 else 0
            tca[c], tcb[c], tcw[c] = first + i, first + min(i + 1, n - 1), f - i

        at(0.75, S0, Ns, _L_SCREW, 4)  # middle of the screw
        at(1.10, T0, Nt, _L_TUBE, 5)  # front of the push tube
        at(0.15, T0, Nt, _L_TUBE, 6)  # rear of the push tube
        tau = np.full((B, 7), _TC_TAU) * sp["tc_tau"][:, None]
        # elongation path: screw from the bearing pair to the nut's mean position, the tube
        wL = np.zeros(nn)
        wL[S0:T0] = segment_weights(xs_e, 0.5 * sum(_BEARING), 0.5 * sum(_STROKE)) * (
            0.5 * sum(_STROKE) - 0.5 * sum(_BEARING)
        )
        wL[T0:] = dxt
        # fastest rate (Gershgorin): conductances + air at the largest forced convection
        # (the annulus at _N_HI, the air at 30 W/(m² K), more than any surface here sees)
        f_hi = _g_annulus_np(_N_HI, ph["forced_convection"]) / _G_ANN_STILL
        tot = np.zeros((B, nn))
        for e, (a, b) in enumerate(zip(ei.tolist(), ej.tolist(), strict=True)):
            g_e = eg[:, e] * (f_hi if eann[e] else 1.0)
            tot[:, a] += g_e
            tot[:, b] += g_e
        g_air_hi = A * 30.0
        g_air_hi[:, S0:T0] = A[:, S0:T0] * _G_ANN_STILL * f_hi
        rho = np.max((tot + g_air_hi) / C, axis=1)
        if ph["thermocouple_lag"]:
            rho = np.maximum(rho, 1.0 / tau.min(axis=1))
        return _Arrays(
            C, ei, ej, eg, eann, A, A2, D, eps, hnat, hrad, ftype, xf, qlin, qcu, qwear, qvisc,
            tca, tcb, tcw, tau, wL, rho,
        )  # fmt: skip

    def _flags(self) -> NDArray[np.int64]:
        cc = self.concealed
        return np.array(
            [
                int("nonlinear_heat_transfer" in cc),
                int("input_dependent_heat_transfer" in cc),
                int("input_nonlinearity" in cc),
                int("time_varying_parameter" in cc),
                int(self.physics["copper_resistance"]),
                int(self.physics["thermocouple_lag"]),
                int(self.physics["forced_convection"]),
            ],
            dtype=np.int64,
        )

    def _par(self) -> NDArray[np.float64]:
        tv = self.concealed.get("time_varying_parameter", {})
        return np.array(
            [
                _D_SCREW,
                _STROKE[1] - _STROKE[0],  # the push tube's boundary layer restarts each stroke
                _LEAD,
                _ALPHA_CU,
                float(tv.get("per_km", 0.04)),
                _N_REF,
                _L_MOTOR,
                _R_SCREW,
                _R_BORE,
                _KR_FREE,
                _G_ANN_COND,
                _G_ANN_RAD,
            ]
        )

    # ------------------------------------------------------------------ contract
    def initial_state(
        self,
        specimens: Specimens,
        u0: NDArray[np.float64],
        *,
        drive_warm_K: float = 0.0,
    ) -> NDArray[np.float64]:
        """At rest at the air temperature ``u0[..., 1]``, shape (B, n_x).

        ``drive_warm_K``: the motor has not fully cooled down since the last run
        (winding and housing that much above the air, the flange 60 % of it).
        """
        B = specimens.n
        u0 = np.asarray(u0, dtype=float)
        Ta = np.broadcast_to(u0[..., 1] if u0.ndim else u0, (B,))
        x = np.repeat(Ta[:, None], self.n_states, axis=1)
        x[:, -1] = 0.0
        if drive_warm_K:
            for node, f in (("winding", 1.0), ("drive", 1.0), ("motor_flange", 0.6)):
                x[:, _IX[node]] += f * drive_warm_K
            x[:, self.n_nodes + 0] += drive_warm_K  # the drive thermocouple
        return x

    def step(
        self,
        x: NDArray[np.float64],
        u: NDArray[np.float64],
        dt: float | NDArray[np.float64],
        specimens: Specimens,
    ) -> NDArray[np.float64]:
        """The state (B, n_x) after ``dt`` seconds with ``u`` (B, 2) or (2,) held."""
        B = specimens.n
        d = self.substeps(dt, self.max_step, B)
        if np.any(d != d[0]):
            raise ShapeError("the strut plant steps every specimen by the same dt")
        if d[0] == 0.0:
            return np.array(x, dtype=float, copy=True)
        U = np.repeat(np.broadcast_to(np.asarray(u, dtype=float), (B, 2))[:, None], 2, axis=1)
        xs = np.empty((B, 2, self.n_states))
        y = np.empty((B, 2, len(OUTPUTS)))
        self._kernel(np.asarray(x, dtype=float), U, float(d[0]), specimens, y, xs, True)
        return xs[:, 1].copy()

    def outputs(
        self, x: NDArray[np.float64], u: NDArray[np.float64] | None, specimens: Specimens
    ) -> NDArray[np.float64]:
        """The seven thermocouple readings [°C] and the elongation [µm], shape (B, 8)."""
        arr = self.arrays(specimens)
        x = np.atleast_2d(x)
        nn = self.n_nodes
        if self.physics["thermocouple_lag"]:
            T = x[:, nn : nn + 7]
        else:
            T = (1 - arr.tcw) * x[:, arr.tca] + arr.tcw * x[:, arr.tcb]
        dL = 1e6 * _ALPHA_STEEL * ((x[:, :nn] - _T_REF) @ arr.wL)
        return np.column_stack([T, dL])

    def hidden(
        self, x: NDArray[np.float64], specimens: Specimens
    ) -> dict[str, NDArray[np.float64]]:
        """Truths no sensor records (:attr:`hidden_names`), each of shape (B,)."""
        x = np.asarray(x, dtype=float)
        S0, T0 = _NL, _NL + self.n_screw
        return {
            "T_winding": x[..., _IX["winding"]].copy(),
            "T_screw_mean": x[..., S0:T0].mean(axis=-1),
            "T_screw_max": x[..., S0:T0].max(axis=-1),
            "T_tube_mean": x[..., T0 : self.n_nodes].mean(axis=-1),
            "travel_km": x[..., -1].copy(),
        }

    def profiles(
        self, x: NDArray[np.float64], specimens: Specimens
    ) -> dict[str, NDArray[np.float64]]:
        """Temperature profiles along the screw and the push tube and their positions [m]."""
        x = np.atleast_2d(x)
        S0, T0 = _NL, _NL + self.n_screw
        return {
            "x_screw": (np.arange(self.n_screw) + 0.5) * _L_SCREW / self.n_screw,
            "T_screw": x[:, S0:T0].copy(),
            "x_tube": (np.arange(self.n_tube) + 0.5) * _L_TUBE / self.n_tube,
            "T_tube": x[:, T0 : self.n_nodes].copy(),
        }

    def plant_inputs(self, u: NDArray[np.float64], dt: float, t0: float) -> NDArray[np.float64]:
        """The inputs the strut sees: the logged feed rate shifted, the air disturbed.

        ``transport_delay``: the feed-rate log runs ``delay`` seconds behind the
        temperature logger, so the strut moved that much earlier than logged.
        ``unmeasured_disturbance``: an air-conditioning cycle around the strut
        that the air sensor does not see.
        """
        s = self.effect("transport_delay")
        d = self.effect("unmeasured_disturbance")
        if s is None and d is None:
            return u
        ua = np.array(u, dtype=float, copy=True)
        T = ua.shape[1]
        if s is not None:
            shift = float(s.get("delay", 600.0)) / dt
            k = np.arange(T)
            for b in range(ua.shape[0]):
                ua[b, :, 0] = np.interp(k + shift, k, ua[b, :, 0], right=ua[b, -1, 0])
        if d is not None:
            t = t0 + dt * np.arange(T)
            amp, per = float(d.get("amplitude", 1.5)), float(d.get("period", 7200.0))
            ua[:, :, 1] += amp * np.sin(2 * np.pi * t / per + float(d.get("phase", 0.0)))
        return ua

    def rate_bound(self, specimens: Specimens) -> float:
        """Bound of the fastest rate of the batch [1/s] (Gershgorin)."""
        return float(self.arrays(specimens).rho.max())

    def heat_flows(
        self, x: NDArray[np.float64], u: NDArray[np.float64], specimens: Specimens
    ) -> dict[str, NDArray[np.float64]]:
        """Heat balance at state ``x`` (B, n_x) with inputs ``u`` (B, 2) or (2,).

        Returns
        -------
        dict
            ``source`` (B, n_nodes) heat generated in each node [W]; ``g_air``
            (B, n_nodes) its conductance to the air [W/K]; ``generated`` and
            ``to_air`` (B,) their totals [W]; ``stored`` (B,) ``Σ C dT/dt`` [W];
            ``dTdt`` (B, n_nodes) each node's rate [K/s].
        """
        arr = self.arrays(specimens)
        B, nn = specimens.n, self.n_nodes
        X = np.ascontiguousarray(np.broadcast_to(np.asarray(x, dtype=float), (B, self.n_states)))
        U = np.ascontiguousarray(np.broadcast_to(np.asarray(u, dtype=float), (B, 2)))
        rec = np.zeros((B, 2, nn))
        dxdt = np.zeros((B, self.n_states))
        _flows(
            X, U, arr.C, arr.ei, arr.ej, arr.eg, arr.eann, arr.A, arr.A2, arr.D, arr.eps,
            arr.hnat, arr.hrad, arr.ftype, arr.xf, arr.qlin, arr.qcu, arr.qwear, arr.qvisc,
            arr.tca, arr.tcb, arr.tcw, arr.tctau,
            _IX["winding"] if self.physics["winding_node"] else _IX["drive"],
            self._flags(), self._par(), rec, dxdt,
        )  # fmt: skip
        to_air = np.sum(rec[:, 1] * (X[:, :nn] - U[:, 1:2]), axis=1)
        return {
            "source": rec[:, 0],
            "g_air": rec[:, 1],
            "generated": rec[:, 0].sum(axis=1),
            "to_air": to_air,
            "stored": np.sum(arr.C * dxdt[:, :nn], axis=1),
            "dTdt": dxdt[:, :nn].copy(),
        }

    def _simulate(
        self,
        u: NDArray[np.float64],
        dt: float,
        specimens: Specimens,
        x: NDArray[np.float64],
        t0: float,
    ) -> PlantRun:
        B, T, _ = u.shape
        y = np.empty((B, T, len(OUTPUTS)))
        xs = np.empty((B, T, self.n_states))
        self._kernel(x, u, dt, specimens, y, xs, True)
        hid = self.hidden(xs, specimens)
        return PlantRun(t0 + dt * np.arange(T, dtype=np.float64), u, y, xs, hid, OUTPUTS)

    def _kernel(
        self,
        x: NDArray[np.float64],
        U: NDArray[np.float64],
        dt: float,
        specimens: Specimens,
        y: NDArray[np.float64],
        xs: NDArray[np.float64],
        keep: bool,
    ) -> None:
        arr = self.arrays(specimens)
        if x.shape != (specimens.n, self.n_states):
            raise ShapeError(f"x has shape {x.shape}, expected ({specimens.n}, {self.n_states})")
        nsub = max(1, math.ceil(dt * float(arr.rho.max())))
        _simulate(
            np.ascontiguousarray(x), np.ascontiguousarray(U), float(dt), nsub,
            arr.C, arr.ei, arr.ej, arr.eg, arr.eann, arr.A, arr.A2, arr.D, arr.eps, arr.hnat,
            arr.hrad, arr.ftype, arr.xf, arr.qlin, arr.qcu, arr.qwear, arr.qvisc, arr.tca,
            arr.tcb, arr.tcw, arr.tctau,
            arr.wL, _IX["winding"] if self.physics["winding_node"] else _IX["drive"],
            self._flags(), self._par(), y, xs, keep,
        )  # fmt: skip


# ------------------------------------------------------------------ compiled kernel
@nb.njit(cache=True)
def _rhs(
    x, v, Ta, C, ei, ej, eg, eann, A, A2, D, eps, hnat, hrad, ftype, xf, qlin, qcu, qwear,
    qvisc, tca, tcb, tcw, tctau, iw, flags, par, out, rec, record,
):  # pragma: no cover - numba  # fmt: skip
    # dx/dt into out; with record, each node's heat source [W] and air conductance [W/K]
    # into rec[0], rec[1]
    nn = C.shape[0]
    nl, fan, visc, tv, cu, tc = flags[0], flags[1], flags[2], flags[3], flags[4], flags[5]
    forced = flags[6]
    n_rpm = abs(v) / par[2]
    g_ann = _g_annulus(n_rpm, forced, par[7], par[8], par[9], par[10], par[11])
    f_ann = g_ann / (par[9] * par[10] + par[11])  # the annulus' links, over their still value
    h_ax = h_moving_surface(abs(v) / 60.0, par[1])
    f_cu = 1.0 + par[3] * (x[iw] - 20.0) if cu else 1.0
    f_wear = 1.0 + par[4] * x[x.shape[0] - 1] if tv else 1.0
    f_visc = (n_rpm / par[5]) ** (5.0 / 3.0) if visc else 0.0
    av = abs(v)
    for i in range(nn):
        s = qlin[i] * av + qcu[i] * av * f_cu + qwear[i] * av * f_wear + qvisc[i] * f_visc
        g = 0.0
        if ftype[i] == 1 and A[i] > 0.0:
            # screw under the bellows: the annulus in series with the bellows' outside
            ga = A[i] * g_ann
            gc = A2[i] * (hnat[i] + hrad[i])
            if nl:  # the bellows' own rise above the air sets its free convection
                dc = (Ta - x[i]) * ga / (ga + gc)
                gc = A2[i] * (h_free_cylinder(dc, D[i]) + h_radiation(Ta - dc, Ta, eps[i]))
            g = ga * gc / (ga + gc)
        elif A[i] > 0.0:
            d = Ta - x[i]
            if nl:
                hn = h_free_cylinder(d, D[i])
                hr = h_radiation(x[i], Ta, eps[i])
            else:
                hn = hnat[i]
                hr = hrad[i]
            hf = 0.0
            if ftype[i] == 2:
                hf = h_ax
            if fan and xf[i] > 0.0:
                hf = h_mixed(hf, h_moving_surface(xf[i] * n_rpm, par[6]))
            h = h_mixed(hn, hf) if hf > 0.0 else hn
            g = A[i] * (h + hr)
        if record:
            rec[0, i] = s
            rec[1, i] = g
        out[i] = s + g * (Ta - x[i])
    for e in range(ei.shape[0]):
        a = ei[e]
        b = ej[e]
        q = eg[e] * (x[b] - x[a])
        if eann[e]:
            q *= f_ann
        out[a] += q
        out[b] -= q
    for i in range(nn):
        out[i] /= C[i]
    for c in range(7):
        src = (1.0 - tcw[c]) * x[tca[c]] + tcw[c] * x[tcb[c]]
        out[nn + c] = (src - x[nn + c]) / tctau[c] if tc else 0.0
    out[nn + 7] = av / 60000.0  # km/s


@nb.njit(cache=True)
def _simulate(
    x0, U, dt, nsub, C, ei, ej, eg, eann, A, A2, D, eps, hnat, hrad, ftype, xf, qlin, qcu,
    qwear, qvisc, tca, tcb, tcw, tctau, wL, iw, flags, par, y, xs, keep,
):  # pragma: no cover - numba  # fmt: skip
    B, T = U.shape[0], U.shape[1]
    n = x0.shape[1]
    nn = C.shape[1]
    h = dt / nsub
    x = np.empty(n)
    k1 = np.empty(n)
    k2 = np.empty(n)
    k3 = np.empty(n)
    k4 = np.empty(n)
    tmp = np.empty(n)
    rec = np.empty((2, 1))
    tc = flags[5]
    for b in range(B):
        x[:] = x0[b]
        for k in range(T):
            for c in range(7):
                if tc:
                    y[b, k, c] = x[nn + c]
                else:
                    y[b, k, c] = (1.0 - tcw[c]) * x[tca[c]] + tcw[c] * x[tcb[c]]
            s = 0.0
            for i in range(nn):
                s += wL[i] * (x[i] - 20.0)
            y[b, k, 7] = 1e6 * 11.5e-6 * s
            if keep:
                xs[b, k, :] = x
            if k + 1 == T:
                break
            v = U[b, k, 0]
            Ta = U[b, k, 1]
            for _ in range(nsub):
                _rhs(x, v, Ta, C[b], ei, ej, eg[b], eann, A[b], A2[b], D, eps, hnat, hrad,
                     ftype, xf, qlin[b], qcu[b], qwear[b], qvisc[b], tca, tcb, tcw, tctau[b],
                     iw, flags, par, k1, rec, False)  # fmt: skip
                for i in range(n):
                    tmp[i] = x[i] + 0.5 * h * k1[i]
                _rhs(tmp, v, Ta, C[b], ei, ej, eg[b], eann, A[b], A2[b], D, eps, hnat, hrad,
                     ftype, xf, qlin[b], qcu[b], qwear[b], qvisc[b], tca, tcb, tcw, tctau[b],
                     iw, flags, par, k2, rec, False)  # fmt: skip
                for i in range(n):
                    tmp[i] = x[i] + 0.5 * h * k2[i]
                _rhs(tmp, v, Ta, C[b], ei, ej, eg[b], eann, A[b], A2[b], D, eps, hnat, hrad,
                     ftype, xf, qlin[b], qcu[b], qwear[b], qvisc[b], tca, tcb, tcw, tctau[b],
                     iw, flags, par, k3, rec, False)  # fmt: skip
                for i in range(n):
                    tmp[i] = x[i] + h * k3[i]
                _rhs(tmp, v, Ta, C[b], ei, ej, eg[b], eann, A[b], A2[b], D, eps, hnat, hrad,
                     ftype, xf, qlin[b], qcu[b], qwear[b], qvisc[b], tca, tcb, tcw, tctau[b],
                     iw, flags, par, k4, rec, False)  # fmt: skip
                for i in range(n):
                    x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])


@nb.njit(cache=True)
def _flows(
    X, U, C, ei, ej, eg, eann, A, A2, D, eps, hnat, hrad, ftype, xf, qlin, qcu, qwear, qvisc,
    tca, tcb, tcw, tctau, iw, flags, par, rec, dxdt,
):  # pragma: no cover - numba  # fmt: skip
    # per specimen: node sources and air conductances (rec), and dx/dt
    for b in range(X.shape[0]):
        _rhs(X[b], U[b, 0], U[b, 1], C[b], ei, ej, eg[b], eann, A[b], A2[b], D, eps, hnat,
             hrad, ftype, xf, qlin[b], qcu[b], qwear[b], qvisc[b], tca, tcb, tcw, tctau[b], iw,
             flags, par, dxdt[b], rec[b], True)  # fmt: skip


cache_depends_on(_rhs, _convection)
cache_depends_on(_flows, _convection)
cache_depends_on(_simulate, _convection)


# ----------------------------------------------------------------------- the rig
class StrutRig(Rig):
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

    def __init__(
        self, effects: Sequence[str | EffectSpec] = (), *, off: Iterable[str] = ()
    ) -> None:
        super().__init__(effects, off=off)
        self.check_sensor_effects(OUTPUTS)

    def plant(self) -> StrutPlant:
        """The true plant with this rig's plant effects and switches."""
        return super().plant()  # type: ignore[return-value]

    @property
    def specimen(self) -> Specimens:
        """The rig's strut: drawn from :data:`SPREAD` with :data:`SPECIMEN_SEED` unless set."""
        if self._specimen is None:
            rng = np.random.default_rng(SPECIMEN_SEED)
            self._specimen = self.plant().draw_specimens(rng, 1)
        return self._specimen

    def with_specimen(self, values: Mapping[str, float] | Specimens | str) -> StrutRig:
        """A copy with another strut: ``"nominal"``, a :class:`Specimens` of one, or factors.

        Factors (names of :data:`SPREAD`) left out keep this rig's values.
        """
        if isinstance(values, str):
            if values != "nominal":
                raise ConfigError(f"specimen {values!r}; expected 'nominal', a dict or Specimens")
            values = self.plant().nominal(1)
        elif not isinstance(values, Specimens):
            bad = [k for k in values if k not in SPREAD]
            if bad:
                raise UnknownNameError(
                    f"strut specimen factor(s) {bad} unknown; factors are {list(SPREAD)} "
                    "(the rig is not the model: it has no ratio parameters)"
                )
        return super().with_specimen(values)  # type: ignore[return-value]

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
