"""Office room heated by a water radiator through an AXT211-driven valve.

Description
-----------
Plant 4 of DESIGN.md: the control loop the AXT211 actuator is built for
(``002_dae2310635fe074e.txt``, section I: room temperature control, dominant
time constants of 15 h and more). A SAUTER AXT211 wax actuator, hanging in the
room, pushes the stem of a radiator valve; the valve sets the hot-water flow
through a panel radiator; the radiator heats a two-capacity zone (room air
with furniture, building structure) that loses heat to the outdoor air.

States ``x = [T_P, T_G, x_P, x_V, T_rad, T_zone, T_struct]``: the four states
of :class:`~thermogym.models.axt211.AXT211` (wax cartridge, housing, cartridge
stroke, valve stroke) followed by the radiator water temperature, the zone air
temperature and the structure temperature.

Equations
---------
Actuator, exactly :mod:`thermogym.models.axt211` (its numba functions are
reused; equation numbers of ``002_dae2310635fe074e.txt``) with the zone air as
its environment, ``T_U = T_zone``::

    R_PTC = Σ_i R_i τ^i,  τ = (T_P − 65 °C)/35 K                          (14)
    P_PTC = (k_U u)² / R_PTC                                              (15)
    C_P dT_P/dt = P_PTC − λ_PG (T_P − T_G)                                (17)
    C_G dT_G/dt = λ_PG (T_P − T_G) − λ_GU (T_G − T_zone)                  (18)
    τ_P dx_P/dt = k_P(x_P)(T_P − T_P0) − x_P,  k_P = a x_P² + b x_P + c   (19), (21)
    x_V = backlash_c(x_P) in [0, x_max]                                   (20)

Valve (chosen here; installed characteristic with valve authority 1, i.e. a
constant differential pressure across the valve), relative stroke
``h = x_V / x_max``::

    linear:            φ(h) = h
    equal_percentage:  φ(h) = R_v^(h − 1)                  for h ≥ h_0
                       φ(h) = (h / h_0) R_v^(h_0 − 1)      for h < h_0,  h_0 = 0.05

so that ``φ(0) = 0`` (the valve shuts tight) and ``φ(1) = 1``; ``R_v`` is the
rangeability (ratio of the largest to the smallest controllable flow).

Heating curve (chosen here; linear between its design point and its foot
point at 20 °C outdoor, clipped outside)::

    T_out* = min(max(T_out, T_out_d), 20 °C)
    T_supply = T_sup_20 + (T_sup_d − T_sup_20)(20 °C − T_out*)/(20 °C − T_out_d)

Radiator: one well-mixed water node (its outlet is at ``T_rad``) whose heat
emission follows the EN 442-2 characteristic ``Φ = K ΔT^n``, calibrated so
that it emits ``Q_rad_nom`` at the design state (supply ``T_sup_d``, return
``T_sup_d − ΔT_w,nom``, room 20 °C, full flow)::

    ṁ c_w = φ(h) · Q_rad_nom / ΔT_w,nom
    C_rad dT_rad/dt = ṁ c_w (T_supply − T_rad) − Q_heat
    Q_heat = Q_rad_nom · sgn(Δ) |Δ / ΔT_ref|^n_rad,   Δ = T_rad − T_zone,
    ΔT_ref = T_sup_d − ΔT_w,nom − 20 °C

``Q_heat`` is negative only when the radiator is colder than the zone (a
supply below the zone temperature; the heat then flows back into the water).

Zone, two capacities (in the spirit of the 5R1C model of ISO 13790:2008 with
its surface node folded into the air node; chosen here)::

    C_a dT_zone/dt = Q_heat + f_int Q_int + H_as (T_struct − T_zone) + H_ao (T_out − T_zone)
    C_s dT_struct/dt = H_as (T_zone − T_struct) + H_so (T_out − T_struct) + (1 − f_int) Q_int

The energy balance ``∫(Q_heat + Q_int) dt = ΔU_a + ΔU_s + ∫[H_ao (T_zone − T_out)
+ H_so (T_struct − T_out)] dt`` with ``U_a = C_a T_zone``, ``U_s = C_s T_struct``
holds for the exact solution, and for the integrated one with RK4's own
quadrature: the update of ``C_a T_zone + C_s T_struct`` is exactly the step
times the weighted stage average of the heat flows.

Why a radiator with its own capacity (rather than a static emission law):
the radiator lags the valve by 3-4 min when it opens at design flow (the water
content is exchanged in ~3 min) and by 10-16 min when it cools with the valve
shut (the emission's slope vanishes as ``Δ → 0`` since ``n_rad > 1``). That is
the same order as the actuator's own strokes (about 5 min to open and 6 min to
close at 25 °C, longer to close in a warm room) and as the PWM periods used
with thermal actuators, so it shapes on/off and PWM results. The flow balance
also gives the concave emission-versus-flow curve of real radiators (about 1/4
of the design output at 10 % flow), the reason equal-percentage valves are used
on them; with emission proportional to ``φ`` the valve keyword would have no
physical meaning.

Left out: the actuator's own dissipation into the zone (≤ 3 W, < 0.3 % of the
design load), valve authority below 1 (pressure redistribution in the pipe
network), pipe transport delays and heat losses, and solar gains as a separate
signal (they enter ``Q_int``).

Numerics: classical Runge-Kutta 4 over all seven states with a fixed step of
at most ``max_step`` = 1 s, one numba call for the whole batch (section III-A
of ``002`` explains why fixed steps). Inside each step the valve stroke seen by
the radiator at every stage is the backlash operator (20) applied to that
stage's ``x_P`` with the memory ``x_V`` of the step start (exact while ``x_P``
is monotonic within the step); after the step ``x_V`` is updated exactly as in
:mod:`~thermogym.models.axt211`, so with the zone temperature held the
actuator reproduces the stand-alone model. Against a 1/8 s reference over a
day of 15-min on/off operation, 1 s steps are within 1e-5 K (``T_zone``),
0.01 W (``Q_heat``) and 2e-3 mm (``x_V``; this largest error lasts the one
step in which the cartridge reaches its end stop, elsewhere it is below
1e-5 mm). 2 s steps would halve the cost at 2-4× those errors; 1 s, the
AXT211's own step, is kept so that the actuator in the room matches the
stand-alone model step for step, and a year already takes only seconds (about
0.2 µs per step and system: a year at 10 s samples in about 6 s for one
system). Batches of 32 or more systems run one system per thread.

Action Space
------------
``u`` in [0, 1]: normalised heater command of the actuator (PWM duty or on/off),
as :class:`~thermogym.models.axt211.AXT211`.

Observation Space
-----------------
Outputs, in this order: ``T_zone``, ``T_struct``, ``T_rad``, ``T_supply`` [°C],
``Q_heat`` [W], ``x_V``, ``x_P`` [mm], ``P_PTC`` [W], ``T_P``, ``T_G`` [°C].
Disturbances: ``k_U`` [V] (actuator supply), ``T_out`` [°C], ``Q_int`` [W]
(internal and solar gains; negative values are accepted as extra losses).

Rewards
-------
None at model level; environments compute them from the KPIs of DESIGN.md
(``discomfort_Kh``, ``heat_delivered_kWh``, ``actuator_energy_Wh``, ...).

Starting State
--------------
:meth:`RoomModel.initial_state`: the steady state of the unheated building for
the first disturbance sample (valve shut, radiator and actuator at the zone
temperature, cartridge retracted), so a simulation starts without a transient.

Episode End
-----------
None at model level.

Arguments
---------
``valve``: ``"linear"`` (default) or ``"equal_percentage"`` (adds the parameter
``R_v``); ``effects``: actuator effects of
:data:`~thermogym.models.axt211.AXT211_EFFECTS`, passed through.

Parameter values
----------------
The first parameters are those of :class:`~thermogym.models.axt211.AXT211`
(same names, same defaults, same order, then the selected actuator effects);
the room's own follow. Building: ~20 m² office (2.7 m high, 54 m³) with one
facade in a moderately insulated, medium-weight building.

==========  =========  ======  ============================================================
parameter   nominal    unit    provenance
==========  =========  ======  ============================================================
C_a         3.0e5      J/K     chosen: air 65 kJ/K (54 m³) plus furniture and light
                               internal mass; air-node time constant ≈ 10 min
C_s         3.3e6      J/K     ISO 13790:2008 Table 12, medium class: 165 kJ/(m²·K) × 20 m²
H_as        455        W/K     ISO 13790:2008 5R1C: h_ms A_m, h_ms = 9.1 W/(m²K), A_m = 2.5 A_f
                               (medium class, Table 12), A_f = 20 m²
H_ao        13         W/K     chosen: ventilation 0.5 1/h × 54 m³ × 0.34 Wh/(m³K) = 9.2 W/K
                               plus a 3 m² window at 1.3 W/(m²K)
H_so        21.3       W/K     chosen: remaining transmission, so that H_ao + H_as‖H_so
                               = 33.35 W/K, design load 1.0 kW at 20 °C / −10 °C
f_int       0.5        1       ISO 13790:2008 annex C: half of the internal gains to the air
Q_rad_nom   1200       W       chosen: radiator sized 1.2 × the design load
n_rad       1.3        1       EN 442-2 radiator exponent (panel radiators 1.25-1.35)
dT_w_nom    10         K       chosen: 55/45 °C design water temperatures
C_rad       3.8e4      J/K     chosen: double panel ~6 l water (25 kJ/K) + ~28 kg steel
T_out_d     −10        °C      chosen: design outdoor temperature (central Europe)
T_sup_d     55         °C      chosen: low-temperature radiator system design supply
T_sup_20    20         °C      chosen: heating-curve foot point (supply at 20 °C outdoor)
R_v         25         1       chosen: rangeability of a small equal-percentage valve
                               (``valve="equal_percentage"`` only)
==========  =========  ======  ============================================================

With these values the zone's time constants are ≈ 29 h (structure, dominant)
and ≈ 10 min (air); the radiator's is 3.5 min at design flow (valve open) and
10-16 min when it cools with the valve shut (excess temperature 25 to 5 K). At
10 % flow the radiator gives 26 % of its design output, at 50 % flow 75 %.

Version History
---------------
* v1: initial release.
"""

