"""API, determinism and correctness sweep over every registered thermogym environment.

Truth comes from outside the environment code: Gymnasium's and
stable-baselines3's environment checkers, the plant models' own
``simulate`` (the environment must run the same dynamics), the KPI functions
applied to the recorded trajectory, and N independent single environments
for the native vector environments.
"""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env

import thermogym.envs
from thermogym.envs import kpis
from thermogym.errors import ConfigError, ParameterError, ShapeError, SimulationError

IDS = thermogym.envs.ENV_IDS
#: Short episodes of every environment (a few dozen steps) for the sweeps.
SHORT = {
    "thermogym/AXT211Valve-v0": {"episode_s": 300.0},
    "thermogym/AXT211Room-v0": {"episode_days": 1 / 96, "start_day": 3, "start_hour": 6.5},
    "thermogym/SpindleThermal-v0": {"episode_s": 1800.0},
    "thermogym/StrutThermal-v0": {"episode_s": 1800.0},
    "thermogym/TCLab-v0": {"episode_s": 30.0},
    "thermogym/IdentifiedPlant-v0": {"episode_steps": 40},
}


def make(env_id: str, **kw):
    return gym.make(env_id, **{**SHORT[env_id], **kw})


def rollout(env, seed: int, n: int, action_seed: int = 0):
    obs, info = env.reset(seed=seed)
    env.action_space.seed(action_seed)
    out = [(obs, 0.0, False, False)]
    for _ in range(n):
        obs, r, te, tr, info = env.step(env.action_space.sample())
        out.append((obs, r, te, tr))
        if te or tr:
            break
    return out, info


# -------------------------------------------------------------------- API
@pytest.mark.parametrize("env_id", IDS)
def test_gymnasium_check_env(env_id):
    env = gym.make(env_id)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        gym_check_env(env.unwrapped)
    assert [str(w.message) for w in caught] == []


@pytest.mark.parametrize("env_id", IDS)
def test_sb3_check_env(env_id):
    sb3 = pytest.importorskip("stable_baselines3.common.env_checker")
    for kw in ({}, {"action_mode": "onoff"}) if "AXT211" in env_id else ({},):
        env = gym.make(env_id, **kw)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            sb3.check_env(env.unwrapped, warn=True)
        assert [str(w.message) for w in caught] == []


@pytest.mark.parametrize("env_id", IDS)
def test_two_envs_with_one_seed_give_identical_rollouts(env_id):
    a, info_a = rollout(make(env_id), seed=42, n=40)
    b, info_b = rollout(make(env_id), seed=42, n=40)
    c, _ = rollout(make(env_id), seed=43, n=40)
    assert len(a) == len(b)
    for (oa, ra, ta, ua), (ob, rb, tb, ub) in zip(a, b, strict=True):
        np.testing.assert_array_equal(oa, ob)
        assert (ra, ta, ua) == (rb, tb, ub)
    assert info_a == info_b
    assert any(not np.array_equal(x[0], y[0]) for x, y in zip(a, c, strict=False))


@pytest.mark.parametrize("env_id", IDS)
def test_observations_stay_in_the_space_and_layout_is_named(env_id):
    env = make(env_id)
    u = env.unwrapped
    assert len(u.obs_names) == env.observation_space.shape[0] == len(u.obs_units)
    steps, _ = rollout(env, seed=0, n=200)
    for obs, *_ in steps:
        assert env.observation_space.contains(obs)


@pytest.mark.parametrize("env_id", IDS)
def test_truncation_at_the_horizon_returns_kpis(env_id):
    env = make(env_id)
    steps, info = rollout(env, seed=1, n=10_000)
    horizon = env.unwrapped.horizon
    assert len(steps) == horizon + 1
    assert [s[3] for s in steps[1:]] == [False] * (horizon - 1) + [True]
    assert not any(s[2] for s in steps)
    assert set(info["kpis"]) >= {"episode_h"}
    assert info["kpis"]["episode_h"] == pytest.approx(horizon * env.unwrapped.dt / 3600)
    with pytest.raises(SimulationError, match="reset"):
        env.step(env.action_space.sample())


@pytest.mark.parametrize(
    ("env_id", "kw", "action"),
    [
        ("thermogym/AXT211Valve-v0", {"trip_C": 40.0, "action_mode": "onoff"}, 1),
        ("thermogym/AXT211Room-v0", {"trip_C": 40.0, "action_mode": "onoff"}, 1),
        ("thermogym/SpindleThermal-v0", {"trip_C": 26.0, "ambient_C": 22.0}, np.ones(1)),
        ("thermogym/StrutThermal-v0", {"trip_C": 24.0, "air_C": 21.0}, np.ones(2)),
        ("thermogym/TCLab-v0", {"trip_C": 40.0, "ambient_C": 21.0}, np.ones(2)),
    ],
)
def test_termination_only_on_a_safety_trip(env_id, kw, action):
    env = gym.make(env_id, **kw)
    env.reset(seed=0)
    for _ in range(env.unwrapped.horizon):
        a = action if np.ndim(action) == 0 else action.astype(np.float32)
        _obs, _r, terminated, truncated, info = env.step(a)
        if terminated or truncated:
            break
    assert terminated and not truncated
    assert "trip_C" in info["trip"] and "kpis" in info


