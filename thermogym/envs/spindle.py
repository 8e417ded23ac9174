"""SpindleThermal: spindle speed scheduling under a bearing-temperature limit.

Description
-----------
The externally driven machine-tool spindle of ``001_6d13a2cd04f5de5e.txt``
(model :class:`thermogym.models.spindle.SpindleModel`, a 14-node thermal
network whose bearings heat in proportion to the speed; or an identified
N4SID state space, eq 3 of paper 001, given as ``params``). The controller
chooses the spindle speed: machining throughput grows with the speed, but the
bearings — whose temperature no sensor can see (paper 001, section 3.3) —
must stay under a limit. Only the outer-housing surface temperatures and the
ambient are measured.

Action Space
------------
``Box(-1, 1, (1,), float32)`` mapped to the speed
``n = n_min + (a + 1)/2 · (n_max − n_min)`` with ``speed_range_rpm``
(default 0-8000 rpm, the range of paper 001 Table 4).

Observation Space
-----------------
``Box(float32)``, entries (:attr:`SpindleThermalEnv.obs_names`)::

    0  T_rear_outer_housing   measured surface temperature [°C] (RTD, -50..300)
    1  T_front_outer_housing  measured surface temperature [°C]
    2  T_amb                  measured ambient temperature [°C]
    3  speed_prev             speed applied in the last period [rpm]

The bearing and inner-housing temperatures are hidden; the virtual-sensor
wrapper :class:`thermogym.envs.virtual_sensor.VirtualSensorObservation`
(Kalman filter on the identified model, paper 001 section 3.3) appends their
estimates to the observation (``env.unwrapped.model``, ``.theta``, ``.dt`` and
``.obs_names`` give what it needs; ``true_outputs()`` the truth for
evaluation).

Rewards
-------
Per control period (weights ``reward_weights``, defaults :data:`DEFAULT_WEIGHTS`)::

    r_k = w_throughput · n_k / n_max − w_over · max(T_b,max − T_limit, 0) [K]
          − w_trip · [safety trip]

with ``T_b,max`` the hottest of the four bearings at the end of the period.

Starting State
--------------
The spindle at rest at the ambient temperature (start of a shift), or warm at
the steady state of ``initial_speed_rpm``.

Episode End
-----------
Termination: a safety trip when a bearing exceeds ``trip_C`` (default
55 °C). Truncation: after ``episode_s`` (default 8 h, a shift).

Disturbances
------------
Workshop air temperature: a daily cycle peaking at 15:00 with a slow random
wander (:func:`thermogym.envs.profiles.ambient_day`), the shift starting at
``start_clock_h``; mean drawn per episode from ``ambient_C``.

KPIs
----
``bearing_over_limit_Kh``, ``time_above_limit_h`` (a bearing above the
limit), ``max_bearing_C``, ``mean_speed_rpm``, ``spindle_revolutions``,
``episode_h``.

Version History
---------------
* v0: initial release.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numba as nb
import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from thermogym.envs._base import ThermoEnv, ThermoVectorEnv, check_number, check_range, draw
from thermogym.envs._kernels import cache_depends_on, measure, plant_loops
from thermogym.envs._machine_env import MachineConfig, MachineEngine
from thermogym.envs._network import lti_output, lti_step
from thermogym.envs._plant import ParamsLike
from thermogym.envs.profiles import ambient_day
from thermogym.errors import ConfigError
from thermogym.models.spindle import SpindleModel

__all__ = ["DEFAULT_WEIGHTS", "SpindleConfig", "SpindleThermalEnv", "SpindleThermalVectorEnv"]

ENV = "SpindleThermal"
#: Default reward weights.
DEFAULT_WEIGHTS = {"throughput": 1.0, "over_limit": 1.0, "trip": 100.0}
#: RTD sensors (σ, resolution), paper 001 Table 2: accuracy ±0.05 K, 1 mK resolution.
SENSORS = {
    "T_rear_outer_housing": (0.02, 0.001),
    "T_front_outer_housing": (0.02, 0.001),
    "T_amb": (0.02, 0.001),
}
_CH = tuple(SENSORS)
OUTPUTS = (
    "T_rear_bearing_A",
    "T_rear_bearing_B",
    "T_front_bearing_C",
    "T_front_bearing_D",
    "T_inner_housing",
    "T_rear_outer_housing",
    "T_front_outer_housing",
)
_OBS = ("T_rear_outer_housing", "T_front_outer_housing", "T_amb", "speed_prev")
_SIG = (*OUTPUTS, "T_amb", "speed", "T_limit", "reward")
_STEPWISE_RIG_EFFECTS = (
    "input_nonlinearity",
    "input_dependent_heat_transfer",
    "nonlinear_heat_transfer",
    "time_varying_parameter",
    "missing_dynamics",
    "sensor_offset",
    "sensor_drift",
)


@dataclass
class SpindleConfig(MachineConfig):
    """Keyword arguments of ``thermogym/SpindleThermal-v0`` (and :class:`MachineConfig`'s)."""

    params: ParamsLike = None
    """FitResult of model ``spindle`` (RC network) or ``ss`` (N4SID state space with input
    ``speed``, the seven outputs of paper 001 Table 6 and, optionally, disturbance ``T_amb``;
    without it the outputs are taken as rises above the ambient)."""
    speed_range_rpm: tuple[float, float] = (0.0, 8000.0)
    """Speed range mapped from the action [rpm]."""
    bearing_limit_C: float = 45.0
    """Bearing temperature limit [°C]."""
    trip_C: float = 55.0
    """Bearing temperature of the safety trip [°C]."""
    ambient_C: float | tuple[float, float] = (22.0, 26.0)
    """Daily mean air temperature [°C] or a range drawn per episode."""
    ambient_swing_K: float = 1.5
    """Amplitude of the daily air-temperature cycle [K]."""
    start_clock_h: float = 6.0
    """Clock time at the start of the episode [h]."""
    initial_speed_rpm: float = 0.0
    """0: start at rest at the ambient; > 0: warm, at the steady state of this speed."""


_T, _HOR, _NMIN, _NMAX, _LIM, _TRIP, _WT, _WO, _WTR = range(9)
_A_OVER, _A_ABOVE, _A_REV, _A_MAX, _A_UPREV = range(5)
_NACC = 5


@nb.njit(cache=True)
def _spindle_row(
    b,
    mode,
    act,
    linear,
    x,
    At,
    Bt,
    Ct,
    Dt,
    h0,
    amb,
    acc,
    ctr,
    noise,
    meas,
    cfg,
    obs,
    out,
    sig,
    scratch,
):  # pragma: no cover - numba
    # one plant: step (mode 0) or observe only (mode 1); returns 1 for an invalid action
    T = cfg[_T]
    tmp = scratch[b, 2:]
    u = scratch[b, :2]
    na = amb.shape[1]
    k = ctr[b, 0]
    r = 0.0
    n = acc[b, _A_UPREV]
    if mode == 0:
        a = act[b, 0]
        if not math.isfinite(a):
            ctr[b, 3] = 1
            return 1
        a = min(max(a, -1.0), 1.0)
        n = cfg[_NMIN] + 0.5 * (a + 1.0) * (cfg[_NMAX] - cfg[_NMIN])
        u[0] = n
        u[1] = amb[b, min(k, na - 1)]
        if linear[b]:
            # exact ZOH step of the linear network / state space
            lti_step(x[b], u, At[b], Bt[b], tmp)
        k += 1
        ctr[b, 0] = k
    u[0] = n
    u[1] = amb[b, min(k, na - 1)]
    y = sig[b]  # the seven outputs, computed once (sig holds them for the history)
    lti_output(Ct[b], Dt[b], h0[b], x[b], u, y[:7])
    tb = max(max(y[0], y[1]), max(y[2], y[3]))
    if mode == 0:
        over = max(tb - cfg[_LIM], 0.0)
        trip = tb > cfg[_TRIP]
        acc[b, _A_OVER] += over * T / 3600.0
        if tb > cfg[_LIM]:
            acc[b, _A_ABOVE] += T
        acc[b, _A_REV] += n * T / 60.0
        acc[b, _A_MAX] = max(acc[b, _A_MAX], tb)
        acc[b, _A_UPREV] = n
        r = cfg[_WT] * n / cfg[_NMAX] - cfg[_WO] * over - (cfg[_WTR] if trip else 0.0)
        out[b, 0] = r
        out[b, 1] = 1.0 if trip else 0.0
        out[b, 2] = 1.0 if k >= cfg[_HOR] else 0.0
    else:
        acc[b, _A_MAX] = tb
    cur = ctr[b, 1]
    z = noise[b, cur]
    ctr[b, 1] = cur + 1
    t_h = k * T / 3600.0
    obs[b, 0] = measure(y[5], meas, 0, z[0], t_h)
    obs[b, 1] = measure(y[6], meas, 1, z[1], t_h)
    obs[b, 2] = measure(u[1], meas, 2, z[2], t_h)
    obs[b, 3] = n
    sig[b, 7] = u[1]
    sig[b, 8] = n
    sig[b, 9] = cfg[_LIM]
    sig[b, 10] = r
    return 0


cache_depends_on(_spindle_row)


class _SpindleEngine(MachineEngine):
    name = ENV
    models = ("spindle", "ss")
    default_model = SpindleModel
    rig_name = "spindle"
    stepwise_effects = _STEPWISE_RIG_EFFECTS
    plant_outputs = OUTPUTS
    plant_inputs = ("speed", "T_amb")
    sensor_table = SENSORS
    default_weights = DEFAULT_WEIGHTS
    n_accumulators = _NACC
    kernels = plant_loops(_spindle_row)
    obs_names = _OBS
    obs_units = ("°C", "°C", "°C", "rpm")
    sig_names = _SIG
    sig_units = ("°C",) * 8 + ("rpm", "°C", "1")
    noise_channels = _CH
    panels = (
        ("bearings [°C]", (*OUTPUTS[:4], "T_limit")),
        ("housing [°C]", (*OUTPUTS[4:], "T_amb")),
        ("speed [rpm]", ("speed",)),
        ("reward", ("reward",)),
    )

    cfg: SpindleConfig

    def __init__(self, B: int, cfg: SpindleConfig) -> None:
        super().__init__(B, cfg)
        w = self.weights
        self.cfgv = np.array(
            [
                self._dt,
                float(self._horizon),
                *self.n_range,
                check_number(ENV, "bearing_limit_C", cfg.bearing_limit_C),
                check_number(ENV, "trip_C", cfg.trip_C),
                w["throughput"],
                w["over_limit"],
                w["trip"],
            ]
        )

    def _settings(self, env: str, cfg: SpindleConfig) -> None:
        nmin, nmax = check_range(env, "speed_range_rpm", cfg.speed_range_rpm, lo=0.0, hi=1e5)
        if nmax <= 0:
            raise ConfigError(f"{env}: speed_range_rpm {cfg.speed_range_rpm}; expected max > 0")
        self.u_max = nmax
        self.n_range = (nmin, nmax)
        self.ambient = check_range(env, "ambient_C", cfg.ambient_C, lo=-20.0, hi=60.0)
        self.swing = check_number(env, "ambient_swing_K", cfg.ambient_swing_K, lo=0.0, hi=20.0)
        self.clock = check_number(env, "start_clock_h", cfg.start_clock_h, lo=0.0, hi=24.0)
        self.n0 = check_number(env, "initial_speed_rpm", cfg.initial_speed_rpm, lo=0.0, hi=1e5)

    def action_space(self) -> spaces.Space[Any]:
        return spaces.Box(-1.0, 1.0, (1,), dtype=np.float32)

    def obs_bounds(self) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
        lo = np.array([-50.0, -50.0, -50.0, 0.0], dtype=np.float32)
        hi = np.array([300.0, 300.0, 300.0, self.cfg.speed_range_rpm[1]], dtype=np.float32)
        return lo, hi

    def _reset_row(self, b: int, rng: np.random.Generator) -> None:
        mean = draw(rng, self.ambient)
        t = self._dt * np.arange(self._horizon + 1, dtype=np.float64)
        self.ambient_tab[b] = ambient_day(
            rng, t, start_clock_h=self.clock, mean_C=mean, swing_K=self.swing
        )
        self.x[b] = self.rest_state(b, np.array([self.n0, self.ambient_tab[b, 0]]))
        self.acc[b, _A_UPREV] = self.n0

    def _manipulated(self, a: NDArray[np.float64]) -> NDArray[np.float64]:
        c = self.cfgv
        return c[_NMIN] + 0.5 * (a + 1.0) * (c[_NMAX] - c[_NMIN])

    def kpis(self, b: int) -> dict[str, float]:
        a = self.acc[b]
        k = self._steps_done(b)
        return {
            "bearing_over_limit_Kh": float(a[_A_OVER]),
            "time_above_limit_h": float(a[_A_ABOVE] / 3600.0),
            "max_bearing_C": float(a[_A_MAX]),
            "mean_speed_rpm": float(a[_A_REV] * 60.0 / (k * self._dt)),
            "spindle_revolutions": float(a[_A_REV]),
            "episode_h": self._episode_h(b),
        }

    def trip_reason(self, b: int) -> str:
        return f"a bearing exceeded trip_C = {self.cfgv[_TRIP]} °C"


class SpindleThermalEnv(ThermoEnv):
    """Spindle speed under a bearing-temperature limit (``thermogym/SpindleThermal-v0``).

    See the module docstring and :class:`SpindleConfig`.

    Examples
    --------
    >>> import gymnasium as gym
    >>> import numpy as np
    >>> import thermogym.envs
    >>> env = gym.make("thermogym/SpindleThermal-v0")
    >>> obs, info = env.reset(seed=0)
    >>> env.unwrapped.obs_names
    ('T_rear_outer_housing', 'T_front_outer_housing', 'T_amb', 'speed_prev')
    >>> for _ in range(120):  # two hours at full speed
    ...     obs, r, terminated, truncated, info = env.step(np.ones(1, np.float32))
    >>> hidden = env.unwrapped.true_outputs()
    >>> bool(hidden["T_front_bearing_C"] > obs[1] > obs[2])  # bearing > housing > air
    True
    """

    env_name = ENV
    config_cls = SpindleConfig
    engine_cls = _SpindleEngine


class SpindleThermalVectorEnv(ThermoVectorEnv):
    """``num_envs`` spindles stepped by one compiled call (native vector env)."""

    single_env_cls = SpindleThermalEnv
