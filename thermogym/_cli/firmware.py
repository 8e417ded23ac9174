"""``thermogym firmware export fit.json --out DIR``: the virtual sensor as C99 firmware.

Sub-commands:

``export FIT --out DIR``
    Generate ``vs_model.h`` (matrices, dimensions, scaling, provenance with the
    FitResult fingerprint) and copy the C sources, host test, simavr harness
    and Makefile (:func:`thermogym.firmware.export.export`). Refuses a model
    that does not fit the target's flash or RAM and says by how much.
    ``--vectors DATA`` adds test vectors of the Python observer on DATA, so
    that ``make -C DIR test`` checks the C code against Python.
``budget FIT``
    Print the estimated footprint on the target without writing anything.
"""

from __future__ import annotations

import argparse

from thermogym._cli.common import positive, whole
from thermogym._cli.data import add_data_options


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument("fit", help="FitResult JSON of an identified 'ss' model")
    p.add_argument(
        "--measured", default="", metavar="NAMES", help="measured outputs (comma-separated)"
    )
    p.add_argument("--hidden", default=None, metavar="NAMES", help="outputs to estimate")
    p.add_argument("--reference", default=None, metavar="NAME", help="e.g. T_amb for relative data")
    p.add_argument(
        "--measurement-std",
        type=positive(what="a noise standard deviation"),
        default=0.05,
        help="sensor noise std",
    )
    p.add_argument(
        "--process-std",
        type=positive(what="a noise standard deviation"),
        default=1e-3,
        help="process noise (no K)",
    )
    p.add_argument("--disturbance", default="", metavar="NAMES", help="random-walk input states")
    p.add_argument("--target", default="atmega328p", help="microcontroller (default atmega328p)")
    p.add_argument(
        "--flash-budget",
        type=whole(1, what="a number of bytes"),
        help="bytes of flash the observer may use (default: all free)",
    )
    p.add_argument(
        "--ram-budget",
        type=whole(1, what="a number of bytes"),
        help="bytes of static RAM the observer may use (default 1536)",
    )
    p.add_argument(
        "--range",
        action="append",
        default=[],
        metavar="NAME=LO:HI",
        help="valid range of an exogenous or measured channel (°C default -50:300)",
    )


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Declare the sub-commands and their options."""
    sub = p.add_subparsers(dest="fw_command", metavar="SUBCOMMAND")
    sub.required = True
    e = sub.add_parser("export", help="write vs_model.h and the C sources into a folder")
    _common(e)
    e.add_argument("--out", required=True, help="folder to create")
    e.add_argument(
        "--vectors",
        metavar="DATA",
        help="recording (or dataset:NAME) for C-versus-Python test vectors",
    )
    add_data_options(e)
    e.add_argument(
        "--rest", action="append", default=[], metavar="NAME=VALUE", help="rest-state input"
    )
    e.add_argument(
        "--offset", action="append", default=[], metavar="NAME=VALUE", help="operating point"
    )
    e.add_argument("--scale", action="append", default=[], metavar="NAME=VALUE", help="scaling")
    e.add_argument("--overwrite", action="store_true", help="replace files in an existing folder")
    e.add_argument(
        "--no-avr-check",
        action="store_true",
        help="do not confirm the footprint with avr-size even when avr-gcc is installed",
    )
    b = sub.add_parser("budget", help="print the estimated flash and RAM on the target")
    _common(b)