from __future__ import annotations

from typing import Any

import numba as nb
import numpy as np
from numpy.typing import ArrayLike, NDArray

from thermogym._jitcache import module_kernels_depend_on
from thermogym.errors import ConfigError, ParameterError, ShapeError
from thermogym.models import _vmath
from thermogym.models import axt211 as _axt211_module
from thermogym.models._effects import EffectLayout
from thermogym.models._vmath import vpow
from thermogym.models.axt211 import (
    _I_C,
    _I_CG,
    _I_CP,
    _I_TAU,
    _I_XMAX,
    _N_LANE,
    AXT211_EFFECTS,
    AXT211_PARAMETERS,
    AXT211_SIGNALS,
    _backlash,
    _backlash_lane,
    _lane_column,
    _power,
    _rhs,
    _rhs_lane,
)
from thermogym.models.base import Model, Parameter, Signal

__all__ = ["MODELS", "ROOM_PARAMETERS", "ROOM_SIGNALS", "VALVES", "RoomModel", "valve_flow"]

#: Valve characteristics and their kernel codes.
VALVES: dict[str, int] = {"linear": 0, "equal_percentage": 1}

_C = "chosen here"
_T_DESIGN = 20.0  # design indoor temperature and heating-curve foot point [°C]
_H0 = 0.05  # relative stroke below which the equal-percentage valve closes linearly

ROOM_SIGNALS: tuple[Signal, ...] = (
    AXT211_SIGNALS[0],
    AXT211_SIGNALS[1],
    Signal("T_out", "disturbance", "°C", "outdoor air temperature"),
    Signal("Q_int", "disturbance", "W", "internal and solar heat gains of the zone"),
    Signal("T_zone", "output", "°C", "zone air (and furniture) temperature"),
    Signal("T_struct", "output", "°C", "building structure temperature"),
    Signal("T_rad", "output", "°C", "radiator water (outlet) temperature"),
    Signal("T_supply", "output", "°C", "supply water temperature from the heating curve"),
    Signal("Q_heat", "output", "W", "heat emitted by the radiator into the zone"),
    Signal("x_V", "output", "mm", "valve stroke (0 = shut)"),
    Signal("x_P", "output", "mm", "wax cartridge stroke (from the rod contact point)"),
    Signal("P_PTC", "output", "W", "actuator PTC power consumption (15)"),
    Signal("T_P", "output", "°C", "actuator wax cartridge temperature"),
    Signal("T_G", "output", "°C", "actuator housing temperature"),
)