# --------------------------------------------------------- configuration
@pytest.mark.parametrize("env_id", IDS)
def test_unknown_keyword_arguments_are_rejected(env_id):
    with pytest.raises(TypeError, match="bogus_option"):
        gym.make(env_id, bogus_option=1)
    with pytest.raises(TypeError, match="bogus_option"):
        gym.make_vec(env_id, 2, vectorization_mode="vector_entry_point", bogus_option=1)


@pytest.mark.parametrize("env_id", IDS)
def test_bad_values_are_named(env_id):
    with pytest.raises(ConfigError, match="control_period"):
        gym.make(env_id, control_period=-1.0)
    with pytest.raises(ConfigError, match="nonsense"):
        gym.make(env_id, reward_weights={"nonsense": 1.0})
    with pytest.raises(ConfigError, match="plant"):
        gym.make(env_id, plant="simulator")
    with pytest.raises(ConfigError, match="sensor_noise"):
        gym.make(env_id, sensor_noise={"no_such_channel": 0.1})


def test_wrong_model_and_plant_combinations_are_refused():
    from thermogym.fitresult import FitResult
    from thermogym.models import AXT211

    fit = FitResult.from_model(AXT211(), method="t")
    with pytest.raises(ConfigError, match="axt211"):
        gym.make("thermogym/SpindleThermal-v0", params=fit)
    with pytest.raises(ConfigError, match="params"):
        gym.make("thermogym/AXT211Valve-v0", plant="rig", params=fit)
    with pytest.raises(ConfigError, match="no virtual rig"):
        gym.make("thermogym/TCLab-v0", plant="rig")
    with pytest.raises(ConfigError, match="rig_effects"):
        gym.make("thermogym/AXT211Valve-v0", rig_effects=["phase_change"])
    with pytest.raises(ConfigError, match="transport_delay"):
        gym.make("thermogym/AXT211Valve-v0", plant="rig", rig_effects=["transport_delay"])
    with pytest.raises(ConfigError, match="episode_s"):
        gym.make("thermogym/AXT211Valve-v0", episode_s=95.0)


def test_invalid_actions_are_reported():
    env = gym.make("thermogym/AXT211Valve-v0", action_mode="onoff")
    env.reset(seed=0)
    with pytest.raises(ShapeError, match="invalid"):
        env.unwrapped.step(3)
    env = gym.make("thermogym/TCLab-v0")
    env.reset(seed=0)
    with pytest.raises(ShapeError, match="invalid"):
        env.unwrapped.step(np.array([np.nan, 0.0]))
    with pytest.raises(ShapeError, match="action"):
        env.unwrapped.step(np.zeros(5))


# ------------------------------------------------------------ vector envs
@pytest.mark.parametrize("env_id", IDS)
def test_vector_env_equals_n_single_envs(env_id):
    n, seed = 3, 7
    kw = dict(SHORT[env_id])
    venv = gym.make_vec(env_id, n, vectorization_mode="vector_entry_point", **kw)
    singles = [gym.make(env_id, **kw) for _ in range(n)]
    vobs, _ = venv.reset(seed=seed)
    sobs = [e.reset(seed=seed + i)[0] for i, e in enumerate(singles)]
    np.testing.assert_array_equal(vobs, np.stack(sobs))
    horizon = singles[0].unwrapped.horizon
    rng = np.random.default_rng(0)
    done = [False] * n
    steps = 2 * horizon + 3  # crosses two autoresets
    for _ in range(steps):
        acts = np.stack([venv.single_action_space.sample() for _ in range(n)])
        if isinstance(venv.single_action_space, gym.spaces.Box):
            acts = rng.uniform(-1, 1, acts.shape).astype(np.float32)
        vo, vr, vte, vtr, vinfo = venv.step(acts)
        for i, e in enumerate(singles):
            if done[i]:  # NEXT_STEP autoreset: this step resets sub-environment i
                o, _ = e.reset()
                r, te, tr = 0.0, False, False
            else:
                o, r, te, tr, info = e.step(acts[i])
                if te or tr:
                    for k, v in info["kpis"].items():
                        assert vinfo["kpis"][k][i] == pytest.approx(v, rel=1e-12, abs=1e-12)
                    assert vinfo["_kpis"][i]
            np.testing.assert_array_equal(vo[i], o)
            assert vr[i] == pytest.approx(r, rel=1e-12, abs=1e-12)
            assert (bool(vte[i]), bool(vtr[i])) == (te, tr)
            done[i] = te or tr


@pytest.mark.parametrize(
    ("env_id", "module"),
    [
        ("thermogym/AXT211Valve-v0", "thermogym.envs.axt211_valve"),
        ("thermogym/AXT211Room-v0", "thermogym.envs.axt211_room"),
    ],
)
def test_lockstep_blocks_equal_the_scalar_kernel_of_single_envs(env_id, module):
    # a full block of plants stepped in lockstep plus a partial block by the scalar kernel,
    # against single environments (scalar kernel only): bit-identical
    import importlib

    n = importlib.import_module(module)._BW + 2
    kw = dict(SHORT[env_id])
    venv = gym.make_vec(env_id, n, vectorization_mode="vector_entry_point", **kw)
    singles = [gym.make(env_id, **kw) for _ in range(n)]
    venv.reset(seed=11)
    for i, e in enumerate(singles):
        e.reset(seed=11 + i)
    rng = np.random.default_rng(1)
    for _ in range(6):
        acts = rng.uniform(-1, 1, (n, 1)).astype(np.float32)  # duty: on and off parts
        vo, vr, _, _, _ = venv.step(acts)
        for i, e in enumerate(singles):
            o, r, _, _, _ = e.step(acts[i])
            np.testing.assert_array_equal(vo[i], o)
            assert vr[i] == r


