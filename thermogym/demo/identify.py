"""Stage 2: prepare the recordings and identify the models; FitResults to ``fits/``.

* spindle (paper 001): raw asynchronous days → Hampel outliers, range limits,
  1 Hz grid, gaps, alignment, ambient subtraction (reported) → N4SID order by
  2-fold cross-validation → the model of the chosen order, validated on a day
  at another speed;
* strut (paper 000): FOPTD set by least squares with delay search (Table 1),
  and the 19-node RC network's 5 ratio parameters by Monte Carlo (Table 2);
* AXT211 (paper 002): grey-box identification submodel by submodel (PTC by
  linear least squares, thermodynamics and mechanics by Gauss-Newton), ξ on
  the held-out tests and the parameters against the rig's true ones.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from thermogym.demo.core import DemoContext, StageResult, StageSkipped, Table
from thermogym.demo.rigs import axt211_specimen
from thermogym.fitresult import load_fit
from thermogym.identification.coordinator import run_identification
from thermogym.identification.foptd import fit_foptd
from thermogym.identification.greybox_axt211 import _SPEC, MECHANICAL, THERMAL, identify_axt211
from thermogym.identification.linear_plots import plot_order_cv
from thermogym.identification.metrics import fit_text
from thermogym.identification.n4sid import n4sid
from thermogym.identification.prepare import prepare
from thermogym.models.registry import get_model
from thermogym.plotting import plot_recordings
from thermogym.rigs import get_rig
from thermogym.studies.axt211 import rig_equivalents
from thermogym.studies.spindle import OUTPUTS as SPINDLE_OUTPUTS
from thermogym.studies.spindle import PREPARE, SpindleData, table5
from thermogym.studies.strut import OUTPUTS as STRUT_OUTPUTS
from thermogym.studies.strut import StrutStudyConfig, run_strut_study, strut_problem

__all__ = ["load_identify", "save_fit", "stage_identify"]


def save_fit(ctx: DemoContext, fit: Any, name: str) -> str:
    """Write a FitResult to ``fits/<name>.json`` (staged); its final relative path."""
    p = ctx.path("fits", f"{name}.json")
    fit.save(p)
    ctx.products.setdefault("fit_paths", {})[name] = ctx.final(p)
    return ctx.rel(p)


def _mean(d: Any, key: str = "mnrmse") -> float:
    """MNRMSE of a FitResult metrics block (its own, or the mean over its experiments)."""
    if not isinstance(d, dict):
        return math.nan
    v = d.get(key)
    if isinstance(v, int | float):
        return float(v)
    sub = d.get("experiments", d)
    vals = [
        float(e[key])
        for e in sub.values()
        if isinstance(e, dict) and isinstance(e.get(key), int | float)
    ]
    return float(np.mean(vals)) if vals else math.nan


def _prepare_spindle(ctx: DemoContext, recs: dict[str, list[Any]]) -> tuple[Any, list[Any]]:
    """The raw spindle days prepared (paper 001 section 2.3.1), and a table row per day."""
    t0 = time.perf_counter()
    runs: dict[tuple[int, int], Any] = {}
    validation: dict[int, Any] = {}
    prep_rows = []
    raw_all = [*recs["spindle/run-in"], *recs["spindle/validation"]]
    for raw in ctx.bar(raw_all, "spindle preparation"):
        p = prepare(raw, PREPARE)
        steps = {s["step"]: s for s in p.meta["preparation"]["steps"]}
        prep_rows.append(
            [
                raw.experiment_id,
                raw.n_samples,
                steps.get("remove_outliers", {}).get("total_removed", 0),
                steps.get("fill_gaps", {}).get("total_filled", 0),
                p.n_samples,
                f"{steps.get('subtract_ambient', {}).get('ambient_mean', math.nan):.2f}",
            ]
        )
        speed = int(raw.meta["speed_rpm"])
        if "fold" in raw.meta:
            runs[(speed, int(raw.meta["fold"]))] = p
        else:
            validation[speed] = p
    data = SpindleData(runs, validation, {"prepare": time.perf_counter() - t0}, 0)
    return data, prep_rows


def _spindle(ctx: DemoContext, res: StageResult, recs: dict[str, list[Any]]) -> None:
    data, prep_rows = _prepare_spindle(ctx, recs)
    ctx.products["spindle_data"] = data
    res.table(
        [
            "day",
            "raw rows",
            "outliers removed",
            "gap samples filled",
            "1 Hz samples",
            "mean T_amb [°C]",
        ],
        prep_rows,
        "Spindle data preparation (paper 001 section 2.3.1); temperatures become rises above "
        "the ambient",
    )
    orders = range(1, 9) if ctx.quick else range(1, 16)
    cv = table5(data, orders=orders, input_set="speed+ambient")
    cv_rows = []
    for speed, c in cv.items():
        cv_rows.append(
            [
                speed,
                c.best_order,
                c.parsimonious_order,
                float(c.ta[list(c.orders).index(c.parsimonious_order)]),
                float(c.va[list(c.orders).index(c.parsimonious_order)]),
            ]
        )
    res.table(
        ["speed [rpm]", "best order", "chosen order (within 0.1 % of best VA)", "TA", "VA"],
        cv_rows,
        f"N4SID order by 2-fold cross-validation (paper 001 Table 5, eqs 7-10), orders "
        f"{orders.start}-{orders.stop - 1}; inputs speed and ambient",
    )
    train_speed = 6000 if 6000 in cv else next(iter(cv))
    c = cv[train_speed]
    p = plot_order_cv(
        c,
        ctx.path("figures", "identify_spindle_order_cv.png"),
        title=f"spindle {train_speed} rpm: training and validation accuracy per order",
    )
    res.figure(ctx.rel(p), "N4SID order cross-validation: TA and VA per order (paper 001 Fig. 15)")
    order = int(c.parsimonious_order)
    vals = [data.validation[s] for s in sorted(data.validation)]
    fit = n4sid(
        data.fold(train_speed, 1),
        ["speed", "T_amb"],
        list(SPINDLE_OUTPUTS),
        order,
        disturbances=["T_amb"],
        feedthrough=True,
        validate=[data.fold(train_speed, 2), *vals],
    ).fit
    fit.notes += "; thermogym demo: order chosen by 2-fold cross-validation"
    rel = save_fit(ctx, fit, "spindle_n4sid")
    ctx.products["fit_spindle_n4sid"] = fit
    va = _mean(fit.metrics.get("validation"))
    res.highlights["spindle N4SID"] = (
        f"order {order} by cross-validation, held-out mean fit {fit_text(va)} (`{rel}`)"
    )
    ctx.products.setdefault("fit_rows", []).append(
        ["spindle", "N4SID (order by CV)", order, _mean(fit.metrics.get("train")), va, f"`{rel}`"]
    )


def _strut(ctx: DemoContext, res: StageResult, recs: dict[str, list[Any]]) -> None:
    strut = recs["strut/steps"]
    train, val = strut[:1], strut[1:]
    fo = fit_foptd(train, ["feed_rate"], list(STRUT_OUTPUTS), max_delay_s=1800.0, validate=val)
    rel = save_fit(ctx, fo.fit, "strut_foptd")
    ctx.products["fit_strut_foptd"] = fo.fit
    ctx.products.setdefault("fit_rows", []).append(
        [
            "strut",
            "FOPTD set (least squares + delay search)",
            f"{3 * len(STRUT_OUTPUTS)} parameters",
            _mean(fo.fit.metrics.get("train")),
            _mean(fo.fit.metrics.get("validation")),
            f"`{rel}`",
        ]
    )
    res.table(
        ["output", "K [K/(m/min)]", "T [min]", "τ [min]"],
        [
            [o, float(fo.K[j, 0]), float(fo.T[j, 0]) / 60.0, float(fo.tau[j, 0]) / 60.0]
            for j, o in enumerate(STRUT_OUTPUTS)
        ],
        "Strut FOPTD set at 20 m/min (paper 000 Table 1, eqs 9-12)",
    )
    n = 500 if ctx.quick else 4000
    mc = run_identification(
        strut_problem(train),
        "montecarlo",
        n_samples=n,
        batch_size=min(n, 2000),
        seed=ctx.seed,
        progress=False,
        uncertainty=False,
        identifiability=False,
    )
    mc.validate(val)
    rel = save_fit(ctx, mc.fit, "strut_ratios")
    ctx.products["fit_strut_ratios"] = mc.fit
    ctx.products.setdefault("fit_rows", []).append(
        [
            "strut",
            f"RC network, 5 ratios (Monte Carlo, {n} sets)",
            5,
            _mean(mc.fit.metrics.get("train")),
            _mean(mc.fit.metrics.get("validation")),
            f"`{rel}`",
        ]
    )
    study = run_strut_study(
        StrutStudyConfig(seed=ctx.seed, n_samples=n, batch_size=min(n, 2000)),
        recordings=strut,
        progress=False,
    )
    feeds = study.feeds
    rows = []
    for name, c in study.criteria.items():
        rc = [(study._mean(c["rmse"][v]) if name == "all" else c["rmse"][v][name]) for v in feeds]
        fo_rmse = [
            (study._mean(study.foptd_rmse[v]) if name == "all" else study.foptd_rmse[v][name])
            for v in feeds
        ]
        rows.append([name, *[round(x, 3) for x in c["ratios"].values()], *rc, *fo_rmse])
    res.table(
        [
            "criterion",
            *list(next(iter(study.criteria.values()))["ratios"]),
            *[f"RC RMSE {v:g} [K]" for v in feeds],
            *[f"FOPTD RMSE {v:g} [K]" for v in feeds],
        ],
        rows,
        "Strut ratio parameters per criterion and RMSE at 20 (training), 25 and 30 m/min "
        "(paper 000 Table 2 against Table 1)",
    )
    res.highlights["strut ratios (Monte Carlo)"] = (
        f"{n} parameter sets in {mc.elapsed_s:.2f} s (paper 000: 60 min); held-out mean "
        f"fit {fit_text(_mean(mc.fit.metrics.get('validation')))}"
    )


def _axt211(ctx: DemoContext, res: StageResult, recs: dict[str, list[Any]]) -> None:
    steps = recs["axt211/steps"]
    train_ids = {"axt211-step-24V-25C", "axt211-step-19V-0C", "axt211-step-29V-50C"}
    train = [r for r in steps if r.experiment_id in train_ids]
    validation = [r for r in steps if r.experiment_id not in train_ids] + list(recs["axt211/pwm"])
    if ctx.quick:
        validation = validation[:2]
    full_stroke = max(train, key=lambda r: float(np.nanmax(r["x_V"])))
    truth = _axt211_truth(ctx.seed)
    # start values: nominal ± 20 % (seeded), so that the fit has something to find
    rng = np.random.default_rng(ctx.seed)
    start = {}
    for n in (*THERMAL, *MECHANICAL):
        p = _SPEC[n]
        v = p.nominal * (1.0 + 0.2 * rng.uniform(-1.0, 1.0))
        span = p.upper - p.lower
        start[n] = float(np.clip(v, p.lower + 0.01 * span, p.upper - 0.01 * span))
    gb = identify_axt211(
        train,
        [*recs["axt211/staircase"], full_stroke],
        validation,
        start=start,
        joint=False,
        mc_samples=200 if ctx.quick else 500,
        max_iter=20 if ctx.quick else 40,
        seed=ctx.seed,
        progress=False,
        truth=truth,
    )
    rel = save_fit(ctx, gb.fit, "axt211_greybox")
    ctx.products["fit_axt211"] = gb.fit
    ctx.products["axt211_truth"] = truth
    xi = gb.mean_xi(True)
    ctx.products.setdefault("fit_rows", []).append(
        [
            "AXT211",
            "grey-box ODE, submodel by submodel (paper 002)",
            len(gb.parameters),
            "– (criteria per submodel)",
            f"ξ {np.mean(list(xi.values())):.4f} (mean ξ, eq 22)",
            f"`{rel}`",
        ]
    )
    res.table(
        ["test case", "ξ PTC", "ξ thermal", "ξ mechanical"],
        [[r["test_case"], r["PTC"], r["thermal"], r["mechanical"]] for r in gb.xi]
        + [["mean (paper 002: 0.93 / 0.95 / 0.84)", xi["PTC"], xi["thermal"], xi["mechanical"]]],
        "AXT211 accuracy ξ (paper 002 eq 22) of the coupled model on held-out tests (Table II)",
    )
    rec_rows = []
    for name, d in gb.recovered.items():
        rec_rows.append(
            [
                name,
                float(start.get(name, math.nan)),
                float(d["value"]),
                f"[{d['lower']:.4g}, {d['upper']:.4g}]",
                float(d.get("truth", math.nan)),
                "yes" if d.get("inside") else "no",
            ]
        )
    res.table(
        ["parameter", "start", "fitted", "95 % interval", "rig's matching value", "inside"],
        rec_rows,
        "AXT211 parameters with a matching quantity in the rig's physics (95 % intervals); "
        "the rig's true plant is not the model, so a miss names physics a parameter absorbs",
    )
    inside = sum(1 for d in gb.recovered.values() if d.get("inside"))
    res.highlights["AXT211 grey-box"] = (
        f"mean ξ PTC {xi['PTC']:.3f}, thermal {xi['thermal']:.3f}, mechanical "
        f"{xi['mechanical']:.3f} (paper 002: 0.93 / 0.95 / 0.84); {inside}/{len(gb.recovered)} "
        "matching rig quantities inside their 95 % intervals"
    )
    # held-out test against the identified model
    m = get_model("axt211")
    theta = gb.fit.theta(m)
    case = validation[0]
    sim = m.simulate(case.exogenous_array(m), case.dt, theta)
    fig = plot_recordings(
        [case],
        ctx.path("figures", "identify_axt211_validation.png"),
        signals=["P_PTC", "T_P", "x_V"],
        overlay={"identified model": {n: sim.output(n)[0] for n in m.output_names}},
        title=f"AXT211 held-out test {case.experiment_id}: rig against the identified model",
    )
    res.figure(ctx.rel(fig), "AXT211 held-out test: the identified grey-box model on new data")


def stage_identify(ctx: DemoContext, res: StageResult) -> None:
    """Prepare the recordings and identify every model of the loop."""
    ctx.need("recordings")
    recs = ctx.products["recordings"]
    parts = [("spindle N4SID", _spindle), ("strut FOPTD + ratios", _strut)]
    parts.append(("AXT211 grey-box", _axt211))
    timings = []
    for name, fn in ctx.bar(parts, "identification"):
        t0 = time.perf_counter()
        fn(ctx, res, recs)
        timings.append(f"{name} {time.perf_counter() - t0:.1f} s")
    res.tables.insert(
        0,
        _fit_table(ctx.products.get("fit_rows", [])),
    )
    res.shows = (
        "Recordings in, FitResults out: each method of the three papers identifies its plant "
        "from the rig's data and writes a FitResult (JSON: parameters, uncertainties, metrics "
        "on training and held-out data, data fingerprints) that environments accept."
    )
    res.text = (
        "Held-out data are never used for fitting: the spindle model is checked on the other "
        "fold and a day at another speed, the strut models at 25 and 30 m/min, the AXT211 "
        "model on the step tests it was not trained on and the PWM test. Timings: "
        + "; ".join(timings)
        + ". The strut models miss the rig's own physics and its concealed effect: their "
        "held-out fit at 25 and "
        "30 m/min is the starting point of stage 3."
    )


def _fit_table(rows: list[list[Any]]) -> Any:
    def cell(v: Any) -> Any:  # a fit (fraction) in percent, as every command shows it
        return fit_text(v) if isinstance(v, float) else v

    return Table(
        [
            "plant",
            "model / method",
            "order / parameters",
            "train fit",
            "held-out fit",
            "file",
        ],
        [[*r[:3], cell(r[3]), cell(r[4]), *r[5:]] for r in rows],
        "FitResults written (fit: mean NRMSE fit of paper 001 eq 6 in %, 100 % = perfect)",
    )


#: FitResult file (under ``fits/``) -> product of the identification stage.
_FIT_PRODUCTS = {
    "spindle_n4sid": "fit_spindle_n4sid",
    "strut_foptd": "fit_strut_foptd",
    "strut_ratios": "fit_strut_ratios",
    "axt211_greybox": "fit_axt211",
}


def _axt211_truth(seed: int) -> dict[str, float]:
    """The demo's AXT211 specimen's values of the model parameters that have a physical match.

    The rig's true plant is not the model (:func:`thermogym.studies.axt211.rig_equivalents`).
    """
    return rig_equivalents(get_rig("axt211").with_specimen(axt211_specimen(seed)[1]))


def load_identify(ctx: DemoContext) -> None:
    """Products of an earlier identification in ``ctx.out``: FitResults, prepared spindle data.

    The prepared spindle days are rebuilt from the recordings only when a stage
    needs them (``spindle_data``).
    """
    found = False
    for name, key in _FIT_PRODUCTS.items():
        p = ctx.out / "fits" / f"{name}.json"
        if p.is_file():
            ctx.products[key] = load_fit(p)
            ctx.products.setdefault("fit_paths", {})[name] = p
            found = True
    if not found:
        raise StageSkipped(f"no earlier FitResults in {str(ctx.out / 'fits')!r}")
    ctx.products["axt211_truth"] = _axt211_truth(ctx.seed)

    def spindle_data() -> Any:
        ctx.need("recordings")
        return _prepare_spindle(ctx, ctx.products["recordings"])[0]

    ctx.lazy["spindle_data"] = spindle_data
