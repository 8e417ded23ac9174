"""Reading the recordings a command names, and its ``--prepare`` steps.

The options and the recording syntax they accept: :mod:`thermogym._cli.data`.
"""

from __future__ import annotations

import argparse
import ast
import json
import math
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

# read_recording and datasets.load are looked up in their modules when called, so that a
# replacement there is used (the tests that check bad input is refused before any work)
from thermogym import datasets, recording
from thermogym._checks import in_range, integer
from thermogym.errors import ConfigError, RecordingError, UnitError
from thermogym.identification.prepare import _DETREND_KINDS, _RESAMPLE_METHODS, resample
from thermogym.identification.prepare import prepare as run_prepare
from thermogym.recording import CSV_SUFFIXES, PARQUET_SUFFIXES

__all__ = [
    "JITTER_TOL",
    "check_units",
    "load_recordings",
    "parse_prepare",
    "recording_inputs",
    "regularise",
]


#: Largest relative deviation of a time step from the median step still treated as
#: timestamp jitter (resampled with a note); TCLab logs show 2 %.
JITTER_TOL = 0.10


def _as_bool(key: str, v: Any) -> bool:
    if isinstance(v, bool):
        return v
    if isinstance(v, str) and v.lower() in ("true", "false", "yes", "no", "on", "off"):
        return v.lower() in ("true", "yes", "on")
    if isinstance(v, int) and v in (0, 1):
        return bool(v)
    raise ConfigError(f"--prepare {key}={v!r}: expected true or false")


def _as_number(key: str, v: Any, lo: float, *, open_: bool, whole: bool = False) -> Any:
    if isinstance(v, bool) or not isinstance(v, int | float):
        raise ConfigError(f"--prepare {key}={v!r}: expected a number")
    if whole:
        least = math.floor(lo) + 1 if open_ else math.ceil(lo)
        return integer(f"--prepare {key}", v, lo=least, error=ConfigError)
    return in_range(f"--prepare {key}", v, lo, lo_open=open_, error=ConfigError, text=False)


def _as_names(key: str, v: Any) -> tuple[str, ...]:
    items = [v] if isinstance(v, str) else v
    if (
        not isinstance(items, list | tuple)
        or not items
        or not all(isinstance(s, str) and s.strip() for s in items)
    ):
        raise ConfigError(f"--prepare {key}={v!r}: expected column names, e.g. {key}=[T1,T2]")
    return tuple(s.strip() for s in items)


def _as_range(key: str, v: Any) -> tuple[float, float]:
    if isinstance(v, str):
        parts = v.replace(":", ",").split(",")
        try:
            v = [float(x) for x in parts]
        except ValueError:
            raise ConfigError(f"--prepare {key}={v!r}: expected LO:HI, two numbers") from None
    if (
        not isinstance(v, list | tuple)
        or len(v) != 2
        or not all(isinstance(x, int | float) and not isinstance(x, bool) for x in v)
        or not all(math.isfinite(x) for x in v)
        or not v[0] < v[1]
    ):
        raise ConfigError(f"--prepare {key}={v!r}: expected LO:HI with LO < HI")
    return float(v[0]), float(v[1])


def _prepare_checks() -> dict[str, Callable[[str, Any], Any]]:
    def one_of(options: Sequence[str], none: bool = False) -> Callable[[str, Any], Any]:
        def check(key: str, v: Any) -> Any:
            if none and (v is None or (isinstance(v, str) and v.lower() == "none")):
                return None
            if v not in options:
                extra = " or none" if none else ""
                raise ConfigError(f"--prepare {key}={v!r}: expected one of {list(options)}{extra}")
            return v

        return check

    def optional(check: Callable[[str, Any], Any]) -> Callable[[str, Any], Any]:
        def wrapped(key: str, v: Any) -> Any:
            if v is None or (isinstance(v, str) and v.lower() == "none"):
                return None
            return check(key, v)

        return wrapped

    def name(key: str, v: Any) -> str:
        if not isinstance(v, str) or not v.strip():
            raise ConfigError(f"--prepare {key}={v!r}: expected a column name")
        return v.strip()

    return {
        "columns": optional(_as_names),
        "outliers": _as_bool,
        "outlier_columns": optional(_as_names),
        "hampel_window": lambda k, v: _as_number(k, v, 1, open_=False, whole=True),
        "hampel_sigma": lambda k, v: _as_number(k, v, 0, open_=True),
        "valid_range": optional(_as_range),
        "dt": optional(lambda k, v: _as_number(k, v, 0, open_=True)),
        "resample_method": one_of(_RESAMPLE_METHODS),
        "max_gap_s": lambda k, v: _as_number(k, v, 0, open_=False),
        "align": _as_bool,
        "ambient": optional(name),
        "ambient_columns": optional(_as_names),
        "drop_ambient": _as_bool,
        "detrend": one_of(_DETREND_KINDS, none=True),
        "detrend_columns": optional(_as_names),
    }


