"""One evaluation of an external model, as every backend runs it.

This module is what a worker process imports (it stays light: numpy and the
standard library), so that local workers start fast. The serial, process and
Ray backends all call :func:`evaluate_task`, which is why their results are
identical.

An :class:`Evaluator` is the per-process part of an adapter: it is pickled
to each worker, :meth:`Evaluator.setup` runs once there (compile a script,
start an Octave session, load an FMU library), then :meth:`Evaluator.run` is
called once per parameter set.
"""

from __future__ import annotations

import contextlib
import math
import signal
import threading
import time as _time
import traceback
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "DEFAULT_TIMEOUT",
    "EvaluationTimeout",
    "Evaluator",
    "ExperimentData",
    "OutputError",
    "Outputs",
    "Result",
    "Task",
    "coerce_outputs",
    "evaluate_task",
    "soft_timeout",
]

#: Default time limit of one evaluation [s].
DEFAULT_TIMEOUT = 600.0

#: What one evaluation returns: outputs (T, n_out) or None, error message or None,
#: wall time of the evaluation [s].
Result = tuple["NDArray[np.float64] | None", "str | None", float]


class EvaluationTimeout(BaseException):
    """Raised inside an evaluation when its time limit is reached.

    Derives from :class:`BaseException` (like :class:`KeyboardInterrupt`) so
    that a model's own ``except Exception:`` cannot swallow it.
    """


class OutputError(ValueError):
    """The outputs an external model produced cannot be used (shape, NaN, missing)."""


@dataclass(frozen=True)
class ExperimentData:
    """The part of a recording an external model sees.

    Attributes
    ----------
    time : ndarray, shape (T,)
        Sample times [s] (the recording's, possibly non-uniform).
    inputs : dict
        Model variable → values, shape (T,), in the recording's units.
    key : str
        Identifies the data within one model (workers cache by it).
    experiment_id : str or None
    """

    time: NDArray[np.float64]
    inputs: dict[str, NDArray[np.float64]]
    key: str
    experiment_id: str | None = None

    @property
    def n_samples(self) -> int:
        """Number of samples T."""
        return int(self.time.shape[0])

    def with_inputs(self, overrides: Mapping[str, NDArray[np.float64]] | None) -> ExperimentData:
        """The same data with some input trajectories replaced (co-simulation)."""
        if not overrides:
            return self
        inputs = dict(self.inputs)
        inputs.update(overrides)
        return ExperimentData(self.time, inputs, self.key, self.experiment_id)


@dataclass(frozen=True)
class Task:
    """One parameter set to evaluate.

    Attributes
    ----------
    index : int
        Position in the batch (results are put back in this order).
    params : dict
        Every variable set in the model: uncertain parameters and fixed
        values, name → float.
    overrides : dict or None
        Input trajectories that replace the experiment's for this set only.
    """

    index: int
    params: dict[str, float]
    overrides: dict[str, NDArray[np.float64]] | None = None


@dataclass
class Outputs:
    """Outputs on a time grid of the model's own (resampled onto the recording's).

    Attributes
    ----------
    values : mapping
        Model variable → values on ``time``.
    time : ndarray or None
        The model's output times [s]; None when ``values`` are already on the
        experiment's grid.
    """

    values: Mapping[str, Any]
    time: Any = None


class Evaluator:
    """Per-process part of an adapter (picklable).

    Attributes
    ----------
    label : str
        How messages name the model (``"script 'lag.py'"``).
    output_vars : tuple of str
        Model variables returned, in :attr:`SimModel.output_names` order.
    handles_timeout : bool
        True when :meth:`run` enforces the time limit itself (subprocesses,
        Octave); otherwise :func:`evaluate_task` interrupts it with a signal.
    """

    label: str = "external model"
    output_vars: tuple[str, ...] = ()
    handles_timeout: bool = False
    _ready: bool = False

    def setup(self) -> None:
        """Prepare this process (called once per worker before the first run)."""
        self._ready = True

    def ensure_setup(self) -> None:
        """Call :meth:`setup` unless it already ran in this process."""
        if not self._ready:
            self.setup()
            self._ready = True

    def run(self, params: dict[str, float], exp: ExperimentData, timeout: float | None) -> Any:
        """Evaluate one parameter set; return a mapping, an array (T, n_out) or :class:`Outputs`."""
        raise NotImplementedError

    def describe_error(self, exc: BaseException) -> str:
        """One-line message for an exception raised by :meth:`run`."""
        return f"{type(exc).__name__}: {exc}"

    def teardown(self) -> None:
        """Release what :meth:`setup` acquired (called when a worker stops)."""

    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        state.pop("_ready", None)
        for k in list(state):
            if k.startswith("_live_"):  # per-process resources never travel
                del state[k]
        return state


