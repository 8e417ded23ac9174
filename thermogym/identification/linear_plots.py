"""Figures of the linear identification (matplotlib, written as PNG; no numerics here).

* :func:`plot_fit` — measured against predicted outputs (MATLAB ``compare``
  style, fit in the legend);
* :func:`plot_singular_values` — the singular values of the projected Hankel
  matrix on a log scale with the chosen order (MATLAB ``n4sid``, paper 001
  Fig. 14);
* :func:`plot_order_cv` — training and validation accuracy against the model
  order with ``n* = argmax VA`` (paper 001 Fig. 15);
* :func:`plot_va_matrix` — a train × test VA matrix as a heat map (paper 001
  Figs. 16a/17a);
* :func:`plot_delay_loss` — the loss of the FOPTD delay search;
* :func:`plot_compare` — several models against one recording (MATLAB
  ``compare``), fit per output in the legend;
* :func:`plot_resid` — residual autocorrelation and input cross-correlation
  with their confidence bounds (MATLAB ``resid``).

Numerical modules never import this one.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from thermogym.plotting import plt, save_figure, time_axis
from thermogym.recording import Recording

__all__ = [
    "plot_compare",
    "plot_delay_loss",
    "plot_fit",
    "plot_order_cv",
    "plot_resid",
    "plot_singular_values",
    "plot_va_matrix",
]


def plot_fit(
    rec: Recording,
    prediction: NDArray[np.float64],
    outputs: Sequence[str],
    path: str | Path,
    *,
    title: str | None = None,
    fits: Mapping[str, float] | None = None,
) -> Path:
    """Measured outputs of ``rec`` against ``prediction`` (T, len(outputs)).

    Parameters
    ----------
    rec : Recording
    prediction : ndarray, shape (T, p)
    outputs : sequence of str
    path : path
        PNG to write.
    title : str, optional
    fits : mapping, optional
        Output → NRMSE fit (fraction) shown in the legend.
    """
    n = len(outputs)
    fig, axes = plt.subplots(n, 1, figsize=(9, 1.7 * n + 0.8), sharex=True, squeeze=False)
    t, xlabel = time_axis(rec.time, relative=True)
    for j, (ax, name) in enumerate(zip(axes[:, 0], outputs, strict=True)):
        ax.plot(t, rec[name], lw=0.9, color="0.2", label="measured")
        lab = "model"
        if fits and name in fits:
            lab += f" (fit {100 * fits[name]:.2f} %)"
        ax.plot(t, prediction[:, j], "--", lw=1.1, color="tab:red", label=lab)
        unit = rec.units.get(name, "")
        ax.set_ylabel(f"{name}\n[{unit}]" if unit else name, fontsize=7)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="best")
    axes[-1, 0].set_xlabel(xlabel)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return save_figure(fig, path)


def plot_singular_values(
    singular_values: Sequence[NDArray[np.float64]] | NDArray[np.float64],
    path: str | Path,
    *,
    chosen: int | None = None,
    labels: Sequence[str] | None = None,
    max_order: int = 40,
    title: str = "singular values of the projected Hankel matrix",
) -> Path:
    """Log singular values against the order (one series per training set)."""
    series = (
        [np.asarray(singular_values)]
        if np.ndim(singular_values) == 1
        else [np.asarray(s) for s in singular_values]
    )
    fig, ax = plt.subplots(figsize=(7, 3.6))
    width = 0.8 / len(series)
    for k, s in enumerate(series):
        s = s[:max_order]
        x = np.arange(1, s.size + 1) + (k - (len(series) - 1) / 2) * width
        lab = labels[k] if labels else None
        ax.bar(x, np.log10(np.maximum(s / s[0], 1e-300)), width=width, label=lab)
    if chosen is not None:
        ax.axvline(chosen, color="tab:red", ls="--", lw=1, label=f"order {chosen}")
    ax.set_xlabel("model order")
    ax.set_ylabel("log10(σ / σ₁)")
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3)
    if labels or chosen is not None:
        ax.legend(fontsize=7)
    fig.tight_layout()
    return save_figure(fig, path)


def plot_order_cv(cv: Any, path: str | Path, *, title: str | None = None) -> Path:
    """TA and VA (percent) against the order, ``n* = argmax VA`` marked (paper 001 Fig. 15).

    ``cv`` is a :class:`~thermogym.identification.crossval.OrderCV`.
    """
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.6))
    for ax, zoom in zip(axes, (False, True), strict=True):
        ax.plot(cv.orders, 100 * cv.ta, "o-", ms=3, label="training accuracy TA")
        ax.plot(cv.orders, 100 * cv.va, "s-", ms=3, label="validation accuracy VA")
        k = int(np.argmax(np.where(np.isfinite(cv.va), cv.va, -np.inf)))
        ax.plot(cv.orders[k], 100 * cv.va[k], "r*", ms=12, label=f"n* = {cv.best_order}")
        ax.set_xlabel("model order n")
        ax.set_ylabel("MNRMSE [%]")
        ax.grid(alpha=0.3)
        if zoom:
            good = cv.va >= np.nanmax(cv.va) - 0.01
            lo = float(np.nanmin(100 * np.r_[cv.va[good], cv.ta[good]])) - 0.05
            ax.set_ylim(lo, 100 * max(np.nanmax(cv.va), np.nanmax(cv.ta)) + 0.05)
            ax.set_title("zoom", fontsize=9)
        else:
            lo = np.nanpercentile(100 * np.r_[cv.va, cv.ta], 10)
            ax.set_ylim(max(lo - 5, -100), 100.5)
            ax.legend(fontsize=7, loc="lower right")
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return save_figure(fig, path)


def plot_va_matrix(
    matrix: NDArray[np.float64],
    labels: Sequence[str],
    path: str | Path,
    *,
    title: str = "validation accuracy VA [%]",
    xlabel: str = "test data",
    ylabel: str = "training data",
) -> Path:
    """Heat map of a train × test accuracy matrix with the values printed (percent)."""
    M = 100 * np.asarray(matrix, dtype=float)
    fig, ax = plt.subplots(figsize=(1.1 * len(labels) + 2.5, 0.9 * len(labels) + 1.8))
    im = ax.imshow(M, cmap="viridis", vmin=np.nanmin(M), vmax=np.nanmax(M))
    ax.set_xticks(range(len(labels)), labels, rotation=30, ha="right", fontsize=8)
    ax.set_yticks(range(len(labels)), labels, fontsize=8)
    mid = 0.5 * (np.nanmin(M) + np.nanmax(M))
    for i in range(M.shape[0]):
        for j in range(M.shape[1]):
            ax.text(
                j,
                i,
                f"{M[i, j]:.2f}",
                ha="center",
                va="center",
                fontsize=8,
                color="white" if M[i, j] < mid else "black",
            )
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=10)
    fig.colorbar(im, ax=ax, shrink=0.8)
    fig.tight_layout()
    return save_figure(fig, path)


def plot_delay_loss(result: Any, path: str | Path, *, title: str | None = None) -> Path:
    """Loss of the FOPTD delay search per output (first input), chosen delay marked.

    ``result`` is a :class:`~thermogym.identification.foptd.FOPTDResult`.
    """
    fig, ax = plt.subplots(figsize=(7, 3.6))
    d = result.delays * result.dt
    for name, f in result.outputs.items():
        loss = f.delay_loss[0]
        ok = np.isfinite(loss)
        line = ax.semilogy(d[ok], loss[ok], lw=1, label=name)[0]
        ax.plot(f.d[0] * result.dt, f.loss, "o", color=line.get_color())
    ax.set_xlabel("delay τ [s]")
    ax.set_ylabel("mean squared error")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    ax.set_title(title or "FOPTD delay search (000 section 4.1)", fontsize=10)
    fig.tight_layout()
    return save_figure(fig, path)


def plot_compare(comparison: Any, path: str | Path, *, title: str | None = None) -> Path:
    """Measured outputs and every model's prediction, one panel per output.

    Parameters
    ----------
    comparison : Comparison
        From :func:`thermogym.identification.compare.compare`.
    path : path
        PNG to write.
    title : str, optional
    """
    rec = comparison.recording
    outs = list(comparison.outputs)
    n = len(outs)
    fig, axes = plt.subplots(n, 1, figsize=(9, 1.9 * n + 0.9), sharex=True, squeeze=False)
    t, xlabel = time_axis(rec.time, relative=True)
    styles = ["--", "-.", ":", (0, (5, 1, 1, 1))]
    for ax, name in zip(axes[:, 0], outs, strict=True):
        ax.plot(t, rec[name], lw=0.9, color="0.2", label="measured")
        for i, m in enumerate(comparison.models):
            if name not in m.outputs:
                continue
            how = f"{m.horizon}-step" if m.horizon else "sim."
            ax.plot(
                t,
                m.outputs[name],
                linestyle=styles[i % len(styles)],
                lw=1.1,
                label=f"{m.label} ({how}, fit {100 * m.fits[name]:.2f} %)",
            )
        unit = rec.units.get(name, "")
        ax.set_ylabel(f"{name}\n[{unit}]" if unit else name, fontsize=7)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=6, loc="best")
    axes[-1, 0].set_xlabel(xlabel)
    fig.suptitle(title or f"compare: {rec.experiment_id or 'recording'}", fontsize=10)
    fig.tight_layout()
    return save_figure(fig, path)


def plot_resid(
    tests: Mapping[str, Any], path: str | Path, *, dt: float = 1.0, title: str | None = None
) -> Path:
    """Residual tests, one column per output (MATLAB ``resid``).

    Top row: the residual's autocorrelation for lags 0..M with the band white
    residuals stay in; below: its cross-correlation with each input for lags
    −M..M (positive lag: the input acting before) with the independence band.

    Parameters
    ----------
    tests : mapping
        Output → :class:`~thermogym.identification.residuals.ResidualTest`
        (from :func:`thermogym.identification.compare.resid`).
    path : path
    dt : float
        Sample period [s] (lags are shown in samples and seconds).
    title : str, optional
    """
    outs = list(tests)
    inputs = list(next(iter(tests.values())).xcorr) if tests else []
    rows = 1 + len(inputs)
    fig, axes = plt.subplots(
        rows, len(outs), figsize=(4.2 * len(outs) + 1, 2.0 * rows + 0.8), squeeze=False
    )
    for c, name in enumerate(outs):
        t = tests[name]
        M = t.max_lag
        lags = np.arange(M + 1)
        ax = axes[0, c]
        ax.bar(lags, t.autocorr, width=0.6, color="tab:blue")
        ax.axhspan(-t.bound, t.bound, color="tab:orange", alpha=0.25, lw=0)
        ax.set_title(f"{name}: autocorrelation (p = {t.p_white:.3g})", fontsize=8)
        ax.set_xlabel(f"lag [samples of {dt:g} s]", fontsize=7)
        ax.grid(alpha=0.3)
        for r, u in enumerate(inputs, start=1):
            ax = axes[r, c]
            lx = np.arange(-M, M + 1)
            ax.bar(lx, t.xcorr[u], width=0.6, color="tab:green")
            b = t.xbound[u]
            ax.axhspan(-b, b, color="tab:orange", alpha=0.25, lw=0)
            ax.set_title(
                f"{name} × {u}: cross-correlation (p = {t.p_independent[u]:.3g})", fontsize=8
            )
            ax.set_xlabel("lag [samples] (> 0: input before the residual)", fontsize=7)
            ax.grid(alpha=0.3)
    fig.suptitle(title or "residual tests", fontsize=10)
    fig.tight_layout()
    return save_figure(fig, path)
