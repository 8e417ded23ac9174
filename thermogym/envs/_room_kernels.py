"""Compiled kernels of the AXT211 room environment: scalar and lockstep steps.

The layouts of the per-plant arrays (``cfg``, ``acc``), the scalar step of
one plant (:func:`_room_dyn`, the room's RK4 with the heater's duty-cycle
parts and trapezoidal heat sums), what follows a step (:func:`_room_post`:
KPIs, reward, measurement, observation), the lockstep that advances blocks of
plants lane by lane (bit for bit the scalar step), and the factory of the
step kernels the engine of :mod:`thermogym.envs.axt211_room` calls
(:func:`_step_kernels`). Every kernel's on-disk cache depends on the model
code it inlines (:func:`~thermogym._jitcache.cache_depends_on`).
"""

from __future__ import annotations

import functools
import math
from typing import Any, NamedTuple

import numba as nb
import numpy as np

from thermogym.envs._kernels import (
    block_steppers,
    cache_depends_on,
    lane_tracker,
    measure,
    tp_push,
)
from thermogym.envs.kpis import tp_update_at
from thermogym.models import axt211_dynamics as ax
from thermogym.models import integrators
from thermogym.models import room_dynamics as rd
from thermogym.models.integrators import rk4_accumulate, rk4_finish, rk4_stage_input

__all__: list[str] = []

# cfg layout (_ROOM: free turning-point places a step needs, see tp_room)
(
    _T, _HMAX, _HOR, _AMODE, _KIND, _WC, _WH, _WA, _WS, _WLIM, _TRIP, _FROST, _HT, _HX,
    _PREV, _OCC0, _OCC1, _OCCD, _SPO, _SPU, _BLO, _BHI, _SLO, _SHI, _GO, _GU, _ROOM,
) = range(27)  # fmt: skip
# acc layout
_A_E, _A_Q, _A_SW, _A_TRAV, _A_ABOVE, _A_DISC, _A_ON, _A_UPREV, _A_QLAST = range(9)
_A_TPT, _A_TPX = 9, 13
_A_TOUT, _A_QINT = 17, 18  # T_out and Q_int held over the next period (set by _room_post)
_NACC = 19


@nb.njit(cache=True, inline="always")
def _table(tab, b, col, base, t):  # pragma: no cover - numba
    # hourly table, linear interpolation, periodic in its length
    n = tab.shape[2]
    bb = b if tab.shape[0] > 1 else 0
    H = t / 3600.0
    i = math.floor(H)
    f = H - i
    j = int(i - base) % n
    j1 = j + 1 if j + 1 < n else 0
    return tab[bb, col, j] * (1.0 - f) + tab[bb, col, j1] * f


@nb.njit(cache=True, inline="always")
def _clock(t, cfg):  # pragma: no cover - numba
    # occupied at time t [s], and the clock time [h]
    day = math.floor(t / 86400.0)
    hour = (t - 86400.0 * day) / 3600.0
    wd = day % 7
    return wd < cfg[_OCCD] and cfg[_OCC0] <= hour < cfg[_OCC1], hour


#: Longest interval of the trapezoidal energy integration [s] (a few RK4 steps).
QUAD_S = 10.0


@nb.njit(cache=True, inline="always")
def _segment(
    x, u, kU, Tout, Qint, pb, L, hmax, kind, P0, Q0, b, acc, tpbuf, ntp, hT
):  # pragma: no cover - numba
    # Advance one system (state tuple x) over a segment of length L with the heater command
    # u held, by the room model's RK4 steps (h <= max_step); P_PTC and Q_heat are integrated
    # by the trapezoidal rule on intervals of at most QUAD_S seconds. The wax temperature
    # after every step goes to plant b's turning-point tracker (ntp: its count of points).
    n = max(1, math.ceil(L / hmax - 1e-9))
    h = L / n
    m = max(1, int(QUAD_S / h + 1e-9))
    q, r, e = ax.coefficients(pb), rd.coefficients(pb), ax.effect_coefficients(pb)
    v = kU * u
    Tsup = rd.supply(Tout, pb)  # T_out is held over the segment
    E = 0.0
    Q = 0.0
    done = 0
    while done < n:
        s = min(m, n - done)
        for _ in range(s):
            x = rd.advance(x, v * v, Tsup, Tout, Qint, h, 1, q, r, e, kind)  # one RK4 step
            ntp = tp_push(acc, b, _A_TPT, x[0], hT, tpbuf, ntp)
        P1 = ax.power(v * v, ax.resistance(x[0], q), pb[ax.I_RS]) if u > 0.0 else 0.0
        Q1 = rd.heat(x[4], x[5], r)
        E += 0.5 * (P0 + P1) * s * h
        Q += 0.5 * (Q0 + Q1) * s * h
        P0 = P1
        Q0 = Q1
        done += s
    return x, E, Q, Q0, ntp


