"""Episode figures of the environments (``render_mode="rgb_array"`` / ``"human"``).

Plotting stays out of the numerical modules: the environments import this
module only inside ``render()``. Figures are built with matplotlib's
object-oriented API on an Agg canvas (no global backend switch, no display
needed); ``"human"`` writes a PNG atomically (:mod:`thermogym._fileio`).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from numpy.typing import NDArray

from thermogym._fileio import atomic_write

__all__ = ["episode_figure", "save", "to_rgb"]


def episode_figure(
    *,
    title: str,
    time_s: NDArray[np.float64],
    names: Sequence[str],
    units: Sequence[str],
    data: NDArray[np.float64],
    panels: Sequence[tuple[str, Sequence[str]]],
) -> Figure:
    """One panel per group of signals over the episode so far.

    Parameters
    ----------
    title : str
    time_s : ndarray, shape (T,)
        Time of each recorded sample [s].
    names, units : sequence of str
        Signal names and units (columns of ``data``).
    data : ndarray, shape (T, n)
    panels : sequence of (label, names)
    """
    fig = Figure(figsize=(8, 1.6 * len(panels) + 0.8), dpi=80)
    FigureCanvasAgg(fig)
    span = float(time_s[-1]) if time_s.size else 0.0
    scale, xlabel = (3600.0, "time [h]") if span > 3 * 3600 else (60.0, "time [min]")
    t = time_s / scale
    axes = fig.subplots(len(panels), 1, sharex=True, squeeze=False)[:, 0]
    for ax, (label, sigs) in zip(axes, panels, strict=True):
        for s in sigs:
            j = list(names).index(s)
            ax.plot(t, data[:, j], lw=1.0, label=f"{s} [{units[j]}]")
        ax.set_ylabel(label, fontsize=8)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="upper left")
    axes[-1].set_xlabel(xlabel)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return fig


def to_rgb(fig: Figure) -> NDArray[np.uint8]:
    """Render ``fig`` to an RGB array of shape (height, width, 3)."""
    canvas = fig.canvas
    canvas.draw()
    return np.asarray(canvas.buffer_rgba())[..., :3].copy()  # type: ignore[attr-defined]


def save(fig: Figure, path: str | os.PathLike[str]) -> Path:
    """Write ``fig`` as PNG to ``path`` atomically."""
    return atomic_write(path, lambda tmp: fig.savefig(tmp, format="png"))
