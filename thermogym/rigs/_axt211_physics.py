"""Compiled physics of the AXT211 rig's true plant (see :mod:`thermogym.rigs.axt211`).

Written for the rig alone: nothing here comes from :mod:`thermogym.models`.
One sub-step advances one specimen; the AXT211 rig and the room rig (whose
actuator it is) both call :func:`substep`. Parameter vector layout: ``P_*``
indices below (the order of ``AXT211Plant.parameters``); switch vector layout:
``S_*`` (1.0 on, 0.0 off, the order of ``AXT211Plant.extras``).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

# parameter indices (order of AXT211Plant.parameters)
(
    P_RMIN, P_TREF, P_WPTC, P_RRATIO, P_ANTC, P_RSRC,
    P_CH, P_CW, P_LW, P_TM, P_WM, P_DTHYS, P_TAUM, P_CG, P_CV,
    P_GHW, P_GHG, P_GWG, P_GWV, P_GVA,
    P_AG, P_LG, P_CCONV, P_NCONV, P_EPS,
    P_SMELT, P_BEXP, P_KC, P_F0, P_KS, P_FST, P_FD, P_BV, P_KOL, P_C, P_XMAX,
) = range(36)  # fmt: skip
N_PARAMS = 36
# switch indices (order of AXT211Plant.extras)
(
    S_PTC, S_NODE, S_LATENT, S_HYST, S_KINETICS, S_CONV, S_RAD, S_VALVE, S_PRELOAD,
    S_FRICTION, S_SOURCE,
) = range(11)  # fmt: skip
N_SWITCHES = 11
# state indices
X_TH, X_TW, X_PHI, X_TG, X_TV, X_XP, X_M, X_XV, X_E = range(9)
N_STATES = 9

SIGMA = 5.670374419e-8  # Stefan-Boltzmann constant [W/(m² K⁴)]
K0 = 273.15
DT_REF = 20.0  # K: the housing's reference excess temperature (linearised laws)
T_ASM = 20.0  # °C: temperature at which the stroke of the solid charge is zero (assembly)


@nb.njit(cache=True, inline="always")
def logistic(z: float) -> float:
    """1 / (1 + e^−z), without overflow."""
    if z >= 0.0:
        return 1.0 / (1.0 + math.exp(-z))
    e = math.exp(z)
    return e / (1.0 + e)


@nb.njit(cache=True)
def ptc_resistance(T: float, p, sw) -> float:  # pragma: no cover - numba
    """PTC resistance [Ω] at its own temperature ``T`` [°C].

    A barium-titanate PTC: slightly NTC below its minimum (``a_ntc`` per K
    below ``T_ref − 30 K``), then ln R rises along a logistic step of width
    ``w_ptc`` from ``R_min`` to ``R_ratio · R_min``, centred so that
    ``R(T_ref) = 2 R_min`` (the datasheet definition of the reference
    temperature). Switched off: a fixed resistor ``R_min``.
    """
    rmin = p[P_RMIN]
    if sw[S_PTC] == 0.0:
        return rmin
    lr = math.log(p[P_RRATIO])
    # centre T_c with σ((T_ref − T_c)/w) = ln 2 / ln R_ratio
    f = math.log(2.0) / lr
    tc = p[P_TREF] - p[P_WPTC] * math.log(f / (1.0 - f))
    r = rmin * math.exp(lr * logistic((T - tc) / p[P_WPTC]))
    t_min = p[P_TREF] - 30.0
    if T < t_min:
        r *= 1.0 + p[P_ANTC] * (t_min - T)
    return r


@nb.njit(cache=True)
def heater(T_h: float, u: float, kU: float, p, sw) -> tuple[float, float]:  # pragma: no cover
    """Power into the PTC [W] and its resistance [Ω] (supply k_U·u behind R_src)."""
    R = ptc_resistance(T_h, p, sw)
    rs = p[P_RSRC] if sw[S_SOURCE] != 0.0 else 0.0
    v = kU * u * R / (R + rs)
    return v * v / R, R


@nb.njit(cache=True, inline="always")
def housing_loss(T_g: float, T_U: float, p, sw) -> float:  # pragma: no cover - numba
    """Heat [W] from the housing to the air: natural convection and radiation."""
    d = T_g - T_U
    A = p[P_AG]
    # laminar natural convection, vertical surface in air: h = c (ΔT / L)^n (Holman, simplified
    # air correlation, c = 1.42, n = 1/4), so Q ∝ ΔT^(1 + n); off: linear at ΔT_ref
    h_ref = p[P_CCONV] * (DT_REF / p[P_LG]) ** p[P_NCONV]
    if sw[S_CONV] != 0.0:
        q = p[P_CCONV] * A * abs(d) ** (1.0 + p[P_NCONV]) * p[P_LG] ** (-p[P_NCONV])
        q = q if d >= 0.0 else -q
    else:
        q = h_ref * A * d
    # grey-body radiation to the surroundings at T_U; off: linear, fixed at 25 + ΔT_ref / 2 °C
    if sw[S_RAD] != 0.0:
        q += p[P_EPS] * SIGMA * A * ((T_g + K0) ** 4 - (T_U + K0) ** 4)
    else:
        q += 4.0 * p[P_EPS] * SIGMA * A * (25.0 + K0 + 0.5 * DT_REF) ** 3 * d
    return q


@nb.njit(cache=True, inline="always")
def melt_targets(T_w: float, p, sw) -> tuple[float, float]:  # pragma: no cover - numba
    """Melted fraction in equilibrium on heating and on cooling at wax temperature T_w."""
    w = p[P_WM]
    hys = p[P_DTHYS] if sw[S_HYST] != 0.0 else 0.0
    return logistic((T_w - p[P_TM]) / w), logistic((T_w - p[P_TM] + hys) / w)


@nb.njit(cache=True, inline="always")
def melt_rate(T_w: float, phi: float, p, sw) -> float:  # pragma: no cover - numba
    """dφ/dt: melting towards the heating curve, solidifying towards the cooling curve."""
    up, down = melt_targets(T_w, p, sw)
    if phi < up:
        return (up - phi) / p[P_TAUM]
    if phi > down:
        return (down - phi) / p[P_TAUM]
    return 0.0


@nb.njit(cache=True, inline="always")
def derivs(x, u, kU, TU, Tw_valve, p, sw):  # pragma: no cover - numba
    """Thermal derivatives (T_h, T_w, φ, T_g, T_v) and the PTC power."""
    T_h, T_w, phi, T_g, T_v = x[0], x[1], x[2], x[3], x[4]
    P, _ = heater(T_h, u, kU, p, sw)
    q_hg = p[P_GHG] * (T_h - T_g)
    q_wg = p[P_GWG] * (T_w - T_g)
    q_wv = p[P_GWV] * (T_w - T_v) if sw[S_VALVE] != 0.0 else 0.0
    q_va = p[P_GVA] * (T_v - Tw_valve)
    q_ga = housing_loss(T_g, TU, p, sw)
    if sw[S_KINETICS] != 0.0:
        dphi = melt_rate(T_w, phi, p, sw)
    else:
        dphi = 0.0  # φ follows its curves at once (set after the step)
    L = p[P_LW] if sw[S_LATENT] != 0.0 else 0.0
    if sw[S_NODE] != 0.0:
        q_hw = p[P_GHW] * (T_h - T_w)
        dTh = (P - q_hw - q_hg) / p[P_CH]
        dTw = (q_hw - q_wg - q_wv - L * dphi) / p[P_CW]
    else:
        # PTC and cartridge one lumped node (T_h = T_w)
        dTw = (P - q_hg - q_wg - q_wv - L * dphi) / (p[P_CH] + p[P_CW])
        dTh = dTw
    dTg = (q_hg + q_wg - q_ga) / p[P_CG]
    dTv = (q_wv - q_va) / p[P_CV]
    return dTh, dTw, dphi, dTg, dTv, P


@nb.njit(cache=True, inline="always")
def _settle_melt(x, p, sw):  # pragma: no cover - numba
    # without melt kinetics φ jumps onto the curve it lies outside of (latent heat then
    # taken from the sensible heat of the cartridge at once)
    up, down = melt_targets(x[X_TW], p, sw)
    new = min(max(x[X_PHI], up), down) if up <= down else up
    L = p[P_LW] if sw[S_LATENT] != 0.0 else 0.0
    cw = p[P_CW] if sw[S_NODE] != 0.0 else p[P_CH] + p[P_CW]
    x[X_TW] -= L * (new - x[X_PHI]) / cw
    if sw[S_NODE] == 0.0:
        x[X_TH] = x[X_TW]
    x[X_PHI] = new


@nb.njit(cache=True, inline="always")
def free_stroke(T_w: float, phi: float, p) -> float:  # pragma: no cover - numba
    """Stroke the charge would push out against no force [mm]: melting plus expansion."""
    return p[P_SMELT] * phi + p[P_BEXP] * (T_w - T_ASM)


@nb.njit(cache=True, inline="always")
def mechanics(x, h, p, sw):  # pragma: no cover - numba
    """Piston (stick-slip against the return spring) and valve stem (play) over h seconds.

    Quasi-static force balance on the piston, overdamped by the flow of the
    rubber plug (``b_v``)::

        F_net = k_c (x_free − x_p) − F_0 − k_s x_p − k_ol max(x_p − x_stop, 0)
        x_stop = x_max + 2c  (the piston stroke at which the stem reaches its end stop)
        b_v dx_p/dt = F_net − m F_d   while moving (m = ±1); stuck while |F_net| <= F_st

    Linear in x_p between events, so it is advanced exactly (exponential
    approach to its moving equilibrium) and sticks where the velocity would
    change sign.
    """
    xf = free_stroke(x[X_TW], x[X_PHI], p)
    kc, ks, kol = p[P_KC], p[P_KS], p[P_KOL]
    F0 = p[P_F0] if sw[S_PRELOAD] != 0.0 else 0.0
    fst = p[P_FST] if sw[S_FRICTION] != 0.0 else 0.0
    fd = min(p[P_FD], p[P_FST]) if sw[S_FRICTION] != 0.0 else 0.0
    # the stem rests on its seat with the piston seated: the coupling's play c is taken up
    # over the first c of piston travel from either side (piston coordinate x_p − c in eq 20)
    xstop = p[P_XMAX] + 2.0 * p[P_C]
    xp = x[X_XP]
    m = x[X_M]
    beyond = 1.0 if xp > xstop else 0.0
    F = kc * (xf - xp) - F0 - ks * xp - kol * beyond * (xp - xstop)
    if m == 0.0 and abs(F) > fst:
        m = 1.0 if F > 0.0 else -1.0
    if m != 0.0:
        k = kc + ks + kol * beyond
        xeq = (kc * xf - F0 - m * fd + kol * beyond * xstop) / k
        if (xeq - xp) * m <= 0.0:
            m = 0.0  # the force no longer overcomes the dynamic friction: it sticks
        else:
            xn = xeq + (xp - xeq) * math.exp(-h * k / p[P_BV])
            # crossing the end stop changes the spring rate: stop there, go on next sub-step
            if (xp - xstop) * (xn - xstop) < 0.0:
                xn = xstop
            xp = max(xn, 0.0)
            if xp == 0.0 and m < 0.0:
                m = 0.0  # seated
    x[X_XP] = xp
    x[X_M] = m
    # the stem follows the piston through the play of half-width c (paper 002 eq 20 is the
    # same operator), between the valve seat and its end stop
    c = p[P_C]
    xr = xp - c
    xv = min(max(x[X_XV], xr - c), xr + c)
    x[X_XV] = min(max(xv, 0.0), p[P_XMAX])


@nb.njit(cache=True)
def substep(x, u, kU, TU, Tw_valve, p, sw, h):  # pragma: no cover - numba
    """Advance one specimen's state ``x`` by ``h`` seconds (midpoint rule, then mechanics)."""
    xm = x.copy()
    a0, a1, a2, a3, a4, _ = derivs(x, u, kU, TU, Tw_valve, p, sw)
    hh = 0.5 * h
    xm[0] = x[0] + hh * a0
    xm[1] = x[1] + hh * a1
    xm[2] = x[2] + hh * a2
    xm[3] = x[3] + hh * a3
    xm[4] = x[4] + hh * a4
    b0, b1, b2, b3, b4, P1 = derivs(xm, u, kU, TU, Tw_valve, p, sw)
    x[0] += h * b0
    x[1] += h * b1
    x[2] = min(max(x[2] + h * b2, 0.0), 1.0)
    x[3] += h * b3
    x[4] += h * b4
    x[X_E] += h * P1
    if sw[S_KINETICS] == 0.0:
        _settle_melt(x, p, sw)
    mechanics(x, h, p, sw)


