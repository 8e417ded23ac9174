"""What one evaluation of a model costs, against one batch call.

Paper 000 (``000_24627a5308ee07db.txt``, section 4.2.4) reports 60 minutes of
Monte Carlo "with the numerous Python script calls". :func:`time_evaluations`
measures, on one recording, the three numbers that decide such a run: the
start-up cost (worker processes, Octave sessions, FMU loading), the time of
one evaluation called on its own, and the time of one batch call (parallel
workers for external models, one vectorised simulation for batched models).
"""

from __future__ import annotations

import os
import time as _time
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from thermogym.errors import ParameterError

if TYPE_CHECKING:
    from thermogym.identification.simmodel import SimModel
    from thermogym.recording import Recording

__all__ = ["EvaluationTiming", "time_evaluations"]


@dataclass(frozen=True)
class EvaluationTiming:
    """Timings of one model on one recording (seconds, best of the repeats).

    Attributes
    ----------
    model : str
    backend : str
        ``batched`` for batched models, else the executor's backend.
    workers : int or None
    startup_s : float
        First call minus a warm single call (pool start, set-up).
    single_s : float
        One parameter set per ``simulate`` call (warm).
    batch_s : float
        One ``simulate`` call of ``batch_size`` parameter sets (warm).
    batch_size : int
    failed : int
        Parameter sets of the batch that failed (they are timed too).
    load : tuple of float
        1, 5 and 15-minute load averages when the timing ended.
    """

    model: str
    backend: str
    workers: int | None
    startup_s: float
    single_s: float
    batch_s: float
    batch_size: int
    failed: int
    load: tuple[float, float, float]

    @property
    def per_eval_batch_s(self) -> float:
        """Batch time per parameter set [s]."""
        return self.batch_s / self.batch_size

    @property
    def speedup(self) -> float:
        """A loop of single calls over the batch call, for the same number of sets."""
        return self.single_s * self.batch_size / self.batch_s

    def as_dict(self) -> dict[str, Any]:
        """Plain values (for JSON), with the derived figures."""
        d = asdict(self)
        d["load"] = list(self.load)
        d["per_eval_batch_s"] = self.per_eval_batch_s
        d["speedup"] = self.speedup
        return d

    def summary(self) -> str:
        """One line for humans."""
        return (
            f"{self.model} [{self.backend}, workers={self.workers}]: "
            f"start-up {self.startup_s:.3f} s, "
            f"single {1e3 * self.single_s:.2f} ms, batch of {self.batch_size} {self.batch_s:.3f} s "
            f"({1e3 * self.per_eval_batch_s:.2f} ms per set, {self.speedup:.1f}x the loop); "
            f"load {self.load[0]:.2f}"
        )


def time_evaluations(
    model: SimModel,
    experiment: Recording,
    *,
    batch_size: int = 16,
    repeats: int = 3,
    theta: ArrayLike | None = None,
    seed: int = 0,
) -> EvaluationTiming:
    """Time start-up, one evaluation and a batch of ``model`` on ``experiment``.

    Parameters
    ----------
    model : SimModel
        Any model (external or batched).
    experiment : Recording
    batch_size : int
        Parameter sets of the batch call.
    repeats : int
        Repeats of the single and of the batch call; the best is kept
        (machines are shared: the best is the least disturbed).
    theta : array_like (batch_size, P), optional
        Parameter sets; default: uniform within finite bounds (start value
        ±10 % where a bound is infinite), drawn with ``seed``.
    seed : int

    Returns
    -------
    EvaluationTiming

    Examples
    --------
    >>> import numpy as np
    >>> from thermogym.recording import Recording
    >>> from thermogym.identification.external import CallableModel
    >>> def gain(time, inputs, params):
    ...     return {"y": params["K"] * inputs["u"]}
    >>> m = CallableModel(gain, parameters={"K": (1.0, 0.5, 2.0)}, inputs=["u"],
    ...                   outputs=["y"], backend="serial")
    >>> t = time_evaluations(m, Recording(np.arange(10.0), {"u": np.ones(10)}), batch_size=4)
    >>> t.batch_size, t.failed, t.single_s > 0
    (4, 0, True)
    >>> m.close()
    """
    if batch_size < 1 or repeats < 1:
        raise ParameterError(f"batch_size {batch_size} and repeats {repeats} must be >= 1")
    P = len(model.param_names)
    if theta is None:
        lo = np.where(
            np.isfinite(model.lower), model.lower, model.nominal - 0.1 * np.abs(model.nominal)
        )
        hi = np.where(
            np.isfinite(model.upper), model.upper, model.nominal + 0.1 * np.abs(model.nominal)
        )
        th = np.random.default_rng(seed).uniform(lo, hi, size=(batch_size, P))
    else:
        th = np.asarray(theta, dtype=float)
        if th.shape != (batch_size, P):
            raise ParameterError(f"theta has shape {th.shape}, expected ({batch_size}, {P})")
    t0 = _time.perf_counter()
    model.simulate(np.asarray(model.nominal, dtype=float)[None], experiment)
    first = _time.perf_counter() - t0
    singles = []
    for i in range(repeats):
        t0 = _time.perf_counter()
        model.simulate(th[i % batch_size : i % batch_size + 1], experiment)
        singles.append(_time.perf_counter() - t0)
    batches = []
    failed = 0
    for _ in range(repeats):
        t0 = _time.perf_counter()
        res = model.simulate(th, experiment)
        batches.append(_time.perf_counter() - t0)
        failed = int(sum(e is not None for e in res.errors))
    single = min(singles)
    executor = getattr(model, "_executor", None)
    backend = "batched" if getattr(model, "batched", False) else getattr(executor, "backend", "?")
    workers = getattr(executor, "workers", None)
    try:
        load = os.getloadavg()
    except OSError:  # pragma: no cover - not available on this platform
        load = (float("nan"),) * 3
    return EvaluationTiming(
        model=str(getattr(model, "name", type(model).__name__)),
        backend=backend,
        workers=workers,
        startup_s=max(0.0, first - single),
        single_s=single,
        batch_s=min(batches),
        batch_size=batch_size,
        failed=failed,
        load=(float(load[0]), float(load[1]), float(load[2])),
    )
