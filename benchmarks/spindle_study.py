"""The spindle study of paper 001 (Table 5, Figs 16/17, section 3.2, Table 6) on the virtual rig.

Runs the rig's ``run-in`` (5 speeds x 2 folds) and ``validation`` (4500, 5300,
7800 rpm) protocols, prepares the raw asynchronous data (section 2.3.1) and
identifies N4SID models as the paper does:

* Table 5: best order per speed by 2-fold cross-validation over orders 1..30,
  TA, VA and the time taken — for the paper's inputs (speed only) and with the
  measured ambient as a second input;
* Figs 16/17: train-speed x test-speed VA matrices of the order-8 and the
  best-order models (heat maps);
* section 3.2: the order-8 model trained on fold 1 at 6000 rpm predicting
  the validation days;
* Table 6: virtual-sensor models 1I7O, 3I5O, 2I5O, 1I5O at order 8.

Writes ``spindle_study.json`` and PNG figures to ``--out``.

Usage::

    python benchmarks/spindle_study.py [--out benchmarks/results/identification] [--quick]
"""

from __future__ import annotations

import argparse
import json
import os
import time
from collections import Counter
from pathlib import Path

import numpy as np

from thermogym._fileio import atomic_write_text
from thermogym.identification.linear_fit import predict_fit
from thermogym.identification.linear_plots import plot_fit, plot_order_cv, plot_va_matrix
from thermogym.studies import spindle as ss


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("benchmarks/results/identification"))
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--quick", action="store_true", help="two speeds, orders 1..12")
    args = ap.parse_args()
    out = args.out
    out.mkdir(parents=True, exist_ok=True)
    speeds = (5000, 7000) if args.quick else ss.SPEEDS
    orders = range(1, 13) if args.quick else range(1, 31)
    report: dict = {"load_average_start": os.getloadavg()[0], "seed": args.seed}
    t0 = time.perf_counter()
    data = ss.spindle_data(seed=args.seed, speeds=speeds)
    n_days = len(data.runs) + len(data.validation)
    report["data"] = {
        "days": n_days,
        "raw_rows_max": data.raw_rows,
        "rig_s": data.seconds["rig"],
        "prepare_s": data.seconds["prepare"],
        "prepare_s_per_day": data.seconds["prepare"] / n_days,
        "prepared_samples": data.fold(speeds[0], 1).n_samples,
    }
    print(
        f"{n_days} days, up to {data.raw_rows} raw rows each: rig {data.seconds['rig']:.1f} s, "
        f"preparation {data.seconds['prepare'] / n_days:.2f} s per day"
    )

    report["table5"] = {}
    best_orders: dict[str, int] = {}
    for iset in ss.INPUT_SETS:
        t = time.perf_counter()
        cvs = ss.table5(data, orders=orders, input_set=iset)
        rows = {}
        for speed, cv in cvs.items():
            k = int(np.argmax(cv.va))
            rows[speed] = {
                "best_order": cv.best_order,
                "parsimonious_order": cv.parsimonious_order,
                "TA": float(cv.ta[k]),
                "VA": float(cv.va[k]),
                "VA_order8": float(cv.va[list(cv.orders).index(8)]) if 8 in cv.orders else None,
                "seconds": cv.seconds["total"],
                "decimate": cv.settings["decimate"],
            }
            plot_order_cv(
                cv,
                out / f"spindle_order_cv_{iset.replace('+', '_')}_{speed}.png",
                title=f"{speed} rpm, inputs: {iset}",
            )
        report["table5"][iset] = rows
        best_orders[iset] = Counter(r["best_order"] for r in rows.values()).most_common(1)[0][0]
        print(f"Table 5, inputs {iset} ({time.perf_counter() - t:.0f} s):")
        print("   rpm   n*   TA [%]   VA [%]   VA(8) [%]   time [s]")
        for speed, r in rows.items():
            print(
                f"  {speed:5d} {r['best_order']:3d}  {100 * r['TA']:7.2f}  {100 * r['VA']:7.2f}  "
                f"{100 * (r['VA_order8'] or np.nan):9.2f}  {r['seconds']:8.1f}"
            )

    report["va_matrix"] = {}
    for iset in ss.INPUT_SETS:
        for order in sorted({8, best_orders[iset]}):
            sp, M = ss.va_matrix(data, order, input_set=iset)
            report["va_matrix"][f"{iset}/order{order}"] = {
                "speeds": sp,
                "VA": M.tolist(),
                "mean_off_diagonal": float(M[~np.eye(len(sp), dtype=bool)].mean()),
                "mean_diagonal": float(np.diag(M).mean()),
            }
            plot_va_matrix(
                M,
                [f"{s}" for s in sp],
                out / f"spindle_va_matrix_{iset.replace('+', '_')}_order{order}.png",
                title=f"VA [%], order {order}, inputs {iset} (paper Figs. 16/17)",
                xlabel="test speed, fold 2 [rpm]",
                ylabel="training speed, fold 1 [rpm]",
            )
            print(
                f"VA matrix, inputs {iset}, order {order}: diagonal "
                f"{100 * np.diag(M).mean():.2f} %, off-diagonal "
                f"{100 * report['va_matrix'][f'{iset}/order{order}']['mean_off_diagonal']:.2f} %"
            )

    train_speed = 6000 if 6000 in speeds else speeds[0]
    report["section_3_2"] = {}
    for iset in ss.INPUT_SETS:
        fit, per = ss.validation_prediction(data, order=8, train_speed=train_speed, input_set=iset)
        report["section_3_2"][iset] = {
            str(s): {"mnrmse": r["mnrmse"], "nrmse": r["nrmse"]} for s, r in per.items()
        }
        print(
            f"section 3.2, inputs {iset}: order-8 model of {train_speed} rpm predicts "
            + ", ".join(f"{s} rpm {100 * r['mnrmse']:.2f} %" for s, r in per.items())
        )
        rec = data.validation[max(data.validation)]
        plot_fit(
            rec,
            predict_fit(fit, rec),
            list(ss.OUTPUTS),
            out / f"spindle_sec32_{iset.replace('+', '_')}_{max(data.validation)}rpm.png",
            title=f"order 8, trained at {train_speed} rpm, inputs {iset}",
        )

    vs = ss.virtual_sensor_study(data, train_speed=train_speed)
    report["table6"] = {}
    print(f"Table 6 (order 8, trained at {train_speed} rpm): MNRMSE / mean accuracy xi [%]")
    for name, r in vs.items():
        report["table6"][name] = {
            str(s): {
                "mnrmse": rep["mnrmse"],
                "xi_mean": float(np.mean(list(rep["xi"].values()))),
                "nrmse": rep["nrmse"],
            }
            for s, rep in r["validation"].items()
        }
        print(
            f"  {name}: "
            + ", ".join(
                f"{s} rpm {100 * v['mnrmse']:.2f} / {100 * v['xi_mean']:.2f}"
                for s, v in report["table6"][name].items()
            )
        )
    rec = data.validation[min(data.validation)]
    fit = vs["3I5O"]["fit"]
    plot_fit(
        rec,
        predict_fit(fit, rec),
        list(ss.INTERNAL),
        out / f"spindle_table6_3I5O_{min(data.validation)}rpm.png",
        title=f"3I5O virtual sensor, order 8, {min(data.validation)} rpm",
    )
    report["seconds_total"] = time.perf_counter() - t0
    report["load_average_end"] = os.getloadavg()[0]
    path = out / ("spindle_study_quick.json" if args.quick else "spindle_study.json")
    atomic_write_text(path, json.dumps(report, indent=2) + "\n")
    print(f"total {report['seconds_total']:.0f} s; wrote {path}")


if __name__ == "__main__":
    main()
