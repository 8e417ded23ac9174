"""Figures of coordinator runs (matplotlib, Agg); numerical modules never import this.

Every function writes a PNG atomically (:func:`thermogym.plotting.save_figure`)
and returns its path.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np

from thermogym.errors import ConfigError
from thermogym.plotting import save_figure  # also selects the Agg backend

__all__ = ["plot_fit", "plot_history", "plot_identifiability", "plot_samples"]


def plot_history(result: Any, path: str | Path, *, title: str | None = None) -> Path:
    """Best criterion against evaluated parameter sets (one point per iteration).

    Parameters
    ----------
    result : IdentificationResult or sequence of them
        Several results are drawn in one panel (comparison of methods).
    path : path
    title : str, optional
    """
    results = result if isinstance(result, list | tuple) else [result]
    fig, ax = plt.subplots(figsize=(7, 4))
    for r in results:
        h = r.history
        if not h:
            continue
        x = [e.evaluations for e in h]
        y = [e.best for e in h]
        ax.step(x, y, where="post", label=f"{r.method} ({r.stop_reason.split(':')[0]})")
    ax.set_xlabel("parameter sets evaluated")
    ax.set_ylabel("best criterion")
    if all(e.best > 0 for r in results for e in r.history):
        ax.set_yscale("log")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    ax.set_title(title or "search history")
    fig.tight_layout()
    return save_figure(fig, path)


def plot_fit(result: Any, path: str | Path, *, experiments: Any = None) -> Path:
    """Measured and simulated signal pairs at the best parameters, one panel per pair.

    Parameters
    ----------
    result : IdentificationResult
    path : path
    experiments : sequence of Recording, optional
        Recordings to show (default: the training experiments).
    """
    pb = result.problem if experiments is None else result.problem.with_experiments(experiments)
    outs, errors = pb.simulate(result.x[None])
    pairs = pb.pairs
    fig, axes = plt.subplots(
        len(pairs), 1, figsize=(9, 2.0 * len(pairs) + 0.8), sharex=True, squeeze=False
    )
    for j, (ax, p) in enumerate(zip(axes[:, 0], pairs, strict=True)):
        for e, yh in zip(pb.experiments, outs, strict=True):
            t = (e.time - e.time[0]) / 60.0
            (line,) = ax.plot(t, e[p.measured], lw=0.8, alpha=0.7, label=f"{e.experiment_id}")
            if errors[0] is None:
                ax.plot(t, yh[0, :, j], "--", lw=1.1, color=line.get_color())
        unit = pb.experiments[0].units.get(p.measured, "")
        ax.set_ylabel(f"{p.label}\n[{unit}]" if unit else p.label, fontsize=8)
        ax.grid(alpha=0.3)
    axes[-1, 0].set_xlabel("time [min] (solid: measured, dashed: simulated)")
    if len(pb.experiments) <= 12:
        axes[0, 0].legend(fontsize=7, ncol=min(3, len(pb.experiments)))
    fig.suptitle(f"{result.method}: criterion {result.criterion:.4g}")
    fig.tight_layout()
    return save_figure(fig, path)


def plot_samples(result: Any, path: str | Path, *, best_fraction: float = 0.1) -> Path:
    """Dotty plots of a Monte Carlo run: criterion against every parameter.

    Parameters
    ----------
    result : IdentificationResult
        With ``samples`` kept (``keep_samples=True``).
    path : path
    best_fraction : float
        The best fraction of the samples is highlighted.
    """
    if result.samples is None:
        raise ConfigError(
            f"the {result.method} result kept no samples; run it with keep_samples=True"
        )
    Z, cost, _ = result.samples
    ok = np.isfinite(cost)
    P = Z.shape[1]
    fig, axes = plt.subplots(1, P, figsize=(2.6 * P + 0.5, 3.0), sharey=True, squeeze=False)
    thr = np.quantile(cost[ok], best_fraction) if ok.any() else np.inf
    for i, ax in enumerate(axes[0]):
        ax.plot(Z[ok, i], cost[ok], ".", ms=1.5, alpha=0.4, color="0.5")
        sel = ok & (cost <= thr)
        ax.plot(Z[sel, i], cost[sel], ".", ms=2.0, color="C0")
        ax.axvline(result.x[i], color="C3", lw=1.0)
        ax.set_xlabel(result.names[i], fontsize=8)
        ax.grid(alpha=0.3)
    axes[0, 0].set_ylabel("criterion")
    if ok.any() and np.all(cost[ok] > 0):
        axes[0, 0].set_yscale("log")
    fig.suptitle(f"{len(cost)} samples; red: best")
    fig.tight_layout()
    return save_figure(fig, path)


def plot_identifiability(idf: Any, path: str | Path) -> Path:
    """Bar chart of parameter importance, proposed parameters highlighted.

    Parameters
    ----------
    idf : Identifiability
    path : path
    """
    order = idf.order
    names = [idf.names[i] for i in order]
    rel = [idf.relative[i] for i in order]
    colors = ["C0" if n in idf.selected else "0.7" for n in names]
    fig, ax = plt.subplots(figsize=(max(5.0, 0.45 * len(names) + 2), 3.6))
    ax.bar(range(len(names)), rel, color=colors)
    ax.set_xticks(range(len(names)))
    ax.set_xticklabels(names, rotation=60, ha="right", fontsize=8)
    ax.set_yscale("log")
    ax.set_ylabel("relative importance")
    ax.set_title("identifiability ranking (blue: proposed to fit)")
    ax.grid(alpha=0.3, axis="y")
    fig.tight_layout()
    return save_figure(fig, path)