def _in_main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


@contextlib.contextmanager
def soft_timeout(seconds: float | None, label: str = "evaluation") -> Iterator[None]:
    """Raise :class:`EvaluationTimeout` in this thread after ``seconds``.

    Uses ``SIGALRM`` (POSIX, main thread only; elsewhere it does nothing).
    It interrupts Python code and sleeps, not a long call into compiled code;
    the process backends kill a worker that does not answer in time.
    """
    usable = (
        seconds is not None
        and math.isfinite(seconds)
        and hasattr(signal, "setitimer")
        and _in_main_thread()
    )
    if not usable or seconds is None:  # (usable implies a number of seconds)
        yield
        return

    def _alarm(signum: int, frame: Any) -> None:
        raise EvaluationTimeout(f"{label} timed out after {seconds:g} s")

    previous = signal.signal(signal.SIGALRM, _alarm)
    signal.setitimer(signal.ITIMER_REAL, float(seconds))
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, previous)


def _as_1d(name: str, value: Any, n: int) -> NDArray[np.float64]:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise OutputError(
            f"output {name!r} is a {type(value).__name__} that is not numeric ({e})"
        ) from None
    if arr.ndim == 2 and 1 in arr.shape:  # column or row vectors (Octave, Matlab)
        arr = arr.reshape(-1)
    if arr.ndim != 1:
        raise OutputError(f"output {name!r} has shape {arr.shape}, expected ({n},)")
    return arr