# ------------------------------------------------------------------ lockstep kernel
# As in axt211_valve: the plants of a batch advance in lockstep, RK4 sub-step s of every
# plant of a block of W lanes per pass (each plant with its own step size and heater input;
# plants with fewer sub-steps idle), in a branch-free loop over the lanes that vectorises;
# the stages (_stage, with room._deriv_lane) are room._advance operation for operation and
# the trapezoidal points are those of _segment, so results are bit for bit those of
# stepping each plant alone. Parameter sets with an active actuator effect take the scalar
# _room_dyn. A block lives in one flat array, row r of lane i at wb[r * W + i]. The wax
# temperature after every sub-step goes to a copy of the plant's turning-point tracker in
# the block (_kernels.lane_tracker, shared with axt211_valve's lockstep: points to _NSLOT
# rows per lane, a period that confirms more is stepped again by _room_dyn).

_NQA = rd.LANE_ROOM  # the room's coefficient rows follow the actuator's in a block
_NQ = rd.LANE_PLAIN  # parameter rows in a block (the plain flag goes to _R_PLAIN)
(
    _R_TP, _R_TG, _R_XP, _R_XV, _R_TR, _R_TA, _R_TS, _R_NON, _R_NTOT, _R_HON, _R_HOFF,
    _R_MQON, _R_MQOFF, _R_CNT, _R_E, _R_QON, _R_QOFF, _R_P0, _R_Q0, _R_KU2, _R_TOUT,
    _R_QINT, _R_TSUP, _R_BASE, _R_PW, _R_EXPV, _R_PWV, _R_H, _R_V2, _R_NTPS,
) = range(_NQ, _NQ + 30)  # fmt: skip
_R_K = _NQ + 30  # 6 rows: derivatives of the last stage (all states but x_V)
_R_S = _R_K + 6  # 6 rows: their weighted RK4 sum so far
_R_TRK = _R_S + 6  # 2 rows: the wax-temperature tracker (as in axt211_valve's lockstep)
_NSLOT = 2  # turning points a lane keeps per period (a valley and a peak, with hysteresis)
_R_TPS = _R_TRK + 2  # _NSLOT rows: turning points confirmed in the period
_NROW = _R_TPS + _NSLOT
_R_PLAIN = _NROW  # 1 where the plant has no actuator effect (the lockstep applies)
_NROWB = _NROW + 1  # rows of a block array: the engine keeps one per block of plants, so the
# parameter rows (0.._NQ-1, written when a parameter set is installed) are not copied per step


@nb.njit(cache=True, inline="always")
def _room_action(b, act, cfg, ctr):  # pragma: no cover - numba
    # duty in [0, 1] of plant b, or -1 for an invalid action
    a = act[b, 0]
    if cfg[_AMODE] == 1.0:
        if a != 0.0 and a != 1.0:
            ctr[b, 3] = 1
            return -1.0
        return a
    if not math.isfinite(a):
        ctr[b, 3] = 1
        return -1.0
    return min(max(0.5 * (a + 1.0), 0.0), 1.0)


@nb.njit(cache=True, inline="always")
def _room_inputs(b, acc):  # pragma: no cover - numba
    # outdoor temperature and gains held over plant b's next period (from _room_post)
    return acc[b, _A_TOUT], acc[b, _A_QINT]


