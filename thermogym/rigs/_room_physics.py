"""Compiled physics of the room rig's true plant (see :mod:`thermogym.rigs.room`).

Written for the rig alone (nothing from :mod:`thermogym.models`); the actuator
is the AXT211 rig's own plant (:mod:`thermogym.rigs._axt211_physics`). State
layout: the AXT211 rig's 9 states, then ``N_PIPE`` supply-pipe segments,
``N_RAD`` radiator segments, the zone's air, internal mass, wall inner layer
and wall outer layer, and the heat the radiator has emitted [J].
"""

from __future__ import annotations

import math

import numba as nb

from thermogym._jitcache import module_kernels_depend_on
from thermogym.rigs import _axt211_physics as ax

N_PIPE = 8
N_RAD = 6
NA = ax.N_STATES
I_PIPE = NA
I_RAD = I_PIPE + N_PIPE
I_AIR = I_RAD + N_RAD
I_INT = I_AIR + 1
I_WI = I_AIR + 2
I_WO = I_AIR + 3
I_Q = I_AIR + 4
N_STATES = I_Q + 1

# room parameter indices (order of RoomPlant.parameters, after the actuator's)
(
    R_CAIR, R_CINT, R_HINT, R_CWI, R_HAWI, R_HWIO, R_CWO, R_HWOE, R_HWIN, R_HINF, R_HOCC,
    R_QOCC, R_FSOLA, R_FSOLI, R_FOCCA, R_PHI50, R_NRAD, R_CRAD, R_FRADR, R_QNOM, R_DTW,
    R_CPIPE, R_GPIPE, R_AUTH, R_RV, R_LEAK, R_TSUPD, R_TOUTD, R_NCURVE, R_RIPPLE,
    R_RIPPER, R_FPLUME,
) = range(32)  # fmt: skip
N_ROOM_PARAMS = 32
CW = 4186.0  # J/(kg K), water
# room switch indices (order of RoomPlant.extras after the actuator's)
(
    W_SOLAR, W_OCCVENT, W_PIPE, W_AUTH, W_RADSEG, W_RADRAD, W_HOTVALVE, W_PLUME, W_CURVE,
    W_RIPPLE, W_ZONE,
) = range(11)  # fmt: skip
N_ROOM_SWITCHES = 11


@nb.njit(cache=True, inline="always")
def valve_flow(h: float, q, sw, kind: int) -> float:  # pragma: no cover - numba
    """Flow through the radiator as a fraction of its design flow at relative stroke h.

    Inherent characteristic f(h) (linear or equal percentage, rangeability R_v,
    linear below 5 % stroke so that f(0) = leakage); installed with authority
    a (pump head shared with the pipe network): Φ = 1 / sqrt(a / f² + 1 − a).
    """
    h = min(max(h, 0.0), 1.0)
    if kind == 0:
        f = h
    else:
        h0 = 0.05
        f = q[R_RV] ** (h - 1.0) if h >= h0 else h / h0 * q[R_RV] ** (h0 - 1.0)
    f = max(f, q[R_LEAK])
    if sw[W_AUTH] == 0.0:
        return f
    a = q[R_AUTH]
    return 1.0 / math.sqrt(a / (f * f) + 1.0 - a)


@nb.njit(cache=True, inline="always")
def supply_temperature(Tout: float, t: float, q, sw) -> float:  # pragma: no cover - numba
    """Heating curve (curved by the radiator exponent), boiler cycling on top."""
    Tset = 20.0
    x = (Tset - min(Tout, Tset)) / (Tset - q[R_TOUTD])
    n = q[R_NCURVE] if sw[W_CURVE] != 0.0 else 1.0
    T = Tset + (q[R_TSUPD] - Tset) * max(x, 0.0) ** (1.0 / n)
    if sw[W_RIPPLE] != 0.0 and Tout < Tset:
        # an on/off boiler at part load: a triangle-like swing around the set supply
        T += q[R_RIPPLE] * math.sin(2.0 * math.pi * t / q[R_RIPPER])
    return T


