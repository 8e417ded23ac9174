"""The README's data-set table gives the commands ``benchmarks/realdata.py`` measures.

Issue 16's must-show runs ``thermogym identify auto`` on every shipped real
data set; the table a user reads must give the same command (the data set in
place of the benchmark's training CSV), or the figures measured are not the
figures of what the README tells a user to run.
"""

from __future__ import annotations

import importlib.util
import re
import shlex
from pathlib import Path

from thermogym.cli import build_parser
from thermogym.studies.realdata import CASES

ROOT = Path(__file__).resolve().parents[1]


def _benchmark():  # type: ignore[no-untyped-def]
    spec = importlib.util.spec_from_file_location(
        "bench_realdata", ROOT / "benchmarks" / "realdata.py"
    )
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _table_commands() -> dict[str, list[str]]:
    """Training data set (first ``dataset:NAME``) -> argv of each command in the table."""
    text = (ROOT / "README.md").read_text()
    start = text.index("| data set (`dataset:NAME`) | plant | example |")
    rows = text[start:].split("\n\n", 1)[0].splitlines()[2:]
    out = {}
    for row in rows:
        cmd = re.findall(r"`(thermogym identify [^`]+)`", row)
        assert len(cmd) == 1, row
        argv = shlex.split(cmd[0])[1:]
        out[argv[2].removeprefix("dataset:")] = argv
    return out


def _options(argv: list[str]) -> dict[str, str]:
    """``--inputs``, ``--outputs`` and ``--operating-point`` of an argv."""
    return {k: argv[argv.index(k) + 1] for k in ("--inputs", "--outputs", "--operating-point")
            if k in argv}  # fmt: skip


def test_readme_dataset_table_gives_the_benchmarked_commands():
    bench = _benchmark()
    table = _table_commands()
    parser = build_parser()
    measured = {c.train[0]: c for c in CASES.values()}
    for name, argv in table.items():
        parser.parse_args(argv)  # a command the CLI takes as written
        if name not in measured:
            continue
        case = measured[name]
        want = bench.command_for(case, f"dataset:{name}", "fit.json")
        assert argv[:2] == want[:2] == ["identify", "auto"], (name, argv)
        assert _options(argv) == _options(want), (name, argv, want)
    # every DaISy and DTU set the benchmark measures on a single recording has its row
    missing = [c.train[0] for c in CASES.values() if not c.validate and c.train[0] not in table]
    assert not missing, missing
