"""Adapter for a Python function: ``outputs = func(time, inputs, params)``.

The contract
------------
``func(time, inputs, params)`` is called once per parameter set with

* ``time``: ndarray (T,), the recording's sample times [s] (read-only);
* ``inputs``: dict model variable → ndarray (T,) (read-only), the mapped
  recording columns;
* ``params``: dict name → float, the uncertain parameters and the values set
  manually;

and returns a mapping model variable → array (T,) holding at least the
output variables, or an array (T, n_out) in the order of ``outputs``.

With ``vectorized=True`` it is called once for the whole batch: each
``params`` value is an array (B,) and it returns arrays (B, T) per variable,
or one array (B, T, n_out). The model is then ``batched`` and evaluated in
this process.

The function is given as an object or as ``"package.module:function"`` or
``"path/to/file.py:function"``. Local worker processes receive it by
reference when it can be imported and by value (cloudpickle) otherwise.
"""

from __future__ import annotations

import hashlib
import importlib
import importlib.util
import os
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from thermogym.errors import ConfigError
from thermogym.identification.external._evaluate import (
    EvaluationTimeout,
    Evaluator,
    ExperimentData,
    OutputError,
    _nonfinite_message,
    soft_timeout,
    traceback_line,
)
from thermogym.identification.external.base import ExternalModel, common_kwargs, file_digest

if TYPE_CHECKING:
    from thermogym.identification.external.config import ExternalConfig
    from thermogym.identification.simmodel import SimBatch
    from thermogym.recording import Recording

__all__ = ["CallableModel", "resolve_callable"]

ModelFunction = Callable[[NDArray[np.float64], dict[str, NDArray[np.float64]], dict[str, Any]], Any]


def resolve_callable(target: str) -> ModelFunction:
    """Import ``"package.module:function"`` or ``"path/file.py:function"``.

    Raises
    ------
    ConfigError
        The module or file cannot be loaded or has no such callable.

    Examples
    --------
    >>> resolve_callable("math:hypot")(3.0, 4.0)
    5.0
    """
    mod_part, sep, attr = target.rpartition(":")
    if not sep or not mod_part or not attr:
        raise ConfigError(
            f"callable {target!r}: expected 'package.module:function' or 'file.py:function'"
        )
    try:
        if mod_part.endswith(".py"):
            path = Path(mod_part).resolve()
            if not path.is_file():
                raise ConfigError(f"callable {target!r}: file {str(path)!r} does not exist")
            digest = hashlib.blake2b(str(path).encode(), digest_size=6).hexdigest()
            modname = f"_thermogym_external_{path.stem}_{digest}"
            spec = importlib.util.spec_from_file_location(modname, path)
            if spec is None or spec.loader is None:
                raise ConfigError(f"callable {target!r}: cannot load {str(path)!r}")
            module = importlib.util.module_from_spec(spec)
            spec.loader.exec_module(module)
        else:
            module = importlib.import_module(mod_part)
    except ConfigError:
        raise
    except Exception as e:
        raise ConfigError(
            f"callable {target!r}: loading {mod_part!r} failed: {type(e).__name__}: {e}"
        ) from e
    fn = module
    for part in attr.split("."):
        if not hasattr(fn, part):
            raise ConfigError(f"callable {target!r}: {mod_part!r} has no attribute {attr!r}")
        fn = getattr(fn, part)
    if not callable(fn):
        raise ConfigError(f"callable {target!r}: {attr!r} is a {type(fn).__name__}, not callable")
    return fn


class _CallableEvaluator(Evaluator):
    def __init__(self, func: ModelFunction | None, target: str | None) -> None:
        self.func = func
        self.target = target
        name = target or getattr(func, "__qualname__", repr(func))
        self.label = f"callable {name!r}"
        self._file = None
        if target is not None and target.rpartition(":")[0].endswith(".py"):
            self._file = str(Path(target.rpartition(":")[0]).resolve())

    def setup(self) -> None:
        self._live_fn = self.func if self.func is not None else resolve_callable(self.target or "")

    def run(self, params: dict[str, float], exp: ExperimentData, timeout: float | None) -> Any:
        return self._live_fn(exp.time, dict(exp.inputs), params)

    def describe_error(self, exc: BaseException) -> str:
        msg = f"{type(exc).__name__}: {exc}"
        code = getattr(self._live_fn, "__code__", None)
        filename = self._file or (code.co_filename if code is not None else None)
        line = traceback_line(exc, filename) if filename else None
        return f"{msg} ({os.path.basename(filename)} line {line})" if line and filename else msg


