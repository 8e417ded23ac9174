"""Adapter for a Functional Mock-up Unit (FMI 2/3, co-simulation or model exchange) via FMPy.

FMUs are the standard exchange format of Modelica, Simulink, Dymola,
OpenModelica and many other tools, so this adapter reaches models of all of
them (paper 000's first way of coupling: an API of the external software).

Parameters and values set manually are **start values**: they are set after
the FMU is instantiated and before its initialisation, so an FMU computes its
dependent quantities from them. Inputs come from the recording's columns.

How outputs are sampled onto the recording's grid
-------------------------------------------------
``mode = "step"`` (FMI 2 co-simulation; the default where possible)
    The adapter is the master algorithm: inputs are set to the recording's
    values at ``t_k`` and held over ``[t_k, t_{k+1})`` (zero-order hold, as
    every thermogym model treats inputs), the FMU steps from ``t_k`` to
    ``t_{k+1}`` (in ``substeps`` equal steps), and the outputs are read at
    ``t_{k+1}``; outputs at ``t_0`` are read after initialisation. The
    outputs therefore lie exactly on the recording's time stamps, uniform or
    not.
``mode = "simulate"`` (any FMU: FMI 1/2/3, model exchange)
    ``fmpy.simulate_fmu`` runs the FMU from ``t_0`` to ``t_{T-1}`` with the
    inputs as a step signal (the same zero-order hold) and records the
    outputs every ``min(diff(time)) / substeps`` seconds (its solver options
    in ``fmpy_options``); the result is interpolated linearly onto the
    recording's times, which is exact at the grid points of a uniform grid.

The FMU is extracted once into a temporary folder (removed by ``close()``);
each worker loads its library once and instantiates the FMU per evaluation.
"""

from __future__ import annotations

import contextlib
import itertools
import os
import shutil
import tempfile
import time as _time
import weakref
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from thermogym.errors import ConfigError
from thermogym.identification.external._evaluate import (
    EvaluationTimeout,
    Evaluator,
    ExperimentData,
    Outputs,
)
from thermogym.identification.external.base import ExternalModel, common_kwargs, file_digest

if TYPE_CHECKING:
    from thermogym.identification.external.config import ExternalConfig

__all__ = ["FMUModel"]

_REAL_TYPES = ("Real", "Float64", "Float32")


def _fmpy() -> Any:
    try:
        import fmpy
    except ImportError as e:
        raise ConfigError("FMU models need FMPy (pip install 'thermogym[ext]')") from e
    return fmpy


