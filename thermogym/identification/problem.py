"""Identification problem: what is fitted, to which data, by which criterion.

The set-up of the identification coordinator of ``000_24627a5308ee07db.txt``
(section 3, workflow steps 3-7), for any :class:`~thermogym.identification.simmodel.SimModel`:

* **signal pairs** (measured column, simulated output) with a weight each; the
  criterion is eq (4), ``Σ_j w_j RMSE_j`` (:class:`SignalPair`);
* **parameters to fit** with bounds and start values (:class:`FreeParameter`);
  the rest keep the model's values or are **set manually** (``fixed``);
* **ratio parameters** (appendix of paper 000): one factor, 1 at the start,
  that multiplies the physically estimated values of one or several model
  parameters (:class:`RatioParameter`); the optimiser searches the ratio;
* **several experiments at once**: every pair is evaluated on every
  recording; the RMSE of a pair pools the samples of all experiments.

A :class:`Problem` maps an optimiser vector ``z`` (free values and ratios) to
the model's parameter batch, simulates a whole batch of candidates with one
``SimModel.simulate`` call per experiment, and returns their criteria,
residuals and failure messages. Optimisers work in *unit coordinates*
(``0 … 1`` across the bounds, logarithmic for ``scale="log"``), see
:meth:`Problem.to_unit`.

Two objectives are offered:

``"rmse"`` (default)
    eq (4) of paper 000: ``J = Σ_j w_j RMSE_j``.
``"mse"``
    the least-squares cost of eq (7) of ``002_dae2310635fe074e.txt`` with a
    weight per pair: ``J = Σ_j w_j MSE_j`` — the sum of squares of the
    residual vector ``r = √(w_j / N_j) (ŷ − y)`` that the local
    (Gauss-Newton / Levenberg-Marquardt) methods minimise.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from thermogym._checks import finite, nonnegative, positive
from thermogym.errors import (
    ConfigError,
    ExternalModelError,
    ParameterError,
    RecordingError,
    ShapeError,
    UnknownNameError,
)
from thermogym.identification.jacobian import residual_jacobian
from thermogym.identification.metrics import fit_report
from thermogym.identification.optimizers.sensitivities import sensitivity_function
from thermogym.identification.simmodel import SimBatch, SimModel, ThermogymModel
from thermogym.models._blas import blas_threads
from thermogym.models.base import Model
from thermogym.recording import Recording

__all__ = [
    "OBJECTIVES",
    "Evaluation",
    "FreeParameter",
    "Problem",
    "RatioParameter",
    "SignalPair",
]

#: Criteria a problem can minimise.
OBJECTIVES: tuple[str, ...] = ("rmse", "mse")
Scale = Literal["linear", "log"]


@dataclass(frozen=True)
class SignalPair:
    """A measured signal compared with a simulated one, eq (4) of paper 000.

    Parameters
    ----------
    measured : str
        Column of the recordings.
    simulated : str, optional
        Output of the model (default: the same name as ``measured``).
    weight : float
        Weight ``w_j`` of the pair in the criterion, >= 0.

    Examples
    --------
    >>> SignalPair("T_P", weight=2.0).simulated
    'T_P'
    """

    measured: str
    simulated: str | None = None
    weight: float = 1.0

    def __post_init__(self) -> None:
        if not isinstance(self.measured, str) or not self.measured:
            raise ConfigError(f"signal pair measured name is {self.measured!r}, expected a str")
        if self.simulated is None:
            object.__setattr__(self, "simulated", self.measured)
        w = self.weight
        if isinstance(w, bool) or not isinstance(w, int | float | np.floating | np.integer):
            raise ConfigError(
                f"weight of signal pair {self.measured!r} is {w!r}, expected a number"
            )
        w = nonnegative(f"weight of signal pair {self.measured!r}", w, text=False)
        object.__setattr__(self, "weight", w)

    @property
    def label(self) -> str:
        """``measured`` or ``measured~simulated`` when the names differ."""
        return (
            self.measured
            if self.simulated == self.measured
            else f"{self.measured}~{self.simulated}"
        )


@dataclass(frozen=True)
class FreeParameter:
    """A model parameter the optimiser varies.

    Parameters
    ----------
    name : str
        Parameter of the model.
    start : float, optional
        Start value (default: the model's value). Methods that need one
        (local, CMA-ES, annealing) begin there; the others include it.
    lower, upper : float, optional
        Search bounds (default: the model's bounds); both must be finite.
    scale : {"linear", "log"}
        ``"log"`` searches ``log(value)`` — for positive parameters whose
        range spans decades.
    """

    name: str
    start: float | None = None
    lower: float | None = None
    upper: float | None = None
    scale: Scale = "linear"


@dataclass(frozen=True)
class RatioParameter:
    """A ratio on physically estimated values (appendix of paper 000).

    The optimiser searches the ratio ``r`` (1 at the start); every target
    model parameter ``p_i`` gets ``r · p̂_i`` with ``p̂_i`` its physical
    estimate. One ratio may scale several model parameters that depend on the
    same uncertain physical quantity (paper 000, Table 5 / Fig. 10).

    Parameters
    ----------
    name : str
        Name of the ratio (e.g. ``"r_air"``), not a model parameter name.
    targets : sequence of str
        Model parameters the ratio multiplies.
    lower, upper : float
        Bounds of the ratio, from the uncertainty of the estimate (paper 000:
        +200/−70 % gives [0.3, 3.0], +30/−20 % gives [0.8, 1.3]).
    start : float
        Start value of the ratio (1: the estimate is right).
    estimates : mapping, optional
        Physical estimates ``p̂_i`` of the targets (default: the value the
        model would use — its nominal or the ``fixed`` value).
    scale : {"linear", "log"}
    """

    name: str
    targets: tuple[str, ...]
    lower: float = 0.3
    upper: float = 3.0
    start: float = 1.0
    estimates: Mapping[str, float] | None = None
    scale: Scale = "linear"

    def __post_init__(self) -> None:
        t = (self.targets,) if isinstance(self.targets, str) else tuple(self.targets)
        if not t:
            raise ConfigError(f"ratio {self.name!r} has no target parameters")
        object.__setattr__(self, "targets", t)


@dataclass
class Evaluation:
    """Criteria of a batch of candidate parameter sets.

    Attributes
    ----------
    criterion : ndarray, shape (B,)
        eq (4) of paper 000, ``Σ_j w_j RMSE_j``; ``inf`` for failed sets.
    mse : ndarray, shape (B,)
        ``Σ_j w_j MSE_j``; ``inf`` for failed sets.
    pair_rmse : ndarray, shape (B, n_pairs)
        RMSE of every signal pair, pooled over the experiments (NaN for failed sets).
    errors : list of str or None
        Failure message of each set (``None`` when it simulated).
    residuals : ndarray, shape (B, N), optional
        Weighted residual vector ``√(w_j/N_j) (ŷ − y)`` (zero where the
        measurement is missing), when requested.
    """

    criterion: NDArray[np.float64]
    mse: NDArray[np.float64]
    pair_rmse: NDArray[np.float64]
    errors: list[str | None]
    residuals: NDArray[np.float64] | None = None

    @property
    def ok(self) -> NDArray[np.bool_]:
        """Which sets simulated."""
        return np.array([e is None for e in self.errors], dtype=bool)

    def cost(self, objective: str) -> NDArray[np.float64]:
        """The criterion named ``objective`` (``"rmse"`` or ``"mse"``)."""
        return self.criterion if objective == "rmse" else self.mse


@dataclass
class _Counters:
    evaluations: int = 0  # parameter sets evaluated
    simulations: int = 0  # parameter sets x experiments simulated
    calls: int = 0  # SimModel.simulate calls
    sensitivity_runs: int = 0  # simulations with forward sensitivities (exact gradient)
    failures: int = 0

    def as_dict(self) -> dict[str, int]:
        return dict(vars(self))


def _as_pair(p: Any) -> SignalPair:
    if isinstance(p, SignalPair):
        return p
    if isinstance(p, str):
        return SignalPair(p)
    if isinstance(p, tuple | list) and 1 <= len(p) <= 3:
        return SignalPair(*p)
    if isinstance(p, Mapping):
        try:
            return SignalPair(**p)
        except TypeError as e:
            raise ConfigError(f"signal pair {dict(p)!r}: {e}") from e
    raise ConfigError(
        f"signal pair {p!r:.60} is not understood; give a name, (measured, simulated[, weight]) "
        "or a SignalPair"
    )


def _free_spec(item: Any, value: Any = None) -> FreeParameter:
    if isinstance(item, FreeParameter):
        return item
    if not isinstance(item, str):
        raise ConfigError(f"free parameter {item!r:.60} is not a name or a FreeParameter")
    if value is None:
        return FreeParameter(item)
    if isinstance(value, FreeParameter):
        return value
    if isinstance(value, Mapping):
        try:
            return FreeParameter(item, **value)
        except TypeError as e:
            raise ConfigError(f"free parameter {item!r}: {e}") from e
    if isinstance(value, tuple | list) and len(value) in (2, 3):
        lo, hi, *rest = value
        return FreeParameter(item, start=rest[0] if rest else None, lower=lo, upper=hi)
    raise ConfigError(
        f"free parameter {item!r}: {value!r:.60} is not understood; give (lower, upper), "
        "(lower, upper, start) or a dict with start/lower/upper/scale"
    )


def _number(v: Any, where: str) -> float:
    if isinstance(v, bool) or not isinstance(v, int | float | np.integer | np.floating):
        raise ConfigError(f"{where} is {v!r:.60}, expected a number")
    return float(v)


class Problem:
    """An identification problem over a :class:`SimModel` and recordings.

    Parameters
    ----------
    model : SimModel or Model
        What is identified. A thermogym :class:`~thermogym.models.base.Model`
        is wrapped in :class:`ThermogymModel` with every parameter exposed.
    experiments : Recording or sequence of Recording
        Training data; every pair is compared on every experiment.
    pairs : sequence, optional
        Signal pairs: names, ``(measured, simulated[, weight])`` tuples or
        :class:`SignalPair`. Default: every model output measured in all
        experiments, weight 1.
    free : sequence or mapping, optional
        Parameters to fit: names, :class:`FreeParameter` objects, or a mapping
        name → ``(lower, upper[, start])`` / dict / FreeParameter. Default:
        every model parameter neither fixed nor the target of a ratio.
    ratios : sequence of RatioParameter
        Ratio parameters (appendix of paper 000).
    fixed : mapping, optional
        Values set manually; they are not fitted (paper 000 workflow step 2).
    objective : {"rmse", "mse"}
        Criterion the global methods minimise (see the module docstring).
    max_batch_mb : float
        Largest simulated output array held at once [MiB]; larger batches are
        simulated in chunks.
    blas_threads : int or None
        BLAS threads while the model simulates (``None``: leave as is). A
        batch is thousands of *small* matrix operations (e.g. a 20 × 20 matrix
        exponential per parameter set), which multithreaded BLAS only slows
        down — by 10x on a busy machine; 1 is the right default.

    Raises
    ------
    ParameterError
        Unknown parameter, a parameter both fixed and fitted, infinite or
        reversed bounds, a start outside its bounds.
    RecordingError
        A measured column is missing in an experiment or has no valid sample.
    UnknownNameError
        A simulated name is not an output of the model.
    ConfigError
        Malformed specifications, unknown objective.

    Examples
    --------
    >>> from thermogym.rigs import run_experiment
    >>> from thermogym.models.strut import StrutModel
    >>> recs = run_experiment("strut", "steps", feed_rates=[20.0], seed=0)
    >>> pb = Problem(StrutModel(), recs, pairs=["T_nut", "T_drive"],
    ...              free=["r_motor", "r_nut"])
    >>> pb.names, pb.n_params
    (('r_motor', 'r_nut'), 2)
    >>> ev = pb.evaluate(pb.start[None])
    >>> ev.criterion.shape, bool(ev.ok[0])
    ((1,), True)
    """

    def __init__(
        self,
        model: SimModel | Model,
        experiments: Recording | Sequence[Recording],
        pairs: Sequence[Any] | None = None,
        *,
        free: Sequence[Any] | Mapping[str, Any] | None = None,
        ratios: Sequence[RatioParameter] = (),
        fixed: Mapping[str, float] | None = None,
        objective: str = "rmse",
        max_batch_mb: float = 256.0,
        blas_threads: int | None = 1,
    ) -> None:
        if isinstance(model, Model):
            model = ThermogymModel(model)
        if not isinstance(model, SimModel):
            raise ConfigError(
                f"model is a {type(model).__name__}; expected a thermogym Model or a SimModel "
                "(see thermogym.identification.simmodel)"
            )
        self.model: SimModel = model
        if objective not in OBJECTIVES:
            raise ConfigError(f"objective is {objective!r}, expected one of {OBJECTIVES}")
        self.objective = objective
        positive("max_batch_mb", max_batch_mb, error=ConfigError, text=False)
        self._max_bytes = float(max_batch_mb) * 2**20
        self.experiments: tuple[Recording, ...] = self._check_experiments(experiments)
        self._sim_names = tuple(model.param_names)
        self._sim_index = {n: i for i, n in enumerate(self._sim_names)}
        self._sim_nominal = np.asarray(model.nominal, dtype=float).copy()
        self._sim_lower = np.asarray(model.lower, dtype=float)
        self._sim_upper = np.asarray(model.upper, dtype=float)
        self._setup_parameters(free, ratios, fixed)
        self.pairs: tuple[SignalPair, ...] = self._setup_pairs(pairs)
        self._setup_data()
        self.counters = _Counters()
        self._sensitivity_fn: Any = None
        self._sensitivity_checked = False
        if blas_threads is not None and (isinstance(blas_threads, bool) or blas_threads < 1):
            raise ConfigError(f"blas_threads is {blas_threads!r}, expected a positive int or None")
        self.blas_threads = blas_threads

    # ------------------------------------------------------------------ set-up
    @staticmethod
    def _check_experiments(experiments: Any) -> tuple[Recording, ...]:
        exps = (experiments,) if isinstance(experiments, Recording) else tuple(experiments)
        if not exps:
            raise RecordingError("no experiment given; an identification needs recordings")
        for i, e in enumerate(exps):
            if not isinstance(e, Recording):
                raise RecordingError(
                    f"experiment {i} is a {type(e).__name__}, expected a thermogym Recording"
                )
        return exps

    def _check_param(self, name: str, what: str) -> int:
        try:
            return self._sim_index[name]
        except KeyError:
            raise ParameterError(
                f"{what} {name!r} is not a parameter of model {self.model.name!r}; its "
                f"parameters are {list(self._sim_names)}"
            ) from None

    def _setup_parameters(
        self,
        free: Sequence[Any] | Mapping[str, Any] | None,
        ratios: Sequence[RatioParameter],
        fixed: Mapping[str, float] | None,
    ) -> None:
        base = self._sim_nominal.copy()
        self.fixed: dict[str, float] = {}
        for k, v in dict(fixed or {}).items():
            j = self._check_param(k, "fixed parameter")
            val = finite(f"fixed value of {k!r}", _number(v, f"fixed value of {k!r}"))
            base[j] = val
            self.fixed[k] = val
        ratios = tuple(ratios)
        for r in ratios:
            if not isinstance(r, RatioParameter):
                raise ConfigError(f"ratio {r!r:.60} is not a RatioParameter")
        targets: dict[str, str] = {}
        for r in ratios:
            for t in r.targets:
                self._check_param(t, f"target of ratio {r.name!r}")
                if t in targets:
                    raise ParameterError(
                        f"parameter {t!r} is the target of ratios {targets[t]!r} and {r.name!r}; "
                        "a parameter can follow one ratio only"
                    )
                targets[t] = r.name
        if free is None:
            specs = [
                FreeParameter(n)
                for n in self._sim_names
                if n not in self.fixed and n not in targets
            ]
        elif isinstance(free, Mapping):
            specs = [_free_spec(k, v) for k, v in free.items()]
        else:
            specs = [_free_spec(x) for x in free]
        names: list[str] = []
        kinds: list[str] = []
        start: list[float] = []
        lower: list[float] = []
        upper: list[float] = []
        scales: list[str] = []
        # D maps the optimiser vector z to the model vector: θ = base ⊙ (1 − m) + D z
        cols: list[list[tuple[int, float]]] = []
        for s in specs:
            j = self._check_param(s.name, "free parameter")
            if s.name in self.fixed:
                raise ParameterError(
                    f"parameter {s.name!r} is both fixed (set manually) and free; choose one"
                )
            if s.name in targets:
                raise ParameterError(
                    f"parameter {s.name!r} is free and the target of ratio {targets[s.name]!r}"
                )
            lo = self._sim_lower[j] if s.lower is None else _number(s.lower, f"lower of {s.name!r}")
            hi = self._sim_upper[j] if s.upper is None else _number(s.upper, f"upper of {s.name!r}")
            st = base[j] if s.start is None else _number(s.start, f"start of {s.name!r}")
            names.append(s.name)
            kinds.append("free")
            start.append(st)
            lower.append(lo)
            upper.append(hi)
            scales.append(s.scale)
            cols.append([(j, 1.0)])
        self.estimates: dict[str, float] = {}
        for r in ratios:
            est = dict(r.estimates or {})
            unknown = [k for k in est if k not in r.targets]
            if unknown:
                raise ParameterError(
                    f"ratio {r.name!r} has estimates for {unknown}, which are not its targets "
                    f"{list(r.targets)}"
                )
            col = []
            for t in r.targets:
                j = self._sim_index[t]
                e = finite(f"estimate of {t!r}", _number(est.get(t, base[j]), f"estimate of {t!r}"))
                self.estimates[t] = e
                col.append((j, e))
            if r.name in self._sim_index and r.name not in r.targets:
                raise ParameterError(
                    f"ratio name {r.name!r} is a parameter of model {self.model.name!r}; name the "
                    "ratio differently (e.g. 'r_' + name)"
                )
            names.append(r.name)
            kinds.append("ratio")
            start.append(_number(r.start, f"start of ratio {r.name!r}"))
            lower.append(_number(r.lower, f"lower of ratio {r.name!r}"))
            upper.append(_number(r.upper, f"upper of ratio {r.name!r}"))
            scales.append(r.scale)
            cols.append(col)
        if len(set(names)) != len(names):
            dup = sorted({n for n in names if names.count(n) > 1})
            raise ParameterError(f"parameter(s) {dup} are given more than once")
        if not names:
            raise ParameterError(
                "nothing to identify: every parameter is fixed; name free parameters or ratios"
            )
        self.names: tuple[str, ...] = tuple(names)
        self.kinds: tuple[str, ...] = tuple(kinds)
        self.lower = np.array(lower, dtype=float)
        self.upper = np.array(upper, dtype=float)
        self.start = np.array(start, dtype=float)
        self.scales: tuple[str, ...] = tuple(scales)
        for i, n in enumerate(names):
            lo, hi, st, sc = self.lower[i], self.upper[i], self.start[i], scales[i]
            if sc not in ("linear", "log"):
                raise ConfigError(f"scale of {n!r} is {sc!r}, expected 'linear' or 'log'")
            if not (math.isfinite(lo) and math.isfinite(hi)):
                raise ParameterError(
                    f"parameter {n!r} has bounds [{lo!r}, {hi!r}]; the coordinator needs finite "
                    "bounds (paper 000 workflow step 4): give them, e.g. free={"
                    f"{n!r}: (lower, upper)}}"
                )
            if not lo < hi:
                raise ParameterError(
                    f"parameter {n!r} has bounds [{lo!r}, {hi!r}]; need lower < upper"
                )
            if not (math.isfinite(st) and lo <= st <= hi):
                raise ParameterError(
                    f"start value of {n!r} is {st!r}, outside its bounds [{lo!r}, {hi!r}]"
                )
            if sc == "log" and lo <= 0:
                raise ParameterError(
                    f"parameter {n!r} is searched on a log scale but its lower bound is {lo!r}; "
                    "a log scale needs positive bounds"
                )
        self._log = np.array([s == "log" for s in scales])
        P = len(names)
        D = np.zeros((len(self._sim_names), P))
        mask = np.zeros(len(self._sim_names), dtype=bool)
        for i, col in enumerate(cols):
            for j, f in col:
                D[j, i] = f
                mask[j] = True
        self._D = D
        self._base = np.where(mask, 0.0, base)
        self._base_values = base

    def _setup_pairs(self, pairs: Sequence[Any] | None) -> tuple[SignalPair, ...]:
        outs = tuple(self.model.output_names)
        if pairs is None:
            ps = [SignalPair(o) for o in outs if all(o in e for e in self.experiments)]
            if not ps:
                raise RecordingError(
                    f"no output of model {self.model.name!r} ({list(outs)}) is measured in every "
                    "experiment; name the signal pairs (measured, simulated)"
                )
        else:
            if isinstance(pairs, str | SignalPair):
                pairs = [pairs]
            ps = [_as_pair(p) for p in pairs]
            if not ps:
                raise ConfigError("pairs is empty; give at least one (measured, simulated) pair")
        for p in ps:
            if p.simulated not in outs:
                raise UnknownNameError(
                    f"simulated signal {p.simulated!r} (pair {p.label!r}) is not an output of "
                    f"model {self.model.name!r}; outputs are {list(outs)}"
                )
            for e in self.experiments:
                if p.measured not in e:
                    raise RecordingError(
                        f"experiment {e.experiment_id!r} has no column {p.measured!r} (pair "
                        f"{p.label!r}); its columns are {list(e.columns)}"
                    )
        labels = [p.label for p in ps]
        if len(set(labels)) != len(labels):
            raise ConfigError(f"signal pairs repeat: {labels}")
        if sum(p.weight for p in ps) <= 0:
            raise ParameterError("every signal pair has weight 0; at least one must be positive")
        return tuple(ps)

    def _setup_data(self) -> None:
        outs = list(self.model.output_names)
        self._out_cols = np.array(
            [outs.index(p.simulated or p.measured) for p in self.pairs], dtype=np.int64
        )
        self._y: list[NDArray[np.float64]] = []
        self._m: list[NDArray[np.bool_]] = []
        for e in self.experiments:
            y = np.column_stack([np.asarray(e[p.measured], dtype=float) for p in self.pairs])
            self._y.append(y)
            self._m.append(np.isfinite(y))
        n = np.sum([m.sum(axis=0) for m in self._m], axis=0)
        for j, p in enumerate(self.pairs):
            if n[j] == 0:
                raise RecordingError(
                    f"measured signal {p.measured!r} has no valid (finite) sample in any experiment"
                )
        self.n_samples: NDArray[np.int64] = n.astype(np.int64)
        self.weights = np.array([p.weight for p in self.pairs], dtype=float)
        # residual factor √(w_j / N_j), shape (n_pairs,)
        self._rfac = np.sqrt(self.weights / self.n_samples)
        self.n_residuals = int(sum(y.size for y in self._y))
        J = len(self.pairs)
        groups = [np.broadcast_to(np.arange(J), y.shape).ravel() for y in self._y]
        self.residual_groups: NDArray[np.int64] = np.concatenate(groups).astype(np.int64)
        # series (experiment × pair) and time index of every residual, for correlated noise
        self.residual_series: NDArray[np.int64] = np.concatenate(
            [e * J + np.broadcast_to(np.arange(J), y.shape).ravel() for e, y in enumerate(self._y)]
        ).astype(np.int64)
        self.residual_time: NDArray[np.int64] = np.concatenate(
            [np.repeat(np.arange(y.shape[0]), J) for y in self._y]
        ).astype(np.int64)
        self.residual_valid: NDArray[np.bool_] = np.concatenate([m.ravel() for m in self._m])

    # ------------------------------------------------------------ parameters
    @property
    def n_params(self) -> int:
        """Number of optimiser variables (free parameters and ratios)."""
        return len(self.names)

    @property
    def sim_param_names(self) -> tuple[str, ...]:
        """Parameters of the SimModel, the columns of :meth:`theta`."""
        return self._sim_names

    def _as_batch(self, z: ArrayLike) -> NDArray[np.float64]:
        a = np.asarray(z, dtype=float)
        if a.ndim == 1:
            a = a[None]
        if a.ndim != 2 or a.shape[1] != self.n_params:
            raise ShapeError(
                f"parameter batch has shape {np.shape(z)}, expected ({self.n_params},) or "
                f"(B, {self.n_params}) for {list(self.names)}"
            )
        return a

    def theta(self, z: ArrayLike) -> NDArray[np.float64]:
        """SimModel parameter batch (B, P_model) for optimiser vectors ``z`` (B, P).

        Free values are copied, ratio targets become ``ratio · estimate``, the
        rest keep their fixed or nominal values.
        """
        Z = self._as_batch(z)
        return self._base[None, :] + Z @ self._D.T

    @property
    def theta_jacobian(self) -> NDArray[np.float64]:
        """``∂θ/∂z`` (P_model, P): how model parameters move with the optimiser vector."""
        return self._D.copy()

    def values(self, z: ArrayLike) -> dict[str, float]:
        """Model parameter values (every SimModel parameter) for one vector ``z``."""
        th = self.theta(z)
        if th.shape[0] != 1:
            raise ShapeError(f"values() takes one parameter vector, got {th.shape[0]}")
        return dict(zip(self._sim_names, th[0].tolist(), strict=True))

    def as_dict(self, z: ArrayLike) -> dict[str, float]:
        """Optimiser variables (free values and ratios) by name for one vector ``z``."""
        a = self._as_batch(z)
        return dict(zip(self.names, a[0].tolist(), strict=True))

    def _t(self, z: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.where(self._log, np.log(np.where(self._log, np.maximum(z, 1e-300), 1.0)), z)

    def to_unit(self, z: ArrayLike) -> NDArray[np.float64]:
        """Unit coordinates ``(t(z) − t(lower)) / (t(upper) − t(lower))``, t = id or log."""
        Z = np.asarray(z, dtype=float)
        lo, hi = self._t(self.lower), self._t(self.upper)
        return (self._t(Z) - lo) / (hi - lo)

    def from_unit(self, u: ArrayLike) -> NDArray[np.float64]:
        """Inverse of :meth:`to_unit` (values outside [0, 1] are clipped)."""
        U = np.clip(np.asarray(u, dtype=float), 0.0, 1.0)
        lo, hi = self._t(self.lower), self._t(self.upper)
        t = lo + U * (hi - lo)
        # exp only of the log-scaled coordinates (exp of a linear one may overflow)
        z = t.copy()
        z[..., self._log] = np.exp(t[..., self._log])
        return np.clip(z, self.lower, self.upper)

    def unit_jacobian(self, z: ArrayLike) -> NDArray[np.float64]:
        """``dz/du`` per coordinate at ``z`` (the chain-rule factor of unit coordinates)."""
        Z = np.asarray(z, dtype=float)
        span = self._t(self.upper) - self._t(self.lower)
        return np.where(self._log, Z * span, span)

    # ------------------------------------------------------------ simulation
    def _chunk(self) -> int:
        T = max(e.n_samples for e in self.experiments)
        per_set = 8.0 * T * max(1, len(self.model.output_names))
        return max(1, int(self._max_bytes // per_set))

    def simulate(self, z: ArrayLike) -> tuple[list[NDArray[np.float64]], list[str | None]]:
        """Simulate a batch on every experiment.

        Parameters
        ----------
        z : array_like, shape (B, P) or (P,)

        Returns
        -------
        outputs : list of ndarray, one (B, T_e, n_pairs) per experiment
            The simulated signal of each pair (NaN rows for failed sets).
        errors : list of str or None
            Per set: ``None`` or ``"experiment <id>: <message>"``.
        """
        Z = self._as_batch(z)
        B = Z.shape[0]
        th = self.theta(Z)
        outs = [np.full((B, e.n_samples, len(self.pairs)), np.nan) for e in self.experiments]
        errors: list[str | None] = [None] * B
        step = self._chunk()
        for a in range(0, B, step):
            b = min(B, a + step)
            for ie, e in enumerate(self.experiments):
                alive = [i for i in range(a, b) if errors[i] is None]
                if not alive:
                    break
                idx = np.array(alive)
                sb = self._call(th[idx], e)
                y = sb.outputs[:, :, self._out_cols]
                errs = list(sb.errors) if sb.errors else [None] * len(idx)
                for k, i in enumerate(idx):
                    msg = errs[k]
                    if msg is None and not np.isfinite(y[k]).all():
                        j = int(np.argwhere(~np.isfinite(y[k]))[0][1])
                        msg = f"non-finite simulated {self.pairs[j].simulated!r}"
                    if msg is not None:
                        errors[i] = f"experiment {e.experiment_id!r}: {msg}"
                    else:
                        outs[ie][i] = y[k]
        n_fail = sum(e is not None for e in errors)
        self.counters.evaluations += B
        self.counters.failures += n_fail
        return outs, errors

    def _call(self, theta: NDArray[np.float64], exp: Recording) -> SimBatch:
        B = theta.shape[0]
        with blas_threads(self.blas_threads):
            sb = self.model.simulate(theta, exp)
        self.counters.calls += 1
        self.counters.simulations += B
        if not isinstance(sb, SimBatch):
            raise ExternalModelError(
                f"model {self.model.name!r} returned a {type(sb).__name__} from simulate(); "
                "expected a SimBatch"
            )
        shape = (B, exp.n_samples, len(self.model.output_names))
        if np.shape(sb.outputs) != shape:
            raise ExternalModelError(
                f"model {self.model.name!r} returned outputs of shape {np.shape(sb.outputs)} on "
                f"experiment {exp.experiment_id!r}; expected {shape} (sets, samples, outputs "
                f"{list(self.model.output_names)})"
            )
        if sb.errors and len(sb.errors) != B:
            raise ExternalModelError(
                f"model {self.model.name!r} returned {len(sb.errors)} error entries for {B} "
                "parameter sets"
            )
        return sb

    def residuals_of(self, outputs: Sequence[NDArray[np.float64]]) -> NDArray[np.float64]:
        """Weighted residual vectors ``√(w_j/N_j) (ŷ − y)`` (B, N) from simulated outputs."""
        parts = []
        for y, m, yh in zip(self._y, self._m, outputs, strict=True):
            e = np.where(m[None], yh - y[None], 0.0) * self._rfac
            parts.append(e.reshape(e.shape[0], -1))
        return np.concatenate(parts, axis=1)

    def _pair_sse(self, outputs: Sequence[NDArray[np.float64]]) -> NDArray[np.float64]:
        B = outputs[0].shape[0]
        s = np.zeros((B, len(self.pairs)))
        for y, m, yh in zip(self._y, self._m, outputs, strict=True):
            d = np.where(m[None], yh - y[None], 0.0)
            s += np.einsum("btj,btj->bj", d, d)
        return s

    def evaluate(self, z: ArrayLike, *, residuals: bool = False) -> Evaluation:
        """Criteria of a batch of optimiser vectors (one simulate call per experiment).

        Parameters
        ----------
        z : array_like, shape (B, P) or (P,)
        residuals : bool
            Also return the weighted residual vectors.

        Returns
        -------
        Evaluation
        """
        outs, errors = self.simulate(z)
        return self.evaluation_of(outs, errors, residuals=residuals)

    def evaluation_of(
        self,
        outputs: Sequence[NDArray[np.float64]],
        errors: list[str | None],
        *,
        residuals: bool = False,
    ) -> Evaluation:
        """:class:`Evaluation` of simulated outputs (as returned by :meth:`simulate`)."""
        ok = np.array([e is None for e in errors], dtype=bool)
        sse = self._pair_sse(outputs)
        with np.errstate(invalid="ignore"):
            rm = np.sqrt(sse / self.n_samples)
            mse = sse / self.n_samples
        rm[~ok] = np.nan
        crit = np.where(ok, np.nansum(rm * self.weights, axis=1), np.inf)  # (4) in 000
        msev = np.where(ok, (mse * self.weights).sum(axis=1), np.inf)
        res = self.residuals_of(outputs) if residuals else None
        if res is not None:
            res[~ok] = np.nan
        return Evaluation(crit, msev, rm, list(errors), res)

    # --------------------------------------------------------- derivatives
    def sensitivity_function(self) -> Callable[..., Any] | None:
        """The model's exact forward-sensitivity function, or ``None`` if it has none.

        See :func:`thermogym.identification.optimizers.sensitivities.sensitivity_function`.
        """
        if not self._sensitivity_checked:
            self._sensitivity_fn = sensitivity_function(self.model)
            self._sensitivity_checked = True
        return self._sensitivity_fn

    def jacobian(
        self,
        z: ArrayLike,
        *,
        method: str = "auto",
        diff: str = "forward",
        step: float | None = None,
        r0: NDArray[np.float64] | None = None,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], int]:
        """Weighted residuals and their Jacobian ``∂r/∂z`` at one vector ``z``.

        Parameters
        ----------
        z : array_like, shape (P,)
        method : {"auto", "fd", "exact"}
            ``"fd"``: finite differences, all perturbed sets simulated as ONE
            batch (section III-A of paper 002: fixed-step solvers keep them
            consistent). ``"exact"``: forward sensitivities of the model
            (:mod:`~thermogym.identification.optimizers.sensitivities`), one
            augmented simulation per experiment. ``"auto"``: exact when the
            model offers it. Computed by :mod:`~thermogym.identification.jacobian`.
        diff : {"forward", "central"}
            Finite-difference scheme.
        step : float, optional
            Step in unit coordinates (default 1e-7 forward, 1e-5 central).
        r0 : ndarray, shape (N,), optional
            Residuals at ``z`` if already known (saves one simulation).

        Returns
        -------
        r : ndarray, shape (N,)
        J : ndarray, shape (N, P)
        n_sim : int
            Parameter sets simulated for it (each on every experiment).

        Raises
        ------
        IdentificationError
            The model fails at ``z`` or at every perturbation of a parameter.
        ConfigError
            ``method="exact"`` for a model without sensitivities.
        """
        return residual_jacobian(self, z, method=method, diff=diff, step=step, r0=r0)

    # ------------------------------------------------------------- reporting
    def metrics(
        self, z: ArrayLike, experiments: Sequence[Recording] | None = None
    ) -> dict[str, Any]:
        """Fit metrics of one parameter vector on the training or other experiments.

        Returns
        -------
        dict
            ``{experiment_id: fit_report}`` (NRMSE, RMSE, ξ per pair, keyed by
            the measured name) plus ``"criterion"`` and ``"pair_rmse"`` (pooled)
            when evaluated on the training experiments.
        """
        Z = self._as_batch(z)
        if Z.shape[0] != 1:
            raise ShapeError("metrics() takes one parameter vector")
        pb = self if experiments is None else self.with_experiments(experiments)
        outs, errors = pb.simulate(Z)
        ev = pb.evaluation_of(outs, errors)
        exps = pb.experiments
        if errors[0] is not None:
            raise ExternalModelError(f"model {self.model.name!r} failed: {errors[0]}")
        out: dict[str, Any] = {}
        for e, yh in zip(exps, outs, strict=True):
            key = e.experiment_id or f"experiment_{len(out)}"
            meas = {p.label: np.asarray(e[p.measured], dtype=float) for p in self.pairs}
            sim = {p.label: yh[0, :, j] for j, p in enumerate(self.pairs)}
            out[key] = fit_report(meas, sim)
        out["criterion"] = float(ev.criterion[0])
        out["mse"] = float(ev.mse[0])
        out["pair_rmse"] = {p.label: float(ev.pair_rmse[0, j]) for j, p in enumerate(self.pairs)}
        return out

    def with_experiments(self, experiments: Recording | Sequence[Recording]) -> Problem:
        """The same problem (model, parameters, pairs) on other recordings.

        The evaluation counters are shared with this problem.
        """
        other = copy.copy(self)
        other.experiments = self._check_experiments(experiments)
        other.pairs = other._setup_pairs(list(self.pairs))
        other._setup_data()
        return other

    def describe(self) -> dict[str, Any]:
        """Set-up as JSON types (stored in FitResult settings)."""
        return {
            "model": self.model.name,
            "objective": self.objective,
            "pairs": [
                {"measured": p.measured, "simulated": p.simulated, "weight": p.weight}
                for p in self.pairs
            ],
            "parameters": [
                {
                    "name": n,
                    "kind": k,
                    "start": float(s),
                    "lower": float(lo),
                    "upper": float(hi),
                    "scale": sc,
                }
                for n, k, s, lo, hi, sc in zip(
                    self.names,
                    self.kinds,
                    self.start,
                    self.lower,
                    self.upper,
                    self.scales,
                    strict=True,
                )
            ],
            "ratios": {
                n: {
                    t: self.estimates[t]
                    for t in self._sim_names
                    if self._D[self._sim_index[t], i] != 0 and t in self.estimates
                }
                for i, (n, k) in enumerate(zip(self.names, self.kinds, strict=True))
                if k == "ratio"
            },
            "fixed": dict(self.fixed),
            "experiments": [e.experiment_id for e in self.experiments],
        }

    def __repr__(self) -> str:
        return (
            f"<Problem {self.model.name!r}: {self.n_params} parameter(s) {list(self.names)}, "
            f"{len(self.pairs)} pair(s), {len(self.experiments)} experiment(s), "
            f"objective {self.objective!r}>"
        )