LONG = {
    "thermogym/AXT211Valve-v0": {"control_period": 120.0, "episode_s": 1200.0, "setpoint": 2.0},
    "thermogym/AXT211Room-v0": {
        "control_period": 120.0, "episode_days": 1200.0 / 86400.0, "start_day": 3,
        "start_hour": 6.5,
    },
}  # fmt: skip


@pytest.mark.parametrize("h", [2.0, 0.0])
@pytest.mark.parametrize(
    ("env_id", "module"),
    [
        ("thermogym/AXT211Valve-v0", "thermogym.envs.axt211_valve"),
        ("thermogym/AXT211Room-v0", "thermogym.envs.axt211_room"),
    ],
)
def test_lockstep_blocks_keep_the_turning_points_of_single_envs(env_id, module, h):
    # the wax tracker takes every sub-step (issue 14): full lockstep blocks (the lanes'
    # tracker), a partial block and single envs (the scalar kernel) agree bit for bit on the
    # turning points and every KPI over 120 s PWM periods. The odd plants get a wax of
    # enormous heat capacity, whose temperature repeats exactly from sub-step to sub-step:
    # with hysteresis 0 each sub-step confirms a turning point, more than a lane keeps, and
    # the period is stepped again by the scalar kernel (and the buffers grow)
    import importlib

    n = importlib.import_module(module)._BW + 2
    kw = {**LONG[env_id], "cycle_hysteresis_K": h}
    venv = gym.make_vec(env_id, n, vectorization_mode="vector_entry_point", **kw)
    singles = [gym.make(env_id, **kw) for _ in range(n)]
    venv.reset(seed=11)
    for i, e in enumerate(singles):
        e.reset(seed=11 + i)
    ve = venv.unwrapped._e
    th = ve.theta[0].copy()
    th[ve.model.param_index("C_P")] = 1e30
    odd = list(range(1, n, 2))
    ve.set_theta(odd, np.tile(th, (len(odd), 1)))
    for i in odd:
        singles[i].unwrapped._e.set_theta([0], th[None])
    rng = np.random.default_rng(2)
    steps = 8
    for _ in range(steps):
        acts = rng.uniform(-1, 1, (n, 1)).astype(np.float32)
        vo, vr, _, _, _ = venv.step(acts)
        for i, e in enumerate(singles):
            o, r, _, _, _ = e.step(acts[i])
            np.testing.assert_array_equal(vo[i], o)
            assert vr[i] == r
    for i, e in enumerate(singles):
        se = e.unwrapped._e
        m = int(ve.ctr[i, 2])
        assert m == se.ctr[0, 2]
        np.testing.assert_array_equal(ve.tpbuf[i, :m], se.tpbuf[0, :m])
        np.testing.assert_array_equal(ve.acc[i], se.acc[0])
        assert ve.kpis(i) == se.kpis(0)
    points = ve.ctr[:, 2]
    if h == 0.0:  # every sub-step of the frozen waxes confirmed one: 120 per period
        assert (points[odd] >= steps * 120).all()
    assert (points[0::2] <= 1 + 2 * steps).all()  # hysteresis or not, at most two a period
    assert points[0::2].max() > steps  # and in-period turns were counted


def test_vector_env_parallel_kernel_gives_the_same_results():
    kw = dict(SHORT["thermogym/AXT211Room-v0"])
    runs = []
    for parallel in (False, True):
        venv = gym.make_vec(
            "thermogym/AXT211Room-v0", 8, vectorization_mode="vector_entry_point",
            parallel=parallel, **kw,
        )  # fmt: skip
        venv.reset(seed=3)
        acts = np.linspace(-1, 1, 8, dtype=np.float32)[:, None]
        runs.append([venv.step(acts)[0] for _ in range(20)])
    np.testing.assert_array_equal(np.array(runs[0]), np.array(runs[1]))


# ----------------------------------------------------- dynamics and KPIs
def _history(env_id: str, policy, seed=0, **kw):
    kw.setdefault("sensor_noise", False)
    env = gym.make(env_id, record=True, **kw)
    obs, _ = env.reset(seed=seed)
    actions = []
    while True:
        a = policy(obs)
        actions.append(a)
        obs, _r, te, tr, info = env.step(a)
        if te or tr:
            return env.unwrapped, env.unwrapped.history(), np.array(actions), info["kpis"]


