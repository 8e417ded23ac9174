"""The ``thermogym`` command line.

Each sub-command lives in its own module under :mod:`thermogym._cli`, which
provides ``add_parser(subparsers)`` and ``run(args) -> int``; modules are
imported only when their command runs, so ``thermogym --help`` stays fast.
Errors thermogym raises on purpose are printed as one line and exit with
status 2; nothing else imports this module.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence

from thermogym import __version__
from thermogym.errors import ThermogymError

#: command -> (module, one-line help)
COMMANDS: dict[str, tuple[str, str]] = {
    "models": ("thermogym._cli.models", "list the models with their signals and parameters"),
    "simulate": ("thermogym._cli.simulate", "simulate a model on the inputs of a recording"),
    "experiment": ("thermogym._cli.experiment", "run a virtual test rig protocol"),
    "identify": ("thermogym._cli.identify", "fit a model to recordings, write a FitResult"),
    "compare": (
        "thermogym._cli.compare",
        "several fitted models on one recording (fit per output)",
    ),
    "resid": ("thermogym._cli.resid", "residual whiteness and input cross-correlation tests"),
    "diagnose": ("thermogym._cli.diagnose", "locate a model mismatch and name the missing physics"),
    "virtual-sensor": ("thermogym._cli.virtual_sensor", "estimate hidden temperatures (Kalman)"),
    "firmware": ("thermogym._cli.firmware", "export the virtual sensor as C firmware"),
    "bench": ("thermogym._cli.bench", "benchmark controllers on energy, lifetime, accuracy"),
    "demo": ("thermogym._cli.demo", "run the whole loop on embedded defaults"),
}


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every sub-command."""
    parser = argparse.ArgumentParser(
        prog="thermogym",
        description="Identified thermal plants as Gymnasium environments: rigs, "
        "identification, diagnosis, control benchmarks.",
    )
    parser.add_argument("--version", action="version", version=f"thermogym {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name, (module, help_text) in COMMANDS.items():
        try:
            mod = importlib.import_module(module)
        except ModuleNotFoundError as e:
            if e.name != module:
                raise
            continue  # a command whose module is not part of this build
        p = sub.add_parser(name, help=help_text, description=help_text)
        p.set_defaults(_module=module)
        mod.add_arguments(p)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(importlib.import_module(args._module).run(args) or 0)
    except ThermogymError as e:
        print(f"thermogym {args.command}: error: {e}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # output piped into e.g. `head`
        return 0
    except KeyboardInterrupt:
        print(f"thermogym {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
