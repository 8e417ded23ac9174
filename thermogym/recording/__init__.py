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

from thermogym._csvdialect import CSV_DELIMITERS, TIME_NAMES, sniff_csv
from thermogym.recording._columns import ROLES
from thermogym.recording._files import (
    CSV_SUFFIXES,
    PARQUET_SUFFIXES,
    read_recording,
    sidecar_path,
    write_recording,
)
from thermogym.recording._recording import Recording

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
