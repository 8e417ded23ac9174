"""Property: every generated bad input gets one clear line, exit 2 (130 when
interrupted), no traceback, and leaves every file as it was.

The cases (``tests/cli_badinput.py``) cover option values of every command,
output paths, malformed CSV recordings, ``.meta.json`` sidecars, FitResults,
external-model TOML/YAML configurations and Ctrl-C at points of valid runs.
Commands run in this process through :func:`thermogym.cli.main`. The default
run draws a fixed set of examples per family (about a minute in all); the slow
test (``make test-all``) draws many more, fresh each run.
``THERMOGYM_FUZZ_EXAMPLES=N`` sets the number per family of either.
"""

from __future__ import annotations

import os

import cli_badinput as cb
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

_TEXT = st.text(
    alphabet=st.characters(blacklist_categories=("Cs", "Cc"), blacklist_characters="\x00"),
    min_size=1,
    max_size=8,
)


class HypothesisPicker:
    """The choices of a case, drawn by hypothesis (so failures shrink)."""

    def __init__(self, data: st.DataObject) -> None:
        self.data = data

    def choice(self, items):
        return self.data.draw(st.sampled_from(list(items)))

    def integer(self, lo, hi):
        return self.data.draw(st.integers(lo, hi))

    def number(self, lo, hi):
        return self.data.draw(st.floats(lo, hi, allow_nan=False, allow_infinity=False))

    def text(self, max_size=8):
        return self.data.draw(_TEXT.filter(lambda s: len(s) <= max_size))


def _examples(default: int) -> int:
    return int(os.environ.get("THERMOGYM_FUZZ_EXAMPLES", default))


_COMMON = {
    "deadline": None,
    "suppress_health_check": [HealthCheck.too_slow, HealthCheck.data_too_large],
    "database": None,
}


def _check(family: str, data: st.DataObject) -> None:
    case = cb.FAMILIES[family][0](HypothesisPicker(data))
    out = cb.run_case(case, timeout=120)
    open_fix = next((v for k, v in cb.KNOWN_OPEN.items() if case.note.startswith(k)), None)
    if open_fix and out.verdict == "silent_wrong":
        return  # fixed elsewhere (see cli_badinput.KNOWN_OPEN); the benchmark counts it
    assert out.verdict == "clear_error", f"{case.describe()}\n{out.err}"
    assert not out.damage, f"{case.describe()}: files changed {out.damage}\n{out.err}"


@pytest.mark.parametrize("family", list(cb.FAMILIES))
@settings(max_examples=_examples(25), derandomize=True, **_COMMON)
@given(data=st.data())
def test_bad_input_gets_one_clear_line_and_changes_no_file(family, data):
    _check(family, data)


@pytest.mark.slow
@pytest.mark.parametrize("family", list(cb.FAMILIES))
@settings(max_examples=_examples(150), **_COMMON)
@given(data=st.data())
def test_bad_input_long_profile(family, data):
    _check(family, data)
