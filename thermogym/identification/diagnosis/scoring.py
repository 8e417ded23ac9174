"""Scoring hypotheses under coloured noise: a whitened likelihood ratio and an IC.

Sensor noise of thermal plants is coloured (a thermocouple's Gauss-Markov
wander, a room sensor drifting with the air), so the simulation residual of a
*correct* model is autocorrelated: Ljung's whiteness test fails for every
model, right or wrong, and comparing raw squared errors rewards whatever
follows the slow part of the noise. A hypothesis ``h`` is compared with the
model ``0`` it extends by the likelihood ratio of their residuals under one
autoregressive noise model, the prediction-error view of Ljung (*System
Identification*, 2nd ed., sec. 7.3)::

    e[k] = Σ_{i=1..p} a_i e[k−i] + ε[k],   ε ~ N(0, σ²)          (fitted to h's residual)
    w_m[k] = e_m[k] − Σ a_i e_m[k−i]                              (m = 0, h: the same filter)
    χ² = Σ_outputs (Σ_k w_0[k]² − Σ_k w_h[k]²) / σ̂²

The noise model (order ``p`` by BIC, at most :data:`MAX_AR_ORDER`) is fitted
to the hypothesis' own residual: if it is right, that residual *is* the
noise. ``χ²`` is twice the log-likelihood ratio of the two models under that
noise; the information criterion of a hypothesis with ``k`` more parameters
is Schwarz's::

    ΔIC = −χ² + k ln N                          (negative favours h)

and among ``M`` candidates of one round a prior spread evenly over them adds
``2 ln M`` to the threshold (the extended BIC of Chen & Chen 2008). On held-out
data the parameters fitted on the training data are penalised too, which
guards against the optimism of picking the best of many; parameters
re-estimated on every held-out recording (a disturbance's course) count once
per recording.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

__all__ = ["MAX_AR_ORDER", "ar_filter", "delta_ic", "whitened_chi2"]

#: Largest order of the AR noise model.
MAX_AR_ORDER = 8


def ar_filter(
    es: Sequence[NDArray[np.float64]], max_order: int = MAX_AR_ORDER
) -> tuple[NDArray[np.float64], float]:
    """AR coefficients (order by BIC) of residual series and the innovation variance.

    Yule-Walker equations of the pooled autocovariance (each recording's own,
    weighted by its length), solved for every order at once by the
    Levinson-Durbin recursion; the order minimises ``N ln σ̂²_p + p ln N``.

    Parameters
    ----------
    es : sequence of ndarray
        One residual series per recording (NaN where not measured).
    max_order : int

    Returns
    -------
    a : ndarray, shape (p,)
        ``e[k] ≈ Σ a_i e[k−i]``.
    sigma2 : float
        Innovation variance (NaN without samples).

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.signal import lfilter
    >>> e = lfilter([1.0], [1.0, -0.9], np.random.default_rng(0).standard_normal(20000))
    >>> a, s2 = ar_filter([e])
    >>> round(float(a[0]), 1), round(float(s2), 1)
    (0.9, 1.0)
    """
    r = np.zeros(max_order + 1)
    n = 0
    for e in es:
        x = np.asarray(e, dtype=float)
        x = np.where(np.isfinite(x), x, 0.0)
        m = x.size
        if m <= max_order + 1:
            continue
        f = np.fft.rfft(x, n=2 * m)
        ac = np.fft.irfft(f * np.conj(f))[: max_order + 1]
        r += ac  # Σ_k e[k] e[k+i]: the biased estimate times m, pooled over recordings
        n += m
    if n == 0 or r[0] <= 0:
        return np.zeros(0), math.nan
    r /= n
    # Levinson-Durbin: a_p and the prediction error variance for p = 0..max_order
    best_bic, best = n * math.log(r[0]), (np.zeros(0), float(r[0]))
    a = np.zeros(0)
    err = float(r[0])
    for p in range(1, max_order + 1):
        k = (r[p] - float(a @ r[1:p][::-1])) / err if err > 0 else 0.0
        a = np.concatenate([a - k * a[::-1], [k]])
        err *= 1.0 - k * k
        if not err > 0:
            break
        bic = n * math.log(err) + p * math.log(n)
        if bic < best_bic - 1e-9:
            best_bic, best = bic, (a.copy(), err)
    return best[0], float(best[1])


def _whiten(e: NDArray[np.float64], a: NDArray[np.float64]) -> NDArray[np.float64]:
    p = a.size
    if p == 0:
        return e[np.isfinite(e)]
    n = e.size
    if n <= p:
        return np.zeros(0)
    w = e[p:].copy()
    for i in range(p):
        w -= a[i] * e[p - i - 1 : n - i - 1]
    return w[np.isfinite(w)]


def whitened_chi2(
    old: Sequence[NDArray[np.float64]], new: Sequence[NDArray[np.float64]]
) -> tuple[float, int]:
    """``χ²`` of the improvement from residuals ``old`` to ``new`` (module docstring), and N.

    Parameters
    ----------
    old, new : sequence of ndarray (T, n_y)
        Residuals of the parent and of the hypothesis, per recording.

    Returns
    -------
    chi2 : float
        Positive when ``new`` is better.
    n : int
        Whitened samples compared.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.signal import lfilter
    >>> rng = np.random.default_rng(0)
    >>> noise = lfilter([1.0], [1.0, -0.95], 0.1 * rng.standard_normal((5000, 1)), axis=0)
    >>> step = (np.arange(5000) % 500 < 250)[:, None] * 0.2
    >>> chi_none, n = whitened_chi2([noise + 0.001], [noise])
    >>> chi_real, n = whitened_chi2([noise + step], [noise])
    >>> bool(abs(chi_none) < 10 and chi_real > 100)
    True
    """
    n_y = new[0].shape[1] if new else 0
    total, n_all = 0.0, 0
    for j in range(n_y):
        eh = [np.asarray(r[:, j], dtype=float) for r in new]
        e0 = [np.asarray(r[:, j], dtype=float) for r in old]
        a, s2 = ar_filter(eh)
        if not (math.isfinite(s2) and s2 > 0):
            continue
        w0 = np.concatenate([_whiten(x, a) for x in e0])
        wh = np.concatenate([_whiten(x, a) for x in eh])
        if w0.size != wh.size or not np.isfinite(w0).all():
            return -math.inf, n_all
        total += float(w0 @ w0 - wh @ wh) / float(s2)
        n_all += wh.size
    return total, n_all


def delta_ic(chi2: float, k: float, n: int) -> float:
    """``−χ² + k ln N`` (negative favours the new model).

    Examples
    --------
    >>> round(delta_ic(20.0, 1, 1000), 3)
    -13.092
    """
    if not math.isfinite(chi2) or n < 2:
        return math.inf
    return -chi2 + k * math.log(n)
