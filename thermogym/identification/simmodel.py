"""The one interface the identification coordinator fits: parameter sets in, outputs out.

Paper 000 identifies models built in other tools "without converting them,
with one workflow for every model type". Here every model type — thermogym's
own batched models and external ones (Python callables and scripts, batch
jobs, FMUs, Octave) — is seen through :class:`SimModel`:

* named parameters with nominal values and bounds;
* the recording columns it reads and the signals it produces;
* ``simulate(theta, experiment)``: outputs for a batch of parameter sets on
  the experiment's time grid, plus a per-set error message (``None`` when the
  set simulated), so a crashing or NaN-producing external model is reported
  and the optimisation goes on.

:class:`ThermogymModel` adapts a :class:`thermogym.models.base.Model`; external
adapters live in :mod:`thermogym.identification.external`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol, cast, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from thermogym.errors import ParameterError
from thermogym.models.base import Model
from thermogym.recording import Recording

__all__ = ["SimBatch", "SimModel", "ThermogymModel"]


@dataclass
class SimBatch:
    """Outputs of a batch of parameter sets on one experiment.

    Attributes
    ----------
    outputs : ndarray, shape (B, T, n_out)
        Simulated signals in :attr:`SimModel.output_names` order on the
        experiment's time grid; rows of failed sets are NaN.
    errors : list of str or None
        One entry per parameter set: ``None`` when it simulated, else the
        model's error message (crash, timeout, non-finite output).
    """

    outputs: NDArray[np.float64]
    errors: list[str | None] = field(default_factory=list)

    @property
    def ok(self) -> NDArray[np.bool_]:
        """Which parameter sets simulated."""
        return np.array([e is None for e in self.errors], dtype=bool)


@runtime_checkable
class SimModel(Protocol):
    """Anything the coordinator can identify."""

    name: str
    param_names: tuple[str, ...]
    nominal: NDArray[np.float64]
    lower: NDArray[np.float64]
    upper: NDArray[np.float64]
    input_names: tuple[str, ...]
    output_names: tuple[str, ...]
    #: True when one ``simulate`` call evaluates a whole batch efficiently.
    batched: bool

    def simulate(self, theta: NDArray[np.float64], experiment: Recording) -> SimBatch:
        """Simulate parameter sets ``theta`` (B, P) on ``experiment``'s inputs and time grid."""
        ...

    def close(self) -> None:
        """Release processes, files or licences the model holds."""
        ...


class ThermogymModel:
    """A thermogym :class:`~thermogym.models.base.Model` seen as a :class:`SimModel`.

    Parameters
    ----------
    model : Model
        A batched thermogym model.
    free : sequence of str, optional
        Parameters the optimiser varies (default: all).
    fixed : mapping, optional
        Values of the other parameters (default: the model's nominal values).
    x0 : str or callable, optional
        ``"rest"`` (the model's initial state at the first input, default) or a
        callable ``x0(model, theta_full, experiment) -> (B, n_x)`` giving the
        initial state, e.g. steady state or a state estimated from the data.

    Examples
    --------
    >>> from thermogym.models.strut import StrutModel
    >>> sm = ThermogymModel(StrutModel(), free=["r_motor", "r_nut"])
    >>> sm.param_names
    ('r_motor', 'r_nut')
    """

    batched = True

    def __init__(
        self,
        model: Model,
        free: Sequence[str] | None = None,
        fixed: Mapping[str, float] | None = None,
        x0: Any = "rest",
    ) -> None:
        self.model = model
        self.name = model.name
        names = list(model.param_names)
        self.param_names = tuple(free) if free is not None else tuple(names)
        unknown = [p for p in self.param_names if p not in names]
        if unknown:
            raise ParameterError(
                f"free parameter(s) {unknown} are not parameters of model {model.name!r}; "
                f"parameters are {names}"
            )
        base = model.theta(dict(fixed or {}))[0]
        self._base = base
        self._cols = np.array([model.param_index(p) for p in self.param_names], dtype=np.int64)
        self.nominal = base[self._cols].copy()
        self.lower = model.lower[self._cols].copy()
        self.upper = model.upper[self._cols].copy()
        self.input_names = model.exogenous_names
        self.output_names = model.output_names
        self._x0 = x0

    @property
    def x0(self) -> Any:
        """Initial-state rule: ``"rest"`` or a callable ``x0(model, theta_full, experiment)``."""
        return self._x0

    def full_theta(self, theta: NDArray[np.float64]) -> NDArray[np.float64]:
        """Model parameter batch (B, P_model) with the free columns set from ``theta``."""
        th = np.atleast_2d(np.asarray(theta, dtype=float))
        if th.shape[1] != self._cols.size:
            raise ParameterError(
                f"theta has {th.shape[1]} columns, expected {self._cols.size} for "
                f"{list(self.param_names)}"
            )
        full = np.repeat(self._base[None], th.shape[0], axis=0)
        full[:, self._cols] = th
        return full

    def simulate(self, theta: NDArray[np.float64], experiment: Recording) -> SimBatch:
        """Simulate the batch on the experiment (one call for all parameter sets)."""
        full = self.full_theta(theta)
        u = experiment.exogenous_array(self.model)
        x0 = None if self._x0 == "rest" else self._x0(self.model, full, experiment)
        try:
            sim = self.model.simulate(
                u, experiment.dt, full, x0, t0=float(experiment.time[0]), strict=False
            )
            out = sim.outputs
        except Exception as e:
            msg = f"{type(e).__name__}: {e}"
            nan = np.full((full.shape[0], experiment.n_samples, len(self.output_names)), np.nan)
            return SimBatch(nan, [msg] * full.shape[0])
        # one flag per parameter set (out is (B, T, p): an array, not a scalar)
        bad = cast(NDArray[np.bool_], ~np.isfinite(out).all(axis=(1, 2)))
        errors: list[str | None] = ["non-finite output" if b else None for b in bad]
        return SimBatch(out, errors)

    def close(self) -> None:
        """Nothing to release."""
