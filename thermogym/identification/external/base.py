"""The parent-side part every non-batched external adapter shares.

:class:`ExternalModel` implements :class:`~thermogym.identification.simmodel.SimModel`
for an :class:`~._evaluate.Evaluator`: it maps recording columns to model
variables, turns each row of ``theta`` into the model's variables (uncertain
parameters plus the values set manually, paper 000 workflow step 2), hands
the parameter sets to an executor (:mod:`.parallel`) and collects outputs and
error messages into a :class:`~thermogym.identification.simmodel.SimBatch`.

Heavy modules (recordings, pandas) are imported lazily so that worker
processes, which import the adapter modules, start fast.
"""

from __future__ import annotations

import hashlib
import math
import os
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from thermogym.errors import ConfigError, ExternalModelError, ParameterError, RecordingError
from thermogym.identification.external._evaluate import (
    DEFAULT_TIMEOUT,
    Evaluator,
    ExperimentData,
    Task,
)
from thermogym.identification.external.parallel import Executor, make_executor

if TYPE_CHECKING:
    from thermogym.identification.external.config import ExternalConfig
    from thermogym.identification.simmodel import SimBatch
    from thermogym.models.base import Parameter
    from thermogym.recording import Recording

__all__ = ["DEFAULT_TIMEOUT", "ExternalModel", "common_kwargs", "file_digest"]


