"""k-fold cross-validation of the N4SID model order (paper 001, eqs 7-10).

Paper 001 chooses the order of the spindle model by cross-validation over
experiments instead of the Hankel singular values::

    Accuracy = test(M^fold_{rpm,n}, D^fold_{rpm})                          (7)
    TA = ½ [test(M¹, D¹) + test(M², D²)]                                   (8)
    VA = ½ [test(M¹, D²) + test(M², D¹)]                                   (9)
    n* = argmax_n VA(rpm, n)                                              (10)

where ``test`` is the MNRMSE of eq (6). :func:`cross_validate_order`
generalises this to ``k`` folds (each a list of experiments):

* ``scheme="paper"`` (default): model ``i`` is trained on fold ``i`` alone
  and tested on every fold ``j``; TA is the mean of the diagonal, VA of the
  off-diagonal (for ``k = 2`` exactly eqs (8)-(9));
* ``scheme="kfold"``: the usual machine-learning k-fold — model ``i`` is
  trained on all folds but ``i``, VA is its fit on fold ``i`` and TA its fit
  on its own training folds.

For every training set the data are decomposed once
(:func:`~thermogym.identification.n4sid.n4sid_decompose`) and every order is
derived from that decomposition; the evaluation simulates each model at the
data's sample period with the initial state estimated on the tested
experiment (``x0="estimate"``, as MATLAB's ``compare``) or zero.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from thermogym._checks import integer
from thermogym.errors import ConfigError, IdentificationError
from thermogym.identification.advice import FitWarning, check_order, parsimonious_index
from thermogym.identification.linear_fit import offset_arrays, operating_point
from thermogym.identification.metrics import nrmse, train_validation_accuracy
from thermogym.identification.n4sid import N4SIDProblem, n4sid_decompose, prepare_problem
from thermogym.recording import Recording

__all__ = [
    "SCHEMES",
    "OrderCV",
    "cross_validate_order",
    "deviation_recordings",
    "make_folds",
    "split_excited",
    "split_recording",
]

#: Cross-validation schemes.
SCHEMES: tuple[str, ...] = ("paper", "kfold")


@dataclass
class OrderCV:
    """Outcome of :func:`cross_validate_order`.

    Attributes
    ----------
    orders : ndarray of int
    fits : ndarray, shape (n_orders, k, k)
        ``fits[o, i, j]``: MNRMSE (eq 6) of model ``i`` on fold ``j`` (scheme
        "paper"), or of model ``i`` on fold ``j`` where model ``i`` was trained
        on all folds but ``i`` (scheme "kfold").
    output_fits : ndarray, shape (n_orders, k, k, p)
        The same per output (NRMSE, eq 5).
    ta, va : ndarray, shape (n_orders,)
        Training and validation accuracy, eqs (8)-(9).
    best_order : int
        ``argmax VA``, eq (10) (reported beside, not used).
    parsimonious_order : int
        The lowest order whose VA is within ``tolerance`` of the best
        (:func:`~thermogym.identification.advice.parsimonious_index`, the rule
        used everywhere, also :attr:`chosen_order`): orders above the true one
        fit the noise and differ from it only in the last digits, so eq (10)
        picks among them by chance.
    tolerance : float
        VA tolerance of ``parsimonious_order`` (fraction, default 0.001 = 0.1 %).
    singular_values : list of ndarray
        Of each training set's decomposition.
    seconds : dict
        Wall time of the stages: ``decomposition``, ``models``,
        ``evaluation``, ``total`` [s].
    folds : list of list of str
        Experiment ids of each fold.
    scheme : str
    settings : dict
        Options of the identification (horizon, decimation, ...).
    """

    orders: NDArray[np.int64]
    fits: NDArray[np.float64]
    output_fits: NDArray[np.float64]
    ta: NDArray[np.float64]
    va: NDArray[np.float64]
    best_order: int
    singular_values: list[NDArray[np.float64]]
    seconds: dict[str, float]
    folds: list[list[str]]
    scheme: str
    output_names: list[str]
    parsimonious_order: int = 0
    tolerance: float = 1e-3
    settings: dict[str, Any] = field(default_factory=dict)

    @property
    def chosen_order(self) -> int:
        """The order the package uses: :attr:`parsimonious_order` (one rule everywhere)."""
        return self.parsimonious_order

    def warnings(self) -> list[FitWarning]:
        """``order_at_edge`` and ``flat_cv`` warnings of this curve (see :mod:`.advice`)."""
        return check_order(
            self.orders.tolist(), self.va, self.chosen_order, tolerance=self.tolerance
        )

    def table(self) -> list[dict[str, float]]:
        """One row per order: order, TA, VA (fractions)."""
        return [
            {"order": int(n), "TA": float(t), "VA": float(v)}
            for n, t, v in zip(self.orders, self.ta, self.va, strict=True)
        ]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary."""
        k = int(np.argmax(self.va))
        return {
            "scheme": self.scheme,
            "folds": self.folds,
            "orders": self.orders.tolist(),
            "TA": self.ta.tolist(),
            "VA": self.va.tolist(),
            "best_order": self.best_order,
            "parsimonious_order": self.parsimonious_order,
            "tolerance": self.tolerance,
            "best_TA": float(self.ta[k]),
            "best_VA": float(self.va[k]),
            "fits": self.fits.tolist(),
            "singular_values": [s.tolist() for s in self.singular_values],
            "seconds": self.seconds,
            "settings": self.settings,
        }


