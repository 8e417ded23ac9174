"""Public generalisation suite of the mismatch diagnosis (issue 15).

Runs :func:`thermogym.identification.diagnosis.diagnose` (public API only) on
every case of :mod:`benchmarks.diagnosis.cases` and scores the answer against
the ground truth the suite made independently of the diagnosis::

    python benchmarks/diagnosis/generalisation.py --json out/results.json --workers 2
    python benchmarks/diagnosis/generalisation.py --json out/quick.json --quick
    python benchmarks/diagnosis/generalisation.py --json out/p.json --cases 'plate/*'
    python benchmarks/diagnosis/generalisation.py --from-json out/results.json  # redraw only

Figures (fractions in [0, 1]):

``single_top1``
    single-effect cases whose first named effect is the truth;
``single_top3``
    single-effect cases whose truth is among the first three distinct effects
    of the ranking (``hypotheses``);
``combo_both``
    two-effect cases with both truths in ``named_effects``;
``controls_no_physics``
    controls whose ``named_effects`` lie within {none, parameter_error};
``heldout_improves``
    correctly named cases (single top-1, combination both) whose held-out fit
    after the augmentation beats the nominal fit;
``median_s``, ``max_s``
    CPU seconds of ``diagnose`` per case (one core: BLAS and numba threads are
    limited to 1; CPU time is what a case costs on an idle core, wall time
    grows with the load of the shared machine and is kept per case).

Until the diagnosis report carries ``named_effects``, :func:`named_effects`
derives it from today's keys (``mismatch_detected``, ``best``); the JSON says
which (``named_effects_source``).

Writes ``PATH`` (``{"figures": ..., "cases": [...]}``), and beside it
``table.md`` and ``summary.png``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import statistics
import sys
import time
import traceback
from collections.abc import Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

if __name__ in ("__main__", "__mp_main__"):  # before numpy, scipy or numba load
    from benchmarks.diagnosis._onecore import one_core

    one_core()


from benchmarks.diagnosis.cases import Case, build, select  # noqa: E402
from thermogym.vocabulary import EFFECT_NAMES, PHYSICS_EFFECTS  # noqa: E402

NO_PHYSICS = ("none", "parameter_error")
ADAPTER_RULE = (
    "named_effects derived from today's report: ['none'] when mismatch_detected is false; "
    "else [best.maps_to or best.effect] when that is a vocabulary name; else ['unexplained'] "
    "(a significant mismatch nothing explains)"
)


# ------------------------------------------------------------------ reading the report
def named_effects(report: Mapping[str, Any]) -> tuple[list[str], str]:
    """The effects a report names, and where they were read from (``report`` or ``adapter``).

    The one place that knows today's report layout: once the diagnosis writes
    ``named_effects`` (contracts.md), that list is used as it is.
    """
    if "named_effects" in report:
        return [str(e) for e in report["named_effects"]], "report"
    if not report.get("mismatch_detected", False):
        return ["none"], "adapter"
    best = report.get("best") or {}
    for key in ("maps_to", "effect"):
        e = best.get(key)
        if e in EFFECT_NAMES:
            return [str(e)], "adapter"
    return ["unexplained"], "adapter"


def ranking(report: Mapping[str, Any]) -> list[str]:
    """Distinct vocabulary effects of the report's hypotheses, best first."""
    hyps = sorted(report.get("hypotheses") or [], key=lambda h: h.get("rank", math.inf))
    out: list[str] = []
    for h in hyps:
        e = h.get("maps_to") if h.get("maps_to") in EFFECT_NAMES else h.get("effect")
        if e in EFFECT_NAMES and e not in out:
            out.append(str(e))
    return out


def _mean_fit(block: Any) -> float:
    if isinstance(block, Mapping):
        v = block.get("mean")
        if isinstance(v, (int, float)) and math.isfinite(v):
            return float(v)
    return math.nan


