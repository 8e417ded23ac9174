"""``thermogym virtual-sensor --fit fit.json DATA --out estimates.csv``: estimate hidden signals.

Runs the Kalman virtual sensor of :mod:`thermogym.estimation` on a
recording: the identified state-space model of ``--fit`` (``ss``, e.g. from
``thermogym identify n4sid``), the exogenous channels and the ``--measured``
outputs read from DATA, the other outputs estimated. Writes a recording with
the estimates, their standard deviations (``<name>_std``) and the observer
status; when DATA also holds the hidden signals (a run-in rig with internal
RTDs) it prints the estimation RMSE, fit (NRMSE fit, paper 001 eq 5, in %) and the NEES
consistency against them. ``--plot`` draws measured, true and estimated
temperatures.
"""

from __future__ import annotations

import argparse

from thermogym._cli.common import positive
from thermogym._cli.data import add_data_options


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Declare the options."""
    p.add_argument(
        "data",
        help="recording (CSV/Parquet or dataset:NAME), uniform at a multiple of the model's dt",
    )
    p.add_argument("--fit", required=True, help="FitResult JSON of an identified 'ss' model")
    p.add_argument("--out", required=True, help="recording to write (CSV/Parquet)")
    p.add_argument(
        "--measured",
        default="",
        metavar="NAMES",
        help="comma-separated model outputs measured at run time (e.g. the surface "
        "temperatures); empty for Table 6 models whose measurements are inputs",
    )
    p.add_argument("--hidden", default=None, metavar="NAMES", help="outputs to estimate")
    p.add_argument(
        "--reference",
        default=None,
        metavar="NAME",
        help="the model's temperatures are relative to this column (e.g. T_amb)",
    )
    p.add_argument(
        "--method",
        choices=("kalman", "observer"),
        default="kalman",
        help="time-varying Kalman filter (filterpy) or the steady-state observer the "
        "firmware runs (default kalman)",
    )
    p.add_argument(
        "--rest",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="exogenous value for the start-up rest state, e.g. speed=0, or another "
        "channel, e.g. T_front_outer_housing=T_amb",
    )
    p.add_argument(
        "--measurement-std",
        type=positive(what="a noise standard deviation"),
        default=0.05,
        help="sensor noise std (default 0.05)",
    )
    p.add_argument(
        "--process-std",
        type=positive(what="a noise standard deviation"),
        default=1e-3,
        help="process noise per sample at the outputs, models without K (default 1e-3)",
    )
    p.add_argument(
        "--disturbance",
        default="",
        metavar="NAMES",
        help="exogenous inputs that get a random-walk disturbance state (offset-free)",
    )
    p.add_argument(
        "--tune",
        metavar="DATA",
        help="calibration recording: scale the process noise until the mean NIS equals "
        "the number of measured channels (never the evaluation data)",
    )
    p.add_argument("--plot", help="also write a PNG of measured, true and estimated signals")
    p.add_argument(
        "--x0",
        choices=("auto", "estimate", "steady", "zero"),
        default="auto",
        help="initial state: estimate (least squares on the measured channels), steady (the "
        "equilibrium at the first readings, --rest applies), zero (at rest at the model's "
        "operating point); auto (default): steady with --rest or without measured channels, "
        "else estimate",
    )
    add_data_options(p)
