"""Tests of the linear identification models against independent truth.

scipy.signal (dlsim, cont2discrete, lsim), hand-written predictor loops and
analytic step responses are the references; nothing is compared with frozen
floats.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
import scipy.signal

from thermogym.errors import (
    ConfigError,
    ParameterError,
    ShapeError,
    SimulationError,
    ThermogymError,
)
from thermogym.models.linear import (
    MODELS,
    FOPTDModel,
    StateSpaceModel,
    c2d_zoh,
    d2c_zoh,
    discrete_to_foptd,
    foptd_to_discrete,
    foptd_zoh,
)
from thermogym.models.registry import get_model


def random_stable(rng, n, m, p, radius=0.95):
    A = rng.normal(size=(n, n))
    A *= radius / np.abs(np.linalg.eigvals(A)).max()
    return A, rng.normal(size=(n, m)), rng.normal(size=(p, n)), rng.normal(size=(p, m))


@pytest.fixture
def rng():
    return np.random.default_rng(1234)


@pytest.fixture
def mimo(rng):
    A, B, C, D = random_stable(rng, 4, 2, 3)
    K = 0.05 * rng.normal(size=(4, 3))
    assert np.abs(np.linalg.eigvals(A - K @ C)).max() < 1  # a stable predictor
    return StateSpaceModel.from_matrices(
        A, B, C, D, K, dt=2.0, inputs=["P", "n"], outputs=["T1", "T2", "T3"]
    )


# ============================================================ state space
def test_simulate_matches_dlsim_for_a_batch(rng):
    n, m, p, T = 5, 2, 3, 300
    systems = [random_stable(rng, n, m, p, radius=r) for r in (0.5, 0.9, 0.99)]
    model = StateSpaceModel.from_matrices(*systems[0], dt=1.0)
    sets = [
        {
            f"{g}_{r}_{c}": M[r, c]
            for g, M in zip("ABCD", S, strict=True)
            for r, c in np.ndindex(M.shape)
        }
        for S in systems
    ]
    theta = model.theta(sets)
    u = rng.normal(size=(T, m))
    x0 = rng.normal(size=(3, n))
    sim = model.simulate(u, dt=1.0, theta=theta, x0=x0, return_states=True)
    assert sim.outputs.shape == (3, T, p)
    for b, (A, B, C, D) in enumerate(systems):
        _, y_ref, x_ref = scipy.signal.dlsim((A, B, C, D, 1.0), u, x0=x0[b])
        np.testing.assert_allclose(sim.outputs[b], y_ref, rtol=1e-10, atol=1e-10)
        np.testing.assert_allclose(sim.states[b], x_ref, rtol=1e-10, atol=1e-10)


def test_batch_equals_one_by_one(mimo, rng):
    theta = mimo.theta(batch=4) * (1 + 0.02 * rng.normal(size=(4, len(mimo.param_names))))
    u = rng.normal(size=(4, 120, 2))  # one input sequence per parameter set
    batch = mimo.simulate(u, dt=2.0, theta=theta).outputs
    for b in range(4):
        one = mimo.simulate(u[b], dt=2.0, theta=theta[b]).outputs[0]
        np.testing.assert_allclose(batch[b], one, rtol=0, atol=0)


def test_dcgain_is_the_steady_state_of_a_long_step(mimo):
    u = np.tile([1.5, -0.5], (600, 1))
    y_end = mimo.simulate(u, dt=2.0).outputs[0, -1]
    np.testing.assert_allclose(y_end, mimo.dcgain()[0] @ [1.5, -0.5], rtol=1e-9)


def test_steady_start_keeps_outputs_constant(mimo):
    m = StateSpaceModel(**{**mimo.config(), "steady_start": True})
    u = np.tile([2.0, 1.0], (50, 1))
    y = m.simulate(u, dt=2.0).outputs[0]
    np.testing.assert_allclose(y, np.broadcast_to(m.dcgain()[0] @ [2.0, 1.0], y.shape), rtol=1e-10)


def test_fit_x0_starts_from_the_parameters(mimo, rng):
    m = StateSpaceModel(**{**mimo.config(), "fit_x0": True, "x0": [1.0, 0.0, -2.0, 0.5]})
    assert m.param_names[-4:] == ("x0_0", "x0_1", "x0_2", "x0_3")
    u = rng.normal(size=(40, 2))
    ref = mimo.simulate(u, dt=2.0, x0=[1.0, 0.0, -2.0, 0.5]).outputs
    np.testing.assert_allclose(m.simulate(u, dt=2.0).outputs, ref, rtol=1e-12)


def test_from_continuous_matches_cont2discrete_and_inverts(rng):
    n, m, p, dt = 4, 2, 3, 30.0
    Ac = -np.diag([1e-3, 5e-3, 2e-2, 0.1]) + 1e-3 * rng.normal(size=(n, n))
    Bc, C, D = rng.normal(size=(n, m)), rng.normal(size=(p, n)), rng.normal(size=(p, m))
    model = StateSpaceModel.from_continuous(Ac, Bc, C, D, dt=dt)
    Ad, Bd, Cd, Dd, _ = scipy.signal.cont2discrete((Ac, Bc, C, D), dt, method="zoh")
    mats = model.matrices()
    np.testing.assert_allclose(mats.A[0], Ad, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(mats.B[0], Bd, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(mats.C[0], Cd)
    np.testing.assert_allclose(mats.D[0], Dd)
    back = model.to_continuous()
    np.testing.assert_allclose(back.A[0], Ac, rtol=1e-8, atol=1e-12)
    np.testing.assert_allclose(back.B[0], Bc, rtol=1e-8, atol=1e-12)
    # continuous eigenvalues map to discrete ones by exp(λ dt)
    lam_c = np.sort_complex(np.linalg.eigvals(Ac))
    np.testing.assert_allclose(np.sort_complex(model.eigenvalues()[0]), np.exp(lam_c * dt))


def test_d2c_refuses_negative_real_eigenvalue():
    with pytest.raises(ParameterError, match="non-positive real axis"):
        d2c_zoh([[-0.5]], [[1.0]], 1.0)
    Ad, Bd = c2d_zoh([[-0.2]], [[0.2]], 1.0)
    np.testing.assert_allclose(d2c_zoh(Ad, Bd, 1.0)[0], [[-0.2]])


def test_eigenvalues_and_stability():
    A = np.array([[0.5, 2.0], [0.0, -0.8]])
    m = StateSpaceModel.from_matrices(A, [[0.0], [1.0]], [[1.0, 0.0]], dt=1.0)
    np.testing.assert_allclose(np.sort(m.eigenvalues()[0].real), [-0.8, 0.5])
    theta = m.theta({"A_1_1": [-0.8, 1.2]})
    assert m.is_stable(theta).tolist() == [True, False]
    # an unstable model is accepted and simulates (it just grows)
    unstable = StateSpaceModel.from_matrices([[1.05]], [[1.0]], [[1.0]], dt=1.0)
    assert not unstable.is_stable()[0]
    y = unstable.simulate(np.ones((20, 1)), dt=1.0).outputs[0, :, 0]
    assert np.all(np.diff(y[1:]) > 0)


def hand_predictor(A, B, C, D, K, y, u, x0, h):
    """ŷ[k|k−h] by brute force: one-step filter, then h−1 open-loop steps."""
    T = len(u)
    xp = [np.array(x0, dtype=float)]
    for k in range(T):
        e = y[k] - C @ xp[k] - D @ u[k]
        xp.append(A @ xp[k] + B @ u[k] + K @ e)
    out = np.empty((T, C.shape[0]))
    for k in range(T):
        s = max(0, k - h + 1)
        x = xp[s]
        for j in range(s, k):
            x = A @ x + B @ u[j]
        out[k] = C @ x + D @ u[k]
    return out


@pytest.mark.parametrize("h", [1, 3, 17])
def test_predict_matches_hand_written_kalman_predictor(mimo, rng, h):
    T = 80
    u = rng.normal(size=(T, 2))
    y = mimo.simulate(u, dt=2.0).outputs[0] + 0.1 * rng.normal(size=(T, 3))
    x0 = rng.normal(size=4)
    mats = [M[0] for M in mimo.matrices()]
    ref = hand_predictor(*mats, y, u, x0, h)
    got = mimo.predict(y, u, x0=x0, horizon=h)[0]
    np.testing.assert_allclose(got, ref, rtol=1e-9, atol=1e-9)


def test_predict_one_step_uses_the_closed_form(mimo, rng):
    # x̂[k+1] = (A − K C) x̂ + (B − K D) u + K y  written out once more
    A, B, C, D, K = (M[0] for M in mimo.matrices())
    u, y = rng.normal(size=(30, 2)), rng.normal(size=(30, 3))
    x, ref = np.zeros(4), []
    for k in range(30):
        ref.append(C @ x + D @ u[k])
        x = (A - K @ C) @ x + (B - K @ D) @ u[k] + K @ y[k]
    np.testing.assert_allclose(mimo.predict(y, u)[0], ref, rtol=1e-10, atol=1e-12)


def test_infinite_horizon_is_simulation_and_nan_is_skipped(mimo, rng):
    u = rng.normal(size=(60, 2))
    y = rng.normal(size=(60, 3))
    sim = mimo.simulate(u, dt=2.0).outputs
    np.testing.assert_allclose(mimo.predict(y, u, horizon=None), sim, rtol=1e-10, atol=1e-12)
    y_nan = y.copy()
    y_nan[10:20, 1] = np.nan
    A, B, C, D, K = (M[0] for M in mimo.matrices())
    x, ref = np.zeros(4), []
    for k in range(60):
        ref.append(C @ x + D @ u[k])
        e = np.nan_to_num(y_nan[k] - ref[-1], nan=0.0)
        x = A @ x + B @ u[k] + K @ e
    np.testing.assert_allclose(mimo.predict(y_nan, u)[0], ref, rtol=1e-10, atol=1e-12)


def test_estimate_x0_recovers_a_known_state(mimo, rng):
    u = rng.normal(size=(200, 2))
    x0 = np.array([3.0, -1.0, 0.5, 2.0])
    y = mimo.simulate(u, dt=2.0, x0=x0).outputs[0]
    np.testing.assert_allclose(mimo.estimate_x0(u, y)[0], x0, rtol=1e-8, atol=1e-8)
    y[5:40, 0] = np.nan  # gaps are skipped
    np.testing.assert_allclose(mimo.estimate_x0(u, y)[0], x0, rtol=1e-8, atol=1e-8)
    # the estimate is what predict(x0="estimate") starts from
    ref = mimo.predict(y, u, x0=x0)
    np.testing.assert_allclose(mimo.predict(y, u, x0="estimate"), ref, rtol=1e-7, atol=1e-7)


def test_estimate_x0_for_a_batch_of_parameter_sets(mimo, rng):
    theta = mimo.theta(batch=3)
    theta[1, mimo.param_index("A_0_0")] *= 0.9
    theta[2, mimo.param_index("C_2_3")] += 0.3
    u = rng.normal(size=(150, 2))
    x0 = rng.normal(size=(3, 4))
    y = mimo.simulate(u, dt=2.0, theta=theta, x0=x0).outputs
    np.testing.assert_allclose(mimo.estimate_x0(u, y, theta), x0, rtol=1e-7, atol=1e-7)


def test_step_and_output_follow_simulate(mimo, rng):
    u = rng.normal(size=(25, 2))
    sim = mimo.simulate(u, dt=2.0, x0=np.ones(4), return_states=True)
    x = np.ones((1, 4))
    for k in range(25):
        np.testing.assert_allclose(mimo.output(x, u[k], None)[0], sim.outputs[0, k], rtol=1e-12)
        x = mimo.step(x, u[k], None, 2.0)
    # a period of 3 model samples holds the input over 3 steps
    coarse = mimo.simulate(u[:5], dt=6.0).outputs[0]
    fine = mimo.simulate(np.repeat(u[:5], 3, axis=0), dt=2.0).outputs[0, ::3]
    np.testing.assert_allclose(coarse, fine, rtol=1e-12)
    # a period that is no whole multiple needs a continuous equivalent; this A has a
    # negative real eigenvalue and has none
    assert (np.linalg.eigvals(mimo.matrices().A[0]).real < 0).any()
    with pytest.raises(SimulationError, match="no real continuous-time equivalent"):
        mimo.simulate(u, dt=3.0)


def test_state_space_config_round_trip(mimo, rng):
    cfg = json.loads(json.dumps(mimo.config()))
    again = get_model("ss", **cfg)
    assert isinstance(again, StateSpaceModel)
    assert again.param_names == mimo.param_names
    np.testing.assert_array_equal(again.nominal, mimo.nominal)
    assert again.describe()["config"] == mimo.config()
    u = rng.normal(size=(30, 2))
    np.testing.assert_array_equal(
        again.simulate(u, dt=2.0).outputs, mimo.simulate(u, dt=2.0).outputs
    )
    fx = StateSpaceModel(**{**cfg, "fit_x0": True, "x0": [1, 2, 3, 4]})
    np.testing.assert_array_equal(
        get_model("ss", **json.loads(json.dumps(fx.config()))).nominal, fx.nominal
    )
    with pytest.raises(ConfigError):
        get_model("ss", **cfg, colour="red")
    assert MODELS == {"ss": StateSpaceModel, "foptd": FOPTDModel}


def test_parameter_names_bounds_and_units():
    m = StateSpaceModel.from_matrices(
        [[0.5]],
        [[2.0, 0.0]],
        [[1.0]],
        dt=1.0,
        inputs=["P"],
        outputs=["T"],
        disturbances=["T_amb"],
        units={"P": "W", "T": "°C", "T_amb": "°C"},
    )
    assert m.exogenous_names == ("P", "T_amb")
    b = m.parameters[m.param_index("B_0_0")]
    assert (b.nominal, b.lower, b.upper, b.unit, b.provenance) == (
        2.0,
        -19.0,
        23.0,
        "state/W",
        "identified",
    )
    assert m.disturbances[0].name == "T_amb"


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        (
            {"A": np.eye(3), "B": np.ones((2, 1)), "C": np.ones((1, 2))},
            r"B has shape \(2, 1\), expected \(3, 1\)",
        ),
        (
            {"A": np.eye(2), "B": np.ones((2, 1)), "C": np.ones((2, 2))},
            r"C has shape \(2, 2\), expected \(1, 2\)",
        ),
        (
            {"A": np.ones((2, 3)), "B": np.ones((2, 1)), "C": np.ones((1, 2))},
            r"A has shape \(2, 3\)",
        ),
        (
            {"A": np.eye(2), "B": np.ones((2, 1)), "C": np.ones((1, 2)), "D": np.ones((2, 1))},
            r"D has shape \(2, 1\), expected \(1, 1\)",
        ),
        (
            {"A": np.eye(2), "B": np.ones((2, 1)), "C": np.ones((1, 2)), "K": np.ones((1, 2))},
            r"K has shape \(1, 2\), expected \(2, 1\)",
        ),
    ],
)
def test_wrong_matrix_shapes_name_the_matrix(kwargs, match):
    n = kwargs["A"].shape[0]
    with pytest.raises(ShapeError, match=match):
        StateSpaceModel(n, ["u"], ["y"], dt=1.0, **kwargs)


def test_bad_state_space_configuration():
    with pytest.raises(ConfigError, match="units given for unknown"):
        StateSpaceModel(1, ["u"], ["y"], units={"v": "W"})
    with pytest.raises(ConfigError, match="has_D=False"):
        StateSpaceModel(1, ["u"], ["y"], D=[[1.0]], has_D=False)
    with pytest.raises(ConfigError, match="dt"):
        StateSpaceModel(1, ["u"], ["y"], dt=0.0)
    with pytest.raises(ConfigError, match="fit_x0 and steady_start"):
        StateSpaceModel(1, ["u"], ["y"], fit_x0=True, steady_start=True)
    with pytest.raises(ParameterError, match="finite"):
        StateSpaceModel(1, ["u"], ["y"], A=[[np.nan]])
    m = StateSpaceModel(2, ["u"], ["y"])
    with pytest.raises(ShapeError, match=r"y has shape"):
        m.predict(np.ones((5, 2)), np.ones((5, 1)))
    with pytest.raises(ShapeError, match="horizon"):
        m.predict(np.ones((5, 1)), np.ones((5, 1)), horizon=0)
    integrator = StateSpaceModel.from_matrices([[1.0]], [[1.0]], [[1.0]], dt=1.0)
    with pytest.raises(SimulationError, match="singular"):
        integrator.dcgain()
    assert issubclass(ShapeError, ThermogymError)


# ================================================================= FOPTD
def analytic_step(t, K, T, tau):
    return np.where(t > tau, K * (1.0 - np.exp(-(t - tau) / T)), 0.0)


@pytest.mark.parametrize("tau", [0.0, 30.0, 37.3, 4.5, 119.999])
def test_foptd_step_response_is_analytic(tau):
    dt, K, T = 10.0, 2.5, 200.0
    m = FOPTDModel(["v_f"], ["T_1"], K=K, T=T, tau=tau)
    y = m.simulate(np.ones((200, 1)), dt=dt).output("T_1")[0]
    t = dt * np.arange(200)
    np.testing.assert_allclose(y, analytic_step(t, K, T, tau), rtol=1e-10, atol=1e-12)


def test_foptd_fractional_delay_matches_fine_lsim(rng):
    # reference: exact ZOH (lsim) on a 10x finer grid where the delay is whole samples
    dt, K, T, tau, N = 5.0, -1.7, 40.0, 13.5, 120
    u = rng.uniform(0, 3, size=N)
    m = FOPTDModel(K=K, T=T, tau=tau)
    y = m.simulate(u[:, None], dt=dt).outputs[0, :, 0]
    fine_dt, shift = dt / 10, round(tau / (dt / 10))
    uf = np.concatenate([np.zeros(shift), np.repeat(u, 10)])[: 10 * N]
    tf = fine_dt * np.arange(10 * N)
    _, yf, _ = scipy.signal.lsim(([K], [T, 1.0]), uf, tf, interp=False)
    np.testing.assert_allclose(y, yf[::10], rtol=1e-8, atol=1e-10)


def test_foptd_superposition_mimo():
    K = [[1.0, -2.0], [0.5, 3.0], [0.0, 1.0]]
    T = [[50.0, 80.0], [20.0, 200.0], [10.0, 30.0]]
    tau = [[0.0, 15.0], [7.5, 40.0], [3.0, 0.0]]
    m = FOPTDModel(["n", "v"], ["a", "b", "c"], K=K, T=T, tau=tau, offsets=True, y0=[20, 21, 22])
    assert m.param_names[:4] == ("K_a__n", "T_a__n", "tau_a__n", "K_a__v")
    u = np.column_stack([np.full(100, 2.0), np.full(100, 0.5)])
    y = m.simulate(u, dt=5.0).outputs[0]
    t = 5.0 * np.arange(100)
    for j in range(3):
        ref = (
            20 + j + sum(analytic_step(t, K[j][i] * u[0, i], T[j][i], tau[j][i]) for i in range(2))
        )
        np.testing.assert_allclose(y[:, j], ref, rtol=1e-10, atol=1e-10)


def test_foptd_batch_equals_one_by_one(rng):
    m = FOPTDModel(["u"], ["y1", "y2"], K=[[1.0], [2.0]], T=[[10.0], [30.0]], tau=[[2.0], [5.5]])
    B = 50
    theta = m.theta(
        {
            "K_y1": rng.uniform(0.5, 2, B),
            "T_y1": rng.uniform(5, 50, B),
            "tau_y1": rng.uniform(0, 10, B),
            "tau_y2": rng.uniform(0, 10, B),
        }
    )
    u = rng.normal(size=(60, 1))
    batch = m.simulate(u, dt=1.0, theta=theta).outputs
    for b in (0, 17, 49):
        np.testing.assert_array_equal(batch[b], m.simulate(u, dt=1.0, theta=theta[b]).outputs[0])


def test_discrete_conversions_invert_each_other(rng):
    K, T, d, dt = rng.uniform(-5, 5, 20), rng.uniform(1, 1e4, 20), rng.integers(0, 30, 20), 2.0
    a, b, d2 = foptd_to_discrete(K, T, d * dt, dt)
    np.testing.assert_array_equal(d2, d)
    K2, T2, tau2 = discrete_to_foptd(a, b, d2, dt)
    np.testing.assert_allclose(K2, K, rtol=1e-10)
    np.testing.assert_allclose(T2, T, rtol=1e-10)
    np.testing.assert_allclose(tau2, d * dt)
    a3, b3, d3 = foptd_to_discrete(*discrete_to_foptd(0.97, 0.06, 4, dt), dt)
    np.testing.assert_allclose([a3, b3, d3], [0.97, 0.06, 4])
    # the exact fractional form reduces to (9) for whole delays and keeps the DC gain
    za, b1, b2, zd = foptd_zoh(K, T, d * dt, dt)
    np.testing.assert_allclose(za, a)
    np.testing.assert_allclose(b1, b, rtol=1e-12)
    np.testing.assert_array_equal(b2, 0.0)
    _, b1, b2, zd = foptd_zoh(K, T, (d + 0.3) * dt, dt)
    np.testing.assert_array_equal(zd, d)
    np.testing.assert_allclose((b1 + b2) / (1 - a), K, rtol=1e-10)


def test_foptd_difference_equation_reproduces_simulation(rng):
    # the (a, b, d) of to_discrete, iterated by hand, is the simulated output (integer delay)
    m = FOPTDModel(K=1.3, T=25.0, tau=6.0)
    a, b, d = (v[0, 0, 0] for v in m.to_discrete(2.0))
    u = rng.normal(size=80)
    y = np.zeros(80)
    for k in range(1, 80):
        y[k] = a * y[k - 1] + (b * u[k - 1 - d] if k - 1 - d >= 0 else 0.0)
    np.testing.assert_allclose(m.simulate(u[:, None], dt=2.0).outputs[0, :, 0], y, atol=1e-12)
    with pytest.raises(ParameterError, match="not a multiple"):
        FOPTDModel(tau=5.0).to_discrete(2.0)
    assert int(FOPTDModel(tau=5.0).to_discrete(2.0, round_delay=True)[2][0, 0, 0]) == 2


def test_foptd_step_follows_simulate_with_history(rng):
    m = FOPTDModel(["u", "w"], ["y"], K=[[1.0, -0.5]], T=[[8.0, 3.0]], tau=[[2.7, 1.0]], history=3)
    u = rng.normal(size=(40, 2))
    sim = m.simulate(u, dt=1.0, return_states=True)
    x = m.initial_state(m.theta(), u[:1])
    for k in range(40):
        np.testing.assert_allclose(sim.states[0, k], x[0], atol=1e-12)
        np.testing.assert_allclose(m.output(x, u[k], None)[0], sim.outputs[0, k], atol=1e-12)
        x = m.step(x, u[k], None, 1.0)
    # continuing from a stored state gives the rest of the run
    rest = m.simulate(u[20:], dt=1.0, x0=sim.states[0, 20]).outputs[0]
    np.testing.assert_allclose(rest, sim.outputs[0, 20:], atol=1e-12)
    short = FOPTDModel(K=1.0, T=5.0, tau=2.5, history=2)
    with pytest.raises(SimulationError, match="history >= 3"):
        short.step(np.zeros((1, 3)), [1.0], None, 1.0)


def test_foptd_steady_start_and_offsets():
    m = FOPTDModel(K=2.0, T=30.0, tau=12.0, steady_start=True, offsets=True, y0=20.0)
    y = m.simulate(np.full((50, 1), 3.0), dt=5.0).outputs[0, :, 0]
    np.testing.assert_allclose(y, 26.0)


def test_foptd_config_round_trip(rng):
    m = FOPTDModel(
        ["n"],
        ["T_b", "T_h"],
        disturbances=["T_amb"],
        units={"n": "rpm", "T_b": "°C"},
        K=[[1e-3, 0.9], [2e-3, 1.0]],
        T=[[600.0, 900.0], [1200.0, 1500.0]],
        tau=30.0,
        offsets=True,
        y0=[1.0, 2.0],
        history=3,
    )
    cfg = json.loads(json.dumps(m.config()))
    again = get_model("foptd", **cfg)
    assert again.param_names == m.param_names
    assert again.state_names == m.state_names
    np.testing.assert_array_equal(again.nominal, m.nominal)
    assert again.signal("n").unit == "rpm" and again.signal("T_h").unit == "1"
    assert m.parameters[m.param_index("K_T_b__n")].unit == "°C/rpm"
    u = rng.normal(size=(30, 2))
    np.testing.assert_array_equal(again.simulate(u, 10.0).outputs, m.simulate(u, 10.0).outputs)


def test_foptd_bad_values():
    with pytest.raises(ParameterError, match=r"T of pair .* must be positive"):
        FOPTDModel(T=0.0)
    with pytest.raises(ParameterError, match="delay must be >= 0"):
        FOPTDModel(tau=-1.0)
    m = FOPTDModel()
    with pytest.raises(ParameterError, match=r"'T_y'.*positive"):
        m.theta(T_y=-5.0)
    with pytest.raises(ParameterError, match=r"'tau_y'.*>= 0"):
        m.theta(tau_y=-0.1)
    with pytest.raises(ShapeError, match=r"K has shape \(3,\)"):
        FOPTDModel(["u"], ["a", "b"], K=[1.0, 2.0, 3.0])
    with pytest.raises(ParameterError, match="0 < a < 1"):
        discrete_to_foptd(1.0, 0.1, 0, 1.0)
    with pytest.raises(ParameterError, match="whole number"):
        discrete_to_foptd(0.5, 0.1, 1.5, 1.0)
    with pytest.raises(ConfigError, match="offsets=False"):
        FOPTDModel(y0=3.0)