@nb.njit(cache=True)
def _room_dyn(
    xb, d, kU, Tout, Qint, pb, T, hmax, kind, Q0, b, acc, tpbuf, ctr, hT
):  # pragma: no cover - numba
    # one plant over one period by the model's scalar RK4 (actuator effects included): on
    # for d·T, then off; returns the actuator energy [J], the heat [J] and the last Q_heat.
    # The wax temperature after every RK4 step goes to plant b's turning-point tracker
    # (hysteresis hT; acc, tpbuf, ctr as _room_post)
    x = (xb[0], xb[1], xb[2], xb[3], xb[4], xb[5], xb[6])
    E = 0.0
    Qsum = 0.0
    ntp = ctr[b, 2]
    ton = d * T
    if ton > 0.0:
        P0 = ax.power(kU * kU, ax.resistance(x[0], ax.coefficients(pb)), pb[ax.I_RS])
        x, e1, q1, Q0, ntp = _segment(
            x, 1.0, kU, Tout, Qint, pb, ton, hmax, kind, P0, Q0, b, acc, tpbuf, ntp, hT
        )
        E += e1
        Qsum += q1
    toff = T - ton
    if toff > 1e-9 * T:
        x, _, q1, Q0, ntp = _segment(
            x, 0.0, kU, Tout, Qint, pb, toff, hmax, kind, 0.0, Q0, b, acc, tpbuf, ntp, hT
        )
        Qsum += q1
    ctr[b, 2] = ntp
    for j in range(7):
        xb[j] = x[j]
    return E, Qsum, Q0


@nb.njit(cache=True, inline="always")
def _room_post(
    b, mode, d, E, Qsum, xV0, x, p, dist, tab, acc, tpbuf, ctr, noise, meas, cfg, obs, out, sig
):  # pragma: no cover - numba
    # KPIs, reward and measurement of plant b after its step (mode 0) or at the start (1).
    # The wax-temperature tracker has had the period's sub-steps already (the dynamics feed
    # it); here it gets the first sample of an episode. Inlined into the row loop: a call
    # per plant would increment and decrement the reference count of each of its array
    # arguments (atomic operations, measured 7 % of a vector step)
    T = cfg[_T]
    TP = x[b, 0]
    xV = x[b, 3]
    Tr = x[b, 4]
    Tz = x[b, 5]
    base = dist[b, 2]
    k = ctr[b, 0]
    ntp = ctr[b, 2]
    Pm = 0.0
    Qm = 0.0
    r = 0.0
    t = dist[b, 1] + k * T
    if mode == 1:
        occ, hour = _clock(t, cfg)
        ntp = tp_push(acc, b, _A_TPT, TP, cfg[_HT], tpbuf, ntp)
        tp_update_at(acc, b, _A_TPX, xV, cfg[_HX])
        acc[b, _A_QLAST] = rd.heat(Tr, Tz, rd.coefficients(p[b]))
    else:
        sw = 1.0 if (d > 0.0 and acc[b, _A_ON] == 0.0) else 0.0
        acc[b, _A_ON] = 1.0 if d >= 1.0 else 0.0
        t1 = t + T
        occ, hour = _clock(t1, cfg)
        dev = 0.0
        if occ:
            dev = max(cfg[_BLO] - Tz, Tz - cfg[_BHI], 0.0)
        D = dev * T / 3600.0
        Pm = E / T
        Qm = Qsum / T
        acc[b, _A_E] += E
        acc[b, _A_Q] += Qsum
        acc[b, _A_SW] += sw
        acc[b, _A_TRAV] += abs(xV - xV0)
        acc[b, _A_DISC] += D
        if TP > cfg[_WLIM]:
            acc[b, _A_ABOVE] += T
        tp_update_at(acc, b, _A_TPX, xV, cfg[_HX])  # the stroke: once per period
        r = -(cfg[_WC] * D + cfg[_WH] * Qsum / 3.6e6 + cfg[_WA] * E / 3600.0 + cfg[_WS] * sw)
        k += 1
        ctr[b, 0] = k
        out[b, 0] = r
        out[b, 1] = 1.0 if (TP > cfg[_TRIP] or Tz < cfg[_FROST]) else 0.0
        out[b, 2] = 1.0 if k >= cfg[_HOR] else 0.0
        acc[b, _A_UPREV] = d
        t = t1
    ctr[b, 2] = ntp
    cur = ctr[b, 1]
    ctr[b, 1] = cur + 1
    # the inputs held over the next period (read by the next step's dynamics)
    Tout = _table(tab, b, 0, base, t)
    Qint = (cfg[_GO] if occ else cfg[_GU]) + _table(tab, b, 1, base, t)
    acc[b, _A_TOUT] = Tout
    acc[b, _A_QINT] = Qint
    t_h = k * T / 3600.0
    obs[b, 0] = measure(Tz, meas, 0, noise[b, cur, 0], t_h)
    obs[b, 1] = cfg[_SPO] if occ else cfg[_SPU]
    obs[b, 2] = measure(Tout, meas, 1, noise[b, cur, 1], t_h)
    obs[b, 3] = 1.0 if occ else 0.0
    obs[b, 4] = cfg[_BLO] if occ else cfg[_SLO]
    obs[b, 5] = cfg[_BHI] if occ else cfg[_SHI]
    obs[b, 6] = math.sin(2.0 * math.pi * hour / 24.0)
    obs[b, 7] = math.cos(2.0 * math.pi * hour / 24.0)
    if cfg[_PREV] > 0.0:
        obs[b, 8] = acc[b, _A_UPREV]
    sig[b, 0] = Tz
    sig[b, 1] = obs[b, 1]
    sig[b, 2] = obs[b, 4]
    sig[b, 3] = obs[b, 5]
    sig[b, 4] = Tout
    sig[b, 5] = Tr
    sig[b, 6] = Qm
    sig[b, 7] = xV
    sig[b, 8] = TP
    sig[b, 9] = Pm
    sig[b, 10] = d
    sig[b, 11] = obs[b, 3]
    sig[b, 12] = Qint
    sig[b, 13] = r


