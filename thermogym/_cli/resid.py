"""``thermogym resid FIT --data REC``: residual tests of a fitted model.

As MATLAB's ``resid``: the residuals ``y − ŷ`` of the fit on a recording are
tested for whiteness (Ljung-Box over lags 1..M) and for independence from
each input (cross-correlation over lags 0..M, bounds widened for coloured
signals); the figure shows both with their confidence bounds. Residuals that
are coloured but independent of the inputs call for more dynamics or a noise
model; residuals correlated with an input say its effect is mis-modelled.

Example::

    thermogym resid fits/foptd.json --data dataset:hair_dryer --plot resid.png
"""

from __future__ import annotations

import argparse

from thermogym._cli.common import probability, whole
from thermogym._cli.compare import X0_OPTION
from thermogym._cli.data import add_data_options


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Declare the options."""
    p.add_argument("fit", metavar="FIT", help="FitResult JSON file")
    p.add_argument("--data", required=True, help="recording (file or dataset:NAME)")
    p.add_argument(
        "--x0",
        choices=X0_OPTION,
        default="auto",
        help="initial state of a linear fit (default auto: estimated from the outputs)",
    )
    p.add_argument(
        "--k-step",
        type=whole(1, 1_000_000, what="a prediction horizon in samples"),
        metavar="K",
        help="test the K-step prediction errors (1: one-step, as MATLAB for models with a "
        "noise model) instead of the simulation residuals",
    )
    p.add_argument(
        "--max-lag",
        type=whole(1, 100_000, what="a number of lags"),
        default=25,
        help="largest lag M [samples] (25)",
    )
    p.add_argument(
        "--alpha", type=probability(), default=0.01, help="level of the bounds and verdicts (0.01)"
    )
    p.add_argument("--plot", help="PNG to write")
    p.add_argument("--json", help="write the test results as JSON")
    add_data_options(p)
