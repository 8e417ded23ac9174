"""Adapter for a command-line batch job: files in, program run, file out.

Paper 000 (``000_24627a5308ee07db.txt``, section 3) names three ways of
coupling external software; the third is "start a simulation as a batch job,
that is, via command line", the choice when no API or interpreter can be
used. Per parameter set the adapter

1. makes a fresh temporary folder and writes there

   * ``inputs.csv``: a header ``time,<input variables>`` and one row per
     sample of the recording (times in s, floats written with 17 significant
     digits, so they read back exactly);
   * ``params.json``: ``{"name": value, ...}`` for the uncertain parameters
     and the values set manually (``params_format = "csv"``: lines
     ``name,value`` after a header ``name,value``);

2. runs the command (a list of words, no shell) with the placeholders
   ``{python}`` (this Python interpreter), ``{inputs}``, ``{params}``,
   ``{outputs}`` (absolute file paths), ``{dir}`` (the temporary folder) and
   ``{config_dir}`` replaced, in ``workdir`` (default: the configuration
   file's folder; for the Python API the current folder);
   the same paths are in the environment as ``THERMOGYM_INPUTS``,
   ``THERMOGYM_PARAMS``, ``THERMOGYM_OUTPUTS`` and ``THERMOGYM_DIR``;

3. waits at most ``timeout`` seconds (then kills the program's whole process
   group), and reads ``outputs.csv``, which the program writes: a header with
   the output variables and one row per sample. With a ``time`` column the
   outputs may lie on the program's own time grid; they are interpolated
   linearly onto the recording's times. Without it there must be one row per
   sample of the recording.

A non-zero exit status, a missing or malformed output file and a timeout are
reported with the program's last lines of standard error. The temporary
folder is removed afterwards (``keep_files = "on_error"`` keeps it when the
evaluation failed, ``"always"`` always; its path is then in the message).
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
import os
import shlex
import shutil
import signal
import subprocess
import sys
import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from thermogym.errors import ConfigError
from thermogym.identification.external._evaluate import (
    Evaluator,
    ExperimentData,
    OutputError,
    Outputs,
)
from thermogym.identification.external.base import ExternalModel, common_kwargs, file_digest

if TYPE_CHECKING:
    from thermogym.identification.external.config import ExternalConfig

__all__ = ["PLACEHOLDERS", "BatchJobModel", "read_output_csv", "write_inputs_csv"]

#: Placeholders replaced in the words of the command.
PLACEHOLDERS: tuple[str, ...] = ("python", "inputs", "params", "outputs", "dir", "config_dir")


def write_inputs_csv(
    path: Path, time: NDArray[np.float64], inputs: Mapping[str, NDArray[np.float64]]
) -> None:
    """Write ``time`` and the input columns as CSV (exact float round trip)."""
    data = np.column_stack([time, *inputs.values()]) if inputs else time[:, None]
    buf = io.StringIO()
    buf.write(",".join(["time", *inputs]) + "\n")
    np.savetxt(buf, data, delimiter=",", fmt="%.17g")
    path.write_text(buf.getvalue(), encoding="utf-8")


def read_output_csv(path: Path) -> dict[str, NDArray[np.float64]]:
    """Read a CSV with a header line into column name → float array.

    Raises
    ------
    OutputError
        Missing file, no header, ragged or non-numeric rows.
    """
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise OutputError(f"the program wrote no output file {path.name!r}") from None
    lines = [ln for ln in text.splitlines() if ln.strip()]
    if not lines:
        raise OutputError(f"the output file {path.name!r} is empty")
    header = [h.strip().strip('"') for h in lines[0].split(",")]
    if len(set(header)) != len(header):
        raise OutputError(f"the output file {path.name!r} names a column twice: {header}")
    if len(lines) == 1:
        raise OutputError(f"the output file {path.name!r} has a header and no rows")
    try:
        data = np.loadtxt(lines[1:], delimiter=",", ndmin=2, dtype=np.float64)
    except ValueError as e:
        raise OutputError(f"the output file {path.name!r} cannot be read as numbers: {e}") from None
    if data.shape[1] != len(header):
        raise OutputError(
            f"the output file {path.name!r} has {data.shape[1]} values per row and "
            f"{len(header)} column names"
        )
    return {h: data[:, j] for j, h in enumerate(header)}


def _tail(text: bytes, n: int = 3, width: int = 400) -> str:
    lines = [ln.strip() for ln in text.decode("utf-8", "replace").splitlines() if ln.strip()]
    out = " | ".join(lines[-n:])
    return out if len(out) <= width else "..." + out[-width:]


class _JobFailed(RuntimeError):
    pass


class _BatchEvaluator(Evaluator):
    handles_timeout = True

    def __init__(
        self,
        command: Sequence[str],
        env: Mapping[str, str],
        params_format: str,
        keep_files: str,
        files: tuple[str, str, str],
        workdir: Path,
        config_dir: Path,
    ) -> None:
        self.command = list(command)
        self.env = dict(env)
        self.params_format = params_format
        self.keep_files = keep_files
        self.files = files
        self.workdir = str(workdir)
        self.config_dir = str(config_dir)
        self.label = f"batch job {Path(self.command[0]).name!r}"

    def _write_params(self, path: Path, params: dict[str, float]) -> None:
        if self.params_format == "json":
            path.write_text(json.dumps(params, indent=1) + "\n", encoding="utf-8")
        else:
            rows = "".join(f"{k},{v!r}\n" for k, v in params.items())
            path.write_text("name,value\n" + rows, encoding="utf-8")

    def run(self, params: dict[str, float], exp: ExperimentData, timeout: float | None) -> Any:
        folder = Path(tempfile.mkdtemp(prefix="thermogym-batchjob-"))
        failed = True
        try:
            f_in, f_par, f_out = (folder / f for f in self.files)
            write_inputs_csv(f_in, exp.time, exp.inputs)
            self._write_params(f_par, params)
            values = {
                "python": sys.executable,
                "inputs": str(f_in),
                "params": str(f_par),
                "outputs": str(f_out),
                "dir": str(folder),
                "config_dir": self.config_dir,
            }
            cmd = []
            for word in self.command:
                for k, v in values.items():
                    word = word.replace("{" + k + "}", v)
                cmd.append(word)
            env = dict(os.environ)
            env.update(self.env)
            env.update(
                THERMOGYM_INPUTS=str(f_in),
                THERMOGYM_PARAMS=str(f_par),
                THERMOGYM_OUTPUTS=str(f_out),
                THERMOGYM_DIR=str(folder),
            )
            try:
                proc = subprocess.Popen(
                    cmd,
                    cwd=self.workdir,
                    env=env,
                    stdin=subprocess.DEVNULL,
                    stdout=subprocess.PIPE,
                    stderr=subprocess.PIPE,
                    start_new_session=True,  # its own process group: a timeout kills all of it
                )
            except OSError as e:
                raise _JobFailed(f"cannot start {cmd[0]!r}: {e}") from None
            try:
                out, err = proc.communicate(timeout=timeout)
            except subprocess.TimeoutExpired:
                _killpg(proc)
                out, err = proc.communicate()
                raise _JobFailed(
                    f"timed out after {timeout:g} s (process group killed); last output: "
                    f"{_tail(err or out) or '(none)'}"
                ) from None
            except BaseException:
                _killpg(proc)
                raise
            if proc.returncode != 0:
                what = (
                    f"killed by signal {signal.Signals(-proc.returncode).name}"
                    if proc.returncode < 0
                    else f"exit status {proc.returncode}"
                )
                raise _JobFailed(f"{what}: {_tail(err or out) or '(no output)'}")
            cols = read_output_csv(f_out)
            failed = False
            if "time" in cols:
                t = cols.pop("time")
                return Outputs(cols, time=t)
            return cols
        except (_JobFailed, OutputError) as e:
            if self.keep_files != "never":
                raise type(e)(f"{e} (files kept in {folder})") from None
            raise
        finally:
            keep = self.keep_files == "always" or (self.keep_files == "on_error" and failed)
            if not keep:
                shutil.rmtree(folder, ignore_errors=True)

    def describe_error(self, exc: BaseException) -> str:
        if isinstance(exc, _JobFailed):
            return str(exc)
        return f"{type(exc).__name__}: {exc}"


def _killpg(proc: subprocess.Popen[bytes]) -> None:
    with contextlib.suppress(OSError):
        os.killpg(proc.pid, signal.SIGKILL)
    with contextlib.suppress(Exception):
        proc.kill()


class BatchJobModel(ExternalModel):
    r"""A command-line program as an identifiable model (see the module docstring).

    Parameters
    ----------
    command : str or sequence of str
        The program and its arguments (a string is split like a shell would,
        but no shell runs); placeholders :data:`PLACEHOLDERS` in braces.
    parameters, outputs, inputs, fixed
        As :class:`~.base.ExternalModel`.
    name : str, optional
        Default: the program's file stem.
    env : mapping, optional
        Extra environment variables of the program.
    params_format : {"json", "csv"}
    keep_files : {"never", "on_error", "always"}
        Keep the temporary folder of an evaluation.
    inputs_file, params_file, outputs_file : str
        File names in the temporary folder.
    workdir : path, optional
        Folder the program runs in (default: the current folder).
    config_dir : path, optional
        Value of ``{config_dir}`` (default: the current folder).
    **evaluation
        ``timeout``, ``kill_grace``, ``backend``, ``workers``, ``chunksize``,
        ``ray_options``.

    Examples
    --------
    >>> import numpy as np
    >>> from thermogym.recording import Recording
    >>> job = ("{python} -c \"import json, numpy as np; K = json.load(open('{params}'))['K'];"
    ...        " d = np.loadtxt('{inputs}', delimiter=',', skiprows=1);"
    ...        " np.savetxt('{outputs}', K * d[:, 1], header='y', comments='')\"")
    >>> rec = Recording(np.arange(3.0), {"u": [1.0, 2.0, 3.0]})
    >>> with BatchJobModel(job, parameters={"K": (1.0, 0.0, 5.0)}, inputs=["u"],
    ...                    outputs=["y"], backend="serial") as m:
    ...     m.simulate(np.array([[2.0]]), rec).outputs[0, :, 0]
    array([2., 4., 6.])
    """

    kind = "batchjob"

    def __init__(
        self,
        command: str | Sequence[str],
        *,
        parameters: Any,
        outputs: Mapping[str, str] | list[str],
        inputs: Mapping[str, str] | list[str] | None = None,
        fixed: Mapping[str, float] | None = None,
        name: str | None = None,
        env: Mapping[str, str] | None = None,
        params_format: str = "json",
        keep_files: str = "never",
        inputs_file: str = "inputs.csv",
        params_file: str = "params.json",
        outputs_file: str = "outputs.csv",
        workdir: str | os.PathLike[str] | None = None,
        config_dir: str | os.PathLike[str] | None = None,
        **evaluation: Any,
    ) -> None:
        if isinstance(command, str):
            command = shlex.split(command)
        words = [str(w) for w in command]
        if not words:
            raise ConfigError("command is empty; expected the program and its arguments")
        if params_format not in ("json", "csv"):
            raise ConfigError(f"params_format is {params_format!r}, expected 'json' or 'csv'")
        if keep_files not in ("never", "on_error", "always"):
            raise ConfigError(
                f"keep_files is {keep_files!r}, expected 'never', 'on_error' or 'always'"
            )
        files = (inputs_file, params_file, outputs_file)
        if len(set(files)) != 3:
            raise ConfigError(f"inputs_file, params_file and outputs_file must differ; got {files}")
        prog = words[0].replace("{python}", sys.executable)
        if "{" not in prog and os.sep not in prog and shutil.which(prog) is None:
            raise ConfigError(f"command: program {prog!r} is not found on PATH")
        ev = _BatchEvaluator(
            words,
            env or {},
            params_format,
            keep_files,
            files,
            Path(workdir).resolve() if workdir is not None else Path.cwd(),
            Path(config_dir) if config_dir is not None else Path.cwd(),
        )
        default = (
            Path(words[1]).stem if words[0] == "{python}" and len(words) > 1 else Path(prog).stem
        )
        super().__init__(
            ev,
            name=name or default,
            parameters=parameters,
            outputs=outputs,
            inputs=inputs,
            fixed=fixed,
            **evaluation,
        )
        if "time" in self.inputs:
            raise ConfigError(
                "inputs: 'time' is the time column of the inputs file; rename the variable"
            )
        self.command = words
        self._type_config = {
            "command": words,
            "params_format": params_format,
            "keep_files": keep_files,
            "inputs_file": inputs_file,
            "params_file": params_file,
            "outputs_file": outputs_file,
            "workdir": ev.workdir,
            **({"env": dict(env)} if env else {}),
        }
        digest = hashlib.sha256("\0".join(words).encode())
        for w in words[1:]:  # files the command names (scripts) change what it computes
            f = Path(w) if os.path.isabs(w) else Path(ev.workdir) / w
            if "{" not in w and f.is_file():
                digest.update(file_digest(f).encode())
        self._source_digest = digest.hexdigest()[:12]
        self._ready = True

    @classmethod
    def from_config(cls, cfg: ExternalConfig) -> BatchJobModel:
        """Build from a checked configuration (``type = "batchjob"``)."""
        o = cfg.options
        return cls(
            o["command"],
            env=o.get("env"),
            params_format=o.get("params_format", "json"),
            keep_files=o.get("keep_files", "never"),
            inputs_file=o.get("inputs_file", "inputs.csv"),
            params_file=o.get("params_file", "params.json"),
            outputs_file=o.get("outputs_file", "outputs.csv"),
            workdir=cfg.workdir or cfg.base_dir,
            config_dir=cfg.base_dir,
            **common_kwargs(cfg),
        )
