"""Recordings: time-indexed multichannel data with units and roles.

A :class:`Recording` holds a strictly increasing ``time`` axis in seconds and
one float column per signal, named as the model signals are (DESIGN.md,
"Recording"). Metadata travel with the data: the unit and role of each column,
an experiment id, the source (rig, simulation, file) and a free ``meta`` dict
(protocol, seed, preparation report, ...).

Raw recordings may be asynchronous: a channel holds NaN where it has no
sample, and a column may even be entirely NaN. Preparation (outliers,
resampling, NaN handling) is explicit and lives in
``thermogym.identification``; :meth:`Recording.check_values` tells whether a
recording is ready for simulation and fitting.

Files
-----
``.csv`` (also ``.csv.gz``)
    A header line ``time,<col>,...`` and one row per sample; NaN is an empty
    field. Floats are written in the shortest form that reads back to the
    same float64 (exact round trip). Metadata go into a JSON sidecar
    ``<file>.meta.json`` written together with the CSV.
``.parquet``
    float64 columns; metadata as JSON in the schema metadata under the key
    ``thermogym``.

Both are written atomically (:mod:`thermogym._fileio`) and read and written
column-wise through pyarrow (no per-row Python loops): a raw spindle recording
of 600 000 rows × 10 columns takes about a second as CSV.
"""

from __future__ import annotations

import copy as _copy
import gzip
import hashlib
import json
import math
import os
import re
from collections.abc import Iterable, Iterator, Mapping, Sequence
from pathlib import Path
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.csv as pa_csv
import pyarrow.parquet as pq
from numpy.typing import ArrayLike, NDArray

from thermogym._csvdialect import (
    CSV_DELIMITERS,
    TIME_NAMES,
    check_encoding,
    csv_parse_hint,
    find_time_column,
    head_lines,
    leading_comments,
    sniff_csv,
    timestamp_seconds,
)
from thermogym._fileio import atomic_write_many, to_jsonable
from thermogym.errors import RecordingError, ThermogymError, UnitError, UnknownNameError

if TYPE_CHECKING:
    from thermogym.models.base import Model, Simulation

__all__ = [
    "CSV_DELIMITERS",
    "CSV_SUFFIXES",
    "PARQUET_SUFFIXES",
    "ROLES",
    "TIME_NAMES",
    "Recording",
    "read_recording",
    "sidecar_path",
    "sniff_csv",
    "write_recording",
]

#: Roles a column may carry (those of :class:`thermogym.models.base.Signal`).
ROLES: tuple[str, ...] = ("input", "disturbance", "output")
#: File name endings read and written as CSV.
CSV_SUFFIXES: tuple[str, ...] = (".csv", ".csv.gz")
#: File name endings read and written as Parquet.
PARQUET_SUFFIXES: tuple[str, ...] = (".parquet", ".pq")

_NAME_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
_META_KEY = "thermogym"
_SIDECAR_FORMAT = "thermogym.recording"
_SIDECAR_VERSION = 1
_SIDECAR_KEYS = frozenset(
    {"format", "version", "columns", "units", "roles", "experiment_id", "source", "meta"}
)
_UNSET: Any = object()

# Spellings of one unit that are accepted as equal when a recording is checked
# against a model (files from other tools write degC, Ω, ...).
_UNIT_ALIASES = {
    "degc": "°C",
    "deg c": "°C",
    "°c": "°C",
    "℃": "°C",
    "c": "°C",
    "celsius": "°C",
    "ohm": "Ohm",
    "ω": "Ohm",
    "Ω": "Ohm",
    "sec": "s",
    "": "1",
    "-": "1",
}


def _canonical_unit(unit: str) -> str:
    u = unit.strip()
    return _UNIT_ALIASES.get(u.lower(), _UNIT_ALIASES.get(u, u))


def _fmt_names(names: Iterable[str]) -> str:
    return "[" + ", ".join(repr(n) for n in names) + "]"


def _check_name(name: Any) -> str:
    if name == "":
        raise RecordingError(
            "column name '' is not an identifier: a column has an empty name (a delimiter at "
            "the end of the header line?); expected letters, digits and _ (the model signal "
            "names)"
        )
    if not isinstance(name, str) or not _NAME_RE.match(name):
        raise RecordingError(
            f"column name {name!r} is not an identifier; expected letters, digits and _ "
            "not starting with a digit (the model signal names)"
        )
    if name == "time":
        raise RecordingError(
            "a column called 'time' was given besides the time axis; the time axis is the "
            "'time' argument, rename or drop the other column"
        )
    return name


def _show(v: Any) -> str:
    """``repr`` of a value, numpy scalars shown as the Python value they hold."""
    return repr(v.item() if isinstance(v, np.generic) else v)


def _first_true(mask: NDArray[np.bool_]) -> int:
    return int(np.argmax(mask))


def _as_float_column(name: str, values: Any, n: int | None) -> NDArray[np.float64]:
    """Validate one column and return it as a new float64 array.

    ``n`` is the expected length (None for the time axis itself); a scalar is
    broadcast to ``n`` samples.
    """
    if isinstance(values, pd.Series | pd.Index):
        if pd.api.types.is_numeric_dtype(values.dtype) and not pd.api.types.is_bool_dtype(
            values.dtype
        ):
            values = values.to_numpy(dtype=np.float64, na_value=np.nan)
        else:
            values = values.to_numpy()
    arr = np.asarray(values)
    if arr.ndim == 0 and n is not None:
        arr = np.full(n, arr)
    if arr.ndim != 1:
        expected = "(T,)" if n is None else f"({n},)"
        raise RecordingError(f"column {name!r} has shape {arr.shape}, expected {expected}")
    if n is not None and arr.shape[0] != n:
        raise RecordingError(
            f"column {name!r} has {arr.shape[0]} samples but time has {n}; every column needs "
            "one value per time sample (NaN where the channel has no sample)"
        )
    kind = arr.dtype.kind
    if kind in "fiu":
        return np.array(arr, dtype=np.float64, copy=True)
    if kind == "O":
        ok = np.fromiter(
            (
                v is None
                or (
                    isinstance(v, int | float | np.integer | np.floating)
                    and not isinstance(v, bool | np.bool_)
                )
                for v in arr
            ),
            dtype=bool,
            count=arr.shape[0],
        )
        if ok.all():
            out = np.empty(arr.shape[0], dtype=np.float64)
            for_none = np.fromiter((v is None for v in arr), dtype=bool, count=arr.shape[0])
            out[for_none] = np.nan
            out[~for_none] = arr[~for_none].astype(np.float64)
            return out
        i = _first_true(~ok)
    else:  # bool, complex, str, bytes, datetime, timedelta, void
        i = 0
    v = arr[i]
    raise RecordingError(
        f"column {name!r} holds a non-numeric value at row {i}: {_show(v)} "
        f"({type(v).__name__}, dtype {arr.dtype}); expected real numbers "
        "(NaN for a missing sample)"
    )


