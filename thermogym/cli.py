"""The ``thermogym`` command line.

Each sub-command is two modules under :mod:`thermogym._cli` (its layout is
described there): ``NAME.py`` declares the options (``add_arguments(parser)``,
argparse and the light helpers of :mod:`thermogym._cli.common` only) and
``NAME_run.py`` does the work (``run(args) -> int``); each imports what it
needs at its top. This module is the one place that defers imports: the table
:data:`COMMANDS` names both modules of each command; the options module is
imported (and its options declared) only when that command is parsed or its
help formatted, and the work module only once the command line parsed
without error. So ``thermogym --help`` loads no command, ``thermogym NAME
--help`` and a bad option load only ``NAME``'s options, and a run loads
``NAME``'s work. Nothing else imports this module.

Exit status and messages (the same for every command):

* ``0`` success; ``1`` the command ran but reports a failure (a demo stage,
  a firmware budget) or an internal error (printed on one line, a bug: set
  ``THERMOGYM_TRACEBACK=1`` to see where);
* ``2`` bad input: an option, a file, a value. One line on stderr,
  ``thermogym COMMAND: error: ...``, naming the offending option, column or
  value; nothing is written;
* ``130`` interrupted (Ctrl-C): nothing is written over an existing file; a
  best-so-far result, when kept, goes to a new name that the message gives;
* ``143`` / ``129`` terminated by SIGTERM / SIGHUP (``kill``, ``timeout``, a
  closed terminal): handled as Ctrl-C (nothing is written over an existing file,
  a search's best-so-far goes to a new name), the line says which signal.

The shared machinery (typed options, the output guard, interruption) is in
:mod:`thermogym._cli.common`.
"""

from __future__ import annotations

import argparse
import importlib
import importlib.util
import os
import signal
import sys
import threading
import warnings
from collections.abc import Sequence
from types import ModuleType
from typing import Any

from thermogym import __version__
from thermogym._cli.common import CliParser, Interrupted, UsageError, one_line
from thermogym.errors import ThermogymError

#: command -> (options module, work module, one-line help)
COMMANDS: dict[str, tuple[str, str, str]] = {
    "models": (
        "thermogym._cli.models",
        "thermogym._cli.models_run",
        "list the models with their signals and parameters",
    ),
    "simulate": (
        "thermogym._cli.simulate",
        "thermogym._cli.simulate_run",
        "simulate a model on the inputs of a recording",
    ),
    "experiment": (
        "thermogym._cli.experiment",
        "thermogym._cli.experiment_run",
        "run a virtual test rig protocol",
    ),
    "identify": (
        "thermogym._cli.identify",
        "thermogym._cli.identify_run",
        "fit a model to recordings, write a FitResult",
    ),
    "compare": (
        "thermogym._cli.compare",
        "thermogym._cli.compare_run",
        "several fitted models on one recording (fit per output)",
    ),
    "resid": (
        "thermogym._cli.resid",
        "thermogym._cli.resid_run",
        "residual whiteness and input cross-correlation tests",
    ),
    "diagnose": (
        "thermogym._cli.diagnose",
        "thermogym._cli.diagnose_run",
        "locate a model mismatch and name the missing physics",
    ),
    "virtual-sensor": (
        "thermogym._cli.virtual_sensor",
        "thermogym._cli.virtual_sensor_run",
        "estimate hidden temperatures (Kalman)",
    ),
    "firmware": (
        "thermogym._cli.firmware",
        "thermogym._cli.firmware_run",
        "export the virtual sensor as C firmware",
    ),
    "bench": (
        "thermogym._cli.bench",
        "thermogym._cli.bench_run",
        "benchmark controllers on energy, lifetime, accuracy",
    ),
    "demo": (
        "thermogym._cli.demo",
        "thermogym._cli.demo_run",
        "run the whole loop on embedded defaults",
    ),
}