def split_recording(rec: Recording, k: int) -> list[Recording]:
    """Cut one recording into ``k`` contiguous parts of (nearly) equal length.

    For cross-validation when only one experiment exists; each part keeps the
    recording's metadata and gets the id ``<id>-part<j>``.

    Examples
    --------
    >>> rec = Recording(np.arange(10.0), {"y": np.arange(10.0)}, experiment_id="run")
    >>> [(p.experiment_id, p.n_samples) for p in split_recording(rec, 3)]
    [('run-part1', 3), ('run-part2', 4), ('run-part3', 3)]
    """
    k = integer("k", k, lo=2, error=ConfigError)
    if rec.n_samples < 2 * k:
        raise IdentificationError(f"{rec.n_samples} samples cannot be cut into {k} parts")
    edges = np.linspace(0, rec.n_samples, int(k) + 1).round().astype(int)
    return _parts(rec, edges.tolist())


def _changes(x: NDArray[np.float64]) -> NDArray[np.int64]:
    """Indices ``i`` where ``x[i + 1]`` differs from ``x[i]`` (beyond round-off; NaN: none)."""
    finite = np.abs(x[np.isfinite(x)])
    tol = 1e-12 * max(1.0, float(finite.max()) if finite.size else 1.0)
    with np.errstate(invalid="ignore"):
        return np.flatnonzero(np.abs(np.diff(x)) > tol).astype(np.int64)