ROOM_PARAMETERS: tuple[Parameter, ...] = (
    Parameter(
        "C_a",
        3.0e5,
        3.0e4,
        3.0e6,
        "J/K",
        "heat capacity of the zone air and furniture",
        _C + ": air 65 kJ/K + furniture and light internal mass of a 20 m² office",
        "zone",
    ),
    Parameter(
        "C_s",
        3.3e6,
        3.0e5,
        3.0e7,
        "J/K",
        "effective heat capacity of the building structure",
        "ISO 13790:2008 Table 12, medium class 165 kJ/(m²K) × 20 m² floor",
        "zone",
    ),
    Parameter(
        "H_as",
        455.0,
        50.0,
        3000.0,
        "W/K",
        "conductance zone air ↔ structure (surface heat transfer)",
        "ISO 13790:2008 5R1C: h_ms A_m = 9.1 W/(m²K) × 2.5 × 20 m² (medium class)",
        "zone",
    ),
    Parameter(
        "H_ao",
        13.0,
        0.5,
        300.0,
        "W/K",
        "conductance zone air ↔ outdoor (ventilation, windows)",
        _C + ": 0.5 1/h × 54 m³ × 0.34 Wh/(m³K) + 3 m² window at 1.3 W/(m²K)",
        "zone",
    ),
    Parameter(
        "H_so",
        21.3,
        0.5,
        300.0,
        "W/K",
        "conductance structure ↔ outdoor (opaque envelope)",
        _C + ": design load 1.0 kW at 20 °C inside, −10 °C outside",
        "zone",
    ),
    Parameter(
        "f_int",
        0.5,
        0.0,
        1.0,
        "1",
        "fraction of Q_int released into the zone air (rest into the structure)",
        "ISO 13790:2008 annex C: half of the internal gains to the air node",
        "zone",
    ),
    Parameter(
        "Q_rad_nom",
        1200.0,
        100.0,
        10000.0,
        "W",
        "radiator output at design supply/return, room 20 °C, full flow",
        _C + ": 1.2 × the 1.0 kW design heat load",
        "radiator",
    ),
    Parameter(
        "n_rad",
        1.3,
        1.0,
        1.6,
        "1",
        "radiator exponent of Φ = K ΔT^n",
        "EN 442-2 characteristic; 1.25-1.35 for panel radiators",
        "radiator",
    ),
    Parameter(
        "dT_w_nom",
        10.0,
        2.0,
        40.0,
        "K",
        "design water temperature drop (sets the design flow)",
        _C + ": 55/45 °C system",
        "radiator",
    ),
    Parameter(
        "C_rad",
        3.8e4,
        2.0e3,
        5.0e5,
        "J/K",
        "heat capacity of the radiator with its water",
        _C + ": double panel radiator, ~6 l water + ~28 kg steel",
        "radiator",
    ),
    Parameter(
        "T_out_d",
        -10.0,
        -40.0,
        10.0,
        "°C",
        "design outdoor temperature (heating-curve design point)",
        _C + ": central European design outdoor temperature",
        "heating_curve",
    ),
    Parameter(
        "T_sup_d",
        55.0,
        25.0,
        95.0,
        "°C",
        "supply temperature at the design outdoor temperature",
        _C + ": low-temperature radiator system",
        "heating_curve",
    ),
    Parameter(
        "T_sup_20",
        20.0,
        10.0,
        45.0,
        "°C",
        "supply temperature at 20 °C outdoor (heating-curve foot point)",
        _C + ": foot point at the room set point",
        "heating_curve",
    ),
    Parameter(
        "R_v",
        25.0,
        2.0,
        200.0,
        "1",
        "rangeability of the equal-percentage valve",
        _C + ": small equal-percentage radiator valve",
        "valve",
    ),
)

# Kernel layout: the AXT211 kernel's full vector (base + every effect) followed by the room's.
_NA = 22
_I_CA, _I_CS, _I_HAS, _I_HAO, _I_HSO, _I_FINT = 22, 23, 24, 25, 26, 27
_I_QN, _I_NR, _I_DTW, _I_CR = 28, 29, 30, 31
_I_TOD, _I_TSD, _I_TS20, _I_RV = 32, 33, 34, 35
_NX, _NY = 7, 10

_AXT_FULL = len(AXT211_PARAMETERS) + sum(len(e.parameters) for e in AXT211_EFFECTS.values())
if _AXT_FULL != _NA or [p.name for p in ROOM_PARAMETERS][_I_RV - _NA] != "R_v":
    raise ImportError(
        f"thermogym.models.room expects the AXT211 kernel vector to have {_NA} entries, it has "
        f"{_AXT_FULL}; update the _I_* indices of room.py"
    )


# ----------------------------------------------------------------------------- kernels
@nb.njit(cache=True, inline="always")
def _valve(h: float, Rv: float, kind: int) -> float:
    # relative flow φ(h); linear, or equal percentage R_v^(h−1) with a linear leak-off
    if h <= 0.0:
        return 0.0
    if h >= 1.0:
        return 1.0
    if kind == 0:
        return h
    if h < _H0:
        return h / _H0 * Rv ** (_H0 - 1.0)
    return vpow(Rv, h - 1.0)


@nb.njit(cache=True, inline="always")
def _supply(Tout: float, p: NDArray[np.float64]) -> float:
    # heating curve, linear in T_out between T_out_d and 20 °C, clipped outside
    return _supply_at(Tout, p[_I_TOD], p[_I_TS20], p[_I_TSD])


@nb.njit(cache=True, inline="always")
def _supply_at(Tout: float, Td: float, Ts20: float, Tsd: float) -> float:
    # _supply from the parameters T_out_d, T_sup_20, T_sup_d
    To = min(max(Tout, Td), _T_DESIGN)
    return Ts20 + (Tsd - Ts20) * (_T_DESIGN - To) / (_T_DESIGN - Td)


