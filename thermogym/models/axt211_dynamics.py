"""The AXT211 actuator's equations, written once: (14)-(21) of ``002_dae2310635fe074e.txt``.

Every compiled variant of the actuator is built from the functions of this module:
the model's scalar and batched kernels (:mod:`thermogym.models.axt211`), the room
model's actuator (:mod:`thermogym.models.room`), the AXT211 environments' lockstep
lanes, the exact sensitivities of the identification
(:mod:`thermogym.identification.optimizers.sensitivities`) and the mechanical submodel
of the grey-box identification. A change to one equation is made here, once.

Equations (numbers of paper 002; the model's docstring explains the choices)::

    R_PTC = Σ_i R_i τ^i,  τ = (T_P − 65 °C) / 35 K                  (14)
    P_PTC = (k_U u)² / R_PTC                                         (15)
    C_P dT_P/dt = P_PTC − λ_PG (T_P − T_G)                           (17)
    C_G dT_G/dt = λ_PG (T_P − T_G) − λ_GU (T_G − T_U)                (18)
    τ_P dx_P/dt = k_P(x_P) (T_P − T_P0) − x_P                        (19)
    k_P(x_P) = a x_P² + b x_P + c,  a < 0                            (21)
    x_V = backlash_c(x_P)  (play of half-width c)                    (20)

with (14) held at R(30 °C) below 30 °C and extended linearly above 101 °C, ``x_P`` held
at its end stops ``[−c, x_max + c]``, and the physical effects of :data:`AXT211_EFFECTS`
(latent heat in ``C_P``, ``λ_GU (|ΔT|/20 K)^n``, a source resistance in (15)).

Layout
------
The kernels receive the *full* parameter vector (:data:`FULL_PARAMETERS`: the base
parameters, then every effect's, indices ``I_*`` derived from the table). From it,
:func:`coefficients` derives once per parameter set the tuple of per-system constants the
equations read (:data:`COEFFICIENTS`, indices ``Q_*``: reciprocals, end stops, the slope of
(14) at 101 °C). The same tuple is a plant's column of the lockstep lane table
(:data:`LANE_ROWS` = the coefficients and a flag "no physical effect active").

Variants
--------
:func:`rhs` is branch-free (selects, no jumps) so that a loop over systems vectorises;
:func:`rhs_effects` adds the physical effects. :func:`step` and :func:`step_effects` are
one RK4 step of either (:mod:`thermogym.models.integrators`), followed by the end stops
and (20) (:func:`constrain`). For parameter sets without an active effect both give the
same bits, so the scalar kernel, the batched kernels and the lanes agree bit for bit.
:func:`rhs_partials` gives the partial derivatives of (14)-(21) for the sensitivities.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
from numpy.typing import NDArray

from thermogym._jitcache import module_kernels_depend_on
from thermogym.models._effects import PhysicalEffect
from thermogym.models._vmath import vmax, vmin
from thermogym.models.base import Parameter, Signal
from thermogym.models.integrators import loader, rk4_step

__all__ = [
    "AXT211_EFFECTS",
    "AXT211_PARAMETERS",
    "AXT211_SIGNALS",
    "COEFFICIENTS",
    "FULL_INDEX",
    "FULL_PARAMETERS",
    "LANE_ROWS",
    "N_COEF",
    "advance",
    "backlash",
    "coefficients",
    "constrain",
    "effect_coefficients",
    "is_plain",
    "lane_column",
    "load_coefficients",
    "outputs",
    "power",
    "ptc_polynomial",
    "resistance",
    "rhs",
    "rhs_effects",
    "rhs_partials",
    "step",
    "step_effects",
    "stroke_rate",
]

_P = (
    "chosen here to reproduce the behaviour stated in 002_dae2310635fe074e.txt (values unpublished)"
)

AXT211_SIGNALS: tuple[Signal, ...] = (
    Signal("u", "input", "1", "normalised control input (heater on-fraction), 0..1"),
    Signal("k_U", "disturbance", "V", "supply voltage"),
    Signal("T_U", "disturbance", "°C", "actuator environment temperature"),
    Signal("P_PTC", "output", "W", "PTC power consumption (15)"),
    Signal("R_PTC", "output", "Ohm", "PTC electrical resistance (14)"),
    Signal("T_P", "output", "°C", "wax cartridge temperature"),
    Signal("T_G", "output", "°C", "actuator housing temperature"),
    Signal("x_P", "output", "mm", "wax cartridge stroke (from the rod contact point)"),
    Signal("x_V", "output", "mm", "valve stroke"),
)

_R_NOM = (120.442, 90.01, 63.107, -16.41, -1.067, 25.602)

AXT211_PARAMETERS: tuple[Parameter, ...] = (
    *(
        Parameter(
            f"R_{i}",
            _R_NOM[i],
            _R_NOM[i] - 3 * abs(_R_NOM[i]) - 20,
            _R_NOM[i] + 3 * abs(_R_NOM[i]) + 20,
            "Ohm",
            f"PTC polynomial coefficient of τ^{i}, τ = (T_P − 65 °C)/35 K (14)",
            _P,
            "ptc",
        )
        for i in range(6)
    ),
    Parameter("C_P", 18.0, 3.0, 60.0, "J/K", "wax cartridge heat capacity (17)", _P, "thermal"),
    Parameter(
        "lambda_PG", 0.07, 0.01, 0.3, "W/K", "conductance cartridge → housing (17)", _P, "thermal"
    ),
    Parameter("C_G", 40.0, 10.0, 300.0, "J/K", "housing heat capacity (18)", _P, "thermal"),
    Parameter(
        "lambda_GU",
        0.11,
        0.01,
        0.3,
        "W/K",
        "conductance housing → environment (18)",
        _P,
        "thermal",
    ),
    Parameter(
        "T_P0",
        60.0,
        45.0,
        75.0,
        "°C",
        "wax temperature at which the stroke begins (19)",
        "002_dae2310635fe074e.txt section V: 'about 60 °C'",
        "mechanical",
    ),
    Parameter(
        "kP_a",
        -0.018,
        -0.1,
        -1e-4,
        "1/(K·mm)",
        "quadratic coefficient of k_P (21)",
        _P,
        "mechanical",
    ),
    Parameter("kP_b", 0.14, 0.0, 0.5, "1/K", "linear coefficient of k_P (21)", _P, "mechanical"),
    Parameter("kP_c", 0.02, 0.0, 0.5, "mm/K", "constant coefficient of k_P (21)", _P, "mechanical"),
    Parameter("tau_P", 8.0, 1.0, 200.0, "s", "mechanical time constant (19)", _P, "mechanical"),
    Parameter(
        "x_max",
        4.5,
        3.0,
        6.0,
        "mm",
        "valve stroke",
        "002 section V: stroke of 4.5 mm",
        "mechanical",
    ),
    Parameter(
        "c_backlash",
        0.1,
        0.0,
        1.0,
        "mm",
        "half width of the backlash deadband (20)",
        _P,
        "mechanical",
    ),
)

AXT211_EFFECTS: dict[str, PhysicalEffect] = {
    "phase_change": PhysicalEffect(
        "phase_change",
        "The wax melts over a narrow temperature range: while it melts, heat goes into latent "
        "heat instead of raising its temperature, so the cartridge lingers near its melting "
        "point and the stroke starts later and more abruptly than a constant heat capacity "
        "predicts.",
        (
            Parameter(
                "L_melt",
                0.0,
                0.0,
                2000.0,
                "J",
                "latent heat of the wax charge",
                "effect parameter; 0 switches it off",
                "effect",
            ),
            Parameter(
                "T_melt",
                58.0,
                40.0,
                75.0,
                "°C",
                "melting temperature of the wax",
                "effect parameter",
                "effect",
            ),
            Parameter(
                "w_melt",
                3.0,
                0.5,
                10.0,
                "K",
                "width (std) of the melting range",
                "effect parameter",
                "effect",
            ),
        ),
    ),
    "nonlinear_heat_transfer": PhysicalEffect(
        "nonlinear_heat_transfer",
        "The housing loses heat by natural convection and radiation, whose conductance grows "
        "with the temperature difference (h ∝ ΔT^n): a hot actuator cools relatively faster "
        "than a warm one, which a constant conductance cannot reproduce at every power level.",
        (
            Parameter(
                "n_conv",
                0.0,
                -0.2,
                0.6,
                "1",
                "exponent of λ_GU ∝ (ΔT/20 K)^n",
                "effect parameter; 0 = constant conductance, 1/4..1/3 natural convection",
                "effect",
            ),
        ),
    ),
    "supply_variation": PhysicalEffect(
        "supply_variation",
        "The supply sags under load: a transformer or long cable with internal resistance "
        "R_s drops part of the voltage while the PTC draws current, so the heater gets less "
        "power than the measured no-load supply voltage implies, most when the PTC is cold.",
        (
            Parameter(
                "R_source",
                0.0,
                0.0,
                200.0,
                "Ohm",
                "internal resistance of the supply",
                "effect parameter; 0 switches it off",
                "effect",
            ),
        ),
    ),
}


# ----------------------------------------------------------------------------- layout
#: The kernels' full parameter vector: the base parameters, then every effect's (neutral
#: values switch an effect off), as :class:`~thermogym.models._effects.EffectLayout` builds it.
FULL_PARAMETERS: tuple[Parameter, ...] = (
    *AXT211_PARAMETERS,
    *(p for e in AXT211_EFFECTS.values() for p in e.parameters),
)
#: Index of each parameter in the full vector.
FULL_INDEX: dict[str, int] = {p.name: i for i, p in enumerate(FULL_PARAMETERS)}
_IX = FULL_INDEX
I_R0 = _IX["R_0"]
I_CP, I_LPG, I_CG, I_LGU = _IX["C_P"], _IX["lambda_PG"], _IX["C_G"], _IX["lambda_GU"]
I_T0, I_KA, I_KB, I_KC = _IX["T_P0"], _IX["kP_a"], _IX["kP_b"], _IX["kP_c"]
I_TAU, I_XMAX, I_C = _IX["tau_P"], _IX["x_max"], _IX["c_backlash"]
I_L, I_TM, I_WM = _IX["L_melt"], _IX["T_melt"], _IX["w_melt"]
I_NCONV, I_RS = _IX["n_conv"], _IX["R_source"]

#: Per-system constants of the equations, derived from the parameters by :func:`coefficients`
#: (name, meaning). Their order is that of the tuple and of a plant's lane-table column.
COEFFICIENTS: tuple[tuple[str, str], ...] = (
    *((f"R_{i}", f"PTC coefficient of τ^{i} (14)") for i in range(6)),
    ("dR_hi", "dR_PTC/dT_P at 101 °C: slope of the linear extension of (14)"),
    ("lambda_PG", "conductance cartridge → housing (17), (18)"),
    ("lambda_GU", "conductance housing → environment (18)"),
    ("inv_C_P", "1 / C_P (17)"),
    ("inv_C_G", "1 / C_G (18)"),
    ("kP_a", "k_P coefficient a (21)"),
    ("kP_b", "k_P coefficient b (21)"),
    ("kP_c", "k_P coefficient c (21)"),
    ("T_P0", "wax temperature where the stroke begins (19)"),
    ("inv_tau_P", "1 / τ_P (19)"),
    ("x_lo", "lower end stop of x_P: −c"),
    ("x_hi", "upper end stop of x_P: x_max + c"),
    ("c_backlash", "half width of the play (20)"),
    ("x_max", "valve stroke (20)"),
)
N_COEF = len(COEFFICIENTS)
_QX = {name: i for i, (name, _) in enumerate(COEFFICIENTS)}
Q_R0, Q_SHI, Q_LPG, Q_LGU = _QX["R_0"], _QX["dR_hi"], _QX["lambda_PG"], _QX["lambda_GU"]
Q_ICP, Q_ICG, Q_KA, Q_KB, Q_KC = (
    _QX["inv_C_P"], _QX["inv_C_G"], _QX["kP_a"], _QX["kP_b"], _QX["kP_c"]
)  # fmt: skip
Q_T0, Q_ITAU, Q_LO, Q_HI = _QX["T_P0"], _QX["inv_tau_P"], _QX["x_lo"], _QX["x_hi"]
Q_C, Q_XMAX = _QX["c_backlash"], _QX["x_max"]

#: Rows of a plant's column in a lockstep lane table: the coefficients, then 1.0 when no
#: physical effect is active (the branch-free :func:`step` applies), else 0.0.
LANE_ROWS: tuple[str, ...] = (*(name for name, _ in COEFFICIENTS), "plain")
LANE_PLAIN = N_COEF

#: Effect constants of :func:`rhs_effects`, in the order of :func:`effect_coefficients`.
_E_L, _E_TM, _E_WM, _E_N, _E_RS, _E_CP = range(6)

T_LO, T_HI = 30.0, 101.0  # validated range of (14) [°C]
_DT_REF = 20.0  # reference temperature difference of the convection effect [K]
_SQRT_2PI = 2.5066282746310002

#: Loads a coefficient tuple from a lane block: ``load_coefficients(wb, o, W, i)``.
load_coefficients = loader(N_COEF)


# ----------------------------------------------------------------------------- equations
@nb.njit(cache=True, inline="always")
def ptc_polynomial(T: float, r: tuple) -> tuple[float, float]:  # type: ignore[type-arg]
    """(14) at ``T`` (no clamp) from ``r = (R_0, …, R_5)``: ``R`` and ``dR/dT`` (Horner)."""
    tau = (T - 65.0) / 35.0
    R = ((((r[5] * tau + r[4]) * tau + r[3]) * tau + r[2]) * tau + r[1]) * tau + r[0]
    dR = (((5.0 * r[5] * tau + 4.0 * r[4]) * tau + 3.0 * r[3]) * tau + 2.0 * r[2]) * tau + r[1]
    return R, dR / 35.0


@nb.njit(cache=True, inline="always")
def resistance(TP: float, q: tuple) -> float:  # type: ignore[type-arg]
    """R_PTC (14) at ``T_P``, branch-free.

    The polynomial at T_P clamped to [30, 101] °C plus the linear extension above 101 °C
    (which adds exactly 0.0 below it).
    """
    tau = (vmin(vmax(TP, T_LO), T_HI) - 65.0) / 35.0
    R = (
        (((q[Q_R0 + 5] * tau + q[Q_R0 + 4]) * tau + q[Q_R0 + 3]) * tau + q[Q_R0 + 2]) * tau
        + q[Q_R0 + 1]
    ) * tau + q[Q_R0]
    return R + q[Q_SHI] * vmax(TP - T_HI, 0.0)


@nb.njit(cache=True, inline="always")
def power(v2: float, R: float, Rs: float) -> float:
    """P_PTC (15) from ``v2 = (k_U u)²``; with a source resistance the PTC sees V·R/(R + R_s)."""
    return v2 * R / ((R + Rs) * (R + Rs))


@nb.njit(cache=True, inline="always")
def stroke_rate(TP: float, xP: float, q: tuple) -> float:  # type: ignore[type-arg]
    """dx_P/dt of (19) with k_P of (21); 0 against an end stop."""
    xpos = vmax(xP, 0.0)
    dx = (((q[Q_KA] * xpos + q[Q_KB]) * xpos + q[Q_KC]) * (TP - q[Q_T0]) - xP) * q[Q_ITAU]
    stop = ((xP >= q[Q_HI]) & (dx > 0.0)) | ((xP <= q[Q_LO]) & (dx < 0.0))
    return 0.0 if stop else dx


@nb.njit(cache=True, inline="always")
def _rates(TP, TG, xP, P, TU, icp, lgu, q):  # type: ignore[no-untyped-def]  # pragma: no cover
    # (17), (18) with the heater power P, 1/C_P and λ_GU given (effects change them); (19)
    q_pg = q[Q_LPG] * (TP - TG)
    dTP = (P - q_pg) * icp  # (17)
    dTG = (q_pg - lgu * (TG - TU)) * q[Q_ICG]  # (18)
    return (dTP, dTG, stroke_rate(TP, xP, q))


@nb.njit(cache=True, inline="always")
def rhs(x: tuple, args: tuple) -> tuple:  # type: ignore[type-arg]
    """Right-hand side of (14)-(21) without physical effects, branch-free.

    ``x = (T_P, T_G, x_P)``, ``args = (v2, T_U, q)`` with ``v2 = (k_U u)²`` and ``q`` the
    :func:`coefficients`. Returns ``((dT_P, dT_G, dx_P), R_PTC)``.
    """
    TP, TG, xP = x
    v2, TU, q = args
    R = resistance(TP, q)
    return _rates(TP, TG, xP, v2 / R, TU, q[Q_ICP], q[Q_LGU], q), R  # (15): P = v2 / R


@nb.njit(cache=True, inline="always")
def rhs_effects(x: tuple, args: tuple) -> tuple:  # type: ignore[type-arg]
    """:func:`rhs` with the physical effects.

    ``args = (v2, T_U, q, e)``, ``e`` from :func:`effect_coefficients`. With neutral
    effect values it gives :func:`rhs`'s bits.
    """
    TP, TG, xP = x
    v2, TU, q, e = args
    R = resistance(TP, q)
    Rs = e[_E_RS]
    P = v2 / R if Rs == 0.0 else power(v2, R, Rs)  # (15), supply_variation
    icp = q[Q_ICP]
    L = e[_E_L]
    if L > 0.0:  # phase_change: latent heat spread as a Gaussian over the melting range
        z = (TP - e[_E_TM]) / e[_E_WM]
        icp = 1.0 / (e[_E_CP] + L * math.exp(-0.5 * z * z) / (e[_E_WM] * _SQRT_2PI))
    lgu = q[Q_LGU]
    n = e[_E_N]
    if n != 0.0:  # nonlinear_heat_transfer: λ_GU (|ΔT| / 20 K)^n
        lgu = lgu * max(abs(TG - TU) / _DT_REF, 1e-3) ** n
    return _rates(TP, TG, xP, P, TU, icp, lgu, q), R


@nb.njit(cache=True, inline="always")
def backlash(xP: float, xV_prev: float, c: float, xmax: float) -> float:
    """Valve stroke by the backlash (20), branch-free.

    The rod follows the cartridge once the play of half-width ``c`` is taken up; the
    valve stroke stays in [0, x_max].
    """
    xV = xP + c if xP < xV_prev - c else (xP - c if xP > xV_prev + c else xV_prev)
    return vmin(vmax(xV, 0.0), xmax)


@nb.njit(cache=True, inline="always")
def constrain(xP: float, xV: float, q: tuple) -> tuple[float, float]:  # type: ignore[type-arg]
    """After a step: ``x_P`` held at its end stops, then the valve stroke by (20)."""
    xP = vmin(vmax(xP, q[Q_LO]), q[Q_HI])
    return xP, backlash(xP, xV, q[Q_C], q[Q_XMAX])


_rk4 = rk4_step(rhs)
_rk4_effects = rk4_step(rhs_effects)


@nb.njit(cache=True, inline="always")
def step(x: tuple, v2: float, TU: float, h: float, q: tuple) -> tuple:  # type: ignore[type-arg]
    """One RK4 step of length ``h`` without effects, branch-free.

    ``x = (T_P, T_G, x_P, x_V)`` to the next state, and R_PTC at ``x``. Loops over
    systems calling it vectorise.
    """
    (TP, TG, xP), R = _rk4((x[0], x[1], x[2]), h, (v2, TU, q))
    xP, xV = constrain(xP, x[3], q)
    return (TP, TG, xP, xV), R


@nb.njit(cache=True, inline="always")
def step_effects(x: tuple, v2: float, TU: float, h: float, q: tuple, e: tuple) -> tuple:  # type: ignore[type-arg]
    """:func:`step` with the physical effects (``e`` from :func:`effect_coefficients`)."""
    (TP, TG, xP), R = _rk4_effects((x[0], x[1], x[2]), h, (v2, TU, q, e))
    xP, xV = constrain(xP, x[3], q)
    return (TP, TG, xP, xV), R


@nb.njit(cache=True, inline="always")
def coefficients(p: NDArray[np.float64]) -> tuple:  # type: ignore[type-arg]
    """The :data:`COEFFICIENTS` of one full parameter vector ``p``."""
    r = (p[I_R0], p[I_R0 + 1], p[I_R0 + 2], p[I_R0 + 3], p[I_R0 + 4], p[I_R0 + 5])
    c = p[I_C]
    return (
        *r,
        ptc_polynomial(T_HI, r)[1], p[I_LPG], p[I_LGU], 1.0 / p[I_CP], 1.0 / p[I_CG],
        p[I_KA], p[I_KB], p[I_KC], p[I_T0], 1.0 / p[I_TAU], -c, p[I_XMAX] + c, c, p[I_XMAX],
    )  # fmt: skip


@nb.njit(cache=True, inline="always")
def effect_coefficients(p: NDArray[np.float64]) -> tuple:  # type: ignore[type-arg]
    """Constants of the physical effects of a full parameter vector ``p``.

    Latent heat, melting point and width, convection exponent, source resistance, and
    C_P (the latent heat adds to it).
    """
    return (p[I_L], p[I_TM], p[I_WM], p[I_NCONV], p[I_RS], p[I_CP])


@nb.njit(cache=True, inline="always")
def is_plain(p: NDArray[np.float64]) -> bool:
    """Whether no physical effect is active in ``p`` (the branch-free :func:`step` applies)."""
    return p[I_L] == 0.0 and p[I_NCONV] == 0.0 and p[I_RS] == 0.0


@nb.njit(cache=True)
def lane_column(p: NDArray[np.float64], out: NDArray[np.float64], b: int) -> None:
    """Fill column ``b`` of a lane table ``out`` (len(LANE_ROWS), B) from ``p``."""
    q = coefficients(p)
    for j in range(N_COEF):
        out[j, b] = q[j]
    out[LANE_PLAIN, b] = 1.0 if is_plain(p) else 0.0


@nb.njit(cache=True, inline="always")
def advance(x: tuple, v2: float, TU: float, h: float, n: int, q: tuple, e: tuple) -> tuple:  # type: ignore[type-arg]
    """``n`` RK4 steps of length ``h`` of one system, physical effects included.

    ``x = (T_P, T_G, x_P, x_V)`` to the state after them (inputs held).
    """
    for _ in range(n):
        x, _R = step_effects(x, v2, TU, h, q, e)
    return x


@nb.njit(cache=True, inline="always")
def outputs(x: tuple, v2: float, q: tuple, Rs: float) -> tuple:  # type: ignore[type-arg]
    """Outputs ``(P_PTC, R_PTC, T_P, T_G, x_P, x_V)`` of state ``x`` (15), (14).

    ``Rs`` is the source resistance (0 without the supply_variation effect).
    """
    R = resistance(x[0], q)
    return (power(v2, R, Rs), R, x[0], x[1], x[2], x[3])


# ------------------------------------------------------------------------- derivatives
#: Parameter derivatives of the right-hand side returned by :func:`rhs_partials` (its
#: tuple ``d``), as (state row, full-parameter index): the R_i of (14), then the others.
PARTIALS: tuple[tuple[int, int], ...] = (
    *((0, I_R0 + i) for i in range(6)),
    (0, I_CP), (0, I_LPG), (1, I_LPG), (1, I_LGU), (1, I_CG),
    (2, I_T0), (2, I_KA), (2, I_KB), (2, I_KC), (2, I_TAU),
)  # fmt: skip


@nb.njit(cache=True, inline="always")
def resistance_partials(TP: float, q: tuple) -> tuple:  # type: ignore[type-arg]
    """``dR/dT_P`` of (14) as :func:`resistance` evaluates it, and ``∂R/∂R_i`` (i = 0..5)."""
    Tc = vmin(vmax(TP, T_LO), T_HI)
    tau = (Tc - 65.0) / 35.0
    ext = vmax(TP - T_HI, 0.0)  # the linear extension above 101 °C: R_hi + dR_hi (T − 101)
    t2 = tau * tau
    t3 = t2 * tau
    t4 = t3 * tau
    dRi = (
        1.0, tau + ext / 35.0, t2 + ext * 2.0 * tau / 35.0, t3 + ext * 3.0 * t2 / 35.0,
        t4 + ext * 4.0 * t3 / 35.0, t4 * tau + ext * 5.0 * t4 / 35.0,
    )  # fmt: skip
    r = (q[Q_R0], q[Q_R0 + 1], q[Q_R0 + 2], q[Q_R0 + 3], q[Q_R0 + 4], q[Q_R0 + 5])
    dRdT = q[Q_SHI] if TP > T_HI else (0.0 if TP < T_LO else ptc_polynomial(Tc, r)[1])
    return dRdT, dRi


@nb.njit(cache=True, inline="always")
def rhs_partials(x: tuple, v2: float, TU: float, q: tuple) -> tuple:  # type: ignore[type-arg]
    """:func:`rhs` with its partial derivatives (the exact sensitivities' f_x and f_θ).

    Returns ``(f, R, stopped, J, d)``: ``f`` and ``R`` as :func:`rhs`; ``stopped`` whether
    x_P rests against an end stop (its row of the derivatives is then 0); ``J`` the
    non-zero entries of ∂f/∂x, ``(∂f₀/∂T_P, ∂f₀/∂T_G, ∂f₁/∂T_P, ∂f₁/∂T_G, ∂f₂/∂x_P,
    ∂f₂/∂T_P)``; ``d`` the derivatives wrt the parameters of :data:`PARTIALS`.
    """
    TP, TG, xP = x
    f, R = rhs(x, (v2, TU, q))
    dRdT, dRi = resistance_partials(TP, q)
    P = v2 / R  # (15)
    icp, icg, itau = q[Q_ICP], q[Q_ICG], q[Q_ITAU]
    lpg = q[Q_LPG]
    xpos = vmax(xP, 0.0)
    kk = (q[Q_KA] * xpos + q[Q_KB]) * xpos + q[Q_KC]  # (21)
    d0 = TP - q[Q_T0]
    f2_free = (kk * d0 - xP) * itau  # (19) before the end stops
    stopped = (xP >= q[Q_HI] and f2_free > 0.0) or (xP <= q[Q_LO] and f2_free < 0.0)
    dk = (2.0 * q[Q_KA] * xpos + q[Q_KB]) if xP > 0.0 else 0.0
    dPdR = -P / R
    J = (
        (dPdR * dRdT - lpg) * icp, lpg * icp, lpg * icg, -(lpg + q[Q_LGU]) * icg,
        0.0 if stopped else (dk * d0 - 1.0) * itau, 0.0 if stopped else kk * itau,
    )  # fmt: skip
    s = 0.0 if stopped else 1.0
    g = dPdR * icp
    d = (
        g * dRi[0], g * dRi[1], g * dRi[2], g * dRi[3], g * dRi[4], g * dRi[5],
        -f[0] * icp, -(TP - TG) * icp, (TP - TG) * icg, -(TG - TU) * icg, -f[1] * icg,
        -s * kk * itau, s * xpos * xpos * d0 * itau, s * xpos * d0 * itau, s * d0 * itau,
        -s * f[2] * itau,
    )  # fmt: skip
    return f, R, stopped, J, d


# the kernels above inline compiled functions of other modules (derived cache dependencies)
module_kernels_depend_on(globals())
