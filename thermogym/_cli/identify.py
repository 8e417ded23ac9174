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
"""

from __future__ import annotations

import argparse
import importlib

from thermogym.errors import UnknownNameError

HANDLERS: dict[str, str] = {
    "foptd": "thermogym._cli.identify_linear",
    "n4sid": "thermogym._cli.identify_linear",
    "rls": "thermogym._cli.identify_linear",
    "arx": "thermogym._cli.identify_pem",
    "armax": "thermogym._cli.identify_pem",
    "oe": "thermogym._cli.identify_pem",
    "bj": "thermogym._cli.identify_pem",
    "sopdt": "thermogym._cli.identify_pem",
    "ssest": "thermogym._cli.identify_pem",
    "auto": "thermogym._cli.identify_pem",
    "greybox": "thermogym._cli.identify_global",
    "montecarlo": "thermogym._cli.identify_global",
    "anneal": "thermogym._cli.identify_global",
    "evolution": "thermogym._cli.identify_global",
    "cmaes": "thermogym._cli.identify_global",
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
    try:
        module = importlib.import_module(HANDLERS[args.method])
    except ModuleNotFoundError as e:
        raise UnknownNameError(
            f"identification method {args.method!r} is not available in this build ({e})"
        ) from e
    return int(module.main(args.method, list(args.args)) or 0)
