"""Figures of the demo report (matplotlib Agg; only the demo stages import this).

Each function writes PNGs through :func:`thermogym.plotting.save_figure`
(atomic) under the running stage's staging folder and returns
``(path, caption)`` pairs.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from thermogym.models.registry import get_model
from thermogym.plotting import plot_recordings, save_figure, time_axis

__all__ = [
    "closed_loop_figure",
    "diagnosis_fit_figure",
    "rig_figures",
    "strut_prediction_figure",
]

Figs = list[tuple[Path, str]]


def rig_figures(ctx: Any, recs: Mapping[str, Sequence[Any]]) -> Figs:
    """Stage 1: an AXT211 step against the nominal model, staircase, strut steps, spindle day."""
    out: Figs = []
    steps = recs["axt211/steps"]
    step = next((r for r in steps if r.experiment_id == "axt211-step-24V-25C"), steps[0])
    model = get_model("axt211")
    sim = model.simulate(step.exogenous_array(model), step.dt)
    p = plot_recordings(
        [step],
        ctx.path("figures", "rigs_axt211_step.png"),
        signals=["u", "P_PTC", "T_P", "x_V"],
        overlay={"nominal model": {n: sim.output(n)[0] for n in model.output_names}},
        title=f"AXT211 rig: {step.experiment_id}",
    )
    out.append((p, "AXT211 rig power step (24 V, 25 °C) against the package's nominal model"))
    p = plot_recordings(
        recs["axt211/staircase"],
        ctx.path("figures", "rigs_axt211_staircase.png"),
        signals=["T_P_setpoint", "T_P", "u", "x_V"],
        title="AXT211 closed-loop temperature staircase (paper 002 Fig. 3)",
    )
    out.append((p, "Temperature staircase: stroke gain and backlash (paper 002 Fig. 3)"))
    p = plot_recordings(
        recs["strut/steps"],
        ctx.path("figures", "rigs_strut_steps.png"),
        signals=["feed_rate", "T_drive", "T_nut", "T_bearing", "dL_um"],
        title="Strut feed-rate steps with a concealed effect (paper 000 section 4)",
    )
    out.append((p, "Strut step tests at 20, 25 and 30 m/min (the rig is a plant of its own)"))
    day = recs["spindle/run-in"][-1]
    p = plot_recordings(
        [day],
        ctx.path("figures", "rigs_spindle_raw.png"),
        signals=["speed", "T_front_bearing_C", "T_front_outer_housing", "T_amb"],
        title=f"Spindle raw asynchronous recording {day.experiment_id}",
    )
    out.append((p, "Raw spindle run-in day: two multiplexed RTD modules, outliers, gaps"))
    return out


def diagnosis_fit_figure(
    path: Path,
    rec: Any,
    outputs: Sequence[str],
    nominal: Mapping[str, np.ndarray],
    augmented: Mapping[str, np.ndarray],
    title: str,
) -> Path:
    """Measured outputs with the nominal and the augmented model's simulations."""
    fig, axes = plt.subplots(len(outputs), 1, figsize=(9, 2.0 * len(outputs) + 0.6), sharex=True)
    axes = np.atleast_1d(axes)
    t, xl = time_axis(np.asarray(rec.time))
    for ax, o in zip(axes, outputs, strict=True):
        ax.plot(t, rec[o], ".", ms=3, color="0.3", label="measured (rig)")
        ax.plot(t, nominal[o], "--", color="tab:red", lw=1.2, label="nominal model")
        ax.plot(t, augmented[o], "-", color="tab:blue", lw=1.2, label="augmented model")
        ax.set_ylabel(f"{o}\n[{rec.units.get(o, '')}]", fontsize=8)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7, ncol=3)
    axes[-1].set_xlabel(xl)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return save_figure(fig, path)


def closed_loop_figure(
    path: Path,
    runs: Mapping[str, Mapping[str, np.ndarray]],
    signals: Sequence[tuple[str, str]],
    title: str,
) -> Path:
    """Signals of several closed-loop runs (``{label: {"time": t, name: y}}``)."""
    fig, axes = plt.subplots(len(signals), 1, figsize=(9, 2.1 * len(signals) + 0.6), sharex=True)
    axes = np.atleast_1d(axes)
    for label, run in runs.items():
        t, xl = time_axis(np.asarray(run["time"]))
        for ax, (name, _) in zip(axes, signals, strict=True):
            if name in run:
                ax.plot(t, run[name], lw=1.0, label=label)
    for ax, (name, unit) in zip(axes, signals, strict=True):
        ax.set_ylabel(f"{name}\n[{unit}]", fontsize=8)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7, ncol=min(4, len(runs)))
    axes[-1].set_xlabel(xl)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return save_figure(fig, path)


def strut_prediction_figure(
    path: Path, runs: Mapping[str, Mapping[str, np.ndarray]], title: str
) -> Path:
    """Thermal elongation and nut temperature of the strut envs against the rig."""
    return closed_loop_figure(
        path, runs, [("feed_rate", "m/min"), ("T_nut", "°C"), ("dL_um", "µm")], title
    )
