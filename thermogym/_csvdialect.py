"""CSV dialects of recordings from other tools: delimiter, decimal mark, time column.

Spreadsheets and loggers write CSV in many dialects: ``;`` with decimal commas
(European locales), tabs, comment lines before the header, a time column
called ``Time`` or ``t``, date-times instead of seconds. :func:`sniff_csv`
tells the delimiter and decimal mark from a file's first lines when they are
unambiguous; :func:`find_time_column` finds the time column; the hints say
what was tried and how to pass another. :mod:`thermogym.recording` reads
through them and reports what it detected in words.
"""

from __future__ import annotations

import gzip
import os
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
from numpy.typing import NDArray

from thermogym.errors import RecordingError

__all__ = [
    "CSV_DELIMITERS",
    "TIME_NAMES",
    "check_encoding",
    "csv_parse_hint",
    "find_time_column",
    "head_lines",
    "leading_comments",
    "sniff_csv",
    "timestamp_seconds",
]


#: Field separators tried when a CSV's delimiter is detected.
CSV_DELIMITERS: tuple[str, ...] = (",", ";", "\t", "|")
#: Time column names accepted (case-insensitively) when the file has no ``time`` column.
TIME_NAMES: tuple[str, ...] = ("time", "t", "time_s", "times", "time[s]", "time [s]", "time (s)")
_DECIMAL_COMMA = re.compile(r"^\s*[+-]?\d+,\d+(?:[eE][+-]?\d+)?\s*$")
_DECIMAL_POINT = re.compile(r"^\s*[+-]?\d*\.\d+(?:[eE][+-]?\d+)?\s*$")


def _shown_delimiter(d: str) -> str:
    return {"\t": "tab ('\\t')", ",": "comma (',')", ";": "semicolon (';')"}.get(d, repr(d))


def head_lines(path: Path, n: int = 30) -> list[str]:
    """The first ``n`` non-empty lines of a (possibly gzipped) text file."""
    opener: Any = gzip.open if path.name.lower().endswith(".gz") else open
    lines: list[str] = []
    try:
        with opener(path, "rt", encoding="utf-8", errors="replace", newline="") as f:
            for line in f:
                line = line.rstrip("\r\n")
                if line.strip():
                    lines.append(line)
                if len(lines) >= n:
                    break
    except (OSError, EOFError) as e:
        raise RecordingError(f"cannot read recording file {str(path)!r}: {e}") from e
    return lines


#: Byte-order marks of encodings other than UTF-8, longest first.
_BOMS: tuple[tuple[bytes, str], ...] = (
    (b"\xff\xfe\x00\x00", "UTF-32"),
    (b"\x00\x00\xfe\xff", "UTF-32"),
    (b"\xff\xfe", "UTF-16"),
    (b"\xfe\xff", "UTF-16"),
)


def check_encoding(path: str | os.PathLike[str], where: str | None = None) -> None:
    r"""Refuse a text file that is not UTF-8 (or ASCII), naming the encoding it looks like.

    Spreadsheets save "Unicode text" as UTF-16 and older tools write Latin-1
    or Windows-1252; read as UTF-8 they give garbled column names or parse
    errors far from the cause. The first 64 KiB are checked (a UTF-8
    byte-order mark is fine).

    Raises
    ------
    RecordingError
        The file starts with a UTF-16/32 byte-order mark, holds the NUL bytes
        of UTF-16/32 text, or bytes that are not UTF-8 (the first is named
        with its line); or it is gzip-compressed without a ``.gz`` name.

    Examples
    --------
    >>> import tempfile
    >>> f = Path(tempfile.mkdtemp()) / "r.csv"
    >>> _ = f.write_bytes("time,T\n0,20\n".encode("utf-16"))
    >>> try:
    ...     check_encoding(f)
    ... except RecordingError as e:
    ...     print(str(e).split(";")[0][-14:])
    is UTF-16 text
    """
    path = Path(path)
    where = where or f"recording file {str(path)!r}"
    opener: Any = gzip.open if path.name.lower().endswith(".gz") else open
    try:
        with opener(path, "rb") as f:
            head = f.read(65536)
    except (OSError, EOFError) as e:
        raise RecordingError(f"cannot read {where}: {e}") from e
    if head.startswith(b"\x1f\x8b") and opener is open:  # gzip's magic number
        raise RecordingError(
            f"{where} is gzip-compressed; expected plain text: name it {path.name + '.gz'!r} "
            "(read as compressed CSV) or decompress it"
        )
    save = "save it as UTF-8 (a spreadsheet's 'CSV UTF-8'; iconv -f {0} -t UTF-8)"
    for bom, name in _BOMS:
        if head.startswith(bom):
            raise RecordingError(f"{where} is {name} text; " + save.format(name))
    if b"\x00" in head:
        pairs = head[: len(head) - len(head) % 2]
        if pairs and (
            pairs[1::2].count(0) > len(pairs) // 4 or pairs[0::2].count(0) > len(pairs) // 4
        ):
            raise RecordingError(f"{where} looks like UTF-16 text; " + save.format("UTF-16"))
    try:
        head.decode("utf-8")
    except UnicodeDecodeError as e:
        if e.start < len(head) - 3:  # not just a character cut at the 64 KiB boundary
            line = head.count(b"\n", 0, e.start) + 1
            byte = head[e.start : e.start + 1].hex()
            raise RecordingError(
                f"{where} is not UTF-8 text: byte 0x{byte} on line {line} (Latin-1 or "
                "Windows-1252, e.g. a '°' or 'µ'?); " + save.format("LATIN1")
            ) from None


