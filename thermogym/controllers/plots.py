"""Figures of a controller benchmark (matplotlib, Agg); numerical code never imports this.

* :func:`plot_trajectories` — the representative episode of every controller
  (controlled variable with its set-point or comfort band; actuator on a
  second axis);
* :func:`plot_kpi_bars` — mean KPI per controller with the seed spread;
* :func:`plot_pareto` — energy against lifetime against accuracy, the
  non-dominated controllers marked;
* :func:`plot_gap` — the accuracy and energy KPIs on the model and on the rig;
* :func:`plot_lifetime_ranks` — each controller's rank under every wear measure
  (switching operations, stem travel, cycle counts and Miner sums under other S-N
  assumptions).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from thermogym.controllers.tables import MAIN_KPIS, kpi_axes, lifetime_rankings, pareto_front
from thermogym.plotting import save_figure

__all__ = [
    "benchmark_figures",
    "plot_gap",
    "plot_kpi_bars",
    "plot_lifetime_ranks",
    "plot_pareto",
    "plot_trajectories",
]

#: (controlled variable, reference, band low, band high, actuator signal, unit) per environment.
_SIGNALS: dict[str, tuple[str, str | None, str | None, str | None, str, str]] = {
    "AXT211Valve": ("x_V", "x_ref", None, None, "duty", "mm"),
    "AXT211Room": ("T_zone", "T_set", "band_low", "band_high", "x_V", "°C"),
    "TCLab": ("T1", "T1_set", None, None, "Q1", "°C"),
}


def _safe(s: str) -> str:
    return "".join(c if c.isalnum() or c in "-_" else "_" for c in s)


def _time(t: np.ndarray) -> tuple[np.ndarray, str]:
    span = float(t[-1] - t[0]) if t.size > 1 else 0.0
    if span > 2 * 86400:
        return t / 86400.0, "time [days]"
    if span > 6 * 3600:
        return t / 3600.0, "time [h]"
    return t / 60.0, "time [min]"


def plot_trajectories(
    trajs: dict[str, dict[str, np.ndarray]], env_name: str, path: Path, *, title: str = ""
) -> Path:
    """One panel per controller: the controlled variable, its reference and the actuator."""
    sig = _SIGNALS.get(env_name)
    names = list(trajs)
    n = len(names)
    fig, axes = plt.subplots(n, 1, figsize=(11, 1.9 * n + 0.8), sharex=True, squeeze=False)
    for ax, name in zip(axes[:, 0], names, strict=True):
        tr = trajs[name]
        t, tl = _time(np.asarray(tr["time"]))
        if sig is None:
            keys = [k for k in tr if k not in ("time", "reward")][:2]
            for k in keys:
                ax.plot(t, tr[k], lw=0.8, label=k)
        else:
            y, ref, lo, hi, act, unit = sig
            if lo and hi and lo in tr and hi in tr:
                ax.fill_between(
                    t, tr[lo], tr[hi], color="tab:green", alpha=0.12, lw=0, label="band"
                )
            if ref and ref in tr:
                ax.plot(t, tr[ref], color="k", lw=0.8, ls="--", label=ref)
            ax.plot(t, tr[y], color="tab:red", lw=0.9, label=y)
            ax.set_ylabel(f"{y} [{unit}]", fontsize=8)
            if act in tr:
                a2 = ax.twinx()
                a2.plot(t, tr[act], color="tab:blue", lw=0.5, alpha=0.6)
                a2.set_ylabel(act, color="tab:blue", fontsize=8)
                a2.tick_params(labelsize=7, colors="tab:blue")
        ax.set_title(name, fontsize=9, loc="left")
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=7, loc="upper right", ncol=3)
    axes[-1, 0].set_xlabel(tl)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return save_figure(fig, path)


def plot_kpi_bars(
    table: Any, path: Path, *, kpis: Sequence[str] | None = None, title: str = ""
) -> Path:
    """Mean KPI per controller (bars) with the standard deviation over seeds."""
    ks = [k for k in (kpis or MAIN_KPIS) if k in table.columns]
    g = table.groupby("controller", sort=False)[ks]
    mean, std = g.mean(), g.std().fillna(0.0)
    n = len(ks)
    cols = min(4, n)
    rows = -(-n // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(3.2 * cols, 2.6 * rows), squeeze=False)
    x = np.arange(len(mean.index))
    colors = plt.get_cmap("tab10")(np.arange(len(x)) % 10)
    for i, k in enumerate(ks):
        ax = axes[i // cols, i % cols]
        ax.bar(x, mean[k], yerr=std[k], color=colors, capsize=2)
        ax.set_title(k, fontsize=9)
        ax.set_xticks(x, list(mean.index), rotation=60, ha="right", fontsize=7)
        ax.tick_params(axis="y", labelsize=7)
        if (mean[k] > 0).all() and mean[k].max() / max(mean[k].min(), 1e-300) > 300:
            ax.set_yscale("log")
        ax.grid(axis="y", alpha=0.3)
    for j in range(n, rows * cols):
        axes[j // cols, j % cols].axis("off")
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return save_figure(fig, path)


def plot_pareto(table: Any, path: Path, *, title: str = "") -> Path | None:
    """Energy, lifetime and accuracy of every controller (seed means ± std), front marked."""
    ax3 = kpi_axes(list(table.columns))
    if len(ax3) < 3:
        return None
    e, life, acc = ax3["energy"], ax3["lifetime"], ax3["accuracy"]
    g = table.groupby("controller", sort=False)[[e, life, acc]]
    m, s = g.mean(), g.std().fillna(0.0)
    front = pareto_front(m.to_numpy())
    pairs = [(e, life), (e, acc), (life, acc)]
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.6))
    cmap = plt.get_cmap("viridis")
    norm = plt.Normalize(float(m[acc].min()), float(m[acc].max()) or 1.0)
    for ax, (a, b) in zip(axes, pairs, strict=True):
        for i, c in enumerate(m.index):
            color = cmap(norm(m.at[c, acc])) if (a, b) == (e, life) else f"C{i % 10}"
            ax.errorbar(
                m.at[c, a],
                m.at[c, b],
                xerr=s.at[c, a],
                yerr=s.at[c, b],
                fmt="o",
                ms=8 if front[i] else 6,
                color=color,
                mec="k" if front[i] else color,
                mew=1.5 if front[i] else 0.5,
                ecolor="0.6",
                elinewidth=0.8,
            )
            ax.annotate(
                c, (m.at[c, a], m.at[c, b]), fontsize=7, xytext=(4, 4), textcoords="offset points"
            )
        ax.set_xlabel(a)
        ax.set_ylabel(b)
        if (m[b] > 0).all() and m[b].max() / max(m[b].min(), 1e-300) > 100:
            ax.set_yscale("log")
        if (m[a] > 0).all() and m[a].max() / max(m[a].min(), 1e-300) > 100:
            ax.set_xscale("log")
        ax.grid(alpha=0.3)
    sm = plt.cm.ScalarMappable(norm=norm, cmap=cmap)
    fig.colorbar(sm, ax=axes[0], label=acc)
    fig.suptitle(
        (title + "\n" if title else "")
        + "energy · lifetime · accuracy (lower is better); black edge: Pareto-optimal",
        fontsize=10,
    )
    fig.tight_layout()
    return save_figure(fig, path)


def plot_gap(table: Any, path: Path, *, title: str = "") -> Path | None:
    """Accuracy and energy KPI means on the identified model and on the rig, per controller."""
    if not {"model", "rig"} <= set(table["plant"]):
        return None
    ax3 = kpi_axes(list(table.columns))
    ks = [ax3[k] for k in ("accuracy", "energy", "lifetime") if k in ax3]
    m = table.groupby(["controller", "plant"], sort=False)[ks].mean().unstack("plant")
    fig, axes = plt.subplots(1, len(ks), figsize=(4.5 * len(ks), 3.6), squeeze=False)
    x = np.arange(len(m.index))
    for ax, k in zip(axes[0], ks, strict=True):
        ax.bar(x - 0.2, m[(k, "model")], 0.4, label="identified model")
        ax.bar(x + 0.2, m[(k, "rig")], 0.4, label="virtual rig")
        ax.set_xticks(x, list(m.index), rotation=60, ha="right", fontsize=7)
        ax.set_title(k, fontsize=9)
        ax.grid(axis="y", alpha=0.3)
    axes[0, 0].legend(fontsize=7)
    fig.suptitle(
        title or "sim-to-real: the same controllers on the model and on the rig", fontsize=10
    )
    fig.tight_layout()
    return save_figure(fig, path)


def plot_lifetime_ranks(table: Any, path: Path, *, title: str = "") -> Path | None:
    """Rank of every controller (1 = least wear) under each wear measure, one line each.

    ``table`` holds one scenario on one plant; None when it has no wear measures
    (:func:`~thermogym.controllers.tables.lifetime_rankings`).
    """
    ranks = lifetime_rankings(table)
    if len(ranks) != 1:
        return None
    r = next(iter(ranks.values()))
    rank, labels = r["rank"], r["labels"]
    cols = list(labels)
    fig, ax = plt.subplots(figsize=(1.0 + 0.62 * len(cols), 0.6 + 0.32 * len(rank) + 1.6))
    x = np.arange(len(cols))
    for c in rank.index:
        y = rank.loc[c, cols].to_numpy(dtype=float)
        ax.plot(x, y, "o-", lw=1.2, ms=4)
        ax.annotate(str(c), (x[-1], y[-1]), xytext=(4, 0), textcoords="offset points",
                    fontsize=7, va="center")  # fmt: skip
    ax.set_xticks(x, [labels[k] for k in cols], rotation=50, ha="right", fontsize=7)
    ax.set_yticks(np.arange(1, len(rank) + 1))
    ax.invert_yaxis()
    ax.set_ylabel("rank (1 = least wear)")
    ax.set_xlim(-0.3, len(cols) - 0.2 + 1.4)
    ax.grid(alpha=0.3)
    ax.set_title(title or "lifetime ranking under each wear measure", fontsize=9)
    fig.tight_layout()
    return save_figure(fig, path)


def benchmark_figures(res: Any, folder: Path) -> dict[str, list[Path]]:
    """Every figure of a benchmark by key: ``"scenario|plant"``, ``"lifetime|…"``, ``"gap"``.

    ``"lifetime|scenario|plant"`` holds the lifetime-ranking figure of that scenario and
    plant (:func:`plot_lifetime_ranks`), shown in the report's lifetime section.
    """
    folder.mkdir(parents=True, exist_ok=True)
    t = res.table
    env_name = str(t["env_id"].iloc[0]).split("/")[-1].split("-v")[0]
    out: dict[str, list[Path]] = {}
    for (scen, plant), grp in t.groupby(["scenario", "plant"], sort=False):
        tag = _safe(f"{env_name}_{scen}_{plant}")
        paths: list[Path] = []
        trajs = {
            f"{c} (seed {sd})": tr
            for (sk, c, p, sd), tr in res.trajectories.items()
            if sk.split("@")[0] == scen and p == plant
        }
        if trajs:
            paths.append(
                plot_trajectories(
                    trajs,
                    env_name,
                    folder / f"{tag}_trajectories.png",
                    title=f"{env_name}, {scen}, {plant}: representative episodes",
                )
            )
        paths.append(
            plot_kpi_bars(grp, folder / f"{tag}_kpis.png", title=f"{env_name}, {scen}, {plant}")
        )
        p = plot_pareto(grp, folder / f"{tag}_pareto.png", title=f"{env_name}, {scen}, {plant}")
        if p is not None:
            paths.append(p)
        out[f"{scen}|{plant}"] = paths
        lr = plot_lifetime_ranks(
            grp, folder / f"{tag}_lifetime_ranks.png", title=f"{env_name}, {scen}, {plant}"
        )
        if lr is not None:
            out[f"lifetime|{scen}|{plant}"] = [lr]
    gaps = []
    for scen, grp in t.groupby("scenario", sort=False):
        p = plot_gap(
            grp,
            folder / (_safe(f"{env_name}_{scen}_sim_to_real") + ".png"),
            title=f"{scen}: model vs rig",
        )
        if p is not None:
            gaps.append(p)
    if gaps:
        out["gap"] = gaps
    return out
