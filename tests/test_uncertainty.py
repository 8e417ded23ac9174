"""Parameter covariance, confidence intervals and identifiability against known answers."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from thermogym.errors import ShapeError
from thermogym.identification.problem import Problem
from thermogym.identification.simmodel import SimBatch
from thermogym.identification.uncertainty import (
    collinearity_index,
    correlation_length,
    covariance_from_jacobian,
    estimate_input_noise,
    identifiability,
    problem_identifiability,
    problem_uncertainty,
)
from thermogym.models.strut import StrutModel
from thermogym.recording import Recording
from thermogym.rigs import run_experiment


def line_fit(y, t):
    X = np.column_stack([np.ones_like(t), t])
    beta, *_ = np.linalg.lstsq(X, y, rcond=None)
    return X, beta, X @ beta - y


def test_classical_least_squares_covariance():
    rng = np.random.default_rng(0)
    t = np.linspace(0, 10, 200)
    y = 1.0 + 0.5 * t + 0.3 * rng.standard_normal(t.size)
    X, _, e = line_fit(y, t)
    cov, se, dof, s2, _ = covariance_from_jacobian(X, e, block=None)
    s2_ref = e @ e / (t.size - 2)
    np.testing.assert_allclose(cov, s2_ref * np.linalg.inv(X.T @ X), rtol=1e-10)
    assert dof == 198 and s2[0] == pytest.approx(s2_ref)
    # white residuals: the batch-means meat gives nearly the same intervals
    _, se2, *_ = covariance_from_jacobian(X, e, series=np.zeros(t.size, int), block="auto")
    np.testing.assert_allclose(se2, se, rtol=0.25)


def test_intervals_cover_the_truth_at_their_level():
    rng = np.random.default_rng(1)
    t = np.linspace(0, 1, 60)
    hits = 0
    n = 400
    for _ in range(n):
        y = 2.0 - 1.0 * t + 0.2 * rng.standard_normal(t.size)
        X, beta, e = line_fit(y, t)
        _, se, dof, _, _ = covariance_from_jacobian(X, e, block=None)
        tq = stats.t.ppf(0.975, dof)
        hits += abs(beta[1] + 1.0) <= tq * se[1]
    assert 0.92 <= hits / n <= 0.98  # binomial spread around 0.95 is 0.011


def test_sandwich_with_two_noise_levels_equals_weighted_least_squares():
    rng = np.random.default_rng(2)
    t = np.linspace(0, 1, 300)
    X = np.vstack([np.column_stack([np.ones_like(t), t])] * 2)
    g = np.repeat([0, 1], t.size)
    sig = np.array([0.1, 1.0])
    e = sig[g] * rng.standard_normal(2 * t.size)
    a = 1.0 / sig**2
    cov, *_ = covariance_from_jacobian(X, e, groups=g, weights=a, block=None)
    # with the estimated noise levels, the GLS covariance (Xᵀ W X)⁻¹
    s2 = np.array([e[g == j] @ e[g == j] / (t.size - 1) for j in (0, 1)])
    W = 1.0 / s2[g]
    gls = np.linalg.inv(X.T @ (W[:, None] * X))
    np.testing.assert_allclose(cov, gls, rtol=0.05)


def test_correlated_residuals_widen_the_intervals_to_their_real_spread():
    rng = np.random.default_rng(3)
    t = np.linspace(0, 1, 2000)
    phi = 0.95
    white, batch = 0, 0
    n = 150
    for _ in range(n):
        w = rng.standard_normal(t.size)
        v = np.empty_like(w)
        v[0] = w[0]
        for k in range(1, t.size):
            v[k] = phi * v[k - 1] + np.sqrt(1 - phi**2) * w[k]
        y = 1.0 + 2.0 * t + 0.5 * v
        X, beta, e = line_fit(y, t)
        _, se_w, dof, _, _ = covariance_from_jacobian(X, e, block=None)
        _, se_b, _, _, _ = covariance_from_jacobian(
            X, e, series=np.zeros(t.size, int), block="auto"
        )
        q = stats.t.ppf(0.975, dof)
        white += abs(beta[1] - 2.0) <= q * se_w[1]
        batch += abs(beta[1] - 2.0) <= q * se_b[1]
    assert white / n < 0.6  # the white-noise formula is far too optimistic here
    assert batch / n > 0.85


def test_correlation_length_of_white_and_smoothed_noise():
    rng = np.random.default_rng(4)
    assert correlation_length(rng.standard_normal(4000)) <= 3
    smooth = np.convolve(rng.standard_normal(4000), np.ones(30) / 30, mode="same")
    assert 15 < correlation_length(smooth) < 50


def test_rank_deficient_jacobian_marks_the_unidentifiable_parameters():
    t = np.linspace(0, 1, 50)
    J = np.column_stack([t, 2 * t, np.cos(4 * t)])
    e = np.sin(37 * t)
    cov, se, *_ = covariance_from_jacobian(J, e, block=None)
    assert cov is None
    assert np.isnan(se[:2]).all() and np.isfinite(se[2])


def test_shape_errors_are_named():
    with pytest.raises(ShapeError, match="J has shape"):
        covariance_from_jacobian(np.ones((5, 2)), np.ones(4))
    with pytest.raises(ShapeError, match="degrees of freedom"):
        covariance_from_jacobian(np.ones((2, 2)), np.ones(2))


def test_collinearity_and_subset_proposal():
    assert collinearity_index(np.eye(3)) == pytest.approx(1.0)
    t = np.linspace(0, 1, 100)
    J = np.column_stack([t, t + 1e-3 * np.sin(50 * t), np.exp(-3 * t), 1e-4 * t**2])
    idf = identifiability(J, ["a", "b", "c", "d"], np.ones(4))
    assert "d" not in idf.selected and "insensitive" in idf.reasons["d"]
    assert len({"a", "b"} & set(idf.selected)) == 1  # two indistinguishable effects: one kept
    assert "collinear" in idf.reasons["a" if "b" in idf.selected else "b"]
    assert idf.table()[0]["rank"] == 1 and "proposed" in str(idf)


def test_strut_ranking_puts_the_heat_sources_first():
    recs = run_experiment("strut", "steps", feed_rates=[20.0], seed=0)
    pb = Problem(StrutModel(), recs, pairs=["T_drive", "T_nut", "T_bearing"], fixed={"T_ref": 20.0})
    idf = problem_identifiability(pb)
    # each measured temperature sits next to one heat source (Table 5 of paper 000)
    assert set(idf.selected[:3]) == {"r_motor", "r_nut", "r_bearing"}


class Gain:
    """y = K · u_measured (the simulation is driven by a noisy measured input)."""

    name = "gain"
    batched = True
    param_names = ("K",)
    nominal = np.array([1.0])
    lower = np.array([0.0])
    upper = np.array([10.0])
    input_names = ("u",)
    output_names = ("y",)

    def simulate(self, theta, experiment):
        u = np.asarray(experiment["u"])
        th = np.atleast_2d(theta)
        return SimBatch(th[:, :1, None] * u[None, :, None], [None] * th.shape[0])

    def close(self):
        pass


def test_input_noise_share_matches_errors_in_variables_theory():
    rng = np.random.default_rng(5)
    n, K, su = 4000, 3.0, 0.2
    u_true = 1.0 + np.sin(np.arange(n) / 50.0)
    rec = Recording(
        np.arange(float(n)),
        {
            "u": u_true + su * rng.standard_normal(n),
            "y": K * u_true + 0.01 * rng.standard_normal(n),
        },
    )
    assert estimate_input_noise([rec], ["u"])["u"] == pytest.approx(su, rel=0.1)
    pb = Problem(Gain(), rec, objective="mse")
    u = np.asarray(rec["u"])
    k_hat = float(u @ rec["y"] / (u @ u))
    unc = problem_uncertainty(pb, [k_hat], input_noise={"u": su}, n_replicates=200, seed=1)
    theory = K**2 * su**2 / (u @ u)  # var of K̂ from δu: K² σ_u² Σu² / (Σu²)²
    assert unc.input_covariance[0, 0] == pytest.approx(theory, rel=0.3)
    assert unc.stderr[0] ** 2 >= unc.input_covariance[0, 0]
