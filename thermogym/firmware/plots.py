"""Figures of the virtual sensor: measured, hidden-true and estimated temperatures.

Plotting only (matplotlib Agg through :mod:`thermogym.plotting`); nothing
numerical imports this module.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from numpy.typing import ArrayLike

from thermogym.plotting import save_figure, time_axis

__all__ = ["plot_virtual_sensor"]


def plot_virtual_sensor(
    time: ArrayLike,
    estimates: Mapping[str, ArrayLike],
    path: str | Path,
    *,
    measured: Mapping[str, ArrayLike] | None = None,
    truth: Mapping[str, ArrayLike] | None = None,
    std: Mapping[str, ArrayLike] | None = None,
    unit: str = "°C",
    title: str | None = None,
    truth_label: str = "true (hidden)",
) -> Path:
    """Measured, hidden-true and estimated signals, one panel per estimate.

    Parameters
    ----------
    time : array_like, shape (T,)
        Sample times [s].
    estimates : mapping
        ``{name: values}`` of the estimated (hidden) signals.
    path : path
        PNG to write (atomically).
    measured : mapping, optional
        The signals the sensor measured (drawn thin in every panel's top
        strip: the surface temperatures the estimate comes from).
    truth : mapping, optional
        The hidden signals' true values (dashed), when known.
    std : mapping, optional
        Standard deviations of the estimates (a ±2σ band).
    unit : str
        Unit of the signals.
    title : str, optional
    truth_label : str
        Legend of ``truth`` (``"recorded"`` for measured internal temperatures).

    Returns
    -------
    Path
    """
    t, xlabel = time_axis(np.asarray(time, dtype=float))
    names = list(estimates)
    rows = len(names) + (1 if measured else 0)
    fig, axes = plt.subplots(rows, 1, figsize=(9, 1.8 * rows + 0.8), sharex=True, squeeze=False)
    ax_iter = iter(axes[:, 0])
    if measured:
        ax = next(ax_iter)
        for name, v in measured.items():
            ax.plot(t, np.asarray(v, dtype=float), lw=0.8, label=f"{name} (measured)")
        ax.set_ylabel(f"measured\n[{unit}]", fontsize=8)
        ax.legend(fontsize=7, loc="best")
        ax.grid(alpha=0.3)
    for name in names:
        ax = next(ax_iter)
        est = np.asarray(estimates[name], dtype=float)
        if truth is not None and name in truth:
            tr = np.asarray(truth[name], dtype=float)
            ax.plot(t, tr, "k--", lw=1.0, label=truth_label)
            err = est - tr
            ok = np.isfinite(err)
            if ok.any():
                rms = float(np.sqrt(np.mean(err[ok] ** 2)))
                ax.text(0.01, 0.05, f"RMSE {rms:.3g} {unit}", transform=ax.transAxes, fontsize=7)
        ax.plot(t, est, lw=1.0, color="C3", label="estimate")
        if std is not None and name in std:
            s = np.asarray(std[name], dtype=float)
            ax.fill_between(t, est - 2 * s, est + 2 * s, color="C3", alpha=0.2, lw=0, label="±2σ")
        ax.set_ylabel(f"{name}\n[{unit}]", fontsize=8)
        ax.grid(alpha=0.3)
    axes[min(1 if measured else 0, rows - 1), 0].legend(fontsize=7, loc="best")
    axes[-1, 0].set_xlabel(xlabel)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return save_figure(fig, path)
