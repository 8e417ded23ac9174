r"""``thermogym identify arx|armax|oe|bj|sopdt|ssest|auto``: prediction-error identification.

Examples
--------
The family with the best cross-validated fit (orders, delays, structure and
operating point chosen on the training data)::

    thermogym identify auto dataset:hair_dryer --inputs u --outputs y --out dryer.json

An output-error model with orders by 2-fold cross-validation, or given as
MATLAB's ``oe(data, [nb nf nk])``::

    thermogym identify oe run.csv --inputs P --outputs T --out oe.json
    thermogym identify oe run.csv --inputs P --outputs T --nb 2 --nf 2 --nk 3 --out oe.json

N4SID refined by PEM, order / feedthrough / input delay by cross-validation
(MATLAB ``ssest``)::

    thermogym identify ssest run.csv --inputs q --outputs th --out ss.json
"""

from __future__ import annotations

import argparse

from thermogym._cli.common import CliParser, choice_list, seconds, whole
from thermogym._cli.data import (
    add_data_options,
    add_prepare_option,
)
from thermogym._cli.identify_linear import X0_CHOICES, add_offset_options

METHODS = ("arx", "armax", "oe", "bj", "sopdt", "ssest", "auto")


_OP_MODES = ("auto", "mean", "none", "initial", "rest")


def build_parser(method: str) -> argparse.ArgumentParser:
    """Options of ``thermogym identify METHOD`` for the PEM families."""
    desc = {
        "arx": "ARX by least squares; orders and delays by cross-validation (MATLAB arx)",
        "armax": "ARMAX by prediction-error minimisation (MATLAB armax)",
        "oe": "output-error model by simulation-error minimisation (MATLAB oe)",
        "bj": "Box-Jenkins model by prediction-error minimisation (MATLAB bj)",
        "sopdt": "second-order-plus-dead-time transfer functions (MATLAB procest P2D)",
        "ssest": "N4SID refined by PEM; order, feedthrough, input delay by "
        "cross-validation (MATLAB ssest)",
        "auto": "the family (ARX, OE, SOPDT, ssest) with the best cross-validated fit",
    }[method]
    p = CliParser(prog=f"thermogym identify {method}", description=desc)
    p.add_argument(
        "data", nargs="+", help="training recordings: CSV/Parquet files, folders, dataset:NAME"
    )
    p.add_argument("--validate", nargs="+", default=[], metavar="DATA", help="validation data")
    p.add_argument("--model", help="thermogym plant whose signal names to use")
    p.add_argument("--inputs", help="exogenous columns, comma separated")
    p.add_argument("--outputs", help="output columns, comma separated")
    p.add_argument("--disturbances", help="which inputs are disturbances (default: roles)")
    add_prepare_option(p)
    add_data_options(p)
    p.add_argument(
        "--operating-point",
        choices=_OP_MODES,
        default="auto",
        help="subtracted from each experiment; auto (default): 'mean' or 'none', whichever "
        "cross-validates better with an ARX model",
    )
    add_offset_options(p)
    p.add_argument(
        "--folds",
        type=whole(2, 100, what="a number of folds"),
        default=2,
        help="cross-validation folds (default 2)",
    )
    p.add_argument(
        "--x0",
        choices=X0_CHOICES,
        default="auto",
        help="initial state when the fit is simulated on the recordings (metrics, plots): "
        "estimate, steady, zero; auto (default): estimate",
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
    if method in ("arx", "armax", "oe", "bj"):
        for k, what in (
            ("na", "order of A"),
            ("nb", "number of B coefficients"),
            ("nc", "order of C"),
            ("nd", "order of D"),
            ("nf", "order of F"),
            ("nk", "input delays [samples]"),
        ):
            if (
                k in ("nb", "nk")
                or k[1] in {"arx": "a", "armax": "ac", "oe": "f", "bj": "fcd"}[method]
            ):
                p.add_argument(f"--{k}", help=f"{what} (default: cross-validation)")
        p.add_argument("--focus", choices=("prediction", "simulation"))
    if method in ("arx", "armax", "oe", "bj", "auto"):
        default = 10 if method in ("arx", "auto") else 6
        p.add_argument(
            "--max-order",
            type=whole(1, 50, what="a model order"),
            default=default,
            help=f"largest order tried (default {default}; auto: ARX, the others up to 4)",
        )
        p.add_argument(
            "--max-delay",
            type=whole(0, 10_000, what="a delay in samples"),
            default=10,
            help="largest delay tried [samples] (default 10)",
        )
    if method == "sopdt":
        p.add_argument(
            "--max-delay-s", type=seconds(what="a largest delay"), help="largest delay [s]"
        )
    if method == "ssest":
        g = p.add_mutually_exclusive_group()
        g.add_argument(
            "--order",
            type=whole(1, 500, what="a model order"),
            help="model order (default: cross-validation)",
        )
        g.add_argument("--orders", default="1:8", help="candidate orders A:B (default 1:8)")
        p.add_argument("--feedthrough", choices=("auto", "yes", "no"), default="auto")
        p.add_argument("--input-delay", help="input delay [samples] or auto (default)")
        p.add_argument(
            "--max-delay",
            type=whole(0, 10_000, what="a delay in samples"),
            default=5,
            help="largest input delay tried [samples] (default 5)",
        )
        p.add_argument("--no-refine", action="store_true", help="N4SID only, no PEM refinement")
        p.add_argument("--focus", choices=("prediction", "simulation"), default="simulation")
    if method == "auto":
        p.add_argument(
            "--families",
            type=choice_list(_FAMILIES, "family"),
            default="arx,oe,sopdt,ssest",
            help=f"families compared, some of {','.join(_FAMILIES)} (default arx,oe,sopdt,ssest)",
        )
    return p


#: The families ``identify auto`` compares (thermogym.identification.ssest.identify_auto).
_FAMILIES = ("arx", "armax", "oe", "bj", "sopdt", "ssest")