def coerce_outputs(
    raw: Any, output_vars: tuple[str, ...], time: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Turn what a model returned into an array (T, n_out) on the experiment's grid.

    Parameters
    ----------
    raw : mapping, array or Outputs
        A mapping variable → values (T,), an array (T, n_out) in
        ``output_vars`` order, or :class:`Outputs` with the model's own times.
    output_vars : tuple of str
    time : ndarray, shape (T,)
        The experiment's times [s].

    Returns
    -------
    ndarray, shape (T, n_out)

    Raises
    ------
    OutputError
        A variable is missing, has the wrong length, or its own time grid does
        not cover the experiment's. Non-finite values are *not* checked here.

    Notes
    -----
    Outputs on the model's own time grid are interpolated linearly onto the
    experiment's times; the grid must cover ``[time[0], time[-1]]`` (within
    1e-9 relative).
    """
    T = time.shape[0]
    n = len(output_vars)
    own_time = None
    if isinstance(raw, Outputs):
        own_time = raw.time
        raw = raw.values
    if isinstance(raw, Mapping):
        missing = [v for v in output_vars if v not in raw]
        if missing:
            have = sorted(k for k in raw if isinstance(k, str) and not k.startswith("_"))[:20]
            raise OutputError(
                f"output variable(s) {missing} were not produced; the model has {have}"
            )
        cols = [_as_1d(v, raw[v], T) for v in output_vars]
        lengths = {c.shape[0] for c in cols}
        if len(lengths) > 1:
            sizes = {v: c.shape[0] for v, c in zip(output_vars, cols, strict=True)}
            raise OutputError(f"outputs have different lengths {sizes}")
        out = np.column_stack(cols) if cols else np.empty((T, 0))
    else:
        try:
            out = np.asarray(raw, dtype=np.float64)
        except (TypeError, ValueError) as e:
            raise OutputError(
                f"the model returned a {type(raw).__name__}, expected a mapping variable -> "
                f"values or an array (T, {n}) ({e})"
            ) from None
        if out.ndim == 1 and n == 1:
            out = out[:, None]
        if out.ndim != 2 or out.shape[1] != n:
            raise OutputError(
                f"the model returned an array of shape {out.shape}, expected (T, {n}) with "
                f"columns {list(output_vars)}"
            )
    if own_time is not None:
        t_own = _as_1d("output time", own_time, out.shape[0])
        if t_own.shape[0] != out.shape[0]:
            raise OutputError(
                f"the output time has {t_own.shape[0]} samples, the outputs {out.shape[0]}"
            )
        if t_own.shape[0] < 1 or not np.all(np.isfinite(t_own)) or np.any(np.diff(t_own) <= 0):
            raise OutputError("the output time is not finite and strictly increasing")
        tol = 1e-9 * max(1.0, float(np.abs(time).max()))
        if t_own[0] > time[0] + tol or t_own[-1] < time[-1] - tol:
            raise OutputError(
                f"the outputs cover {float(t_own[0])!r}..{float(t_own[-1])!r} s, the experiment "
                f"{float(time[0])!r}..{float(time[-1])!r} s"
            )
        if t_own.shape[0] == 1:
            out = np.repeat(out, T, axis=0)
        else:
            # linear interpolation between the model's output times
            out = np.column_stack([np.interp(time, t_own, out[:, j]) for j in range(n)])
    elif out.shape[0] != T:
        raise OutputError(
            f"the outputs have {out.shape[0]} samples, the experiment {T} (give the model's "
            "own output times to have them resampled)"
        )
    return np.ascontiguousarray(out, dtype=np.float64)


def _nonfinite_message(out: NDArray[np.float64], output_vars: tuple[str, ...], time: Any) -> str:
    bad = ~np.isfinite(out)
    k, j = np.argwhere(bad)[0]
    n_bad = int(bad[:, j].sum())
    return (
        f"non-finite output: {output_vars[j]!r} is {float(out[k, j])!r} at t = "
        f"{float(time[k]):g} s (sample {int(k)}; {n_bad} of {out.shape[0]} samples)"
    )


def evaluate_task(
    evaluator: Evaluator, exp: ExperimentData, task: Task, timeout: float | None
) -> Result:
    """Run one parameter set and check its outputs; never raises for model failures.

    Parameters
    ----------
    evaluator : Evaluator
    exp : ExperimentData
    task : Task
    timeout : float or None
        Time limit [s]; enforced by a signal (soft) unless the evaluator
        enforces it itself.

    Returns
    -------
    outputs : ndarray (T, n_out) or None
        None when the evaluation failed.
    error : str or None
        The failure: the model's exception with its message, a non-zero exit,
        a timeout, missing or non-finite outputs.
    seconds : float
        Wall time of the evaluation.

    Notes
    -----
    :class:`KeyboardInterrupt` propagates (the user stops the run).
    """
    t0 = _time.perf_counter()
    data = exp.with_inputs(task.overrides)
    try:
        evaluator.ensure_setup()
        if evaluator.handles_timeout:
            raw = evaluator.run(dict(task.params), data, timeout)
        else:
            with soft_timeout(timeout, "evaluation"):
                raw = evaluator.run(dict(task.params), data, timeout)
        out = coerce_outputs(raw, evaluator.output_vars, data.time)
    except EvaluationTimeout as e:
        return None, str(e), _time.perf_counter() - t0
    except OutputError as e:
        return None, str(e), _time.perf_counter() - t0
    except KeyboardInterrupt:
        raise
    except SystemExit as e:
        return None, f"the model called exit({e.code!r})", _time.perf_counter() - t0
    except Exception as e:
        try:
            msg = evaluator.describe_error(e)
        except Exception:  # a broken describe_error must not hide the model's error
            msg = f"{type(e).__name__}: {e}"
        return None, msg, _time.perf_counter() - t0
    if not np.isfinite(out).all():
        return (
            None,
            _nonfinite_message(out, evaluator.output_vars, data.time),
            (_time.perf_counter() - t0),
        )
    return out, None, _time.perf_counter() - t0


def traceback_line(exc: BaseException, filename: str) -> int | None:
    """Line number of the innermost frame of ``exc`` that lies in ``filename``."""
    line = None
    for fs in traceback.extract_tb(exc.__traceback__):
        if fs.filename == filename:
            line = fs.lineno
    return line


@dataclass
class WorkerStats:
    """Counters of one backend (reported by :attr:`ExternalModel.stats`)."""

    startup_s: float = 0.0
    workers_started: int = 0
    workers_killed: int = 0
    evaluations: int = 0
    failed: int = 0
    eval_s: float = 0.0
    extra: dict[str, Any] = field(default_factory=dict)
