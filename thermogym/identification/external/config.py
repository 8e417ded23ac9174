"""Configuration of external models: TOML, YAML or JSON files and dicts.

Paper 000 (``000_24627a5308ee07db.txt``, section 3, workflow steps 1-4):
the user names the script (or program, FMU) that holds the model, the
variables that are uncertain parameters with their bounds and start values,
sets other variables manually, and maps the measured signals to the model's
variables. One file says all of that; :func:`read_config` checks it and names
the offending key when something is wrong.

File layout (TOML; YAML and JSON have the same keys)::

    type = "script"              # callable | script | batchjob | fmu | octave | cosim
    name = "lag"                 # optional, default: the file's stem
    path = "lag_model.py"        # relative paths are relative to this file's folder
    timeout = 20.0               # s per evaluation (inf: none); default 600
    workdir = "."                # folder the model runs in; default: this file's folder

    [parameters.K]               # uncertain parameters: variables of the script
    start = 1.0                  # default: the middle of the bounds
    lower = 0.1
    upper = 10.0
    unit = "K/W"                 # optional, as is description

    [fixed]                      # variables set manually (paper 000 step 2)
    y0 = 0.0

    [inputs]                     # model variable = recording column
    u = "P_heater"

    [outputs]                    # model variable = recording column it is compared with
    y = "T_rise"

    [evaluation]                 # optional
    backend = "process"          # process (default) | ray | serial
    workers = 2                  # default: the CPUs this process may use
    chunksize = 4                # evaluations sent to a worker at once (default: auto)

``inputs`` and ``outputs`` may also be lists of names when the model variable
and the recording column are called the same. Keys of the model types:

==========  ==================================================================
type        keys
==========  ==================================================================
callable    ``callable = "package.module:function"`` or ``path`` + ``function``;
            ``vectorized`` (bool)
script      ``path`` (``.py``); ``time_variable`` (default ``"time"``);
            ``output_time`` (name of a variable holding the outputs' own times)
batchjob    ``command`` (string or list; placeholders ``{python}``,
            ``{inputs}``, ``{params}``, ``{outputs}``, ``{dir}``,
            ``{config_dir}``); ``env`` (table); ``params_format``
            (``json``/``csv``); ``keep_files`` (``never``/``on_error``/
            ``always``); ``inputs_file``, ``params_file``, ``outputs_file``
fmu         ``path`` (``.fmu``); ``mode`` (``auto``/``step``/``simulate``);
            ``substeps`` (int); ``fmpy_options`` (table for
            ``fmpy.simulate_fmu``)
octave      ``path`` (``.m``); ``time_variable``; ``output_time``;
            ``executable``
cosim       ``models`` (table: prefix → inline model table or the path of a
            model file); ``connections`` (list of ``{from = "a.y", to =
            "b.u"}``); no ``parameters``/``inputs``/``outputs`` of its own
==========  ==================================================================
"""

from __future__ import annotations

import json
import math
import os
import re
import shlex
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from thermogym.errors import ConfigError
from thermogym.identification.external._evaluate import DEFAULT_TIMEOUT
from thermogym.models.base import Parameter

__all__ = [
    "MODEL_TYPES",
    "EvaluationOptions",
    "ExternalConfig",
    "parse_parameters",
    "parse_signal_map",
    "read_config",
]

#: Model types a configuration may name.
MODEL_TYPES: tuple[str, ...] = ("callable", "script", "batchjob", "fmu", "octave", "cosim")

_NAME_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
_BACKENDS = ("process", "ray", "serial")