@nb.njit(cache=True)
def advance(x, u, kU, TU, Tw_valve, p, sw, dt, max_step):  # pragma: no cover - numba
    """Advance one specimen by ``dt`` seconds in fixed sub-steps of at most ``max_step``."""
    if dt <= 0.0:
        return
    n = max(1, math.ceil(dt / max_step - 1e-9))
    h = dt / n
    for _ in range(n):
        substep(x, u, kU, TU, Tw_valve, p, sw, h)


@nb.njit(cache=True, inline="always")
def note_turn(v: float, st, out) -> None:  # pragma: no cover - numba
    """Keep the turns of a series fed sample by sample, in time order.

    ``st = [last sample, direction of its move (1, -1, 0; 2 before any), count]``; a
    sample that does not lie strictly between its neighbours (a local maximum or minimum,
    or a point of a plateau) goes to ``out[count]`` once the next sample shows it. The
    first sample (the one ``st`` starts from) and the last (pending) are never kept: the
    caller has them. Dropped samples lie inside strictly monotone runs, which no
    hysteresis turning-point filter needs: it finds the same turning points from the kept
    ones and the last sample as from every sample.
    """
    last = st[0]
    s = 1.0 if v > last else (-1.0 if v < last else 0.0)
    d = st[1]
    if d != 2.0 and (d == 0.0 or s != d):
        n = int(st[2])
        if n < out.shape[0]:
            out[n] = last
        st[2] = n + 1
    st[0] = v
    st[1] = s


