"""The main job: the loop of DESIGN.md end to end on embedded defaults.

``thermogym demo --out out`` (or :func:`run_demo`) runs six stages:

========  ===========  ==========================================================
key       module       what it does
========  ===========  ==========================================================
rigs      .rigs        virtual rigs run the papers' experiments (strut: concealed
                       effect; AXT211: a specimen off nominal)
identify  .identify    preparation; FOPTD, N4SID (cross-validated order), AXT211
                       grey-box, strut ratio parameters; FitResults in ``fits/``
diagnose  .diagnose    diagnosis of the strut mismatch; augmented model; fits
                       before/after on training and held-out data
envs      .refresh     envs built from the new FitResults; ParameterRefresh;
                       closed loop on nominal env, refreshed env and rig
control   .control     on/off, PWM, PID, MPC, PPO on energy, lifetime, accuracy
sensor    .sensor      spindle virtual sensor; firmware export, host build,
                       AVR/simavr run
========  ===========  ==========================================================

and writes ``report.html`` (self-contained) and ``report.md``
(:mod:`thermogym.demo.report`). The framework (:mod:`thermogym.demo.core`)
guarantees that a failing stage is reported while the others still run, and
that nothing is left half-written.

Examples
--------
>>> import tempfile
>>> from thermogym.demo import run_demo
>>> res = run_demo(tempfile.mkdtemp(), quick=True, only=["rigs"], progress=False)
>>> [(r.key, r.status) for r in res]
[('rigs', 'ok')]
"""

from __future__ import annotations

import os
import time
from collections.abc import Sequence
from pathlib import Path

from thermogym._fileio import atomic_write_text
from thermogym.demo.control import stage_control
from thermogym.demo.core import (
    DemoContext,
    Stage,
    StageResult,
    StageSkipped,
    Table,
    run_stages,
)
from thermogym.demo.diagnose import stage_diagnose
from thermogym.demo.identify import stage_identify
from thermogym.demo.refresh import stage_refresh
from thermogym.demo.report import render_html, render_markdown
from thermogym.demo.rigs import stage_rigs
from thermogym.demo.sensor import stage_sensor
from thermogym.errors import UnknownNameError

__all__ = [
    "STAGES",
    "DemoContext",
    "Stage",
    "StageResult",
    "StageSkipped",
    "Table",
    "run_demo",
    "stage_keys",
]

STAGES: list[Stage] = [
    Stage("rigs", "1. Virtual test rigs: the papers' experiments", stage_rigs),
    Stage("identify", "2. Preparation and identification", stage_identify),
    Stage("diagnose", "3. Diagnosis of the concealed effect", stage_diagnose),
    Stage("envs", "4. Environments refreshed from the new FitResults", stage_refresh),
    Stage("control", "5. Controller benchmark: energy, lifetime, accuracy", stage_control),
    Stage("sensor", "6. Spindle virtual sensor and its firmware", stage_sensor),
]


def stage_keys() -> list[str]:
    """Keys of the stages, in order (``--only`` takes these)."""
    return [s.key for s in STAGES]


def run_demo(
    out: str | os.PathLike[str] = "out",
    *,
    quick: bool = False,
    seed: int = 0,
    only: Sequence[str] | None = None,
    progress: bool = True,
    stages: Sequence[Stage] | None = None,
) -> list[StageResult]:
    """Run the demo stages and write ``report.html`` and ``report.md`` under ``out``.

    Parameters
    ----------
    out : path
        Output folder (created). Files of earlier runs of the same stages are
        replaced; other files are left alone.
    quick : bool
        Smaller experiments and grids (tests; about a minute).
    seed : int
        Seed of every random draw (same seed, same numbers).
    only : sequence of str, optional
        Run only these stage keys (:func:`stage_keys`); stages that need the
        products of a stage not run are skipped with the reason.
    progress : bool
        Print a line per stage and show progress bars inside stages.
    stages : sequence of Stage, optional
        Run these stages instead of :data:`STAGES` (tests).

    Returns
    -------
    list of StageResult

    Raises
    ------
    UnknownNameError
        A key in ``only`` is not a stage.
    """
    todo = list(STAGES if stages is None else stages)
    if only:
        keys = [s.key for s in todo]
        bad = [k for k in only if k not in keys]
        if bad:
            raise UnknownNameError(f"unknown stage(s) {bad}; stages are {keys}")
        todo = [s for s in todo if s.key in only]
    ctx = DemoContext(Path(out), quick=quick, seed=seed, progress=progress)
    t0 = time.perf_counter()
    results = run_stages(ctx, todo, progress=progress)
    total = time.perf_counter() - t0
    load = os.getloadavg() if hasattr(os, "getloadavg") else None
    kw = {"seed": seed, "quick": quick, "total": total, "load": load}
    atomic_write_text(ctx.out / "report.md", render_markdown(results, **kw))
    atomic_write_text(ctx.out / "report.html", render_html(results, ctx.out, **kw))
    if progress:
        print(f"report: {ctx.out / 'report.html'} (and report.md); total {total:.0f} s")
    return results
