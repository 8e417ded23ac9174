"""What every ``thermogym`` command shares: typed options, output guard, interruption.

Three rules hold for every command (issue "never lose a user's file, never
show a traceback"):

1. **Options are typed and range-checked before any work starts.** The
   ``type=`` factories here (:func:`number`, :func:`whole`,
   :func:`probability`, :func:`seconds`, :func:`names`, ...) turn a bad value
   into one line that names the option and the value and says what was
   expected, e.g. ``argument --alpha: 2 is outside (0, 1); expected a
   significance level in (0, 1)``. :class:`CliParser` (the parser class of
   every command and sub-command) reports every parse error on one line and
   raises :class:`UsageError` instead of printing the usage block.
2. **Every file a command writes is checked first and replaced last.**
   :class:`OutputPlan` checks each output (not an input, its folder exists and
   is writable, a file where a file is expected and a folder where a folder
   is), hands the command a *staged* path in a hidden folder beside the target
   and moves the staged files into place only when the command succeeded
   (one ``os.replace`` per file, with Ctrl-C held off while they move). A
   failure or an interruption removes the staged files: nothing existing is
   touched.
3. **An interrupted command exits 130 and writes nothing over an existing
   file.** A command that keeps a best-so-far result writes it under a new
   name (:meth:`OutputPlan.write_partial`) and raises :class:`Interrupted`,
   which :func:`thermogym.cli.main` prints as one line.

Adopting them in a command::

    def add_arguments(p):
        p.add_argument("--alpha", type=probability("significance level"), default=0.01)
        p.add_argument("--out", required=True)

    def run(args):
        plan = plan_outputs(args, files={"out": "json"}, inputs=("params", "data"))
        with plan:
            ...  # the work
            fit.save(plan.path("out"))  # staged; moved onto --out when the block ends
        return 0
"""

from __future__ import annotations

import argparse
import math
import os
import re
import secrets
import shutil
import signal
import sys
import threading
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any, NoReturn

from thermogym.errors import ConfigError

__all__ = [
    "CliParser",
    "Interrupted",
    "OutputPlan",
    "UsageError",
    "choice_list",
    "names",
    "nonnegative",
    "number",
    "plan_outputs",
    "positive",
    "probability",
    "seconds",
    "whole",
]


# =============================================================================== errors
class UsageError(ConfigError):
    """A command line that does not parse (unknown option, bad value, missing argument)."""

    def __init__(self, message: str, prog: str = "thermogym") -> None:
        super().__init__(message)
        self.prog = prog


class Interrupted(Exception):
    """The user interrupted a command; the message says what was (not) written.

    :func:`thermogym.cli.main` prints it on one line and exits with 130 (Ctrl-C),
    or ``128 + signum`` when a termination signal (SIGTERM, SIGHUP) ended it.

    Parameters
    ----------
    message : str
        What was and was not written.
    signum : int, optional
        The signal that interrupted, when known (else the one :mod:`thermogym.cli`
        recorded, else SIGINT).
    """

    def __init__(self, message: str, signum: int | None = None) -> None:
        super().__init__(message)
        self.signum = signum


# =============================================================================== parser
class CliParser(argparse.ArgumentParser):
    """``ArgumentParser`` whose errors are one line and raise :class:`UsageError`.

    Sub-parsers made with ``add_subparsers`` inherit the class. ``--help``
    still prints the help and exits 0.
    """

    def error(self, message: str) -> NoReturn:
        raise UsageError(f"{message} (see {self.prog} --help)", prog=self.prog)


# =============================================================================== option types
def _fmt(x: float) -> str:
    return f"{x:g}"


def _interval(lo: float, hi: float, lo_open: bool, hi_open: bool, unit: str) -> str:
    u = f" {unit}" if unit else ""
    if math.isinf(lo) and math.isinf(hi):
        return "any finite number"
    if math.isinf(hi):
        return f"{'>' if lo_open else '>='} {_fmt(lo)}{u}"
    if math.isinf(lo):
        return f"{'<' if hi_open else '<='} {_fmt(hi)}{u}"
    return f"in {'(' if lo_open else '['}{_fmt(lo)}, {_fmt(hi)}{')' if hi_open else ']'}{u}"


