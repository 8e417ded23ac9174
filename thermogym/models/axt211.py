"""SAUTER AXT211 electrothermal valve actuator (PTC heater, wax cartridge, spring return).

Description
-----------
Grey-box model of ``002_dae2310635fe074e.txt`` (Muffato & Kunz), section VI:
a PTC thermistor heats a wax cartridge; the wax expands and pushes the valve
rod through a play (backlash); a spring closes the valve when the wax cools.

States ``x = [T_P, T_G, x_P, x_V]``: wax-cartridge temperature, housing
temperature, cartridge stroke (the paper's three states, eq 12) plus the
valve stroke ``x_V`` that the backlash operator (20) keeps as memory of the
previous sample.

Equations (numbers of ``002_dae2310635fe074e.txt``)::

    R_PTC = Σ_i R_i τ^i,  τ = (T_P − 65 °C) / 35 K                  (14)
    P_PTC = (k_U u)² / R_PTC                                         (15)
    C_P dT_P/dt = P_PTC − λ_PG (T_P − T_G)                           (17)
    C_G dT_G/dt = λ_PG (T_P − T_G) − λ_GU (T_G − T_U)                (18)
    τ_P dx_P/dt = k_P(x_P) (T_P − T_P0) − x_P                        (19)
    k_P(x_P) = a x_P² + b x_P + c,  a < 0                            (21)
    x_V = backlash_c(x_P)  (play of half-width c)                    (20)

Eq. (14) is written in a normalised temperature τ so that the polynomial
coefficients have comparable magnitudes (least-squares conditioning); it is the
same 5th-order polynomial in T_P. It is validated for T_P in [30, 101] °C
(paper); below 30 °C the resistance is held at R(30 °C) (a PTC is flat below its
switching range), above 101 °C it is extended linearly with the slope at
101 °C.

The stroke coordinate ``x_P`` is measured from the point where the cartridge
touches the closed valve rod, so it ranges over ``[−c, x_max + c]`` and the
valve stroke ``x_V`` over ``[0, x_max]`` (x_max = 4.5 mm).

Integration: explicit classical Runge-Kutta 4 with a fixed step of at most
``max_step`` = 1 s (section III-A: fixed steps keep finite-difference Jacobians
consistent); compiled with numba, one call for the whole batch.

Parameter values
----------------
The paper does not publish its parameter values. The defaults below were chosen
here to reproduce what it states (section V and VI): at 24 V and 25 °C ambient,
u = 1, the valve starts moving when T_P is about 60 °C and reaches 4.5 mm after
about 5 minutes; the stroke gain peaks near T_P = 68 °C (Fig. 3); closing is
slower than opening (16); supply 19-29 V and ambient 0-50 °C stay in range;
and PWM at 50 % duty and high frequency holds the actuator mid-stroke, where the
spread between specimens is large (section VIII, Fig. 8). The PTC curve gives
about 7 W cold and 2.5-3 W when self-regulating.

Consequences of these choices, measured with the defaults: at 24 V, 25 °C the
valve is fully open 301 s after power-on and closed 353 s after power-off
(1,100 s in a 50 °C room); 50 % duty at a 10 s period holds 3.5 mm. The half-duty
requirement needs a PTC that is fairly flat between 70 and 90 °C, so at the
corner 19 V / 0 °C the heater cannot reach the full-stroke temperature: the
valve opens to about 0.9 mm only (every other corner opens fully).

====================  ========  =========  =================================================
parameter             nominal   unit       provenance
====================  ========  =========  =================================================
R_0 … R_5             see code  Ω          chosen: PTC 85 Ω cold, 135 Ω at 70 °C, 290 Ω at 101 °C
C_P                   18        J/K        chosen: 4.5 mm stroke after ~5 min at 24 V, 25 °C
lambda_PG             0.07      W/K        chosen: self-regulation near 89 °C at u = 1
C_G                   40        J/K        chosen: ~50 g plastic housing
lambda_GU             0.11      W/K        chosen: 50 % duty holds mid-stroke (Fig. 8)
T_P0                  60        °C         paper section V: movement begins at about 60 °C
kP_a, kP_b, kP_c      -0.018,   mm/K/mm²,  chosen: gain peaks at 68 °C (paper Fig. 3), full
                      0.14,     1/K,       stroke near 76 °C
                      0.02      mm/K
tau_P                 8         s          chosen: mechanical lag, much faster than thermal
x_max                 4.5       mm         paper section V: 4.5 mm stroke
c_backlash            0.1       mm         chosen: visible hysteresis as in paper Fig. 3
====================  ========  =========  =================================================

Version History
---------------
* v1: initial release.
"""

