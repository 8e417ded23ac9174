"""Cross-validated N4SID order sweep on two day-long spindle runs, against SIPPY and nfoursid.

Data: two days of the virtual spindle rig at 6000 rpm (folds 1 and 2 of Table 4
of ``001_6d13a2cd04f5de5e.txt``), raw asynchronous RTD data prepared to 1 Hz
(≈86,400 samples each), 1 input (speed), 7 outputs (temperature rises above
ambient).

* thermogym: 2-fold cross-validation (eqs 7-10) over orders 1..30 —
  decomposition once per fold, every order derived from it, each model
  evaluated at 1 Hz on both folds. Best of ``--repeat`` runs.
* SIPPY (``sippy_unipi``): its N4SID order sweep by information criterion
  (AIC) over orders 1..30 on fold 1 (``SS_f=30`` so that all 30 orders are
  tried; no cross-validation). One run.
* nfoursid: one order (8) at 8,640 samples (2.4 h of each fold centred on the
  spindle stop, so that the input changes; at 86,400 samples it needs about
  55 GiB), against thermogym's single-order identification of the same data.
  One run of the peer, best of ``--repeat`` of ours.

Validation fit: MNRMSE (eq 6) of the fold-1 model simulated on fold 2 at 1 Hz
with the initial state estimated by least squares (MATLAB ``compare``), the
same for every tool.

Usage::

    python benchmarks/n4sid.py [--json PATH] [--repeat 2] [--no-peers]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from pathlib import Path

import numpy as np

from thermogym._fileio import atomic_write_text
from thermogym.identification.crossval import cross_validate_order
from thermogym.identification.metrics import nrmse
from thermogym.identification.n4sid import n4sid, n4sid_decompose
from thermogym.models.linear import StateSpaceModel
from thermogym.studies.spindle import OUTPUTS, spindle_data


def load() -> float:
    return os.getloadavg()[0]


def mnrmse(y, yh) -> float:
    return float(np.mean(nrmse(y.T, yh.T)))


def validation_fit(A, B, C, D, u, y) -> float:
    """MNRMSE on (u, y) with the initial state estimated by least squares."""
    m = StateSpaceModel.from_matrices(A, B, C, D, dt=1.0)
    x0 = m.estimate_x0(u, y)[0]
    return mnrmse(y, m.simulate(u, 1.0, x0=x0).outputs[0])


def arrays(rec, sl=slice(None)):
    u = rec["speed"][sl][:, None].copy()
    y = np.column_stack([rec[c][sl] for c in OUTPUTS])
    return u, y


def around_stop(rec, n):
    """``n`` samples centred on the spindle stop (the input's step)."""
    k = int(np.argmax(rec["speed"] == 0.0))
    a = max(0, k - n // 2)
    return slice(a, a + n)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", type=Path, help="write the figures to this file")
    ap.add_argument("--repeat", type=int, default=2, help="runs of our sweep (best is kept)")
    ap.add_argument("--no-peers", action="store_true", help="skip SIPPY and nfoursid")
    ap.add_argument("--no-sippy", action="store_true", help="skip SIPPY (slow)")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()

    load0 = load()
    t0 = time.perf_counter()
    data = spindle_data(seed=args.seed, speeds=(6000,), validation_speeds=())
    r1, r2 = data.fold(6000, 1), data.fold(6000, 2)
    t_data = time.perf_counter() - t0
    print(f"machine: {platform.node()}, {os.cpu_count()} cores, load average {load0:.2f}")
    print(
        f"data: 2 spindle days at 6000 rpm, {r1.n_samples} and {r2.n_samples} samples at 1 Hz, "
        f"1 input, {len(OUTPUTS)} outputs (rig {data.seconds['rig']:.1f} s, preparation of "
        f"2 x {data.raw_rows} raw rows {data.seconds['prepare']:.1f} s)"
    )

    # ------------------------------------------------------------------ ours
    cross_validate_order([r1, r2], ["speed"], list(OUTPUTS), [1, 2])  # compile numba kernels
    best = None
    for _ in range(max(1, args.repeat)):
        cv = cross_validate_order([r1, r2], ["speed"], list(OUTPUTS), range(1, 31))
        if best is None or cv.seconds["total"] < best.seconds["total"]:
            best = cv
    cv = best
    assert cv is not None
    k = int(np.argmax(cv.va))
    print(
        f"thermogym 2-fold CV, orders 1..30: {cv.seconds['total']:.2f} s "
        f"(decomposition {cv.seconds['decomposition']:.2f} s, 60 models "
        f"{cv.seconds['models']:.2f} s, 120 evaluations at 1 Hz {cv.seconds['evaluation']:.2f} s); "
        f"decimation {cv.settings['decimate']}, horizon {cv.settings['horizon']}"
    )
    print(f"  n* = {cv.best_order}: TA {100 * cv.ta[k]:.2f} %, VA {100 * cv.va[k]:.2f} %")
    u1, y1 = arrays(r1)
    u2, y2 = arrays(r2)
    ours_at = {}
    for n in sorted({cv.best_order, 8}):
        res = n4sid(r1, ["speed"], list(OUTPUTS), n)
        s = res.system
        ours_at[n] = validation_fit(s.A, s.B, s.C, s.D, u2, y2)
    figures = {
        "samples_per_run": [r1.n_samples, r2.n_samples],
        "sweep_s": cv.seconds["total"],
        "sweep_decomposition_s": cv.seconds["decomposition"],
        "sweep_models_s": cv.seconds["models"],
        "sweep_evaluation_s": cv.seconds["evaluation"],
        "best_order": cv.best_order,
        "TA": float(cv.ta[k]),
        "VA": float(cv.va[k]),
        "validation_fit_fold1_model": ours_at[cv.best_order],
        "validation_fit_order8": ours_at[8],
        "decimate": cv.settings["decimate"],
        "horizon": cv.settings["horizon"],
        "data_preparation_s": data.seconds["prepare"],
        "data_total_s": t_data,
    }
    out = {"benchmark": "n4sid", "figures": figures, "peer": "sippy_unipi", "ratio": None}

    if not (args.no_peers or args.no_sippy):
        # --------------------------------------------------------------- SIPPY
        import io
        from contextlib import redirect_stdout

        from sippy_unipi import system_identification

        t = time.perf_counter()
        with redirect_stdout(io.StringIO()) as buf:
            sip = system_identification(
                y1.T.copy(), u1.T.copy(), "N4SID", IC="AIC", SS_orders=[1, 30], SS_f=30
            )
        t_sippy = time.perf_counter() - t
        n_sippy = int(np.asarray(sip.A).shape[0])
        sippy_fit = validation_fit(
            np.asarray(sip.A), np.asarray(sip.B), np.asarray(sip.C), np.asarray(sip.D), u2, y2
        )
        msg = buf.getvalue().strip().splitlines()
        print(
            f"SIPPY N4SID sweep by AIC, orders 1..30 (SS_f=30), fold 1 only: {t_sippy:.1f} s; "
            f"chosen order {n_sippy}; its fit on fold 2 {100 * sippy_fit:.2f} %"
            + (f" ({msg[-1]})" if msg else "")
        )
        ratio = t_sippy / cv.seconds["total"]
        print(
            f"  -> thermogym's cross-validated sweep is {ratio:.1f}x faster; fold-2 fit "
            f"{100 * ours_at[cv.best_order]:.2f} % (order {cv.best_order}) vs "
            f"{100 * sippy_fit:.2f} % (order {n_sippy})"
        )
        figures.update(
            {
                "sippy_sweep_s": t_sippy,
                "sippy_order": n_sippy,
                "sippy_validation_fit": sippy_fit,
                "vs_sippy": ratio,
            }
        )
        out["ratio"] = ratio

    if not args.no_peers:
        # ------------------------------------------------------------ nfoursid
        import pandas as pd
        from nfoursid.nfoursid import NFourSID

        n_small = 8640
        w1, w2 = around_stop(r1, n_small), around_stop(r2, n_small)
        us1, ys1 = arrays(r1, w1)
        us2, ys2 = arrays(r2, w2)
        cols = [f"y{j}" for j in range(ys1.shape[1])]
        df = pd.DataFrame(np.column_stack([us1, ys1]), columns=["u", *cols])
        t = time.perf_counter()
        nf = NFourSID(df, output_columns=cols, input_columns=["u"], num_block_rows=10)
        nf.subspace_identification()
        ssn, _ = nf.system_identification(rank=8)
        t_nf = time.perf_counter() - t
        nf_fit = validation_fit(ssn.a, ssn.b, ssn.c, ssn.d, us2, ys2)
        # ours: decomposition + order-8 model (what nfoursid's two calls do), best of runs
        n4sid_decompose([us1], [ys1], 1.0, max_order=8).system(8)  # warm
        t_ours = np.inf
        for _ in range(max(3, args.repeat)):
            t = time.perf_counter()
            dec = n4sid_decompose([us1], [ys1], 1.0, max_order=8)
            s = dec.system(8)
            t_ours = min(t_ours, time.perf_counter() - t)
        ours_fit = validation_fit(s.A, s.B, s.C, s.D, us2, ys2)
        small1 = r1.slice(r1.time[w1.start], r1.time[w1.stop - 1])
        t = time.perf_counter()
        n4sid(small1, ["speed"], list(OUTPUTS), 8)  # the whole call: checks, FitResult, metrics
        t_call = time.perf_counter() - t
        print(
            f"nfoursid order 8 at {n_small} samples (10 block rows): {t_nf:.2f} s, fit on fold 2 "
            f"{100 * nf_fit:.2f} %; thermogym order 8 on the same data: {t_ours:.3f} s "
            f"(decimation {dec.decimate}), fit {100 * ours_fit:.2f} % -> {t_nf / t_ours:.0f}x "
            f"faster; the whole n4sid() call with FitResult and metrics {t_call:.2f} s"
        )
        figures.update(
            {
                "nfoursid_order8_8640_s": t_nf,
                "ours_order8_8640_s": t_ours,
                "vs_nfoursid_per_order": t_nf / t_ours,
                "ours_n4sid_call_with_metrics_8640_s": t_call,
                "nfoursid_validation_fit_8640": nf_fit,
                "ours_validation_fit_8640": ours_fit,
            }
        )
    figures["load_average_start"] = load0
    figures["load_average_end"] = load()
    out["machine"] = {"cores": os.cpu_count(), "platform": platform.platform()}
    print(f"load average at the end {figures['load_average_end']:.2f}")
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_text(args.json, json.dumps(out, indent=2) + "\n")
        print(f"wrote {args.json}")


if __name__ == "__main__":
    main()
