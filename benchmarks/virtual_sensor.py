"""Virtual sensors on held-out rig runs: spindle internal temperatures and AXT211 wax temperature.

Spindle (paper ``001_6d13a2cd04f5de5e.txt``, section 3.3). Order-8 models are
identified by N4SID on the rig's run-in day ``D¹_6000`` (clean 1 Hz channels)
in the formulations of :mod:`thermogym.estimation`:

* ``1I7O-KF`` — speed and ambient in, all seven temperatures out, the two
  surface temperatures *measured*: the steady-state Kalman observer corrects
  with their innovations (the formulation this package recommends);
* ``1I7O-open`` — the same model run open loop (no correction): the paper's
  way of predicting, and the named peer of the ratios printed;
* ``3I5O`` — Table 6's 3I5O with surface temperatures as *inputs*
  (identified on ambient-subtracted data, used with ``reference="T_amb"``),
  from :func:`thermogym.studies.spindle.virtual_sensor_fit`;
* ``3I5O+amb`` — the same with the ambient as a fourth input.

The process-noise scale of each sensor is tuned on the other run-in day
``D²_6000`` (NEES against the recorded internal temperatures smoothed over
5 min, their remaining noise accounted for) — never on the evaluation days.
Evaluation: the section 3.2 validation days (4500, 5300, 7800 rpm, another seed) against the rig's
noise-free truth (``RigRun.truth``): RMSE, NRMSE fit (eq 5) and NEES
consistency, in three scenarios — *nominal* (the run starts at rest, as the
estimator assumes), *warm start* (the estimator starts 4 h into the run
believing the spindle is at rest; the time-varying Kalman filter with a wide
initial covariance), *disturbance* (a rig with an unmeasured 2 K, 5 h
disturbance on the ambient the spindle sees).

AXT211 (paper ``002_dae2310635fe074e.txt``): the unscented Kalman filter
estimating the wax temperature T_P from the valve stroke and the PTC power,
plain and with the specimen parameters ``T_P0``, ``kP_b`` estimated jointly,
on the rig's ``steps`` runs (three supply/ambient corners), the ``pwm`` run,
two specimens of the ``spread`` protocol (parameters off nominal) and runs of
rigs with an unmeasured ambient disturbance and a sagging supply (first 2 h
of each); filters started with T_P 15 K wrong; the peer is the open-loop
model from the same start.

Usage::

    python benchmarks/virtual_sensor.py [--json PATH] [--quick]
"""

from __future__ import annotations

import argparse
import json
import os
import time
import warnings

import numpy as np
from scipy.ndimage import uniform_filter1d

from thermogym._fileio import atomic_write_text
from thermogym.estimation import AXT211WaxUKF, VirtualSensor, consistency
from thermogym.identification.metrics import nrmse
from thermogym.identification.n4sid import n4sid
from thermogym.recording import Recording
from thermogym.rigs import get_rig

HIDDEN = [
    "T_rear_bearing_A",
    "T_rear_bearing_B",
    "T_front_bearing_C",
    "T_front_bearing_D",
    "T_inner_housing",
]
SURFACE = ["T_front_outer_housing", "T_rear_outer_housing"]
REST = {"speed": 0.0}
# at rest the housing is at the ambient temperature: surface-input models take it from there
REST_SURFACE = {"speed": 0.0, **{s: "T_amb" for s in SURFACE}}
RTD_STD = 0.02  # K, the rig's RTD noise (paper 001 Table 2: ±0.05 K accuracy)
SMOOTH = 301  # samples of the moving average of the recorded truth used for tuning


def _rec(run, start: int = 0) -> Recording:
    return Recording(
        run.time[start:],
        {k: v[start:].copy() for k, v in run.columns.items()},
        units=run.units,
        roles=dict(run.roles),
        experiment_id=run.experiment_id,
    )


def _rise(rec: Recording) -> Recording:
    amb = rec["T_amb"]
    cols = {k: (rec[k] - amb if k in HIDDEN + SURFACE else rec[k]) for k in rec.columns}
    return Recording(rec.time, cols, units=dict(rec.units), roles=dict(rec.roles))


def identify(train: Recording) -> dict:
    t0 = time.perf_counter()
    r1 = n4sid(train, ["speed", "T_amb"], HIDDEN + SURFACE, order=8, disturbances=["T_amb"])
    r4 = n4sid(train, ["speed", *SURFACE, "T_amb"], HIDDEN, order=8, disturbances=["T_amb"])
    fits = {"1I7O": r1.fit, "3I5O+amb": r4.fit}
    try:
        from thermogym.studies.spindle import virtual_sensor_fit

        fits["3I5O"] = virtual_sensor_fit("3I5O", order=8)
    except ImportError:
        r3 = n4sid(_rise(train), ["speed", *SURFACE], HIDDEN, order=8, disturbances=SURFACE)
        fits["3I5O"] = r3.fit
    print(f"identified order-8 models in {time.perf_counter() - t0:.1f} s")
    return fits


