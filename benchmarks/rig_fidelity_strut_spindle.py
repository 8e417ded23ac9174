"""Model adequacy measured on the strut and spindle rigs (papers 000 and 001), not on the model.

The rigs' true plants are written apart from the identified models
(:mod:`thermogym.rigs.strut`, :mod:`thermogym.rigs.spindle`), so these figures
measure how well the papers' model classes describe a richer plant:

* ``strut_rmse_ratio_30_20`` — paper 000 section 4.1: the RC network fitted at
  20 m/min (5 ratios, Monte Carlo, Table 2) validated unchanged at 30 m/min;
  RMSE at 30 over RMSE at 20 (target ≥ 2, the paper's "much larger" error),
  beside the nominal network, the FOPTD set of Table 1, the rig's noise
  ceiling and the share of the gap today's diagnosis closes;
* ``spindle_va`` / ``spindle_order`` — paper 001 Table 5: the N4SID order that
  2-fold cross-validation picks per speed and its validation accuracy (target
  VA ≥ 99 %, paper 99.2-99.7 % at orders 21-26), beside the rig's noise
  ceiling and a plain first-order ARX.

The JSON has the shape of ``benchmarks/rig_fidelity.py``'s (``figures`` plus
the details), so its figures can be merged there.

Usage::

    python benchmarks/rig_fidelity_strut_spindle.py [--json PATH] [--quick]
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

from thermogym._fileio import atomic_write_text
from thermogym.studies import spindle as ss
from thermogym.studies import strut as st


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--json", type=Path, default=Path("benchmarks/results/rigs/rig_fidelity_strut_spindle.json")
    )
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--quick", action="store_true", help="two speeds, orders 1..12, 2000 sets")
    args = ap.parse_args()
    t0 = time.perf_counter()
    load0 = os.getloadavg()[0]
    strut = st.rig_fidelity(seed=args.seed, n_samples=2000 if args.quick else 10_000)
    s = strut.to_dict()
    r = s["rmse_ratio_30_20"]
    print(
        f"strut: RMSE 30/20 fitted RC {r['fitted_rc']:.2f} (target 2), nominal RC "
        f"{r['nominal_rc']:.2f}, FOPTD {r['foptd']:.2f}, noise ceiling {r['noise_ceiling']:.2f}"
    )
    for name, d in s["rmse_K"].items():
        print(f"  {name:>13}: " + ", ".join(f"{k} m/min {v:.3f} K" for k, v in d.items()))
    dg = s["diagnosis"]
    if dg:
        print(f"  diagnosis names {dg.get('named')!r}; gap closed {dg.get('gap_closed')}")
    speeds = (5000, 7000) if args.quick else ss.SPEEDS
    orders = range(1, 13) if args.quick else range(1, 31)
    spindle = ss.rig_fidelity(seed=args.seed, speeds=speeds, orders=orders)
    p = spindle.to_dict()
    for sp in p["va"]:
        print(
            f"spindle {sp} rpm: order {p['order'][sp]}, VA {p['va'][sp]:.4f} (ceiling "
            f"{p['noise_ceiling'][sp]:.4f}, ARX {p['arx_baseline'][sp]:.4f})"
        )
    report = {
        "figures": {**strut.figures(), **spindle.figures()},
        "strut": s,
        "spindle": p,
        "seed": args.seed,
        "quick": args.quick,
        "seconds": time.perf_counter() - t0,
        "load_average": [load0, os.getloadavg()[0]],
    }
    args.json.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(args.json, json.dumps(report, indent=2) + "\n")
    print(f"wrote {args.json} ({report['seconds']:.0f} s)")


if __name__ == "__main__":
    main()
