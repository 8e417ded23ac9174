"""Detection limits of the mismatch diagnosis (issue 15, item 7).

For each effect, a ladder of magnitudes on the suite's lamp-heated plate (the
family's own nominal model, constants 10-30 % off design, coloured sensor
noise; :mod:`benchmarks.diagnosis.plants`, written independently of the
augmentations), several seeds per magnitude, and controls with no hidden
physics. A magnitude counts as *named* in a seed when the effect is among the
report's ``named_effects``, and as *flagged* when any physics is named at all::

    python benchmarks/diagnosis/detection_limits.py --json out/limits.json --workers 2
    python benchmarks/diagnosis/detection_limits.py --from-json out/limits.json  # redraw

The JSON holds every run; beside it ``detection_limits.md`` (per effect: hits per
magnitude and the smallest magnitude named in at least 90 % of the seeds, and the
controls' false-alarm rate) and ``detection_limits.png`` (named fraction against
magnitude).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
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


from benchmarks.diagnosis.cases import Case, control, h  # noqa: E402
from benchmarks.diagnosis.generalisation import NO_PHYSICS, run_case  # noqa: E402

#: (effect, form, parameter, unit, magnitudes, fixed parameters): the suite's own plate
#: effects, each from well below to well above the size the suite's single cases use
LADDERS: list[tuple[str, str, str, str, tuple[float, ...], dict[str, Any]]] = [
    ("sensor_offset", "constant", "offset", "K", (0.1, 0.25, 0.5, 1.0, 2.0), {}),
    ("sensor_drift", "linear", "rate", "K/h", (0.05, 0.1, 0.3, 1.0), {}),
    ("sensor_lag", "first_order", "tau", "s", (5.0, 10.0, 20.0, 60.0), {}),
    ("transport_delay", "clock_skew", "delay", "s", (5.0, 15.0, 30.0, 60.0), {}),
    ("nonlinear_heat_transfer", "radiation", "emissivity", "", (0.05, 0.15, 0.35, 0.9), {}),
    ("input_nonlinearity", "power_law", "exponent", "", (1.05, 1.1, 1.3, 2.0), {}),
    (
        "unmeasured_disturbance",
        "periodic",
        "amplitude_K",
        "K",
        (0.1, 0.3, 1.0),
        {"period": 1800.0, "sharpness": 2.0},
    ),
    ("time_varying_parameter", "ramp", "change", "", (0.05, 0.1, 0.2, 0.4), {}),
]
#: seeds per magnitude; "at least 90 %" of 5 seeds is all 5
N_SEEDS = 5
N_CONTROLS = 20
#: share of seeds a detection limit asks for
SHARE = 0.9
_WHERE = {
    "sensor_offset": "T_plate",
    "sensor_drift": "T_plate",
    "sensor_lag": "T_plate",
    "transport_delay": "lamp",
    "nonlinear_heat_transfer": "plate surface",
    "input_nonlinearity": "lamp",
    "unmeasured_disturbance": "air at the plate",
    "time_varying_parameter": "G",
}


def runs(n_seeds: int = N_SEEDS, n_controls: int = N_CONTROLS) -> list[tuple[dict, Case]]:
    """Every (label, case) of the study: the ladders, then the controls."""
    out = []
    for i, (eff, form, par, unit, mags, fixed) in enumerate(LADDERS):
        for j, m in enumerate(mags):
            for r in range(n_seeds):
                seed = 20000 + 1000 * i + 10 * j + r
                hid = h(
                    eff, form, _WHERE[eff], f"{par} = {m:g} {unit}".strip(), **{par: m}, **fixed
                )
                label = {"effect": eff, "form": form, "param": par, "unit": unit, "magnitude": m}
                out.append((label, Case("plate", (hid,), "user", seed, False)))
    for r in range(n_controls):
        label = {"effect": "control", "form": "", "param": "", "unit": "", "magnitude": 0.0}
        out.append((label, control("plate", "user", 29000 + r)))
    return out


def _one(label: dict, case: Case, time_limit: float | None) -> dict[str, Any]:
    row = run_case(case, time_limit)
    named = row.get("named_effects", [])
    return {
        **label,
        "seed": case.seed,
        "named_effects": named,
        "named": label["effect"] in named,
        "flagged": any(e not in NO_PHYSICS for e in named),
        "cpu_seconds": row.get("cpu_seconds"),
        "error": row.get("error"),
    }


def summary(rows: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """Per effect and magnitude: seeds named / flagged; the limit; the controls' rates."""
    eff: dict[str, Any] = {}
    ctl = [r for r in rows if r["effect"] == "control"]
    for eff_name, form, par, unit, mags, _ in LADDERS:
        per = []
        for m in mags:
            rs = [r for r in rows if r["effect"] == eff_name and r["magnitude"] == m]
            per.append(
                {
                    "magnitude": m,
                    "n": len(rs),
                    "named": sum(r["named"] for r in rs),
                    "flagged": sum(r["flagged"] for r in rs),
                }
            )
        met = [bool(p["n"]) and p["named"] >= SHARE * p["n"] for p in per]
        eff[eff_name] = {
            # controls that name this effect: the rate a "named" count is to be read against
            "controls_naming": sum(eff_name in r["named_effects"] for r in ctl),
            "form": form,
            "param": par,
            "unit": unit,
            "ladder": per,
            # the smallest magnitude from which every larger one is named too
            "limit": next((p["magnitude"] for k, p in enumerate(per) if all(met[k:])), None),
        }
    return {
        "effects": eff,
        "controls": {
            "n": len(ctl),
            "false_alarms": sum(r["flagged"] for r in ctl),
            "false_alarm_rate": (sum(r["flagged"] for r in ctl) / len(ctl)) if ctl else None,
        },
        "share": SHARE,
    }


