"""``thermogym identify METHOD ...``: fit a model to recordings and write a FitResult.

The methods are implemented by handler modules that parse their own options
(``thermogym identify METHOD --help``):

* linear identification (issue "Identification I"): ``foptd``, ``n4sid``, ``rls``
  in :mod:`thermogym._cli.identify_linear`;
* prediction-error families (issue 16): ``arx``, ``armax``, ``oe``, ``bj``,
  ``sopdt``, ``ssest``, ``auto`` in :mod:`thermogym._cli.identify_pem`;
* the identification coordinator (issue "Identification II"): ``greybox``,
  ``montecarlo``, ``anneal``, ``evolution``, ``cmaes`` in
  :mod:`thermogym._cli.identify_global`.

Each handler module provides ``main(method: str, argv: list[str]) -> int``.
All three are imported with this module: they share most of what they import
(the recordings, the linear fits, the figures), so loading the other two costs
little next to the one that runs.
"""

from __future__ import annotations

import argparse
from types import ModuleType

from thermogym._cli import identify_global, identify_linear, identify_pem

HANDLERS: dict[str, ModuleType] = {
    "foptd": identify_linear,
    "n4sid": identify_linear,
    "rls": identify_linear,
    "arx": identify_pem,
    "armax": identify_pem,
    "oe": identify_pem,
    "bj": identify_pem,
    "sopdt": identify_pem,
    "ssest": identify_pem,
    "auto": identify_pem,
    "greybox": identify_global,
    "montecarlo": identify_global,
    "anneal": identify_global,
    "evolution": identify_global,
    "cmaes": identify_global,
}


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Declare the options (the method's own options follow it)."""
    p.add_argument("method", choices=sorted(HANDLERS), help="identification method")
    p.add_argument(
        "args",
        nargs=argparse.REMAINDER,
        help="options of the method (see thermogym identify METHOD --help)",
    )


def run(args: argparse.Namespace) -> int:
    """Dispatch to the method's handler."""
    return int(HANDLERS[args.method].main(args.method, list(args.args)) or 0)
