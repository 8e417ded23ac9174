"""The room's equations, written once: actuator, valve, radiator and zone of the room model.

Every compiled variant of the room (:class:`thermogym.models.room.RoomModel`'s scalar and
batched kernels, the AXT211Room environment's lockstep lanes) is built from the functions
of this module; the actuator is :mod:`thermogym.models.axt211_dynamics` with the zone air
as its environment. The equations and the choices behind them are in the docstring of
:mod:`thermogym.models.room`::

    φ(h) = h  (linear)  or  R_v^(h − 1), h ≥ h_0; (h/h_0) R_v^(h_0 − 1), h < h_0        valve
    T_supply = T_sup_20 + (T_sup_d − T_sup_20)(20 °C − T_out*)/(20 °C − T_out_d)   heating curve
    Q_heat = Q_rad_nom sgn(Δ) |Δ / ΔT_ref|^n_rad,  Δ = T_rad − T_zone               EN 442-2
    C_rad dT_rad/dt = φ Q_rad_nom/ΔT_w,nom (T_supply − T_rad) − Q_heat
    C_a dT_zone/dt = Q_heat + f_int Q_int + H_as (T_struct − T_zone) + H_ao (T_out − T_zone)
    C_s dT_struct/dt = H_as (T_zone − T_struct) + H_so (T_out − T_struct) + (1 − f_int) Q_int

The two power laws are evaluated by :func:`power_law` (vectorises);
:func:`rates` takes their values as arguments, so that a lockstep kernel can evaluate them
in loops of their own, while :func:`rhs` evaluates them itself. Within an RK4 step the
valve sees (20) applied to each stage's ``x_P`` with the valve stroke of the step start.

Layout: the full parameter vector is the AXT211's (:data:`~thermogym.models.axt211_dynamics.
FULL_PARAMETERS`) followed by :data:`ROOM_PARAMETERS` (indices derived from the tables);
:func:`coefficients` gives the room's per-system constants (:data:`COEFFICIENTS`), and a
plant's column of a lane table (:data:`LANE_ROWS`) is the actuator's coefficients, the
room's, and the "no actuator effect" flag.
"""

from __future__ import annotations

import numba as nb
import numpy as np
from numpy.typing import NDArray

from thermogym._jitcache import module_kernels_depend_on
from thermogym.models import axt211_dynamics as ax
from thermogym.models._vmath import vpow
from thermogym.models.axt211_dynamics import AXT211_SIGNALS
from thermogym.models.base import Parameter, Signal
from thermogym.models.integrators import loader, rk4_step

__all__ = [
    "COEFFICIENTS",
    "FULL_PARAMETERS",
    "LANE_ROWS",
    "ROOM_PARAMETERS",
    "ROOM_SIGNALS",
    "advance",
    "coefficients",
    "emission",
    "emission_base",
    "flow",
    "heat",
    "lane_column",
    "lane_rhs",
    "load_coefficients",
    "outputs",
    "power_law",
    "rates",
    "rhs",
    "step",
    "supply",
    "valve_stroke",
]

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


T_DESIGN = _T_DESIGN
H0 = _H0

# ----------------------------------------------------------------------------- layout
#: The room kernels' full parameter vector: the AXT211's full vector, then the room's.
FULL_PARAMETERS: tuple[Parameter, ...] = (*ax.FULL_PARAMETERS, *ROOM_PARAMETERS)
_IX = {p.name: i for i, p in enumerate(FULL_PARAMETERS)}
I_CA, I_CS, I_HAS, I_HAO, I_HSO = _IX["C_a"], _IX["C_s"], _IX["H_as"], _IX["H_ao"], _IX["H_so"]
I_FINT, I_QN, I_NR, I_DTW, I_CR = (
    _IX["f_int"], _IX["Q_rad_nom"], _IX["n_rad"], _IX["dT_w_nom"], _IX["C_rad"]
)  # fmt: skip
I_TOD, I_TSD, I_TS20, I_RV = _IX["T_out_d"], _IX["T_sup_d"], _IX["T_sup_20"], _IX["R_v"]