def sensors(fits: dict) -> dict:
    def build(fit, **kw):
        m = fit.build_model()
        return VirtualSensor(m, fit.theta(m), measurement_std=RTD_STD, **kw)

    return {
        "1I7O-KF": build(fits["1I7O"], measured=SURFACE),
        "1I7O-open": build(fits["1I7O"], hidden=HIDDEN),
        "3I5O": build(fits["3I5O"], reference="T_amb"),
        "3I5O+amb": build(fits["3I5O+amb"]),
    }


def tune(vs: VirtualSensor, cal: Recording) -> tuple[VirtualSensor, float]:
    # the recorded internal temperatures, smoothed over 5 min (centred): their 0.02 K
    # noise would otherwise hide model errors of a few mK from the NEES
    u, z = vs.arrays(cal)
    truth = uniform_filter1d(np.column_stack([cal[h] for h in HIDDEN]), SMOOTH, axis=0)
    std = RTD_STD / np.sqrt(SMOOTH)
    return vs.tuned(u, z, hidden_truth=truth, truth_std=std, rest=_rest(vs), discard=SMOOTH)


def _rest(vs: VirtualSensor) -> dict:
    return REST_SURFACE if set(SURFACE) <= set(vs.exogenous_names) else REST


def evaluate(vs: VirtualSensor, run, *, start: int = 0, method: str = "observer") -> dict:
    rec = _rec(run, start)
    kw: dict = {"rest": _rest(vs)}
    if method == "kalman":
        kw["P0"] = np.eye(vs.n_states) * 1e3 * np.trace(vs.gains.P)
    e = vs.estimate(rec, method=method, **kw)
    Y = np.column_stack([run.truth[h][start:] for h in HIDDEN])
    fits = np.asarray(nrmse(Y.T, e.values.T))
    rep = consistency(e.nees(Y), len(HIDDEN))
    # noise ceiling: the internal RTDs the sensor replaces, against the truth
    R = np.column_stack([np.asarray(rec[h], dtype=float) for h in HIDDEN])
    return {
        "rtd_rmse_K": float(np.sqrt(np.nanmean((R - Y) ** 2, axis=0)).max()),
        "nrmse_min": float(fits.min()),
        "nrmse_mean": float(fits.mean()),
        "rmse_max_K": float(np.sqrt(np.mean((Y - e.values) ** 2, axis=0)).max()),
        "nees_mean": rep.mean,
        "nees_consistent": rep.consistent,
        "nees_fraction_inside": rep.fraction_inside,
    }


def spindle(quick: bool) -> dict:
    rig = get_rig("spindle")
    speeds = [5300] if quick else [4500, 5300, 7800]
    train = rig.run("run-in", seed=0, raw=False, speeds=[6000], folds=[1, 2])
    fits = identify(_rec(train[0]))
    cal = _rec(train[1])
    out: dict = {"tuning": {}}
    vss = {}
    for name, vs in sensors(fits).items():
        tuned, alpha = tune(vs, cal)
        vss[name] = tuned
        out["tuning"][name] = alpha
    scen = {
        "nominal": (rig.run("validation", seed=11, raw=False, speeds=speeds), 0),
        "warm start": (rig.run("validation", seed=11, raw=False, speeds=speeds), 4 * 3600),
        "disturbance": (
            get_rig("spindle", ["unmeasured_disturbance"]).run(
                "validation", seed=11, raw=False, speeds=speeds
            ),
            0,
        ),
    }
    for sname, (runs, start) in scen.items():
        out[sname] = {}
        for name, vs in vss.items():
            method = "kalman" if (start and vs.measured_names) else "observer"
            per = [evaluate(vs, r, start=start, method=method) for r in runs]
            out[sname][name] = {
                "method": method,
                "runs": {r.experiment_id: p for r, p in zip(runs, per, strict=True)},
                "nrmse_min": min(p["nrmse_min"] for p in per),
                "rmse_max_K": max(p["rmse_max_K"] for p in per),
                "nees_mean": float(np.mean([p["nees_mean"] for p in per])),
                "consistent_runs": sum(p["nees_consistent"] for p in per),
                "rtd_rmse_K": max(p["rtd_rmse_K"] for p in per),
            }
    return out


