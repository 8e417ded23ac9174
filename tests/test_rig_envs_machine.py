"""Strut and spindle environments on the rigs' true plants (``plant="rig"``)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import thermogym.envs  # noqa: F401
from thermogym.errors import ConfigError
from thermogym.rigs import get_rig
from thermogym.rigs.strut import TEMPERATURES


def test_strut_env_steps_the_rigs_plant_and_measures_through_its_sensors():
    kw = {"sensor_noise": False, "air_swing_K": 0.0, "air_C": 21.0, "episode_s": 3600.0}
    env = gym.make("thermogym/StrutThermal-v0", plant="rig", **kw).unwrapped
    obs, _ = env.reset(seed=0)
    assert env.plant_kind == "rig"
    for _ in range(60):  # an hour at 30 m/min
        obs, *_ = env.step(np.array([1.0, 0.0], np.float32))
    rig = get_rig("strut")
    u = np.tile([30.0, 21.0], (61, 1))
    run = rig.plant().simulate(u, 60.0, rig.specimen)
    truth = env.true_outputs()
    for i, name in enumerate(TEMPERATURES):
        assert truth[name] == pytest.approx(run.outputs[0, -1, i], abs=1e-9)
        assert obs[i] == pytest.approx(truth[name], abs=1e-4)  # exact readings (float32)
    # the axis is referenced at the start: ΔL counts from the first state
    assert truth["dL_um"] == pytest.approx(run.outputs[0, -1, 7] - run.outputs[0, 0, 7], abs=1e-9)
    # another specimen of the rig is another strut
    other = gym.make("thermogym/StrutThermal-v0", plant="rig", specimen_seed=5, **kw).unwrapped
    other.reset(seed=0)
    for _ in range(60):
        other.step(np.array([1.0, 0.0], np.float32))
    assert other.true_outputs()["T_drive"] != pytest.approx(truth["T_drive"], abs=0.05)
    with pytest.raises(ConfigError, match="randomize is not available"):
        gym.make("thermogym/StrutThermal-v0", plant="rig", randomize="bounds")
    with pytest.raises(ConfigError, match="not available step-wise"):
        gym.make("thermogym/StrutThermal-v0", plant="rig", rig_effects=["transport_delay"])


def test_spindle_env_on_the_rig_with_a_concealed_effect():
    kw = {"sensor_noise": False, "ambient_swing_K": 0.0, "ambient_C": 24.0, "episode_s": 7200.0}
    full = np.ones(1, np.float32)
    temps = []
    for effects in ((), ("input_nonlinearity",)):
        env = gym.make("thermogym/SpindleThermal-v0", plant="rig", rig_effects=effects, **kw)
        env.reset(seed=0)
        for _ in range(120):
            env.step(full)
        temps.append(env.unwrapped.true_outputs()["T_front_bearing_C"])
    # the balls' centrifugal load at 8000 rpm adds friction heat: a hotter bearing
    assert temps[1] > temps[0] + 0.5
