"""The README's "your own data" walkthrough runs as written (in a temporary folder)."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"


def walkthrough() -> str:
    """The shell block between the walkthrough markers of the README."""
    text = README.read_text()
    m = re.search(
        r"<!-- walkthrough:start -->\s*```bash\n(.*?)```\s*<!-- walkthrough:end -->", text, re.S
    )
    assert m, "README has no walkthrough block between the markers"
    return m.group(1)


def test_walkthrough_block_is_there_and_covers_the_loop():
    cmds = walkthrough()
    for part in ("experiment", "identify", "diagnose", "params=", "bench"):
        assert part in cmds, part


@pytest.mark.slow
def test_readme_walkthrough_runs_as_written(tmp_path):
    # the commands use .venv/bin/... from the repository root: give the temp folder that layout
    venv = Path(sys.prefix)
    if not (venv / "bin" / "thermogym").exists():
        pytest.skip(f"{venv} is not the project's virtual environment (no bin/thermogym)")
    (tmp_path / ".venv").symlink_to(venv, target_is_directory=True)
    script = "set -euo pipefail\n" + walkthrough()
    env = {**os.environ, "MPLBACKEND": "Agg"}
    proc = subprocess.run(
        ["bash", "-c", script],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=900,
        env=env,
    )
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    for f in (
        "mydata/strut-step-20.csv",
        "fits/strut_foptd.json",
        "fits/strut_augmented.json",
        "diagnosis.html",
        "bench/summary.md",
        "bench/results.csv",
    ):
        assert (tmp_path / f).is_file(), f
    assert "20 m/min:" in proc.stdout and "30 m/min:" in proc.stdout
    shutil.rmtree(tmp_path / "mydata")
