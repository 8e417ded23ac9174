"""Signals, parameters and the batched model interface shared by every plant.

A :class:`Model` is pure numerics. It declares

* its **signals** (:class:`Signal`: name, role, unit, description); the
  exogenous signals (role ``input`` then ``disturbance``, in declaration
  order) form the columns of the ``u`` array every simulation takes;
* its **parameters** (:class:`Parameter`: nominal value, bounds, unit,
  description, provenance); a *batch* of parameter sets is an array
  ``theta`` of shape ``(B, P)`` whose columns follow :attr:`Model.param_names`;
* its **states**.

and simulates a whole batch at once on a uniform time grid:
``y[k] = h(x[k], u[k])``, ``x[k+1] = Φ(x[k], u[k], Δt)`` with the inputs held
constant over each sample interval (zero-order hold). Nonlinear plants use a
fixed-step explicit integrator (section III-A of ``002_dae2310635fe074e.txt``
explains why fixed steps suit finite-difference identification); linear plants
use exact discretisation.
"""

from __future__ import annotations

import math
import re
from abc import ABC, abstractmethod
from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from thermogym.errors import ParameterError, ShapeError, SimulationError, UnknownNameError

__all__ = ["ROLES", "Model", "Parameter", "Signal", "Simulation", "ThetaLike"]

Role = Literal["input", "disturbance", "output"]
ROLES: tuple[str, ...] = ("input", "disturbance", "output")
_NAME_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")

#: Most fixed integrator steps one simulation of one parameter set may take (about
#: three years of 1 s steps): beyond it a time axis is almost surely in the wrong
#: unit (milliseconds read as seconds, epoch seconds) and the run would not end.
MAX_INTEGRATOR_STEPS = 10**8


def check_step_budget(model: str, n_substeps: int, n_samples: int, dt: float) -> None:
    """Refuse a simulation of more than :data:`MAX_INTEGRATOR_STEPS` integrator steps.

    Raises
    ------
    SimulationError
        Naming the span, the sample period and the steps it would take.
    """
    steps = int(n_substeps) * max(int(n_samples) - 1, 1)
    if steps > MAX_INTEGRATOR_STEPS:
        span = dt * max(n_samples - 1, 1)
        raise SimulationError(
            f"model {model!r}: {n_samples} samples {dt:g} s apart (a span of {span:g} s) need "
            f"{steps:.3g} integrator steps ({n_substeps} per sample), more than "
            f"{MAX_INTEGRATOR_STEPS:.0e}; is the time in seconds? Resample onto a shorter "
            "period or shorten the recording"
        )


ThetaLike = (
    None | Mapping[str, ArrayLike] | Sequence[Mapping[str, ArrayLike]] | NDArray[np.floating]
)


@dataclass(frozen=True)
class Signal:
    """One named, unit-carrying channel of a model.

    Parameters
    ----------
    name : str
        Column name in recordings (a Python identifier).
    role : {"input", "disturbance", "output"}
        ``input``: manipulated by a controller; ``disturbance``: exogenous but
        not manipulated; ``output``: computed by the model / measured.
    unit : str
        Unit, one of the conventions of DESIGN.md (s, °C, W, V, mm, rpm, ...).
    description : str
        One line saying what the signal is.
    """

    name: str
    role: Role
    unit: str
    description: str

    def __post_init__(self) -> None:
        if not _NAME_RE.match(self.name):
            raise ParameterError(
                f"signal name {self.name!r} is not an identifier (letters, digits, _)"
            )
        if self.role not in ROLES:
            raise ParameterError(
                f"signal {self.name!r} has role {self.role!r}, expected one of {ROLES}"
            )


@dataclass(frozen=True)
class Parameter:
    """One scalar model parameter with its bounds and provenance.

    Parameters
    ----------
    name : str
        Identifier used in FitResults, ``--set NAME=VALUE`` and ``theta`` columns.
    nominal : float
        Default value.
    lower, upper : float
        Plausible range; optimisers search within it.
    unit : str
        Unit of the value.
    description : str
        What the parameter means physically.
    provenance : str
        Where the nominal value comes from (paper, equation, assumption).
    group : str
        Sub-model the parameter belongs to (e.g. ``"ptc"``, ``"thermal"``);
        identification can fit one group at a time.
    """

    name: str
    nominal: float
    lower: float
    upper: float
    unit: str
    description: str
    provenance: str
    group: str = "main"

    def __post_init__(self) -> None:
        if not _NAME_RE.match(self.name):
            raise ParameterError(f"parameter name {self.name!r} is not an identifier")
        if not (self.lower <= self.nominal <= self.upper):
            raise ParameterError(
                f"parameter {self.name!r}: nominal {self.nominal!r} outside its bounds "
                f"[{self.lower!r}, {self.upper!r}]"
            )


