"""Adapter for a GNU Octave / Matlab ``.m`` script via oct2py.

Paper 000 (``000_24627a5308ee07db.txt``, section 3) couples Matlab scripts
through the Matlab Engine API; here GNU Octave runs them through oct2py (an
optional extra: ``pip install 'thermogym[ext]'`` and an ``octave``
executable, e.g. ``apt-get install octave``).

The contract
------------
The script is run inside a fresh function workspace per evaluation, which
already holds

* each uncertain parameter and value set manually, as a double scalar;
* each input variable as a column vector (T×1) of the recording's values;
* the sample times [s] as a column vector under ``time`` (or
  ``time_variable``).

It leaves each output variable as a vector of T values (or of the length of
the variable named by ``output_time``, which are then interpolated linearly
onto the recording's times).

Default values for stand-alone runs must be guarded, because a script's
assignments always run::

    if ~exist('K', 'var'), K = 2.0; end

A script that clears the workspace (``clear``, ``clear all``,
``clearvars``) would delete the values the adapter sets; it is refused with
the offending line. Each worker process keeps one Octave session; a session
that timed out is restarted.
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import tempfile
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

__all__ = ["OctaveModel", "find_octave"]

_RUNNER = "thermogym_run_script__"
# Runs the script in this function's fresh workspace; local names end in __ so
# that they cannot clash with the script's variables.
_RUNNER_SOURCE = f"""function tg_out__ = {_RUNNER}(tg_script__, tg_vars__, tg_outnames__)
  tg_names__ = fieldnames(tg_vars__);
  for tg_i__ = 1:numel(tg_names__)
    eval([tg_names__{{tg_i__}} ' = tg_vars__.(tg_names__{{tg_i__}});']);
  end
  clear tg_i__ tg_names__ tg_vars__
  run(tg_script__);
  tg_out__ = struct();
  for tg_j__ = 1:numel(tg_outnames__)
    if exist(tg_outnames__{{tg_j__}}, 'var')
      tg_out__.(tg_outnames__{{tg_j__}}) = eval(tg_outnames__{{tg_j__}});
    end
  end
end
"""

_CLEAR_RE = re.compile(r"^[ \t]*(clear\b|clearvars\b|clc[ \t]*[;,][ \t]*clear\b)", re.MULTILINE)


def find_octave(executable: str | None = None) -> str | None:
    """Path of the Octave executable oct2py would use, or None.

    Looks at ``executable``, then ``$OCTAVE_EXECUTABLE``, ``$OCTAVE``, then
    ``octave-cli`` and ``octave`` on ``PATH``.
    """
    for cand in (executable, os.environ.get("OCTAVE_EXECUTABLE"), os.environ.get("OCTAVE")):
        if cand:
            found = shutil.which(cand)
            if found:
                return found
    for name in ("octave-cli", "octave"):
        found = shutil.which(name)
        if found:
            return found
    return None


def _strip_comments(source: str) -> str:
    """Remove ``%``/``#`` comments (not inside single- or double-quoted strings)."""
    out = []
    for line in source.splitlines():
        buf = []
        quote = None
        prev = ""
        for ch in line:
            if quote:
                if ch == quote:
                    quote = None
            elif ch in "%#":
                break
            elif ch == '"' or (ch == "'" and not (prev.isalnum() or prev in ")]}_.'")):
                quote = ch
            buf.append(ch)
            prev = ch
        out.append("".join(buf))
    return "\n".join(out)


class _OctaveEvaluator(Evaluator):
    handles_timeout = True

    def __init__(
        self,
        path: Path,
        time_variable: str,
        output_time: str | None,
        workdir: Path | None,
        executable: str | None,
    ) -> None:
        self.path = str(path)
        self.time_variable = time_variable
        self.output_time = output_time
        self.workdir = str(workdir) if workdir is not None else None
        self.executable = executable
        self.label = f"Octave script {path.name!r}"

    def _start(self) -> None:
        from oct2py import Oct2Py

        kwargs: dict[str, Any] = {}
        if self.executable:
            kwargs["executable"] = self.executable
        oc = Oct2Py(**kwargs)
        # a session that is interrupted or killed must not leave 'octave-workspace' files
        oc.eval(
            "crash_dumps_octave_core(false); sighup_dumps_octave_core(false); "
            "sigterm_dumps_octave_core(false);",
            nout=0,
        )
        oc.addpath(self._live_dir)
        if self.workdir:
            oc.cd(self.workdir)
        self._live_oc = oc

    def setup(self) -> None:
        self._live_dir = tempfile.mkdtemp(prefix="thermogym-octave-")
        Path(self._live_dir, f"{_RUNNER}.m").write_text(_RUNNER_SOURCE, encoding="utf-8")
        self._start()

    def teardown(self) -> None:
        oc = getattr(self, "_live_oc", None)
        if oc is not None:
            with contextlib.suppress(Exception):
                oc.exit()
        d = getattr(self, "_live_dir", None)
        if d:
            shutil.rmtree(d, ignore_errors=True)

    def run(self, params: dict[str, float], exp: ExperimentData, timeout: float | None) -> Any:
        from oct2py import Oct2PyError

        variables: dict[str, Any] = {k: float(v) for k, v in params.items()}
        for k, v in exp.inputs.items():
            variables[k] = np.asarray(v, dtype=float).reshape(-1, 1)
        variables[self.time_variable] = exp.time.reshape(-1, 1).copy()
        names = list(self.output_vars) + ([self.output_time] if self.output_time else [])
        cell = np.array(names, dtype=object).reshape(1, -1)  # a cell array of strings
        try:
            res = self._live_oc.feval(_RUNNER, self.path, variables, cell, timeout=timeout)
        except Oct2PyError as e:
            msg = str(e)
            if "Timed out" in msg:
                with contextlib.suppress(Exception):
                    self._live_oc.exit()
                self._start()  # the interrupted session may still be busy
                raise EvaluationTimeout(f"evaluation timed out after {timeout:g} s") from None
            raise
        res = dict(res) if res is not None else {}
        values = {k: res[k] for k in self.output_vars if k in res}
        if self.output_time:
            if self.output_time not in res:
                return values  # coerce_outputs reports what is missing
            return Outputs(values, time=res[self.output_time])
        return values

    def describe_error(self, exc: BaseException) -> str:
        msg = str(exc)
        lines = [ln.strip() for ln in msg.splitlines() if ln.strip()]
        errs = [ln for ln in lines if ln.lower().startswith("error:")]
        text = "; ".join(errs) if errs else "; ".join(lines[-3:])
        return f"Octave: {text}" if text else f"{type(exc).__name__}"