from __future__ import annotations

import math
from typing import Any

import numba as nb
import numpy as np
from numpy.typing import NDArray

from thermogym.errors import ShapeError
from thermogym.models._effects import EffectLayout, PhysicalEffect
from thermogym.models.base import Model, Parameter, Signal

__all__ = ["AXT211", "AXT211_EFFECTS", "AXT211_PARAMETERS", "AXT211_SIGNALS", "ptc_resistance"]

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

# Column indices in the kernel's full parameter vector.
_I_R = 0
_I_CP, _I_LPG, _I_CG, _I_LGU = 6, 7, 8, 9
_I_T0, _I_KA, _I_KB, _I_KC, _I_TAU, _I_XMAX, _I_C = 10, 11, 12, 13, 14, 15, 16
_I_L, _I_TM, _I_WM, _I_NCONV, _I_RS = 17, 18, 19, 20, 21
_T_LO, _T_HI, _DT_REF = 30.0, 101.0, 20.0


@nb.njit(cache=True, inline="always")
def _ptc_poly(T: float, p: NDArray[np.float64]) -> tuple[float, float]:
    tau = (T - 65.0) / 35.0
    r = p[_I_R + 5]
    dr = 5.0 * p[_I_R + 5]
    for i in range(4, -1, -1):
        r = r * tau + p[_I_R + i]
        if i > 0:
            dr = dr * tau + i * p[_I_R + i]
    return r, dr / 35.0


@nb.njit(cache=True, inline="always")
def _resistance(T: float, p: NDArray[np.float64]) -> float:
    # (14), clamped below 30 °C and extended linearly above 101 °C (validated range).
    if T < _T_LO:
        return _ptc_poly(_T_LO, p)[0]
    if T > _T_HI:
        r, dr = _ptc_poly(_T_HI, p)
        return r + dr * (T - _T_HI)
    return _ptc_poly(T, p)[0]


@nb.njit(cache=True)
def _power(T: float, u: float, kU: float, p: NDArray[np.float64]) -> tuple[float, float]:
    R = _resistance(T, p)
    v = kU * u
    Rs = p[_I_RS]
    # (15); with a source resistance R_s the PTC sees V·R/(R+R_s).
    return v * v * R / ((R + Rs) * (R + Rs)), R


@nb.njit(cache=True, inline="always")
def _rhs(
    TP: float,
    TG: float,
    xP: float,
    u: float,
    kU: float,
    TU: float,
    p: NDArray[np.float64],
    inv_cp: float,
    inv_cg: float,
    inv_tau: float,
) -> tuple[float, float, float]:
    # 1/C_P, 1/C_G and 1/τ_P are computed once per step by the caller.
    R = _resistance(TP, p)
    v = kU * u
    Rs = p[_I_RS]
    P = v * v / R if Rs == 0.0 else v * v * R / ((R + Rs) * (R + Rs))  # (15)
    L = p[_I_L]
    if L > 0.0:
        z = (TP - p[_I_TM]) / p[_I_WM]
        # latent heat spread as a Gaussian over the melting range
        inv_cp = 1.0 / (p[_I_CP] + L * math.exp(-0.5 * z * z) / (p[_I_WM] * 2.5066282746310002))
    q_pg = p[_I_LPG] * (TP - TG)
    dT = TG - TU
    lgu = p[_I_LGU]
    n = p[_I_NCONV]
    if n != 0.0:
        # natural convection / radiation: λ_GU (|ΔT| / 20 K)^n
        lgu = lgu * max(abs(dT) / _DT_REF, 1e-3) ** n
    dTP = (P - q_pg) * inv_cp  # (17)
    dTG = (q_pg - lgu * dT) * inv_cg  # (18)
    xpos = max(xP, 0.0)
    k = (p[_I_KA] * xpos + p[_I_KB]) * xpos + p[_I_KC]  # (21)
    dx = (k * (TP - p[_I_T0]) - xP) * inv_tau  # (19)
    c = p[_I_C]
    if (xP >= p[_I_XMAX] + c and dx > 0.0) or (xP <= -c and dx < 0.0):
        dx = 0.0
    return dTP, dTG, dx