def parse_prepare(items: Sequence[str] | None) -> dict[str, Any] | None:
    """``--prepare KEY=VALUE ...`` as checked options of ``prepare`` (None: not given).

    Raises
    ------
    ConfigError
        An item that is not ``KEY=VALUE``, an unknown key, or a value of the
        wrong type or range (the message names it).

    Examples
    --------
    >>> parse_prepare(["ambient=T_amb", "valid_range=-50:300", "dt=1"])
    {'ambient': 'T_amb', 'valid_range': (-50.0, 300.0), 'dt': 1.0}
    """
    if items is None:
        return None
    checks = _prepare_checks()
    out: dict[str, Any] = {}
    for item in items:
        key, sep, value = item.partition("=")
        key = key.strip()
        if not sep or not key.isidentifier():
            hint = (
                "; recordings go before --prepare, or end its list with --"
                if Path(item).exists() or item.startswith("dataset:")
                else ""
            )
            raise ConfigError(f"--prepare {item!r} is not of the form KEY=VALUE{hint}")
        if key not in checks:
            raise ConfigError(
                f"--prepare {key!r} is not a preparation option; options are {sorted(checks)}"
            )
        if key in out:
            raise ConfigError(f"--prepare {key} is given twice ({item!r}); give it once")
        try:
            v: Any = ast.literal_eval(value.strip())
        except (ValueError, SyntaxError, MemoryError, RecursionError):
            v = value.strip()
        out[key] = checks[key](key, v)
    return out


# ------------------------------------------------------------------------------ reading
def _files_of(folder: Path, what: str) -> list[Path]:
    manifest = folder / "manifest.json"
    if manifest.is_file():
        where = f"{what} folder {str(folder)!r}: its manifest.json"
        shape = 'expected {"recordings": [{"file": NAME, ...}, ...]}, one entry per recording'
        try:
            doc = json.loads(manifest.read_text(encoding="utf-8"))
        except (ValueError, UnicodeDecodeError) as e:
            raise RecordingError(f"{where} cannot be read ({e}); fix or delete it") from e
        entries = doc.get("recordings") if isinstance(doc, dict) else None
        if not isinstance(entries, list) or not all(
            isinstance(e, dict) and isinstance(e.get("file"), str) and e["file"].strip()
            for e in entries
        ):
            raise RecordingError(f"{where} does not list recordings as {shape}; fix or delete it")
        if not entries:
            raise RecordingError(f"{where} lists no recording; {shape}")
        files = [folder / e["file"] for e in entries]
        names = [e["file"] for e in entries]
        twice = sorted({n for n in names if names.count(n) > 1})
        if twice:
            raise RecordingError(
                f"{where} lists {twice} more than once; expected each recording once"
            )
        missing = [str(f) for f in files if not f.is_file()]
        if missing:
            raise RecordingError(
                f"{what} folder {str(folder)!r}: manifest.json lists {missing[:3]}, which do "
                "not exist"
            )
        return files
    files = sorted(
        f
        for f in folder.iterdir()
        if f.is_file() and f.name.lower().endswith((*CSV_SUFFIXES, *PARQUET_SUFFIXES))
    )
    if not files:
        raise RecordingError(f"{what} folder {str(folder)!r} holds no CSV or Parquet recording")
    return files


def regularise(rec: Any, label: str, say: Callable[[str], None] = print) -> Any:
    """``rec`` itself when uniform; resampled with a note when its steps only jitter.

    Steps within :data:`JITTER_TOL` of the mean step are timestamp jitter: the
    recording is interpolated (linearly, each channel from its own samples)
    onto the grid of the mean step rounded to 3 significant digits, starting
    at the first sample.
    """
    if rec.n_samples < 3 or rec.is_uniform():
        return rec
    d = np.diff(rec.time)
    mean = float((rec.time[-1] - rec.time[0]) / (rec.n_samples - 1))
    spread = float(np.max(np.abs(d - mean)) / mean)
    if spread > JITTER_TOL:
        return rec
    dt = float(f"{mean:.3g}")
    out, _ = resample(rec, dt, t_start=float(rec.time[0]))
    say(
        f"note: {label}: time steps vary by up to {100 * spread:.2g} % around {mean:.4g} s "
        f"(timestamp jitter); resampled onto a uniform {dt:g} s grid by linear interpolation "
        f"({out.n_samples} samples)"
    )
    return out