@nb.njit(cache=True, inline="always")
def _emission(Tr: float, Ta: float, p: NDArray[np.float64], iref: float) -> float:
    # Q_heat = Q_rad_nom sgn(Δ)|Δ/ΔT_ref|^n_rad (EN 442-2); iref = 1/ΔT_ref
    d = Tr - Ta
    q = p[_I_QN] * vpow(abs(d) * iref, p[_I_NR])
    return q if d >= 0.0 else -q


@nb.njit(cache=True, inline="always")
def _inv_ref(p: NDArray[np.float64]) -> float:
    # 1/ΔT_ref, ΔT_ref = T_sup_d − ΔT_w,nom − 20 °C: radiator excess temperature at design
    return 1.0 / (p[_I_TSD] - p[_I_DTW] - _T_DESIGN)


@nb.njit(cache=True, inline="always")
def _deriv(
    TP: float,
    TG: float,
    xP: float,
    Tr: float,
    Ta: float,
    Ts: float,
    xV0: float,
    u: float,
    kU: float,
    Tsup: float,
    Tout: float,
    Qint: float,
    p: NDArray[np.float64],
    kind: int,
    k: tuple[float, float, float, float, float, float, float, float, float],
) -> tuple[float, float, float, float, float, float]:
    # k: per-call constants, see _advance
    mcn, icr, ica, ics, iref, ixmax, icp, icg, itau = k
    # actuator (17)-(19), its environment is the zone air: T_U = T_zone
    dTP, dTG, dxP = _rhs(TP, TG, xP, u, kU, Ta, p, icp, icg, itau)
    # (20) at this stage, from the valve stroke at the start of the step
    xV = _backlash(xP, xV0, p[_I_C], p[_I_XMAX])
    phi = _valve(xV * ixmax, p[_I_RV], kind)
    Q = _emission(Tr, Ta, p, iref)
    # C_rad dT_rad/dt = ṁ c_w (T_sup − T_rad) − Q_heat,  ṁ c_w = φ Q_rad_nom / ΔT_w,nom
    dTr = (phi * mcn * (Tsup - Tr) - Q) * icr
    f = p[_I_FINT]
    q_as = p[_I_HAS] * (Ts - Ta)
    # C_a dT_a/dt = Q_heat + f Q_int + H_as (T_s − T_a) + H_ao (T_out − T_a)
    dTa = (Q + f * Qint + q_as + p[_I_HAO] * (Tout - Ta)) * ica
    # C_s dT_s/dt = H_as (T_a − T_s) + H_so (T_out − T_s) + (1 − f) Q_int
    dTs = (-q_as + p[_I_HSO] * (Tout - Ts) + (1.0 - f) * Qint) * ics
    return dTP, dTG, dxP, dTr, dTa, dTs


@nb.njit(cache=True)
def _advance(
    x: NDArray[np.float64],
    u: float,
    kU: float,
    Tout: float,
    Qint: float,
    p: NDArray[np.float64],
    h: float,
    n: int,
    kind: int,
) -> None:
    TP, TG, xP, xV, Tr, Ta, Ts = x[0], x[1], x[2], x[3], x[4], x[5], x[6]
    c = p[_I_C]
    xmax = p[_I_XMAX]
    lo = -c
    hi = xmax + c
    Tsup = _supply(Tout, p)  # T_out is held over the sample
    # ṁ_nom c_w, 1/C_rad, 1/C_a, 1/C_s, 1/ΔT_ref, 1/x_max, then 1/C_P, 1/C_G, 1/τ_P for axt211._rhs
    k = (
        p[_I_QN] / p[_I_DTW],
        1.0 / p[_I_CR],
        1.0 / p[_I_CA],
        1.0 / p[_I_CS],
        _inv_ref(p),
        1.0 / xmax,
        1.0 / p[_I_CP],
        1.0 / p[_I_CG],
        1.0 / p[_I_TAU],
    )
    hh = 0.5 * h
    w = h / 6.0
    for _ in range(n):
        # classical RK4, fixed step h, all seven states together
        a1, b1, c1, d1, e1, f1 = _deriv(
            TP, TG, xP, Tr, Ta, Ts, xV, u, kU, Tsup, Tout, Qint, p, kind, k
        )
        a2, b2, c2, d2, e2, f2 = _deriv(
            TP + hh * a1, TG + hh * b1, xP + hh * c1, Tr + hh * d1, Ta + hh * e1, Ts + hh * f1,
            xV, u, kU, Tsup, Tout, Qint, p, kind, k,
        )  # fmt: skip
        a3, b3, c3, d3, e3, f3 = _deriv(
            TP + hh * a2, TG + hh * b2, xP + hh * c2, Tr + hh * d2, Ta + hh * e2, Ts + hh * f2,
            xV, u, kU, Tsup, Tout, Qint, p, kind, k,
        )  # fmt: skip
        a4, b4, c4, d4, e4, f4 = _deriv(
            TP + h * a3, TG + h * b3, xP + h * c3, Tr + h * d3, Ta + h * e3, Ts + h * f3,
            xV, u, kU, Tsup, Tout, Qint, p, kind, k,
        )  # fmt: skip
        TP += w * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
        TG += w * (b1 + 2.0 * b2 + 2.0 * b3 + b4)
        xP += w * (c1 + 2.0 * c2 + 2.0 * c3 + c4)
        Tr += w * (d1 + 2.0 * d2 + 2.0 * d3 + d4)
        Ta += w * (e1 + 2.0 * e2 + 2.0 * e3 + e4)
        Ts += w * (f1 + 2.0 * f2 + 2.0 * f3 + f4)
        # end stops and (20), as in axt211._advance
        xP = min(max(xP, lo), hi)
        xV = _backlash(xP, xV, c, xmax)
    x[0], x[1], x[2], x[3], x[4], x[5], x[6] = TP, TG, xP, xV, Tr, Ta, Ts