@nb.njit(cache=True, inline="always")
def _backlash(xP: float, xV_prev: float, c: float, xmax: float) -> float:
    # (20): the rod follows the cartridge only once the play of half-width c is taken up.
    if xP < xV_prev - c:
        xV = xP + c
    elif xP > xV_prev + c:
        xV = xP - c
    else:
        xV = xV_prev
    return min(max(xV, 0.0), xmax)


@nb.njit(cache=True, inline="always")
def _advance(
    x: NDArray[np.float64], u: float, kU: float, TU: float, p: NDArray[np.float64], h: float, n: int
) -> None:
    TP, TG, xP, xV = x[0], x[1], x[2], x[3]
    lo = -p[_I_C]
    hi = p[_I_XMAX] + p[_I_C]
    icp = 1.0 / p[_I_CP]
    icg = 1.0 / p[_I_CG]
    itau = 1.0 / p[_I_TAU]
    hh = 0.5 * h
    for _ in range(n):
        # classical RK4, fixed step h
        a1, b1, c1 = _rhs(TP, TG, xP, u, kU, TU, p, icp, icg, itau)
        a2, b2, c2 = _rhs(TP + hh * a1, TG + hh * b1, xP + hh * c1, u, kU, TU, p, icp, icg, itau)
        a3, b3, c3 = _rhs(TP + hh * a2, TG + hh * b2, xP + hh * c2, u, kU, TU, p, icp, icg, itau)
        a4, b4, c4 = _rhs(TP + h * a3, TG + h * b3, xP + h * c3, u, kU, TU, p, icp, icg, itau)
        TP += h / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
        TG += h / 6.0 * (b1 + 2.0 * b2 + 2.0 * b3 + b4)
        xP += h / 6.0 * (c1 + 2.0 * c2 + 2.0 * c3 + c4)
        xP = min(max(xP, lo), hi)
        xV = _backlash(xP, xV, p[_I_C], p[_I_XMAX])
    x[0], x[1], x[2], x[3] = TP, TG, xP, xV


@nb.njit(cache=True)
def _outputs(
    x: NDArray[np.float64], u: float, kU: float, p: NDArray[np.float64], y: NDArray[np.float64]
) -> None:
    P, R = _power(x[0], u, kU, p)
    y[0] = P
    y[1] = R
    y[2] = x[0]
    y[3] = x[1]
    y[4] = x[2]
    y[5] = x[3]


def _make_simulate_kernel(parallel: bool):
    @nb.njit(cache=True, parallel=parallel)
    def kernel(theta, u, x0, h, n, y, xs, keep):
        # reading `parallel` makes it a closure cell: numba keys its on-disk cache on the
        # cells, so the serial and the threaded kernel get separate cache entries
        _variant = parallel
        B, T = y.shape[0], y.shape[1]
        shared_u = u.shape[0] == 1
        for b in nb.prange(B):
            p = theta[b]
            ub = u[0] if shared_u else u[b]
            x = x0[b].copy()
            for k in range(T):
                _outputs(x, ub[k, 0], ub[k, 1], p, y[b, k])
                if keep:
                    xs[b, k, :] = x
                if k + 1 < T:
                    _advance(x, ub[k, 0], ub[k, 1], ub[k, 2], p, h, n)

    return kernel


@nb.njit(cache=True, inline="always")
def _rhs_plain(
    TP: float,
    TG: float,
    xP: float,
    v2: float,
    TU: float,
    r0: float,
    r1: float,
    r2: float,
    r3: float,
    r4: float,
    r5: float,
    r_hi: float,
    s_hi: float,
    lpg: float,
    lgu: float,
    icp: float,
    icg: float,
    ka: float,
    kb: float,
    kc: float,
    t0: float,
    itau: float,
    lo: float,
    hi: float,
) -> tuple[float, float, float]:
    # Branch-free form of _rhs without effects (selects instead of jumps), so that the
    # loop over the batch vectorises; the equations are the same (14)-(21).
    tau = (min(max(TP, _T_LO), _T_HI) - 65.0) / 35.0
    R = r0 + tau * (r1 + tau * (r2 + tau * (r3 + tau * (r4 + tau * r5))))
    R = R + s_hi * max(TP - _T_HI, 0.0)
    q_pg = lpg * (TP - TG)
    dTP = (v2 / R - q_pg) * icp
    dTG = (q_pg - lgu * (TG - TU)) * icg
    xpos = max(xP, 0.0)
    dx = (((ka * xpos + kb) * xpos + kc) * (TP - t0) - xP) * itau
    dx = 0.0 if (xP >= hi and dx > 0.0) or (xP <= lo and dx < 0.0) else dx
    return dTP, dTG, dx


