"""Controller benchmark: energy, lifetime and accuracy of on/off, PWM, PID, MPC and PPO.

Two grids of :func:`thermogym.controllers.run_benchmark`, each controller
preset × scenario × seed, on the identified model and on the virtual rig:

* ``AXT211Room`` — ``winter-week`` (model and rig) and ``actuator-spread``
  (rig, one actuator specimen per seed);
* ``AXT211Valve`` — ``setpoint-steps`` (model and rig), ``actuator-spread``
  and ``supply-19V``.

Controllers: ``onoff`` (thermostat), open-loop PWM at the high, medium and low
frequency of paper 002 section VIII (``pwm-*``), PI + PWM at the three
frequencies (``pid-*``), ``mpc`` and the shipped ``ppo`` policy; on the room also
the thermostat and the PI without optimum start (``onoff-reactive``,
``pid-reactive``). Writes the
reports into ``benchmarks/results/controllers/{room,valve}/`` and prints, per
grid, every controller's accuracy, energy and lifetime KPI as a ratio to the
room-thermostat peer (``onoff``), plus the harness throughput (local processes
against one process on the same grid) with the machine load.

Each report shows, beside the KPI tables, the sim-to-real gap (the same
controllers on the identified model and on the rig's own true plant), how the
controllers' lifetime ranking changes with the wear measure (the heater's
switching operations, cycle counts and Miner sums under other S-N assumptions)
and the Pareto front with the switching operations as a wear axis of their own.

Usage::

    python benchmarks/controllers.py [--seeds 5] [--only room|valve] [--json PATH]
        [--out benchmarks/results/controllers] [--workers 2]
    python benchmarks/controllers.py --redraw [--only room|valve]   # report from the tables

``--redraw`` runs no episode: it rebuilds ``summary.md`` and the figures of a
folder from its ``results.parquet`` and ``trajectories.parquet`` (after a change
of the report code); a Discussion appended by hand is dropped, as on a re-run.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

from thermogym.controllers import run_benchmark
from thermogym.controllers.tables import kpi_axes

ROOT = Path(__file__).resolve().parent
CONTROLLERS = {
    # the room adds the thermostat and the PI without optimum start (the schedule as it comes)
    "room": "onoff,onoff-reactive,pwm,pid-pwm,pid-reactive,mpc,ppo",
    "valve": "onoff,pwm,pid-pwm,mpc,ppo",
}
GRIDS = {
    "room": (
        "thermogym/AXT211Room-v0",
        [("winter-week", ("model", "rig")), ("actuator-spread", ("rig",))],
        "AXT211Room: a winter week",
    ),
    "valve": (
        "thermogym/AXT211Valve-v0",
        [
            ("setpoint-steps", ("model", "rig")),
            ("actuator-spread", ("rig",)),
            ("supply-19V", ("model",)),
        ],
        "AXT211Valve: set-point steps",
    ),
}


def _load() -> str:
    try:
        return " / ".join(f"{v:.2f}" for v in os.getloadavg())
    except OSError:
        return "n/a"


def run_grid(name: str, seeds: int, out: Path, workers: int) -> dict:
    """Run one grid (all its scenarios), write its report, return the key numbers."""
    env_id, scens, title = GRIDS[name]
    import pandas as pd

    from thermogym.controllers.harness import BenchmarkResult
    from thermogym.controllers.report import write_report

    t0 = time.perf_counter()
    parts = []
    for scen, plants in scens:
        parts.append(
            run_benchmark(
                env_id,
                scen,
                CONTROLLERS[name],
                seeds,
                None,
                "local",
                plants=plants,
                workers=workers,
                trajectory_points=2500,
                report=False,
            )
        )
    seconds = time.perf_counter() - t0
    table = pd.concat([p.table for p in parts], ignore_index=True)
    trajs = {k: v for p in parts for k, v in p.trajectories.items()}
    specs = [s for p in parts for s in p.specs]
    res = BenchmarkResult(table, trajs, specs, "local", workers, seconds)
    write_report(res, out / name, title=f"Controller benchmark — {title}")
    axes = kpi_axes(list(table.columns))
    summary = {}
    for (scen, plant), grp in table.groupby(["scenario", "plant"], sort=False):
        m = grp.groupby("controller", sort=False)[list(axes.values())].mean()
        ref = m.loc["onoff"]
        summary[f"{scen}|{plant}"] = {
            c: {k: float(m.at[c, k]) for k in axes.values()}
            | {
                f"{k}_vs_onoff": float(m.at[c, k] / ref[k]) if ref[k] else None
                for k in axes.values()
            }
            for c in m.index
        }
    return {
        "env_id": env_id,
        "episodes": len(table),
        "seconds": seconds,
        "workers": workers,
        "axes": axes,
        "summary": summary,
    }


def redraw(name: str, out: Path) -> dict:
    """Rebuild the report of a grid from its committed tables (no episode is run)."""
    import numpy as np
    import pandas as pd

    from thermogym.controllers.harness import BenchmarkResult
    from thermogym.controllers.report import write_report

    _, _, title = GRIDS[name]
    folder = out / name
    table = pd.read_parquet(folder / "results.parquet")
    trajs: dict = {}
    tp = folder / "trajectories.parquet"
    if tp.exists():
        tf = pd.read_parquet(tp)
        keys = ["scenario", "controller", "plant", "seed"]
        for key, grp in tf.groupby(keys, sort=False):
            sig = grp.drop(columns=keys).dropna(axis=1, how="all")
            trajs[(key[0], key[1], key[2], int(key[3]))] = {
                c: np.asarray(sig[c], dtype=float) for c in sig.columns
            }
    run = json.loads((folder / "run.json").read_text()) if (folder / "run.json").exists() else {}
    res = BenchmarkResult(
        table,
        trajs,
        [],
        str(run.get("backend", "local")),
        int(run.get("workers", 1)),
        float(run.get("seconds", float("nan"))),
    )
    files = write_report(res, folder, title=f"Controller benchmark — {title}")
    return {"folder": str(folder), "files": sorted(files)}


def throughput(workers: int) -> dict:
    """Episodes per second of the local backend against one process on the same small grid."""
    kw = {"seeds": 4, "record": "none", "report": False}
    env = "thermogym/AXT211Valve-v0"
    run_benchmark(env, "setpoint-steps", "onoff", seeds=1, backend="serial", report=False)
    best_serial = best_local = float("inf")
    for _ in range(2):
        t0 = time.perf_counter()
        run_benchmark(env, "setpoint-steps", "onoff,pid,pwm", backend="serial", **kw)
        best_serial = min(best_serial, time.perf_counter() - t0)
        t0 = time.perf_counter()
        run_benchmark(
            env, "setpoint-steps", "onoff,pid,pwm", backend="local", workers=workers, **kw
        )
        best_local = min(best_local, time.perf_counter() - t0)
    return {
        "episodes": 5 * 4,
        "serial_s": best_serial,
        "local_s": best_local,
        "speedup_local_vs_serial": best_serial / best_local,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--only", choices=list(GRIDS))
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "controllers")
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--json", type=Path)
    ap.add_argument("--no-throughput", action="store_true")
    ap.add_argument(
        "--redraw", action="store_true", help="rebuild the reports from their tables, run nothing"
    )
    args = ap.parse_args()
    if args.redraw:
        for name in [args.only] if args.only else list(GRIDS):
            print(json.dumps(redraw(name, args.out), indent=1))
        return
    print(f"machine load (1/5/15 min): {_load()}, {os.cpu_count()} CPUs")
    result: dict = {"load_before": _load(), "grids": {}}
    for name in [args.only] if args.only else list(GRIDS):
        r = run_grid(name, args.seeds, args.out, args.workers)
        result["grids"][name] = r
        print(f"\n{r['env_id']}: {r['episodes']} episodes in {r['seconds']:.0f} s")
        for key, ctrls in r["summary"].items():
            print(f"  {key}  (ratio to the on/off thermostat, peer)")
            for c, v in ctrls.items():
                cells = "  ".join(
                    f"{k}={v[k]:.4g} ({v[k + '_vs_onoff']:.2f}x)"
                    if v[k + "_vs_onoff"] is not None
                    else f"{k}={v[k]:.4g}"
                    for k in r["axes"].values()
                )
                print(f"    {c:11s} {cells}")
    if not args.no_throughput:
        tp = throughput(args.workers)
        result["throughput"] = tp
        print(
            f"\nharness: {tp['episodes']} episodes, one process {tp['serial_s']:.1f} s, "
            f"{args.workers} local processes {tp['local_s']:.1f} s: "
            f"{tp['speedup_local_vs_serial']:.2f}x (best of 2)"
        )
    result["load_after"] = _load()
    print(f"machine load after: {result['load_after']}")
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(result, indent=1, default=str) + "\n")


if __name__ == "__main__":
    main()
