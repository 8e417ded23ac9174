"""AXT211Valve: position a valve with the AXT211 electrothermal actuator.

Description
-----------
A SAUTER AXT211 wax-cartridge actuator (``002_dae2310635fe074e.txt``; model
:class:`thermogym.models.axt211.AXT211`, eqs 14-21) pushes a valve stem. The
controller switches the actuator's PTC heater and must make the valve stroke
``x_V`` follow a set-point profile ``x_ref`` while using little energy and
wearing the actuator little (switching, stroke travel, wax thermal cycles).
The actuator is slow (about 5 min to open, 6 min to close at 25 °C) and
asymmetric (heating is forced, cooling is passive, eq 16), has a backlash
(20) and a stroke gain that depends on the stroke (21) — and specimens differ
(section VIII): the reasons PWM control of it is hard.

Action Space
------------
``action_mode="duty"`` (default): ``Box(-1, 1, (1,), float32)``, mapped to a
PWM duty cycle ``d = (a + 1) / 2`` in [0, 1] (clipped). The PWM period is the
control period: the heater is on for ``d · control_period`` at the start of
the period and off for the rest. ``action_mode="onoff"``: ``Discrete(2)``,
heater off (0) or on (1) for the whole control period.

Observation Space
-----------------
``Box(float32)`` with the sensor ranges as bounds, entries
(:attr:`AXT211ValveEnv.obs_names`)::

    0  x_V     measured valve stroke [mm]           (noisy stroke sensor, -0.5..7)
    1  T_G     measured housing temperature [°C]    (-30..150)
    2  T_U     measured ambient temperature [°C]    (-30..80)
    3  k_U     measured supply voltage [V]          (0..40)
    4  x_ref   stroke set-point for the next period [mm] (0..7)
    5  u_prev  duty applied in the last period [1]  (only with previous_action=True)

The wax temperature and the cartridge stroke are not observed (no sensor in a
real actuator).

Rewards
-------
Per control period ``k`` (weights ``reward_weights``, defaults in
:data:`DEFAULT_WEIGHTS`)::

    r_k = −( w_tracking  |x_V − x_ref| / x_max
           + w_energy    P̄_k / 10 W
           + w_switching s_k
           + w_travel    |Δx_V| / x_max )

with ``x_V`` the true stroke at the end of the period, ``P̄_k`` the mean PTC
power over the period, ``s_k`` 1 when the heater switched on in the period
and ``x_max`` the stroke (4.5 mm nominal).

Starting State
--------------
The actuator at rest (wax and housing at the ambient temperature, cartridge
retracted, valve shut), as after a long time without power.

Episode End
-----------
Termination: a safety trip when the wax temperature exceeds ``trip_C``
(default 110 °C; the self-regulating PTC normally stays below 95 °C).
Truncation: after ``episode_s`` (default 1 h).

Arguments
---------
See :class:`ValveConfig` (every field is a keyword argument of
``gymnasium.make("thermogym/AXT211Valve-v0", ...)``), plus ``render_mode``
(``"rgb_array"``, ``"human"``), ``render_path`` and ``record``.

KPIs (``info["kpis"]`` at the episode end; :mod:`thermogym.envs.kpis`)
----------------------------------------------------------------------
``actuator_energy_Wh``, ``switch_cycles``, ``stroke_travel_mm``,
``stroke_reversals`` (hysteresis ``reversal_hysteresis_mm``),
``wax_thermal_cycles`` and ``wax_damage`` (rainflow on T_P with
``cycle_hysteresis_K``), ``time_above_limit_h`` (T_P above
``wax_limit_C``), ``stroke_rmse_mm``, ``stroke_iae_mm_s``, ``episode_h``.
The wax temperature's turning points are taken after every RK4 sub-step
(with ``plant="rig"``: every sub-step of the rig), so that the heating and
cooling within one PWM period count as a thermal cycle; the other signals are
sampled at the end of every control period (the stroke reversals too). The
energy is integrated by the trapezoidal rule on intervals of at most 10 s.

Version History
---------------
* v0: initial release. Revised in place (observations, rewards and every other KPI
  bit-identical): the wax-cycle and Miner-damage KPIs count the turning points of every
  integration sub-step, not only of period ends.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, NamedTuple

import numba as nb
import numpy as np
from gymnasium import spaces
from numpy.typing import ArrayLike, NDArray

from thermogym.envs._base import (
    C_K,
    C_NTP,
    Engine,
    ThermoEnv,
    ThermoVectorEnv,
    check_number,
    check_range,
    draw,
    parse_noise,
    parse_weights,
    steps_of,
)
from thermogym.envs._kernels import (
    block_steppers,
    cache_depends_on,
    lane_blocks,
    lane_tracker,
    meas_array,
    measure,
    put_lane,
    tp_buffer_full,
    tp_push,
    tp_push_all,
    tp_room,
)
from thermogym.envs._plant import ParamsLike, resolve_plant, rig_only
from thermogym.envs.kpis import _rainflow_tp, tp_finish, tp_update_at, wax_cycle_kpis
from thermogym.errors import ConfigError
from thermogym.models import axt211_dynamics as ax
from thermogym.models.axt211 import AXT211

__all__ = ["DEFAULT_WEIGHTS", "AXT211ValveEnv", "AXT211ValveVectorEnv", "ValveConfig"]

ENV = "AXT211Valve"
#: Default reward weights (see the module docstring).
DEFAULT_WEIGHTS = {"tracking": 1.0, "energy": 0.05, "switching": 0.01, "travel": 0.0}
_P_REF = 10.0  # W, normalises the energy term
#: Sensor (σ, quantisation) of the observed channels with plant="model".
SENSORS = {"x_V": (0.02, 0.001), "T_G": (0.1, 0.01), "T_U": (0.1, 0.01), "k_U": (0.05, 0.01)}
_CH = ("x_V", "T_G", "T_U", "k_U")
_STEPWISE_RIG_EFFECTS = (
    "backlash",
    "phase_change",
    "supply_variation",
    "nonlinear_heat_transfer",
    "sensor_offset",
    "sensor_drift",
    "sensor_lag",
)


@dataclass
class ValveConfig:
    """Keyword arguments of ``thermogym/AXT211Valve-v0``."""

    params: ParamsLike = None
    """FitResult (object, JSON path or dict) of model ``axt211``; default nominal values."""
    plant: str = "model"
    """``"model"``: the identified model; ``"rig"``: the AXT211 rig's true plant
    (:mod:`thermogym.rigs.axt211`), observed through its sensors."""
    rig_effects: Sequence[str] = ()
    """Rig effects (``plant="rig"``), e.g. ``["phase_change", "backlash:c_backlash=0.3"]``."""
    specimen_seed: int | None = 0
    """Rig only: seed of the specimen drawn from the manufacturing spread (None: nominal)."""
    action_mode: str = "duty"
    """``"duty"`` (continuous PWM duty) or ``"onoff"``."""
    control_period: float = 10.0
    """Control (and PWM) period [s]."""
    episode_s: float = 3600.0
    """Episode length [s], a whole number of control periods."""
    setpoint: str | float | ArrayLike = "random"
    """``"random"`` (levels drawn per episode), a constant [mm] or one value per step [mm]."""
    setpoint_range: tuple[float, float] = (0.5, 4.0)
    """Range of the random set-point levels [mm]."""
    setpoint_hold_s: float = 900.0
    """Time each random level is held [s]."""
    supply_V: float | tuple[float, float] = 24.0
    """Supply voltage [V], or a range drawn per episode (paper: 19-29 V)."""
    ambient_C: float | tuple[float, float] = 25.0
    """Ambient temperature [°C], or a range drawn per episode (paper: 0-50 °C)."""
    sensor_noise: bool | Mapping[str, float] = True
    """Sensor noise on; False: exact measurements; a dict overrides σ per channel."""
    previous_action: bool = True
    """Append the last applied duty to the observation."""
    reward_weights: Mapping[str, float] | None = None
    """Overrides of :data:`DEFAULT_WEIGHTS`."""
    wax_limit_C: float = 85.0
    """Wax temperature above which time counts in ``time_above_limit_h`` [°C]."""
    trip_C: float = 110.0
    """Wax temperature of the safety trip (termination) [°C]."""
    cycle_hysteresis_K: float = 2.0
    """Smallest wax-temperature cycle counted [K]."""
    reversal_hysteresis_mm: float = 0.05
    """Smallest stroke movement that counts as a reversal [mm]."""
    randomize: str | None = None
    """Domain randomisation per episode: ``"covariance"``, ``"bounds"``, ``"relative"``."""
    randomize_kwargs: Mapping[str, Any] | None = None
    """``scale``, ``names``, ``bounds`` of the randomisation."""


# cfg vector layout (_ROOM: free turning-point places a step needs, see tp_room)
(_T, _HMAX, _HOR, _AMODE, _HOLD, _WT, _WE, _WS, _WV, _PREF, _WLIM, _TRIP, _HT, _HX, _PREV,
 _ROOM) = range(16)  # fmt: skip
# acc layout
_A_E, _A_SW, _A_TRAV, _A_ABOVE, _A_IAE, _A_SSE, _A_N, _A_ON, _A_UPREV = range(9)
_A_TPT = 9  # wax-temperature tracker (4)
_A_TPX = 13  # stroke tracker (4)
_NACC = 17
_OBS = ("x_V", "T_G", "T_U", "k_U", "x_ref", "u_prev")
_SIG = ("x_V", "x_ref", "T_P", "T_G", "T_U", "k_U", "P_PTC", "duty", "reward")


@nb.njit(cache=True, inline="always")
def _segments(d, T, hmax):  # pragma: no cover - numba
    # PWM within the period: on for d·T, then off; each part in RK4 steps of at most hmax
    ton = d * T
    toff = T - ton
    n_on = math.ceil(ton / hmax - 1e-9) if ton > 0.0 else 0
    n_off = math.ceil(toff / hmax - 1e-9) if toff > 1e-9 * T else 0
    h_on = ton / n_on if n_on > 0 else 0.0
    h_off = toff / n_off if n_off > 0 else 0.0
    return n_on, h_on, n_off, h_off


@nb.njit(cache=True, inline="always")
def _action(b, act, cfg, ctr):  # pragma: no cover - numba
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


#: Longest interval of the trapezoidal energy integration [s] (RK4 steps are 1 s at most).
QUAD_S = 10.0


@nb.njit(cache=True)
def _dyn_scalar(xb, d, kU, TU, pb, T, hmax, b, acc, tpbuf, ctr, hT):  # pragma: no cover
    # One plant over one control period by the model's RK4 step (physical effects included):
    # on for d·T, then off. P_PTC is integrated by the trapezoidal rule on intervals of at
    # most QUAD_S (a few RK4 steps; within 0.5 % of a 0.1 s quadrature, see the tests).
    # The wax temperature after every RK4 step goes to plant b's turning-point tracker
    # (hysteresis hT; acc, tpbuf, ctr as _valve_post). Returns the energy [J].
    n_on, h_on, n_off, h_off = _segments(d, T, hmax)
    q, e, Rs = ax.coefficients(pb), ax.effect_coefficients(pb), pb[ax.I_RS]
    x = (xb[0], xb[1], xb[2], xb[3])
    v2 = kU * kU  # (k_U u)², u = 1
    E = 0.0
    ntp = ctr[b, 2]
    if n_on > 0:
        m = max(1, int(QUAD_S / h_on + 1e-9))
        P0 = ax.power(v2, ax.resistance(x[0], q), Rs)
        done = 0
        while done < n_on:
            s = min(m, n_on - done)
            for _ in range(s):
                x = ax.advance(x, v2, TU, h_on, 1, q, e)  # (17)-(21), one RK4 step
                ntp = tp_push(acc, b, _A_TPT, x[0], hT, tpbuf, ntp)
            P1 = ax.power(v2, ax.resistance(x[0], q), Rs)  # (15)
            E += 0.5 * (P0 + P1) * s * h_on
            P0 = P1
            done += s
    for _ in range(n_off):
        x = ax.advance(x, 0.0, TU, h_off, 1, q, e)
        ntp = tp_push(acc, b, _A_TPT, x[0], hT, tpbuf, ntp)
    ctr[b, 2] = ntp
    xb[0], xb[1], xb[2], xb[3] = x
    return E


@nb.njit(cache=True, inline="always")
def _valve_post(
    b,
    mode,
    d,
    E,
    xV0,
    TP,
    TG,
    xV,
    xmax,
    dist,
    sp,
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
    # KPIs, reward and measurement of plant b after its step (mode 0) or at the start (1).
    # The wax-temperature tracker has had the period's sub-steps already (the dynamics feed
    # it); here it gets the first sample of an episode
    T = cfg[_T]
    hold = int(cfg[_HOLD])
    nseg = sp.shape[1]
    kU = dist[b, 0]
    TU = dist[b, 1]
    k = ctr[b, 0]
    ntp = ctr[b, 2]
    Pm = 0.0
    r = 0.0
    if mode == 1:
        # episode start: first samples of the trackers
        ntp = tp_push(acc, b, _A_TPT, TP, cfg[_HT], tpbuf, ntp)
        tp_update_at(acc, b, _A_TPX, xV, cfg[_HX])
    else:
        sw = 1.0 if (d > 0.0 and acc[b, _A_ON] == 0.0) else 0.0
        acc[b, _A_ON] = 1.0 if d >= 1.0 else 0.0
        e = xV - sp[b, min(k // hold, nseg - 1)]
        dx = abs(xV - xV0)
        Pm = E / T
        acc[b, _A_E] += E
        acc[b, _A_SW] += sw
        acc[b, _A_TRAV] += dx
        acc[b, _A_IAE] += abs(e) * T
        acc[b, _A_SSE] += e * e
        acc[b, _A_N] += 1.0
        if TP > cfg[_WLIM]:
            acc[b, _A_ABOVE] += T
        tp_update_at(acc, b, _A_TPX, xV, cfg[_HX])  # the stroke: once per period
        r = -(
            cfg[_WT] * abs(e) / xmax
            + cfg[_WE] * Pm / cfg[_PREF]
            + cfg[_WS] * sw
            + cfg[_WV] * dx / xmax
        )
        k += 1
        ctr[b, 0] = k
        out[b, 0] = r
        out[b, 1] = 1.0 if TP > cfg[_TRIP] else 0.0
        out[b, 2] = 1.0 if k >= cfg[_HOR] else 0.0
        acc[b, _A_UPREV] = d
    ctr[b, 2] = ntp
    # measurement of the state after the step (or at the start)
    cur = ctr[b, 1]
    ctr[b, 1] = cur + 1
    t_h = k * T / 3600.0
    obs[b, 0] = measure(xV, meas, 0, noise[b, cur, 0], t_h)
    obs[b, 1] = measure(TG, meas, 1, noise[b, cur, 1], t_h)
    obs[b, 2] = measure(TU, meas, 2, noise[b, cur, 2], t_h)
    obs[b, 3] = measure(kU, meas, 3, noise[b, cur, 3], t_h)
    obs[b, 4] = sp[b, min(k // hold, nseg - 1)]
    if cfg[_PREV] > 0.0:
        obs[b, 5] = acc[b, _A_UPREV]
    sig[b, 0] = xV
    sig[b, 1] = sp[b, min(max(k - 1, 0) // hold, nseg - 1)]
    sig[b, 2] = TP
    sig[b, 3] = TG
    sig[b, 4] = TU
    sig[b, 5] = kU
    sig[b, 6] = Pm
    sig[b, 7] = d
    sig[b, 8] = r


# ------------------------------------------------------------------ lockstep kernel
# The plants of a batch advance in lockstep (batch innermost): for RK4 sub-step s, every
# plant of a block of W lanes does its own sub-step s — its own step size h (on or off part
# of its PWM period, each cut into steps of at most max_step) and heater input; a plant
# with fewer sub-steps idles (its state is kept by a select). The loop over a block's lanes
# is branch-free and vectorises (8 doubles per AVX-512 instruction); independent plants
# also hide each other's latencies. The arithmetic is that of _dyn_scalar (the model's
# _advance and the same trapezoidal points), so results are bit for bit those of stepping
# each plant alone. Parameter sets with an active physical effect (rig effects
# phase_change, supply_variation, nonlinear_heat_transfer) take the scalar _dyn_scalar.
#
# A block lives in one flat array ``wb``: row r of lane i at wb[r * W + i], W a
# compile-time constant, so that LLVM sees the rows as disjoint and vectorises without
# run-time alias checks (it refuses for separate arrays: too many checks).
#
# The wax temperature after every sub-step goes to the plant's turning-point tracker, a
# copy of it in the block's rows (_kernels.lane_tracker, shared with the room's lockstep: the
# branch-free tp_select, bit for bit tp_update); the turning points it confirms go to _NSLOT
# rows per lane, to the plant's buffer after the period. A period that confirms more
# (hysteresis 0, or a trajectory that turns often) is stepped again from its start by the
# scalar kernel (the lockstep wrote nothing back).

_BW = 64  # lanes of a full block: its 40 rows x 64 lanes x 8 B = 20 KiB stay in L1 cache
_NQ = ax.N_COEF  # lane-table rows in a block (all but the plain flag)
_NSLOT = 2  # turning points a lane keeps per period (a valley and a peak, with hysteresis)
(_R_TP, _R_TG, _R_XP, _R_XV, _R_NON, _R_NTOT, _R_HON, _R_HOFF, _R_MQ, _R_CNT, _R_E, _R_P0,
 _R_KU2, _R_TU, _R_NTPS) = range(_NQ, _NQ + 15)  # fmt: skip
_R_TRK = _NQ + 15  # 2 rows: the wax-temperature tracker's extreme and direction
_R_TPS = _R_TRK + 2  # _NSLOT rows: turning points confirmed in the period
_R_PLAIN = _R_TPS + _NSLOT  # 1 where the plant has no physical effect (the lockstep applies)
_NROWB = _R_PLAIN + 1  # rows of a block array: the engine keeps one per block of plants, so
# the parameter rows (written when a parameter set is installed) are not copied per step


@nb.njit(cache=True, inline="always")
def _quad_point(wb, W, i, sf, non, hon, ku2, R):  # pragma: no cover - numba
    # trapezoidal ∫P_PTC dt as in _dyn_scalar: a point at state j = sf (j RK4 steps done)
    # of the heater-on part, every QUAD_S seconds and at its end; R = R_PTC at that state
    P = ax.power(ku2, R, 0.0)  # (15) at u = 1
    inq = (sf >= 1.0) & (sf <= non)
    cnt = wb[_R_CNT * W + i] + (1.0 if inq else 0.0)
    due = inq & ((cnt == wb[_R_MQ * W + i]) | (sf == non))
    P0 = wb[_R_P0 * W + i]
    E = wb[_R_E * W + i]
    wb[_R_E * W + i] = E + 0.5 * (P0 + P) * cnt * hon if due else E
    wb[_R_P0 * W + i] = P if (due | (sf == 0.0)) else P0
    wb[_R_CNT * W + i] = 0.0 if due else cnt


@nb.njit(cache=True, inline="always")
def _lockstep(wb, W, nmax, hT):  # pragma: no cover - numba
    # nmax RK4 sub-steps of the W lanes of block wb, then the last trapezoidal points
    for s in range(nmax):
        sf = float(s)
        for i in range(W):
            q = ax.load_coefficients(wb, 0, W, i)
            TP = wb[_R_TP * W + i]
            TG = wb[_R_TG * W + i]
            xP = wb[_R_XP * W + i]
            xV = wb[_R_XV * W + i]
            non = wb[_R_NON * W + i]
            on = sf < non
            run = sf < wb[_R_NTOT * W + i]
            hon = wb[_R_HON * W + i]
            h = hon if on else wb[_R_HOFF * W + i]
            ku2 = wb[_R_KU2 * W + i]
            v2 = ku2 if on else 0.0  # (k_U u)², u = 1 on, 0 off
            (TPn, TGn, xPn, xVn), R = ax.step((TP, TG, xP, xV), v2, wb[_R_TU * W + i], h, q)
            _quad_point(wb, W, i, sf, non, hon, ku2, R)  # R is that of the state before
            wb[_R_TP * W + i] = TPn if run else TP
            wb[_R_TG * W + i] = TGn if run else TG
            wb[_R_XP * W + i] = xPn if run else xP
            wb[_R_XV * W + i] = xVn if run else xV
            lane_tracker(wb, W, i, TPn, run, hT, _R_TRK, _R_NTPS, _R_TPS, _NSLOT)
    sf = float(nmax)
    for i in range(W):
        R = ax.resistance(wb[_R_TP * W + i], ax.load_coefficients(wb, 0, W, i))
        _quad_point(wb, W, i, sf, wb[_R_NON * W + i], wb[_R_HON * W + i], wb[_R_KU2 * W + i], R)


@nb.njit(cache=True, error_model="numpy")
def _lockstep_bw(wb, nmax, hT):  # pragma: no cover - numba
    _lockstep(wb, _BW, nmax, hT)


class _StepKernels(NamedTuple):
    step: Any
    step_parallel: Any


@functools.cache
def _step_kernels(lockstep: bool) -> _StepKernels:
    """Compiled step kernels, with or without lockstep.

    Without lockstep every plant advances by the scalar kernel (_dyn_scalar): a single
    environment or a few plants, and the heavily inlined lockstep loop (a minute and more
    to compile on a cold cache) is not compiled. With lockstep, full blocks of _BW plants
    advance together (bit-identical to the scalar kernel for plants without a physical
    effect) and a partial block by the scalar kernel. ``lockstep`` is a compile-time
    constant of the closures (its branches are pruned).
    """
    ls = _lockstep_bw if lockstep else None

    @nb.njit(cache=True)
    def block(
        b0, W, wb, act, active, x, p, dist, acc, tpbuf, cfg, ctr, dd, EE, xv0, ok, lo
    ):  # pragma: no cover - numba
        # advance plants b0..b0+W-1 by one control period; returns 1 if an action was invalid.
        # wb: the block's array (parameter rows filled, row stride _BW; W < _BW only for the
        # last, partial block, whose plants take the scalar kernel)
        T = cfg[_T]
        hmax = cfg[_HMAX]
        hT = cfg[_HT]
        status = 0
        nmax = 0
        for i in range(W):
            b = b0 + i
            j = b - lo
            non, ntot, hon, hoff, mq = 0, 0, 0.0, 0.0, 1.0
            if active[b]:
                d = _action(b, act, cfg, ctr)
                if d < 0.0:
                    status = 1
                else:
                    ok[j] = True
                    dd[j] = d
                    xv0[j] = x[b, 3]
                    # the scalar kernel: physical effects, the lanes of a partial block, every
                    # plant of the variant without lockstep (and a wax-temperature tracker
                    # without its first sample, which the lanes' tracker assumes)
                    if (
                        not lockstep or W != _BW or wb[_R_PLAIN * _BW + i] == 0.0
                        or acc[b, _A_TPT] == 0.0
                    ):  # fmt: skip
                        EE[j] = _dyn_scalar(
                            x[b], d, dist[b, 0], dist[b, 1], p[b], T, hmax, b, acc, tpbuf, ctr,
                            hT,
                        )  # fmt: skip
                    else:
                        non, hon, n_off, hoff = _segments(d, T, hmax)
                        ntot = non + n_off
                        if non > 0:
                            mq = float(max(1, int(QUAD_S / hon + 1e-9)))
            nmax = max(nmax, ntot)
            if not lockstep or W != _BW:
                continue
            wb[_R_TP * W + i] = x[b, 0]
            wb[_R_TG * W + i] = x[b, 1]
            wb[_R_XP * W + i] = x[b, 2]
            wb[_R_XV * W + i] = x[b, 3]
            wb[_R_NON * W + i] = non
            wb[_R_NTOT * W + i] = ntot
            wb[_R_HON * W + i] = hon
            wb[_R_HOFF * W + i] = hoff
            wb[_R_MQ * W + i] = mq
            wb[_R_CNT * W + i] = 0.0
            wb[_R_E * W + i] = 0.0
            wb[_R_P0 * W + i] = 0.0
            wb[_R_KU2 * W + i] = dist[b, 0] * dist[b, 0]
            wb[_R_TU * W + i] = dist[b, 1]
            wb[_R_NTPS * W + i] = 0.0
            wb[_R_TRK * W + i] = acc[b, _A_TPT + 1]  # extreme
            wb[(_R_TRK + 1) * W + i] = acc[b, _A_TPT + 2]  # direction
        if not lockstep:  # (a compile-time constant: the lockstep code is pruned)
            return status
        if nmax > 0:
            ls(wb, nmax, hT)
            for i in range(W):
                if wb[_R_NTOT * W + i] > 0.0:
                    b = b0 + i
                    n = int(wb[_R_NTPS * W + i])
                    if n > _NSLOT:
                        # more turning points than slots: the period again by the scalar
                        # kernel (same arithmetic), from the start state still in x[b]
                        EE[b - lo] = _dyn_scalar(
                            x[b], dd[b - lo], dist[b, 0], dist[b, 1], p[b], T, hmax, b, acc,
                            tpbuf, ctr, hT,
                        )  # fmt: skip
                        continue
                    x[b, 0] = wb[_R_TP * W + i]
                    x[b, 1] = wb[_R_TG * W + i]
                    x[b, 2] = wb[_R_XP * W + i]
                    x[b, 3] = wb[_R_XV * W + i]
                    EE[b - lo] = wb[_R_E * W + i]
                    ntp = ctr[b, 2]
                    for k in range(n):
                        tpbuf[b, ntp + k] = wb[(_R_TPS + k) * W + i]
                    ctr[b, 2] = ntp + n
                    acc[b, _A_TPT + 1] = wb[_R_TRK * W + i]
                    acc[b, _A_TPT + 2] = wb[(_R_TRK + 1) * W + i]
                    acc[b, _A_TPT + 3] += n  # each point of the lane a confirmed turn
        return status

    @nb.njit(cache=True)
    def rows(
        lo, hi, mode, act, active, x, p, lanes, dist, sp, acc, tpbuf, ctr, noise, meas, cfg, obs,
        out, sig,
    ):  # fmt: skip  # pragma: no cover - numba
        # plants lo..hi-1: step (mode 0: lockstep dynamics, then KPIs and measurement per plant)
        # or observe (mode 1); returns 1 if an action was invalid (that plant does not move)
        n = hi - lo
        dd = np.zeros(n)
        EE = np.zeros(n)
        xv0 = np.zeros(n)
        ok = np.zeros(n, dtype=np.bool_)
        status = 0
        if mode == 0:
            b = lo  # lo is a multiple of _BW
            while b < hi:
                W = min(_BW, hi - b)
                s = block(
                    b, W, lanes[b // _BW], act, active, x, p, dist, acc, tpbuf, cfg, ctr, dd, EE,
                    xv0, ok, lo,
                )  # fmt: skip
                status = max(status, s)
                b += W
        for j in range(n):
            b = lo + j
            if mode == 0 and not ok[j]:
                continue
            if mode == 1 and not active[b]:
                continue
            _valve_post(
                b, mode, dd[j], EE[j], x[b, 3] if mode == 1 else xv0[j], x[b, 0], x[b, 1],
                x[b, 3], p[b, ax.I_XMAX], dist, sp, acc, tpbuf, ctr, noise, meas, cfg, obs, out,
                sig,
            )  # fmt: skip
        return status

    step, step_parallel = block_steppers(rows, _BW, _ROOM)

    for k in (block, rows):
        cache_depends_on(k)
    return _StepKernels(step, step_parallel)


for _k in (_dyn_scalar, _valve_post, _quad_point, _lockstep_bw):
    cache_depends_on(_k)


class _ValveEngine(Engine):
    name = ENV
    sig_names = _SIG
    sig_units = ("mm", "mm", "°C", "°C", "°C", "V", "W", "1", "1")
    noise_channels = _CH
    panels = (
        ("stroke [mm]", ("x_V", "x_ref")),
        ("temperature [°C]", ("T_P", "T_G", "T_U")),
        ("heater", ("duty", "P_PTC")),
        ("reward", ("reward",)),
    )

    def __init__(self, B: int, cfg: ValveConfig) -> None:
        self.cfg = cfg
        env = ENV
        if cfg.action_mode not in ("duty", "onoff"):
            raise ConfigError(f"{env}: action_mode is {cfg.action_mode!r}; 'duty' or 'onoff'")
        self.obs_names = _OBS if cfg.previous_action else _OBS[:5]
        self.obs_units = ("mm", "°C", "°C", "V", "mm", "1")[: len(self.obs_names)]
        T = check_number(env, "control_period", cfg.control_period, lo=0.0, lo_open=True)
        self._dt = T
        self._horizon = steps_of(env, "episode_s", check_number(env, "episode_s", cfg.episode_s), T)
        self.supply = check_range(env, "supply_V", cfg.supply_V, lo=0.0, hi=40.0)
        self.ambient = check_range(env, "ambient_C", cfg.ambient_C, lo=-30.0, hi=80.0)
        w = parse_weights(env, cfg.reward_weights, DEFAULT_WEIGHTS)
        specimen = None
        if cfg.plant == "rig" and cfg.specimen_seed is not None:
            # the rigs (~0.4 s) load only for plant='rig'
            from thermogym.rigs.axt211 import specimen_spread

            specimen = specimen_spread(np.random.default_rng(cfg.specimen_seed), n=1)
        plant = resolve_plant(
            env,
            params=cfg.params,
            plant=cfg.plant,
            models=("axt211",),
            default=AXT211,
            rig="axt211",
            rig_effects=cfg.rig_effects,
            stepwise_effects=_STEPWISE_RIG_EFFECTS,
            specimen=specimen,
        )
        super().__init__(B, plant, _NACC, tp_capacity=256)
        self._setpoint(cfg)
        sens = parse_noise(env, cfg.sensor_noise, _CH, SENSORS, plant.sensors)
        lo, hi = self.obs_bounds()
        off, drift = plant.sensor_errors(_CH, len(lo))
        self.meas = meas_array(sens, lo, hi, off, drift)
        h_T = check_number(env, "cycle_hysteresis_K", cfg.cycle_hysteresis_K, lo=0.0)
        h_x = check_number(env, "reversal_hysteresis_mm", cfg.reversal_hysteresis_mm, lo=0.0)
        self.cfgv = np.array(
            [
                T,
                AXT211.max_step,
                float(self._horizon),
                1.0 if cfg.action_mode == "onoff" else 0.0,
                float(self.hold),
                w["tracking"],
                w["energy"],
                w["switching"],
                w["travel"],
                _P_REF,
                check_number(env, "wax_limit_C", cfg.wax_limit_C),
                check_number(env, "trip_C", cfg.trip_C),
                h_T,
                h_x,
                1.0 if cfg.previous_action else 0.0,
                float(tp_room(T, AXT211.max_step)),
            ]
        )
        self.x = np.zeros((B, 4))
        self.p = np.zeros((B, plant.model.full_theta(plant.theta).shape[1]))  # type: ignore[attr-defined]
        self.lanes = lane_blocks(B, _BW, _NROWB)  # the kernel's block arrays, rows from p
        self.dist = np.zeros((B, 2))
        self.sp = np.zeros((B, self.n_seg))

    def _setpoint(self, cfg: ValveConfig) -> None:
        env = ENV
        sp = cfg.setpoint
        self.sp_fixed: NDArray[np.float64] | None = None
        if isinstance(sp, str):
            if sp != "random":
                raise ConfigError(
                    f"{env}: setpoint is {sp!r}; expected 'random', a number or an array"
                )
            self.sp_range = check_range(env, "setpoint_range", cfg.setpoint_range, lo=0.0, hi=7.0)
            hold_s = check_number(env, "setpoint_hold_s", cfg.setpoint_hold_s, lo=0.0, lo_open=True)
            self.hold = steps_of(env, "setpoint_hold_s", hold_s, self._dt)
            self.n_seg = -(-self._horizon // self.hold)
        elif np.ndim(sp) == 0:
            v = check_number(env, "setpoint", sp, lo=0.0, hi=7.0)
            self.sp_fixed = np.array([v])
            self.hold, self.n_seg = self._horizon, 1
        else:
            a = np.asarray(sp, dtype=float)
            if a.ndim != 1 or a.size < self._horizon:
                raise ConfigError(
                    f"{env}: setpoint has shape {a.shape}; expected one value per control "
                    f"step, at least {self._horizon}"
                )
            if not (np.isfinite(a).all() and (a >= 0).all() and (a <= 7).all()):
                raise ConfigError(f"{env}: setpoint values must be finite, within [0, 7] mm")
            self.sp_fixed = a[: self._horizon].copy()
            self.hold, self.n_seg = 1, self._horizon

    def action_space(self) -> spaces.Space[Any]:
        if self.cfg.action_mode == "onoff":
            return spaces.Discrete(2)
        return spaces.Box(-1.0, 1.0, (1,), dtype=np.float32)

    def obs_bounds(self) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
        lo = np.array([-0.5, -30.0, -30.0, 0.0, 0.0, 0.0], dtype=np.float32)
        hi = np.array([7.0, 150.0, 80.0, 40.0, 7.0, 1.0], dtype=np.float32)
        n = len(self.obs_names)
        return lo[:n], hi[:n]

    def _set_theta_row(self, b: int, theta: NDArray[np.float64]) -> None:
        self.p[b] = self.model.full_theta(theta)[0]  # type: ignore[attr-defined]
        col = np.zeros((len(ax.LANE_ROWS), 1))
        ax.lane_column(self.p[b], col, 0)
        put_lane(self.lanes, b, _BW, col[:_NQ, 0], col[ax.LANE_PLAIN, 0], _R_PLAIN)

    def _reset_row(self, b: int, rng: np.random.Generator) -> None:
        TU = draw(rng, self.ambient)
        kU = draw(rng, self.supply)
        self.dist[b] = (kU, TU)
        if self.sp_fixed is None:
            self.sp[b] = rng.uniform(self.sp_range[0], self.sp_range[1], self.n_seg)
        else:
            self.sp[b] = self.sp_fixed
        u0 = np.array([[0.0, kU, TU]])
        self.x[b] = self.model.initial_state(self.theta[b : b + 1], u0)[0]

    def _kernel(self, mode: int) -> int:
        args = (
            mode, self.act, self.active, self.x, self.p, self.lanes, self.dist, self.sp,
            self.acc, self.tpbuf, self.ctr, self.noise, self.meas, self.cfgv, self.obs,
            self.out, self.sig,
        )  # fmt: skip
        if self.parallel and self.B > _BW:
            return int(_step_kernels(True).step_parallel(*args, nb.get_num_threads()))
        return int(_step_kernels(self.B >= _BW).step(*args))

    def kpis(self, b: int) -> dict[str, float]:
        a = self.acc[b]
        n = max(a[_A_N], 1.0)
        tps = self.tpbuf[b, : self.ctr[b, C_NTP]]
        last = tp_finish(a[_A_TPT : _A_TPT + 4].copy())
        if not math.isnan(last):
            tps = np.append(tps, last)

        cycles = _rainflow_tp(tps, self.cfgv[_HT])
        return {
            "actuator_energy_Wh": float(a[_A_E] / 3600.0),
            "switch_cycles": float(a[_A_SW]),
            "stroke_travel_mm": float(a[_A_TRAV]),
            "stroke_reversals": float(a[_A_TPX + 3]),
            **wax_cycle_kpis(cycles),
            "time_above_limit_h": float(a[_A_ABOVE] / 3600.0),
            "stroke_rmse_mm": float(math.sqrt(a[_A_SSE] / n)),
            "stroke_iae_mm_s": float(a[_A_IAE]),
            "episode_h": float(self.ctr[b, C_K] * self._dt / 3600.0),
        }

    def trip_reason(self, b: int) -> str:
        return f"wax temperature {self.x[b, 0]:.1f} °C above trip_C = {self.cfgv[_TRIP]} °C"


class _ValveRigEngine(_ValveEngine):
    """The valve on the AXT211 rig's true plant (``plant="rig"``, :mod:`thermogym.envs._rig`).

    Every control period the rig's plant advances all plants at once, heater on for
    ``d·T`` then off (the rig's own sub-steps); KPIs, reward and the noise-free signals
    come from the rig's physical state through :func:`_valve_post`, the observation
    from the rig's sensors. The wax-temperature tracker gets the turns of the cartridge
    temperature over the rig's sub-steps (:class:`thermogym.rigs.base.Turns`) and its
    value at the period's end: the turning points of every sub-step.
    """

    def __init__(self, B: int, cfg: ValveConfig) -> None:
        from thermogym.envs._rig import RigSensors  # the rigs load only for plant='rig'
        from thermogym.rigs.base import Turns

        super().__init__(B, cfg)
        pl = self.plant
        self.tp = pl.true_plant
        self.spec = pl.specimens.take(np.zeros(B, dtype=np.int64))
        self.xr = np.zeros((B, len(self.tp.state_names)))
        # state columns of the rig: cartridge (wax) and housing temperature, stem, energy
        self._iw, self._ig, self._iv, self._ie = (
            self.tp.state_names.index(n) for n in ("T_w", "T_g", "x_v", "E")
        )
        self.xmax = float(self.spec["x_max"][0])
        # the rig's sub-steps per period (on and off parts) bound the turns noted and the
        # turning points a period can confirm
        room = tp_room(self._dt, self.tp.max_step) + 1
        self.cfgv[_ROOM] = room
        self.turns = Turns(self._iw, B, capacity=room)
        lo, hi = self.obs_bounds()
        spans = [(float(lo[j]), float(hi[j])) for j in range(4)]
        self.rsens = RigSensors(ENV, pl.rig, _CH, spans, cfg.sensor_noise, _CH, B)
        self._rngs: Sequence[np.random.Generator] = ()

    def apply_fit(self, fit: ParamsLike, rows: Sequence[int] | None = None) -> dict[str, Any]:
        raise rig_only(ENV, "set_parameters / a FitResult")

    def randomize(self, method: str | None, **kwargs: Any) -> None:
        if method is not None:
            raise rig_only(ENV, "randomize")
        super().randomize(None)

    def reset_rows(self, rows: Sequence[int], rngs: Sequence[np.random.Generator]) -> None:
        self._rngs = rngs
        super().reset_rows(rows, rngs)

    def step(self, rngs: Sequence[np.random.Generator], active: NDArray[np.bool_] | None) -> None:
        self._rngs = rngs
        super().step(rngs, active)

    def _reset_row(self, b: int, rng: np.random.Generator) -> None:
        super()._reset_row(b, rng)
        kU, TU = self.dist[b]
        self.xr[b] = self.tp.initial_state(self.spec.take([b]), np.array([0.0, kU, TU]))[0]

    def _truth(self) -> NDArray[np.float64]:
        # the observed channels' true values: stem stroke, housing, ambient, supply
        return np.column_stack(
            [self.xr[:, self._iv], self.xr[:, self._ig], self.dist[:, 1], self.dist[:, 0]]
        )

    def _kernel(self, mode: int) -> int:
        iw, ig, iv, ie = self._iw, self._ig, self._iv, self._ie
        if tp_buffer_full(self.active, self.ctr, self.tpbuf, int(self.cfgv[_ROOM])):
            return 2  # ST_GROW: the engine grows the turning-point buffer and calls again
        rows = np.flatnonzero(self.active)
        xr = self.xr
        args = (self.dist, self.sp, self.acc, self.tpbuf, self.ctr, self.noise, self.meas,
                self.cfgv, self.obs, self.out, self.sig)  # fmt: skip
        if mode == 1:
            for b in rows:
                _valve_post(b, 1, 0.0, 0.0, xr[b, iv], xr[b, iw], xr[b, ig],
                            xr[b, iv], self.xmax, *args)  # fmt: skip
            self.obs[rows, :4] = self.rsens.start(rows, self._truth()[rows], self._rngs)
            return 0
        status = 0
        ok = np.zeros(self.B, dtype=np.bool_)
        d = np.zeros(self.B)
        for b in rows:
            v = _action(b, self.act, self.cfgv, self.ctr)
            if v < 0.0:
                status = 1
            else:
                ok[b], d[b] = True, v
        T = self.cfgv[_T]
        xv0 = xr[:, iv].copy()
        E0 = xr[:, ie].copy()
        ones = np.ones(self.B)
        u_on = np.column_stack([ones, self.dist[:, 0], self.dist[:, 1]])
        u_off = np.column_stack([0.0 * ones, self.dist[:, 0], self.dist[:, 1]])
        # heater on for d·T, then off for the rest of the period (PWM at the control period)
        turns = self.turns
        turns.start(xr)
        xr = self.tp.step(xr, u_on, np.where(ok, d * T, 0.0), self.spec, turns=turns)
        xr = self.tp.step(xr, u_off, np.where(ok, (1.0 - d) * T, 0.0), self.spec, turns=turns)
        self.xr = xr
        E = xr[:, ie] - E0
        hT = self.cfgv[_HT]
        for b in np.flatnonzero(ok):
            # the wax temperature's turns within the period, then its value at the end
            n = turns.count(int(b))
            ntp = tp_push_all(self.acc, b, _A_TPT, turns.values[b], n, hT, self.tpbuf,
                              self.ctr[b, C_NTP])  # fmt: skip
            self.ctr[b, C_NTP] = tp_push_all(self.acc, b, _A_TPT, xr[b, iw : iw + 1], 1, hT,
                                             self.tpbuf, ntp)  # fmt: skip
            _valve_post(b, 0, d[b], E[b], xv0[b], xr[b, iw], xr[b, ig], xr[b, iv],
                        self.xmax, *args)  # fmt: skip
        readings = self.rsens.read(ok, self._truth(), T, self._rngs)
        self.obs[ok, :4] = readings[ok]
        return status

    def trip_reason(self, b: int) -> str:
        T = self.xr[b, self._iw]
        return f"wax temperature {T:.1f} °C above trip_C = {self.cfgv[_TRIP]} °C"


def _valve_engine(B: int, cfg: ValveConfig) -> _ValveEngine:
    # the rig's true plant or the identified model's kernels
    return _ValveRigEngine(B, cfg) if cfg.plant == "rig" else _ValveEngine(B, cfg)


class AXT211ValveEnv(ThermoEnv):
    """Valve positioning with the AXT211 actuator (``thermogym/AXT211Valve-v0``).

    See the module docstring for spaces, reward, KPIs and episode end, and
    :class:`ValveConfig` for the keyword arguments.

    Examples
    --------
    >>> import gymnasium as gym
    >>> import thermogym.envs
    >>> env = gym.make("thermogym/AXT211Valve-v0", action_mode="onoff", setpoint=3.0)
    >>> obs, info = env.reset(seed=0)
    >>> env.unwrapped.obs_names
    ('x_V', 'T_G', 'T_U', 'k_U', 'x_ref', 'u_prev')
    >>> for _ in range(60):  # ten minutes of a thermostat-like on/off rule
    ...     obs, r, terminated, truncated, info = env.step(int(obs[0] < obs[4]))
    >>> bool(2.0 < env.unwrapped.true_outputs()["x_V"] < 4.0)
    True
    """

    env_name = ENV
    config_cls = ValveConfig
    engine_cls = staticmethod(_valve_engine)


class AXT211ValveVectorEnv(ThermoVectorEnv):
    """``num_envs`` AXT211 valves stepped by one compiled call (native vector env).

    Keyword arguments as :class:`ValveConfig`, plus ``num_envs`` and
    ``autoreset_mode`` (``"NextStep"`` default, ``"SameStep"``, ``"Disabled"``) and
    ``parallel`` (one plant per thread).
    """

    single_env_cls = AXT211ValveEnv