def _check_time(t: NDArray[np.float64]) -> None:
    if t.shape[0] == 0:
        raise RecordingError("the recording is empty: time has no samples")
    bad = ~np.isfinite(t)
    if bad.any():
        i = _first_true(bad)
        raise RecordingError(f"time is {float(t[i])!r} at index {i}; expected finite seconds")
    if t.shape[0] > 1:
        d = np.diff(t)
        bad = d <= 0
        if bad.any():
            i = _first_true(bad)
            raise RecordingError(
                f"time is not strictly increasing at index {i + 1}: "
                f"time[{i}] = {float(t[i])!r} s, time[{i + 1}] = {float(t[i + 1])!r} s"
            )


def _readonly(a: NDArray[np.float64]) -> NDArray[np.float64]:
    a.flags.writeable = False
    return a


class Recording:
    """Time-indexed multichannel data: a time axis in seconds and float columns.

    Parameters
    ----------
    time : array_like, shape (T,)
        Sample times [s], finite and strictly increasing, at least one sample.
    columns : mapping or iterable of (name, array_like), optional
        One column per signal, each of shape (T,) (a scalar is repeated).
        Names are identifiers (the model signal names) and not ``time``.
        Values are real numbers; NaN marks a missing sample.
    units : mapping, optional
        Column name → unit (``"°C"``, ``"W"``, ...). ``time`` is always in
        seconds (``{"time": "s"}`` is accepted). Columns without a unit are
        allowed.
    roles : mapping, optional
        Column name → ``"input"``, ``"disturbance"`` or ``"output"``.
    experiment_id : str, optional
        Identifier of the experiment (e.g. ``"step_24V_25C"``).
    source : str, optional
        Where the data come from (``"rig:axt211"``, ``"simulation"``, a file).
    meta : dict, optional
        Free metadata (protocol, seed, preparation report, ...); copied. It
        must be JSON-serialisable to be written to a file.

    Raises
    ------
    RecordingError
        Empty recording, bad time axis, mismatched column lengths,
        non-numeric values, duplicate or invalid column names, bad metadata.
    UnitError
        ``time`` given a unit other than seconds.

    Notes
    -----
    The arrays are copied and kept read-only, so a recording cannot change
    behind the fingerprint a FitResult stores; derive new recordings with
    :meth:`with_columns`, :meth:`select`, :meth:`slice`, :meth:`replace`.

    Examples
    --------
    >>> rec = Recording([0.0, 1.0, 2.0], {"u": [0, 1, 1], "T_P": [25.0, np.nan, 26.5]},
    ...                 units={"u": "1", "T_P": "°C"}, roles={"u": "input", "T_P": "output"})
    >>> rec.columns, rec.n_samples, rec.dt
    (('u', 'T_P'), 3, 1.0)
    >>> rec["T_P"]
    array([25. ,  nan, 26.5])
    """

    __hash__ = None  # type: ignore[assignment]  # mutable meta; equality is by value

    def __init__(
        self,
        time: ArrayLike,
        columns: Mapping[str, ArrayLike] | Iterable[tuple[str, ArrayLike]] | None = None,
        *,
        units: Mapping[str, str] | None = None,
        roles: Mapping[str, str] | None = None,
        experiment_id: str | None = None,
        source: str | None = None,
        meta: Mapping[str, Any] | None = None,
    ) -> None:
        t = _as_float_column("time", time, None)
        _check_time(t)
        n = t.shape[0]
        items = list(columns.items() if isinstance(columns, Mapping) else (columns or ()))
        data: dict[str, NDArray[np.float64]] = {}
        for item in items:
            if not (isinstance(item, tuple) and len(item) == 2):
                raise RecordingError(
                    f"columns must be a mapping name -> values or (name, values) pairs; "
                    f"got the item {item!r:.60}"
                )
            name, values = item
            name = _check_name(name)
            if name in data:
                raise RecordingError(f"column {name!r} is given twice; column names are unique")
            data[name] = _readonly(_as_float_column(name, values, n))
        self._time = _readonly(t)
        self._data = data
        self._units = self._check_units(units)
        self._roles = self._check_roles(roles)
        self._experiment_id = self._check_str("experiment_id", experiment_id)
        self._source = self._check_str("source", source)
        if meta is not None and not isinstance(meta, Mapping):
            raise RecordingError(f"meta is a {type(meta).__name__}, expected a dict")
        self.meta: dict[str, Any] = _copy.deepcopy(dict(meta)) if meta else {}

    # ----------------------------------------------------------- validation
    @staticmethod
    def _check_str(what: str, value: Any) -> str | None:
        if value is not None and not isinstance(value, str):
            raise RecordingError(f"{what} is a {type(value).__name__} ({value!r}), expected a str")
        return value

    def _check_units(self, units: Mapping[str, str] | None) -> dict[str, str]:
        if units is None:
            return {}
        if not isinstance(units, Mapping):
            raise RecordingError(
                f"units is a {type(units).__name__}, expected a dict column -> unit"
            )
        out: dict[str, str] = {}
        for k, v in units.items():
            if not isinstance(v, str):
                raise RecordingError(f"unit of column {k!r} is {v!r}, expected a str")
            if k == "time":
                if _canonical_unit(v) != "s":
                    raise UnitError(f"time is always in seconds; units gives 'time' the unit {v!r}")
                continue
            if k not in self._data:
                raise RecordingError(
                    f"units name column {k!r}, which the recording lacks; columns are "
                    f"{_fmt_names(self._data)}"
                )
            out[k] = v
        return out

    def _check_roles(self, roles: Mapping[str, str] | None) -> dict[str, str]:
        if roles is None:
            return {}
        if not isinstance(roles, Mapping):
            raise RecordingError(
                f"roles is a {type(roles).__name__}, expected a dict column -> role"
            )
        out: dict[str, str] = {}
        for k, v in roles.items():
            if k not in self._data:
                raise RecordingError(
                    f"roles name column {k!r}, which the recording lacks; columns are "
                    f"{_fmt_names(self._data)}"
                )
            if v not in ROLES:
                raise RecordingError(f"column {k!r} has role {v!r}, expected one of {ROLES}")
            out[k] = v
        return out

    @classmethod
    def _trusted(
        cls,
        time: NDArray[np.float64],
        data: dict[str, NDArray[np.float64]],
        units: dict[str, str],
        roles: dict[str, str],
        experiment_id: str | None,
        source: str | None,
        meta: dict[str, Any],
    ) -> Recording:
        """Build from already validated read-only arrays (no copy, no checks)."""
        rec = cls.__new__(cls)
        rec._time = time
        rec._data = data
        rec._units = {k: v for k, v in units.items() if k in data}
        rec._roles = {k: v for k, v in roles.items() if k in data}
        rec._experiment_id = experiment_id
        rec._source = source
        rec.meta = _copy.deepcopy(meta)
        return rec

    def _derive(self, time: NDArray[np.float64], data: dict[str, NDArray[np.float64]]) -> Recording:
        return Recording._trusted(
            time, data, self._units, self._roles, self._experiment_id, self._source, self.meta
        )

    # ----------------------------------------------------------- properties
    @property
    def time(self) -> NDArray[np.float64]:
        """Sample times [s], shape (T,), read-only."""
        return self._time

    @property
    def columns(self) -> tuple[str, ...]:
        """Column names (without ``time``), in order."""
        return tuple(self._data)

    @property
    def units(self) -> Mapping[str, str]:
        """Column name → unit (read-only view); columns without a unit are absent."""
        return MappingProxyType(self._units)

    @property
    def roles(self) -> Mapping[str, str]:
        """Column name → role (read-only view); columns without a role are absent."""
        return MappingProxyType(self._roles)

    @property
    def experiment_id(self) -> str | None:
        """Identifier of the experiment, or None."""
        return self._experiment_id

    @property
    def source(self) -> str | None:
        """Where the data come from, or None."""
        return self._source

    @property
    def n_samples(self) -> int:
        """Number of time samples T."""
        return int(self._time.shape[0])

    @property
    def duration(self) -> float:
        """``time[-1] - time[0]`` [s]; 0 for a single sample."""
        return float(self._time[-1] - self._time[0])

    def is_uniform(self, rtol: float = 1e-6) -> bool:
        """Whether the samples are equally spaced.

        Parameters
        ----------
        rtol : float
            Largest deviation of any step from the mean step, relative to the
            mean step.

        Returns
        -------
        bool
            True when every ``time[k+1] - time[k]`` is within ``rtol`` of the
            mean step; False for a single sample.
        """
        if self.n_samples < 2:
            return False
        d = np.diff(self._time)
        mean = (self._time[-1] - self._time[0]) / (self.n_samples - 1)
        return bool(np.max(np.abs(d - mean)) <= rtol * mean)

    @property
    def dt(self) -> float:
        """Sample period [s] of a uniform recording (mean step).

        Raises
        ------
        RecordingError
            Fewer than two samples, or steps that differ by more than a
            relative 1e-6 (see :meth:`is_uniform`); the message names the
            first step that deviates.
        """
        if self.n_samples < 2:
            raise RecordingError("a recording with a single sample has no sample period")
        mean = (self._time[-1] - self._time[0]) / (self.n_samples - 1)
        if not self.is_uniform():
            d = np.diff(self._time)
            i = int(np.argmax(np.abs(d - mean)))
            spread = float(np.max(np.abs(d - mean)) / mean)
            raise RecordingError(
                f"recording{self._label()} is not uniformly sampled: its time steps range from "
                f"{float(d.min()):.6g} s to {float(d.max()):.6g} s around a mean of "
                f"{float(mean):.6g} s ({100 * spread:.3g} % off at most, the step of "
                f"{float(d[i]):.6g} s from time {float(self._time[i]):.6g} s to "
                f"{float(self._time[i + 1]):.6g} s); resample it "
                "onto a uniform grid first (thermogym.identification.prepare.resample, or "
                "--prepare dt=SECONDS on the command line)"
            )
        return float(mean)

    # -------------------------------------------------------------- access
    def __len__(self) -> int:
        return self.n_samples

    def __contains__(self, name: object) -> bool:
        return name == "time" or name in self._data

    def __iter__(self) -> Iterator[str]:
        """Iterate over the column names (like a DataFrame; ``len`` counts samples)."""
        return iter(self._data)

    def __getitem__(self, name: str) -> NDArray[np.float64]:
        """Return column ``name`` (or ``"time"``) as a read-only array, shape (T,)."""
        if name == "time":
            return self._time
        try:
            return self._data[name]
        except (KeyError, TypeError):
            raise UnknownNameError(
                f"recording{self._label()} has no column {name!r}; columns are "
                f"{_fmt_names(self._data)}"
            ) from None

    def _label(self) -> str:
        return f" {self._experiment_id!r}" if self._experiment_id else ""

    def _require(self, names: Iterable[str]) -> list[str]:
        names = [names] if isinstance(names, str) else list(names)
        unknown = [n for n in names if n not in self._data]
        if unknown:
            raise UnknownNameError(
                f"recording{self._label()} has no column(s) {_fmt_names(unknown)}; columns are "
                f"{_fmt_names(self._data)}"
            )
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise RecordingError(f"column(s) {_fmt_names(dup)} named more than once")
        return names

    def select(self, names: Iterable[str]) -> Recording:
        """Return a recording with only the columns ``names``, in that order.

        Raises
        ------
        UnknownNameError
            A name is not a column (the message lists the columns).
        """
        names = self._require(
            n for n in ([names] if isinstance(names, str) else names) if n != "time"
        )
        return self._derive(self._time, {n: self._data[n] for n in names})

    def drop(self, *names: str) -> Recording:
        """Return a recording without the columns ``names``."""
        gone = set(self._require(names))
        return self._derive(self._time, {k: v for k, v in self._data.items() if k not in gone})

    def slice(self, t0: float | None = None, t1: float | None = None) -> Recording:
        """Return the samples with ``t0 <= time <= t1`` [s] (both ends included).

        ``None`` leaves that end open. Time is not shifted.

        Raises
        ------
        RecordingError
            ``t0 > t1`` or no sample in the window.
        """
        lo = -math.inf if t0 is None else float(t0)
        hi = math.inf if t1 is None else float(t1)
        if lo > hi:
            raise RecordingError(f"slice start {lo!r} s is after its end {hi!r} s")
        i0 = int(np.searchsorted(self._time, lo, side="left"))
        i1 = int(np.searchsorted(self._time, hi, side="right"))
        if i1 <= i0:
            raise RecordingError(
                f"no sample of recording{self._label()} lies in [{lo!r}, {hi!r}] s; it spans "
                f"[{float(self._time[0])!r}, {float(self._time[-1])!r}] s"
            )
        return self._derive(self._time[i0:i1], {k: v[i0:i1] for k, v in self._data.items()})

    def with_columns(
        self,
        columns: Mapping[str, ArrayLike] | None = None,
        /,
        *,
        units: Mapping[str, str] | None = None,
        roles: Mapping[str, str] | None = None,
        **arrays: ArrayLike,
    ) -> Recording:
        """Return a recording with columns added or replaced.

        Parameters
        ----------
        columns : mapping, optional
            Name → values (shape (T,) or a scalar), for names that are not
            valid keyword arguments.
        units, roles : mapping, optional
            Units and roles of the new columns. A replaced column keeps its
            unit and role unless given here.
        **arrays
            Name → values.

        Examples
        --------
        >>> rec = Recording([0.0, 1.0], {"u": [0.0, 1.0]})
        >>> rec.with_columns(k_U=24.0, units={"k_U": "V"})["k_U"]
        array([24., 24.])
        """
        new = {**(dict(columns) if columns else {}), **arrays}
        data = dict(self._data)
        n = self.n_samples
        for name, values in new.items():
            data[_check_name(name)] = _readonly(_as_float_column(name, values, n))
        rec = self._derive(self._time, data)
        rec._units = {**rec._units, **rec._check_units(units)}
        rec._roles = {**rec._roles, **rec._check_roles(roles)}
        return rec

    def replace(
        self,
        *,
        units: Mapping[str, str] | None = _UNSET,
        roles: Mapping[str, str] | None = _UNSET,
        experiment_id: str | None = _UNSET,
        source: str | None = _UNSET,
        meta: Mapping[str, Any] | None = _UNSET,
    ) -> Recording:
        """Return a copy with the metadata given replaced (data unchanged).

        Each argument replaces the whole field (``units={}`` clears all units);
        arguments not given are kept.
        """
        return Recording(
            self._time,
            self._data,
            units=self._units if units is _UNSET else units,
            roles=self._roles if roles is _UNSET else roles,
            experiment_id=self._experiment_id if experiment_id is _UNSET else experiment_id,
            source=self._source if source is _UNSET else source,
            meta=self.meta if meta is _UNSET else meta,
        )

    def copy(self) -> Recording:
        """Return an independent copy (arrays and ``meta`` copied)."""
        return Recording._trusted(
            _readonly(self._time.copy()),
            {k: _readonly(v.copy()) for k, v in self._data.items()},
            self._units,
            self._roles,
            self._experiment_id,
            self._source,
            self.meta,
        )

    # ------------------------------------------------------------- checks
    def all_nan_columns(self) -> list[str]:
        """Names of the columns that hold no sample at all (entirely NaN)."""
        return [k for k, v in self._data.items() if np.isnan(v).all()]

    def check_values(self, names: Iterable[str] | None = None, *, allow_nan: bool = False) -> None:
        """Check that columns hold data fit for simulation and fitting.

        An entirely NaN column is allowed only in raw data; a prepared
        recording has finite values everywhere.

        Parameters
        ----------
        names : iterable of str, optional
            Columns to check; all when omitted.
        allow_nan : bool
            Accept NaN/inf samples as long as the column holds some finite
            sample (raw, asynchronous data).

        Raises
        ------
        RecordingError
            A column is entirely NaN, or (``allow_nan=False``) holds a
            non-finite sample; the message names the column, the number of
            such samples and the first one's row and time.
        """
        names = list(self._data) if names is None else self._require(names)
        empty = [k for k in names if not np.isfinite(self._data[k]).any()]
        if empty:
            raise RecordingError(
                f"column(s) {_fmt_names(empty)} of recording{self._label()} hold no finite "
                "sample; an empty channel is allowed only in raw data: drop it or prepare the "
                "recording"
            )
        for k in names:
            v = self._data[k]
            bad = ~np.isfinite(v)
            if not allow_nan and bad.any():
                i = _first_true(bad)
                raise RecordingError(
                    f"column {k!r} of recording{self._label()} has {int(bad.sum())} non-finite "
                    f"sample(s), the first {float(v[i])!r} at row {i} "
                    f"(time {float(self._time[i])!r} s); "
                    "prepare the recording (resample, fill or drop gaps) first"
                )

    # --------------------------------------------------- model integration
    def validate_for(
        self,
        model: Model,
        *,
        outputs: bool | Sequence[str] = True,
        finite: bool = False,
    ) -> None:
        """Check that this recording has the columns and units ``model`` needs.

        Parameters
        ----------
        model : Model
            A model from :func:`thermogym.models.registry.get_model`.
        outputs : bool or sequence of str
            Also require the model outputs (all of them, or the names given).
        finite : bool
            Also require finite values in those columns (:meth:`check_values`).

        Raises
        ------
        RecordingError
            Columns are missing; the message lists them, the names the model
            expects and the columns the recording has.
        UnitError
            A column's unit in the metadata differs from the model's (a column
            without a unit is accepted).
        UnknownNameError
            ``outputs`` names a signal that is not a model output.
        """
        needed = self._needed(model, outputs)
        missing = [s.name for s in needed if s.name not in self._data]
        if missing:
            raise RecordingError(
                f"recording{self._label()} lacks column(s) {_fmt_names(missing)} needed by model "
                f"{model.name!r}; the model expects exogenous {_fmt_names(model.exogenous_names)}"
                f" and outputs {_fmt_names(model.output_names)}; the recording has "
                f"{_fmt_names(self._data)}"
            )
        for s in needed:
            unit = self._units.get(s.name)
            if unit is not None and _canonical_unit(unit) != _canonical_unit(s.unit):
                raise UnitError(
                    f"column {s.name!r} of recording{self._label()} is in {unit!r}, model "
                    f"{model.name!r} expects {s.unit!r}"
                )
        if finite:
            self.check_values([s.name for s in needed])

    @staticmethod
    def _needed(model: Model, outputs: bool | Sequence[str]) -> list[Any]:
        needed = list(model.exogenous)
        if outputs is True:
            needed += list(model.outputs)
        elif outputs is not False:
            names = [outputs] if isinstance(outputs, str) else list(outputs)
            unknown = [n for n in names if n not in model.output_names]
            if unknown:
                raise UnknownNameError(
                    f"{_fmt_names(unknown)} are not outputs of model {model.name!r}; outputs "
                    f"are {_fmt_names(model.output_names)}"
                )
            needed += [model.signal(n) for n in names]
        return needed

    def exogenous_array(self, model: Model) -> NDArray[np.float64]:
        """Exogenous signals as the ``u`` array of :meth:`Model.simulate`.

        Returns
        -------
        ndarray, shape (T, n_u)
            Columns in ``model.exogenous`` order (inputs, then disturbances);
            a new, writable array. NaN samples are passed through.

        Raises
        ------
        RecordingError, UnitError
            As :meth:`validate_for` with ``outputs=False``.
        """
        self.validate_for(model, outputs=False)
        names = model.exogenous_names
        out = np.empty((self.n_samples, len(names)), dtype=np.float64)
        for j, n in enumerate(names):
            out[:, j] = self._data[n]
        return out

    def output_array(self, model: Model, names: Sequence[str] | None = None) -> NDArray[np.float64]:
        """Measured outputs as an array.

        Parameters
        ----------
        model : Model
        names : sequence of str, optional
            Outputs to take, in this order; all of ``model.output_names``
            when omitted.

        Returns
        -------
        ndarray, shape (T, n_y)
            A new, writable array.
        """
        names = list(model.output_names) if names is None else list(names)
        self.validate_for(model, outputs=names)
        out = np.empty((self.n_samples, len(names)), dtype=np.float64)
        for j, n in enumerate(names):
            out[:, j] = self._data[n]
        return out

    @classmethod
    def from_simulation(
        cls,
        sim: Simulation,
        index: int = 0,
        *,
        model: Model | None = None,
        experiment_id: str | None = None,
        source: str | None = "simulation",
        meta: Mapping[str, Any] | None = None,
    ) -> Recording:
        """Build a recording from one member of a simulated batch.

        Parameters
        ----------
        sim : Simulation
            Result of :meth:`Model.simulate`.
        index : int
            Which parameter set of the batch, ``0 <= index < sim.batch_size``.
        model : Model, optional
            The simulated model; gives the exogenous signals their exact roles
            (input or disturbance). Without it the model named in ``sim.meta``
            is looked up in the registry; if that fails, exogenous columns get
            no role.
        experiment_id, source : str, optional
        meta : mapping, optional
            Added to ``{"simulation": sim.meta + index}``.

        Returns
        -------
        Recording
            Columns: the exogenous signals, then the outputs.
        """
        if not isinstance(index, int | np.integer) or not 0 <= index < sim.batch_size:
            raise RecordingError(
                f"index {index!r} is not a member of the simulated batch of size "
                f"{sim.batch_size}; expected 0 <= index < {sim.batch_size}"
            )
        sim_model = sim.meta.get("model")
        if model is None and sim_model is not None:
            from thermogym.models.registry import get_model

            try:
                model = get_model(sim_model)
            except ThermogymError:  # unregistered or needs arguments: roles stay partial
                model = None
        elif model is not None and sim_model is not None and sim_model != model.name:
            raise RecordingError(
                f"the simulation comes from model {sim_model!r}, but model {model.name!r} was given"
            )
        cols: dict[str, NDArray[np.float64]] = {}
        roles: dict[str, str] = {}
        for j, n in enumerate(sim.input_names):
            cols[n] = sim.inputs[index, :, j]
            if model is not None and n in model.exogenous_names:
                roles[n] = model.signal(n).role
        for j, n in enumerate(sim.output_names):
            if n in cols:
                raise RecordingError(f"signal {n!r} is both an exogenous signal and an output")
            cols[n] = sim.outputs[index, :, j]
            roles[n] = "output"
        units = {n: sim.units[n] for n in cols if n in sim.units}
        full_meta: dict[str, Any] = {"simulation": {**sim.meta, "index": int(index)}}
        full_meta.update(meta or {})
        return cls(
            sim.time,
            cols,
            units=units,
            roles=roles,
            experiment_id=experiment_id,
            source=source,
            meta=full_meta,
        )

    # --------------------------------------------------------------- pandas
    def to_frame(self) -> pd.DataFrame:
        """Return a :class:`pandas.DataFrame` with a ``time`` column first.

        The metadata are put in ``df.attrs["thermogym"]``, which
        :meth:`from_frame` reads back.
        """
        df = pd.DataFrame({"time": self._time, **self._data}, copy=True)
        df.attrs[_META_KEY] = self._metadata()
        return df

    @classmethod
    def from_frame(
        cls,
        df: pd.DataFrame,
        time: str = "time",
        *,
        columns: Sequence[str] | None = None,
        units: Mapping[str, str] | None = None,
        roles: Mapping[str, str] | None = None,
        experiment_id: str | None = None,
        source: str | None = None,
        meta: Mapping[str, Any] | None = None,
    ) -> Recording:
        """Build a recording from a :class:`pandas.DataFrame`.

        Parameters
        ----------
        df : DataFrame
            One column per signal; the time axis [s] is column ``time`` or the
            index when the index is named ``time``.
        time : str
            Name of the time column; it becomes ``time`` in the recording.
        columns : sequence of str, optional
            Columns to take (others, e.g. text columns, are ignored); all
            when omitted.
        units, roles, experiment_id, source, meta
            As in :class:`Recording`. Metadata in ``df.attrs["thermogym"]``
            (from :meth:`to_frame`) are used too; ``units`` and ``roles`` given
            here must agree with them.

        Raises
        ------
        RecordingError
            No time column (the message lists the columns), duplicate column
            labels, non-numeric values (column and row), and every check of
            :class:`Recording`.
        """
        if not isinstance(df, pd.DataFrame):
            raise RecordingError(f"expected a pandas DataFrame, got {type(df).__name__}")
        labels = list(df.columns)
        dup = sorted({str(c) for c in labels if labels.count(c) > 1})
        if dup:
            raise RecordingError(f"column(s) {dup} appear more than once in the DataFrame")
        if time in labels:
            t = df[time]
            rest = [c for c in labels if c != time]
        elif df.index.name == time:
            t = df.index
            rest = labels
        else:
            raise RecordingError(
                f"the DataFrame has no time column {time!r}; columns are "
                f"{[str(c) for c in labels]}, index name {df.index.name!r} (pass time=...)"
            )
        if columns is not None:
            missing = [c for c in columns if c not in rest]
            if missing:
                raise RecordingError(
                    f"the DataFrame lacks column(s) {missing}; columns are {[str(c) for c in rest]}"
                )
            rest = list(columns)
        attrs = df.attrs.get(_META_KEY, {}) if isinstance(df.attrs.get(_META_KEY), dict) else {}
        return cls._from_parts(
            t,
            [(c, df[c]) for c in rest],
            file_meta=attrs,
            units=units,
            roles=roles,
            experiment_id=experiment_id,
            source=source,
            meta=meta,
            where="the DataFrame",
        )

    @classmethod
    def _from_parts(
        cls,
        time: Any,
        items: list[tuple[Any, Any]],
        *,
        file_meta: Mapping[str, Any],
        units: Mapping[str, str] | None,
        roles: Mapping[str, str] | None,
        experiment_id: str | None,
        source: str | None,
        meta: Mapping[str, Any] | None,
        where: str,
    ) -> Recording:
        """Merge stored and given metadata and build the recording."""
        merged_units = _merge_labels(file_meta.get("units"), units, "unit", where, UnitError)
        merged_roles = _merge_labels(file_meta.get("roles"), roles, "role", where, RecordingError)
        full_meta = dict(file_meta.get("meta") or {})
        full_meta.update(meta or {})
        return cls(
            time,
            items,
            units=merged_units,
            roles=merged_roles,
            experiment_id=experiment_id
            if experiment_id is not None
            else file_meta.get("experiment_id"),
            source=source if source is not None else file_meta.get("source"),
            meta=full_meta,
        )

    def _metadata(self) -> dict[str, Any]:
        return {
            "units": dict(self._units),
            "roles": dict(self._roles),
            "experiment_id": self._experiment_id,
            "source": self._source,
            "meta": _copy.deepcopy(self.meta),
        }

    # ---------------------------------------------------------- identity
    def fingerprint(self) -> str:
        """Stable SHA-256 over the time axis, the columns and their units.

        Column order, roles, ids and ``meta`` do not enter it; ``-0.0`` and
        ``0.0`` hash alike, as do all NaN bit patterns. FitResults store it to
        identify their training and validation data.

        Returns
        -------
        str
            64 hexadecimal digits.
        """
        h = hashlib.sha256()
        h.update(f"thermogym.recording.v1:{self.n_samples}:{len(self._data)}\n".encode())
        h.update(_canonical_bytes(self._time))
        for name in sorted(self._data):
            unit = self._units.get(name, "")
            h.update(f"\n{name}\x00{unit}\x00".encode())
            h.update(_canonical_bytes(self._data[name]))
        return h.hexdigest()

    def equals(self, other: object, *, metadata: bool = True) -> bool:
        """Whether ``other`` has the same time, columns (NaN equal to NaN) and metadata."""
        if not isinstance(other, Recording):
            return False
        if list(self._data) != list(other._data) or not np.array_equal(self._time, other._time):
            return False
        if not all(
            np.array_equal(v, other._data[k], equal_nan=True) for k, v in self._data.items()
        ):
            return False
        if metadata:
            return self._metadata() == other._metadata()
        return True

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Recording):
            return NotImplemented
        return self.equals(other)

    def __repr__(self) -> str:
        cols = ", ".join(f"{k} [{self._units[k]}]" if k in self._units else k for k in self._data)
        if self.n_samples > 1 and self.is_uniform():
            step = f", dt={self.dt:g} s"
        elif self.n_samples > 1:
            step = ", non-uniform"
        else:
            step = ""
        ident = f"{self._experiment_id!r}, " if self._experiment_id else ""
        return (
            f"<Recording {ident}{self.n_samples} samples, time {self._time[0]:g}..."
            f"{self._time[-1]:g} s{step}, columns: {cols}>"
        )


