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

Each family is split like every command (:mod:`thermogym._cli`): the module
named above declares the method's options (``build_parser(method)``, argparse
only) and ``..._run`` does the work (``run(method, args)``). The method's
options are parsed while ``thermogym identify`` itself is parsed (the ``args``
positional's action, :class:`MethodOptions`), so ``identify METHOD --help`` and
a bad option load no fitting code; :mod:`thermogym._cli.identify_run` then
runs the family's ``run`` (the three work modules are imported together: they
share most of what they import).
"""

from __future__ import annotations

import argparse
from types import ModuleType
from typing import Any

from thermogym._cli import identify_global, identify_linear, identify_pem
from thermogym._cli.data import hoist_recordings

#: method -> the module declaring its options (its work: the same name + ``_run``)
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


class MethodOptions(argparse.Action):
    """Parse the method's own options (``args``) with its parser, into the same attribute."""

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: Any,
        option_string: str | None = None,
    ) -> None:
        method = namespace.method
        parsed = HANDLERS[method].build_parser(method).parse_args(hoist_recordings(list(values)))
        setattr(namespace, self.dest, parsed)


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Declare the options (the method's own options follow it)."""
    p.add_argument("method", choices=sorted(HANDLERS), help="identification method")
    p.add_argument(
        "args",
        nargs=argparse.REMAINDER,
        action=MethodOptions,
        help="options of the method (see thermogym identify METHOD --help)",
    )
