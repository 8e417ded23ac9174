"""Golden closed-loop regression: on/off and PI episodes of every environment.

The reference trajectories in ``tests/data/golden`` were written by
``tests/data/golden/regenerate.py``; this test replays the same loops (same
controllers, imported from that script) and compares with tolerances. It
never rewrites the files: after a deliberate behaviour change, run the script
and review the diff.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

GOLDEN = Path(__file__).resolve().parent / "data" / "golden"
_spec = importlib.util.spec_from_file_location("golden_regenerate", GOLDEN / "regenerate.py")
regen = importlib.util.module_from_spec(_spec)  # type: ignore[arg-type]
_spec.loader.exec_module(regen)  # type: ignore[union-attr]

CASES = [(n, c) for n in regen.CASES for c in regen.CONTROLLERS]


@pytest.mark.parametrize(("name", "ctrl"), CASES)
def test_closed_loop_matches_the_golden_trajectory(name, ctrl):
    path = GOLDEN / f"{name}_{ctrl}.npz"
    ref = np.load(path)
    got = regen.run(name, ctrl)
    assert got["rewards"].shape == ref["rewards"].shape, "episode length changed"
    np.testing.assert_array_equal(got["flags"], ref["flags"])
    assert got["signal_names"].tolist() == ref["signal_names"].tolist()
    for key in ("obs", "actions", "rewards", "signals"):
        np.testing.assert_allclose(got[key], ref[key], rtol=1e-6, atol=1e-6, err_msg=key)
    # every KPI of the reference keeps its value; KPIs added since (the S-N variants of the
    # wax damage, issue 14) are checked by tests/test_kpis.py, not here
    names = got["kpi_names"].tolist()
    ref_names = ref["kpi_names"].tolist()
    assert set(ref_names) <= set(names), f"KPIs gone: {set(ref_names) - set(names)}"
    kpis = dict(zip(names, got["kpis"].tolist(), strict=True))
    np.testing.assert_allclose(
        [kpis[k] for k in ref_names], ref["kpis"], rtol=1e-6, atol=1e-9, err_msg="kpis"
    )


def test_golden_episodes_exercise_the_controllers():
    # the references are meaningful episodes, not trivial ones
    for name, _ in regen.CASES.items():
        on = np.load(GOLDEN / f"{name}_onoff.npz")
        pid = np.load(GOLDEN / f"{name}_pid.npz")
        assert np.unique(on["actions"][:, 0]).size >= 2, name
        assert np.unique(np.round(pid["actions"][:, 0], 3)).size > 5, name
