"""Small shared helpers of the estimation package: matrix checks and factors."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from thermogym.errors import ParameterError, ShapeError


def _mat(name: str, value: ArrayLike, shape: tuple[int, int]) -> NDArray[np.float64]:
    a = np.asarray(value, dtype=float)
    if a.ndim == 0 and shape == (1, 1):
        a = a.reshape(1, 1)
    if a.shape != shape:
        raise ShapeError(f"{name} has shape {a.shape}, expected {shape}")
    if not np.isfinite(a).all():
        r, c = np.argwhere(~np.isfinite(a))[0]
        raise ParameterError(f"{name}[{r}, {c}] is {a[r, c]!r}; expected a finite number")
    return a


def _check_psd(name: str, M: NDArray[np.float64], *, definite: bool = False) -> None:
    if M.size == 0:
        return
    if not np.allclose(M, M.T, rtol=1e-9, atol=1e-12 * max(1.0, float(np.abs(M).max()))):
        raise ParameterError(f"{name} is not symmetric; a covariance must be")
    w = np.linalg.eigvalsh(0.5 * (M + M.T))
    tol = 1e-10 * max(1.0, float(np.abs(w).max()))
    if definite and w.min() <= 0:
        raise ParameterError(
            f"{name} has eigenvalue {w.min():.3g}; expected a positive definite covariance "
            "(every measured channel needs some noise)"
        )
    if w.min() < -tol:
        raise ParameterError(
            f"{name} has eigenvalue {w.min():.3g}; expected a positive semi-definite covariance"
        )


def _psd_sqrt_rows(P: NDArray[np.float64]) -> NDArray[np.float64]:
    """Upper factor ``U`` with ``Uᵀ U = P``: Cholesky, or eigen-clipping when P is singular."""
    try:
        return scipy.linalg.cholesky(P, lower=False)
    except (np.linalg.LinAlgError, scipy.linalg.LinAlgError):
        w, V = np.linalg.eigh(0.5 * (P + P.T))
        return (V * np.sqrt(np.clip(w, 0.0, None))).T


def _spectral_radius(A: NDArray[np.float64]) -> float:
    return float(np.abs(np.linalg.eigvals(A)).max()) if A.size else 0.0


def _names(value: Sequence[str] | str, what: str) -> tuple[str, ...]:
    if isinstance(value, str):
        return (value,)
    return tuple(str(v) for v in value)