#: The rig's training tests of paper 002's procedure (benchmarks/rig_fidelity.py): the model
#: a deployed wax-temperature filter would carry is identified on these, never on the runs
#: the filter is evaluated on.
AXT211_TRAIN = [(24.0, 25.0), (19.0, 0.0), (29.0, 50.0)]
#: Held-out supply/ambient corners the filters are evaluated on.
AXT211_HELD = [(19.0, 50.0), (24.0, 0.0), (29.0, 25.0)]


def _axt211_fitted_theta() -> tuple[np.ndarray, dict[str, float]]:
    """AXT211 parameters identified by paper 002's procedure (stages 1-3) on rig training tests.

    Also the RMS of the fitted model's open-loop residuals of the filter's measurements on
    those tests: the model error a filter carrying this model should expect (a deployed filter
    is tuned on its training data, as the spindle sensors are on another run-in day).
    """
    from thermogym.identification.greybox_axt211 import identify_axt211
    from thermogym.models import AXT211
    from thermogym.rigs import to_recording

    rig = get_rig("axt211")
    v, a = zip(*AXT211_TRAIN, strict=True)
    steps = rig.run("steps", seed=0, voltages=list(v), ambients=list(a))
    stair = rig.run("staircase", seed=1)
    train = [to_recording(r, "axt211") for r in steps]
    full = max(train, key=lambda r: float(np.nanmax(r["x_V"])))
    res = identify_axt211(
        train, [to_recording(r, "axt211") for r in stair] + [full], [], joint=False,
        mc_samples=500, max_iter=60, seed=0, progress=False,
    )  # fmt: skip
    m = AXT211()
    theta = m.theta(batch=1)
    for k, val in res.stage_parameters.items():
        theta[0, m.param_index(k)] = val
    resid: dict[str, list[float]] = {"x_V": [], "P_PTC": []}
    for r in train:
        sim = m.simulate(r.exogenous_array(m), r.dt, theta)
        for k, v in resid.items():
            e = np.asarray(r[k], dtype=float) - sim.output(k)[0]
            v.extend(e[np.isfinite(e)].tolist())
    return theta, {k: float(np.sqrt(np.mean(np.square(v)))) for k, v in resid.items()}


