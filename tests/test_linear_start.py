"""Operating point, sample period and initial state of the generic linear models.

Independent truth: hand-written difference equations of known systems started
away from rest, scipy's ZOH discretisation, analytic steady states.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal

from thermogym.errors import ConfigError, ShapeError
from thermogym.models.linear import X0_MODES, FOPTDModel, StateSpaceModel


def loop_ss(A, B, C, D, u, x0, u_op, y_op):
    """x[k+1] = A x + B (u − u_op), y = y_op + C x + D (u − u_op), by hand."""
    x = np.array(x0, dtype=float)
    out = []
    for uk in u:
        du = uk - u_op
        out.append(y_op + C @ x + D @ du)
        x = A @ x + B @ du
    return np.array(out)


@pytest.fixture
def plant():
    A = np.array([[0.92, 0.05], [-0.03, 0.85]])
    B = np.array([[0.4, 0.1], [0.2, -0.3]])
    C = np.array([[1.0, 0.5]])
    D = np.array([[0.05, 0.0]])
    return A, B, C, D


def test_state_space_started_away_from_rest_is_recovered(plant):
    A, B, C, D = plant
    u_op, y_op = np.array([3.0, 20.0]), np.array([55.0])
    rng = np.random.default_rng(3)
    u = u_op + rng.normal(size=(300, 2))
    x_true = np.array([4.0, -2.5])
    y = loop_ss(A, B, C, D, u, x_true, u_op, y_op)
    m = StateSpaceModel.from_matrices(A, B, C, D, u_op=u_op, y_op=y_op)
    sim = m.simulate(u, 60.0, x0="estimate", y=y, return_states=True)
    assert sim.meta["x0"] == "estimate"
    np.testing.assert_allclose(sim.states[0, 0], x_true, atol=1e-8)
    np.testing.assert_allclose(sim.outputs[0], y, atol=1e-8)
    # the explicit state gives the same; zero and steady start elsewhere
    np.testing.assert_allclose(m.simulate(u, 60.0, x0=x_true).outputs[0], y, atol=1e-10)
    zero = m.simulate(u, 60.0, x0="zero").outputs[0]
    np.testing.assert_allclose(zero, loop_ss(A, B, C, D, u, np.zeros(2), u_op, y_op), atol=1e-10)
    # the Kalman predictor with x0 modes and the step-wise path apply the operating point too
    np.testing.assert_allclose(m.predict(y, u, x0="estimate")[0], y, atol=1e-8)
    x = x_true[None]
    for k in range(5):
        np.testing.assert_allclose(m.output(x, u[k], None)[0], y[k], atol=1e-10)
        x = m.step(x, u[k], None, 60.0)


def test_steady_start_and_dc_gain_about_the_operating_point(plant):
    A, B, C, D = plant
    u_op, y_op = np.array([3.0, 20.0]), np.array([55.0])
    m = StateSpaceModel.from_matrices(A, B, C, D, u_op=u_op, y_op=y_op)
    u1 = np.array([5.0, 18.0])
    G = C @ np.linalg.solve(np.eye(2) - A, B) + D  # DC gain by hand
    np.testing.assert_allclose(m.dcgain()[0], G, rtol=1e-12)
    y = m.simulate(np.tile(u1, (40, 1)), 1.0, x0="steady").outputs[0]
    np.testing.assert_allclose(y, np.tile(y_op + G @ (u1 - u_op), (40, 1)), rtol=1e-12)
    # at rest at the operating point: the output stays at y_op
    y = m.simulate(np.tile(u_op, (40, 1)), 1.0, x0="zero").outputs[0]
    np.testing.assert_allclose(y, np.full((40, 1), 55.0), rtol=1e-14)
    cfg = m.config()
    assert cfg["u_op"] == [3.0, 20.0] and cfg["y_op"] == [55.0]
    again = StateSpaceModel(**cfg)
    np.testing.assert_array_equal(
        again.simulate(np.tile(u1, (5, 1)), 1.0).outputs,
        m.simulate(np.tile(u1, (5, 1)), 1.0).outputs,
    )


def test_state_space_without_period_simulates_at_the_data_period(plant):
    # a model identified at 1228.8 s (DTU building): one step of A per sample
    A, B, C, D = plant
    m = StateSpaceModel.from_matrices(A, B, C, D)
    assert m.dt is None
    u = np.random.default_rng(0).normal(size=(50, 2))
    ref = loop_ss(A, B, C, D, u, np.zeros(2), np.zeros(2), np.zeros(1))
    for dt in (1228.8, 1.0, 0.37):
        y = m.simulate(u, dt).outputs[0]
        np.testing.assert_allclose(y, ref, atol=1e-12)


@pytest.mark.parametrize("dt", [1228.8, 7.5, 30.0])
def test_state_space_with_a_period_resamples_exactly(dt):
    # continuous plant sampled at 10 s, simulated at another period: the exact ZOH
    Ac = np.array([[-1 / 900.0, 1 / 1800.0], [1 / 2400.0, -1 / 600.0]])
    Bc = np.array([[1 / 300.0], [0.0]])
    C = np.array([[0.0, 1.0]])
    m = StateSpaceModel.from_continuous(Ac, Bc, C, dt=10.0)
    Ad, Bd, Cd, Dd, _ = scipy.signal.cont2discrete((Ac, Bc, C, np.zeros((1, 1))), dt, "zoh")
    u = np.random.default_rng(1).uniform(0, 100, size=(80, 1))
    _, ref, _ = scipy.signal.dlsim((Ad, Bd, Cd, Dd, dt), u)
    y = m.simulate(u, dt).outputs[0]
    assert np.isfinite(y).all()
    np.testing.assert_allclose(y, ref, rtol=1e-8, atol=1e-9 * np.abs(ref).max())


def test_foptd_operating_point_and_modes():
    K, T, tau, y0, u_op = 2.0, 30.0, 4.0, 20.0, 5.0
    m = FOPTDModel(K=K, T=T, tau=tau, offsets=True, y0=y0, u_op=[u_op])
    t = np.arange(200.0)
    u = np.full((200, 1), 8.0)
    step = K * 3.0 * np.where(t > tau, 1.0 - np.exp(-(t - tau) / T), 0.0)
    # zero: at rest at u_op, the 3-unit step above u_op arrives after the delay
    np.testing.assert_allclose(
        m.simulate(u, 1.0, x0="zero").outputs[0, :, 0], y0 + step, atol=1e-10
    )
    # steady: already settled at u[0]
    np.testing.assert_allclose(
        m.simulate(u, 1.0, x0="steady").outputs[0, :, 0], y0 + 6.0, atol=1e-10
    )
    assert set(X0_MODES) == {"zero", "steady", "estimate"}


def test_foptd_fits_a_log_that_starts_mid_operation():
    # a lag started 4 units above its steady state, input held before the start
    true = FOPTDModel(
        ["u"], ["y"], K=1.5, T=40.0, tau=6.0, offsets=True, y0=12.0, steady_start=True
    )
    rng = np.random.default_rng(7)
    u = np.repeat(rng.uniform(0, 4, 20), 25)[:, None]
    z0 = 1.5 * u[0, 0] + 4.0
    y = true.simulate(u, 2.0, x0=[z0]).outputs[0]
    m = FOPTDModel(["u"], ["y"], K=1.5, T=40.0, tau=6.0, offsets=True, y0=12.0)
    sim = m.simulate(u, 2.0, x0="estimate", y=y, return_states=True)
    np.testing.assert_allclose(sim.states[0, 0, 0], z0, rtol=1e-9)
    np.testing.assert_allclose(sim.outputs[0], y, atol=1e-9)
    # a noisy first sample does not become an offset: the error stays at the noise level
    noisy = y + rng.normal(0, 0.05, size=y.shape)
    noisy[0] += 2.0
    est = m.simulate(u, 2.0, x0="estimate", y=noisy).outputs[0]
    # (an offset would stay; the start transient decays with T = 40 s, 20 samples)
    assert np.abs(est - y)[100:].max() < 0.01
    assert np.sqrt(np.mean((est - y) ** 2)) < 0.1


def test_x0_mode_errors():
    m = FOPTDModel()
    u = np.ones((10, 1))
    with pytest.raises(ConfigError, match="expected one of"):
        m.simulate(u, 1.0, x0="rest")
    with pytest.raises(ConfigError, match="needs the measured outputs"):
        m.simulate(u, 1.0, x0="estimate")
    with pytest.raises(ConfigError, match="only with x0='estimate'"):
        m.simulate(u, 1.0, y=u)
    with pytest.raises(ShapeError, match="y has shape"):
        m.simulate(u, 1.0, x0="estimate", y=np.ones((9, 1)))
    with pytest.raises(ShapeError, match="u_op has shape"):
        StateSpaceModel(1, ["a", "b"], ["y"], u_op=[1.0])
    with pytest.raises(ConfigError, match="not exogenous signal"):
        FOPTDModel(["a"], ["y"], u_op={"b": 1.0})
    with pytest.raises(ConfigError, match="dt"):
        StateSpaceModel(1, dt=-2.0)
