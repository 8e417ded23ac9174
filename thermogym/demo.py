"""The main job: the loop of DESIGN.md end to end on embedded defaults.

``thermogym demo --out out`` runs a sequence of *stages*. Each stage reads
what earlier stages left in the shared :class:`DemoContext`, writes its files
under the output folder and returns a :class:`StageResult` (text, tables,
figures). A stage that fails is reported as failed with its error and the
following stages still run (those that need its products are skipped with a
reason). The report (``report.md``) is written atomically at the end.
"""

from __future__ import annotations

import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from thermogym import __version__
from thermogym._fileio import atomic_write_text

__all__ = ["STAGES", "DemoContext", "Stage", "StageResult", "run_demo"]


@dataclass
class StageResult:
    """What one stage produced."""

    key: str
    title: str
    status: str = "ok"  # ok | failed | skipped
    seconds: float = 0.0
    text: str = ""
    tables: list[str] = field(default_factory=list)
    figures: list[tuple[str, str]] = field(default_factory=list)  # (relative path, caption)
    error: str | None = None


@dataclass
class DemoContext:
    """Shared state of a demo run."""

    out: Path
    quick: bool = False
    seed: int = 0
    products: dict[str, Any] = field(default_factory=dict)

    def path(self, *parts: str) -> Path:
        """A path under the output folder, its parent created."""
        p = self.out.joinpath(*parts)
        p.parent.mkdir(parents=True, exist_ok=True)
        return p

    def rel(self, p: Path) -> str:
        """``p`` relative to the output folder (for the report)."""
        return str(Path(p).relative_to(self.out))

    def need(self, *keys: str) -> None:
        """Raise :class:`StageSkipped` if an earlier stage did not produce ``keys``."""
        missing = [k for k in keys if k not in self.products]
        if missing:
            raise StageSkipped(f"needs {missing} from an earlier stage that did not finish")


class StageSkipped(Exception):
    """Raised by a stage whose inputs are missing."""


@dataclass(frozen=True)
class Stage:
    """A step of the demo."""

    key: str
    title: str
    run: Callable[[DemoContext, StageResult], None]


def _md_table(header: list[str], rows: list[list[Any]]) -> str:
    def fmt(v: Any) -> str:
        if isinstance(v, float):
            return f"{v:.4g}"
        return str(v)

    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(fmt(v) for v in row) + " |" for row in rows]
    return "\n".join(lines)


# --------------------------------------------------------------------------- stages
def _stage_rigs(ctx: DemoContext, res: StageResult) -> None:
    from thermogym.models.registry import get_model
    from thermogym.plotting import plot_recordings
    from thermogym.rigs import run_experiment

    rec_dir = ctx.out / "recordings"
    recs: dict[str, list[Any]] = {}
    spindle_speeds = [4000, 8000] if ctx.quick else [4000, 5000, 6000, 7000, 8000]
    jobs = [
        ("axt211", "steps", {}, "csv"),
        ("axt211", "pwm", {}, "csv"),
        ("axt211", "staircase", {}, "csv"),
        ("strut", "steps", {}, "csv"),
        ("spindle", "run-in", {"speeds": spindle_speeds}, "parquet"),
    ]
    rows = []
    for rig, proto, opts, fmt in jobs:
        t0 = time.perf_counter()
        got = run_experiment(rig, proto, rec_dir / f"{rig}-{proto}", seed=ctx.seed, fmt=fmt, **opts)
        recs[f"{rig}/{proto}"] = got
        rows.append(
            [
                rig,
                proto,
                len(got),
                sum(r.n_samples for r in got),
                f"{time.perf_counter() - t0:.1f} s",
                f"recordings/{rig}-{proto}/",
            ]
        )
    ctx.products["recordings"] = recs
    res.tables.append(
        _md_table(["rig", "protocol", "recordings", "samples", "time", "folder"], rows)
    )

    step = next(r for r in recs["axt211/steps"] if r.experiment_id == "axt211-step-24V-25C")
    model = get_model("axt211")
    sim = model.simulate(step.exogenous_array(model), step.dt)
    fig = plot_recordings(
        [step],
        ctx.path("figures", "axt211_step.png"),
        signals=["u", "P_PTC", "T_P", "T_G", "x_V"],
        overlay={"nominal model": {n: sim.output(n)[0] for n in model.output_names}},
        title="AXT211 rig: power step at 24 V, 25 °C",
    )
    res.figures.append((ctx.rel(fig), "AXT211 rig step test against the nominal model"))
    fig = plot_recordings(
        recs["axt211/staircase"],
        ctx.path("figures", "axt211_staircase.png"),
        signals=["T_P_setpoint", "T_P", "u", "x_V"],
        title="AXT211 closed-loop temperature staircase (paper 002 Fig. 3)",
    )
    res.figures.append((ctx.rel(fig), "Stroke gain and backlash from the temperature staircase"))
    fig = plot_recordings(
        recs["strut/steps"],
        ctx.path("figures", "strut_steps.png"),
        signals=["T_drive", "T_nut", "T_spindle", "T_tube_rear", "dL_um"],
        title="Strut feed-rate steps (paper 000 section 4)",
    )
    res.figures.append((ctx.rel(fig), "Strut step tests at 20, 25 and 30 m/min"))
    day = recs["spindle/run-in"][-1]
    fig = plot_recordings(
        [day],
        ctx.path("figures", "spindle_raw.png"),
        signals=["speed", "T_front_bearing_C", "T_inner_housing", "T_front_outer_housing", "T_amb"],
        title=f"Spindle raw asynchronous recording {day.experiment_id}",
    )
    res.figures.append((ctx.rel(fig), "Raw spindle run-in day (two multiplexed RTD modules)"))
    res.text = (
        "The virtual test rigs ran the experiments of the three papers and wrote their "
        "recordings (CSV or Parquet with metadata) under `recordings/`. The AXT211 step is "
        "overlaid with the nominal model: the rig adds sensor noise only, so they agree."
    )


