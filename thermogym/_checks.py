"""Checks of user-facing values: one place for "a finite number in [lo, hi]".

Every public function and command that takes a number, a name from a list or an
array validates it here, so that the messages read alike everywhere: they name
the offending value, show it as the user wrote it (``30.0``, never
``np.float64(30.0)``) and say what was expected. Each check returns the value
converted to its Python type, so a call site reads
``dt = positive("dt", dt, unit="s")``.

This module sits at the bottom of the package beside :mod:`thermogym.errors`
(every layer, ``models`` included, may import it).

Examples
--------
>>> in_range("alpha", 0.05, 0.0, 1.0, lo_open=True, hi_open=True)
0.05
>>> positive("dt", 0.0, unit="s")
Traceback (most recent call last):
...
thermogym.errors.ParameterError: dt = 0.0 s, expected a finite number > 0 s
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from thermogym.errors import ParameterError, ShapeError, ThermogymError, UnknownNameError

__all__ = [
    "choice",
    "finite",
    "in_range",
    "integer",
    "nonnegative",
    "positive",
    "probability",
    "shape",
    "show",
    "with_unit",
]


#: Units that mean "dimensionless": shown as no unit at all (never "2 1").
DIMENSIONLESS = frozenset({"", "1", "-"})


def with_unit(text: str, unit: str | None) -> str:
    """``text`` followed by its unit after a space; nothing for a dimensionless unit.

    Examples
    --------
    >>> with_unit("2", "1"), with_unit("30", "K")
    ('2', '30 K')
    """
    u = (unit or "").strip()
    return text if u in DIMENSIONLESS else f"{text} {u}"


def show(value: Any, unit: str = "") -> str:
    """A value as a user would write it, with its unit after a space.

    Examples
    --------
    >>> show(np.float64(30.0), "K")
    '30.0 K'
    >>> show("abc")
    "'abc'"
    >>> show(2.0, "1")
    '2.0'
    """
    if isinstance(value, np.generic):
        value = value.item()
    return with_unit(repr(value), unit)


def _number(
    name: str,
    value: Any,
    unit: str,
    expected: str,
    error: type[ThermogymError],
    text: bool = True,
) -> float:
    kinds = (numbers.Real, str, np.generic) if text else (numbers.Real,)
    if isinstance(value, bool | np.bool_) or not isinstance(value, kinds):
        raise error(f"{name} = {show(value, unit)}, expected {expected}")
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise error(f"{name} = {show(value, unit)}, expected {expected}") from None
    if not math.isfinite(x):
        raise error(f"{name} = {show(value, unit)}, expected {expected}")
    return x


def finite(
    name: str,
    value: Any,
    *,
    unit: str = "",
    error: type[ThermogymError] = ParameterError,
    text: bool = True,
) -> float:
    """``value`` as a finite float, or ``error`` naming it.

    ``text=False`` refuses a number written as text (keyword arguments of the
    Python API, where ``"2.5"`` is a mistake rather than a command-line value).

    Examples
    --------
    >>> finite("gain", "2.5")
    2.5
    >>> finite("gain", "2.5", text=False)
    Traceback (most recent call last):
    ...
    thermogym.errors.ParameterError: gain = '2.5', expected a finite number
    """
    return _number(name, value, unit, "a finite number", error, text)


def in_range(
    name: str,
    value: Any,
    lo: float = -math.inf,
    hi: float = math.inf,
    *,
    lo_open: bool = False,
    hi_open: bool = False,
    unit: str = "",
    error: type[ThermogymError] = ParameterError,
    text: bool = True,
) -> float:
    """``value`` as a finite float inside ``[lo, hi]`` (ends open on request).

    Parameters
    ----------
    name : str
        What the value is called where the user gave it (option, key, argument).
    value : number or str
        The value to check.
    lo, hi : float
        Bounds; infinite bounds are left out of the message.
    lo_open, hi_open : bool
        Exclude the bound itself.
    unit : str
        Unit shown after the value and the bounds.
    error : type
        Exception class to raise (a :class:`~thermogym.errors.ThermogymError`).
    text : bool
        Accept a number written as text (``"5"``); ``False`` for keyword
        arguments of the Python API.

    Examples
    --------
    >>> in_range("tau", 5, 0.0, 10.0, unit="s")
    5.0
    >>> in_range("alpha", 2, 0.0, 1.0, lo_open=True, hi_open=True)
    Traceback (most recent call last):
    ...
    thermogym.errors.ParameterError: alpha = 2, expected a finite number in (0, 1)
    """
    u = f" {unit}" if unit else ""
    lo_s, hi_s = f"{lo:g}", f"{hi:g}"
    if math.isinf(lo) and math.isinf(hi):
        expected = "a finite number"
    elif math.isinf(hi):
        expected = f"a finite number {'>' if lo_open else '>='} {lo_s}{u}"
    elif math.isinf(lo):
        expected = f"a finite number {'<' if hi_open else '<='} {hi_s}{u}"
    else:
        expected = (
            f"a finite number in {'(' if lo_open else '['}{lo_s}, {hi_s}{')' if hi_open else ']'}"
            f"{u}"
        )
    x = _number(name, value, unit, expected, error, text)
    if x < lo or x > hi or (lo_open and x == lo) or (hi_open and x == hi):
        raise error(f"{name} = {show(value, unit)}, expected {expected}")
    return x


def positive(
    name: str,
    value: Any,
    *,
    unit: str = "",
    error: type[ThermogymError] = ParameterError,
    text: bool = True,
) -> float:
    """``value`` as a finite float > 0.

    Examples
    --------
    >>> positive("dt", 0.5, unit="s")
    0.5
    """
    return in_range(name, value, 0.0, lo_open=True, unit=unit, error=error, text=text)


def nonnegative(
    name: str,
    value: Any,
    *,
    unit: str = "",
    error: type[ThermogymError] = ParameterError,
    text: bool = True,
) -> float:
    """``value`` as a finite float >= 0.

    Examples
    --------
    >>> nonnegative("noise", 0)
    0.0
    """
    return in_range(name, value, 0.0, unit=unit, error=error, text=text)


def probability(
    name: str, value: Any, *, error: type[ThermogymError] = ParameterError, text: bool = True
) -> float:
    """A significance level or fraction strictly between 0 and 1.

    Examples
    --------
    >>> probability("alpha", 0.01)
    0.01
    """
    return in_range(name, value, 0.0, 1.0, lo_open=True, hi_open=True, error=error, text=text)


def integer(
    name: str,
    value: Any,
    lo: int | None = None,
    hi: int | None = None,
    *,
    error: type[ThermogymError] = ParameterError,
) -> int:
    """``value`` as an int in ``[lo, hi]`` (a float is accepted only when whole).

    Examples
    --------
    >>> integer("folds", "3", lo=2)
    3
    >>> integer("folds", 1, lo=2)
    Traceback (most recent call last):
    ...
    thermogym.errors.ParameterError: folds = 1, expected a whole number >= 2
    """
    if lo is not None and hi is not None:
        expected = f"a whole number in [{lo}, {hi}]"
    elif lo is not None:
        expected = f"a whole number >= {lo}"
    elif hi is not None:
        expected = f"a whole number <= {hi}"
    else:
        expected = "a whole number"
    if isinstance(value, bool):
        raise error(f"{name} = {show(value)}, expected {expected}")
    if isinstance(value, str):
        try:
            n = int(value.strip())
        except ValueError:
            raise error(f"{name} = {show(value)}, expected {expected}") from None
    elif isinstance(value, numbers.Integral):
        n = int(value)
    elif isinstance(value, numbers.Real) and math.isfinite(float(value)):
        if float(value) != math.trunc(value):
            raise error(f"{name} = {show(value)}, expected {expected}")
        n = int(float(value))  # exact: float(value) equals the whole number trunc(value)
    else:
        raise error(f"{name} = {show(value)}, expected {expected}")
    if (lo is not None and n < lo) or (hi is not None and n > hi):
        raise error(f"{name} = {show(value)}, expected {expected}")
    return n


def choice(
    name: str,
    value: Any,
    choices: Iterable[str],
    *,
    error: type[ThermogymError] = UnknownNameError,
) -> str:
    """``value`` if it is one of ``choices``, else ``error`` listing them.

    Examples
    --------
    >>> choice("x0", "estimate", ("zero", "steady", "estimate"))
    'estimate'
    """
    options = list(choices)
    if not isinstance(value, str) or value not in options:
        raise error(f"{name} = {show(value)}, expected one of {options}")
    return value


def shape(
    name: str,
    array: Any,
    expected: Sequence[int | None],
    *,
    dtype: type = float,
    finite_values: bool = False,
) -> NDArray[Any]:
    """``array`` as an ndarray of the expected shape (``None`` matches any length).

    Examples
    --------
    >>> shape("u", np.zeros((10, 2)), (None, 2)).shape
    (10, 2)
    >>> shape("u", np.zeros((10, 3)), (None, 2))
    Traceback (most recent call last):
    ...
    thermogym.errors.ShapeError: u has shape (10, 3), expected (N, 2)
    """
    try:
        a: NDArray[Any] = np.asarray(array, dtype=dtype)
    except (TypeError, ValueError) as e:
        raise ShapeError(f"{name} cannot be read as an array of {dtype.__name__}: {e}") from e
    want = "(" + ", ".join("N" if n is None else str(n) for n in expected)
    want += ",)" if len(expected) == 1 else ")"
    if a.ndim != len(expected) or any(
        n is not None and n != m for n, m in zip(expected, a.shape, strict=True)
    ):
        raise ShapeError(f"{name} has shape {a.shape}, expected {want}")
    if finite_values and a.size and not np.all(np.isfinite(a)):
        bad = np.argwhere(~np.isfinite(a))[0]
        raise ShapeError(
            f"{name} holds a non-finite value at index {tuple(int(i) for i in bad)}; "
            "expected finite numbers"
        )
    return a