def split_excited(
    rec: Recording, k: int, inputs: Sequence[str], *, min_samples: int = 16
) -> list[Recording]:
    """Cut one recording into ``k`` contiguous parts in each of which every input moves.

    A short real recording with a few input steps cut into equal parts gives
    parts where an input is constant, which carry no information about its
    dynamics (identification refuses them). The cuts here are placed as close
    to the equal split as the data allow such that every part holds a change
    of every input and at least ``min_samples`` samples, and each cut falls
    where an input moves (the part after it starts with that change).

    Parameters
    ----------
    rec : Recording
    k : int
        Number of parts, >= 2.
    inputs : sequence of str
        Input columns that must move in every part.
    min_samples : int
        Fewest samples of a part.

    Returns
    -------
    list of Recording
        Ids ``<id>-part<j>`` as :func:`split_recording`.

    Raises
    ------
    IdentificationError
        The inputs do not change often enough for ``k`` such parts.

    Examples
    --------
    >>> u = np.r_[np.zeros(40), np.ones(5), np.zeros(45), np.ones(10)]  # two short pulses
    >>> rec = Recording(np.arange(100.0), {"u": u, "y": u}, experiment_id="run")
    >>> [p.n_samples for p in split_recording(rec, 2)]  # the second half is constant
    [50, 50]
    >>> [p.n_samples for p in split_excited(rec, 2, ["u"])]
    [45, 55]
    """
    k = integer("k", k, lo=2, error=ConfigError)
    n = rec.n_samples
    missing = [c for c in inputs if c not in rec.columns]
    if missing:
        raise ConfigError(f"inputs {missing} are not columns of recording {rec.experiment_id!r}")
    changes = [_changes(np.asarray(rec[c], dtype=float)) for c in inputs]
    moves = np.unique(np.concatenate(changes)) + 1 if changes else np.arange(n)

    def earliest_end(start: int) -> int:
        # smallest end e such that [start, e) holds a change of every input: x[i] != x[i+1]
        # with start <= i and i + 1 < e
        e = start + int(min_samples)
        for ch in changes:
            j = int(np.searchsorted(ch, start))
            if j >= ch.size:
                return n + 1
            e = max(e, int(ch[j]) + 2)
        return e

    def feasible(start: int, parts: int) -> bool:
        for _ in range(parts - 1):
            start = earliest_end(start)
            if start > n:
                return False
        return earliest_end(start) <= n

    if not feasible(0, k):
        raise IdentificationError(
            f"recording {rec.experiment_id!r}: the inputs {list(inputs)} do not change often "
            f"enough for {k} parts in each of which every input moves ({n} samples, "
            f"{min(ch.size for ch in changes) if changes else n} changes of the least "
            "moving input)"
        )
    edges = [0]
    for j in range(1, k):
        lo = earliest_end(edges[-1])
        # the largest cut that still leaves room for the remaining parts (monotone)
        a, b = lo, n
        while a < b:
            mid = (a + b + 1) // 2
            if feasible(mid, k - j):
                a = mid
            else:
                b = mid - 1
        hi = a
        target = round(j * n / k)
        cand = moves[(moves >= lo) & (moves <= hi)]
        if cand.size:  # cut where an input moves, nearest the equal split
            cut = int(cand[np.argmin(np.abs(cand - target))])
        else:
            cut = int(np.clip(target, lo, hi))
        edges.append(cut)
    edges.append(n)
    return _parts(rec, edges)


def _parts(rec: Recording, edges: Sequence[int]) -> list[Recording]:
    k = len(edges) - 1
    parts = []
    for j in range(k):
        sel = slice(int(edges[j]), int(edges[j + 1]))
        parts.append(
            Recording(
                rec.time[sel],
                {c: rec[c][sel] for c in rec.columns},
                units=dict(rec.units),
                roles=dict(rec.roles),
                experiment_id=f"{rec.experiment_id or 'recording'}-part{j + 1}",
                source=rec.source,
                meta={**rec.meta, "part": j + 1, "of": k},
            )
        )
    return parts


def make_folds(
    recordings: Sequence[Recording],
    k: int,
    inputs: Sequence[str],
    *,
    min_samples: int = 16,
) -> tuple[list[list[Recording]] | None, list[str]]:
    """Folds for :func:`cross_validate_order` with excitation in each, or a stated fallback.

    Several recordings (at least ``k``) are dealt round robin into ``k``
    folds. One recording is cut with :func:`split_excited`; when it cannot
    give ``k`` parts with every input moving, fewer parts are tried (down to
    2); when not even two such parts exist there is no cross-validation
    (``None``). Every departure from what was asked is described in the
    returned notes (the CLI prints them as ``cv_fallback`` warnings).

    Returns
    -------
    folds : list of list of Recording, or None
    notes : list of str
    """
    k = integer("--folds", k, lo=2, error=ConfigError)
    recs = list(recordings)
    if not recs:
        raise ConfigError("no recording to cross-validate on")
    if len(recs) >= k:
        return [recs[f::k] for f in range(k)], []
    if len(recs) > 1:
        raise ConfigError(
            f"--folds {k} with {len(recs)} recordings: give one recording (it is cut into "
            f"{k} parts) or at least {k}"
        )
    rec = recs[0]
    notes: list[str] = []
    equal = split_recording(rec, k)
    if all(_moves(p, inputs) for p in equal):
        return [[p] for p in equal], notes
    for kk in range(k, 1, -1):
        try:
            parts = split_excited(rec, kk, inputs, min_samples=min_samples)
        except IdentificationError:
            continue
        sizes = ", ".join(str(p.n_samples) for p in parts)
        if kk == k:
            notes.append(
                f"equal parts would leave an input constant in a fold; cut the recording "
                f"where the inputs move instead ({kk} parts of {sizes} samples)"
            )
        else:
            notes.append(
                f"the inputs do not move often enough for {k} folds with excitation in each; "
                f"used {kk} folds ({sizes} samples)"
            )
        return [[p] for p in parts], notes
    notes.append(
        f"the inputs of recording {rec.experiment_id!r} do not move in two separate parts; "
        "no cross-validation: the order comes from the singular values instead"
    )
    return None, notes


