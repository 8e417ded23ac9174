"""Reading and writing recordings: CSV (with a JSON sidecar) and Parquet.

Both formats are written atomically (:mod:`thermogym._fileio`) and read and
written column-wise through pyarrow; a CSV's delimiter, decimal mark and time
column are detected (:mod:`thermogym._csvdialect`). The metadata document (the
sidecar, or the Parquet schema metadata) is checked before it is trusted.
"""

from __future__ import annotations

import gzip
import json
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.csv as pa_csv
import pyarrow.parquet as pq

from thermogym._csvdialect import (
    check_encoding,
    csv_parse_hint,
    find_time_column,
    head_lines,
    leading_comments,
    sniff_csv,
    timestamp_seconds,
)
from thermogym._fileio import atomic_write_many, to_jsonable
from thermogym.errors import RecordingError, UnitError
from thermogym.recording._columns import _first_true, _show
from thermogym.recording._recording import _META_KEY, Recording

__all__ = [
    "CSV_SUFFIXES",
    "PARQUET_SUFFIXES",
    "read_recording",
    "sidecar_path",
    "write_recording",
]

#: File name endings read and written as CSV.
CSV_SUFFIXES: tuple[str, ...] = (".csv", ".csv.gz")
#: File name endings read and written as Parquet.
PARQUET_SUFFIXES: tuple[str, ...] = (".parquet", ".pq")

_SIDECAR_FORMAT = "thermogym.recording"
_SIDECAR_VERSION = 1
_SIDECAR_KEYS = frozenset(
    {"format", "version", "columns", "units", "roles", "experiment_id", "source", "meta"}
)


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
    if pa.types.is_time(t):  # 08:00:00 without a date: no order across midnight
        hint = "; times of day: give seconds, or date-times with the date (2024-03-01 08:00:00)"
    elif pa.types.is_boolean(t):
        hint = "; true/false: give 1/0"
    elif i == 0 and line0 is not None and (pa.types.is_string(t) or pa.types.is_large_string(t)):
        hint = "; a units row under the header? remove it (units go into the .meta.json sidecar)"
    else:
        hint = ""
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
    except UnitError as e:
        if where in str(e):  # a conflict of the sidecar with ``units=`` names the file
            raise
        raise UnitError(f"{where}: {e}") from e  # e.g. a unit of 'time' other than s
    except RecordingError as e:
        raise RecordingError(f"{where}: {e}") from e