@nb.njit(cache=True, inline="always")
def _quad_point(wb, W, i, sf, non, ntot, hon, hoff, ku2, R, Q, first):  # pragma: no cover
    # trapezoidal ∫P_PTC dt (heater-on part) and ∫Q_heat dt (both parts) as in _segment:
    # a point at state j = sf every QUAD_S seconds of a part and at its end; R, Q: R_PTC
    # and Q_heat at that state; only at stage 1 of a sub-step (first)
    P = ax.power(ku2, R, 0.0)  # (15) at u = 1
    inon = first & (sf >= 1.0) & (sf <= non)
    inoff = first & (sf > non) & (sf <= ntot)
    cnt = wb[_R_CNT * W + i] + (1.0 if (inon | inoff) else 0.0)
    due_on = inon & ((cnt == wb[_R_MQON * W + i]) | (sf == non))
    due_off = inoff & ((cnt == wb[_R_MQOFF * W + i]) | (sf == ntot))
    P0 = wb[_R_P0 * W + i]
    Q0 = wb[_R_Q0 * W + i]
    E = wb[_R_E * W + i]
    Qon = wb[_R_QON * W + i]
    Qoff = wb[_R_QOFF * W + i]
    wb[_R_E * W + i] = E + 0.5 * (P0 + P) * cnt * hon if due_on else E
    wb[_R_QON * W + i] = Qon + 0.5 * (Q0 + Q) * cnt * hon if due_on else Qon
    wb[_R_QOFF * W + i] = Qoff + 0.5 * (Q0 + Q) * cnt * hoff if due_off else Qoff
    wb[_R_P0 * W + i] = P if (due_on | (first & (sf == 0.0))) else P0
    wb[_R_Q0 * W + i] = Q if (due_on | due_off) else Q0
    wb[_R_CNT * W + i] = 0.0 if (due_on | due_off) else cnt


@nb.njit(cache=True, inline="always")
def _stage_base(wb, W, i, xP, xV0, Tr, Ta, kind):  # pragma: no cover - numba
    # the bases of the power laws of the next stage at its inputs (stroke xP, step-start
    # valve stroke xV0, radiator Tr, zone Ta): emission, and the equal-percentage valve
    r = rd.load_coefficients(wb, _NQA, W, i)
    wb[_R_BASE * W + i] = rd.emission_base(Tr, Ta, r)
    if kind != 0:
        q = ax.load_coefficients(wb, 0, W, i)
        wb[_R_EXPV * W + i] = rd.valve_stroke(xP, xV0, q, r) - 1.0