def deviation_recordings(
    recordings: Recording | Sequence[Recording],
    inputs: Sequence[str] | str,
    outputs: Sequence[str] | str,
    operating_point_mode: str,
    *,
    offsets: Mapping[str, Any] | None = None,
) -> list[Recording]:
    """Each recording minus its own operating point, for folds cut from it.

    A fold cut out of a recording must be judged about the recording's
    operating point, not its own: a part of a TCLab run cut at minute 5 does
    not start at rest (``"rest"``, ``"initial"``), and a part's mean is not
    the run's (``"mean"``). Cut the returned deviation recordings into folds
    (:func:`make_folds`, :func:`split_recording`) and pass
    ``deviations=True`` to :func:`cross_validate_order`. Other columns are
    kept as they are; ``meta["operating_point"]`` holds what was subtracted.
    ``offsets`` are given values that replace the mode's
    (:func:`~thermogym.identification.linear_fit.check_offsets`).

    Examples
    --------
    >>> rec = Recording(np.arange(4.0), {"u": [0.0, 1, 1, 1], "y": [20.0, 21, 22, 23]})
    >>> dev = deviation_recordings(rec, ["u"], ["y"], "rest")[0]
    >>> dev["y"].tolist(), split_recording(dev, 2)[1]["y"].tolist()
    ([0.0, 1.0, 2.0, 3.0], [2.0, 3.0])
    """
    recs = [recordings] if isinstance(recordings, Recording) else list(recordings)
    ins = [inputs] if isinstance(inputs, str) else list(inputs)
    outs = [outputs] if isinstance(outputs, str) else list(outputs)
    given = offset_arrays(offsets, ins, outs)
    out = []
    for rec in recs:
        missing = [c for c in ins + outs if c not in rec.columns]
        if missing:
            raise ConfigError(
                f"columns {missing} are not in recording {rec.experiment_id!r}; it has "
                f"{list(rec.columns)}"
            )
        u = np.column_stack([np.asarray(rec[c], dtype=float) for c in ins])
        y = np.column_stack([np.asarray(rec[c], dtype=float) for c in outs])
        u_op, y_op = operating_point(u, y, operating_point_mode, given)
        assert y_op is not None
        cols = {c: np.asarray(rec[c]) for c in rec.columns}
        cols.update({c: u[:, k] - u_op[k] for k, c in enumerate(ins)})
        cols.update({c: y[:, k] - y_op[k] for k, c in enumerate(outs)})
        op = {
            "mode": operating_point_mode,
            "inputs": dict(zip(ins, u_op.tolist(), strict=True)),
            "outputs": dict(zip(outs, y_op.tolist(), strict=True)),
        }
        out.append(
            Recording(
                rec.time,
                cols,
                units=dict(rec.units),
                roles=dict(rec.roles),
                experiment_id=rec.experiment_id,
                source=rec.source,
                meta={**rec.meta, "operating_point": op},
            )
        )
    return out


