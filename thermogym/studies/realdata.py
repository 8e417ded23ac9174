"""FOPTD and N4SID on the real data sets shipped in :mod:`thermogym.datasets`.

Data nobody here generated check the identification methods where the
virtual rigs cannot: real noise, quantisation, unmeasured disturbances and
plants that are not exactly linear. Each case of :data:`CASES` says how a data
set is used:

==================  =====================  ==============================================
case                training               validation
==================  =====================  ==============================================
hair_dryer          first half             second half (DaISy 96-006, MATLAB ``dryer2``)
thermic_wall        first half             second half
heat_exchanger      first half             second half
glass_furnace       first half             second half
building            first half             second half
tclab_sin_2_50      run 1                  runs 2 and 3 (same experiment repeated)
tclab_5min          sine test              sin_5_50 run 2, both step tests
tclab_mimo          MIMO steps, 1 s        the two 3 s MIMO runs (resampled to 3 s)
==================  =====================  ==============================================

For each case: an FOPTD set (paper 000, section 4.1) and an N4SID model whose
order is chosen by 2-fold cross-validation on the training data (paper 001,
eqs 7-10, the training data cut in two when it is a single record), both
evaluated on the validation data with the metrics of
:mod:`~thermogym.identification.metrics`. TCLab data start at rest with the
heater switched on at ``t = 0`` (operating point ``"rest"``); TCLab time
stamps jitter (0.98-1.02 s, one 2 s gap), so those runs are resampled
(:mod:`~thermogym.identification.prepare`).

Published reference: MATLAB's System Identification Toolbox example
"Estimating Simple Models from Real Laboratory Process Data" uses the hair
dryer (``dryer2``, the same 1000 samples at 0.08 s; estimation on the first
samples, validation on the rest, after removing the means). The stored copy of
that page available here ends before its fit figures, so no published fit
value is compared; see ``benchmarks/results/identification/README.md``.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from thermogym.datasets import load
from thermogym.errors import UnknownNameError
from thermogym.fitresult import FitResult
from thermogym.identification.crossval import (
    OrderCV,
    cross_validate_order,
    deviation_recordings,
    split_recording,
)
from thermogym.identification.foptd import fit_foptd
from thermogym.identification.n4sid import n4sid
from thermogym.identification.prepare import prepare
from thermogym.recording import Recording

__all__ = ["CASES", "Case", "CaseResult", "case_data", "identify_all", "identify_case"]


@dataclass(frozen=True)
class Case:
    """How one shipped data set is identified and validated.

    Attributes
    ----------
    name : str
    train : tuple of str
        Data set names used for training (``thermogym.datasets.load``).
    validate : tuple of str
        Data sets for validation; empty: the second half of the training set.
    inputs, outputs : tuple of str
    operating_point : str
        ``"mean"`` (MATLAB ``detrend``), ``"initial"`` or ``"rest"``.
    n4sid_operating_point : str, optional
        A different one for N4SID (``"none"``: absolute values, e.g. when an
        input such as the outdoor temperature sets the output level).
    dt : float, optional
        Resample to this period [s] first (irregular time stamps).
    orders : tuple of int
        N4SID orders tried by cross-validation.
    max_delay_s : float, optional
        FOPTD delay search range [s].
    note : str
    """

    name: str
    train: tuple[str, ...]
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    validate: tuple[str, ...] = ()
    operating_point: str = "mean"
    n4sid_operating_point: str | None = None
    dt: float | None = None
    orders: tuple[int, ...] = tuple(range(1, 11))
    max_delay_s: float | None = None
    note: str = ""


CASES: dict[str, Case] = {
    c.name: c
    for c in (
        Case(
            "hair_dryer",
            ("hair_dryer",),
            ("u",),
            ("y",),
            max_delay_s=1.6,
            note="heater voltage -> outlet air temperature (thermocouple voltage)",
        ),
        Case(
            "thermic_wall",
            ("thermic_wall",),
            ("T_in", "T_out"),
            ("q",),
            max_delay_s=30.0,
            note="inner and outer temperatures -> heat-flow density",
        ),
        Case(
            "heat_exchanger",
            ("heat_exchanger",),
            ("q",),
            ("th",),
            max_delay_s=60.0,
            note="liquid flow -> outlet temperature (non-minimum phase)",
        ),
        Case(
            "glass_furnace",
            ("glass_furnace",),
            ("u1", "u2", "u3"),
            ("y1", "y2", "y3", "y4", "y5", "y6"),
            max_delay_s=20.0,
            note="3 heating/cooling inputs -> 6 temperatures (normalised)",
        ),
        Case(
            "building",
            ("building",),
            ("P_heater", "T_out", "G_solar"),
            ("T_in",),
            n4sid_operating_point="none",
            max_delay_s=3600.0,
            note="PRBS heater, outdoor temperature, solar -> indoor temperature; N4SID on "
            "absolute values (with zero heating and sun the room tends to the outdoor "
            "temperature, so the levels themselves carry the gain)",
        ),
        Case(
            "tclab_sin_2_50",
            ("tclab_sin_2_50_run1",),
            ("Q1",),
            ("T1", "T2"),
            validate=("tclab_sin_2_50_run2", "tclab_sin_2_50_run3"),
            operating_point="rest",
            dt=1.0,
            max_delay_s=60.0,
            note="heater 1 -> both sensors; train on run 1, validate on the repeats",
        ),
        Case(
            "tclab_5min",
            ("tclab_sine",),
            ("Q1",),
            ("T1", "T2"),
            validate=("tclab_sin_5_50_run2", "tclab_step", "tclab_step_50_run2"),
            operating_point="rest",
            dt=1.0,
            max_delay_s=60.0,
            note="5-min sine -> validated on a repeat and on two step tests",
        ),
        Case(
            "tclab_mimo",
            ("tclab_mimo_1s",),
            ("Q1", "Q2"),
            ("T1", "T2"),
            validate=("tclab_mimo_3s_a", "tclab_mimo_3s_b"),
            operating_point="rest",
            dt=3.0,
            max_delay_s=60.0,
            note="two heaters -> two sensors; 1 s run resampled to 3 s, validated on 3 s runs",
        ),
    )
}


@dataclass
class CaseResult:
    """Outcome of :func:`identify_case`.

    Attributes
    ----------
    case : Case
    foptd : FitResult
    n4sid : FitResult
    cv : OrderCV
    seconds : dict
        Wall time of each step [s].
    summary : dict
        JSON-ready numbers (MNRMSE on training and validation, order, ...).
    """

    case: Case
    foptd: FitResult
    n4sid: FitResult
    cv: OrderCV
    seconds: dict[str, float] = field(default_factory=dict)
    summary: dict[str, Any] = field(default_factory=dict)


def _load(name: str, dt: float | None) -> Recording:
    rec = load(name)
    if dt is not None or not rec.is_uniform():
        rec = prepare(rec, dt=dt or float(np.median(np.diff(rec.time))), outliers=False)
    return rec


def case_data(case: Case | str) -> tuple[list[Recording], list[Recording]]:
    """Training and validation recordings of a case (prepared, uniform)."""
    c = _case(case)
    train = [_load(n, c.dt) for n in c.train]
    if c.validate:
        vals = [_load(n, c.dt) for n in c.validate]
    else:
        first, second = split_recording(train[0], 2)
        train, vals = [first], [second]
    return train, vals


def _case(case: Case | str) -> Case:
    if isinstance(case, Case):
        return case
    try:
        return CASES[case]
    except KeyError:
        raise UnknownNameError(f"unknown case {case!r}; cases are {list(CASES)}") from None


def identify_case(case: Case | str, *, orders: Sequence[int] | None = None) -> CaseResult:
    """FOPTD and cross-validated N4SID of one case, evaluated on its validation data.

    Parameters
    ----------
    case : Case or str
        A :class:`Case` or a name in :data:`CASES`.
    orders : sequence of int, optional
        Override the case's N4SID orders.

    Returns
    -------
    CaseResult
    """
    c = _case(case)
    t0 = time.perf_counter()
    train, vals = case_data(c)
    t1 = time.perf_counter()
    fo = fit_foptd(
        train,
        list(c.inputs),
        list(c.outputs),
        max_delay_s=c.max_delay_s,
        operating_point_mode=c.operating_point,
        validate=vals,
    )
    t2 = time.perf_counter()
    op = c.n4sid_operating_point or c.operating_point
    # folds about each whole recording's operating point (a half of a run from rest does
    # not start at rest)
    dev = deviation_recordings(train, list(c.inputs), list(c.outputs), op)
    folds = split_recording(dev[0], 2) if len(dev) == 1 else dev
    cv = cross_validate_order(
        folds,
        list(c.inputs),
        list(c.outputs),
        orders or c.orders,
        operating_point_mode=op,
        deviations=True,
    )
    ss = n4sid(
        train,
        list(c.inputs),
        list(c.outputs),
        cv.chosen_order,
        operating_point_mode=op,
        validate=vals,
    )
    ss.fit.settings["cross_validation"] = cv.to_dict()
    ss.fit.settings["order_source"] = (
        "2-fold cross-validation on the training data (smallest order within tolerance)"
    )
    t3 = time.perf_counter()
    summary = {
        "case": c.name,
        "note": c.note,
        "train": [r.experiment_id for r in train],
        "validation": [r.experiment_id for r in vals],
        "inputs": list(c.inputs),
        "outputs": list(c.outputs),
        "operating_point": {"foptd": c.operating_point, "n4sid": op},
        "foptd": {
            "train_mnrmse": fo.fit.metrics["train"]["mnrmse"],
            "validation_mnrmse": fo.fit.metrics["validation"]["mnrmse"],
            "K": fo.K.tolist(),
            "T_s": fo.T.tolist(),
            "tau_s": fo.tau.tolist(),
            "seconds": fo.seconds,
        },
        "n4sid": {
            "order": cv.chosen_order,
            "argmax_order": cv.best_order,
            "cv_VA": float(np.max(cv.va)),
            "train_mnrmse": ss.fit.metrics["train"]["mnrmse"],
            "validation_mnrmse": ss.fit.metrics["validation"]["mnrmse"],
            "validation_per_output": {
                eid: rep["nrmse"]
                for eid, rep in ss.fit.metrics["validation"]["experiments"].items()
            },
            "decimate": ss.fit.settings["decimate"],
            "horizon": ss.fit.settings["horizon"],
        },
    }
    return CaseResult(
        c,
        fo.fit,
        ss.fit,
        cv,
        {"load": t1 - t0, "foptd": t2 - t1, "n4sid_cv": t3 - t2},
        summary,
    )


def identify_all(names: Sequence[str] | None = None) -> dict[str, CaseResult]:
    """:func:`identify_case` for every case (or the ones named)."""
    return {n: identify_case(n) for n in (names or list(CASES))}
