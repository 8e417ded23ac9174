"""Pulse-width modulation: open loop, and as the output stage of other controllers.

A PWM output stage turns a duty cycle ``d`` in [0, 1] into heater on/off
times: at the start of every PWM period ``P`` the duty is latched (a fixed
``duty`` — open loop — or the command of an ``inner`` controller, which then
runs once per PWM period) and the heater is on for ``d·P``, off for the rest.
The environment's actions are per control period ``Δt`` (P must be a whole
number of them): the step that contains the end of the pulse gets the
fraction of ``Δt`` still on as its duty (the environments apply that duty as
on-at-the-start, so the pulse is exact); with on/off actions the on-time is
rounded to whole control periods.

PWM frequencies (``002_dae2310635fe074e.txt``, section VIII and Fig. 8)
---------------------------------------------------------------------------
The paper drove 15 actuators with 50 % PWM at a high, a medium and a low
frequency and found the actuators' spread large at high and medium
frequency; "controllers should operate AXT211 at f_PWM low, also called
on-off operation". The paper does not give the frequencies; the virtual rig's
``pwm``/``spread`` protocols use periods of 10 s, 2 min and 20 min, and so
does :data:`PWM_PERIODS`. At 10 s the wax integrates the pulses and the
actuator behaves like a proportional one whose stroke depends steeply on the
duty, the supply voltage and the specimen; at 20 min every pulse is a full
open-close stroke.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from thermogym._checks import positive
from thermogym.controllers.base import Controller, EnvInfo, Loop, _num, whole_periods
from thermogym.errors import ConfigError

__all__ = ["PWM", "PWM_PERIODS"]

#: PWM periods [s] of the high, medium and low frequency of paper 002 section VIII
#: (as the AXT211 rig's ``pwm`` protocol; "low" is the on-off operation).
PWM_PERIODS: dict[str, float] = {"high": 10.0, "medium": 120.0, "low": 1200.0}


class PWM(Controller):
    """PWM at a chosen period: fixed duty (open loop) or an inner controller's duty.

    Parameters
    ----------
    period : float or {"high", "medium", "low"}
        PWM period [s], a whole number of control periods (or a name of
        :data:`PWM_PERIODS`).
    duty : float, optional
        Fixed duty cycle in [0, 1] (open loop).
    inner : Controller, optional
        Controller whose command (a duty in [0, 1]) is latched at the start of
        every PWM period; it runs with ``sample_time = period``. Exactly one of
        ``duty`` and ``inner``.
    min_pulse_s : float
        Shortest on or off pulse [s]: a shorter on-time becomes 0, a shorter
        off-time makes the heater stay on for the whole period.
    loop : Loop, optional
        Loop of the inner controller (default: the environment's).

    Examples
    --------
    Open-loop PWM at 50 % with a 2-minute period on a 10-s environment:

    >>> import gymnasium as gym
    >>> import thermogym.envs
    >>> env = gym.make("thermogym/AXT211Valve-v0")
    >>> pwm = PWM(period=120.0, duty=0.5).bind(env)
    >>> obs, _ = env.reset(seed=0)
    >>> [float(pwm.command(obs)) for _ in range(12)]
    [1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]

    As the output stage of a PID controller, on on/off actions:

    >>> from thermogym.controllers import PID
    >>> env = gym.make("thermogym/AXT211Valve-v0", action_mode="onoff")
    >>> ctrl = PWM("medium", inner=PID(kp=0.1, ti=300.0)).bind(env)
    >>> ctrl.inner.h  # the PID runs once per PWM period
    120.0
    """

    kind = "any"
    label = "pwm"

    def __init__(
        self,
        period: float | str,
        duty: float | None = None,
        *,
        inner: Controller | None = None,
        min_pulse_s: float = 0.0,
        loop: Loop | None = None,
    ) -> None:
        super().__init__(loop=loop)
        who = "PWM"
        if isinstance(period, str):
            if period not in PWM_PERIODS:
                raise ConfigError(
                    f"{who}: period is {period!r}; expected seconds or one of {list(PWM_PERIODS)}"
                )
            self.frequency: str | None = period
            period = PWM_PERIODS[period]
        else:
            self.frequency = None
        self.period = positive(f"{who}: period", period, unit="s", error=ConfigError, text=False)
        if (duty is None) == (inner is None):
            raise ConfigError(
                f"{who}: give exactly one of duty (open loop) and inner (a controller)"
            )
        self.duty = None if duty is None else _num(who, "duty", duty, lo=0.0, hi=1.0)
        if inner is not None and not isinstance(inner, Controller):
            raise ConfigError(f"{who}: inner is {inner!r:.60}; expected a Controller")
        if isinstance(inner, PWM):
            raise ConfigError(f"{who}: inner is another PWM stage; nest a controller instead")
        self.inner = inner
        self.min_pulse_s = _num(who, "min_pulse_s", min_pulse_s, lo=0.0)
        self._n = 1
        self._j = 0
        self._t_on = 0.0
        self._d = 0.0

    def _default_loop(self, info: EnvInfo) -> Loop:
        if self.inner is not None and self.inner.loop is not None:
            return self.inner.loop
        return super()._default_loop(info)

    def _needs_measurement(self) -> bool:
        return self.inner is not None  # the inner controller's loop

    def _needs_setpoint(self) -> bool:
        return self.inner is not None

    def _bind(self, info: EnvInfo) -> None:
        who = f"PWM on {info.name}"
        if self.period < info.dt * (1 - 1e-9):
            raise ConfigError(
                f"{who}: period {self.period!r} s is shorter than the control period {info.dt} s; "
                "the environment applies one duty per control period (its own PWM): use "
                f"period={info.dt}"
            )
        self._n = whole_periods(who, "period", self.period, info.dt)
        if self.inner is not None:
            if self.inner.loop is None:
                self.inner.loop = self.bound_loop
            self.inner.bind(info, sample_time=self.period, inner=True)

    def _reset(self, seed: int | None) -> None:
        self._j = 0
        self._t_on = 0.0
        self._d = 0.0
        if self.inner is not None and self.inner._info is not None:
            self.inner.reset(seed=seed)

    def latch(self, obs: NDArray[np.float64]) -> float:
        """The duty of the PWM period starting now (fixed or from the inner controller)."""
        if self.inner is None:
            return float(self.duty)  # type: ignore[arg-type]
        d = float(self.inner.update(obs))
        if not math.isfinite(d):
            return 0.0 if not math.isfinite(self._d) else self._d
        return min(max(d, 0.0), 1.0)

    def update(self, obs: NDArray[np.float64]) -> float:
        """Duty of this control period: on-time remaining, as a fraction of ``Δt``."""
        dt = self.info.dt
        if self._j == 0:
            d = self.latch(obs)
            self._d = d
            t_on = d * self.period
            if t_on < self.min_pulse_s:
                t_on = 0.0
            elif self.period - t_on < self.min_pulse_s:
                t_on = self.period
            if self.info.discrete:
                t_on = round(t_on / dt) * dt  # whole control periods for on/off actions
            self._t_on = t_on
        u = min(max((self._t_on - self._j * dt) / dt, 0.0), 1.0)
        if self.info.discrete:
            u = 1.0 if u >= 0.5 else 0.0
        self._j = (self._j + 1) % self._n
        return u

    @property
    def last_duty(self) -> float:
        """Duty latched for the current PWM period."""
        return self._d

    def _settings(self) -> dict[str, Any]:
        out: dict[str, Any] = {"period_s": self.period}
        if self.frequency is not None:
            out["frequency"] = self.frequency
        if self.duty is not None:
            out["duty"] = self.duty
        if self.inner is not None:
            out["inner"] = self.inner.settings()
        if self.min_pulse_s:
            out["min_pulse_s"] = self.min_pulse_s
        return out

    def stats(self) -> dict[str, float]:
        """Stats of the inner controller."""
        return {} if self.inner is None else self.inner.stats()
