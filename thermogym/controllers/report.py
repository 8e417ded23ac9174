"""Benchmark reports: tidy tables (CSV, Parquet), a Markdown summary, figures.

:func:`write_report` writes, into a folder:

``results.csv`` / ``results.parquet``
    The tidy table, one row per episode (:func:`~.harness.run_episode`).
``summary.md``
    Per scenario and plant: mean ± standard deviation (over seeds) of every
    KPI per controller, the sim-to-real gap when both plants ran, the
    Pareto-optimal controllers on energy, lifetime and accuracy (and with the
    heater's switching operations as a wear axis of their own), how the
    lifetime ranking changes with the S-N assumptions (cut-off, exponent) and
    between counting cycles and Miner's damage, and the figures.
``trajectories.parquet``
    The recorded episodes (block means), long format.
``figures/``
    Trajectories of the representative episodes, KPI bars and the
    energy-lifetime-accuracy Pareto view (:mod:`thermogym.controllers.plots`).

The KPI axes, the Pareto front and the sim-to-real gap are computed by
:mod:`thermogym.controllers.tables`.

Files are written atomically (:mod:`thermogym._fileio`): a failed report
never leaves a half-written file in place of a good one.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any

import pandas as pd

from thermogym import __version__
from thermogym._fileio import atomic_write, atomic_write_text
from thermogym.controllers.tables import (
    MAIN_KPIS,
    format_mean_std,
    kpi_axes,
    lifetime_rankings,
    pareto_front,
    sim_to_real_gap,
)

__all__ = ["summary_markdown", "write_report"]


def _md_table(header: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(lines)


def _lifetime_section(table: Any, figures: dict[str, list[str]] | None = None) -> list[str]:
    """Ranks of the controllers under every wear measure, with Kendall's τ to the default."""
    ranks = lifetime_rankings(table)
    if not ranks:
        return []
    lines = [
        "## Lifetime: how the ranking depends on the wear measure",
        "",
        "Rank of each controller (1 = least wear) by the heater's switching operations "
        "(relay contacts), the stem's travel, the rainflow count of wax-temperature cycles "
        "at least a cut-off range (twice the amplitude; smaller cycles do no damage) and "
        "Palmgren-Miner's sum `Σ n (ΔT/50 K)^m / 1e5` for exponents m and cut-offs "
        "(`thermogym.envs.kpis`; the S-N curve of a wax cartridge is not published, "
        "so none of these is the true one). Last row: Kendall's τ between the "
        "ranking and the one by the default Miner sum (m = 2, ≥ 2 K); 1 = the same order.",
        "",
    ]
    for (scen, plant), r in ranks.items():
        rank, tau, labels = r["rank"], r["tau"], r["labels"]
        cols = list(labels)
        lines += [f"### {scen} on the {'virtual rig' if plant == 'rig' else 'model'}", ""]
        rows = [[f"`{c}`", *[str(int(rank.at[c, k])) for k in cols]] for c in rank.index]
        rows.append(
            ["Kendall τ", *[f"{tau[k]:.2f}" if math.isfinite(tau[k]) else "–" for k in cols]]
        )
        lines += [_md_table(["controller", *[labels[k] for k in cols]], rows), ""]
        best = {k: ", ".join(f"`{c}`" for c in rank.index[rank[k] == 1]) for k in cols}
        groups: dict[str, list[str]] = {}
        for k in cols:
            groups.setdefault(best[k], []).append(labels[k])
        lines += [
            "Least wear: "
            + "; ".join(f"{who} by {', '.join(what)}" for who, what in groups.items())
            + ".",
            "",
        ]
        for rel in (figures or {}).get(f"lifetime|{scen}|{plant}", []):
            lines += [f"![{Path(rel).stem}]({rel})", ""]
    return lines


def _pareto_with_switching(mean: Any, axes: dict[str, str]) -> list[str]:
    """Pareto front with the switching operations as a fourth (wear) axis."""
    if len(axes) != 3 or "switch_cycles" not in mean.columns:
        return []
    if axes["lifetime"] == "switch_cycles":
        return []
    keys = [axes["energy"], axes["lifetime"], "switch_cycles", axes["accuracy"]]
    front = pareto_front(mean[keys].to_numpy())
    names = [f"`{c}`" for c, f in zip(mean.index, front, strict=True) if f]
    return [
        "With the heater's switching operations as a wear axis of their own "
        f"({', '.join(keys)}): " + ", ".join(names) + ".",
        "",
    ]


