"""Balanced truncation: model reduction for reference models and small targets."""

from __future__ import annotations

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from thermogym._checks import integer
from thermogym.errors import ConfigError, ParameterError
from thermogym.estimation._linalg import _mat, _spectral_radius

__all__ = ["balanced_truncation"]


# ============================================================ model reduction
def _gramian_factor(W: NDArray[np.float64]) -> NDArray[np.float64]:
    """Lower factor ``F`` with ``F Fᵀ = W`` (Cholesky, eigen-clipping if singular)."""
    W = 0.5 * (W + W.T)
    try:
        return np.asarray(np.linalg.cholesky(W), dtype=np.float64)
    except np.linalg.LinAlgError:
        w, V = np.linalg.eigh(W)
        return np.asarray(V * np.sqrt(np.clip(w, 0.0, None)), dtype=np.float64)


def balanced_truncation(
    A: ArrayLike,
    B: ArrayLike,
    C: ArrayLike,
    D: ArrayLike | None = None,
    *,
    order: int,
    method: str = "truncate",
) -> tuple[
    NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64],
    NDArray[np.float64],
]:  # fmt: skip
    """Square-root balanced reduction of a stable discrete system.

    Written here because python-control's ``balred`` needs the Fortran
    package slycot, which thermogym does not depend on; the square-root
    method (Laub; Tombs and Sorensen) takes a few lines with scipy.

    Parameters
    ----------
    A : array_like, shape (n, n)
        Discrete state matrix, spectral radius < 1.
    B : array_like, shape (n, m)
    C : array_like, shape (p, n)
    D : array_like, shape (p, m), optional
        Feedthrough (zero when omitted).
    order : int
        Order ``r`` of the reduced model, ``1 <= r <= n``.
    method : {"truncate", "residualize"}
        ``truncate`` drops the weak balanced states (exact at high
        frequency); ``residualize`` holds them at their steady state
        (singular perturbation: exact DC gain, adds a feedthrough) —
        thermal virtual sensors need the right steady temperatures.

    Returns
    -------
    Ar, Br, Cr, Dr : ndarray
        Reduced model, shapes (r, r), (r, m), (p, r), (p, m).
    hsv : ndarray, shape (n,)
        Hankel singular values of the full system (the H∞ error bound of
        either method is ``2 Σ_{i>r} hsv_i``).

    Examples
    --------
    >>> import numpy as np
    >>> A = np.diag([0.5, 0.9, 0.99]); B = np.ones((3, 1)); C = np.ones((1, 3))
    >>> Ar, Br, Cr, Dr, hsv = balanced_truncation(A, B, C, order=3)
    >>> bool(np.allclose(np.sort(np.linalg.eigvals(Ar).real), [0.5, 0.9, 0.99]))
    True
    >>> Ar, Br, Cr, Dr, _ = balanced_truncation(A, B, C, order=1, method="residualize")
    >>> dc = Cr @ np.linalg.solve(np.eye(1) - Ar, Br) + Dr
    >>> round(float(dc[0, 0]), 9), round(float(1 / 0.5 + 1 / 0.1 + 1 / 0.01), 9)
    (112.0, 112.0)
    """
    Aa = np.asarray(A, dtype=float)
    n = Aa.shape[0] if Aa.ndim == 2 else -1
    Aa = _mat("A", Aa, (n, n))
    Ba = np.asarray(B, dtype=float)
    Ba = _mat("B", Ba, (n, Ba.shape[1] if Ba.ndim == 2 else -1))
    Ca = np.asarray(C, dtype=float)
    Ca = _mat("C", Ca, (Ca.shape[0] if Ca.ndim == 2 else -1, n))
    p, m = Ca.shape[0], Ba.shape[1]
    Da = np.zeros((p, m)) if D is None else _mat("D", D, (p, m))
    order = integer("order", order, lo=1, hi=n)
    if method not in ("truncate", "residualize"):
        raise ConfigError(f"method is {method!r}; expected 'truncate' or 'residualize'")
    rho = _spectral_radius(Aa)
    if rho >= 1.0:
        raise ParameterError(f"A has spectral radius {rho:.6g} >= 1; balancing needs a stable A")
    Wc = scipy.linalg.solve_discrete_lyapunov(Aa, Ba @ Ba.T)  # Wc = A Wc Aᵀ + B Bᵀ
    Wo = scipy.linalg.solve_discrete_lyapunov(Aa.T, Ca.T @ Ca)  # Wo = Aᵀ Wo A + Cᵀ C
    Lc, Lo = _gramian_factor(Wc), _gramian_factor(Wo)
    U, s, Vt = np.linalg.svd(Lo.T @ Lc)
    r = int(order)
    if s[r - 1] <= 1e-14 * s[0]:
        raise ParameterError(
            f"Hankel singular value {r} is {s[r - 1]:.3g} (relative {s[r - 1] / s[0]:.3g}); the "
            f"system has fewer than {r} controllable and observable states"
        )
    if method == "truncate" or r == n:
        Si = np.diag(s[:r] ** -0.5)
        T = Lc @ Vt[:r].T @ Si  # x = T x_r
        Ti = Si @ U[:, :r].T @ Lo.T  # x_r = Ti x
        return Ti @ Aa @ T, Ti @ Ba, Ca @ T, Da.copy(), s
    k = int(np.sum(s > 1e-14 * s[0]))  # balance the minimal part only
    Si = np.diag(s[:k] ** -0.5)
    T = Lc @ Vt[:k].T @ Si
    Ti = Si @ U[:, :k].T @ Lo.T
    Ab, Bb, Cb = Ti @ Aa @ T, Ti @ Ba, Ca @ T
    A11, A12, A21, A22 = Ab[:r, :r], Ab[:r, r:], Ab[r:, :r], Ab[r:, r:]
    # weak states at their steady state: x2 = (I − A22)⁻¹ (A21 x1 + B2 u)
    E = np.eye(k - r) - A22
    X = np.linalg.solve(E, np.hstack([A21, Bb[r:]]))
    Ar = A11 + A12 @ X[:, :r]
    Br = Bb[:r] + A12 @ X[:, r:]
    Cr = Cb[:, :r] + Cb[:, r:] @ X[:, :r]
    Dr = Da + Cb[:, r:] @ X[:, r:]
    return Ar, Br, Cr, Dr, s