def markdown(doc: Mapping[str, Any]) -> str:
    """The committed table."""
    s = doc["summary"]
    m = doc["meta"]
    lines = [
        "# Detection limits of the diagnosis (issue 15, item 7)",
        "",
        f"`python benchmarks/diagnosis/detection_limits.py` ({m['date']}; plate family, the "
        f"family's own nominal model, {m['n_seeds']} seeds per magnitude, time limit "
        f"{m['time_limit']} s per case). *Named*: the effect is among the report's "
        "`named_effects`; *flagged*: some physics is named. The limit is the smallest "
        f"magnitude from which every larger one is named in at least {100 * s['share']:.0f} % "
        "of the seeds.",
        "",
        "| effect (form) | magnitudes | named / seeds | flagged / seeds | limit | "
        "controls naming it |",
        "|---|---|---|---|---|---|",
    ]
    for name, e in s["effects"].items():
        mags = ", ".join(f"{p['magnitude']:g}" for p in e["ladder"])
        named = ", ".join(f"{p['named']}/{p['n']}" for p in e["ladder"])
        flagged = ", ".join(f"{p['flagged']}/{p['n']}" for p in e["ladder"])
        unit = f" {e['unit']}" if e["unit"] else ""
        lim = f"{e['limit']:g}{unit}" if e["limit"] is not None else "not reached"
        n_ctl = s["controls"]["n"]
        lines.append(
            f"| {name} ({e['form']}, {e['param']}) | {mags}{unit} | {named} | {flagged} | {lim} | "
            f"{e.get('controls_naming', '–')}/{n_ctl} |"
        )
    c = s["controls"]
    rate = "–" if c["false_alarm_rate"] is None else f"{100 * c['false_alarm_rate']:.0f} %"
    lines += [
        "",
        f"Controls (no hidden physics, constants 10-30 % off design, coloured noise): "
        f"{c['false_alarms']} of {c['n']} name physics (false-alarm rate {rate}).",
        "",
    ]
    return "\n".join(lines)