def _canonical_bytes(a: NDArray[np.float64]) -> bytes:
    c = np.asarray(a, dtype="<f8") + 0.0  # -0.0 + 0.0 == +0.0
    nan = np.isnan(c)
    if nan.any():
        c = np.where(nan, np.nan, c)
    return c.tobytes()


def _merge_labels(
    stored: Any,
    given: Mapping[str, str] | None,
    what: str,
    where: str,
    error: type[RecordingError],
) -> dict[str, str]:
    """Merge column labels (units or roles) stored with the data and given by the caller."""
    out: dict[str, str] = dict(stored or {})
    for k, v in (given or {}).items():
        if k not in out:
            out[k] = v
        elif out[k] != v and not (what == "unit" and _canonical_unit(out[k]) == _canonical_unit(v)):
            raise error(f"{where} gives column {k!r} the {what} {out[k]!r}, the argument {v!r}")
    return out


# ------------------------------------------------------------------------ files
def sidecar_path(path: str | os.PathLike[str]) -> Path:
    """Path of the JSON sidecar that holds the metadata of a CSV recording."""
    p = Path(path)
    return p.with_name(p.name + ".meta.json")


def _file_format(path: Path) -> str:
    name = path.name.lower()
    if name.endswith(CSV_SUFFIXES):
        return "csv"
    if name.endswith(PARQUET_SUFFIXES):
        return "parquet"
    raise RecordingError(
        f"cannot tell the format of {str(path)!r} from its extension; supported are "
        f"{list(CSV_SUFFIXES + PARQUET_SUFFIXES)}"
    )


