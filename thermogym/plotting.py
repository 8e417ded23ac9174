"""Figures for recordings and simulations (matplotlib, no display needed).

Plotting lives here, outside the numerical modules. Every function writes a PNG
atomically and returns its path.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from thermogym._fileio import atomic_write
from thermogym.recording import Recording

__all__ = ["plot_recordings", "save_figure"]


def save_figure(fig: plt.Figure, path: str | Path, dpi: int = 110) -> Path:
    """Save ``fig`` to ``path`` atomically and close it."""
    try:
        return atomic_write(path, lambda tmp: fig.savefig(tmp, dpi=dpi, format="png"))
    finally:
        plt.close(fig)


def time_axis(t: np.ndarray, *, relative: bool = False) -> tuple[np.ndarray, str]:
    """Times [s] in a readable unit (h above 6 h, min above 10 min) and the axis label.

    ``relative``: count from the first sample.
    """
    t = np.asarray(t, dtype=float)
    span = float(t[-1] - t[0]) if t.size else 0.0
    if relative and t.size:
        t = t - t[0]
    if span > 6 * 3600:
        return t / 3600.0, "time [h]"
    if span > 600:
        return t / 60.0, "time [min]"
    return t, "time [s]"


def plot_recordings(
    recordings: Sequence[Recording],
    path: str | Path,
    *,
    signals: Sequence[str] | None = None,
    title: str | None = None,
    overlay: Mapping[str, Mapping[str, np.ndarray]] | None = None,
) -> Path:
    """Plot signals of one or several recordings, one panel per signal.

    Parameters
    ----------
    recordings : sequence of Recording
        Drawn in the same panels, labelled by experiment id.
    path : path
        PNG file to write.
    signals : sequence of str, optional
        Columns to draw (default: every column of the first recording).
    title : str, optional
    overlay : mapping, optional
        ``{label: {signal: values}}`` drawn dashed over the first recording
        (e.g. a simulation on the same time axis).
    """
    names = list(signals or recordings[0].columns)
    fig, axes = plt.subplots(
        len(names), 1, figsize=(9, 1.9 * len(names) + 0.6), sharex=True, squeeze=False
    )
    for ax, name in zip(axes[:, 0], names, strict=True):
        for rec in recordings:
            if name not in rec:
                continue
            t, xlabel = time_axis(rec.time)
            y = rec[name]
            ok = np.isfinite(y)
            ax.plot(t[ok], y[ok], lw=0.9, label=rec.experiment_id or "")
        for label, sig in (overlay or {}).items():
            if name in sig:
                t, _ = time_axis(recordings[0].time)
                ax.plot(t, sig[name], "--", lw=1.1, label=label)
        unit = recordings[0].units.get(name, "")
        ax.set_ylabel(f"{name}\n[{unit}]" if unit else name, fontsize=8)
        ax.grid(alpha=0.3)
    axes[-1, 0].set_xlabel(xlabel)
    _, labels = axes[0, 0].get_legend_handles_labels()
    if 1 < len(labels) <= 16:
        axes[0, 0].legend(fontsize=7, ncol=min(4, len(labels)), loc="best")
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return save_figure(fig, path)