def number(
    lo: float = -math.inf,
    hi: float = math.inf,
    *,
    lo_open: bool = False,
    hi_open: bool = False,
    unit: str = "",
    what: str = "a number",
) -> Callable[[str], float]:
    """An argparse ``type=``: a finite float in a range, or a one-line error.

    Parameters
    ----------
    lo, hi : float
        Bounds (infinite: no bound).
    lo_open, hi_open : bool
        Exclude the bound itself.
    unit : str
        Unit named in the message (the value is read in this unit).
    what : str
        What the value is, for the message (``"a significance level"``).

    Examples
    --------
    >>> number(0, 1, lo_open=True, hi_open=True)("0.5")
    0.5
    >>> number(0, unit="s", what="a delay")("-5")
    Traceback (most recent call last):
    ...
    argparse.ArgumentTypeError: -5 s is outside the range; expected a delay >= 0 s
    """
    rng = _interval(lo, hi, lo_open, hi_open, unit)
    expected = f"{what} {rng}" if "any" not in rng else what

    def parse(text: str) -> float:
        try:
            x = float(text)
        except (TypeError, ValueError):
            raise argparse.ArgumentTypeError(
                f"{text!r} is not a number; expected {expected}"
            ) from None
        u = f" {unit}" if unit else ""
        if not math.isfinite(x):
            raise argparse.ArgumentTypeError(f"{text}{u} is not finite; expected {expected}")
        if x < lo or x > hi or (lo_open and x == lo) or (hi_open and x == hi):
            raise argparse.ArgumentTypeError(f"{text}{u} is outside the range; expected {expected}")
        return x

    parse.__name__ = "number"
    return parse


def positive(unit: str = "", what: str = "a number") -> Callable[[str], float]:
    """``type=`` for a finite float > 0 (see :func:`number`)."""
    return number(0.0, lo_open=True, unit=unit, what=what)


def nonnegative(unit: str = "", what: str = "a number") -> Callable[[str], float]:
    """``type=`` for a finite float >= 0 (see :func:`number`)."""
    return number(0.0, unit=unit, what=what)


def seconds(
    lo: float = 0.0, *, lo_open: bool = False, what: str = "a duration"
) -> Callable[[str], float]:
    """``type=`` for a time in seconds (the message speaks in seconds).

    Examples
    --------
    >>> seconds(what="a delay")("2.5")
    2.5
    """
    return number(lo, lo_open=lo_open, unit="s", what=what)


def probability(what: str = "a significance level") -> Callable[[str], float]:
    """``type=`` for a number strictly between 0 and 1.

    Examples
    --------
    >>> probability()("2")
    Traceback (most recent call last):
    ...
    argparse.ArgumentTypeError: 2 is outside the range; expected a significance level in (0, 1)
    """
    return number(0.0, 1.0, lo_open=True, hi_open=True, what=what)


def whole(
    lo: int | None = None, hi: int | None = None, *, what: str = "a whole number"
) -> Callable[[str], int]:
    """``type=`` for an int in ``[lo, hi]``.

    Examples
    --------
    >>> whole(2, what="a number of folds")("1")
    Traceback (most recent call last):
    ...
    argparse.ArgumentTypeError: 1 is outside the range; expected a number of folds >= 2
    """
    if lo is not None and hi is not None:
        rng = f"in [{lo}, {hi}]"
    elif lo is not None:
        rng = f">= {lo}"
    elif hi is not None:
        rng = f"<= {hi}"
    else:
        rng = ""
    expected = f"{what} {rng}".strip()

    def parse(text: str) -> int:
        try:
            n = int(text.strip())
        except (AttributeError, TypeError, ValueError):
            raise argparse.ArgumentTypeError(
                f"{text!r} is not a whole number; expected {expected}"
            ) from None
        if (lo is not None and n < lo) or (hi is not None and n > hi):
            raise argparse.ArgumentTypeError(f"{text} is outside the range; expected {expected}")
        return n

    parse.__name__ = "whole"
    return parse


def names(what: str = "column") -> Callable[[str], tuple[str, ...]]:
    """``type=`` for a comma-separated list of names (at least one, no empty item).

    Examples
    --------
    >>> names()("u, y")
    ('u', 'y')
    """

    def parse(text: str) -> tuple[str, ...]:
        items = [s.strip() for s in text.split(",")]
        if not text.strip() or any(not s for s in items):
            raise argparse.ArgumentTypeError(
                f"{text!r} is not a list of {what} names; expected NAME,NAME,... (no empty item)"
            )
        dup = sorted({s for s in items if items.count(s) > 1})
        if dup:
            raise argparse.ArgumentTypeError(f"{text!r} names {dup} more than once")
        return tuple(items)

    parse.__name__ = "names"
    return parse