def score(
    case_truth: Sequence[str], kind: str, named: Sequence[str], ranked: Sequence[str]
) -> dict[str, Any]:
    """Hit flags of one case (None where a flag does not apply to its kind)."""
    top1 = top3 = both = control = None
    if kind == "single":
        top1 = bool(named) and named[0] == case_truth[0]
        top3 = case_truth[0] in list(ranked)[:3]
    elif kind == "combo":
        both = all(t in named for t in case_truth)
    else:
        control = bool(named) and all(e in NO_PHYSICS for e in named)
    correct = bool(top1 or both)
    return {"top1": top1, "top3": top3, "both": both, "control_ok": control, "correct": correct}


# ------------------------------------------------------------------------- one case
def run_case(case: Case, time_limit: float | None = None) -> dict[str, Any]:
    """Make a case's recordings, diagnose them blind, score the answer."""
    from threadpoolctl import threadpool_limits

    from thermogym.identification.diagnosis import diagnose

    row: dict[str, Any] = {
        "case": case.name,
        "family": case.family,
        "kind": case.kind,
        "model": case.model,
        "seed": case.seed,
        "truth": case.truth,
        "hidden": [h.to_dict() for h in case.hidden],
    }
    t0 = time.perf_counter()
    try:
        built = build(case)
    except Exception as e:  # a bug in the suite: say so, do not score the diagnosis
        row.update(error=f"building the case failed: {e!r}", traceback=traceback.format_exc())
        return row
    row.update(
        seconds_generate=time.perf_counter() - t0,
        share=built.share,
        rms=built.rms,
        note=built.note,
        constants=built.constants,
        n_train=[r.n_samples for r in built.train],
        n_validate=[r.n_samples for r in built.validate],
        model_given=(
            built.model
            if isinstance(built.model, str)
            else f"{type(built.model).__name__} (user's Model)"
        ),
    )
    opts = dict(built.options)
    if time_limit is not None:
        opts["time_limit"] = time_limit
    w0, c0 = time.perf_counter(), time.process_time()
    try:
        with threadpool_limits(1):
            rep = diagnose(built.model, built.train, built.validate, **opts)
        report = rep.to_dict()
    except Exception as e:
        row.update(
            seconds=time.perf_counter() - w0,
            cpu_seconds=time.process_time() - c0,
            error=f"diagnose raised {type(e).__name__}: {e}",
            named_effects=["error"],
            named_effects_source="error",
            ranking=[],
            **score(case.truth, case.kind, ["error"], []),
        )
        return row
    named, source = named_effects(report)
    ranked = ranking(report)
    # hypotheses the diagnosis could not fit, with the first reason (for its engineers)
    failed = [h for h in report.get("hypotheses") or [] if h.get("error")]
    before = _mean_fit((report.get("fit_before") or {}).get("validation"))
    after = _mean_fit((report.get("fit_after") or {}).get("validation"))
    if math.isnan(after):
        after = before  # nothing adopted: the nominal model stands
    row.update(
        seconds=time.perf_counter() - w0,
        cpu_seconds=time.process_time() - c0,
        named_effects=named,
        named_effects_source=source,
        ranking=ranked,
        verdict=report.get("verdict", ""),
        hypotheses_failed=len(failed),
        hypotheses_failed_first=str(failed[0]["error"])[:300] if failed else None,
        mismatch_detected=report.get("mismatch_detected"),
        heldout_before=before,
        heldout_after=after,
        train_before=_mean_fit((report.get("fit_before") or {}).get("train")),
        train_after=_mean_fit((report.get("fit_after") or {}).get("train")),
        **score(case.truth, case.kind, named, ranked),
    )
    row["heldout_improves"] = (
        bool(after > before) if math.isfinite(before) and math.isfinite(after) else False
    )
    return row


# -------------------------------------------------------------------------- figures
def _frac(flags: Sequence[bool | None]) -> float | None:
    vals = [bool(f) for f in flags if f is not None]
    return sum(vals) / len(vals) if vals else None