@dataclass(frozen=True)
class Simulation:
    """Result of :meth:`Model.simulate` for a batch of parameter sets.

    Attributes
    ----------
    time : ndarray, shape (T,)
        Sample times [s].
    outputs : ndarray, shape (B, T, n_y)
        Output signals in the order of ``output_names``.
    output_names : tuple of str
    units : dict
        Unit of every output and exogenous signal.
    states : ndarray, shape (B, T, n_x), optional
        State trajectories when requested.
    state_names : tuple of str
    inputs : ndarray, shape (B, T, n_u)
        The exogenous signals the simulation was driven with.
    input_names : tuple of str
    """

    time: NDArray[np.float64]
    outputs: NDArray[np.float64]
    output_names: tuple[str, ...]
    units: dict[str, str]
    inputs: NDArray[np.float64]
    input_names: tuple[str, ...]
    states: NDArray[np.float64] | None = None
    state_names: tuple[str, ...] = ()
    meta: dict[str, Any] = field(default_factory=dict)

    @property
    def batch_size(self) -> int:
        """Number of parameter sets simulated."""
        return int(self.outputs.shape[0])

    def output(self, name: str) -> NDArray[np.float64]:
        """Return one output for the whole batch, shape (B, T)."""
        try:
            j = self.output_names.index(name)
        except ValueError:
            raise UnknownNameError(
                f"output {name!r} not simulated; outputs are {list(self.output_names)}"
            ) from None
        return self.outputs[:, :, j]

    def state(self, name: str) -> NDArray[np.float64]:
        """Return one state trajectory for the whole batch, shape (B, T)."""
        if self.states is None:
            raise SimulationError("states were not kept; simulate with return_states=True")
        try:
            j = self.state_names.index(name)
        except ValueError:
            raise UnknownNameError(
                f"state {name!r} unknown; states are {list(self.state_names)}"
            ) from None
        return self.states[:, :, j]