@nb.njit(cache=True)
def _outputs(
    x: NDArray[np.float64],
    u: float,
    kU: float,
    Tout: float,
    p: NDArray[np.float64],
    y: NDArray[np.float64],
) -> None:
    P, _ = _power(x[0], u, kU, p)  # (15)
    y[0] = x[5]
    y[1] = x[6]
    y[2] = x[4]
    y[3] = _supply(Tout, p)
    y[4] = _emission(x[4], x[5], p, _inv_ref(p))
    y[5] = x[3]
    y[6] = x[2]
    y[7] = P
    y[8] = x[0]
    y[9] = x[1]


@nb.njit(cache=True)
def _simulate_one(
    p: NDArray[np.float64],
    u: NDArray[np.float64],
    x0: NDArray[np.float64],
    h: float,
    n: int,
    kind: int,
    y: NDArray[np.float64],
    xs: NDArray[np.float64],
    keep: bool,
) -> None:
    # one system over the whole grid: y[k] = h(x[k]), x[k+1] = Φ(x[k], u[k])
    x = x0.copy()
    T = u.shape[0]
    for k in range(T):
        uk = u[k]
        _outputs(x, uk[0], uk[1], uk[2], p, y[k])
        if keep:
            xs[k, :] = x
        if k + 1 < T:
            _advance(x, uk[0], uk[1], uk[2], uk[3], p, h, n, kind)


@nb.njit(cache=True)
def _simulate_serial(
    theta: NDArray[np.float64],
    u: NDArray[np.float64],
    x0: NDArray[np.float64],
    h: float,
    n: int,
    kind: int,
    y: NDArray[np.float64],
    xs: NDArray[np.float64],
    keep: bool,
) -> None:
    # u has B rows, or one row shared by the batch; xs has B rows when keep
    for b in range(y.shape[0]):
        ub = u[0] if u.shape[0] == 1 else u[b]
        _simulate_one(theta[b], ub, x0[b], h, n, kind, y[b], xs[b if keep else 0], keep)


@nb.njit(cache=True, parallel=True)
def _simulate_parallel(
    theta: NDArray[np.float64],
    u: NDArray[np.float64],
    x0: NDArray[np.float64],
    h: float,
    n: int,
    kind: int,
    y: NDArray[np.float64],
    xs: NDArray[np.float64],
    keep: bool,
) -> None:
    # one system per thread; each writes only its own rows, so results equal the serial ones
    for b in nb.prange(y.shape[0]):
        i = np.int64(b)  # the prange index is unsigned; keep index arithmetic signed
        ub = u[0] if u.shape[0] == 1 else u[i]
        _simulate_one(theta[i], ub, x0[i], h, n, kind, y[i], xs[i if keep else 0], keep)


# Threads pay off only for larger batches (start-up ~10 µs), as in axt211. Steps of an
# environment stay serial: 1024 systems take ~1 ms, where thread hand-offs cost more than
# they save on a loaded machine (measured 8 ms with 2 threads on 2 busy cores).
_PARALLEL_MIN_BATCH = 32


@nb.njit(cache=True)
def _bad_input_row(u: NDArray[np.float64]) -> int:
    # first row with u outside [0, 1], k_U < 0 or a non-finite value; −1 when all are valid
    for b in range(u.shape[0]):
        ub = u[b]
        if not (0.0 <= ub[0] <= 1.0 and ub[1] >= 0.0):
            return b
        if not (np.isfinite(ub[1]) and np.isfinite(ub[2]) and np.isfinite(ub[3])):
            return b
    return -1


@nb.njit(cache=True, inline="always")
def _fill(p: NDArray[np.float64], theta_b: NDArray[np.float64], cols: NDArray[np.int64]) -> None:
    # public parameter set -> kernel vector (absent effects and R_v keep their neutral values)
    for j in range(cols.shape[0]):
        p[cols[j]] = theta_b[j]


@nb.njit(cache=True)
def _step_kernel(
    x: NDArray[np.float64],
    u: NDArray[np.float64],
    theta: NDArray[np.float64],
    cols: NDArray[np.int64],
    neutral: NDArray[np.float64],
    h: float,
    n: int,
    kind: int,
) -> int:
    # advance every system in place; theta is the public batch (1 or B rows), expanded here
    bad = _bad_input_row(u)
    if bad >= 0:
        return bad
    p = neutral.copy()
    for b in range(x.shape[0]):
        if b == 0 or theta.shape[0] > 1:
            _fill(p, theta[b], cols)
        _advance(x[b], u[b, 0], u[b, 1], u[b, 2], u[b, 3], p, h, n, kind)
    return -1


@nb.njit(cache=True)
def _output_kernel(
    x: NDArray[np.float64],
    u: NDArray[np.float64],
    theta: NDArray[np.float64],
    cols: NDArray[np.int64],
    neutral: NDArray[np.float64],
    y: NDArray[np.float64],
) -> int:
    bad = _bad_input_row(u)
    if bad >= 0:
        return bad
    p = neutral.copy()
    for b in range(x.shape[0]):
        if b == 0 or theta.shape[0] > 1:
            _fill(p, theta[b], cols)
        _outputs(x[b], u[b, 0], u[b, 1], u[b, 2], p, y[b])
    return -1


# ----------------------------------------------------------------------------- lockstep lanes
# Batch-innermost pieces of _deriv for the environments' lockstep kernels (see the lane
# functions of axt211): the right-hand side of one system ("lane"), branch-free so that a
# loop over lanes vectorises; the actuator part is axt211's own lane right-hand side, the
# rest is _deriv operation for operation, so a lane reproduces _advance bit for bit (for
# actuator parameter sets without an active effect). The power laws (emission,
# equal-percentage valve) use _vmath.vpow, which vectorises (libm's pow does not without
# SVML) and is the same function in _deriv, so results stay identical.

#: Rows of the room's lane table after the AXT211 rows (axt211._N_LANE of them).
(
    _LR_MCN, _LR_ICR, _LR_ICA, _LR_ICS, _LR_IREF, _LR_IXMAX, _LR_RV, _LR_RVH, _LR_QN, _LR_NR,
    _LR_FINT, _LR_HAS, _LR_HAO, _LR_HSO,
) = range(_N_LANE, _N_LANE + 14)  # fmt: skip
_N_ROOM_LANE = _N_LANE + 14


