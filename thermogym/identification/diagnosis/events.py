"""Disturbance events read from a residual: the change points of a step-wise disturbance.

A draw-off from a hot-water tank, a door left open, a crowd in a room: an
unmeasured heat flow that switches on and off at times nobody logged. Through
a plant whose response to the port is close to first order with time constant
``τ``, the residual of the output obeys ``r[k+1] = a r[k] + g (1 − a) d[k]``
with ``a = exp(−Δt/τ)``, so the inverse filter ::

    e[k] = r[k+1] − a r[k]

is the disturbance itself, sample by sample (scaled), plus the noise's own
increments. Where ``d`` is zero most of the time and switches to a level for
a while, ``e`` is zero-centred noise with runs of large values of one sign:
the events. They are found as runs beyond :data:`Z_EVENT` robust standard
deviations of ``e`` (the median absolute deviation: the events themselves
leave it nearly untouched; never less than the white sensor noise's own
increments, so that a quantised reading's steps are not events), merged
across single-sample gaps. Two patterns are not disturbances and are dropped:

* a run of one sample: a spike of the sensor (an outlier in one reading
  gives ``+`` then ``−``), a quantised reading stepping to its next level, or
  an event too short for the sampling to resolve;
* a run that starts or ends on a step of a manipulated input (within a
  sample): the input's own effect, not something nobody logged — a wrong
  gain while a heater is on (both edges on steps), a sensor lag (a transient
  from each step), a dead time or a skewed clock (a run as long as the delay,
  between the step and its effect).

A residual with more than :data:`MAX_EVENTS` runs in a recording, or runs over
more than :data:`MAX_SHARE` of its samples, is not sparse: a course of the
recording's time (``steps``, ``smooth``) describes it, not events.

Nothing here knows a plant: the time constant and the input steps are the
caller's (the nominal model's response time to the port, the recorded
inputs).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = ["MAX_EVENTS", "MAX_SHARE", "Z_EVENT", "Event", "find_events", "input_steps"]

#: Robust standard deviations of the inverse-filtered residual an event exceeds: the tail of
#: Gaussian noise beyond 6 σ is 2·10⁻⁹ per sample, so noise alone gives none in a year at 1 Hz.
Z_EVENT = 6.0
#: Most events in one recording (the augmentation's slot limit).
MAX_EVENTS = 64
#: Largest share of a recording's samples inside events.
MAX_SHARE = 0.25


@dataclass(frozen=True)
class Event:
    """One on-period: samples ``start`` to ``stop − 1``, ``sign`` of the residual's jump."""

    start: int
    stop: int
    sign: int


def input_steps(u: NDArray[np.float64], ratio: float = 5.0) -> NDArray[np.bool_]:
    """Samples at which some column of ``u`` (T, n) steps: ``u[k] ≠ u[k−1]`` by much.

    A change counts when it exceeds ``ratio`` times the column's median
    absolute change and a thousandth of its range (a modulating input varying
    every sample steps only where it jumps).

    Examples
    --------
    >>> u = np.zeros((10, 1)); u[4:, 0] = 1.0
    >>> np.flatnonzero(input_steps(u)).tolist()
    [4]
    """
    u = np.asarray(u, dtype=float).reshape(u.shape[0], -1)
    out = np.zeros(u.shape[0], dtype=bool)
    if u.shape[0] < 2:
        return out
    du = np.abs(np.diff(u, axis=0))
    for j in range(u.shape[1]):
        d = du[:, j]
        ok = np.isfinite(d)
        if not ok.any():
            continue
        rng = float(np.nanmax(u[:, j]) - np.nanmin(u[:, j]))
        thr = max(ratio * float(np.median(d[ok])), 1e-3 * rng)
        if thr <= 0:
            continue
        out[1:] |= ok & (d > thr)
    return out


def find_events(
    r: NDArray[np.float64],
    dt: float,
    tau: float,
    steps: NDArray[np.bool_] | None = None,
    z: float = Z_EVENT,
    noise: float = 0.0,
) -> list[Event] | None:
    """Events of one recording's residual ``r`` (T,), or None when it is not sparse.

    Parameters
    ----------
    r : ndarray, shape (T,)
        Residual of one output (NaN where not measured).
    dt : float
        Sample period [s].
    tau : float
        Time constant [s] of the output's response to the port (``inf``: the
        residual's increments are taken as they are; 0: the residual itself).
    steps : ndarray of bool, shape (T,), optional
        Samples where a manipulated input steps (:func:`input_steps`).
    z : float
        Threshold in robust standard deviations.
    noise : float
        White-noise level of the reading (its standard deviation; 0 when
        unknown): the spread of ``e`` is taken as at least ``√2·noise``.

    Returns
    -------
    list of Event or None

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> a, d = np.exp(-30.0 / 3600.0), np.zeros(960)
    >>> d[200:208] = -1.0; d[600:608] = -1.0
    >>> r = np.zeros(960)
    >>> for k in range(959):
    ...     r[k + 1] = a * r[k] + (1 - a) * 50.0 * d[k]
    >>> ev = find_events(r + 0.01 * rng.standard_normal(960), 30.0, 3600.0)
    >>> [(e.start, e.stop, e.sign) for e in ev]
    [(200, 208, -1), (600, 608, -1)]
    """
    r = np.asarray(r, dtype=float).reshape(-1)
    if r.size < 8:
        return []
    if tau == 0:  # the output follows the port within its own sample: the residual itself
        e = r.copy()
    else:  # inf: an integrator, the residual's increments
        a = math.exp(-dt / tau) if math.isfinite(tau) and tau > 0 else 1.0
        e = r[1:] - a * r[:-1]
    ok = np.isfinite(e)
    if ok.sum() < 8:
        return []
    med = float(np.median(e[ok]))
    c = np.where(ok, e - med, 0.0)
    peak = float(np.max(np.abs(c)))
    if not peak > 0:
        return []
    # a residual without noise (a simulation) has no spread between its jumps: a floor
    s = max(
        1.4826 * float(np.median(np.abs(e[ok] - med))),
        math.sqrt(2.0) * noise if math.isfinite(noise) else 0.0,
        1e-9 * peak,
    )
    sign = np.where(c > z * s, 1, np.where(c < -z * s, -1, 0))
    runs = [ev for ev in _runs(sign) if ev.stop - ev.start >= 2]
    if steps is not None:
        st = np.asarray(steps, dtype=bool)
        near = st.copy()  # within a sample of a step (no wrap-around at the ends)
        near[1:] |= st[:-1]
        near[:-1] |= st[1:]
        last = near.size - 1
        runs = [ev for ev in runs if not (near[min(ev.start, last)] or near[min(ev.stop, last)])]
    inside = sum(ev.stop - ev.start for ev in runs)
    if len(runs) > MAX_EVENTS or inside > MAX_SHARE * r.size:
        return None
    return runs


def _runs(sign: NDArray[np.int64]) -> list[Event]:
    """Runs of one sign, merged across gaps of one sample."""
    out: list[Event] = []
    k, n = 0, sign.size
    while k < n:
        if sign[k] == 0:
            k += 1
            continue
        s0, j = int(sign[k]), k + 1
        while j < n and (sign[j] == s0 or (j + 1 < n and sign[j] == 0 and sign[j + 1] == s0)):
            j += 1
        out.append(Event(k, j, s0))
        k = j
    return out