def summary_markdown(
    table: Any, *, title: str | None = None, figures: dict[str, list[str]] | None = None
) -> str:
    """The Markdown summary of a benchmark table (see the module docstring)."""
    t = table
    env_ids = sorted(set(t["env_id"]))
    lines = [f"# {title or 'Controller benchmark: ' + ', '.join(env_ids)}", ""]
    seeds = sorted(set(t["seed"]))
    lines += [
        f"thermogym {__version__}; environment {', '.join(env_ids)}; "
        f"{len(t)} episodes; seeds {seeds[0]}..{seeds[-1]} ({len(seeds)}); "
        f"controllers {', '.join(dict.fromkeys(t['controller']))}.",
        "",
        "Values are mean ± standard deviation over the seeds (sample standard deviation). "
        "Energy, lifetime and accuracy axes: "
        + ", ".join(f"{k} = `{v}`" for k, v in kpi_axes(list(t.columns)).items())
        + ". Lower is better for every KPI shown.",
        "",
    ]
    kpis = [k for k in MAIN_KPIS if k in t.columns]
    axes = kpi_axes(list(t.columns))
    for (scen, plant), grp in t.groupby(["scenario", "plant"], sort=False):
        ver = int(grp["scenario_version"].iloc[0])
        lines += [f"## {scen}@{ver} on the {'virtual rig' if plant == 'rig' else 'model'}", ""]
        g = grp.groupby("controller", sort=False)
        mean, std, cnt = g[kpis].mean(), g[kpis].std(), g[kpis].count()
        rows = []
        for c in mean.index:
            rows.append(
                [f"`{c}`"]
                + [format_mean_std(mean.at[c, k], std.at[c, k], int(cnt.at[c, k])) for k in kpis]
            )
        lines += [_md_table(["controller", *[f"`{k}`" for k in kpis]], rows), ""]
        trips = grp[grp["terminated"]]
        if len(trips):
            lines += [
                f"Safety trips: {len(trips)} episode(s): "
                + "; ".join(f"{r.controller} seed {r.seed}: {r.trip}" for r in trips.itertuples()),
                "",
            ]
        if len(axes) == 3:
            pts = mean[[axes["energy"], axes["lifetime"], axes["accuracy"]]].to_numpy()
            front = pareto_front(pts)
            names = [f"`{c}`" for c, f in zip(mean.index, front, strict=True) if f]
            lines += [
                "Pareto-optimal (no other controller is at least as good on all of "
                f"{axes['energy']}, {axes['lifetime']}, {axes['accuracy']} and better on one): "
                + ", ".join(names)
                + ".",
                "",
            ]
            wear = [k for k in dict.fromkeys([*axes.values(), "switch_cycles"]) if k in t.columns]
            lines += _pareto_with_switching(g[wear].mean(), axes)
        for rel in (figures or {}).get(f"{scen}|{plant}", []):
            lines += [f"![{Path(rel).stem}]({rel})", ""]
    gap = sim_to_real_gap(t, [k for k in kpis if k in t.columns])
    if len(gap):
        lines += [
            "## Sim-to-real gap",
            "",
            "Tuned or trained on the identified model, evaluated on the identified model and on "
            "the virtual rig (its own parameters, sensors and an actuator specimen): "
            "`rig − model` of the mean KPI.",
            "",
        ]
        show = [k for k in (axes.get("accuracy"), axes.get("energy"), axes.get("lifetime")) if k]
        header = ["scenario", "controller"]
        for k in show:
            header += [f"`{k}` model", "rig", "gap"]
        rows = []
        for (scen, ctrl), r in gap.iterrows():
            row = [str(scen), f"`{ctrl}`"]
            for k in show:
                row += [f"{r[f'{k}_model']:.4g}", f"{r[f'{k}_rig']:.4g}", f"{r[f'{k}_gap']:+.3g}"]
            rows.append(row)
        lines += [_md_table(header, rows), ""]
        for rel in (figures or {}).get("gap", []):
            lines += [f"![{Path(rel).stem}]({rel})", ""]
    lines += _lifetime_section(t, figures)
    lines += [
        "## Reproducing",
        "",
        "Every row of `results.csv` records the package version, the environment ID and "
        "version, the scenario key, the controller settings (JSON), the fingerprints of the "
        "FitResults the controller was tuned on (`controller_fits`) and of the plant "
        "(`env_fit_fingerprint`), the plant and the seed.",
        "",
    ]
    return "\n".join(lines)


def _write_table(table: Any, path_csv: Path, path_parquet: Path) -> None:
    atomic_write_text(path_csv, table.to_csv(index=False))
    atomic_write(path_parquet, lambda tmp: table.to_parquet(tmp, index=False))


def _trajectories_frame(res: Any) -> Any:
    frames = []
    for (scen, ctrl, plant, seed), tr in res.trajectories.items():
        df = pd.DataFrame(tr)
        df.insert(0, "seed", seed)
        df.insert(0, "plant", plant)
        df.insert(0, "controller", ctrl)
        df.insert(0, "scenario", scen)
        frames.append(df)
    return pd.concat(frames, ignore_index=True) if frames else None


def write_report(
    res: Any, out: str | os.PathLike[str], *, title: str | None = None, figures: bool = True
) -> dict[str, Path]:
    """Write the tables, trajectories, figures and Markdown summary of a benchmark.

    Parameters
    ----------
    res : BenchmarkResult
    out : path
        Folder (created).
    title : str, optional
        Title of ``summary.md``.
    figures : bool
        Draw the figures (matplotlib).

    Returns
    -------
    dict
        ``name → path`` of what was written.
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    files: dict[str, Path] = {}
    t = res.table
    _write_table(t, out / "results.csv", out / "results.parquet")
    files["results.csv"] = out / "results.csv"
    files["results.parquet"] = out / "results.parquet"
    tf = _trajectories_frame(res)
    if tf is not None:
        atomic_write(out / "trajectories.parquet", lambda tmp: tf.to_parquet(tmp, index=False))
        files["trajectories.parquet"] = out / "trajectories.parquet"
    figs: dict[str, list[str]] = {}
    if figures:
        from thermogym.controllers import plots  # matplotlib (~1 s) only when figures are drawn

        made = plots.benchmark_figures(res, out / "figures")
        for key, paths in made.items():
            figs[key] = [str(p.relative_to(out)) for p in paths]
            for p in paths:
                files[str(p.relative_to(out))] = p
    md = summary_markdown(t, title=title, figures=figs)
    atomic_write_text(out / "summary.md", md)
    files["summary.md"] = out / "summary.md"
    meta = {
        "package_version": __version__,
        "backend": res.backend,
        "workers": res.workers,
        "seconds": res.seconds,
        "episodes": len(t),
        "files": sorted(files),
    }
    atomic_write_text(out / "run.json", json.dumps(meta, indent=1) + "\n")
    files["run.json"] = out / "run.json"
    return files