@nb.njit(cache=True)
def advance_noting(x, u, kU, TU, Tw_valve, p, sw, dt, max_step, col, st, out):  # pragma: no cover
    """:func:`advance`, and the turns of state ``col`` over its sub-steps (:func:`note_turn`)."""
    if dt <= 0.0:
        return
    n = max(1, math.ceil(dt / max_step - 1e-9))
    h = dt / n
    for _ in range(n):
        substep(x, u, kU, TU, Tw_valve, p, sw, h)
        note_turn(x[col], st, out)


@nb.njit(cache=True)
def outputs(x, u, kU, p, sw, y):  # pragma: no cover - numba
    """P_PTC, R_PTC, T_P (cartridge), T_G (housing), x_V (valve stem)."""
    P, R = heater(x[X_TH], u, kU, p, sw)
    y[0] = P
    y[1] = R
    y[2] = x[X_TW]
    y[3] = x[X_TG]
    y[4] = x[X_XV]


@nb.njit(cache=True)
def step_batch(x, u, dt, p, sw, max_step):  # pragma: no cover - numba
    """Every specimen b by dt[b] with inputs u[b] = (u, k_U, T_U); the valve water at T_U."""
    for b in range(x.shape[0]):
        advance(x[b], u[b, 0], u[b, 1], u[b, 2], u[b, 2], p[b], sw, dt[b], max_step)


