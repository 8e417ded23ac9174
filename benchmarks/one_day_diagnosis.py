"""A day at 1 Hz through the diagnosis (issue 15: "a one-day recording at 1 Hz (86,400 samples)
at most 60 s").

The heated block of ``tests/_diag_plants.py`` (its own RK4 code and hidden effects, coloured
sensor noise; written apart from the augmentations) is recorded for 24 hours at 1 Hz: two
8-hour training recordings and one 8-hour held-out recording, 86,400 samples in all. Each
effect is diagnosed blind with the default options on one core: the diagnosis averages the
recordings onto a grid of a twentieth of the model's fastest half-response
(``experiments.auto_period``). The peer, measured in the same run, is the same diagnosis kept
at the recordings' own 1 s (``dt=1``) on the first case::

    python benchmarks/one_day_diagnosis.py --json out/one_day.json
    python benchmarks/one_day_diagnosis.py --no-peer  # skip the full-rate run (5 min)
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
for p in (ROOT, ROOT / "tests"):
    if str(p) not in sys.path:
        sys.path.insert(0, str(p))

if __name__ == "__main__":  # before numpy, scipy or numba load
    from benchmarks.diagnosis._onecore import one_core

    one_core()

from _diag_plants import NodeModel, node_recordings  # noqa: E402

from thermogym.identification.diagnosis import diagnose  # noqa: E402

#: (label, effects of the block, the effect a right answer names)
CASES: list[tuple[str, dict[str, Any], str]] = [
    ("radiation, emissivity x area 0.2 m2", {"radiation": 0.2}, "nonlinear_heat_transfer"),
    ("sensor lag 60 s", {"lag": 60.0}, "sensor_lag"),
    ("input dead time 60 s", {"delay": 60.0}, "transport_delay"),
    ("coupled mass 8 kJ/K, 2 W/K", {"mass": (8000.0, 2.0)}, "missing_dynamics"),
    ("control (none)", {}, "none"),
]


def run_one(effects: dict[str, Any], dt: float | None) -> dict[str, Any]:
    """Make the day, diagnose it; CPU seconds of the diagnosis alone."""
    tr, va = node_recordings(
        3, effects=effects, hours=8.0, dt=1.0, n_train=2, n_val=1, hold=(600.0, 3600.0)
    )
    c0, w0 = time.process_time(), time.perf_counter()
    rep = diagnose(NodeModel(), tr, va, dt=dt)
    return {
        "samples": sum(r.n_samples for r in [*tr, *va]),
        "grid_s": rep.nominal_fit.settings.get("dt"),
        "cpu_s": time.process_time() - c0,
        "wall_s": time.perf_counter() - w0,
        "named": list(rep.named_effects),
        "heldout_before": rep.best.get("validation_before", {}).get("mean"),
        "heldout_after": rep.best.get("validation_after", {}).get("mean"),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", type=Path, help="write the results here")
    ap.add_argument("--no-peer", action="store_true", help="skip the full-rate peer run")
    args = ap.parse_args(argv)
    load0 = os.getloadavg()[0]
    print(f"machine: {platform.node()}, {os.cpu_count()} cores, load average {load0:.2f}")
    rows = []
    for label, eff, truth in CASES:
        r = run_one(eff, None)
        physics = [e for e in r["named"] if e not in ("none", "parameter_error")]
        r.update(
            case=label,
            truth=truth,
            right=(physics[:1] == [truth]) or (truth == "none" and not physics),
        )
        rows.append(r)
        print(
            f"{label:36s} grid {r['grid_s']} s  {r['cpu_s']:6.1f} CPU s  named {r['named']}"
            f"  {'right' if r['right'] else 'WRONG'}",
            flush=True,
        )
    peer = None
    if not args.no_peer:
        label, eff, truth = CASES[0]
        peer = {"case": label, **run_one(eff, 1.0)}
        ratio = peer["cpu_s"] / rows[0]["cpu_s"]
        print(
            f"peer: {label} at the full 1 s rate: {peer['cpu_s']:.1f} CPU s, named "
            f"{peer['named']}; the default grid is {ratio:.1f}x faster"
        )
        peer["ratio_full_over_default"] = ratio
    n_ok = sum(r["cpu_s"] <= 60.0 for r in rows)
    print(f"{n_ok} of {len(rows)} days diagnosed in at most 60 CPU s")
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        tmp = args.json.with_suffix(".tmp")
        tmp.write_text(
            json.dumps({"cases": rows, "peer": peer, "load_average_start": load0}, indent=1)
        )
        tmp.replace(args.json)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
