"""On/off control with hysteresis: the room thermostat, and on/off of the actuator supply.

An on/off controller switches the actuator fully on or fully off. With
hysteresis (a "two-point controller") it switches on when the measurement
falls to the lower threshold and off when it rises to the upper one, and keeps
its state in between::

    on  when  y ≤ r − h_below      (direct acting: more actuation raises y)
    off when  y ≥ r + h_above
    otherwise: unchanged

For the AXT211 this *is* the manufacturer's recommended "on-off operation"
(``002_dae2310635fe074e.txt``, section VIII: "Controllers should operate
AXT211 at f_PWM low, also called on-off operation"): the supply is switched
on until the valve is fully open and off until it is fully shut, so the
actuator's spread (section VIII, Fig. 8) affects only the timing, not the
valve position. Optional minimum on and off times keep the switching period
above the actuator's opening and closing times (about 5 and 6 min at 25 °C),
so that every switch-on is a full stroke (``min_on_s``/``min_off_s``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from thermogym.controllers.base import Controller, Loop, _num
from thermogym.errors import ConfigError

__all__ = ["OnOff"]


class OnOff(Controller):
    """Two-point controller with hysteresis and optional minimum on/off times.

    Parameters
    ----------
    hysteresis : float
        Width of the switching band (unit of the measurement); the
        thresholds are ``r − hysteresis/2`` and ``r + hysteresis/2`` unless
        ``band`` is given.
    band : (float, float), optional
        ``(h_below, h_above)``: switch on at ``r − h_below``, off at
        ``r + h_above`` (both ≥ 0; they replace ``hysteresis``).
    min_on_s, min_off_s : float
        Shortest time the actuator stays on / off after a switch [s]
        (anti-short-cycling; rounded up to whole sample times).
    initially_on : bool
        State at the start of an episode.
    loop : Loop, optional
        Loop to close (default: the environment's).
    sample_time : float, optional
        Seconds between two decisions (default: the control period).

    Notes
    -----
    Switching is exactly at the thresholds: ``y ≤ r − h_below`` switches on
    (inclusive), ``y ≥ r + h_above`` switches off. With ``direct=False`` in
    the loop (cooling) the roles swap.

    Examples
    --------
    >>> import gymnasium as gym
    >>> import thermogym.envs
    >>> env = gym.make("thermogym/AXT211Room-v0", action_mode="onoff", start_day=10)
    >>> ctrl = OnOff(hysteresis=0.5).bind(env)
    >>> obs, info = env.reset(seed=0)
    >>> ctrl.reset()
    >>> done = False
    >>> while not done:
    ...     obs, r, terminated, truncated, info = env.step(ctrl.act(obs))
    ...     done = terminated or truncated
    >>> info["kpis"]["switch_cycles"] > 10
    True
    """

    kind = "binary"
    label = "onoff"

    def __init__(
        self,
        hysteresis: float = 0.5,
        *,
        band: tuple[float, float] | None = None,
        min_on_s: float = 0.0,
        min_off_s: float = 0.0,
        initially_on: bool = False,
        loop: Loop | None = None,
        sample_time: float | None = None,
    ) -> None:
        super().__init__(loop=loop, sample_time=sample_time)
        who = "OnOff"
        if band is None:
            h = _num(who, "hysteresis", hysteresis, lo=0.0)
            self.h_below = self.h_above = h / 2.0
        else:
            if len(band) != 2:
                raise ConfigError(f"{who}: band is {band!r}; expected (h_below, h_above)")
            self.h_below = _num(who, "band[0]", band[0], lo=0.0)
            self.h_above = _num(who, "band[1]", band[1], lo=0.0)
        self.hysteresis = self.h_below + self.h_above
        self.band = band
        self.min_on_s = _num(who, "min_on_s", min_on_s, lo=0.0)
        self.min_off_s = _num(who, "min_off_s", min_off_s, lo=0.0)
        self.initially_on = bool(initially_on)
        self._on = self.initially_on
        self._since = math.inf
        self._n_on = 0
        self._n_off = 0

    def _bind(self, info: Any) -> None:
        # minimum times in samples, rounded up
        self._n_on = math.ceil(self.min_on_s / self.h - 1e-9)
        self._n_off = math.ceil(self.min_off_s / self.h - 1e-9)

    def _reset(self, seed: int | None) -> None:
        self._on = self.initially_on
        self._since = math.inf  # no dwell constraint at the start

    def thresholds(self, r: float) -> tuple[float, float]:
        """Switch-on and switch-off thresholds for set-point ``r``."""
        if self.bound_loop.direct:
            return r - self.h_below, r + self.h_above
        return r + self.h_above, r - self.h_below

    def update(self, obs: NDArray[np.float64]) -> float:
        """Switch at the thresholds, respecting the minimum on/off times."""
        y = self.measurement(obs)
        y_on, y_off = self.thresholds(self.setpoint(obs))
        direct = self.bound_loop.direct
        self._since += 1
        if self._on:
            leave = y >= y_off if direct else y <= y_off
            if leave and self._since >= self._n_on:
                self._on, self._since = False, 0
        else:
            enter = y <= y_on if direct else y >= y_on
            if enter and self._since >= self._n_off:
                self._on, self._since = True, 0
        return 1.0 if self._on else 0.0

    @property
    def is_on(self) -> bool:
        """The current switch state."""
        return self._on

    def _settings(self) -> dict[str, Any]:
        out: dict[str, Any] = {"hysteresis": self.hysteresis}
        if self.band is not None:
            out["band"] = [self.h_below, self.h_above]
        if self.min_on_s or self.min_off_s:
            out["min_on_s"] = self.min_on_s
            out["min_off_s"] = self.min_off_s
        if self.initially_on:
            out["initially_on"] = True
        return out