class _CommandParser(CliParser):
    """A command's parser: its options module is imported and declared on first use.

    argparse hands a sub-command's parser its arguments (``parse_known_args``)
    only when that command is named, and formats its help only then: until
    that moment the parser is an empty shell with the command's name and one
    line of help (:data:`COMMANDS`).
    """

    def __init__(self, *args: Any, module: str, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.module = module
        self._declared = False

    def load(self) -> ModuleType:
        """The command's options module, its options declared on this parser (once)."""
        mod = importlib.import_module(self.module)
        if not self._declared:
            self._declared = True
            mod.add_arguments(self)
        return mod

    def parse_known_args(self, *args: Any, **kwargs: Any) -> Any:
        self.load()
        return super().parse_known_args(*args, **kwargs)

    def format_usage(self) -> str:
        self.load()
        return super().format_usage()

    def format_help(self) -> str:
        self.load()
        return super().format_help()

    def add_subparsers(self, **kwargs: Any) -> Any:
        kwargs.setdefault("parser_class", CliParser)  # a command's own sub-commands: plain
        return super().add_subparsers(**kwargs)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every sub-command (each command's options load on use)."""
    parser = CliParser(
        prog="thermogym",
        description="Identified thermal plants as Gymnasium environments: rigs, "
        "identification, diagnosis, control benchmarks.",
    )
    parser.add_argument("--version", action="version", version=f"thermogym {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_CommandParser)
    for name, (options, work, help_text) in COMMANDS.items():
        if importlib.util.find_spec(options) is None:
            continue  # a command whose module is not part of this build
        p = sub.add_parser(name, help=help_text, description=help_text, module=options)
        p.set_defaults(_module=work)
    return parser


def _parse(parser: argparse.ArgumentParser, argv: Sequence[str] | None) -> argparse.Namespace:
    items = list(sys.argv[1:] if argv is None else argv)
    for i, item in enumerate(items):  # no file name or value can hold a NUL character
        if "\x00" in str(item):
            after = f" after {items[i - 1]!r}" if i else ""
            raise UsageError(
                f"argument {i + 1}{after} holds a NUL character ({one_line(repr(item), 80)}); "
                "no file name or value can"
            )
    args, extra = parser.parse_known_args(items)
    if extra:
        prog = f"thermogym {args.command}" if getattr(args, "command", None) else "thermogym"
        raise UsageError(
            f"unrecognized argument(s) {' '.join(extra)} (see {prog} --help)", prog=prog
        )
    if getattr(args, "command", None) is None:
        raise UsageError(
            f"no command given; commands are {', '.join(COMMANDS)} (see thermogym --help)"
        )
    return args


def _short_path(name: Any, limit: int = 120) -> str:
    """A path for a message: quoted, its middle elided when long (the reason stays visible)."""
    text = repr(os.fsdecode(name) if isinstance(name, bytes) else str(name))
    if len(text) <= limit:
        return text
    return f"{text[: limit // 2]}…{text[-limit // 2 :]} ({len(text) - 2} characters)"


class Terminated(KeyboardInterrupt):
    """SIGTERM or SIGHUP arrived (``kill``, ``timeout``, a closed terminal).

    A ``KeyboardInterrupt``: every path that handles Ctrl-C handles it too
    (staged outputs discarded, a search's best-so-far kept under a new name,
    the demo's reports made to match what finished).
    """

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = signum


#: termination signals received during the running command (the search that keeps
#: its best-so-far swallows the exception; the exit status still tells the signal)
_RECEIVED: list[int] = []


def _raise_terminated(signum: int, frame: Any) -> None:
    _RECEIVED.append(signum)
    raise Terminated(signum)


def _termination_handlers() -> dict[int, Any]:
    """Turn SIGTERM/SIGHUP into :class:`Terminated` (main thread only); the old handlers."""
    old: dict[int, Any] = {}
    if threading.current_thread() is not threading.main_thread():
        return old
    for name in ("SIGTERM", "SIGHUP"):
        sig = getattr(signal, name, None)
        if sig is None:
            continue
        try:
            if signal.getsignal(sig) is signal.SIG_IGN:  # nohup: leave it ignored
                continue
            old[sig] = signal.signal(sig, _raise_terminated)
        except (OSError, ValueError):  # pragma: no cover - not allowed here
            continue
    return old


def _warn_one_line(message: Any, category: Any, *rest: Any, **kw: Any) -> None:
    print(f"thermogym: warning: {one_line(str(message))}", file=sys.stderr)


def _interrupted(prog: str, what: str, signum: int | None) -> int:
    """Print the one line of an interrupted command; its exit status (130, 143, 129)."""
    if signum is None and _RECEIVED:
        signum = _RECEIVED[-1]
    if signum is None or signum == signal.SIGINT:
        print(f"{prog}: interrupted: {what}", file=sys.stderr)
        return 130
    print(f"{prog}: terminated by {signal.Signals(signum).name}: {what}", file=sys.stderr)
    return 128 + signum


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the exit status (never raises for bad input)."""
    prog = "thermogym"
    _RECEIVED.clear()
    old_handlers = _termination_handlers()
    with warnings.catch_warnings():
        warnings.showwarning = _warn_one_line
        try:
            parser = build_parser()
            args = _parse(parser, argv)
            prog = f"thermogym {args.command}"
            return int(importlib.import_module(args._module).run(args) or 0)
        except UsageError as e:
            print(f"{e.prog}: error: {one_line(str(e))}", file=sys.stderr)
            return 2
        except ThermogymError as e:
            print(f"{prog}: error: {one_line(str(e))}", file=sys.stderr)
            return 2
        except SystemExit as e:  # --help, --version
            code = e.code
            return code if isinstance(code, int) else (0 if code is None else 2)
        except Interrupted as e:
            return _interrupted(prog, one_line(str(e)), e.signum)
        except KeyboardInterrupt as e:  # Ctrl-C, or Terminated (SIGTERM, SIGHUP)
            return _interrupted(
                prog, "nothing was written over an existing file", getattr(e, "signum", None)
            )
        except BrokenPipeError:  # output piped into e.g. `head`
            try:
                sys.stdout = open(os.devnull, "w")
            except OSError:  # pragma: no cover
                pass
            return 0
        except OSError as e:  # a file the user named: missing, not readable, disk full
            name = getattr(e, "filename", None)
            where = f" {_short_path(name)}" if name else ""
            print(f"{prog}: error: cannot use{where}: {e.strerror or e}", file=sys.stderr)
            return 2
        except MemoryError:
            print(
                f"{prog}: error: out of memory; ask for less at once (smaller --batch-size, "
                "--samples, --order, shorter or fewer recordings)",
                file=sys.stderr,
            )
            return 2
        except RecursionError:  # e.g. a JSON file nested thousands of levels deep
            print(
                f"{prog}: error: an input is nested too deeply to read (a JSON or YAML file of "
                "thousands of levels?); check the files given",
                file=sys.stderr,
            )
            return 2
        except Exception as e:
            if os.environ.get("THERMOGYM_TRACEBACK"):
                raise
            print(
                f"{prog}: internal error ({type(e).__name__}: {one_line(str(e), 300)}); this "
                "is a bug in thermogym, please report it with the command line "
                "(THERMOGYM_TRACEBACK=1 shows where)",
                file=sys.stderr,
            )
            return 1
        finally:
            for sig, handler in old_handlers.items():
                signal.signal(sig, handler)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
