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
(:mod:`thermogym.demo.report`), with ``report.json`` (the sections, read back
when a later ``--only`` run keeps a stage's earlier section). The framework
(:mod:`thermogym.demo.core`) guarantees that a failing stage is reported while
the others still run, that nothing is left half-written, and that a stage not
run leaves its earlier files and report section alone.

Examples
--------
>>> import tempfile
>>> from thermogym.demo import run_demo
>>> res = run_demo(tempfile.mkdtemp(), quick=True, only=["rigs"], progress=False)
>>> [(r.key, r.status) for r in res]
[('rigs', 'ok')]
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from thermogym._fileio import atomic_write_many
from thermogym.demo.control import stage_control
from thermogym.demo.core import (
    MANIFEST,
    DemoContext,
    DemoInterrupted,
    Stage,
    StageResult,
    StageSkipped,
    Table,
    run_stages,
)
from thermogym.demo.diagnose import load_diagnose, stage_diagnose
from thermogym.demo.identify import load_identify, stage_identify
from thermogym.demo.refresh import stage_refresh
from thermogym.demo.report import render_html, render_markdown
from thermogym.demo.rigs import load_rigs, stage_rigs
from thermogym.demo.sensor import stage_sensor
from thermogym.errors import UnknownNameError

__all__ = [
    "STAGES",
    "DemoContext",
    "DemoInterrupted",
    "Stage",
    "StageResult",
    "StageSkipped",
    "Table",
    "run_demo",
    "stage_keys",
]

#: Sections of the last report, read back when a later run does not run every stage.
REPORT_DATA = "report.json"

STAGES: list[Stage] = [
    Stage("rigs", "1. Virtual test rigs: the papers' experiments", stage_rigs, load_rigs),
    Stage("identify", "2. Preparation and identification", stage_identify, load_identify),
    Stage("diagnose", "3. Diagnosis of the concealed effect", stage_diagnose, load_diagnose),
    Stage("envs", "4. Environments refreshed from the new FitResults", stage_refresh),
    Stage("control", "5. Controller benchmark: energy, lifetime, accuracy", stage_control),
    Stage("sensor", "6. Spindle virtual sensor and its firmware", stage_sensor),
]


def stage_keys() -> list[str]:
    """Keys of the stages, in order (``--only`` takes these)."""
    return [s.key for s in STAGES]


def _earlier_sections(out: Path) -> dict[str, StageResult]:
    """The report sections of an earlier run in ``out`` (``report.json``), by stage."""
    try:
        doc = json.loads((out / REPORT_DATA).read_text(encoding="utf-8"))
        return {d["key"]: StageResult.from_dict(d) for d in doc["sections"]}
    except (OSError, ValueError, KeyError, TypeError):
        return {}


def _sections(
    todo: Sequence[Stage],
    results: list[StageResult],
    earlier: dict[str, StageResult],
    manifest: dict[str, Any],
) -> list[StageResult]:
    """The report's sections in stage order: this run's, else an earlier run's (marked)."""
    now = {r.key: r for r in results}
    out = []
    for stage in todo:
        r = now.get(stage.key)
        old = earlier.get(stage.key)
        entry = manifest.get(stage.key, {})
        keep = (
            old is not None
            and old.status == "ok"
            and entry.get("status") == "ok"
            and (r is None or r.status in ("skipped", "interrupted"))
        )
        if keep:
            assert old is not None  # for the type checker; checked above
            when = old.ran_at or entry.get("ran_at") or "an earlier run"
            why = "not run this time" if r is None else f"{r.status} this time ({r.error})"
            other = (
                f" with seed {entry['seed']}{', quick mode' if entry.get('quick') else ''}"
                if "seed" in entry
                else ""
            )
            old.carried = True
            old.note = (
                f"{why[0].upper()}{why[1:]}: this section and its files are from the run of "
                f"{when}{other}."
            )
            old.seconds = 0.0 if r is None else r.seconds
            out.append(old)
        elif r is not None:
            out.append(r)
        elif entry.get("status") in ("failed", "interrupted"):
            # not run this time, and it did not finish last time: say so (its log stays)
            when = entry.get("ran_at") or "an earlier run"
            if old is None or old.status != entry["status"]:
                old = StageResult(
                    stage.key,
                    stage.title,
                    status=str(entry["status"]),
                    error=f"see logs/{stage.key}.txt",
                    ran_at=str(entry.get("ran_at", "")),
                )
            old.carried = True
            old.seconds = 0.0
            old.note = f"Not run this time: it {old.status} in the run of {when}."
            out.append(old)
    return out


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
        Run only these stage keys (:func:`stage_keys`). The other stages keep
        their earlier files and report sections; a selected stage reuses the
        outputs an earlier run of the stages before it left in ``out`` (same
        seed and mode), and is skipped with the reason when they are not there.
    progress : bool
        Print a line per stage and show progress bars inside stages (bars
        only on a terminal).
    stages : sequence of Stage, optional
        Run these stages instead of :data:`STAGES` (tests).

    Returns
    -------
    list of StageResult
        The stages run, in order.

    Raises
    ------
    UnknownNameError
        A key in ``only`` is not a stage.
    DemoInterrupted
        Ctrl-C (a ``KeyboardInterrupt``); the interrupted stage published
        nothing. The manifest and the reports are rewritten only when a stage
        of this run finished before it (its files were replaced); otherwise
        every file in ``out`` is as it was.
    """
    every = list(STAGES if stages is None else stages)
    todo = every
    if only:
        keys = [s.key for s in todo]
        bad = [k for k in only if k not in keys]
        if bad:
            raise UnknownNameError(f"unknown stage(s) {bad}; stages are {keys}")
        todo = [s for s in todo if s.key in only]
    ctx = DemoContext(Path(out), quick=quick, seed=seed, progress=progress)
    earlier = _earlier_sections(ctx.out)
    t0 = time.perf_counter()
    results = run_stages(ctx, todo, progress=progress, all_stages=every)
    total = time.perf_counter() - t0
    load = os.getloadavg() if hasattr(os, "getloadavg") else None
    kw: dict[str, Any] = {"seed": seed, "quick": quick, "total": total, "load": load}
    try:
        manifest = json.loads((ctx.out / MANIFEST).read_text())["stages"]
    except (OSError, ValueError, KeyError):
        manifest = {}
    sections = _sections(every, results, earlier, manifest)
    stopped = next((r.key for r in results if r.status == "interrupted"), None)
    finished = [r.key for r in results if r.status in ("ok", "failed")]
    if stopped is not None and not finished:
        # nothing this run did changed a file: the earlier reports still describe the folder
        raise DemoInterrupted(stopped, [], reports=False)
    atomic_write_many(
        [
            (ctx.out / "report.md", _writer(render_markdown(sections, **kw))),
            (ctx.out / "report.html", _writer(render_html(sections, ctx.out, **kw))),
            (
                ctx.out / REPORT_DATA,
                _writer(
                    json.dumps(
                        {
                            "seed": seed,
                            "quick": quick,
                            "sections": [
                                {**r.to_dict(), "carried": False, "note": ""}
                                for r in sections
                                if r.status in ("ok", "failed")
                            ],
                        },
                        indent=1,
                        default=str,
                    )
                ),
            ),
        ]
    )
    if stopped is not None:
        raise DemoInterrupted(stopped, finished, reports=True)
    if progress:
        print(f"report: {ctx.out / 'report.html'} (and report.md); total {total:.0f} s")
    return results


def _writer(text: str) -> Callable[[Path], None]:
    data = text.encode("utf-8")

    def write(tmp: Path) -> None:
        tmp.write_bytes(data)

    return write
