"""Generated bad inputs for the ``thermogym`` command line, and how a run is judged.

Shared by the property-based test (``tests/test_cli_fuzz.py``, cases drawn by
``hypothesis``) and ``benchmarks/bad_input.py`` (cases drawn from a seeded
generator). A *case* is one command line over a small work folder of valid
files with exactly one thing wrong: an option value, an output path, a CSV
recording, a ``.meta.json`` sidecar, a FitResult, an external-model TOML/YAML
configuration, or a Ctrl-C (SIGTERM, SIGHUP) at some point of an otherwise valid
run.

Every case is known to be wrong, so its run is judged as:

``clear_error``
    exit status 2 (130 for Ctrl-C, 143/129 for SIGTERM/SIGHUP), exactly one
    non-empty line on stderr that starts ``thermogym`` and says ``error``
    (``interrupted``, ``terminated by SIGTERM``), no
    traceback, no ``np.float64(...)``, and the line names the offending
    option, value, column, key or file (one of the case's *needles*).
``unclear``
    exit 2 (130) but not all of the above (e.g. the message does not name the
    offender, or several lines).
``traceback``
    an exception escaped, a ``Traceback`` was printed, or the CLI reported an
    internal error (exit 1), or the case ran past its time limit.
``silent_wrong``
    exit status 0: a known-bad input accepted.
``file_damage`` (counted besides the above)
    any file of the work folder changed or removed, or, after a run that did
    not succeed, a new file left behind (except a best-so-far
    ``*.interrupted*`` file that the message names). The outputs of a run that
    wrongly exits 0 are counted under ``silent_wrong`` only.

A *picker* draws the case's choices: :class:`RandomPicker` (seeded) or the
test's hypothesis picker; both provide ``choice``, ``integer``, ``number`` and
``text``.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
import math
import os
import shutil
import signal
import tempfile
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

__all__ = [
    "FAMILIES",
    "Case",
    "Outcome",
    "RandomPicker",
    "build_fixtures",
    "run_case",
]


class Picker(Protocol):
    """Source of the choices a case makes."""

    def choice(self, items: Sequence[Any]) -> Any: ...
    def integer(self, lo: int, hi: int) -> int: ...
    def number(self, lo: float, hi: float) -> float: ...
    def text(self, max_size: int = 8) -> str: ...


class RandomPicker:
    """Choices from a seeded :class:`numpy.random.Generator`."""

    _ALPHABET = "abcxyzQ_-;,. :#\"'[]{}()=%é°\t"

    def __init__(self, rng: np.random.Generator) -> None:
        self.rng = rng

    def choice(self, items: Sequence[Any]) -> Any:
        return items[int(self.rng.integers(len(items)))]

    def integer(self, lo: int, hi: int) -> int:
        return int(self.rng.integers(lo, hi + 1))

    def number(self, lo: float, hi: float) -> float:
        return float(self.rng.uniform(lo, hi))

    def text(self, max_size: int = 8) -> str:
        n = int(self.rng.integers(1, max_size + 1))
        return "".join(self._ALPHABET[int(i)] for i in self.rng.integers(0, len(self._ALPHABET), n))


@dataclass
class Case:
    """One command line over the work folder, with one thing wrong."""

    family: str
    argv: list[str]
    needles: list[str]
    files: dict[str, bytes | None] = field(default_factory=dict)  # None: remove
    expect: str = "error"  # or "interrupt"
    inject: tuple[str, str] | None = None  # (module, attribute) that raises Ctrl-C
    inject_after: int = 0  # calls let through before the interruption
    signal_name: str = "SIGINT"  # or SIGTERM, SIGHUP: sent to this process (`kill`)
    note: str = ""

    def describe(self) -> str:
        return f"[{self.family}] thermogym {' '.join(self.argv)}" + (
            f"  ({self.note})" if self.note else ""
        )


@dataclass
class Outcome:
    """How a case ran and how it is judged."""

    code: int | None
    out: str
    err: str
    verdict: str  # clear_error | unclear | traceback | silent_wrong
    damage: list[str]
    seconds: float


# =============================================================================== fixtures
_FIXTURES: dict[str, bytes] | None = None


def _csv(cols: dict[str, Sequence[float]], fmt: str = "{:.6g}") -> bytes:
    names = list(cols)
    n = len(next(iter(cols.values())))
    rows = [",".join(names)]
    rows += [",".join(fmt.format(cols[c][i]) for c in names) for i in range(n)]
    return ("\n".join(rows) + "\n").encode()


def build_fixtures() -> dict[str, bytes]:
    """The valid files of a work folder (built once per process)."""
    global _FIXTURES
    if _FIXTURES is not None:
        return _FIXTURES
    from thermogym.cli import main

    files: dict[str, bytes] = {}
    t = np.arange(60.0)
    files["ax.csv"] = _csv(
        {"time": t, "u": (t < 30).astype(float), "k_U": np.full(60, 24.0), "T_U": np.full(60, 25.0)}
    )
    d = np.loadtxt(ROOT / "thermogym/datasets/data/daisy_hair_dryer/dryer.dat")[:300]
    files["hd.csv"] = _csv({"time": 0.08 * np.arange(300), "u": d[:, 0], "y": d[:, 1]})
    files["lag_func.py"] = (ROOT / "tests/data/external/lag_func.py").read_bytes()
    files["ext.toml"] = EXT_TOML.encode()
    with tempfile.TemporaryDirectory() as tmp, contextlib.redirect_stdout(io.StringIO()):
        w = Path(tmp)
        (w / "hd.csv").write_bytes(files["hd.csv"])
        argv = [
            "experiment",
            "strut",
            "steps",
            "--out",
            str(w / "s"),
            "--option",
            "feed_rates=[20]",
        ]
        assert main(argv) == 0
        files["strut.csv"] = (w / "s" / "strut-step-20.csv").read_bytes()
        files["strut.csv.meta.json"] = (w / "s" / "strut-step-20.csv.meta.json").read_bytes()
        common = ["--inputs", "u", "--outputs", "y"]
        assert main(["identify", "n4sid", str(w / "hd.csv"), *common, "--order", "2",
                     "--out", str(w / "ss.json")]) == 0  # fmt: skip
        assert main(["identify", "foptd", str(w / "hd.csv"), *common, "--operating-point",
                     "mean", "--out", str(w / "fo.json")]) == 0  # fmt: skip
        files["fit_ss.json"] = (w / "ss.json").read_bytes()
        files["fit_foptd.json"] = (w / "fo.json").read_bytes()
    from thermogym.fitresult import FitResult
    from thermogym.models.registry import get_model

    fit = FitResult.from_model(get_model("axt211"), {"C_P": 20.0}, method="by hand")
    files["fit_axt211.json"] = json.dumps(fit.to_dict()).encode()
    files["sub/.keep"] = b""
    _FIXTURES = files
    return files


EXT_TOML = """type = "callable"
path = "lag_func.py"
function = "lag"
timeout = 30

[parameters]
K = {start = 1.0, lower = 0.1, upper = 10.0}
tau = {start = 5.0, lower = 0.1, upper = 100.0}

[inputs]
u = "u"

[outputs]
y = "y"

[evaluation]
backend = "serial"
"""

EXT_YAML = """type: callable
path: lag_func.py
function: lag
timeout: 30
parameters:
  K: {start: 1.0, lower: 0.1, upper: 10.0}
  tau: {start: 5.0, lower: 0.1, upper: 100.0}
