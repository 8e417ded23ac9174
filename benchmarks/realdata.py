"""Every shipped real data set: thermogym's documented command beside ARX and SIPPY, held out.

For each case of :data:`thermogym.studies.realdata.CASES` (DaISy hair
dryer, thermic wall, heat exchanger, glass furnace; the DTU building; the two
TCLab collections: Dowling lab sine/step runs, APMonitor MIMO runs) the
training data (first half, or the runs named there) are written to CSV and
identified three ways, and every model is simulated on the held-out data
with the same metric:

* **thermogym** — the command the README gives for the data set, run through
  the command line in this process:
  ``thermogym identify auto TRAIN.csv --inputs ... --outputs ... --out FIT.json``
  (family, orders, delays, structure and operating point chosen by 2-fold
  cross-validation on the training data alone), with ``--operating-point rest``
  for the TCLab runs, which start at rest (:func:`command_for`).
* **arx** — the baseline of issue 16: ARX by least squares, per output a
  multi-input ARX with ``na = nb = n`` (1..10) and one delay ``nk`` (0..10)
  for all inputs, chosen by 2-fold cross-validation of the simulation fit on
  the training data; operating point of the case (``mean``, or ``rest`` for
  the TCLab runs) or absolute values (``none``, which thermogym's default may
  choose too), whichever cross-validates better. Written here with numpy,
  independently of thermogym's identification code.
* **sippy** — SIPPY (``sippy_unipi``, LGPL-3.0): its N4SID, MOESP and CVA
  with the order by AIC (1..10), and for single-input single-output sets also
  its ARX and ARMAX with orders and delay by AIC; centred by the case's
  operating point and, separately, on absolute values (``none``).
  *SIPPY's best structure and operating point are picked on the held-out
  data* (hindsight in the peer's favour, so the margin below is a
  conservative one).

Metric: NRMSE fit ``1 − ‖y − ŷ‖/‖y − ȳ‖`` per output, mean over outputs
(MNRMSE, eq 6 of paper 001) and over the held-out recordings; each model is
simulated on the held-out inputs about the held-out data's own operating point
in that model's mode (its means for ``mean``, as MATLAB's example detrends
estimation and validation data separately; zero for ``none``; its first
output sample for ``rest``) with the initial state fitted to the held-out
outputs by least squares (MATLAB ``compare``). The same for all three.
``worst_margin`` is the smallest ``thermogym − max(arx, sippy)`` over the data
sets (target >= 0).

Usage (SIPPY from the ``bench`` extra; ``--readme`` rewrites the README's table)::

    python benchmarks/realdata.py --json benchmarks/results/identification/realdata_pem.json \
        --readme README.md
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import sys
import tempfile
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np
from scipy.signal import lfilter

from thermogym._fileio import atomic_write_text
from thermogym.fitresult import FitResult
from thermogym.identification.linear_fit import operating_point, predict_fit
from thermogym.identification.metrics import nrmse
from thermogym.models.linear import StateSpaceModel
from thermogym.recording import Recording, write_recording
from thermogym.studies.realdata import CASES, case_data


# ------------------------------------------------------------------ metric
def heldout_ss(
    A: Any, B: Any, C: Any, D: Any, dt: float, recs: list[Recording], ins: list[str],
    outs: list[str], mode: str,
) -> float:  # fmt: skip
    """MNRMSE of a deviation-form state space on held-out recordings (x0 estimated)."""
    A, B, C, D = (np.atleast_2d(np.asarray(a, dtype=float)) for a in (A, B, C, D))
    if A.size == 0:
        A, B, C = np.zeros((1, 1)), np.zeros((1, len(ins))), np.zeros((len(outs), 1))
    m = StateSpaceModel.from_matrices(A, B, C, D, dt=dt)
    vals = []
    for rec in recs:
        u = np.column_stack([rec[c] for c in ins])
        y = np.column_stack([rec[c] for c in outs])
        u_op, y_op = operating_point(u, y, mode)
        du, dy = u - u_op, y - y_op
        try:
            x0 = m.estimate_x0(du, dy)
            yh = m.simulate(du, dt, None, x0, strict=False).outputs[0]
        except Exception:
            vals.append(-np.inf)
            continue
        f = np.atleast_1d(nrmse(dy.T, yh.T))
        vals.append(float(np.mean(np.where(np.isfinite(f), f, -np.inf))))
    return float(np.mean(vals))


def heldout_fit(fit: FitResult, recs: list[Recording], outs: list[str]) -> float:
    """MNRMSE of a thermogym FitResult on held-out recordings (the package's predict_fit)."""
    vals = []
    for rec in recs:
        yh = predict_fit(fit, rec, x0="estimate", operating="recording")
        vals.append(float(np.mean([nrmse(rec[c], yh[:, j]) for j, c in enumerate(outs)])))
    return float(np.mean(vals))


# ------------------------------------------------------------ ARX baseline
def _arx_fit(us: list, ys: list, n: int, nk: int) -> tuple[np.ndarray, np.ndarray]:  # type: ignore[type-arg]
    """Least-squares MISO ARX per output; returns a (p, n) and b (p, m, n)."""
    m, p = us[0].shape[1], ys[0].shape[1]
    a = np.zeros((p, n))
    b = np.zeros((p, m, n))
    L = max(n, nk + n - 1, 1)
    for j in range(p):
        rows, rhs = [], []
        for u, y in zip(us, ys, strict=True):
            T = y.shape[0]
            cols = [-y[L - k : T - k, j] for k in range(1, n + 1)]
            for i in range(m):
                cols += [u[L - nk - l : T - nk - l, i] for l in range(n)]
            rows.append(np.column_stack(cols))
            rhs.append(y[L:, j])
        th = np.linalg.lstsq(np.vstack(rows), np.concatenate(rhs), rcond=None)[0]
        a[j] = th[:n]
        b[j] = th[n:].reshape(m, n)
    return a, b


def _arx_sim(a: np.ndarray, b: np.ndarray, nk: int, u: np.ndarray) -> np.ndarray:  # type: ignore[type-arg]
    p, m, _n = b.shape
    out = np.zeros((u.shape[0], p))
    for j in range(p):
        den = np.r_[1.0, a[j]]
        for i in range(m):
            out[:, j] += lfilter(np.r_[np.zeros(nk), b[j, i]], den, u[:, i])
    return out


def _arx_ss(a: np.ndarray, b: np.ndarray, nk: int) -> tuple[np.ndarray, ...]:  # type: ignore[type-arg]
    """Block-diagonal observer-form realisation of the ARX (for the common metric)."""
    import scipy.signal

    p, m, _n = b.shape
    blocks = []
    for j in range(p):
        den = np.r_[1.0, a[j]]
        nums = [np.r_[np.zeros(nk), b[j, i]] for i in range(m)]
        L = max(len(den), max(len(x) for x in nums))
        den = np.r_[den, np.zeros(L - len(den))]
        num = np.array([np.r_[x, np.zeros(L - len(x))] for x in nums])
        Ai, Bi, Ci, Di = [], [], [], []
        for i in range(m):
            A_, B_, C_, D_ = scipy.signal.tf2ss(num[i], den)
            Ai.append(A_), Bi.append(B_), Ci.append(C_), Di.append(D_)
        blocks.append((Ai, Bi, Ci, Di))
    import scipy.linalg

    As, Ds = [], np.zeros((p, m))
    col = 0
    n_tot = sum(A_.shape[0] for blk in blocks for A_ in blk[0])
    Bm = np.zeros((n_tot, m))
    Cm = np.zeros((p, n_tot))
    for j, (Ai, Bi, Ci, Di) in enumerate(blocks):
        for i in range(m):
            k = Ai[i].shape[0]
            As.append(Ai[i])
            Bm[col : col + k, i] = Bi[i][:, 0]
            Cm[j, col : col + k] = Ci[i][0]
            Ds[j, i] = Di[i][0, 0]
            col += k
    A = scipy.linalg.block_diag(*As) if As else np.zeros((0, 0))
    return A, Bm, Cm, Ds


def arx_baseline(train: list[Recording], ins: list[str], outs: list[str], mode: str) -> dict:  # type: ignore[type-arg]
    """ARX, orders and delay by 2-fold CV of the simulation fit on the training data."""

    def dev(rec: Recording) -> tuple[np.ndarray, np.ndarray]:  # type: ignore[type-arg]
        u = np.column_stack([rec[c] for c in ins])
        y = np.column_stack([rec[c] for c in outs])
        u0, y0 = operating_point(u, y, mode)
        return u - u0, y - y0

    data = [dev(r) for r in train]
    if len(data) == 1:
        T = data[0][0].shape[0]
        h = T // 2
        folds = [[(data[0][0][:h], data[0][1][:h])], [(data[0][0][h:], data[0][1][h:])]]
    else:
        folds = [data[0::2], data[1::2]]
    best = (-np.inf, 1, 0)
    for n in range(1, 11):
        for nk in range(0, 11):
            s = []
            for i in (0, 1):
                a, b = _arx_fit([d[0] for d in folds[i]], [d[1] for d in folds[i]], n, nk)
                for u, y in folds[1 - i]:
                    yh = _arx_sim(a, b, nk, u)
                    f = np.atleast_1d(nrmse(y.T, yh.T))
                    s.append(np.mean(np.where(np.isfinite(f), f, -10.0)))
            score = float(np.mean(s))
            if score > best[0]:
                best = (score, n, nk)
    _, n, nk = best
    a, b = _arx_fit([d[0] for d in data], [d[1] for d in data], n, nk)
    return {"n": n, "nk": nk, "cv": best[0], "ss": _arx_ss(a, b, nk)}


# ------------------------------------------------------------------ SIPPY
def sippy_models(train: list[Recording], ins: list[str], outs: list[str], mode: str) -> dict:  # type: ignore[type-arg]
    """SIPPY's structures (order by AIC) on the training data, as state spaces."""
    import control
    from sippy_unipi import system_identification

    u = np.vstack([np.column_stack([r[c] for c in ins]) for r in train])
    y = np.vstack([np.column_stack([r[c] for c in outs]) for r in train])
    u0, y0 = operating_point(u, y, mode)
    u, y = u - u0, y - y0
    dt = train[0].dt
    runs: list[tuple[str, dict[str, Any]]] = [
        (m, {"SS_orders": [1, 10]}) for m in ("N4SID", "MOESP", "CVA")
    ]
    if len(ins) == 1 and len(outs) == 1:
        runs += [
            ("ARX", {"na_ord": [1, 5], "nb_ord": [1, 5], "delays": [0, 10]}),
            ("ARMAX", {"na_ord": [1, 4], "nb_ord": [1, 4], "nc_ord": [1, 4], "delays": [0, 10]}),
        ]
    out = {}
    for meth, kw in runs:
        t = time.perf_counter()
        try:
            with contextlib.redirect_stdout(io.StringIO()), warnings.catch_warnings():
                warnings.simplefilter("ignore")
                mod = system_identification(y.T, u.T, meth, IC="AIC", tsample=dt, **kw)
            if hasattr(mod, "A"):
                ss = (mod.A, mod.B, mod.C, mod.D)
            else:
                s = control.ss(mod.G)
                ss = (s.A, s.B, s.C, s.D)
            out[meth] = {"ss": ss, "seconds": time.perf_counter() - t}
        except BaseException as e:
            out[meth] = {"error": repr(e)[:200], "seconds": time.perf_counter() - t}
    return out


# ------------------------------------------------------------------- main
def command_for(case: Any, train_csv: str, out: str) -> list[str]:
    """The README's one-line command for a case (as argv).

    The default options, plus ``--operating-point rest`` where the data set's
    description says every run starts at rest with the inputs at zero (the
    TCLab runs: board at ambient, heaters off at ``t = 0``; the ``rest`` mode of
    :data:`thermogym.studies.realdata.CASES`, which the baselines get too).
    Cross-validation cannot judge that mode on one cut run: only the first
    part starts at rest.
    """
    argv = [
        "identify", "auto", train_csv, "--inputs", ",".join(case.inputs),
        "--outputs", ",".join(case.outputs), "--out", out,
    ]  # fmt: skip
    if case.operating_point == "rest":
        argv += ["--operating-point", "rest"]
    return argv


_TABLE_START = "<!-- realdata-table:start -->"
_TABLE_END = "<!-- realdata-table:end -->"


def readme_table(doc: dict[str, Any]) -> str:
    """The README's real-data table (Markdown) from a results JSON of this benchmark."""
    rows = [
        "| data set | command (`thermogym identify auto ...`, on the training part) | chosen "
        "| thermogym | ARX (LS, CV) | SIPPY best | margin |",
        "|---|---|---|---|---|---|---|",
    ]
    sets = doc["figures"]["sets"]
    for name, c in doc["details"]["cases"].items():
        f = sets[name]
        cmd = c["command"].removeprefix("thermogym ")
        tg = c["thermogym"]
        sip = c["sippy"]
        sip_txt = (
            f"{100 * f['sippy']:.1f} % ({sip['best']})"
            if sip.get("best") and np.isfinite(f["sippy"])
            else "not run"
        )
        rows.append(
            f"| {name} | `{cmd}` | {tg['family']} ({tg['operating_point']}) | "
            f"{100 * f['thermogym']:.1f} % | {100 * f['arx']:.1f} % | {sip_txt} | "
            f"{100 * c['margin']:+.1f} |"
        )
    worst = doc["figures"]["worst_margin"]
    rows += [
        "",
        f"Worst margin (thermogym − best baseline): **{100 * worst:+.1f} points** "
        f"(target ≥ 0{': met' if worst >= 0 else ': missed'}).",
    ]
    return "\n".join(rows)


def update_readme(readme: Path, doc: dict[str, Any]) -> None:
    """Replace the block between the realdata-table markers of ``readme`` (atomically)."""
    text = readme.read_text(encoding="utf-8")
    a, b = text.find(_TABLE_START), text.find(_TABLE_END)
    if a < 0 or b < a:
        raise SystemExit(f"{readme}: no {_TABLE_START} ... {_TABLE_END} block to replace")
    new = text[: a + len(_TABLE_START)] + "\n" + readme_table(doc) + "\n" + text[b:]
    atomic_write_text(readme, new)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", type=Path, required=True, help="figures JSON to write (or read)")
    ap.add_argument("--cases", nargs="*", default=list(CASES))
    ap.add_argument("--no-sippy", action="store_true")
    ap.add_argument("--fits", type=Path, help="folder to keep the thermogym FitResults in")
    ap.add_argument(
        "--readme", type=Path, help="also rewrite this README's real-data table from the results"
    )
    ap.add_argument(
        "--table-only",
        action="store_true",
        help="run nothing: rewrite --readme's table from the existing --json",
    )
    args = ap.parse_args()
    if args.table_only:
        if args.readme is None:
            raise SystemExit("--table-only needs --readme")
        update_readme(args.readme, json.loads(args.json.read_text(encoding="utf-8")))
        print(f"rewrote the real-data table of {args.readme} from {args.json}")
        return
    from thermogym.cli import main as cli

    report: dict[str, Any] = {"load_average_start": os.getloadavg()[0], "cases": {}}
    sets: dict[str, dict[str, float]] = {}
    tmp = Path(tempfile.mkdtemp(prefix="thermogym-realdata-"))
    print(f"{'case':<16} {'thermogym':>10} {'arx':>8} {'sippy':>8} {'margin':>8}  chosen")
    for name in args.cases:
        case = CASES[name]
        ins, outs = list(case.inputs), list(case.outputs)
        train, vals = case_data(name)
        csvs = []
        for k, r in enumerate(train):
            p = tmp / f"{name}_train{k}.csv"
            write_recording(r, p)
            csvs.append(str(p))
        fit_path = (args.fits or tmp) / f"{name}.json"
        fit_path.parent.mkdir(parents=True, exist_ok=True)
        t = time.perf_counter()
        argv = command_for(case, csvs[0], str(fit_path))
        argv[2:3] = csvs  # every training run (TCLab: one; the halves: one)
        buf = io.StringIO()
        with contextlib.redirect_stdout(buf):
            rc = cli(argv)
        t_tg = time.perf_counter() - t
        if rc != 0:
            print(buf.getvalue(), file=sys.stderr)
            raise SystemExit(f"{name}: thermogym identify failed (exit {rc})")
        fit = FitResult.load(fit_path)
        tg = heldout_fit(fit, vals, outs)
        # the baselines get the case's operating point and absolute values ("none", which
        # thermogym's default may choose too): ARX takes the better by its own
        # cross-validation, SIPPY the better on the held-out data (hindsight in its favour)
        modes = [case.operating_point] + (["none"] if case.operating_point != "none" else [])
        t = time.perf_counter()
        arxs = {mode: arx_baseline(train, ins, outs, mode) for mode in modes}
        arx_mode = max(modes, key=lambda md: arxs[md]["cv"])
        arx = arxs[arx_mode]
        arx_val = heldout_ss(*arx["ss"], train[0].dt, vals, ins, outs, arx_mode)
        t_arx = time.perf_counter() - t
        sip_scores: dict[str, float] = {}
        sip_detail: dict[str, Any] = {}
        for mode in [] if args.no_sippy else modes:
            for meth, res in sippy_models(train, ins, outs, mode).items():
                key = meth if mode == case.operating_point else f"{meth} ({mode})"
                sip_detail[key] = {"seconds": res["seconds"]}
                if "ss" in res:
                    sip_scores[key] = heldout_ss(*res["ss"], train[0].dt, vals, ins, outs, mode)
                    sip_detail[key]["heldout"] = sip_scores[key]
                else:
                    sip_detail[key]["error"] = res["error"]
        sip_best = max(sip_scores, key=lambda k: sip_scores[k]) if sip_scores else None
        sip = sip_scores[sip_best] if sip_best else float("nan")
        margin = tg - np.nanmax([arx_val, sip])
        sets[name] = {"thermogym": tg, "arx": arx_val, "sippy": sip}
        chosen = fit.settings.get("auto", {}).get("chosen")
        op = fit.settings.get("operating_point_mode")
        report["cases"][name] = {
            "command": "thermogym " + " ".join(command_for(case, "TRAIN.csv", "fit.json")),
            "train": [r.experiment_id for r in train],
            "validation": [r.experiment_id for r in vals],
            "thermogym": {"heldout": tg, "family": chosen, "operating_point": op,
                          "auto": fit.settings.get("auto"), "seconds": t_tg},
            "arx": {"heldout": arx_val, "n": arx["n"], "nk": arx["nk"], "cv": arx["cv"],
                    "operating_point": arx_mode,
                    "cv_per_mode": {md: arxs[md]["cv"] for md in modes}, "seconds": t_arx},
            "sippy": {"heldout": sip, "best": sip_best, "structures": sip_detail},
            "margin": margin,
        }  # fmt: skip
        print(
            f"{name:<16} {100 * tg:9.1f}% {100 * arx_val:7.1f}% {100 * sip:7.1f}% "
            f"{100 * margin:7.1f}  {chosen} ({op}); arx n={arx['n']} nk={arx['nk']}; "
            f"sippy {sip_best}; {t_tg:.0f} s",
            flush=True,
        )
    worst = min(v["thermogym"] - np.nanmax([v["arx"], v["sippy"]]) for v in sets.values())
    report["load_average_end"] = os.getloadavg()[0]
    doc = {"benchmark": "realdata", "figures": {"sets": sets, "worst_margin": worst},
           "peers": ["arx (least squares, numpy)", "sippy_unipi"], "details": report}  # fmt: skip
    atomic_write_text(args.json, json.dumps(doc, indent=2, default=float) + "\n")
    print(f"worst margin {100 * worst:.1f} points; wrote {args.json}")
    if args.readme is not None:
        update_readme(args.readme, doc)
        print(f"rewrote the real-data table of {args.readme}")


if __name__ == "__main__":
    main()