class OctaveModel(ExternalModel):
    """A GNU Octave / Matlab ``.m`` script as an identifiable model (see the module docstring).

    Parameters
    ----------
    path : path
        The ``.m`` script.
    parameters, outputs, inputs, fixed
        As :class:`~.base.ExternalModel`; names are the script's variables.
    name : str, optional
        Default: the script's file stem.
    time_variable : str
        Variable holding the sample times (default ``"time"``).
    output_time : str, optional
        Variable holding the outputs' own times.
    workdir : path, optional
        Folder Octave works in (default: the script's folder).
    executable : str, optional
        The Octave program (default: ``$OCTAVE_EXECUTABLE`` or ``octave-cli``
        / ``octave`` on ``PATH``).
    **evaluation
        ``timeout``, ``kill_grace``, ``backend``, ``workers``, ``chunksize``,
        ``ray_options``.

    Raises
    ------
    ConfigError
        oct2py or Octave missing; the script cannot be read; a parameter,
        fixed value, input or output does not occur in it; it clears the
        workspace.
    """

    kind = "octave"

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        parameters: Any,
        outputs: Mapping[str, str] | list[str],
        inputs: Mapping[str, str] | list[str] | None = None,
        fixed: Mapping[str, float] | None = None,
        name: str | None = None,
        time_variable: str = "time",
        output_time: str | None = None,
        workdir: str | os.PathLike[str] | None = None,
        executable: str | None = None,
        **evaluation: Any,
    ) -> None:
        try:
            import oct2py  # noqa: F401
        except ImportError as e:
            raise ConfigError("Octave models need oct2py (pip install 'thermogym[ext]')") from e
        exe = find_octave(executable)
        if exe is None:
            raise ConfigError(
                "GNU Octave was not found (no octave-cli or octave on PATH, OCTAVE_EXECUTABLE "
                "unset); install it, e.g. apt-get install octave"
            )
        p = Path(path).resolve()
        try:
            source = p.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as e:
            raise ConfigError(f"cannot read Octave script {str(p)!r}: {e}") from e
        code = _strip_comments(source)
        m = _CLEAR_RE.search(code)
        if m:
            line = code[: m.start()].count("\n") + 1
            raise ConfigError(
                f"Octave script {p.name!r} line {line} clears the workspace "
                f"({m.group(0).strip()!r}), "
                "which deletes the values the adapter sets; remove that line"
            )
        ev = _OctaveEvaluator(
            p, time_variable, output_time, Path(workdir) if workdir else p.parent, exe
        )
        super().__init__(
            ev,
            name=name or p.stem,
            parameters=parameters,
            outputs=outputs,
            inputs=inputs,
            fixed=fixed,
            **evaluation,
        )
        words = set(re.findall(r"[A-Za-z_][A-Za-z0-9_]*", code))
        for key, names in (
            ("parameters", self.param_names),
            ("fixed", self.fixed),
            ("inputs", self.inputs),
            ("outputs", self.outputs),
        ):
            for n in names:
                if n not in words:
                    raise ConfigError(
                        f"configuration key '{key}.{n}': {n!r} is not a variable of Octave "
                        f"script {p.name!r}"
                    )
        self.path = p
        self._words = words
        self._type_config = {
            "path": str(p),
            "time_variable": time_variable,
            **({"output_time": output_time} if output_time else {}),
            **({"workdir": str(Path(workdir).resolve())} if workdir else {}),
            **({"executable": executable} if executable else {}),
        }
        self._source_digest = file_digest(p)
        self._ready = True

    def _new_value_names(self, names: list[str]) -> None:
        for n in names:
            if n not in self._words:
                raise ConfigError(f"{n!r} is not a variable of Octave script {self.path.name!r}")

    @classmethod
    def from_config(cls, cfg: ExternalConfig) -> OctaveModel:
        """Build from a checked configuration (``type = "octave"``)."""
        o = cfg.options
        return cls(
            o["path"],
            time_variable=o.get("time_variable", "time"),
            output_time=o.get("output_time"),
            workdir=cfg.workdir,
            executable=o.get("executable"),
            **common_kwargs(cfg),
        )
