"""What the stages of :func:`.run.diagnose` hand on to each other.

:class:`_Run` is the state one diagnosis builds up stage by stage (the model, the
prepared recordings, the nominal hypothesis, the test results, the selection, ...);
:func:`_deadline` is when fitting stops under a time limit.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from thermogym.identification.diagnosis.context import Context
from thermogym.identification.diagnosis.hypothesis import Hypothesis, NominalSpec
from thermogym.identification.diagnosis.select import Data, Selection
from thermogym.models.base import Model
from thermogym.recording import Recording


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
    tr: list[Any] = field(default_factory=list)
    va: list[Any] = field(default_factory=list)
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
    arx: dict[str, Any] = field(default_factory=dict)
    data: Data | None = None
    tests: dict[str, Any] = field(default_factory=dict)
    detected: bool = False
    train_material: bool = False
    sigma: dict[str, float] = field(default_factory=dict)
    located: dict[str, Any] = field(default_factory=dict)
    regs: list[Any] = field(default_factory=list)
    parameters: dict[str, Any] = field(default_factory=dict)
    ctx: Context | None = None
    candidates: list[Any] = field(default_factory=list)
    selection: Selection | None = None
    notes: list[str] = field(default_factory=list)
    seconds: dict[str, float] = field(default_factory=dict)


def _deadline(st: _Run) -> float | None:
    """When fitting stops: the time limit less a margin for the stages that finish the report.

    The margin is 10 % of the limit, at most 5 s: the limit bounds the whole run.
    """
    limit = st.opts["time_limit"]
    if limit is None:
        return None
    return st.t0 + limit - min(5.0, 0.1 * limit)
