"""Open-loop (feedforward) duty from an identified model's steady state.

Paper 002's PWM experiments (section VIII, Fig. 8) drive the actuator with a
*fixed* duty: open-loop PWM. In a benchmark, the duty of an open-loop PWM
controller is the one the identified model says holds the set-point — the
static inverse of the model:

* :class:`StaticMap` interpolates a tabulated steady-state characteristic
  (set-point → duty), e.g. the AXT211's valve stroke against the PWM duty,
  which is strongly nonlinear (no stroke below about 35 % duty at 24 V, full
  stroke above about 55 %: :func:`steady_state_map` tabulates it from an
  environment running the identified model);
* :class:`LinearFeedforward` inverts the steady-state gains of a linear model
  with measured disturbances — a weather-compensated heating curve when the
  model is ``T_zone`` from the duty and ``T_out``.

Neither uses the measurement: model error, supply voltage, ambient and the
actuator's specimen spread go uncorrected, which is what these controllers
are there to show.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from thermogym.controllers.base import Controller, EnvInfo, Loop, _num
from thermogym.controllers.linmodel import LinearPlant, linear_plant
from thermogym.errors import ConfigError

__all__ = ["LinearFeedforward", "StaticMap", "steady_state_map"]


class StaticMap(Controller):
    """Duty interpolated from a steady-state characteristic ``set-point → duty``.

    Parameters
    ----------
    setpoints : array_like
        Steady-state values of the measured variable, increasing.
    duties : array_like
        The duties that hold them, in [0, 1] (same length).
    source : str
        Provenance (recorded in the settings).
    loop : Loop, optional
        Loop whose set-point is looked up (default: the environment's).

    Examples
    --------
    >>> import gymnasium as gym
    >>> import thermogym.envs
    >>> ctrl = StaticMap([0.0, 4.5], [0.35, 0.55]).bind(gym.make("thermogym/AXT211Valve-v0"))
    >>> obs = np.array([0.0, 25.0, 25.0, 24.0, 2.25, 0.0])
    >>> round(ctrl.update(obs), 6)
    0.45
    """

    label = "static-map"

    def __init__(
        self,
        setpoints: ArrayLike,
        duties: ArrayLike,
        *,
        source: str = "given",
        loop: Loop | None = None,
        sample_time: float | None = None,
    ) -> None:
        super().__init__(loop=loop, sample_time=sample_time)
        x = np.asarray(setpoints, dtype=float).reshape(-1)
        u = np.asarray(duties, dtype=float).reshape(-1)
        if x.size < 2 or x.shape != u.shape:
            raise ConfigError(
                f"StaticMap: {x.size} set-points and {u.size} duties; expected two equal-length "
                "tables of at least 2 points"
            )
        if not (np.isfinite(x).all() and np.isfinite(u).all()):
            raise ConfigError("StaticMap: the tables hold non-finite values")
        if (np.diff(x) <= 0).any():
            raise ConfigError("StaticMap: set-points must be strictly increasing")
        if (u < 0).any() or (u > 1).any():
            raise ConfigError("StaticMap: duties must lie in [0, 1]")
        self.x, self.u = x, u
        self.source = source

    def _needs_measurement(self) -> bool:
        return False

    def update(self, obs: NDArray[np.float64]) -> float:
        """Duty for the current set-point (clamped at the table ends)."""
        return float(np.interp(self.setpoint(obs), self.x, self.u))

    def _settings(self) -> dict[str, Any]:
        return {"setpoints": self.x.tolist(), "duties": self.u.tolist(), "source": self.source}


class LinearFeedforward(Controller):
    """Static inverse of a linear model: the duty whose steady state is the set-point.

    ``u = u_op + (r − y_op − G_d (d − d_op)) / G_u`` with the model's
    steady-state gains ``G_u`` (duty) and ``G_d`` (measured disturbances).

    Parameters
    ----------
    model : LinearPlant, FOPTDModel, StateSpaceModel or FitResult
    disturbances : mapping, optional
        ``{model disturbance: observation name}``.
    input : str, optional
        The model's duty input.
    input_scale : float
        Model-input units per unit command.
    loop, sample_time
        See :class:`~thermogym.controllers.base.Controller`.
    """

    label = "linear-feedforward"

    def __init__(
        self,
        model: Any,
        *,
        disturbances: Mapping[str, str] | None = None,
        input: str | None = None,
        input_scale: float = 1.0,
        loop: Loop | None = None,
        sample_time: float | None = None,
    ) -> None:
        super().__init__(loop=loop, sample_time=sample_time)
        self.source = model
        self.dist_map = dict(disturbances or {})
        self.input = input
        self.input_scale = _num("LinearFeedforward", "input_scale", input_scale)
        if self.input_scale == 0:
            raise ConfigError("LinearFeedforward: input_scale is 0")
        self.plant: LinearPlant | None = None

    def _needs_measurement(self) -> bool:
        return False

    def _bind(self, info: EnvInfo) -> None:
        who = f"LinearFeedforward on {info.name}"
        dt = self.source.dt if isinstance(self.source, LinearPlant) else None
        try:
            lp = linear_plant(
                self.source, input=self.input, disturbances=list(self.dist_map), dt=dt
            )
        except ConfigError:
            lp = linear_plant(
                self.source, input=self.input, disturbances=list(self.dist_map), dt=self.h
            )
        self.plant = lp
        self._i_d = [info.index(self.dist_map[d], who) for d in lp.disturbances]

    def update(self, obs: NDArray[np.float64]) -> float:
        """Duty that holds the set-point in steady state at the measured disturbances."""
        lp = self.plant
        assert lp is not None
        d = np.array([obs[i] for i in self._i_d], dtype=float)
        return lp.inverse(self.setpoint(obs), d) / self.input_scale

    def _settings(self) -> dict[str, Any]:
        out: dict[str, Any] = {"disturbances": dict(self.dist_map)}
        if self.plant is not None:
            Gu, Gd = self.plant.dc_gain()
            out["model"] = {
                "gain_input": float(Gu[0, 0]),
                "gain_disturbances": Gd[0].tolist(),
                "y_op": float(self.plant.y_op[0]),
                "fingerprint": self.plant.fingerprint,
            }
        if self.input_scale != 1.0:
            out["input_scale"] = self.input_scale
        return out


def steady_state_map(
    make_env: Callable[[], Any],
    duties: Sequence[float],
    *,
    measurement: str,
    controller: Callable[[float], Controller],
    settle_s: float,
    average_s: float,
    seed: int = 0,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Tabulate the steady state of an environment's measurement against the duty.

    Each duty is applied open loop (through ``controller(duty)``, e.g. a
    :class:`~thermogym.controllers.pwm.PWM` at a given period) until
    ``settle_s`` and the measurement is averaged over the following
    ``average_s`` (a whole number of PWM periods averages out the ripple).

    Parameters
    ----------
    make_env : callable
        ``make_env() -> gymnasium.Env`` (the identified model, no sensor noise).
    duties : sequence of float
        Duties to apply, in [0, 1].
    measurement : str
        Observation name to tabulate.
    controller : callable
        ``controller(duty) -> Controller`` (open loop).
    settle_s, average_s : float
        Settling and averaging times [s].
    seed : int
        Reset seed.

    Returns
    -------
    duties, values : ndarray
        The duties and the mean measurement at each.
    """
    vals = []
    for d in duties:
        env = make_env()
        ctrl = controller(float(d)).bind(env)
        obs, _ = env.reset(seed=seed)
        ctrl.reset()
        i = env.get_wrapper_attr("obs_names").index(measurement)
        n_settle = round(settle_s / env.get_wrapper_attr("dt"))
        n_avg = round(average_s / env.get_wrapper_attr("dt"))
        acc = []
        for k in range(n_settle + n_avg):
            obs, _, term, trunc, _ = env.step(ctrl.act(obs))
            if k >= n_settle:
                acc.append(float(obs[i]))
            if term or trunc:
                raise ConfigError(
                    f"steady_state_map: the episode ended after {k + 1} steps; make it longer "
                    f"than settle_s + average_s = {settle_s + average_s} s"
                )
        vals.append(float(np.mean(acc)))
    return np.asarray(duties, dtype=float), np.asarray(vals)