@nb.njit(cache=True)
def derivs(x, dx, u, kU, Tout, Qsol, Qocc, t, pa, q, swa, swr, kind):  # pragma: no cover
    """Room derivatives into dx (all but the actuator); returns (Q emitted, T_U of the actuator)."""
    Ta = x[I_AIR]
    Ti = x[I_INT]
    Twi = x[I_WI]
    Two = x[I_WO]
    zone = swr[W_ZONE] != 0.0
    # valve: stroke of the actuator's stem, flow through pipe and radiator
    h = x[ax.X_XV] / pa[ax.P_XMAX]
    mc = valve_flow(h, q, swr, kind) * q[R_QNOM] / q[R_DTW]  # ṁ c_w [W/K] (design ΔT_w)
    Tsup = supply_temperature(Tout, t, q, swr)
    # supply pipe: plug flow in N_PIPE mixed segments (upwind), losing heat to the room air
    if swr[W_PIPE] != 0.0:
        cp = q[R_CPIPE] / N_PIPE
        gp = q[R_GPIPE] / N_PIPE
        prev = Tsup
        for i in range(N_PIPE):
            Tp = x[I_PIPE + i]
            dx[I_PIPE + i] = (mc * (prev - Tp) - gp * (Tp - Ta)) / cp
            prev = Tp
        Tin = prev
        Qpipe = 0.0
        for i in range(N_PIPE):
            Qpipe += gp * (x[I_PIPE + i] - Ta)
    else:
        for i in range(N_PIPE):
            dx[I_PIPE + i] = 0.0
        Tin = Tsup
        Qpipe = 0.0
    # radiator: N_RAD segments along the water path, each K_seg (T − T_a)^n (EN 442-2)
    n = q[R_NRAD]
    K = q[R_PHI50] / 50.0**n
    Q = 0.0
    if swr[W_RADSEG] != 0.0:
        cr = q[R_CRAD] / N_RAD
        ks = K / N_RAD
        prev = Tin
        for i in range(N_RAD):
            Tr = x[I_RAD + i]
            d = Tr - Ta
            qi = ks * abs(d) ** n * (1.0 if d >= 0.0 else -1.0)
            dx[I_RAD + i] = (mc * (prev - Tr) - qi) / cr
            Q += qi
            prev = Tr
    else:
        # one well-mixed node (all segments move together)
        Tr = x[I_RAD]
        d = Tr - Ta
        Q = K * abs(d) ** n * (1.0 if d >= 0.0 else -1.0)
        dT = (mc * (Tin - Tr) - Q) / q[R_CRAD]
        for i in range(N_RAD):
            dx[I_RAD + i] = dT
    frad = q[R_FRADR] if swr[W_RADRAD] != 0.0 else 0.0
    # gains: solar mostly onto the floor and furniture, occupancy half radiant
    if swr[W_SOLAR] != 0.0:
        sa, si = q[R_FSOLA], q[R_FSOLI]
    else:
        sa, si = 0.5, 0.5
    sw_ = 1.0 - sa - si
    oa = q[R_FOCCA]
    Hve = q[R_HINF]
    if swr[W_OCCVENT] != 0.0:
        Hve += q[R_HOCC] * min(max(Qocc / q[R_QOCC], 0.0), 1.0)
    else:
        Hve += 0.5 * q[R_HOCC]
    # the actuator: in the radiator's plume, on a valve body full of supply water
    Trm = 0.0
    for i in range(N_RAD):
        Trm += x[I_RAD + i]
    Trm /= N_RAD
    TU = Ta + (q[R_FPLUME] * max(Trm - Ta, 0.0) if swr[W_PLUME] != 0.0 else 0.0)
    P, _ = ax.heater(x[ax.X_TH], u, kU, pa, swa)
    # zone nodes
    Hint = q[R_HINT]
    qi_a = Hint * (Ti - Ta)
    if zone:
        qwi_a = q[R_HAWI] * (Twi - Ta)
    else:
        qwi_a = 0.0
    dx[I_AIR] = (
        (1.0 - frad) * Q + qi_a + qwi_a + Qpipe + P
        + sa * Qsol + oa * Qocc
        - Hve * (Ta - Tout) - q[R_HWIN] * (Ta - Tout)
    ) / q[R_CAIR]  # fmt: skip
    if zone:
        dx[I_INT] = (-qi_a + si * Qsol + 0.6 * (1.0 - oa) * Qocc + 0.5 * frad * Q) / q[R_CINT]
        dx[I_WI] = (
            -qwi_a - q[R_HWIO] * (Twi - Two) + sw_ * Qsol + 0.4 * (1.0 - oa) * Qocc
            + 0.5 * frad * Q
        ) / q[R_CWI]  # fmt: skip
        dx[I_WO] = (q[R_HWIO] * (Twi - Two) - q[R_HWOE] * (Two - Tout)) / q[R_CWO]
    else:
        # the zone as air plus one lumped store coupled through the internal-mass surface
        Uw = 1.0 / (1.0 / q[R_HWIO] + 1.0 / q[R_HWOE])
        dx[I_INT] = (
            -qi_a + (si + sw_) * Qsol + (1.0 - oa) * Qocc + frad * Q - Uw * (Ti - Tout)
        ) / (q[R_CINT] + q[R_CWI] + q[R_CWO])  # fmt: skip
        dx[I_WI] = dx[I_INT]
        dx[I_WO] = dx[I_INT]
    dx[I_Q] = Q
    Twater = Tin if swr[W_HOTVALVE] != 0.0 else TU
    return Q, TU, Twater