@nb.njit(cache=True, inline="always")
def _powers(wb, W, kind):  # pragma: no cover - numba
    # the power laws of a stage, in a loop of their own (vpow: vectorises, as the scalar
    # kernel's)
    for i in range(W):
        wb[_R_PW * W + i] = rd.power_law(
            wb[_R_BASE * W + i], wb[(_NQA + rd.R_NR) * W + i]
        )  # ^n_rad
    if kind != 0:
        for i in range(W):
            wb[_R_PWV * W + i] = rd.power_law(wb[(_NQA + rd.R_RV) * W + i], wb[_R_EXPV * W + i])


@nb.njit(cache=True, inline="always")
def _stage(wb, W, i, sf, j, kind, hT):  # pragma: no cover - numba
    # stage j (1-4, a compile-time constant) of RK4 sub-step sf of lane i: the model's step
    # (room_dynamics.step) cut into stages by the shared integrator's stage functions, with
    # the power laws from _powers and the sub-step's step size and heater input from _prepare
    first = j == 1
    last = j == 4
    q = ax.load_coefficients(wb, 0, W, i)
    r = rd.load_coefficients(wb, _NQA, W, i)
    non = wb[_R_NON * W + i]
    ntot = wb[_R_NTOT * W + i]
    h = wb[_R_H * W + i]
    # the six integrated states (x_V is the step-start memory of (20)), the previous
    # stage's derivatives and the weighted sum so far (loads outside the selects: a load
    # under a condition keeps the loop from vectorising)
    x = (
        wb[_R_TP * W + i], wb[_R_TG * W + i], wb[_R_XP * W + i], wb[_R_TR * W + i],
        wb[_R_TA * W + i], wb[_R_TS * W + i],
    )  # fmt: skip
    xV = wb[_R_XV * W + i]
    kp = _load6(wb, _R_K, W, i)
    sp = _load6(wb, _R_S, W, i)
    xin = rk4_stage_input(x, kp, h, j)
    Q = rd.emission(xin[3], xin[4], wb[_R_PW * W + i], r)
    pwv = wb[_R_PWV * W + i] if kind != 0 else 0.0
    k, R = rd.lane_rhs(
        xin, xV, wb[_R_V2 * W + i], wb[_R_TSUP * W + i], wb[_R_TOUT * W + i],
        wb[_R_QINT * W + i], Q, pwv, q, r, kind,
    )  # fmt: skip
    _quad_point(
        wb, W, i, sf, non, ntot, wb[_R_HON * W + i], wb[_R_HOFF * W + i], wb[_R_KU2 * W + i],
        R, Q, first,
    )  # fmt: skip
    sn = rk4_accumulate(sp, k, j)
    _store6(wb, _R_K, W, i, k)
    _store6(wb, _R_S, W, i, sn)
    # after stage 4: the new state (lanes past their last sub-step keep theirs)
    run = last & (sf < ntot)
    xn = rk4_finish(x, h, sn)
    xPn, xVn = ax.constrain(xn[2], xV, q)  # end stops and (20), as in the model's step
    y = (
        xn[0] if run else x[0], xn[1] if run else x[1], xPn if run else x[2],
        xn[3] if run else x[3], xn[4] if run else x[4], xn[5] if run else x[5],
    )  # fmt: skip
    y3 = xVn if run else xV
    if last:  # (a compile-time constant) the wax temperature after the sub-step
        lane_tracker(wb, W, i, y[0], run, hT, _R_TRK, _R_NTPS, _R_TPS, _NSLOT)
    wb[_R_TP * W + i] = y[0]
    wb[_R_TG * W + i] = y[1]
    wb[_R_XP * W + i] = y[2]
    wb[_R_XV * W + i] = y3
    wb[_R_TR * W + i] = y[3]
    wb[_R_TA * W + i] = y[4]
    wb[_R_TS * W + i] = y[5]
    # arguments of the powers of the next stage (stage 1 of the next sub-step after 4)
    nxt = y if last else rk4_stage_input(x, k, h, j + 1)
    _stage_base(wb, W, i, nxt[2], y3 if last else xV, nxt[3], nxt[4], kind)


_load6 = integrators.loader(6)


@nb.njit(cache=True, inline="always")
def _store6(wb, o, W, i, t):  # pragma: no cover - numba
    # a 6-tuple to rows o..o+5 of lane i (explicit stores: the loop over lanes vectorises)
    wb[o * W + i] = t[0]
    wb[(o + 1) * W + i] = t[1]
    wb[(o + 2) * W + i] = t[2]
    wb[(o + 3) * W + i] = t[3]
    wb[(o + 4) * W + i] = t[4]
    wb[(o + 5) * W + i] = t[5]


