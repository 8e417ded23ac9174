r"""``thermogym identify foptd|n4sid|rls``: linear identification from recordings.

Examples
--------
FOPTD set of the strut (paper 000, section 4.1)::

    thermogym experiment strut steps --out runs
    thermogym identify foptd --model strut runs/strut-step-20.csv \\
        --validate runs/strut-step-25.csv runs/strut-step-30.csv --out foptd.json --plots figs

N4SID of the spindle with a 2-fold cross-validated order (paper 001)::

    thermogym experiment spindle run-in --out raw --option speeds=[6000]
    thermogym identify n4sid raw/spindle-6000rpm-fold1.csv raw/spindle-6000rpm-fold2.csv \\
        --inputs speed --outputs T_rear_bearing_A,T_front_bearing_C \\
        --prepare ambient=T_amb valid_range=-50,300 --orders 1:12 --folds 2 --out ss.json

Any CSV/Parquet recording works with ``--inputs``/``--outputs`` naming its columns.
"""

from __future__ import annotations

import argparse

from thermogym._cli.common import CliParser, name_values, number, seconds, whole
from thermogym._cli.data import (
    add_data_options,
    add_prepare_option,
)

#: ``--x0`` choices of the linear fits: :data:`thermogym.identification.linear_fit.X0_CHOICES`,
#: written out so that the options load without the fits (tests/test_cli.py checks they match).
X0_CHOICES: tuple[str, ...] = ("auto", "zero", "steady", "estimate")
#: :data:`thermogym.identification.advice.DEFAULT_TOLERANCE`, written out likewise.
DEFAULT_TOLERANCE = 1e-3


METHODS = ("foptd", "n4sid", "rls")


def _range(text: str) -> range:
    """``--orders A:B`` (an argparse ``type=``: refused before any work starts)."""
    a, sep, b = str(text).partition(":")
    try:
        lo, hi = int(a), int(b) if sep else int(a)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"{text!r} is not of the form A:B (whole numbers)"
        ) from None
    if lo < 1 or hi < lo or hi > 500:
        raise argparse.ArgumentTypeError(f"{text!r}: expected 1 <= A <= B <= 500 (model orders)")
    return range(lo, hi + 1)


def add_offset_options(p: argparse.ArgumentParser) -> None:
    """``--u-offset`` and ``--y-offset``: given operating-point values.

    Shared by every identify method that takes ``--operating-point``. A named
    signal's offset replaces what the mode gives it in every experiment; the
    others keep the mode's values (so ``--operating-point none`` with offsets
    is exactly the given values, zero for the rest). The names are checked
    against the fit's inputs and outputs before any fitting.
    """
    what = (
        "{kind} operating point(s) given, NAME=VALUE[,NAME=VALUE...] (finite, in the "
        "signal's units): subtracted from every experiment instead of what --operating-point "
        "gives that {kind} (the {kind}s not named keep the mode's value; with "
        "--operating-point none: zero), and stored in the FitResult, so simulate, compare, "
        "diagnose, virtual-sensor and firmware apply them unchanged"
    )
    p.add_argument(
        "--u-offset",
        type=name_values("an input offset"),
        metavar="NAME=VALUE",
        help=what.format(kind="input"),
    )
    p.add_argument(
        "--y-offset",
        type=name_values("an output offset"),
        metavar="NAME=VALUE",
        help=what.format(kind="output") + "; foptd's 'estimate' mode then fixes the output "
        "offset instead of fitting it",
    )


