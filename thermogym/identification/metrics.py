"""Fit metrics of the three papers.

==========================  ==============================================  =====================
metric                      definition                                      source
==========================  ==============================================  =====================
SSE                         Σ_k (y_k − ŷ_k)²                                000 eq (1)
RMSE                        √(SSE / N)                                      000 eq (2)
weighted criterion          Σ_j w_j RMSE_j                                  000 eq (4)
NRMSE fit                   1 − ‖y − ŷ‖ / ‖y − mean(y)‖                     001 eq (5)
MNRMSE                      mean of NRMSE over outputs                      001 eq (6)
TA / VA                     mean MNRMSE over folds, own / other data        001 eqs (7)-(9)
accuracy ξ                  1 − ‖y_m − y‖ / ‖y‖                             002 eq (22)
confidence interval P       x̄ ± t σ / √n                                    002 eq (23)
==========================  ==============================================  =====================

**One name and scale.** The NRMSE fit of 001 eq (5) is *the fit* (MATLAB's
``compare`` calls it "fit" too). The API and every JSON file (FitResult
metrics ``nrmse``/``mnrmse``, cross-validation ``TA``/``VA``) hold it as a
**fraction** (1 = perfect, 0 = as good as the output's mean, below 0 =
worse); everything a person reads (command output, reports, figures) shows
the same number as **percent** with the word "fit", through :func:`fit_text`:
``0.843`` is shown as ``fit 84.30 %``.

All functions take arrays whose **last axis is time**, so a batch of
simulations ``(B, T)`` or several outputs ``(n_y, T)`` are evaluated at once;
they return one value per leading index. Samples where the measurement is NaN
are ignored (asynchronous or gappy data); a series with no valid sample gives
NaN, never a silent number.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import stats

from thermogym.errors import ShapeError

__all__ = [
    "accuracy_xi",
    "confidence_interval",
    "fit_report",
    "fit_text",
    "mnrmse",
    "nrmse",
    "rmse",
    "sse",
    "train_validation_accuracy",
    "weighted_criterion",
]


def _pair(y: ArrayLike, yhat: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    a = np.asarray(y, dtype=float)
    b = np.asarray(yhat, dtype=float)
    try:
        a, b = np.broadcast_arrays(a, b)
    except ValueError:
        raise ShapeError(
            f"measured data has shape {a.shape} and prediction {b.shape}; they must "
            "broadcast, with time on the last axis"
        ) from None
    return a, b


def _masked(y: NDArray[np.float64], yhat: NDArray[np.float64]) -> NDArray[np.bool_]:
    return np.isfinite(y) & np.isfinite(yhat)


def sse(y: ArrayLike, yhat: ArrayLike) -> NDArray[np.float64] | float:
    """Sum of squared errors, eq (1) of 000_24627a5308ee07db.txt.

    Parameters
    ----------
    y, yhat : array_like, time on the last axis
        Measured and simulated series.

    Returns
    -------
    float or ndarray
        One value per leading index; NaN where no sample is valid.

    Examples
    --------
    >>> sse([1.0, 2.0, 3.0], [1.0, 2.0, 5.0])
    4.0
    """
    a, b = _pair(y, yhat)
    m = _masked(a, b)
    e2 = np.where(m, (a - b) ** 2, 0.0)
    out = np.where(m.any(axis=-1), e2.sum(axis=-1), np.nan)
    return float(out) if out.ndim == 0 else out


def rmse(y: ArrayLike, yhat: ArrayLike) -> NDArray[np.float64] | float:
    """Root-mean-square error, eq (2) of 000_24627a5308ee07db.txt.

    Examples
    --------
    >>> rmse([0.0, 0.0, 0.0, 0.0], [1.0, -1.0, 1.0, -1.0])
    1.0
    """
    a, b = _pair(y, yhat)
    m = _masked(a, b)
    n = m.sum(axis=-1)
    e2 = np.where(m, (a - b) ** 2, 0.0).sum(axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.where(n > 0, np.sqrt(e2 / np.maximum(n, 1)), np.nan)
    return float(out) if out.ndim == 0 else out


def weighted_criterion(
    y: Mapping[str, ArrayLike] | Sequence[ArrayLike],
    yhat: Mapping[str, ArrayLike] | Sequence[ArrayLike],
    weights: Mapping[str, float] | Sequence[float] | None = None,
) -> float | NDArray[np.float64]:
    """Weighted multi-signal criterion Σ_j w_j RMSE_j, eq (4) of 000_24627a5308ee07db.txt.

    Parameters
    ----------
    y, yhat : mapping of name to array, or sequences in the same order
        Signal pairs (measured, simulated); a simulated array may carry a
        leading batch axis, giving one criterion per parameter set.
    weights : mapping or sequence, optional
        Weight of each pair (1 when omitted).

    Examples
    --------
    >>> weighted_criterion({"a": [0, 0], "b": [0, 0]}, {"a": [1, 1], "b": [2, 2]},
    ...                    {"a": 1.0, "b": 0.5})
    2.0
    """
    if isinstance(y, Mapping):
        if not isinstance(yhat, Mapping):
            raise ShapeError("give measured and simulated signals both as mappings")
        names = list(y)
        missing = [n for n in names if n not in yhat]
        if missing:
            raise ShapeError(f"simulated signals lack {missing}; measured are {names}")
        ys = [y[n] for n in names]
        yh = [yhat[n] for n in names]
        if weights is None:
            w = [1.0] * len(names)
        elif isinstance(weights, Mapping):
            w = [float(weights.get(n, 0.0)) for n in names]
        else:
            w = [float(v) for v in weights]
    else:
        ys, yh = list(y), list(yhat)
        w = [1.0] * len(ys) if weights is None else [float(v) for v in weights]  # type: ignore[union-attr]
    if not (len(ys) == len(yh) == len(w)):
        raise ShapeError(
            f"{len(ys)} measured, {len(yh)} simulated signals and {len(w)} weights; they must match"
        )
    total = sum(wj * np.asarray(rmse(a, b)) for wj, a, b in zip(w, ys, yh, strict=True))
    return float(total) if np.ndim(total) == 0 else np.asarray(total)


def nrmse(y: ArrayLike, yhat: ArrayLike) -> NDArray[np.float64] | float:
    """NRMSE goodness of fit ``1 − ‖y − ŷ‖ / ‖y − mean(y)‖``, eq (5) of 001.

    1 is a perfect fit, 0 no better than the mean, negative worse than the mean.
    A constant measured series has no variance to explain: its fit is NaN.

    Examples
    --------
    >>> round(nrmse([1.0, 2.0, 3.0, 4.0], [1.0, 2.0, 3.0, 4.0]), 6)
    1.0
    >>> round(nrmse([1.0, 2.0, 3.0, 4.0], [2.5, 2.5, 2.5, 2.5]), 6)
    0.0
    """
    a, b = _pair(y, yhat)
    m = _masked(a, b)
    n = m.sum(axis=-1, keepdims=True)
    mean = np.where(m, a, 0.0).sum(axis=-1, keepdims=True) / np.maximum(n, 1)
    num = np.sqrt(np.where(m, (a - b) ** 2, 0.0).sum(axis=-1))
    den = np.sqrt(np.where(m, (a - mean) ** 2, 0.0).sum(axis=-1))
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.where(den > 0, 1.0 - num / np.where(den > 0, den, 1.0), np.nan)
    return float(out) if out.ndim == 0 else out


def mnrmse(y: ArrayLike, yhat: ArrayLike) -> NDArray[np.float64] | float:
    """Mean NRMSE over outputs, eq (6) of 001_6d13a2cd04f5de5e.txt.

    Parameters
    ----------
    y, yhat : array_like, shape (..., n_y, T)
        Outputs on the axis before time; leading axes (e.g. a batch) are kept.

    Examples
    --------
    >>> y = [[1.0, 2.0, 3.0], [0.0, 1.0, 0.0]]
    >>> round(mnrmse(y, y), 6)
    1.0
    """
    fits = np.atleast_1d(np.asarray(nrmse(y, yhat)))
    out = np.nanmean(fits, axis=-1)
    return float(out) if np.ndim(out) == 0 else out


def accuracy_xi(y: ArrayLike, ym: ArrayLike) -> NDArray[np.float64] | float:
    """Simulation accuracy ``ξ = 1 − ‖y_m − y‖₂ / ‖y‖₂``, eq (22) of 002.

    Parameters
    ----------
    y : array_like
        Measured series.
    ym : array_like
        Simulated series.

    Examples
    --------
    >>> round(accuracy_xi([3.0, 4.0], [3.0, 4.0]), 6)
    1.0
    """
    a, b = _pair(y, ym)
    m = _masked(a, b)
    num = np.sqrt(np.where(m, (a - b) ** 2, 0.0).sum(axis=-1))
    den = np.sqrt(np.where(m, a**2, 0.0).sum(axis=-1))
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.where(den > 0, 1.0 - num / np.where(den > 0, den, 1.0), np.nan)
    return float(out) if out.ndim == 0 else out


def confidence_interval(
    samples: ArrayLike, gamma: float = 0.99, axis: int = 0, t: float | None = None
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Confidence interval of the mean ``x̄ ± t σ/√n``, eq (23) of 002.

    Parameters
    ----------
    samples : array_like
        Repeated measurements (e.g. 15 actuators' strokes) along ``axis``.
    gamma : float
        Confidence level (paper: 99 %).
    axis : int
        Axis of the repetitions.
    t : float, optional
        Student factor; by default the two-sided quantile for ``n − 1``
        degrees of freedom (the paper uses 2.98 for n = 15, γ = 99 %).

    Returns
    -------
    lower, upper : ndarray
    """
    x = np.asarray(samples, dtype=float)
    n = x.shape[axis]
    if n < 2:
        raise ShapeError(f"a confidence interval needs at least 2 samples along axis {axis}")
    mean = np.nanmean(x, axis=axis)
    sigma = np.nanstd(x, axis=axis, ddof=1)
    tf = float(stats.t.ppf(0.5 + gamma / 2, n - 1)) if t is None else float(t)
    half = tf * sigma / np.sqrt(n)
    return mean - half, mean + half