def test_valve_runs_the_axt211_model_and_its_kpis_match_the_kpi_functions():
    from thermogym.models import AXT211

    _env, h, acts, k = _history(
        "thermogym/AXT211Valve-v0",
        lambda o: int(o[0] < o[4]),
        action_mode="onoff",
        episode_s=3600.0,
        setpoint=2.5,
        ambient_C=20.0,
    )
    m = AXT211()
    T = acts.size
    u = np.column_stack([acts.astype(float), np.full(T, 24.0), np.full(T, 20.0)])
    sim = m.simulate(np.r_[u, u[-1:]], 10.0)
    np.testing.assert_allclose(h["x_V"], sim.output("x_V")[0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(h["T_P"], sim.output("T_P")[0], rtol=0, atol=1e-12)
    # KPIs from the recorded trajectory (samples at the ends of the periods)
    x, ref, TP = h["x_V"][1:], h["x_ref"][1:], h["T_P"]
    assert k["switch_cycles"] == kpis.switch_cycles(acts)
    assert k["stroke_travel_mm"] == pytest.approx(kpis.stroke_travel_mm(h["x_V"]))
    assert k["stroke_reversals"] == kpis.stroke_reversals(h["x_V"], 0.05)
    assert k["wax_thermal_cycles"] == pytest.approx(kpis.wax_thermal_cycles(TP, 2.0))
    assert k["wax_damage"] == pytest.approx(kpis.wax_damage(TP, 2.0))
    assert k["stroke_rmse_mm"] == pytest.approx(kpis.stroke_rmse_mm(x, ref))
    assert k["stroke_iae_mm_s"] == pytest.approx(kpis.stroke_iae_mm_s(x, ref, 10.0))
    assert k["time_above_limit_h"] == kpis.time_above_limit_h(TP[1:], 85.0, 10.0)
    assert k["actuator_energy_Wh"] == pytest.approx(kpis.actuator_energy_Wh(h["P_PTC"][1:], 10.0))
    # the energy is ∫P dt: against a fine (0.1 s) simulation of the model
    fine = m.simulate(np.repeat(u, 100, axis=0), 0.1)
    E = kpis.energy_Wh(fine.output("P_PTC")[0], 0.1, method="rectangle")
    assert k["actuator_energy_Wh"] == pytest.approx(E, rel=5e-3)
    assert k["switch_cycles"] > 3 and k["wax_thermal_cycles"] > 1


def test_valve_duty_is_pwm_within_the_period():
    from thermogym.models import AXT211

    _env, h, _acts, k = _history(
        "thermogym/AXT211Valve-v0", lambda o: np.array([0.0], np.float32), episode_s=600.0
    )
    # duty 0.5 of a 10 s period: heater on 5 s, off 5 s -> the model at 1 s with a square wave
    u1 = np.column_stack(
        [np.tile([1.0] * 5 + [0.0] * 5, 60), np.full(600, 24.0), np.full(600, 25.0)]
    )
    sim = AXT211().simulate(np.r_[u1, u1[-1:]], 1.0)
    np.testing.assert_allclose(h["x_V"], sim.output("x_V")[0, ::10], atol=1e-10)
    assert k["switch_cycles"] == 60


def _wax_kpis(T_P: np.ndarray, h: float = 2.0) -> dict[str, float]:
    # the wax KPIs of a trajectory: rainflow on its turning points (the test's truth)
    return kpis.wax_cycle_kpis(kpis.rainflow_cycles(T_P, h))


def _assert_wax_kpis(k: dict[str, float], truth: dict[str, float]) -> None:
    for name, v in truth.items():
        if "cycles" in name:
            assert k[name] == v, name
        else:
            assert k[name] == pytest.approx(v, rel=1e-9, abs=1e-15), name


def test_valve_counts_the_wax_cycles_within_long_pwm_periods():
    # issue 14: a 120 s PWM at duty 0.5 heats and cools the wax in every period; the
    # tracker takes every RK4 sub-step, so the env counts the cycles rainflow finds on
    # the densely sampled (1 s, the sub-steps) trajectory of the same model: about one a
    # period. Sampled once a period (the tracker before), T_P is the same every period
    # and no cycle is counted.
    from thermogym.models import AXT211

    n = 30
    _env, h, _acts, k = _history(
        "thermogym/AXT211Valve-v0", lambda o: np.array([0.0], np.float32),
        control_period=120.0, episode_s=120.0 * n, setpoint=2.0,
    )  # fmt: skip
    u = np.column_stack(
        [np.tile([1.0] * 60 + [0.0] * 60, n), np.full(120 * n, 24.0), np.full(120 * n, 25.0)]
    )
    dense = AXT211().simulate(np.r_[u, u[-1:]], 1.0).output("T_P")[0]
    np.testing.assert_allclose(h["T_P"], dense[::120], rtol=0, atol=1e-9)
    truth = _wax_kpis(dense)
    _assert_wax_kpis(k, truth)
    assert n - 2 <= k["wax_thermal_cycles"] <= n
    assert kpis.wax_thermal_cycles(h["T_P"], 2.0) <= 1.0  # what the end samples give


def test_room_counts_the_wax_cycles_within_long_pwm_periods():
    from thermogym.models.room import RoomModel

    n = 30
    env = gym.make(
        "thermogym/AXT211Room-v0", record=True, sensor_noise=False, control_period=120.0,
        episode_days=n * 120.0 / 86400.0, start_day=2, start_hour=8.0,
    )  # fmt: skip
    env.reset(seed=0)
    x0 = env.unwrapped._e.x[0].copy()
    while True:
        _o, _r, te, tr, info = env.step(np.array([0.0], np.float32))  # duty 0.5
        if te or tr:
            break
    h, k = env.unwrapped.history(), info["kpis"]
    u = np.column_stack([np.ones(n + 1), np.full(n + 1, 24.0), h["T_out"], h["Q_int"]])
    ud = np.repeat(u[:-1], 120, axis=0)
    ud[:, 0] = np.tile([1.0] * 60 + [0.0] * 60, n)
    dense = RoomModel().simulate(np.r_[ud, u[-1:]], 1.0, x0=x0).output("T_P")[0]
    np.testing.assert_allclose(h["T_P"], dense[::120], rtol=0, atol=1e-9)
    _assert_wax_kpis(k, _wax_kpis(dense))
    assert n - 2 <= k["wax_thermal_cycles"] <= n
    assert kpis.wax_thermal_cycles(h["T_P"], 2.0) <= 1.0


def test_room_runs_the_room_model_and_its_kpis_match():
    from thermogym.models.room import RoomModel

    env = gym.make(
        "thermogym/AXT211Room-v0", record=True, sensor_noise=False, action_mode="onoff",
        control_period=60.0, episode_days=0.5, start_day=2, start_hour=4.0,
    )  # fmt: skip
    obs, _ = env.reset(seed=5)
    x0 = env.unwrapped._e.x[0].copy()
    acts, on = [], 0
    while True:
        on = int(obs[0] < obs[1] - 0.25 or (obs[0] < obs[1] + 0.25 and on))
        acts.append(on)
        obs, _r, te, tr, info = env.step(on)
        if te or tr:
            break
    h, k = env.unwrapped.history(), info["kpis"]
    T = len(acts)
    u = np.column_stack([np.r_[acts, 0], np.full(T + 1, 24.0), h["T_out"], h["Q_int"]])
    sim = RoomModel().simulate(u, 60.0, x0=x0)
    np.testing.assert_allclose(h["T_zone"], sim.output("T_zone")[0], rtol=0, atol=1e-10)
    np.testing.assert_allclose(h["x_V"], sim.output("x_V")[0], rtol=0, atol=1e-10)
    lo, hi, occ = h["band_low"][1:], h["band_high"][1:], h["occupied"][1:]
    assert k["discomfort_Kh"] == pytest.approx(
        kpis.discomfort_Kh(h["T_zone"][1:], lo, hi, 60.0, occ)
    )
    assert k["heat_delivered_kWh"] == pytest.approx(kpis.heat_delivered_kWh(h["Q_heat"][1:], 60.0))
    fine = RoomModel().simulate(np.repeat(u[:-1], 60, axis=0), 1.0, x0=x0)
    E = kpis.heat_delivered_kWh(fine.output("Q_heat")[0], 1.0)
    assert k["heat_delivered_kWh"] == pytest.approx(E, rel=5e-3)
    assert k["switch_cycles"] == kpis.switch_cycles(acts)
    assert k["discomfort_Kh"] > 0 and k["heat_delivered_kWh"] > 0.5


def test_room_compiled_hook_equals_the_step_loop():
    import numba as nb

    @nb.njit
    def ctrl(obs, st):
        st[0] = 1.0 if obs[0] < obs[1] else 0.0
        return st[0]

    kw = {"action_mode": "onoff", "episode_days": 0.1, "start_day": 9, "start_hour": 5.0}
    a = gym.make("thermogym/AXT211Room-v0", **kw)
    obs, _ = a.reset(seed=11)
    while True:
        obs, _r, te, tr, info = a.step(int(obs[0] < obs[1]))
        if te or tr:
            break
    b = gym.make("thermogym/AXT211Room-v0", **kw)
    b.reset(seed=11)
    res = b.unwrapped.run_compiled(ctrl)
    assert res["truncated"] and res["steps"] == a.unwrapped.horizon
    assert res["kpis"] == info["kpis"]
    np.testing.assert_array_equal(b.unwrapped._e.obs[0], obs)


def test_spindle_matches_the_model_and_hides_the_bearings():
    from thermogym.models.spindle import SpindleModel

    speeds = np.linspace(-1, 1, 30)
    it = iter(speeds)
    env, h, _acts, k = _history(
        "thermogym/SpindleThermal-v0", lambda o: np.array([next(it)], np.float32),
        episode_s=1800.0, ambient_swing_K=0.0, ambient_C=24.0,
    )  # fmt: skip
    assert "T_front_bearing_C" not in env.obs_names
    n = 8000.0 * (speeds.astype(np.float32).astype(float) + 1) / 2
    u = np.column_stack([np.r_[n, 0.0], h["T_amb"]])
    sim = SpindleModel().simulate(u, 60.0)
    for name in ("T_front_bearing_C", "T_rear_outer_housing"):
        # the env starts from the solved steady state, the model from "every node at T_amb"
        np.testing.assert_allclose(h[name], sim.output(name)[0], rtol=0, atol=1e-6)
    Tb = np.column_stack([h[c] for c in env.model.output_names[:4]])[1:]
    assert k["bearing_over_limit_Kh"] == pytest.approx(kpis.bearing_over_limit_Kh(Tb, 45.0, 60.0))
    assert k["mean_speed_rpm"] == pytest.approx(n.mean())


def test_spindle_runs_an_identified_state_space_model():
    from thermogym.fitresult import FitResult
    from thermogym.models.linear import StateSpaceModel
    from thermogym.models.spindle import SPINDLE_OUTPUTS, SpindleModel

    net = SpindleModel()
    Ad, Bd, arrays = net.discrete(net.theta(), 60.0)
    ss = StateSpaceModel.from_matrices(
        Ad[0], Bd[0], arrays.H, dt=60.0, inputs=["speed"], disturbances=["T_amb"],
        outputs=list(SPINDLE_OUTPUTS),
    )  # fmt: skip
    fit = FitResult.from_model(ss, method="n4sid-like")
    kw = {"episode_s": 1800.0, "ambient_C": 23.0, "sensor_noise": False}
    a, _ = rollout(gym.make("thermogym/SpindleThermal-v0", **kw), 0, 30)
    b, _ = rollout(gym.make("thermogym/SpindleThermal-v0", params=fit.to_dict(), **kw), 0, 30)
    for x, y in zip(a, b, strict=True):
        np.testing.assert_allclose(x[0], y[0], rtol=1e-6, atol=1e-4)


def test_spindle_refuses_a_state_space_model_without_sample_period():
    # a model without dt cannot be stepped every control period: said, not a TypeError
    from thermogym.fitresult import FitResult
    from thermogym.models.linear import StateSpaceModel
    from thermogym.models.spindle import SPINDLE_OUTPUTS, SpindleModel

    net = SpindleModel()
    Ad, Bd, arrays = net.discrete(net.theta(), 60.0)
    ss = StateSpaceModel.from_matrices(
        Ad[0], Bd[0], arrays.H, inputs=["speed"], disturbances=["T_amb"],
        outputs=list(SPINDLE_OUTPUTS),
    )  # fmt: skip
    assert ss.dt is None
    fit = FitResult.from_model(ss, method="n4sid-like")
    with pytest.raises(ConfigError, match=r"no sample period \(dt is None\)"):
        gym.make("thermogym/SpindleThermal-v0", params=fit.to_dict(), episode_s=1800.0)


def test_strut_elongation_and_compensation():
    from thermogym.models.strut import StrutModel

    _env, h, acts, k = _history(
        "thermogym/StrutThermal-v0", lambda o: np.array([1.0, 0.1], np.float32),
        episode_s=3600.0, air_swing_K=0.0, air_C=21.0,
    )  # fmt: skip
    T = acts.shape[0]
    u = np.column_stack([np.full(T + 1, 30.0), np.full(T + 1, 21.0)])
    u[-1, 0] = 0.0
    sim = StrutModel().simulate(u, 60.0, {"T_ref": 21.0})
    np.testing.assert_allclose(h["dL_um"], sim.output("dL_um")[0], rtol=0, atol=1e-8)
    assert h["dL_um"][0] == pytest.approx(0.0, abs=1e-9)  # referenced at the start
    comp = 0.1 * 600.0
    assert k["elongation_error_um"] == pytest.approx(kpis.elongation_error_um(h["dL_um"][1:], comp))
    assert k["travel_m"] == pytest.approx(30.0 * T)


def test_tclab_runs_the_identified_model():
    from thermogym.envs.tclab import FIT_PATH
    from thermogym.fitresult import FitResult

    env, h, _acts, k = _history(
        "thermogym/TCLab-v0", lambda o: np.array([0.6, -0.2], np.float32),
        episode_s=600.0, ambient_C=22.0,
    )  # fmt: skip
    fit = FitResult.load(FIT_PATH)
    assert env.fit.fingerprint() == fit.fingerprint()
    m = fit.build_model()
    q1, q2 = (50.0 * (float(np.float32(a)) + 1.0) for a in (0.6, -0.2))  # float32 actions
    u = np.column_stack([np.full(601, q1), np.full(601, q2), np.full(601, 22.0)])
    sim = m.simulate(u, 1.0, fit.theta(m))
    np.testing.assert_allclose(h["T1"], sim.output("T1")[0], rtol=0, atol=1e-10)
    P = m.theta(fit.parameters)[0]
    Pw = q1 * P[m.param_index("alpha_1")] + q2 * P[m.param_index("alpha_2")]
    assert k["actuator_energy_Wh"] == pytest.approx(Pw * 600.0 / 3600.0)


def test_tclab_measurement_is_quantised_like_the_adc():
    env = gym.make("thermogym/TCLab-v0")
    obs, _ = env.reset(seed=0)
    for _ in range(20):
        obs, *_ = env.step(np.ones(2, np.float32))
    steps = obs[:2] / 0.322
    np.testing.assert_allclose(steps, np.round(steps), atol=1e-4)


# -------------------------------------------------- render and the rig
def test_render_rgb_array_and_human(tmp_path):
    env = gym.make("thermogym/AXT211Valve-v0", render_mode="rgb_array", episode_s=100.0)
    env.reset(seed=0)
    for _ in range(5):
        env.step(env.action_space.sample())
    img = env.render()
    assert img.ndim == 3 and img.shape[2] == 3 and img.dtype == np.uint8 and img.std() > 0
    path = tmp_path / "episode.png"
    env = gym.make("thermogym/TCLab-v0", render_mode="human", render_path=str(path), episode_s=5.0)
    env.reset(seed=0)
    for _ in range(5):
        env.step(env.action_space.sample())
    assert path.read_bytes()[:4] == b"\x89PNG"  # written at the episode end


def test_rig_plant_runs_the_rigs_own_physics_and_sensors():
    kw = {"action_mode": "onoff", "episode_s": 1800.0, "sensor_noise": False}
    on = lambda o: 1  # noqa: E731
    env, rig_h, _, _ = _history("thermogym/AXT211Valve-v0", on, plant="rig", **kw)
    assert env.plant_kind == "rig"
    # the rig's true plant runs (not the model): its own simulation of the same input
    from thermogym.rigs.axt211 import AXT211Plant, specimen_spread

    plant = AXT211Plant()
    spec = specimen_spread(np.random.default_rng(0), n=1)  # specimen_seed=0
    u = np.tile([1.0, 24.0, 25.0], (181, 1))
    truth = plant.simulate(u, 10.0, spec).output("x_V")[0]
    np.testing.assert_allclose(rig_h["x_V"], truth, atol=1e-9)
    # a concealed effect of the rig (latent heat of another wax grade) delays the opening
    _, eff_h, _, _ = _history(
        "thermogym/AXT211Valve-v0", on, plant="rig", rig_effects=["phase_change"], **kw
    )
    assert np.argmax(eff_h["x_V"] > 1.0) > np.argmax(rig_h["x_V"] > 1.0)
    # the rig's sensors: its LVDT (4 µm white, 3 µm coloured) instead of the field sensor
    e = gym.make("thermogym/AXT211Valve-v0", plant="rig").unwrapped
    lvdt = e._e.rsens.sensors[0]
    assert lvdt.noise == pytest.approx(0.004) and lvdt.colored == pytest.approx(0.003)
    # sensor offset on an observed channel
    e = gym.make(
        "thermogym/SpindleThermal-v0", plant="rig", rig_effects=["sensor_offset"],
        sensor_noise=False, ambient_swing_K=0.0, ambient_C=24.0,
    )  # fmt: skip
    obs, _ = e.reset(seed=0)
    assert obs[1] - obs[0] == pytest.approx(1.0, abs=1e-3)  # front housing reads 1 K high
    # the rig's own default magnitude applies when only the channel is named (AXT211: 1.5 K)
    e = gym.make(
        "thermogym/AXT211Valve-v0", plant="rig", rig_effects=["sensor_offset:signal=T_G"],
        sensor_noise=False,
    ).unwrapped  # fmt: skip
    obs, _ = e.reset(seed=0)
    assert obs[1] - e.true_outputs()["T_G"] == pytest.approx(1.5, abs=1e-9)
    with pytest.raises(ConfigError, match="offset is 'abc'; expected a number"):
        gym.make("thermogym/AXT211Valve-v0", plant="rig",
                 rig_effects=["sensor_offset:signal=T_G,offset=abc"])  # fmt: skip


def test_network_rig_with_nonlinear_physics():
    kw = {"episode_s": 3600.0, "sensor_noise": False, "ambient_swing_K": 0.0}
    full = lambda o: np.ones(1, np.float32)  # noqa: E731
    _, lin, _, _ = _history("thermogym/SpindleThermal-v0", full, plant="rig", **kw)
    _, nl, _, _ = _history(
        "thermogym/SpindleThermal-v0", full, plant="rig", rig_effects=["input_nonlinearity"], **kw
    )
    # the balls' centrifugal load raises the SKF friction (+38 % at 8000 rpm): hotter
    assert nl["T_front_bearing_C"][-1] > lin["T_front_bearing_C"][-1] + 1.0


def test_weather_file(tmp_path):
    from thermogym.recording import Recording, write_recording

    t = 3600.0 * np.arange(48)
    rec = Recording(t, {"T_out": np.full(48, -7.5)}, units={"T_out": "°C"})
    path = write_recording(rec, tmp_path / "weather.csv")
    env = gym.make(
        "thermogym/AXT211Room-v0", weather=str(path), sensor_noise=False, start_day=100,
        episode_days=0.1,
    )  # fmt: skip
    obs, _ = env.reset(seed=0)
    assert obs[env.unwrapped.obs_names.index("T_out")] == pytest.approx(-7.5)
    with pytest.raises(ConfigError, match="T_out"):
        bad = Recording(t, {"temp": np.zeros(48)})
        gym.make("thermogym/AXT211Room-v0", weather=bad)


# ------------------------------------------------------------ parameters
def _valve_fit(**values):
    from thermogym.fitresult import FitResult
    from thermogym.models import AXT211

    return FitResult.from_model(AXT211(), values, method="test")


def test_parameter_refresh_between_episodes_equals_a_fresh_env():
    from thermogym.envs.wrappers import ParameterRefresh

    kw = {**SHORT["thermogym/AXT211Valve-v0"]}
    new = _valve_fit(C_P=30.0, lambda_GU=0.15)
    env = ParameterRefresh(gym.make("thermogym/AXT211Valve-v0", **kw), new)
    _, info = env.reset(seed=0)
    assert info["parameter_refresh"]["changed"]["C_P"] == (18.0, 30.0)
    a, _ = rollout(env, 5, 30)
    b, _ = rollout(gym.make("thermogym/AXT211Valve-v0", params=new, **kw), 5, 30)
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x[0], y[0])
    assert len(env.log) == 1


def test_parameter_refresh_mid_episode_changes_the_dynamics_from_that_step():
    from thermogym.envs.wrappers import ParameterRefresh
    from thermogym.models import AXT211

    kw = {"action_mode": "onoff", "episode_s": 1200.0, "sensor_noise": False, "record": True}
    slow = _valve_fit(C_P=40.0)
    ref = gym.make("thermogym/AXT211Valve-v0", **kw)
    env = ParameterRefresh(gym.make("thermogym/AXT211Valve-v0", **kw), slow, at_reset=False,
                           at_step=30)  # fmt: skip
    for e in (ref, env):
        e.reset(seed=0)
        for _ in range(120):
            _, _, _, _, _info = e.step(1)
    h0, h1 = ref.unwrapped.history(), env.unwrapped.history()
    np.testing.assert_array_equal(h0["T_P"][:31], h1["T_P"][:31])
    assert np.all(h1["T_P"][40:] < h0["T_P"][40:])  # larger capacity heats more slowly
    # truth: the model with C_P = 18 for 30 steps, then 40, the state carried over
    m = AXT211()
    u = np.column_stack([np.ones(121), np.full(121, 24.0), np.full(121, 25.0)])
    s1 = m.simulate(u[:31], 10.0, return_states=True)
    s2 = m.simulate(u[30:], 10.0, {"C_P": 40.0}, x0=s1.states[0, -1])
    np.testing.assert_allclose(h1["T_P"][30:], s2.output("T_P")[0], atol=1e-10)


def test_parameter_refresh_rereads_a_file(tmp_path):
    from thermogym.envs.wrappers import ParameterRefresh

    path = tmp_path / "fit.json"
    env = ParameterRefresh(gym.make("thermogym/AXT211Valve-v0", episode_s=50.0), path)
    env.reset(seed=0)  # no file yet: parameters kept
    assert env.log == []
    _valve_fit(C_P=20.0).save(path)
    _, info = env.reset()
    assert info["parameter_refresh"]["changed"] == {"C_P": (18.0, 20.0)}
    _, info = env.reset()  # unchanged file: nothing applied
    assert "parameter_refresh" not in info
    _valve_fit(C_P=22.0, tau_P=9.0).save(path)
    _, info = env.reset()
    assert set(info["parameter_refresh"]["changed"]) == {"C_P", "tau_P"}
    assert env.unwrapped.theta[0, env.unwrapped.model.param_index("C_P")] == 22.0
    assert len(env.log) == 2


def test_domain_randomization_is_seeded_and_within_bounds():
    from thermogym.envs.wrappers import DomainRandomization

    env = DomainRandomization(gym.make("thermogym/TCLab-v0"), "covariance", scale=2.0)
    fit = env.unwrapped.fit
    draws = [env.reset(seed=s)[1]["parameters"] for s in (1, 1, 2)]
    assert draws[0] == draws[1] and draws[0] != draws[2]
    for d in draws:
        for name, (lo, hi) in fit.bounds.items():
            assert lo <= d[name] <= hi
        for name in fit.fixed:
            assert d[name] == fit.parameters[name]
    env = DomainRandomization(
        gym.make("thermogym/AXT211Valve-v0"), "relative", scale=0.1, names=["C_P", "tau_P"]
    )
    vals = np.array([env.reset(seed=s)[1]["parameters"]["C_P"] for s in range(50)])
    assert vals.min() >= 18.0 * 0.9 and vals.max() <= 18.0 * 1.1 and vals.std() > 0.5
    with pytest.raises(ParameterError, match="no_such"):
        DomainRandomization(gym.make("thermogym/AXT211Valve-v0"), "relative", names=["no_such"])


def test_vector_env_randomization_equals_single_envs():
    kw = {**SHORT["thermogym/TCLab-v0"], "randomize": "covariance",
          "randomize_kwargs": {"scale": 3.0}}  # fmt: skip
    venv = gym.make_vec("thermogym/TCLab-v0", 2, vectorization_mode="vector_entry_point", **kw)
    venv.reset(seed=4)
    th = venv.unwrapped._e.theta.copy()
    for i in range(2):
        e = gym.make("thermogym/TCLab-v0", **kw)
        e.reset(seed=4 + i)
        np.testing.assert_array_equal(e.unwrapped.theta[0], th[i])
    assert not np.array_equal(th[0], th[1])


def test_reset_options_install_parameters_and_reject_unknown_keys():
    env = gym.make("thermogym/AXT211Valve-v0", episode_s=50.0)
    env.reset(seed=0, options={"params": _valve_fit(C_P=33.0)})
    assert env.unwrapped.theta[0, env.unwrapped.model.param_index("C_P")] == 33.0
    with pytest.raises(ConfigError, match="warp"):
        env.reset(options={"warp": 1})


def test_vector_env_same_step_autoreset():
    kw = dict(SHORT["thermogym/TCLab-v0"])
    venv = gym.make_vec(
        "thermogym/TCLab-v0", 2, vectorization_mode="vector_entry_point",
        autoreset_mode="SameStep", **kw,
    )  # fmt: skip
    single = gym.make("thermogym/TCLab-v0", **kw)
    venv.reset(seed=1)
    single.reset(seed=1)
    a = np.zeros((2, 2), np.float32)
    for _ in range(single.unwrapped.horizon):
        vo, _, _, vtr, info = venv.step(a)
        so, _, _, str_, _ = single.step(a[0])
    assert vtr[0] and str_
    np.testing.assert_array_equal(info["final_obs"][0], so)  # the last observation
    np.testing.assert_array_equal(vo[0], single.reset()[0])  # already the next episode
    with pytest.raises(ConfigError, match="autoreset_mode"):
        gym.make_vec("thermogym/TCLab-v0", 2, vectorization_mode="vector_entry_point",
                     autoreset_mode="Sometimes")  # fmt: skip