def _metadata_json(rec: Recording, path: Path) -> str:
    doc = {
        "format": _SIDECAR_FORMAT,
        "version": _SIDECAR_VERSION,
        "columns": ["time", *rec.columns],
        **rec._metadata(),
    }
    try:
        return json.dumps(
            to_jsonable(doc, "recording"), indent=2, ensure_ascii=False, allow_nan=False
        )
    except TypeError as e:
        raise RecordingError(f"cannot write {str(path)!r}: {e}") from e


def write_recording(
    rec: Recording,
    path: str | os.PathLike[str],
    *,
    overwrite: bool = True,
    float_format: str | None = None,
    compression: str = "zstd",
) -> Path:
    """Write a recording to CSV or Parquet, atomically.

    Parameters
    ----------
    rec : Recording
    path : str or path-like
        ``.csv``, ``.csv.gz`` or ``.parquet``; the extension picks the format.
        A CSV gets its metadata in ``<path>.meta.json``, written together
        with it (the sidecar is always written, so a stale one cannot be
        paired with the new data).
    overwrite : bool
        When False, refuse if the file (or its sidecar) exists.
    float_format : str, optional
        CSV only: a ``%`` format such as ``"%.6g"`` for compact files that do
        not round-trip exactly (and write about ten times slower). By default
        floats are written in the shortest form that reads back to the same
        float64.
    compression : str
        Parquet codec (``"zstd"``, ``"snappy"``, ``"gzip"``, ``"none"``).

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    RecordingError
        Unknown extension, existing file with ``overwrite=False``, metadata
        that JSON cannot hold, an invalid ``float_format``, or an OS error.
        In every case no file is created or changed.
    """
    if not isinstance(rec, Recording):
        raise RecordingError(f"expected a Recording, got {type(rec).__name__}")
    path = Path(path)
    fmt = _file_format(path)
    text = _metadata_json(rec, path)
    names = ["time", *rec.columns]
    arrays = [rec.time, *(rec[c] for c in rec.columns)]
    writes: list[tuple[Path, Any]]
    if fmt == "csv":
        gz = path.name.lower().endswith(".gz")
        if float_format is not None:
            try:
                float_format % 1.0  # validate the format before anything is written
            except (TypeError, ValueError) as e:
                raise RecordingError(
                    f"float_format {float_format!r} does not format a float: {e}"
                ) from e

        def write_csv(tmp: Path) -> None:
            if float_format is None:
                table = pa.table(
                    [pa.array(a, from_pandas=True) for a in arrays], names=names
                )  # from_pandas: NaN -> null -> empty field
                options = pa_csv.WriteOptions(
                    batch_size=65536, quoting_style="none", quoting_header="none"
                )
                if gz:  # level 1: CSV numbers compress little better at higher levels
                    with gzip.GzipFile(tmp, "wb", compresslevel=1, mtime=0) as out:
                        pa_csv.write_csv(table, out, options)
                else:
                    pa_csv.write_csv(table, str(tmp), options)
            else:
                frame = pd.DataFrame(dict(zip(names, arrays, strict=True)))
                frame.to_csv(
                    tmp,
                    index=False,
                    float_format=float_format,
                    na_rep="",
                    compression={"method": "gzip", "compresslevel": 1, "mtime": 0} if gz else None,
                )

        def write_meta(tmp: Path) -> None:
            tmp.write_text(text + "\n", encoding="utf-8")

        writes = [(path, write_csv), (sidecar_path(path), write_meta)]
    else:

        def write_parquet(tmp: Path) -> None:
            schema = pa.schema(
                [pa.field(n, pa.float64()) for n in names],
                metadata={_META_KEY: text.encode("utf-8")},
            )
            table = pa.Table.from_arrays([pa.array(a) for a in arrays], schema=schema)
            pq.write_table(table, str(tmp), compression=compression)

        writes = [(path, write_parquet)]
    try:
        atomic_write_many(writes, overwrite=overwrite)
    except FileExistsError as e:
        raise RecordingError(f"not writing the recording: {e}") from e
    except (OSError, pa.ArrowException) as e:
        raise RecordingError(f"cannot write recording {str(path)!r}: {e}") from e
    return path