@nb.njit(cache=True, inline="always")
def _prepare(wb, W, sf):  # pragma: no cover - numba
    # step size and (k_U u)² of sub-step sf per lane: the on or the off part. Kept apart
    # from the stage loops: there LLVM would turn these selects of two loaded values into
    # a load from a selected address, and then refuse to vectorise ("indirect dependence")
    for i in range(W):
        on = sf < wb[_R_NON * W + i]
        wb[_R_H * W + i] = wb[_R_HON * W + i] if on else wb[_R_HOFF * W + i]
        wb[_R_V2 * W + i] = wb[_R_KU2 * W + i] if on else 0.0


def _make_lockstep(W, kind):  # type: ignore[no-untyped-def]
    """Compiled lockstep of a block of W lanes (valve characteristic ``kind``).

    W, the stage number and ``kind`` are compile-time constants of each compiled loop
    (closure variables): the row stride is then known, the stage's selects fold away, and
    each loop over the lanes vectorises. The four stage loops are compiled apart (numba's
    IR inlining of all four into one function took minutes to compile).
    """

    def stage_loop(j):  # type: ignore[no-untyped-def]
        @nb.njit(cache=True, error_model="numpy", _nrt=False)
        def stage(wb, sf, hT):  # pragma: no cover - numba
            for i in range(W):
                _stage(wb, W, i, sf, j, kind, hT)

        return stage

    st1, st2, st3, st4 = stage_loop(1), stage_loop(2), stage_loop(3), stage_loop(4)

    @nb.njit(cache=True, error_model="numpy", _nrt=False)
    def lockstep(wb, nmax, hT):  # pragma: no cover - numba
        # nmax RK4 sub-steps of the W lanes of block wb, then the last trapezoidal points
        for i in range(W):
            _stage_base(
                wb, W, i, wb[_R_XP * W + i], wb[_R_XV * W + i], wb[_R_TR * W + i],
                wb[_R_TA * W + i], kind,
            )  # fmt: skip
        for s in range(nmax):
            sf = float(s)
            _prepare(wb, W, sf)
            _powers(wb, W, kind)
            st1(wb, sf, hT)
            _powers(wb, W, kind)
            st2(wb, sf, hT)
            _powers(wb, W, kind)
            st3(wb, sf, hT)
            _powers(wb, W, kind)
            st4(wb, sf, hT)
        _powers(wb, W, 0)
        sf = float(nmax)
        for i in range(W):
            R = ax.resistance(wb[_R_TP * W + i], ax.load_coefficients(wb, 0, W, i))
            Q = rd.emission(
                wb[_R_TR * W + i], wb[_R_TA * W + i], wb[_R_PW * W + i],
                rd.load_coefficients(wb, _NQA, W, i),
            )  # fmt: skip
            _quad_point(
                wb, W, i, sf, wb[_R_NON * W + i], wb[_R_NTOT * W + i], wb[_R_HON * W + i],
                wb[_R_HOFF * W + i], wb[_R_KU2 * W + i], R, Q, True,
            )  # fmt: skip

    return lockstep, (st1, st2, st3, st4)


_BW = 32  # lanes of a full block (81 rows x 32 lanes x 8 B = 20 KiB: L1 cache)


@nb.njit(cache=True)
def _part(L, hmax):  # pragma: no cover - numba
    # sub-steps, step and trapezoidal interval (in steps) of a part of length L, as _segment
    n = max(1, math.ceil(L / hmax - 1e-9))
    h = L / n
    return n, h, float(max(1, int(QUAD_S / h + 1e-9)))


class _StepKernels(NamedTuple):
    step: Any
    step_parallel: Any
    rollout: Any


