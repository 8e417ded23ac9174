"""thermogym/IdentifiedPlant-v0: the generic environment of an identified model.

Truth: analytic step responses of the identified transfer functions (not the
environment's realisation), the recorded ranges written into the fit, and the
plant environments a nonlinear fit is handed to. The checker, determinism and
vector-equals-singles sweeps run in tests/test_envs.py over every registered ID.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import thermogym.envs  # noqa: F401 - registers the environments
from thermogym.errors import ConfigError
from thermogym.fitresult import FitResult
from thermogym.models.linear import FOPTDModel
from thermogym.models.polynomial import PolynomialModel
from thermogym.models.process import SOPDTModel

ID = "thermogym/IdentifiedPlant-v0"


def _settings(ranges, u_op, y_op, mode="rest"):
    return {
        "signal_ranges": ranges,
        "operating_point": {"mode": mode, "inputs": u_op, "outputs": y_op},
    }


def test_sopdt_env_reproduces_the_analytic_step_response():
    K, T1, T2, tau = 2.0, 60.0, 20.0, 10.5  # a fractional delay of 10.5 periods
    m = SOPDTModel(["P"], ["T"], units={"P": "W", "T": "°C"}, K=K, T1=T1, T2=T2, tau=tau)
    fit = FitResult.from_model(
        m, settings=_settings({"P": [0.0, 10.0], "T": [20.0, 60.0]}, {"P": 0.0}, {"T": 20.0})
    )
    env = gym.make(ID, params=fit, control_period=1.0, episode_steps=400, setpoint=40.0)
    obs, _ = env.reset(seed=0)
    assert obs[0] == pytest.approx(-1.0)  # starts at rest: 20 °C is the bottom of the range
    ys = []
    for _ in range(300):
        obs, r, term, trunc, _info = env.step(np.ones(1, dtype=np.float32))  # P = 10 W
        ys.append(env.unwrapped.true_outputs()["T"])
    t = np.arange(1, 301) - tau
    step = np.where(
        t > 0, 1 - (T1 * np.exp(-t / T1) - T2 * np.exp(-t / T2)) / (T1 - T2), 0.0
    )  # y(t) = K u (1 − (T1 e^{−t/T1} − T2 e^{−t/T2}) / (T1 − T2)) after the delay
    np.testing.assert_allclose(ys, 20.0 + K * 10.0 * step, atol=1e-9)
    # observation scaling from the recorded range, reward from tracking and energy
    y = ys[-1]
    assert obs[0] == pytest.approx(2 * (y - 20.0) / 40.0 - 1, abs=1e-6)
    w = {"tracking": 1.0, "energy": 0.05}
    assert r == pytest.approx(-(w["tracking"] * abs(y - 40.0) / 40.0 + w["energy"] * 1.0))
    assert not term and not trunc


def test_foptd_and_arx_fits_run_at_their_own_period():
    fo = FOPTDModel(["u"], ["y"], K=0.5, T=30.0, tau=4.0)
    fit = FitResult.from_model(
        fo, settings=_settings({"u": [0, 2], "y": [0, 1]}, {"u": 0.0}, {"y": 0.0})
    )
    env = gym.make(ID, params=fit, control_period=2.0, episode_steps=100, setpoint=0.5)
    env.reset(seed=0)
    for _ in range(100):
        env.step(np.ones(1, dtype=np.float32))  # u = 2
    t = 200.0 - 4.0
    assert env.unwrapped.true_outputs()["y"] == pytest.approx(0.5 * 2 * (1 - np.exp(-t / 30)))
    arx = PolynomialModel(["u"], ["y"], structure="arx", na=1, nb=1, nk=2, dt=5.0)
    fit = FitResult.from_model(
        arx,
        {"a1_y": -0.5, "b0_y": 1.0},
        settings=_settings({"u": [0, 1], "y": [0, 2]}, {"u": 0.0}, {"y": 0.0}),
    )
    env = gym.make(ID, params=fit, episode_steps=20)
    assert env.unwrapped.dt == 5.0
    env.reset(seed=0)
    ys = []
    for _ in range(3):
        env.step(np.ones(1, dtype=np.float32))
        ys.append(env.unwrapped.true_outputs()["y"])
    # y(k) = 0.5 y(k−1) + u(k−2): the output moves two periods after the step
    assert ys == pytest.approx([0.0, 1.0, 1.5])


def test_covariance_randomisation_draws_stable_models_per_episode():
    m = PolynomialModel(["u"], ["y"], structure="arx", na=1, nb=1, nk=1)
    fit = FitResult.from_model(
        m,
        {"a1_y": -0.95, "b0_y": 0.1},
        stderr={"a1_y": 0.03, "b0_y": 0.01},
        settings=_settings({"u": [0, 1], "y": [0, 2]}, {"u": 0.0}, {"y": 0.0}),
    )
    env = gym.make(ID, params=fit, episode_steps=5, randomize="covariance")
    thetas = []
    for seed in (0, 1, 2, 0):
        env.reset(seed=seed)
        thetas.append(env.unwrapped.theta[0].copy())
    assert not np.allclose(thetas[0], thetas[1])
    np.testing.assert_array_equal(thetas[0], thetas[3])
    # a1 near −0.95 with σ 0.03: unstable draws (a1 <= −1) are drawn again
    assert all(t[0] > -1.0 for t in thetas)


def test_nonlinear_fits_go_to_their_plant_environment():
    from thermogym.envs.tclab import FIT_PATH, TCLabEnv

    env = gym.make(ID, params=str(FIT_PATH), episode_s=30.0)
    assert isinstance(env.unwrapped, TCLabEnv)
    venv = gym.make_vec(ID, 2, vectorization_mode="vector_entry_point", params=str(FIT_PATH))
    assert venv.num_envs == 2 and venv.unwrapped.obs_names[0] == "T1"


@pytest.mark.parametrize(
    ("kw", "match"),
    [
        ({"setpoint": [1.0, 2.0, 3.0]}, "setpoint"),
        ({"input_range": {"u": (2.0, 1.0)}}, "input_range"),
        ({"input_range": {"v": (0.0, 1.0)}}, "input_range"),
        ({"episode_steps": 0}, "episode_steps"),
        ({"disturbances": {"u": 1.0}}, "disturbances"),
        ({"output_limits": {"y": 3.0}}, "output_limits"),
        ({"setpoint_hold_steps": -1}, "setpoint_hold_steps"),
        ({"sensor_noise": -0.1}, "sensor_noise"),
    ],
)
def test_bad_values_are_named(kw, match):
    m = PolynomialModel(["u"], ["y"], structure="arx", na=1, nb=1)
    fit = FitResult.from_model(
        m,
        {"a1_y": -0.5, "b0_y": 0.5},
        settings=_settings({"u": [0, 1], "y": [0, 1]}, {"u": 0.0}, {"y": 0.0}),
    )
    with pytest.raises(ConfigError, match=match):
        gym.make(ID, params=fit, **kw)


def test_a_fit_without_recorded_ranges_asks_for_input_range():
    m = PolynomialModel(["u"], ["y"], structure="arx", na=1, nb=1)
    fit = FitResult.from_model(m, {"a1_y": -0.5, "b0_y": 0.5})
    with pytest.raises(ConfigError, match="input_range"):
        gym.make(ID, params=fit)
    env = gym.make(ID, params=fit, input_range={"u": (0.0, 4.0)}, episode_steps=3)
    env.reset(seed=0)
    env.step(np.ones(1, dtype=np.float32))
    assert env.unwrapped.true_outputs()["u"] == 4.0


def test_a_batch_mixing_whole_and_fractional_delays_is_realised():
    from thermogym.models.process import discrete_realization

    m = SOPDTModel(["u"], ["y"], K=1.0, T1=20.0, T2=5.0, tau=3.0)
    th = m.theta({"tau_y": [3.0, 2.5]})  # the larger delay has no fractional share
    r, H = discrete_realization(m, th, 1.0)
    assert H == 3
    u = np.ones((60, 1))
    for b, tau in enumerate((3.0, 2.5)):
        one = SOPDTModel(["u"], ["y"], K=1.0, T1=20.0, T2=5.0, tau=tau)
        y = one.simulate(u, 1.0).outputs[0, :, 0]
        x = np.zeros(r.A.shape[1])
        ys = []
        for k in range(60):
            ys.append(float((r.C[b] @ x)[0]))
            x = r.A[b] @ x + r.B[b] @ u[k]
        np.testing.assert_allclose(ys, y, atol=1e-12)