#: The room's per-system constants, derived by :func:`coefficients` (name, meaning), in the
#: order of the tuple and of the room's rows of a lane-table column.
COEFFICIENTS: tuple[tuple[str, str], ...] = (
    ("mc_nom", "ṁ_nom c_w = Q_rad_nom / ΔT_w,nom: design water flow capacity rate"),
    ("inv_C_rad", "1 / C_rad"),
    ("inv_C_a", "1 / C_a"),
    ("inv_C_s", "1 / C_s"),
    ("inv_dT_ref", "1 / ΔT_ref, ΔT_ref = T_sup_d − ΔT_w,nom − 20 °C"),
    ("inv_x_max", "1 / x_max: relative valve stroke"),
    ("R_v", "rangeability of the equal-percentage valve"),
    ("R_v_h0", "R_v^(h_0 − 1): the equal-percentage flow at h_0"),
    ("Q_rad_nom", "design radiator output"),
    ("n_rad", "radiator exponent"),
    ("f_int", "fraction of Q_int into the zone air"),
    ("H_as", "conductance zone air ↔ structure"),
    ("H_ao", "conductance zone air ↔ outdoor"),
    ("H_so", "conductance structure ↔ outdoor"),
)
N_COEF = len(COEFFICIENTS)
_RX = {name: i for i, (name, _) in enumerate(COEFFICIENTS)}
R_MCN, R_ICR, R_ICA, R_ICS, R_IREF = (
    _RX["mc_nom"], _RX["inv_C_rad"], _RX["inv_C_a"], _RX["inv_C_s"], _RX["inv_dT_ref"]
)  # fmt: skip
R_IXMAX, R_RV, R_RVH, R_QN, R_NR = (
    _RX["inv_x_max"], _RX["R_v"], _RX["R_v_h0"], _RX["Q_rad_nom"], _RX["n_rad"]
)  # fmt: skip
R_FINT, R_HAS, R_HAO, R_HSO = _RX["f_int"], _RX["H_as"], _RX["H_ao"], _RX["H_so"]

#: Rows of a plant's column of the room's lane table: the actuator's coefficients (from
#: row :data:`LANE_ACTUATOR`), the room's (from :data:`LANE_ROOM`), then the flag "no
#: actuator effect" (row :data:`LANE_PLAIN`).
LANE_ROWS: tuple[str, ...] = (
    *(name for name, _ in ax.COEFFICIENTS),
    *(name for name, _ in COEFFICIENTS),
    "plain",
)
LANE_ACTUATOR = 0
LANE_ROOM = ax.N_COEF
LANE_PLAIN = ax.N_COEF + N_COEF

#: Loads the room's coefficient tuple from a lane block: ``load_coefficients(wb, o, W, i)``.
load_coefficients = loader(N_COEF)


# ----------------------------------------------------------------------------- equations
@nb.njit(cache=True, inline="always")
def power_law(x: float, y: float) -> float:
    """``x ** y`` of the emission and valve laws, branch-free.

    Every variant evaluates the power laws with it (``_vmath.vpow``: a loop calling it
    vectorises).
    """
    return vpow(x, y)


@nb.njit(cache=True, inline="always")
def supply(Tout: float, p: NDArray[np.float64]) -> float:
    """Heating curve: supply temperature, linear in T_out between T_out_d and 20 °C, clipped."""
    Td = p[I_TOD]
    To = min(max(Tout, Td), _T_DESIGN)
    return p[I_TS20] + (p[I_TSD] - p[I_TS20]) * (_T_DESIGN - To) / (_T_DESIGN - Td)


@nb.njit(cache=True, inline="always")
def emission_base(Tr: float, Ta: float, r: tuple) -> float:  # type: ignore[type-arg]
    """|Δ| / ΔT_ref, Δ = T_rad − T_zone: the base of the emission's power law."""
    return abs(Tr - Ta) * r[R_IREF]


@nb.njit(cache=True, inline="always")
def emission(Tr: float, Ta: float, pw: float, r: tuple) -> float:  # type: ignore[type-arg]
    """Q_heat = Q_rad_nom sgn(Δ) |Δ/ΔT_ref|^n_rad (EN 442-2) from ``pw`` = the power law."""
    q = r[R_QN] * pw
    return q if Tr - Ta >= 0.0 else -q