def _arrow_column(name: str, col: pa.ChunkedArray, where: str, line0: int | None) -> Any:
    """Turn one Arrow column into float64 values or raise naming the bad cell."""
    t = col.type
    if pa.types.is_floating(t) or pa.types.is_integer(t) or pa.types.is_decimal(t):
        return col.cast(pa.float64()).to_numpy(zero_copy_only=False)
    if pa.types.is_null(t):
        return np.full(len(col), np.nan)
    values = col.to_numpy(zero_copy_only=False)
    if pa.types.is_string(t) or pa.types.is_large_string(t):
        parsed = pd.to_numeric(pd.Series(values, dtype=object), errors="coerce").to_numpy(
            dtype=np.float64, na_value=np.nan
        )
        bad = (
            np.isnan(parsed)
            & pd.notna(values)
            & (
                ~pd.Series(values, dtype=object).str.strip().str.lower().isin(["nan", "-nan", ""])
            ).to_numpy()
        )
        if not bad.any():
            return parsed
        i = _first_true(bad)
    else:
        notnull = np.asarray(pd.notna(values))
        i = _first_true(notnull) if notnull.any() else 0
    line = f" (line {i + line0})" if line0 is not None else ""
    hint = (
        "; a units row under the header? remove it (units go into the .meta.json sidecar)"
        if i == 0 and line0 is not None
        else ""
    )
    raise RecordingError(
        f"{where}: column {name!r} holds a non-numeric value {_show(values[i])} at row {i}{line} "
        f"(read as {t}); expected real numbers, an empty field for a missing sample{hint}"
    )


