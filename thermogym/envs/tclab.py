"""TCLab: temperature control of the two-heater Temperature Control Lab.

Description
-----------
The TCLab (BYU / Notre Dame) is a small Arduino board with two transistor
heaters and two temperature sensors about 1 cm apart. Its model
(:class:`thermogym.models.tclab.TCLabModel`: two coupled energy balances with
convection and radiation plus sensor lags, after the APMonitor course
material) is the one in thermogym identified from *real* recordings: the
package ships the FitResult ``thermogym/envs/data/tclab_fit.json`` made by
``scripts/fit_tclab.py`` from the public recordings in
:mod:`thermogym.datasets` (trained on some runs, validated on others); it is
the default ``params``. The controller sets both heaters to make the two
sensors follow their set-points — a small coupled MIMO problem.

Identification (``scripts/fit_tclab.py``)
-----------------------------------------------------
Trained on ``tclab_mimo_1s``, ``tclab_step`` and ``tclab_sine`` (two boards:
shared thermal parameters, a heater-1 gain per board), residual standard
deviation 0.43 K. NRMSE fit (1 is perfect) T1 / T2 on the training runs
0.92/0.90, 0.97/0.95, 0.97/0.95; on unseen runs: ``tclab_mimo_3s_a``
0.91/0.86, ``tclab_step_50_run2`` 0.985/0.95, ``tclab_sin_5_50_run2``
0.90/0.55, ``tclab_mimo_3s_b`` 0.67/0.59 (starts with the sensors 2 K apart,
not at rest), and ``tclab_sin_2_50_run1..3`` 0.37-0.52 / 0.25-0.45: those
runs settle about 20 % lower above ambient at the same mean heater power on
both sensors — recorded with more heat loss (another environment), a real
mismatch left visible for the diagnosis tools rather than fitted away. The
shipped parameters are the APMonitor (MIMO) board's.

Action Space
------------
``Box(-1, 1, (2,), float32)`` mapped to the heater commands
``Q_i = 50 (a_i + 1)`` in [0, 100] %.

Observation Space
-----------------
``Box(float32)``, entries (:attr:`TCLabEnv.obs_names`)::

    0  T1       measured sensor 1 temperature [°C] (TMP36 through a 10-bit ADC:
                0.32 K steps, as in the recordings; -10..150)
    1  T2       measured sensor 2 temperature [°C]
    2  T1_set   set-point of sensor 1 for the next period [°C]
    3  T2_set   set-point of sensor 2 [°C]
    4  Q1_prev  heater 1 command of the last period [%]
    5  Q2_prev  heater 2 command of the last period [%]

Rewards
-------
Per control period (weights ``reward_weights``, defaults :data:`DEFAULT_WEIGHTS`)::

    r_k = −( w_tracking (|T1 − T1_set| + |T2 − T2_set|) / 10 K
           + w_energy   (P1 + P2) / 1.75 W )

with the true sensor temperatures at the end of the period and the heater
powers ``P_i = α_i Q_i``.

Starting State
--------------
The board at rest at the ambient temperature (drawn per episode from
``ambient_C``).

Episode End
-----------
Termination: a safety trip when a heater exceeds ``trip_C`` (100 °C).
Truncation: after ``episode_s`` (default 20 min).

KPIs
----
``actuator_energy_Wh`` (heater energy), ``temperature_rmse_K`` and
``temperature_iae_K_s`` (both sensors), ``time_above_limit_h`` (a sensor above
``temp_limit_C``), ``max_temperature_C``, ``episode_h``.

Version History
---------------
* v0: initial release.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

import numba as nb
import numpy as np
from gymnasium import spaces
from numpy.typing import ArrayLike, NDArray

from thermogym.envs._base import (
    Engine,
    ThermoEnv,
    ThermoVectorEnv,
    check_number,
    check_range,
    draw,
    parse_noise,
    parse_weights,
    steps_of,
)
from thermogym.envs._kernels import cache_depends_on, meas_array, measure, plant_loops
from thermogym.envs._plant import ParamsLike, resolve_plant
from thermogym.errors import ConfigError
from thermogym.models import tclab as _tc
from thermogym.models.tclab import TCLabModel

__all__ = ["DEFAULT_WEIGHTS", "FIT_PATH", "TCLabConfig", "TCLabEnv", "TCLabVectorEnv"]

ENV = "TCLab"
#: Default reward weights.
DEFAULT_WEIGHTS = {"tracking": 1.0, "energy": 0.05}
#: TMP36 on a 10-bit ADC at 3.3 V: 3.22 mV = 0.322 K per count; small noise on top.
SENSORS = {"T1": (0.05, 0.322), "T2": (0.05, 0.322)}
_CH = ("T1", "T2")
_OBS = ("T1", "T2", "T1_set", "T2_set", "Q1_prev", "Q2_prev")
_SIG = ("T1", "T2", "T1_set", "T2_set", "TH1", "TH2", "Q1", "Q2", "T_amb", "reward")


def fit_path() -> Path:
    """The shipped TCLab FitResult (identified from the real recordings)."""
    return Path(str(resources.files("thermogym.envs").joinpath("data", "tclab_fit.json")))


FIT_PATH = fit_path()


@dataclass
class TCLabConfig:
    """Keyword arguments of ``thermogym/TCLab-v0``."""

    params: ParamsLike = None
    """FitResult of model ``tclab``; default: the shipped fit to the real recordings."""
    plant: str = "model"
    """Only ``"model"``: the TCLab's real plant is hardware (no virtual rig)."""
    control_period: float = 1.0
    """Control period [s] (the recordings' sample period)."""
    episode_s: float = 1200.0
    """Episode length [s]."""
    setpoint: str | tuple[float, float] | ArrayLike = "random"
    """``"random"``, a pair of constants [°C], or an array (steps, 2) [°C]."""
    setpoint_range: tuple[float, float] = (30.0, 60.0)
    """Range of the random set-point levels [°C]."""
    setpoint_hold_s: float = 300.0
    """Time each random level is held [s]."""
    ambient_C: float | tuple[float, float] = (19.0, 25.0)
    """Ambient temperature [°C] or a range drawn per episode."""
    sensor_noise: bool | Mapping[str, float] = True
    """Sensor noise and ADC quantisation; False: exact; a dict overrides σ."""
    reward_weights: Mapping[str, float] | None = None
    """Overrides of :data:`DEFAULT_WEIGHTS`."""
    temp_limit_C: float = 60.0
    """Sensor temperature counted in ``time_above_limit_h`` [°C]."""
    trip_C: float = 100.0
    """Heater temperature of the safety trip [°C]."""
    randomize: str | None = None
    """Domain randomisation per episode (``"covariance"`` uses the fit's covariance)."""
    randomize_kwargs: Mapping[str, Any] | None = None
    """``scale``, ``names``, ``bounds`` of the randomisation."""