_COMMON_KEYS = frozenset(
    {
        "type",
        "name",
        "parameters",
        "fixed",
        "inputs",
        "outputs",
        "timeout",
        "kill_grace",
        "workdir",
        "evaluation",
    }
)
_TYPE_KEYS: dict[str, frozenset[str]] = {
    "callable": frozenset({"callable", "path", "function", "vectorized"}),
    "script": frozenset({"path", "time_variable", "output_time"}),
    "batchjob": frozenset(
        {
            "command",
            "env",
            "params_format",
            "keep_files",
            "inputs_file",
            "params_file",
            "outputs_file",
        }
    ),
    "fmu": frozenset({"path", "mode", "substeps", "fmpy_options"}),
    "octave": frozenset({"path", "time_variable", "output_time", "executable"}),
    "cosim": frozenset({"models", "connections"}),
}
_EVAL_KEYS = frozenset({"backend", "workers", "chunksize", "ray"})
_PARAM_KEYS = frozenset({"start", "lower", "upper", "unit", "description"})


@dataclass(frozen=True)
class EvaluationOptions:
    """How a non-batched external model is evaluated.

    Attributes
    ----------
    backend : {"process", "ray", "serial"}
        ``process``: a pool of local worker processes (default); ``ray``:
        actors on a Ray cluster (a local one is started when none is
        running); ``serial``: one after the other in this process (soft
        timeouts only, for debugging).
    workers : int or None
        Number of worker processes / actors, all started together on first
        use and kept until ``close()``; None: the CPUs available.
    chunksize : int or None
        Evaluations handed to a worker at once; None: about a quarter of an
        even share, so that slow evaluations still balance.
    ray : dict
        Keyword arguments of ``ray.init`` used when no Ray instance is
        running, e.g. ``{"address": "auto"}`` to join a cluster.
    """

    backend: str = "process"
    workers: int | None = None
    chunksize: int | None = None
    ray: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.backend not in _BACKENDS:
            raise ConfigError(
                f"evaluation.backend is {self.backend!r}, expected one of {list(_BACKENDS)}"
            )
        for key in ("workers", "chunksize"):
            v = getattr(self, key)
            if v is not None and (isinstance(v, bool) or not isinstance(v, int) or v < 1):
                raise ConfigError(f"evaluation.{key} is {v!r}, expected a positive integer")
        if not isinstance(self.ray, Mapping):
            raise ConfigError(
                f"evaluation.ray is a {type(self.ray).__name__}, expected a table of "
                "ray.init keyword arguments"
            )


@dataclass(frozen=True)
class ExternalConfig:
    """A checked external-model configuration (what :func:`read_config` returns).

    Attributes
    ----------
    type : str
        One of :data:`MODEL_TYPES`.
    name : str
        Model name (FitResults, messages).
    base_dir : Path
        Folder relative paths are resolved against (the file's folder).
    parameters : tuple of Parameter
        Uncertain parameters: start value (``nominal``), bounds, unit.
    fixed : dict
        Variables set manually: name → value.
    inputs, outputs : dict
        Model variable → recording column.
    timeout : float or None
        Time limit of one evaluation [s]; None: no limit.
    kill_grace : float or None
        Extra time [s] after ``timeout`` before a worker that does not answer
        is killed; None: automatic.
    workdir : Path or None
        Folder the model runs in.
    evaluation : EvaluationOptions
    options : dict
        The keys of the model type (``path``, ``command``, ...), paths made
        absolute.
    source : str
        The file read, or ``"<dict>"``.
    """

    type: str
    name: str
    base_dir: Path
    parameters: tuple[Parameter, ...]
    fixed: dict[str, float]
    inputs: dict[str, str]
    outputs: dict[str, str]
    timeout: float | None
    kill_grace: float | None
    workdir: Path | None
    evaluation: EvaluationOptions
    options: dict[str, Any]
    source: str = "<dict>"


def _err(source: str, key: str, msg: str) -> ConfigError:
    where = "" if source == "<dict>" else f" in {source}"
    return ConfigError(f"configuration key {key!r}{where}: {msg}")