inputs: {u: u}
outputs: {y: y}
evaluation: {backend: serial}
"""


# =============================================================================== option values
def _bad_number(p: Picker, kind: str, lo: float = 0.0, hi: float = 1.0) -> str:
    """A value outside what an option of ``kind`` accepts."""
    common = ["nan", "inf", "-inf", "abc", "", "1e", "--", "0x1g", "½"]
    if p.integer(0, 2) == 0:
        return p.choice([*common, p.text(5)]) if kind != "text" else p.text(5)
    if kind == "prob":
        return p.choice([f"{p.number(1.0, 1e3):.6g}", f"{-p.number(0, 10):.6g}", "0", "1"])
    if kind == "pos":
        return p.choice(["0", f"{-p.number(1e-9, 1e6):.6g}", "-0"])
    if kind == "nonneg":
        return f"{-p.number(1e-6, 1e6):.6g}"
    if kind.startswith("int>="):
        k = int(kind[5:])
        return p.choice([str(k - p.integer(1, 50)), f"{k + 0.5}", "1e400", "2.5"])
    if kind == "unit":  # (0, 1]
        return p.choice(["0", f"{p.number(1.0001, 50):.6g}", f"{-p.number(0, 1):.6g}"])
    return p.text(5)


_BASES: dict[str, list[str]] = {
    "diagnose": ["diagnose", "--model", "strut", "--train", "strut.csv", "--validate",
                 "strut.csv", "--out", "r.json", "--quiet"],
    "bench": ["bench", "--env", "AXT211Valve", "--controllers", "onoff", "--seeds", "1",
              "--out", "bench", "--no-progress"],
    "n4sid": ["identify", "n4sid", "hd.csv", "--inputs", "u", "--outputs", "y", "--out", "f.json"],
    "foptd": ["identify", "foptd", "hd.csv", "--inputs", "u", "--outputs", "y", "--out", "f.json"],
    "rls": ["identify", "rls", "hd.csv", "--inputs", "u", "--outputs", "y", "--out", "f.json"],
    "montecarlo": ["identify", "montecarlo", "--model", "strut", "strut.csv", "--free", "r_motor",
                   "--samples", "20", "--no-progress", "--out", "f.json"],
    "evolution": ["identify", "evolution", "--model", "strut", "strut.csv", "--free", "r_motor",
                  "--max-iter", "1", "--no-progress", "--out", "f.json"],
    "cmaes": ["identify", "cmaes", "--model", "strut", "strut.csv", "--free", "r_motor",
              "--max-iter", "1", "--no-progress", "--out", "f.json"],
    "anneal": ["identify", "anneal", "--model", "strut", "strut.csv", "--free", "r_motor",
               "--max-iter", "1", "--no-progress", "--out", "f.json"],
    "greybox": ["identify", "greybox", "--model", "strut", "strut.csv", "--free", "r_motor",
                "--max-iter", "2", "--no-progress", "--out", "f.json"],
    "simulate": ["simulate", "axt211", "--inputs", "ax.csv", "--out", "sim.csv"],
    "experiment": ["experiment", "strut", "steps", "--out", "exp", "--option", "feed_rates=[20]"],
    "virtual-sensor": ["virtual-sensor", "hd.csv", "--fit", "fit_ss.json", "--out", "vs.csv"],
    "budget": ["firmware", "budget", "fit_ss.json"],
    "export": ["firmware", "export", "fit_ss.json", "--out", "fw", "--no-avr-check"],
    "demo": ["demo", "--out", "demo", "--quick", "--no-progress", "--only", "rigs"],
    "models": ["models", "strut"],
    "compare": ["compare", "fit_ss.json", "fit_foptd.json", "--data", "hd.csv"],
    "resid": ["resid", "fit_ss.json", "--data", "hd.csv"],
    "arx": ["identify", "arx", "hd.csv", "--inputs", "u", "--outputs", "y", "--max-order", "3",
            "--out", "f.json"],
    "ssest": ["identify", "ssest", "hd.csv", "--inputs", "u", "--outputs", "y", "--order", "2",
              "--no-refine", "--out", "f.json"],
    "auto": ["identify", "auto", "hd.csv", "--inputs", "u", "--outputs", "y", "--families",
             "arx", "--max-order", "2", "--out", "f.json"],
    "sopdt": ["identify", "sopdt", "hd.csv", "--inputs", "u", "--outputs", "y", "--out",
              "f.json"],
    "armax": ["identify", "armax", "hd.csv", "--inputs", "u", "--outputs", "y", "--max-order",
              "2", "--out", "f.json"],
    "oe": ["identify", "oe", "hd.csv", "--inputs", "u", "--outputs", "y", "--max-order", "2",
           "--out", "f.json"],
    "bj": ["identify", "bj", "hd.csv", "--inputs", "u", "--outputs", "y", "--max-order", "2",
           "--out", "f.json"],
}  # fmt: skip

#: (base, option, kind, extra): numeric options and their range
_NUMERIC: list[tuple[str, str, str]] = [
    ("diagnose", "--alpha", "prob"),
    ("diagnose", "--dt", "pos"),
    ("diagnose", "--time-limit", "pos"),
    ("bench", "--workers", "int>=1"),
    ("bench", "--seeds", "int>=1"),
    ("n4sid", "--folds", "int>=2"),
    ("n4sid", "--order", "int>=1"),
    ("n4sid", "--horizon", "int>=1"),
    ("foptd", "--max-delay-s", "nonneg"),
    ("rls", "--forgetting", "unit"),
    ("rls", "--max-delay-s", "nonneg"),
    ("montecarlo", "--samples", "int>=1"),
    ("montecarlo", "--batch-size", "int>=1"),
    ("montecarlo", "--level", "prob"),
    ("montecarlo", "--time-limit", "pos"),
    ("montecarlo", "--max-iter", "int>=1"),
    ("montecarlo", "--max-evals", "int>=1"),
    ("montecarlo", "--seed", "int>=0"),
    ("montecarlo", "--target", "pos"),
    ("evolution", "--popsize", "int>=2"),
    ("cmaes", "--sigma0", "pos"),
    ("anneal", "--chains", "int>=1"),
    ("experiment", "--seed", "int>=0"),
    ("virtual-sensor", "--measurement-std", "pos"),
    ("virtual-sensor", "--process-std", "pos"),
    ("budget", "--flash-budget", "int>=1"),
    ("budget", "--ram-budget", "int>=1"),
    ("budget", "--measurement-std", "pos"),
    ("demo", "--seed", "int>=0"),
    ("compare", "--k-step", "int>=1"),
    ("resid", "--k-step", "int>=1"),
    ("resid", "--max-lag", "int>=1"),
    ("resid", "--alpha", "prob"),
    ("arx", "--folds", "int>=2"),
    ("arx", "--max-order", "int>=1"),
    ("arx", "--max-delay", "int>=0"),
    ("ssest", "--order", "int>=1"),
    ("ssest", "--max-delay", "int>=0"),
    ("sopdt", "--max-delay-s", "nonneg"),
    ("auto", "--folds", "int>=2"),
    ("armax", "--max-order", "int>=1"),
    ("oe", "--folds", "int>=2"),
    ("bj", "--max-delay", "int>=0"),
]

#: (base, option, bad values, needles): options with a structure of their own
_STRUCTURED: list[tuple[str, str, list[str], list[str]]] = [
    ("diagnose", "--scheme", ["best", "SPLIT", ""], ["--scheme"]),
    ("diagnose", "--model", ["nope", "ss:0", "ss:x", "foptd:3"], ["nope", "ss:0", "ss:x",
                                                                  "foptd:3", "--model"]),
    ("diagnose", "--candidates", ["gremlins", ",", "backlash,zz"],
     ["gremlins", "candidates", ",", "zz"]),
    ("bench", "--backend", ["threads", ""], ["--backend"]),
    ("bench", "--record", ["some"], ["--record"]),
    ("bench", "--seed-list", ["a", "-1", "1,x", ","], ["--seed-list"]),
    ("bench", "--plant", ["moon", ",", "model,moon"], ["--plant", "moon"]),
    ("bench", "--env", ["Nope", "thermogym/Nope-v0"], ["Nope"]),
    ("bench", "--controllers", ["nope", "onoff,zz"], ["nope", "zz"]),
    ("bench", "--scenario", ["nope"], ["nope"]),
    ("n4sid", "--orders", ["5:2", "0:3", "a:b", "1:"], ["--orders"]),
    ("n4sid", "--decimate", ["0", "-2", "x", "1.5"], ["--decimate"]),
    ("n4sid", "--weighting", ["pca"], ["--weighting"]),
    ("n4sid", "--scheme", ["loo"], ["--scheme"]),
    ("foptd", "--operating-point", ["median"], ["--operating-point"]),
    ("foptd", "--criterion", ["aic"], ["--criterion"]),
    ("foptd", "--inputs", ["nope", "u,nope", ","], ["nope", "--inputs", ","]),
    ("foptd", "--outputs", ["zz", ","], ["zz", "--outputs", ","]),
    ("foptd", "--model", ["nope"], ["nope"]),
    ("rls", "--delays", ["a", "-1", "1,x", "100000"], ["--delays"]),
    ("montecarlo", "--free", ["nope", "r_motor=3:1", "r_motor=a:b", "r_nut=1:2:9", "r_nut=1"],
     ["nope", "r_motor", "r_nut"]),
    ("montecarlo", "--fix", ["r_nut=abc", "nope=1", "r_nut"], ["r_nut", "nope"]),
    ("montecarlo", "--pair", ["nope", "T_nut@-1", "T_nut@abc", "T_nut:zz"],
     ["nope", "T_nut", "zz"]),
    ("montecarlo", "--log", ["nope"], ["nope", "--log"]),
    ("montecarlo", "--input-noise", ["feed_rate=-1", "nope", "feed_rate=x"],
     ["feed_rate", "nope"]),
    ("montecarlo", "--chains", ["3"], ["--chains"]),
    ("montecarlo", "--sampler", ["grid"], ["--sampler"]),
    ("montecarlo", "--model", ["nope"], ["nope"]),
    ("montecarlo", "--effects", ["gremlins"], ["gremlins"]),
    ("montecarlo", "--objective", ["mae"], ["--objective"]),
    ("simulate", "--set", ["C_P=abc", "C_P=nan", "=1", "nope=1", "C_P", "C_P=-5"],
     ["C_P", "=1", "nope"]),
    ("simulate", "MODEL", ["nope", "ss:x"], ["nope", "ss:x"]),
    ("experiment", "--option", ["feed_rates=abc", "feed_rates=[]", "feed_rates=[-1]",
                                "T_air=hot", "T_air=1e9", "nope=1", "feed_rates",
                                "feed_rates=[1e400]"], ["feed_rates", "T_air", "nope"]),
    ("experiment", "--format", ["xlsx"], ["--format"]),
    ("experiment", "--effect", ["gremlins", "backlash:zz=1"], ["gremlins", "backlash", "zz"]),
    ("experiment", "RIG", ["nope"], ["nope"]),
    ("virtual-sensor", "--method", ["ukf"], ["--method"]),
    ("virtual-sensor", "--measured", ["nope"], ["nope"]),
    ("virtual-sensor", "--hidden", ["nope"], ["nope"]),
    ("virtual-sensor", "--rest", ["u", "u=", "=1", "u=nan", "u=inf"], ["u", "=1"]),
    ("virtual-sensor", "--reference", ["nope"], ["nope"]),
    ("budget", "--range", ["u=5:1", "u=a:b", "u", "u=1"], ["u=", "--range"]),
    ("budget", "--target", ["z80"], ["z80"]),
    ("export", "--offset", ["u=abc", "u", "=2"], ["u=abc", "'u'", "=2"]),
    ("export", "--scale", ["y=x"], ["y=x"]),
    ("demo", "--only", ["nope", "all"], ["--only"]),
    ("models", "MODEL", ["nope", "ss:0", "Strut"], ["nope", "ss:0", "Strut"]),
    ("simulate", "--delimiter", ["ab", "", ".", "dot"], ["--delimiter"]),
    ("simulate", "--decimal", [";", "x"], ["--decimal"]),
    ("simulate", "--time-column", ["nope", "u"], ["nope", "time"]),
    ("foptd", "--prepare", ["hampel_window=0", "dt=-1", "valid_range=5:1", "nope=1",
                            "detrend=bad", "dt=abc", "outliers=maybe", "max_gap_s=-3"],
     ["hampel_window", "dt", "valid_range", "nope", "detrend", "outliers", "max_gap_s"]),
    ("montecarlo", "--prepare", ["hampel_sigma=0", "resample_method=cubic", "columns=[]"],
     ["hampel_sigma", "resample_method", "columns"]),
    # found by the second review of issue 17 (values parsed late, duplicates, huge numbers)
    ("montecarlo", "--samples", ["1000000000000", "10000001"], ["--samples"]),
    ("bench", "--seed-list", ["99999999999999999999999", "1,1", "4294967296"], ["--seed-list"]),
    ("diagnose", "--candidates", ["sensor_lag,sensor_lag"], ["--candidates", "sensor_lag"]),
    ("diagnose", "--inputs", ["u,u", ",", ""], ["--inputs"]),
    ("diagnose", "--model", ["augmented", "ss:", "ss:-1", "strut:2"], ["--model"]),
    ("n4sid", "--orders", ["1:100000", "0:0", "3:1"], ["--orders"]),
    ("simulate", "--set", ["C_P=20 --set C_P=30"], ["C_P"]),
    ("arx", "--na", ["abc", "-1", "1;x"], ["--na"]),
    ("arx", "--nk", ["x", "-2"], ["--nk"]),
    ("armax", "--nc", ["x", "-1", "1;"], ["--nc"]),
    ("oe", "--nf", ["abc", "-3"], ["--nf"]),
    ("bj", "--nd", ["1;x", "-1"], ["--nd"]),
    ("bj", "--focus", ["both"], ["--focus"]),
    ("arx", "--model", ["nope"], ["nope"]),
    ("rls", "--delays", ["-1,2", "1.5"], ["--delays"]),
    ("foptd", "--prepare", ["dt=1 dt=2"], ["dt"]),
    ("greybox", "--free", ["r_motor --free r_motor"], ["r_motor"]),
    ("ssest", "--orders", ["3:1", "a:b", "1:100000"], ["--orders"]),
    ("ssest", "--input-delay", ["1,2", "x", "-1"], ["--input-delay"]),
    ("auto", "--families", ["zz", "arx,zz", ",", "arx,arx"], ["--families", "zz", ","]),
    ("compare", "--labels", ["a,b,c", "a,a", ","], ["--labels"]),
    ("compare", "--x0", ["guess"], ["--x0"]),
    ("resid", "--x0", ["guess"], ["--x0"]),
    ("experiment", "--option", ["feed_rates=[1e300]", "feed_rates=[1e30]"],
     ["1e+300", "1e+30", "physics"]),
]  # fmt: skip


def _with(base: str, option: str, value: str) -> list[str]:
    argv = list(_BASES[base])
    if option == "MODEL":  # the positional model name of simulate
        argv[1] = value
    elif option == "RIG":
        argv[1] = value
    elif option == "--option":  # replaces the base's value of the same key
        key = value.partition("=")[0] + "="
        at = [i for i in range(len(argv) - 1) if argv[i] == option and argv[i + 1].startswith(key)]
        if at:
            argv[at[0] + 1] = value
        else:
            argv += [option, value]
    elif " --set " in value or " --free " in value:  # the same option twice
        first, second = value.split(f" {option} ")
        argv += [option, first, option, second]
    elif option == "--prepare" and " " in value:  # the same key twice in one list
        argv += [option, *value.split()]
    elif option in argv and option not in ("--option", "--free"):
        i = argv.index(option)
        argv[i + 1] = value
    else:
        argv += [option, value]
    return argv


def option_value(p: Picker) -> Case:
    """A numeric option out of its range, or a structured option with a bad value."""
    if p.integer(0, 1) == 0:
        base, option, kind = p.choice(_NUMERIC)
        value = _bad_number(p, kind)
        needles = [option]
        return Case("option", _with(base, option, value), needles, note=kind)
    base, option, values, needles = p.choice(_STRUCTURED)
    value = p.choice(values)
    return Case("option", _with(base, option, value), needles)


def command_line(p: Picker) -> Case:
    """An unknown option, command or method; a missing argument."""
    base = p.choice(list(_BASES))
    kind = p.integer(0, 3)
    if kind == 0:
        flag = "--" + p.choice(["bogus", "alpa", "fold", "output", "verbose-x", "x"])
        return Case("command", [*_BASES[base], flag], [flag])
    if kind == 1:
        word = p.choice(["simulat", "identfy", "nope", "run", "--bogus"])
        return Case("command", [word], [word, "command"])
    if kind == 2:
        method = p.choice(["arx9", "ls", "nope"])
        return Case("command", ["identify", method, "hd.csv", "--out", "f.json"], [method])
    # a required argument left out
    argv, needles = p.choice(
        [
            (["experiment", "strut"], ["protocol"]),
            (["experiment", "strut", "steps"], ["--out"]),
            (["simulate", "axt211", "--out", "s.csv"], ["--inputs"]),
            (["simulate", "--inputs", "ax.csv", "--out", "s.csv"], ["MODEL", "--params"]),
            (["diagnose", "--model", "strut", "--train", "strut.csv", "--out", "r.json"],
             ["--validate"]),
            (["virtual-sensor", "hd.csv", "--out", "v.csv"], ["--fit"]),
            (["firmware", "budget"], ["fit"]),
            (["firmware"], ["SUBCOMMAND", "fw_command", "required"]),
            (["identify", "foptd", "--out", "f.json"], ["data"]),
            (["identify", "foptd", "hd.csv"], ["--out"]),
            (["identify", "montecarlo", "strut.csv", "--out", "f.json"], ["--model", "--external"]),
            (["identify"], ["method"]),
            (["bench", "--env", "AXT211Valve"], ["--out"]),
            (["bench", "--out", "b"], ["--env"]),
        ]
    )  # fmt: skip
    return Case("command", argv, needles, note="missing argument")


# =============================================================================== outputs
#: base -> (input option or positional to collide with, output option, kind)
_OUTPUTS: dict[str, tuple[str, str]] = {
    "simulate": ("ax.csv", "--out"),
    "virtual-sensor": ("hd.csv", "--out"),
    "foptd": ("fit_foptd.json", "--out"),
    "diagnose": ("strut.csv", "--out"),
    "montecarlo": ("fit_foptd.json", "--out"),
    "experiment": ("ax.csv", "--out"),
    "bench": ("ax.csv", "--out"),
    "export": ("ax.csv", "--out"),
    "demo": ("ax.csv", "--out"),
}
_FOLDER_OUT = {"experiment", "bench", "export", "demo"}


def outputs(p: Picker) -> Case:
    """An output that must be refused before any work: an input, a missing folder, a clash."""
    base = p.choice(list(_OUTPUTS))
    existing, opt = _OUTPUTS[base]
    if base in _FOLDER_OUT:
        value = p.choice([existing, "strut.csv", "sub/.keep"])
        return Case("outputs", _with(base, opt, value), [opt, value], note="file for folder")
    kind = p.integer(0, 7)
    if kind == 5:  # a name no file system takes: a NUL, hundreds of characters, a trailing /
        value = p.choice(["f\x00" + _ext(base), "x" * p.integer(256, 400) + _ext(base),
                          "/".join(["d"] * p.integer(1100, 3000)) + "/x" + _ext(base)])  # fmt: skip
        return Case("outputs", _with(base, opt, value), [opt, "NUL", "bytes long"],
                    note="unusable name")  # fmt: skip
    if kind == 6 and base not in _FOLDER_OUT:
        value = "x" + _ext(base) + "/"
        return Case("outputs", _with(base, opt, value), [opt, "'/'"], note="trailing slash")
    if kind == 7:  # an output below a file
        value = f"{existing}/x{_ext(base)}"
        return Case("outputs", _with(base, opt, value), [opt, existing], note="under a file")
    if kind == 0:  # the output is an input (or names it another way)
        src = {"simulate": "ax.csv", "virtual-sensor": "hd.csv", "diagnose": "strut.csv"}
        if base in src:
            value = p.choice([src[base], f"./{src[base]}", f"sub/../{src[base]}"])
            return Case("outputs", _with(base, opt, value), [opt], note="output is input")
        if base == "montecarlo":
            argv = [*_with("rls", "--out", "fit_foptd.json"), "--from-fit", "fit_foptd.json"]
            return Case("outputs", argv, ["--out", "fit_foptd.json"], note="out is --from-fit")
        value = "hd.csv"
        return Case("outputs", _with(base, opt, value), [opt, "hd.csv"], note="bad extension")
    if kind == 1:
        value = p.choice(["nodir/x", "nodir/deeper/x"]) + _ext(base)
        return Case("outputs", _with(base, opt, value), [opt, "nodir"], note="missing folder")
    if kind == 2:
        value = p.choice(["sub", ".", "sub/"])
        return Case("outputs", _with(base, opt, value), [opt, "folder"], note="folder for file")
    if kind == 3:
        value = "x" + p.choice([".txt", ".xlsx", "", ".json.bak"])
        if base in ("foptd", "montecarlo", "diagnose") and value.endswith(".json"):
            value += ".x"
        if _ext(base) == value[-len(_ext(base)) :]:
            value += ".x"
        return Case("outputs", _with(base, opt, value), [opt, value], note="extension")
    if base == "diagnose":
        extra = p.choice([["--augmented-fit", "r.json"], ["--html", "r.json"]])
        return Case("outputs", [*_BASES[base], *extra], [extra[0], "--out", "r.json"])
    if base == "simulate":
        return Case("outputs", [*_BASES[base], "--plot", "ax.csv"], ["--plot"])
    if base == "foptd":
        return Case("outputs", [*_BASES[base], "--plots", "ax.csv"], ["--plots", "ax.csv"])
    if base == "montecarlo":
        argv = [*_with(base, "--out", "fit_foptd.json"), "--no-overwrite"]
        return Case("outputs", argv, ["--out", "fit_foptd.json"], note="--no-overwrite")
    return Case("outputs", [*_BASES[base], "--plot", "sub"], ["--plot", "sub"])


def _ext(base: str) -> str:
    return {"simulate": ".csv", "virtual-sensor": ".csv"}.get(base, ".json")


# =============================================================================== CSV files
#: slot -> (argv with FILE for the recording, its columns, needles always accepted)
_CSV_SLOTS: dict[str, tuple[list[str], str]] = {
    "simulate": (["simulate", "axt211", "--inputs", "FILE", "--out", "sim.csv"], "ax.csv"),
    "foptd": (["identify", "foptd", "FILE", "--inputs", "u", "--outputs", "y", "--out",
               "f.json"], "hd.csv"),
    "n4sid": (["identify", "n4sid", "FILE", "--inputs", "u", "--outputs", "y", "--order", "2",
               "--out", "f.json"], "hd.csv"),
    "diagnose": (["diagnose", "--model", "strut", "--train", "FILE", "--validate", "strut.csv",
                  "--out", "r.json", "--quiet"], "strut.csv"),
    "virtual-sensor": (["virtual-sensor", "FILE", "--fit", "fit_ss.json", "--out", "vs.csv"],
                       "hd.csv"),
    "montecarlo": (["identify", "montecarlo", "--model", "strut", "FILE", "--free", "r_motor",
                    "--samples", "20", "--no-progress", "--out", "f.json"], "strut.csv"),
    "external": (["identify", "montecarlo", "--external", "ext.toml", "FILE", "--samples", "10",
                  "--no-progress", "--out", "f.json"], "hd.csv"),
}  # fmt: skip


def _table(data: bytes) -> tuple[list[str], list[list[str]]]:
    lines = data.decode().strip().splitlines()
    return lines[0].split(","), [ln.split(",") for ln in lines[1:]]


def _join(header: list[str], rows: list[list[str]]) -> bytes:
    return ("\n".join([",".join(header), *(",".join(r) for r in rows)]) + "\n").encode()


def csv_file(p: Picker) -> Case:
    """A recording with one defect, fed to a command that reads recordings."""
    slot = p.choice(list(_CSV_SLOTS))
    argv, base = _CSV_SLOTS[slot]
    fx = build_fixtures()
    header, rows = _table(fx[base])
    name = "bad.csv"
    files: dict[str, bytes | None] = {}
    data_cols = [c for c in header if c != "time"]
    # the columns the command cannot do without (an output a diagnosis or a virtual
    # sensor does without is no error)
    needed = {"simulate": ["u", "k_U", "T_U"], "diagnose": ["feed_rate", "T_air"],
              "montecarlo": ["feed_rate", "T_air"], "virtual-sensor": ["u"]}.get(
        slot, ["u", "y"])  # fmt: skip
    col = p.choice([c for c in needed if c in data_cols])
    j = header.index(col)
    i = p.integer(0, len(rows) - 1)
    kind = p.choice(
        ["empty", "header", "cell", "drop", "notime", "dup", "order", "timenan", "ragged",
         "binary", "delimiter", "inf", "single", "allnan", "suffix", "missing", "gz", "parquet",
         "blankname", "utf16", "utf16le", "utf32", "latin1", "backwards", "nul", "gzcut",
         "spaces", "short", "span"]
    )  # fmt: skip
    if kind == "span" and slot in ("virtual-sensor", "montecarlo", "external"):
        # two samples decades apart: a filter or a grey-box search has a defined (if
        # uninformative) answer on them; only fixed-step simulation and the methods with a
        # least length refuse them
        kind = "backwards"
    needles = [name]
    data: bytes | None
    if kind == "empty":
        data, needles = b"", ["empty"]
    elif kind == "header":
        data, needles = _join(header, []), ["no samples", "header", "sample"]
    elif kind == "cell":
        bad = p.choice(["abc", "1.2.3", "--", "x" + p.text(4).replace(",", "")])
        bad = bad.replace("\n", "").replace(",", "") or "q"
        rows[i][j] = bad
        data, needles = _join(header, rows), [col]
    elif kind == "drop":
        data = _join([h for h in header if h != col], [r[:j] + r[j + 1 :] for r in rows])
        needles = [col]
    elif kind == "notime":
        header[0] = p.choice(["zeit", "clock", "stamp_ms"])
        data, needles = _join(header, rows), ["time"]
    elif kind == "dup":
        header[j] = header[1 if j != 1 else 2]
        data, needles = _join(header, rows), [header[j]]
    elif kind == "order":
        k = max(1, i)
        rows[k][0] = rows[k - 1][0]
        data, needles = _join(header, rows), ["increasing", "time"]
    elif kind == "timenan":
        rows[i][0] = p.choice(["nan", "", "inf"])
        data, needles = _join(header, rows), ["time"]
    elif kind == "ragged":
        rows[i] = [*rows[i], "1"]
        data, needles = _join(header, rows), ["columns", "delimiter", "line"]
    elif kind == "binary":
        data, needles = bytes(range(256)) * 3, [name, "utf", "read"]
    elif kind == "delimiter":
        data = _join(header, rows)
        argv = [*argv, "--delimiter", ";"]
        needles = ["delimiter", "--delimiter"]
    elif kind == "inf":
        rows[i][j] = p.choice(["inf", "-inf", "Infinity"])
        data, needles = _join(header, rows), [col]
    elif kind == "single":
        data, needles = _join(header, rows[:1]), ["sample", "single", "1 "]
    elif kind == "allnan":
        for r in rows:
            r[j] = ""
        data, needles = _join(header, rows), [col]
    elif kind == "suffix":
        name = "bad.txt"
        data, needles = _join(header, rows), [".txt", "extension", name]
    elif kind == "missing":
        name, data, needles = "absent.csv", None, ["absent.csv"]
    elif kind == "gz":
        name = "bad.csv.gz"
        data, needles = _join(header, rows), [name]
    elif kind == "parquet":
        name = "bad.parquet"
        data, needles = _join(header, rows), [name]
    elif kind == "blankname":
        header[j] = p.choice(["", " ", "T U", "1x"])
        data, needles = _join(header, rows), ["column", col]
    elif kind == "utf16":  # a spreadsheet export in another encoding
        data, needles = _join(header, rows).decode().encode("utf-16"), [name, "UTF-16"]
    elif kind == "utf16le":  # ... without a byte-order mark
        data, needles = _join(header, rows).decode().encode("utf-16-le"), [name, "UTF-16"]
    elif kind == "utf32":
        data, needles = _join(header, rows).decode().encode("utf-32"), [name, "UTF-32"]
    elif kind == "latin1":  # a unit in the header, written by an older tool
        header[j] = header[j] + p.choice([" [°C]", " (µm)", "_é"])
        data, needles = _join(header, rows).decode().encode("latin-1"), [name, "UTF-8"]
    elif kind == "backwards":
        data, needles = _join(header, rows[::-1]), ["increasing", "time"]
    elif kind == "nul":
        rows[i][j] = "\x00" * p.integer(1, 3)
        data, needles = _join(header, rows), [col, name]
    elif kind == "gzcut":
        import gzip

        name = "bad.csv.gz"
        whole = gzip.compress(_join(header, rows))
        data, needles = whole[: p.integer(11, len(whole) - 9)], [name]
    elif kind == "spaces":
        header[j] = f" {header[j]} "
        data, needles = _join(header, rows), [col, "column"]
    elif kind == "short":
        rows[i] = rows[i][:-1]
        data, needles = _join(header, rows), ["columns", "delimiter", name]
    else:  # span: two samples decades apart (a time axis in the wrong unit)
        rows = [rows[0], [*rows[1]]]
        rows[1][0] = p.choice(["1e9", "3e9", "1.7e9"])
        data, needles = _join(header, rows), ["time", "samples", "integrator", "resample"]
    if data is not None:
        files[name] = data
    argv = [name if a == "FILE" else a for a in argv]
    return Case("csv", argv, needles, files, note=kind)


# =============================================================================== sidecars
def sidecar(p: Picker) -> Case:
    """A valid CSV whose ``.meta.json`` sidecar is broken."""
    fx = build_fixtures()
    doc = json.loads(fx["strut.csv.meta.json"])
    kind = p.choice(["json", "list", "unknown", "units", "unit", "role", "columns", "version",
                     "format", "eid", "unitclash"])  # fmt: skip
    text: str
    needles = ["bad.csv.meta.json", "sidecar", "metadata"]
    if kind == "json":
        raw = json.dumps(doc)
        text = raw[: p.integer(1, len(raw) - 2)]
    elif kind == "list":
        text = json.dumps([doc])
    elif kind == "unknown":
        doc[p.choice(["unit", "colums", "zz"])] = 1
        text = json.dumps(doc)
    elif kind == "units":
        doc["units"] = ["°C"]
        text = json.dumps(doc)
    elif kind == "unit":
        doc["units"]["T_nut"] = 5
        text, needles = json.dumps(doc), [*needles, "T_nut"]
    elif kind == "role":
        doc["roles"]["T_nut"] = p.choice(["inputt", "state", ""])
        text, needles = json.dumps(doc), [*needles, "T_nut", "role"]
    elif kind == "columns":
        doc["columns"] = doc["columns"][:-1]
        text = json.dumps(doc)
    elif kind == "version":
        doc["version"] = 99
        text = json.dumps(doc)
    elif kind == "format":
        doc["format"] = "csvy"
        text = json.dumps(doc)
    elif kind == "eid":
        doc["experiment_id"] = 7
        text = json.dumps(doc)
    else:
        doc["units"]["T_nut"] = "V"
        text, needles = json.dumps(doc), ["T_nut", "unit"]
    argv = list(_CSV_SLOTS[p.choice(["diagnose", "montecarlo"])][0])
    argv = ["bad.csv" if a == "FILE" else a for a in argv]
    files = {"bad.csv": fx["strut.csv"], "bad.csv.meta.json": text.encode()}
    return Case("sidecar", argv, needles, files, note=kind)


# =============================================================================== FitResults
_FIT_SLOTS = {
    "simulate": ["simulate", "--params", "FIT", "--inputs", "hd.csv", "--out", "sim.csv"],
    "virtual-sensor": ["virtual-sensor", "hd.csv", "--fit", "FIT", "--out", "vs.csv"],
    "budget": ["firmware", "budget", "FIT"],
    "export": ["firmware", "export", "FIT", "--out", "fw", "--no-avr-check"],
    "rls": ["identify", "rls", "hd.csv", "--inputs", "u", "--outputs", "y", "--from-fit", "FIT",
            "--out", "f.json"],
}  # fmt: skip


def fitresult(p: Picker) -> Case:
    """A FitResult with one defect (a missing parameter included: ident-core's fix)."""
    fx = build_fixtures()
    slot = p.choice([*_FIT_SLOTS, "axt211"])
    if slot == "axt211":  # a plant's own fit: a missing parameter must not become nominal
        doc = json.loads(fx["fit_axt211.json"])
        name = p.choice(sorted(doc["parameters"]))
        for key in ("parameters", "stderr", "bounds"):
            if isinstance(doc.get(key), dict):
                doc[key].pop(name, None)
        names = doc.get("covariance_names") or []
        if name in names:
            k = names.index(name)
            doc["covariance_names"] = names[:k] + names[k + 1 :]
            cov = doc.get("covariance")
            if cov:
                doc["covariance"] = [r[:k] + r[k + 1 :] for i, r in enumerate(cov) if i != k]
        argv = ["simulate", "--params", "bad.json", "--inputs", "ax.csv", "--out", "sim.csv"]
        files = {"bad.json": json.dumps(doc).encode()}
        return Case("fitresult", argv, [name], files, note=f"plant fit lacks {name}")
    base = "fit_foptd.json" if slot in ("simulate", "rls") else "fit_ss.json"
    doc = json.loads(fx[base])
    params = doc["parameters"]
    name = p.choice(sorted(params))
    kind = p.choice(["json", "list", "nomodel", "model", "noparams", "value", "nan", "missing",
                     "extra", "version", "params_list", "format", "nested", "null", "empty",
                     "utf16", "folder"])  # fmt: skip
    needles = ["bad.json"]
    if kind == "json":
        raw = json.dumps(doc)
        text = raw[: p.integer(1, len(raw) - 2)]
    elif kind == "list":
        text = json.dumps([doc])
    elif kind == "nomodel":
        del doc["model"]
        text, needles = json.dumps(doc), [*needles, "model"]
    elif kind == "model":
        doc["model"] = p.choice(["nope", "ss:x", ""])
        text, needles = json.dumps(doc), [*needles, "model", doc["model"] or "''"]
    elif kind == "noparams":
        del doc["parameters"]
        text, needles = json.dumps(doc), [*needles, "parameters"]
    elif kind == "value":
        params[name] = p.choice(["abc", None, [1, 2], {"v": 1}])
        text, needles = json.dumps(doc), [*needles, name]
    elif kind == "nan":
        params[name] = p.choice([math.inf, math.nan, -math.inf])
        text, needles = json.dumps(doc), [*needles, name]  # Python's json writes NaN/Infinity
    elif kind == "missing":
        del params[name]
        text, needles = json.dumps(doc), [*needles, name]
    elif kind == "extra":
        params["zz_" + p.text(3).replace('"', "")] = 1.0
        text, needles = json.dumps(doc), [*needles, "zz_"]
    elif kind == "version":
        doc["schema_version"] = 999
        text, needles = json.dumps(doc), [*needles, "version"]
    elif kind == "nested":
        depth = p.integer(2000, 200000)
        text, needles = "[" * depth + "]" * depth, [*needles, "nested"]
    elif kind == "null":
        text = p.choice(["null", "3", '"a fit"', "true"])
    elif kind == "empty":
        text = p.choice(["", " ", "\n"])
    elif kind == "utf16":
        argv = ["bad.json" if a == "FIT" else a for a in _FIT_SLOTS[slot]]
        files = {"bad.json": json.dumps(doc).encode("utf-16")}
        return Case("fitresult", argv, [*needles, "UTF-8"], files, note=kind)
    elif kind == "folder":
        argv = ["sub" if a == "FIT" else a for a in _FIT_SLOTS[slot]]
        return Case("fitresult", argv, ["sub"], {}, note=kind)
    elif kind == "params_list":
        doc["parameters"] = list(params.values())
        text, needles = json.dumps(doc), [*needles, "parameters"]
    else:
        doc["format"] = "something-else"
        text, needles = json.dumps(doc), [*needles, "format"]
    argv = ["bad.json" if a == "FIT" else a for a in _FIT_SLOTS[slot]]
    return Case("fitresult", argv, needles, {"bad.json": text.encode()}, note=f"{kind} {name}")


# =============================================================================== configurations
def config(p: Picker) -> Case:
    """An external-model configuration (TOML or YAML) with one defect."""
    yaml_ = p.integer(0, 1) == 1
    src = EXT_YAML if yaml_ else EXT_TOML
    kind = p.choice(
        ["syntax", "type", "path", "bounds", "start", "input", "output", "backend", "workers",
         "unknown", "timeout", "noparams", "function", "dupkey", "utf16", "pysyntax", "raises",
         "exits", "imports"]
    )  # fmt: skip
    name = "bad.yaml" if yaml_ else "bad.toml"
    needles = [name]
    if kind == "syntax":
        cut = p.integer(5, len(src) - 5)
        text = src[:cut] + p.choice(["[[", "= =", "{", ":\n  - : :", '"'])
    elif kind == "type":
        text = src.replace("callable", p.choice(["callabel", "dll", "matlab"]), 1)
        needles += ["type"]
    elif kind == "path":
        text = src.replace("lag_func.py", "missing_model.py", 1)
        needles += ["missing_model.py", "path"]
    elif kind == "bounds":
        text = src.replace("lower = 0.1, upper = 10.0", "lower = 10.0, upper = 0.1").replace(
            "lower: 0.1, upper: 10.0", "lower: 10.0, upper: 0.1"
        )
        needles += ["K", "lower", "upper"]
    elif kind == "start":
        text = src.replace("start = 1.0", "start = 50.0").replace("start: 1.0", "start: 50.0")
        needles += ["K", "start"]
    elif kind == "input":
        text = src.replace('u = "u"', 'u = "nope"').replace("inputs: {u: u}", "inputs: {u: nope}")
        needles += ["nope"]
    elif kind == "output":
        text = src.replace('y = "y"', "y = 5").replace("outputs: {y: y}", "outputs: {y: 5}")
        needles += ["outputs", "y"]
    elif kind == "backend":
        text = src.replace('"serial"', '"gpu"').replace("backend: serial", "backend: gpu")
        needles += ["backend", "gpu"]
    elif kind == "workers":  # the last table of the TOML file is [evaluation]
        text = src + "workers = 0\n"
        if yaml_:
            text = src.replace("evaluation: {backend: serial}", "evaluation: {workers: 0}")
        needles += ["workers"]
    elif kind == "unknown":
        text = ("colour = 3\n" if not yaml_ else "colour: 3\n") + src
        needles += ["colour"]
    elif kind == "timeout":
        text = src.replace("timeout = 30", "timeout = -1").replace("timeout: 30", "timeout: -1")
        needles += ["timeout"]
    elif kind == "noparams":
        start = src.index("[parameters]" if not yaml_ else "parameters:")
        end = src.index("[inputs]" if not yaml_ else "inputs:")
        text = src[:start] + src[end:]
        needles += ["parameters"]
    elif kind == "function":
        text = src.replace('function = "lag"', 'function = "nope"').replace(
            "function: lag", "function: nope"
        )
        needles += ["nope", "function"]
    elif kind == "dupkey":  # TOML refuses a key given twice; YAML would take the last
        text = src.replace("timeout = 30", "timeout = 30\ntimeout = 20").replace(
            "timeout: 30", "timeout: 30\ntimeout: [1, 2]"
        )
        needles += ["timeout"]
    elif kind == "utf16":
        argv = ["identify", "montecarlo", "--external", name, "hd.csv", "--samples", "10",
                "--no-progress", "--out", "f.json"]  # fmt: skip
        return Case("config", argv, needles, {name: src.encode("utf-16")}, note=kind)
    else:  # the model's own Python file is broken: it must be named, not crash the run
        body = {
            "pysyntax": "def lag(:\n",
            "raises": "def lag(*a, **k):\n    raise RuntimeError('boom in the model')\n",
            "exits": "import sys\n\ndef lag(*a, **k):\n    sys.exit(3)\n",
            "imports": "import no_such_module_xyz\n\ndef lag(*a, **k):\n    pass\n",
        }[kind]
        files = {name: src.encode(), "lag_func.py": body.encode()}
        argv = ["identify", "montecarlo", "--external", name, "hd.csv", "--samples", "10",
                "--no-progress", "--out", "f.json"]  # fmt: skip
        needles = ["lag_func.py", "boom", "exit", "no_such_module_xyz"]
        return Case("config", argv, needles, files, note=kind)
    argv = ["identify", "montecarlo", "--external", name, "hd.csv", "--samples", "10",
            "--no-progress", "--out", "f.json"]  # fmt: skip
    return Case("config", argv, needles, {name: text.encode()}, note=kind)


# =============================================================================== interruptions
_INTERRUPTS: list[tuple[list[str], str, tuple[str, str], int]] = [
    (["simulate", "axt211", "--inputs", "ax.csv", "--out", "old.csv"], "old.csv",
     ("thermogym.recording", "write_recording"), 0),
    (["simulate", "axt211", "--inputs", "ax.csv", "--out", "old.csv", "--plot", "old.png"],
     "old.png", ("thermogym.plotting", "plot_recordings"), 0),
    (["identify", "foptd", "hd.csv", "--inputs", "u", "--outputs", "y", "--out", "old.json"],
     "old.json", ("thermogym.fitresult.FitResult", "save"), 0),
    (["identify", "montecarlo", "--model", "strut", "strut.csv", "--free", "r_motor",
      "--samples", "200", "--batch-size", "50", "--no-progress", "--out", "old.json"],
     "old.json", ("thermogym.identification.optimizers.base.Tracker", "evaluate"), 1),
    (["experiment", "strut", "steps", "--out", "oldexp", "--option", "feed_rates=[20,25]"],
     "oldexp/strut-step-20.csv", ("thermogym.rigs", "write_recording"), 1),
    (["virtual-sensor", "hd.csv", "--fit", "fit_ss.json", "--out", "old.csv"], "old.csv",
     ("thermogym.recording", "write_recording"), 0),
    # long commands interrupted mid-work (second review of issue 17)
    (["identify", "n4sid", "hd.csv", "--inputs", "u", "--outputs", "y", "--order", "2", "--out",
      "old.json"], "old.json", ("thermogym.identification.n4sid", "n4sid"), 0),
    (["identify", "arx", "hd.csv", "--inputs", "u", "--outputs", "y", "--max-order", "2",
      "--out", "old.json"], "old.json", ("thermogym.identification.pem", "pem"), 0),
    (["diagnose", "--model", "strut", "--train", "strut.csv", "--validate", "strut.csv", "--out",
      "old.json", "--quiet"], "old.json",
     ("thermogym.identification.diagnosis.select", "fit_hypothesis"), 1),
    (["bench", "--env", "AXT211Valve", "--controllers", "onoff,pid", "--seeds", "1", "--out",
      "oldb", "--no-progress", "--backend", "serial"], "oldb/earlier.txt",
     ("thermogym.controllers.harness", "run_episode"), 1),
    (["firmware", "export", "fit_ss.json", "--out", "oldfw", "--no-avr-check", "--overwrite"],
     "oldfw/earlier.txt", ("thermogym.firmware.export", "_publish_dir"), 0),
    (["resid", "fit_ss.json", "--data", "hd.csv", "--json", "old.json"], "old.json",
     ("thermogym.identification.compare", "resid"), 0),
]  # fmt: skip


def interrupt(p: Picker) -> Case:
    """Ctrl-C (or SIGTERM, SIGHUP) at a point of a valid run whose output exists already."""
    argv, existing, target, after = p.choice(_INTERRUPTS)
    sig = p.choice(["SIGINT", "SIGINT", "SIGTERM", "SIGHUP"])
    files: dict[str, bytes | None] = {existing: b"an earlier result\n"}
    needle = "interrupted" if sig == "SIGINT" else f"terminated by {sig}"
    return Case("interrupt", list(argv), [needle], files, "interrupt", target, after,
                note=".".join(target) + ("" if sig == "SIGINT" else f" {sig}"),
                signal_name=sig)  # fmt: skip


# =============================================================================== mismatches
def _nan_rows(data: bytes, col: str, rows: Sequence[int]) -> bytes:
    header, table = _table(data)
    j = header.index(col)
    for i in rows:
        table[i][j] = ""
    return _join(header, table)


_MISMATCH: list[tuple[list[str], list[str], dict[str, str]]] = [
    (["virtual-sensor", "hd.csv", "--fit", "fit_foptd.json", "--out", "vs.csv"],
     ["foptd", "ss"], {}),
    (["firmware", "budget", "fit_foptd.json"], ["foptd", "ss"], {}),
    (["firmware", "export", "fit_foptd.json", "--out", "fw"], ["foptd", "ss"], {}),
    (["simulate", "--params", "fit_ss.json", "--inputs", "strut.csv", "--out", "s.csv"],
     ["'u'"], {}),
    (["simulate", "axt211", "--params", "fit_foptd.json", "--inputs", "ax.csv", "--out",
      "s.csv"], ["axt211", "foptd"], {}),
    (["identify", "rls", "hd.csv", "--inputs", "u", "--outputs", "y", "--from-fit",
      "fit_ss.json", "--out", "f.json"], ["foptd", "ss"], {}),
    (["identify", "foptd", "hd.csv", "--inputs", "y", "--outputs", "y", "--out", "f.json"],
     ["'y'"], {}),
    (["identify", "n4sid", "hd.csv", "--inputs", "u", "--outputs", "u", "--out", "f.json"],
     ["'u'"], {}),
    (["identify", "foptd", "hd.csv", "--inputs", "u", "--outputs", "y", "--validate",
      "strut.csv", "--out", "f.json"], ["'u'", "'y'", "strut"], {}),
    (["diagnose", "--model", "strut", "--train", "hd.csv", "--validate", "strut.csv", "--out",
      "r.json"], ["feed_rate", "T_air", "hd"], {}),
    (["bench", "--env", "AXT211Valve", "--controllers", "onoff", "--seeds", "1", "--out", "b",
      "--params", "fit_foptd.json", "--no-progress"], ["foptd", "axt211"], {}),
    (["bench", "--env", "AXT211Valve", "--controllers", "ppo", "--seeds", "1", "--out", "b",
      "--policy", "ppo=missing.zip", "--no-progress"], ["missing.zip"], {}),
    (["virtual-sensor", "hd.csv", "--fit", "fit_ss.json", "--out", "vs.csv", "--tune",
      "missing.csv"], ["missing.csv"], {}),
    (["firmware", "export", "fit_ss.json", "--out", "fw", "--vectors", "strut.csv",
      "--no-avr-check"], ["'u'"], {}),
    (["identify", "foptd", "nanu.csv", "--inputs", "u", "--outputs", "y", "--out", "f.json"],
     ["'u'"], {"nanu.csv": "u"}),
    (["identify", "n4sid", "nanu.csv", "--inputs", "u", "--outputs", "y", "--order", "2",
      "--out", "f.json"], ["'u'", "'y'"], {"nanu.csv": "y"}),
    (["simulate", "axt211", "--inputs", "nanax.csv", "--out", "s.csv"], ["'T_U'"],
     {"nanax.csv": "T_U"}),
    (["identify", "montecarlo", "--model", "axt211", "strut.csv", "--free", "C_P", "--samples",
      "10", "--no-progress", "--out", "f.json"], ["'u'", "k_U", "T_U", "strut"], {}),
    (["identify", "montecarlo", "--model", "strut", "strut.csv", "--free", "C_P", "--samples",
      "10", "--no-progress", "--out", "f.json"], ["C_P"], {}),
    (["identify", "n4sid", "hd.csv", "--inputs", "u", "--outputs", "y", "--order", "400",
      "--out", "f.json"], ["order", "400", "horizon"], {}),
    (["experiment", "axt211", "steps", "--out", "e", "--option", "dt=1e-9", "--option",
      "voltages=[24]", "--option", "ambients=[25]"], ["samples", "dt"], {}),
    (["virtual-sensor", "hd.csv", "--fit", "fit_ss.json", "--out", "vs.csv", "--measured",
      "y", "--hidden", "y"], ["'y'"], {}),
    (["identify", "foptd", "hd.csv", "--inputs", "u", "--outputs", "y", "--max-delay-s", "1e9",
      "--out", "f.json"], ["--max-delay-s"], {}),
    (["identify", "rls", "hd.csv", "--inputs", "u", "--outputs", "y", "--max-delay-s", "1e6",
      "--out", "f.json"], ["--max-delay-s"], {}),
    (["diagnose", "--model", "strut", "--train", "strut.csv", "--validate", "strut.csv",
      "--out", "r.json", "--dt", "1e9"], ["1000000000", "period", "short"], {}),
    (["identify", "sopdt", "hd.csv", "--inputs", "u", "--outputs", "y", "--max-delay-s", "1e6",
      "--out", "f.json"], ["--max-delay-s"], {}),
    (["resid", "fit_ss.json", "--data", "ax.csv"], ["'y'", "ax"], {}),
    (["compare", "fit_ss.json", "--data", "strut.csv"], ["'u'", "'y'", "strut"], {}),
    (["compare", "fit_ss.json", "ax.csv", "--data", "hd.csv"], ["ax.csv"], {}),
    (["diagnose", "--model", "ss:3", "--params", "fit_ss.json", "--inputs", "u", "--outputs", "y",
      "--train", "hd.csv", "--validate", "hd.csv", "--out", "r.json"], ["'ss:3'"], {}),
    (["virtual-sensor", "hd.csv", "--fit", "fit_axt211.json", "--out", "vs.csv"],
     ["axt211", "ss"], {}),
]  # fmt: skip


def mismatch(p: Picker) -> Case:
    """Valid files in a combination that cannot work (wrong model, column, fit kind)."""
    argv, needles, nan_files = p.choice(_MISMATCH)
    fx = build_fixtures()
    files: dict[str, bytes | None] = {}
    for name, col in nan_files.items():
        src = fx["ax.csv"] if col in ("T_U", "k_U") else fx["hd.csv"]
        n = 60 if src is fx["ax.csv"] else 300
        start = p.integer(0, n - 5)
        files[name] = _nan_rows(src, col, range(start, start + p.integer(1, 4)))
    return Case("mismatch", list(argv), needles, files)


#: Cases whose fix belongs to another change, by the start of their note: the test
#: tolerates them as silent until it lands (the benchmark counts them as they are).
KNOWN_OPEN: dict[str, str] = {}

#: family name -> generator, with its weight in the benchmark's mix
FAMILIES: dict[str, tuple[Callable[[Picker], Case], int]] = {
    "option": (option_value, 30),
    "command": (command_line, 6),
    "outputs": (outputs, 14),
    "csv": (csv_file, 22),
    "sidecar": (sidecar, 8),
    "fitresult": (fitresult, 10),
    "config": (config, 8),
    "interrupt": (interrupt, 4),
    "mismatch": (mismatch, 8),
}


# =============================================================================== running
class _Timeout(BaseException):
    """A case ran past its time limit (not an Exception: the CLI must not catch it)."""


def _snapshot(folder: Path) -> dict[str, str]:
    return {
        str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(folder.rglob("*"))
        if p.is_file()
    }


def _resolve(target: str) -> tuple[Any, str]:
    import importlib

    mod_name, attr = target
    parts = mod_name.split(".")
    for k in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:k]))
        except ImportError:
            continue
        for name in parts[k:]:
            obj = getattr(obj, name)
        return obj, attr
    raise ImportError(mod_name)