STAGES: list[Stage] = [
    Stage("rigs", "1. Virtual test rigs: experiments like the papers'", _stage_rigs),
]


# --------------------------------------------------------------------------- runner
def _render_markdown(results: list[StageResult], ctx: DemoContext, total: float) -> str:
    lines = [
        "# thermogym demo report",
        "",
        f"thermogym {__version__}, seed {ctx.seed}{', quick mode' if ctx.quick else ''}; "
        f"total {total:.0f} s.",
        "",
        _md_table(
            ["stage", "status", "time"],
            [[r.title, r.status, f"{r.seconds:.1f} s"] for r in results],
        ),
        "",
    ]
    for r in results:
        lines += [f"## {r.title}", ""]
        if r.status != "ok":
            lines += [f"**{r.status.upper()}**: {r.error}", ""]
        if r.text:
            lines += [r.text, ""]
        for t in r.tables:
            lines += [t, ""]
        for path, caption in r.figures:
            lines += [f"![{caption}]({path})", "", f"*{caption}*", ""]
    return "\n".join(lines)


def run_demo(
    out: str | Path = "out",
    *,
    quick: bool = False,
    seed: int = 0,
    only: list[str] | None = None,
    progress: bool = True,
) -> list[StageResult]:
    """Run the demo stages and write ``report.md`` under ``out``.

    Parameters
    ----------
    out : path
        Output folder (created).
    quick : bool
        Smaller experiments, for tests.
    seed : int
        Seed of every random draw.
    only : list of str, optional
        Run only these stage keys.
    progress : bool
        Print a line per stage.

    Returns
    -------
    list of StageResult
    """
    ctx = DemoContext(Path(out), quick=quick, seed=seed)
    ctx.out.mkdir(parents=True, exist_ok=True)
    results = []
    t_all = time.perf_counter()
    stages = [s for s in STAGES if only is None or s.key in only]
    for i, stage in enumerate(stages, 1):
        res = StageResult(stage.key, stage.title)
        if progress:
            print(f"[{i}/{len(stages)}] {stage.title} ...", flush=True)
        t0 = time.perf_counter()
        try:
            stage.run(ctx, res)
        except StageSkipped as e:
            res.status, res.error = "skipped", str(e)
        except Exception as e:
            res.status = "failed"
            res.error = f"{type(e).__name__}: {e}"
            (ctx.path("logs", f"{stage.key}.txt")).write_text(traceback.format_exc())
        res.seconds = time.perf_counter() - t0
        if progress:
            print(
                f"      {res.status} in {res.seconds:.1f} s"
                + (f": {res.error}" if res.error else ""),
                flush=True,
            )
        results.append(res)
    total = time.perf_counter() - t_all
    atomic_write_text(ctx.out / "report.md", _render_markdown(results, ctx, total))
    if progress:
        print(f"report: {ctx.out / 'report.md'}")
    return results
