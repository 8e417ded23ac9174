"""The virtual-sensor observation wrapper, on a toy environment and on SpindleThermal-v0."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium import spaces
from gymnasium.utils.env_checker import check_env

from thermogym.envs.virtual_sensor import VirtualSensorObservation
from thermogym.errors import ConfigError, UnknownNameError
from thermogym.estimation import VirtualSensor
from thermogym.models.linear import StateSpaceModel

DT = 10.0
# a heated core behind a skin: only the skin and the heater power are observed
AC = np.array([[-1 / 600, 1 / 600], [1 / 900, -2 / 900]])
BC = np.array([[1 / 600, 0.0], [0.0, 1 / 900]])  # heater [K/s per W·s/J], ambient


def _model() -> StateSpaceModel:
    return StateSpaceModel.from_continuous(
        AC, BC, np.eye(2), dt=DT, inputs=["P"], disturbances=["T_amb"],
        outputs=["T_core", "T_skin"], units={"T_core": "°C", "T_skin": "°C", "T_amb": "°C"},
    )  # fmt: skip


class CoreEnv(gym.Env):
    """Toy plant: observation [T_skin (noisy), P_prev, T_core (true, 'hidden' slot)]."""

    metadata = {"render_modes": []}  # noqa: RUF012

    def __init__(self) -> None:
        self.model = _model()
        self.theta = self.model.theta()
        self.dt = DT
        self.obs_names = ("T_skin", "P_prev", "T_core")
        self.observation_space = spaces.Box(-50.0, 300.0, (3,), np.float32)
        self.action_space = spaces.Box(-1.0, 1.0, (1,), np.float32)

    def _obs(self, P: float) -> np.ndarray:
        skin = self.x[1] + 0.02 * self.np_random.standard_normal()
        return np.array([skin, P, self.x[0]], dtype=np.float32)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.x = np.full(2, 20.0)
        self.k = 0
        return self._obs(0.0), {}

    def step(self, action):
        P = 50.0 * (float(np.clip(action[0], -1, 1)) + 1.0)
        u = np.array([[P, 20.0]])
        self.x = self.model.step(self.x[None], u, self.theta, DT)[0]
        self.k += 1
        return self._obs(P), -abs(self.x[0] - 60.0), False, self.k >= 200, {}

    def true_outputs(self):
        return {"T_core": float(self.x[0]), "T_skin": float(self.x[1])}


def _observer():
    vs = VirtualSensor(_model(), measured=["T_skin"], measurement_std=0.02)
    return vs.step_observer()


def _wrap(env, **kw):
    return VirtualSensorObservation(
        env,
        _observer(),
        inputs={"P": "P_prev", "T_amb": lambda obs, info, action: 20.0},
        **kw,
    )


def test_wrapper_passes_the_gymnasium_checker_and_is_deterministic():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        check_env(_wrap(CoreEnv()), skip_render_check=True)
    a, b = _wrap(CoreEnv()), _wrap(CoreEnv())
    oa, _ = a.reset(seed=3)
    ob, _ = b.reset(seed=3)
    for _ in range(20):
        act = np.array([0.5], np.float32)
        oa = a.step(act)[0]
        ob = b.step(act)[0]
    assert np.array_equal(oa, ob)


def test_estimate_replaces_the_hidden_slot_and_converges_to_the_truth():
    env = _wrap(CoreEnv())
    assert env.observation_names == ("T_skin", "P_prev", "T_core")  # replaced, not appended
    obs, info = env.reset(seed=0)
    errs = []
    for _ in range(150):
        obs, _, _, _, info = env.step(np.array([1.0], np.float32))
        vs = info["virtual_sensor"]
        errs.append(vs["error"]["T_core"])
        assert obs[2] == pytest.approx(vs["estimate"]["T_core"], abs=1e-4)
    assert abs(np.mean(errs[-50:])) < 0.1
    assert abs(vs["truth"]["T_core"] - env.unwrapped.x[0]) < 1e-9


def test_truth_mode_gives_the_controller_the_true_state_in_the_same_slot():
    est, tru = _wrap(CoreEnv()), _wrap(CoreEnv(), mode="truth")
    est.reset(seed=1)
    tru.reset(seed=1)
    for _ in range(30):
        oe = est.step(np.array([0.2], np.float32))[0]
        ot = tru.step(np.array([0.2], np.float32))[0]
    assert est.observation_space == tru.observation_space
    assert ot[2] == pytest.approx(tru.unwrapped.x[0], abs=1e-4)
    assert oe[2] != ot[2]


def test_unobserved_estimates_are_appended():
    class NoCore(CoreEnv):
        def __init__(self):
            super().__init__()
            self.obs_names = ("T_skin", "P_prev")
            self.observation_space = spaces.Box(-50.0, 300.0, (2,), np.float32)

        def _obs(self, P):
            return super()._obs(P)[:2]

    env = _wrap(NoCore())
    assert env.observation_names == ("T_skin", "P_prev", "T_core")
    obs, info = env.reset(seed=0)
    assert obs.shape == (3,) and env.observation_space.contains(obs)
    assert "T_core" in info["virtual_sensor"]["truth"]  # from true_outputs()


def test_wrapper_refuses_bad_configurations():
    with pytest.raises(UnknownNameError, match="not an observation name"):
        VirtualSensorObservation(CoreEnv(), _observer(), inputs={"P": "power"})
    with pytest.raises(UnknownNameError, match="does not use"):
        _wrap(CoreEnv(), measured={"T_x": 0})
    with pytest.raises(ConfigError, match="mode"):
        _wrap(CoreEnv(), mode="oracle")
    slow = VirtualSensor(_model(), measured=["T_skin"]).at_period(2 * DT).step_observer()
    with pytest.raises(ConfigError, match="control period"):
        VirtualSensorObservation(CoreEnv(), slow, inputs={"P": "P_prev", "T_amb": 2})


def test_spindle_env_with_the_virtual_sensor():
    thermogym_envs = pytest.importorskip("thermogym.envs")
    from thermogym.firmware.reference import spindle_reference_model

    assert "thermogym/SpindleThermal-v0" in thermogym_envs.ENV_IDS
    env = gym.make("thermogym/SpindleThermal-v0")
    model = spindle_reference_model("1I7O", order=8, dt=1.0)
    vs = VirtualSensor(
        model, measured=["T_front_outer_housing", "T_rear_outer_housing"], measurement_std=0.02
    ).at_period(env.unwrapped.dt)
    wrapped = VirtualSensorObservation(
        env, vs.step_observer(), inputs={"speed": "speed_prev"}, rest={"speed": 0.0}
    )
    obs, info = wrapped.reset(seed=0)
    assert wrapped.observation_space.contains(obs)
    errs = []
    for k in range(240):  # 4 h: full speed, then half
        a = np.array([1.0 if k < 120 else 0.0], np.float32)
        obs, _, terminated, truncated, info = wrapped.step(a)
        errs.append(max(abs(v) for v in info["virtual_sensor"]["error"].values()))
        if terminated or truncated:
            break
    assert max(errs) < 0.1  # K, bearing and housing temperatures