@nb.njit(cache=True, inline="always")
def valve_stroke(xP: float, xV0: float, q: tuple, r: tuple) -> float:  # type: ignore[type-arg]
    """Relative valve stroke h = x_V / x_max at a stage: (20) from the step-start ``xV0``."""
    return ax.backlash(xP, xV0, q[ax.Q_C], q[ax.Q_XMAX]) * r[R_IXMAX]


@nb.njit(cache=True, inline="always")
def flow(h: float, pwv: float, RvH: float, kind: int) -> float:
    """Relative flow φ(h) of the valve, branch-free.

    Linear (``kind`` 0), or equal percentage with ``pwv`` = R_v^(h − 1), ``RvH`` =
    R_v^(h_0 − 1) and a linear leak-off below h_0; 0 shut, 1 fully open.
    """
    phi = h if kind == 0 else (h / _H0 * RvH if h < _H0 else pwv)
    return 0.0 if h <= 0.0 else (1.0 if h >= 1.0 else phi)


@nb.njit(cache=True, inline="always")
def rates(
    Tr: float, Ta: float, Ts: float, phi: float, Q: float, Tsup: float, Tout: float,
    Qint: float, r: tuple,  # type: ignore[type-arg]
) -> tuple[float, float, float]:  # fmt: skip
    """dT_rad/dt, dT_zone/dt, dT_struct/dt from the flow ``phi`` and the emission ``Q``."""
    # C_rad dT_rad/dt = ṁ c_w (T_sup − T_rad) − Q_heat,  ṁ c_w = φ Q_rad_nom / ΔT_w,nom
    dTr = (phi * r[R_MCN] * (Tsup - Tr) - Q) * r[R_ICR]
    f = r[R_FINT]
    q_as = r[R_HAS] * (Ts - Ta)
    # C_a dT_a/dt = Q_heat + f Q_int + H_as (T_s − T_a) + H_ao (T_out − T_a)
    dTa = (Q + f * Qint + q_as + r[R_HAO] * (Tout - Ta)) * r[R_ICA]
    # C_s dT_s/dt = H_as (T_a − T_s) + H_so (T_out − T_s) + (1 − f) Q_int
    dTs = (-q_as + r[R_HSO] * (Tout - Ts) + (1.0 - f) * Qint) * r[R_ICS]
    return dTr, dTa, dTs


@nb.njit(cache=True, inline="always")
def lane_rhs(
    x: tuple, xV0: float, v2: float, Tsup: float, Tout: float, Qint: float, Q: float,
    pwv: float, q: tuple, r: tuple, kind: int,  # type: ignore[type-arg]
) -> tuple:  # type: ignore[type-arg]  # fmt: skip
    """Right-hand side without actuator effects, given the stage's power laws.

    ``Q`` is the emission and ``pwv`` = R_v^(h − 1): lockstep kernels evaluate the power
    laws in loops of their own. Branch-free. ``x = (T_P, T_G, x_P, T_rad, T_zone,
    T_struct)``; returns the derivatives and R_PTC.
    """
    TP, TG, xP, Tr, Ta, Ts = x
    (dTP, dTG, dxP), R = ax.rhs((TP, TG, xP), (v2, Ta, q))  # (17)-(19), T_U = T_zone
    phi = flow(valve_stroke(xP, xV0, q, r), pwv, r[R_RVH], kind)
    dTr, dTa, dTs = rates(Tr, Ta, Ts, phi, Q, Tsup, Tout, Qint, r)
    return (dTP, dTG, dxP, dTr, dTa, dTs), R


@nb.njit(cache=True, inline="always")
def rhs(x: tuple, args: tuple) -> tuple:  # type: ignore[type-arg]
    """Right-hand side of the room with actuator effects.

    ``x = (T_P, T_G, x_P, T_rad, T_zone, T_struct)``, ``args = (x_V0, v2, T_sup, T_out,
    Q_int, q, r, e, kind)``. Returns the derivatives and ``(R_PTC, Q_heat)``.
    """
    TP, TG, xP, Tr, Ta, Ts = x
    xV0, v2, Tsup, Tout, Qint, q, r, e, kind = args
    (dTP, dTG, dxP), R = ax.rhs_effects((TP, TG, xP), (v2, Ta, q, e))  # T_U = T_zone
    h = valve_stroke(xP, xV0, q, r)
    pwv = power_law(r[R_RV], h - 1.0) if kind != 0 else 0.0
    Q = emission(Tr, Ta, power_law(emission_base(Tr, Ta, r), r[R_NR]), r)
    dTr, dTa, dTs = rates(Tr, Ta, Ts, flow(h, pwv, r[R_RVH], kind), Q, Tsup, Tout, Qint, r)
    return (dTP, dTG, dxP, dTr, dTa, dTs), (R, Q)