@contextlib.contextmanager
def _injected(case: Case) -> Any:
    if case.inject is None:
        yield
        return
    owner, attr = _resolve(case.inject)
    original = getattr(owner, attr)
    calls = {"n": 0}

    def interrupted(*a: Any, **kw: Any) -> Any:
        calls["n"] += 1
        if calls["n"] > case.inject_after:
            if case.signal_name == "SIGINT":
                raise KeyboardInterrupt
            signum = getattr(signal, case.signal_name)
            if callable(signal.getsignal(signum)):  # the CLI's handler raises in this frame
                os.kill(os.getpid(), signum)
            else:  # not the main thread: no handler to send it to; what it would raise
                from thermogym.cli import Terminated

                raise Terminated(signum)
        return original(*a, **kw)

    setattr(owner, attr, interrupted)
    try:
        yield
    finally:
        setattr(owner, attr, original)


def run_case(case: Case, *, timeout: float = 120.0, keep: Path | None = None) -> Outcome:
    """Run ``case`` in a fresh work folder, in this process, and judge it."""
    import time

    from thermogym.cli import main

    fx = build_fixtures()
    tmp = Path(tempfile.mkdtemp(prefix="tg-badinput-")) if keep is None else keep
    cwd = os.getcwd()
    try:
        for name, data in {**fx, **case.files}.items():
            p = tmp / name
            if data is None:
                if p.exists():
                    p.unlink()
                continue
            p.parent.mkdir(parents=True, exist_ok=True)
            p.write_bytes(data)
        before = _snapshot(tmp)
        out, err = io.StringIO(), io.StringIO()
        code: int | None = None
        escaped = ""
        os.chdir(tmp)
        t0 = time.perf_counter()

        def alarm(*_: Any) -> None:
            raise _Timeout

        old = signal.signal(signal.SIGALRM, alarm) if timeout else None
        if timeout:
            signal.setitimer(signal.ITIMER_REAL, timeout)
        try:
            with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err), _injected(case):
                code = main(case.argv)
        except _Timeout:
            escaped = f"timeout after {timeout:g} s"
        except BaseException as e:
            escaped = f"{type(e).__name__}: {e}"
        finally:
            if timeout:
                signal.setitimer(signal.ITIMER_REAL, 0)
                signal.signal(signal.SIGALRM, old)
            os.chdir(cwd)
        seconds = time.perf_counter() - t0
        after = _snapshot(tmp)
        stderr = err.getvalue()
        damage = [k for k in before if after.get(k) != before[k]]
        new = [k for k in after if k not in before]
        allowed = [k for k in new if ".interrupted" in k and k in stderr]
        if code != 0:  # a run that exits 0 wrote its outputs (a silent accept, counted so)
            damage += [f"+{k}" for k in new if k not in allowed]
        verdict = _judge(case, code, stderr, escaped)
        if escaped:
            stderr += f"\n[escaped] {escaped}"
        return Outcome(code, out.getvalue(), stderr, verdict, damage, seconds)
    finally:
        if keep is None:
            shutil.rmtree(tmp, ignore_errors=True)


def _judge(case: Case, code: int | None, err: str, escaped: str) -> str:
    if escaped or "Traceback (most recent call last)" in err or "internal error" in err:
        return "traceback"
    if code == 0:
        return "silent_wrong"
    want = 2
    if case.expect == "interrupt":
        want = 128 + getattr(signal, case.signal_name)  # 130 for Ctrl-C (SIGINT)
    lines = [ln for ln in err.splitlines() if ln.strip()]
    # warnings the CLI prints on one line each are allowed before the error line
    errors = [ln for ln in lines if not ln.startswith("thermogym: warning:")]
    word = "error"
    if case.expect == "interrupt":
        word = "interrupted" if case.signal_name == "SIGINT" else "terminated by"
    if code != want or len(errors) != 1:
        return "unclear"
    line = errors[0]
    if not line.startswith("thermogym") or word not in line or "np.float64(" in line:
        return "unclear"
    low = line.lower()
    if not any(n.lower() in low for n in case.needles):
        return "unclear"
    return "clear_error"