_T, _HMAX, _HOR, _HOLD, _WT, _WE, _LIM, _TRIP = range(8)
_A_E, _A_SSE, _A_IAE, _A_ABOVE, _A_MAX, _A_Q1, _A_Q2 = range(7)
_NACC = 7


@nb.njit(cache=True)
def _tclab_row(
    b, mode, act, x, p, amb, sp, acc, ctr, noise, meas, cfg, obs, out, sig
):  # pragma: no cover - numba
    # one plant: step (mode 0) or observe only (mode 1); returns 1 for an invalid action
    T = cfg[_T]
    hold = int(cfg[_HOLD])
    nseg = sp.shape[1]
    k = ctr[b, 0]
    pb = p[b]
    Ta = amb[b]
    q1 = acc[b, _A_Q1]
    q2 = acc[b, _A_Q2]
    r = 0.0
    if mode == 0:
        a0 = act[b, 0]
        a1 = act[b, 1]
        if not (math.isfinite(a0) and math.isfinite(a1)):
            ctr[b, 3] = 1
            return 1
        q1 = 50.0 * (min(max(a0, -1.0), 1.0) + 1.0)
        q2 = 50.0 * (min(max(a1, -1.0), 1.0) + 1.0)
        n = max(1, math.ceil(T / cfg[_HMAX] - 1e-9))
        # the model's RK4 steps over the period, heater commands held
        _tc.advance(x[b], q1, q2, Ta, pb, T / n, n)
        s = sp[b, min(k // hold, nseg - 1)]
        e1 = x[b, 2] - s[0]
        e2 = x[b, 3] - s[1]
        P = _tc.heater_power(pb, q1, q2)
        acc[b, _A_E] += P * T
        acc[b, _A_SSE] += e1 * e1 + e2 * e2
        acc[b, _A_IAE] += (abs(e1) + abs(e2)) * T
        if max(x[b, 2], x[b, 3]) > cfg[_LIM]:
            acc[b, _A_ABOVE] += T
        acc[b, _A_MAX] = max(acc[b, _A_MAX], x[b, 2], x[b, 3])
        acc[b, _A_Q1] = q1
        acc[b, _A_Q2] = q2
        r = -(cfg[_WT] * (abs(e1) + abs(e2)) / 10.0 + cfg[_WE] * P / 1.75)
        k += 1
        ctr[b, 0] = k
        out[b, 0] = r
        out[b, 1] = 1.0 if max(x[b, 0], x[b, 1]) > cfg[_TRIP] else 0.0
        out[b, 2] = 1.0 if k >= cfg[_HOR] else 0.0
    else:
        acc[b, _A_MAX] = max(x[b, 2], x[b, 3])
    cur = ctr[b, 1]
    z = noise[b, cur]
    ctr[b, 1] = cur + 1
    t_h = k * T / 3600.0
    s = sp[b, min(k // hold, nseg - 1)]
    obs[b, 0] = measure(x[b, 2], meas, 0, z[0], t_h)
    obs[b, 1] = measure(x[b, 3], meas, 1, z[1], t_h)
    obs[b, 2] = s[0]
    obs[b, 3] = s[1]
    obs[b, 4] = q1
    obs[b, 5] = q2
    sprev = sp[b, min(max(k - 1, 0) // hold, nseg - 1)]
    sig[b, 0] = x[b, 2]
    sig[b, 1] = x[b, 3]
    sig[b, 2] = sprev[0]
    sig[b, 3] = sprev[1]
    sig[b, 4] = x[b, 0]
    sig[b, 5] = x[b, 1]
    sig[b, 6] = q1
    sig[b, 7] = q2
    sig[b, 8] = Ta
    sig[b, 9] = r
    return 0


cache_depends_on(_tclab_row)
_TCLAB_KERNELS = plant_loops(_tclab_row)


class _TCLabEngine(Engine):
    name = ENV
    obs_names = _OBS
    obs_units = ("°C", "°C", "°C", "°C", "%", "%")
    sig_names = _SIG
    sig_units = ("°C", "°C", "°C", "°C", "°C", "°C", "%", "%", "°C", "1")
    noise_channels = _CH
    panels = (
        ("sensor 1 [°C]", ("T1", "T1_set")),
        ("sensor 2 [°C]", ("T2", "T2_set")),
        ("heaters [%]", ("Q1", "Q2")),
        ("reward", ("reward",)),
    )

    def __init__(self, B: int, cfg: TCLabConfig) -> None:
        env = ENV
        self.cfg = cfg
        T = self._period(env, cfg)
        self.ambient = check_range(env, "ambient_C", cfg.ambient_C, lo=-10.0, hi=50.0)
        w = parse_weights(env, cfg.reward_weights, DEFAULT_WEIGHTS)
        plant = resolve_plant(
            env,
            params=cfg.params,
            plant=cfg.plant,
            models=("tclab",),
            default=FIT_PATH if FIT_PATH.exists() else TCLabModel,
            rig=None,
        )
        super().__init__(B, plant, _NACC)
        self._setpoint(cfg)
        sens = parse_noise(env, cfg.sensor_noise, _CH, SENSORS, plant.sensors)
        lo, hi = self.obs_bounds()
        self.meas = meas_array(sens, lo, hi)
        self.cfgv = np.array(
            [
                T,
                TCLabModel.max_step,
                float(self._horizon),
                float(self.hold),
                w["tracking"],
                w["energy"],
                check_number(env, "temp_limit_C", cfg.temp_limit_C),
                check_number(env, "trip_C", cfg.trip_C),
            ]
        )
        self.x = np.zeros((B, 4))
        self.p = np.zeros((B, len(plant.model.param_names)))
        self.amb = np.zeros(B)
        self.sp = np.zeros((B, self.n_seg, 2))

    def _setpoint(self, cfg: TCLabConfig) -> None:
        env = ENV
        sp = cfg.setpoint
        self.sp_fixed: NDArray[np.float64] | None = None
        if isinstance(sp, str):
            if sp != "random":
                raise ConfigError(f"{env}: setpoint is {sp!r}; 'random', a pair or an array")
            self.sp_range = check_range(env, "setpoint_range", cfg.setpoint_range, lo=0.0, hi=100)
            hold_s = check_number(env, "setpoint_hold_s", cfg.setpoint_hold_s, lo=0.0, lo_open=True)
            self.hold = steps_of(env, "setpoint_hold_s", hold_s, self._dt)
            self.n_seg = -(-self._horizon // self.hold)
            return
        a = np.asarray(sp, dtype=float)
        if a.shape == (2,):
            a = a[None, :]
            self.hold, self.n_seg = self._horizon, 1
        elif a.ndim == 2 and a.shape[1] == 2 and a.shape[0] >= self._horizon:
            a = a[: self._horizon]
            self.hold, self.n_seg = 1, self._horizon
        else:
            raise ConfigError(
                f"{env}: setpoint has shape {a.shape}; expected (2,) or ({self._horizon}, 2)"
            )
        if not (np.isfinite(a).all() and (a >= 0).all() and (a <= 100).all()):
            raise ConfigError(f"{env}: setpoint values must be finite, within [0, 100] °C")
        self.sp_fixed = a.copy()

    def n_act(self) -> int:
        return 2

    def action_space(self) -> spaces.Space[Any]:
        return spaces.Box(-1.0, 1.0, (2,), dtype=np.float32)

    def obs_bounds(self) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
        lo = np.array([-10.0, -10.0, 0.0, 0.0, 0.0, 0.0], dtype=np.float32)
        hi = np.array([150.0, 150.0, 100.0, 100.0, 100.0, 100.0], dtype=np.float32)
        return lo, hi

    def _set_theta_row(self, b: int, theta: NDArray[np.float64]) -> None:
        self.p[b] = theta[0]

    def _reset_row(self, b: int, rng: np.random.Generator) -> None:
        Ta = draw(rng, self.ambient)
        self.amb[b] = Ta
        if self.sp_fixed is None:
            lo, hi = self.sp_range
            self.sp[b] = rng.uniform(lo, hi, (self.n_seg, 2)) if hi > lo else lo
        else:
            self.sp[b] = self.sp_fixed
        self.x[b] = Ta

    def _kernel(self, mode: int) -> int:
        return self._call(
            _TCLAB_KERNELS, mode, self.act, self.x, self.p, self.amb, self.sp, self.acc,
            self.ctr, self.noise, self.meas, self.cfgv, self.obs, self.out, self.sig,
        )  # fmt: skip

    def kpis(self, b: int) -> dict[str, float]:
        a = self.acc[b]
        k = self._steps_done(b)
        return {
            "actuator_energy_Wh": float(a[_A_E] / 3600.0),
            "temperature_rmse_K": float(math.sqrt(a[_A_SSE] / (2 * k))),
            "temperature_iae_K_s": float(a[_A_IAE]),
            "time_above_limit_h": float(a[_A_ABOVE] / 3600.0),
            "max_temperature_C": float(a[_A_MAX]),
            "episode_h": self._episode_h(b),
        }

    def trip_reason(self, b: int) -> str:
        return f"a heater exceeded trip_C = {self.cfgv[_TRIP]} °C"


class TCLabEnv(ThermoEnv):
    """Two-heater TCLab temperature control (``thermogym/TCLab-v0``).

    See the module docstring and :class:`TCLabConfig`.

    Examples
    --------
    >>> import gymnasium as gym
    >>> import numpy as np
    >>> import thermogym.envs
    >>> env = gym.make("thermogym/TCLab-v0", setpoint=(45.0, 35.0), sensor_noise=False)
    >>> obs, info = env.reset(seed=0)
    >>> for _ in range(900):  # a proportional controller on each heater
    ...     a = np.clip(0.5 * (obs[2:4] - obs[0:2]), -1.0, 1.0).astype(np.float32)
    ...     obs, r, terminated, truncated, info = env.step(a)
    >>> bool(abs(obs[0] - 45.0) < 5.0)
    True
    """

    env_name = ENV
    config_cls = TCLabConfig
    engine_cls = _TCLabEngine


class TCLabVectorEnv(ThermoVectorEnv):
    """``num_envs`` TCLab boards stepped by one compiled call (native vector env)."""

    single_env_cls = TCLabEnv