_rk4 = rk4_step(rhs)


@nb.njit(cache=True, inline="always")
def step(
    x: tuple, v2: float, Tsup: float, Tout: float, Qint: float, h: float, q: tuple,
    r: tuple, e: tuple, kind: int,  # type: ignore[type-arg]
) -> tuple:  # type: ignore[type-arg]  # fmt: skip
    """One RK4 step of all seven states, then the end stops and (20) as the AXT211's.

    ``x = (T_P, T_G, x_P, x_V, T_rad, T_zone, T_struct)``.
    """
    (TP, TG, xP, Tr, Ta, Ts), _aux = _rk4(
        (x[0], x[1], x[2], x[4], x[5], x[6]), h, (x[3], v2, Tsup, Tout, Qint, q, r, e, kind)
    )
    xP, xV = ax.constrain(xP, x[3], q)
    return (TP, TG, xP, xV, Tr, Ta, Ts)


@nb.njit(cache=True, inline="always")
def advance(
    x: tuple, v2: float, Tsup: float, Tout: float, Qint: float, h: float, n: int,
    q: tuple, r: tuple, e: tuple, kind: int,  # type: ignore[type-arg]
) -> tuple:  # type: ignore[type-arg]  # fmt: skip
    """``n`` steps of :func:`step` (inputs held)."""
    for _ in range(n):
        x = step(x, v2, Tsup, Tout, Qint, h, q, r, e, kind)
    return x


@nb.njit(cache=True, inline="always")
def heat(Tr: float, Ta: float, r: tuple) -> float:  # type: ignore[type-arg]
    """Q_heat at radiator temperature ``Tr`` and zone temperature ``Ta``."""
    return emission(Tr, Ta, power_law(emission_base(Tr, Ta, r), r[R_NR]), r)


@nb.njit(cache=True, inline="always")
def outputs(x: tuple, v2: float, Tsup: float, q: tuple, r: tuple, Rs: float) -> tuple:  # type: ignore[type-arg]
    """Outputs ``(T_zone, T_struct, T_rad, T_supply, Q_heat, x_V, x_P, P_PTC, T_P, T_G)``."""
    P = ax.power(v2, ax.resistance(x[0], q), Rs)  # (15)
    return (x[5], x[6], x[4], Tsup, heat(x[4], x[5], r), x[3], x[2], P, x[0], x[1])


@nb.njit(cache=True, inline="always")
def coefficients(p: NDArray[np.float64]) -> tuple:  # type: ignore[type-arg]
    """The room's :data:`COEFFICIENTS` of one full parameter vector ``p``."""
    return (
        p[I_QN] / p[I_DTW], 1.0 / p[I_CR], 1.0 / p[I_CA], 1.0 / p[I_CS],
        1.0 / (p[I_TSD] - p[I_DTW] - _T_DESIGN), 1.0 / p[ax.I_XMAX], p[I_RV],
        p[I_RV] ** (_H0 - 1.0), p[I_QN], p[I_NR], p[I_FINT], p[I_HAS], p[I_HAO], p[I_HSO],
    )  # fmt: skip


@nb.njit(cache=True)
def lane_column(p: NDArray[np.float64], out: NDArray[np.float64], b: int) -> None:
    """Fill column ``b`` of a room lane table ``out`` (len(LANE_ROWS), B) from ``p``."""
    q = ax.coefficients(p)
    for j in range(ax.N_COEF):
        out[LANE_ACTUATOR + j, b] = q[j]
    r = coefficients(p)
    for j in range(N_COEF):
        out[LANE_ROOM + j, b] = r[j]
    out[LANE_PLAIN, b] = 1.0 if ax.is_plain(p) else 0.0


# the kernels above inline compiled functions of other modules (derived cache dependencies)
module_kernels_depend_on(globals())