def _moves(rec: Recording, inputs: Sequence[str]) -> bool:
    return all(_changes(np.asarray(rec[c], dtype=float)).size > 0 for c in inputs)


def _as_folds(
    folds: Sequence[Recording | Sequence[Recording]],
) -> list[list[Recording]]:
    out = []
    for f in folds:
        out.append([f] if isinstance(f, Recording) else list(f))
    if len(out) < 2:
        raise ConfigError(
            f"cross-validation needs at least 2 folds, got {len(out)}; give several "
            "experiments, or cut one with split_recording(rec, k)"
        )
    if any(not f for f in out):
        raise ConfigError("a fold holds no recording")
    return out


def cross_validate_order(
    folds: Sequence[Recording | Sequence[Recording]],
    inputs: Sequence[str] | str,
    outputs: Sequence[str] | str,
    orders: Sequence[int] = range(1, 31),
    *,
    scheme: str = "paper",
    disturbances: Sequence[str] | None = None,
    horizon: int | None = None,
    decimate: int | str = "auto",
    weighting: str = "moesp",
    feedthrough: bool = False,
    x0: str = "estimate",
    operating_point_mode: str = "none",
    tolerance: float = 1e-3,
    deviations: bool = False,
    offsets: Mapping[str, Any] | None = None,
) -> OrderCV:
    """Choose the N4SID order by k-fold cross-validation over experiments.

    Parameters
    ----------
    folds : sequence
        Each fold a recording or a list of recordings (e.g. fold 1 and fold 2
        of Table 4 of paper 001).
    inputs, outputs : sequence of str
        Columns (as for :func:`~thermogym.identification.n4sid.n4sid`).
    orders : sequence of int
        Orders to try (paper: 1..30).
    scheme : {"paper", "kfold"}
        See the module docstring.
    disturbances, horizon, decimate, weighting, feedthrough, operating_point_mode
        As :func:`~thermogym.identification.n4sid.n4sid`. ``horizon``
        defaults to what the highest order needs.
    x0 : {"estimate", "zero"}
        Initial state of each tested experiment (and of each training
        experiment in the regression).
    tolerance : float
        VA tolerance of :attr:`OrderCV.parsimonious_order` (fraction).
    deviations : bool
        The folds hold deviations from their recordings' operating points
        already (:func:`deviation_recordings`, then cut): nothing more is
        subtracted (``operating_point_mode`` is only recorded) and an input
        held constant (a step from rest) is accepted.
    offsets : mapping, optional
        Given operating-point values that replace the mode's (as
        :func:`~thermogym.identification.n4sid.n4sid`; not used with
        ``deviations``: give them to :func:`deviation_recordings`).

    Returns
    -------
    OrderCV

    Examples
    --------
    >>> from thermogym.identification.n4sid import simulate_ss
    >>> rng = np.random.default_rng(3)
    >>> A = np.diag([0.95, 0.8]); B = np.ones((2, 1)); C = np.array([[1.0, 1.0]])
    >>> def run(seed):
    ...     u = np.random.default_rng(seed).normal(size=(600, 1))
    ...     y = simulate_ss(A, B, C, np.zeros((1, 1)), u)[:, 0] + 0.01 * rng.normal(size=600)
    ...     return Recording(np.arange(600.0), {"u": u[:, 0], "y": y})
    >>> cv = cross_validate_order([run(1), run(2)], ["u"], ["y"], range(1, 5), decimate=1)
    >>> cv.parsimonious_order, bool(cv.va[1] > cv.va[0] + 0.05)
    (2, True)
    """
    t_all = time.perf_counter()
    if scheme not in SCHEMES:
        raise ConfigError(f"scheme is {scheme!r}; expected one of {SCHEMES}")
    fl = _as_folds(folds)
    orders_a = np.array(sorted({int(n) for n in orders}), dtype=np.int64)
    if orders_a.size == 0 or orders_a[0] < 1:
        raise ConfigError(f"orders {list(orders)!r}: expected whole numbers >= 1")
    probs: list[N4SIDProblem] = [
        prepare_problem(
            f,
            inputs,
            outputs,
            disturbances=disturbances,
            operating_point_mode="none" if deviations else operating_point_mode,
            step_inputs=True if deviations else None,
            offsets=None if deviations else offsets,
        )
        for f in fl
    ]
    k = len(fl)
    p = len(probs[0].outputs)
    dts = {round(pr.dt, 12) for pr in probs}
    if len(dts) > 1:
        raise ConfigError(f"the folds have different sample periods {sorted(dts)} s")
    train_sets = (
        [[i] for i in range(k)]
        if scheme == "paper"
        else [[j for j in range(k) if j != i] for i in range(k)]
    )
    fits = np.full((orders_a.size, k, k), np.nan)
    out_fits = np.full((orders_a.size, k, k, p), np.nan)
    t_dec = t_mod = t_eval = 0.0
    svs = []
    settings: dict[str, Any] = {}
    for i, ts in enumerate(train_sets):
        t0 = time.perf_counter()
        us = [u for j in ts for u in probs[j].us]
        ys = [y for j in ts for y in probs[j].ys]
        dec = n4sid_decompose(
            us,
            ys,
            probs[0].dt,
            horizon=horizon,
            max_order=int(orders_a[-1]),
            decimate=decimate,
            weighting=weighting,
        )
        t_dec += time.perf_counter() - t0
        svs.append(dec.singular_values)
        settings = {
            "horizon": dec.horizon,
            "decimate": dec.decimate,
            "weighting": weighting,
            "feedthrough": feedthrough,
            "x0": x0,
            "operating_point_mode": operating_point_mode,
            "operating_point_of": "each recording before the cut" if deviations else "each fold",
            "inputs": probs[0].inputs + probs[0].disturbances,
            "outputs": probs[0].outputs,
        }
        for o, n in enumerate(orders_a):
            if n > dec.max_order:
                raise IdentificationError(
                    f"order {int(n)} exceeds what horizon {dec.horizon} supports "
                    f"({dec.max_order}); pass a larger horizon"
                )
            t1 = time.perf_counter()
            sys_ = dec.system(int(n), x0=x0, feedthrough=feedthrough)
            t_mod += time.perf_counter() - t1
            t2 = time.perf_counter()
            for j in range(k):
                vals = []
                for u, y in zip(probs[j].us, probs[j].ys, strict=True):
                    yh = sys_.predict(u, y, x0=x0)
                    vals.append(np.atleast_1d(nrmse(y.T, yh.T)))
                per = np.nanmean(np.stack(vals), axis=0)  # mean over the fold's experiments
                out_fits[o, i, j] = per
                fits[o, i, j] = float(np.nanmean(per))  # MNRMSE, eq (6)
            t_eval += time.perf_counter() - t2
    if scheme == "paper":
        ta = np.array([train_validation_accuracy(f)[0] for f in fits])
        va = np.array([train_validation_accuracy(f)[1] for f in fits])
    else:
        # model i: VA on the held-out fold i, TA on its training folds
        ta = np.array([np.mean([np.mean(f[i, train_sets[i]]) for i in range(k)]) for f in fits])
        va = np.array([np.mean([f[i, i] for i in range(k)]) for f in fits])
    va_safe = np.where(np.isfinite(va), va, -np.inf)
    best = int(orders_a[int(np.argmax(va_safe))])  # n* = argmax VA, eq (10)
    parsimonious = int(orders_a[parsimonious_index(va, tolerance)])
    return OrderCV(
        orders=orders_a,
        fits=fits,
        output_fits=out_fits,
        ta=ta,
        va=va,
        best_order=best,
        singular_values=svs,
        seconds={
            "decomposition": t_dec,
            "models": t_mod,
            "evaluation": t_eval,
            "total": time.perf_counter() - t_all,
        },
        folds=[[r.experiment_id or f"recording_{n}" for n, r in enumerate(f)] for f in fl],
        scheme=scheme,
        output_names=probs[0].outputs,
        parsimonious_order=parsimonious,
        tolerance=float(tolerance),
        settings=settings,
    )
