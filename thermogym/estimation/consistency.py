"""Filter consistency: NEES, NIS and chi-square tests of an estimator."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.stats
from numpy.typing import ArrayLike, NDArray

from thermogym._checks import integer, probability
from thermogym.errors import ShapeError

__all__ = ["ConsistencyReport", "consistency", "normalized_error_squared"]


# ============================================================== consistency
def normalized_error_squared(err: ArrayLike, cov: ArrayLike) -> NDArray[np.float64]:
    """``eᵀ P⁻¹ e`` per sample: NEES for estimation errors, NIS for innovations.

    Parameters
    ----------
    err : array_like, shape (T, d)
        Errors (truth − estimate) or innovations; rows with NaN give NaN.
    cov : array_like, shape (T, d, d) or (d, d)
        Their covariance.

    Returns
    -------
    ndarray, shape (T,)
        NaN where an error or covariance is not finite; ``inf`` where the
        covariance is singular and the error lies outside its range.

    Examples
    --------
    >>> normalized_error_squared([[1.0, 2.0]], [[1.0, 0.0], [0.0, 4.0]]).tolist()
    [2.0]
    """
    e = np.asarray(err, dtype=float)
    if e.ndim == 1:
        e = e[:, None]
    T, d = e.shape
    P = np.asarray(cov, dtype=float)
    if P.shape == (d, d):
        P = np.broadcast_to(P, (T, d, d))
    if P.shape != (T, d, d):
        raise ShapeError(f"cov has shape {np.shape(cov)}, expected ({T}, {d}, {d}) or ({d}, {d})")
    out = np.full(T, np.nan)
    ok = np.isfinite(e).all(axis=1) & np.isfinite(P).all(axis=(1, 2))
    if d == 0:
        return out
    idx = np.flatnonzero(ok)
    if idx.size:
        try:
            sol = np.linalg.solve(P[idx], e[idx][:, :, None])[:, :, 0]
            out[idx] = np.einsum("ti,ti->t", e[idx], sol)
        except np.linalg.LinAlgError:
            # a singular covariance (a state known exactly): pseudo-inverse; an error
            # outside its range is infinitely unlikely
            for t in idx:
                Pi = np.linalg.pinv(P[t])
                et = e[t]
                resid = et - P[t] @ (Pi @ et)
                scale = max(float(np.abs(et).max()), 1e-300)
                out[t] = np.inf if np.abs(resid).max() > 1e-9 * scale else float(et @ Pi @ et)
    return out


@dataclass(frozen=True)
class ConsistencyReport:
    """Chi-square consistency test of a NEES or NIS series.

    Attributes
    ----------
    mean : float
        Average of the series (ANEES / ANIS); a consistent filter gives ``dof``.
    dof : int
        Degrees of freedom (dimension of the error).
    n_samples : int
        Finite samples used.
    n_effective : float
        Effective number of independent samples (the series is autocorrelated;
        batch-means estimate of the integrated autocorrelation time).
    mean_bounds : (float, float)
        Two-sided ``1 − alpha`` interval of the mean for a consistent filter,
        ``χ²(N_eff·dof) / N_eff``.
    fraction_inside : float
        Share of samples inside the per-sample interval ``χ²_dof(alpha/2 ..
        1 − alpha/2)``; ``1 − alpha`` for a consistent filter.
    consistent : bool
        ``mean`` lies inside ``mean_bounds``.
    alpha : float
    """

    mean: float
    dof: int
    n_samples: int
    n_effective: float
    mean_bounds: tuple[float, float]
    fraction_inside: float
    consistent: bool
    alpha: float

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {
            "mean": self.mean,
            "dof": self.dof,
            "n_samples": self.n_samples,
            "n_effective": self.n_effective,
            "mean_bounds": list(self.mean_bounds),
            "fraction_inside": self.fraction_inside,
            "consistent": self.consistent,
            "alpha": self.alpha,
        }


def consistency(values: ArrayLike, dof: int, *, alpha: float = 0.05) -> ConsistencyReport:
    """Chi-square test of a NEES/NIS series (Bar-Shalom et al., 5.4.2).

    Parameters
    ----------
    values : array_like, shape (T,)
        NEES or NIS values (NaN ignored, ``inf`` fails the test).
    dof : int
        Dimension of the error vector.
    alpha : float
        Significance level of the two-sided tests.

    Returns
    -------
    ConsistencyReport

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> e = rng.normal(size=(5000, 2))
    >>> rep = consistency(normalized_error_squared(e, np.eye(2)), dof=2)
    >>> rep.consistent, bool(0.94 < rep.fraction_inside < 0.97)
    (True, True)
    """
    v = np.asarray(values, dtype=float).reshape(-1)
    v = v[~np.isnan(v)]  # inf (an impossible error) stays and fails the test
    dof = integer("dof", dof, lo=1)
    probability("alpha", alpha, text=False)
    N = v.size
    if N < 2:
        raise ShapeError(f"{N} finite values; the consistency test needs at least 2")
    mean = float(v.mean())
    if not np.isfinite(mean):
        return ConsistencyReport(mean, int(dof), N, float(N), (0.0, 0.0), 0.0, False, alpha)
    # integrated autocorrelation time by batch means (batches of √N samples)
    b = max(1, int(math.sqrt(N)))
    nb_ = N // b
    var = float(v.var())
    if nb_ >= 2 and var > 0:
        bm = v[: nb_ * b].reshape(nb_, b).mean(axis=1)
        tau = max(1.0, b * float(bm.var(ddof=1)) / var)
    else:
        tau = 1.0
    n_eff = N / tau
    k = n_eff * dof
    lo = float(scipy.stats.chi2.ppf(alpha / 2, k)) / n_eff
    hi = float(scipy.stats.chi2.ppf(1 - alpha / 2, k)) / n_eff
    plo = float(scipy.stats.chi2.ppf(alpha / 2, dof))
    phi = float(scipy.stats.chi2.ppf(1 - alpha / 2, dof))
    inside = float(np.mean((v >= plo) & (v <= phi)))
    return ConsistencyReport(mean, int(dof), N, n_eff, (lo, hi), inside, lo <= mean <= hi, alpha)