@functools.cache
def _step_kernels(kind: int, lockstep: bool) -> _StepKernels:
    """Compiled step kernels for valve characteristic ``kind``, with or without lockstep.

    Without lockstep every plant advances by the scalar kernel (_room_dyn): a single
    environment or a few plants, and nothing of the lockstep is compiled (its 5 heavily
    inlined loops per variant take minutes to compile on a cold cache). With lockstep,
    full blocks of _BW plants advance together (bit-identical to the scalar kernel for
    plants without an actuator effect) and a partial block by the scalar kernel.
    ``kind`` and ``lockstep`` are compile-time constants of the closures (pruned branches).
    """
    ls, stage_loops = _make_lockstep(_BW, kind) if lockstep else (None, ())

    @nb.njit(cache=True)
    def block(
        b0, W, wb, act, active, x, p, dist, tab, acc, tpbuf, cfg, ctr, dd, EE, QQ, xv0, ok, lo
    ):  # pragma: no cover - numba
        # advance plants b0..b0+W-1 by one control period; returns 1 if an action was invalid.
        # wb: the block's array (parameter rows filled, row stride _BW; W < _BW only for the
        # last, partial block, whose plants take the scalar kernel)
        T = cfg[_T]
        hmax = cfg[_HMAX]
        hT = cfg[_HT]
        kind = int(cfg[_KIND])
        status = 0
        nmax = 0
        for i in range(W):
            b = b0 + i
            j = b - lo
            non, n_off, hon, hoff, mqon, mqoff = 0, 0, 0.0, 0.0, 1.0, 1.0
            Tout, Qint = 0.0, 0.0
            if active[b]:
                d = _room_action(b, act, cfg, ctr)
                if d < 0.0:
                    status = 1
                else:
                    ok[j] = True
                    dd[j] = d
                    xv0[j] = x[b, 3]
                    Tout, Qint = _room_inputs(b, acc)
                    # the scalar kernel: actuator effects, the lanes of a partial block, every
                    # plant of the variant without lockstep (and a wax-temperature tracker
                    # without its first sample, which the lanes' tracker assumes)
                    if (
                        not lockstep or W != _BW or wb[_R_PLAIN * _BW + i] == 0.0
                        or acc[b, _A_TPT] == 0.0
                    ):  # fmt: skip
                        EE[j], QQ[j], acc[b, _A_QLAST] = _room_dyn(
                            x[b], d, dist[b, 0], Tout, Qint, p[b], T, hmax, kind,
                            acc[b, _A_QLAST], b, acc, tpbuf, ctr, hT,
                        )  # fmt: skip
                    else:
                        ton = d * T
                        toff = T - ton
                        if ton > 0.0:
                            non, hon, mqon = _part(ton, hmax)
                        if toff > 1e-9 * T:
                            n_off, hoff, mqoff = _part(toff, hmax)
            ntot = non + n_off
            nmax = max(nmax, ntot)
            if not lockstep or W != _BW:
                continue
            for k in range(7):
                wb[(_R_TP + k) * W + i] = x[b, k]
            wb[_R_NON * W + i] = non
            wb[_R_NTOT * W + i] = ntot
            wb[_R_HON * W + i] = hon
            wb[_R_HOFF * W + i] = hoff
            wb[_R_MQON * W + i] = mqon
            wb[_R_MQOFF * W + i] = mqoff
            wb[_R_CNT * W + i] = 0.0
            wb[_R_E * W + i] = 0.0
            wb[_R_QON * W + i] = 0.0
            wb[_R_QOFF * W + i] = 0.0
            wb[_R_P0 * W + i] = 0.0
            wb[_R_Q0 * W + i] = acc[b, _A_QLAST]
            wb[_R_KU2 * W + i] = dist[b, 0] * dist[b, 0]
            wb[_R_TOUT * W + i] = Tout
            wb[_R_QINT * W + i] = Qint
            # heating curve, T_out held
            wb[_R_TSUP * W + i] = rd.supply(Tout, p[b])
            for k in range(6):
                wb[(_R_K + k) * W + i] = 0.0
                wb[(_R_S + k) * W + i] = 0.0
            wb[_R_NTPS * W + i] = 0.0
            wb[_R_TRK * W + i] = acc[b, _A_TPT + 1]  # extreme
            wb[(_R_TRK + 1) * W + i] = acc[b, _A_TPT + 2]  # direction
        if not lockstep:  # (a compile-time constant: the lockstep code is pruned)
            return status
        if nmax > 0:
            ls(wb, nmax, hT)
            for i in range(W):
                ntot = wb[_R_NTOT * W + i]
                if ntot > 0.0:
                    b = b0 + i
                    n = int(wb[_R_NTPS * W + i])
                    if n > _NSLOT:
                        # more turning points than slots: the period again by the scalar
                        # kernel (same arithmetic), from the start state still in x[b]
                        Tout, Qint = _room_inputs(b, acc)
                        EE[b - lo], QQ[b - lo], acc[b, _A_QLAST] = _room_dyn(
                            x[b], dd[b - lo], dist[b, 0], Tout, Qint, p[b], T, hmax, kind,
                            acc[b, _A_QLAST], b, acc, tpbuf, ctr, hT,
                        )  # fmt: skip
                        continue
                    ntp = ctr[b, 2]
                    for k in range(n):
                        tpbuf[b, ntp + k] = wb[(_R_TPS + k) * W + i]
                    ctr[b, 2] = ntp + n
                    acc[b, _A_TPT + 1] = wb[_R_TRK * W + i]
                    acc[b, _A_TPT + 2] = wb[(_R_TRK + 1) * W + i]
                    acc[b, _A_TPT + 3] += n  # each point of the lane a confirmed turn
                    for k in range(7):
                        x[b, k] = wb[(_R_TP + k) * W + i]
                    non = wb[_R_NON * W + i]
                    E = 0.0  # sums as in _room_dyn: E = 0 + E_on, Q = 0 + Q_on + Q_off
                    Qsum = 0.0
                    if non > 0.0:
                        E += wb[_R_E * W + i]
                        Qsum += wb[_R_QON * W + i]
                    if ntot > non:
                        Qsum += wb[_R_QOFF * W + i]
                    EE[b - lo] = E
                    QQ[b - lo] = Qsum
                    acc[b, _A_QLAST] = wb[_R_Q0 * W + i]
        return status

    @nb.njit(cache=True)
    def rows(
        lo, hi, mode, act, active, x, p, lanes, dist, tab, acc, tpbuf, ctr, noise, meas, cfg, obs,
        out, sig,
    ):  # fmt: skip  # pragma: no cover - numba
        # plants lo..hi-1: step (mode 0: lockstep dynamics, then KPIs and measurement per plant)
        # or observe (mode 1); returns 1 if an action was invalid (that plant does not move)
        n = hi - lo
        dd = np.zeros(n)
        EE = np.zeros(n)
        QQ = np.zeros(n)
        xv0 = np.zeros(n)
        ok = np.zeros(n, dtype=np.bool_)
        status = 0
        if mode == 0:
            b = lo  # lo is a multiple of _BW
            while b < hi:
                W = min(_BW, hi - b)
                s = block(
                    b, W, lanes[b // _BW], act, active, x, p, dist, tab, acc, tpbuf, cfg, ctr,
                    dd, EE, QQ, xv0, ok, lo,
                )  # fmt: skip
                status = max(status, s)
                b += W
        for j in range(n):
            b = lo + j
            if (mode == 0 and ok[j]) or (mode == 1 and active[b]):
                _room_post(
                    b, mode, dd[j], EE[j], QQ[j], xv0[j], x, p, dist, tab, acc, tpbuf, ctr, noise,
                    meas, cfg, obs, out, sig,
                )  # fmt: skip
        return status

    step, step_parallel = block_steppers(rows, _BW, _ROOM)

    @nb.njit
    def rollout(
        ctrl,
        cstate,
        n,
        act,
        active,
        x,
        p,
        lanes,
        dist,
        tab,
        acc,
        tpbuf,
        ctr,
        noise,
        meas,
        cfg,
        obs,
        out,
        sig,
    ):  # pragma: no cover - numba
        # compiled controller loop over the same step kernel (one plant)
        total = 0.0
        for i in range(n):
            act[0, 0] = ctrl(obs[0], cstate)
            status = step(
                0, act, active, x, p, lanes, dist, tab, acc, tpbuf, ctr, noise, meas, cfg, obs, out,
                sig,
            )  # fmt: skip
            if status != 0:
                return status, i, total
            total += out[0, 0]
            if out[0, 1] > 0.5 or out[0, 2] > 0.5:
                return 0, i + 1, total
        return 0, n, total

    for k in (*([ls] if lockstep else []), *stage_loops, block, rows):
        cache_depends_on(k)
    return _StepKernels(step, step_parallel, rollout)


for _k in (_room_dyn, _room_post, _part):
    cache_depends_on(_k)