class Model(ABC):
    """Batched plant model: signals, parameters, states and fixed-step simulation.

    Subclasses set :attr:`name`, :attr:`version` and implement
    :meth:`initial_state`, :meth:`_simulate` and, for environments,
    :meth:`_step` and :meth:`_output`.

    Parameters
    ----------
    signals : sequence of Signal
    parameters : sequence of Parameter
    state_names : sequence of str
    """

    #: Model name used on the command line and in FitResults.
    name: str = "model"
    #: Version of the model equations; a behaviour change bumps it.
    version: str = "1"
    #: Largest internal integration step [s] for fixed-step integrators.
    max_step: float = math.inf

    def __init__(
        self,
        signals: Sequence[Signal],
        parameters: Sequence[Parameter],
        state_names: Sequence[str],
    ) -> None:
        counts = Counter([s.name for s in signals] + [p.name for p in parameters])
        dup = sorted(n for n, c in counts.items() if c > 1)
        if dup:
            raise ParameterError(f"{type(self).__name__}: duplicate names {dup}")
        self._signals = tuple(signals)
        self._parameters = tuple(parameters)
        self._state_names = tuple(state_names)
        self._pindex = {p.name: i for i, p in enumerate(self._parameters)}

    # ------------------------------------------------------------------ metadata
    @property
    def signals(self) -> tuple[Signal, ...]:
        """All signals: inputs, disturbances and outputs."""
        return self._signals

    @property
    def parameters(self) -> tuple[Parameter, ...]:
        """Parameter specifications in ``theta`` column order."""
        return self._parameters

    @property
    def state_names(self) -> tuple[str, ...]:
        """Names of the state variables."""
        return self._state_names

    def _by_role(self, role: str) -> tuple[Signal, ...]:
        return tuple(s for s in self._signals if s.role == role)

    @property
    def inputs(self) -> tuple[Signal, ...]:
        """Manipulated inputs."""
        return self._by_role("input")

    @property
    def disturbances(self) -> tuple[Signal, ...]:
        """Exogenous, non-manipulated inputs."""
        return self._by_role("disturbance")

    @property
    def outputs(self) -> tuple[Signal, ...]:
        """Output signals in the column order of :attr:`Simulation.outputs`."""
        return self._by_role("output")

    @property
    def exogenous(self) -> tuple[Signal, ...]:
        """Inputs then disturbances: the columns of every ``u`` array."""
        return self.inputs + self.disturbances

    @property
    def exogenous_names(self) -> tuple[str, ...]:
        """Names of :attr:`exogenous`."""
        return tuple(s.name for s in self.exogenous)

    @property
    def output_names(self) -> tuple[str, ...]:
        """Names of :attr:`outputs`."""
        return tuple(s.name for s in self.outputs)

    @property
    def param_names(self) -> tuple[str, ...]:
        """Parameter names in ``theta`` column order."""
        return tuple(p.name for p in self._parameters)

    def signal(self, name: str) -> Signal:
        """Return the signal called ``name``."""
        for s in self._signals:
            if s.name == name:
                return s
        raise UnknownNameError(
            f"model {self.name!r} has no signal {name!r}; signals are "
            f"{[s.name for s in self._signals]}"
        )

    def param_index(self, name: str) -> int:
        """Column of parameter ``name`` in ``theta``."""
        try:
            return self._pindex[name]
        except KeyError:
            raise ParameterError(
                f"model {self.name!r} has no parameter {name!r}; parameters are "
                f"{list(self.param_names)}"
            ) from None

    @property
    def nominal(self) -> NDArray[np.float64]:
        """Nominal parameter vector, shape (P,)."""
        return np.array([p.nominal for p in self._parameters], dtype=float)

    @property
    def lower(self) -> NDArray[np.float64]:
        """Lower parameter bounds, shape (P,)."""
        return np.array([p.lower for p in self._parameters], dtype=float)

    @property
    def upper(self) -> NDArray[np.float64]:
        """Upper parameter bounds, shape (P,)."""
        return np.array([p.upper for p in self._parameters], dtype=float)

    def config(self) -> dict[str, Any]:
        """Constructor arguments that rebuild this model (stored in FitResults)."""
        return {}

    def describe(self) -> dict[str, Any]:
        """Machine-readable description (``thermogym models --json``)."""
        return {
            "name": self.name,
            "version": self.version,
            "description": (type(self).__doc__ or "").strip().splitlines()[0],
            "config": self.config(),
            "states": list(self._state_names),
            "signals": [vars(s).copy() for s in self._signals],
            "parameters": [vars(p).copy() for p in self._parameters],
        }

    # ---------------------------------------------------------------- parameters
    def theta(
        self, values: ThetaLike = None, *, batch: int | None = None, **overrides: Any
    ) -> NDArray[np.float64]:
        """Build a parameter batch ``theta`` of shape (B, P).

        Parameters
        ----------
        values : None, mapping, sequence of mappings or array
            ``None``: the nominal set. A mapping ``{name: value}`` overrides
            nominal values (a value may be an array of length B). A sequence of
            mappings gives one parameter set each. An array of shape (P,) or
            (B, P) is taken as it is.
        batch : int, optional
            Repeat a single parameter set ``batch`` times.
        **overrides
            Further ``name=value`` overrides applied on top of ``values``.

        Returns
        -------
        ndarray, shape (B, P)

        Raises
        ------
        ParameterError
            Unknown parameter name, wrong array shape or non-finite value.
        """
        P = len(self._parameters)
        if values is None:
            th = self.nominal[None, :]
        elif isinstance(values, np.ndarray) or (
            isinstance(values, Sequence)
            and not isinstance(values, str)
            and len(values) > 0
            and not isinstance(values[0], Mapping)
        ):
            try:
                th = np.array(values, dtype=float)
            except (TypeError, ValueError) as e:
                raise ParameterError(
                    f"theta cannot be read as numbers ({e}); expected an array ({P},) or "
                    f"(B, {P}) of the parameters {list(self.param_names)} of model {self.name!r}"
                ) from None
            given = th.shape
            if th.ndim == 1:
                th = th[None, :]
            if th.ndim != 2 or th.shape[1] != P:
                raise ParameterError(
                    f"theta has shape {given}, expected ({P},) or (B, {P}) for the "
                    f"parameters {list(self.param_names)} of model {self.name!r}"
                )
        elif isinstance(values, Mapping):
            th = self._theta_from_mapping(values)
        elif isinstance(values, Sequence):
            if len(values) == 0:
                raise ParameterError("an empty list of parameter sets was given")
            th = np.concatenate([self._theta_from_mapping(v) for v in values], axis=0)
        else:
            raise ParameterError(
                f"parameters given as {type(values).__name__}; expected None, a mapping "
                "name -> value, a list of mappings or an array"
            )
        if overrides:
            th = self._theta_from_mapping(overrides, base=th)
        if batch is not None:
            if th.shape[0] == 1:
                th = np.repeat(th, int(batch), axis=0)
            elif th.shape[0] != batch:
                raise ParameterError(f"theta has {th.shape[0]} parameter sets, batch={batch}")
        bad = ~np.isfinite(th)
        if bad.any():
            b, j = np.argwhere(bad)[0]
            raise ParameterError(
                f"parameter {self.param_names[j]!r} of set {b} is {float(th[b, j])!r}; "
                "expected a finite number"
            )
        self._validate_theta(th)
        return th

    def _theta_from_mapping(
        self, values: Mapping[str, ArrayLike], base: NDArray[np.float64] | None = None
    ) -> NDArray[np.float64]:
        unknown = [k for k in values if k not in self._pindex]
        if unknown:
            raise ParameterError(
                f"unknown parameter(s) {unknown} for model {self.name!r}; parameters are "
                f"{list(self.param_names)}"
            )
        arrays = {}
        for k, v in values.items():
            try:
                arrays[k] = np.atleast_1d(np.asarray(v, dtype=float))
            except (TypeError, ValueError):
                shown = repr(v.item() if isinstance(v, np.generic) else v)
                raise ParameterError(
                    f"parameter {k!r} of model {self.name!r} is {shown[:80]}; expected a "
                    "finite number (or an array of them, one per parameter set)"
                ) from None
        sizes = {a.shape[0] for a in arrays.values() if a.shape[0] != 1}
        if base is not None and base.shape[0] != 1:
            sizes.add(base.shape[0])
        if len(sizes) > 1:
            raise ParameterError(f"parameter arrays have different lengths {sorted(sizes)}")
        B = sizes.pop() if sizes else 1
        th = np.repeat(self.nominal[None, :] if base is None else base, 1, axis=0)
        if th.shape[0] != B:
            th = np.repeat(th, B, axis=0)
        for k, a in arrays.items():
            if a.ndim != 1:
                raise ParameterError(f"parameter {k!r} has shape {a.shape}, expected a scalar")
            th[:, self._pindex[k]] = a
        return th

    def _validate_theta(self, theta: NDArray[np.float64]) -> None:  # noqa: B027
        """Raise :class:`ParameterError` for physically impossible values."""

    def _require_positive(self, theta: NDArray[np.float64], names: Sequence[str]) -> None:
        for n in names:
            col = theta[:, self._pindex[n]]
            if (col <= 0).any():
                b = int(np.argmax(col <= 0))
                raise ParameterError(
                    f"parameter {n!r} of set {b} is {float(col[b])!r}; it must be positive"
                )

    # ----------------------------------------------------------------- numerics
    def _exog_batch(self, u: ArrayLike) -> NDArray[np.float64]:
        n = len(self.exogenous)
        try:
            ua = np.asarray(u, dtype=float)
        except (TypeError, ValueError) as e:
            raise ShapeError(
                f"u cannot be read as numbers ({e}); expected an array (T, {n}) or (B, T, {n}) "
                f"with columns {list(self.exogenous_names)}"
            ) from None
        if ua.ndim == 1 and n == 1:
            ua = ua[:, None]
        if ua.ndim == 2:
            if ua.shape[1] != n:
                raise ShapeError(
                    f"u has shape {ua.shape}, expected (T, {n}) with columns "
                    f"{list(self.exogenous_names)}"
                )
            ua = ua[None]
        elif ua.ndim == 3:
            if ua.shape[2] != n:
                raise ShapeError(
                    f"u has shape {ua.shape}, expected (B, T, {n}) with columns "
                    f"{list(self.exogenous_names)}"
                )
        else:
            raise ShapeError(f"u has {ua.ndim} dimensions, expected (T, {n}) or (B, T, {n})")
        if ua.shape[1] < 1:
            raise ShapeError("u has no samples")
        bad = ~np.isfinite(ua)
        if bad.any():
            b, k, j = np.argwhere(bad)[0]
            raise ShapeError(
                f"exogenous signal {self.exogenous_names[j]!r} is {float(ua[b, k, j])!r} at "
                f"sample {int(k)}; simulation needs finite inputs (prepare the recording first)"
            )
        return ua

    def simulate(
        self,
        u: ArrayLike,
        dt: float,
        theta: ThetaLike = None,
        x0: ArrayLike | None = None,
        *,
        t0: float = 0.0,
        return_states: bool = False,
        strict: bool = True,
    ) -> Simulation:
        """Simulate a batch of parameter sets on a uniform time grid.

        Parameters
        ----------
        u : array_like, shape (T, n_u) or (B, T, n_u)
            Exogenous signals (:attr:`exogenous_names` order), held constant
            over each interval ``[t_k, t_k + dt)``.
        dt : float
            Sample period [s].
        theta : parameter batch, optional
            Anything :meth:`theta` accepts; nominal when omitted.
        x0 : array_like, shape (n_x,) or (B, n_x), optional
            Initial state; :meth:`initial_state` at ``u[0]`` when omitted.
        t0 : float
            Time of the first sample [s].
        return_states : bool
            Keep the state trajectories (memory: B·T·n_x floats).
        strict : bool
            Raise :class:`SimulationError` when a parameter set's outputs become
            non-finite (default). Optimisers pass ``False`` and get NaN rows.

        Returns
        -------
        Simulation
        """
        th, ua = self._simulation_batch(u, dt, theta)
        x = self._initial_array(x0, th, ua)
        y, xs = self._simulate(th, ua, float(dt), x, return_states)
        return self._simulation_result(th, ua, dt, y, xs, t0=t0, strict=strict)

    def _simulation_batch(
        self, u: ArrayLike, dt: float, theta: ThetaLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Checked parameter batch (B, P) and exogenous batch (B, T, n_u) of :meth:`simulate`."""
        try:  # a number (text and booleans are mistakes here)
            ok = not isinstance(dt, str | bytes | bool | np.bool_) and 0 < float(dt) < math.inf
        except (TypeError, ValueError):
            ok = False
        if not ok:
            shown = repr(dt.item() if isinstance(dt, np.generic) else dt)
            raise ShapeError(f"dt is {shown[:80]}, expected a positive sample period in seconds")
        th = self.theta(theta)
        ua = self._exog_batch(u)
        check_step_budget(self.name, self.n_substeps(float(dt)), ua.shape[1], float(dt))
        B = max(th.shape[0], ua.shape[0])
        if th.shape[0] not in (1, B) or ua.shape[0] not in (1, B):
            raise ShapeError(f"theta batch {th.shape[0]} and u batch {ua.shape[0]} differ")
        if th.shape[0] == 1 and B > 1:
            th = np.repeat(th, B, axis=0)
        if ua.shape[0] == 1 and B > 1:
            # a read-only view (stride 0): kernels may use the shared trajectory as it is
            ua = np.broadcast_to(ua, (B, *ua.shape[1:]))
        elif not ua.flags.c_contiguous:
            ua = np.ascontiguousarray(ua)
        return th, ua

    def _initial_array(
        self, x0: ArrayLike | None, th: NDArray[np.float64], ua: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """Initial state batch (B, n_x): :meth:`initial_state` or the given ``x0``."""
        B = th.shape[0]
        if x0 is None:
            x = self.initial_state(th, ua[:, 0, :])
        else:
            x = np.array(x0, dtype=float)
            if x.ndim == 1:
                x = np.repeat(x[None], B, axis=0)
            if x.shape != (B, len(self._state_names)):
                raise ShapeError(
                    f"x0 has shape {x.shape}, expected ({len(self._state_names)},) or "
                    f"({B}, {len(self._state_names)}) for states {list(self._state_names)}"
                )
        return np.ascontiguousarray(x)

    def _simulation_result(
        self,
        th: NDArray[np.float64],
        ua: NDArray[np.float64],
        dt: float,
        y: NDArray[np.float64],
        xs: NDArray[np.float64] | None,
        *,
        t0: float,
        strict: bool,
        meta: Mapping[str, Any] | None = None,
    ) -> Simulation:
        """Wrap kernel outputs in a :class:`Simulation` (non-finite check when ``strict``)."""
        if strict and not np.isfinite(y).all():
            b, k, j = (int(i) for i in np.argwhere(~np.isfinite(y))[0])
            ub = ua[min(b, ua.shape[0] - 1)]
            # the inputs up to that sample, largest magnitude first: often the cause
            span = np.max(np.abs(ub[: k + 1]), axis=0)
            inputs = ", ".join(
                f"{n} up to {float(v):.4g}"
                for v, n in sorted(zip(span, self.exogenous_names, strict=True), reverse=True)
            )
            params = {n: float(v) for n, v in zip(self.param_names, th[b], strict=True)}
            raise SimulationError(
                f"model {self.name!r}: simulation of parameter set {b} became non-finite at "
                f"sample {k} (time {t0 + k * dt:g} s, output {self.output_names[j]!r}); inputs "
                f"so far: {inputs} (magnitudes); parameters {params}"
            )
        T = ua.shape[1]
        units = {s.name: s.unit for s in self._signals}
        return Simulation(
            time=t0 + dt * np.arange(T, dtype=np.float64),
            outputs=y,
            output_names=self.output_names,
            units=units,
            inputs=np.asarray(ua),
            input_names=self.exogenous_names,
            states=xs,
            state_names=self._state_names,
            meta={
                "model": self.name,
                "model_version": self.version,
                "dt": float(dt),
                **dict(meta or {}),
            },
        )

    def n_substeps(self, dt: float) -> int:
        """Number of fixed integrator steps per sample interval ``dt``."""
        return max(1, math.ceil(dt / self.max_step - 1e-9))

    @abstractmethod
    def initial_state(
        self, theta: NDArray[np.float64], u0: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """Physically sensible initial state (usually a rest state), shape (B, n_x)."""

    @abstractmethod
    def _simulate(
        self,
        theta: NDArray[np.float64],
        u: NDArray[np.float64],
        dt: float,
        x0: NDArray[np.float64],
        return_states: bool,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
        """Simulate validated arrays; return outputs (B,T,n_y) and states or None."""

    def step(self, x: ArrayLike, u: ArrayLike, theta: ThetaLike, dt: float) -> NDArray[np.float64]:
        """Advance a batch of states by ``dt`` with inputs ``u`` held constant.

        Parameters
        ----------
        x : array_like, shape (B, n_x)
        u : array_like, shape (B, n_u)
        theta : parameter batch
        dt : float
            Step [s]; split into :meth:`n_substeps` fixed integrator steps.

        Returns
        -------
        ndarray, shape (B, n_x)
        """
        th = self.theta(theta)
        xa = np.array(x, dtype=float, ndmin=2)
        ua = np.array(u, dtype=float, ndmin=2)
        return self._step(xa, ua, th, float(dt))

    def output(self, x: ArrayLike, u: ArrayLike, theta: ThetaLike) -> NDArray[np.float64]:
        """Outputs ``h(x, u)`` for a batch of states, shape (B, n_y)."""
        th = self.theta(theta)
        return self._output(
            np.array(x, dtype=float, ndmin=2), np.array(u, dtype=float, ndmin=2), th
        )

    def _step(
        self, x: NDArray[np.float64], u: NDArray[np.float64], theta: NDArray[np.float64], dt: float
    ) -> NDArray[np.float64]:
        raise NotImplementedError(f"model {self.name!r} has no step-wise integrator")

    def _output(
        self, x: NDArray[np.float64], u: NDArray[np.float64], theta: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        raise NotImplementedError(f"model {self.name!r} has no step-wise output function")

    def __repr__(self) -> str:
        return (
            f"<{type(self).__name__} {self.name!r} v{self.version}: "
            f"{len(self.exogenous)} exogenous, {len(self.outputs)} outputs, "
            f"{len(self._parameters)} parameters, {len(self._state_names)} states>"
        )
