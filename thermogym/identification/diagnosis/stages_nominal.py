"""The stages of :func:`.run.diagnose` that prepare the data and test the nominal model.

``nominal`` (resolve the model, prepare the recordings, re-calibrate the identifiable
parameters), ``baseline`` (a plain ARX the nominal model must not lose to),
``detection`` (residual tests and materiality; the scoring scheme), ``location``
(noise levels, outputs, windows and regimes carrying the error) and ``parameters``
(the given parameters against the re-calibrated ones on held-out data).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from thermogym.errors import ConfigError, RecordingError, UnknownNameError
from thermogym.fitresult import FitResult, load_fit
from thermogym.identification.diagnosis.effects import CATALOGUE
from thermogym.identification.diagnosis.experiments import (
    AUTO_SHARE,
    Experiment,
    auto_period,
    prepare_experiments,
)
from thermogym.identification.diagnosis.fit import FitProblem, output_weights
from thermogym.identification.diagnosis.hypothesis import Hypothesis, NominalSpec
from thermogym.identification.diagnosis.identify import intervals
from thermogym.identification.diagnosis.locate import locate, regime_variables
from thermogym.identification.diagnosis.nominal import (
    arx_baseline,
    calibrate,
    calibration_set,
    generic_bounds,
    generic_start,
    resolve_model,
)
from thermogym.identification.diagnosis.run_state import _deadline, _need, _Run
from thermogym.identification.diagnosis.scoring import delta_ic, whitened_chi2
from thermogym.identification.diagnosis.select import (
    Data,
    fit_hypothesis,
    nrmse_table,
    residuals_of,
    score_self,
)
from thermogym.identification.metrics import fit_text
from thermogym.identification.residuals import ResidualTest, noise_sigma, residual_tests
from thermogym.models.augmented import AugmentedModel
from thermogym.models.base import Model
from thermogym.recording import Recording

_MIN_SAMPLES = 10
#: How much better (mean held-out NRMSE fit, 0.01 = one per cent of the outputs' variation)
#: the plain ARX baseline must predict before the nominal model is called inadequate: a
#: tie within a few thousandths (0.993 against 0.992) is coloured noise, not a verdict.
INADEQUATE_MARGIN = 0.01


# ------------------------------------------------------------------ stage: nominal
def _check_inputs(st: _Run) -> None:
    o = st.opts
    model = o["model"]
    generic = isinstance(model, str) and model.partition(":")[0] in ("foptd", "ss")
    if generic and o["params"] is not None:
        _fit_columns(o, model.partition(":")[0])
    nominal, spec = resolve_model(
        model,
        st.tr_list[0],
        model_config=o["model_config"],
        inputs=o["inputs"],
        outputs=o["outputs"],
    )
    st.generic = isinstance(model, str) and model.partition(":")[0] in ("foptd", "ss")
    for i, r in enumerate([*st.tr_list, *st.va_list]):
        if not isinstance(r, Recording):
            raise RecordingError(
                f"item {i} of the recordings is a {type(r).__name__}; expected a Recording "
                "(read files with thermogym.recording.read_recording)"
            )
        r.validate_for(nominal, outputs=False)  # names the columns a recording of this model needs
    outputs = o["outputs"]
    if outputs and not st.generic:
        bad = [x for x in outputs if x not in nominal.output_names]
        if bad:
            raise UnknownNameError(
                f"{bad} are not outputs of model {nominal.name!r}; outputs are "
                f"{list(nominal.output_names)}"
            )
    outs = [x for x in (outputs or nominal.output_names) if x in nominal.output_names]
    if not outputs:
        outs = [
            x for x in nominal.output_names if all(x in r.columns for r in st.tr_list + st.va_list)
        ]
        left = [x for x in nominal.output_names if x not in outs]
        if outs and left and not st.generic:
            st.notes.append(
                f"output(s) {left} of model {nominal.name!r} are not columns of every recording "
                f"and are left out; the diagnosis compares {outs} (name them with outputs=..., "
                "--outputs)"
            )
    if not outs:
        raise RecordingError(
            f"the recordings hold none of the outputs of model {nominal.name!r} "
            f"({list(nominal.output_names)}); columns are {list(st.tr_list[0].columns)}: are they "
            "recordings of another plant?"
        )
    for r in st.va_list:  # the same data on both sides: its scores are not held out
        for twin in (q for q in st.tr_list if _same_data(q, r)):
            st.notes.append(
                f"validation recording {r.experiment_id!r} holds the same data as training "
                f"recording {twin.experiment_id!r}: its held-out scores are training scores "
                "(give recordings not used for training)"
            )
    for role, recs in (("training", st.tr_list), ("validation", st.va_list)):
        # an output column left empty throughout (a sensor that was off)
        empty = [x for x in outs if not any(np.isfinite(r[x]).any() for r in recs if x in r)]
        if empty:
            raise RecordingError(
                f"output(s) {empty} hold no finite sample in any {role} recording "
                f"({[r.experiment_id for r in recs]}); expected measurements to compare: give "
                "--outputs without them, or recordings that measured them"
            )
    if st.generic and o["params"] is None:
        # operating point: the training data's mean exogenous values (model column order)
        us = [r.exogenous_array(nominal) for r in st.tr_list]
        u = np.concatenate(us)
        spec.base_config["u_op"] = np.nanmean(u, axis=0).tolist()
        if all(_constant(x) for x in us):
            # every input holds one value through every training recording (a step test logged
            # from the step on): with the initial state free, the input's effect cannot be told
            # from the state the recording starts in. Its only evidence is the step from zero at
            # the start, so the recordings are taken to start at rest with the inputs off before
            spec.base_config["u_op"] = [0.0] * u.shape[1]
            if "steady_start" in spec.base_config:
                spec.base_config["steady_start"] = False
            if o.get("x0", "auto") == "auto":  # an explicit x0 is kept as given
                st.x0 = "rest"
                st.notes.append(
                    "every input is constant within every training recording: the recordings "
                    "are taken to start at rest with the inputs at zero before their start (the "
                    "initial state is not estimated; give training recordings in which the "
                    "inputs change to have it estimated)"
                )
        nominal = spec.build()
    st.model, st.spec, st.outs = nominal, spec, outs


def _same_data(a: Recording, b: Recording) -> bool:
    """Whether two recordings hold the same samples (units, ids and metadata aside)."""
    return (
        a.n_samples == b.n_samples
        and set(a.columns) == set(b.columns)
        and np.array_equal(a.time, b.time)
        and all(np.array_equal(a[c], b[c], equal_nan=True) for c in a.columns)
    )


def _fit_columns(o: dict[str, Any], name: str) -> None:
    """Take the columns of a given generic FitResult (``params``) into ``o``.

    Its fitted model reads its exogenous columns in its own order: ``inputs``, when
    given, must name exactly those (they are put in the FitResult's order), and
    ``outputs`` only its outputs.

    Parameters
    ----------
    o : dict
        The run's options (``params``, ``inputs``, ``outputs``); updated in place.
    name : str
        The generic model diagnosed (``"foptd"`` or ``"ss"``). A FitResult of another
        model only fills the columns not given; :func:`_given` refuses it.

    Raises
    ------
    ConfigError
        ``inputs`` other than the FitResult's exogenous columns, or an output it lacks;
        the message names both.
    """
    fit = load_fit(o["params"])
    cfg = fit.model_config
    base = cfg.get("base") if fit.model == "augmented" else fit.model
    cfg = cfg.get("base_config", cfg) if "base" in cfg else cfg
    exo = [*cfg.get("inputs", []), *cfg.get("disturbances", [])]
    outs = list(cfg.get("outputs", []))
    if base != name:  # another model's FitResult: _given refuses it, naming both models
        o["inputs"] = o["inputs"] or exo
        o["outputs"] = o["outputs"] or outs
        return
    if o["inputs"] and sorted(o["inputs"]) != sorted(exo):
        raise ConfigError(
            f"inputs {list(o['inputs'])} (--inputs) are not the exogenous columns of the "
            f"FitResult (params, --params), {exo}; a fitted model reads exactly its own: give "
            "those, or leave out inputs (--inputs) to take them from the FitResult"
        )
    bad = [c for c in o["outputs"] or () if c not in outs]
    if bad:
        raise ConfigError(
            f"output(s) {bad} (--outputs) are not outputs of the FitResult (params, --params), "
            f"whose outputs are {outs}; name some of those, or leave out outputs (--outputs)"
        )
    o["inputs"] = exo  # in the FitResult's order: the recordings' input columns follow it
    o["outputs"] = o["outputs"] or outs


def _beyond_training(
    names: Sequence[str], tr: Sequence[Experiment], va: Sequence[Experiment]
) -> list[str]:
    """Notes on inputs the held-out recordings take beyond the training range (extrapolation).

    Beyond by more than 10 % of the training span at either end: what the held-out data
    show there, the training data could not have taught any hypothesis.
    """
    out = []
    for i, name in enumerate(names):
        a = np.concatenate([e.u[:, i] for e in tr])
        b = np.concatenate([e.u[:, i] for e in va])
        a, b = a[np.isfinite(a)], b[np.isfinite(b)]
        if not (a.size and b.size):
            continue
        lo, hi = float(a.min()), float(a.max())
        span = hi - lo
        if span <= 0:
            continue
        blo, bhi = float(b.min()), float(b.max())
        if bhi > hi + 0.1 * span or blo < lo - 0.1 * span:
            out.append(
                f"the held-out recordings take {name} to {blo:.4g}..{bhi:.4g}, beyond its "
                f"training range {lo:.4g}..{hi:.4g}: a mismatch there may be extrapolation "
                "the training data could not teach any hypothesis (train over the whole range)"
            )
    return out


def _constant(u: NDArray[np.float64]) -> bool:
    """Whether every column of ``u`` (T, n) holds one value (NaN samples ignored)."""
    if u.size == 0:
        return False
    lo, hi = np.nanmin(u, axis=0), np.nanmax(u, axis=0)
    return bool(np.all(hi - lo <= 1e-9 * np.maximum(1.0, np.abs(hi))))


def _stage_nominal(st: _Run) -> None:
    _check_inputs(st)
    o = st.opts
    model, spec, outs = st.model, st.spec, st.outs
    assert model is not None and spec is not None
    st.say(f"model {spec.name}: outputs {outs}")
    st.tr = prepare_experiments(model, st.tr_list, outs, dt=o["dt"], what="training")
    st.va = prepare_experiments(model, st.va_list, outs, dt=o["dt"], what="validation")
    for e in [*st.tr, *st.va]:
        if e.n < _MIN_SAMPLES:
            raise RecordingError(
                f"recording {e.name!r} has {e.n} samples; diagnosis needs at least "
                f"{_MIN_SAMPLES} per recording (too short to fit or validate)"
            )
    st.notes += [n for e in st.tr + st.va for n in e.notes]
    st.notes += _beyond_training(list(model.exogenous_names), st.tr, st.va)
    weights = output_weights(st.tr)
    st.weights = weights
    # ---- the given parameters
    given = model.nominal.copy()
    fixed: set[str] = set()
    if o["params"] is not None:
        given, fixed, model, spec = _given(o["params"], model, spec, st)
        st.model, st.spec = model, spec
        st.method = "given, re-calibrated"
    elif st.generic:
        given = generic_start(model, st.tr)
        st.method = "identified (generic model)"
    else:
        st.method = "design values, re-calibrated"
    st.given_fixed = fixed
    if o["dt"] is None and (step := auto_period(model, given, [*st.tr, *st.va], outs)):
        # long recordings: the search runs on a grid the model's dynamics still resolve
        dt_new, t_half = step
        n_all = sum(e.n for e in [*st.tr, *st.va])
        st.tr = prepare_experiments(model, st.tr_list, outs, dt=dt_new, what="training")
        st.va = prepare_experiments(model, st.va_list, outs, dt=dt_new, what="validation")
        o["dt"] = dt_new
        st.weights = weights = output_weights(st.tr)
        if st.generic:
            given = generic_start(model, st.tr)
        msg = (
            f"the recordings hold {n_all} samples: averaged onto a {dt_new:g} s grid for the "
            f"search ({100 * AUTO_SHARE:g} % of the model's fastest half-response, "
            f"{t_half:.4g} s; effects faster than the grid cannot be seen: give dt equal "
            "to the recordings' period to keep it, at a higher cost)"
        )
        st.say(msg)
        st.notes.append(msg)
    cands = [p for p in model.param_names if p not in fixed]
    if st.generic:
        lo, hi = generic_bounds(model, cands, given, st.tr)
    else:
        idx = [model.param_index(p) for p in cands]
        lo, hi = model.lower[idx].copy(), model.upper[idx].copy()
        # a given value outside the declared range widens it (the FitResult's own bounds)
        g = given[idx]
        lo, hi = np.minimum(lo, g), np.maximum(hi, g)
    given[[model.param_index(p) for p in cands]] = np.clip(
        given[[model.param_index(p) for p in cands]], lo, hi
    )
    st.bounds = {p: (float(a), float(b)) for p, a, b in zip(cands, lo, hi, strict=True)}
    st.given = given.copy()
    n_obs = sum(e.n * len(outs) for e in st.tr)
    # ---- which parameters the training data identify
    table: dict[str, Any]
    if st.generic:
        sel, table = list(cands), {}
    else:
        sel, table = calibration_set(model, given, cands, lo, hi, st.tr, weights, st.x0)
    if n_obs < 5 * max(len(sel), 1):
        raise RecordingError(
            f"the training recordings hold {n_obs} output samples for {len(sel)} parameters; "
            "too short to fit the nominal model (need at least 5 per parameter)"
        )
    st.calibrated, st.idf_table = sel, table
    st.say(f"re-calibrating {len(sel)} identifiable parameter(s) of {len(cands)}: {sel}")
    sel_lo = np.array([st.bounds[p][0] for p in sel])
    sel_hi = np.array([st.bounds[p][1] for p in sel])
    deadline = _deadline(st)
    out = calibrate(
        model,
        given,
        sel,
        sel_lo,
        sel_hi,
        st.tr,
        weights,
        st.x0,
        n_random=6 if not st.generic else 4,
        max_nfev=max(o["max_nfev"], 60) if not st.generic else 150,
        deadline=deadline,
    )
    h = Hypothesis(
        candidates=(),
        model=model,
        free=tuple(sel),
        bounds={p: st.bounds[p] for p in sel},
        theta=out.theta.copy(),
        outcome=out,
    )
    pb = FitProblem(model, (), out.theta, np.zeros(0), np.zeros(0), st.tr, weights, st.x0)
    h.sims_train = [pb.simulate(np.zeros((1, 0)), i)[0] for i in range(len(st.tr))]
    pv = FitProblem(model, (), out.theta, np.zeros(0), np.zeros(0), st.va, weights, st.x0)
    h.sims_val = [pv.simulate(np.zeros((1, 0)), i)[0] for i in range(len(st.va))]
    st.nominal = h


def _given(
    params: FitResult | str | Mapping[str, Any], model: Model, spec: NominalSpec, st: _Run
) -> tuple[NDArray[np.float64], set[str], Model, NominalSpec]:
    """Parameters of a given FitResult, in the nominal model (its operating point kept)."""
    fit = load_fit(params)
    built = fit.build_model()
    name = spec.name.split(":")[0]
    if fit.model == model.name or (fit.model == "augmented" and model.name == "augmented"):
        theta = fit.theta(built)[0]
        return (
            np.asarray(theta, dtype=float),
            {p for p in fit.fixed if p in built.param_names},
            built,
            _spec_of(built, spec),
        )
    if name in ("ss", "foptd") and fit.model == name:
        # a FitResult of the generic model itself: wrapped with the diagnosis' output offsets
        order = spec.name.partition(":")[2]
        n_fit = fit.model_config.get("n_states")
        if name == "ss" and order and n_fit is not None and int(order) != int(n_fit):
            raise ConfigError(
                f"the FitResult (params, --params) is of model 'ss' with {n_fit} states; the "
                f"diagnosed model is {spec.name!r}: give --model ss:{n_fit}, or leave out "
                f"params (--params) to fit {spec.name!r} here"
            )
        new_spec = NominalSpec(name, dict(fit.model_config), list(spec.augmentations), spec.name)
        m = new_spec.build()
        th = m.nominal.copy()
        for p, v in zip(built.param_names, fit.theta(built)[0], strict=True):
            th[m.param_index(p)] = v
        for p in m.param_names:
            if p.startswith("offset_"):
                th[m.param_index(p)] = 0.0  # the FitResult's y_op carries the level
        return th, {p for p in fit.fixed if p in built.param_names}, m, new_spec
    raise ConfigError(
        f"the FitResult (params, --params) is for model {fit.model!r}, not for the diagnosed "
        f"model {spec.name!r}; give a FitResult of {spec.name!r}, the augmented FitResult "
        f"(--augmented-fit) of an earlier diagnosis of {spec.name!r}, or leave out params "
        "(--params) to fit it here"
    )


def _spec_of(model: Model, spec: NominalSpec) -> NominalSpec:
    if isinstance(model, AugmentedModel):
        cfg = model.config()
        return NominalSpec(cfg["base"], cfg["base_config"], cfg["augmentations"], spec.name)
    return NominalSpec(model.name, model.config(), [], spec.name) if spec.registered else spec


# ------------------------------------------------------------------ stage: baseline
def _stage_baseline(st: _Run) -> None:
    try:
        arx = arx_baseline(st.tr, st.va)
    except Exception as e:  # a baseline that cannot be fitted is said, not fatal
        st.arx = {"error": f"{type(e).__name__}: {e}"}
        return
    fit = nrmse_table(st.outs, [e.y for e in st.va], arx["sims"])
    nom = nrmse_table(st.outs, [e.y for e in st.va], _need(st.nominal, "nominal fit").sims_val)
    st.arx = {
        "model": "ARX(2, 2), one intercept, per output (least squares, simulated)",
        "n_params": arx["n_params"],
        "validation": fit,
        "nominal_validation": nom,
        "nominal_adequate": not (
            fit.get("mean", -math.inf) > nom.get("mean", math.nan) + INADEQUATE_MARGIN
        ),
        "sims": arx["sims"],
    }
    if not st.arx["nominal_adequate"]:
        st.say(
            f"nominal model inadequate: held-out mean fit {fit_text(nom['mean'])} against a "
            f"plain ARX's {fit_text(fit['mean'])}"
        )


# ------------------------------------------------------------------ stage: detection
def _tests(
    outputs: Sequence[str],
    exps: Sequence[Experiment],
    sims: Sequence[NDArray[np.float64]],
    alpha: float,
    max_lag: int,
    inputs: Sequence[str],
) -> dict[str, ResidualTest]:
    out = {}
    for j, o in enumerate(outputs):
        res = [e.y[:, j] - s[:, j] for e, s in zip(exps, sims, strict=True)]
        ins = [{c: e.u[:, i] for i, c in enumerate(inputs)} for e in exps]
        out[o] = residual_tests(
            res, ins, signal=o, measured=[e.y[:, j] for e in exps], max_lag=max_lag, alpha=alpha
        )
    return out


def _significant(t: ResidualTest, alpha_adj: float, min_snr: float, min_rel: float) -> bool:
    stat = t.p_white < alpha_adj or any(p < alpha_adj for p in t.p_independent.values())
    return bool(stat and t.material(min_snr, min_rel))


def _stage_detection(st: _Run) -> None:
    o = st.opts
    h = _need(st.nominal, "nominal fit")
    exo = list(_need(st.model, "model").exogenous_names)
    tests_tr = _tests(st.outs, st.tr, h.sims_train, o["alpha"], o["max_lag"], exo)
    tests_va = _tests(st.outs, st.va, h.sims_val, o["alpha"], o["max_lag"], exo)
    alpha_adj = o["alpha"] / (len(st.outs) * (1 + len(exo)))
    sig_tr = {
        x: _significant(t, alpha_adj, o["min_snr"], o["min_rel"]) for x, t in tests_tr.items()
    }
    sig_va = {
        x: _significant(t, alpha_adj, o["min_snr"], o["min_rel"]) for x, t in tests_va.items()
    }
    st.detected = any(sig_tr.values()) or any(sig_va.values())
    st.train_material = any(sig_tr.values())
    st.tests = {
        "train": tests_tr,
        "validation": tests_va,
        "sig_tr": sig_tr,
        "sig_va": sig_va,
        "alpha_adj": alpha_adj,
    }
    use = o["scheme"]
    if use == "auto":
        use = "crossfit" if (st.detected and not st.train_material and len(st.va) >= 2) else "split"
    if use == "crossfit" and len(st.va) < 2:
        raise ConfigError("scheme 'crossfit' needs at least two validation recordings")
    deadline = _deadline(st)
    data = Data(
        st.tr,
        st.va,
        _need(st.weights, "output weights"),
        st.x0,
        o["alpha"],
        use,
        o["max_nfev"],
        deadline,
        st.say,
    )
    st.data = data
    # the nominal's own scores (the reference of every comparison)
    score_self(h, data)
    if use == "crossfit":
        # the nominal's held-out predictions from the folds, like every hypothesis'
        ref = fit_hypothesis(_need(st.spec, "nominal spec"), h, None, data, h)
        if ref.ok:
            h.sims_val = ref.sims_val
            score_self(h, data)
    st.say(
        "mismatch: "
        + (
            ", ".join(x for x in st.outs if sig_tr[x] or sig_va[x])
            if st.detected
            else "none significant"
        )
    )


# ------------------------------------------------------------------ stage: location
def _stage_location(st: _Run) -> None:
    h = _need(st.nominal, "nominal fit")
    model = _need(st.model, "model")
    weights = _need(st.weights, "output weights")
    all_exps = [*st.tr, *st.va]
    roles = ["train"] * len(st.tr) + ["validation"] * len(st.va)
    all_sims = [*h.sims_train, *h.sims_val]
    units = {s.name: s.unit for s in model.signals}
    exo = list(model.exogenous_names)
    sigma = {}
    for j, o in enumerate(st.outs):
        vals = [noise_sigma(e.y[:, j] - s[:, j]) for e, s in zip(all_exps, all_sims, strict=True)]
        vals = [v for v in vals if math.isfinite(v)]
        sigma[o] = float(np.sqrt(np.mean(np.square(vals)))) if vals else math.nan
    st.sigma = sigma
    if st.data is not None:
        st.data.noise = np.array([sigma[o] for o in st.outs], dtype=float)
        st.data.min_snr = float(st.opts["min_snr"])
    scale = {o: 1.0 / float(weights[j]) for j, o in enumerate(st.outs)}
    st.regs = regime_variables(
        [e.name for e in all_exps],
        roles,
        units,
        [(c, [e.u[:, i] for e in all_exps]) for i, c in enumerate(exo)],
        [(o, [s[:, j] for s in all_sims]) for j, o in enumerate(st.outs)],
        [e.dt for e in all_exps],
        [e.time for e in all_exps],
    )
    recs_loc = [
        {
            "name": e.name,
            "role": r,
            "time": e.time,
            "dt": e.dt,
            "residual": e.y - s,
            "measured": e.y,
        }
        for e, r, s in zip(all_exps, roles, all_sims, strict=True)
    ]
    st.located = locate(st.outs, recs_loc, st.regs, sigma, scale)
    floor = sum(
        float(weights[j] ** 2)
        * sigma[o] ** 2
        * sum(int(np.isfinite(e.y[:, j]).sum()) for e in st.va)
        for j, o in enumerate(st.outs)
        if math.isfinite(sigma[o])
    )
    h.baseline = {"noise_floor": floor}


# ------------------------------------------------------------------ stage: parameters
def _stage_parameters(st: _Run) -> None:
    """Parameter or physics: whether the given parameters were off."""
    h = _need(st.nominal, "nominal fit")
    if st.generic or not st.calibrated:
        st.parameters = {
            "tested": False,
            "reason": "a generic model has no given parameters"
            if st.generic
            else "no identifiable parameter",
        }
        return
    model = _need(st.model, "model")
    given = _need(st.given, "given parameters")
    weights = _need(st.weights, "output weights")
    data = _need(st.data, "scoring data")
    theta = _need(h.theta, "nominal fit's values")
    g = Hypothesis(candidates=(), model=model, theta=given.copy())
    pb = FitProblem(model, (), given, np.zeros(0), np.zeros(0), st.tr, weights, st.x0)
    g.sims_train = [pb.simulate(np.zeros((1, 0)), i)[0] for i in range(len(st.tr))]
    pv = FitProblem(model, (), given, np.zeros(0), np.zeros(0), st.va, weights, st.x0)
    g.sims_val = [pv.simulate(np.zeros((1, 0)), i)[0] for i in range(len(st.va))]
    score_self(g, data)
    st.given_h = g
    # the calibrated model against the given one: k re-calibrated parameters
    chi2, n = whitened_chi2(residuals_of(g, data)[1], residuals_of(h, data)[1])
    d = delta_ic(chi2, len(st.calibrated), n)
    better = bool(d < 0 and h.wsse_val < g.wsse_val)
    iv = intervals(
        h,
        st.calibrated,
        st.tr,
        weights,
        st.x0,
        experiment={p: CATALOGUE["parameter_error"].experiment(p) for p in st.calibrated},
    )
    moved = {}
    for p in st.calibrated:
        v0 = float(given[model.param_index(p)])
        v1 = float(theta[model.param_index(p)])
        spec_p = model.parameters[model.param_index(p)]
        row = {
            "given": v0,
            "calibrated": v1,
            "value": v1,
            "unit": spec_p.unit,
            "description": spec_p.description,
            **iv.get(p, {}),
        }
        lo_, hi_ = row.get("low", math.nan), row.get("high", math.nan)
        row["moved"] = bool(math.isfinite(lo_) and not (lo_ <= v0 <= hi_))
        moved[p] = row
    h.intervals.update(iv)
    outs = st.outs
    st.parameters = {
        "tested": True,
        "delta_ic": d,
        "chi2_heldout": chi2,
        "significant": better,
        "parameters": moved,
        "moved": [p for p, r in moved.items() if r["moved"]],
        "validation_given": nrmse_table(outs, [e.y for e in st.va], g.sims_val),
        "validation_calibrated": nrmse_table(outs, [e.y for e in st.va], h.sims_val),
        "identifiability": st.idf_table,
    }
    verdict = "explains part of the mismatch" if better else "changes nothing significant"
    st.say(f"parameters: re-calibration {verdict} (held-out ΔIC {d:.1f})")
