"""The :class:`Recording` class: a time axis, float columns and their metadata.

Construction and its checks (through :mod:`thermogym.recording._columns`),
derived recordings (select, slice, with_columns, ...), the arrays a model takes,
pandas conversion and the fingerprint FitResults store. Files are read and
written by :mod:`thermogym.recording._files`.
"""

from __future__ import annotations

import copy as _copy
import hashlib
import math
from collections.abc import Iterable, Iterator, Mapping, Sequence
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from thermogym.errors import RecordingError, ThermogymError, UnitError, UnknownNameError
from thermogym.recording._columns import (
    _UNSET,
    ROLES,
    _absolute_zero,
    _as_float_column,
    _canonical_unit,
    _check_name,
    _check_time,
    _first_true,
    _fmt_names,
    _readonly,
    _unit_unspecified,
)

if TYPE_CHECKING:
    from thermogym.models.base import Model, Simulation

__all__ = ["Recording"]

_META_KEY = "thermogym"


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
    ) -> tuple[str, ...]:
        """Check that this recording has the columns and units ``model`` needs.

        Parameters
        ----------
        model : Model
            A model from :func:`thermogym.models.registry.get_model`.
        outputs : bool or sequence of str
            Also require the model outputs (all of them, or the names given).
        finite : bool
            Also require finite values in those columns (:meth:`check_values`).

        Returns
        -------
        tuple of str
            The needed columns whose units could not be checked because one
            side leaves the unit unspecified (see :meth:`check_units`); empty
            when every unit given on both sides agrees.

        Raises
        ------
        RecordingError
            Columns are missing; the message lists them, the names the model
            expects and the columns the recording has.
        UnitError
            A column's unit in the metadata differs from the model's (a column
            without a unit, or a model signal in ``"1"``, is accepted).
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
        unchecked = self.check_units({s.name: s.unit for s in needed}, f"model {model.name!r}")
        if finite:
            self.check_values([s.name for s in needed])
        return unchecked

    def check_temperatures(
        self, expected: Mapping[str, str | None] | None = None, owner: str = ""
    ) -> None:
        """Refuse a temperature below absolute zero (a sensor's error code, another unit).

        A column is a temperature when its unit is ``°C`` or ``K`` (any spelling
        of them): its own unit, or for a column without one the unit in
        ``expected``. Missing samples (NaN) are skipped.

        Parameters
        ----------
        expected : mapping, optional
            Column name → the unit a model or fit expects for it, taken for the
            columns whose own unit is unspecified; only these columns are
            checked (all when omitted).
        owner : str
            Who expects those units, for the message (``"model 'strut'"``).

        Raises
        ------
        UnitError
            Naming the column, the first such value, its row and time, and the unit.

        Examples
        --------
        >>> import numpy as np
        >>> rec = Recording(np.arange(3.0), {"T": [20.0, -9999.0, 21.0]})
        >>> rec.check_temperatures()  # no unit: not known to be a temperature
        >>> rec.check_temperatures({"T": "degC"}, "model 'm'")  # doctest: +ELLIPSIS
        Traceback (most recent call last):
        ...
        thermogym.errors.UnitError: column 'T' of recording holds -9999 at row 1 ...
        """
        names = self._data if expected is None else [n for n in expected if n in self._data]
        for name in names:
            v = self._data[name]
            unit, whose = self._units.get(name), "its unit"
            if _unit_unspecified(unit) and expected is not None:
                unit, whose = expected.get(name), f"the unit {owner} expects"
            lo = _absolute_zero(unit)
            if lo is None:
                continue
            bad = v < lo - 1e-9 * max(1.0, abs(lo))  # NaN compares False
            if bad.any():
                i = _first_true(bad)
                raise UnitError(
                    f"column {name!r} of recording{self._label()} holds {float(v[i]):g} at row {i} "
                    f"(time {float(self._time[i]):g} s), below absolute zero ({lo:g} {unit}, "
                    f"{whose}); expected a temperature in {unit}: a sensor's error code (leave a "
                    "missing sample empty) or a column in another unit (give its unit in the "
                    ".meta.json sidecar)?"
                )

    def check_units(self, expected: Mapping[str, str | None], owner: str) -> tuple[str, ...]:
        """Check the units of columns against the units a model or fit expects.

        A unit that says nothing (none given, ``""``, ``"-"``, ``"1"`` as a
        FitResult identified from a CSV without units stores, ``"unknown"``)
        on either side cannot be checked and is accepted; a real conflict
        (``"°C"`` against ``"K"``, ``"%"`` against ``"W"``) is refused.

        Parameters
        ----------
        expected : mapping
            Column name → the unit expected for it; names that are not
            columns of this recording are skipped.
        owner : str
            Who expects the units, for the message (``"model 'ss'"``).

        Returns
        -------
        tuple of str
            The columns whose units were not checked because exactly one side
            gives a unit (the other leaves it unspecified), in the order of
            ``expected``.

        Raises
        ------
        UnitError
            A column's unit differs from the one expected; the message names
            the column, both units and ``owner``. Or a temperature (``°C``,
            ``K`` on either side) is below absolute zero
            (:meth:`check_temperatures`).

        Examples
        --------
        >>> import numpy as np
        >>> rec = Recording(np.arange(3.0), {"Q1": [0.0, 50.0, 50.0]}, units={"Q1": "%"})
        >>> rec.check_units({"Q1": "1"}, "model 'ss'")
        ('Q1',)
        >>> rec.check_units({"Q1": "%"}, "model 'ss'")
        ()
        """
        unchecked = []
        for name, want in expected.items():
            if name not in self._data:
                continue
            have = self._units.get(name)
            if have is None or want is None or _unit_unspecified(have) or _unit_unspecified(want):
                if not (_unit_unspecified(have) and _unit_unspecified(want)):
                    unchecked.append(name)
            elif _canonical_unit(have) != _canonical_unit(want):
                raise UnitError(
                    f"column {name!r} of recording{self._label()} is in {have!r}, {owner} "
                    f"expects {want!r}"
                )
        self.check_temperatures(expected, owner)  # a unit known on either side
        return tuple(unchecked)

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
            # the registry loads the models (~0.3 s): only for a simulation that names its model
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
