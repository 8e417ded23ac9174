"""N4SID subspace identification of MIMO state-space models (paper 001, section 2.3.3).

Identifies the innovation form, eq (3) of ``001_6d13a2cd04f5de5e.txt``::

    x[k+1] = A x[k] + B u[k] + K e[k],    y[k] = C x[k] + D u[k] + e[k]   (3)

from one or several experiments, as MATLAB's ``n4sid`` does for the paper.

Algorithm
---------
1. *Scaling and operating point.* Each experiment's operating point is
   subtracted (``"none"`` by default: prepared spindle data are temperature
   rises above ambient) and every channel is divided by its RMS, so that a
   speed in rpm and temperatures in K weigh alike in the projections.
2. *Decimation.* Slow thermal plants sampled at 1 Hz have time constants of
   hours: a block Hankel matrix of a few dozen rows then spans seconds, the
   state is barely visible in it and the model is poor (on two rig days of
   the spindle, speed and ambient as inputs, an order-12 model identified at
   1 Hz validated at 99.2 %, the same identified at 1 min at 99.6 %, the
   noise floor of the data). ``decimate="auto"`` estimates the dominant time
   constant with a first-order ARX fit and keeps about 200 samples per time
   constant. Inputs and outputs are averaged over blocks of ``r`` samples
   (:func:`decimate_data`): with inputs held within a block this is an exact
   state-space model at ``r·dt`` with the same states, and the averaging cuts
   the noise without looking ahead. The dynamics are converted back exactly
   (``d2c_zoh`` → ``c2d_zoh``) and ``C``, ``D`` re-estimated on every sample,
   so FitResults always run at the recording's ``dt``.
3. *One decomposition.* The block Hankel matrix of past and future inputs and
   outputs (``2·i`` block rows, the columns of all experiments side by side,
   never across an experiment boundary) is reduced to its triangular factor
   ``H = L Qᵀ`` block by block (QR of ``[R; H_chunk]``), so memory does not
   grow with the number of samples. Every projection after that is an
   operation on the rows of ``L`` (``2i(m+p)`` columns wide):

   * the oblique projection ``O_i = Y_f /_{U_f} W_p`` (Van Overschee and
     De Moor 1996, Theorem 2) and ``O_{i+1}`` of the shifted partition;
   * the weighted matrix ``W₁ O_i W₂`` — ``"moesp"`` (``W₂ = Π_{U_f⊥}``,
     default), ``"cva"`` or ``"n4sid"`` (no weighting) — and its SVD. The
     singular values are those MATLAB's ``n4sid`` plots for the order choice.

4. *Every order from it.* For order ``n``: ``Γ = W₁⁻¹ U₁ S₁^{1/2}``;
   ``C`` = first block row of ``Γ``, ``A`` from the shift invariance
   ``Γ_↑ A = Γ_↓`` (least squares); unstable eigenvalues are mirrored into
   the unit circle in the real Schur form (``stable=True``). ``B``, ``D`` and
   each experiment's initial state then follow by linear least squares on the
   (decimated) data, i.e. minimising the *simulation* error given ``A`` and
   ``C`` (MATLAB's ``Focus="simulation"``); regressors are FFT convolutions of
   the inputs with ``C A^k``. ``bd="subspace"`` instead takes ``B``, ``D``
   from the state-sequence regression on ``L`` alone (no second pass over the
   data: for data that arrives in chunks). ``K`` is the Kalman gain of the
   state-sequence residual covariances (discrete Riccati equation).

Nothing is recomputed per order but these small matrices and the regression,
so a sweep over orders 1..30 with cross-validation costs seconds
(:mod:`thermogym.identification.crossval`).

References: P. Van Overschee, B. De Moor, *Subspace Identification for Linear
Systems*, Kluwer 1996 (algorithms 1-3, section 4.3); M. Verhaegen, V. Verdult,
*Filtering and System Identification*, CUP 2007 (PO-MOESP, chapter 9). The
implementation is written here because no maintained Python library does the
chunked one-decomposition, all-orders sweep: SIPPY and nfoursid form the full
Hankel matrices (``benchmarks/n4sid.py`` measures both).
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, cast

import numba as nb
import numpy as np
import scipy.linalg
from numpy.lib.stride_tricks import sliding_window_view
from numpy.typing import NDArray
from scipy.signal import fftconvolve

from thermogym._jitcache import module_kernels_depend_on
from thermogym.errors import ConfigError, IdentificationError
from thermogym.fitresult import FitResult
from thermogym.identification.advice import check_fit
from thermogym.identification.linear_fit import (
    OPERATING_POINTS,
    data_entries,
    evaluate_fit,
    exogenous_roles,
    operating_point,
    signal_arrays,
    signal_ranges,
)
from thermogym.models._blas import blas_threads, single_blas_thread
from thermogym.models.linear import StateSpaceModel, c2d_zoh, d2c_zoh
from thermogym.models.lti import lti_output, lti_update
from thermogym.recording import Recording

__all__ = [
    "WEIGHTINGS",
    "HankelAccumulator",
    "N4SIDDecomposition",
    "N4SIDResult",
    "StateSpaceFit",
    "auto_decimation",
    "decimate_data",
    "n4sid",
    "n4sid_decompose",
]

#: Weightings of the projected Hankel matrix before the SVD.
WEIGHTINGS: tuple[str, ...] = ("moesp", "cva", "n4sid")
_X0_MODES = ("estimate", "zero")
_BD_MODES = ("regression", "subspace")
_SAMPLES_PER_TAU = 200.0  # auto decimation keeps ~200 samples per dominant time constant


# ================================================================ numba kernels
@nb.njit(cache=True)
def _obs_seq(A, C, N):  # pragma: no cover - numba
    """C A^k for k = 0..N−1, shape (N, p, n)."""
    p, n = C.shape
    out = np.empty((N, p, n))
    M = C.copy()
    tmp = np.empty((p, n))
    for k in range(N):
        out[k] = M
        for r in range(p):
            for c in range(n):
                acc = 0.0
                for j in range(n):
                    acc += M[r, j] * A[j, c]
                tmp[r, c] = acc
        M[:, :] = tmp
    return out


@nb.njit(cache=True, fastmath=True)
def _sim(A, B, C, D, u, x0):  # pragma: no cover - numba
    """y[k] = C x + D u, x[k+1] = A x + B u; returns y, shape (T, p).

    The package's linear recursion (:mod:`thermogym.models.lti`) compiled with
    ``fastmath`` (reassociated sums, SIMD); results differ from the strict order
    only in the last bits.
    """
    T = u.shape[0]
    y = np.empty((T, C.shape[0]))
    At, Bt, Ct, Dt = A.T.copy(), B.T.copy(), C.T.copy(), D.T.copy()
    zero = np.zeros(C.shape[0])
    x = x0.copy()
    xn = np.empty(A.shape[0])
    for k in range(T):
        lti_output(Ct, Dt, zero, x, u[k], y[k])
        lti_update(At, Bt, x, u[k], xn)
        x, xn = xn, x
    return y


@nb.njit(cache=True, fastmath=True)
def _states(A, B, u, x0):  # pragma: no cover - numba
    """x[k] for k = 0..T−1 with x[k+1] = A x[k] + B u[k]; shape (T, n)."""
    T = u.shape[0]
    X = np.empty((T, A.shape[0]))
    At, Bt = A.T.copy(), B.T.copy()
    x = x0.copy()
    xn = np.empty(A.shape[0])
    for k in range(T):
        X[k] = x
        lti_update(At, Bt, x, u[k], xn)
        x, xn = xn, x
    return X


def simulate_ss(
    A: NDArray[np.float64],
    B: NDArray[np.float64],
    C: NDArray[np.float64],
    D: NDArray[np.float64],
    u: NDArray[np.float64],
    x0: NDArray[np.float64] | None = None,
) -> NDArray[np.float64]:
    """Deterministic simulation of ``(A, B, C, D)`` (compiled loop), shape (T, p)."""
    x = np.zeros(A.shape[0]) if x0 is None else np.asarray(x0, dtype=float)
    return _sim(
        np.ascontiguousarray(A),
        np.ascontiguousarray(B),
        np.ascontiguousarray(C),
        np.ascontiguousarray(D),
        np.ascontiguousarray(u, dtype=float),
        np.ascontiguousarray(x, dtype=float),
    )


# =================================================================== decimation
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


# ============================================================ Hankel reduction
class HankelAccumulator:
    """Triangular factor of a block Hankel data matrix, accumulated chunk by chunk.

    The data matrix has ``2·horizon`` block rows of inputs (``m`` rows each)
    followed by ``2·horizon`` block rows of outputs (``p`` each); column ``k``
    holds ``u[k], …, u[k+2i−1], y[k], …, y[k+2i−1]``. Columns never straddle
    two experiments. Only the triangular factor ``R`` (``H Hᵀ = Rᵀ R``) is
    kept, updated by a QR of ``[R; H_chunkᵀ]``; memory is
    ``O(chunk · 2i(m+p))`` whatever the number of samples.

    Parameters
    ----------
    n_inputs, n_outputs : int
    horizon : int
        Block rows ``i`` of the past (and of the future).
    chunk : int
        Hankel columns per QR update.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> u, y = rng.normal(size=(500, 1)), rng.normal(size=(500, 2))
    >>> acc = HankelAccumulator(1, 2, horizon=3, chunk=64)
    >>> for k in range(0, 500, 100):
    ...     acc.add(u[k:k + 100], y[k:k + 100])
    >>> acc.n_columns, acc.r_factor().shape
    (495, (18, 18))
    """

    def __init__(self, n_inputs: int, n_outputs: int, horizon: int, *, chunk: int = 4096):
        if horizon < 1 or int(horizon) != horizon:
            raise ConfigError(f"horizon is {horizon!r}; expected a whole number >= 1")
        self.m, self.p, self.horizon = int(n_inputs), int(n_outputs), int(horizon)
        self.rows = 2 * self.horizon * (self.m + self.p)
        self.chunk = max(int(chunk), self.rows)
        self._R = np.zeros((0, self.rows))
        self._tail_u = np.zeros((0, self.m))
        self._tail_y = np.zeros((0, self.p))
        self.n_columns = 0
        self.n_experiments = 0
        self._open = False

    def add(self, u: NDArray[np.float64], y: NDArray[np.float64]) -> None:
        """Append samples to the current experiment (opens one if none is open)."""
        u = np.asarray(u, dtype=float).reshape(-1, self.m)
        y = np.asarray(y, dtype=float).reshape(-1, self.p)
        if u.shape[0] != y.shape[0]:
            raise ConfigError(f"u has {u.shape[0]} samples, y {y.shape[0]}; expected equal")
        if not (np.isfinite(u).all() and np.isfinite(y).all()):
            raise IdentificationError("HankelAccumulator.add: u and y must be finite")
        if not self._open:
            self.n_experiments += 1
            self._open = True
        bu = np.concatenate([self._tail_u, u])
        by = np.concatenate([self._tail_y, y])
        w = 2 * self.horizon
        ncol = bu.shape[0] - w + 1
        if ncol > 0:
            for c0 in range(0, ncol, self.chunk):
                c1 = min(ncol, c0 + self.chunk)
                self._update(bu[c0 : c1 + w - 1], by[c0 : c1 + w - 1])
            # the last w − 1 samples start columns that need the next chunk's samples
            self._tail_u, self._tail_y = bu[ncol:], by[ncol:]
        else:
            self._tail_u, self._tail_y = bu, by

    def _update(self, u: NDArray[np.float64], y: NDArray[np.float64]) -> None:
        w = 2 * self.horizon
        # Hᵀ rows: [u[k], …, u[k+w−1], y[k], …, y[k+w−1]] for each column k
        Uw = sliding_window_view(u, w, axis=0)  # (ncol, m, w)
        Yw = sliding_window_view(y, w, axis=0)
        ncol = Uw.shape[0]
        Ht = np.empty((ncol, self.rows))
        Ht[:, : w * self.m] = Uw.transpose(0, 2, 1).reshape(ncol, w * self.m)
        Ht[:, w * self.m :] = Yw.transpose(0, 2, 1).reshape(ncol, w * self.p)
        # numpy's stubs type every mode as QRResult; mode="r" returns R alone
        self._R = cast(NDArray[np.float64], np.linalg.qr(np.vstack([self._R, Ht]), mode="r"))
        self.n_columns += ncol

    def end_experiment(self) -> None:
        """Close the current experiment: the next samples start a new one."""
        self._tail_u = np.zeros((0, self.m))
        self._tail_y = np.zeros((0, self.p))
        self._open = False

    def r_factor(self) -> NDArray[np.float64]:
        """Upper-triangular ``R`` with ``H Hᵀ = Rᵀ R``, shape (rows, rows)."""
        if self.n_columns < self.rows:
            raise IdentificationError(
                f"the data give {self.n_columns} Hankel columns, fewer than the {self.rows} rows "
                f"of a horizon of {self.horizon} block rows; use more samples, a shorter "
                "horizon or a lower order"
            )
        return self._R[: self.rows]


# ============================================================= decomposition
def _mirror_schur(A: NDArray[np.float64], max_radius: float, positive: bool) -> NDArray[np.float64]:
    """Move eigenvalues into the unit circle (and off the negative real axis).

    In the real Schur form ``A = Q T Qᵀ`` a 1×1 block is an eigenvalue and a
    2×2 block a complex pair; scaling a block changes only its eigenvalues,
    which is exact where an eigenvector basis may be ill conditioned.
    ``|λ| ≥ max_radius`` is mirrored to ``min(1/|λ|, max_radius)``;
    ``positive`` replaces a negative real eigenvalue by its magnitude (a
    sampled continuous system has none; they must go before ``d2c_zoh``).
    """
    T, Q = scipy.linalg.schur(A, output="real")
    n = T.shape[0]
    changed = False
    k = 0
    while k < n:
        two = k + 1 < n and abs(T[k + 1, k]) > 0.0
        if two:
            blk = T[k : k + 2, k : k + 2]
            rad = math.sqrt(abs(np.linalg.det(blk)))
            if rad >= max_radius:
                T[k : k + 2, k : k + 2] = blk * (min(1.0 / rad, max_radius) / rad)
                changed = True
            k += 2
        else:
            lam = T[k, k]
            new = lam
            if abs(lam) >= max_radius:
                new = math.copysign(min(1.0 / abs(lam), max_radius), lam)
            if positive and new <= 0.0:
                new = max(abs(new), 1e-6)
            if new != lam:
                T[k, k] = new
                changed = True
            k += 1
    return Q @ T @ Q.T if changed else A


@dataclass
class StateSpaceFit:
    """An identified state-space model at the data's sample period.

    Attributes
    ----------
    A, B, C, D, K : ndarray
        Discrete matrices of (3) at period ``dt``, in the recordings' units.
    dt : float
        Sample period [s].
    order : int
    x0 : list of ndarray
        Initial state of each training experiment (zero when not estimated).
    decimate : int
        Factor the model was identified at (``dt_id = decimate · dt``).
    A_id, B_id, C_id, D_id : ndarray
        The model at the identification period, in scaled units (for fast
        initial-state estimation on decimated data).
    u_scale, y_scale : ndarray
        Channel scales used in the identification.
    info : dict
        Notes: eigenvalues moved, noise model status.
    """

    A: NDArray[np.float64]
    B: NDArray[np.float64]
    C: NDArray[np.float64]
    D: NDArray[np.float64]
    K: NDArray[np.float64]
    dt: float
    order: int
    x0: list[NDArray[np.float64]]
    decimate: int
    A_id: NDArray[np.float64]
    B_id: NDArray[np.float64]
    C_id: NDArray[np.float64]
    D_id: NDArray[np.float64]
    u_scale: NDArray[np.float64]
    y_scale: NDArray[np.float64]
    info: dict[str, Any] = field(default_factory=dict)

    def estimate_x0(self, u: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
        """Least-squares initial state for deviation data ``u``, ``y`` at ``dt``.

        Computed on the decimated data with the identification-rate model
        (the state coordinates are the same at both rates).
        """
        ur, yr = decimate_data(u / self.u_scale, y / self.y_scale, self.decimate)
        assert yr is not None
        forced = simulate_ss(self.A_id, self.B_id, self.C_id, self.D_id, ur)
        Psi = _obs_seq(
            np.ascontiguousarray(self.A_id), np.ascontiguousarray(self.C_id), ur.shape[0]
        )
        with blas_threads(1):
            sol = np.linalg.lstsq(
                Psi.reshape(-1, self.order), (yr - forced).reshape(-1), rcond=None
            )
        return sol[0]

    def predict(
        self, u: NDArray[np.float64], y: NDArray[np.float64] | None = None, x0: str = "estimate"
    ) -> NDArray[np.float64]:
        """Simulated outputs for deviation inputs ``u`` (T, m) at ``dt``.

        ``x0="estimate"`` fits the initial state to ``y`` (MATLAB ``compare``),
        ``"zero"`` starts at rest.
        """
        if x0 == "estimate" and y is not None:
            xi = self.estimate_x0(u, y)
        elif x0 in ("zero", "estimate"):
            xi = np.zeros(self.order)
        else:
            raise ConfigError(f"x0 is {x0!r}; expected 'estimate' or 'zero'")
        return simulate_ss(self.A, self.B, self.C, self.D, u, xi)

    def model(
        self,
        inputs: Sequence[str],
        outputs: Sequence[str],
        *,
        disturbances: Sequence[str] = (),
        units: dict[str, str] | None = None,
        feedthrough: bool = False,
        noise_model: bool = True,
    ) -> StateSpaceModel:
        """The fitted :class:`~thermogym.models.linear.StateSpaceModel`."""
        return StateSpaceModel.from_matrices(
            self.A,
            self.B,
            self.C,
            self.D if feedthrough else None,
            self.K if noise_model else None,
            dt=self.dt,
            inputs=list(inputs),
            outputs=list(outputs),
            disturbances=list(disturbances),
            units=units,
        )


@dataclass
class N4SIDDecomposition:
    """The data decomposition of one training set, from which every order is derived.

    Built by :func:`n4sid_decompose`; :meth:`system` gives the model of any
    order, :meth:`suggest_order` the order the singular values suggest.

    Attributes
    ----------
    singular_values : ndarray
        Of the weighted projected Hankel matrix (as MATLAB's n4sid plots them).
    horizon : int
    decimate : int
    dt : float
        Sample period of the data [s].
    n_inputs, n_outputs : int
    weighting : str
    seconds : float
        Wall time of the decomposition [s].
    """

    singular_values: NDArray[np.float64]
    horizon: int
    decimate: int
    dt: float
    n_inputs: int
    n_outputs: int
    weighting: str
    u_scale: NDArray[np.float64]
    y_scale: NDArray[np.float64]
    seconds: float
    _U: NDArray[np.float64]
    _W1inv: NDArray[np.float64] | None
    _Oi: NDArray[np.float64]
    _Oi1: NDArray[np.float64]
    _Ui: NDArray[np.float64]
    _Yi: NDArray[np.float64]
    _ncol: int
    _data: list[tuple[NDArray[np.float64], NDArray[np.float64]]] | None
    _noise_fine: NDArray[np.float64] | None
    _fine: list[tuple[NDArray[np.float64], NDArray[np.float64]]] | None = None
    info: dict[str, Any] = field(default_factory=dict)

    @property
    def max_order(self) -> int:
        """Largest order the horizon supports: ``(horizon − 1) · n_outputs``."""
        return min((self.horizon - 1) * self.n_outputs, int(np.sum(self.singular_values > 0)))

    def suggest_order(self, orders: Sequence[int] | None = None) -> int:
        """Order with the largest gap between consecutive log singular values.

        The rule of SLICOT's ``IB01OD`` without a tolerance; MATLAB's ``n4sid``
        shows the same singular values for a manual choice.

        Parameters
        ----------
        orders : sequence of int, optional
            Candidates (default ``1 .. max_order``).
        """
        s = self.singular_values
        cand = [n for n in (orders or range(1, self.max_order + 1)) if 1 <= n < s.size]
        cand = [n for n in cand if n <= self.max_order]
        if not cand:
            raise ConfigError(f"no candidate order in {orders!r} is below {self.max_order + 1}")
        with np.errstate(divide="ignore"):
            gaps = [np.log10(s[n - 1] / max(s[n], 1e-300)) for n in cand]
        return int(cand[int(np.argmax(gaps))])

    def _check_order(self, order: int) -> int:
        if int(order) != order or order < 1:
            raise ConfigError(f"order is {order!r}; expected a whole number >= 1")
        if order > self.max_order:
            raise IdentificationError(
                f"order {order} needs a longer horizon: horizon {self.horizon} with "
                f"{self.n_outputs} output(s) supports orders up to {self.max_order}; pass "
                f"horizon >= {math.ceil(order / self.n_outputs) + 1}"
            )
        return int(order)

    @single_blas_thread
    def system(
        self,
        order: int,
        *,
        x0: str = "estimate",
        bd: str = "regression",
        feedthrough: bool = False,
        stable: bool = True,
        max_radius: float = 1.0 - 1e-9,
        noise_model: bool = True,
    ) -> StateSpaceFit:
        """Model of one order: A, C from the decomposition; B, D, x0, K as asked.

        Parameters
        ----------
        order : int
        x0 : {"estimate", "zero"}
            Estimate each training experiment's initial state jointly with
            ``B``, ``D`` (regression only).
        bd : {"regression", "subspace"}
            ``B``, ``D`` by least squares of the simulation error on the
            training data, or from the state-sequence regression on the
            triangular factor (no data needed).
        feedthrough : bool
            Estimate ``D`` (paper 001's model has none).
        stable : bool
            Mirror unstable eigenvalues of ``A`` into the unit circle.
        max_radius : float
            Largest eigenvalue magnitude kept.
        noise_model : bool
            Compute the Kalman gain ``K``.

        Returns
        -------
        StateSpaceFit
        """
        n = self._check_order(order)
        if x0 not in _X0_MODES:
            raise ConfigError(f"x0 is {x0!r}; expected one of {_X0_MODES}")
        if bd not in _BD_MODES:
            raise ConfigError(f"bd is {bd!r}; expected one of {_BD_MODES}")
        if bd == "regression" and self._data is None:
            raise ConfigError(
                "bd='regression' needs the training data; this decomposition was built from "
                "an accumulator without them: use bd='subspace'"
            )
        p = self.n_outputs
        info: dict[str, Any] = {}
        # Γ_i = W1⁻¹ U1 S1^{1/2}                  (Van Overschee & De Moor, Theorem 2)
        G = self._U[:, :n] * np.sqrt(self.singular_values[:n])
        if self._W1inv is not None:
            G = self._W1inv @ G
        C = G[:p].copy()
        # shift invariance: Γ_{i−1}(first i−1 block rows) A = Γ(last i−1 block rows)
        # (float64 in, float64 out: numpy's stubs say floating[Any])
        A = cast(NDArray[np.float64], np.linalg.lstsq(G[:-p], G[p:], rcond=None)[0])
        lam0 = np.linalg.eigvals(A)
        if stable or self.decimate > 1:
            A = _mirror_schur(A, max_radius if stable else np.inf, self.decimate > 1)
            lam1 = np.linalg.eigvals(A)
            moved = int(np.sum(np.abs(np.sort_complex(lam0) - np.sort_complex(lam1)) > 1e-12))
            if moved:
                info["eigenvalues_moved"] = moved
        # state sequences X_i = Γ_i^† O_i, X_{i+1} = Γ_{i−1}^† O_{i+1}    (algorithm 2)
        Xi = np.linalg.lstsq(G, self._Oi, rcond=None)[0]
        Xi1 = np.linalg.lstsq(G[:-p], self._Oi1, rcond=None)[0]
        # [X_{i+1}; Y_i] − [A; C] X_i = [B; D] U_i + ρ   (least squares in R-space)
        lhs = np.vstack([Xi1 - A @ Xi, self._Yi - C @ Xi])
        r = self.decimate
        # block means have a feedthrough D̄ = D + C N B even when the plant has none
        coarse_d = feedthrough or r > 1
        BD = cast(NDArray[np.float64], np.linalg.lstsq(self._Ui.T, lhs.T, rcond=None)[0].T)
        if not coarse_d:
            BD[n:] = 0.0
        rho = lhs - BD @ self._Ui
        Sig = rho @ rho.T / max(self._ncol, 1)
        Sig = 0.5 * (Sig + Sig.T)
        if bd == "subspace":
            B, D = BD[:n].copy(), BD[n:].copy()
            x0s = [np.zeros(n) for _ in range(self.info.get("n_experiments", 1))]
        else:
            assert self._data is not None
            B, D, x0s = _regress_bd(A, C, self._data, coarse_d, x0 == "estimate")
        A_id, B_id, C_id, D_id = A, B, C, D
        if r > 1:
            # exact ZOH conversion of the dynamics to the data period ...
            Ac, Bc = d2c_zoh(A, B, self.dt * r)
            A, B = c2d_zoh(Ac, Bc, self.dt)
            # ... and C, D by least squares on the data at that period, the states
            # propagated inside each block from the block-start states (C̄ = C M cannot
            # be inverted safely: M is near singular for modes that oscillate or decay
            # within a block)
            if self._fine is not None:
                assert self._data is not None  # kept with the fine-rate data
                C, D = _fine_output_map(
                    A, B, A_id, B_id, self._data, self._fine, x0s, r, feedthrough
                )
            else:
                Mm, Nm = _block_mean_maps(A, r)
                C = cast(
                    NDArray[np.float64], np.linalg.lstsq(Mm.T, C_id.T, rcond=1e-6)[0].T
                )  # C̄ = C M
                D = D_id - C @ Nm @ B if feedthrough else np.zeros_like(D_id)
        # Kalman gain of the innovation form (3): DARE on the residual covariances
        K = np.zeros((n, p))
        if noise_model:
            Q = Sig[:n, :n]
            S = Sig[:n, n:]
            R = Sig[n:, n:]
            if r > 1 and self._noise_fine is not None:
                # per fine step: process noise ≈ Q_id / r, measurement noise measured at dt
                Q, S, R = Q / r, np.zeros_like(S), np.diag(self._noise_fine)
            K, status = _kalman_gain(A, C, Q, R, S)
            info["noise_model"] = status
        Cs = C * self.y_scale[:, None]
        return StateSpaceFit(
            A=A,
            B=B / self.u_scale[None, :],
            C=Cs,
            D=(D * self.y_scale[:, None]) / self.u_scale[None, :],
            K=K / self.y_scale[None, :],
            dt=self.dt,
            order=n,
            x0=x0s,
            decimate=self.decimate,
            A_id=A_id,
            B_id=B_id,
            C_id=C_id,
            D_id=D_id,
            u_scale=self.u_scale,
            y_scale=self.y_scale,
            info=info,
        )


def _fine_output_map(
    A: NDArray[np.float64],
    B: NDArray[np.float64],
    A_id: NDArray[np.float64],
    B_id: NDArray[np.float64],
    coarse: list[tuple[NDArray[np.float64], NDArray[np.float64]]],
    fine: list[tuple[NDArray[np.float64], NDArray[np.float64]]],
    x0s: list[NDArray[np.float64]],
    r: int,
    feedthrough: bool,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``C``, ``D`` at the data period by least squares on every sample.

    Block-start states come from the coarse model; inside block ``k`` the state
    is ``x[kr + j] = A^j x_k + Σ_{l<j} A^l B ū_k`` (the input held at its block
    mean, exact for inputs that switch on the coarse grid). One matrix product
    per experiment builds all states; ``y = C x + D u`` is then linear.
    """
    n, m = B.shape
    P = np.empty((r, n, n))
    Q = np.empty((r, n, m))
    Pj, Sj = np.eye(n), np.zeros((n, n))
    for j in range(r):
        P[j], Q[j] = Pj, Sj @ B
        Sj = Sj + Pj
        Pj = A @ Pj
    Pcat = P.transpose(2, 0, 1).reshape(n, r * n)  # x_k @ Pcat -> [A^j x_k]_j
    Qcat = Q.transpose(2, 0, 1).reshape(m, r * n)
    blocks_X, blocks_U, blocks_Y = [], [], []
    for (ur, _yr), (uf, yf), x0 in zip(coarse, fine, x0s, strict=True):
        Nc = ur.shape[0]
        Xc = _states(
            np.ascontiguousarray(A_id),
            np.ascontiguousarray(B_id),
            np.ascontiguousarray(ur),
            np.ascontiguousarray(x0, dtype=float),
        )
        Xf = (Xc @ Pcat + ur @ Qcat).reshape(Nc * r, n)
        blocks_X.append(Xf)
        blocks_U.append(uf[: Nc * r])
        blocks_Y.append(yf[: Nc * r])
    X = np.concatenate(blocks_X)
    Phi = np.hstack([X, np.concatenate(blocks_U)]) if feedthrough else X
    Y = np.concatenate(blocks_Y)
    # normal equations (tens of columns, 10⁵ rows): the Gram matrix in one BLAS call,
    # then a scaled least-squares solve of the small system
    G = Phi.T @ Phi
    sc = np.sqrt(np.diag(G)) + 1e-300
    th = np.linalg.lstsq(G / np.outer(sc, sc), (Phi.T @ Y) / sc[:, None], rcond=1e-13)[0]
    th /= sc[:, None]
    C = th[:n].T
    D = th[n:].T if feedthrough else np.zeros((Y.shape[1], m))
    return C, D


def _kalman_gain(
    A: NDArray[np.float64],
    C: NDArray[np.float64],
    Q: NDArray[np.float64],
    R: NDArray[np.float64],
    S: NDArray[np.float64],
) -> tuple[NDArray[np.float64], str]:
    """``K = (A P Cᵀ + S)(C P Cᵀ + R)⁻¹`` with P from the filter Riccati equation."""
    n, p = A.shape[0], C.shape[0]

    def psd(M: NDArray[np.float64], floor: float) -> NDArray[np.float64]:
        w, V = np.linalg.eigh(0.5 * (M + M.T))
        return (V * np.maximum(w, floor)) @ V.T

    scale = max(float(np.trace(R)) / p, 1e-300)
    Rp = psd(R, 1e-9 * scale)
    Qp = psd(Q, 0.0)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            P = scipy.linalg.solve_discrete_are(A.T, C.T, Qp, Rp, s=S)
        K = (A @ P @ C.T + S) @ np.linalg.inv(C @ P @ C.T + Rp)
    except (np.linalg.LinAlgError, ValueError) as e:
        return np.zeros((n, p)), f"no Kalman gain (Riccati equation failed: {e}); K = 0"
    if not np.isfinite(K).all() or np.abs(np.linalg.eigvals(A - K @ C)).max() >= 1.0:
        return np.zeros((n, p)), "no stabilising Kalman gain found; K = 0"
    return K, "ok"


def _regress_bd(
    A: NDArray[np.float64],
    C: NDArray[np.float64],
    data: list[tuple[NDArray[np.float64], NDArray[np.float64]]],
    feedthrough: bool,
    est_x0: bool,
) -> tuple[NDArray[np.float64], NDArray[np.float64], list[NDArray[np.float64]]]:
    """B, D and initial states minimising the simulation error for fixed A, C.

    ``y[k] = C A^k x0 + Σ_{l<k} C A^{k−1−l} B u[l] + D u[k]`` is linear in
    ``(B, D, x0)``. The regressors of ``B[r, c]`` are the inputs ``u_c``
    convolved with ``(C A^k)[:, r]`` (FFT); the least squares is reduced output
    by output with QR updates, so only one output's regressors exist at a time.
    """
    n, p = A.shape[0], C.shape[0]
    m = data[0][0].shape[1]
    E = len(data)
    nb_ = n * m
    nd = p * m if feedthrough else 0
    nx = n * E if est_x0 else 0
    ncols = nb_ + nd + nx
    R = np.zeros((0, ncols + 1))
    Ac = np.ascontiguousarray(A)
    Cc = np.ascontiguousarray(C)
    for e, (u, y) in enumerate(data):
        N = u.shape[0]
        Psi = _obs_seq(Ac, Cc, N)  # (N, p, n): C A^k
        # Z[k, q, r, c] = Σ_{l<k} u_c[l] (C A^{k−1−l})[q, r]
        Z = np.empty((N, p, n, m))
        for c in range(m):
            conv = fftconvolve(u[:, c][:, None, None], Psi, axes=0)[: N - 1]
            Z[0, :, :, c] = 0.0
            Z[1:, :, :, c] = conv
        for q in range(p):
            Phi = np.zeros((N, ncols + 1))
            Phi[:, :nb_] = Z[:, q].reshape(N, nb_)  # column r*m + c  ↔  B[r, c]
            if feedthrough:
                Phi[:, nb_ + q * m : nb_ + (q + 1) * m] = u  # D[q, :]
            if est_x0:
                Phi[:, nb_ + nd + e * n : nb_ + nd + (e + 1) * n] = Psi[:, q, :]
            Phi[:, -1] = y[:, q]
            R = cast(NDArray[np.float64], np.linalg.qr(np.vstack([R, Phi]), mode="r"))  # R alone
    Rr = R[:ncols, :ncols]
    rhs = R[:ncols, -1]
    sc = np.sqrt((Rr**2).sum(axis=0)) + 1e-300
    th = np.linalg.lstsq(Rr / sc, rhs, rcond=None)[0] / sc
    B = th[:nb_].reshape(n, m)
    D = th[nb_ : nb_ + nd].reshape(p, m) if feedthrough else np.zeros((p, m))
    x0s = (
        [th[nb_ + nd + e * n : nb_ + nd + (e + 1) * n] for e in range(E)]
        if est_x0
        else [np.zeros(n) for _ in range(E)]
    )
    return B, D, x0s


def _coords(L: NDArray[np.float64], i: int, m: int, p: int) -> dict[str, Any]:
    """Row blocks of the lower-triangular factor (coordinates of data matrices)."""

    def U(a: int, b: int) -> NDArray[np.float64]:
        return L[a * m : b * m]

    def Y(a: int, b: int) -> NDArray[np.float64]:
        o = 2 * i * m
        return L[o + a * p : o + b * p]

    return {"U": U, "Y": Y}


def _oblique(
    Yf: NDArray[np.float64], Wp: NDArray[np.float64], Uf: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Oblique projection ``Yf /_{Uf} Wp`` in coordinates: the ``Wp`` part of ``Yf / [Wp; Uf]``."""
    Z = np.vstack([Wp, Uf])
    Theta = np.linalg.lstsq(Z.T, Yf.T, rcond=None)[0].T
    return Theta[:, : Wp.shape[0]] @ Wp


def _decompose_factor(
    L: NDArray[np.float64], i: int, m: int, p: int, weighting: str
) -> dict[str, Any]:
    blk = _coords(L, i, m, p)
    U, Y = blk["U"], blk["Y"]
    Up, Uf, Yp, Yf = U(0, i), U(i, 2 * i), Y(0, i), Y(i, 2 * i)
    Wp = np.vstack([Up, Yp])
    Oi = _oblique(Yf, Wp, Uf)  # O_i = Y_f /_{U_f} W_p
    Oi1 = _oblique(Y(i + 1, 2 * i), np.vstack([U(0, i + 1), Y(0, i + 1)]), U(i + 1, 2 * i))
    W1inv = None

    def perp(M: NDArray[np.float64]) -> NDArray[np.float64]:
        # M Π_{U_f⊥}: remove the part in the row space of U_f
        return M - np.linalg.lstsq(Uf.T, M.T, rcond=None)[0].T @ Uf

    if weighting == "n4sid":
        Ow = Oi
    elif weighting == "moesp":
        Ow = perp(Oi)
    else:  # cva: W1 = (Y_f Π_{U_f⊥} Y_fᵀ)^{-1/2}
        Yfp = perp(Yf)
        w, V = np.linalg.eigh(Yfp @ Yfp.T)
        w = np.maximum(w, 1e-12 * max(float(w.max()), 1e-300))
        W1 = (V / np.sqrt(w)) @ V.T
        W1inv = (V * np.sqrt(w)) @ V.T
        Ow = W1 @ perp(Oi)
    Us, s, _ = np.linalg.svd(Ow, full_matrices=False)
    return {
        "U": Us,
        "s": s,
        "W1inv": W1inv,
        "Oi": Oi,
        "Oi1": Oi1,
        "Ui": U(i, i + 1),
        "Yi": Y(i, i + 1),
    }


def _default_horizon(max_order: int, p: int) -> int:
    return max(10, math.ceil(max_order / p) + 1)


@single_blas_thread
def n4sid_decompose(
    u: Sequence[NDArray[np.float64]],
    y: Sequence[NDArray[np.float64]],
    dt: float,
    *,
    horizon: int | None = None,
    max_order: int = 10,
    decimate: int | str = "auto",
    weighting: str = "moesp",
    scale: bool = True,
    chunk: int = 4096,
) -> N4SIDDecomposition:
    """Decompose deviation data once; every order is then derived from it.

    Parameters
    ----------
    u : sequence of ndarray (T_e, m)
        Inputs of each experiment, operating point already subtracted.
    y : sequence of ndarray (T_e, p)
        Outputs of each experiment.
    dt : float
        Sample period [s].
    horizon : int, optional
        Block rows ``i`` (past and future); default
        ``max(10, ceil(max_order / p) + 1)``.
    max_order : int
        Highest order that will be asked for (sets the default horizon).
    decimate : int or "auto"
        Identification at ``decimate · dt`` (see the module docstring).
    weighting : {"moesp", "cva", "n4sid"}
    scale : bool
        Divide every channel by its RMS over the training data.
    chunk : int
        Hankel columns per QR update.

    Returns
    -------
    N4SIDDecomposition

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> A = np.array([[0.9, 0.2], [0.0, 0.7]]); B = np.array([[0.0], [1.0]])
    >>> C = np.array([[1.0, 0.0]]); u = rng.normal(size=(2000, 1))
    >>> y = simulate_ss(A, B, C, np.zeros((1, 1)), u)
    >>> dec = n4sid_decompose([u], [y], 1.0, decimate=1)
    >>> dec.suggest_order(range(1, 6))
    2
    >>> sys = dec.system(2)
    >>> sorted(np.linalg.eigvals(sys.A).real.round(6).tolist())
    [0.7, 0.9]
    """
    t0 = time.perf_counter()
    us = [np.asarray(v, dtype=float) for v in u]
    ys = [np.asarray(v, dtype=float) for v in y]
    if weighting not in WEIGHTINGS:
        raise ConfigError(f"weighting is {weighting!r}; expected one of {WEIGHTINGS}")
    m, p = us[0].shape[1], ys[0].shape[1]
    i = int(horizon) if horizon is not None else _default_horizon(max_order, p)
    if i < 2:
        raise ConfigError(f"horizon is {horizon!r}; expected at least 2 block rows")
    tau = math.nan
    if decimate == "auto":
        r, tau = auto_decimation(us, ys, dt, min_samples=max(400, 4 * 2 * i * (m + p) + 2 * i))
    elif (
        isinstance(decimate, int | np.integer) and not isinstance(decimate, bool) and decimate >= 1
    ):
        r = int(decimate)
    else:
        raise ConfigError(f"decimate is {decimate!r}; expected a whole number >= 1 or 'auto'")
    if scale:
        su = np.sqrt(np.mean(np.concatenate([v**2 for v in us]), axis=0))
        sy = np.sqrt(np.mean(np.concatenate([v**2 for v in ys]), axis=0))
        su = np.where(su > 0, su, 1.0)
        sy = np.where(sy > 0, sy, 1.0)
    else:
        su, sy = np.ones(m), np.ones(p)
    # measurement noise at the fine rate (scaled): var(Δy)/2 of white noise
    noise = None
    if r > 1:
        d = np.concatenate([np.diff(v / sy, axis=0) for v in ys])
        noise = np.maximum(0.5 * np.var(d, axis=0), 1e-16)
    data = []
    fine: list[tuple[NDArray[np.float64], NDArray[np.float64]]] | None = [] if r > 1 else None
    acc = HankelAccumulator(m, p, i, chunk=chunk)
    rows = acc.rows
    for ue, ye in zip(us, ys, strict=True):
        ur, yr = decimate_data(ue / su, ye / sy, r)
        assert yr is not None
        if ur.shape[0] < 2 * i + 1:
            raise IdentificationError(
                f"an experiment has {ue.shape[0]} samples ({ur.shape[0]} after decimation by "
                f"{r}); N4SID with a horizon of {i} block rows needs at least {2 * i + 1}"
            )
        data.append((ur, yr))
        if fine is not None:
            fine.append((ue / su, ye / sy))
        acc.add(ur, yr)
        acc.end_experiment()
    if acc.n_columns < rows:
        need = rows + 2 * i - 1
        raise IdentificationError(
            f"N4SID: {acc.n_columns} Hankel columns for {rows} rows (horizon {i}, {m} inputs, "
            f"{p} outputs{f', decimation {r}' if r > 1 else ''}); give at least {need * r} "
            "samples, a lower order or a shorter horizon"
        )
    L = acc.r_factor().T
    dec = _decompose_factor(L, i, m, p, weighting)
    return N4SIDDecomposition(
        singular_values=dec["s"],
        horizon=i,
        decimate=r,
        dt=float(dt),
        n_inputs=m,
        n_outputs=p,
        weighting=weighting,
        u_scale=su,
        y_scale=sy,
        seconds=time.perf_counter() - t0,
        _U=dec["U"],
        _W1inv=dec["W1inv"],
        _Oi=dec["Oi"],
        _Oi1=dec["Oi1"],
        _Ui=dec["Ui"],
        _Yi=dec["Yi"],
        _ncol=acc.n_columns,
        _data=data,
        _noise_fine=noise,
        _fine=fine,
        info={"n_experiments": len(us), "dominant_tau_s": tau, "hankel_columns": acc.n_columns},
    )


def decomposition_from_accumulator(
    acc: HankelAccumulator, dt: float, *, weighting: str = "moesp"
) -> N4SIDDecomposition:
    """Decomposition from streamed data (no data kept: use ``bd="subspace"``).

    The accumulator must have been fed scaled deviation data at the
    identification period ``dt`` (no decimation is applied here).
    """
    if weighting not in WEIGHTINGS:
        raise ConfigError(f"weighting is {weighting!r}; expected one of {WEIGHTINGS}")
    t0 = time.perf_counter()
    L = acc.r_factor().T
    dec = _decompose_factor(L, acc.horizon, acc.m, acc.p, weighting)
    return N4SIDDecomposition(
        singular_values=dec["s"],
        horizon=acc.horizon,
        decimate=1,
        dt=float(dt),
        n_inputs=acc.m,
        n_outputs=acc.p,
        weighting=weighting,
        u_scale=np.ones(acc.m),
        y_scale=np.ones(acc.p),
        seconds=time.perf_counter() - t0,
        _U=dec["U"],
        _W1inv=dec["W1inv"],
        _Oi=dec["Oi"],
        _Oi1=dec["Oi1"],
        _Ui=dec["Ui"],
        _Yi=dec["Yi"],
        _ncol=acc.n_columns,
        _data=None,
        _noise_fine=None,
        info={"n_experiments": acc.n_experiments, "hankel_columns": acc.n_columns},
    )


# ================================================================= top level
@dataclass
class N4SIDResult:
    """Outcome of :func:`n4sid`.

    Attributes
    ----------
    fit : FitResult
        The ``ss`` FitResult.
    system : StateSpaceFit
    decomposition : N4SIDDecomposition
    order : int
    order_source : str
        ``"given"`` or ``"singular values"``.
    seconds : float
    """

    fit: FitResult
    system: StateSpaceFit
    decomposition: N4SIDDecomposition
    order: int
    order_source: str
    seconds: float


@dataclass(frozen=True)
class N4SIDProblem:
    """Checked training data of an N4SID call (names, arrays, operating points)."""

    inputs: list[str]
    disturbances: list[str]
    outputs: list[str]
    us: list[NDArray[np.float64]]
    ys: list[NDArray[np.float64]]
    ops: list[tuple[NDArray[np.float64], NDArray[np.float64]]]
    dt: float
    units: dict[str, str]
    recordings: list[Recording]
    mode: str = "none"  # the operating-point mode that made the deviations


def prepare_problem(
    recordings: Recording | Sequence[Recording],
    inputs: Sequence[str] | str,
    outputs: Sequence[str] | str,
    *,
    disturbances: Sequence[str] | None = None,
    operating_point_mode: str = "none",
    min_samples: int = 8,
    step_inputs: bool | None = None,
) -> N4SIDProblem:
    """Check recordings and return deviation arrays in model column order.

    ``step_inputs`` accepts an input held constant at a non-zero value (a step
    from zero at ``t = 0``); default: with operating point ``"rest"`` only.
    """
    inputs = [inputs] if isinstance(inputs, str) else list(inputs)
    outputs = [outputs] if isinstance(outputs, str) else list(outputs)
    if operating_point_mode not in OPERATING_POINTS:
        raise ConfigError(
            f"operating_point_mode is {operating_point_mode!r}; expected one of {OPERATING_POINTS}"
        )
    exps = signal_arrays(
        recordings,
        inputs,
        outputs,
        min_samples=min_samples,
        what="N4SID",
        step_inputs=operating_point_mode == "rest" if step_inputs is None else step_inputs,
    )
    ins, dis = exogenous_roles(exps[0].recording, inputs, disturbances)
    order = [inputs.index(c) for c in ins + dis]
    us, ys, ops = [], [], []
    for e in exps:
        u_op, y_op = operating_point(e.u, e.y, operating_point_mode)
        assert y_op is not None
        us.append((e.u - u_op)[:, order])
        ys.append(e.y - y_op)
        ops.append((u_op[order], y_op))
    rec0 = exps[0].recording
    units = {c: rec0.units[c] for c in ins + dis + outputs if c in rec0.units}
    return N4SIDProblem(
        ins,
        dis,
        outputs,
        us,
        ys,
        ops,
        exps[0].dt,
        units,
        [e.recording for e in exps],
        operating_point_mode,
    )


def system_fitresult(
    system: StateSpaceFit,
    prob: N4SIDProblem,
    *,
    settings: dict[str, Any],
    validate: Sequence[Recording] = (),
    feedthrough: bool = False,
    noise_model: bool = True,
    arrays: dict[str, Any] | None = None,
    metrics: bool = True,
) -> FitResult:
    """The ``ss`` FitResult of an identified system (with train/validation metrics)."""
    model = system.model(
        prob.inputs,
        prob.outputs,
        disturbances=prob.disturbances,
        units=prob.units,
        feedthrough=feedthrough,
        noise_model=noise_model,
    )
    exo = prob.inputs + prob.disturbances
    st = dict(settings)
    u_op = np.mean([op[0] for op in prob.ops], axis=0)
    y_op = np.mean([op[1] for op in prob.ops], axis=0)
    st["operating_point"] = {
        "mode": st.get("operating_point_mode", "none"),
        "inputs": {c: float(u_op[k]) for k, c in enumerate(exo)},
        "outputs": {c: float(y_op[k]) for k, c in enumerate(prob.outputs)},
    }
    if prob.recordings:  # the recorded ranges: what IdentifiedPlant-v0 scales by
        st.setdefault("signal_ranges", signal_ranges(prob.recordings, exo + prob.outputs))
    # the model itself carries the operating point: every simulation path applies it
    model = StateSpaceModel(**{**model.config(), "u_op": u_op.tolist(), "y_op": y_op.tolist()})
    arr = {
        "x0_train": [x.tolist() for x in system.x0],
        "eigenvalues_abs": np.abs(np.linalg.eigvals(system.A)).tolist(),
        **(arrays or {}),
    }
    fit = FitResult.from_model(
        model,
        method="n4sid",
        settings=st,
        arrays=arr,
        data=data_entries(prob.recordings, list(validate)),
        notes="paper 001 section 2.3.3: N4SID subspace identification, innovation form (3)",
    )
    if metrics:
        fit.metrics["train"] = evaluate_fit(fit, prob.recordings)
        if validate:
            fit.metrics["validation"] = evaluate_fit(fit, list(validate))
        fit.add_warnings(check_fit(fit, units=prob.units))
    return fit


def n4sid(
    recordings: Recording | Sequence[Recording],
    inputs: Sequence[str] | str,
    outputs: Sequence[str] | str,
    order: int | None = None,
    *,
    orders: Sequence[int] = range(1, 11),
    disturbances: Sequence[str] | None = None,
    horizon: int | None = None,
    decimate: int | str = "auto",
    weighting: str = "moesp",
    feedthrough: bool = False,
    x0: str = "estimate",
    bd: str = "regression",
    stable: bool = True,
    noise_model: bool = True,
    operating_point_mode: str = "none",
    validate: Recording | Sequence[Recording] = (),
) -> N4SIDResult:
    """Identify a MIMO state-space model by N4SID (paper 001, section 2.3.3).

    Parameters
    ----------
    recordings : Recording or sequence
        Training experiments (uniform, finite: prepare them first).
    inputs : sequence of str
        Exogenous columns (manipulated inputs and measured disturbances).
    outputs : sequence of str
    order : int, optional
        Model order; chosen from the singular values over ``orders`` when
        omitted (:meth:`N4SIDDecomposition.suggest_order`; for a
        cross-validated order see
        :func:`thermogym.identification.crossval.cross_validate_order`).
    orders : sequence of int
        Candidate orders for the singular-value choice.
    disturbances : sequence of str, optional
        Which inputs are disturbances (default: the recording's roles).
    horizon, decimate, weighting
        See :func:`n4sid_decompose`.
    feedthrough : bool
        Estimate ``D``.
    x0 : {"estimate", "zero"}
        Estimate the initial state of each experiment (stored in the
        FitResult's ``arrays["x0_train"]`` and used for its metrics).
    bd : {"regression", "subspace"}
    stable : bool
        Project unstable poles into the unit circle.
    noise_model : bool
        Estimate the Kalman gain ``K`` (innovation form).
    operating_point_mode : {"none", "initial", "mean"}
    validate : Recording or sequence
        Validation recordings for the FitResult's metrics.

    Returns
    -------
    N4SIDResult

    Raises
    ------
    IdentificationError
        Too few samples for horizon and order, constant input, NaN data.

    Examples
    --------
    >>> from thermogym.models.linear import StateSpaceModel
    >>> true = StateSpaceModel.from_continuous([[-1 / 300, 0.0], [1 / 600, -1 / 600]],
    ...                                        [[1 / 300], [0.0]], [[1, 0], [0, 1]], dt=10.0,
    ...                                        inputs=["P"], outputs=["T1", "T2"])
    >>> u = np.repeat(np.random.default_rng(0).integers(0, 2, 200), 20)[:, None].astype(float)
    >>> y = true.simulate(u, 10.0).outputs[0]
    >>> rec = Recording(10.0 * np.arange(u.shape[0]), {"P": u[:, 0], "T1": y[:, 0],
    ...                 "T2": y[:, 1]})
    >>> res = n4sid(rec, ["P"], ["T1", "T2"], order=2)
    >>> res.fit.metrics["train"]["mnrmse"] > 0.999
    True
    """
    t0 = time.perf_counter()
    prob = prepare_problem(
        recordings,
        inputs,
        outputs,
        disturbances=disturbances,
        operating_point_mode=operating_point_mode,
    )
    vals = [validate] if isinstance(validate, Recording) else list(validate)
    max_order = int(order) if order is not None else max(orders)
    dec = n4sid_decompose(
        prob.us,
        prob.ys,
        prob.dt,
        horizon=horizon,
        max_order=max_order,
        decimate=decimate,
        weighting=weighting,
    )
    if order is None:
        order = dec.suggest_order(orders)
        source = "singular values"
    else:
        source = "given"
    system = dec.system(
        order, x0=x0, bd=bd, feedthrough=feedthrough, stable=stable, noise_model=noise_model
    )
    seconds = time.perf_counter() - t0
    settings = {
        "order": int(order),
        "order_source": source,
        "horizon": dec.horizon,
        "decimate": dec.decimate,
        "dt": dec.dt,
        "dt_identification": dec.dt * dec.decimate,
        "dominant_time_constant_s": dec.info.get("dominant_tau_s"),
        "weighting": weighting,
        "feedthrough": bool(feedthrough),
        "x0": x0,
        "bd": bd,
        "stable": bool(stable),
        "noise_model": bool(noise_model),
        "noise_model_status": system.info.get("noise_model"),
        "eigenvalues_moved": system.info.get("eigenvalues_moved", 0),
        "operating_point_mode": operating_point_mode,
        "u_scale": dec.u_scale.tolist(),
        "y_scale": dec.y_scale.tolist(),
        "seconds": seconds,
    }
    fit = system_fitresult(
        system,
        prob,
        settings=settings,
        validate=vals,
        feedthrough=feedthrough,
        noise_model=noise_model,
        arrays={"singular_values": dec.singular_values.tolist()},
    )
    return N4SIDResult(fit, system, dec, int(order), source, seconds)


# the kernels above inline the shared linear recursion (derived cache dependencies)
module_kernels_depend_on(globals())