def build_parser(method: str) -> argparse.ArgumentParser:
    """Options of ``thermogym identify METHOD``."""
    p = CliParser(
        prog=f"thermogym identify {method}",
        description={
            "foptd": "FOPTD transfer functions by least squares and delay search (000 section 4.1)",
            "n4sid": "MIMO state space by N4SID; order by singular values or k-fold "
            "cross-validation (001 section 2.3.3, eqs 7-10)",
            "rls": "FOPTD parameters by recursive least squares with forgetting",
        }[method],
    )
    p.add_argument(
        "data", nargs="+", help="training recordings: CSV/Parquet files, folders, dataset:NAME"
    )
    p.add_argument("--validate", nargs="+", default=[], metavar="DATA", help="validation data")
    p.add_argument("--model", help="thermogym plant whose signal names to use (e.g. spindle)")
    p.add_argument("--inputs", help="exogenous columns, comma separated")
    p.add_argument("--outputs", help="output columns, comma separated")
    p.add_argument("--disturbances", help="which inputs are disturbances (default: roles)")
    add_prepare_option(p)
    add_data_options(p)
    p.add_argument(
        "--operating-point",
        choices=("estimate", "none", "initial", "mean", "rest")
        if method == "foptd"
        else ("auto", "none", "initial", "mean", "rest")
        if method == "n4sid"
        else ("none", "initial", "mean"),
        help="foptd: 'estimate' (default) fits the output offset and the initial lag, no "
        "sample is taken as rest; the others subtract from each experiment its first samples "
        "(initial, paper 000), its means (mean) or nothing (none; rest: inputs from zero). "
        "rls: default initial; n4sid: default auto, the better of none (absolute levels: a "
        "plant at rest at zero input) and mean (MATLAB's detrend) on held-out folds",
    )
    add_offset_options(p)
    p.add_argument(
        "--x0",
        choices=X0_CHOICES,
        default="auto",
        help="initial state when the fit is simulated on the recordings (metrics, plots): "
        "estimate (least squares on the outputs, as MATLAB's compare), steady (settled at the "
        "first input), zero (at rest at the operating point); auto (default): estimate",
    )
    p.add_argument(
        "--expect-sign",
        metavar="IN=+|IN:OUT=-",
        help="declared sign of steady-state gains, comma separated (e.g. P_heater=+); a gain "
        "of the other sign is warned about. Without it: heaters (power units) and temperature "
        "inputs must raise a temperature output; 'none' checks nothing",
    )
    p.add_argument("--out", required=True, help="FitResult JSON to write")
    p.add_argument("--plots", help="folder for figures")
    if method in ("foptd", "rls"):
        p.add_argument(
            "--max-delay-s",
            type=seconds(what="a largest delay"),
            help="largest delay searched [s]",
        )
        p.add_argument("--criterion", choices=("simulation", "equation"), default="simulation")
    if method == "rls":
        p.add_argument(
            "--forgetting",
            type=number(0.0, 1.0, lo_open=True, what="a forgetting factor"),
            default=0.999,
            help="λ in (0, 1] (default 0.999)",
        )
        p.add_argument("--delays", help="delays [samples], one or one per output")
        p.add_argument("--from-fit", help="warm start from a foptd FitResult")
    if method == "n4sid":
        g = p.add_mutually_exclusive_group()
        g.add_argument("--order", type=whole(1, 500, what="a model order"), help="model order")
        g.add_argument(
            "--orders", type=_range, default="1:10", help="candidate orders A:B (default 1:10)"
        )
        p.add_argument(
            "--folds",
            type=whole(2, 100, what="a number of folds"),
            help="choose the order by k-fold cross-validation (recordings are dealt round "
            "robin into the folds; a single recording is cut into K parts)",
        )
        p.add_argument("--scheme", choices=("paper", "kfold"), default="paper")
        p.add_argument(
            "--horizon",
            type=whole(1, 100_000, what="a number of block rows"),
            help="block rows (default from the orders)",
        )
        p.add_argument("--decimate", default="auto", help="factor or 'auto' (default)")
        p.add_argument("--weighting", choices=("moesp", "cva", "n4sid"), default="moesp")
        p.add_argument("--feedthrough", action="store_true", help="estimate D")
        p.add_argument(
            "--cv-tolerance",
            type=number(0.0, 100.0, what="a tolerance in percentage points"),
            default=100 * DEFAULT_TOLERANCE,
            metavar="PERCENT",
            help="the order is the smallest whose validation fit is within this many "
            "percentage points of the best (default %(default)g)",
        )
        p.add_argument("--no-noise-model", action="store_true", help="K = 0")
    return p