def sniff_csv(
    path: str | os.PathLike[str],
    *,
    delimiter: str | None = None,
    decimal: str | None = None,
) -> tuple[str, str, list[str]]:
    r"""Tell a CSV file's field delimiter and decimal mark from its first lines.

    A delimiter is detected only when it is unambiguous: exactly one of
    :data:`CSV_DELIMITERS` splits the header and the first rows into the same
    number (> 1) of fields. A decimal comma is detected when the delimiter is
    not a comma and the fields hold numbers such as ``21,5`` but none such as
    ``21.5``. Anything not detected falls back to ``,`` and ``.``.

    Parameters
    ----------
    path : path-like
        A ``.csv`` or ``.csv.gz`` file.
    delimiter, decimal : str, optional
        Given values are kept (and checked); ``None`` detects.

    Returns
    -------
    delimiter, decimal : str
    notes : list of str
        What was detected, in words (empty when the file is a plain CSV).

    Raises
    ------
    RecordingError
        A delimiter or decimal mark that is not one character, or a decimal
        comma with a comma delimiter.

    Examples
    --------
    >>> import tempfile
    >>> f = Path(tempfile.mkdtemp()) / "r.csv"
    >>> _ = f.write_text("time;T\n0;20,5\n1;21,0\n")
    >>> sniff_csv(f)[:2]
    (';', ',')
    """
    path = Path(path)
    for what, v in (("delimiter", delimiter), ("decimal mark", decimal)):
        if v is not None and (not isinstance(v, str) or len(v) != 1 or v in "\r\n\"'"):
            raise RecordingError(f"CSV {what} {v!r} is not a single character such as ',' or ';'")
    if decimal is not None and decimal not in ".,":
        raise RecordingError(f"decimal mark {decimal!r}; expected '.' or ','")
    notes: list[str] = []
    lines = head_lines(path) if (delimiter is None or decimal is None) else []
    lines = lines[leading_comments(lines) :]
    if delimiter is None:
        found = []
        for d in CSV_DELIMITERS:
            counts = {line.count(d) for line in lines}
            if len(counts) == 1 and next(iter(counts)) > 0:
                found.append(d)
        if len(found) == 1:
            delimiter = found[0]
        elif len(found) > 1 and "," in found:
            # a comma that splits every line evenly beside another candidate: take the
            # other one when the comma sits between digits (a decimal comma)
            rows = lines[1:]
            comma_in_numbers = rows and all(re.search(r"\d,\d", r) for r in rows)
            others = [d for d in found if d != ","]
            delimiter = others[0] if comma_in_numbers and len(others) == 1 else ","
        else:
            delimiter = ","
        if delimiter != ",":
            notes.append(f"detected the field delimiter {_shown_delimiter(delimiter)}")
    if decimal is None:
        decimal = "."
        if delimiter != ",":
            fields = [f for line in lines[1:] for f in line.split(delimiter)]
            if any(_DECIMAL_COMMA.match(f) for f in fields) and not any(
                _DECIMAL_POINT.match(f) for f in fields
            ):
                decimal = ","
                notes.append("detected decimal commas (21,5 read as 21.5)")
    if delimiter == decimal:
        raise RecordingError(
            f"the CSV delimiter and the decimal mark are both {delimiter!r}; a decimal-comma "
            "file needs another delimiter, e.g. ';'"
        )
    return delimiter, decimal, notes


def leading_comments(lines: Sequence[str]) -> int:
    """How many of the first lines are comments (``# ...``) before the header."""
    n = 0
    while n < len(lines) and lines[n].lstrip().startswith("#"):
        n += 1
    return n


def csv_parse_hint(path: Path, delimiter: str, decimal: str) -> str:
    """Why a CSV did not parse, in words: the delimiter tried and what the header suggests."""
    try:
        head = head_lines(path, 3)
    except RecordingError:
        head = []
    header = head[0] if head else ""
    others = [d for d in CSV_DELIMITERS if d != delimiter and d in header]
    hint = f"read with the delimiter {_shown_delimiter(delimiter)} and decimal mark {decimal!r}"
    if others:
        d = others[0]
        shown = "\\t" if d == "\t" else d
        hint += (
            f"; its header {header[:80]!r} looks {_shown_delimiter(d)}-separated: pass "
            f"--delimiter '{shown}' (read_recording(delimiter={d!r}))"
        )
        if any(re.search(r"\d,\d", line) for line in head[1:]):
            hint += " and --decimal ',' for decimal commas"
    else:
        hint += "; pass another with --delimiter (read_recording(delimiter=...))"
    return hint


def find_time_column(names: Sequence[str], time: str | None, where: str) -> tuple[str, str | None]:
    """The time column's name in the file, and a note when it was detected."""
    if time is not None:
        if time not in names:
            raise RecordingError(
                f"{where} has no time column {time!r}; its columns are {list(names)} (name it "
                "with --time-column NAME, read_recording(time=NAME))"
            )
        return time, None
    if "time" in names:
        return "time", None
    cands = [n for n in names if n.strip().lower() in TIME_NAMES]
    if len(cands) == 1:
        return cands[0], f"took column {cands[0]!r} as the time [s]"
    raise RecordingError(
        f"{where} has no time column 'time'"
        + (f" and several candidates {cands}" if cands else "")
        + f"; its columns are {list(names)}: name it with --time-column NAME "
        "(read_recording(time=NAME))"
    )


def timestamp_seconds(col: pa.ChunkedArray) -> NDArray[np.float64]:
    """Seconds from the first sample of a date-time column."""
    ns = col.cast(pa.timestamp("ns")).cast(pa.int64()).to_numpy(zero_copy_only=False)
    return (ns - ns[0]).astype(np.float64) * 1e-9
