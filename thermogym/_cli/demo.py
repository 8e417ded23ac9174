"""``thermogym demo``: the whole loop on embedded defaults, with a report.

Writes ``OUT/report.html`` (self-contained, every figure embedded),
``OUT/report.md`` (its Markdown twin), ``OUT/fits/*.json`` and each stage's
files; exit status 1 when a stage failed (the report says which and why).
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence

from thermogym._cli.common import CliParser, whole

#: Keys of the demo's stages (:func:`thermogym.demo.stage_keys`), written out so that the
#: options load without the stages (tests/test_demo.py checks they match). ``--only`` is
#: checked against the stage table itself when the demo runs (:func:`check_only`).
STAGE_KEYS = ("rigs", "identify", "diagnose", "envs", "control", "sensor")


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Declare the options."""
    p.add_argument("--out", default="out", help="output folder (default: out)")
    p.add_argument(
        "--seed",
        type=whole(0, 2**32 - 1, what="a seed"),
        default=0,
        help="seed of every random draw (default 0)",
    )
    p.add_argument(
        "--quick", action="store_true", help="smaller experiments and grids (about a minute)"
    )
    p.add_argument(
        "--only",
        action="append",
        metavar="STAGE",
        help=f"run only this stage (repeatable): {', '.join(STAGE_KEYS)}",
    )
    p.add_argument("--no-progress", action="store_true", help="no progress lines or bars")


def check_only(only: Sequence[str] | None, keys: Sequence[str]) -> None:
    """Refuse a ``--only`` that is not among ``keys``, in argparse's words (exit status 2).

    Examples
    --------
    >>> check_only(["rigs"], STAGE_KEYS)
    >>> check_only(["nope"], STAGE_KEYS)
    Traceback (most recent call last):
    ...
    thermogym._cli.common.UsageError: argument --only: invalid choice: 'nope' (choose from ...
    """
    if only:
        p = CliParser(prog="thermogym demo", add_help=False)
        p.add_argument("--only", action="append", choices=list(keys))
        p.parse_args([a for key in only for a in ("--only", key)])
