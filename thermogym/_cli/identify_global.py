r"""``thermogym identify greybox|montecarlo|anneal|evolution|cmaes``: the coordinator.

Fits a registered thermogym model (``--model``) or an external model
(``--external CONFIG``, a TOML/YAML file read by
:func:`thermogym.identification.external.load_external`) to recordings and
writes a FitResult JSON::

    thermogym identify greybox --model axt211 data/axt211/*.csv --out fit.json \\
        --free C_P --free lambda_PG --free C_G --free lambda_GU --pair T_P --pair T_G

    thermogym identify montecarlo --model strut strut/strut-step-20.csv --out fit.json \\
        --free r_motor --free r_nut --fix T_ref=20 --samples 10000 --time-limit 60

The problem set-up follows paper 000 (workflow steps 2-7): free parameters
with bounds and start values (``--free NAME=LO:HI[:START]``), values set
manually (``--fix``), ratio parameters (``--ratio``), signal pairs with weights
(``--pair``), the method and its stop criteria. Ctrl-C ends the search and
writes the best result found so far to a new name (``FIT.interrupted.json``,
never over ``--out``) and exits with status 130.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from thermogym._cli.common import (
    CliParser,
    positive,
    probability,
    whole,
)
from thermogym._cli.data import (
    add_data_options,
    add_prepare_option,
)

_METHODS = ("greybox", "montecarlo", "anneal", "evolution", "cmaes")


def build_parser(method: str) -> argparse.ArgumentParser:
    """Parser of ``thermogym identify METHOD``."""
    p = CliParser(
        prog=f"thermogym identify {method}",
        description=__doc__.splitlines()[0] if __doc__ else None,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument("--model", help="registered thermogym model (thermogym models)")
    src.add_argument("--external", type=Path, help="TOML/YAML configuration of an external model")
    p.add_argument(
        "data", nargs="+", help="recordings: CSV/Parquet files, folders of them, dataset:NAME"
    )
    p.add_argument("--out", required=True, help="FitResult JSON to write")
    add_prepare_option(p)
    add_data_options(p)
    p.add_argument("--effects", nargs="*", default=[], help="physical effects of --model")
    p.add_argument(
        "--free",
        action="append",
        default=[],
        metavar="NAME[=LO:HI[:START]]",
        help="parameter to fit (default bounds/start: the model's); repeatable",
    )
    p.add_argument(
        "--fix",
        "--set",
        dest="fix",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="parameter set manually (not fitted); repeatable",
    )
    p.add_argument(
        "--ratio",
        action="append",
        default=[],
        metavar="NAME=TARGET[,TARGET...][:LO:HI]",
        help="ratio on the physical estimates of the targets, 1 at the start (paper 000)",
    )
    p.add_argument(
        "--log", action="append", default=[], metavar="NAME", help="search NAME on a log scale"
    )
    p.add_argument(
        "--pair",
        action="append",
        default=[],
        metavar="MEASURED[:SIMULATED][@WEIGHT]",
        help="signal pair of the criterion (eq 4); default: every measured model output",
    )
    p.add_argument("--objective", choices=("rmse", "mse"), default="rmse")
    stop = p.add_argument_group("stop criteria (any one ends the run)")
    stop.add_argument("--max-iter", type=whole(1, what="a number of iterations"))
    stop.add_argument("--max-evals", type=whole(1, what="a number of evaluations"))
    stop.add_argument("--time-limit", type=positive("s", "a time limit"), metavar="SECONDS")
    stop.add_argument(
        "--target", type=positive(what="a criterion value"), help="quality limit on the criterion"
    )
    m = p.add_argument_group("method options")
    m.add_argument("--seed", type=whole(0, 2**32 - 1, what="a seed"), default=0)
    m.add_argument("--jac", choices=("auto", "fd", "exact"), help="greybox: Jacobian")
    m.add_argument("--diff", choices=("forward", "central"), help="greybox: finite differences")
    m.add_argument("--solver", choices=("trf", "dogbox", "lm"), help="greybox: scipy solver")
    m.add_argument(
        "--samples",
        # a montecarlo run keeps every set it drew (for its intervals): 10^7 sets of a few
        # parameters are about a gigabyte
        type=whole(1, 10**7, what="a number of parameter sets"),
        help="montecarlo: sets (at most 10^7)",
    )
    m.add_argument(
        "--batch-size", type=whole(1, what="a batch size"), help="montecarlo: sets per batch"
    )
    m.add_argument("--sampler", choices=("uniform", "sobol", "lhs"), help="montecarlo")
    m.add_argument(
        "--chains", type=whole(1, what="a number of chains"), help="anneal: chains per batch"
    )
    m.add_argument(
        "--popsize", type=whole(2, what="a population size"), help="evolution/cmaes: population"
    )
    m.add_argument(
        "--sigma0",
        type=positive(what="an initial step"),
        help="cmaes: initial step (unit coordinates)",
    )
    m.add_argument("--polish", action="store_true", help="refine a global result with greybox")
    m.add_argument(
        "--level",
        type=probability("a confidence level"),
        default=0.95,
        help="confidence level of the intervals",
    )
    m.add_argument(
        "--input-noise",
        action="append",
        default=[],
        metavar="COLUMN[=SIGMA]",
        help="noise of a measured input that drives the simulation (sensor sigma, or "
        "estimated from the data when omitted); its effect enters the intervals",
    )
    ext = p.add_argument_group("external models")
    ext.add_argument(
        "--backend",
        choices=("local", "process", "serial", "ray"),
        help="evaluation of non-batched external models: local processes (default; 'local' "
        "and 'process' are the same), in this process ('serial'), or a Ray cluster",
    )
    ext.add_argument("--workers", type=whole(1, what="a number of workers"), help="processes")
    out = p.add_argument_group("output")
    out.add_argument("--validate", nargs="+", default=[], help="validation recordings")
    out.add_argument("--history", help="write the search history (JSON)")
    out.add_argument("--plot", help="write a PNG of measured vs simulated signals")
    out.add_argument("--no-progress", action="store_true", help="no progress bar")
    out.add_argument("--no-overwrite", action="store_true", help="refuse to replace --out")
    return p