def _read_sidecar(path: Path) -> dict[str, Any]:
    side = sidecar_path(path)
    if not side.exists():
        return {}
    try:
        doc = json.loads(side.read_text(encoding="utf-8-sig"))
    except RecursionError:
        raise RecordingError(
            f"sidecar {str(side)!r} is nested too deeply; fix or delete it"
        ) from None
    except json.JSONDecodeError as e:
        raise RecordingError(
            f"sidecar {str(side)!r} is not valid JSON (line {e.lineno}, column {e.colno}): "
            f"{e.msg}; fix or delete it"
        ) from e
    except (OSError, UnicodeDecodeError) as e:
        raise RecordingError(f"cannot read sidecar {str(side)!r}: {e}") from e
    return _check_metadata_doc(doc, f"sidecar {str(side)!r}")


def _check_metadata_doc(doc: Any, where: str) -> dict[str, Any]:
    if not isinstance(doc, dict):
        raise RecordingError(f"{where} holds a {type(doc).__name__}, expected a JSON object")
    unknown = sorted(set(doc) - _SIDECAR_KEYS)
    if unknown:
        raise RecordingError(
            f"{where} has unknown key(s) {unknown}; expected some of {sorted(_SIDECAR_KEYS)}"
        )
    if doc.get("format", _SIDECAR_FORMAT) != _SIDECAR_FORMAT:
        raise RecordingError(f"{where} has format {doc['format']!r}, expected {_SIDECAR_FORMAT!r}")
    version = doc.get("version", _SIDECAR_VERSION)
    if not isinstance(version, int) or version > _SIDECAR_VERSION:
        raise RecordingError(
            f"{where} has version {version!r}; this thermogym reads up to {_SIDECAR_VERSION}"
        )
    for key in ("units", "roles", "meta"):
        if doc.get(key) is not None and not isinstance(doc[key], dict):
            raise RecordingError(
                f"{where}: {key!r} is a {type(doc[key]).__name__}, expected a JSON object"
            )
    for key in ("units", "roles"):
        for k, v in (doc.get(key) or {}).items():
            if not isinstance(v, str):
                raise RecordingError(f"{where}: {key}[{k!r}] is {v!r}, expected a string")
    for key in ("experiment_id", "source"):
        if doc.get(key) is not None and not isinstance(doc[key], str):
            raise RecordingError(f"{where}: {key!r} is {doc[key]!r}, expected a string or null")
    cols = doc.get("columns")
    if cols is not None and not (isinstance(cols, list) and all(isinstance(c, str) for c in cols)):
        raise RecordingError(f"{where}: 'columns' is {cols!r:.80}, expected a list of names")
    return doc