def _check_finite(rec: Any, label: str) -> None:
    """Refuse what no sensor records (NaN is a missing sample).

    ±inf, a single sample, and a temperature below absolute zero where the file gives
    the column a unit (``°C``, ``K``: a logger's error code such as -9999).
    """
    if rec.n_samples < 2:
        raise RecordingError(
            f"recording {label!r} has a single sample; a recording needs at least 2"
        )
    for c in rec.columns:
        x = rec[c]
        bad = np.isinf(x)
        if bad.any():
            i = int(np.argmax(bad))
            raise RecordingError(
                f"recording {label!r}: column {c!r} holds {float(x[i])} at row {i} (time "
                f"{float(rec.time[i]):g} s); expected finite values (an empty field for a "
                "missing sample)"
            )
    try:
        rec.check_temperatures()
    except UnitError as e:
        raise UnitError(f"{label!r}: {e}") from e


def recording_inputs(items: Sequence[str] | None) -> list[str]:
    """The paths among recording items (``dataset:NAME`` left out), for the output guard."""
    return [s for s in (items or []) if not str(s).startswith("dataset:")]


def load_recordings(
    items: Sequence[Any],
    what: str = "input",
    args: argparse.Namespace | None = None,
    *,
    prepare: dict[str, Any] | None = None,
    jitter: bool = True,
    say: Callable[[str], None] = print,
) -> list[Any]:
    """Read recordings from files, folders and ``dataset:NAME`` items.

    Parameters
    ----------
    items : sequence
        Paths or ``dataset:NAME``.
    what : str
        What they are, for messages (``"training"``).
    args : argparse.Namespace, optional
        Parsed options; ``time_column``, ``delimiter`` and ``decimal`` are used
        when present (:func:`add_data_options`).
    prepare : dict, optional
        Options of :func:`thermogym.identification.prepare.prepare`
        (:func:`parse_prepare`); applied to each recording.
    jitter : bool
        Resample recordings whose time steps only jitter (:func:`regularise`).
    say : callable
        Where notes go.

    Returns
    -------
    list of Recording
        Each with an experiment id (the file's stem when the file has none).

    Raises
    ------
    RecordingError
        A path that does not exist, an empty folder, a file that cannot be read.
    UnknownNameError
        An unknown data set.
    """
    time = getattr(args, "time_column", None)
    delimiter = getattr(args, "delimiter", None)
    decimal = getattr(args, "decimal", None)
    recs = []
    for item in items:
        text = str(item)
        if text.startswith("dataset:"):
            name = text.split(":", 1)[1]
            got = [(datasets.load(name), text)]
        else:
            path = Path(text)
            if path.is_dir():
                files = _files_of(path, what)
            elif path.exists():
                files = [path]
            else:
                raise RecordingError(f"{what} recording {text!r} does not exist")
            got = []
            for f in files:
                notes: list[str] = []
                rec = recording.read_recording(
                    f, time=time, delimiter=delimiter, decimal=decimal, notes=notes
                )
                for n in notes:
                    say(f"note: {f}: {n}")
                if rec.experiment_id is None:
                    rec = rec.replace(experiment_id=f.name.split(".")[0])
                got.append((rec, str(f)))
        for rec, label in got:
            _check_finite(rec, label)
            if prepare is not None:
                rec = run_prepare(rec, **prepare)
            if jitter:
                rec = regularise(rec, label, say)
            recs.append(rec)
    return recs


def check_units(
    rec: Any,
    expected: Mapping[str, str | None],
    owner: str,
    say: Callable[[str], None] = print,
) -> None:
    """Check a recording's units against a model's or fit's, noting what was not checked.

    Parameters
    ----------
    rec : Recording
        The recording read.
    expected : mapping
        Column name → the unit the model or fit expects (``"1"`` or none:
        unspecified).
    owner : str
        Who expects them, for messages (``"model 'ss'"``).
    say : callable
        Where the note goes.

    Raises
    ------
    UnitError
        A real conflict (``"°C"`` against ``"K"``), naming the column and both units.
    """
    unchecked = rec.check_units(expected, owner)
    if not unchecked:
        return

    def shown(unit: str | None) -> str:
        return repr(unit) if unit and unit.strip() not in ("1", "-") else "unspecified"

    parts = ", ".join(
        f"{n!r} (recording {shown(rec.units.get(n))}, {owner} {shown(expected.get(n))})"
        for n in unchecked
    )
    label = rec.experiment_id or "recording"
    say(f"note: {label}: units not checked for {parts}: one side gives no unit")
