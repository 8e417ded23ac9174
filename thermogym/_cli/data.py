"""Recordings into a command: files, folders, ``dataset:NAME``; CSV dialect; jitter.

Every command that takes a recording reads it through :func:`load_recordings`
and declares the reading options with :func:`add_data_options`, so the same
things are accepted everywhere:

* a CSV or Parquet file, a folder of them (its ``manifest.json`` when there
  is one), or ``dataset:NAME`` for a shipped data set
  (``thermogym.datasets.dataset_names()``);
* ``--time-column NAME`` (default ``time``, else one column called ``Time``,
  ``t``, ``time_s``, ... is taken, with a note), ``--delimiter`` and
  ``--decimal`` (detected when unambiguous, with a note);
* ``--prepare KEY=VALUE ...`` (where the command offers it): the preparation
  pipeline of :func:`thermogym.identification.prepare.prepare`, its values
  checked before any file is read;
* values no sensor records are refused: ±inf, a single sample (NaN, an empty
  field, is a missing sample);
* timestamp jitter: time steps that vary by up to :data:`JITTER_TOL` around
  their mean are resampled onto the uniform grid of the mean step (linear
  interpolation) with a note; a recording more irregular than that is left
  as it is for the method to refuse with its own message.

Notes go to standard output as ``note: FILE: ...`` (errors alone go to
standard error).
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path

PREPARE_HELP = (
    "prepare raw data first (outliers, uniform grid, gaps, alignment, ambient); options of "
    "thermogym.identification.prepare.PrepareConfig, e.g. ambient=T_amb valid_range=-50:300 "
    "dt=1 (end the list with -- when recordings follow)"
)


def _delimiter(text: str) -> str:
    named = {"tab": "\t", "\\t": "\t", "comma": ",", "semicolon": ";", "pipe": "|", "space": " "}
    d = named.get(text.lower(), text)
    if len(d) != 1 or d in "\r\n\"'.":
        raise argparse.ArgumentTypeError(
            f"{text!r} is not a field delimiter; expected one character such as ',' or ';' "
            "(or tab, semicolon)"
        )
    return d


def add_data_options(p: argparse.ArgumentParser) -> None:
    """Declare ``--time-column``, ``--delimiter`` and ``--decimal``."""
    g = p.add_argument_group("reading recordings (CSV)")
    g.add_argument(
        "--time-column",
        metavar="NAME",
        help="time column [s] of the files (default: 'time', else a single column named "
        "Time, t, time_s, ...)",
    )
    g.add_argument(
        "--delimiter",
        type=_delimiter,
        help="CSV field delimiter: ',' ';' tab ... (default: detected when unambiguous)",
    )
    g.add_argument(
        "--decimal",
        choices=(".", ","),
        help="CSV decimal mark (default: a decimal comma is detected)",
    )


def add_prepare_option(p: argparse.ArgumentParser) -> None:
    """Declare ``--prepare KEY=VALUE ...``."""
    p.add_argument("--prepare", nargs="*", metavar="KEY=VALUE", help=PREPARE_HELP)


# ------------------------------------------------------------------------------ --prepare
def hoist_recordings(argv: Sequence[str], option: str = "--prepare") -> list[str]:
    """``argv`` with recordings written after ``--prepare KEY=VALUE ...`` moved to the front.

    ``--prepare`` takes any number of items, so ``--prepare dt=1 data.csv``
    would hand the recording to it; items that exist as paths or name a data
    set (``dataset:NAME``) are recordings and go back among the positionals.

    Examples
    --------
    >>> hoist_recordings(["--prepare", "dt=1", "dataset:x", "--out", "f.json"])
    ['dataset:x', '--prepare', 'dt=1', '--out', 'f.json']
    """
    out: list[str] = []
    moved: list[str] = []
    inside = False
    for tok in argv:
        if tok == option:
            inside = True
        elif tok.startswith("-"):
            inside = False
        elif inside and "=" not in tok and (tok.startswith("dataset:") or Path(tok).exists()):
            moved.append(tok)
            continue
        out.append(tok)
    return moved + out
