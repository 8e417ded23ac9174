"""Scoring hypotheses under coloured noise: effective sample size, an IC, a held-out test.

Sensor noise of thermal plants is coloured (a thermocouple's Gauss-Markov
wander, a room sensor drifting with the air), so the simulation residual of a
*correct* model is autocorrelated: Ljung's whiteness test fails for every
model, right or wrong, and ``N`` residual samples carry far fewer than ``N``
independent pieces of evidence. The diagnosis therefore decides with

* an **information criterion on the effective sample size**: for a model
  ``h`` with ``k`` more parameters than the model ``0`` it extends, and
  weighted squared simulation errors ``S``::

      ΔIC = N_eff ln(S_h / S_0) + k ln N_eff,       N_eff = Σ_r N_r / τ_r

  (Schwarz's BIC for Gaussian errors, Schwarz 1978, with the sample count
  replaced by the number of effectively independent samples; ``τ_r`` is the
  integrated autocorrelation time ``1 + 2 Σ ρ(k)`` of the parent's residual,
  summed over lags up to its first non-positive autocorrelation, Sokal's
  window); among ``M`` candidates of one round, a prior spread evenly over
  them adds ``2 ln M`` (the extended BIC of Chen & Chen 2008);

* a **held-out test of improvement beyond the noise**: the reduction of the
  held-out squared error ``D = Σ_k d_k``, ``d_k = S_0,k − S_h,k``, against
  its standard error from batch means over each recording (blocks of twice
  the loss differential's autocorrelation time: a HAC estimate as in the
  Diebold-Mariano test, Diebold & Mariano 1995). ``z = D / se(D)`` must
  exceed the normal quantile at ``α / M`` (Bonferroni over the round).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray
from scipy import stats

__all__ = ["autocorrelation_time", "delta_ic", "effective_n", "improvement_z", "z_threshold"]

#: Largest lag of the autocorrelation-time sum.
_MAX_LAG = 2000


def autocorrelation_time(e: NDArray[np.float64]) -> float:
    """Integrated autocorrelation time ``1 + 2 Σ_{k≥1} ρ(k)`` of a series, in samples.

    The sum runs up to the first lag whose autocorrelation is not positive
    (Sokal's adaptive window); at least 1.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.signal import lfilter
    >>> e = lfilter([1.0], [1.0, -0.9], np.random.default_rng(0).standard_normal(100000))
    >>> round(autocorrelation_time(e))  # (1 + 0.9) / (1 − 0.9)
    19
    """
    x = np.asarray(e, dtype=float)
    x = x[np.isfinite(x)]
    n = x.size
    if n < 4:
        return 1.0
    x = x - x.mean()
    f = np.fft.rfft(x, n=2 * n)
    ac = np.fft.irfft(f * np.conj(f))[: min(n, _MAX_LAG + 1)]
    if ac[0] <= 0:
        return 1.0
    rho = ac / ac[0]
    neg = np.flatnonzero(rho[1:] <= 0.0)
    m = int(neg[0]) + 1 if neg.size else rho.size
    return float(max(1.0, 1.0 + 2.0 * np.sum(rho[1:m])))


def effective_n(
    residuals: Sequence[NDArray[np.float64]], weights: NDArray[np.float64]
) -> float:
    """Effectively independent samples of residuals (T, n_y) per recording.

    Per recording and output ``N / τ``, weighted by the output's share of the
    squared error, summed over recordings.

    Examples
    --------
    >>> import numpy as np
    >>> e = np.random.default_rng(0).standard_normal((5000, 1))
    >>> 4000 < effective_n([e], np.ones(1)) <= 5000
    True
    """
    total = 0.0
    for r in residuals:
        r = np.asarray(r, dtype=float)
        ss = np.array([np.nansum((r[:, j] * weights[j]) ** 2) for j in range(r.shape[1])])
        share = ss / ss.sum() if ss.sum() > 0 else np.full(r.shape[1], 1.0 / r.shape[1])
        for j in range(r.shape[1]):
            n = int(np.isfinite(r[:, j]).sum())
            if n:
                total += share[j] * n / autocorrelation_time(r[:, j])
    return float(max(total, 2.0))


def delta_ic(s_new: float, s_old: float, k: float, n_eff: float) -> float:
    """``N_eff ln(S_new / S_old) + k ln N_eff`` (negative favours the new model).

    Examples
    --------
    >>> round(delta_ic(90.0, 100.0, 1, 1000.0), 3)
    -98.455
    """
    if not (math.isfinite(s_new) and math.isfinite(s_old)) or s_new <= 0 or s_old <= 0:
        return math.inf
    n = max(float(n_eff), 2.0)
    return n * math.log(s_new / s_old) + k * math.log(n)


def improvement_z(
    old: Sequence[NDArray[np.float64]],
    new: Sequence[NDArray[np.float64]],
    weights: NDArray[np.float64],
) -> float:
    """``z`` of the held-out squared-error reduction ``D`` against its batch-means error.

    Parameters
    ----------
    old, new : sequence of ndarray (T, n_y)
        Residuals of the parent and of the hypothesis, per recording.
    weights : ndarray (n_y,)

    Returns
    -------
    float
        ``D / se(D)``; ``+inf`` when ``D > 0`` is exact (no spread), NaN
        without samples.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> e = rng.standard_normal((4000, 1))
    >>> z_same = improvement_z([e + 0.01 * rng.standard_normal((4000, 1))], [e], np.ones(1))
    >>> z_real = improvement_z([e + 0.3], [e], np.ones(1))
    >>> bool(abs(z_same) < 4 and z_real > 10)
    True
    """
    blocks: list[float] = []
    D = 0.0
    n_all = 0
    ds = []
    for a, b in zip(old, new, strict=True):
        d = np.nansum(((a * weights) ** 2 - (b * weights) ** 2), axis=1)
        ok = np.isfinite(a).all(axis=1) & np.isfinite(b).all(axis=1)
        d = d[ok]
        if d.size:
            ds.append(d)
    if not ds:
        return math.nan
    tau = max(autocorrelation_time(np.concatenate(ds)), 1.0)
    L = max(2, math.ceil(2.0 * tau))
    for d in ds:
        D += float(d.sum())
        n_all += d.size
        nb = max(1, d.size // L)
        for part in np.array_split(d, nb):
            blocks.append(float(part.sum()) - 0.0)
    mean = D / n_all
    # batch means: blocks of (nearly) equal length, centred on the mean differential
    sizes = []
    for d in ds:
        nb = max(1, d.size // L)
        sizes += [p.size for p in np.array_split(d, nb)]
    dev = np.array(blocks) - mean * np.array(sizes)
    nb = len(blocks)
    var = float(np.sum(dev**2)) * nb / max(nb - 1, 1)
    if var <= 0:
        return math.inf if D > 0 else (0.0 if D == 0 else -math.inf)
    return D / math.sqrt(var)


def z_threshold(alpha: float, m: int) -> float:
    """One-sided normal quantile at ``α / m`` (Bonferroni over ``m`` candidates).

    Examples
    --------
    >>> round(z_threshold(0.01, 1), 3)
    2.326
    """
    return float(stats.norm.isf(alpha / max(int(m), 1)))