_BLOCK = 64  # time steps kept in a local buffer before they are copied out per system


@nb.njit(cache=True, parallel=True)
def _simulate_soa(theta, u, x0, h, n, y, edges):
    """Effect-free batch with one shared input trajectory, batch innermost (SIMD-friendly)."""
    T = y.shape[1]
    n_chunks = edges.size - 1
    for c in nb.prange(n_chunks):
        b0, b1 = edges[c], edges[c + 1]
        m = b1 - b0
        P = np.ascontiguousarray(theta[b0:b1].T)  # (P_full, m): one row per parameter
        r_hi = np.empty(m)
        s_hi = np.empty(m)
        for i in range(m):
            r, dr = _ptc_poly(_T_HI, theta[b0 + i])
            r_hi[i] = r
            s_hi[i] = dr
        icp, icg, itau = 1.0 / P[_I_CP], 1.0 / P[_I_CG], 1.0 / P[_I_TAU]
        lo = -P[_I_C]
        hi = P[_I_XMAX] + P[_I_C]
        TP = x0[b0:b1, 0].copy()
        TG = x0[b0:b1, 1].copy()
        XP = x0[b0:b1, 2].copy()
        XV = x0[b0:b1, 3].copy()
        buf = np.empty((_BLOCK, 6, m))
        for k0 in range(0, T, _BLOCK):
            kn = min(_BLOCK, T - k0)
            for kk in range(kn):
                k = k0 + kk
                uk, kU, TU = u[k, 0], u[k, 1], u[k, 2]
                v2 = (kU * uk) * (kU * uk)
                for i in range(m):
                    Tc = (min(max(TP[i], _T_LO), _T_HI) - 65.0) / 35.0
                    R = P[0, i] + Tc * (
                        P[1, i] + Tc * (P[2, i] + Tc * (P[3, i] + Tc * (P[4, i] + Tc * P[5, i])))
                    )
                    R = R + s_hi[i] * max(TP[i] - _T_HI, 0.0)
                    buf[kk, 0, i] = v2 / R
                    buf[kk, 1, i] = R
                    buf[kk, 2, i] = TP[i]
                    buf[kk, 3, i] = TG[i]
                    buf[kk, 4, i] = XP[i]
                    buf[kk, 5, i] = XV[i]
                if k + 1 == T:
                    continue
                hh = 0.5 * h
                for _ in range(n):
                    for i in range(m):
                        a = (TP[i], TG[i], XP[i])
                        p0, p1, p2, p3, p4, p5 = (
                            P[0, i],
                            P[1, i],
                            P[2, i],
                            P[3, i],
                            P[4, i],
                            P[5, i],
                        )
                        k1 = _rhs_plain(
                            a[0],
                            a[1],
                            a[2],
                            v2,
                            TU,
                            p0,
                            p1,
                            p2,
                            p3,
                            p4,
                            p5,
                            r_hi[i],
                            s_hi[i],
                            P[_I_LPG, i],
                            P[_I_LGU, i],
                            icp[i],
                            icg[i],
                            P[_I_KA, i],
                            P[_I_KB, i],
                            P[_I_KC, i],
                            P[_I_T0, i],
                            itau[i],
                            lo[i],
                            hi[i],
                        )
                        k2 = _rhs_plain(
                            a[0] + hh * k1[0],
                            a[1] + hh * k1[1],
                            a[2] + hh * k1[2],
                            v2,
                            TU,
                            p0,
                            p1,
                            p2,
                            p3,
                            p4,
                            p5,
                            r_hi[i],
                            s_hi[i],
                            P[_I_LPG, i],
                            P[_I_LGU, i],
                            icp[i],
                            icg[i],
                            P[_I_KA, i],
                            P[_I_KB, i],
                            P[_I_KC, i],
                            P[_I_T0, i],
                            itau[i],
                            lo[i],
                            hi[i],
                        )
                        k3 = _rhs_plain(
                            a[0] + hh * k2[0],
                            a[1] + hh * k2[1],
                            a[2] + hh * k2[2],
                            v2,
                            TU,
                            p0,
                            p1,
                            p2,
                            p3,
                            p4,
                            p5,
                            r_hi[i],
                            s_hi[i],
                            P[_I_LPG, i],
                            P[_I_LGU, i],
                            icp[i],
                            icg[i],
                            P[_I_KA, i],
                            P[_I_KB, i],
                            P[_I_KC, i],
                            P[_I_T0, i],
                            itau[i],
                            lo[i],
                            hi[i],
                        )
                        k4 = _rhs_plain(
                            a[0] + h * k3[0],
                            a[1] + h * k3[1],
                            a[2] + h * k3[2],
                            v2,
                            TU,
                            p0,
                            p1,
                            p2,
                            p3,
                            p4,
                            p5,
                            r_hi[i],
                            s_hi[i],
                            P[_I_LPG, i],
                            P[_I_LGU, i],
                            icp[i],
                            icg[i],
                            P[_I_KA, i],
                            P[_I_KB, i],
                            P[_I_KC, i],
                            P[_I_T0, i],
                            itau[i],
                            lo[i],
                            hi[i],
                        )
                        TP[i] = a[0] + h / 6.0 * (k1[0] + 2.0 * k2[0] + 2.0 * k3[0] + k4[0])
                        TG[i] = a[1] + h / 6.0 * (k1[1] + 2.0 * k2[1] + 2.0 * k3[1] + k4[1])
                        x = a[2] + h / 6.0 * (k1[2] + 2.0 * k2[2] + 2.0 * k3[2] + k4[2])
                        x = min(max(x, lo[i]), hi[i])
                        XP[i] = x
                        # (20) as a clip: the rod stays unless the play is taken up
                        c = P[_I_C, i]
                        XV[i] = min(max(min(max(XV[i], x - c), x + c), 0.0), P[_I_XMAX, i])
            for i in range(m):
                for kk in range(kn):
                    for j in range(6):
                        y[b0 + i, k0 + kk, j] = buf[kk, j, i]