@nb.njit(cache=True)
def substep(
    x, xm, k1, k2, u, kU, Tout, Qsol, Qocc, t, pa, q, swa, swr, h, kind
):  # pragma: no cover
    """Advance one room by h: room by the midpoint rule, the actuator by its own sub-step."""
    derivs(x, k1, u, kU, Tout, Qsol, Qocc, t, pa, q, swa, swr, kind)
    for i in range(NA, N_STATES):
        xm[i] = x[i] + 0.5 * h * k1[i]
    for i in range(NA):
        xm[i] = x[i]
    _, TU2, Tw2 = derivs(xm, k2, u, kU, Tout, Qsol, Qocc, t + 0.5 * h, pa, q, swa, swr, kind)
    # the actuator, with its air and valve water at the mid-step values of the room
    ax.substep(x, u, kU, TU2, Tw2, pa, swa, h)
    for i in range(NA, N_STATES):
        x[i] += h * k2[i]


@nb.njit(cache=True)
def advance(x, u, kU, Tout, Qsol, Qocc, t, dt, pa, q, swa, swr, max_step, kind):  # pragma: no cover
    """One room over dt seconds in fixed sub-steps."""
    if dt <= 0.0:
        return
    n = max(1, math.ceil(dt / max_step - 1e-9))
    h = dt / n
    xm = x.copy()
    k1 = x.copy()
    k2 = x.copy()
    for j in range(n):
        substep(x, xm, k1, k2, u, kU, Tout, Qsol, Qocc, t + j * h, pa, q, swa, swr, h, kind)


@nb.njit(cache=True)
def advance_noting(
    x, u, kU, Tout, Qsol, Qocc, t, dt, pa, q, swa, swr, max_step, kind, col, st, out
):  # pragma: no cover - numba
    """:func:`advance`, and the turns of state ``col`` over its sub-steps (``ax.note_turn``)."""
    if dt <= 0.0:
        return
    n = max(1, math.ceil(dt / max_step - 1e-9))
    h = dt / n
    xm = x.copy()
    k1 = x.copy()
    k2 = x.copy()
    for j in range(n):
        substep(x, xm, k1, k2, u, kU, Tout, Qsol, Qocc, t + j * h, pa, q, swa, swr, h, kind)
        ax.note_turn(x[col], st, out)


@nb.njit(cache=True)
def step_batch_noting(
    x, u, t, dt, pa, q, swa, swr, max_step, kind, col, st, out
):  # pragma: no cover - numba
    """:func:`step_batch`, noting the turns of state ``col`` of room b in ``st[b], out[b]``."""
    for b in range(x.shape[0]):
        advance_noting(x[b], u[b, 0], u[b, 1], u[b, 2], u[b, 3], u[b, 4], t[b], dt[b], pa[b],
                       q[b], swa, swr, max_step, kind, col, st[b], out[b])  # fmt: skip


@nb.njit(cache=True)
def step_batch(x, u, t, dt, pa, q, swa, swr, max_step, kind):  # pragma: no cover - numba
    """Every room b by dt[b] with inputs u[b] = (u, k_U, T_out, Q_sol, Q_occ) from time t[b]."""
    for b in range(x.shape[0]):
        advance(x[b], u[b, 0], u[b, 1], u[b, 2], u[b, 3], u[b, 4], t[b], dt[b], pa[b], q[b],
                swa, swr, max_step, kind)  # fmt: skip


@nb.njit(cache=True)
def observe(x, u, t, pa, q, swa, swr, kind, y):  # pragma: no cover - numba
    """Outputs of one room: T_zone, T_rad, T_supply, Q_heat, x_V, P_PTC, T_P, the actuator's T_U."""
    dx = x.copy()
    Q, TU, _ = derivs(x, dx, u[0], u[1], u[2], u[3], u[4], t, pa, q, swa, swr, kind)
    Trm = 0.0
    for i in range(N_RAD):
        Trm += x[I_RAD + i]
    P, _ = ax.heater(x[ax.X_TH], u[0], u[1], pa, swa)
    y[0] = x[I_AIR]
    y[1] = Trm / N_RAD
    y[2] = supply_temperature(u[2], t, q, swr)
    y[3] = Q
    y[4] = x[ax.X_XV]
    y[5] = P
    y[6] = x[ax.X_TW]
    y[7] = TU


@nb.njit(cache=True)
def simulate_batch(x0, u, t0, dt, pa, q, swa, swr, max_step, kind, y, xs):  # pragma: no cover
    """Whole series of B rooms (inputs held over each sample)."""
    B, T = u.shape[0], u.shape[1]
    for b in range(B):
        x = x0[b].copy()
        for k in range(T):
            t = t0 + k * dt
            observe(x, u[b, k], t, pa[b], q[b], swa, swr, kind, y[b, k])
            xs[b, k] = x
            if k + 1 < T:
                uk = u[b, k]
                advance(x, uk[0], uk[1], uk[2], uk[3], uk[4], t, dt, pa[b], q[b], swa, swr,
                        max_step, kind)  # fmt: skip


# the room's kernels contain the actuator's (ax.substep, ax.note_turn): their cache follows
# _axt211_physics.py too
module_kernels_depend_on(globals())
