"""Optimum start: raise a schedule's set-point ahead of occupancy.

A room thermostat that follows a night setback reacts only when the
occupied set-point appears, at the start of occupancy. A water-heated room
recovers slowly — on ``AXT211Room`` in January about 0.6-0.7 K/h with the
valve fully open (17.0 → 20.3 °C in 5 h, on/off thermostat, benchmark
``winter-week@1``) — so every reactive controller, however tuned, starts the
occupied day several kelvin below the comfort band. Building automation
solves this with *optimum start* (EN 12098-2, optimum start-stop control
equipment for hot water heating systems): the occupied set-point is applied
early by the time the room needs to recover::

    lead = (r_occ − T_zone) / rate                    recovery time [h]
    r_k  = r_occ   from the first t_k with 0 < t_occ − t_k <= lead until t_occ

(latched: once the preheat has begun it holds until occupancy, or the
shrinking lead of a warming room would switch it off and on again), with
``t_occ`` the next start of occupancy and ``rate`` the recovery rate of the
room at full heat. :class:`OptimumStart` wraps any controller of a loop whose
set-point is an observation (``T_set``) and hands it the observation with
that set-point replaced; the wrapped controller is not changed. It reads the
occupancy schedule of the environment's keyword arguments
(:class:`~thermogym.controllers.mpc.SchedulePreview`), the same
preview the room MPC gets.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from thermogym.controllers.base import Controller, EnvInfo, _num
from thermogym.controllers.mpc import SchedulePreview
from thermogym.errors import ConfigError

__all__ = ["OptimumStart"]


class OptimumStart(Controller):
    """Apply the occupied set-point early by the room's recovery time.

    Parameters
    ----------
    inner : Controller
        The controller that follows the set-point (any: on/off, PWM + PID,
        open-loop PWM); it sees the observation with the set-point entry
        replaced.
    schedule : SchedulePreview
        Occupancy schedule and set-points of the episode.
    rate_K_per_h : float
        Recovery rate of the room at full heat [K/h].
    max_lead_h : float
        Longest preheat [h] (a cold room after a weekend).

    Examples
    --------
    >>> import gymnasium as gym
    >>> import thermogym.envs
    >>> from thermogym.controllers import OnOff, SchedulePreview
    >>> env = gym.make("thermogym/AXT211Room-v0", start_day=14, control_period=600.0)
    >>> ctrl = OptimumStart(OnOff(0.5), SchedulePreview(start_day=14)).bind(env)
    >>> obs = np.array([18.0, 17.0, 0.0, 0.0, 16.0, 28.0, 0.0, 1.0, 0.0])  # 18 °C at night
    >>> ctrl.effective_setpoint(obs, t=1.0 * 3600.0)  # Monday 1:00: 6 h ahead > 3 K / 0.6 K/h
    17.0
    >>> ctrl.effective_setpoint(obs, t=3.0 * 3600.0)  # 3:00: 4 h ahead <= 5 h: preheat
    21.0
    """

    kind = "any"
    label = "optimum-start"

    def __init__(
        self,
        inner: Controller,
        schedule: SchedulePreview,
        *,
        rate_K_per_h: float = 0.6,
        max_lead_h: float = 10.0,
    ) -> None:
        super().__init__(loop=inner.loop if isinstance(inner, Controller) else None)
        who = "OptimumStart"
        if not isinstance(inner, Controller):
            raise ConfigError(f"{who}: inner is {inner!r:.60}; expected a Controller")
        if not isinstance(schedule, SchedulePreview):
            raise ConfigError(f"{who}: schedule is {schedule!r:.60}; expected a SchedulePreview")
        self.inner = inner
        self.schedule = schedule
        self.rate = _num(who, "rate_K_per_h", rate_K_per_h, lo=1e-6)
        self.max_lead_h = _num(who, "max_lead_h", max_lead_h, lo=0.0)
        self._steps = 0
        self._n_pre = 0
        self._until = -math.inf

    def _bind(self, info: EnvInfo) -> None:
        if self._i_r < 0:
            raise ConfigError(
                f"OptimumStart on {info.name}: the loop's set-point {self.bound_loop.setpoint!r} "
                "is a constant, not an observation; there is no schedule to preheat for"
            )
        if self.inner.loop is None:
            self.inner.loop = self.bound_loop
        self.inner.bind(info)

    def _reset(self, seed: int | None) -> None:
        self._steps = 0
        self._n_pre = 0
        self._until = -math.inf
        if self.inner._info is not None:
            self.inner.reset(seed=seed)

    def time_to_occupancy(self, t: float) -> float:
        """Seconds from episode time ``t`` to the next start of occupancy (inf: none ahead).

        0 while the room is occupied; resolved to 60 s, searched up to ``max_lead_h``.
        """
        if bool(self.schedule.occupied(np.array([t]))[0]):
            return 0.0
        grid = t + 60.0 * np.arange(1, int(self.max_lead_h * 60.0) + 1)
        occ = self.schedule.occupied(grid)
        if not occ.any():
            return math.inf
        return float(grid[int(np.argmax(occ))] - t)

    def effective_setpoint(self, obs: ArrayLike, t: float) -> float:
        """The set-point handed to the inner controller at episode time ``t`` [s].

        A preheat, once begun, is latched until the occupancy it heats for starts.
        """
        o = np.asarray(obs, dtype=np.float64)
        r = float(o[self._i_r])
        r_occ = self.schedule.sp[0]
        if r >= r_occ:
            return r
        if t < self._until:
            return r_occ
        t_occ = self.time_to_occupancy(t)
        lead_s = max(r_occ - float(o[self._i_y]), 0.0) / self.rate * 3600.0
        if 0.0 < t_occ <= min(lead_s, self.max_lead_h * 3600.0):
            self._until = t + t_occ
            return r_occ
        return r

    def _shifted(self, obs: ArrayLike) -> NDArray[np.float64]:
        o = np.array(obs, dtype=np.float64)
        r = self.effective_setpoint(o, self._steps * self.info.dt)
        if r != o[self._i_r]:
            self._n_pre += 1
            o[self._i_r] = r
        return o

    def update(self, obs: NDArray[np.float64]) -> float:
        """The inner controller's command for the shifted set-point (when nested)."""
        u = self.inner.command(self._shifted(obs))
        self._steps += 1
        return u

    def act(self, obs: ArrayLike) -> Any:
        """The inner controller's action for the observation with the shifted set-point."""
        if self._info is None:
            raise ConfigError("OptimumStart is not bound; call bind(env) first")
        a = self.inner.act(self._shifted(obs))
        self._steps += 1
        self._k += 1
        return a

    def _settings(self) -> dict[str, Any]:
        s = self.schedule
        return {
            "rate_K_per_h": self.rate,
            "max_lead_h": self.max_lead_h,
            "schedule": {
                "start_s": s.t0,
                "occupied_hours": list(s.occ),
                "occupied_days": s.days,
                "setpoints_C": list(s.sp),
            },
            "inner": self.inner.settings(),
        }

    def stats(self) -> dict[str, float]:
        """``preheat_h``: hours with the set-point raised early, and the inner controller's."""
        return {"preheat_h": self._n_pre * self.info.dt / 3600.0, **self.inner.stats()}
