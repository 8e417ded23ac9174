"""``diagnose``: a pipeline of named stages from a nominal model to the physics it misses.

::

    nominal          resolve the model; estimate every recording's initial state; rank the
                     parameters by identifiability; re-calibrate the identifiable ones from
                     their given values and from points drawn in their bounds (nominal.py)
    baseline         a plain second-order ARX on the same training data; a nominal model
                     worse than it on held-out data is reported inadequate first
    detection        residual whiteness / input-independence tests and materiality, per
                     output, on training and held-out data (residuals.py); the AR noise
                     model every later comparison uses (scoring.py)
    location         outputs, time windows, operating regimes carrying the error (locate.py)
    parameters       parameter or physics: the given parameters against the re-calibrated
                     ones on held-out data (an information criterion under coloured noise)
    hypotheses       the catalogue proposes every effect in each of its forms (effects.py)
    selection        screening, joint refits, forward selection stopped by held-out
                     improvement and the information criterion (select.py); a generic extra
                     state with as many parameters beside each kept effect
    identifiability  an interval for every reported parameter, or the experiment that
                     would identify it (identify.py)
    report           named effects, their forms and shares, fits before and after,
                     the augmented model's FitResult (report.py)
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from thermogym._checks import probability
from thermogym.errors import ConfigError, RecordingError, UnknownNameError
from thermogym.fitresult import FitResult, data_entry, load_fit
from thermogym.identification.diagnosis.context import Context, signatures
from thermogym.identification.diagnosis.effects import (
    CATALOGUE,
    candidates_for,
    course_baseline,
    generic_fix,
)
from thermogym.identification.diagnosis.fit import (
    FitProblem,
    output_weights,
    prepare_experiments,
)
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
from thermogym.identification.diagnosis.report import DiagnosisReport
from thermogym.identification.diagnosis.residuals import noise_sigma, residual_tests
from thermogym.identification.diagnosis.scoring import delta_ic, whitened_chi2
from thermogym.identification.diagnosis.select import (
    Data,
    Selection,
    fit_hypothesis,
    forward_selection,
    nrmse_table,
    passes,
    residuals_of,
    score_self,
    shares,
)
from thermogym.models.base import Model
from thermogym.recording import Recording
from thermogym.vocabulary import EFFECT_NAMES

__all__ = ["STAGES", "diagnose", "resolve_model"]

_MIN_SAMPLES = 10
#: How much better (mean held-out NRMSE fit, 0.01 = one per cent of the outputs' variation)
#: the plain ARX baseline must predict before the nominal model is called inadequate: a
#: tie within a few thousandths (0.993 against 0.992) is coloured noise, not a verdict.
INADEQUATE_MARGIN = 0.01
#: The pipeline's stages, in order.
STAGES = (
    "nominal",
    "baseline",
    "detection",
    "location",
    "parameters",
    "hypotheses",
    "selection",
    "identifiability",
    "report",
)


@dataclass
class _Run:
    """What the stages hand on to each other."""

    opts: dict[str, Any]
    say: Callable[[str], None]
    t0: float
    tr_list: list[Recording]
    va_list: list[Recording]
    model: Model | None = None
    spec: NominalSpec | None = None
    generic: bool = False
    outs: list[str] = field(default_factory=list)
    tr: list[Any] = field(default_factory=list)
    va: list[Any] = field(default_factory=list)
    weights: NDArray[np.float64] | None = None
    x0: str = "estimate"
    given: NDArray[np.float64] | None = None
    given_fixed: set[str] = field(default_factory=set)
    bounds: dict[str, tuple[float, float]] = field(default_factory=dict)
    calibrated: list[str] = field(default_factory=list)
    idf_table: dict[str, Any] = field(default_factory=dict)
    method: str = ""
    nominal: Hypothesis | None = None
    given_h: Hypothesis | None = None
    arx: dict[str, Any] = field(default_factory=dict)
    data: Data | None = None
    tests: dict[str, Any] = field(default_factory=dict)
    detected: bool = False
    train_material: bool = False
    sigma: dict[str, float] = field(default_factory=dict)
    located: dict[str, Any] = field(default_factory=dict)
    regs: list[Any] = field(default_factory=list)
    parameters: dict[str, Any] = field(default_factory=dict)
    ctx: Context | None = None
    candidates: list[Any] = field(default_factory=list)
    selection: Selection | None = None
    notes: list[str] = field(default_factory=list)
    seconds: dict[str, float] = field(default_factory=dict)


# ------------------------------------------------------------------ diagnose
def diagnose(
    model: str | Model,
    train: Recording | Sequence[Recording],
    validate: Recording | Sequence[Recording],
    *,
    params: FitResult | str | Mapping[str, Any] | None = None,
    model_config: Mapping[str, Any] | None = None,
    inputs: Sequence[str] | None = None,
    outputs: Sequence[str] | None = None,
    candidates: Sequence[str] | None = None,
    dt: float | None = None,
    alpha: float = 0.01,
    max_lag: int = 25,
    min_snr: float = 0.5,
    min_rel: float = 0.002,
    scheme: str = "auto",
    max_effects: int = 3,
    max_candidates: int | None = None,
    max_nfev: int = 25,
    sparse: bool = True,
    time_limit: float | None = None,
    progress: Callable[[str], None] | None = None,
    min_explained: float | None = None,
) -> DiagnosisReport:
    """Locate a model mismatch, name the missing physics, model it, show the fit improve.

    Parameters
    ----------
    model : str or Model
        The nominal model: a registered thermogym model (``axt211``,
        ``strut``, ``spindle``, ...), ``foptd`` or ``ss:ORDER`` for any
        recording (with ``inputs`` and ``outputs``), or a model instance
        (a user's own :class:`~thermogym.models.base.Model`).
    train : Recording or sequence
        Training recordings (uniformly sampled; slightly uneven time stamps
        are resampled).
    validate : Recording or sequence
        Held-out recordings, at least one.
    params : FitResult, path or dict, optional
        Given parameters of the nominal model (its design values when
        omitted); a FitResult's operating point is honoured. The identifiable
        ones are re-calibrated on ``train``; whether that was needed is the
        ``parameter_error`` question.
    model_config : mapping, optional
        Constructor arguments of a registered model.
    inputs, outputs : sequence of str, optional
        Generic models: exogenous and output columns. Plant models: the
        outputs to compare (default: every model output in the recordings).
    candidates : sequence of str, optional
        Effects to consider (default: every effect of the vocabulary).
    dt : float, optional
        Average the recordings onto this period [s] first.
    alpha : float
        Significance level of the residual tests (Bonferroni over outputs and tests).
    max_lag : int
        Lags of the residual tests [samples].
    min_snr, min_rel : float
        Materiality of a mismatch: systematic residual at least ``min_snr`` ×
        the noise level and ``min_rel`` × the output's spread.
    scheme : {"auto", "split", "crossfit"}
        How hypotheses are scored on held-out data (:mod:`.select`).
    max_effects : int
        Most effects a combination holds.
    max_candidates : int, optional
        Most candidates screened (highest signature score first; default all).
    max_nfev : int
        Cost evaluations of a joint refit.
    sparse : bool
        Try a sparse regression of the residual's dynamics when nothing in
        the catalogue explains a mismatch.
    time_limit : float, optional
        Seconds the whole run may take: fits stop early enough (a margin of
        10 % of it, at most 5 s) for the report to be finished within it, and
        the report says what was left out (``complete``, ``incomplete``).
    progress : callable, optional
        Called with a line of text at each stage.
    min_explained : float, optional
        Ignored (the information criterion decides); kept for old callers.

    Returns
    -------
    DiagnosisReport

    Raises
    ------
    ConfigError
        No training or no validation recording, unknown option.
    RecordingError
        Recordings of another model (missing columns named), too short,
        unusable samples.

    Examples
    --------
    The strut model's own step tests (train at 20 m/min, validate at 25 and 30), the
    nut's thermocouple reading 1 K high (the virtual rig is a richer plant than the
    model: its recordings show more than this one effect):

    >>> import numpy as np
    >>> from thermogym.models.registry import get_model
    >>> from thermogym.recording import Recording
    >>> m = get_model("strut")
    >>> rng = np.random.default_rng(0)
    >>> def steps(v, n=49, dt=150.0):
    ...     u = np.column_stack([np.full(n, v), np.full(n, 21.0)])
    ...     u[0, 0] = 0.0
    ...     y = m.simulate(u, dt, {"T_ref": 21.0}).outputs[0]
    ...     cols = {"feed_rate": u[:, 0], "T_air": u[:, 1]}
    ...     cols |= {k: y[:, j] + rng.normal(0, 0.05, n) for j, k in enumerate(m.output_names)}
    ...     cols["T_nut"] = cols["T_nut"] + 1.0  # the nut's sensor reads 1 K high
    ...     return Recording(dt * np.arange(n), cols)
    >>> rep = diagnose("strut", [steps(20.0)], [steps(25.0), steps(30.0)],
    ...                candidates=["sensor_offset", "sensor_lag"])
    >>> rep.best["effect"], rep.best["target"]
    ('sensor_offset', 'T_nut')
    >>> round(rep.best["params"]["offset_T_nut"]["value"], 1)
    1.0
    """
    del min_explained
    say = progress or (lambda s: None)
    tr_list = [train] if isinstance(train, Recording) else list(train or [])
    va_list = [validate] if isinstance(validate, Recording) else list(validate or [])
    if not tr_list:
        raise ConfigError("no training recordings: diagnosis fits the nominal model on them")
    if not va_list:
        raise ConfigError(
            "no validation recordings: diagnosis ranks hypotheses by their fit on held-out "
            "data; give at least one recording not used for training (--validate)"
        )
    if scheme not in ("auto", "split", "crossfit"):
        raise ConfigError(f"scheme is {scheme!r}; expected 'auto', 'split' or 'crossfit'")
    alpha = probability("alpha", alpha, error=ConfigError)  # a test level in (0, 1)
    if candidates is not None:
        unknown = [c for c in candidates if c not in CATALOGUE or c in ("none", "parameter_error")]
        if unknown:
            raise UnknownNameError(
                f"unknown effect(s) {unknown}; the vocabulary is "
                f"{[k for k in CATALOGUE if k not in ('none', 'parameter_error')]}"
            )
    if not (isinstance(max_effects, int) and max_effects >= 1):
        raise ConfigError(f"max_effects is {max_effects!r}; expected a whole number >= 1")
    opts = dict(
        params=params,
        model_config=model_config,
        inputs=inputs,
        outputs=outputs,
        candidates=candidates,
        dt=dt,
        alpha=alpha,
        max_lag=max_lag,
        min_snr=min_snr,
        min_rel=min_rel,
        scheme=scheme,
        max_effects=max_effects,
        max_candidates=max_candidates,
        max_nfev=max_nfev,
        sparse=sparse,
        time_limit=time_limit,
        model=model,
    )
    st = _Run(opts, say, time.perf_counter(), tr_list, va_list)
    for name in STAGES:
        t = time.perf_counter()
        out = _STAGE_FUNCS[name](st)
        st.seconds[name] = time.perf_counter() - t
        if isinstance(out, DiagnosisReport):
            return out
    raise AssertionError("the report stage returns the report")  # pragma: no cover


# ------------------------------------------------------------------ stage: nominal
def _check_inputs(st: _Run) -> None:
    o = st.opts
    model = o["model"]
    generic = isinstance(model, str) and model.partition(":")[0] in ("foptd", "ss")
    if generic and o["params"] is not None and not (o["inputs"] and o["outputs"]):
        # the columns of a given generic FitResult are its own
        cfg = load_fit(o["params"]).model_config
        cfg = cfg.get("base_config", cfg) if "base" in cfg else cfg
        o["inputs"] = o["inputs"] or [*cfg.get("inputs", []), *cfg.get("disturbances", [])]
        o["outputs"] = o["outputs"] or list(cfg.get("outputs", []))
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
    if not outs:
        raise RecordingError(
            f"the recordings hold none of the outputs of model {nominal.name!r} "
            f"({list(nominal.output_names)}); columns are {list(st.tr_list[0].columns)}: are they "
            "recordings of another plant?"
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
            st.x0 = "rest"
            st.notes.append(
                "every input is constant within every training recording: the recordings are "
                "taken to start at rest with the inputs at zero before their start (the initial "
                "state is not estimated; give training recordings in which the inputs change to "
                "have it estimated)"
            )
        nominal = spec.build()
    st.model, st.spec, st.outs = nominal, spec, outs


def _beyond_training(names: Sequence[str], tr: Sequence[Any], va: Sequence[Any]) -> list[str]:
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


def _deadline(st: _Run) -> float | None:
    """When fitting stops: the time limit less a margin for the stages that finish the report.

    The margin is 10 % of the limit, at most 5 s: the limit bounds the whole run.
    """
    limit = st.opts["time_limit"]
    if limit is None:
        return None
    return st.t0 + limit - min(5.0, 0.1 * limit)


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
    st.weights = output_weights(st.tr)
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
    if st.generic:
        sel, table = list(cands), {}
    else:
        sel, table = calibration_set(model, given, cands, lo, hi, st.tr, st.weights, st.x0)
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
        st.weights,
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
    pb = FitProblem(model, (), out.theta, np.zeros(0), np.zeros(0), st.tr, st.weights, st.x0)
    h.sims_train = [pb.simulate(np.zeros((1, 0)), i)[0] for i in range(len(st.tr))]
    pv = FitProblem(model, (), out.theta, np.zeros(0), np.zeros(0), st.va, st.weights, st.x0)
    h.sims_val = [pv.simulate(np.zeros((1, 0)), i)[0] for i in range(len(st.va))]
    st.nominal = h


def _given(params, model, spec, st):
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
    from thermogym.models.augmented import AugmentedModel

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
    nom = nrmse_table(st.outs, [e.y for e in st.va], st.nominal.sims_val)
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
            f"nominal model inadequate: held-out mean NRMSE {nom['mean']:.3f} against a plain "
            f"ARX's {fit['mean']:.3f}"
        )


# ------------------------------------------------------------------ stage: detection
def _tests(outputs, exps, sims, alpha, max_lag, inputs) -> dict[str, Any]:
    out = {}
    for j, o in enumerate(outputs):
        res = [e.y[:, j] - s[:, j] for e, s in zip(exps, sims, strict=True)]
        ins = [{c: e.u[:, i] for i, c in enumerate(inputs)} for e in exps]
        out[o] = residual_tests(
            res, ins, signal=o, measured=[e.y[:, j] for e in exps], max_lag=max_lag, alpha=alpha
        )
    return out


def _significant(t, alpha_adj, min_snr, min_rel) -> bool:
    stat = t.p_white < alpha_adj or any(p < alpha_adj for p in t.p_independent.values())
    return bool(stat and t.material(min_snr, min_rel))


def _stage_detection(st: _Run) -> None:
    o = st.opts
    h = st.nominal
    exo = list(st.model.exogenous_names)
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
    st.data = Data(
        st.tr, st.va, st.weights, st.x0, o["alpha"], use, o["max_nfev"], deadline, st.say
    )
    # the nominal's own scores (the reference of every comparison)
    score_self(h, st.data)
    if use == "crossfit":
        # the nominal's held-out predictions from the folds, like every hypothesis'
        ref = fit_hypothesis(st.spec, h, None, st.data, h)
        if ref.ok:
            h.sims_val = ref.sims_val
            score_self(h, st.data)
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
    h = st.nominal
    all_exps = [*st.tr, *st.va]
    roles = ["train"] * len(st.tr) + ["validation"] * len(st.va)
    all_sims = [*h.sims_train, *h.sims_val]
    units = {s.name: s.unit for s in st.model.signals}
    exo = list(st.model.exogenous_names)
    sigma = {}
    for j, o in enumerate(st.outs):
        vals = [noise_sigma(e.y[:, j] - s[:, j]) for e, s in zip(all_exps, all_sims, strict=True)]
        vals = [v for v in vals if math.isfinite(v)]
        sigma[o] = float(np.sqrt(np.mean(np.square(vals)))) if vals else math.nan
    st.sigma = sigma
    if st.data is not None:
        st.data.noise = np.array([sigma[o] for o in st.outs], dtype=float)
        st.data.min_snr = float(st.opts["min_snr"])
    scale = {o: 1.0 / float(st.weights[j]) for j, o in enumerate(st.outs)}
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
        float(st.weights[j] ** 2)
        * sigma[o] ** 2
        * sum(int(np.isfinite(e.y[:, j]).sum()) for e in st.va)
        for j, o in enumerate(st.outs)
        if math.isfinite(sigma[o])
    )
    h.baseline = {"noise_floor": floor}


# ------------------------------------------------------------------ stage: parameters
def _stage_parameters(st: _Run) -> None:
    """Parameter or physics: whether the given parameters were off."""
    h = st.nominal
    if st.generic or not st.calibrated:
        st.parameters = {
            "tested": False,
            "reason": "a generic model has no given parameters"
            if st.generic
            else "no identifiable parameter",
        }
        return
    g = Hypothesis(candidates=(), model=st.model, theta=st.given.copy())
    pb = FitProblem(st.model, (), st.given, np.zeros(0), np.zeros(0), st.tr, st.weights, st.x0)
    g.sims_train = [pb.simulate(np.zeros((1, 0)), i)[0] for i in range(len(st.tr))]
    pv = FitProblem(st.model, (), st.given, np.zeros(0), np.zeros(0), st.va, st.weights, st.x0)
    g.sims_val = [pv.simulate(np.zeros((1, 0)), i)[0] for i in range(len(st.va))]
    score_self(g, st.data)
    st.given_h = g
    # the calibrated model against the given one: k re-calibrated parameters
    chi2, n = whitened_chi2(residuals_of(g, st.data)[1], residuals_of(h, st.data)[1])
    d = delta_ic(chi2, len(st.calibrated), n)
    better = bool(d < 0 and h.wsse_val < g.wsse_val)
    iv = intervals(
        h,
        st.calibrated,
        st.tr,
        st.weights,
        st.x0,
        experiment={p: CATALOGUE["parameter_error"].experiment(p) for p in st.calibrated},
    )
    moved = {}
    for p in st.calibrated:
        v0 = float(st.given[st.model.param_index(p)])
        v1 = float(h.theta[st.model.param_index(p)])
        spec_p = st.model.parameters[st.model.param_index(p)]
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


# ------------------------------------------------------------------ stage: hypotheses
def _stage_hypotheses(st: _Run) -> None:
    if not st.detected:
        return
    h = st.nominal
    all_exps = [*st.tr, *st.va]
    share = {d["signal"]: d["share_of_error"] for d in st.located["signals"]}
    units = {s.name: s.unit for s in st.model.signals}
    no_units = all(units.get(o, "1") in ("1", "", None) for o in st.outs)
    st.ctx = Context(
        model=st.model,
        spec=st.spec,
        theta=h.theta,
        free=h.free,
        outputs=tuple(st.outs),
        time=[e.time for e in all_exps],
        dt=[e.dt for e in all_exps],
        u=[e.u for e in all_exps],
        y=[e.y for e in all_exps],
        sim=[*h.sims_train, *h.sims_val],
        is_train=[True] * len(st.tr) + [False] * len(st.va),
        sigma=st.sigma,
        scale={o: 1.0 / float(st.weights[j]) for j, o in enumerate(st.outs)},
        share=share,
        regimes=st.located["all_regimes"],
        assumed_celsius=no_units,
    )
    if no_units:
        st.notes.append(
            "the outputs carry no unit: heat-transfer hypotheses took them as temperatures in °C "
            "(give units in the recording's sidecar to decide otherwise)"
        )
    st.ctx.features = signatures(st.ctx)
    if st.data is not None:
        ctx = st.ctx
        st.data.course_baseline = lambda n: course_baseline(ctx, n)
    cands = candidates_for(st.ctx, list(st.opts["candidates"]) if st.opts["candidates"] else None)
    if st.opts["max_candidates"]:
        cands = cands[: st.opts["max_candidates"]]
    st.candidates = cands
    st.say(f"{len(cands)} candidate effects and forms")


# ------------------------------------------------------------------ stage: selection
def _stage_selection(st: _Run) -> None:
    if not st.detected or not st.candidates:
        st.selection = Selection()
        return
    sel = forward_selection(
        st.spec, st.nominal, st.candidates, st.data, max_effects=st.opts["max_effects"]
    )
    # a generic extra state with as many parameters beside each kept effect (item 6)
    parent = st.nominal
    for h in sel.steps:
        if st.data.expired:
            st.data.skip(f"no generic-fix baseline beside {h.last.label}")
            continue
        n = max(2, h.k_global - parent.k_global)
        g = generic_fix(st.ctx, n)
        if h.last.effect == "missing_dynamics" and h.last.form == g.form:
            parent = h
            continue
        gh = fit_hypothesis(st.spec, parent, g, st.data, st.nominal)
        h.baseline = {
            **h.baseline,
            "generic_fix": f"{g.form} ({gh.k_global - parent.k_global} parameters)",
            "delta_ic": gh.delta_ic,
            "validation_after": gh.validation_after,
            "physics_favoured": bool(not gh.ok or h.delta_ic < gh.delta_ic),
        }
        if not h.baseline["physics_favoured"]:
            h.notes.append(
                "the evidence does not favour a physical explanation: a generic extra state "
                "with as many parameters fits the held-out data as well or better"
            )
        parent = h
    if not sel.steps and st.opts["sparse"]:
        if st.data.expired:
            st.data.skip("the sparse regression of the residual not tried")
        else:
            _sparse(st, sel)
    st.selection = sel


def _sparse(st: _Run, sel: Selection) -> None:
    from thermogym.identification.diagnosis.sindy import sparse_candidates

    try:
        cands = sparse_candidates(st.ctx)
    except Exception as e:  # pysindy missing or failing: said, not fatal
        st.notes.append(f"sparse regression not run: {type(e).__name__}: {e}")
        return
    best = None
    for c in cands:
        h = fit_hypothesis(st.spec, st.nominal, c, st.data, st.nominal)
        sel.first_round.append(h)
        if passes(h, st.nominal, len(cands), st.data) and (
            best is None or h.delta_ic < best.delta_ic
        ):
            best = h
    if best is not None:
        sel.steps.append(best)


# ------------------------------------------------------------------ stage: identifiability
def _stage_identifiability(st: _Run) -> None:
    sel = st.selection
    if sel is None or not sel.steps:
        return
    final = sel.final
    names = [p for p in final.free if p in final.extra or p in st.calibrated]
    exp = _experiments(final, names, st)
    try:
        final.intervals.update(intervals(final, names, st.tr, st.weights, st.x0, experiment=exp))
    except Exception as e:  # reported, not fatal
        final.notes.append(f"intervals not computed: {type(e).__name__}: {e}")


def _experiments(final: Hypothesis, names: Sequence[str], st: _Run) -> dict[str, str]:
    """Per parameter, the experiment that would identify it (from the effect that owns it)."""
    out: dict[str, str] = {}
    owner: dict[str, str] = {}
    for c in final.candidates:
        sub = st.spec.build([x for x in final.candidates if x is not c])
        for p in final.model.param_names:
            if p not in sub.param_names:
                owner[p] = c.effect
    for p in names:
        eff = owner.get(p, "parameter_error")
        text = CATALOGUE[eff].experiment(p) if eff in CATALOGUE else "a richer excitation"
        if eff == "input_dependent_heat_transfer" or "second level" in text:
            src = _source_of(final, p)
            if src:
                text = f"a second level of {src} in the training data"
        out[p] = text
    return out


def _source_of(final: Hypothesis, p: str) -> str | None:
    for c in final.candidates:
        for a in c.augmentations:
            if a.get("source") and a.get("signal") and p.endswith(str(a["signal"])):
                return str(a["source"])
    if any(c.internal for c in final.candidates) and final.model is not None:
        ins = [s.name for s in final.model.inputs]
        return ins[0] if ins else None
    return None


# ------------------------------------------------------------------ stage: report
def _stage_report(st: _Run) -> DiagnosisReport:
    h = st.nominal
    o = st.opts
    outs = st.outs
    exo = list(st.model.exogenous_names)
    units = {s.name: s.unit for s in st.model.signals}
    fit_before_tr = nrmse_table(outs, [e.y for e in st.tr], h.sims_train)
    fit_before_va = nrmse_table(outs, [e.y for e in st.va], h.sims_val)
    data = [data_entry(r, "train") for r in st.tr_list] + [
        data_entry(r, "validation") for r in st.va_list
    ]
    nominal_fit = _build_fit(
        st.model,
        h,
        method=f"diagnosis nominal ({st.method})",
        settings={
            "x0": st.x0,
            "weights": dict(zip(outs, st.weights.tolist(), strict=True)),
            "dt": o["dt"],
            "calibrated": list(st.calibrated),
        },
        metrics={"train": {"nrmse": fit_before_tr}, "validation": {"nrmse": fit_before_va}},
        data=data,
        notes="nominal model of thermogym diagnosis",
    )
    tests_tr, tests_va = st.tests["train"], st.tests["validation"]
    alpha_adj = st.tests["alpha_adj"]
    sel = st.selection or Selection()
    steps = sel.steps
    # the combination is reported largest share first: the effect that removes most of the
    # held-out error is named first, whichever round kept it
    sh = shares(h, steps) if steps else []
    order = sorted(range(len(steps)), key=lambda i: -(sh[i] if math.isfinite(sh[i]) else -math.inf))
    physics = []
    for i in order:
        e = steps[i].last.effect
        if e in EFFECT_NAMES and e not in physics:
            physics.append(e)
    par = st.parameters
    if physics:
        named = list(physics)
        if par.get("significant"):
            named.append("parameter_error")
    elif par.get("significant"):
        named = ["parameter_error"]
    elif st.detected and st.arx and not st.arx.get("nominal_adequate", True):
        named = ["unexplained"]
    else:
        named = ["none"]
    report = DiagnosisReport(
        model=st.spec.name,
        model_config=st.spec.config(),
        outputs=list(outs),
        exogenous=exo,
        units=units,
        mismatch_detected=named != ["none"],
        alpha=o["alpha"],
        detection={
            "train": {
                x: {**t.to_dict(alpha_adj), "significant": st.tests["sig_tr"][x]}
                for x, t in tests_tr.items()
            },
            "validation": {
                x: {**t.to_dict(alpha_adj), "significant": st.tests["sig_va"][x]}
                for x, t in tests_va.items()
            },
            "alpha_per_test": alpha_adj,
            "materiality": {"min_snr": o["min_snr"], "min_rel": o["min_rel"]},
            "residual_structure": st.detected,
        },
        located=st.located,
        nominal_fit=nominal_fit,
        fit_before={"train": fit_before_tr, "validation": fit_before_va},
        notes=st.notes,
    )
    report.named_effects = named
    if st.data is not None and st.data.skipped:
        report.complete = False
        report.incomplete = [
            f"time limit of {o['time_limit']:g} s: " + st.data.skipped[0],
            *st.data.skipped[1:],
        ]
    report.parameters = par
    report.baseline = {k: v for k, v in st.arx.items() if k != "sims"}
    report.nominal_adequate = bool(st.arx.get("nominal_adequate", True))
    report.scheme = st.data.scheme if st.data else ""
    report.stages = {k: round(v, 3) for k, v in st.seconds.items()}
    report.selection = sel.summary()
    report.series = [
        {"name": e.name, "role": r, "time": e.time, "measured": e.y, "nominal": s, "u": e.u}
        for e, r, s in zip(
            [*st.tr, *st.va],
            ["train"] * len(st.tr) + ["validation"] * len(st.va),
            [*h.sims_train, *h.sims_val],
            strict=True,
        )
    ]
    report.regime_values = st.regs
    report.tests_before = {"train": tests_tr, "validation": tests_va}
    if st.ctx is not None:
        report.signatures = st.ctx.features
    report.hypotheses = [x.to_dict() for x in sel.first_round]
    for i, x in enumerate(report.hypotheses):
        x["rank"] = i + 1
        x["explanation"] = CATALOGUE[x["effect"]].explanation if x["effect"] in CATALOGUE else ""
    report.combination = []
    if steps:
        final = steps[-1]
        for s, share in ((steps[i], sh[i]) for i in order):
            c = s.last
            report.combination.append(
                {
                    "effect": c.effect,
                    "form": c.form,
                    "target": c.target,
                    "evidence": c.evidence,
                    "share_of_explained_error": share,
                    "delta_ic": s.delta_ic,
                    "params": final.params_table(
                        [
                            p
                            for p in final.extra
                            if p in s.extra
                            and p not in (steps[0].extra if s is not steps[0] else ())
                        ]
                        if s is not steps[0]
                        else list(s.extra)
                    ),
                    "baseline": s.baseline,
                    "notes": s.notes,
                }
            )
        first = steps[0]
        top = steps[order[0]]
        report.alternatives = _alternatives(first, sel, physics)
        report.best = {
            "effect": top.last.effect,
            "form": top.last.form,
            "target": top.last.target,
            "explanation": CATALOGUE[top.last.effect].explanation
            if top.last.effect in CATALOGUE
            else "",
            "evidence": top.last.evidence,
            "params": final.params_table([p for p in final.extra]),
            "fit_before": fit_before_tr,
            "fit_after": final.fit_after,
            "validation_before": fit_before_va,
            "validation_after": final.validation_after,
            "explained": final.explained,
            "delta_ic": top.delta_ic,
            "named_effects": named,
            "notes": [n for s in steps for n in s.notes],
        }
        _finalise(report, final, st, data)
    else:
        eff = named[0]
        text = {
            "none": CATALOGUE["none"].explanation,
            "parameter_error": CATALOGUE["parameter_error"].explanation,
            "unexplained": "A significant mismatch remains that none of the hypotheses tried "
            "explains on held-out data, and a plain ARX predicts the held-out data better than "
            "the nominal model: the model lacks something outside the catalogue, or the data "
            "cannot separate the candidates (see the ranked hypotheses).",
        }[eff]
        report.best = {"effect": eff, "target": "", "explanation": text, "named_effects": named}
        if eff == "parameter_error":
            report.best["params"] = {
                p: r for p, r in par.get("parameters", {}).items() if r.get("moved")
            }
    report.seconds = time.perf_counter() - st.t0
    st.say(f"named: {', '.join(named)} ({report.seconds:.1f} s)")
    return report


#: Largest held-out ΔIC difference between two hypotheses the data do not tell apart (Kass &
#: Raftery 1995: below 6 on the BIC scale is weaker than "strong" evidence).
ALTERNATIVE_DIC = 6.0


def _alternatives(
    first: Hypothesis, sel: Selection, named: Sequence[str] = ()
) -> list[dict[str, Any]]:
    """Other effects the first round fitted about as well as the first one kept.

    Jointly refitted (not only screened) hypotheses of another effect whose held-out
    ΔIC is within :data:`ALTERNATIVE_DIC` of the first kept one's and that remove
    at least 90 % of the error it removes: the data do not tell them apart, and
    the report names the experiment that would. Effects already in the combination
    (``named``) are not alternatives to it; each entry says which effect it is an
    alternative to (``instead_of``).
    """
    out: list[dict[str, Any]] = []
    if first.last is None or not math.isfinite(first.delta_ic):
        return out
    seen = {first.last.effect, *named}
    for h in sel.first_round:
        c = h.last
        if c is None or h.screened or not h.ok or c.effect in seen:
            continue
        if not math.isfinite(h.delta_ic) or h.delta_ic > first.delta_ic + ALTERNATIVE_DIC:
            continue
        if first.explained > 0 and h.explained < 0.9 * first.explained:
            continue
        seen.add(c.effect)
        entry = CATALOGUE.get(c.effect)
        out.append(
            {
                "effect": c.effect,
                "form": c.form,
                "target": c.target,
                "delta_ic": h.delta_ic,
                "explained": h.explained,
                "instead_of": first.last.effect,
                "tell_apart": (
                    f"{entry.experiment('')} (for {c.effect}); "
                    f"{CATALOGUE[first.last.effect].experiment('')} (for {first.last.effect})"
                    if entry is not None and first.last.effect in CATALOGUE
                    else ""
                ),
            }
        )
    return out


def _finalise(report: DiagnosisReport, final: Hypothesis, st: _Run, data: list) -> None:
    from thermogym.models.augmented import AugmentedModel

    o = st.opts
    outs = st.outs
    exo = list(st.model.exogenous_names)
    alpha_adj = st.tests["alpha_adj"]
    tests_tr = _tests(outs, st.tr, final.sims_train, o["alpha"], o["max_lag"], exo)
    tests_va = _tests(outs, st.va, final.sims_val, o["alpha"], o["max_lag"], exo)
    report.detection_after = {
        "train": {x: t.to_dict(alpha_adj) for x, t in tests_tr.items()},
        "validation": {x: t.to_dict(alpha_adj) for x, t in tests_va.items()},
    }
    report.tests_after = {"train": tests_tr, "validation": tests_va}
    for s, sim in zip(report.series, [*final.sims_train, *final.sims_val], strict=True):
        s["augmented"] = sim
    model = final.model
    theta = final.theta
    if isinstance(model, AugmentedModel) and any(
        a["effect"] == "transport_delay" for a in model.augmentations
    ):
        # keep enough history for step-wise use of the fitted dead times
        cfg = model.config()
        dtm = min(e.dt for e in st.tr)
        for a in cfg["augmentations"]:
            if a["effect"] == "transport_delay":
                pname = ("delay_out_" if a.get("form") == "output" else "delay_") + a["signal"]
                d = float(theta[model.param_index(pname)])
                a["history"] = math.ceil(d / dtm) + 2
        base = model.base if not st.spec.registered else cfg["base"]
        model2 = AugmentedModel(
            base, None if not st.spec.registered else cfg["base_config"], cfg["augmentations"]
        )
        theta = np.array(
            [
                theta[model.param_index(p)]
                if p in model.param_names
                else model2.nominal[model2.param_index(p)]
                for p in model2.param_names
            ]
        )
        model = model2
    h2 = Hypothesis(
        candidates=final.candidates,
        model=model,
        free=final.free,
        bounds=final.bounds,
        theta=theta,
        outcome=final.outcome,
    )
    report.augmented_fit = _build_fit(
        model,
        h2,
        method="thermogym diagnosis: " + " + ".join(c.effect for c in final.candidates),
        settings={
            "named_effects": report.named_effects,
            "forms": [c.form for c in final.candidates],
            "targets": [c.target for c in final.candidates],
            "x0": st.x0,
            "scheme": report.scheme,
            "nominal_model": st.spec.name,
            "local_parameters_neutral": list(final.local),
        },
        metrics={
            "train": {"nrmse": final.fit_after},
            "validation": {"nrmse": final.validation_after},
        },
        data=data,
        notes="; ".join(
            CATALOGUE[c.effect].explanation[:80] for c in final.candidates if c.effect in CATALOGUE
        ),
    )


def _build_fit(
    model: Model,
    h: Hypothesis,
    *,
    method: str,
    settings: dict[str, Any],
    metrics: dict[str, Any],
    data: list[dict[str, Any]],
    notes: str,
) -> FitResult:
    stderr = {p: math.nan for p in model.param_names}
    cov, cov_names = None, []
    out = h.outcome
    if out is not None:
        stderr.update({p: v for p, v in out.stderr.items() if p in stderr})
        if out.covariance is not None and all(p in model.param_names for p in out.covariance_names):
            cov = np.asarray(out.covariance).tolist()
            cov_names = list(out.covariance_names)
    b = {p.name: [p.lower, p.upper] for p in model.parameters}
    for p, (lo, hi) in h.bounds.items():
        if p in b:
            b[p] = [float(lo), float(hi)]
    th = np.asarray(h.theta, dtype=float).reshape(-1)
    for i, p in enumerate(model.param_names):
        lo, hi = b[p]
        b[p] = [min(lo, float(th[i])), max(hi, float(th[i]))]
    free = [p for p in h.free if p in model.param_names]
    return FitResult.from_model(
        model,
        th,
        stderr=stderr,
        covariance=cov,
        covariance_names=cov_names,
        bounds=b,
        fixed=[p for p in model.param_names if p not in free],
        method=method,
        settings=settings,
        metrics=metrics,
        data=data,
        notes=notes,
    )


_STAGE_FUNCS: dict[str, Callable[[_Run], Any]] = {
    "nominal": _stage_nominal,
    "baseline": _stage_baseline,
    "detection": _stage_detection,
    "location": _stage_location,
    "parameters": _stage_parameters,
    "hypotheses": _stage_hypotheses,
    "selection": _stage_selection,
    "identifiability": _stage_identifiability,
    "report": _stage_report,
}
