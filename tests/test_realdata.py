"""FOPTD and N4SID on the shipped real data sets (data nobody here generated)."""

from __future__ import annotations

import numpy as np
import pytest

from thermogym.errors import UnknownNameError
from thermogym.fitresult import FitResult
from thermogym.identification.linear_fit import evaluate_fit
from thermogym.studies.realdata import CASES, case_data, identify_case


def test_tclab_runs_are_resampled_to_a_uniform_grid():
    train, vals = case_data("tclab_sin_2_50")
    assert [r.experiment_id for r in vals] == ["tclab_sin_2_50_run2", "tclab_sin_2_50_run3"]
    for rec in train + vals:
        assert rec.is_uniform() and rec.dt == 1.0
        assert np.isfinite(rec["T1"]).all()
    # run 1 has one 2 s step: 900 logged samples become 901 on the grid, and the report says so
    steps = {s["step"]: s for s in train[0].meta["preparation"]["steps"]}
    assert steps["resample"]["raw_rows"] == 900 and train[0].n_samples == 901


def test_single_recordings_are_split_in_halves():
    train, vals = case_data("hair_dryer")
    assert train[0].n_samples == vals[0].n_samples == 500
    assert vals[0].time[0] == pytest.approx(40.0)


def test_hair_dryer():
    res = identify_case("hair_dryer")
    s = res.summary
    assert s["n4sid"]["validation_mnrmse"] > 0.85  # held-out half, simulation (no prediction)
    assert s["n4sid"]["validation_mnrmse"] > s["foptd"]["validation_mnrmse"]
    assert res.cv.best_order in CASES["hair_dryer"].orders
    for fit in (res.foptd, res.n4sid):
        again = FitResult.from_dict(fit.to_dict())
        _, vals = case_data("hair_dryer")
        assert evaluate_fit(again, vals)["mnrmse"] == pytest.approx(
            fit.metrics["validation"]["mnrmse"], abs=1e-9
        )


def test_tclab_two_heaters_validated_on_other_runs():
    s = identify_case("tclab_mimo").summary
    assert s["validation"] == ["tclab_mimo_3s_a", "tclab_mimo_3s_b"]
    assert s["n4sid"]["validation_mnrmse"] > 0.7 and s["foptd"]["validation_mnrmse"] > 0.5


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(CASES))
def test_every_case_beats_the_mean_on_held_out_data(name):
    s = identify_case(name).summary
    assert s["n4sid"]["validation_mnrmse"] > 0.0
    assert np.isfinite(s["foptd"]["validation_mnrmse"])


def test_unknown_case():
    with pytest.raises(UnknownNameError, match="cases are"):
        identify_case("toaster")
