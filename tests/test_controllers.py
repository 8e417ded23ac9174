"""Controllers on known plants: on/off thresholds, PWM timing, PID, tuning rules, MPC limits."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from gymnasium import spaces

import thermogym.envs  # noqa: F401
from thermogym.controllers import (
    FOPTD,
    MPC,
    PID,
    PWM,
    Decentralized,
    LinearFeedforward,
    Loop,
    OnOff,
    PreviewData,
    StaticMap,
    env_info,
    foptd_of,
    lambda_tuning,
    linear_plant,
    simc,
)
from thermogym.errors import ConfigError, UnknownNameError
from thermogym.models.linear import FOPTDModel, StateSpaceModel


class FOPTDPlant(gym.Env):
    """Discrete FOPTD with a whole-sample delay: y[k+1] = a y[k] + K (1 − a) u[k − d] + load.

    The exact zero-order-hold solution of T dy/dt + y = K u(t − d·dt), written here
    independently of thermogym's linear models (independent truth for the tests).
    """

    def __init__(self, K=2.0, T=100.0, delay=2, dt=10.0, r=1.0, load=0.0, discrete=False):
        self.K, self.T, self.d, self.dt, self.r, self.load = K, T, delay, dt, r, load
        self.a = math.exp(-dt / T)
        self.observation_space = spaces.Box(-100.0, 100.0, (2,), dtype=np.float32)
        self.action_space = spaces.Discrete(2) if discrete else spaces.Box(-1.0, 1.0, (1,))
        self.obs_names = ("y", "r")
        self.obs_units = ("K", "K")

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.y = 0.0
        self.hist = [0.0] * (self.d + 1)
        self.us: list[float] = []
        return self._obs(), {}

    def _obs(self):
        return np.array([self.y, self.r], dtype=np.float32)

    def step(self, action):
        if isinstance(self.action_space, spaces.Discrete):
            u = float(action)
        else:
            u = 0.5 * (float(np.asarray(action).reshape(-1)[0]) + 1.0)
        self.us.append(u)
        self.hist.append(u)
        ud = self.hist[-1 - self.d]
        self.y = self.a * self.y + self.K * (1 - self.a) * ud + self.load * (1 - self.a)
        return self._obs(), 0.0, False, False, {}


def run(env, ctrl, n, r=None):
    obs, _ = env.reset(seed=0)
    ctrl.reset()
    ys = []
    for k in range(n):
        if r is not None:
            env.r = r(k)
            obs = env._obs()
        obs, *_ = env.step(ctrl.act(obs))
        ys.append(float(env.y))
    return np.array(ys), np.array(env.us)


class Scripted(gym.Env):
    """An environment whose observation is set by the test: ``y`` and ``r``."""

    def __init__(self, dt=10.0, discrete=False):
        self.observation_space = spaces.Box(-100.0, 100.0, (2,), dtype=np.float32)
        self.action_space = spaces.Discrete(2) if discrete else spaces.Box(-1.0, 1.0, (1,))
        self.obs_names = ("y", "r")
        self.dt = dt


# ------------------------------------------------------------------- on/off
def test_onoff_switches_exactly_at_the_thresholds():
    env = Scripted()
    c = OnOff(hysteresis=1.0, loop=Loop("y", "r")).bind(env)
    c.reset()
    r = 20.0
    # falling: stays off above r − 0.5, on at exactly r − 0.5
    for y, want in [(21.0, 0), (20.0, 0), (19.5000001, 0), (19.5, 1), (19.7, 1), (20.4999, 1)]:
        assert c.update(np.array([y, r])) == want, y
    # rising: off at exactly r + 0.5, stays off down to just above r − 0.5
    for y, want in [(20.5, 0), (20.0, 0), (19.5001, 0), (19.4, 1)]:
        assert c.update(np.array([y, r])) == want, y
    assert c.thresholds(r) == (19.5, 20.5)


def test_onoff_asymmetric_band_reverse_acting_and_min_times():
    env = Scripted(dt=60.0)
    c = OnOff(band=(0.2, 1.0), loop=Loop("y", "r", direct=False)).bind(env)
    c.reset()  # cooling: on when y ≥ r + 1.0, off when y ≤ r − 0.2
    assert c.update(np.array([20.9, 20.0])) == 0
    assert c.update(np.array([21.0, 20.0])) == 1
    assert c.update(np.array([19.81, 20.0])) == 1
    assert c.update(np.array([19.8, 20.0])) == 0
    # minimum on time of 3 min at 1-min samples: on for 3 samples whatever the measurement
    d = OnOff(hysteresis=1.0, min_on_s=180.0, min_off_s=120.0, loop=Loop("y", "r")).bind(env)
    d.reset()
    seq = [d.update(np.array([y, 20.0])) for y in (19.0, 25.0, 25.0, 25.0, 19.0, 19.0, 19.0)]
    assert seq == [1, 1, 1, 0, 0, 1, 1]


def test_onoff_drives_the_room_within_its_band():
    env = gym.make("thermogym/AXT211Room-v0", action_mode="onoff", start_day=14)
    c = OnOff(hysteresis=0.5).bind(env)
    obs, _ = env.reset(seed=1)
    c.reset()
    T = []
    for _ in range(6 * 360):  # six hours
        obs, *_ = env.step(c.act(obs))
        T.append(obs[0])
    # the zone ends up cycling around the night set-point 17 °C (sensor noise 0.1 K)
    tail = np.array(T[-360:])
    assert 16.0 < tail.min() and tail.max() < 18.2


def test_optimum_start_preheats_by_the_recovery_time_and_latches():
    from thermogym.controllers import OptimumStart, SchedulePreview

    env = gym.make("thermogym/AXT211Room-v0", start_day=14, control_period=600.0)
    c = OptimumStart(OnOff(0.5), SchedulePreview(start_day=14), rate_K_per_h=1.0).bind(env)
    names = env.get_wrapper_attr("obs_names")
    obs = np.zeros(len(names))
    obs[names.index("T_set")] = 17.0
    # Monday, occupancy from 7:00; at 18 °C the recovery takes (21 − 18) / 1 = 3 h: from 4:00
    obs[names.index("T_zone")] = 18.0
    assert c.effective_setpoint(obs, 4.0 * 3600.0 - 60.0) == 17.0
    assert c.effective_setpoint(obs, 4.0 * 3600.0) == 21.0
    # latched: a room that warmed up keeps the occupied set-point until occupancy
    obs[names.index("T_zone")] = 20.9
    assert c.effective_setpoint(obs, 6.5 * 3600.0) == 21.0
    c.reset()
    assert c.effective_setpoint(obs, 6.5 * 3600.0) == 17.0  # not latched: 0.5 h > 0.1 h lead
    # Saturday (day 19): no occupancy ahead within the lead
    assert c.time_to_occupancy(5 * 86400.0 + 6.0 * 3600.0) == math.inf
    with pytest.raises(ConfigError, match="constant"):
        OptimumStart(OnOff(0.5, loop=Loop("T_zone", 21.0)), SchedulePreview(14)).bind(env)


def test_optimum_start_reaches_the_band_at_occupancy_where_the_reactive_thermostat_does_not():
    from thermogym.controllers import OptimumStart, SchedulePreview

    def zone_at_seven(preheat: bool) -> float:
        env = gym.make(
            "thermogym/AXT211Room-v0",
            start_day=14,
            control_period=60.0,
            initial_zone_C=17.0,
            sensor_noise=False,
        )
        c: OnOff | OptimumStart = OnOff(0.5)
        if preheat:
            c = OptimumStart(c, SchedulePreview(start_day=14))
        c.bind(env)
        obs, _ = env.reset(seed=0)
        c.reset()
        for _ in range(7 * 60):  # midnight to 7:00
            obs, *_ = env.step(c.act(obs))
        return float(obs[0])

    reactive, preheated = zone_at_seven(False), zone_at_seven(True)
    assert reactive < 18.0  # the setback held until the occupied set-point came
    # a Monday after a cold weekend: the recovery is slower than the preset's 0.6 K/h, yet
    # the room starts the day far closer to the comfort band
    assert preheated > reactive + 1.5


# ----------------------------------------------------------------------- PWM
@pytest.mark.parametrize("period,duty", [(120.0, 0.37), (60.0, 0.5), (10.0, 0.73), (1200.0, 0.01)])
def test_pwm_on_time_is_duty_times_period(period, duty):
    env = Scripted(dt=10.0)
    c = PWM(period, duty=duty).bind(env)
    c.reset()
    n = round(period / 10.0)
    u = np.array([c.command(np.zeros(2)) for _ in range(3 * n)])
    on_s = u.reshape(3, n).sum(axis=1) * 10.0  # seconds on per period
    np.testing.assert_allclose(on_s, duty * period, atol=1e-9)
    # on at the start of each period, off at its end
    first = u[:n]
    assert (np.diff(first) <= 1e-12).all()


def test_pwm_on_off_actions_round_to_whole_control_periods_and_min_pulse():
    env = Scripted(dt=10.0, discrete=True)
    c = PWM(120.0, duty=0.37).bind(env)  # 44.4 s → 4 periods of 10 s
    acts = [c.act(np.zeros(2)) for _ in range(24)]
    assert acts[:12] == [1, 1, 1, 1, 0, 0, 0, 0, 0, 0, 0, 0] and acts[12:] == acts[:12]
    short = PWM(120.0, duty=0.1, min_pulse_s=15.0).bind(Scripted(dt=10.0))
    assert sum(short.command(np.zeros(2)) for _ in range(12)) == 0.0  # 12 s pulse dropped
    full = PWM(120.0, duty=0.95, min_pulse_s=15.0).bind(Scripted(dt=10.0))
    assert sum(full.command(np.zeros(2)) for _ in range(12)) == 12.0  # 6 s gap dropped


def test_pwm_runs_inner_controller_once_per_period_and_checks_the_period():
    class Count(StaticMap):
        n = 0

        def update(self, obs):
            Count.n += 1
            return 0.5

    env = Scripted(dt=10.0)
    c = PWM("medium", inner=Count([0.0, 1.0], [0.0, 1.0], loop=Loop("y", "r"))).bind(env)
    for _ in range(36):
        c.command(np.zeros(2))
    assert Count.n == 3 and c.inner.h == 120.0
    with pytest.raises(ConfigError, match="whole number of control periods"):
        PWM(25.0, duty=0.5).bind(env)
    with pytest.raises(ConfigError, match="shorter than the control period"):
        PWM(5.0, duty=0.5).bind(env)
    with pytest.raises(ConfigError, match="exactly one"):
        PWM(10.0)


# ----------------------------------------------------------------------- PID
def test_pid_removes_the_steady_error_of_the_foptd_plant_p_only_keeps_it():
    K, T, d, dt = 2.0, 100.0, 2, 10.0
    plant = FOPTDPlant(K, T, d, dt, r=1.0, load=0.3)  # a load the controller must reject
    gains = simc(FOPTD(K, T, d * dt), extra_delay=dt / 2)
    pi = PID(gains=gains, loop=Loop("y", "r"), u_min=0.0, u_max=1.0).bind(plant)
    y, _ = run(plant, pi, 600)
    assert abs(y[-1] - 1.0) < 1e-4
    # proportional only: y_ss = (K Kp r + load) / (1 + K Kp) (independent steady-state balance)
    kp = 0.5
    p = PID(kp=kp, loop=Loop("y", "r"), u_min=0.0, u_max=1.0).bind(plant)
    y, _ = run(plant, p, 600)
    assert y[-1] == pytest.approx((K * kp * 1.0 + 0.3) / (1 + K * kp), abs=1e-6)


def test_pid_output_limits_and_anti_windup_reduce_overshoot():
    def overshoot(mode):
        plant = FOPTDPlant(2.0, 100.0, 2, 10.0)
        pid = PID(kp=2.0, ti=60.0, anti_windup=mode, u_min=0.0, u_max=0.7, loop=Loop("y", "r"))
        pid.bind(plant)
        # a set-point that needs u = 0.6 of at most 0.7: the output saturates during the rise
        y, u = run(plant, pid, 400, r=lambda k: 1.2)
        assert u.min() >= 0.0 and u.max() <= 0.7 + 1e-6  # float32 actions
        assert np.isclose(u, 0.7, atol=1e-6).sum() > 5  # it did saturate
        return y.max() - 1.2, abs(y[-1] - 1.2)

    none_os, _ = overshoot("none")
    for mode in ("back-calculation", "clamping"):
        os_, err = overshoot(mode)
        assert os_ < 0.5 * none_os and err < 1e-3


def test_pid_derivative_filter_and_setpoint_weight_and_bumpless_changes():
    env = Scripted(dt=1.0)
    kp, td, n, h = 2.0, 10.0, 5.0, 1.0
    c = PID(kp=kp, td=td, n=n, b=0.0, bias=0.5, u_min=0.0, u_max=1.0, loop=Loop("y", "r"))
    c.bind(env)
    c.update(np.array([0.0, 0.0]))
    # a measurement step of 0.01: derivative on the measurement, backward difference with filter
    u = c.update(np.array([0.01, 0.0]))
    d_expect = -kp * td * n / (td + n * h) * 0.01
    assert u == pytest.approx(0.5 + kp * (0.0 - 0.01) + d_expect, abs=1e-12)
    # set-point weight: b = 0 a set-point step does not move a P controller, b = 1 by kp·Δr
    for b, jump in ((0.0, 0.0), (1.0, kp * 0.1)):
        p = PID(kp=kp, b=b, bias=0.5, loop=Loop("y", "r")).bind(env)
        before = p.update(np.array([0.01, 0.0]))
        assert p.update(np.array([0.01, 0.1])) - before == pytest.approx(jump)
    pi = PID(kp=0.5, ti=100.0, u0=0.3, loop=Loop("y", "r")).bind(env)
    assert pi.update(np.array([1.0, 2.0])) == pytest.approx(0.3)  # bumpless start from manual
    u1 = pi.update(np.array([1.0, 2.0]))
    pi.set_gains(kp=1.5)
    u2 = pi.update(np.array([1.0, 2.0]))
    assert u2 - u1 == pytest.approx(0.5 * 1.0 / 100.0 * 1.0)  # only the integral moved


def test_pid_rejects_bad_settings_and_unknown_keywords():
    with pytest.raises(ConfigError, match="anti_windup"):
        PID(kp=1.0, anti_windup="magic")
    with pytest.raises(ConfigError, match="u_min"):
        PID(kp=1.0, u_min=0.8, u_max=0.2)
    with pytest.raises(TypeError):
        PID(kp=1.0, kd=3.0)  # type: ignore[call-arg]


# -------------------------------------------------------------------- tuning
def test_simc_and_lambda_follow_their_formulas():
    g = simc(FOPTD(K=4.0, T=300.0, tau=30.0), tau_c=60.0)
    assert (g.kp, g.ti) == pytest.approx((300.0 / (4.0 * 90.0), 300.0))  # Ti = min(T, 4·90)
    g = simc(FOPTD(K=4.0, T=300.0, tau=30.0))  # tight: tau_c = theta
    assert (g.kp, g.ti) == pytest.approx((300.0 / (4.0 * 60.0), 240.0))
    g = lambda_tuning(FOPTD(K=0.5, T=100.0, tau=20.0), lam=50.0, derivative=True, input_scale=100)
    assert g.kp == pytest.approx(110.0 / (50.0 * 60.0))
    assert (g.ti, g.td) == pytest.approx((110.0, 100.0 * 20.0 / 220.0))
    with pytest.raises(ConfigError, match="tau_c"):
        simc(FOPTD(1.0, 10.0, 0.0))


def test_foptd_from_state_space_by_the_method_of_areas():
    # the exact FOPTD → state space conversion and back by areas: K exact, T + tau preserved
    m = FOPTDModel(["u"], ["y"], K=3.0, T=500.0, tau=80.0)
    lp = linear_plant(m, dt=5.0)
    ss = StateSpaceModel.from_matrices(lp.A, lp.B, lp.C, dt=5.0)
    f = foptd_of(ss)
    assert f.K == pytest.approx(3.0, rel=1e-9)
    assert f.T + f.tau == pytest.approx(580.0, rel=2e-3)
    assert f.T == pytest.approx(500.0, rel=0.02) and f.tau == pytest.approx(80.0, abs=8.0)


def test_linear_plant_of_an_foptd_matches_its_simulation():
    m = FOPTDModel(["u"], ["y"], disturbances=["d"], K=[[2.0, 0.5]], T=[[120.0, 600.0]],
                   tau=[[25.0, 0.0]], offsets=True, y0=10.0)  # fmt: skip
    rng = np.random.default_rng(0)
    u = np.repeat(rng.uniform(0, 1, (40, 2)), 10, axis=0)
    ref = m.simulate(u, 10.0).outputs[0, :, 0]
    lp = linear_plant(m, input="u", disturbances=["d"], dt=10.0)
    x = np.zeros(lp.n_states)
    y = []
    for k in range(len(u)):
        y.append(lp.output(x, u[k, 0], [u[k, 1]])[0])
        x = lp.A @ x + lp.B[:, 0] * u[k, 0] + lp.E @ [u[k, 1]]
    np.testing.assert_allclose(y, ref, atol=1e-10)
    Gu, Gd = lp.dc_gain()
    assert (Gu[0, 0], Gd[0, 0]) == pytest.approx((2.0, 0.5))
    lp3 = lp.resample(30.0)
    np.testing.assert_allclose(lp3.A, np.linalg.matrix_power(lp.A, 3), atol=1e-14)


# ------------------------------------------------------------------- MPC
def test_mpc_respects_input_and_move_limits_and_tracks_without_offset():
    plant = FOPTDPlant(K=2.4, T=100.0, delay=2, dt=10.0)  # the true gain is 20 % above the model's
    model = FOPTDModel(["u"], ["y"], K=2.0, T=100.0, tau=20.0, offsets=True, y0=0.0)
    mpc = MPC(model, horizon=20, u_min=0.1, u_max=0.6, du_max=0.05, loop=Loop("y", "r"),
              noise=(1e-4, 1e-3, 1e-4)).bind(plant)  # fmt: skip
    y, u = run(plant, mpc, 400, r=lambda k: 2.0 if k < 150 else 1.0)
    assert u.min() >= 0.1 - 1e-6 and u.max() <= 0.6 + 1e-6  # float32 actions
    assert np.abs(np.diff(u)).max() <= 0.05 + 1e-6
    assert u[100:150].min() == pytest.approx(0.6, abs=1e-6)  # 2.0 needs u = 0.83: saturated
    assert abs(y[-1] - 1.0) < 2e-3  # offset-free despite the 20 % gain error
    assert mpc.stats()["qp_failures"] == 0


def test_mpc_switching_cost_makes_fewer_moves_and_band_holds():
    model = FOPTDModel(["u"], ["y"], K=2.0, T=100.0, tau=20.0, offsets=True, y0=0.0)

    def travel(w):
        plant = FOPTDPlant(K=2.0, T=100.0, delay=2, dt=10.0)
        mpc = MPC(model, horizon=20, r_du=0.0, switching_cost=w, loop=Loop("y", "r")).bind(plant)
        _, u = run(plant, mpc, 300, r=lambda k: 1.0 + 0.5 * np.sin(k / 15.0))
        return np.abs(np.diff(u)).sum()

    t = [travel(w) for w in (0.0, 0.05, 0.5)]
    assert t[0] > t[1] > t[2]

    class Band:
        def __call__(self, obs, t, n, h):
            return PreviewData(np.zeros(n), np.full(n, 0.8), np.full(n, 1.2))

    plant = FOPTDPlant(K=2.0, T=100.0, delay=2, dt=10.0)
    mpc = MPC(model, horizon=20, q=0.0, energy_cost=0.1, band_weight=(10.0, 10.0),
              preview=Band(), loop=Loop("y", "r")).bind(plant)  # fmt: skip
    y, _ = run(plant, mpc, 300)
    # economic: the least energy inside the band is its lower edge
    assert y[-50:].min() > 0.79 and y[-1] == pytest.approx(0.8, abs=0.02)


# -------------------------------------------------------------- feedforward
def test_feedforward_inverts_the_steady_state():
    m = FOPTDModel(["u"], ["y"], disturbances=["d"], K=[[10.0, 0.5]], T=[[100.0, 50.0]],
                   tau=[[0.0, 0.0]], offsets=True, y0=5.0)  # fmt: skip

    class Env(Scripted):
        def __init__(self):
            super().__init__()
            self.observation_space = spaces.Box(-100.0, 100.0, (3,), dtype=np.float32)
            self.obs_names = ("y", "r", "d")

    ff = LinearFeedforward(m, disturbances={"d": "d"}, loop=Loop("y", "r")).bind(Env())
    u = ff.update(np.array([0.0, 9.0, 2.0]))
    assert 5.0 + 10.0 * u + 0.5 * 2.0 == pytest.approx(9.0)
    sm = StaticMap([0.0, 1.0, 4.0], [0.2, 0.4, 0.5], loop=Loop("y", "r")).bind(Scripted())
    assert sm.update(np.array([0.0, 2.5])) == pytest.approx(0.45)
    with pytest.raises(ConfigError, match="increasing"):
        StaticMap([0.0, 0.0], [0.1, 0.2])


# ---------------------------------------------------------------- binding
def test_binding_names_what_is_missing():
    env = gym.make("thermogym/AXT211Valve-v0")
    with pytest.raises(UnknownNameError, match=r"T_zone.*AXT211Valve does not have"):
        OnOff(loop=Loop("T_zone", "T_set")).bind(env)
    on_off_env = gym.make("thermogym/AXT211Valve-v0", action_mode="onoff")
    with pytest.raises(ConfigError, match="PWM output stage"):
        PID(kp=0.1, ti=100.0).bind(on_off_env)
    spindle = gym.make("thermogym/SpindleThermal-v0")
    with pytest.raises(ConfigError, match="has no default one"):
        OnOff().bind(spindle)
    c = OnOff(loop=Loop("T_front_outer_housing", 30.0)).bind(spindle)
    obs, _ = spindle.reset(seed=0)
    assert spindle.action_space.contains(c.act(obs))
    with pytest.raises(ConfigError, match="not bound"):
        PID(kp=1.0).act(np.zeros(6))
    info = env_info(env)
    assert info.name == "AXT211Valve" and info.env_id == "thermogym/AXT211Valve-v0"


def test_decentralized_pid_on_tclab_reaches_both_setpoints():
    env = gym.make("thermogym/TCLab-v0", setpoint=(40.0, 35.0), episode_s=1800.0,
                   sensor_noise=False)  # fmt: skip
    K, T, tau = [[0.54, 0.07], [0.16, 0.26]], [[150.0, 150.0], [180.0, 180.0]], [[15.0, 60.0]] * 2
    fit = FOPTDModel(["Q1", "Q2"], ["T1", "T2"], K=K, T=T, tau=tau)
    ctrls = [PID(gains=simc(fit, input=f"Q{i}", output=f"T{i}", input_scale=100.0, tau_c=60.0))
             for i in (1, 2)]  # fmt: skip
    c = Decentralized(ctrls).bind(env)
    obs, _ = env.reset(seed=0)
    c.reset()
    for _ in range(1800):
        obs, *_ = env.step(c.act(obs))
    assert abs(obs[0] - 40.0) < 0.3 and abs(obs[1] - 35.0) < 0.3
