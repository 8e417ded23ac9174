"""``thermogym simulate [MODEL] --inputs FILE --out FILE``: simulate on recorded inputs."""

from __future__ import annotations

import argparse

from thermogym._cli.data import add_data_options


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Declare the options."""
    p.add_argument("model", nargs="?", help="model name (optional with --params)")
    p.add_argument(
        "--inputs",
        required=True,
        help="recording (CSV/Parquet, or dataset:NAME) with the inputs",
    )
    p.add_argument("--out", required=True, help="recording to write (CSV/Parquet)")
    p.add_argument("--params", help="FitResult JSON: model and parameters")
    p.add_argument(
        "--set", action="append", default=[], metavar="NAME=VALUE", help="override a parameter"
    )
    p.add_argument("--plot", help="also write a PNG comparing simulation and recording")
    p.add_argument(
        "--x0",
        choices=("auto", "estimate", "steady", "zero"),
        default="auto",
        help="initial state of a linear fit (ss, foptd, arx, armax, oe, bj, sopdt): estimate "
        "(least squares on the "
        "recording's outputs), steady (settled at the first input), zero (at rest at the "
        "operating point); auto (default): estimate when the recording has the outputs, "
        "else steady. Other models start in their own initial state",
    )
    add_data_options(p)