# One system per core pays off only for larger batches (thread start-up ~10 µs).
_simulate_serial = _make_simulate_kernel(False)
_simulate_parallel = _make_simulate_kernel(True)
_PARALLEL_MIN_BATCH = 32


@nb.njit(cache=True)
def _step_kernel(
    x: NDArray[np.float64], u: NDArray[np.float64], theta: NDArray[np.float64], h: float, n: int
) -> None:
    for b in range(x.shape[0]):
        _advance(x[b], u[b, 0], u[b, 1], u[b, 2], theta[b], h, n)


@nb.njit(cache=True)
def _output_kernel(
    x: NDArray[np.float64],
    u: NDArray[np.float64],
    theta: NDArray[np.float64],
    y: NDArray[np.float64],
) -> None:
    for b in range(x.shape[0]):
        _outputs(x[b], u[b, 0], u[b, 1], theta[b], y[b])


# ----------------------------------------------------------------------------- lockstep lanes
# Batch-innermost stepping for the environments' step kernels: many systems ("lanes") advance
# together, one RK4 step of every lane per pass over the batch, each lane with its own step
# size and input (per-plant PWM segments). The functions below are branch-free (selects
# instead of jumps), so that a loop over lanes vectorises; their arithmetic is that of
# _rhs/_advance operation for operation (same order; numba does not contract to fused
# multiply-adds), so a lane reproduces _advance bit for bit for parameter sets without an
# active physical effect (row _LN_PLAIN; sets with effects need the scalar _advance).

#: Rows of the lane table, one column per system (see :func:`_lane_column`).
(
    _LN_R0, _LN_R1, _LN_R2, _LN_R3, _LN_R4, _LN_R5, _LN_SHI, _LN_LPG, _LN_LGU, _LN_ICP,
    _LN_ICG, _LN_KA, _LN_KB, _LN_KC, _LN_T0, _LN_ITAU, _LN_LO, _LN_HI, _LN_C, _LN_XMAX,
    _LN_PLAIN,
) = range(21)  # fmt: skip
_N_LANE = 21