@nb.njit(cache=True)
def _room_lane_column(p: NDArray[np.float64], out: NDArray[np.float64], b: int) -> None:
    """Fill column ``b`` of a room lane table (_N_ROOM_LANE, B) from a full kernel vector.

    The AXT211 rows (:func:`thermogym.models.axt211._lane_column`; the room's kernel vector
    starts with the AXT211 one), then ṁ_nom c_w = Q_rad_nom/ΔT_w,nom, 1/C_rad, 1/C_a,
    1/C_s, 1/ΔT_ref, 1/x_max, R_v, R_v^(h_0 − 1), Q_rad_nom, n_rad, f_int, H_as, H_ao, H_so.
    """
    _lane_column(p, out, b)
    out[_LR_MCN, b] = p[_I_QN] / p[_I_DTW]
    out[_LR_ICR, b] = 1.0 / p[_I_CR]
    out[_LR_ICA, b] = 1.0 / p[_I_CA]
    out[_LR_ICS, b] = 1.0 / p[_I_CS]
    out[_LR_IREF, b] = _inv_ref(p)
    out[_LR_IXMAX, b] = 1.0 / p[_I_XMAX]
    out[_LR_RV, b] = p[_I_RV]
    out[_LR_RVH, b] = p[_I_RV] ** (_H0 - 1.0)
    out[_LR_QN, b] = p[_I_QN]
    out[_LR_NR, b] = p[_I_NR]
    out[_LR_FINT, b] = p[_I_FINT]
    out[_LR_HAS, b] = p[_I_HAS]
    out[_LR_HAO, b] = p[_I_HAO]
    out[_LR_HSO, b] = p[_I_HSO]


@nb.njit(cache=True, inline="always")
def _room_lane_load(wb: NDArray[np.float64], o: int, W: int, i: int) -> tuple:  # type: ignore[type-arg]
    # lane i's room parameters from a block array holding room lane rows o.. (row length W)
    return (
        wb[o * W + i], wb[(o + 1) * W + i], wb[(o + 2) * W + i], wb[(o + 3) * W + i],
        wb[(o + 4) * W + i], wb[(o + 5) * W + i], wb[(o + 6) * W + i], wb[(o + 7) * W + i],
        wb[(o + 8) * W + i], wb[(o + 9) * W + i], wb[(o + 10) * W + i],
        wb[(o + 11) * W + i], wb[(o + 12) * W + i], wb[(o + 13) * W + i],
    )  # fmt: skip


@nb.njit(cache=True, inline="always")
def _valve_lane(h: float, RvH: float, pwv: float, kind: int) -> float:
    # _valve with selects: RvH = R_v^(h_0 − 1); pwv = R_v^(h − 1), evaluated by the caller
    # (equal percentage only; kind is a compile-time constant of the calling kernel)
    phi = h if kind == 0 else (h / _H0 * RvH if h < _H0 else pwv)
    return 0.0 if h <= 0.0 else (1.0 if h >= 1.0 else phi)


@nb.njit(cache=True, inline="always")
def _stroke_lane(xP: float, xV0: float, qa: tuple, ixmax: float) -> float:  # type: ignore[type-arg]
    # relative valve stroke h = x_V / x_max at a stage: (20) from the step-start stroke xV0
    return _backlash_lane(xP, xV0, qa[18], qa[19]) * ixmax


@nb.njit(cache=True, inline="always")
def _emission_base(Tr: float, Ta: float, iref: float) -> float:
    # |Δ| / ΔT_ref, the base of the emission's power law
    return abs(Tr - Ta) * iref


@nb.njit(cache=True, inline="always")
def _emission_signed(Tr: float, Ta: float, QN: float, pw: float) -> float:
    # _emission from pw = |Δ/ΔT_ref|^n_rad: Q_heat = Q_rad_nom sgn(Δ) pw (EN 442-2)
    q = QN * pw
    return q if Tr - Ta >= 0.0 else -q


@nb.njit(cache=True, inline="always")
def _deriv_lane(
    TP: float,
    TG: float,
    xP: float,
    Tr: float,
    Ta: float,
    Ts: float,
    xV0: float,
    v2: float,
    Tsup: float,
    Tout: float,
    Qint: float,
    Q: float,
    pwv: float,
    qa: tuple,  # type: ignore[type-arg]
    qr: tuple,  # type: ignore[type-arg]
    kind: int,
) -> tuple[float, float, float, float, float, float, float]:
    # _deriv for one lane, given the stage's emission Q (and pwv, see _valve_lane): the
    # power laws are left to the caller, so that a kernel can evaluate them in a loop of
    # their own; also returns R_PTC
    mcn, icr, ica, ics, _, ixmax, _, RvH, _, _, f, Has, Hao, Hso = qr
    dTP, dTG, dxP, R = _rhs_lane(TP, TG, xP, v2, Ta, qa)  # (17)-(19), T_U = T_zone
    phi = _valve_lane(_stroke_lane(xP, xV0, qa, ixmax), RvH, pwv, kind)
    # C_rad dT_rad/dt = ṁ c_w (T_sup − T_rad) − Q_heat,  ṁ c_w = φ Q_rad_nom / ΔT_w,nom
    dTr = (phi * mcn * (Tsup - Tr) - Q) * icr
    q_as = Has * (Ts - Ta)
    # C_a dT_a/dt = Q_heat + f Q_int + H_as (T_s − T_a) + H_ao (T_out − T_a)
    dTa = (Q + f * Qint + q_as + Hao * (Tout - Ta)) * ica
    # C_s dT_s/dt = H_as (T_a − T_s) + H_so (T_out − T_s) + (1 − f) Q_int
    dTs = (-q_as + Hso * (Tout - Ts) + (1.0 - f) * Qint) * ics
    return dTP, dTG, dxP, dTr, dTa, dTs, R


