"""Recursive least squares with forgetting against batch least squares and known FOPTDs."""

from __future__ import annotations

import numpy as np
import pytest

from thermogym.errors import ConfigError, IdentificationError, ShapeError
from thermogym.identification.foptd import fit_foptd
from thermogym.identification.linear_fit import evaluate_fit
from thermogym.identification.rls import RLS, RecursiveFOPTD
from thermogym.models.linear import FOPTDModel
from thermogym.recording import Recording


def test_rls_without_forgetting_equals_batch_least_squares():
    rng = np.random.default_rng(0)
    Phi = rng.normal(size=(400, 2, 3))
    theta = np.array([[1.0, -2.0, 0.5], [0.3, 0.0, 4.0]])
    Y = np.einsum("tjq,jq->tj", Phi, theta) + 0.1 * rng.standard_normal((400, 2))
    est = RLS(3, n_problems=2, forgetting=1.0, p0=1e8)
    est.update_many(Phi, Y)
    for j in range(2):
        batch = np.linalg.lstsq(Phi[:, j], Y[:, j], rcond=None)[0]
        assert np.allclose(est.theta[j], batch, atol=1e-6)


def test_rls_one_sample_at_a_time_equals_a_block():
    rng = np.random.default_rng(1)
    Phi, Y = rng.normal(size=(50, 1, 2)), rng.normal(size=(50, 1))
    a, b = RLS(2, forgetting=0.98), RLS(2, forgetting=0.98)
    a.update_many(Phi, Y)
    for k in range(50):
        b.update(Phi[k], Y[k])
    assert np.allclose(a.theta, b.theta) and np.allclose(a.P, b.P)
    assert b.n_updates == 50


def test_covariance_is_bounded_without_excitation():
    est = RLS(2, forgetting=0.9, p0=10.0)
    est.update_many(np.tile([1.0, 1.0], (2000, 1)), np.ones(2000))  # no new information
    assert np.trace(est.P[0]) <= est.max_trace * (1 + 1e-12)
    assert np.isfinite(est.theta).all()


