"""Concealed-effect benchmark: can ``diagnose`` name physics it was not told about?

For each of the three plants (strut, AXT211, spindle) the virtual rig records
the papers' experiments with one concealed effect at a realistic magnitude (or
none: controls), at the rig's realistic sensor noise. ``diagnose`` runs blind
(it gets the recordings and the nominal model name, nothing else) and the
table compares its top-ranked effect with the truth, together with the
held-out fit before and after.

Figures (fractions in [0, 1]):

* ``top1_accuracy``: effect cases whose top-ranked effect is the concealed one;
* ``controls_correct``: controls diagnosed ``none``;
* ``improved_when_correct``: correct effect cases whose held-out mean NRMSE improved;
* ``under_60s``: cases whose diagnosis took less than 60 s (wall clock) on this machine;
* ``under_60s_cpu``: the same in CPU seconds of the process (independent of the load
  other users put on a shared machine);
* ``named_as_control``: effect cases whose top-ranked effect is the one the diagnosis
  names on the same rig without a concealed effect (its first control): there it
  names the rig's own mismatch with the model, not the concealed effect.

The rigs are plants of their own (issue 14), richer than the models: a control
still differs from the nominal model by the physics in the rig's table, so
``none`` on a control means the diagnosis judged that mismatch insignificant.

Usage::

    python benchmarks/concealed/run.py [--json PATH] [--out DIR] [--only strut,axt211]
                                       [--quick] [--report CASE]

``--quick`` runs the strut cases only (seconds). Timings depend on the load of
the machine, which is printed and stored; they are not assertions.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from cases import CASES, Case, generate

from thermogym.identification.diagnosis import diagnose

ROOT = Path(__file__).resolve().parents[2]
DEFAULT_OUT = ROOT / "benchmarks" / "results" / "concealed"


def run_case(case: Case) -> tuple[dict, object]:
    """Generate the recordings of a case and diagnose them blind."""
    t0 = time.perf_counter()
    train, val, opts = generate(case)
    t_gen = time.perf_counter() - t0
    load0 = os.getloadavg()[0]
    t0, c0 = time.perf_counter(), time.process_time()
    rep = diagnose(case.plant, train, val, **opts)
    t_diag = time.perf_counter() - t0
    # CPU seconds of this process: what the case costs on an idle core (the wall time
    # grows with the load other users put on the shared machine)
    c_diag = time.process_time() - c0
    b = rep.best
    top = b.get("effect", "none")
    if case.effect == "none":
        correct = top == "none"
    else:
        correct = top == case.effect or b.get("maps_to") == case.effect
    before = rep.fit_before["validation"].get("mean", math.nan)
    after = b.get("validation_after", {}).get("mean", before)
    row = {
        "case": case.name,
        "plant": case.plant,
        "true_effect": case.effect,
        "spec": case.spec,
        "top_effect": top,
        "target": b.get("target", ""),
        "correct": bool(correct),
        "mismatch_detected": bool(rep.mismatch_detected),
        "validation_nrmse_before": before,
        "validation_nrmse_after": after,
        "train_nrmse_before": rep.fit_before["train"].get("mean", math.nan),
        "train_nrmse_after": b.get("fit_after", {}).get("mean", math.nan),
        "explained": b.get("explained", math.nan),
        "scheme": rep.scheme,
        "runner_up": rep.hypotheses[1]["effect"] if len(rep.hypotheses) > 1 else "",
        "params": {k: v["value"] for k, v in (b.get("params") or {}).items()},
        "seconds_generate": t_gen,
        "seconds_diagnose": t_diag,
        "cpu_seconds_diagnose": c_diag,
        "load_1min": load0,
        "note": case.note,
    }
    return row, rep


def figures(rows: list[dict]) -> dict:
    """Summary fractions of the table."""
    eff = [r for r in rows if r["true_effect"] != "none"]
    ctl = [r for r in rows if r["true_effect"] == "none"]
    good = [r for r in eff if r["correct"]]
    improved = [r for r in good if r["validation_nrmse_after"] > r["validation_nrmse_before"]]

    def frac(a, b):
        return len(a) / len(b) if b else math.nan

    control_top = {
        r["plant"]: r["top_effect"]
        for r in reversed(ctl)  # the first control of each plant wins
    }
    as_control = [
        r for r in eff if not r["correct"] and r["top_effect"] == control_top.get(r["plant"])
    ]
    return {
        "top1_accuracy": frac(good, eff),
        "named_as_control": frac(as_control, eff),
        "controls_correct": frac([r for r in ctl if r["correct"]], ctl),
        "improved_when_correct": frac(improved, good),
        "under_60s": frac([r for r in rows if r["seconds_diagnose"] < 60], rows),
        "under_60s_cpu": frac(
            [r for r in rows if r.get("cpu_seconds_diagnose", math.inf) < 60], rows
        ),
        "max_cpu_seconds": max(
            (r.get("cpu_seconds_diagnose", math.nan) for r in rows), default=math.nan
        ),
        "n_effect_cases": len(eff),
        "n_controls": len(ctl),
        "max_seconds": max((r["seconds_diagnose"] for r in rows), default=math.nan),
        "median_seconds": sorted(r["seconds_diagnose"] for r in rows)[len(rows) // 2]
        if rows
        else math.nan,
    }


def table(rows: list[dict]) -> str:
    """Markdown table of the cases."""
    head = (
        "| case | true effect | top-ranked effect (target) | held-out NRMSE before → after "
        "| explained | s (CPU s) |\n|---|---|---|---|---|---|"
    )
    lines = [head]
    for r in rows:
        mark = "✓" if r["correct"] else "✗"
        tgt = f" ({r['target']})" if r["target"] else ""
        lines.append(
            f"| {r['case']} | {r['true_effect']} | {mark} {r['top_effect']}{tgt} | "
            f"{r['validation_nrmse_before']:.4f} → {r['validation_nrmse_after']:.4f} | "
            + (f"{100 * r['explained']:.0f} %" if math.isfinite(r["explained"]) else "–")
            + f" | {r['seconds_diagnose']:.1f}"
            + (
                f" ({r['cpu_seconds_diagnose']:.1f})"
                if math.isfinite(r.get("cpu_seconds_diagnose", math.nan))
                else ""
            )
            + " |"
        )
    return "\n".join(lines)


def summary_figure(rows: list[dict], path: Path) -> None:
    """Held-out mean NRMSE before and after, per case (green: correct top-1)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(9, 0.32 * len(rows) + 1.2))
    y = list(range(len(rows)))[::-1]
    for yi, r in zip(y, rows, strict=True):
        b, a = r["validation_nrmse_before"], r["validation_nrmse_after"]
        color = "tab:green" if r["correct"] else "tab:red"
        ax.plot([b, a], [yi, yi], color="0.6", lw=1)
        ax.plot(b, yi, "o", color="0.4", ms=4)
        ax.plot(a, yi, "o", color=color, ms=6)
    ax.set_yticks(y)
    ax.set_yticklabels([f"{r['case']} → {r['top_effect']}" for r in rows], fontsize=7)
    ax.set_xlabel("held-out mean NRMSE (grey: nominal; green/red: winner, correct/wrong)")
    ax.grid(alpha=0.3, axis="x")
    ax.set_title("concealed effects: held-out fit before and after diagnosis", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", help="write {figures, cases} JSON here")
    ap.add_argument("--out", default=str(DEFAULT_OUT), help="results folder (table, figures)")
    ap.add_argument("--only", help="comma-separated plants or case names")
    ap.add_argument("--quick", action="store_true", help="strut cases only")
    ap.add_argument(
        "--report",
        action="append",
        default=[],
        help="also write the JSON/Markdown diagnosis report of this case (e.g. strut/"
        "input_dependent_heat_transfer)",
    )
    ap.add_argument(
        "--from-json", help="redraw the table and figure from a results JSON, run nothing"
    )
    args = ap.parse_args(argv)
    out = Path(args.out)
    if args.from_json:
        doc = json.loads(Path(args.from_json).read_text())
        out.mkdir(parents=True, exist_ok=True)
        (out / "table.md").write_text(table(doc["cases"]) + "\n")
        summary_figure(doc["cases"], out / "summary.png")
        print(table(doc["cases"]))
        print(json.dumps({k: round(v, 4) for k, v in figures(doc["cases"]).items()}))
        return 0
    sel = CASES
    if args.quick:
        sel = [c for c in sel if c.plant == "strut"]
    if args.only:
        keys = args.only.split(",")
        sel = [c for c in sel if c.plant in keys or c.name in keys]
    out.mkdir(parents=True, exist_ok=True)
    load_start = os.getloadavg()
    print(
        f"concealed-effect benchmark: {len(sel)} cases on {platform.node()} "
        f"({os.cpu_count()} cores), load {load_start[0]:.2f} {load_start[1]:.2f} "
        f"{load_start[2]:.2f}",
        flush=True,
    )
    rows = []
    for case in sel:
        row, rep = run_case(case)
        rows.append(row)
        mark = "ok " if row["correct"] else "MISS"
        print(
            f"{mark} {row['case']:<42} {row['true_effect']:<30} -> {row['top_effect']:<30} "
            f"held-out {row['validation_nrmse_before']:.4f} -> {row['validation_nrmse_after']:.4f}"
            f"  {row['seconds_diagnose']:5.1f} s, {row['cpu_seconds_diagnose']:5.1f} CPU s "
            f"(load {row['load_1min']:.1f})",
            flush=True,
        )
        if case.name in args.report:
            tag = case.name.replace("/", "_")
            # JSON + Markdown with PNG figures (the HTML would embed the same figures again;
            # `thermogym diagnose --html` writes it for a user)
            rep.save(out / f"{tag}.json")
            rep.save_markdown(out / f"{tag}.md", figures_dir=f"{tag}_figures")
    figs = figures(rows)
    load_end = os.getloadavg()
    figs["load_1min_start"] = load_start[0]
    figs["load_1min_end"] = load_end[0]
    print()
    print(table(rows))
    print()
    print(json.dumps({k: round(v, 4) if isinstance(v, float) else v for k, v in figs.items()}))
    doc = {"figures": figs, "cases": rows, "machine": {"cores": os.cpu_count()}}
    text = json.dumps(doc, indent=2, default=float) + "\n"
    if args.json:
        Path(args.json).write_text(text)
    (out / "results.json").write_text(text)
    (out / "table.md").write_text(table(rows) + "\n")
    summary_figure(rows, out / "summary.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