def axt211(quick: bool) -> dict:
    from thermogym.models import AXT211

    rig = get_rig("axt211")
    corners = AXT211_HELD if not quick else AXT211_HELD[:1]
    runs = [rig.run("steps", seed=5, voltages=[v], ambients=[a])[0] for v, a in corners]
    two_h = 7200
    if not quick:
        runs += rig.run("pwm", seed=5)
        runs += rig.run("spread", seed=5, n=2)
        for eff in ("unmeasured_disturbance", "supply_variation"):
            r = get_rig("axt211", [eff]).run("steps", seed=5, voltages=[24.0], ambients=[25.0])[0]
            r.experiment_id += f"+{eff}"
            runs.append(r)
    t0 = time.perf_counter()
    fitted, model_err = _axt211_fitted_theta()
    print(
        f"AXT211 model identified on the rig's training tests in {time.perf_counter() - t0:.0f} s;"
        f" its training residuals: x_V {model_err['x_V']:.3f} mm, P_PTC {model_err['P_PTC']:.3f} W"
    )
    model = AXT211()
    models = {"nominal": model.theta(batch=1), "fitted": fitted}
    params = {"parameters": {"T_P0": 1.5, "kP_b": 0.015}}
    filters = {
        "UKF nominal": ("nominal", {}),
        "UKF fitted": ("fitted", {}),
        "UKF fitted+T_P0,kP_b": ("fitted", params),
        # measurement noise = the model's training residuals (model error), not the sensors'
        "UKF fitted, model-error noise": ("fitted", {"measurement_std": model_err}),
    }
    res: dict = {}
    for run in runs:
        k = slice(0, min(two_h, run.time.size))
        u = np.column_stack([run.columns[c][k] for c in ("u", "k_U", "T_U")])
        z = np.column_stack([run.columns[c][k] for c in ("x_V", "P_PTC")])
        truth = run.truth["T_P"][k]
        late = slice(600, None)
        # noise ceiling: the cartridge thermocouple itself against the truth (what measuring
        # T_P would give, the quantity the filter estimates without a thermocouple)
        meas = run.columns["T_P"][k]
        ok = np.isfinite(meas[late])
        entry: dict = {
            "thermocouple_rmse_K": float(np.sqrt(np.mean((meas[late] - truth[late])[ok] ** 2)))
        }
        for name, (mk, kw) in filters.items():
            ukf = AXT211WaxUKF(model, theta=models[mk], **kw)
            x0 = ukf.rest_state(u[0])
            x0[0] += 15.0
            t1 = time.perf_counter()
            est = ukf.run(u, z, x0=x0)
            secs = time.perf_counter() - t1
            err = est["T_P"] - truth
            rep = consistency((err**2 / est.cov[:, 0, 0])[late], 1)
            entry[name] = {
                "rmse_K": float(np.sqrt(np.mean(err[late] ** 2))),
                "max_abs_K": float(np.abs(err[late]).max()),
                "nees_mean": rep.mean,
                "ms_per_step": 1e3 * secs / len(truth),
            }
        for mk, th in models.items():
            ukf = AXT211WaxUKF(model, theta=th)
            x0 = ukf.rest_state(u[0])
            x0[0] += 15.0
            sim = model.simulate(u, 1.0, th, x0=x0[:4]).output("T_P")[0]
            entry[f"open_loop_{mk}_rmse_K"] = float(np.sqrt(np.mean((sim - truth)[late] ** 2)))
        res[run.experiment_id] = entry
    return res


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", help="write the results as JSON")
    ap.add_argument("--quick", action="store_true", help="one validation day, fewer AXT211 runs")
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    load = os.getloadavg()
    print(f"machine load (1/5/15 min): {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}")
    t0 = time.perf_counter()
    sp = spindle(args.quick)
    print("\nspindle, held-out validation days, internal temperatures (5) against the truth")
    print(
        f"{'scenario':<12} {'sensor':<10} {'NRMSE min':>9} {'RMSE max':>9} {'ANEES':>8}  consistent"
    )
    for sname in ("nominal", "warm start", "disturbance"):
        peer = sp[sname]["1I7O-open"]["rmse_max_K"]
        for name, r in sp[sname].items():
            print(
                f"{sname:<12} {name:<10} {100 * r['nrmse_min']:8.2f}% {r['rmse_max_K']:8.3f}K "
                f"{r['nees_mean']:8.3g}  {r['consistent_runs']}/{len(r['runs'])}"
                + (
                    f"   RMSE ratio to 1I7O-open {r['rmse_max_K'] / peer:.2f}"
                    if name != "1I7O-open"
                    else ""
                )
            )
    ax = axt211(args.quick)
    print("\nAXT211, T_P from stroke and PTC power, filters started 15 K off (errors after 10 min)")
    print(
        f"  {'run':<42} {'UKF nom':>8} {'UKF fit':>8} {'+params':>8} {'mod.err':>8} "
        f"{'open nom':>8} {'open fit':>8} {'thermoc.':>8}  [RMSE K]"
    )
    for rid, r in ax.items():
        cols = [
            r[k]["rmse_K"]
            for k in (
                "UKF nominal",
                "UKF fitted",
                "UKF fitted+T_P0,kP_b",
                "UKF fitted, model-error noise",
            )
        ]
        cols += [r["open_loop_nominal_rmse_K"], r["open_loop_fitted_rmse_K"]]
        cols += [r["thermocouple_rmse_K"]]
        print(f"  {rid:<42} " + " ".join(f"{c:8.3f}" for c in cols))
    best = sp["nominal"]["1I7O-KF"]
    figures = {
        "spindle_nrmse_min_1i7o_kf": best["nrmse_min"],
        "spindle_rmse_max_K_1i7o_kf": best["rmse_max_K"],
        "spindle_nees_mean_1i7o_kf": best["nees_mean"],
        "spindle_rmse_max_K_1i7o_open": sp["nominal"]["1I7O-open"]["rmse_max_K"],
        "spindle_rtd_rmse_K": best["rtd_rmse_K"],
        "axt211_rmse_K_max": max(r["UKF fitted, model-error noise"]["rmse_K"] for r in ax.values()),
        "axt211_rmse_K_median_sensor_noise": float(
            np.median([r["UKF fitted"]["rmse_K"] for r in ax.values()])
        ),
        "axt211_rmse_K_median": float(
            np.median([r["UKF fitted, model-error noise"]["rmse_K"] for r in ax.values()])
        ),
        "axt211_open_loop_fitted_rmse_K_median": float(
            np.median([r["open_loop_fitted_rmse_K"] for r in ax.values()])
        ),
        "axt211_thermocouple_rmse_K_median": float(
            np.median([r["thermocouple_rmse_K"] for r in ax.values()])
        ),
    }
    result = {"figures": figures, "spindle": sp, "axt211": ax, "load": list(load)}
    print(f"\ntotal {time.perf_counter() - t0:.0f} s")
    if args.json:
        atomic_write_text(args.json, json.dumps(result, indent=2, default=float) + "\n")
        print(f"wrote {args.json}")


if __name__ == "__main__":
    main()