@nb.njit(cache=True, inline="always")
def _max(a: float, b: float) -> float:
    # the builtin max(a, b) of numba (b if b > a else a, NaN in a propagates), written out:
    # numba's builtin is a separate overload that does not always inline into a loop, and
    # a loop with a call in it does not vectorise
    return b if b > a else a


@nb.njit(cache=True, inline="always")
def _min(a: float, b: float) -> float:
    # the builtin min(a, b) of numba (b if b < a else a), written out (see _max)
    return b if b < a else a


@nb.njit(cache=True)
def _lane_column(p: NDArray[np.float64], out: NDArray[np.float64], b: int) -> None:
    """Fill column ``b`` of a lane table ``out`` (_N_LANE, B) from a full kernel vector ``p``.

    Rows: R_0..R_5, dR/dT at 101 °C (linear extension of (14)), λ_PG, λ_GU, 1/C_P, 1/C_G,
    k_P coefficients a, b, c (21), T_P0, 1/τ_P, end stops −c and x_max + c, play c, x_max,
    and 1.0 when no physical effect is active (L_melt = n_conv = R_source = 0).
    """
    for j in range(6):
        out[_LN_R0 + j, b] = p[_I_R + j]
    out[_LN_SHI, b] = _ptc_poly(_T_HI, p)[1]
    out[_LN_LPG, b] = p[_I_LPG]
    out[_LN_LGU, b] = p[_I_LGU]
    out[_LN_ICP, b] = 1.0 / p[_I_CP]
    out[_LN_ICG, b] = 1.0 / p[_I_CG]
    out[_LN_KA, b] = p[_I_KA]
    out[_LN_KB, b] = p[_I_KB]
    out[_LN_KC, b] = p[_I_KC]
    out[_LN_T0, b] = p[_I_T0]
    out[_LN_ITAU, b] = 1.0 / p[_I_TAU]
    out[_LN_LO, b] = -p[_I_C]
    out[_LN_HI, b] = p[_I_XMAX] + p[_I_C]
    out[_LN_C, b] = p[_I_C]
    out[_LN_XMAX, b] = p[_I_XMAX]
    plain = p[_I_L] == 0.0 and p[_I_NCONV] == 0.0 and p[_I_RS] == 0.0
    out[_LN_PLAIN, b] = 1.0 if plain else 0.0


@nb.njit(cache=True, inline="always")
def _lane_load(wb: NDArray[np.float64], o: int, W: int, i: int) -> tuple:  # type: ignore[type-arg]
    # lane i's parameters from a block array holding lane-table rows o.. with row length W
    return (
        wb[o * W + i], wb[(o + 1) * W + i], wb[(o + 2) * W + i], wb[(o + 3) * W + i],
        wb[(o + 4) * W + i], wb[(o + 5) * W + i], wb[(o + 6) * W + i], wb[(o + 7) * W + i],
        wb[(o + 8) * W + i], wb[(o + 9) * W + i], wb[(o + 10) * W + i], wb[(o + 11) * W + i],
        wb[(o + 12) * W + i], wb[(o + 13) * W + i], wb[(o + 14) * W + i],
        wb[(o + 15) * W + i], wb[(o + 16) * W + i], wb[(o + 17) * W + i],
        wb[(o + 18) * W + i], wb[(o + 19) * W + i],
    )  # fmt: skip


@nb.njit(cache=True, inline="always")
def _lane_resistance(TP: float, q: tuple) -> float:  # type: ignore[type-arg]
    # (14) as _resistance: the polynomial at T_P clamped to [30, 101] °C (Horner, same order
    # as _ptc_poly), plus the linear extension above 101 °C (adds exactly 0.0 below it)
    r0, r1, r2, r3, r4, r5, s_hi = q[0], q[1], q[2], q[3], q[4], q[5], q[6]
    tau = (_min(_max(TP, _T_LO), _T_HI) - 65.0) / 35.0
    R = ((((r5 * tau + r4) * tau + r3) * tau + r2) * tau + r1) * tau + r0
    return R + s_hi * _max(TP - _T_HI, 0.0)