@nb.njit(cache=True)
def step_batch_noting(x, u, dt, p, sw, max_step, col, st, out):  # pragma: no cover - numba
    """:func:`step_batch`, noting the turns of state ``col`` of specimen b in ``st[b], out[b]``."""
    for b in range(x.shape[0]):
        advance_noting(x[b], u[b, 0], u[b, 1], u[b, 2], u[b, 2], p[b], sw, dt[b], max_step, col,
                       st[b], out[b])  # fmt: skip


@nb.njit(cache=True)
def simulate_batch(x0, u, dt, p, sw, max_step, y, xs):  # pragma: no cover - numba
    """Whole series: outputs and states at each sample, inputs held over each period."""
    B, T = u.shape[0], u.shape[1]
    for b in range(B):
        x = x0[b].copy()
        for k in range(T):
            outputs(x, u[b, k, 0], u[b, k, 1], p[b], sw, y[b, k])
            xs[b, k] = x
            if k + 1 < T:
                advance(x, u[b, k, 0], u[b, k, 1], u[b, k, 2], u[b, k, 2], p[b], sw, dt, max_step)


def switch_vector(on: dict[str, bool], names: tuple[str, ...]) -> np.ndarray:
    """Switches in kernel order (1.0 on)."""
    return np.array([1.0 if on[n] else 0.0 for n in names])