class ExternalModel:
    """An external model seen as a :class:`~thermogym.identification.simmodel.SimModel`.

    Not used directly: the adapters (:class:`~.callable.CallableModel`,
    :class:`~.script.ScriptModel`, :class:`~.batchjob.BatchJobModel`,
    :class:`~.fmu.FMUModel`, :class:`~.octave.OctaveModel`) build it.

    Parameters
    ----------
    evaluator : Evaluator
        The per-process part of the adapter.
    name : str
        Model name.
    parameters : mapping or sequence
        Uncertain parameters (see :func:`~.config.parse_parameters`): model
        variable → ``{start, lower, upper}`` or ``(start, lower, upper)``.
    outputs : mapping or sequence of str
        Model variable → recording column it is compared with (a list when
        both are called the same).
    inputs : mapping or sequence of str, optional
        Model variable → recording column it reads.
    fixed : mapping, optional
        Further model variables set manually, name → value.
    timeout : float or None
        Time limit of one evaluation [s] (default 600; None: none).
    kill_grace : float, optional
        Seconds after ``timeout`` before an unresponsive worker is killed.
    backend : {"process", "ray", "serial"}
        Where parameter sets are evaluated (:mod:`.parallel`).
    workers, chunksize : int, optional
        Parallel workers and evaluations handed to one at once.
    ray_options : dict, optional
        ``ray.init`` keyword arguments when no Ray instance runs.

    Attributes
    ----------
    param_names, nominal, lower, upper, input_names, output_names, batched
        The :class:`SimModel` protocol; ``input_names``/``output_names`` are
        recording columns.
    fixed : dict
        Values set manually (:meth:`set_values`).
    """

    batched = False
    #: Configuration ``type`` of the adapter (see :mod:`.config`).
    kind = "external"

    def __init__(
        self,
        evaluator: Evaluator,
        *,
        name: str,
        parameters: Mapping[str, Any] | Sequence[Parameter] | None,
        outputs: Mapping[str, str] | Sequence[str],
        inputs: Mapping[str, str] | Sequence[str] | None = None,
        fixed: Mapping[str, float] | None = None,
        timeout: float | None = DEFAULT_TIMEOUT,
        kill_grace: float | None = None,
        backend: str = "process",
        workers: int | None = None,
        chunksize: int | None = None,
        ray_options: Mapping[str, Any] | None = None,
    ) -> None:
        # lazy: workers import the adapters and start fast (docstring)
        from thermogym.identification.external.config import (
            EvaluationOptions,
            parse_parameters,
            parse_signal_map,
        )

        self.name = str(name)
        self.parameters = parse_parameters(parameters)
        names = [p.name for p in self.parameters]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ConfigError(f"parameter {dup[0]!r} is named twice")
        self.param_names = tuple(names)
        self.nominal = np.array([p.nominal for p in self.parameters], dtype=float)
        self.lower = np.array([p.lower for p in self.parameters], dtype=float)
        self.upper = np.array([p.upper for p in self.parameters], dtype=float)
        self.inputs = parse_signal_map(inputs, "inputs")
        self.outputs = parse_signal_map(outputs, "outputs")
        if not self.outputs:
            raise ConfigError("outputs is empty; name the model variables to compare")
        clash = sorted(set(self.inputs) & set(self.outputs))
        if clash:
            raise ConfigError(f"variable {clash[0]!r} is both an input and an output")
        self.input_names = tuple(self.inputs.values())
        self.output_names = tuple(self.outputs.values())
        self.fixed: dict[str, float] = {}
        self.set_values(**dict(fixed or {}))
        if timeout is not None:
            timeout = float(timeout)
            if not timeout > 0:
                raise ConfigError(f"timeout is {timeout!r}, expected seconds > 0 (None: no limit)")
            if math.isinf(timeout):
                timeout = None
        self.timeout = timeout
        self.kill_grace = kill_grace
        self.evaluation = EvaluationOptions(
            backend=backend,
            workers=workers,
            chunksize=chunksize,
            ray=dict(ray_options or {}),
        )
        evaluator.output_vars = tuple(self.outputs)
        self.evaluator = evaluator
        self._executor: Executor | None = None
        self._ready = False  # subclasses set it when construction is complete
        self._type_config: dict[str, Any] = {}  # the adapter's own keys (config())
        self._source_digest = ""  # content hash of the model file (version)

    # ------------------------------------------------------------ provenance
    @property
    def version(self) -> str:
        """``kind:hash`` of the model file or command (FitResults record what was fitted)."""
        return f"{self.kind}:{self._source_digest}" if self._source_digest else self.kind

    def config(self) -> dict[str, Any]:
        """A configuration that rebuilds this model with :func:`~.load_external`.

        Stored in FitResults (``model_config``). Paths are absolute.
        """
        params = {
            p.name: {"start": p.nominal, "lower": p.lower, "upper": p.upper}
            | ({"unit": p.unit} if p.unit else {})
            for p in self.parameters
        }
        ev = self.evaluation
        return {
            "type": self.kind,
            "name": self.name,
            **self._type_config,
            "parameters": params,
            "fixed": dict(self.fixed),
            "inputs": dict(self.inputs),
            "outputs": dict(self.outputs),
            "timeout": math.inf if self.timeout is None else self.timeout,
            "evaluation": {
                "backend": ev.backend,
                **({"workers": ev.workers} if ev.workers else {}),
                **({"chunksize": ev.chunksize} if ev.chunksize else {}),
            },
        }

    # ------------------------------------------------------------ set-up
    def set_values(self, **values: float) -> None:
        """Set model variables manually (paper 000 workflow step 2).

        Parameters
        ----------
        **values : float
            Variable name → value; they are passed to every evaluation. An
            uncertain parameter cannot be set here (its value comes from
            ``theta``).

        Raises
        ------
        ParameterError
            The name is an uncertain parameter or the value is not finite.
        ConfigError
            The model has no such variable (where the adapter can tell).
        """
        checked: dict[str, float] = {}
        for k, v in values.items():
            if k in self.param_names:
                raise ParameterError(
                    f"{k!r} is an uncertain parameter of {self.name!r}; its value comes from "
                    "theta (fix it by leaving it out of the parameters)"
                )
            try:
                fv = float(v)
            except (TypeError, ValueError):
                raise ParameterError(f"value of {k!r} is {v!r}, expected a number") from None
            if not math.isfinite(fv):
                raise ParameterError(f"value of {k!r} is {fv!r}, expected a finite number")
            checked[k] = fv
        new = [k for k in checked if k not in self.fixed]
        if new and getattr(self, "_ready", False):
            self._new_value_names(new)
        self.fixed.update(checked)

    def _new_value_names(self, names: list[str]) -> None:
        """Check (and prepare for) variables set manually for the first time."""

    @property
    def executor(self) -> Executor:
        """The executor (created on first use, reused until :meth:`close`)."""
        if self._executor is None:
            ev = self.evaluation
            self._executor = make_executor(
                self.evaluator,
                backend=ev.backend,
                timeout=self.timeout,
                kill_grace=self.kill_grace,
                workers=ev.workers,
                chunksize=ev.chunksize,
                ray_options=dict(ev.ray),
            )
        return self._executor

    @property
    def stats(self) -> dict[str, Any]:
        """Start-up time [s], workers started/killed, evaluations, failures, evaluation time [s]."""
        if self._executor is None:
            return {"backend": self.evaluation.backend, "workers_started": 0, "evaluations": 0}
        s = self._executor.stats
        return {
            "backend": self._executor.backend,
            "workers": self._executor.workers,
            "startup_s": s.startup_s,
            "workers_started": s.workers_started,
            "workers_killed": s.workers_killed,
            "evaluations": s.evaluations,
            "failed": s.failed,
            "eval_s": s.eval_s,
        }

    # ------------------------------------------------------------ numerics
    def _theta(self, theta: ArrayLike) -> NDArray[np.float64]:
        th = np.asarray(theta, dtype=float)
        given = th.shape
        if th.ndim == 1:
            th = th[None, :]
        P = len(self.param_names)
        if th.ndim != 2 or th.shape[1] != P:
            raise ParameterError(
                f"theta has shape {given}, expected (B, {P}) for the parameters "
                f"{list(self.param_names)} of {self.name!r}"
            )
        bad = ~np.isfinite(th)
        if bad.any():
            b, j = np.argwhere(bad)[0]
            raise ParameterError(
                f"parameter {self.param_names[j]!r} of set {b} is {float(th[b, j])!r}; "
                "expected a finite number"
            )
        return th

    def params_of(self, row: ArrayLike) -> dict[str, float]:
        """Every variable set in the model for one parameter vector (free and fixed)."""
        out = dict(self.fixed)
        out.update({n: float(v) for n, v in zip(self.param_names, np.asarray(row), strict=True)})
        return out

    def experiment_data(
        self, experiment: Recording, provided: Sequence[str] = ()
    ) -> ExperimentData:
        """The recording's time and input columns as the model's variables.

        Parameters
        ----------
        experiment : Recording
        provided : sequence of str
            Input columns every parameter set gets from elsewhere
            (co-simulation); the recording need not have them.

        Raises
        ------
        RecordingError
            A mapped input column is missing or holds a non-finite value.
        """
        missing = [c for c in self.input_names if c not in experiment.columns and c not in provided]
        if missing:
            raise RecordingError(
                f"recording{_label(experiment)} lacks column(s) {missing} read by external model "
                f"{self.name!r} (inputs {self.inputs}); it has {list(experiment.columns)}"
            )
        time = np.array(experiment.time, dtype=float)
        inputs = {}
        h = hashlib.blake2b(time.tobytes(), digest_size=16)
        for var, col in self.inputs.items():
            if col in provided and col not in experiment.columns:
                continue  # every task brings its own trajectory
            v = np.array(experiment[col], dtype=float)
            bad = ~np.isfinite(v)
            if bad.any():
                i = int(np.argmax(bad))
                raise RecordingError(
                    f"column {col!r} of recording{_label(experiment)} is {float(v[i])!r} at "
                    f"t = {float(time[i]):g} s (sample {i}); external model {self.name!r} needs "
                    "finite inputs (prepare the recording first)"
                )
            v.flags.writeable = False
            inputs[var] = v
            h.update(var.encode())
            h.update(v.tobytes())
        time.flags.writeable = False
        return ExperimentData(time, inputs, h.hexdigest(), experiment.experiment_id)

    def simulate(self, theta: ArrayLike, experiment: Recording) -> SimBatch:
        """Simulate parameter sets ``theta`` (B, P) on the experiment.

        Parameters
        ----------
        theta : array_like, shape (B, P) or (P,)
            Values of :attr:`param_names`.
        experiment : Recording
            Provides the time grid and the input columns.

        Returns
        -------
        SimBatch
            ``outputs`` (B, T, n_out) in :attr:`output_names` order (NaN rows
            for failed sets) and one error message or None per set.

        Raises
        ------
        ParameterError
            ``theta`` has the wrong shape or non-finite values.
        RecordingError
            Input columns are missing or not finite.
        """
        return self.simulate_sets(theta, experiment)

    def simulate_sets(
        self,
        theta: ArrayLike,
        experiment: Recording,
        input_overrides: Mapping[str, NDArray[np.float64]] | None = None,
    ) -> SimBatch:
        """:meth:`simulate` with per-set input trajectories (co-simulation).

        Parameters
        ----------
        theta : array_like, shape (B, P)
        experiment : Recording
        input_overrides : mapping, optional
            Recording column → values (B, T) that replace that input column
            for each parameter set.
        """
        # lazy: workers start without pandas (module docstring)
        from thermogym.identification.simmodel import SimBatch

        th = self._theta(theta)
        B = th.shape[0]
        exp = self.experiment_data(experiment, tuple(input_overrides or ()))
        T = exp.n_samples
        col_to_var = {c: v for v, c in self.inputs.items()}
        ov = {}
        for col, arr in (input_overrides or {}).items():
            if col not in col_to_var:
                raise RecordingError(
                    f"input override {col!r} is not an input of {self.name!r}; inputs are "
                    f"{list(self.input_names)}"
                )
            a = np.asarray(arr, dtype=float)
            if a.shape != (B, T):
                raise RecordingError(
                    f"input override {col!r} has shape {a.shape}, expected ({B}, {T})"
                )
            ov[col_to_var[col]] = a
        tasks = [
            Task(b, self.params_of(th[b]), {v: a[b] for v, a in ov.items()} or None)
            for b in range(B)
        ]
        results = self.executor.map(exp, tasks)
        outputs = np.full((B, T, len(self.output_names)), np.nan)
        errors: list[str | None] = []
        for b, (out, err, _) in enumerate(results):
            if err is None and out is not None:
                outputs[b] = out
                errors.append(None)
            else:
                errors.append(err or "no output")
        return SimBatch(outputs, errors)

    def predict(self, experiment: Recording, **values: float) -> Recording:
        """Simulate one parameter set and return the outputs as a recording.

        Parameters
        ----------
        experiment : Recording
        **values : float
            Values of uncertain parameters (the others keep their start
            values).

        Returns
        -------
        Recording
            ``time`` and the output columns (role ``output``).

        Raises
        ------
        ExternalModelError
            The evaluation failed; the message is the model's.
        """
        # lazy: workers start without pandas (module docstring)
        from thermogym.recording import Recording

        unknown = sorted(set(values) - set(self.param_names))
        if unknown:
            raise ParameterError(
                f"{unknown[0]!r} is not an uncertain parameter of {self.name!r}; parameters "
                f"are {list(self.param_names)}"
            )
        row = self.nominal.copy()
        for k, v in values.items():
            row[self.param_names.index(k)] = float(v)
        sim = self.simulate(row[None], experiment)
        if sim.errors[0] is not None:
            raise ExternalModelError(f"external model {self.name!r} failed: {sim.errors[0]}")
        return Recording(
            experiment.time,
            {c: sim.outputs[0, :, j] for j, c in enumerate(self.output_names)},
            roles=dict.fromkeys(self.output_names, "output"),
            experiment_id=experiment.experiment_id,
            source=f"external:{self.name}",
            meta={"parameters": self.params_of(row)},
        )

    # ------------------------------------------------------------ lifetime
    def close(self) -> None:
        """Stop the worker processes or actors (a later call starts new ones)."""
        if self._executor is not None:
            self._executor.close()
            self._executor = None

    def __enter__(self) -> ExternalModel:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __repr__(self) -> str:
        return (
            f"{type(self).__name__}({self.name!r}, parameters={list(self.param_names)}, "
            f"outputs={list(self.output_names)}, backend={self.evaluation.backend!r})"
        )


def _label(rec: Any) -> str:
    eid = getattr(rec, "experiment_id", None)
    return f" {eid!r}" if eid else ""


def common_kwargs(cfg: ExternalConfig) -> dict[str, Any]:
    """Keyword arguments every adapter takes, from a checked configuration."""
    ev = cfg.evaluation
    return dict(
        parameters=cfg.parameters,
        outputs=cfg.outputs,
        inputs=cfg.inputs,
        fixed=cfg.fixed,
        name=cfg.name,
        timeout=cfg.timeout,
        kill_grace=cfg.kill_grace,
        backend=ev.backend,
        workers=ev.workers,
        chunksize=ev.chunksize,
        ray_options=dict(ev.ray),
    )


def file_digest(path: str | os.PathLike[str]) -> str:
    """First 12 hex digits of the SHA-256 of a file's content."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()[:12]
