"""FitResult: the JSON contract between identification and everything after it.

A :class:`FitResult` says which model (name, version, constructor arguments)
was fitted, the parameter values found, their uncertainty (standard errors,
covariance), the bounds and fixed parameters of the search, the method and its
settings, fit metrics on training and validation recordings, fingerprints of
those recordings and the package version (DESIGN.md, "FitResult").
Environments accept one as ``params=FitResult | path | dict``
(:func:`load_fit`).

The JSON file is a single object::

    {"format": "thermogym.fitresult", "schema_version": 1,
     "model": "axt211", "model_version": "1", "model_config": {},
     "parameters": {"R_0": 103.2, ...}, "arrays": {}, "stderr": {...},
     "covariance": [[...], ...] | null, "covariance_names": [...],
     "bounds": {"C_P": [3.0, 60.0], ...}, "fixed": [...],
     "method": "...", "settings": {...},
     "metrics": {"train": {...}, "validation": {...}},
     "data": [{"experiment_id": ..., "fingerprint": ..., "n_samples": ...,
               "source": ..., "role": "train"}],
     "package_version": "0.1.0", "created": "2025-01-01T00:00:00+00:00",
     "notes": "", "warnings": [{"code": "gain_sign", "message": "..."}]}

JSON has no NaN or infinity: NaN (in standard errors, metrics, arrays) is
written as ``null`` and read back as NaN; an infinite bound is written as
``null`` and read back as ``-inf`` (lower) or ``+inf`` (upper).
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import json
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

import thermogym
from thermogym._checks import nonnegative
from thermogym._fileio import atomic_write_text, to_jsonable
from thermogym.errors import ConfigError, ParameterError
from thermogym.recording import Recording

if TYPE_CHECKING:
    from thermogym.models.base import Model

__all__ = ["FORMAT", "SCHEMA_VERSION", "FitResult", "data_entry", "load_fit"]

#: Value of the ``format`` key of every FitResult JSON file.
FORMAT = "thermogym.fitresult"
#: Version of the JSON layout; a reader refuses files of a newer layout.
SCHEMA_VERSION = 1
_REQUIRED = ("model", "model_version", "parameters")
_SAMPLE_METHODS = ("auto", "normal", "uniform")


def _now() -> str:
    return _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")


def _package_version() -> str:
    return thermogym.__version__


def data_entry(rec: Recording, role: str | None = None) -> dict[str, Any]:
    """Describe a recording for :attr:`FitResult.data`.

    Parameters
    ----------
    rec : Recording
    role : str, optional
        What the recording was used for, e.g. ``"train"`` or ``"validation"``.

    Returns
    -------
    dict
        ``experiment_id``, ``fingerprint`` (:meth:`Recording.fingerprint`),
        ``n_samples``, ``source`` and, when given, ``role``.
    """
    entry: dict[str, Any] = {
        "experiment_id": rec.experiment_id,
        "fingerprint": rec.fingerprint(),
        "n_samples": rec.n_samples,
        "source": rec.source,
    }
    if role is not None:
        entry["role"] = role
    return entry


def _nan_for_none(obj: Any) -> Any:
    """Inverse of the NaN -> null conversion for numeric JSON trees."""
    if obj is None:
        return math.nan
    if isinstance(obj, dict):
        return {k: _nan_for_none(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_nan_for_none(v) for v in obj]
    return obj


def _jsonable(obj: Any, where: str) -> Any:
    try:
        return to_jsonable(obj, where)
    except TypeError as e:
        raise ConfigError(str(e)) from e


def _as_float(value: Any, where: str, *, allow_nan: bool) -> float:
    if value is None and allow_nan:
        return math.nan
    if isinstance(value, bool | np.bool_) or not isinstance(
        value, int | float | np.integer | np.floating
    ):
        raise ConfigError(f"{where} is {value!r:.60} ({type(value).__name__}), expected a number")
    v = float(value)
    if not allow_nan and not math.isfinite(v):
        raise ParameterError(f"{where} is {v!r}, expected a finite number")
    return v


@dataclass(kw_only=True)
class FitResult:
    """Outcome of an identification: model, parameter values, uncertainty, provenance.

    Parameters
    ----------
    model : str
        Registered model name (:func:`thermogym.models.registry.get_model`).
    model_version : str
        ``Model.version`` of the fitted model; :meth:`build_model` refuses a
        different installed version.
    parameters : dict
        Parameter name → value (in the model's units), in model order.
    model_config : dict
        Constructor arguments for ``get_model`` (JSON types).
    arrays : dict
        Name → nested list for matrix-valued results (state-space ``A``,
        ``B``, ``C``, ``D``, ``K``, ...).
    stderr : dict
        Parameter name → standard error (NaN where not identifiable).
    covariance : list of lists, optional
        Parameter covariance, shape (k, k), rows/columns in the order of
        ``covariance_names``.
    covariance_names : list of str
        Parameters the covariance refers to.
    bounds : dict
        Parameter name → ``[lower, upper]`` used in the search (±inf allowed).
    fixed : list of str
        Parameters held fixed during the fit.
    method : str
        Identification method (``"least_squares"``, ``"n4sid"``, ...).
    settings : dict
        Method settings (JSON types).
    metrics : dict
        Fit metrics, e.g. ``{"train": {"nrmse_fit": {...}}, "validation": {...}}``;
        numbers, NaN allowed.
    data : list of dict
        Recordings used (see :func:`data_entry`; a :class:`Recording` given
        here is converted). Each entry needs a ``fingerprint``.
    package_version : str
        thermogym version that produced the result (default: this one).
    created : str
        ISO 8601 time of creation (default: now, UTC).
    notes : str
        Free text.
    warnings : list of dict
        What the identification warned about, ``{"code", "message"}`` each
        (:mod:`thermogym.identification.advice`).

    Raises
    ------
    ConfigError
        A field has the wrong type, a name refers to no parameter, JSON
        cannot hold a config/setting/metric value.
    ParameterError
        Non-finite parameter, reversed bounds, covariance of the wrong shape,
        not symmetric or not finite.

    Examples
    --------
    >>> from thermogym.models import AXT211
    >>> fit = FitResult.from_model(AXT211(), {"C_P": 30.0}, method="example")
    >>> fit.parameters["C_P"], fit.theta().shape
    (30.0, (1, 17))
    """

    model: str
    model_version: str
    parameters: dict[str, float]
    model_config: dict[str, Any] = field(default_factory=dict)
    arrays: dict[str, list[Any]] = field(default_factory=dict)
    stderr: dict[str, float] = field(default_factory=dict)
    covariance: list[list[float]] | None = None
    covariance_names: list[str] = field(default_factory=list)
    bounds: dict[str, list[float]] = field(default_factory=dict)
    fixed: list[str] = field(default_factory=list)
    method: str = ""
    settings: dict[str, Any] = field(default_factory=dict)
    metrics: dict[str, Any] = field(default_factory=dict)
    data: list[dict[str, Any]] = field(default_factory=list)
    package_version: str = field(default_factory=_package_version)
    created: str = field(default_factory=_now)
    notes: str = ""
    warnings: list[dict[str, str]] = field(default_factory=list)

    # ------------------------------------------------------------ validation
    def __post_init__(self) -> None:
        for name in ("model", "method", "package_version", "created", "notes"):
            value = getattr(self, name)
            if not isinstance(value, str):
                raise ConfigError(f"FitResult.{name} is {value!r:.60}, expected a str")
        if not self.model:
            raise ConfigError("FitResult.model is empty, expected a registered model name")
        if isinstance(self.model_version, int) and not isinstance(self.model_version, bool):
            self.model_version = str(self.model_version)
        if not isinstance(self.model_version, str):
            raise ConfigError(
                f"FitResult.model_version is {self.model_version!r:.60}, expected a str"
            )
        try:
            _dt.datetime.fromisoformat(self.created)
        except ValueError as e:
            raise ConfigError(
                f"FitResult.created is {self.created!r}, expected an ISO 8601 time"
            ) from e

        self.parameters = self._float_map("parameters", self.parameters, allow_nan=False)
        names = set(self.parameters)

        def check_known(what: str, keys: Sequence[str]) -> None:
            unknown = [k for k in keys if k not in names]
            if unknown:
                raise ConfigError(
                    f"FitResult.{what} names {unknown}, which are not among the parameters "
                    f"{list(self.parameters)}"
                )

        self.stderr = self._float_map("stderr", self.stderr, allow_nan=True)
        check_known("stderr", list(self.stderr))
        self.model_config = self._json_dict("model_config", self.model_config)
        self.settings = self._json_dict("settings", self.settings)
        self.metrics = _nan_for_none(self._json_dict("metrics", self.metrics))
        self.arrays = self._arrays(self.arrays)
        self.bounds = self._bounds(self.bounds)
        check_known("bounds", list(self.bounds))
        if not isinstance(self.fixed, list | tuple) or not all(
            isinstance(n, str) for n in self.fixed
        ):
            raise ConfigError(f"FitResult.fixed is {self.fixed!r:.60}, expected a list of names")
        self.fixed = list(self.fixed)
        check_known("fixed", self.fixed)
        self._covariance()
        check_known("covariance_names", self.covariance_names)
        self.data = self._data(self.data)
        self.warnings = self._warnings(self.warnings)

    @staticmethod
    def _warnings(value: Any) -> list[dict[str, str]]:
        if not isinstance(value, list | tuple):
            raise ConfigError(
                f"FitResult.warnings is a {type(value).__name__}, expected a list of "
                "{'code', 'message'} dicts"
            )
        out = []
        for i, w in enumerate(value):
            if hasattr(w, "to_dict"):
                w = w.to_dict()
            if (
                not isinstance(w, Mapping)
                or not isinstance(w.get("code"), str)
                or not isinstance(w.get("message"), str)
            ):
                raise ConfigError(
                    f"FitResult.warnings[{i}] is {w!r:.80}; expected a dict with the strings "
                    "'code' and 'message'"
                )
            out.append({"code": w["code"], "message": w["message"]})
        return out

    def add_warnings(self, warnings: Sequence[Any]) -> None:
        """Append warnings (``FitWarning`` or ``{"code", "message"}``), skipping repeats."""
        have = {(w["code"], w["message"]) for w in self.warnings}
        for w in self._warnings(list(warnings)):
            if (w["code"], w["message"]) not in have:
                self.warnings.append(w)
                have.add((w["code"], w["message"]))

    @staticmethod
    def _float_map(what: str, value: Any, *, allow_nan: bool) -> dict[str, float]:
        if not isinstance(value, Mapping):
            raise ConfigError(
                f"FitResult.{what} is a {type(value).__name__}, expected a dict name -> number"
            )
        out: dict[str, float] = {}
        for k, v in value.items():
            if not isinstance(k, str):
                raise ConfigError(f"FitResult.{what} has the key {k!r}, expected a str")
            out[k] = _as_float(v, f"FitResult.{what}[{k!r}]", allow_nan=allow_nan)
        return out

    @staticmethod
    def _json_dict(what: str, value: Any) -> dict[str, Any]:
        if not isinstance(value, Mapping):
            raise ConfigError(f"FitResult.{what} is a {type(value).__name__}, expected a dict")
        return _jsonable(dict(value), f"FitResult.{what}")

    @staticmethod
    def _arrays(value: Any) -> dict[str, list[Any]]:
        if not isinstance(value, Mapping):
            raise ConfigError(f"FitResult.arrays is a {type(value).__name__}, expected a dict")
        out: dict[str, list[Any]] = {}
        for k, v in value.items():
            if not isinstance(k, str):
                raise ConfigError(f"FitResult.arrays has the key {k!r}, expected a str")
            try:
                a = np.array(_nan_for_none(v) if isinstance(v, list) else v, dtype=np.float64)
            except (TypeError, ValueError) as e:
                raise ConfigError(
                    f"FitResult.arrays[{k!r}] is not a rectangular array of numbers: {e}"
                ) from e
            out[k] = a.tolist()
        return out

    def _bounds(self, value: Any) -> dict[str, list[float]]:
        if not isinstance(value, Mapping):
            raise ConfigError(f"FitResult.bounds is a {type(value).__name__}, expected a dict")
        out: dict[str, list[float]] = {}
        for k, b in value.items():
            if not (
                isinstance(b, Sequence | np.ndarray) and not isinstance(b, str) and len(b) == 2
            ):
                raise ConfigError(f"FitResult.bounds[{k!r}] is {b!r:.60}, expected [lower, upper]")
            lo = -math.inf if b[0] is None else _as_float(b[0], f"bounds[{k!r}][0]", allow_nan=True)
            hi = math.inf if b[1] is None else _as_float(b[1], f"bounds[{k!r}][1]", allow_nan=True)
            if math.isnan(lo) or math.isnan(hi) or lo > hi:
                raise ParameterError(
                    f"FitResult.bounds[{k!r}] is [{lo!r}, {hi!r}], expected lower <= upper"
                )
            out[k] = [lo, hi]
        return out

    def _covariance(self) -> None:
        names = self.covariance_names
        if not isinstance(names, list | tuple) or not all(isinstance(n, str) for n in names):
            raise ConfigError(
                f"FitResult.covariance_names is {names!r:.60}, expected a list of names"
            )
        self.covariance_names = list(names)
        if len(set(names)) != len(names):
            raise ConfigError(f"FitResult.covariance_names repeats a name: {list(names)}")
        if self.covariance is None:
            if names:
                raise ConfigError("FitResult.covariance_names is given without a covariance")
            return
        try:
            c = np.array(self.covariance, dtype=np.float64)
        except (TypeError, ValueError) as e:
            raise ConfigError(f"FitResult.covariance is not a matrix of numbers: {e}") from e
        k = len(names)
        if c.shape != (k, k):
            raise ParameterError(
                f"FitResult.covariance has shape {c.shape}, expected ({k}, {k}) for "
                f"covariance_names {list(names)}"
            )
        if not np.isfinite(c).all():
            raise ParameterError("FitResult.covariance holds non-finite values")
        scale = float(np.max(np.abs(c))) if c.size else 0.0
        if not np.allclose(c, c.T, rtol=1e-8, atol=1e-12 * scale):
            i, j = np.unravel_index(np.argmax(np.abs(c - c.T)), c.shape)
            raise ParameterError(
                f"FitResult.covariance is not symmetric: [{names[i]!r}, {names[j]!r}] = "
                f"{float(c[i, j])!r} but [{names[j]!r}, {names[i]!r}] = {float(c[j, i])!r}"
            )
        self.covariance = c.tolist()

    @staticmethod
    def _data(value: Any) -> list[dict[str, Any]]:
        if not isinstance(value, list | tuple):
            raise ConfigError(
                f"FitResult.data is a {type(value).__name__}, expected a list of recording entries"
            )
        out: list[dict[str, Any]] = []
        for i, d in enumerate(value):
            if isinstance(d, Recording):
                d = data_entry(d)
            if not isinstance(d, Mapping) or not isinstance(d.get("fingerprint"), str):
                raise ConfigError(
                    f"FitResult.data[{i}] is {d!r:.80}; expected a dict with at least a "
                    "'fingerprint' (see thermogym.fitresult.data_entry)"
                )
            out.append(_jsonable(dict(d), f"FitResult.data[{i}]"))
        return out

    # ------------------------------------------------------------- builders
    @classmethod
    def from_model(
        cls,
        model: Model,
        parameters: Mapping[str, float] | ArrayLike | None = None,
        **kwargs: Any,
    ) -> FitResult:
        """Make a FitResult for ``model`` with every parameter in model order.

        Parameters
        ----------
        model : Model
        parameters : mapping or array_like, optional
            Values overriding the nominal ones (a mapping), or a full
            parameter vector of shape (P,) or (1, P).
        **kwargs
            Further fields (``stderr``, ``bounds``, ``method``, ...). ``bounds``
            defaults to the model's parameter bounds.
        """
        th = model.theta(parameters)  # type: ignore[arg-type]
        if th.shape[0] != 1:
            raise ParameterError(f"expected one parameter set, got {th.shape[0]}")
        kwargs.setdefault("bounds", {p.name: [p.lower, p.upper] for p in model.parameters})
        return cls(
            model=model.name,
            model_version=str(model.version),
            model_config=model.config(),
            parameters=dict(zip(model.param_names, th[0].tolist(), strict=True)),
            **kwargs,
        )

    # --------------------------------------------------------- dict and JSON
    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-ready dict (NaN and ±inf as ``None``), ``format`` key first."""
        out: dict[str, Any] = {"format": FORMAT, "schema_version": SCHEMA_VERSION}
        for f in fields(self):
            out[f.name] = to_jsonable(getattr(self, f.name), f.name)
        return out

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> FitResult:
        """Build from :meth:`to_dict` output, strictly.

        Raises
        ------
        ConfigError
            Not a mapping, unknown or missing keys (named), wrong format or a
            newer schema version, and every check of :class:`FitResult`.
        """
        if not isinstance(d, Mapping):
            raise ConfigError(f"a FitResult must be a JSON object/dict, got {type(d).__name__}")
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(d) - known - {"format", "schema_version"})
        if unknown:
            raise ConfigError(
                f"unknown FitResult key(s) {unknown}; allowed keys are "
                f"{['format', 'schema_version', *sorted(known)]}"
            )
        missing = [k for k in _REQUIRED if k not in d]
        if missing:
            raise ConfigError(
                f"FitResult lacks required key(s) {missing}; it has {sorted(d)} (a FitResult "
                f"needs at least {list(_REQUIRED)})"
            )
        fmt = d.get("format", FORMAT)
        if fmt != FORMAT:
            raise ConfigError(f"format is {fmt!r}, expected {FORMAT!r}")
        version = d.get("schema_version", SCHEMA_VERSION)
        if not isinstance(version, int) or isinstance(version, bool) or version < 1:
            raise ConfigError(f"schema_version is {version!r}, expected a positive integer")
        if version > SCHEMA_VERSION:
            raise ConfigError(
                f"schema_version {version} is newer than this thermogym reads "
                f"({SCHEMA_VERSION}); upgrade thermogym"
            )
        return cls(**{k: d[k] for k in known if k in d})

    def save(self, path: str | os.PathLike[str], *, overwrite: bool = True) -> Path:
        """Write the FitResult as JSON, atomically.

        Parameters
        ----------
        path : str or path-like
        overwrite : bool
            When False, refuse if ``path`` exists.

        Returns
        -------
        Path

        Raises
        ------
        ConfigError
            ``path`` exists with ``overwrite=False`` or cannot be written;
            nothing is created or changed then.
        """
        text = json.dumps(self.to_dict(), indent=2, ensure_ascii=False, allow_nan=False) + "\n"
        try:
            return atomic_write_text(path, text, overwrite=overwrite)
        except FileExistsError as e:
            raise ConfigError(f"not writing the FitResult: {e}") from e
        except OSError as e:
            raise ConfigError(f"cannot write FitResult {os.fspath(path)!r}: {e}") from e

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> FitResult:
        """Read a FitResult JSON file.

        Raises
        ------
        ConfigError
            Missing file, invalid JSON (line and column named), wrong schema
            (the file is named in the message).
        """
        p = Path(path)
        if not p.exists():
            raise ConfigError(f"FitResult file {str(p)!r} does not exist")
        try:
            text = p.read_text(encoding="utf-8-sig")  # a byte-order mark is no error
        except UnicodeDecodeError as e:
            raise ConfigError(
                f"FitResult file {str(p)!r} is not UTF-8 text ({e.reason} at byte {e.start}); "
                "a FitResult is a UTF-8 JSON file"
            ) from e
        except OSError as e:
            raise ConfigError(f"cannot read FitResult file {str(p)!r}: {e}") from e
        try:
            doc = json.loads(text)
        except json.JSONDecodeError as e:
            raise ConfigError(
                f"FitResult file {str(p)!r} is not valid JSON: {e.msg} at line {e.lineno}, "
                f"column {e.colno}"
            ) from e
        except RecursionError:
            raise ConfigError(
                f"FitResult file {str(p)!r} is nested too deeply to be a FitResult"
            ) from None
        try:
            return cls.from_dict(doc)
        except ParameterError as e:
            raise ParameterError(f"FitResult file {str(p)!r}: {e}") from e
        except ConfigError as e:
            raise ConfigError(f"FitResult file {str(p)!r}: {e}") from e

    # --------------------------------------------------------------- identity
    def fingerprint(self) -> str:
        """SHA-256 over model, version, config, parameters and arrays.

        Two FitResults describing the same fitted model have the same
        fingerprint whatever their metrics, provenance or creation time.

        Returns
        -------
        str
            64 hexadecimal digits.
        """
        core = {
            "model": self.model,
            "model_version": self.model_version,
            "model_config": self.model_config,
            "parameters": self.parameters,
            "arrays": self.arrays,
        }
        text = json.dumps(to_jsonable(core), sort_keys=True, separators=(",", ":"), allow_nan=False)
        return hashlib.sha256(text.encode("utf-8")).hexdigest()

    def array(self, name: str) -> NDArray[np.float64]:
        """Return ``arrays[name]`` as a float array (a new copy)."""
        try:
            return np.array(self.arrays[name], dtype=np.float64)
        except KeyError:
            raise ConfigError(
                f"FitResult has no array {name!r}; arrays are {sorted(self.arrays)}"
            ) from None

    # ------------------------------------------------------------ the model
    def build_model(self, *, check_version: bool = True) -> Model:
        """Build the fitted model: ``get_model(self.model, **self.model_config)``.

        Parameters
        ----------
        check_version : bool
            Refuse a model whose installed version differs from
            :attr:`model_version` (its equations changed since the fit).

        Raises
        ------
        UnknownNameError
            The model is not registered.
        ConfigError
            The config does not fit the constructor, or the versions differ.
        ParameterError
            A parameter name is unknown to the model.
        """
        # the registry loads every plant model (~0.5 s): only when one is built
        from thermogym.models.registry import get_model

        config = dict(self.model_config)
        op = self.settings.get("operating_point")
        if (
            self.model == "ss"
            and "u_op" not in config
            and "y_op" not in config
            and isinstance(op, Mapping)
        ):
            # state-space fits made before the model carried its operating point kept it
            # in the settings only: apply it here, so every simulation path honours it
            config["u_op"] = dict(op.get("inputs") or {})
            config["y_op"] = dict(op.get("outputs") or {})
        model = get_model(self.model, **config)
        self._check_model(model, check_version=check_version, check_name=False)
        return model

    def _check_model(
        self, model: Model, *, check_version: bool = True, check_name: bool = True
    ) -> None:
        if check_name and model.name != self.model:
            raise ConfigError(
                f"the FitResult is for model {self.model!r}, the model given is {model.name!r}"
            )
        if check_version and str(model.version) != self.model_version:
            raise ConfigError(
                f"the FitResult was fitted with model {self.model!r} version "
                f"{self.model_version!r}, the installed model is version {model.version!r}; "
                "refit on the recordings or use the thermogym version that produced it "
                f"({self.package_version})"
            )
        known = set(model.param_names)  # a set: state-space models have thousands
        unknown = [n for n in self.parameters if n not in known]
        if unknown:
            raise ParameterError(
                f"the FitResult has parameter(s) {unknown} that model {self.model!r} "
                f"({self.model_config}) lacks; its parameters are {list(model.param_names)}"
            )

    def theta(self, model: Model | None = None) -> NDArray[np.float64]:
        """Parameter batch of this fit, shape (1, P), via ``model.theta(self.parameters)``.

        Parameters
        ----------
        model : Model, optional
            The model to use; built with :meth:`build_model` when omitted.
            It must have this FitResult's name and version.
        """
        if model is None:
            model = self.build_model()
        else:
            self._check_model(model)
        missing = [n for n in model.param_names if n not in self.parameters]
        if missing:
            shown = missing if len(missing) <= 12 else [*missing[:12], "..."]
            raise ParameterError(
                f"the FitResult of model {self.model!r} lacks parameter(s) {shown} "
                f"({len(missing)} of {len(model.param_names)}); a FitResult gives every "
                "parameter of its model (a missing one would silently take the nominal value): "
                "refit, or write the values in"
            )
        return model.theta(self.parameters)

    def sample(
        self,
        n: int,
        rng: np.random.Generator | int,
        *,
        method: str = "auto",
        scale: float = 1.0,
    ) -> dict[str, NDArray[np.float64]]:
        """Draw ``n`` parameter sets around the fit, e.g. for domain randomisation.

        ``"normal"``: multivariate normal with the covariance (parameters in
        ``covariance_names``), or independent normals with ``stderr`` where no
        covariance is given. ``"uniform"``: uniform within the finite bounds.
        ``"auto"`` uses ``"normal"`` when a covariance or a finite standard
        error exists, else ``"uniform"``. Fixed parameters and parameters
        without uncertainty (or, for ``"uniform"``, without finite bounds) stay
        at their fitted value; every draw is clipped to ``bounds``.

        Parameters
        ----------
        n : int
            Number of parameter sets, >= 1.
        rng : numpy.random.Generator or int
            Source of randomness (an int seeds a new generator); the same seed
            gives the same draws.
        method : {"auto", "normal", "uniform"}
        scale : float
            Multiplies the standard deviations (``"normal"``), e.g. 2 for a
            wider randomisation.

        Returns
        -------
        dict
            Parameter name → array of shape (n,); ``model.theta(result)``
            turns it into a batch of shape (n, P).

        Raises
        ------
        ParameterError
            ``n < 1``, bad ``scale``, or nothing to randomise with the method.
        ConfigError
            Unknown ``method`` or ``rng``.
        """
        if isinstance(n, bool) or not isinstance(n, int | np.integer) or n < 1:
            raise ParameterError(f"n is {n!r}, expected a positive number of parameter sets")
        if method not in _SAMPLE_METHODS:
            raise ConfigError(f"method is {method!r}, expected one of {_SAMPLE_METHODS}")
        nonnegative("scale", scale, text=False)
        if isinstance(rng, int | np.integer) and not isinstance(rng, bool):
            rng = np.random.default_rng(int(rng))
        if not isinstance(rng, np.random.Generator):
            raise ConfigError(
                f"rng is a {type(rng).__name__}, expected a numpy.random.Generator or an int seed"
            )
        n = int(n)
        fixed = set(self.fixed)
        out = {k: np.full(n, v) for k, v in self.parameters.items()}
        cov_names = [k for k in self.covariance_names if k not in fixed]
        std_names = [
            k
            for k, s in self.stderr.items()
            if k not in fixed and k not in self.covariance_names and math.isfinite(s) and s > 0
        ]
        uni_names = [
            k
            for k, (lo, hi) in self.bounds.items()
            if k not in fixed and math.isfinite(lo) and math.isfinite(hi) and hi > lo
        ]
        if method == "auto":
            method = "normal" if (cov_names or std_names) else "uniform"
        if method == "normal":
            if not (cov_names or std_names):
                raise ParameterError(
                    "sampling method 'normal' needs a covariance or standard errors of free "
                    "parameters; this FitResult has none (use method='uniform')"
                )
            if cov_names:
                idx = [self.covariance_names.index(k) for k in cov_names]
                c = np.asarray(self.covariance, dtype=np.float64)[np.ix_(idx, idx)]
                # x = μ + V √w z with C = V diag(w) Vᵀ; negative round-off eigenvalues -> 0
                w, V = np.linalg.eigh(c)
                z = rng.standard_normal((n, len(cov_names)))
                dx = (z * np.sqrt(np.clip(w, 0.0, None))) @ V.T * scale
                for j, k in enumerate(cov_names):
                    out[k] = out[k] + dx[:, j]
            for k in std_names:
                out[k] = out[k] + scale * self.stderr[k] * rng.standard_normal(n)
        else:
            if not uni_names:
                raise ParameterError(
                    "sampling method 'uniform' needs finite bounds of free parameters; this "
                    "FitResult has none"
                )
            for k in uni_names:
                lo, hi = self.bounds[k]
                out[k] = rng.uniform(lo, hi, size=n)
        for k, (lo, hi) in self.bounds.items():
            out[k] = np.clip(out[k], lo, hi)
        return out

    def sample_theta(
        self,
        n: int,
        rng: np.random.Generator | int,
        model: Model | None = None,
        **kwargs: Any,
    ) -> NDArray[np.float64]:
        """:meth:`sample` as a parameter batch of shape (n, P) for ``model``."""
        if model is None:
            model = self.build_model()
        else:
            self._check_model(model)
        return model.theta(self.sample(n, rng, **kwargs))


def load_fit(obj: FitResult | str | os.PathLike[str] | Mapping[str, Any]) -> FitResult:
    """Accept a FitResult, a path to its JSON file or its dict.

    Parameters
    ----------
    obj : FitResult, str, path-like or mapping

    Returns
    -------
    FitResult
        ``obj`` itself when it is one.

    Raises
    ------
    ConfigError
        Any other type, or what :meth:`FitResult.load` /
        :meth:`FitResult.from_dict` raise.
    """
    if isinstance(obj, FitResult):
        return obj
    if isinstance(obj, str | os.PathLike):
        return FitResult.load(obj)
    if isinstance(obj, Mapping):
        return FitResult.from_dict(obj)
    raise ConfigError(
        f"expected a FitResult, a path to a FitResult JSON file or a FitResult dict; got "
        f"{type(obj).__name__}"
    )
