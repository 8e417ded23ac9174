"""Compiled helpers shared by the environment step kernels.

Measurement model of every observed channel ``j`` (rows of the ``meas``
array: σ, quantisation step, lower and upper sensor range, offset, drift per
hour)::

    y = clip(q(v + offset + drift · t_h + σ z), lo, hi),   q(v) = res · round(v / res)

with ``z`` a pre-drawn standard normal. A real transmitter saturates at the
ends of its range, which is also what keeps observations inside the
observation space.
"""

from __future__ import annotations

import math
from types import ModuleType
from typing import Any

import numba as nb
import numpy as np
from numpy.typing import NDArray

from thermogym._jitcache import cache_depends_on
from thermogym.envs.kpis import tp_select, tp_update_at

__all__ = [
    "M_DRIFT",
    "M_HI",
    "M_LO",
    "M_OFF",
    "M_RES",
    "M_SIG",
    "block_steppers",
    "cache_depends_on",
    "lane_blocks",
    "lane_tracker",
    "meas_array",
    "measure",
    "plant_loops",
    "put_lane",
    "tp_buffer_full",
    "tp_push",
    "tp_push_all",
    "tp_room",
]

M_SIG, M_RES, M_LO, M_HI, M_OFF, M_DRIFT = range(6)


def plant_loops(row: Any, *modules: ModuleType) -> tuple[Any, Any]:
    """Serial and parallel kernels that step every active plant with a row kernel.

    ``row(b, *args)`` advances (or observes) plant ``b`` and returns its status
    (0, or 1 for an invalid action). The returned kernels take
    ``(active, *args)`` and return the largest status: ``serial`` loops over the
    plants, ``parallel`` gives one plant per thread (numba ``prange``; each row
    writes only its own plant, so the results equal the serial ones). Their cache
    depends on the sources the row's code reaches (:func:`cache_depends_on`), and on
    ``modules`` if given.
    """

    @nb.njit(cache=True)
    def serial(active, *args):  # type: ignore[no-untyped-def]  # pragma: no cover - numba
        status = 0
        for b in range(active.shape[0]):
            if active[b]:
                status = max(status, row(b, *args))
        return status

    @nb.njit(cache=True, parallel=True)
    def parallel(active, *args):  # type: ignore[no-untyped-def]  # pragma: no cover - numba
        st = np.zeros(active.shape[0], dtype=np.int64)
        for i in nb.prange(active.shape[0]):
            b = np.int64(i)  # the prange index is unsigned; keep index arithmetic signed
            if active[b]:
                st[b] = row(b, *args)
        return st.max() if st.shape[0] > 0 else 0

    for k in (serial, parallel):
        cache_depends_on(k, *modules)
    return serial, parallel


@nb.njit(cache=True)
def tp_buffer_full(active, ctr, tpbuf, room):  # type: ignore[no-untyped-def]  # pragma: no cover
    """Whether an active plant's turning-point buffer lacks ``room`` free places.

    ``room`` is the most turning points one call of a step kernel can confirm (see
    :func:`tp_room`); checked before any plant moves, the engine grows the buffer.
    """
    for b in range(active.shape[0]):
        if active[b] and ctr[b, 2] + room > tpbuf.shape[1]:
            return True
    return False


def tp_room(period: float, max_step: float) -> int:
    """Free places a turning-point buffer needs before a control period of ``period`` s.

    The wax-temperature tracker is fed every integration sub-step of the period (steps of
    at most ``max_step``; the heater's on and off parts each a whole number of them, so at
    most ``ceil(period / max_step) + 1`` sub-steps), and one sample confirms at most one
    turning point. A period with one heating and one cooling phase confirms two with a
    hysteresis (a valley while it heats, a peak while it cools; the most the tests see),
    but nothing bounds a trajectory's turns in general, and with hysteresis 0 every
    repeated value confirms one: the sub-step count is the bound that always holds. One
    place more for the first sample of an episode.

    Examples
    --------
    >>> tp_room(10.0, 1.0), tp_room(120.0, 0.5)
    (12, 242)
    """
    return math.ceil(period / max_step - 1e-9) + 2