class _FMUEvaluator(Evaluator):
    handles_timeout = True

    def __init__(
        self,
        fmu_path: Path,
        unzip_dir: str,
        mode: str,
        substeps: int,
        fmpy_options: Mapping[str, Any],
        input_vars: tuple[str, ...],
    ) -> None:
        self.fmu_path = str(fmu_path)
        self.unzip_dir = unzip_dir
        self.mode = mode
        self.substeps = int(substeps)
        self.fmpy_options = dict(fmpy_options)
        self.input_vars = input_vars
        self.label = f"FMU {fmu_path.name!r}"

    def setup(self) -> None:
        fmpy = _fmpy()
        from fmpy import read_model_description

        if not os.path.isdir(self.unzip_dir):  # e.g. a Ray worker on another machine
            self._live_tmp = tempfile.mkdtemp(prefix="thermogym-fmu-")
            fmpy.extract(self.fmu_path, self._live_tmp)
            self.unzip_dir = self._live_tmp
        md = read_model_description(self.unzip_dir)
        self._live_md = md
        self._live_vr = {v.name: v.valueReference for v in md.modelVariables}
        self._live_count = itertools.count()

    def teardown(self) -> None:
        tmp = getattr(self, "_live_tmp", None)
        if tmp:
            shutil.rmtree(tmp, ignore_errors=True)

    def run(self, params: dict[str, float], exp: ExperimentData, timeout: float | None) -> Any:
        deadline = None if timeout is None else _time.perf_counter() + timeout
        if self.mode == "step":
            return self._run_step(params, exp, timeout, deadline)
        return self._run_simulate(params, exp, timeout)

    def _run_step(
        self,
        params: dict[str, float],
        exp: ExperimentData,
        timeout: float | None,
        deadline: float | None,
    ) -> Any:
        from fmpy.fmi2 import FMU2Slave

        md = self._live_md
        vr = self._live_vr
        t = exp.time
        T = t.shape[0]
        p_vr = [vr[k] for k in params]
        p_val = list(params.values())
        u_vr = [vr[k] for k in self.input_vars]
        U = np.column_stack([exp.inputs[k] for k in self.input_vars]) if u_vr else np.empty((T, 0))
        y_vr = [vr[k] for k in self.output_vars]
        Y = np.empty((T, len(y_vr)))
        fmu = FMU2Slave(
            guid=md.guid,
            unzipDirectory=self.unzip_dir,
            modelIdentifier=md.coSimulation.modelIdentifier,
            instanceName=f"thermogym{next(self._live_count)}",
        )
        fmu.instantiate()
        try:
            if p_vr:
                fmu.setReal(p_vr, p_val)  # start values, before initialisation
            if u_vr:
                fmu.setReal(u_vr, list(U[0]))
            fmu.setupExperiment(startTime=float(t[0]), stopTime=float(t[-1]))
            fmu.enterInitializationMode()
            fmu.exitInitializationMode()
            Y[0] = fmu.getReal(y_vr)
            n = self.substeps
            for k in range(T - 1):
                if u_vr:
                    fmu.setReal(u_vr, list(U[k]))  # zero-order hold over [t_k, t_k+1)
                h = (t[k + 1] - t[k]) / n
                for s in range(n):
                    fmu.doStep(
                        currentCommunicationPoint=float(t[k] + s * h),
                        communicationStepSize=float(h),
                    )
                Y[k + 1] = fmu.getReal(y_vr)
                if deadline is not None and _time.perf_counter() > deadline:
                    raise EvaluationTimeout(
                        f"evaluation timed out after {timeout:g} s (at t = {float(t[k + 1]):g} s)"
                    )
            fmu.terminate()
        finally:
            with contextlib.suppress(Exception):
                fmu.freeInstance()
        return Y

    def _run_simulate(
        self, params: dict[str, float], exp: ExperimentData, timeout: float | None
    ) -> Any:
        from fmpy import simulate_fmu

        t = exp.time
        if self.input_vars:
            # zero-order hold: every step is a pair of samples at the same time
            tt = np.repeat(t, 2)[1:]
            sig = np.zeros(
                tt.shape[0], dtype=[("time", float)] + [(k, float) for k in self.input_vars]
            )
            sig["time"] = tt
            for k in self.input_vars:
                sig[k] = np.repeat(exp.inputs[k], 2)[:-1]
        else:
            sig = None
        dt_min = float(np.min(np.diff(t))) if t.shape[0] > 1 else 1.0
        opts: dict[str, Any] = {"output_interval": dt_min / self.substeps}
        opts.update(self.fmpy_options)
        res = simulate_fmu(
            self.unzip_dir,
            start_time=float(t[0]),
            stop_time=float(t[-1]) if t.shape[0] > 1 else float(t[0]) + dt_min,
            start_values=dict(params),
            input=sig,
            output=list(self.output_vars),
            timeout=timeout,
            model_description=self._live_md,
            **opts,
        )
        if timeout is not None and res["time"][-1] < t[-1] - 1e-9 * max(1.0, abs(t[-1])):
            raise EvaluationTimeout(
                f"evaluation timed out after {timeout:g} s (at t = {float(res['time'][-1]):g} s)"
            )
        # the result may hold several samples at one time (events): keep the last of each
        rt = res["time"]
        keep = np.append(np.diff(rt) > 0, True)
        return Outputs({k: res[k][keep] for k in self.output_vars}, time=rt[keep])

    def describe_error(self, exc: BaseException) -> str:
        return f"{type(exc).__name__}: {exc}"


