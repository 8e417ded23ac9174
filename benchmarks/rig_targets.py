"""Why two rig-fidelity targets are missed: the strut's 30/20 RMSE ratio and the spindle's VA.

Issue 14 sets targets on the rigs: the strut's fitted RC network at least 2x worse in RMSE at
30 m/min than at 20 (paper 000, section 4.1), and the spindle's VA at least 99 % at every
speed with the order picked by 2-fold cross-validation (paper 001, Table 5). The rig is never
tuned to a target; this script measures what the missed figures depend on, so the reason can
be stated with numbers. Nothing here changes a rig: rows of a rig's table are switched off
and concealed effects switched on only to attribute a figure to the physics behind it.

Strut (``--only strut``; each case the rig's three step tests and paper 000's Table 2 Monte
Carlo, :func:`thermogym.studies.strut.rig_fidelity`):

* ``seeds``: the ratio over seeds of the step tests' noise and of the Monte Carlo, the rig's
  own strut;
* ``specimens``: over struts drawn from the paper's stated uncertainty (the rig's spread);
* ``rows_off``: with rows of the rig's table switched off (the physics that makes the rig
  nonlinear in the feed rate: forced convection, the copper's resistance);
* ``effects_on``: with physics the rig keeps concealed that grows faster or slower than the
  feed rate (viscous friction of bearing and nut, a self-ventilated motor);
* ``final_rise``: paper 000's own argument, "according to the measured data the final
  temperature does not change significantly" from 20 to 30 m/min: the recorded rise at the
  end of each test (170 min at 20, 80 min at 30) and the steady rises of the rig's plant;
* ``diagnosis``: today's diagnosis (trained at 20, validated at 25 and 30) over seeds: the
  share of the 30 m/min gap it closes, by the issue's definition and by the ratio.

Spindle (``--only spindle``; :func:`thermogym.studies.spindle.rig_fidelity` and
:func:`~thermogym.studies.spindle.table5`):

* ``orders``: orders 1..40 at the speeds whose pick was the top of 1..30;
* ``directions``: the VA of each direction of the 2-fold CV (fold 1 -> 2 and 2 -> 1);
* ``clean``: the rig's clean 1 Hz data instead of the raw asynchronous days (what the
  preparation of section 2.3.1 costs);
* ``seeds``: VA and order per speed over seeds of the data's realisation.

Usage::

    python benchmarks/rig_targets.py [--only strut spindle] [--seeds 5] [--specimens 10]
        [--json benchmarks/results/rigs/targets.json]
"""

from __future__ import annotations

import argparse
import json
import os
import time
from typing import Any

import numpy as np

from thermogym._fileio import atomic_write_text
from thermogym.identification.metrics import rmse
from thermogym.rigs import get_rig, to_recording
from thermogym.rigs.strut import SPECIMEN_SEED as STRUT_SPECIMEN_SEED
from thermogym.studies import spindle as sst
from thermogym.studies import strut as stt

FEEDS = (20.0, 25.0, 30.0)


# ----------------------------------------------------------------------------- strut
def _strut_case(rig: Any, seed: int, *, diagnosis: bool = False) -> dict[str, Any]:
    """The rig's three step tests, Table 2's Monte Carlo, the ratio and its parts."""
    runs = rig.run("steps", seed=seed)
    recs = [to_recording(r, "strut") for r in runs]
    fid = stt.rig_fidelity(seed=seed, recordings=recs, diagnosis=diagnosis)
    ceil = {
        f"{v:g}": float(np.mean([rmse(rec[o], r.truth[o]) for o in stt.OUTPUTS]))
        for v, rec, r in zip(FEEDS, recs, runs, strict=True)
    }
    f, n, d = fid.rmse_fitted, fid.rmse_nominal, fid.rmse_foptd
    out: dict[str, Any] = {
        "ratio": f[30.0] / f[20.0],
        "rmse_fitted": {f"{v:g}": f[v] for v in FEEDS},
        "ratio_nominal": n[30.0] / n[20.0],
        "ratio_foptd": d[30.0] / d[20.0],
        "rmse_foptd": {f"{v:g}": d[v] for v in FEEDS},
        "ceiling": ceil,
        # the recorded rise at the end of each test over its start (paper 000's argument)
        "final_rise": {
            f"{v:g}": {o: float(rec[o][-1] - rec[o][0]) for o in stt.OUTPUTS}
            for v, rec in zip(FEEDS, recs, strict=True)
        },
    }
    if diagnosis:
        out["diagnosis"] = fid.diagnosis
    return out


def _steady_rises(off: tuple[str, ...] = ()) -> dict[str, dict[str, float]]:
    """Steady rises above the air of the rig's own strut at 20 and 30 m/min (30 h)."""
    rig = get_rig("strut", off=off)
    plant, spec = rig.plant(), rig.specimen
    out = {}
    for v in (20.0, 30.0):
        U = np.tile([v, 20.0], (30, 1))
        y = plant.simulate(U, 3600.0, spec).outputs[0, -1]
        out[f"{v:g}"] = {o: float(y[i] - 20.0) for i, o in enumerate(plant.output_names[:7])}
    return out


