"""StrutThermal: feed-rate scheduling and thermal-elongation compensation.

Description
-----------
The ball-screw actuator strut of ``000_24627a5308ee07db.txt`` (model
:class:`thermogym.models.strut.StrutModel`: the 19-node thermal RC network,
eq 13, with the five identified ratio parameters). The strut moves
periodically at the commanded feed rate; its motor, bearings and nut heat it
and it lengthens by ``ΔL = Σ_i α_i ΔT_i L_i`` (eq 5). The controller chooses
the feed rate (throughput) and a compensation offset ``c`` that the machine
control adds to the axis position; the accuracy is the elongation error
``ΔL − c``. ``ΔL`` itself is not measured in production (a laser
interferometer is costly, paper 000): the controller sees the seven
thermocouples of the paper's test stand and the air temperature.

Action Space
------------
``Box(-1, 1, (2,), float32)``: feed rate ``v = (a_0 + 1)/2 · v_max``
[m/min] and compensation ``c = a_1 · c_max`` [µm].

Observation Space
-----------------
``Box(float32)``, entries (:attr:`StrutThermalEnv.obs_names`)::

    0-6  T_drive, T_belt_housing, T_bearing, T_nut, T_spindle, T_tube_front,
         T_tube_rear   measured temperatures [°C] (thermocouples, -20..150)
    7    T_air         measured air temperature [°C]
    8    feed_prev     feed rate of the last period [m/min]
    9    comp_prev     compensation of the last period [µm]

Rewards
-------
Per control period (weights ``reward_weights``, defaults :data:`DEFAULT_WEIGHTS`)::

    r_k = w_throughput · v_k / v_max − w_error · |ΔL − c_k| [µm] − w_trip · [safety trip]

with ``ΔL`` at the end of the period.

Starting State
--------------
The strut at rest at the air temperature; with ``zero_at_start=True``
(default) the axis is referenced at the start, so ``ΔL(0) = 0`` (the
reference temperature ``T_ref`` is the starting air temperature — the
paper's "change compared to its initial value").

Episode End
-----------
Termination: a safety trip when the drive exceeds ``trip_C`` (default
70 °C). Truncation: after ``episode_s`` (default 8 h).

KPIs
----
``elongation_error_um`` (RMS of ``ΔL − c``), ``elongation_error_max_um``,
``time_above_limit_h`` (drive above ``drive_limit_C``), ``travel_m``,
``mean_feed_m_min``, ``episode_h``.

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
from thermogym.models.strut import STRUT_OUTPUTS, StrutModel

__all__ = ["DEFAULT_WEIGHTS", "StrutConfig", "StrutThermalEnv", "StrutThermalVectorEnv"]

ENV = "StrutThermal"
#: Default reward weights.
DEFAULT_WEIGHTS = {"throughput": 1.0, "error": 0.02, "trip": 100.0}
_TEMPS = tuple(STRUT_OUTPUTS)
OUTPUTS = (*_TEMPS, "dL_um")
#: Thermocouples (σ, resolution) as on the rig of paper 000.
SENSORS = {**{k: (0.05, 0.01) for k in _TEMPS}, "T_air": (0.05, 0.01)}
_CH = (*_TEMPS, "T_air")
_OBS = (*_TEMPS, "T_air", "feed_prev", "comp_prev")
_SIG = (*OUTPUTS, "T_air", "feed_rate", "compensation", "error_um", "reward")
_STEPWISE_RIG_EFFECTS = (
    "input_dependent_heat_transfer",
    "input_nonlinearity",
    "nonlinear_heat_transfer",
    "time_varying_parameter",
    "missing_dynamics",
    "sensor_offset",
    "sensor_drift",
)


@dataclass
class StrutConfig(MachineConfig):
    """Keyword arguments of ``thermogym/StrutThermal-v0`` (and :class:`MachineConfig`'s)."""

    params: ParamsLike = None
    """FitResult of model ``strut`` (the RC network with its five ratio parameters)."""
    max_feed_m_min: float = 30.0
    """Largest feed rate [m/min] (paper 000 tests 20-30 m/min)."""
    max_compensation_um: float = 600.0
    """Largest compensation offset [µm]."""
    air_C: float | tuple[float, float] = (19.0, 23.0)
    """Mean air temperature [°C] or a range drawn per episode."""
    air_swing_K: float = 0.3
    """Amplitude of the 6-hour air-temperature oscillation (as on the rig) [K]."""
    zero_at_start: bool = True
    """Reference the axis at the start (``ΔL(0) = 0``); False keeps the parameter ``T_ref``."""
    drive_limit_C: float = 45.0
    """Drive temperature counted in ``time_above_limit_h`` [°C]."""
    trip_C: float = 70.0
    """Drive temperature of the safety trip [°C]."""


_T, _HOR, _VMAX, _CMAX, _LIM, _TRIP, _WT, _WE, _WTR = range(9)
_A_SSE, _A_MAXE, _A_ABOVE, _A_TRAV, _A_V, _A_C = range(6)
_NACC = 6


@nb.njit(cache=True)
def _strut_row(
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
    air,
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
    na = air.shape[1]
    k = ctr[b, 0]
    r = 0.0
    e = 0.0
    v = acc[b, _A_V]
    c = acc[b, _A_C]
    if mode == 0:
        a0 = act[b, 0]
        a1 = act[b, 1]
        if not (math.isfinite(a0) and math.isfinite(a1)):
            ctr[b, 3] = 1
            return 1
        v = 0.5 * (min(max(a0, -1.0), 1.0) + 1.0) * cfg[_VMAX]
        c = min(max(a1, -1.0), 1.0) * cfg[_CMAX]
        u[0] = v
        u[1] = air[b, min(k, na - 1)]
        if linear[b]:
            lti_step(x[b], u, At[b], Bt[b], tmp)
        k += 1
        ctr[b, 0] = k
    u[0] = v
    u[1] = air[b, min(k, na - 1)]
    y = sig[b]  # the eight outputs (seven temperatures, ΔL eq 5), computed once
    lti_output(Ct[b], Dt[b], h0[b], x[b], u, y[:8])
    if mode == 0:
        dL = y[7]
        Td = y[0]
        e = dL - c
        acc[b, _A_SSE] += e * e
        acc[b, _A_MAXE] = max(acc[b, _A_MAXE], abs(e))
        if Td > cfg[_LIM]:
            acc[b, _A_ABOVE] += T
        acc[b, _A_TRAV] += v * T / 60.0
        acc[b, _A_V] = v
        acc[b, _A_C] = c
        trip = Td > cfg[_TRIP]
        r = cfg[_WT] * v / cfg[_VMAX] - cfg[_WE] * abs(e) - (cfg[_WTR] if trip else 0.0)
        out[b, 0] = r
        out[b, 1] = 1.0 if trip else 0.0
        out[b, 2] = 1.0 if k >= cfg[_HOR] else 0.0
    cur = ctr[b, 1]
    z = noise[b, cur]
    ctr[b, 1] = cur + 1
    t_h = k * T / 3600.0
    for i in range(7):
        obs[b, i] = measure(y[i], meas, i, z[i], t_h)
    obs[b, 7] = measure(u[1], meas, 7, z[7], t_h)
    obs[b, 8] = v
    obs[b, 9] = c
    sig[b, 8] = u[1]
    sig[b, 9] = v
    sig[b, 10] = c
    sig[b, 11] = e
    sig[b, 12] = r
    return 0


cache_depends_on(_strut_row)


class _StrutEngine(MachineEngine):
    name = ENV
    models = ("strut",)
    default_model = StrutModel
    rig_name = "strut"
    stepwise_effects = _STEPWISE_RIG_EFFECTS
    plant_outputs = OUTPUTS
    plant_inputs = ("feed_rate", "T_air")
    sensor_table = SENSORS
    default_weights = DEFAULT_WEIGHTS
    n_accumulators = _NACC
    kernels = plant_loops(_strut_row)
    obs_names = _OBS
    obs_units = ("°C",) * 8 + ("m/min", "µm")
    sig_names = _SIG
    sig_units = ("°C",) * 7 + ("µm", "°C", "m/min", "µm", "µm", "1")
    noise_channels = _CH
    panels = (
        ("temperature [°C]", (*_TEMPS, "T_air")),
        ("elongation [µm]", ("dL_um", "compensation", "error_um")),
        ("feed [m/min]", ("feed_rate",)),
        ("reward", ("reward",)),
    )

    cfg: StrutConfig

    def __init__(self, B: int, cfg: StrutConfig) -> None:
        super().__init__(B, cfg)
        w = self.weights
        self.cfgv = np.array(
            [
                self._dt,
                float(self._horizon),
                self.u_max,
                self.c_max,
                check_number(ENV, "drive_limit_C", cfg.drive_limit_C),
                check_number(ENV, "trip_C", cfg.trip_C),
                w["throughput"],
                w["error"],
                w["trip"],
            ]
        )
        self._h0_dL = np.zeros(B)
        self._iref = self.model.param_index("T_ref")
        self._L_total_um = float(self.model._L_total_um)  # type: ignore[attr-defined]

    def _settings(self, env: str, cfg: StrutConfig) -> None:
        self.u_max = check_number(env, "max_feed_m_min", cfg.max_feed_m_min, lo=0.0, lo_open=True)
        self.c_max = check_number(env, "max_compensation_um", cfg.max_compensation_um, lo=0.0)
        self.air = check_range(env, "air_C", cfg.air_C, lo=-20.0, hi=60.0)
        self.swing = check_number(env, "air_swing_K", cfg.air_swing_K, lo=0.0, hi=20.0)

    def action_space(self) -> spaces.Space[Any]:
        return spaces.Box(-1.0, 1.0, (2,), dtype=np.float32)

    def n_act(self) -> int:
        return 2

    def obs_bounds(self) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
        c = self.cfg
        lo = np.array([-20.0] * 8 + [0.0, -c.max_compensation_um], dtype=np.float32)
        hi = np.array([150.0] * 8 + [c.max_feed_m_min, c.max_compensation_um], dtype=np.float32)
        return lo, hi

    def _reset_row(self, b: int, rng: np.random.Generator) -> None:
        mean = draw(rng, self.air)
        phase = float(rng.uniform(0.0, 2 * np.pi))
        t = self._dt * np.arange(self._horizon + 1)
        self.ambient_tab[b] = mean + self.swing * np.sin(2 * np.pi * t / (6 * 3600.0) + phase)
        if self.cfg.zero_at_start and self.rig_plant is None:
            # the axis is referenced now: T_ref = starting air temperature, so ΔL(0) = 0.
            # T_ref enters only the offset of ΔL (h_0 = −Σ α L · T_ref, eq 5)
            T_ref = self.theta[b, self._iref]
            self.h0[b, 7] = self._h0_dL[b] + self._L_total_um * (T_ref - self.ambient_tab[b, 0])
        self.x[b] = self.rest_state(b, np.array([0.0, self.ambient_tab[b, 0]]))
        if self.cfg.zero_at_start and self.rig_plant is not None:
            # the rig's ΔL is against the ISO 20 °C length: reference the axis now
            self.h0[b, 7] = -self.x[b, 7]
        self.acc[b, _A_V] = 0.0
        self.acc[b, _A_C] = 0.0

    def _set_theta_row(self, b: int, theta: NDArray[np.float64]) -> None:
        super()._set_theta_row(b, theta)
        self._h0_dL[b] = self.h0[b, 7]

    def _manipulated(self, a: NDArray[np.float64]) -> NDArray[np.float64]:
        return 0.5 * (a + 1.0) * self.cfgv[_VMAX]

    def kpis(self, b: int) -> dict[str, float]:
        a = self.acc[b]
        k = self._steps_done(b)
        return {
            "elongation_error_um": float(math.sqrt(a[_A_SSE] / k)),
            "elongation_error_max_um": float(a[_A_MAXE]),
            "time_above_limit_h": float(a[_A_ABOVE] / 3600.0),
            "travel_m": float(a[_A_TRAV]),
            "mean_feed_m_min": float(a[_A_TRAV] * 60.0 / (k * self._dt)),
            "episode_h": self._episode_h(b),
        }

    def trip_reason(self, b: int) -> str:
        return f"drive above trip_C = {self.cfgv[_TRIP]} °C"


class StrutThermalEnv(ThermoEnv):
    """Feed rate and elongation compensation of the strut (``thermogym/StrutThermal-v0``).

    See the module docstring and :class:`StrutConfig`.

    Examples
    --------
    >>> import gymnasium as gym
    >>> import numpy as np
    >>> import thermogym.envs
    >>> env = gym.make("thermogym/StrutThermal-v0")
    >>> obs, info = env.reset(seed=0)
    >>> for _ in range(60):  # an hour at 20 m/min without compensation
    ...     obs, r, terminated, truncated, info = env.step(np.array([1/3, 0.0], np.float32))
    >>> bool(env.unwrapped.true_outputs()["dL_um"] > 20.0)
    True
    """

    env_name = ENV
    config_cls = StrutConfig
    engine_cls = _StrutEngine


class StrutThermalVectorEnv(ThermoVectorEnv):
    """``num_envs`` struts stepped by one compiled call (native vector env)."""

    single_env_cls = StrutThermalEnv
