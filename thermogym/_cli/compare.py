r"""``thermogym compare FIT [FIT ...] --data REC``: several fitted models on one recording.

As MATLAB's ``compare``: each FitResult is simulated (or predicted ``--k-step``
samples ahead) on the recording's inputs; the fit of every output (NRMSE
fit, in percent) is printed and drawn in one figure.

Example::

    thermogym compare fits/foptd.json fits/ss.json --data dataset:hair_dryer \
        --plot compare.png
"""

from __future__ import annotations

import argparse

from thermogym._cli.common import names, whole
from thermogym._cli.data import add_data_options

#: Initial-state choices of the commands that simulate a linear fit.
X0_OPTION = ("auto", "estimate", "steady", "zero")


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Declare the options."""
    p.add_argument("fits", nargs="+", metavar="FIT", help="FitResult JSON files")
    p.add_argument(
        "--data", required=True, help="recording (CSV/Parquet file or dataset:NAME) to compare on"
    )
    p.add_argument(
        "--x0",
        choices=X0_OPTION,
        default="auto",
        help="initial state of linear fits (default auto: estimated from the outputs)",
    )
    p.add_argument(
        "--k-step",
        type=whole(1, 1_000_000, what="a prediction horizon in samples"),
        metavar="K",
        help="compare K-step-ahead predictions instead of simulations",
    )
    p.add_argument(
        "--labels",
        type=names("label"),
        help="names of the fits in the table and figure, comma separated",
    )
    p.add_argument("--plot", help="PNG to write (one panel per output)")
    p.add_argument("--json", help="write the fits per output as JSON")
    add_data_options(p)