class CallableModel(ExternalModel):
    """A Python function as an identifiable model (see the module docstring).

    Parameters
    ----------
    func : callable or str
        ``func(time, inputs, params)``, or ``"package.module:function"`` /
        ``"path/file.py:function"``.
    parameters, outputs, inputs, fixed
        As :class:`~.base.ExternalModel`.
    name : str, optional
        Default: the function's name.
    vectorized : bool
        ``func`` evaluates a whole batch at once (then ``batched`` is True
        and it runs in this process).
    **evaluation
        ``timeout``, ``kill_grace``, ``backend``, ``workers``, ``chunksize``,
        ``ray_options`` (:class:`~.base.ExternalModel`).

    Examples
    --------
    >>> import numpy as np
    >>> from thermogym.recording import Recording
    >>> def gain(time, inputs, params):
    ...     return {"y": params["K"] * inputs["u"]}
    >>> rec = Recording(np.arange(3.0), {"u": [1.0, 2.0, 3.0]})
    >>> with CallableModel(gain, parameters={"K": (2.0, 0.0, 5.0)}, inputs=["u"],
    ...                    outputs=["y"], backend="serial") as m:
    ...     batch = m.simulate(np.array([[1.0], [3.0]]), rec)
    >>> batch.outputs[:, :, 0]
    array([[1., 2., 3.],
           [3., 6., 9.]])
    """

    kind = "callable"

    def __init__(
        self,
        func: ModelFunction | str,
        *,
        parameters: Any,
        outputs: Mapping[str, str] | list[str],
        inputs: Mapping[str, str] | list[str] | None = None,
        fixed: Mapping[str, float] | None = None,
        name: str | None = None,
        vectorized: bool = False,
        **evaluation: Any,
    ) -> None:
        if isinstance(func, str):
            mod_part, _, attr = func.rpartition(":")
            if mod_part.endswith(".py"):  # absolute, so that config() rebuilds it anywhere
                func = f"{Path(mod_part).resolve()}:{attr}"
            target: str | None = func
            fobj = None
            resolve_callable(func)  # fail here, not in every worker
            default_name = func.rpartition(":")[2]
        elif callable(func):
            target, fobj = None, func
            default_name = getattr(func, "__name__", "callable")
        else:
            raise ConfigError(
                f"func is a {type(func).__name__}, expected a callable or 'module:function'"
            )
        evaluator = _CallableEvaluator(fobj, target)
        super().__init__(
            evaluator,
            name=name or default_name,
            parameters=parameters,
            outputs=outputs,
            inputs=inputs,
            fixed=fixed,
            **evaluation,
        )
        self.vectorized = bool(vectorized)
        if self.vectorized:
            self.batched = True
        if target is None:
            mod = getattr(func, "__module__", None)
            qual = getattr(func, "__qualname__", "")
            importable = mod not in (None, "__main__") and "<" not in qual
            target = f"{mod}:{qual}" if importable else f"<{default_name}>"
        path_part = target.rpartition(":")[0]
        if path_part.endswith(".py"):
            self._type_config = {"path": path_part, "function": target.rpartition(":")[2]}
            self._source_digest = file_digest(path_part)
        else:
            self._type_config = {"callable": target}
        if self.vectorized:
            self._type_config["vectorized"] = True
        self._ready = True

    @classmethod
    def from_config(cls, cfg: ExternalConfig) -> CallableModel:
        """Build from a checked configuration (``type = "callable"``)."""
        o = cfg.options
        target = o["callable"] if "callable" in o else f"{o['path']}:{o['function']}"
        return cls(target, vectorized=o.get("vectorized", False), **common_kwargs(cfg))

    def simulate_sets(
        self,
        theta: ArrayLike,
        experiment: Recording,
        input_overrides: Mapping[str, NDArray[np.float64]] | None = None,
    ) -> SimBatch:
        """Simulate the batch; one call of ``func`` when ``vectorized``."""
        if not self.vectorized:
            return super().simulate_sets(theta, experiment, input_overrides)
        # lazy: workers start without pandas (see base)
        from thermogym.identification.simmodel import SimBatch

        th = self._theta(theta)
        B = th.shape[0]
        exp = self.experiment_data(experiment, tuple(input_overrides or ()))
        T = exp.n_samples
        params: dict[str, Any] = {k: np.full(B, v) for k, v in self.fixed.items()}
        params.update({n: th[:, j].copy() for j, n in enumerate(self.param_names)})
        inputs: dict[str, Any] = dict(exp.inputs)
        col_to_var = {c: v for v, c in self.inputs.items()}
        for col, arr in (input_overrides or {}).items():
            inputs[col_to_var[col]] = np.asarray(arr, dtype=float)
        n_out = len(self.output_names)
        ev = self.evaluator
        ev.ensure_setup()
        try:
            with soft_timeout(self.timeout, "vectorized evaluation"):
                raw = ev.run(params, ExperimentData(exp.time, inputs, exp.key), self.timeout)
            out = _batch_outputs(raw, tuple(self.outputs), B, T)
        except (Exception, EvaluationTimeout) as e:
            msg = str(e) if isinstance(e, EvaluationTimeout | OutputError) else ev.describe_error(e)
            return SimBatch(np.full((B, T, n_out), np.nan), [msg] * B)
        errors: list[str | None] = []
        for b in range(B):
            if np.isfinite(out[b]).all():
                errors.append(None)
            else:
                errors.append(_nonfinite_message(out[b], tuple(self.outputs), exp.time))
                out[b] = np.nan
        return SimBatch(out, errors)


def _batch_outputs(raw: Any, output_vars: tuple[str, ...], B: int, T: int) -> NDArray[np.float64]:
    n = len(output_vars)
    if isinstance(raw, Mapping):
        missing = [v for v in output_vars if v not in raw]
        if missing:
            raise OutputError(f"output variable(s) {missing} were not produced")
        cols = []
        for v in output_vars:
            a = np.asarray(raw[v], dtype=float)
            if a.shape != (B, T):
                raise OutputError(f"output {v!r} has shape {a.shape}, expected ({B}, {T})")
            cols.append(a)
        return np.stack(cols, axis=2)
    a = np.asarray(raw, dtype=float)
    if a.shape != (B, T, n):
        raise OutputError(f"the function returned shape {a.shape}, expected ({B}, {T}, {n})")
    return a.copy()