@nb.njit(cache=True)
def tp_push_all(acc, r, c, vals, n, h, buf, ntp):  # type: ignore[no-untyped-def]  # pragma: no cover
    """Feed ``vals[:n]`` in order to the tracker in ``acc[r, c:c + 4]`` (:func:`tp_push`).

    Returns the new count of turning points in ``buf[r]``.
    """
    for i in range(n):
        ntp = tp_push(acc, r, c, vals[i], h, buf, ntp)
    return ntp


def block_steppers(rows: Any, bw: int, room_at: int, *modules: ModuleType) -> tuple[Any, Any]:
    """Step kernels of the AXT211 environments around their ``rows`` kernel.

    ``rows(lo, hi, mode, act, active, x, p, lanes, dist, aux, acc, tpbuf, ctr, noise, meas,
    cfg, obs, out, sig)`` steps (mode 0) or observes (mode 1) plants ``lo..hi-1`` in blocks
    of ``bw``. Returns ``step(mode, act, ...)`` over all plants, and ``step_parallel(...,
    nch)`` over ``nch`` chunks of whole blocks on threads (each chunk writes only its own
    rows, so results equal the serial ones). Both return 2 when a turning-point buffer must
    grow first (nothing moved: fewer free places than ``cfg[room_at]``, see
    :func:`tp_room`), else the largest status of ``rows``. Cache dependencies as
    :func:`plant_loops`.
    """

    @nb.njit(cache=True)
    def step(
        mode, act, active, x, p, lanes, dist, aux, acc, tpbuf, ctr, noise, meas, cfg, obs, out, sig
    ):  # type: ignore[no-untyped-def]  # pragma: no cover - numba
        if tp_buffer_full(active, ctr, tpbuf, int(cfg[room_at])):
            return 2
        return rows(
            0, x.shape[0], mode, act, active, x, p, lanes, dist, aux, acc, tpbuf, ctr, noise,
            meas, cfg, obs, out, sig,
        )  # fmt: skip

    @nb.njit(cache=True, parallel=True)
    def step_parallel(
        mode, act, active, x, p, lanes, dist, aux, acc, tpbuf, ctr, noise, meas, cfg, obs, out,
        sig, nch,
    ):  # type: ignore[no-untyped-def]  # fmt: skip  # pragma: no cover - numba
        if tp_buffer_full(active, ctr, tpbuf, int(cfg[room_at])):
            return 2
        B = x.shape[0]
        nblk = -(-B // bw)
        nch = min(nch, nblk)
        st = np.zeros(nch, dtype=np.int64)
        for c in nb.prange(nch):
            lo = (nblk * c // nch) * bw
            hi = min((nblk * (c + 1) // nch) * bw, B)
            st[c] = rows(
                lo, hi, mode, act, active, x, p, lanes, dist, aux, acc, tpbuf, ctr, noise, meas,
                cfg, obs, out, sig,
            )  # fmt: skip
        return st.max()

    for k in (step, step_parallel):
        cache_depends_on(k, *modules)
    return step, step_parallel


def lane_blocks(n_plants: int, bw: int, n_rows: int) -> NDArray[np.float64]:
    """Block arrays of a lockstep kernel: one flat array of ``n_rows`` x ``bw`` per block.

    Row ``r`` of plant ``b`` lies at ``[b // bw, r * bw + b % bw]``. The parameter rows are
    written once per parameter set (:func:`put_lane`), the other rows by the kernel.
    """
    return np.zeros((-(-n_plants // bw), n_rows * bw))


@nb.njit(cache=True, inline="always")
def lane_tracker(
    wb: NDArray[np.float64],
    W: int,
    i: int,
    v: float,
    run: bool,
    hT: float,
    r_trk: int,
    r_ntps: int,
    r_tps: int,
    nslot: int,
) -> None:  # pragma: no cover - numba
    """Feed sample ``v`` (if ``run``) to lane ``i``'s wax-temperature tracker in block ``wb``.

    The lockstep kernels of the AXT211 environments keep, in the rows of a block of ``W``
    lanes (row ``r`` of lane ``i`` at ``wb[r * W + i]``), a copy of each plant's tracker
    (started: the first sample of the episode is in): its extreme and direction in rows
    ``r_trk`` and ``r_trk + 1``, the count of turning points it confirmed in the period in
    row ``r_ntps``. A confirmed turning point (:func:`~thermogym.envs.kpis.tp_select`,
    hysteresis ``hT``) goes to the next of the ``nslot`` rows from ``r_tps``; the count goes
    on past them (overflow). The plant's count of confirmed points is its own plus the
    lane's count after the period. The row layout is the caller's (compile-time constants
    there, so the inlined code indexes as with literal rows); branch-free, so the loop over
    a block's lanes vectorises.
    """
    ex = wb[r_trk * W + i]
    dr = wb[(r_trk + 1) * W + i]
    n = wb[r_ntps * W + i]
    _, ex1, dr1, _, tp, hit = tp_select(1.0, ex, dr, 0.0, v, hT)
    hit = hit & run
    wb[r_trk * W + i] = ex1 if run else ex
    wb[(r_trk + 1) * W + i] = dr1 if run else dr
    for k in range(nslot):
        old = wb[(r_tps + k) * W + i]
        wb[(r_tps + k) * W + i] = tp if (hit & (n == k)) else old
    wb[r_ntps * W + i] = n + 1.0 if hit else n


def put_lane(
    blocks: NDArray[np.float64],
    b: int,
    bw: int,
    values: NDArray[np.float64],
    plain: float,
    plain_row: int,
) -> None:
    """Write plant ``b``'s parameter rows (``values`` to rows 0, 1, ...) into its block.

    ``plain`` (1: no actuator effect, the lockstep applies to the plant) goes to row
    ``plain_row``.
    """
    wb = blocks[b // bw]
    i = b % bw
    wb[i : len(values) * bw : bw] = values
    wb[plain_row * bw + i] = plain


def meas_array(
    sens: NDArray[np.float64],
    lo: NDArray[np.floating],
    hi: NDArray[np.floating],
    offset: NDArray[np.float64] | None = None,
    drift: NDArray[np.float64] | None = None,
) -> NDArray[np.float64]:
    """Stack the measurement rows (σ, res, lo, hi, offset, drift) into one (6, n) array."""
    n = len(lo)
    out = np.zeros((6, n))
    k = sens.shape[1]
    out[M_SIG, :k] = sens[0]
    out[M_RES, :k] = sens[1]
    out[M_LO] = lo
    out[M_HI] = hi
    if offset is not None:
        out[M_OFF] = offset
    if drift is not None:
        out[M_DRIFT] = drift
    return out


@nb.njit(cache=True, inline="always")
def measure(v: float, meas: NDArray[np.float64], j: int, z: float, t_h: float) -> float:
    """Measured value of channel ``j`` (see the module docstring)."""
    y = v + meas[M_OFF, j] + meas[M_DRIFT, j] * t_h + meas[M_SIG, j] * z
    r = meas[M_RES, j]
    if r > 0.0:
        y = r * math.floor(y / r + 0.5)
    return min(max(y, meas[M_LO, j]), meas[M_HI, j])


@nb.njit(cache=True, inline="always")
def tp_push(
    a: NDArray[np.float64],
    r: int,
    c: int,
    v: float,
    h: float,
    buf: NDArray[np.float64],
    n: int,
) -> int:
    """Feed ``v`` to the tracker in ``a[r, c:c + 4]``; keep a confirmed point in ``buf``.

    A turning point confirmed by ``v`` goes to ``buf[r, n]``; returns the new count.
    """
    tp = tp_update_at(a, r, c, v, h)
    if not math.isnan(tp):
        buf[r, n] = tp
        return n + 1
    return n
