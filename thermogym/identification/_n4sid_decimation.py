"""Decimation for N4SID: block means and the factor chosen from the dominant time constant.

Slow thermal plants sampled fast are identified at ``r·dt``: inputs and
outputs are averaged over blocks of ``r`` samples (:func:`decimate_data`), and
:func:`auto_decimation` picks ``r`` so that about 200 samples span the
dominant time constant (see :mod:`thermogym.identification.n4sid`, step 2).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

__all__ = ["auto_decimation", "decimate_data"]

_SAMPLES_PER_TAU = 200.0  # auto decimation keeps ~200 samples per dominant time constant


def decimate_data(
    u: NDArray[np.float64], y: NDArray[np.float64] | None, r: int
) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
    """Block means over ``[k·r, (k+1)·r)`` of inputs and outputs.

    With inputs held over each block (zero-order hold on the coarse grid) the
    block means obey an exact state-space model at period ``r·dt`` with the
    same ``A_r = A^r``, ``B_r = Σ_j A^j B``, the state at the start of each
    block, and output matrices ``C̄ = C M``, ``D̄ = D + C N B`` where
    ``M = (1/r) Σ_{j<r} A^j`` and ``N = (1/r) Σ_{j<r} Σ_{l<j} A^l``
    (:func:`_block_mean_maps`). Averaging cuts the output noise by ``√r``
    without looking ahead of the block, so nothing is biased.

    Parameters
    ----------
    u : ndarray, shape (T, m)
    y : ndarray, shape (T, p) or None
    r : int
        Factor >= 1 (a trailing partial block is dropped).

    Returns
    -------
    u_r : ndarray, shape (T // r, m)
    y_r : ndarray, shape (T // r, p) or None

    Examples
    --------
    >>> u = np.arange(6.0)[:, None]; y = 10 * np.arange(6.0)[:, None]
    >>> ur, yr = decimate_data(u, y, 2)
    >>> ur[:, 0].tolist(), yr[:, 0].tolist()
    ([0.5, 2.5, 4.5], [5.0, 25.0, 45.0])
    """
    if r == 1:
        return u, y
    N = u.shape[0] // r
    ur = u[: N * r].reshape(N, r, -1).mean(axis=1)
    yr = None if y is None else y[: N * r].reshape(N, r, -1).mean(axis=1)
    return ur, yr


def _block_mean_maps(
    A: NDArray[np.float64], r: int
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``M = (1/r) Σ_{j<r} A^j`` and ``N = (1/r) Σ_{j<r} Σ_{l<j} A^l`` (fine-rate ``A``).

    The mean of ``y[kr + j] = C A^j x + C Σ_{l<j} A^l B u + D u`` over
    ``j < r`` is ``C M x + (D + C N B) u``.
    """
    n = A.shape[0]
    P = np.eye(n)  # A^j
    S = np.zeros((n, n))  # Σ_{l<j} A^l
    M = np.zeros((n, n))
    N = np.zeros((n, n))
    for _ in range(r):
        M += P
        N += S
        S += P
        P = A @ P
    return M / r, N / r


def auto_decimation(
    us: Sequence[NDArray[np.float64]],
    ys: Sequence[NDArray[np.float64]],
    dt: float,
    *,
    min_samples: int = 400,
) -> tuple[int, float]:
    """Decimation factor that keeps about 200 samples per dominant time constant.

    The dominant time constant is the largest ``T = −dt / ln a`` of first-order
    ARX fits ``y_j[k] = a y_j[k−1] + b·u[k−1] + c`` (one per output, least
    squares on the longest experiment). The factor is capped so that each
    experiment keeps at least ``min_samples`` samples, and so that a
    piecewise-constant input holds each value for at least two blocks (the
    block means assume inputs constant within a block).

    Returns
    -------
    r : int
        Factor >= 1 (1 when no stable first-order lag is found).
    tau : float
        The dominant time constant [s] (NaN when none).
    """
    e = int(np.argmax([u.shape[0] for u in us]))
    u, y = us[e], ys[e]
    N = u.shape[0]
    taus = []
    X = np.column_stack([u[:-1], np.ones(N - 1)])
    for j in range(y.shape[1]):
        Phi = np.column_stack([y[:-1, j], X])
        sc = np.sqrt((Phi**2).sum(axis=0)) + 1e-300
        th = np.linalg.lstsq(Phi / sc, y[1:, j], rcond=None)[0] / sc
        a = float(th[0])
        if 0.0 < a < 1.0:
            taus.append(-dt / math.log(a))
    if not taus:
        return 1, math.nan
    tau = max(taus)
    r = int(tau / (_SAMPLES_PER_TAU * dt))
    # a commanded, piecewise-constant input should switch on block boundaries or at least
    # rarely inside a block: keep blocks at most half its typical hold time
    for ue in us:
        for c in range(ue.shape[1]):
            change = np.flatnonzero(np.diff(ue[:, c]) != 0)
            if 0 < change.size < 0.1 * ue.shape[0] and change.size > 1:
                hold = float(np.percentile(np.diff(change), 10))
                r = min(r, max(1, int(hold // 2)))
    n_min = min(v.shape[0] for v in us)
    r_max = max(1, n_min // min_samples)
    return int(min(max(r, 1), r_max)), tau