@nb.njit(cache=True, inline="always")
def _rhs_lane(
    TP: float,
    TG: float,
    xP: float,
    v2: float,
    TU: float,
    q: tuple,  # type: ignore[type-arg]
) -> tuple[float, float, float, float]:
    # _rhs without effects, branch-free; v2 = (k_U u)²; also returns R_PTC at (TP, TG, xP)
    lpg, lgu, icp, icg, ka, kb, kc, t0, itau, lo, hi = (
        q[7], q[8], q[9], q[10], q[11], q[12], q[13], q[14], q[15], q[16], q[17]
    )  # fmt: skip
    R = _lane_resistance(TP, q)
    q_pg = lpg * (TP - TG)
    dTP = (v2 / R - q_pg) * icp  # (15), (17)
    dTG = (q_pg - lgu * (TG - TU)) * icg  # (18)
    xpos = _max(xP, 0.0)
    dx = (((ka * xpos + kb) * xpos + kc) * (TP - t0) - xP) * itau  # (19), (21)
    stop = ((xP >= hi) & (dx > 0.0)) | ((xP <= lo) & (dx < 0.0))  # end stops
    return dTP, dTG, 0.0 if stop else dx, R


@nb.njit(cache=True, inline="always")
def _backlash_lane(xP: float, xV_prev: float, c: float, xmax: float) -> float:
    # (20) as _backlash, with selects
    xV = xP + c if xP < xV_prev - c else (xP - c if xP > xV_prev + c else xV_prev)
    return _min(_max(xV, 0.0), xmax)


@nb.njit(cache=True, inline="always")
def _rk4_lane(
    TP: float,
    TG: float,
    xP: float,
    xV: float,
    v2: float,
    TU: float,
    h: float,
    q: tuple,  # type: ignore[type-arg]
) -> tuple[float, float, float, float, float]:
    """One RK4 step of one lane as _advance (n = 1); also R_PTC at the start of the step."""
    hh = 0.5 * h
    a1, b1, c1, R = _rhs_lane(TP, TG, xP, v2, TU, q)
    a2, b2, c2, _ = _rhs_lane(TP + hh * a1, TG + hh * b1, xP + hh * c1, v2, TU, q)
    a3, b3, c3, _ = _rhs_lane(TP + hh * a2, TG + hh * b2, xP + hh * c2, v2, TU, q)
    a4, b4, c4, _ = _rhs_lane(TP + h * a3, TG + h * b3, xP + h * c3, v2, TU, q)
    TPn = TP + h / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
    TGn = TG + h / 6.0 * (b1 + 2.0 * b2 + 2.0 * b3 + b4)
    x = xP + h / 6.0 * (c1 + 2.0 * c2 + 2.0 * c3 + c4)
    x = _min(_max(x, q[16]), q[17])
    return TPn, TGn, x, _backlash_lane(x, xV, q[18], q[19]), R


def ptc_resistance(
    T_P: NDArray[np.float64] | float, coeffs: NDArray[np.float64]
) -> NDArray[np.float64]:
    """PTC resistance (14) for temperatures ``T_P`` [°C] and coefficients ``R_0..R_5`` [Ω].

    Parameters
    ----------
    T_P : float or ndarray
        Wax-cartridge temperature [°C].
    coeffs : ndarray, shape (6,)
        Polynomial coefficients of τ^0..τ^5, τ = (T_P − 65 °C)/35 K.

    Returns
    -------
    ndarray
        Resistance [Ω], clamped below 30 °C and linearly extended above 101 °C.

    Examples
    --------
    >>> from thermogym.models.axt211 import AXT211, ptc_resistance
    >>> m = AXT211()
    >>> round(float(ptc_resistance(30.0, m.nominal[:6])), 1)
    90.5
    """
    p = np.zeros(len(AXT211_PARAMETERS) + 5)
    p[:6] = np.asarray(coeffs, dtype=float)
    T = np.atleast_1d(np.asarray(T_P, dtype=float))
    out = np.array([_resistance(float(t), p) for t in T.ravel()]).reshape(T.shape)
    return out if np.ndim(T_P) else out[0]