def name_values(what: str = "value") -> Callable[[str], dict[str, float]]:
    """``type=`` for ``NAME=VALUE[,NAME=VALUE...]`` with finite numbers, each name once.

    Examples
    --------
    >>> name_values("an offset")("P=0, T=20.5")
    {'P': 0.0, 'T': 20.5}
    """
    expected = f"expected NAME=VALUE with {what} as a finite number"

    def parse(text: str) -> dict[str, float]:
        out: dict[str, float] = {}
        for item in text.split(","):
            name, sep, value = (s.strip() for s in item.partition("="))
            if not sep or not name or not value:
                raise argparse.ArgumentTypeError(
                    f"{text!r}: item {item.strip()!r} is not of the form NAME=VALUE; "
                    f"{expected} (several comma separated)"
                )
            try:
                v = float(value)
            except ValueError:
                raise argparse.ArgumentTypeError(
                    f"{text!r}: {value!r} is not a number; {expected}"
                ) from None
            if not math.isfinite(v):
                raise argparse.ArgumentTypeError(f"{text!r}: {value} is not finite; {expected}")
            if name in out:
                raise argparse.ArgumentTypeError(f"{text!r} names {name!r} more than once")
            out[name] = v
        return out

    parse.__name__ = "name_values"
    return parse


def choice_list(allowed: Sequence[str], what: str = "item") -> Callable[[str], tuple[str, ...]]:
    """``type=`` for a comma-separated list whose items are all in ``allowed``."""
    base = names(what)

    def parse(text: str) -> tuple[str, ...]:
        items = base(text)
        bad = [s for s in items if s not in allowed]
        if bad:
            raise argparse.ArgumentTypeError(
                f"unknown {what}(s) {bad}; expected some of {list(allowed)}"
            )
        return items

    parse.__name__ = "choice_list"
    return parse


# =============================================================================== outputs
#: File name endings accepted for each kind of output file.
KIND_SUFFIXES: dict[str, tuple[str, ...]] = {
    "recording": (".csv", ".csv.gz", ".parquet", ".pq"),
    "json": (".json",),
    "figure": (".png", ".pdf", ".svg", ".jpg", ".jpeg"),
    "html": (".html", ".htm"),
    "md": (".md", ".markdown"),
    "csv": (".csv",),
}

_STAGING_PREFIX = ".thermogym-staging-"

#: endings of a CSV recording, whose ``NAME.meta.json`` sidecar the reader takes with it
#: (as :data:`thermogym.recording.CSV_SUFFIXES`, not imported: this module stays light)
_CSV_SUFFIXES = (".csv", ".csv.gz")


def _option(dest: str) -> str:
    return "--" + dest.replace("_", "-")


def _same(a: Path, b: Path) -> bool:
    try:
        if a.exists() and b.exists():
            return os.path.samefile(a, b)
    except OSError:
        pass
    return a.resolve() == b.resolve()


def _check_name(option: str, text: str, anchor: Path) -> None:
    """Refuse a path the file system cannot take: a part or the whole too long."""
    try:
        name_max = os.pathconf(anchor, "PC_NAME_MAX")
        path_max = os.pathconf(anchor, "PC_PATH_MAX")
    except (OSError, ValueError, AttributeError):  # pragma: no cover - not POSIX
        name_max, path_max = 255, 4096
    long = [part for part in Path(text).parts if len(os.fsencode(part)) > name_max]
    if long:
        raise ConfigError(
            f"{option}: the name {long[0][:40]!r}… is {len(os.fsencode(long[0]))} bytes long; "
            f"file names take at most {name_max}"
        )
    full = len(os.fsencode(os.path.abspath(text)))
    room = path_max - 1 - 48  # the staging folder the file is written in first
    if full > room:
        raise ConfigError(
            f"{option}: the path is {full} bytes long (absolute); at most {room} are taken"
        )


def _exists(p: Path) -> bool:
    try:
        return p.exists()
    except OSError:  # a name too long, a loop of links
        return False


def _ancestor(p: Path) -> Path:
    """The nearest existing ancestor of ``p`` (``p`` itself excluded)."""
    a = p.parent
    while not _exists(a) and a != a.parent:
        a = a.parent
    return a


