"""An identified N4SID system and the least-squares steps that complete it.

:class:`StateSpaceFit` is one order's model at the data's sample period. Given
``A`` and ``C`` from the decomposition, ``B``, ``D`` and the initial states are
regressed on the data (:func:`_regress_bd`), the output map is re-estimated at
the data period after decimation (:func:`_fine_output_map`), the Kalman gain
solves the filter Riccati equation (:func:`_kalman_gain`) and unstable
eigenvalues are mirrored in the real Schur form (:func:`_mirror_schur`).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, cast

import numpy as np
import scipy.linalg
from numpy.typing import NDArray
from scipy.signal import fftconvolve

from thermogym.errors import ConfigError
from thermogym.identification._n4sid_decimation import decimate_data
from thermogym.identification._n4sid_kernels import _obs_seq, _states, simulate_ss
from thermogym.models._blas import blas_threads
from thermogym.models.linear import StateSpaceModel

__all__ = ["StateSpaceFit"]


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