def read_recording(
    path: str | os.PathLike[str],
    *,
    time: str | None = None,
    columns: Sequence[str] | None = None,
    units: Mapping[str, str] | None = None,
    roles: Mapping[str, str] | None = None,
    experiment_id: str | None = None,
    source: str | None = None,
    meta: Mapping[str, Any] | None = None,
    delimiter: str | None = None,
    decimal: str | None = None,
    notes: list[str] | None = None,
) -> Recording:
    """Read a recording from CSV or Parquet.

    Parameters
    ----------
    path : str or path-like
        ``.csv``, ``.csv.gz`` or ``.parquet``; a CSV's metadata are read from
        ``<path>.meta.json`` when it exists.
    time : str, optional
        Name of the time column [s] in the file; it becomes ``time``. By
        default ``time``, else the one column called ``Time``, ``t``,
        ``time_s``, ... (:data:`TIME_NAMES`, any case). A date-time column
        becomes seconds from its first sample.
    columns : sequence of str, optional
        Columns to keep (others, e.g. text columns, are not converted); all
        when omitted.
    units, roles : mapping, optional
        Units and roles for files without metadata. They must agree with the
        file's metadata where both name a column.
    experiment_id, source : str, optional
        Override the stored values.
    meta : mapping, optional
        Merged over the stored ``meta``.
    delimiter : str, optional
        CSV field separator; detected when unambiguous (:func:`sniff_csv`),
        else ``,``.
    decimal : str, optional
        CSV decimal mark, ``.`` or ``,``; a decimal comma is detected.
    notes : list, optional
        Receives what was detected (delimiter, decimal mark, time column), in
        words, for the caller to show.

    Returns
    -------
    Recording

    Raises
    ------
    RecordingError
        Missing or empty file, unknown extension, unparsable CSV, no time
        column (the message lists the columns), a non-numeric cell (column,
        row and line), time not strictly increasing, corrupt sidecar or
        Parquet metadata, sidecar that does not match the file.
    UnitError
        ``units`` disagrees with the file's metadata.
    """
    if not isinstance(path, str | os.PathLike):
        raise RecordingError(
            f"the recording path is a {type(path).__name__} ({repr(path)[:60]}); expected a "
            "file name (str or pathlib.Path)"
        )
    path = Path(path)
    where = repr(str(path))
    if not path.exists():
        raise RecordingError(f"recording file {where} does not exist")
    if not path.is_file():
        raise RecordingError(f"recording path {where} is not a file")
    fmt = _file_format(path)
    if path.stat().st_size == 0:
        raise RecordingError(f"recording file {where} is empty (0 bytes)")
    found: list[str] = []
    skip = 0
    if fmt == "csv":
        try:
            check_encoding(path, f"recording file {where}")
            delimiter, decimal, found = sniff_csv(path, delimiter=delimiter, decimal=decimal)
            skip = leading_comments(head_lines(path, 200))
        except OSError as e:  # unreadable (permissions), a bad gzip stream, ...
            raise RecordingError(f"cannot read recording file {where}: {e}") from e
        if skip:
            found.append(f"skipped {skip} comment line(s) (# ...) before the header")
    try:
        if fmt == "csv":
            try:
                table = pa_csv.read_csv(
                    str(path),
                    read_options=pa_csv.ReadOptions(skip_rows=skip),
                    parse_options=pa_csv.ParseOptions(delimiter=delimiter),
                    convert_options=pa_csv.ConvertOptions(
                        strings_can_be_null=True, decimal_point=decimal or "."
                    ),
                )
            except pa.ArrowInvalid as e:
                raise RecordingError(
                    f"cannot read CSV file {where} ({str(e).splitlines()[0]}); "
                    + csv_parse_hint(path, delimiter or ",", decimal or ".")
                ) from e
            stored = _read_sidecar(path)
            line0: int | None = 2 + skip
        else:
            table = pq.read_table(str(path))
            raw = (table.schema.metadata or {}).get(_META_KEY.encode())
            stored = {}
            if raw is not None:
                try:
                    stored = json.loads(raw.decode("utf-8"))
                except (json.JSONDecodeError, UnicodeDecodeError) as e:
                    raise RecordingError(
                        f"the thermogym metadata of {where} are not valid JSON: {e}"
                    ) from e
                stored = _check_metadata_doc(stored, f"the thermogym metadata of {where}")
            line0 = None
    except pa.ArrowException as e:
        raise RecordingError(f"cannot read {fmt.upper()} file {where}: {e}") from e
    except OSError as e:
        raise RecordingError(f"cannot read recording file {where}: {e}") from e
    names = table.column_names
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise RecordingError(f"{where}: column(s) {dup} appear more than once in the header")
    if stored.get("columns") is not None and stored["columns"] != names:
        raise RecordingError(
            f"the metadata of {where} describe columns {stored['columns']}, but the file has "
            f"{names}; the sidecar belongs to another file: fix or delete it"
        )
    if len(names) == 1 and fmt == "csv":
        raise RecordingError(
            f"{where} reads as a single column {names[0][:60]!r}: "
            + csv_parse_hint(path, delimiter or ",", decimal or ".")
        )
    time, time_note = find_time_column(names, time, where)
    if time_note:
        found.append(time_note)
    if table.num_rows == 0:
        raise RecordingError(f"{where} has a header but no samples")
    rest = [n for n in names if n != time]
    if columns is not None:
        missing = [c for c in columns if c not in rest]
        if missing:
            raise RecordingError(f"{where} lacks column(s) {missing}; its columns are {rest}")
        rest = list(columns)
    tcol = table.column(time)
    if pa.types.is_timestamp(tcol.type) or pa.types.is_date(tcol.type):
        t = timestamp_seconds(tcol)
        found.append(f"converted the date-times of column {time!r} to seconds from the first")
    else:
        t = _arrow_column(time, tcol, where, line0)
    if notes is not None:
        notes.extend(found)
    items = [(n, _arrow_column(n, table.column(n), where, line0)) for n in rest]
    for key in ("units", "roles"):  # keep the labels of the columns taken
        labels = stored.get(key) or {}
        strange = [k for k in labels if k not in names and k != "time"]
        if strange:
            raise RecordingError(
                f"the metadata of {where} give {key} for column(s) {strange} that the file "
                f"lacks; its columns are {names}"
            )
        stored[key] = {k: v for k, v in labels.items() if k in rest or k == "time"}
    try:
        return Recording._from_parts(
            t,
            items,
            file_meta=stored,
            units=units,
            roles=roles,
            experiment_id=experiment_id,
            source=source,
            meta=meta,
            where=where,
        )
    except UnitError:
        raise
    except RecordingError as e:
        raise RecordingError(f"{where}: {e}") from e
