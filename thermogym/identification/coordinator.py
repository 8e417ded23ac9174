"""The identification coordinator: one workflow for every model type (paper 000).

``000_24627a5308ee07db.txt`` describes a coordinator that identifies the
parameters of models built in other tools "without converting them", with the
same workflow for every model type (section 3): choose the data and the signal
pairs, the parameters with bounds and start values, the criterion (eq 4), the
method and the stop criteria, and run. Here every model is a
:class:`~thermogym.identification.simmodel.SimModel` — thermogym's batched
models and the external adapters alike — set up as a
:class:`~thermogym.identification.problem.Problem`, and

>>> from thermogym.rigs import run_experiment
>>> from thermogym.models.strut import StrutModel
>>> from thermogym.identification.problem import Problem
>>> recs = run_experiment("strut", "steps", feed_rates=[20.0], seed=0)
>>> pb = Problem(StrutModel(), recs, pairs=["T_nut"], free=["r_nut", "r_spindle_air"])
>>> res = run_identification(pb, "greybox", progress=False)
>>> i = pb.names.index("r_nut")  # bounded by paper 000's stated range of a loss ratio
>>> float(pb.lower[i]), float(pb.upper[i])
(0.3, 3.0)
>>> res.stop_reason.startswith("converged"), bool(0.3 <= res.values["r_nut"] <= 3.0)
(True, True)
>>> fit = res.fit          # the FitResult (JSON contract); identify() returns it directly

Methods
-------
==============  ===========================================================================
``greybox``     bounded Gauss-Newton / Levenberg-Marquardt / trust region
                (:func:`scipy.optimize.least_squares`), finite-difference Jacobian
                simulated as one batch or exact forward sensitivities (paper 002, III)
``montecarlo``  random search in the bounds (paper 000, the strut's ratio parameters)
``anneal``      simulated annealing, a population of chains per batch
``evolution``   differential evolution (scipy, vectorised)
``cmaes``       CMA-ES (``cma``)
==============  ===========================================================================

Stop criteria (each ends a run): ``max_iter``, ``max_evals``, ``time_limit``
[s] and ``target`` — the quality limit on the criterion that paper 000 says
"could be added easily". A ``KeyboardInterrupt`` ends the run too and keeps
the best result. A parameter set whose simulation fails is reported (message
and values) and the search goes on; if nothing simulates, an
:class:`~thermogym.errors.IdentificationError` says why.

After the search the coordinator computes, at the best parameters, the fit
metrics per experiment, the parameter covariance and confidence intervals from
the Jacobian and an identifiability ranking
(:mod:`~thermogym.identification.uncertainty`), and writes everything into a
:class:`~thermogym.fitresult.FitResult`.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from thermogym._fileio import atomic_write_text, to_jsonable
from thermogym.errors import ConfigError, IdentificationError, ThermogymError
from thermogym.fitresult import FitResult, data_entry
from thermogym.identification.optimizers.base import HistoryEntry, StopCriteria, StopSearch, Tracker
from thermogym.identification.optimizers.local import LEAST_SQUARES_OPTIONS, run_least_squares
from thermogym.identification.optimizers.stochastic import (
    ANNEAL_OPTIONS,
    CMAES_OPTIONS,
    EVOLUTION_OPTIONS,
    MONTECARLO_OPTIONS,
    run_anneal,
    run_cmaes,
    run_evolution,
    run_monte_carlo,
)
from thermogym.identification.problem import Problem
from thermogym.identification.simmodel import ThermogymModel
from thermogym.identification.uncertainty import (
    Identifiability,
    ParameterUncertainty,
    problem_identifiability,
    problem_uncertainty,
)
from thermogym.recording import Recording

__all__ = [
    "METHODS",
    "IdentificationResult",
    "Method",
    "identify",
    "run_identification",
]


@dataclass(frozen=True)
class Method:
    """An optimiser the coordinator can run.

    Attributes
    ----------
    name : str
    run : callable
        ``run(problem, tracker, rng, **options) -> dict``.
    options : dict
        Accepted options and their defaults.
    local : bool
        Gradient-based (minimises the least-squares cost).
    default_stop : StopCriteria
        Used when the caller gives no stop criterion.
    description : str
    """

    name: str
    run: Callable[..., dict[str, Any]]
    options: dict[str, Any]
    local: bool
    default_stop: StopCriteria
    description: str


#: The methods by name (``thermogym identify METHOD``).
METHODS: dict[str, Method] = {
    "greybox": Method(
        "greybox",
        run_least_squares,
        LEAST_SQUARES_OPTIONS,
        True,
        StopCriteria(max_iter=100),
        "bounded Gauss-Newton / Levenberg-Marquardt / trust region (paper 002, section III)",
    ),
    "montecarlo": Method(
        "montecarlo",
        run_monte_carlo,
        MONTECARLO_OPTIONS,
        False,
        StopCriteria(),
        "Monte Carlo search in the bounds (paper 000, section 4.2.4)",
    ),
    "anneal": Method(
        "anneal",
        run_anneal,
        ANNEAL_OPTIONS,
        False,
        StopCriteria(max_iter=300),
        "simulated annealing, a population of Metropolis chains",
    ),
    "evolution": Method(
        "evolution",
        run_evolution,
        EVOLUTION_OPTIONS,
        False,
        StopCriteria(max_iter=200),
        "differential evolution (scipy, whole generation per batch)",
    ),
    "cmaes": Method(
        "cmaes",
        run_cmaes,
        CMAES_OPTIONS,
        False,
        StopCriteria(max_iter=300),
        "CMA-ES (cma package)",
    ),
}


@dataclass
class IdentificationResult:
    """Outcome of a coordinator run: best parameters, history, uncertainty, FitResult.

    Attributes
    ----------
    method : str
    names : tuple of str
        Optimiser variables (free parameters and ratios).
    x : ndarray, shape (P,)
        Best optimiser vector.
    values : dict
        ``x`` by name.
    parameters : dict
        Every SimModel parameter at the best point (ratios applied).
    criterion : float
        eq (4) of paper 000 at the best point.
    mse : float
        ``Σ_j w_j MSE_j`` at the best point.
    stop_reason : str
        ``"max_iter"``, ``"max_evals"``, ``"time_limit"``, ``"target"``,
        ``"interrupted"``, ``"callback"``, ``"completed"`` or ``"converged: …"``.
    iterations, evaluations, simulations, sensitivity_runs, failed : int
        Work done: iterations, parameter sets evaluated, simulations (sets ×
        experiments), simulations with exact sensitivities, failed sets.
    failures : list of dict
        The first failed sets (``parameters``, ``message``).
    failure_messages : dict
        Message → count.
    elapsed_s : float
    history : list of HistoryEntry
    uncertainty : ParameterUncertainty or None
    identifiability : Identifiability or None
    metrics : dict
        ``{"train": …, "validation": …}`` fit metrics.
    samples : tuple of arrays, optional
        Every evaluated set ``(z, cost, pair_rmse)`` when kept.
    info : dict
        What the optimiser reported.
    fit : FitResult
    problem : Problem
    """

    method: str
    names: tuple[str, ...]
    x: NDArray[np.float64]
    values: dict[str, float]
    parameters: dict[str, float]
    criterion: float
    mse: float
    stop_reason: str
    iterations: int
    evaluations: int
    simulations: int
    sensitivity_runs: int
    failed: int
    failures: list[dict[str, Any]]
    failure_messages: dict[str, int]
    elapsed_s: float
    history: list[HistoryEntry]
    uncertainty: ParameterUncertainty | None
    identifiability: Identifiability | None
    metrics: dict[str, Any]
    fit: FitResult
    problem: Problem = field(repr=False)
    samples: tuple[NDArray[np.float64], ...] | None = field(default=None, repr=False)
    info: dict[str, Any] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)

    def validate(self, recordings: Recording | Sequence[Recording]) -> dict[str, Any]:
        """Fit metrics of the best parameters on other recordings (added to the FitResult).

        Returns
        -------
        dict
            ``{experiment_id: fit_report, "criterion": …, "pair_rmse": …}``.
        """
        recs = [recordings] if isinstance(recordings, Recording) else list(recordings)
        m = self.problem.metrics(self.x, recs)
        self.metrics.setdefault("validation", {}).update(m)
        self.fit.metrics.setdefault("validation", {}).update(to_jsonable(m))
        known = {d.get("fingerprint") for d in self.fit.data}
        for r in recs:
            d = data_entry(r, "validation")
            if d["fingerprint"] not in known:
                self.fit.data.append(d)
        return m

    def to_dict(self) -> dict[str, Any]:
        """Summary, history and uncertainty as JSON types (no FitResult)."""
        return to_jsonable(
            {
                "method": self.method,
                "values": self.values,
                "parameters": self.parameters,
                "criterion": self.criterion,
                "mse": self.mse,
                "stop_reason": self.stop_reason,
                "iterations": self.iterations,
                "evaluations": self.evaluations,
                "simulations": self.simulations,
                "sensitivity_runs": self.sensitivity_runs,
                "failed": self.failed,
                "failures": self.failures,
                "failure_messages": self.failure_messages,
                "elapsed_s": self.elapsed_s,
                "history": [vars(h) for h in self.history],
                "uncertainty": None if self.uncertainty is None else self.uncertainty.to_dict(),
                "identifiability": (
                    None if self.identifiability is None else self.identifiability.to_dict()
                ),
                "metrics": self.metrics,
                "info": self.info,
                "notes": self.notes,
            }
        )

    def save_history(self, path: str | os.PathLike[str]) -> Path:
        """Write :meth:`to_dict` as JSON, atomically."""
        text = json.dumps(self.to_dict(), indent=2, allow_nan=False) + "\n"
        return atomic_write_text(path, text)

    def summary(self) -> str:
        """Human-readable table of the result."""
        u = self.uncertainty
        lines = [
            f"method {self.method}: {self.stop_reason}; {self.iterations} iterations, "
            f"{self.evaluations} parameter sets, {self.simulations} simulations"
            + (f" + {self.sensitivity_runs} with sensitivities" if self.sensitivity_runs else "")
            + f", {self.failed} failed, {self.elapsed_s:.2f} s",
            f"criterion (eq 4) {self.criterion:.6g}, weighted MSE {self.mse:.6g}",
        ]
        head = f"  {'parameter':<16} {'value':>12}"
        if u is not None:
            pct = round(100 * u.level)
            head += f" {'stderr':>11} {f'{pct}% interval':>27}"
        lines.append(head)
        for i, n in enumerate(self.names):
            row = f"  {n:<16} {self.x[i]:>12.6g}"
            if u is not None:
                row += f" {u.stderr[i]:>11.3g} [{u.lower[i]:>12.6g}, {u.upper[i]:>12.6g}]"
            lines.append(row)
        for note in self.notes:
            lines.append(f"note: {note}")
        return "\n".join(lines)


def _check_options(method: Method, options: dict[str, Any]) -> dict[str, Any]:
    unknown = sorted(set(options) - set(method.options))
    if unknown:
        raise ConfigError(
            f"method {method.name!r} has no option(s) {unknown}; its options are "
            f"{sorted(method.options)} plus the common ones (seed, max_iter, max_evals, "
            "time_limit, target, progress, callback, uncertainty, level, polish, validation, "
            "keep_samples, identifiability, input_noise, input_prepare)"
        )
    return {**method.options, **options}


def _stop(method: Method, **given: Any) -> StopCriteria:
    if all(v is None for v in given.values()):
        return method.default_stop
    return StopCriteria(**given)


def _run_search(
    problem: Problem,
    method: Method,
    options: dict[str, Any],
    stop: StopCriteria,
    rng: np.random.Generator,
    *,
    progress: bool | None,
    callback: Callable[[HistoryEntry], bool | None] | None,
    keep_samples: bool,
    start: NDArray[np.float64] | None = None,
) -> tuple[Tracker, str, dict[str, Any]]:
    total = None
    if method.name == "montecarlo":
        n = min(options["n_samples"], stop.max_evals or options["n_samples"])
        total = math.ceil(n / options["batch_size"]) if options["batch_size"] > 0 else None
    tracker = Tracker(
        problem,
        stop,
        cost="mse" if method.local else problem.objective,
        method=method.name,
        progress=progress,
        callback=callback,
        keep_samples=keep_samples,
        total=total,
    )
    info: dict[str, Any] = {}
    try:
        if method.local:
            info = method.run(problem, tracker, rng, start=start, **options)
            reason = f"converged: {info.get('message', '')}".rstrip(": ")
        else:
            info = method.run(problem, tracker, rng, **options)
            reason = "completed" if method.name == "montecarlo" else "converged"
            if "message" in info:
                reason = f"converged: {info['message']}"
    except StopSearch as s:
        reason = s.reason
    except KeyboardInterrupt:
        reason = "interrupted"
    finally:
        tracker.close()
    return tracker, reason, info


def run_identification(
    problem: Problem,
    method: str = "greybox",
    *,
    seed: int | None = 0,
    max_iter: int | None = None,
    max_evals: int | None = None,
    time_limit: float | None = None,
    target: float | None = None,
    progress: bool | None = None,
    callback: Callable[[HistoryEntry], bool | None] | None = None,
    uncertainty: bool = True,
    identifiability: bool = True,
    level: float = 0.95,
    polish: bool = False,
    keep_samples: bool | None = None,
    validation: Sequence[Recording] | None = None,
    input_noise: Mapping[str, float] | None = None,
    input_prepare: Callable[[Recording], Recording] | None = None,
    **options: Any,
) -> IdentificationResult:
    """Identify the problem's parameters with ``method``; return the full result.

    Parameters
    ----------
    problem : Problem
        Model, data, signal pairs, parameters.
    method : str
        A key of :data:`METHODS`.
    seed : int, optional
        Seed of every random choice (same seed, same result).
    max_iter, max_evals, time_limit, target
        Stop criteria (:class:`StopCriteria`); any one ends the run. Without
        any, the method's default applies (e.g. 100 Gauss-Newton iterations,
        10 000 Monte Carlo samples).
    progress : bool, optional
        Progress bar with the best criterion (default: when stderr is a terminal).
    callback : callable, optional
        ``callback(HistoryEntry) -> bool``; True stops the run.
    uncertainty : bool
        Compute covariance and confidence intervals at the best point.
    identifiability : bool
        Rank the parameters (importance, collinearity) at the best point.
    level : float
        Confidence level of the intervals.
    polish : bool
        After a global method, refine its best point with ``greybox``.
    keep_samples : bool, optional
        Keep every evaluated set (default: for ``montecarlo``).
    validation : sequence of Recording, optional
        Recordings for validation metrics.
    input_noise : mapping, optional
        Noise standard deviation of measured input columns; its effect on the
        parameters is added to the covariance (errors in variables, see
        :func:`~thermogym.identification.uncertainty.problem_uncertainty`).
    input_prepare : callable, optional
        The preparation the inputs went through (applied to the replicates).
    **options
        Options of the method (see its ``*_OPTIONS`` defaults); unknown ones
        raise :class:`ConfigError`. For ``greybox``: ``jac`` (``"auto"``,
        ``"fd"``, ``"exact"``), ``diff``, ``fd_step``, ``solver``, ``loss``,
        tolerances.

    Returns
    -------
    IdentificationResult

    Raises
    ------
    ConfigError
        Unknown method or option, bad stop criteria.
    IdentificationError
        No parameter set simulated, or the run ended before any was evaluated.
    """
    try:
        m = METHODS[method]
    except KeyError:
        raise ConfigError(f"unknown method {method!r}; methods are {sorted(METHODS)}") from None
    if not isinstance(problem, Problem):
        raise ConfigError(f"problem is a {type(problem).__name__}, expected a Problem")
    opts = _check_options(m, options)
    stop = _stop(m, max_iter=max_iter, max_evals=max_evals, time_limit=time_limit, target=target)
    rng = np.random.default_rng(seed)
    keep = (method == "montecarlo") if keep_samples is None else bool(keep_samples)
    c0 = problem.counters.as_dict()
    tracker, reason, info = _run_search(
        problem, m, opts, stop, rng, progress=progress, callback=callback, keep_samples=keep
    )
    history = list(tracker.history)
    trackers = [tracker]
    notes: list[str] = []
    if tracker.best_z is None:
        top = "; ".join(f"{m} ({n}x)" for m, n in tracker.failure_messages.most_common(3))
        raise IdentificationError(
            f"the {method} run on model {problem.model.name!r} ended ({reason}) and none of "
            f"the {tracker.n_evaluated} parameter sets evaluated simulated"
            + (f"; most frequent errors: {top}" if top else "")
        )
    if polish and not m.local and reason != "interrupted":
        left = None if time_limit is None else max(time_limit - tracker.elapsed, 1e-3)
        gb = METHODS["greybox"]
        t2, r2, info2 = _run_search(
            problem,
            gb,
            dict(gb.options),
            StopCriteria(max_iter=50, time_limit=left),
            rng,
            progress=progress,
            callback=callback,
            keep_samples=False,
            start=tracker.best_z,
        )
        trackers.append(t2)
        info = {**info, "polish": {**info2, "stop_reason": r2}}
        off = history[-1] if history else None
        for h in t2.history:
            history.append(
                HistoryEntry(
                    h.iteration + (off.iteration if off else 0),
                    h.evaluations + (off.evaluations if off else 0),
                    h.simulations + (off.simulations if off else 0),
                    h.best,
                    h.current,
                    h.elapsed_s + (off.elapsed_s if off else 0.0),
                )
            )
        reason = f"{reason}; polished ({r2})"
    # the best point: by the problem's objective over every stage
    cands = [t.best_z for t in trackers if t.best_z is not None]
    evs = problem.evaluate(np.array(cands))
    k = int(np.argmin(evs.cost(problem.objective if not m.local else "mse")))
    z = np.array(cands[k])
    train = problem.metrics(z)
    unc: ParameterUncertainty | None = None
    idf: Identifiability | None = None
    if reason == "interrupted" and (uncertainty or identifiability):
        notes.append("interrupted: no uncertainty or identifiability computed")
    elif uncertainty or identifiability:
        jac = opts.get("jac", "auto") if m.local else "auto"
        try:
            r, J, _ = problem.jacobian(z, method=jac, diff="central")
            if uncertainty:
                unc = problem_uncertainty(
                    problem,
                    z,
                    level=level,
                    J=J,
                    r=r,
                    input_noise=input_noise,
                    input_prepare=input_prepare,
                    seed=seed,
                )
            if identifiability:
                idf = problem_identifiability(problem, z, J=J)
        except ThermogymError as e:
            notes.append(f"no uncertainty: {e}")
        if unc is not None:
            at = [
                n
                for n, v, lo, hi in zip(problem.names, z, problem.lower, problem.upper, strict=True)
                if np.isclose(v, lo, rtol=0, atol=1e-6 * (hi - lo))
                or np.isclose(v, hi, rtol=0, atol=1e-6 * (hi - lo))
            ]
            if at:
                notes.append(
                    f"{at} ended at a bound: their confidence intervals ignore the bound and the "
                    "optimum may lie outside the search range"
                )
            if unc.covariance is None:
                notes.append(
                    "the Jacobian is rank deficient: parameters with NaN standard errors are not "
                    "identifiable together from these data (see the identifiability ranking)"
                )
    c1 = problem.counters.as_dict()
    work = {k: c1[k] - c0[k] for k in c1}
    samples = tracker.samples() if keep else None
    failures = [f for t in trackers for f in t.failures][:20]
    fmsgs: dict[str, int] = {}
    for t in trackers:
        for msg, n in t.failure_messages.items():
            fmsgs[msg] = fmsgs.get(msg, 0) + n
    result = IdentificationResult(
        method=method,
        names=problem.names,
        x=z,
        values=problem.as_dict(z),
        parameters=problem.values(z),
        criterion=float(train["criterion"]),
        mse=float(train["mse"]),
        stop_reason=reason,
        iterations=len(history),
        evaluations=sum(t.n_evaluated for t in trackers),
        simulations=work["simulations"],
        sensitivity_runs=work["sensitivity_runs"],
        failed=sum(t.n_failed for t in trackers),
        failures=failures,
        failure_messages=fmsgs,
        elapsed_s=sum(t.elapsed for t in trackers),
        history=history,
        uncertainty=unc,
        identifiability=idf,
        metrics={"train": train},
        fit=None,  # type: ignore[arg-type]  # built just below
        problem=problem,
        samples=samples,
        info=info,
        notes=notes,
    )
    settings = {
        "method": method,
        "options": {k: v for k, v in opts.items() if k not in ("start",)},
        "seed": seed,
        "stop": stop.as_dict(),
        "polish": polish,
        "confidence_level": level,
        "input_noise": dict(input_noise or {}),
        "problem": problem.describe(),
    }
    result.fit = build_fit_result(result, settings)
    if validation:
        result.validate(validation)
    return result


def identify(problem: Problem, method: str = "greybox", **options: Any) -> FitResult:
    """Identify the problem's parameters and return the :class:`FitResult`.

    The short form of :func:`run_identification` (same arguments); use that
    to get the history, uncertainty details and samples.

    Examples
    --------
    >>> from thermogym.rigs import run_experiment
    >>> from thermogym.models.strut import StrutModel
    >>> from thermogym.identification.problem import Problem
    >>> recs = run_experiment("strut", "steps", feed_rates=[20.0], seed=0)
    >>> pb = Problem(StrutModel(), recs, pairs=["T_drive"], free=["r_motor"])
    >>> fit = identify(pb, "montecarlo", n_samples=200, seed=1, progress=False)
    >>> fit.model, fit.method, sorted(fit.stderr)
    ('strut', 'coordinator:montecarlo', ['r_motor'])
    """
    return run_identification(problem, method, **options).fit


def build_fit_result(result: IdentificationResult, settings: dict[str, Any]) -> FitResult:
    """The FitResult of a coordinator run (model parameters, uncertainty, provenance)."""
    pb = result.problem
    sm = pb.model
    theta = pb.theta(result.x)  # (1, P_sim)
    D = pb.theta_jacobian  # ∂θ_sim/∂z
    moved = [i for i in range(D.shape[0]) if np.any(D[i] != 0)]
    sim_names = pb.sim_param_names
    unc = result.uncertainty
    stderr: dict[str, float] = {}
    cov_names: list[str] = []
    cov: list[list[float]] | None = None
    if unc is not None:
        Dm = D[moved]
        se_sim = np.sqrt(np.einsum("ij,j->i", Dm**2, unc.stderr**2))
        # a parameter moved by an unidentifiable optimiser variable gets NaN
        bad = (np.abs(Dm) > 0) & ~np.isfinite(unc.stderr)[None, :]
        se_sim = np.where(bad.any(axis=1), np.nan, se_sim)
        stderr = {sim_names[i]: float(s) for i, s in zip(moved, se_sim, strict=True)}
        if unc.covariance is not None:
            C = Dm @ unc.covariance @ Dm.T  # Cov(θ) = D Cov(z) Dᵀ
            cov = (0.5 * (C + C.T)).tolist()
            cov_names = [sim_names[i] for i in moved]
    bounds_sim: dict[str, list[float]] = {}
    for i in moved:
        j = int(np.flatnonzero(D[i])[0])
        f = D[i, j]
        lo, hi = sorted((f * pb.lower[j], f * pb.upper[j]))
        bounds_sim[sim_names[i]] = [float(lo), float(hi)]
    metrics = to_jsonable(
        {
            **result.metrics,
            "identification": {
                "criterion": result.criterion,
                "mse": result.mse,
                "iterations": result.iterations,
                "evaluations": result.evaluations,
                "simulations": result.simulations,
                "sensitivity_runs": result.sensitivity_runs,
                "failed": result.failed,
                "elapsed_s": result.elapsed_s,
            },
        }
    )
    ratios = {
        n: {"value": float(result.x[i]), "targets": settings["problem"]["ratios"].get(n, {})}
        for i, (n, k) in enumerate(zip(pb.names, pb.kinds, strict=True))
        if k == "ratio"
    }
    if unc is not None:
        for i, n in enumerate(pb.names):
            if n in ratios:
                ratios[n]["stderr"] = float(unc.stderr[i])
    full_settings = {
        **settings,
        "stop_reason": result.stop_reason,
        "ratios": ratios,
        "identifiability": (
            None if result.identifiability is None else result.identifiability.selected
        ),
    }
    data = [data_entry(e, "train") for e in pb.experiments]
    notes = "; ".join(result.notes)
    common: dict[str, Any] = {
        "stderr": stderr,
        "covariance": cov,
        "covariance_names": cov_names,
        "method": f"coordinator:{result.method}",
        "settings": to_jsonable(full_settings),
        "metrics": metrics,
        "data": data,
        "notes": notes,
    }
    if isinstance(sm, ThermogymModel):
        model = sm.model
        full = sm.full_theta(theta)[0]
        names = model.param_names
        bounds = {p.name: [p.lower, p.upper] for p in model.parameters}
        bounds.update(bounds_sim)
        fixed = [n for n in names if n not in bounds_sim]
        return FitResult.from_model(model, full, bounds=bounds, fixed=fixed, **common)
    version = getattr(sm, "version", "external")
    config = getattr(sm, "config", None)
    cfg = config() if callable(config) else (config if isinstance(config, dict) else {})
    params = dict(zip(sim_names, theta[0].tolist(), strict=True))
    bounds = {
        n: [float(lo), float(hi)]
        for n, lo, hi in zip(sim_names, np.asarray(sm.lower), np.asarray(sm.upper), strict=True)
    }
    bounds.update(bounds_sim)
    return FitResult(
        model=sm.name,
        model_version=str(version),
        model_config=to_jsonable(cfg),
        parameters=params,
        bounds=bounds,
        fixed=[n for n in sim_names if n not in bounds_sim],
        **common,
    )
