"""Actuator strut: the 5 ratio parameters by Monte Carlo beside the FOPTD set (paper 000, 4.2.4).

``000_24627a5308ee07db.txt`` models the thermal behaviour of a machine-tool
actuator strut twice and identifies both with the same coordinator:

* **Table 1** — a set of first-order-plus-time-delay (FOPTD) transfer
  functions from the feed rate to each of the 7 measured temperatures
  (21 parameters), by least squares with a search over the integer delay;
* **Table 2** — a 19-node electric equivalent circuit (a Python script in the
  paper, :class:`~thermogym.models.strut.StrutModel` here) whose 5 ratio
  parameters are identified by Monte Carlo, once for each single output and
  once for all outputs together (the mean of the 7 RMSEs, eq 4 with weights
  1/7).

Both are trained on the 20 m/min step test and validated unchanged at 25 and
30 m/min. The paper's Monte Carlo took 60 minutes through Python script calls.

The data come from the strut rig (:mod:`thermogym.rigs.strut`), a plant written
apart from the model: 1-D conduction along the screw and the push tube, the
forced convection of the screw turning in its enclosed annulus and of the
moving tube (the screw, nut and tube warm less than in proportion to the feed
rate, a nonlinearity of the kind the paper names), motor losses that grow
with the winding temperature, one strut drawn from the appendix's uncertainty
of the physical estimates. :func:`rig_fidelity` measures the paper's
validation gap on it beside its noise ceiling and the nominal model. The 8
criteria are
evaluated on **one** shared Monte Carlo sample (``shared_samples=True``): a
Monte Carlo search draws its candidates independently of the criterion, so
each single-output optimum is the best of the same 10 000 simulations —
identical to 8 runs with the same seed, at an eighth of the cost.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from thermogym.errors import ConfigError, ShapeError
from thermogym.identification.coordinator import run_identification
from thermogym.identification.diagnosis import diagnose
from thermogym.identification.foptd import fit_foptd
from thermogym.identification.metrics import rmse
from thermogym.identification.problem import Problem
from thermogym.identification.simmodel import ThermogymModel
from thermogym.models.linear import FOPTDModel
from thermogym.models.strut import STRUT_OUTPUTS, StrutModel
from thermogym.recording import Recording
from thermogym.rigs import get_rig, to_recording

__all__ = [
    "RATIOS",
    "FOPTDFit",
    "StrutFidelity",
    "StrutStudyConfig",
    "StrutStudyResult",
    "fit_foptd_set",
    "measured_initial_state",
    "rig_fidelity",
    "run_strut_study",
    "strut_problem",
]

#: The 5 ratio parameters of paper 000 (Table 5).
RATIOS: tuple[str, ...] = ("r_motor", "r_bearing", "r_nut", "r_spindle_air", "r_tube_air")
#: The 7 measured temperatures.
OUTPUTS: tuple[str, ...] = tuple(STRUT_OUTPUTS)


def measured_initial_state(
    model: Any, theta_full: NDArray[np.float64], experiment: Recording
) -> NDArray[np.float64]:
    """Initial node temperatures from the first samples of a recording.

    Nodes with a measured temperature start at it, the others at the first air
    temperature (the 25 m/min test starts with a drive still warm from the
    previous run, paper 000 section 4.1). Usable as ``ThermogymModel(x0=...)``.

    Returns
    -------
    ndarray, shape (B, n_nodes)
    """
    nodes = list(model.state_names)
    x = np.full(len(nodes), float(np.asarray(experiment["T_air"])[0]))
    for out, node in STRUT_OUTPUTS.items():
        if out in experiment and node in nodes:
            v = float(np.asarray(experiment[out])[0])
            if np.isfinite(v):
                x[nodes.index(node)] = v
    return np.repeat(x[None], theta_full.shape[0], axis=0)


def strut_problem(
    train: Recording | Sequence[Recording],
    outputs: Sequence[str] = OUTPUTS,
    weights: Sequence[float] | None = None,
    *,
    model: StrutModel | None = None,
) -> Problem:
    """The coordinator problem of paper 000: 5 ratios, the temperatures as signal pairs.

    Parameters
    ----------
    train : Recording or sequence of Recording
    outputs : sequence of str
        Measured temperatures compared.
    weights : sequence of float, optional
        Weights of eq (4) (default ``1/len(outputs)`` each: the mean RMSE).
    model : StrutModel, optional

    Examples
    --------
    >>> from thermogym.rigs import run_experiment
    >>> recs = run_experiment("strut", "steps", feed_rates=[20.0], seed=0)
    >>> strut_problem(recs).names
    ('r_motor', 'r_bearing', 'r_nut', 'r_spindle_air', 'r_tube_air')
    """
    m = model or StrutModel()
    sm = ThermogymModel(m, free=RATIOS, fixed={"T_ref": 20.0}, x0=measured_initial_state)
    w = [1.0 / len(outputs)] * len(outputs) if weights is None else list(weights)
    if len(w) != len(outputs):
        raise ShapeError(f"{len(w)} weights for {len(outputs)} outputs")
    return Problem(sm, train, pairs=[(o, o, float(wi)) for o, wi in zip(outputs, w, strict=True)])


# ------------------------------------------------------------------- FOPTD set
@dataclass
class FOPTDFit:
    """The FOPTD set of Table 1: gain, time constant and delay per output.

    Attributes
    ----------
    outputs : tuple of str
    K : ndarray
        Gains [K / (m/min)].
    T : ndarray
        Time constants [s].
    tau : ndarray
        Delays [s].
    seconds : float
        Time the least-squares fits took.
    """

    outputs: tuple[str, ...]
    K: NDArray[np.float64]
    T: NDArray[np.float64]
    tau: NDArray[np.float64]
    seconds: float = 0.0

    def model(self) -> FOPTDModel:
        """The fitted :class:`~thermogym.models.linear.FOPTDModel` (deviation outputs)."""
        n = len(self.outputs)
        return FOPTDModel(
            ["feed_rate"],
            list(self.outputs),
            units={"feed_rate": "m/min", **{o: "°C" for o in self.outputs}},
            K=self.K.reshape(n, 1),
            T=self.T.reshape(n, 1),
            tau=self.tau.reshape(n, 1),
        )

    def simulate(self, rec: Recording) -> dict[str, NDArray[np.float64]]:
        """Simulated temperatures: first measured value plus the FOPTD response (Fig. 6)."""
        m = self.model()
        sim = m.simulate(np.asarray(rec["feed_rate"], dtype=float)[:, None], rec.dt)
        return {o: float(rec[o][0]) + sim.output(o)[0] for o in self.outputs}


def fit_foptd_set(rec: Recording, outputs: Sequence[str] = OUTPUTS, *, d_max: int = 20) -> FOPTDFit:
    """Fit the FOPTD set of paper 000 section 4.1 (Table 1) to one step test.

    For each output, the initial value is subtracted and
    ``y[k] = a y[k−1] + b u[k−1−d]`` is fitted by least squares for every
    integer delay ``d`` in ``[0, d_max]``; the delay with the smallest mean
    squared simulation error is kept and converted by eqs (11)-(12):
    ``T = −Δt/ln a``, ``K = b/(1 − a)``, ``τ = d Δt``. The fit is
    :func:`thermogym.identification.foptd.fit_foptd` (linear identification).

    Parameters
    ----------
    rec : Recording
        Uniformly sampled, with ``feed_rate`` and the outputs, starting at rest.
    outputs : sequence of str
    d_max : int
        Largest delay tried [samples].

    Returns
    -------
    FOPTDFit
    """
    t0 = time.perf_counter()
    # the paper's method: deviations from the initial values, the start at rest
    res = fit_foptd(
        rec, ["feed_rate"], list(outputs), max_delay=d_max, operating_point_mode="initial"
    )
    return FOPTDFit(
        tuple(outputs),
        np.asarray(res.K, dtype=float)[:, 0],
        np.asarray(res.T, dtype=float)[:, 0],
        np.asarray(res.tau, dtype=float)[:, 0],
        time.perf_counter() - t0,
    )


# ---------------------------------------------------------------------- study
@dataclass(frozen=True)
class StrutStudyConfig:
    """Arguments of :func:`run_strut_study`.

    Attributes
    ----------
    seed : int
        Seed of the rig data and of the Monte Carlo samples.
    effects : tuple of str
        Physics of the rig's strut beyond the model (the paper's plant is nonlinear).
    specimen : dict
        True ratio values of the rig's strut (default: the estimates are right).
    n_samples : int
        Monte Carlo samples (parameter sets).
    batch_size : int
        Sets simulated per batch.
    sampler : {"uniform", "sobol", "lhs"}
    shared_samples : bool
        Evaluate the 8 criteria on one sample (else 8 Monte Carlo runs).
    """

    seed: int = 0
    effects: tuple[str, ...] = ()
    specimen: Mapping[str, float] = field(default_factory=dict)
    n_samples: int = 10_000
    batch_size: int = 2_000
    sampler: str = "uniform"
    shared_samples: bool = True


@dataclass
class StrutStudyResult:
    """Tables 1 and 2 of paper 000 reproduced on rig data.

    Attributes
    ----------
    criteria : dict
        Criterion (an output name or ``"all"``) → ``{"ratios": {...},
        "rmse": {feed: {output: RMSE}}}`` (Table 2).
    foptd : FOPTDFit
        Table 1 parameters.
    foptd_rmse : dict
        ``{feed: {output: RMSE}}`` of the FOPTD set.
    feeds : tuple of float
        Feed rates [m/min]: training first.
    seconds : dict
        Wall time of the Monte Carlo, the FOPTD fits and the evaluations.
    evaluations : int
        Parameter sets simulated by the Monte Carlo.
    """

    criteria: dict[str, dict[str, Any]]
    foptd: FOPTDFit
    foptd_rmse: dict[float, dict[str, float]]
    feeds: tuple[float, ...]
    seconds: dict[str, float]
    evaluations: int
    outputs: tuple[str, ...] = OUTPUTS

    def table(self) -> str:
        """Tables 1 and 2 side by side: RMSE [K] per output, training and validation."""
        f = self.feeds
        head = " ".join(f"{v:>6g}" for v in f)
        lines = [
            "Table 2 (equivalent circuit, 5 ratios by Monte Carlo) vs Table 1 (FOPTD set)",
            f"{'criterion':<15} {'r_motor':>7} {'r_bear':>7} {'r_nut':>7} {'r_sp_a':>7} "
            f"{'r_tb_a':>7} | RC RMSE [K] at {head} | FOPTD {head}",
        ]
        for name, c in self.criteria.items():
            r = c["ratios"]
            rc = " ".join(
                f"{self._mean(c['rmse'][v]) if name == 'all' else c['rmse'][v][name]:>6.3f}"
                for v in f
            )
            fr = self.foptd_rmse
            fo = " ".join(f"{self._mean(fr[v]) if name == 'all' else fr[v][name]:>6.3f}" for v in f)
            lines.append(
                f"{name:<15} "
                + " ".join(f"{r[k]:>7.3f}" for k in RATIOS)
                + f" |               {rc} |       {fo}"
            )
        lines.append("")
        lines.append(
            f"{'FOPTD (Table 1)':<15} {'K [K/(m/min)]':>14} {'T [min]':>9} {'tau [min]':>10}"
        )
        for i, o in enumerate(self.foptd.outputs):
            lines.append(
                f"{o:<15} {self.foptd.K[i]:>14.4f} {self.foptd.T[i] / 60:>9.1f} "
                f"{self.foptd.tau[i] / 60:>10.1f}"
            )
        s = self.seconds
        lines.append("")
        lines.append(
            f"Monte Carlo: {self.evaluations} simulations in {s['montecarlo']:.2f} s (paper: 60 "
            f"min with script calls); FOPTD least squares: {s['foptd']:.3f} s (paper: < 1 s)"
        )
        return "\n".join(lines)

    @staticmethod
    def _mean(d: Mapping[str, float]) -> float:
        return float(np.mean(list(d.values())))

    def to_dict(self) -> dict[str, Any]:
        """JSON types."""
        return {
            "feeds_m_min": list(self.feeds),
            "criteria": {
                k: {
                    "ratios": v["ratios"],
                    "rmse": {str(f): r for f, r in v["rmse"].items()},
                }
                for k, v in self.criteria.items()
            },
            "foptd": {
                o: {
                    "K": float(self.foptd.K[i]),
                    "T_s": float(self.foptd.T[i]),
                    "tau_s": float(self.foptd.tau[i]),
                    "rmse": {str(f): self.foptd_rmse[f][o] for f in self.feeds},
                }
                for i, o in enumerate(self.foptd.outputs)
            },
            "seconds": self.seconds,
            "evaluations": self.evaluations,
        }


def run_strut_study(
    config: StrutStudyConfig | None = None,
    *,
    recordings: Sequence[Recording] | None = None,
    progress: bool | None = None,
) -> StrutStudyResult:
    """Reproduce Tables 1 and 2 of paper 000 on strut rig data.

    Parameters
    ----------
    config : StrutStudyConfig, optional
    recordings : sequence of Recording, optional
        Step tests (training first); generated by the rig when omitted.
    progress : bool, optional

    Returns
    -------
    StrutStudyResult
    """
    cfg = config or StrutStudyConfig()
    if recordings is None:
        rig = get_rig("strut", cfg.effects)
        if cfg.specimen:
            rig = rig.with_specimen(dict(cfg.specimen))
        recordings = [to_recording(r, "strut") for r in rig.run("steps", seed=cfg.seed)]
    recs = list(recordings)
    if len(recs) < 1:
        raise ConfigError("the strut study needs at least the training step test")
    feeds = tuple(float(r["feed_rate"][-1]) for r in recs)
    train = recs[0]
    pb = strut_problem(train)
    t0 = time.perf_counter()
    sets: dict[str, NDArray[np.float64]] = {}
    evaluations = 0
    if cfg.shared_samples:
        res = run_identification(
            pb,
            "montecarlo",
            n_samples=cfg.n_samples,
            batch_size=cfg.batch_size,
            sampler=cfg.sampler,
            seed=cfg.seed,
            progress=progress,
            uncertainty=False,
            identifiability=False,
            keep_samples=True,
        )
        evaluations = res.evaluations
        Z, _, pair = res.samples  # type: ignore[misc]
        for j, o in enumerate(OUTPUTS):
            sets[o] = Z[int(np.nanargmin(np.where(np.isfinite(pair[:, j]), pair[:, j], np.inf)))]
        sets["all"] = res.x
    else:
        for j, o in enumerate([*OUTPUTS, "all"]):
            w = [1.0 / 7] * 7 if o == "all" else [1.0 if i == j else 0.0 for i in range(7)]
            res = run_identification(
                strut_problem(train, weights=w),
                "montecarlo",
                n_samples=cfg.n_samples,
                batch_size=cfg.batch_size,
                sampler=cfg.sampler,
                seed=cfg.seed,
                progress=progress,
                uncertainty=False,
                identifiability=False,
            )
            evaluations += res.evaluations
            sets[o] = res.x
    t_mc = time.perf_counter() - t0
    # the 8 parameter sets on every feed rate, one batch per recording
    t1 = time.perf_counter()
    names = list(sets)
    Z8 = np.array([sets[k] for k in names])
    per_feed: dict[float, NDArray[np.float64]] = {}
    for v, rec in zip(feeds, recs, strict=True):
        ev = pb.with_experiments([rec]).evaluate(Z8)
        per_feed[v] = ev.pair_rmse  # (8, 7)
    criteria = {
        k: {
            "ratios": dict(zip(RATIOS, sets[k].tolist(), strict=True)),
            "rmse": {
                v: {o: float(per_feed[v][i, j]) for j, o in enumerate(OUTPUTS)} for v in feeds
            },
        }
        for i, k in enumerate(names)
    }
    t_eval = time.perf_counter() - t1
    fo = fit_foptd_set(train)
    fo_rmse = {}
    for v, rec in zip(feeds, recs, strict=True):
        sim = fo.simulate(rec)
        fo_rmse[v] = {o: float(rmse(rec[o], sim[o])) for o in OUTPUTS}
    return StrutStudyResult(
        criteria=criteria,
        foptd=fo,
        foptd_rmse=fo_rmse,
        feeds=feeds,
        seconds={"montecarlo": t_mc, "foptd": fo.seconds, "validation": t_eval},
        evaluations=evaluations,
    )


# ------------------------------------------------------------------- rig fidelity
@dataclass
class StrutFidelity:
    """Paper 000's validation gap measured on the rig, beside its ceiling and baselines.

    Every RMSE is the mean over the seven temperatures [K] of a step test
    (training at 20 m/min, validation at 25 and 30).

    Attributes
    ----------
    feeds : tuple of float
    rmse_fitted : dict
        The RC network with the 5 ratios fitted at 20 m/min (all outputs, Monte
        Carlo as Table 2).
    rmse_nominal : dict
        The RC network at its physical estimates (every ratio 1): the model
        before fitting.
    rmse_foptd : dict
        The FOPTD set of Table 1 fitted at 20 m/min.
    ceiling : dict
        Noise ceiling: the rig's noise-free sensor values against its own
        recording.
    diagnosis : dict
        Today's diagnosis trained at 20, validated at 25 and 30: ``named``
        (effect of the best hypothesis), ``rmse_before`` / ``rmse_after`` per
        feed (its nominal fit and its augmented model) and ``gap_closed``, the
        share of the 30 m/min gap it closes,
        ``(before_30 − after_30) / (before_30 − before_20)``; None where it
        could not be evaluated (with ``error``).
    specimen : dict
        Factors of the rig's strut.
    seconds : float
    """

    feeds: tuple[float, ...]
    rmse_fitted: dict[float, float]
    rmse_nominal: dict[float, float]
    rmse_foptd: dict[float, float]
    ceiling: dict[float, float]
    diagnosis: dict[str, Any]
    specimen: dict[str, float]
    seconds: float

    @staticmethod
    def ratio(d: Mapping[float, float]) -> float:
        """RMSE at 30 m/min over RMSE at 20."""
        return float(d[30.0] / d[20.0])

    def figures(self) -> dict[str, float]:
        """The headline figure of ``benchmarks/rig_fidelity.py``."""
        return {"strut_rmse_ratio_30_20": self.ratio(self.rmse_fitted)}

    def to_dict(self) -> dict[str, Any]:
        """JSON types: every figure beside its ceiling and baselines."""

        def per(d: Mapping[float, float]) -> dict[str, float]:
            return {f"{k:g}": float(v) for k, v in d.items()}

        return {
            "rmse_ratio_30_20": {
                "fitted_rc": self.ratio(self.rmse_fitted),
                "nominal_rc": self.ratio(self.rmse_nominal),
                "foptd": self.ratio(self.rmse_foptd),
                "noise_ceiling": self.ratio(self.ceiling),
                "target": 2.0,
                "paper": "linear models much worse at 25 and 30 m/min than at 20 (000 section 4.1)",
            },
            "rmse_K": {
                "fitted_rc": per(self.rmse_fitted),
                "nominal_rc": per(self.rmse_nominal),
                "foptd": per(self.rmse_foptd),
                "noise_ceiling": per(self.ceiling),
            },
            "diagnosis": self.diagnosis,
            "specimen": self.specimen,
            "seconds": self.seconds,
        }


def _mean_rmse(y: Any, sim: Any, outputs: Sequence[str]) -> float:
    return float(np.mean([rmse(np.asarray(y[o]), np.asarray(sim[o])) for o in outputs]))


def _diagnosis_gap(recs: Sequence[Recording], feeds: Sequence[float]) -> dict[str, Any]:
    """Today's diagnosis on the step tests and the share of the 30 m/min gap it closes.

    The RMSEs are the diagnosis' own simulations of each test (its report's series:
    the nominal and the augmented model, each with the initial state and per-test
    quantities the diagnosis estimated), over the temperatures of :data:`OUTPUTS`.
    """
    rep = diagnose("strut", list(recs[:1]), list(recs[1:]))
    out: dict[str, Any] = {
        "named": rep.best.get("effect") if rep.best else "none",
        "named_effects": list(rep.named_effects),
        "mismatch_detected": bool(rep.mismatch_detected),
        "rmse_before": None,
        "rmse_after": None,
        "gap_closed": None,
    }
    cols = [rep.outputs.index(o) for o in OUTPUTS if o in rep.outputs]
    if not cols or len(rep.series) != len(feeds):
        out["error"] = "the report's series do not cover the temperatures of every test"
        return out
    for key, curve in (("rmse_before", "nominal"), ("rmse_after", "augmented")):
        if any(curve not in ser for ser in rep.series):
            continue
        out[key] = {
            f"{v:g}": float(
                np.sqrt(
                    np.nanmean((ser[curve][:, cols] - ser["measured"][:, cols]) ** 2, axis=0)
                ).mean()
            )
            for v, ser in zip(feeds, rep.series, strict=True)
        }
    b, a = out["rmse_before"], out["rmse_after"]
    if b is not None and a is not None and b["30"] > b["20"]:
        out["gap_closed"] = (b["30"] - a["30"]) / (b["30"] - b["20"])
    return out


def rig_fidelity(
    *,
    seed: int = 0,
    n_samples: int = 10_000,
    diagnosis: bool = True,
    recordings: Sequence[Recording] | None = None,
) -> StrutFidelity:
    """Paper 000's validation gap on the strut rig: RMSE at 30 m/min over RMSE at 20.

    The rig's three step tests (20, 25, 30 m/min); the RC network fitted at
    20 m/min as Table 2 (all outputs, ``n_samples`` Monte Carlo sets), beside
    the nominal network, the FOPTD set of Table 1, the rig's noise ceiling and,
    with ``diagnosis``, the share of the gap today's diagnosis closes.

    Parameters
    ----------
    seed : int
        Seed of the rig's step tests and of the Monte Carlo.
    n_samples : int
        Monte Carlo parameter sets.
    diagnosis : bool
        Also run :func:`thermogym.identification.diagnosis.diagnose`.
    recordings : sequence of Recording, optional
        The three step tests (training first); default: the rig's, with their
        noise-free values for the ceiling.

    Returns
    -------
    StrutFidelity
    """
    t0 = time.perf_counter()
    rig = get_rig("strut")
    truth: list[dict[str, Any]] | None = None
    if recordings is None:
        runs = rig.run("steps", seed=seed)
        recordings = [to_recording(r, "strut") for r in runs]
        truth = [r.truth for r in runs]
    recs = list(recordings)
    feeds = tuple(float(r["feed_rate"][-1]) for r in recs)
    if feeds[:1] != (20.0,) or 30.0 not in feeds:
        raise ConfigError(f"rig_fidelity needs step tests at 20 (first) and 30 m/min; got {feeds}")
    res = run_strut_study(
        StrutStudyConfig(seed=seed, n_samples=n_samples), recordings=recs, progress=False
    )
    mean = lambda d: float(np.mean(list(d.values())))  # noqa: E731
    fitted = {v: mean(res.criteria["all"]["rmse"][v]) for v in feeds}
    foptd = {v: mean(res.foptd_rmse[v]) for v in feeds}
    pb = strut_problem(recs[0])
    ones = np.ones((1, len(RATIOS)))
    nominal = {
        v: float(pb.with_experiments([rec]).evaluate(ones).pair_rmse[0].mean())
        for v, rec in zip(feeds, recs, strict=True)
    }
    ceiling = (
        {v: _mean_rmse(rec, t, OUTPUTS) for v, rec, t in zip(feeds, recs, truth, strict=True)}
        if truth is not None
        else {v: float("nan") for v in feeds}
    )
    diag = _diagnosis_gap(recs, feeds) if diagnosis else {}
    return StrutFidelity(
        feeds,
        fitted,
        nominal,
        foptd,
        ceiling,
        diag,
        rig.specimen.to_dicts()[0],
        time.perf_counter() - t0,
    )