class AXT211(Model):
    """SAUTER AXT211 wax-cartridge electrothermal valve actuator (paper 002, eqs 12-21).

    Parameters
    ----------
    effects : sequence of str
        Physical effects to include (``phase_change``, ``nonlinear_heat_transfer``,
        ``supply_variation``); their parameters are appended to the public
        parameters with neutral nominal values.

    Examples
    --------
    >>> import numpy as np
    >>> from thermogym.models import AXT211
    >>> m = AXT211()
    >>> u = np.column_stack([np.ones(601), np.full(601, 24.0), np.full(601, 25.0)])
    >>> sim = m.simulate(u, dt=1.0)
    >>> bool(sim.output("x_V")[0, -1] > 4.4)
    True
    """

    name = "axt211"
    version = "1"
    max_step = 1.0
    physical_effects = AXT211_EFFECTS

    def __init__(self, effects: tuple[str, ...] | list[str] = ()) -> None:
        self._layout = EffectLayout(AXT211_PARAMETERS, AXT211_EFFECTS, effects, self.name)
        super().__init__(AXT211_SIGNALS, self._layout.public, ("T_P", "T_G", "x_P", "x_V"))

    @property
    def effects(self) -> tuple[str, ...]:
        """Physical effects this instance includes."""
        return self._layout.selected

    def config(self) -> dict[str, Any]:
        """Constructor arguments (stored in FitResults)."""
        return {"effects": list(self._layout.selected)} if self._layout.selected else {}

    def _validate_theta(self, theta: NDArray[np.float64]) -> None:
        self._require_positive(theta, ("C_P", "lambda_PG", "C_G", "lambda_GU", "tau_P", "x_max"))

    @staticmethod
    def _check_u(u: NDArray[np.float64]) -> None:
        uu = u[..., 0]
        if (uu < 0).any() or (uu > 1).any():
            v = uu[(uu < 0) | (uu > 1)].flat[0]
            raise ShapeError(f"input 'u' is {float(v)!r}; expected a normalised input in [0, 1]")
        kU = u[..., 1]
        if (kU < 0).any():
            raise ShapeError(f"supply 'k_U' is {float(kU[kU < 0].flat[0])!r} V; expected >= 0")

    def initial_state(
        self, theta: NDArray[np.float64], u0: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """Rest state: both temperatures at the environment, cartridge retracted, valve shut."""
        B = theta.shape[0]
        x = np.empty((B, 4))
        x[:, 0] = u0[:, 2]
        x[:, 1] = u0[:, 2]
        x[:, 2] = -theta[:, self.param_index("c_backlash")]
        x[:, 3] = 0.0
        return x

    def _simulate(self, theta, u, dt, x0, return_states):
        self._check_u(u)
        full = self._layout.full_theta(theta)
        B, T = u.shape[0], u.shape[1]
        if B > 1 and u.strides[0] == 0:  # one input trajectory shared by the batch
            u = np.ascontiguousarray(u[:1])
        n = self.n_substeps(dt)
        y = np.empty((B, T, 6))
        xs = np.empty((B, T, 4)) if return_states else np.empty((1, 1, 4))
        plain = not self._layout.selected or not np.any(full[:, _I_L:] != full[0, _I_L:][None])
        plain = plain and full[0, _I_L] == 0.0 and full[0, _I_NCONV] == 0.0
        plain = plain and full[0, _I_RS] == 0.0
        if plain and u.shape[0] == 1 and B >= _PARALLEL_MIN_BATCH and not return_states:
            chunks = max(1, min(2 * nb.get_num_threads(), B // 16))
            edges = np.linspace(0, B, chunks + 1).astype(np.int64)
            _simulate_soa(
                full, np.ascontiguousarray(u[0]), np.ascontiguousarray(x0), dt / n, n, y, edges
            )
        else:
            kernel = _simulate_parallel if B >= _PARALLEL_MIN_BATCH else _simulate_serial
            kernel(
                full,
                np.ascontiguousarray(u),
                np.ascontiguousarray(x0),
                dt / n,
                n,
                y,
                xs,
                return_states,
            )
        return y, (xs if return_states else None)

    def _step(self, x, u, theta, dt):
        xn = np.array(x, dtype=float, copy=True)
        n = self.n_substeps(dt)
        _step_kernel(xn, np.ascontiguousarray(u), self._layout.full_theta(theta), dt / n, n)
        return xn

    def _output(self, x, u, theta):
        y = np.empty((x.shape[0], 6))
        _output_kernel(
            np.ascontiguousarray(x), np.ascontiguousarray(u), self._layout.full_theta(theta), y
        )
        return y

    def full_theta(self, theta: NDArray[np.float64]) -> NDArray[np.float64]:
        """Kernel parameter vector including neutral values of absent effects."""
        return self._layout.full_theta(theta)