class FMUModel(ExternalModel):
    """An FMU as an identifiable model (see the module docstring).

    Parameters
    ----------
    path : path
        The ``.fmu`` file.
    parameters, outputs, inputs, fixed
        As :class:`~.base.ExternalModel`; names are FMU variable names.
        Parameters and fixed values must be Real variables that can be set
        before initialisation (causality ``parameter`` or ``input``); inputs
        Real variables of causality ``input``; outputs any Real variables.
    name : str, optional
        Default: the FMU's model name.
    mode : {"auto", "step", "simulate"}
        ``auto``: ``step`` for FMI 2 co-simulation FMUs, else ``simulate``.
    substeps : int
        FMU steps per sample interval (``step``), or output points per
        smallest interval (``simulate``).
    fmpy_options : mapping, optional
        Further arguments of ``fmpy.simulate_fmu`` (``simulate`` mode), e.g.
        ``{"solver": "CVode", "relative_tolerance": 1e-6}``.
    **evaluation
        ``timeout``, ``kill_grace``, ``backend``, ``workers``, ``chunksize``,
        ``ray_options``.

    Raises
    ------
    ConfigError
        FMPy missing, the file is not an FMU, or a variable is unknown or of
        the wrong kind; the message names the configuration key.
    """

    kind = "fmu"

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        parameters: Any,
        outputs: Mapping[str, str] | list[str],
        inputs: Mapping[str, str] | list[str] | None = None,
        fixed: Mapping[str, float] | None = None,
        name: str | None = None,
        mode: str = "auto",
        substeps: int = 1,
        fmpy_options: Mapping[str, Any] | None = None,
        **evaluation: Any,
    ) -> None:
        fmpy = _fmpy()
        from fmpy import read_model_description

        p = Path(path).resolve()
        if not p.is_file():
            raise ConfigError(f"FMU {str(p)!r} does not exist")
        try:
            md = read_model_description(str(p))
        except Exception as e:
            raise ConfigError(
                f"{str(p)!r} cannot be read as an FMU: {type(e).__name__}: {e}"
            ) from e
        if mode not in ("auto", "step", "simulate"):
            raise ConfigError(f"mode is {mode!r}, expected 'auto', 'step' or 'simulate'")
        if isinstance(substeps, bool) or not isinstance(substeps, int) or substeps < 1:
            raise ConfigError(f"substeps is {substeps!r}, expected a positive integer")
        can_step = md.fmiVersion.startswith("2") and md.coSimulation is not None
        if mode == "auto":
            mode = "step" if can_step else "simulate"
        elif mode == "step" and not can_step:
            raise ConfigError(
                f"mode 'step' needs an FMI 2 co-simulation FMU; {p.name!r} is FMI "
                f"{md.fmiVersion} {'co-simulation' if md.coSimulation else 'model exchange'} "
                "(use mode = 'simulate')"
            )
        self.model_description = md
        placeholder = _FMUEvaluator(p, "", mode, substeps, fmpy_options or {}, ())
        super().__init__(
            placeholder,
            name=name or md.modelName,
            parameters=parameters,
            outputs=outputs,
            inputs=inputs,
            fixed=fixed,
            **evaluation,
        )
        variables = {v.name: v for v in md.modelVariables}
        known = sorted(variables)[:30]

        def _check(key: str, names: Any, causalities: tuple[str, ...] | None) -> None:
            for n in names:
                v = variables.get(n)
                if v is None:
                    raise ConfigError(
                        f"configuration key '{key}.{n}': FMU {p.name!r} has no variable {n!r}; "
                        f"it has {known}"
                    )
                if v.type not in _REAL_TYPES:
                    raise ConfigError(
                        f"configuration key '{key}.{n}': FMU variable {n!r} is of type {v.type}, "
                        "only Real variables are supported"
                    )
                if causalities is not None and v.causality not in causalities:
                    raise ConfigError(
                        f"configuration key '{key}.{n}': FMU variable {n!r} has causality "
                        f"{v.causality!r}, expected one of {list(causalities)}"
                    )

        _check("parameters", self.param_names, ("parameter", "input"))
        _check("fixed", self.fixed, ("parameter", "input"))
        _check("inputs", self.inputs, ("input",))
        _check("outputs", self.outputs, None)
        self._tmp = tempfile.mkdtemp(prefix="thermogym-fmu-")
        self._cleanup = weakref.finalize(self, shutil.rmtree, self._tmp, True)
        fmpy.extract(str(p), self._tmp)
        ev = _FMUEvaluator(p, self._tmp, mode, substeps, fmpy_options or {}, tuple(self.inputs))
        ev.output_vars = tuple(self.outputs)
        self.evaluator = ev
        self.path = p
        self.mode = mode
        self._check_vars = _check
        self._type_config = {"path": str(p), "mode": mode, "substeps": substeps}
        if fmpy_options:
            self._type_config["fmpy_options"] = dict(fmpy_options)
        self._source_digest = file_digest(p)
        self._ready = True

    def _new_value_names(self, names: list[str]) -> None:
        self._check_vars("fixed", names, ("parameter", "input"))

    @classmethod
    def from_config(cls, cfg: ExternalConfig) -> FMUModel:
        """Build from a checked configuration (``type = "fmu"``)."""
        o = cfg.options
        return cls(
            o["path"],
            mode=o.get("mode", "auto"),
            substeps=o.get("substeps", 1),
            fmpy_options=o.get("fmpy_options"),
            **common_kwargs(cfg),
        )

    def close(self) -> None:
        """Stop the workers; the extracted FMU stays until the model is garbage-collected."""
        super().close()
