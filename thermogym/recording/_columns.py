"""Checks of a recording's columns: names, values, the time axis and units.

The validation :class:`~thermogym.recording.Recording` applies to what it is
given (identifier names, real float64 values, a finite strictly increasing time
axis) and the spellings of one unit taken as equal (``degC`` and ``°C``), with
the roles a column may carry.
"""

from __future__ import annotations

import datetime as dt
import re
from collections.abc import Iterable
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from thermogym.errors import RecordingError

__all__ = ["ROLES"]

#: Roles a column may carry (those of :class:`thermogym.models.base.Signal`).
ROLES: tuple[str, ...] = ("input", "disturbance", "output")

_NAME_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
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


# Units that say nothing: a raw CSV without a sidecar gives its columns no unit, and a
# FitResult identified from one stores "1" for its signals. Such a side cannot be checked
# against the other, so it is not a conflict.
_UNSPECIFIED_UNITS = frozenset({"1", "?", "unknown", "none", "n/a"})


#: The lowest value a temperature takes (absolute zero), per canonical unit.
_ABSOLUTE_ZERO = {"°C": -273.15, "K": 0.0}


def _absolute_zero(unit: str | None) -> float | None:
    """Absolute zero in ``unit`` when it is a temperature unit (``°C``, ``K``), else None."""
    return None if unit is None else _ABSOLUTE_ZERO.get(_canonical_unit(unit))


def _unit_unspecified(unit: str | None) -> bool:
    """Whether ``unit`` says nothing (missing, empty, ``"1"``, ``"-"``, ``"unknown"``)."""
    return unit is None or _canonical_unit(unit).lower() in _UNSPECIFIED_UNITS


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
    """``repr`` of a value as a file wrote it.

    Numpy scalars as the Python value they hold, a date or a time of day as its text
    (``'08:00:00'``, not ``datetime.time(8, 0)``).
    """
    v = v.item() if isinstance(v, np.generic) else v
    return repr(v.isoformat()) if isinstance(v, dt.date | dt.time) else repr(v)


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