def plot(doc: Mapping[str, Any], path: Path) -> None:
    """Named fraction against magnitude, one panel per effect."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    effs = doc["summary"]["effects"]
    fig, axes = plt.subplots(2, math.ceil(len(effs) / 2), figsize=(14, 6), squeeze=False)
    for ax, (name, e) in zip(axes.ravel(), effs.items(), strict=False):
        x = [p["magnitude"] for p in e["ladder"]]
        ax.plot(x, [p["named"] / max(p["n"], 1) for p in e["ladder"]], "o-", label="named")
        ax.plot(x, [p["flagged"] / max(p["n"], 1) for p in e["ladder"]], "s--", label="flagged")
        ax.axhline(doc["summary"]["share"], color="grey", lw=0.8)
        ax.set_xscale("log")
        ax.minorticks_off()
        ax.set_xticks(x, [f"{v:g}" for v in x], fontsize=8)
        ax.set_ylim(-0.05, 1.05)
        ax.set_title(name, fontsize=9)
        ax.set_xlabel(f"{e['param']} [{e['unit']}]" if e["unit"] else e["param"], fontsize=8)
    axes.ravel()[0].legend(fontsize=8)
    c = doc["summary"]["controls"]
    fig.suptitle(
        f"Diagnosis detection limits (plate); controls: {c['false_alarms']}/{c['n']} name physics"
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write(doc: Mapping[str, Any], json_path: Path, *, with_json: bool = True) -> None:
    """JSON (atomically), and the Markdown and figure beside it."""
    from thermogym._fileio import atomic_write_text

    if with_json:
        atomic_write_text(json_path, json.dumps(doc, indent=1, default=float) + "\n")
    atomic_write_text(json_path.with_name("detection_limits.md"), markdown(doc))
    plot(doc, json_path.with_name("detection_limits.png"))


def main(argv: Sequence[str] | None = None) -> int:
    """Command line."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--json", type=Path, help="results file (Markdown and figure beside it)")
    ap.add_argument("--workers", type=int, default=1, help="processes (default 1)")
    ap.add_argument("--seeds", type=int, default=N_SEEDS, help=f"per magnitude ({N_SEEDS})")
    ap.add_argument("--controls", type=int, default=N_CONTROLS, help=f"({N_CONTROLS})")
    ap.add_argument("--time-limit", type=float, default=60.0, help="per case [s] (60)")
    ap.add_argument("--from-json", type=Path, help="redraw the Markdown and figure")
    args = ap.parse_args(argv)
    if args.from_json is not None:
        doc = json.loads(args.from_json.read_text(encoding="utf-8"))
        target = args.json or args.from_json
        write(doc, target, with_json=target.resolve() != args.from_json.resolve())
        return 0
    if args.json is None:
        ap.error("--json PATH is required")
    for name in ("workers", "seeds"):
        if getattr(args, name) < 1:
            ap.error(f"--{name} is {getattr(args, name)}, expected at least 1")
    if args.controls < 0:
        ap.error(f"--controls is {args.controls}, expected at least 0")
    todo = runs(args.seeds, args.controls)
    t0 = time.perf_counter()
    rows: list[dict[str, Any]] = []
    with ProcessPoolExecutor(args.workers, mp_context=get_context("spawn")) as ex:
        futs = [ex.submit(_one, lab, c, args.time_limit) for lab, c in todo]
        for i, f in enumerate(futs):
            rows.append(f.result())
            r = rows[-1]
            print(
                f"[{i + 1:3d}/{len(todo)}] {r['effect']:<26s} {r['magnitude']:<6g} s{r['seed']} "
                f"-> {','.join(r['named_effects'])}",
                file=sys.stderr,
                flush=True,
            )
    doc = {
        "summary": summary(rows),
        "meta": {
            "date": time.strftime("%Y-%m-%d %H:%M"),
            "n_seeds": args.seeds,
            "n_controls": args.controls,
            "time_limit": args.time_limit,
            "wall_seconds_total": time.perf_counter() - t0,
            "cpus": os.cpu_count(),
            "workers": args.workers,
        },
        "runs": rows,
    }
    write(doc, args.json)
    print(markdown(doc))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