def valve_flow(
    h: ArrayLike, valve: str = "linear", rangeability: float = 25.0
) -> NDArray[np.float64]:
    """Relative flow φ of the radiator valve at relative stroke ``h``.

    Parameters
    ----------
    h : array_like
        Relative valve stroke ``x_V / x_max`` [1]; clipped to [0, 1].
    valve : {"linear", "equal_percentage"}
        Valve characteristic.
    rangeability : float
        Rangeability ``R_v`` [1] of the equal-percentage characteristic (> 1).

    Returns
    -------
    ndarray
        Relative flow [1], 0 when shut and 1 when fully open.

    Raises
    ------
    ConfigError
        Unknown ``valve``.
    ParameterError
        ``rangeability`` not above 1.

    Examples
    --------
    >>> from thermogym.models.room import valve_flow
    >>> valve_flow([0.0, 0.5, 1.0], "equal_percentage", 25.0).round(3).tolist()
    [0.0, 0.2, 1.0]
    """
    kind = _valve_kind(valve)
    if not (np.isfinite(rangeability) and rangeability > 1.0):
        raise ParameterError(f"rangeability is {rangeability!r}; expected a number above 1")
    ha = np.asarray(h, dtype=float)
    out = np.array([_valve(float(v), float(rangeability), kind) for v in ha.ravel()])
    return out.reshape(ha.shape)


def _valve_kind(valve: str) -> int:
    try:
        return VALVES[valve]
    except (KeyError, TypeError):
        raise ConfigError(f"valve is {valve!r}; expected one of {sorted(VALVES)}") from None


