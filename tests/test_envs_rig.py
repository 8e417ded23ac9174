"""Environments on the rigs' true plants (``plant="rig"``): API, batching, physics, sensors."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import thermogym.envs  # noqa: F401 - registers the environments
from thermogym.errors import ConfigError

VALVE = "thermogym/AXT211Valve-v0"
ROOM = "thermogym/AXT211Room-v0"
SHORT = {
    VALVE: {"plant": "rig", "episode_s": 600.0, "control_period": 60.0},
    ROOM: {"plant": "rig", "episode_days": 0.125, "control_period": 600.0, "start_day": 10},
}


@pytest.mark.parametrize("env_id", [VALVE, ROOM])
def test_rig_envs_pass_the_checkers(env_id):
    env = gym.make(env_id, **SHORT[env_id])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env.unwrapped)
    assert [str(w.message) for w in caught] == []


@pytest.mark.parametrize("env_id", [VALVE, ROOM])
def test_rig_vector_env_equals_single_envs(env_id):
    n, seed = 3, 4
    kw = SHORT[env_id]
    venv = gym.make_vec(env_id, n, vectorization_mode="vector_entry_point", **kw)
    singles = [gym.make(env_id, **kw) for _ in range(n)]
    vobs, _ = venv.reset(seed=seed)
    sobs = [e.reset(seed=seed + i)[0] for i, e in enumerate(singles)]
    np.testing.assert_array_equal(vobs, np.stack(sobs))
    rng = np.random.default_rng(0)
    done = [False] * n
    for _ in range(singles[0].unwrapped.horizon + 2):  # crosses an autoreset
        acts = rng.uniform(-1, 1, (n, 1)).astype(np.float32)
        vo, vr, vte, vtr, vinfo = venv.step(acts)
        for i, e in enumerate(singles):
            if done[i]:
                o, _ = e.reset()
                r, te, tr = 0.0, False, False
            else:
                o, r, te, tr, info = e.step(acts[i])
                if te or tr:
                    for k, v in info["kpis"].items():
                        assert vinfo["kpis"][k][i] == pytest.approx(v, rel=1e-12, abs=1e-12)
            np.testing.assert_array_equal(vo[i], o)
            assert vr[i] == pytest.approx(r, rel=1e-12, abs=1e-12)
            assert (bool(vte[i]), bool(vtr[i])) == (te, tr)
            done[i] = te or tr


def test_valve_energy_and_stroke_kpis_come_from_the_rigs_state():
    from thermogym.rigs.axt211 import AXT211Plant, specimen_spread

    env = gym.make(VALVE, plant="rig", action_mode="onoff", episode_s=1200.0, setpoint=2.0,
                   control_period=30.0, sensor_noise=False)  # fmt: skip
    env.reset(seed=0)
    for _ in range(40):
        _, _, te, tr, info = env.step(1)
    assert tr and not te
    # 20 min with the heater on: the electrical energy of the rig's own simulation
    plant = AXT211Plant()
    spec = specimen_spread(np.random.default_rng(0), n=1)
    u = np.tile([1.0, 24.0, 25.0], (1201, 1))
    run = plant.simulate(u, 1.0, spec)
    assert info["kpis"]["actuator_energy_Wh"] == pytest.approx(
        run.hidden["E_el"][0, -1] / 3600.0, rel=1e-9
    )
    assert info["kpis"]["stroke_travel_mm"] == pytest.approx(run.output("x_V")[0, -1], rel=1e-9)


def test_rig_sensors_are_coloured_and_lagged_not_the_envs_white_noise():
    env = gym.make(ROOM, plant="rig", episode_days=1.0, control_period=60.0, start_day=10)
    env.reset(seed=1)
    e = env.unwrapped._e
    thermostat = e.rsens.sensors[0]
    assert thermostat.lag == pytest.approx(240.0) and thermostat.colored > 0
    errs = []
    for _ in range(300):
        obs, *_ = env.step(env.action_space.sample())
        errs.append(obs[0] - env.unwrapped.true_outputs()["T_zone"])
    errs = np.asarray(errs)
    assert np.isfinite(errs).all()
    assert abs(np.corrcoef(errs[1:], errs[:-1])[0, 1]) > 0.3  # not white


def test_model_only_operations_are_refused_on_the_rig():
    env = gym.make(VALVE, plant="rig")
    with pytest.raises(ConfigError, match="not available with plant='rig'"):
        env.unwrapped.set_randomization("relative", scale=0.1)
    with pytest.raises(ConfigError, match="not available with plant='rig'"):
        gym.make(VALVE, plant="rig", randomize="relative")
    from thermogym.fitresult import FitResult
    from thermogym.models import AXT211

    env.reset(seed=0)
    with pytest.raises(ConfigError, match="not available with plant='rig'"):
        env.unwrapped.set_parameters(FitResult.from_model(AXT211()))
    room = gym.make(ROOM, plant="rig", start_day=10)
    room.reset(seed=0)
    with pytest.raises(ConfigError, match="run_compiled"):
        room.unwrapped.run_compiled(lambda o, s: 0.0)


def test_room_rig_heats_with_the_rigs_radiator():
    env = gym.make(ROOM, plant="rig", action_mode="onoff", episode_days=0.5, start_day=14,
                   control_period=300.0, sensor_noise=False)  # fmt: skip
    env.reset(seed=2)
    while True:
        _, _, te, tr, info = env.step(1)
        if te or tr:
            break
    k = info["kpis"]
    # heater on for 12 h: the valve stays open and the radiator emits about its design
    # output into a January room (≈ 1 kW → ≈ 12 kWh); the actuator draws a few watts
    assert 6.0 < k["heat_delivered_kWh"] < 16.0
    assert 30.0 < k["actuator_energy_Wh"] < 120.0
    # the stem at the end stop of the env's actuator specimen (specimen_seed 0 of the AXT211
    # rig's manufacturing spread: the stroke carries 1 %)
    from thermogym.rigs.axt211 import specimen_spread

    x_max = float(np.asarray(specimen_spread(np.random.default_rng(0), n=1)["x_max"]).ravel()[0])
    assert abs(x_max - 4.5) < 0.2
    assert env.unwrapped.true_outputs()["x_V"] == pytest.approx(x_max, abs=1e-6)


class _SubSteps:
    """Stands in for a rig plant's ``step``: the real step, and the same again sub-step by
    sub-step (the rig's own step size), keeping one state column after every sub-step."""

    def __init__(self, plant, col: int) -> None:
        self.step, self.max_step, self.col = plant.step, plant.max_step, col
        self.series: list[float] = []

    def __call__(self, x, u, dt, spec, *t, turns=None):
        out = self.step(x, u, dt, spec, *t, turns=turns)
        d = float(np.asarray(dt).reshape(-1)[0])  # one plant
        if d > 0.0:
            n = max(1, int(np.ceil(d / self.max_step - 1e-9)))
            h = d / n
            t0 = float(np.asarray(t[0]).reshape(-1)[0]) if t else 0.0
            xs = x
            for j in range(n):
                xs = self.step(xs, u, h, spec, *((t0 + j * h,) if t else ()))
                self.series.append(float(xs[0, self.col]))
            np.testing.assert_array_equal(xs, out)  # the same sub-steps
        return out


@pytest.mark.parametrize(
    ("env_id", "kw"),
    [
        (VALVE, {"setpoint": 2.0}),
        (ROOM, {"start_day": 10, "start_hour": 8.0}),
    ],
)
def test_rig_envs_count_the_wax_cycles_of_every_rig_sub_step(env_id, kw):
    # issue 14: with a 120 s PWM at duty 0.5 the tracker gets the turns the rig notes over
    # its sub-steps and the period's end value: the env's wax KPIs are those of rainflow on
    # the cartridge temperature after every sub-step of the rig's own integration
    from thermogym.envs import kpis

    n = 20
    T = 120.0
    span = {"episode_s": n * T} if env_id == VALVE else {"episode_days": n * T / 86400.0}
    env = gym.make(env_id, plant="rig", control_period=T, sensor_noise=False, **span, **kw)
    env.reset(seed=3)
    e = env.unwrapped._e
    sub = _SubSteps(e.tp, e._iw)
    sub.series.append(float(e.xr[0, e._iw]))
    e.tp.step = sub
    end = [sub.series[0]]
    while True:
        _o, _r, te, tr, info = env.step(np.array([0.0], np.float32))  # duty 0.5
        end.append(float(e.xr[0, e._iw]))
        if te or tr:
            break
    k = info["kpis"]
    dense = np.array(sub.series)
    assert dense.size == 1 + n * int(T / e.tp.max_step)
    truth = kpis.wax_cycle_kpis(kpis.rainflow_cycles(dense, 2.0))
    for name, v in truth.items():
        assert k[name] == pytest.approx(v, rel=1e-12, abs=1e-18), name
    assert k["wax_thermal_cycles"] >= n - 2
    assert kpis.wax_thermal_cycles(np.array(end), 2.0) <= 1.0  # the end samples alone
