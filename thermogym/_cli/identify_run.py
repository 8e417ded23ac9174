"""The work of ``thermogym identify METHOD`` (options: :mod:`thermogym._cli.identify`).

``args.args`` holds the method's parsed options; the family's work module runs them.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable

from thermogym._cli import identify_global_run, identify_linear_run, identify_pem_run
from thermogym._cli.identify import HANDLERS

#: options module -> its work module's ``run(method, args)``
_RUN: dict[str, Callable[[str, argparse.Namespace], int]] = {
    "thermogym._cli.identify_global": identify_global_run.run,
    "thermogym._cli.identify_linear": identify_linear_run.run,
    "thermogym._cli.identify_pem": identify_pem_run.run,
}


def run(args: argparse.Namespace) -> int:
    """Run the method on its parsed options."""
    return int(_RUN[HANDLERS[args.method].__name__](args.method, args.args) or 0)