def figures(rows: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """The suite's headline figures (fractions in [0, 1]; None where nothing counts)."""
    ok = [r for r in rows if "building the case failed" not in str(r.get("error", ""))]
    single = [r for r in ok if r["kind"] == "single"]
    combo = [r for r in ok if r["kind"] == "combo"]
    ctrl = [r for r in ok if r["kind"] == "control"]
    correct = [r for r in ok if r.get("correct")]
    cpu = [r["cpu_seconds"] for r in ok if "cpu_seconds" in r]
    wall = [r["seconds"] for r in ok if "seconds" in r]
    return {
        "single_top1": _frac([r["top1"] for r in single]),
        "single_top3": _frac([r["top3"] for r in single]),
        "combo_both": _frac([r["both"] for r in combo]),
        "controls_no_physics": _frac([r["control_ok"] for r in ctrl]),
        "heldout_improves": _frac([r.get("heldout_improves") for r in correct]),
        "median_s": statistics.median(cpu) if cpu else None,
        "max_s": max(cpu) if cpu else None,
        # beside the headline: counts and the lenient control figure
        "controls_no_named_physics": _frac(
            [not any(e in PHYSICS_EFFECTS for e in r.get("named_effects", [])) for r in ctrl]
        ),
        "median_wall_s": statistics.median(wall) if wall else None,
        "max_wall_s": max(wall) if wall else None,
        "cases_over_60s": sum(1 for c in cpu if c > 60.0),
        "n_cases": len(rows),
        "n_single": len(single),
        "n_combo": len(combo),
        "n_controls": len(ctrl),
        "n_correct": len(correct),
        "n_errors": sum(1 for r in rows if r.get("error")),
        "n_cases_with_failed_hypotheses": sum(1 for r in rows if r.get("hypotheses_failed")),
    }


def breakdown(rows: Sequence[Mapping[str, Any]], key: str) -> dict[str, dict[str, int]]:
    """Hits and cases per family or per true effect (a combination counts for each)."""
    out: dict[str, dict[str, int]] = {}
    for r in rows:
        keys = [r["family"]] if key == "family" else list(r["truth"])
        hit = bool(r.get("correct") or r.get("control_ok"))
        for k in keys:
            d = out.setdefault(k, {"hit": 0, "n": 0})
            d["n"] += 1
            d["hit"] += int(hit)
    return out


# --------------------------------------------------------------------------- outputs
def _f(v: Any, fmt: str = ".3f") -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "–"
    return format(v, fmt)


def markdown(doc: Mapping[str, Any]) -> str:
    """The results as a Markdown page: figures, per family and effect, one row per case."""
    fig, meta = doc["figures"], doc["meta"]
    lines = [
        "# Generalisation suite of the diagnosis: results",
        "",
        f"Run {meta['date']} on {meta['machine']}; {meta['n_workers']} worker(s), "
        f"{fig['n_cases']} cases. `named_effects` source: {meta['named_effects_source']}.",
        "",
        "| figure | value |",
        "|---|---|",
    ]
    for k in (
        "single_top1",
        "single_top3",
        "combo_both",
        "controls_no_physics",
        "controls_no_named_physics",
        "heldout_improves",
        "median_s",
        "max_s",
        "cases_over_60s",
    ):
        lines.append(f"| {k} | {_f(fig[k], '.3g') if isinstance(fig[k], float) else fig[k]} |")
    for title, key in (("Per family", "by_family"), ("Per true effect", "by_effect")):
        lines += ["", f"## {title}", "", "| | hits | cases |", "|---|---|---|"]
        for k, d in sorted(doc[key].items()):
            lines.append(f"| {k} | {d['hit']} | {d['n']} |")
    lines += [
        "",
        "## Cases",
        "",
        "Share: the effect's share of the output power on the noise-free training data before any "
        "refit, `ms(Δ)/(ms(Δ)+var(y))`, and its RMS size in the output's unit.",
        "",
        "| case | truth: size | share (RMS) | named | ranking (first 3) | hit "
        "| held-out fit before → after | CPU s |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in doc["cases"]:
        truth = (
            "; ".join(f"{h['effect']} ({h['form']}): {h['size']}" for h in r["hidden"])
            or "none (control)"
        )
        share = r.get("share", {}).get("all")
        rms = r.get("rms", {}).get("all")
        share_s = f"{_f(share, '.3g')} ({_f(rms, '.2g')})" if share is not None else "–"
        hit = "✓" if (r.get("correct") or r.get("control_ok")) else "✗"
        if r["kind"] == "single" and not r.get("top1") and r.get("top3"):
            hit = "top-3"
        named = ", ".join(r.get("named_effects", [])) or "–"
        if r.get("error"):
            named = f"error: {r['error'][:60]}"
        ranked = ", ".join(r.get("ranking", [])[:3]) or "–"
        fits = f"{_f(r.get('heldout_before'))} → {_f(r.get('heldout_after'))}"
        lines.append(
            f"| {r['case']} | {truth} | {share_s} | {named} | {ranked} | {hit} | {fits} "
            f"| {_f(r.get('cpu_seconds'), '.1f')} |"
        )
    return "\n".join(lines) + "\n"


def plot(doc: Mapping[str, Any], path: Path) -> None:
    """Summary figure: hits per family and per effect, and the CPU time per case."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(16, 5.5), gridspec_kw={"width_ratios": [1, 2.2, 1.6]})
    for ax, key, title in (
        (axes[0], "by_family", "per family"),
        (axes[1], "by_effect", "per true effect"),
    ):
        items = sorted(doc[key].items())
        names = [k for k, _ in items]
        hit = [d["hit"] for _, d in items]
        miss = [d["n"] - d["hit"] for _, d in items]
        ax.barh(names, hit, color="tab:green", label="hit")
        ax.barh(names, miss, left=hit, color="tab:red", alpha=0.6, label="miss")
        ax.set_title(f"Hits {title}")
        ax.set_xlabel("cases")
        ax.invert_yaxis()
        ax.tick_params(axis="y", labelsize=8)
    axes[0].legend(loc="lower right")
    import numpy as np

    rows = [r for r in doc["cases"] if "cpu_seconds" in r]
    fams = sorted({r["family"] for r in rows})
    for i, f in enumerate(fams):
        ts = [r["cpu_seconds"] for r in rows if r["family"] == f]
        ok = [bool(r.get("correct") or r.get("control_ok")) for r in rows if r["family"] == f]
        x = i + 0.5 * (np.linspace(0.0, 1.0, len(ts)) - 0.5) if len(ts) > 1 else np.full(1, i)
        axes[2].scatter(x, ts, c=["tab:green" if o else "tab:red" for o in ok], s=14)
    axes[2].axhline(60.0, color="k", ls="--", lw=0.8)
    axes[2].set_yscale("log")
    axes[2].set_xticks(range(len(fams)), fams, rotation=30)
    axes[2].set_ylabel("CPU seconds of diagnose")
    axes[2].set_title("Time per case (green: hit)")
    fg = doc["figures"]
    fig.suptitle(
        f"Generalisation suite: single top-1 {_f(fg['single_top1'], '.2f')}, top-3 "
        f"{_f(fg['single_top3'], '.2f')}, combinations {_f(fg['combo_both'], '.2f')}, controls "
        f"{_f(fg['controls_no_physics'], '.2f')}"
    )
    fig.tight_layout()
    from thermogym._fileio import atomic_write

    atomic_write(path, lambda tmp: fig.savefig(tmp, dpi=110, format="png"))
    plt.close(fig)


def write(doc: Mapping[str, Any], json_path: Path, *, with_json: bool = True) -> None:
    """The JSON, the Markdown table and the figure beside it (each written atomically)."""
    from thermogym._fileio import atomic_write_text

    json_path.parent.mkdir(parents=True, exist_ok=True)
    if with_json:
        text = json.dumps(doc, indent=1, allow_nan=False, default=_json) + "\n"
        atomic_write_text(json_path, text)
    atomic_write_text(json_path.parent / "table.md", markdown(doc))
    plot(doc, json_path.parent / "summary.png")


def _json(v: Any) -> Any:
    if hasattr(v, "tolist"):
        return v.tolist()
    raise TypeError(f"not JSON-serialisable: {type(v).__name__}")


def _clean(v: Any) -> Any:
    """NaN and infinities as None (strict JSON)."""
    if isinstance(v, float) and not math.isfinite(v):
        return None
    if isinstance(v, dict):
        return {k: _clean(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_clean(x) for x in v]
    return v


def main(argv: Sequence[str] | None = None) -> int:
    """Command line."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--json", type=Path, help="results file (table.md and summary.png beside it)")
    ap.add_argument("--quick", action="store_true", help="the representative ~20-case subset")
    ap.add_argument(
        "--cases", help="only cases whose name matches this pattern (fnmatch or substring)"
    )
    ap.add_argument("--workers", type=int, default=1, help="processes (default 1)")
    ap.add_argument(
        "--time-limit",
        type=float,
        default=None,
        help="pass diagnose(time_limit=S) (recorded in the JSON; default: none)",
    )
    ap.add_argument("--list", action="store_true", help="list the selected cases and exit")
    ap.add_argument(
        "--from-json", type=Path, help="redraw table.md and summary.png from a results file"
    )
    args = ap.parse_args(argv)
    if args.from_json is not None:
        # redraw: the table and figure beside --json (or the input); the input is never rewritten
        doc = json.loads(args.from_json.read_text(encoding="utf-8"))
        target = args.json or args.from_json
        write(doc, target, with_json=target.resolve() != args.from_json.resolve())
        return 0
    cases = select(args.cases, quick=args.quick)
    if args.list:
        for c in cases:
            print(c.name)
        print(f"{len(cases)} cases", file=sys.stderr)
        return 0
    if args.json is None:
        ap.error("--json PATH is required")
    if not cases:
        ap.error(f"no case matches {args.cases!r}")
    if args.workers < 1:
        ap.error(f"--workers is {args.workers}, expected at least 1")
    load0 = os.getloadavg()[0]
    t0 = time.perf_counter()
    rows: list[dict[str, Any]] = []
    if args.workers == 1:
        for c in cases:
            rows.append(run_case(c, args.time_limit))
            _progress(rows[-1], len(rows), len(cases))
    else:
        with ProcessPoolExecutor(args.workers, mp_context=get_context("spawn")) as ex:
            futs = [ex.submit(run_case, c, args.time_limit) for c in cases]
            for i, f in enumerate(futs):
                rows.append(f.result())
                _progress(rows[-1], i + 1, len(cases))
    sources = sorted({r.get("named_effects_source", "error") for r in rows} - {"error"})
    doc = {
        "figures": figures(rows),
        "by_family": breakdown(rows, "family"),
        "by_effect": breakdown(rows, "effect"),
        "meta": {
            "date": time.strftime("%Y-%m-%d %H:%M"),
            "machine": f"{platform.machine()}, {os.cpu_count()} CPUs",
            "python": platform.python_version(),
            "n_workers": args.workers,
            "quick": args.quick,
            "pattern": args.cases,
            "time_limit": args.time_limit,
            "wall_seconds_total": time.perf_counter() - t0,
            "load_1min_start": load0,
            "load_1min_end": os.getloadavg()[0],
            "named_effects_source": ", ".join(sources) or "–",
            "adapter_rule": ADAPTER_RULE if "adapter" in sources else None,
            "threads": "BLAS, OpenMP and numba limited to 1 thread per case",
        },
        "cases": rows,
    }
    doc = _clean(doc)
    write(doc, args.json)
    fg = doc["figures"]
    print(json.dumps({k: fg[k] for k in list(fg)[:7]}, indent=1))
    return 0


def _progress(row: Mapping[str, Any], i: int, n: int) -> None:
    hit = "ok " if (row.get("correct") or row.get("control_ok")) else "MISS"
    named = ",".join(row.get("named_effects", []))
    cpu = row.get("cpu_seconds", math.nan)
    print(
        f"[{i:3d}/{n}] {hit} {row['case']:<78s} -> {named:<40s} {cpu:6.1f} s"
        + (f"  ERROR {row['error'][:80]}" if row.get("error") else ""),
        file=sys.stderr,
        flush=True,
    )


if __name__ == "__main__":
    raise SystemExit(main())