def train_validation_accuracy(
    fits: NDArray[np.float64] | Sequence[Sequence[float]],
) -> tuple[float, float]:
    """Training accuracy TA and validation accuracy VA from a k-fold matrix, eqs (7)-(9).

    Parameters
    ----------
    fits : array_like, shape (k, k)
        ``fits[i, j] = test(M^i, D^j)``: MNRMSE of the model trained on fold
        ``i`` evaluated on fold ``j``.

    Returns
    -------
    TA, VA : float
        Mean of the diagonal (own data) and of the off-diagonal entries.

    Examples
    --------
    >>> train_validation_accuracy([[0.99, 0.97], [0.95, 0.98]])
    (0.985, 0.96)
    """
    f = np.asarray(fits, dtype=float)
    if f.ndim != 2 or f.shape[0] != f.shape[1] or f.shape[0] < 2:
        raise ShapeError(f"fits has shape {f.shape}; expected a square (k, k) matrix, k >= 2")
    k = f.shape[0]
    off = ~np.eye(k, dtype=bool)
    return float(np.mean(np.diag(f))), float(np.mean(f[off]))


def fit_report(
    y: Mapping[str, ArrayLike], yhat: Mapping[str, ArrayLike]
) -> dict[str, dict[str, float] | float]:
    """Per-signal NRMSE, RMSE and ξ plus their summary (for FitResult metrics).

    Returns
    -------
    dict
        ``{"nrmse": {name: ...}, "rmse": {...}, "xi": {...}, "mnrmse": ...}``
    """
    out: dict[str, dict[str, float] | float] = {"nrmse": {}, "rmse": {}, "xi": {}}
    for name, a in y.items():
        b = yhat[name]
        out["nrmse"][name] = float(nrmse(a, b))  # type: ignore[index]
        out["rmse"][name] = float(rmse(a, b))  # type: ignore[index]
        out["xi"][name] = float(accuracy_xi(a, b))  # type: ignore[index]
    vals = [v for v in out["nrmse"].values() if np.isfinite(v)]  # type: ignore[union-attr]
    out["mnrmse"] = float(np.mean(vals)) if vals else float("nan")
    return out


def fit_text(value: float) -> str:
    """An NRMSE fit (fraction) as people read it: percent, two decimals.

    Examples
    --------
    >>> fit_text(0.8431), fit_text(-1.39), fit_text(float("nan"))
    ('84.31 %', '-139.00 %', 'n/a')
    """
    v = float(value)
    if not np.isfinite(v):
        return "n/a"
    return f"{100.0 * v:.2f} %"
