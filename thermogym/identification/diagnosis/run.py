"""``diagnose``: detect, locate, explain, model and show a model mismatch.

The six stages (issue "Mismatch diagnosis")::

    1 nominal   fit the nominal model on the training recordings (or take a FitResult)
    2 detect    residual whiteness / input-independence tests + materiality, per output,
                on training and validation data (residuals.py)
    3 locate    signals, time windows, operating regimes carrying the error (locate.py)
    4 explain   shortlist catalogued effects by their residual signature (effects.py),
                fit each augmented model, rank by held-out improvement with a BIC penalty;
                sparse regression of the residual dynamics when none explains it (sindy.py)
    5 model     the winner as a FitResult (plant with its effect switched on, or the
                registered ``augmented`` model)
    6 show      fits before/after on training and held-out data, residual tests after,
                figures (report.py, plots.py)

Ranking. Each hypothesis ``h`` (``k_h`` extra parameters) is fitted on the
training recordings with the nominal parameters refitted too; on the ``N``
validation samples its weighted squared error ``S_h`` (outputs weighted by
1/spread, as NRMSE) is compared with the nominal's ``S_0``::

    ΔBIC_h = N ln(S_h / S_0) + k_h ln N          score_h = −ΔBIC_h
    explained_h = (S_0 − S_h) / (S_0 − S_noise)   share of the systematic error removed

``S_noise`` is the floor white measurement noise would leave. The winner has
the highest score among hypotheses that improve the held-out fit beyond the
penalty and remove at least ``min_explained`` of the systematic error.

Held-out data. When the training recordings show no material mismatch but the
validation recordings do (the model is right at the training operating point
and wrong elsewhere — the situation of paper 000 section 4.1), the effect
cannot be identified from the training data alone. ``scheme="auto"`` then
cross-fits over the validation recordings: each is predicted by models fitted
on the training recordings plus the *other* validation recordings (leave one
out), so every reported held-out number is still out of sample; the final
augmented model is fitted on all recordings.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from thermogym._checks import probability
from thermogym.errors import ConfigError, RecordingError, UnknownNameError
from thermogym.fitresult import FitResult, data_entry, load_fit
from thermogym.identification.diagnosis.effects import (
    CATALOGUE,
    Candidate,
    Context,
    candidates_for,
    signatures,
)
from thermogym.identification.diagnosis.fit import (
    NOMINAL_SPECS,
    Experiment,
    FitOutcome,
    FitProblem,
    fit_model,
    output_weights,
    prepare_experiments,
    simulate_all,
)
from thermogym.identification.diagnosis.locate import locate, regime_variables
from thermogym.identification.diagnosis.report import DiagnosisReport
from thermogym.identification.diagnosis.residuals import noise_sigma, residual_tests
from thermogym.identification.metrics import nrmse
from thermogym.models.augmented import AugmentedModel
from thermogym.models.base import Model
from thermogym.models.fastnet import (
    fast_or_none,
    switched_or_none,
)
from thermogym.models.registry import get_model, model_names
from thermogym.recording import Recording

__all__ = ["diagnose", "resolve_model"]

_MIN_SAMPLES = 10
#: Training samples above which RK4-integrated hypotheses are screened first (see _explain).
_SCREEN_SAMPLES = 2000


# ------------------------------------------------------------------ the nominal model
def _units_roles(rec: Recording, cols: Sequence[str]) -> dict[str, str]:
    return {c: rec.units.get(c, "1") for c in cols}


def resolve_model(
    model: str | Model,
    recording: Recording | None = None,
    *,
    model_config: Mapping[str, Any] | None = None,
    inputs: Sequence[str] | None = None,
    outputs: Sequence[str] | None = None,
) -> tuple[Model, str, dict[str, Any]]:
    """Build the nominal model from a name, a ``foptd`` / ``ss:ORDER`` spec or an instance.

    Parameters
    ----------
    model : str or Model
        A registered model (``axt211``, ``strut``, ...), ``foptd``, ``ss:ORDER``,
        or a model instance.
    recording : Recording, optional
        Gives units and roles of the columns of a generic model.
    model_config : mapping, optional
        Constructor arguments of a registered model.
    inputs, outputs : sequence of str
        Columns of a generic model (``foptd``, ``ss:ORDER``): exogenous
        columns (those with role ``disturbance`` in the recording become
        disturbances) and outputs.

    Returns
    -------
    model : Model
    name : str
    config : dict

    Raises
    ------
    ConfigError
        A generic model without ``inputs`` / ``outputs``, a bad order.
    UnknownNameError
        An unknown model name.
    """
    if isinstance(model, Model):
        return model, model.name, model.config()
    if not isinstance(model, str):
        raise ConfigError(f"model is a {type(model).__name__}; expected a name or a Model")
    name, _, order = model.partition(":")
    if name in ("foptd", "ss"):
        if not inputs or not outputs:
            raise ConfigError(
                f"model {model!r} is generic: name the recording's input columns and output "
                "columns (inputs=..., outputs=...; --inputs COL,... --outputs COL,...)"
            )
        rec = recording
        roles = dict(rec.roles) if rec is not None else {}
        units = _units_roles(rec, [*inputs, *outputs]) if rec is not None else {}
        dis = [c for c in inputs if roles.get(c) == "disturbance"]
        ins = [c for c in inputs if c not in dis] or list(inputs[:1])
        dis = [c for c in dis if c not in ins]
        if name == "foptd":
            cfg = {
                "inputs": ins,
                "outputs": list(outputs),
                "disturbances": dis,
                "units": units,
                "offsets": True,
            }
            return get_model("foptd", **cfg), "foptd", cfg
        try:
            n = int(order or 1)
        except ValueError:
            raise ConfigError(
                f"model {model!r}: the order after 'ss:' must be an integer"
            ) from None
        if n < 1:
            raise ConfigError(f"model {model!r}: order {n} must be >= 1")
        cfg = {
            "base": "ss",
            "base_config": {
                "n_states": n,
                "inputs": ins,
                "outputs": list(outputs),
                "disturbances": dis,
                "units": units,
                "steady_start": False,
            },
            "augmentations": [
                {"effect": "sensor_offset", "signal": o, "bounds": {"offset": [-1e6, 1e6]}}
                for o in outputs
            ],
        }
        return AugmentedModel(**cfg), "augmented", cfg
    if model_config:
        m = get_model(name, **dict(model_config))
    else:
        m = get_model(name)
    return m, name, m.config()


def _nominal_problem(
    model: Model,
    name: str,
    config: dict[str, Any],
    train: list[Experiment],
) -> tuple[list[str], dict[str, float], NDArray[np.float64], NDArray[np.float64], str]:
    """Free parameters, fixed values, bounds and the initial-state policy of the nominal fit."""
    spec = NOMINAL_SPECS.get(name, {})
    fixed = {k: float(v) for k, v in spec.get("fixed", {}).items() if k in model.param_names}
    x0 = spec.get("x0", "estimate")
    if name in ("foptd", "augmented"):
        # generic linear models predict deviations from each recording's first values
        x0 = "initial"
        for p in model.param_names:
            if p.startswith(("y0_", "offset_")):
                fixed[p] = float(model.nominal[model.param_index(p)])
    free = list(spec.get("free") or [p for p in model.param_names if p not in fixed])
    free = [p for p in free if p not in fixed]
    idx = [model.param_index(p) for p in free]
    lo, hi = model.lower[idx].copy(), model.upper[idx].copy()
    return free, fixed, lo, hi, x0


def _generic_start(model: Model, name: str, train: list[Experiment]) -> NDArray[np.float64]:
    """Data-based start values of a generic model (FOPTD: step-response estimates)."""
    th = model.nominal.copy()
    base = model.base if isinstance(model, AugmentedModel) else model
    y = np.concatenate([e.y for e in train])
    u = np.concatenate([e.u for e in train])
    dur = sum(e.n * e.dt for e in train) / len(train)
    for j, o in enumerate(train[0].outputs):
        y0 = float(np.nanmedian([e.y[0, j] for e in train]))
        for pname in (f"y0_{o}", f"offset_{o}"):
            if pname in model.param_names:
                th[model.param_index(pname)] = y0
        for i, c in enumerate(base.exogenous_names):
            du = float(np.nanmax(u[:, i]) - np.nanmin(u[:, i]))
            dy = float(np.nanmax(y[:, j]) - np.nanmin(y[:, j]))
            tag = o if len(base.exogenous_names) == 1 else f"{o}__{c}"
            if f"K_{tag}" in model.param_names:
                th[model.param_index(f"K_{tag}")] = (dy / du if du > 0 else 0.0) * (
                    1.0 if i == 0 else 0.1
                )
                th[model.param_index(f"T_{tag}")] = max(dur / 5.0, train[0].dt)
    return th


def _refine_bounds(model: Model, free: Sequence[str], theta: NDArray[np.float64], lo, hi, train):
    """Finite, data-scaled bounds for generic linear parameters."""
    lo, hi = lo.copy(), hi.copy()
    dur = max(e.n * e.dt for e in train)
    dt = min(e.dt for e in train)
    for i, p in enumerate(free):
        v = theta[model.param_index(p)]
        if p.startswith("T_"):
            lo[i], hi[i] = max(dt / 10, 1e-3), 20 * dur
        elif p.startswith("tau_"):
            lo[i], hi[i] = 0.0, 0.5 * dur
        elif p.startswith(("y0_", "offset_")):
            lo[i], hi[i] = v - 1e3 - 10 * abs(v), v + 1e3 + 10 * abs(v)
        elif p.startswith(("K_", "B_", "C_", "D_")):
            w = 100 * abs(v) + 10.0
            lo[i], hi[i] = v - w, v + w
        elif p.startswith("A_"):
            r, c = p.split("_")[1:3]
            lo[i], hi[i] = (-0.5, 0.99999) if r == c else (-1.0, 1.0)
    return lo, hi


def _ss_n4sid_start(
    model: AugmentedModel, train: list[Experiment]
) -> tuple[NDArray[np.float64], dict[str, float]] | None:
    """State-space start from N4SID (paper 001) when it succeeds on the training data."""
    try:
        from thermogym.identification.n4sid import n4sid

        base = model.base
        # N4SID needs excitation: recordings whose exogenous signals all vary
        usable = [e.recording for e in train if np.all(np.ptp(e.u, axis=0) > 0)]
        res = n4sid(
            usable,
            list(base.exogenous_names),
            list(base.output_names),
            order=base.n_states,
            disturbances=[s.name for s in base.disturbances],
            noise_model=False,
            operating_point_mode="initial",
        )
        mats = res.system
        A, B, C = np.asarray(mats.A), np.asarray(mats.B), np.asarray(mats.C)
    except Exception:  # no N4SID in this build, or it failed on these data: modal start
        return None
    if A.shape != (base.n_states, base.n_states) or not np.isfinite(A).all():
        return None
    if np.max(np.abs(np.linalg.eigvals(A))) >= 1.0:
        return None
    th = model.nominal.copy()
    for name, M in (("A", A), ("B", B), ("C", C)):
        for r in range(M.shape[0]):
            for c in range(M.shape[1]):
                th[model.param_index(f"{name}_{r}_{c}")] = M[r, c]
    return th, {}


def _ss_start(
    model: AugmentedModel, train: list[Experiment]
) -> tuple[NDArray[np.float64], dict[str, float]]:
    """State-space start in modal form and the entries that stay fixed.

    Real poles ``a_i`` spread logarithmically over the data's time scales (a
    thermal plant is overdamped), ``A`` diagonal, ``B[i, 0] = 1 − a_i`` (each
    mode has unit DC gain from the first input: fixes the scale between ``B``
    and ``C``); ``C`` and the other columns of ``B`` by linear regression of
    the outputs' rise on the mode responses. The off-diagonal entries of ``A``
    and the first column of ``B`` are held (the modal form is unique up to
    their order); every other entry is fitted.
    """
    base = model.base
    n, m = base.n_states, base.n_inputs
    dt = train[0].dt
    dur = sum(e.n * e.dt for e in train) / len(train)
    taus = np.geomspace(max(5 * dt, dur / 200), dur / 3, n)
    a = np.exp(-dt / taus)
    th = model.nominal.copy()
    fixed: dict[str, float] = {}
    for i in range(n):
        th[model.param_index(f"A_{i}_{i}")] = a[i]
        for c in range(n):
            if c != i:
                fixed[f"A_{i}_{c}"] = 0.0
        fixed[f"B_{i}_0"] = 1.0 - a[i]
        th[model.param_index(f"B_{i}_0")] = 1.0 - a[i]
    X_parts, Y_parts = [], []
    for e in train:
        xs = np.zeros((e.n, n * m))
        for i in range(n):
            for c in range(m):
                x = np.zeros(e.n)
                for k in range(1, e.n):
                    x[k] = a[i] * x[k - 1] + (1 - a[i]) * e.u[k - 1, c]
                xs[:, i * m + c] = x
        X_parts.append(xs)
        Y_parts.append(e.y - e.y[:1])
    X, Y = np.concatenate(X_parts), np.concatenate(Y_parts)
    for j in range(Y.shape[1]):
        ok = np.isfinite(Y[:, j])
        coef, *_ = np.linalg.lstsq(X[ok], Y[ok, j], rcond=None)
        for i in range(n):
            th[model.param_index(f"C_{j}_{i}")] = coef[i * m]
            if j == 0:
                for c in range(1, m):
                    ratio = coef[i * m + c] / coef[i * m] if abs(coef[i * m]) > 1e-12 else 0.0
                    th[model.param_index(f"B_{i}_{c}")] = ratio * (1 - a[i])
    return th, fixed


# ------------------------------------------------------------------ helpers
def _nrmse_table(
    outputs: Sequence[str], ys: Sequence[NDArray], sims: Sequence[NDArray]
) -> dict[str, float]:
    if not ys:
        return {}
    Y = np.concatenate(ys)
    S = np.concatenate(sims)
    out = {o: float(nrmse(Y[:, j], S[:, j])) for j, o in enumerate(outputs)}
    vals = [v for v in out.values() if math.isfinite(v)]
    out["mean"] = float(np.mean(vals)) if vals else math.nan
    return out


def _wsse(ys, sims, w) -> tuple[float, int]:
    s, n = 0.0, 0
    for y, yh in zip(ys, sims, strict=True):
        e = (y - yh) * w[None, :]
        ok = np.isfinite(e)
        s += float(np.sum(e[ok] ** 2))
        n += int(ok.sum())
    return s, n


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


def _build_fit(
    model: Model,
    theta: NDArray[np.float64],
    outcome: FitOutcome | None,
    free: Sequence[str],
    bounds: dict[str, tuple[float, float]],
    *,
    method: str,
    settings: dict[str, Any],
    metrics: dict[str, Any],
    data: list[dict[str, Any]],
    notes: str,
) -> FitResult:
    stderr = {p: math.nan for p in model.param_names}
    cov, cov_names = None, []
    if outcome is not None:
        stderr.update({p: v for p, v in outcome.stderr.items() if p in stderr})
        if outcome.covariance is not None:
            cov = np.asarray(outcome.covariance).tolist()
            cov_names = list(outcome.free)
    b = {p.name: [p.lower, p.upper] for p in model.parameters}
    for p, (lo, hi) in bounds.items():
        if p in b:
            b[p] = [float(lo), float(hi)]
    # a fitted value may sit outside the model's declared bounds only if the fit widened them
    th = np.asarray(theta, dtype=float).reshape(-1)
    for i, p in enumerate(model.param_names):
        lo, hi = b[p]
        b[p] = [min(lo, float(th[i])), max(hi, float(th[i]))]
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
    min_explained: float = 0.25,
    scheme: str = "auto",
    max_candidates: int = 12,
    max_nfev: int = 25,
    sparse: bool = True,
    time_limit: float | None = None,
    progress: Callable[[str], None] | None = None,
) -> DiagnosisReport:
    """Locate a model mismatch, name the missing physics, model it, show the fit improve.

    Parameters
    ----------
    model : str or Model
        The nominal model: a registered thermogym model (``axt211``,
        ``strut``, ``spindle``, ...), ``foptd`` or ``ss:ORDER`` for any
        recording (with ``inputs`` and ``outputs``), or a model instance.
    train : Recording or sequence
        Training recordings (uniformly sampled; slightly uneven time stamps
        are resampled).
    validate : Recording or sequence
        Held-out recordings, at least one.
    params : FitResult, path or dict, optional
        Nominal parameters; the nominal model is fitted on ``train`` when
        omitted.
    model_config : mapping, optional
        Constructor arguments of a registered model.
    inputs, outputs : sequence of str, optional
        Generic models: exogenous and output columns. Plant models: the
        outputs to compare (default: every model output in the recordings).
    candidates : sequence of str, optional
        Effects to consider (default: every applicable effect).
    dt : float, optional
        Average the recordings onto this period [s] first (slow thermal data
        at 1 Hz: e.g. 60 s).
    alpha : float
        Significance level of the residual tests (Bonferroni-corrected over
        outputs and tests).
    max_lag : int
        Lags of the residual tests [samples].
    min_snr, min_rel : float
        Materiality: the systematic residual must reach ``min_snr`` × the
        noise level and ``min_rel`` × the output's spread.
    min_explained : float
        Least share of the systematic held-out error a winner must remove.
    scheme : {"auto", "split", "crossfit"}
        How hypotheses are scored on held-out data (module docstring).
    max_candidates : int
        Most hypotheses fitted (by signature score).
    max_nfev : int
        Cost evaluations per hypothesis fit.
    sparse : bool
        Try the sparse-regression fallback when no catalogued effect explains
        the mismatch.
    time_limit : float, optional
        Seconds after which no further hypothesis is started.
    progress : callable, optional
        Called with a line of text at each stage.

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
    >>> from thermogym.rigs import run_experiment
    >>> recs = run_experiment("strut", "steps", seed=0,
    ...                       effects=["sensor_offset:signal=T_nut,offset=1.0"])
    >>> rep = diagnose("strut", recs[:1], recs[1:])
    >>> rep.mismatch_detected, rep.best["effect"], rep.best["target"]
    (True, 'sensor_offset', 'T_nut')
    """
    t_start = time.perf_counter()
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
        unknown = [c for c in candidates if c not in CATALOGUE or c == "none"]
        if unknown:
            raise UnknownNameError(
                f"unknown effect(s) {unknown}; the vocabulary is "
                f"{[k for k in CATALOGUE if k != 'none']}"
            )
    nominal, name, config = resolve_model(
        model, tr_list[0], model_config=model_config, inputs=inputs, outputs=outputs
    )
    generic = isinstance(model, str) and model.partition(":")[0] in ("foptd", "ss")
    for i, r in enumerate([*tr_list, *va_list]):
        if not isinstance(r, Recording):
            raise RecordingError(
                f"item {i} of the recordings is a {type(r).__name__}; expected a Recording "
                "(read files with thermogym.recording.read_recording)"
            )
        r.validate_for(nominal, outputs=False)  # names the columns a recording of this model needs
    outs = [o for o in (outputs or nominal.output_names) if o in nominal.output_names]
    if outputs and not generic:
        bad = [o for o in outputs if o not in nominal.output_names]
        if bad:
            raise UnknownNameError(
                f"{bad} are not outputs of model {nominal.name!r}; outputs are "
                f"{list(nominal.output_names)}"
            )
    if not outputs:
        outs = [o for o in nominal.output_names if all(o in r.columns for r in tr_list + va_list)]
    if not outs:
        raise RecordingError(
            f"the recordings hold none of the outputs of model {nominal.name!r} "
            f"({list(nominal.output_names)}); columns are {list(tr_list[0].columns)}: are they "
            "recordings of another plant?"
        )
    # the model as the caller named it ('ss:3'), not its internal wrapper ('augmented')
    shown = model if isinstance(model, str) else name
    say(f"model {shown}: outputs {outs}")
    # generic linear models see measured disturbances as deviations from their first value
    # (the operating point), manipulated inputs as they are (at rest: zero before the start)
    dev = [s.name for s in nominal.disturbances] if generic else []
    tr = prepare_experiments(nominal, tr_list, outs, dt=dt, what="training", deviation=dev)
    va = prepare_experiments(nominal, va_list, outs, dt=dt, what="validation", deviation=dev)
    for e in [*tr, *va]:
        if e.n < _MIN_SAMPLES:
            raise RecordingError(
                f"recording {e.name!r} has {e.n} samples; diagnosis needs at least "
                f"{_MIN_SAMPLES} per recording (too short to fit or validate)"
            )
    notes = [n for e in tr + va for n in e.notes]
    weights = output_weights(tr)

    # ---- 1 nominal
    free, fixed, lo, hi, x0 = _nominal_problem(nominal, name, config, tr)
    theta0 = nominal.nominal.copy()
    for k, v in fixed.items():
        theta0[nominal.param_index(k)] = v
    nominal_outcome: FitOutcome | None = None
    if params is not None:
        fit_in = load_fit(params)
        if fit_in.model != name:
            hint = (
                f"; the nominal model of {shown!r} is fitted here when params (--params) is "
                "left out, or give the augmented FitResult (--augmented-fit) of an earlier "
                f"diagnosis with {shown!r}"
                if generic and name == "augmented"
                else f"; give a FitResult of {shown!r} or leave out params (--params)"
            )
            raise ConfigError(
                f"the FitResult (params, --params) is for model {fit_in.model!r}, not for the "
                f"diagnosed model {shown!r}{hint}"
            )
        nominal = fit_in.build_model()
        theta0 = fit_in.theta(nominal)[0]
        fixed = {
            p: float(theta0[nominal.param_index(p)])
            for p in fit_in.fixed
            if p in nominal.param_names
        }
        free = [p for p in nominal.param_names if p not in fixed]
        idx = [nominal.param_index(p) for p in free]
        lo, hi = nominal.lower[idx], nominal.upper[idx]
        config = nominal.config()
        method = "given"
    else:
        if generic:
            if name == "augmented":
                theta0, more = _ss_n4sid_start(nominal, tr) or _ss_start(nominal, tr)
                fixed.update(more)
                free = [p for p in free if p not in fixed]
                idx = [nominal.param_index(p) for p in free]
                lo, hi = nominal.lower[idx].copy(), nominal.upper[idx].copy()
            else:
                theta0 = _generic_start(nominal, name, tr)
            lo, hi = _refine_bounds(nominal, free, theta0, lo, hi, tr)
            theta0[[nominal.param_index(p) for p in free]] = np.clip(
                theta0[[nominal.param_index(p) for p in free]], lo, hi
            )
        n_free = len(free)
        n_obs = sum(e.n * len(outs) for e in tr)
        if n_obs < 5 * max(n_free, 1):
            raise RecordingError(
                f"the training recordings hold {n_obs} output samples for {n_free} parameters; "
                "too short to fit the nominal model (need at least 5 per parameter)"
            )
        say(f"fitting the nominal model ({n_free} parameters) on {len(tr)} recording(s)")
        pb = FitProblem(nominal, free, theta0, lo, hi, tr, weights, x0)
        nominal_outcome = fit_model(pb, max_nfev=max(max_nfev, 60) if not generic else 200)
        theta0 = nominal_outcome.theta
        method = "least_squares"
    bounds_nom = {p: (float(a), float(b)) for p, a, b in zip(free, lo, hi, strict=True)}

    # ---- 2 detect
    sims_tr = simulate_all(nominal, theta0, tr, x0)
    sims_va = simulate_all(nominal, theta0, va, x0)
    exo = list(nominal.exogenous_names)
    tests_tr = _tests(outs, tr, sims_tr, alpha, max_lag, exo)
    tests_va = _tests(outs, va, sims_va, alpha, max_lag, exo)
    alpha_adj = alpha / (len(outs) * (1 + len(exo)))
    sig_tr = {o: _significant(t, alpha_adj, min_snr, min_rel) for o, t in tests_tr.items()}
    sig_va = {o: _significant(t, alpha_adj, min_snr, min_rel) for o, t in tests_va.items()}
    detected = any(sig_tr.values()) or any(sig_va.values())
    say(
        "mismatch: "
        + (", ".join(o for o in outs if sig_tr[o] or sig_va[o]) if detected else "none significant")
    )

    # ---- 3 locate
    all_exps = [*tr, *va]
    roles = ["train"] * len(tr) + ["validation"] * len(va)
    all_sims = [*sims_tr, *sims_va]
    units = {s.name: s.unit for s in nominal.signals}
    sigma = {}
    for j, o in enumerate(outs):
        vals = [noise_sigma(e.y[:, j] - s[:, j]) for e, s in zip(all_exps, all_sims, strict=True)]
        vals = [v for v in vals if math.isfinite(v)]
        sigma[o] = float(np.sqrt(np.mean(np.square(vals)))) if vals else math.nan
    scale = {o: 1.0 / float(weights[j]) for j, o in enumerate(outs)}
    regs = regime_variables(
        [e.name for e in all_exps],
        roles,
        units,
        [(c, [e.u[:, i] for e in all_exps]) for i, c in enumerate(exo)],
        [(o, [s[:, j] for s in all_sims]) for j, o in enumerate(outs)],
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
    located = locate(outs, recs_loc, regs, sigma, scale)

    fit_before_tr = _nrmse_table(outs, [e.y for e in tr], sims_tr)
    fit_before_va = _nrmse_table(outs, [e.y for e in va], sims_va)
    data = [data_entry(r, "train") for r in tr_list] + [
        data_entry(r, "validation") for r in va_list
    ]
    nominal_fit = _build_fit(
        nominal,
        theta0,
        nominal_outcome,
        free,
        bounds_nom,
        method=f"diagnosis nominal ({method})",
        settings={"x0": x0, "weights": dict(zip(outs, weights.tolist(), strict=True)), "dt": dt},
        metrics={"train": {"nrmse": fit_before_tr}, "validation": {"nrmse": fit_before_va}},
        data=data,
        notes="nominal model of thermogym diagnosis",
    )
    report = DiagnosisReport(
        model=name,
        model_config=config,
        outputs=list(outs),
        exogenous=exo,
        units=units,
        mismatch_detected=detected,
        alpha=alpha,
        detection={
            "train": {
                o: {**t.to_dict(alpha_adj), "significant": sig_tr[o]} for o, t in tests_tr.items()
            },
            "validation": {
                o: {**t.to_dict(alpha_adj), "significant": sig_va[o]} for o, t in tests_va.items()
            },
            "alpha_per_test": alpha_adj,
            "materiality": {"min_snr": min_snr, "min_rel": min_rel},
        },
        located=located,
        nominal_fit=nominal_fit,
        fit_before={"train": fit_before_tr, "validation": fit_before_va},
        notes=notes,
    )
    report.series = [
        {"name": e.name, "role": r, "time": e.time, "measured": e.y, "nominal": s, "u": e.u}
        for e, r, s in zip(all_exps, roles, all_sims, strict=True)
    ]
    report.regime_values = regs
    report.tests_before = {"train": tests_tr, "validation": tests_va}
    if not detected:
        report.best = {
            "effect": "none",
            "target": "",
            "explanation": CATALOGUE["none"].explanation,
        }
        report.seconds = time.perf_counter() - t_start
        say("no significant mismatch: effect 'none'")
        return report

    # ---- 4 explain
    share = {d["signal"]: d["share_of_error"] for d in located["signals"]}
    ctx = Context(
        model=nominal,
        model_name=name,
        model_config=config,
        theta=theta0,
        free=tuple(free),
        fixed=fixed,
        outputs=tuple(outs),
        units=units,
        roles={s.name: s.role for s in nominal.signals},
        time=[e.time for e in all_exps],
        dt=[e.dt for e in all_exps],
        u=[e.u for e in all_exps],
        y=[e.y for e in all_exps],
        sim=all_sims,
        is_train=[r == "train" for r in roles],
        sigma=sigma,
        scale=scale,
        share=share,
        regimes=located["all_regimes"],
    )
    feats = signatures(ctx)
    cands = candidates_for(ctx, feats)
    if candidates is not None:
        cands = [c for c in cands if c.effect in candidates]
    cands = cands[:max_candidates]
    train_material = any(sig_tr.values())
    use = scheme
    if scheme == "auto":
        use = "crossfit" if (not train_material and len(va) >= 2) else "split"
    if use == "crossfit" and len(va) < 2:
        raise ConfigError("scheme 'crossfit' needs at least two validation recordings")
    report.scheme = use
    say(f"fitting {len(cands)} hypotheses ({use})")
    deadline = None if time_limit is None else t_start + time_limit
    hyps = _explain(
        ctx, cands, tr, va, weights, x0, bounds_nom, use, max_nfev, deadline, sigma, say
    )
    # sparse-regression fallback
    s0_va, n_va = _wsse([e.y for e in va], _heldout_nominal(hyps, sims_va), weights)
    floor = sum(
        float(weights[j] ** 2) * sigma[o] ** 2 * sum(int(np.isfinite(e.y[:, j]).sum()) for e in va)
        for j, o in enumerate(outs)
        if math.isfinite(sigma[o])
    )
    for h in hyps:
        _score(h, s0_va, n_va, floor)
    hyps.sort(key=lambda h: -h["score"] if math.isfinite(h["score"]) else math.inf)
    winners = [h for h in hyps if h["score"] > 0 and h["explained"] >= min_explained]
    if not winners and sparse:
        say("no catalogued effect explains the residual: sparse regression")
        from thermogym.identification.diagnosis.sindy import sparse_hypothesis

        h = sparse_hypothesis(ctx, tr, va, weights, x0, bounds_nom, use, max_nfev, say)
        if h is not None:
            _score(h, s0_va, n_va, floor)
            hyps.append(h)
            hyps.sort(key=lambda h: -h["score"] if math.isfinite(h["score"]) else math.inf)
            if h["score"] > 0 and h["explained"] >= min_explained:
                winners = [h]
    report.signatures = feats
    report.hypotheses = hyps
    if winners:
        best = winners[0]
        report.best = {k: v for k, v in best.items() if not k.startswith("_")}
        _finalise_best(
            report,
            best,
            ctx=ctx,
            tr=tr,
            va=va,
            tr_list=tr_list,
            va_list=va_list,
            weights=weights,
            x0=x0,
            alpha_adj=alpha_adj,
            max_lag=max_lag,
            data=data,
            scheme=use,
            max_nfev=max_nfev,
        )
    else:
        report.best = {
            "effect": "unexplained",
            "target": "",
            "explanation": "A significant mismatch remains that none of the hypotheses tried "
            "explains on held-out data: the model lacks something outside the catalogue, or the "
            "data cannot separate the candidates (see the ranked hypotheses).",
        }
    report.seconds = time.perf_counter() - t_start
    say(f"best: {report.best['effect']} ({report.seconds:.1f} s)")
    return report


def _heldout_nominal(hyps: list[dict[str, Any]], sims_va: list[NDArray]) -> list[NDArray]:
    # in the cross-fit scheme the nominal's held-out predictions come from the folds
    for h in hyps:
        if "_nominal_heldout" in h:
            return h["_nominal_heldout"]
    return sims_va


def _score(h: dict[str, Any], s0: float, n: int, floor: float) -> None:
    s = h["_wsse_val"]
    k = h["n_extra"]
    if not (math.isfinite(s) and s > 0 and s0 > 0):
        h["score"], h["delta_bic"], h["explained"] = -math.inf, math.inf, 0.0
        return
    dbic = n * math.log(s / s0) + k * math.log(max(n, 2))
    h["delta_bic"] = float(dbic)
    h["score"] = float(-dbic)
    h["explained"] = float((s0 - s) / max(s0 - floor, 1e-12 * s0)) if s0 > floor else 0.0
    h["validation_sse_reduction"] = float(1.0 - s / s0)


def _candidate_problem(
    cand: Candidate,
    ctx: Context,
    exps: list[Experiment],
    weights: NDArray[np.float64],
    x0: str,
    bounds_nom: dict[str, tuple[float, float]],
    theta_nom: NDArray[np.float64] | None = None,
    *,
    extras_only: bool = False,
    extra_start: Mapping[str, float] | None = None,
) -> tuple[Model, FitProblem, list[NDArray[np.float64]]]:
    model = get_model(cand.model_name, **cand.model_config)
    fit_with = fast_or_none(model) or model  # fast path for stepped inputs (fastnet.py)
    th_nom = ctx.theta if theta_nom is None else theta_nom
    base = model.nominal.copy()
    for i, p in enumerate(ctx.model.param_names):
        if p in model.param_names:
            base[model.param_index(p)] = th_nom[i]
    for p, (start, _, _) in cand.extra.items():
        base[model.param_index(p)] = start
    for p, v in (extra_start or {}).items():
        base[model.param_index(p)] = v
    nominal_free = [] if extras_only else [p for p in ctx.free if p in model.param_names]
    free = nominal_free + list(cand.extra)
    lo = np.array([bounds_nom[p][0] if p in bounds_nom else cand.extra[p][1] for p in free])
    hi = np.array([bounds_nom[p][1] if p in bounds_nom else cand.extra[p][2] for p in free])
    pb = FitProblem(fit_with, free, base, lo, hi, exps, weights, x0)
    starts = []
    if extra_start is None:
        # the nominal fit compensated the missing effect: also start from the model's own
        # (physical) values of the nominal parameters
        prior = base.copy()
        for p in nominal_free:
            prior[model.param_index(p)] = model.nominal[model.param_index(p)]
        for b0 in (base, prior) if nominal_free else (base,):
            for alt in [{}, *cand.starts]:
                v = b0[[model.param_index(p) for p in free]].copy()
                for p, val in alt.items():
                    v[free.index(p)] = val
                starts.append(np.clip(v, lo, hi))
        starts = starts[1:]  # the first is the default start
    return model, pb, starts


def _fit_candidate(
    cand: Candidate,
    ctx: Context,
    tr: list[Experiment],
    va: list[Experiment],
    weights: NDArray[np.float64],
    x0: str,
    bounds_nom: dict[str, tuple[float, float]],
    scheme: str,
    folds: list[Any],
    max_nfev: int,
    deadline: float | None,
    *,
    extras_only: bool = False,
    extra_start: Mapping[str, float] | None = None,
) -> dict[str, Any]:
    t0 = time.perf_counter()
    outs = list(ctx.outputs)
    kw = {"extras_only": extras_only, "extra_start": extra_start}
    try:
        model, pb, starts = _candidate_problem(cand, ctx, tr, weights, x0, bounds_nom, **kw)
        if scheme == "split":
            out = fit_model(pb, starts=starts, max_nfev=max_nfev, deadline=deadline)
            sims_tr = simulate_all(pb.model, out.theta, tr, x0)
            sims_va = simulate_all(pb.model, out.theta, va, x0)
            theta = out.theta
        else:
            held = []
            for k, fit_set, th_fold, _ in folds:
                m2, pb2, st2 = _candidate_problem(
                    cand, ctx, fit_set, weights, x0, bounds_nom, th_fold, **kw
                )
                o2 = fit_model(pb2, starts=st2, max_nfev=max_nfev, deadline=deadline)
                held.append(simulate_all(m2, o2.theta, [va[k]], x0)[0])
            # the model reported: fitted on every recording
            pb_all = FitProblem(
                model, pb.free, pb.base, pb.lower, pb.upper, [*tr, *va], weights, x0
            )
            out = fit_model(pb_all, starts=starts, max_nfev=max_nfev, deadline=deadline)
            theta = out.theta
            sims_tr = simulate_all(model, theta, tr, x0)
            sims_va = held
    except Exception as e:  # a hypothesis that cannot be fitted is reported, not fatal
        return {
            "effect": cand.effect,
            "target": cand.target,
            "explanation": CATALOGUE[cand.effect].explanation,
            "evidence": cand.evidence,
            "error": f"{type(e).__name__}: {e}",
            "n_extra": len(cand.extra),
            "_wsse_val": math.nan,
            "seconds": time.perf_counter() - t0,
            "_candidate": cand,
        }
    s_va, _ = _wsse([e.y for e in va], sims_va, weights)
    params = {
        p: {
            "value": out.values[p],
            "stderr": out.stderr.get(p, math.nan),
            "unit": model.parameters[model.param_index(p)].unit,
            "description": model.parameters[model.param_index(p)].description,
        }
        for p in cand.extra
    }
    h = {
        "effect": cand.effect,
        "target": cand.target,
        "explanation": CATALOGUE[cand.effect].explanation,
        "evidence": cand.evidence,
        "augmentation": CATALOGUE[cand.effect].augmentation,
        "params": params,
        "n_extra": len(cand.extra),
        "refitted_nominal": not extras_only,
        "fit_before": _nrmse_table(outs, [e.y for e in tr], ctx.sim[: len(tr)]),
        "fit_after": _nrmse_table(outs, [e.y for e in tr], sims_tr),
        "validation_before": _nrmse_table(
            outs,
            [e.y for e in va],
            [f[3] for f in folds] if scheme == "crossfit" else ctx.sim[len(tr) :],
        ),
        "validation_after": _nrmse_table(outs, [e.y for e in va], sims_va),
        "at_bounds": [p for p in out.at_bounds if p in cand.extra],
        "signature_score": cand.prior,
        "seconds": time.perf_counter() - t0,
        "_wsse_val": s_va,
        "_model": model,
        "_theta": theta,
        "_outcome": out,
        "_free": list(pb.free),
        "_bounds": {
            p: (float(a), float(b)) for p, a, b in zip(pb.free, pb.lower, pb.upper, strict=True)
        },
        "_sims_tr": sims_tr,
        "_sims_va": sims_va,
        "_candidate": cand,
    }
    if scheme == "crossfit":
        h["_nominal_heldout"] = [f[3] for f in folds]
    return h


def _integrated_by_rk4(model: Model) -> bool:
    """Whether a candidate is an RC network that must be integrated by RK4 (slow)."""
    from thermogym.models.thermal_network import ThermalNetworkModel

    return isinstance(model, ThermalNetworkModel) and switched_or_none(model) is None


def _explain(
    ctx,
    cands,
    tr,
    va,
    weights,
    x0,
    bounds_nom,
    scheme,
    max_nfev,
    deadline,
    sigma,
    say,
    refine: int = 1,
):
    """Fit every candidate; expensive ones are screened first and refined if promising.

    A hypothesis an RC network can only integrate by fixed-step RK4 (today:
    ``nonlinear_heat_transfer``) over long training data (more than
    ``_SCREEN_SAMPLES`` samples) is first fitted with only its extra
    parameters free — a Jacobian of k + 1 simulations instead of P + k + 1.
    If its held-out error then ranks among the best ``refine``, it is refitted
    with every nominal parameter free, since a missing effect biases the
    nominal fit. (The rule depends on the model and the data only, so the
    diagnosis stays deterministic.)
    """
    folds: list[Any] = []
    if scheme == "crossfit":
        for k in range(len(va)):
            fit_set = [*tr, *[e for i, e in enumerate(va) if i != k]]
            # the nominal refitted on the fold's data: the "before" of the held-out recording
            free = list(ctx.free)
            pb = FitProblem(
                ctx.model,
                free,
                ctx.theta,
                [bounds_nom[p][0] for p in free],
                [bounds_nom[p][1] for p in free],
                fit_set,
                weights,
                x0,
            )
            out = fit_model(pb, max_nfev=max_nfev)
            folds.append(
                (k, fit_set, out.theta, simulate_all(ctx.model, out.theta, [va[k]], x0)[0])
            )
    hyps: list[dict[str, Any]] = []
    screened: list[dict[str, Any]] = []
    n_train = sum(e.n for e in tr)
    for cand in cands:
        if deadline is not None and time.perf_counter() > deadline:
            say(f"time limit: {cand.label} not fitted")
            continue
        screen = False
        if scheme == "split" and ctx.free and n_train > _SCREEN_SAMPLES:
            try:
                screen = _integrated_by_rk4(get_model(cand.model_name, **cand.model_config))
            except Exception:  # the fit below reports the failure
                screen = False
        h = _fit_candidate(
            cand,
            ctx,
            tr,
            va,
            weights,
            x0,
            bounds_nom,
            scheme,
            folds,
            min(max_nfev, 12) if screen else max_nfev,
            deadline,
            extras_only=screen,
        )
        h["screened"] = screen
        hyps.append(h)
        if screen:
            screened.append(h)
        if "error" in h:
            say(f"{cand.label}: failed ({h['error']})")
        else:
            say(
                f"{cand.label}: held-out mean NRMSE {h['validation_before']['mean']:.4f} → "
                f"{h['validation_after']['mean']:.4f} ({h['seconds']:.1f} s"
                + (", extra parameters only)" if screen else ")")
            )
    ok = sorted((h for h in hyps if math.isfinite(h["_wsse_val"])), key=lambda h: h["_wsse_val"])
    for h in [h for h in ok[:refine] if h in screened]:
        if deadline is not None and time.perf_counter() > deadline:
            break
        cand = h["_candidate"]
        start = {p: v["value"] for p, v in h["params"].items()}
        h2 = _fit_candidate(
            cand,
            ctx,
            tr,
            va,
            weights,
            x0,
            bounds_nom,
            scheme,
            folds,
            min(max_nfev, 15),
            deadline,
            extra_start=start,
        )
        if "error" not in h2:
            h2["seconds"] += h["seconds"]
            h2["screened"] = False
            hyps[hyps.index(h)] = h2
            say(
                f"{cand.label}: refitted with the nominal parameters: held-out mean NRMSE "
                f"{h2['validation_after']['mean']:.4f} ({h2['seconds']:.1f} s)"
            )
    return hyps


def _finalise_best(
    report,
    best,
    *,
    ctx,
    tr,
    va,
    tr_list,
    va_list,
    weights,
    x0,
    alpha_adj,
    max_lag,
    data,
    scheme,
    max_nfev,
):
    model = best["_model"]
    theta = best["_theta"]
    outs = list(ctx.outputs)
    exo = list(ctx.exogenous)
    tests_tr = _tests(outs, tr, best["_sims_tr"], report.alpha, max_lag, exo)
    tests_va = _tests(outs, va, best["_sims_va"], report.alpha, max_lag, exo)
    report.detection_after = {
        "train": {o: t.to_dict(alpha_adj) for o, t in tests_tr.items()},
        "validation": {o: t.to_dict(alpha_adj) for o, t in tests_va.items()},
    }
    report.tests_after = {"train": tests_tr, "validation": tests_va}
    for s, sim in zip(report.series, [*best["_sims_tr"], *best["_sims_va"]], strict=True):
        s["augmented"] = sim
    if isinstance(model, AugmentedModel) and any(
        a["effect"] == "transport_delay" for a in model.augmentations
    ):
        # keep enough input history for step-wise use of the fitted delay
        cfg = model.config()
        dtm = min(e.dt for e in tr)
        for a in cfg["augmentations"]:
            if a["effect"] == "transport_delay":
                d = float(theta[model.param_index(f"delay_{a['signal']}")])
                a["history"] = math.ceil(d / dtm) + 2
        if cfg["base"] not in model_names():  # a user's own model: rebuild around the instance
            cfg = {"base": ctx.model, "augmentations": cfg["augmentations"]}
        model = AugmentedModel(**cfg)
    fit = _build_fit(
        model,
        theta,
        best["_outcome"],
        best["_free"],
        best["_bounds"],
        method=f"thermogym diagnosis: {best['effect']}",
        settings={
            "effect": best["effect"],
            "target": best["target"],
            "x0": x0,
            "scheme": scheme,
            "nominal_model": ctx.model_name,
            "nominal_config": ctx.model_config,
        },
        metrics={
            "train": {"nrmse": best["fit_after"]},
            "validation": {"nrmse": best["validation_after"]},
        },
        data=data,
        notes=best["explanation"],
    )
    report.augmented_fit = fit
