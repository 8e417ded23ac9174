"""Stage 1: the virtual test rigs run the papers' experiments.

The strut and spindle rigs are plants of their own, richer than the models
(:mod:`thermogym.rigs.strut`: the convection of the screw turning in its
enclosed annulus and of the moving push tube grows with the feed rate, a
nonlinearity of the kind paper 000 section 4.1 names as the reason its linear
models fail at other feed rates). The strut rig also
carries a *concealed* effect (``input_dependent_heat_transfer``: a
self-ventilated drive motor whose fan cools it harder at higher feed rates).
Nothing downstream is told about either; stage 3 has to find them.
"""

from __future__ import annotations

import json
import time
from typing import Any

import numpy as np

from thermogym.demo.core import DemoContext, StageResult, StageSkipped
from thermogym.demo.plots import rig_figures
from thermogym.recording import read_recording, write_recording
from thermogym.rigs import get_rig, run_experiment, to_recording
from thermogym.rigs.axt211 import specimen_spread

__all__ = ["CONCEALED", "axt211_specimen", "load_rigs", "stage_rigs"]

#: The strut rig's concealed physics (effect spec of :func:`thermogym.rigs.parse_effect`).
CONCEALED = "input_dependent_heat_transfer"


def axt211_specimen(seed: int) -> tuple[int, Any]:
    """The AXT211 rig's specimen: its physical parameters drawn from the manufacturing spread.

    Returns the specimen seed (``specimen_seed=`` of the AXT211 environments
    with ``plant="rig"`` gives the same actuator) and the specimen
    (:class:`~thermogym.rigs.base.Specimens` of one; paper 002 section VIII
    spread, :func:`thermogym.rigs.axt211.specimen_spread`).
    """
    s = int(seed) + 7
    return s, specimen_spread(np.random.default_rng(s), n=1)


def _run_axt211(ctx: DemoContext, proto: str, folder: Any, seed: int) -> list[Any]:
    """Run an AXT211 protocol on the demo's specimen; write CSV recordings."""
    _, spec = axt211_specimen(ctx.seed)
    rig = get_rig("axt211").with_specimen(spec)
    recs = [to_recording(r, "axt211") for r in rig.run(proto, seed=seed)]
    folder.mkdir(parents=True, exist_ok=True)
    for r in recs:
        write_recording(r, folder / f"{r.experiment_id}.csv")
    return recs


def _spindle_speeds(ctx: DemoContext) -> tuple[list[int], list[int]]:
    """Run-in speeds (Table 4 of paper 001) and validation speeds."""
    if ctx.quick:
        return [6000], [5300]
    return [4000, 6000, 8000], [5300]


def stage_rigs(ctx: DemoContext, res: StageResult) -> None:
    """Run the AXT211, strut and spindle experiments and write the recordings."""
    speeds, vspeeds = _spindle_speeds(ctx)
    s = ctx.seed
    jobs: list[tuple[str, str, dict[str, Any], str, int, list[str]]] = [
        ("axt211", "steps", {}, "csv", s, []),
        ("axt211", "staircase", {}, "csv", s + 1, []),
        ("axt211", "pwm", {}, "csv", s + 2, []),
        ("strut", "steps", {}, "csv", s, [CONCEALED]),
        ("spindle", "run-in", {"speeds": speeds}, "parquet", s, []),
        ("spindle", "validation", {"speeds": vspeeds}, "parquet", s + 1, []),
    ]
    recs: dict[str, list[Any]] = {}
    rows = []
    for rig, proto, opts, fmt, seed, effects in ctx.bar(jobs, "rig experiments"):
        t0 = time.perf_counter()
        folder = ctx.path("recordings", f"{rig}-{proto}")
        if rig == "axt211":
            got = _run_axt211(ctx, proto, folder, seed)
        else:
            got = run_experiment(rig, proto, folder, seed=seed, fmt=fmt, effects=effects, **opts)
        recs[f"{rig}/{proto}"] = got
        rows.append(
            [
                rig,
                proto,
                ", ".join(effects) or "none",
                len(got),
                sum(r.n_samples for r in got),
                f"{time.perf_counter() - t0:.1f} s",
                f"`{ctx.rel(folder)}/`",
            ]
        )
    ctx.products["recordings"] = recs
    res.table(
        ["rig", "protocol", "concealed effect", "recordings", "samples", "time", "folder"],
        rows,
        "Experiments run (CSV with a .meta.json sidecar, or Parquet)",
    )
    for path, caption in rig_figures(ctx, recs):
        res.figure(ctx.rel(path), caption)
    n_raw = max(r.n_samples for r in recs["spindle/run-in"])
    res.shows = (
        "The virtual rigs stand in for the real devices: they run the experiments of the three "
        "papers and write recordings a lab would, with sensor noise, and for the spindle raw "
        "asynchronous multiplexed RTD data with outliers and gaps."
    )
    res.text = (
        "* AXT211 (paper 002): power steps on the 19-29 V × 0-50 °C grid, the closed-loop "
        "temperature staircase (stroke gain and backlash) and a PWM test. The step is "
        "overlaid with the package's nominal model.\n"
        f"* Strut (paper 000): feed-rate steps at 20, 25 and 30 m/min on a plant of its own "
        "(conduction along the screw and the push tube, the enclosed screw's convection "
        "growing with the feed rate, copper losses growing with the winding temperature). The "
        f"rig also carries a **concealed effect** (`{CONCEALED}`: the drive motor's fan cools "
        "it harder at higher feed rates) that no model downstream is told about.\n"
        f"* Spindle (paper 001): run-in days at {', '.join(map(str, speeds))} rpm (two folds "
        f"each) and a validation day at {', '.join(map(str, vspeeds))} rpm, raw: up to "
        f"{n_raw} rows a day at 4.17 Hz per module."
    )
    spec_seed, spec = axt211_specimen(ctx.seed)
    res.text += (
        f"\n\nThe AXT211 rig is one actuator from the manufacturing spread of paper 002 "
        f"section VIII (specimen seed {spec_seed}: "
        + ", ".join(
            f"`{k}` = {spec[k][0]:.4g}" for k in ("T_m", "L_w", "R_min", "T_ref", "c_backlash")
        )
        + ", and the rest of its physical parameters), not the package's nominal actuator: "
        "identification has to find it with a model that lacks part of the rig's physics."
    )
    res.highlights["recordings written"] = str(sum(len(v) for v in recs.values()))


def load_rigs(ctx: DemoContext) -> None:
    """Products of an earlier rigs stage in ``ctx.out``: its recordings, by experiment."""
    root = ctx.out / "recordings"
    if not root.is_dir():
        raise StageSkipped(f"no earlier recordings in {str(root)!r}")
    recs: dict[str, list[Any]] = {}
    for folder in sorted(p for p in root.iterdir() if p.is_dir()):
        rig, sep, proto = folder.name.partition("-")
        if not sep:
            continue
        manifest = folder / "manifest.json"
        if manifest.is_file():
            names = [e["file"] for e in json.loads(manifest.read_text())["recordings"]]
        else:  # the AXT211 experiments are written one by one, without a manifest
            names = sorted(
                f.name for f in folder.iterdir() if f.name.endswith((".csv", ".parquet"))
            )
        recs[f"{rig}/{proto}"] = [read_recording(folder / n) for n in names]
    if not recs:
        raise StageSkipped(f"no earlier recordings in {str(root)!r}")
    ctx.products["recordings"] = recs
