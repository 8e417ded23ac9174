"""What the stages of :func:`.run.diagnose` hand on to each other.

:class:`_Run` is the state one diagnosis builds up stage by stage (the model, the
prepared recordings, the nominal hypothesis, the test results, the selection, ...);
:func:`_need` reads a field an earlier stage set; :func:`_deadline` is when fitting
stops under a time limit.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, TypedDict, TypeVar

import numpy as np
from numpy.typing import NDArray

from thermogym.identification.diagnosis.context import Context
from thermogym.identification.diagnosis.fit import Experiment
from thermogym.identification.diagnosis.hypothesis import Candidate, Hypothesis, NominalSpec
from thermogym.identification.diagnosis.locate import Regime
from thermogym.identification.diagnosis.select import Data, Selection
from thermogym.identification.residuals import ResidualTest
from thermogym.models.base import Model
from thermogym.recording import Recording

_T = TypeVar("_T")


class _Baseline(TypedDict, total=False):
    """The ``baseline`` stage's plain ARX beside the nominal model (only ``error`` if unfitted)."""

    error: str
    model: str
    n_params: int
    validation: dict[str, float]
    nominal_validation: dict[str, float]
    nominal_adequate: bool
    sims: list[NDArray[np.float64]]


class _Tests(TypedDict):
    """The ``detection`` stage's residual tests of the nominal model, per output."""

    train: dict[str, ResidualTest]
    validation: dict[str, ResidualTest]
    sig_tr: dict[str, bool]
    sig_va: dict[str, bool]
    alpha_adj: float


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
    tr: list[Experiment] = field(default_factory=list)
    va: list[Experiment] = field(default_factory=list)
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
    arx: _Baseline = field(default_factory=lambda: _Baseline())
    data: Data | None = None
    tests: _Tests | None = None
    detected: bool = False
    train_material: bool = False
    sigma: dict[str, float] = field(default_factory=dict)
    located: dict[str, Any] = field(default_factory=dict)
    regs: list[Regime] = field(default_factory=list)
    parameters: dict[str, Any] = field(default_factory=dict)
    ctx: Context | None = None
    candidates: list[Candidate] = field(default_factory=list)
    selection: Selection | None = None
    notes: list[str] = field(default_factory=list)
    seconds: dict[str, float] = field(default_factory=dict)


def _need(value: _T | None, what: str) -> _T:
    """``value``, which an earlier stage sets: an internal error if that stage has not run."""
    if value is None:
        raise RuntimeError(f"internal: the diagnosis has no {what} here (an earlier stage sets it)")
    return value


def _deadline(st: _Run) -> float | None:
    """When fitting stops: the time limit less a margin for the stages that finish the report.

    The margin is 10 % of the limit, at most 5 s: the limit bounds the whole run.
    """
    limit = st.opts["time_limit"]
    if limit is None:
        return None
    return st.t0 + limit - min(5.0, 0.1 * limit)