def _partial_name(target: Path) -> Path:
    name = target.name
    for multi in (".csv.gz", ".meta.json"):
        if name.lower().endswith(multi):
            stem, suffix = name[: -len(multi)], name[-len(multi) :]
            break
    else:
        suffix = target.suffix
        stem = name[: -len(suffix)] if suffix else name
    for i in range(1, 1000):
        tag = "interrupted" if i == 1 else f"interrupted-{i}"
        cand = target.with_name(f"{stem}.{tag}{suffix}")
        if not cand.exists() and not Path(str(cand) + ".meta.json").exists():
            return cand
    raise ConfigError(f"no free name for the interrupted result next to {str(target)!r}")


@contextmanager
def _interrupts_held() -> Iterator[None]:
    """Hold off Ctrl-C, SIGTERM and SIGHUP while files are moved into place (main thread)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    got: list[Any] = []
    held = [getattr(signal, n) for n in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, n)]
    old: dict[Any, Any] = {}
    try:
        for sig in held:
            if signal.getsignal(sig) is not signal.SIG_IGN:
                old[sig] = signal.signal(sig, lambda *a: got.append(a))
    except (ValueError, OSError):  # pragma: no cover - not allowed here
        for sig, handler in old.items():
            signal.signal(sig, handler)
        yield
        return
    try:
        yield
    finally:
        for sig, handler in old.items():
            signal.signal(sig, handler)
    if got:  # the files are in place: say so rather than "nothing was written"
        signum = got[0][0]
        name = signal.Signals(signum).name
        raise Interrupted(
            f"{name} came while the outputs were moved into place; they were", signum=signum
        )


class OutputPlan:
    """The files and folders a command writes: checked first, replaced last.

    Parameters
    ----------
    inputs : iterable of path
        Files (and folders) the command reads; no output may be one of them.
        ``dataset:NAME`` items and ``None`` are ignored.
    command : str
        Name used in messages.

    Notes
    -----
    Declare each output with :meth:`file` or :meth:`folder` before the work
    starts (that is where every check runs), write through :meth:`path`
    during the work, and let the ``with`` block (or :meth:`commit`) move the
    staged files into place. A staged file keeps its final name, so writers
    that add companions (a CSV's ``.meta.json`` sidecar, a Markdown report's
    figure folder) are staged and published together with it.
    """

    def __init__(self, inputs: Iterable[Any] = (), *, command: str = "thermogym") -> None:
        self.command = command
        self._inputs: list[tuple[str, Path]] = []
        for item in inputs:
            self.add_input(item)
        self._targets: dict[str, tuple[Path, str, bool]] = {}
        self._roots: dict[Path, Path] = {}  # existing ancestor -> staging root
        self._closed = False

    # ------------------------------------------------------------------ declaration
    def add_input(self, item: Any, option: str = "input") -> None:
        """Record a path the command reads (ignored: ``None``, ``dataset:NAME``)."""
        if item is None:
            return
        if isinstance(item, list | tuple):
            for x in item:
                self.add_input(x, option)
            return
        text = os.fspath(item)
        if not text or text.startswith("dataset:"):
            return
        p = Path(text)
        self._inputs.append((option, p))
        if p.name.lower().endswith(_CSV_SUFFIXES):
            # the reader takes the CSV's units and roles from this sidecar, whether it exists
            # now or is written later: an output there would replace or reinterpret the input
            side = p.with_name(p.name + ".meta.json")
            self._inputs.append((f"{option}: the sidecar of {text!r}", side))
        if p.is_dir():
            try:
                for f in p.iterdir():
                    if f.is_file():
                        self._inputs.append((option, f))
            except OSError:
                pass

    def _clash(self, option: str, p: Path) -> None:
        for opt, q in self._inputs:
            if _same(p, q):
                raise ConfigError(
                    f"{option} {str(p)!r} is also an input ({opt}); writing it would destroy "
                    "the input: choose another name"
                )
            if p.name.lower().endswith(_CSV_SUFFIXES):  # its sidecar would be replaced
                side = p.with_name(p.name + ".meta.json")
                if _same(side, q):
                    raise ConfigError(
                        f"{option} {str(p)!r} would replace {str(q)!r}, an input ({opt})"
                    )
        for other, (q, _, _) in self._targets.items():
            if _same(p, q):
                raise ConfigError(f"{option} and {other} name the same path {str(p)!r}")

    def file(self, option: str, path: Any, kind: str = "file", *, stage: bool = True) -> Path:
        """Declare an output file; raise :class:`ConfigError` naming the problem.

        Parameters
        ----------
        option : str
            The option that names it (``"--out"``), for messages and :meth:`path`.
        path : path-like
            The target.
        kind : str
            ``"recording"``, ``"json"``, ``"figure"``, ``"html"``, ``"md"``,
            ``"csv"`` (the name must end accordingly) or ``"file"`` (any name).
        stage : bool
            Write through a staged path (False: only checked; the writer is
            atomic itself).
        """
        text = os.fspath(path) if path is not None else ""
        if not text.strip():
            raise ConfigError(f"{option} is empty; expected a file name")
        _check_name(option, text, _ancestor(Path(text)))
        p = Path(text)
        if p.is_dir():
            raise ConfigError(f"{option} {text!r} is a folder; expected a file name")
        if text.endswith(("/", os.sep)):
            raise ConfigError(f"{option} {text!r} ends in a '/' (a folder); expected a file name")
        suffixes = KIND_SUFFIXES.get(kind)
        if suffixes and not p.name.lower().endswith(suffixes):
            raise ConfigError(
                f"{option} {text!r}: expected a file name ending in {' or '.join(suffixes)}"
            )
        parent = p.parent
        if not parent.exists():
            raise ConfigError(
                f"{option} {text!r}: its folder {str(parent)!r} does not exist; create it first"
            )
        if not parent.is_dir():
            raise ConfigError(f"{option} {text!r}: {str(parent)!r} is a file, not a folder")
        if not os.access(parent, os.W_OK | os.X_OK):
            raise ConfigError(f"{option} {text!r}: the folder {str(parent)!r} is not writable")
        if p.exists() and not os.access(p, os.W_OK):
            raise ConfigError(f"{option} {text!r} exists and is read-only")
        self._clash(option, p)
        self._targets[option] = (p, "file", stage)
        return p

    def folder(self, option: str, path: Any, *, stage: bool = True) -> Path:
        """Declare an output folder (created when missing); raise naming the problem."""
        text = os.fspath(path) if path is not None else ""
        if not text.strip():
            raise ConfigError(f"{option} is empty; expected a folder")
        _check_name(option, text, _ancestor(Path(text)))
        p = Path(text)
        if p.exists() and not p.is_dir():
            raise ConfigError(
                f"{option} {text!r} is a file; expected a folder (created when missing)"
            )
        anc = p if p.is_dir() else _ancestor(p)
        if not anc.is_dir():
            raise ConfigError(f"{option} {text!r}: {str(anc)!r} is a file, not a folder")
        if not os.access(anc, os.W_OK | os.X_OK):
            raise ConfigError(f"{option} {text!r}: the folder {str(anc)!r} is not writable")
        for opt, q in self._inputs:
            if _same(p, q):
                raise ConfigError(
                    f"{option} {text!r} is also an input ({opt}); choose another folder"
                )
        for other, (q, _, _) in self._targets.items():
            if _same(p, q):
                raise ConfigError(f"{option} and {other} name the same path {text!r}")
        self._targets[option] = (p, "folder", stage)
        return p

    def must_not_exist(self, option: str) -> None:
        """Refuse when the output of ``option`` exists (e.g. ``--no-overwrite``)."""
        p = self._targets[option][0]
        if p.exists():
            raise ConfigError(f"{option} {str(p)!r} exists and overwriting was refused")

    # ------------------------------------------------------------------ writing
    def _root(self, anchor: Path) -> Path:
        root = self._roots.get(anchor)
        if root is None:
            root = anchor / f"{_STAGING_PREFIX}{os.getpid()}-{secrets.token_hex(4)}"
            root.mkdir()
            self._roots[anchor] = root
        return root

    def path(self, option: str) -> Path:
        """Where the command writes the output of ``option`` (staged until commit)."""
        if self._closed:
            raise ConfigError(f"the outputs of {self.command} were already published")
        try:
            p, kind, stage = self._targets[option]
        except KeyError:
            raise ConfigError(f"{option} was not declared as an output") from None
        if not stage:
            return p
        anchor = p.parent if kind == "file" else (p if p.is_dir() else _ancestor(p))
        rel = p.relative_to(anchor) if p != anchor else Path(".")
        staged = self._root(anchor) / rel
        if kind == "folder":
            staged.mkdir(parents=True, exist_ok=True)
        return staged

    def get(self, option: str) -> Path | None:
        """:meth:`path` for a declared option, ``None`` for one not given."""
        return self.path(option) if option in self._targets else None

    def final(self, p: Any) -> Path:
        """The published path of a staged path (or ``p`` itself)."""
        p = Path(p)
        for anchor, root in self._roots.items():
            try:
                return anchor / p.relative_to(root)
            except ValueError:
                continue
        return p

    def commit(self) -> list[Path]:
        """Move every staged file into place; the published files."""
        moved: list[Path] = []
        if self._closed:
            return moved
        with _interrupts_held():
            for anchor, root in self._roots.items():
                for src in sorted(root.rglob("*")):
                    if src.is_dir() and not src.is_symlink():
                        continue
                    dst = anchor / src.relative_to(root)
                    dst.parent.mkdir(parents=True, exist_ok=True)
                    if dst.is_dir() and not dst.is_symlink():
                        raise ConfigError(
                            f"cannot replace the folder {str(dst)!r} by a file; nothing more "
                            "was written"
                        )
                    os.replace(src, dst)
                    moved.append(dst)
                shutil.rmtree(root, ignore_errors=True)
            for p, kind, _ in self._targets.values():
                if kind == "folder":
                    p.mkdir(parents=True, exist_ok=True)
            self._closed = True
        return moved

    def discard(self) -> None:
        """Remove every staged file; the targets stay as they were."""
        for root in self._roots.values():
            shutil.rmtree(root, ignore_errors=True)
        self._roots.clear()
        self._closed = True

    def write_partial(self, option: str, write: Callable[[Path], Any]) -> Path:
        """Write a best-so-far result of an interrupted run under a new name.

        The name is the target's with ``.interrupted`` before its ending
        (``fit.interrupted.json``, numbered when taken); the target itself and
        every staged file are left alone (staged files are discarded).
        ``write(path)`` must write the file (atomically).
        """
        target = self._targets[option][0]
        self.discard()
        new = _partial_name(target)
        write(new)
        return new

    def __enter__(self) -> OutputPlan:
        return self

    def __exit__(self, exc_type: Any, exc: Any, tb: Any) -> None:
        if exc_type is None:
            self.commit()
        else:
            self.discard()


def plan_outputs(
    args: argparse.Namespace,
    *,
    files: Mapping[str, str] | Sequence[str] = (),
    folders: Sequence[str] = (),
    inputs: Sequence[str] = (),
    extra_inputs: Iterable[Any] = (),
    unstaged: Sequence[str] = (),
) -> OutputPlan:
    """Check the outputs named by ``args`` before any work starts.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options.
    files : mapping dest -> kind, or sequence of dest
        Options naming output files (kinds: see :meth:`OutputPlan.file`);
        options left ``None`` are skipped.
    folders : sequence of str
        Options naming output folders.
    inputs : sequence of str
        Options naming inputs (a path, a list of paths, ``dataset:NAME``).
    extra_inputs : iterable of path
        Further input paths.
    unstaged : sequence of str
        Outputs only checked, not staged (their writer is atomic and checks
        overwriting itself).

    Returns
    -------
    OutputPlan
        Use :meth:`OutputPlan.path` with the option (``"--out"``) to write.
    """
    plan = OutputPlan(command=str(getattr(args, "command", "thermogym")))
    for dest in inputs:
        plan.add_input(getattr(args, dest, None), _option(dest))
    for item in extra_inputs:
        plan.add_input(item)
    kinds = dict(files) if isinstance(files, Mapping) else dict.fromkeys(files, "file")
    for dest, kind in kinds.items():
        value = getattr(args, dest, None)
        if value is not None:
            plan.file(_option(dest), value, kind, stage=dest not in unstaged)
    for dest in folders:
        value = getattr(args, dest, None)
        if value is not None:
            plan.folder(_option(dest), value, stage=dest not in unstaged)
    return plan


# =============================================================================== messages
def one_line(text: str, limit: int = 800) -> str:
    r"""A message on one line (newlines folded, numpy reprs shown as numbers, capped).

    A message longer than ``limit`` keeps its start and its end (where the
    reason usually is) and loses its middle.

    Examples
    --------
    >>> one_line("value np.float64(30.0)\n  expected < 10")
    'value 30.0 expected < 10'
    """
    text = re.sub(r"\bnp\.(?:float|int|uint|bool_|str_)\w*\(([^()]*)\)", r"\1", str(text))
    text = " ".join(text.split())
    if len(text) <= limit:
        return text
    # elide the middle: the start names the thing, the end usually says what is wrong
    head = (2 * limit) // 3
    return f"{text[:head]} … {text[-(limit - head - 3) :]}"


def progress_wanted(requested: bool | None = None, stream: Any = None) -> bool:
    """Whether to draw a progress bar: never when switched off or not on a terminal."""
    if requested is False:
        return False
    s = sys.stderr if stream is None else stream
    return bool(getattr(s, "isatty", lambda: False)())