def prbs(n, hold, seed):
    return np.repeat(np.random.default_rng(seed).integers(0, 2, n // hold + 1), hold)[:n]


def test_recursive_foptd_recovers_known_parameters_and_matches_the_batch_fit():
    u = np.r_[np.zeros(20), prbs(3000, 60, 2)].astype(float)
    y = 20.0 + FOPTDModel(K=1.5, T=80.0, tau=7.0).simulate(u[:, None], 1.0).outputs[0, :, 0]
    est = RecursiveFOPTD(["P"], ["T"], dt=1.0, delays=7, forgetting=1.0)
    errors = est.update_many(u[:, None], y[:, None])
    K, T, tau = est.parameters()
    assert K[0, 0] == pytest.approx(1.5, rel=1e-4) and T[0, 0] == pytest.approx(80.0, rel=1e-4)
    assert tau[0, 0] == 7.0 and abs(errors[-1, 0]) < 1e-5
    rec = Recording(np.arange(u.size, dtype=float), {"P": u, "T": y})
    fit = est.to_fitresult()
    assert fit.method == "rls" and fit.model == "foptd"
    assert evaluate_fit(fit, rec)["mnrmse"] == pytest.approx(1.0, abs=1e-4)
    batch = fit_foptd(rec, ["P"], ["T"], max_delay=20)
    assert batch.K[0, 0] == pytest.approx(K[0, 0], rel=1e-4)


def test_forgetting_tracks_a_drifting_gain():
    n = 6000
    u = np.r_[np.zeros(10), prbs(n - 10, 50, 3)].astype(float)
    K = np.where(np.arange(n) < n // 2, 1.0, 2.0)  # the plant ages: gain doubles
    a = np.exp(-1.0 / 40.0)
    y = np.zeros(n)
    for k in range(1, n):
        y[k] = a * y[k - 1] + K[k] * (1 - a) * u[k - 1]
    fast = RecursiveFOPTD(["u"], ["y"], dt=1.0, delays=0, forgetting=0.99)
    slow = RecursiveFOPTD(["u"], ["y"], dt=1.0, delays=0, forgetting=1.0)
    fast.update_many(u[:, None], y[:, None])
    slow.update_many(u[:, None], y[:, None])
    assert fast.parameters()[0][0, 0] == pytest.approx(2.0, rel=0.01)
    assert 1.1 < slow.parameters()[0][0, 0] < 1.9  # growing memory averages both


def test_bias_absorbs_a_start_that_is_not_a_steady_state():
    u = prbs(4000, 50, 4).astype(float)
    u[:50] = 1.0  # the heater is already on, but the plant starts cold
    y = 20.0 + FOPTDModel(K=2.0, T=40.0, tau=3.0).simulate(u[:, None], 1.0).outputs[0, :, 0]
    plain = RecursiveFOPTD(["u"], ["y"], dt=1.0, delays=3, forgetting=1.0)
    plain.update_many(u[:, None], y[:, None])
    with_c = RecursiveFOPTD(["u"], ["y"], dt=1.0, delays=3, forgetting=1.0, bias=True)
    with_c.update_many(u[:, None], y[:, None])
    K, T, _ = with_c.parameters()
    # only the first 3 samples (inside the delay) see a wrong input history
    assert K[0, 0] == pytest.approx(2.0, rel=0.01) and T[0, 0] == pytest.approx(40.0, rel=0.01)
    try:  # without c the offset ruins the estimate (here the pole even leaves (0, 1))
        plain_error = abs(plain.parameters()[0][0, 0] - 2.0)
    except IdentificationError:
        plain_error = np.inf
    assert plain_error > 5 * abs(K[0, 0] - 2.0)
    y0 = with_c.to_fitresult().build_model().config()["y0"][0]
    assert y0 == pytest.approx(20.0, abs=0.05)  # the true rest level


def test_warm_start_from_a_batch_fit_and_nan_outputs():
    true = FOPTDModel(
        ["v"], ["T1", "T2"], K=[[0.5], [0.2]], T=[[600.0], [1800.0]], tau=[[0.0], [300.0]]
    )
    u = np.r_[np.zeros(3), np.full(400, 20.0)]
    y = 21.0 + true.simulate(u[:, None], 60.0).outputs[0]
    rec = Recording(60.0 * np.arange(u.size), {"v": u, "T1": y[:, 0], "T2": y[:, 1]})
    batch = fit_foptd(rec, ["v"], ["T1", "T2"], max_delay=10)
    est = RecursiveFOPTD.from_fit(batch.fit, forgetting=0.995)
    K, T, tau = est.parameters()
    assert np.allclose(K, batch.K) and np.allclose(T, batch.T) and np.allclose(tau, batch.tau)
    y_gap = y.copy()
    y_gap[100:110, 1] = np.nan  # a missing sample only skips that output's update
    err = est.update_many(u[:, None], y_gap)
    assert np.isnan(err[99:109, 1]).all() and np.isfinite(err[:, 0]).all()
    assert np.allclose(est.parameters()[0], [[0.5], [0.2]], rtol=1e-3)


def test_errors():
    with pytest.raises(ConfigError, match="forgetting"):
        RLS(2, forgetting=1.5)
    with pytest.raises(ShapeError):
        RLS(2).update_many(np.ones((5, 3)), np.ones(5))
    est = RecursiveFOPTD(["u"], ["y"], dt=1.0)
    est.update_many(np.zeros((5, 1)), np.zeros((5, 1)))
    with pytest.raises(IdentificationError, match="not a stable first-order lag"):
        est.parameters()  # nothing learned yet: a = 0
    with pytest.raises(ConfigError, match="delays"):
        RecursiveFOPTD(["u"], ["y"], dt=1.0, delays=-1)


def test_cli_identify_rls(tmp_path):
    from thermogym.cli import main as cli_main
    from thermogym.fitresult import FitResult
    from thermogym.recording import write_recording

    u = np.r_[np.zeros(20), prbs(2000, 40, 5)].astype(float)
    y = 20.0 + FOPTDModel(K=1.5, T=60.0, tau=5.0).simulate(u[:, None], 1.0).outputs[0, :, 0]
    write_recording(
        Recording(np.arange(u.size, dtype=float), {"P": u, "T": y}), tmp_path / "run.csv"
    )
    rc = cli_main(
        [
            "identify",
            "rls",
            str(tmp_path / "run.csv"),
            "--inputs",
            "P",
            "--outputs",
            "T",
            "--delays",
            "5",
            "--forgetting",
            "1.0",
            "--out",
            str(tmp_path / "f.json"),
        ]
    )
    assert rc == 0
    fit = FitResult.load(tmp_path / "f.json")
    assert fit.method == "rls" and fit.parameters["K_T"] == pytest.approx(1.5, rel=1e-3)
    assert fit.metrics["train"]["mnrmse"] > 0.999