class RoomModel(Model):
    """Office room heated by a radiator through an AXT211-driven valve.

    The AXT211 actuator (paper 002, eqs 14-21) sits in the zone and moves the
    valve of a one-node radiator that heats a two-capacity zone; see the module
    docstring for the equations and the parameter table.

    Parameters
    ----------
    valve : {"linear", "equal_percentage"}
        Valve characteristic; ``"equal_percentage"`` adds the parameter
        ``R_v`` (rangeability).
    effects : sequence of str
        Physical effects of the actuator to include (``phase_change``,
        ``nonlinear_heat_transfer``, ``supply_variation``); their parameters
        follow the AXT211 base parameters, before the room's own.

    Raises
    ------
    ConfigError
        Unknown ``valve``.
    UnknownNameError
        Unknown effect.

    Examples
    --------
    >>> import numpy as np
    >>> from thermogym.models.room import RoomModel
    >>> m = RoomModel()
    >>> T = 3 * 360  # three hours at 10 s: heater on, 24 V, 0 °C outside, 200 W gains
    >>> u = np.column_stack([np.ones(T), np.full(T, 24.0), np.zeros(T), np.full(T, 200.0)])
    >>> sim = m.simulate(u, dt=10.0)
    >>> round(float(sim.output("x_V")[0, -1]), 2)  # valve fully open
    4.5
    >>> bool(sim.output("T_zone")[0, -1] > sim.output("T_zone")[0, 0] + 2.0)
    True
    """

    name = "room"
    version = "1"
    max_step = 1.0
    physical_effects = AXT211_EFFECTS

    def __init__(self, valve: str = "linear", effects: tuple[str, ...] | list[str] = ()) -> None:
        self._valve_name = valve
        self._kind = _valve_kind(valve)
        self._layout = EffectLayout(AXT211_PARAMETERS, AXT211_EFFECTS, effects, self.name)
        room = ROOM_PARAMETERS if self._kind == 1 else ROOM_PARAMETERS[:-1]
        public = (*self._layout.public, *room)
        full = (*self._layout.full, *ROOM_PARAMETERS)
        super().__init__(
            ROOM_SIGNALS, public, ("T_P", "T_G", "x_P", "x_V", "T_rad", "T_zone", "T_struct")
        )
        index = {p.name: i for i, p in enumerate(full)}
        self._cols = np.array([index[p.name] for p in public], dtype=np.int64)
        self._neutral = np.array([p.nominal for p in full], dtype=float)

    @property
    def valve(self) -> str:
        """Valve characteristic of this instance."""
        return self._valve_name

    @property
    def effects(self) -> tuple[str, ...]:
        """Physical effects of the actuator this instance includes."""
        return self._layout.selected

    def config(self) -> dict[str, Any]:
        """Constructor arguments (stored in FitResults)."""
        cfg: dict[str, Any] = {"valve": self._valve_name}
        if self._layout.selected:
            cfg["effects"] = list(self._layout.selected)
        return cfg

    def full_theta(self, theta: NDArray[np.float64]) -> NDArray[np.float64]:
        """Kernel parameter vector: AXT211 full vector (absent effects neutral), then the room's."""
        out = np.repeat(self._neutral[None, :], theta.shape[0], axis=0)
        out[:, self._cols] = theta
        return out

    def _validate_theta(self, theta: NDArray[np.float64]) -> None:
        self._require_positive(
            theta,
            (
                "C_P", "lambda_PG", "C_G", "lambda_GU", "tau_P", "x_max",
                "C_a", "C_s", "H_as", "H_ao", "H_so", "Q_rad_nom", "dT_w_nom", "C_rad",
            ),
        )  # fmt: skip
        col = {n: theta[:, self.param_index(n)] for n in ("f_int", "n_rad", "T_out_d")}
        checks = [
            ("f_int", (col["f_int"] < 0) | (col["f_int"] > 1), "must lie in [0, 1]"),
            ("n_rad", col["n_rad"] < 1, "must be at least 1 (EN 442 exponents are 1.2-1.4)"),
            ("T_out_d", col["T_out_d"] >= _T_DESIGN, "must be below 20 °C"),
        ]
        tsd = theta[:, self.param_index("T_sup_d")]
        t20 = theta[:, self.param_index("T_sup_20")]
        dtw = theta[:, self.param_index("dT_w_nom")]
        checks.append(("T_sup_d", tsd < t20, "must not be below T_sup_20"))
        checks.append(
            ("T_sup_d", tsd - dtw <= _T_DESIGN, "minus dT_w_nom (design return) must exceed 20 °C")
        )
        if self._kind == 1:
            checks.append(("R_v", theta[:, self.param_index("R_v")] <= 1, "must exceed 1"))
        for name, bad, what in checks:
            if bad.any():
                b = int(np.argmax(bad))
                v = float(theta[b, self.param_index(name)])
                raise ParameterError(f"parameter {name!r} of set {b} is {v!r}; it {what}")

    @staticmethod
    def _check_u(u: NDArray[np.float64]) -> None:
        uu = u[..., 0]
        bad = (uu < 0) | (uu > 1)
        if bad.any():
            raise ShapeError(
                f"input 'u' is {float(uu[bad].flat[0])!r}; expected a normalised input in [0, 1]"
            )
        kU = u[..., 1]
        if (kU < 0).any():
            raise ShapeError(f"supply 'k_U' is {float(kU[kU < 0].flat[0])!r} V; expected >= 0")

    def closed_steady_state(
        self, theta: NDArray[np.float64], T_out: ArrayLike, Q_int: ArrayLike
    ) -> NDArray[np.float64]:
        """Zone and structure temperatures of the unheated building, shape (B, 2).

        Solves the two-node balance with ``Q_heat = 0``::

            0 = f_int Q_int + H_as (T_s − T_a) + H_ao (T_out − T_a)
            0 = H_as (T_a − T_s) + H_so (T_out − T_s) + (1 − f_int) Q_int

        Parameters
        ----------
        theta : ndarray, shape (B, P)
            Validated parameter batch.
        T_out : array_like, shape (B,) or scalar
            Outdoor temperature [°C].
        Q_int : array_like, shape (B,) or scalar
            Internal gains [W].

        Returns
        -------
        ndarray, shape (B, 2)
            ``[T_zone, T_struct]`` [°C].
        """
        To = np.broadcast_to(np.asarray(T_out, dtype=float), theta.shape[:1])
        Q = np.broadcast_to(np.asarray(Q_int, dtype=float), theta.shape[:1])
        G, a, s, f = (theta[:, self.param_index(n)] for n in ("H_as", "H_ao", "H_so", "f_int"))
        # [[G + a, −G], [−G, G + s]] [T_a, T_s] = [a T_out + f Q, s T_out + (1 − f) Q]
        r1 = a * To + f * Q
        r2 = s * To + (1.0 - f) * Q
        det = (G + a) * (G + s) - G * G
        Ta = ((G + s) * r1 + G * r2) / det
        Ts = (G * r1 + (G + a) * r2) / det
        return np.column_stack([Ta, Ts])

    def initial_state(
        self, theta: NDArray[np.float64], u0: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """Steady state of the unheated building at the first disturbances.

        Valve shut, zone and structure at :meth:`closed_steady_state` for
        ``T_out`` and ``Q_int`` of ``u0``, radiator and actuator (wax and
        housing) at the zone temperature, cartridge retracted to ``−c``.
        """
        B = theta.shape[0]
        TaTs = self.closed_steady_state(theta, u0[:, 2], u0[:, 3])
        x = np.empty((B, _NX))
        x[:, 0] = TaTs[:, 0]
        x[:, 1] = TaTs[:, 0]
        x[:, 2] = -theta[:, self.param_index("c_backlash")]
        x[:, 3] = 0.0
        x[:, 4] = TaTs[:, 0]
        x[:, 5] = TaTs[:, 0]
        x[:, 6] = TaTs[:, 1]
        return x

    def _simulate(self, theta, u, dt, x0, return_states):
        self._check_u(u)
        full = self.full_theta(theta)
        B, T = u.shape[0], u.shape[1]
        n = self.n_substeps(dt)
        y = np.empty((B, T, _NY))
        xs = np.empty((B, T, _NX)) if return_states else np.empty((1, 1, _NX))
        if B > 1 and u.strides[0] == 0:  # one input trajectory shared by the batch
            u = u[:1]
        if not (u.flags.c_contiguous and u.flags.writeable):
            u = np.array(u, order="C")  # broadcast views: one kernel signature for all callers
        kernel = _simulate_parallel if B >= _PARALLEL_MIN_BATCH else _simulate_serial
        kernel(
            full,
            u,
            np.ascontiguousarray(x0),
            dt / n,
            n,
            self._kind,
            y,
            xs,
            return_states,
        )
        return y, (xs if return_states else None)

    def _check_step_args(
        self, x: NDArray[np.float64], u: NDArray[np.float64], theta: NDArray[np.float64]
    ) -> None:
        if x.ndim != 2 or x.shape[1] != _NX:
            raise ShapeError(
                f"x has shape {x.shape}, expected (B, {_NX}) for states {list(self.state_names)}"
            )
        B = x.shape[0]
        if u.shape != (B, 4):
            raise ShapeError(
                f"u has shape {u.shape}, expected ({B}, 4) with columns "
                f"{list(self.exogenous_names)}"
            )
        if theta.ndim != 2 or theta.shape[0] not in (1, B) or theta.shape[1] != self._cols.size:
            raise ShapeError(
                f"theta has shape {theta.shape}, expected (1, {self._cols.size}) or "
                f"({B}, {self._cols.size})"
            )

    def _raise_bad_row(self, u: NDArray[np.float64], b: int) -> None:
        self._check_u(u[b : b + 1])
        j = int(np.argmax(~np.isfinite(u[b])))
        raise ShapeError(
            f"exogenous signal {self.exogenous_names[j]!r} of system {b} is {float(u[b, j])!r}; "
            "expected a finite value"
        )

    def _step(self, x, u, theta, dt):
        # hot path of environments: shape checks here, value checks inside the kernel
        self._check_step_args(x, u, theta)
        if not dt > 0.0:
            raise ShapeError(f"dt is {dt!r}, expected a positive step in seconds")
        n = self.n_substeps(dt)
        xn = np.array(x, dtype=np.float64, order="C")
        ua = np.ascontiguousarray(u, dtype=np.float64)
        th = np.ascontiguousarray(theta, dtype=np.float64)
        bad = _step_kernel(xn, ua, th, self._cols, self._neutral, dt / n, n, self._kind)
        if bad >= 0:
            self._raise_bad_row(ua, bad)
        return xn

    def _output(self, x, u, theta):
        self._check_step_args(x, u, theta)
        y = np.empty((x.shape[0], _NY))
        ua = np.ascontiguousarray(u, dtype=np.float64)
        bad = _output_kernel(
            np.ascontiguousarray(x, dtype=np.float64),
            ua,
            np.ascontiguousarray(theta, dtype=np.float64),
            self._cols,
            self._neutral,
            y,
        )
        if bad >= 0:
            self._raise_bad_row(ua, bad)
        return y


MODELS = {"room": RoomModel}


# the kernels above inline compiled functions of these modules (cache validity)
module_kernels_depend_on(globals(), _axt211_module, _vmath)
