"""Fitting hypotheses and choosing among them: screening, joint refits, forward selection.

A hypothesis adds one candidate to the model it extends (its *parent*: the
calibrated nominal model, or the combination chosen so far). It is fitted on
the training recordings with every parameter of the parent refitted jointly
with the candidate's (a missing effect biases the nominal fit), from the
parent's values and the candidate's neutral values and from starts drawn
inside the bounds. Per-recording parameters (a disturbance's course) are
fitted in every training recording and estimated afresh in every held-out
recording; the initial state of every recording is estimated too.

**Screening.** Every candidate is first fitted with only its own parameters
free (a few iterations: a Jacobian of ``k + 1`` simulations instead of
``P + k + 1``) and ranked by the information criterion of its training fit
(:mod:`.scoring`). The best by the training criterion, and the best held-out
form of every effect that helps held out (:func:`refit_set`), are refitted
jointly and scored on held-out data.

**Forward selection.** The hypothesis with the lowest held-out ΔIC is kept
when it passes (:func:`passes`); a hypothesis that predicts the held-out
recordings outright is preferred to one whose course (an unmeasured
disturbance, a supply's wander) had to be re-estimated on them; the
remaining candidates are then screened again on top of it (joint refits of
the whole combination), until none passes or :data:`MAX_EFFECTS` effects are
in. Each effect's share of the explained error is its step's reduction of the
held-out squared error over the total.

**Held-out schemes.** ``split``: fitted on the training recordings, scored on
the held-out ones. ``crossfit`` (when the training recordings show no
material mismatch but the held-out ones do, the situation of paper 000
section 4.1): each held-out recording is predicted by models fitted on the
training recordings and the *other* held-out recordings; the model reported
is fitted on all of them.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import stats

from thermogym.identification.diagnosis.experiments import Experiment
from thermogym.identification.diagnosis.fit import (
    LOCAL_GROUP,
    STOPPED,
    FitProblem,
    fit_model,
    unit_jacobian,
)
from thermogym.identification.diagnosis.hypothesis import (
    Candidate,
    Hypothesis,
    NominalSpec,
    merge_values,
)
from thermogym.identification.diagnosis.scoring import delta_ic, whitened_chi2
from thermogym.identification.metrics import fit_text, nrmse
from thermogym.models.augmented import RECORDED, AugmentedModel
from thermogym.models.base import Model
from thermogym.models.fastnet import fast_or_none

__all__ = ["MAX_EFFECTS", "Data", "fit_hypothesis", "forward_selection", "nrmse_table"]

#: Most effects a combination holds.
MAX_EFFECTS = 3
#: Paths the first round keeps (beam search).
BEAM = 2
#: Least share of the nominal model's systematic held-out error a kept effect removes.
MIN_SHARE = 0.05
#: ... or, on top of kept effects, least share of the systematic held-out error they leave:
#: a small second effect beside a dominant first one (a 0.3 K/h drift beside a dead zone
#: that carries 95 % of the error) removes nearly all of what is left, where what a first
#: effect of a slightly wrong form leaves for a second one to mop up is a part of it.
MIN_SHARE_LEFT = 0.5
#: ... and never less than this share of the nominal model's error (once two effects have
#: removed 99.9 % of it, half of the rest is any course's share of the coloured noise).
MIN_SHARE_FLOOR = 0.01
#: Least RMS change of some output's held-out prediction a kept effect makes, in units of
#: that output's white-noise level. Loggers' own coloured noise (1/f and Gauss-Markov
#: wander of thermocouples, RTDs and their amplifiers) is commonly of the order of the
#: white level, and an effect that changes the prediction by no more than that cannot be
#: told from the sensor itself: a re-estimated course or an extra state fits such wander
#: as readily as it fits physics. Measured on the generalisation suite's controls (constants
#: 10-30 % off, white plus Gauss-Markov noise): the courses kept there changed the
#: prediction by 1.1-1.6 σ; the hidden effects named correctly by 4-125 σ. The bar is asked
#: of what can follow wander: a hypothesis that adds per-recording parameters or a state
#: whose start is estimated in every recording. One that adds only parameters shared by
#: every recording (a constant offset, an exponent) cannot follow a held-out recording's
#: wander, and its held-out test on whitened residuals is the guard: it is asked the
#: detection's materiality only (a 0.7 K offset on a building zone, re-calibration
#: absorbing most of it, changes the prediction by 1.2 σ and removes 28 % of the error).
KEEP_SNR = 2.0
#: Share of a re-estimated course's held-out gain that a predictive hypothesis must reach to be
#: preferred to it (the course then joins only on top, if it still removes a material share).
PREDICTIVE_SHARE = 0.95
#: Evaluations of a screening fit (joint, from the neutral values and the starts).
_SCREEN_NFEV = 8
#: Hypotheses refitted jointly after screening: in the first round, in later rounds.
N_FULL_FIRST = 8
N_FULL_NEXT = 5
#: Under a time limit, the time a round's screening leaves for refitting the best screened
#: candidates jointly and testing them, in screening fits (their mean time so far): a
#: screening that ran to the deadline left nothing refitted, and named nothing however good
#: a screened candidate was. A joint refit took 3-4 screening fits on the AXT211 (all
#: parameters free, 25 evaluations against :data:`_SCREEN_NFEV`): this is about two refits.
REFIT_RESERVE = 8.0


@dataclass
class Data:
    """The recordings and settings every fit shares.

    Attributes
    ----------
    train, val : list of Experiment
    weights : ndarray
        Output weights (1 / spread).
    x0 : str
        Initial-state policy.
    alpha : float
        Level of the held-out test (Bonferroni over a round's candidates).
    scheme : {"split", "crossfit"}
    max_nfev : int
        Evaluations of a joint refit.
    deadline : float, optional
        ``time.perf_counter()`` after which no further hypothesis starts.
    say : callable
    """

    train: list[Experiment]
    val: list[Experiment]
    weights: NDArray[np.float64]
    x0: str
    alpha: float = 0.01
    scheme: str = "split"
    max_nfev: int = 25
    deadline: float | None = None
    say: Callable[[str], None] = field(default=lambda s: None)
    #: White-noise level of each output (data units; NaN when unknown) and the least ratio of
    #: a kept effect's change to the held-out prediction to it (the detection's materiality).
    noise: NDArray[np.float64] | None = None
    min_snr: float = 0.0
    #: Makes the baseline of a per-recording course: a course of that many knots added to an
    #: output's reading (:func:`.effects.course_baseline`); None skips the comparison.
    course_baseline: Callable[[int], Candidate] | None = None
    #: What the time limit left out, in words (the report says the search is incomplete).
    skipped: list[str] = field(default_factory=list)

    @property
    def expired(self) -> bool:
        """Whether the time limit has passed."""
        return self.deadline is not None and time.perf_counter() > self.deadline

    def skip(self, what: str) -> None:
        """Record that the time limit left ``what`` out."""
        if what not in self.skipped:
            self.skipped.append(what)


def nrmse_table(
    outputs: Sequence[str], ys: Sequence[NDArray], sims: Sequence[NDArray]
) -> dict[str, float]:
    """NRMSE fit per output over recordings, and their mean."""
    if not ys:
        return {}
    Y = np.concatenate(ys)
    S = np.concatenate(sims)
    out = {o: float(nrmse(Y[:, j], S[:, j])) for j, o in enumerate(outputs)}
    vals = [v for v in out.values() if math.isfinite(v)]
    out["mean"] = float(np.mean(vals)) if vals else math.nan
    return out


def wsse(ys: Sequence[NDArray], sims: Sequence[NDArray], w: NDArray[np.float64]) -> float:
    """Weighted squared error over recordings (NaN samples skipped)."""
    s = 0.0
    for y, yh in zip(ys, sims, strict=True):
        e = (y - yh) * w[None, :]
        ok = np.isfinite(y)
        if not np.isfinite(e[ok]).all():
            return math.inf
        s += float(np.sum(e[ok] ** 2))
    return s


def _local_bounds(model: Model, names: Sequence[str]) -> tuple[NDArray, NDArray]:
    idx = [model.param_index(p) for p in names]
    return model.lower[idx].copy(), model.upper[idx].copy()


def _added(h: Hypothesis) -> Candidate:
    """The candidate ``h`` adds to its parent (each hypothesis a round fits adds one)."""
    c = h.last
    assert c is not None, "internal: a hypothesis of a selection round adds no candidate"
    return c


def held_out(
    model: Model,
    theta: NDArray[np.float64],
    exps: Sequence[Experiment],
    data: Data,
    local: Sequence[str],
    recorded: Sequence[Mapping[str, float]] | None = None,
) -> tuple[list[NDArray[np.float64]], list[dict[str, float]]]:
    """Simulations of held-out recordings: per-recording parameters estimated on each.

    ``recorded`` (one dict per recording) holds the values read from each
    recording's data (:attr:`.Candidate.recorded`); they are returned with the
    estimated ones.
    """
    sims, vals = [], []
    for i, e in enumerate(exps):
        rec = dict(recorded[i]) if recorded else {}
        if local:
            lo, hi = _local_bounds(model, local)
            pb = FitProblem(
                model, tuple(local), theta, lo, hi, [e], data.weights, data.x0, local_values=[rec]
            )
            out = fit_model(pb, max_nfev=15, covariance=False)
            sims.append(pb.simulate(out.z[None], 0)[0])
            vals.append({**(out.local[0] if out.local else {}), **rec})
        else:
            pb = FitProblem(
                model,
                (),
                theta,
                np.zeros(0),
                np.zeros(0),
                [e],
                data.weights,
                data.x0,
                local_values=[rec],
            )
            sims.append(pb.simulate(np.zeros((1, 0)), 0)[0])
            vals.append(rec)
    return sims, vals


def recorded_values(
    cands: Sequence[Candidate], n: int
) -> tuple[list[dict[str, float]], list[int]] | None:
    """Per recording (training, then held-out), the values the candidates read from it.

    None when no candidate reads any; else the merged values and, per
    recording, how many numbers were read.
    """
    if not any(c.recorded for c in cands):
        return None
    vals: list[dict[str, float]] = [{} for _ in range(n)]
    counts = [0] * n
    for c in cands:
        if not c.recorded:
            continue
        if len(c.recorded) != n:
            raise ValueError(
                f"{c.label} holds values of {len(c.recorded)} recordings; expected {n}"
            )
        for i in range(n):
            vals[i].update(c.recorded[i])
            counts[i] += int(c.n_recorded[i]) if c.n_recorded else 0
    return vals, counts


def _problem(
    model: Model,
    free: Sequence[str],
    base: NDArray[np.float64],
    bounds: dict[str, tuple[float, float]],
    exps: Sequence[Experiment],
    data: Data,
    recorded: Sequence[Mapping[str, float]] | None = None,
) -> FitProblem:
    lo = np.array([bounds[p][0] for p in free])
    hi = np.array([bounds[p][1] for p in free])
    return FitProblem(
        model,
        tuple(free),
        base,
        lo,
        hi,
        exps,
        data.weights,
        data.x0,
        local_values=[dict(r) for r in recorded] if recorded else None,
    )


def fit_hypothesis(
    spec: NominalSpec,
    parent: Hypothesis,
    cand: Candidate | None,
    data: Data,
    nominal: Hypothesis,
    *,
    screen: bool = False,
    max_nfev: int | None = None,
    start: dict[str, float] | None = None,
    parent_columns: NDArray[np.float64] | None = None,
) -> Hypothesis:
    """Fit ``parent`` + ``cand`` and score it against ``parent`` (module docstring).

    Parameters
    ----------
    spec : NominalSpec
    parent : Hypothesis
        The model it extends (fitted).
    cand : Candidate or None
        None refits the parent itself.
    data : Data
    nominal : Hypothesis
        The calibrated nominal model (its held-out error is the reference of
        ``explained`` and ``validation_before``).
    screen : bool
        Only the candidate's parameters free, few iterations.
    max_nfev : int, optional
    start : dict, optional
        Start values of shared parameters (a screened fit refined).
    parent_columns : ndarray, optional
        A screening fit's Jacobian columns of the parent's shared parameters at
        the parent's optimum (:func:`parent_columns`): the same for every
        candidate of a round, so computed once for the round.

    Returns
    -------
    Hypothesis
        With ``error`` set when it could not be fitted.
    """
    t0 = time.perf_counter()
    cands = (*parent.candidates, cand) if cand is not None else parent.candidates
    outs = list(data.train[0].outputs)
    h = Hypothesis(candidates=tuple(cands), screened=screen)
    try:
        model = spec.build(cands)
        fit_with = fast_or_none(model) or model
        # the parent (the nominal model or a kept hypothesis) was fitted by an earlier stage
        assert parent.model is not None and parent.theta is not None, (
            "internal: the parent hypothesis has no fitted model"
        )
        base = merge_values(parent.model, parent.theta, model)
        groups = {p.name: p.group for p in model.parameters}
        new = [p for p in model.param_names if p not in parent.model.param_names]
        new_g = [p for p in new if groups[p] not in (LOCAL_GROUP, RECORDED)]
        local = [p for p in model.param_names if groups[p] == LOCAL_GROUP]
        parent_g = [p for p in parent.free if groups.get(p) != LOCAL_GROUP]
        n_tr = len(data.train)
        rec = recorded_values(cands, n_tr + len(data.val))
        rec_vals = rec[0] if rec else [{} for _ in range(n_tr + len(data.val))]
        bounds = dict(parent.bounds)
        for p in new + local:
            spec_p = model.parameters[model.param_index(p)]
            bounds.setdefault(p, (float(spec_p.lower), float(spec_p.upper)))
        for k, v in (start or {}).items():
            if k in model.param_names:
                base[model.param_index(k)] = v
        free_g = [*parent_g, *new_g]
        free = [*free_g, *local]
        nfev = max_nfev or (_SCREEN_NFEV if screen else data.max_nfev)
        starts = []
        if cand is not None and start is None:
            for st in cand.starts:
                z = np.array([base[model.param_index(p)] for p in free_g])
                for k, v in st.items():
                    if k in free_g:
                        z[free_g.index(k)] = v
                starts.append(z)
        h.model = model
        h.free = tuple(free)
        h.bounds = {p: bounds[p] for p in free}
        assert nominal.model is not None, "internal: the nominal hypothesis has no model"
        h.extra = tuple(
            p
            for p in model.param_names
            if p not in nominal.model.param_names and groups[p] not in (LOCAL_GROUP, RECORDED)
        )
        h.local = tuple(local)
        h.k_global = len(h.extra)
        h.k_local = len(local)
        if rec:
            h.k_recorded_train = sum(rec[1][:n_tr])
            h.k_recorded_val = sum(rec[1][n_tr:])
        if data.scheme == "crossfit":
            _fit_crossfit(h, fit_with, base, free, bounds, starts, data, nfev, rec_vals)
        else:
            pb = _problem(fit_with, free, base, bounds, data.train, data, rec_vals[:n_tr])
            out = fit_model(
                pb,
                starts=starts,
                n_refine=2 if starts else 1,
                max_nfev=nfev,
                deadline=data.deadline,
                covariance=not screen,
                # screening: the parent's own parameters start at their optimum, their
                # Jacobian columns are computed once (the joint refit recomputes them all)
                frozen=parent_g if screen else (),
                frozen_columns=parent_columns if screen else None,
            )
            h.outcome = out
            if out.message == STOPPED and cand is not None:
                data.skip(f"the fit of {cand.label} stopped at the time limit")
            h.theta = out.theta.copy()
            for p in [*local, *recorded_names(model)]:
                # the model reported runs with per-recording parts neutral
                h.theta[model.param_index(p)] = model.nominal[model.param_index(p)]
            h.sims_train = [pb.simulate(out.z[None], i)[0] for i in range(len(data.train))]
            h.local_train = (
                [{**(out.local[i] if out.local else {}), **rec_vals[i]} for i in range(n_tr)]
                if (out.local or rec)
                else out.local
            )
            h.sims_val, h.local_val = held_out(
                model, out.theta, data.val, data, local, rec_vals[n_tr:] if rec else None
            )
    except Exception as e:  # a hypothesis that cannot be fitted is reported, not fatal
        h.error = f"{type(e).__name__}: {e}"
        h.seconds = time.perf_counter() - t0
        return h
    _score(h, parent, nominal, data, outs)
    h.seconds = time.perf_counter() - t0
    return h


def parent_columns(parent: Hypothesis, data: Data) -> NDArray[np.float64] | None:
    """Jacobian columns of ``parent``'s shared parameters at its optimum (training data).

    A screening fit starts every candidate at its neutral values, where the
    augmented model is the parent, with the parent's parameters at their
    optimum; it takes their Jacobian columns as given (a quasi-Newton
    shortcut: only the candidate's own columns are simulated again). They are
    the same for every candidate of a round: computed here once instead of
    once per candidate (P + 1 simulations of every recording saved per
    candidate). None when they cannot be computed (each screening then
    computes its own).
    """
    if parent.model is None or parent.theta is None or data.scheme == "crossfit":
        return None
    model = parent.model
    groups = {p.name: p.group for p in model.parameters}
    free = [p for p in parent.free if groups.get(p) != LOCAL_GROUP]
    if not free:
        return None
    n_tr = len(data.train)
    rec = recorded_values(parent.candidates, n_tr + len(data.val))
    try:
        pb = _problem(
            fast_or_none(model) or model,
            free,
            parent.theta,
            {p: parent.bounds[p] for p in free},
            data.train,
            data,
            rec[0][:n_tr] if rec else None,
        )
        return unit_jacobian(pb)
    except Exception:  # the screening computes the columns itself, as it always could
        return None


def _fit_crossfit(h, fit_with, base, free, bounds, starts, data, nfev, rec_vals) -> None:
    """Leave one held-out recording out at a time; the reported model fitted on all.

    ``rec_vals``: per recording (training, then held-out), values read from its data.
    """
    n_tr = len(data.train)
    sims_val, local_val = [], []
    for k in range(len(data.val)):
        keep = [*range(n_tr), *[n_tr + i for i in range(len(data.val)) if i != k]]
        fit_set = [*data.train, *[e for i, e in enumerate(data.val) if i != k]]
        pb = _problem(fit_with, free, base, bounds, fit_set, data, [rec_vals[i] for i in keep])
        out = fit_model(
            pb, starts=starts, n_refine=1, max_nfev=nfev, deadline=data.deadline, covariance=False
        )
        s, v = held_out(h.model, out.theta, [data.val[k]], data, h.local, [rec_vals[n_tr + k]])
        sims_val += s
        local_val += v
    pb = _problem(fit_with, free, base, bounds, [*data.train, *data.val], data, rec_vals)
    out = fit_model(pb, starts=starts, n_refine=1, max_nfev=nfev, deadline=data.deadline)
    h.outcome = out
    h.theta = out.theta.copy()
    for p in [*h.local, *recorded_names(h.model)]:
        h.theta[h.model.param_index(p)] = h.model.nominal[h.model.param_index(p)]
    h.sims_train = [pb.simulate(out.z[None], i)[0] for i in range(len(data.train))]
    h.local_train = [{**(out.local[i] if out.local else {}), **rec_vals[i]} for i in range(n_tr)]
    h.sims_val, h.local_val = sims_val, local_val


def recorded_names(model: Model) -> list[str]:
    """Parameters of ``model`` read from each recording's data (never fitted)."""
    return [p.name for p in model.parameters if p.group == RECORDED]


def residuals_of(h: Hypothesis, data: Data) -> tuple[list[NDArray], list[NDArray]]:
    """Training and held-out residuals ``y − ŷ`` of a fitted hypothesis."""
    res_tr = [e.y - s for e, s in zip(data.train, h.sims_train, strict=True)]
    res_va = [e.y - s for e, s in zip(data.val, h.sims_val, strict=True)]
    return res_tr, res_va


def score_self(h: Hypothesis, data: Data) -> None:
    """A hypothesis' own squared errors (as a parent of others)."""
    _, res_va = residuals_of(h, data)
    h.wsse_train = wsse([e.y for e in data.train], h.sims_train, data.weights)
    h.wsse_val = wsse([e.y for e in data.val], h.sims_val, data.weights)
    h.n_val = sum(int(np.isfinite(r).sum()) for r in res_va)


def _score(h: Hypothesis, parent: Hypothesis, nominal: Hypothesis, data: Data, outs) -> None:
    score_self(h, data)
    res_tr, res_va = residuals_of(h, data)
    par_tr, par_va = residuals_of(parent, data)
    dk_g = h.k_global - parent.k_global
    dk_l = h.k_local - parent.k_local
    # numbers read from a recording's data cost what a parameter fitted on it costs
    dk_rv = h.k_recorded_val - parent.k_recorded_val
    dk_rt = h.k_recorded_train - parent.k_recorded_train
    h.chi2_val, n_va = whitened_chi2(par_va, res_va)
    h.chi2_train, n_tr = whitened_chi2(par_tr, res_tr)
    h.delta_ic = delta_ic(h.chi2_val, dk_g + len(data.val) * dk_l + dk_rv, n_va)
    h.delta_ic_train = delta_ic(h.chi2_train, dk_g + len(data.train) * dk_l + dk_rt, n_tr)
    h.score = -h.delta_ic if math.isfinite(h.delta_ic) else -math.inf
    s0 = nominal.wsse_val
    floor = nominal.baseline.get("noise_floor", 0.0) if nominal.baseline else 0.0
    if math.isfinite(h.wsse_val) and s0 > floor:
        h.explained = float((s0 - h.wsse_val) / (s0 - floor))
    h.fit_before = nrmse_table(outs, [e.y for e in data.train], nominal.sims_train)
    h.fit_after = nrmse_table(outs, [e.y for e in data.train], h.sims_train)
    h.validation_before = nrmse_table(outs, [e.y for e in data.val], nominal.sims_val)
    h.validation_after = nrmse_table(outs, [e.y for e in data.val], h.sims_val)


def passes(h: Hypothesis, parent: Hypothesis, m: int, data: Data | None = None) -> bool:
    """Kept: held-out improvement beyond the coloured noise, by the information criterion.

    ``ΔIC + 2 ln m < 0`` on the held-out data (``m`` candidates in the round:
    the extended BIC's prior over them), and material: the held-out squared
    error falls by at least :data:`MIN_SHARE` of the nominal model's
    systematic held-out error, or by :data:`MIN_SHARE_LEFT` of what the kept
    effects leave (:func:`material_share`; what an effect of the wrong form
    leaves behind is significant at thousands of samples, but not material),
    and the effect changes the held-out prediction of some output by at least
    ``max(data.min_snr,`` :data:`KEEP_SNR` ``)`` × that output's white-noise level
    (RMS; the materiality the detection asks of a mismatch, asked of what is to explain
    it, and at least what the sensor's own coloured noise could make where the hypothesis
    can follow that noise: :func:`follows_recordings`).
    """
    if data is None:
        bar = 0.0
    elif follows_recordings(h, parent):
        bar = max(data.min_snr, KEEP_SNR)
    else:
        bar = data.min_snr
    return bool(
        h.ok
        and h.delta_ic + 2.0 * math.log(max(m, 1)) < 0.0
        and h.wsse_val < parent.wsse_val
        and material_share(h, parent)
        and (data is None or change_snr(h, parent, data) >= bar)
    )


def material_share(h: Hypothesis, parent: Hypothesis) -> bool:
    """Whether ``h`` removes a material share of the systematic held-out error.

    At least :data:`MIN_SHARE` of the nominal model's, or, for an effect that does not
    follow each recording (:func:`follows_recordings`) on top of kept effects (a parent
    with candidates that explain some), at least :data:`MIN_SHARE_LEFT` of
    what they leave and :data:`MIN_SHARE_FLOOR` of the nominal model's (the first
    effect always needs :data:`MIN_SHARE`: a re-calibration that leaves little is no
    reason to keep less).
    """
    gain = h.explained - parent.explained
    left = 1.0 - parent.explained
    # courses re-estimated in every recording can follow what any first effect leaves (coloured
    # noise, a form slightly off): the relative share is asked only of effects that cannot
    on_top = (
        bool(parent.candidates) and parent.explained > 0.0 and not follows_recordings(h, parent)
    )
    return bool(
        gain >= MIN_SHARE or (on_top and gain >= max(MIN_SHARE_LEFT * left, MIN_SHARE_FLOOR))
    )


def follows_recordings(h: Hypothesis, parent: Hypothesis) -> bool:
    """Whether ``h`` adds freedom in every recording.

    Per-recording parameters, or a state whose start is estimated in each
    recording (an extra store, a lag).
    """
    if h.k_local > parent.k_local:
        return True
    return _n_free_starts(h.model) > _n_free_starts(parent.model)


def _n_free_starts(model: Model | None) -> int:
    if isinstance(model, AugmentedModel):
        return int(np.count_nonzero(model.x0_free))
    return 0 if model is None else len(model.state_names)


def change_snr(h: Hypothesis, parent: Hypothesis, data: Data) -> float:
    """Largest RMS change of an output's held-out prediction by ``h``, in noise units.

    Infinite when the noise level is unknown.
    """
    if data.noise is None or not h.sims_val or not parent.sims_val:
        return math.inf
    d = np.concatenate([a - b for a, b in zip(h.sims_val, parent.sims_val, strict=True)])
    rms = np.sqrt(np.nanmean(d**2, axis=0))
    ok = np.isfinite(data.noise) & (data.noise > 0)
    if not ok.any():
        return math.inf
    return float(np.nanmax(np.where(ok, rms / np.where(ok, data.noise, 1.0), -math.inf)))


@dataclass
class Selection:
    """Outcome of :func:`forward_selection`.

    Attributes
    ----------
    steps : list of Hypothesis
        The kept hypotheses, each extending the one before.
    first_round : list of Hypothesis
        Every candidate of the first round (joint refits first, by ΔIC; then
        the screened rest, by training ΔIC).
    rounds : list of list of Hypothesis
        The joint refits of every round.
    """

    steps: list[Hypothesis] = field(default_factory=list)
    first_round: list[Hypothesis] = field(default_factory=list)
    rounds: list[list[Hypothesis]] = field(default_factory=list)
    passed: list[list[bool]] = field(default_factory=list)

    def summary(self) -> list[dict[str, Any]]:
        """Per round, the jointly refitted hypotheses: ΔIC, share explained, kept or not."""
        return [
            {
                "round": r + 1,
                "hypotheses": [
                    {
                        "effect": h.last.effect if h.last else "none",
                        "form": h.last.form if h.last else "",
                        "target": h.last.target if h.last else "",
                        "delta_ic": h.delta_ic,
                        "explained": h.explained,
                        "passes": ok,
                        "error": h.error,
                    }
                    for h, ok in zip(hs, oks, strict=True)
                ],
            }
            for r, (hs, oks) in enumerate(zip(self.rounds, self.passed, strict=True))
        ]

    @property
    def final(self) -> Hypothesis | None:
        """The last kept hypothesis (the whole combination)."""
        return self.steps[-1] if self.steps else None


def _key(h: Hypothesis) -> float:
    return h.delta_ic if h.ok and math.isfinite(h.delta_ic) else math.inf


def refit_set(screened: Sequence[Hypothesis], n_full: int) -> list[Hypothesis]:
    """The screened hypotheses a round refits jointly, in the order they are refitted.

    The ``n_full`` best by the training criterion, the best few by the held-out one, and
    the best form of every effect that already helps held out (``delta_ic < 0``): a
    per-recording course leads the training criterion by following each recording, so a
    hypothesis that predicts the held-out data can rank low there (a latent heat that
    only part of the training range crosses) and still be the strongest evidence.
    """
    ok = sorted(screened, key=lambda h: h.delta_ic_train)
    held = sorted(ok, key=_key)
    top = ok[:n_full]
    by_effect: dict[str, Hypothesis] = {}
    for h in held:
        if h.delta_ic < 0:
            by_effect.setdefault(_added(h).effect, h)
    for h in [*held[: max(2, n_full // 3)], *by_effect.values()]:
        if h not in top:
            top.append(h)
    return top


def _round(
    spec: NominalSpec,
    current: Hypothesis,
    pool: Sequence[Candidate],
    data: Data,
    nominal: Hypothesis,
    n_full: int,
) -> tuple[list[Hypothesis], list[bool], list[Hypothesis]]:
    """One round on top of ``current``: screen, refit the best jointly, test them.

    Returns the refitted hypotheses (passing ones first, predictive before
    re-estimated courses), whether each passes, and the screened rest.
    """
    screened = []
    cols = parent_columns(current, data) if pool else None
    spent: list[float] = []  # seconds of each screening fit
    for i, c in enumerate(pool):
        left = math.inf if data.deadline is None else data.deadline - time.perf_counter()
        if left <= 0.0 or (spent and left < REFIT_RESERVE * float(np.mean(spent))):
            data.say(f"time limit: {len(pool) - i} of {len(pool)} candidates not screened")
            data.skip(
                f"{len(pool) - i} of {len(pool)} candidates not screened"
                + (
                    f" on top of {' + '.join(x.label for x in current.candidates)}"
                    if current.candidates
                    else ""
                )
                + f" ({', '.join(x.label for x in pool[i : i + 3])}"
                + (", ...)" if len(pool) - i > 3 else ")")
            )
            break
        t0 = time.perf_counter()
        screened.append(
            fit_hypothesis(spec, current, c, data, nominal, screen=True, parent_columns=cols)
        )
        spent.append(time.perf_counter() - t0)
    top = refit_set([h for h in screened if not h.error], n_full)
    fitted = []
    for j, hs in enumerate(top):
        if data.expired:
            data.skip(f"{len(top) - j} screened candidates not refitted jointly")
            break
        # hs was fitted without error (``ok`` above), so its model is set
        assert hs.model is not None, "internal: a screened hypothesis has no model"
        start = {p: hs.value(p) for p in hs.extra if p in hs.model.param_names}
        h = fit_hypothesis(spec, current, hs.last, data, nominal, start=start)
        if not h.ok or (hs.ok and hs.delta_ic < h.delta_ic and hs.wsse_val < h.wsse_val):
            # the longer refit did worse held out than the screening fit: keep that one
            h = hs if hs.ok else h
        fitted.append(h)
        data.say(
            f"{_added(h).label}: held-out ΔIC {h.delta_ic:.1f}, mean fit "
            f"{fit_text(h.validation_after.get('mean', math.nan))} ({h.seconds:.1f} s)"
        )
    m = max(1, len(screened))
    oks = {id(h): passes(h, current, m, data) for h in fitted}
    # a per-recording course must not follow the inputs (an unmeasured disturbance is not set
    # by the operator); one that does absorbed a structure error, and is not kept
    for h in fitted:
        if oks[id(h)] and h.k_local > current.k_local:
            p, where = course_independence(h, data)
            if p < data.alpha:
                oks[id(h)] = False
                h.notes.append(
                    f"its course follows {where} (p = {p:.2g}): not independent of the inputs"
                )
    # a course re-estimated on every held-out recording can follow whatever is left there
    # (coloured noise too): when a hypothesis that predicts the held-out data outright removes
    # nearly all the error the course removes, the course adds nothing the data can vouch for
    # (a constant sensor offset and a constant unmeasured disturbance look alike once the
    # initial state is estimated); it may still join on top, as a second effect
    pred = [h for h in fitted if oks[id(h)] and h.k_local == current.k_local]
    for h in fitted:
        gain = h.explained - current.explained
        if not (oks[id(h)] and h.k_local > current.k_local and gain > 0 and pred):
            continue
        p_best = max(pred, key=lambda x: x.explained)
        ratio = (p_best.explained - current.explained) / gain
        if ratio >= PREDICTIVE_SHARE:
            oks[id(h)] = False
            h.notes.append(
                f"{_added(p_best).label} predicts the held-out data without re-estimating a course "
                f"there and removes {100 * min(ratio, 1.0):.1f} % of the error this one removes"
            )
    # a course the plant's physics shapes (a disturbance filtered by the plant, a coefficient
    # whose effect scales with the temperature rise) must fit the held-out recordings better
    # than a course of as many knots added to the reading unshaped: that one follows coloured
    # sensor noise as well as any course can, so a physical course that does no better is not
    # evidence of physics
    survived = 0
    for h in sorted(fitted, key=_key):  # the best first; at most BEAM survivors are tested
        # knots per recording of the baseline: as many as the hypothesis fits or reads there
        read = (h.k_recorded_val - current.k_recorded_val) / max(1, len(data.val))
        n_new = min(64, h.k_local - current.k_local + math.ceil(read))
        if not (oks[id(h)] and n_new >= 2 and data.course_baseline is not None):
            continue
        if survived >= BEAM:
            break
        if data.expired:
            data.skip(f"no course baseline beside {_added(h).label}")
            continue
        # g.last is this baseline candidate (a hypothesis keeps its candidates, fitted or not)
        gc = data.course_baseline(n_new)
        g = fit_hypothesis(spec, current, gc, data, nominal)
        h.baseline = {
            **h.baseline,
            "course": {
                "baseline": f"{gc.form} on {gc.target} ({n_new} knots per recording)",
                "delta_ic": g.delta_ic,
                "validation_after": g.validation_after,
                "physics_favoured": bool(not g.ok or h.delta_ic < g.delta_ic),
            },
        }
        if g.ok and g.delta_ic <= h.delta_ic:
            oks[id(h)] = False
            h.notes.append(
                f"a course of {n_new} knots per recording added to {gc.target}'s reading "
                f"fits the held-out data as well (ΔIC {g.delta_ic:.1f} against "
                f"{h.delta_ic:.1f}): what this course follows cannot be told from coloured "
                "noise of the sensor"
            )
        else:
            survived += 1
    pred = [h for h in fitted if oks[id(h)] and h.k_local == current.k_local]
    # a hypothesis that predicts the held-out data outright is stronger evidence than one
    # whose course had to be re-estimated on them, unless that one is both independent of the
    # inputs and better by the information criterion
    best_pred = min((_key(h) for h in pred), default=math.inf)
    fitted.sort(
        key=lambda h: (
            not oks[id(h)],
            h.k_local > current.k_local and _key(h) >= best_pred,
            _key(h),
        )
    )
    passed = [oks[id(h)] for h in fitted]
    rest = [h for h in screened if h not in top]
    rest.sort(key=lambda h: (h.error != "", h.delta_ic_train))
    return fitted, passed, rest


def course_independence(h: Hypothesis, data: Data) -> tuple[float, str]:
    """Whether a hypothesis' per-recording course is independent of the manipulated inputs.

    An unmeasured disturbance, a supply's wander or a drifting coefficient is
    not set by the operator: its course must not follow what the inputs do.
    A course fitted to absorb a model-structure error (a loss that grows with
    the temperature the heater sets) does. The course of every recording
    (training and held-out, at the values fitted in each) and each
    manipulated input are averaged over 12 blocks per recording; the
    correlation of their deviations from each recording's mean (the input
    taken in the same block and one block earlier) is tested by Fisher's z
    with a Bonferroni correction over inputs and lags.

    Returns
    -------
    p : float
        Smallest corrected p-value (1 when there is no course or no input).
    where : str
        The input it follows most, in words.
    """
    model = h.model
    if not isinstance(model, AugmentedModel) or not h.local:
        return 1.0, ""
    ins = [s.name for s in model.inputs]
    exo = list(model.exogenous_names)
    exps = [*data.train, *data.val]
    locs = [*h.local_train, *h.local_val]
    if len(locs) != len(exps) or not ins:
        return 1.0, ""
    xs: dict[tuple[str, int], list[float]] = {}
    ds: list[float] = []
    # h was fitted (it passed its round), so its values are set
    assert h.theta is not None, "internal: a kept hypothesis has no fitted values"
    for e, loc in zip(exps, locs, strict=True):
        th = h.theta.copy()
        for k, v in loc.items():
            th[model.param_index(k)] = v
        courses = model.courses(th, e.n, e.dt)
        if not courses:
            return 1.0, ""
        d = courses[0][2][0]
        nb = 12
        if e.n < 2 * nb:
            continue
        edges = np.linspace(0, e.n, nb + 1).astype(int)
        db = np.add.reduceat(d, edges[:-1]) / np.diff(edges)
        ds += list(db[1:] - db[1:].mean())
        for name in ins:
            u = e.u[:, exo.index(name)]
            ub = np.add.reduceat(u, edges[:-1]) / np.diff(edges)
            for lag in (0, 1):
                x = ub[1 - lag : nb - lag]
                xs.setdefault((name, lag), []).extend(list(x - x.mean()))
    n = len(ds)
    n_rec = len(exps)
    if n - n_rec < 4:
        return 1.0, ""
    dv = np.array(ds)
    best_p, where = 1.0, ""
    m = len(xs)
    for (name, lag), x_block in xs.items():
        xv = np.array(x_block)
        if xv.std() == 0 or dv.std() == 0:
            continue
        r = float(np.corrcoef(xv, dv)[0, 1])
        z = math.atanh(min(abs(r), 0.999999)) * math.sqrt(max(n - n_rec - 3, 1))
        p = min(1.0, m * 2.0 * float(stats.norm.sf(z)))
        if p < best_p:
            best_p = p
            where = f"{name}{' one block earlier' if lag else ''} (r = {r:+.2f})"
    return best_p, where


def _next_pool(pool: Sequence[Candidate], current: Hypothesis) -> list[Candidate]:
    """Candidates at other places or of other effects than those kept."""
    keys = {c.key for c in current.candidates}
    kept = {(c.effect, c.target) for c in current.candidates}
    return [c for c in pool if c.key not in keys and (c.effect, c.target) not in kept]


def total_ic(nominal: Hypothesis, h: Hypothesis, data: Data) -> float:
    """Held-out information criterion of a whole combination against the nominal model."""
    chi2, n = whitened_chi2(residuals_of(nominal, data)[1], residuals_of(h, data)[1])
    return delta_ic(chi2, h.k_global + len(data.val) * h.k_local + h.k_recorded_val, n)


def forward_selection(
    spec: NominalSpec,
    nominal: Hypothesis,
    candidates: Sequence[Candidate],
    data: Data,
    *,
    max_effects: int = MAX_EFFECTS,
    n_full_first: int = N_FULL_FIRST,
    n_full_next: int = N_FULL_NEXT,
    beam: int = BEAM,
) -> Selection:
    """Forward selection with joint refits (module docstring).

    The first round keeps the ``beam`` best passing hypotheses as separate
    paths (two forms of one effect, or two effects that each mimic the other
    partly, are told apart only once a second effect joins them); every path
    then grows greedily; the combination with the lowest held-out information
    criterion against the nominal model is reported.
    """
    sel = Selection()
    paths: list[tuple[list[Hypothesis], list[Candidate], bool]] = [([], list(candidates), False)]
    # per path (by the id of its step list): the candidates its last round tried and rejected
    rejected: dict[int, set[str]] = {}
    full: list[Candidate] = list(candidates)
    promising: set[int] = {id(c) for c in candidates}
    for r in range(max_effects):
        grown: list[tuple[list[Hypothesis], list[Candidate], bool]] = []
        for steps, pool, done in paths:
            if done or not pool or data.expired:
                if not done and pool and data.expired:
                    data.skip(
                        f"none of {len(pool)} candidates tried on top of "
                        + " + ".join(h.last.label for h in steps if h.last)
                        if steps
                        else f"none of {len(pool)} candidates tried"
                    )
                grown.append((steps, pool, True))
                continue
            current = steps[-1] if steps else nominal
            fitted, oks, rest = _round(
                spec, current, pool, data, nominal, n_full_first if r == 0 else n_full_next
            )
            if r == 0:
                sel.rounds.append(fitted)
                sel.passed.append(oks)
                sel.first_round = [*fitted, *rest]
                # the second round of the leading path screens every candidate that could be
                # fitted, those that helped the training fit most on their own first (under a
                # time limit they are the ones tried): an effect masked by a larger one (a
                # radiative loss under a sensor lag that smooths every transient) explains
                # nothing alone and shows only once the larger one is modelled. Other paths
                # and later rounds screen only what improved the training fit on its own
                rank = {
                    id(h.last): (h.delta_ic_train if math.isfinite(h.delta_ic_train) else 1e300)
                    for h in sel.first_round
                    if h.last is not None and not h.error
                }
                promising = {i for i, v in rank.items() if v < 0}
                full = sorted((c for c in pool if id(c) in rank), key=lambda c: rank[id(c)])
                pool = [c for c in full if id(c) in promising]
            elif steps is paths[0][0]:
                sel.rounds.append(fitted)
                sel.passed.append(oks)
            winners = [h for h, ok in zip(fitted, oks, strict=True) if ok]
            if not winners:
                rejected[id(steps)] = {h.last.label for h in [*fitted, *rest] if h.last}
                grown.append((steps, pool, True))
                continue
            if r == 0:
                # the same form of the same effect at another port (a disturbance entered
                # through the surroundings or beside the heater) is not an alternative
                # explanation: the beam holds distinct forms
                distinct: list[Hypothesis] = []
                for w in winners:
                    c = _added(w)
                    if all(
                        (c.effect, c.form) != (_added(x).effect, _added(x).form) for x in distinct
                    ):
                        distinct.append(w)
                winners = distinct
            for k, w in enumerate(winners[: beam if r == 0 else 1]):
                data.say(f"kept {_added(w).label} (ΔIC {w.delta_ic:.1f})")
                nxt = full if (r == 0 and k == 0) else [c for c in pool if id(c) in promising]
                grown.append(([*steps, w], _next_pool(nxt, w), False))
        paths = grown
        if all(done for _, _, done in paths):
            break
    ended = [steps for steps, _, _ in paths if steps]
    # a combination that another path reached without an effect it then tried and rejected
    # is that path plus a rejected effect: the held-out test already said no to it
    kept = [
        s
        for s in ended
        if not any(
            _labels(o) < _labels(s) and (_labels(s) - _labels(o)) & rejected.get(id(o), set())
            for o in ended
        )
    ]
    finals = [(steps, total_ic(nominal, steps[-1], data)) for steps in kept or ended]
    if finals:
        steps = choose_combination(finals)
        # paths that reach the same combination in another order: the order is the one whose
        # first effect explained most on its own (the shares are counted along the order)
        same = [s for s, _ in finals if _labels(s) == _labels(steps)]
        # two statements: inside list(...) mypy infers min's type from the context
        first = min(same, key=lambda s: s[0].delta_ic)
        sel.steps = list(first)
    return sel


def choose_combination(finals: Sequence[tuple[list[Hypothesis], float]]) -> list[Hypothesis]:
    """The combination reported among the paths' ends, each with its held-out total ΔIC.

    The lowest criterion, unless a simpler end removes nearly all the error
    that one removes (at least :data:`PREDICTIVE_SHARE`): the same preference
    as within a round. Simpler is fewer courses re-estimated on the held-out
    data, or as many and fewer effects (one drift against an extra store plus
    an offset that together remove 0.1 % more). Among the simpler ends, the
    fewest courses, then the fewest effects, then the criterion.
    """
    steps, _ = min(finals, key=lambda x: x[1])
    gain = steps[-1].explained
    k = _per_recording(steps[-1])
    simpler = [
        (s, ic)
        for s, ic in finals
        if (_per_recording(s[-1]) < k or (_per_recording(s[-1]) == k and len(s) < len(steps)))
        and gain > 0
        and s[-1].explained >= PREDICTIVE_SHARE * gain
    ]
    if simpler:
        steps, _ = min(simpler, key=lambda x: (_per_recording(x[0][-1]), len(x[0]), x[1]))
    return steps


def _per_recording(h: Hypothesis) -> float:
    """Numbers fitted on or read from each held-out recording (a course's knots, event times)."""
    return h.k_local + h.k_recorded_val / max(1, len(h.sims_val))


def _labels(steps: Sequence[Hypothesis]) -> frozenset[str]:
    return frozenset(h.last.label for h in steps if h.last is not None)


def shares(nominal: Hypothesis, steps: Sequence[Hypothesis]) -> list[float]:
    """Each kept effect's share of the held-out squared error the combination removes."""
    total = nominal.wsse_val - (steps[-1].wsse_val if steps else nominal.wsse_val)
    out = []
    prev = nominal.wsse_val
    for h in steps:
        out.append(float((prev - h.wsse_val) / total) if total > 0 else math.nan)
        prev = h.wsse_val
    return out


def as_dict(h: Hypothesis, rank: int) -> dict[str, Any]:
    """A ranked hypothesis for the report."""
    return {"rank": rank, **h.to_dict()}
