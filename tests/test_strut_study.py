"""Strut study of paper 000 (Tables 1 and 2): FOPTD set and ratio parameters by Monte Carlo."""

from __future__ import annotations

import numpy as np
import pytest

from thermogym.models.linear import FOPTDModel
from thermogym.models.strut import StrutModel
from thermogym.recording import Recording
from thermogym.rigs import get_rig, to_recording
from thermogym.studies.strut import (
    OUTPUTS,
    RATIOS,
    StrutStudyConfig,
    fit_foptd_set,
    measured_initial_state,
    run_strut_study,
    strut_problem,
)


def test_foptd_set_recovers_known_gains_time_constants_and_delays():
    dt = 140.9
    K, T, tau = np.array([0.8, 0.3]), np.array([4000.0, 9000.0]), np.array([0.0, 3 * dt])
    m = FOPTDModel(["feed_rate"], ["T_a", "T_b"], K=K[:, None], T=T[:, None], tau=tau[:, None])
    u = np.full((90, 1), 20.0)
    u[0] = 0.0
    sim = m.simulate(u, dt)
    rec = Recording(
        sim.time,
        {"feed_rate": u[:, 0], "T_a": 21 + sim.output("T_a")[0], "T_b": 22 + sim.output("T_b")[0]},
    )
    fit = fit_foptd_set(rec, ["T_a", "T_b"])
    np.testing.assert_allclose(fit.K, K, rtol=1e-8)
    np.testing.assert_allclose(fit.T, T, rtol=1e-8)
    np.testing.assert_allclose(fit.tau, tau, atol=1e-6)
    back = fit.simulate(rec)
    np.testing.assert_allclose(back["T_b"], rec["T_b"], atol=1e-8)


def test_measured_initial_state_starts_measured_nodes_at_their_first_sample():
    m = StrutModel()
    rec = Recording([0.0, 60.0], {"T_air": [20.0, 20.1], "T_drive": [24.0, 24.5]})
    x0 = measured_initial_state(m, np.zeros((3, 6)), rec)
    assert x0.shape == (3, len(m.state_names))
    assert x0[0, m.state_names.index("drive")] == 24.0
    assert x0[0, m.state_names.index("nut")] == 20.0


@pytest.fixture(scope="module")
def rig_recs():
    rig = get_rig("strut", ["input_dependent_heat_transfer"])  # and the drive motor's fan
    return [to_recording(r, "strut") for r in rig.run("steps", seed=1)]


def test_study_tables_and_their_invariants(rig_recs):
    res = run_strut_study(
        StrutStudyConfig(n_samples=600, batch_size=300), recordings=rig_recs, progress=False
    )
    assert list(res.criteria) == [*OUTPUTS, "all"]
    assert res.feeds == (20.0, 25.0, 30.0) and res.evaluations == 600
    c = res.criteria
    for o in OUTPUTS:
        assert set(c[o]["ratios"]) == set(RATIOS)
        # the best of the same samples for one output beats the all-outputs optimum there
        assert c[o]["rmse"][20.0][o] <= c["all"]["rmse"][20.0][o] + 1e-12
    mean_all = np.mean(list(c["all"]["rmse"][20.0].values()))
    for o in OUTPUTS:
        assert mean_all <= np.mean(list(c[o]["rmse"][20.0].values())) + 1e-12
    # the FOPTD set is fitted per output: small errors on its training data
    assert max(res.foptd_rmse[20.0].values()) < 1.5
    assert "Table 2" in res.table() and res.to_dict()["evaluations"] == 600


def test_shared_samples_equal_separate_monte_carlo_runs(rig_recs):
    kw = {"n_samples": 200, "batch_size": 100, "seed": 3}
    a = run_strut_study(StrutStudyConfig(**kw), recordings=rig_recs[:1], progress=False)
    b = run_strut_study(
        StrutStudyConfig(shared_samples=False, **kw), recordings=rig_recs[:1], progress=False
    )
    for k in a.criteria:
        assert a.criteria[k]["ratios"] == pytest.approx(b.criteria[k]["ratios"], rel=1e-12)
    assert b.evaluations == 8 * a.evaluations


def test_problem_of_the_study_has_the_five_ratios(rig_recs):
    pb = strut_problem(rig_recs[0])
    assert pb.names == RATIOS
    np.testing.assert_allclose(pb.weights, 1 / 7)
    np.testing.assert_allclose(pb.lower, [0.3, 0.3, 0.3, 0.8, 0.8])


@pytest.mark.slow
def test_paper000_findings_on_rig_data():
    res = run_strut_study(StrutStudyConfig(), progress=False)
    c, fo = res.criteria, res.foptd_rmse
    mean = lambda d: float(np.mean(list(d.values())))  # noqa: E731
    # (iii): all outputs together, the circuit is worse than the set of independent FOPTDs
    assert mean(c["all"]["rmse"][20.0]) > mean(fo[20.0])
    # (the paper's single-output finding, the circuit mostly at least as accurate as the
    # FOPTD on the training data, held while the rig was the circuit itself; on the rig's own
    # plant the 5 ratios cannot absorb its screw convection: see benchmarks/results/rigs)
    # (iv): the optimal ratios differ widely between the criteria
    r = np.array([[c[o]["ratios"][k] for k in RATIOS] for o in OUTPUTS])
    assert (r.max(axis=0) / r.min(axis=0)).max() > 2.0
    # nonlinear plant: the FOPTD extrapolation to 30 m/min is worse than its training fit
    assert mean(fo[30.0]) > mean(fo[20.0])
    assert res.evaluations == 10_000