def _number(value: Any, key: str, source: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise _err(source, key, f"is {value!r} ({type(value).__name__}), expected a number")
    return float(value)


def _identifier(value: Any, key: str, source: str, what: str = "name") -> str:
    if not isinstance(value, str) or not _NAME_RE.match(value):
        raise _err(
            source,
            key,
            f"{what} {value!r} is not an identifier (letters, digits and _, not starting "
            "with a digit)",
        )
    return value


def parse_parameters(
    value: Any, key: str = "parameters", source: str = "<dict>"
) -> tuple[Parameter, ...]:
    """Parameter specifications from a table, a mapping or a list of Parameters.

    Parameters
    ----------
    value : mapping or sequence
        ``{name: {"start": s, "lower": l, "upper": u, "unit": ..}}``,
        ``{name: (start, lower, upper)}``, ``{name: Parameter}`` or a sequence
        of :class:`~thermogym.models.base.Parameter`.
    key, source : str
        Where the value comes from (error messages).

    Returns
    -------
    tuple of Parameter
        ``nominal`` holds the start value; a missing start value is the
        middle of finite bounds.

    Raises
    ------
    ConfigError
        Unknown keys, non-numeric values, start outside the bounds, lower
        above upper; the message names the key (``parameters.K.lower``).

    Examples
    --------
    >>> [p.nominal for p in parse_parameters({"K": {"lower": 0.0, "upper": 4.0}, "T": (5, 1, 9)})]
    [2.0, 5.0]
    """
    if value is None:
        return ()
    if isinstance(value, Sequence) and not isinstance(value, str):
        out = []
        for i, p in enumerate(value):
            if not isinstance(p, Parameter):
                raise _err(
                    source,
                    f"{key}[{i}]",
                    f"is a {type(p).__name__}; a list must hold Parameter objects, "
                    "a table maps names to {start, lower, upper}",
                )
            out.append(p)
        return tuple(out)
    if not isinstance(value, Mapping):
        raise _err(
            source,
            key,
            f"is a {type(value).__name__}, expected a table name -> {{start, lower, upper}}",
        )
    params = []
    for name, spec in value.items():
        k = f"{key}.{name}"
        _identifier(name, k, source, "parameter name")
        if isinstance(spec, Parameter):
            if spec.name != name:
                raise _err(source, k, f"holds the Parameter {spec.name!r}")
            params.append(spec)
            continue
        unit, description = "", ""
        if isinstance(spec, Mapping):
            unknown = sorted(set(spec) - _PARAM_KEYS)
            if unknown:
                raise _err(
                    source, f"{k}.{unknown[0]}", f"unknown key; expected {sorted(_PARAM_KEYS)}"
                )
            lower = _number(spec["lower"], f"{k}.lower", source) if "lower" in spec else -math.inf
            upper = _number(spec["upper"], f"{k}.upper", source) if "upper" in spec else math.inf
            start = _number(spec["start"], f"{k}.start", source) if "start" in spec else None
            unit = str(spec.get("unit", ""))
            description = str(spec.get("description", ""))
        elif isinstance(spec, Sequence) and not isinstance(spec, str) and len(spec) == 3:
            start = _number(spec[0], f"{k}[0]", source)
            lower = _number(spec[1], f"{k}[1]", source)
            upper = _number(spec[2], f"{k}[2]", source)
        else:
            raise _err(
                source,
                k,
                f"is {spec!r}, expected a table {{start, lower, upper}} or (start, lower, upper)",
            )
        if math.isnan(lower) or math.isnan(upper) or lower > upper:
            raise _err(source, k, f"lower bound {lower!r} is above the upper bound {upper!r}")
        if start is None:
            if not (math.isfinite(lower) and math.isfinite(upper)):
                raise _err(
                    source, f"{k}.start", "is missing; it is required when a bound is infinite"
                )
            start = 0.5 * (lower + upper)
        if not math.isfinite(start):
            raise _err(source, f"{k}.start", f"is {start!r}, expected a finite number")
        if not (lower <= start <= upper):
            raise _err(
                source, f"{k}.start", f"{start!r} is outside the bounds [{lower!r}, {upper!r}]"
            )
        params.append(
            Parameter(
                name,
                start,
                lower,
                upper,
                unit,
                description,
                f"external model configuration ({source})",
            )
        )
    return tuple(params)


def parse_signal_map(value: Any, key: str, source: str = "<dict>") -> dict[str, str]:
    """Model variable → recording column from a table, a list of names or None.

    Examples
    --------
    >>> parse_signal_map(["u", "T_air"], "inputs")
    {'u': 'u', 'T_air': 'T_air'}
    >>> parse_signal_map({"y": "T_sensor"}, "outputs")
    {'y': 'T_sensor'}
    """
    if value is None:
        return {}
    if isinstance(value, str):
        value = [value]
    if isinstance(value, Mapping):
        out = {}
        for var, col in value.items():
            _identifier(var, f"{key}.{var}", source, "model variable")
            _identifier(col, f"{key}.{var}", source, "recording column")
            out[var] = col
    elif isinstance(value, Sequence):
        out = {}
        for i, var in enumerate(value):
            _identifier(var, f"{key}[{i}]", source, "variable")
            if var in out:
                raise _err(source, f"{key}[{i}]", f"names {var!r} twice")
            out[var] = var
    else:
        raise _err(
            source,
            key,
            f"is a {type(value).__name__}, expected a table model variable -> recording column "
            "or a list of names",
        )
    cols = list(out.values())
    dup = sorted({c for c in cols if cols.count(c) > 1})
    if dup:
        raise _err(source, key, f"maps several model variables to the recording column {dup[0]!r}")
    return out


def _load_file(path: Path) -> dict[str, Any]:
    text_suffix = path.suffix.lower()
    try:
        raw = path.read_bytes()
    except OSError as e:
        raise ConfigError(f"cannot read the external-model configuration {str(path)!r}: {e}") from e
    try:
        if text_suffix == ".toml":
            data = tomllib.loads(raw.decode("utf-8-sig"))
        elif text_suffix in (".yaml", ".yml"):
            data = yaml.safe_load(raw.decode("utf-8-sig"))
        elif text_suffix == ".json":
            data = json.loads(raw.decode("utf-8-sig"))
        else:
            raise ConfigError(
                f"configuration file {str(path)!r} has the suffix {text_suffix!r}; expected "
                ".toml, .yaml, .yml or .json"
            )
    except ConfigError:
        raise
    except Exception as e:  # tomllib, yaml and json each raise their own error types
        raise ConfigError(f"configuration file {str(path)!r} cannot be parsed: {e}") from e
    if not isinstance(data, dict):
        raise ConfigError(
            f"configuration file {str(path)!r} holds a {type(data).__name__}, expected a table "
            "of keys (type, path, parameters, ...)"
        )
    return data


def _abs_path(value: Any, key: str, base: Path, source: str, must_exist: bool = True) -> Path:
    if not isinstance(value, str | os.PathLike) or not str(value):
        raise _err(source, key, f"is {value!r}, expected a file path")
    p = Path(os.path.expanduser(os.fspath(value)))
    if not p.is_absolute():
        p = base / p
    if must_exist and not p.exists():
        raise _err(source, key, f"names {str(p)!r}, which does not exist")
    return p


def read_config(
    config: str | os.PathLike[str] | Mapping[str, Any],
    *,
    base_dir: str | os.PathLike[str] | None = None,
    **overrides: Any,
) -> ExternalConfig:
    """Read and check an external-model configuration.

    Parameters
    ----------
    config : path or mapping
        A ``.toml``, ``.yaml``/``.yml`` or ``.json`` file, or the same keys
        as a dict.
    base_dir : path, optional
        Folder relative paths of a dict configuration are resolved against
        (default: the current folder; for a file: the file's folder).
    **overrides
        Top-level keys that replace the file's (``timeout=...``) and
        evaluation keys (``backend="ray"``, ``workers=4``, ``chunksize=1``).

    Returns
    -------
    ExternalConfig

    Raises
    ------
    ConfigError
        The file cannot be read or parsed, or a key is unknown, missing or of
        the wrong kind; the message names the key.

    Examples
    --------
    >>> cfg = read_config({"type": "callable", "callable": "math:exp",
    ...                    "parameters": {"K": {"lower": 0, "upper": 2}}, "outputs": ["y"]})
    >>> cfg.type, cfg.parameters[0].nominal, cfg.outputs, cfg.evaluation.backend
    ('callable', 1.0, {'y': 'y'}, 'process')
    """
    if isinstance(config, Mapping):
        data = dict(config)
        source = "<dict>"
        base = Path(base_dir) if base_dir is not None else Path.cwd()
        default_name = "external"
    else:
        path = Path(os.fspath(config))
        data = _load_file(path)
        source = str(path)
        base = Path(base_dir) if base_dir is not None else path.resolve().parent
        default_name = path.stem
    base = base.resolve()
    evaluation = data.pop("evaluation", None) or {}
    if not isinstance(evaluation, Mapping):
        raise _err(source, "evaluation", f"is a {type(evaluation).__name__}, expected a table")
    evaluation = dict(evaluation)
    for k, v in overrides.items():
        if k in _EVAL_KEYS:
            evaluation[k] = v
        else:
            data[k] = v
    mtype = data.get("type")
    if mtype is None:
        raise _err(source, "type", f"is missing; expected one of {list(MODEL_TYPES)}")
    if mtype not in MODEL_TYPES:
        raise _err(source, "type", f"is {mtype!r}, expected one of {list(MODEL_TYPES)}")
    allowed = _COMMON_KEYS | _TYPE_KEYS[mtype]
    unknown = sorted(set(data) - allowed)
    if unknown:
        raise _err(
            source,
            unknown[0],
            f"is not a key of a {mtype!r} model; keys are {sorted(allowed - {'evaluation'})} "
            "and the table [evaluation]",
        )
    unknown = sorted(set(evaluation) - _EVAL_KEYS)
    if unknown:
        raise _err(
            source, f"evaluation.{unknown[0]}", f"unknown key; expected {sorted(_EVAL_KEYS)}"
        )
    name = data.get("name", default_name)
    if not isinstance(name, str) or not name:
        raise _err(source, "name", f"is {name!r}, expected a non-empty string")

    timeout: float | None = DEFAULT_TIMEOUT
    if "timeout" in data:
        t = data["timeout"]
        if t is None:
            timeout = None
        else:
            t = _number(t, "timeout", source)
            if not t > 0:
                raise _err(source, "timeout", f"is {t!r}, expected seconds > 0 (inf: no limit)")
            timeout = None if math.isinf(t) else t
    kill_grace = None
    if data.get("kill_grace") is not None:
        kill_grace = _number(data["kill_grace"], "kill_grace", source)
        if not (kill_grace >= 0 and math.isfinite(kill_grace)):
            raise _err(source, "kill_grace", f"is {kill_grace!r}, expected finite seconds >= 0")
    workdir = None
    if data.get("workdir") is not None:
        workdir = _abs_path(data["workdir"], "workdir", base, source)
        if not workdir.is_dir():
            raise _err(source, "workdir", f"names {str(workdir)!r}, which is not a folder")
    elif source != "<dict>":
        workdir = base

    try:
        ev = EvaluationOptions(
            backend=evaluation.get("backend", "process"),
            workers=evaluation.get("workers"),
            chunksize=evaluation.get("chunksize"),
            ray=dict(evaluation.get("ray") or {}),
        )
    except ConfigError as e:
        where = "" if source == "<dict>" else f" (in {source})"
        raise ConfigError(f"{e}{where}") from None

    if mtype == "cosim":
        for k in ("parameters", "fixed", "inputs", "outputs"):
            if k in data:
                raise _err(
                    source,
                    k,
                    "a co-simulation takes its parameters, inputs and outputs from its models; "
                    "set them in each model's table",
                )
        params: tuple[Parameter, ...] = ()
        fixed: dict[str, float] = {}
        inputs: dict[str, str] = {}
        outputs: dict[str, str] = {}
    else:
        params = parse_parameters(data.get("parameters"), "parameters", source)
        fixed_raw = data.get("fixed") or {}
        if not isinstance(fixed_raw, Mapping):
            raise _err(
                source, "fixed", f"is a {type(fixed_raw).__name__}, expected a table name -> value"
            )
        fixed = {}
        for k, v in fixed_raw.items():
            _identifier(k, f"fixed.{k}", source, "variable")
            fixed[k] = _number(v, f"fixed.{k}", source)
            if not math.isfinite(fixed[k]):
                raise _err(source, f"fixed.{k}", f"is {fixed[k]!r}, expected a finite number")
        both = sorted({p.name for p in params} & set(fixed))
        if both:
            raise _err(source, f"fixed.{both[0]}", "is also an uncertain parameter; name it once")
        inputs = parse_signal_map(data.get("inputs"), "inputs", source)
        outputs = parse_signal_map(data.get("outputs"), "outputs", source)
        if not outputs:
            raise _err(
                source, "outputs", "is missing or empty; name the model variables to compare"
            )
        clash = sorted(set(inputs) & set(outputs))
        if clash:
            raise _err(source, f"outputs.{clash[0]}", "is also an input variable")

    options = {k: data[k] for k in _TYPE_KEYS[mtype] if k in data}
    options = _check_options(mtype, options, base, source)
    if mtype == "cosim":
        # what the co-simulation's file or caller says about evaluation applies to every model
        sub = dict(evaluation)
        sub.update({k: data[k] for k in ("timeout", "kill_grace") if k in data})
        options["sub_overrides"] = sub
    return ExternalConfig(
        type=mtype,
        name=name,
        base_dir=base,
        parameters=params,
        fixed=fixed,
        inputs=inputs,
        outputs=outputs,
        timeout=timeout,
        kill_grace=kill_grace,
        workdir=workdir,
        evaluation=ev,
        options=options,
        source=source,
    )


def _check_options(mtype: str, o: dict[str, Any], base: Path, source: str) -> dict[str, Any]:
    """Check the keys of one model type; make paths absolute."""

    def _str(key: str, choices: Sequence[str] | None = None) -> None:
        if key in o:
            v = o[key]
            if not isinstance(v, str) or not v:
                raise _err(source, key, f"is {v!r}, expected a non-empty string")
            if choices is not None and v not in choices:
                raise _err(source, key, f"is {v!r}, expected one of {list(choices)}")

    def _require(key: str) -> None:
        if key not in o:
            raise _err(source, key, f"is missing; a {mtype!r} model needs it")

    def _path(key: str, suffixes: Sequence[str] | None = None) -> None:
        p = _abs_path(o[key], key, base, source)
        if suffixes and p.suffix.lower() not in suffixes:
            raise _err(source, key, f"names {str(p)!r}; expected a file ending in {list(suffixes)}")
        if not p.is_file():
            raise _err(source, key, f"names {str(p)!r}, which is not a file")
        o[key] = p

    if mtype == "callable":
        if ("callable" in o) == ("path" in o):
            raise _err(
                source,
                "callable",
                "give either callable = 'module:function' or path = 'file.py' with "
                "function = 'name'",
            )
        if "callable" in o:
            _str("callable")
            if ":" not in o["callable"]:
                raise _err(source, "callable", f"is {o['callable']!r}, expected 'module:function'")
            if "function" in o:
                raise _err(
                    source, "function", "goes with path; callable already names the function"
                )
        else:
            _path("path", [".py"])
            _require("function")
            _str("function")
        if "vectorized" in o and not isinstance(o["vectorized"], bool):
            raise _err(source, "vectorized", f"is {o['vectorized']!r}, expected true or false")
    elif mtype in ("script", "octave"):
        _require("path")
        _path("path", [".py"] if mtype == "script" else [".m"])
        for k in ("time_variable", "output_time"):
            if k in o:
                _identifier(o[k], k, source, "variable")
        _str("executable")
    elif mtype == "batchjob":
        _require("command")
        cmd = o["command"]
        if isinstance(cmd, str):
            try:
                cmd = shlex.split(cmd)
            except ValueError as e:
                raise _err(source, "command", f"cannot be split into words: {e}") from e
        if (
            not isinstance(cmd, Sequence)
            or not cmd
            or not all(isinstance(c, str | int | float) and not isinstance(c, bool) for c in cmd)
        ):
            raise _err(
                source,
                "command",
                f"is {o['command']!r}, expected a command line or a list of words",
            )
        o["command"] = [str(c) for c in cmd]
        env = o.get("env", {})
        if not isinstance(env, Mapping) or not all(
            isinstance(k, str) and isinstance(v, str | int | float) for k, v in env.items()
        ):
            raise _err(source, "env", f"is {env!r}, expected a table NAME = 'value'")
        o["env"] = {k: str(v) for k, v in env.items()}
        _str("params_format", ["json", "csv"])
        _str("keep_files", ["never", "on_error", "always"])
        for k in ("inputs_file", "params_file", "outputs_file"):
            _str(k)
            if k in o and (os.sep in o[k] or o[k] in (".", "..")):
                raise _err(source, k, f"is {o[k]!r}, expected a plain file name")
    elif mtype == "fmu":
        _require("path")
        _path("path", [".fmu"])
        _str("mode", ["auto", "step", "simulate"])
        if "substeps" in o:
            s = o["substeps"]
            if isinstance(s, bool) or not isinstance(s, int) or s < 1:
                raise _err(source, "substeps", f"is {s!r}, expected a positive integer")
        if "fmpy_options" in o and not isinstance(o["fmpy_options"], Mapping):
            raise _err(source, "fmpy_options", "expected a table of fmpy.simulate_fmu arguments")
    elif mtype == "cosim":
        _require("models")
        models = o["models"]
        if not isinstance(models, Mapping) or len(models) < 1:
            raise _err(source, "models", "expected a table prefix -> model table or model file")
        checked: dict[str, Path | dict[str, Any]] = {}
        for prefix, sub in models.items():
            _identifier(prefix, f"models.{prefix}", source, "model prefix")
            if isinstance(sub, str | os.PathLike):
                checked[prefix] = _abs_path(sub, f"models.{prefix}", base, source)
            elif isinstance(sub, Mapping):
                checked[prefix] = dict(sub)
            else:
                raise _err(
                    source,
                    f"models.{prefix}",
                    f"is a {type(sub).__name__}, expected a table or a file path",
                )
        o["models"] = checked
        conns = o.get("connections", [])
        if not isinstance(conns, Sequence) or isinstance(conns, str):
            raise _err(source, "connections", "expected a list of {from = 'a.y', to = 'b.u'}")
        pairs = []
        for i, c in enumerate(conns):
            k = f"connections[{i}]"
            if not isinstance(c, Mapping) or set(c) != {"from", "to"}:
                raise _err(
                    source, k, f"is {c!r}, expected {{from = 'model.output', to = 'model.input'}}"
                )
            ends = []
            for end in ("from", "to"):
                v = c[end]
                if not isinstance(v, str) or v.count(".") != 1:
                    raise _err(source, f"{k}.{end}", f"is {v!r}, expected 'model_prefix.signal'")
                m, s = v.split(".")
                if m not in checked:
                    raise _err(
                        source, f"{k}.{end}", f"names the model {m!r}; models are {list(checked)}"
                    )
                _identifier(s, f"{k}.{end}", source, "signal")
                ends.append((m, s))
            pairs.append((ends[0], ends[1]))
        o["connections"] = pairs
    return o
