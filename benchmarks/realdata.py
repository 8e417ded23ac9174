"""FOPTD and cross-validated N4SID on every shipped real data set, validated on held-out data.

For each case of :data:`thermogym.studies.realdata.CASES` (training
and validation data named there) prints and writes the MNRMSE fit of both
methods on the training and on the validation data, the N4SID order chosen by
2-fold cross-validation, and a figure of the N4SID model on the first
validation recording.

Usage::

    python benchmarks/realdata.py [--out benchmarks/results/identification]
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

from thermogym._fileio import atomic_write_text
from thermogym.identification.linear_fit import predict_fit
from thermogym.identification.linear_plots import plot_fit
from thermogym.identification.metrics import nrmse
from thermogym.studies.realdata import CASES, case_data, identify_case


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("benchmarks/results/identification"))
    ap.add_argument("--cases", nargs="*", default=list(CASES))
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    report: dict = {"load_average_start": os.getloadavg()[0], "cases": {}}
    print(
        f"{'case':<16} {'FOPTD train':>11} {'FOPTD val':>10} {'n*':>4} "
        f"{'N4SID train':>11} {'N4SID val':>10} {'time [s]':>9}"
    )
    for name in args.cases:
        t = time.perf_counter()
        res = identify_case(name)
        s = res.summary
        s["seconds"] = time.perf_counter() - t
        report["cases"][name] = s
        print(
            f"{name:<16} {100 * s['foptd']['train_mnrmse']:10.1f}% "
            f"{100 * s['foptd']['validation_mnrmse']:9.1f}% {s['n4sid']['order']:4d} "
            f"{100 * s['n4sid']['train_mnrmse']:10.1f}% "
            f"{100 * s['n4sid']['validation_mnrmse']:9.1f}% {s['seconds']:9.1f}"
        )
        _, vals = case_data(name)
        rec = vals[0]
        outs = list(res.case.outputs)
        yh = predict_fit(res.n4sid, rec)
        plot_fit(
            rec,
            yh,
            outs,
            args.out / f"realdata_{name}.png",
            title=f"{name}: N4SID order {s['n4sid']['order']} on {rec.experiment_id} (held out)",
            fits={c: float(nrmse(rec[c], yh[:, j])) for j, c in enumerate(outs)},
        )
    report["load_average_end"] = os.getloadavg()[0]
    path = args.out / "realdata.json"
    atomic_write_text(path, json.dumps(report, indent=2) + "\n")
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