def strut(args: argparse.Namespace) -> dict[str, Any]:
    t0 = time.perf_counter()
    res: dict[str, Any] = {}
    base = get_rig("strut")
    print("strut: seeds", flush=True)
    res["seeds"] = {str(s): _strut_case(base, s) for s in range(args.seeds)}
    print("strut: specimens", flush=True)
    draws = base.plant().draw_specimens(
        np.random.default_rng(STRUT_SPECIMEN_SEED + 1), args.specimens
    )
    res["specimens"] = {}
    for i in range(args.specimens):
        sp = draws.take(np.array([i]))
        row = _strut_case(base.with_specimen(sp), 0)
        row["specimen"] = sp.to_dicts()[0]
        res["specimens"][str(i)] = row
    print("strut: rows off, effects on", flush=True)
    res["rows_off"] = {
        "+".join(off): _strut_case(get_rig("strut", off=off), 0)
        for off in (
            ("forced_convection",),
            ("copper_resistance",),
            ("forced_convection", "copper_resistance"),
            ("stroke_contacts",),
            ("heat_partition",),
            ("winding_node",),
        )
    }
    res["effects_on"] = {
        e: _strut_case(get_rig("strut", [e]), 0)
        for e in ("input_nonlinearity", "input_dependent_heat_transfer", "nonlinear_heat_transfer")
    }
    res["steady_rise"] = {
        "rig": _steady_rises(),
        "linear_rig": _steady_rises(("forced_convection", "copper_resistance")),
    }
    print("strut: diagnosis", flush=True)
    res["diagnosis"] = {
        str(s): _strut_case(base, s, diagnosis=True)["diagnosis"]
        for s in range(min(args.seeds, args.diag_seeds))
    }
    res["seconds"] = time.perf_counter() - t0
    return res


# --------------------------------------------------------------------------- spindle
def _va_table(cvs: dict[int, Any]) -> dict[str, Any]:
    out = {}
    for s, cv in cvs.items():
        k = int(np.argmax(cv.va))
        # fits[o, i, j]: model trained on fold i evaluated on fold j (MNRMSE)
        out[str(s)] = {
            "order": int(cv.orders[k]),
            "va": float(cv.va[k]),
            "va_1_to_2": float(cv.fits[k, 0, 1]),
            "va_2_to_1": float(cv.fits[k, 1, 0]),
            "va_by_order": [float(v) for v in cv.va],
            "orders": [int(o) for o in cv.orders],
        }
    return out


def spindle(args: argparse.Namespace) -> dict[str, Any]:
    t0 = time.perf_counter()
    res: dict[str, Any] = {}
    print("spindle: seed 0, raw, orders 1..40", flush=True)
    data = sst.spindle_data(seed=0, validation_speeds=())
    cvs = sst.table5(data, orders=range(1, 41), input_set="speed+ambient", speeds=list(sst.SPEEDS))
    res["orders_1_40"] = _va_table(cvs)
    res["ceiling"] = {str(s): sst._ceiling(data.fold(s, 2), data.truth[(s, 2)]) for s in sst.SPEEDS}
    res["speed_only"] = _va_table(
        sst.table5(data, orders=range(1, 31), input_set="speed", speeds=list(sst.SPEEDS))
    )
    print("spindle: clean 1 Hz data", flush=True)
    clean = sst.spindle_data(seed=0, validation_speeds=(), raw=False)
    res["clean"] = _va_table(
        sst.table5(clean, orders=range(1, 31), input_set="speed+ambient", speeds=list(sst.SPEEDS))
    )
    print("spindle: seeds", flush=True)
    res["seeds"] = {}
    for s in range(1, args.seeds):
        d = sst.spindle_data(seed=s, validation_speeds=())
        res["seeds"][str(s)] = _va_table(
            sst.table5(d, orders=range(1, 31), input_set="speed+ambient", speeds=list(sst.SPEEDS))
        )
    res["seconds"] = time.perf_counter() - t0
    return res


def _summary(doc: dict[str, Any]) -> None:
    st = doc.get("strut")
    if st:
        r = [v["ratio"] for v in st["seeds"].values()]
        print(f"strut ratio over {len(r)} seeds: {np.round(r, 2).tolist()}")
        r = [v["ratio"] for v in st["specimens"].values()]
        print(f"strut ratio over {len(r)} specimens: {np.round(r, 2).tolist()}")
        for k, v in {**st["rows_off"], **st["effects_on"]}.items():
            print(f"  {k:<45} ratio {v['ratio']:.2f}  foptd {v['ratio_foptd']:.2f}")
        for k, v in st["diagnosis"].items():
            print(f"  diagnosis seed {k}: {v.get('named')} gap_closed {v.get('gap_closed')}")
    sp = doc.get("spindle")
    if sp:
        for key in ("orders_1_40", "speed_only", "clean"):
            print(key, {s: (v["order"], round(100 * v["va"], 2)) for s, v in sp[key].items()})
        for seed, tab in sp["seeds"].items():
            print("seed", seed, {s: (v["order"], round(100 * v["va"], 2)) for s, v in tab.items()})


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", nargs="*", default=["strut", "spindle"], choices=["strut", "spindle"])
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--diag-seeds", type=int, default=3)
    ap.add_argument("--specimens", type=int, default=10)
    ap.add_argument("--json", help="write the results here")
    args = ap.parse_args()
    doc: dict[str, Any] = {"load_1min_start": os.getloadavg()[0]}
    if "strut" in args.only:
        doc["strut"] = strut(args)
    if "spindle" in args.only:
        doc["spindle"] = spindle(args)
    doc["load_1min_end"] = os.getloadavg()[0]
    _summary(doc)
    if args.json:
        atomic_write_text(args.json, json.dumps(doc, indent=1) + "\n")


if __name__ == "__main__":
    main()
