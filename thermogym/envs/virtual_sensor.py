"""Virtual-sensor observation wrapper: controllers see estimated instead of true hidden states.

Description
-----------
Paper 001 (section 3.3) computes a spindle's internal temperatures, which no
sensor can reach, from its surface temperatures with an identified model.
:class:`VirtualSensorObservation` puts such an estimator between an
environment and its controller: after every reset and step it feeds the
estimator with the channels it reads from the observation (or the info, or the
action) and writes the estimates into the observation — over entries that are
there (``targets``), or appended as new entries when the environment hides
them. With ``mode="truth"`` the same slots carry the true values instead, so
one controller can be compared on true and on estimated state with identical
observation spaces.

The wrapper is generic: channels are given by observation index, observation
name (``observation_names`` or the environment's ``obs_names``) or a callable
``(obs, info, action) -> float``. The estimator is any object with
``input_names``, ``measured_names``, ``output_names``, ``reset(u, z)`` and
``update(u_prev, u, z)`` returning the estimates —
:class:`~thermogym.estimation.SteadyStateObserver` (from
:meth:`VirtualSensor.step_observer`, use :meth:`VirtualSensor.at_period` to
match the control period) or :class:`~thermogym.estimation.AXT211WaxUKF`.

Info
----
``info["virtual_sensor"]``: ``{"estimate": {name: value}, "truth": {name:
value} (when known), "error": {name: estimate − truth}, "mode": ...}``. The
truth comes from ``truth(env)`` — by default the environment's
``true_outputs()`` when it has one, else the observation's own entries that
are replaced.

Examples
--------
>>> import gymnasium as gym
>>> import numpy as np
>>> import thermogym.envs
>>> from thermogym.firmware.reference import spindle_reference_model
>>> from thermogym.estimation import VirtualSensor
>>> env = gym.make("thermogym/SpindleThermal-v0")
>>> model = spindle_reference_model("1I7O", order=8, dt=1.0)
>>> vs = VirtualSensor(model, measured=["T_front_outer_housing", "T_rear_outer_housing"],
...                    measurement_std=0.02).at_period(env.unwrapped.dt)
>>> wrapped = VirtualSensorObservation(env, vs.step_observer(), inputs={"speed": "speed_prev"},
...                                    rest={"speed": 0.0})
>>> obs, info = wrapped.reset(seed=0)
>>> wrapped.observation_names[-1], obs.shape
('T_inner_housing', (9,))
>>> obs, *_, info = wrapped.step(np.ones(1, np.float32))
>>> sorted(info["virtual_sensor"])
['error', 'estimate', 'mode', 'truth']
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from thermogym.errors import ConfigError, ShapeError, UnknownNameError

__all__ = ["VirtualSensorObservation"]

Source = int | str | Callable[[Any, Mapping[str, Any], Any], float]
_MODES = ("estimate", "truth")


def _true_outputs(env: Any) -> Any:
    # the wrapped environment's noise-free signals (a thermogym environment's own method)
    return env.unwrapped.true_outputs()


class VirtualSensorObservation(gym.Wrapper, gym.utils.RecordConstructorArgs):
    """Write virtual-sensor estimates (or the truth) into the observation.

    Parameters
    ----------
    env : gymnasium.Env
        Environment with a 1-D ``Box`` observation space.
    estimator : object
        Step estimator (see the module docstring); its sample period must be
        the environment's control period when both declare ``dt``.
    inputs : mapping, optional
        Source of each estimator input ``{name: index | observation name |
        callable}``; an input left out is looked up by its own name among the
        observation names.
    measured : mapping, optional
        Sources of the measured channels, likewise.
    targets : mapping, optional
        ``{estimate name: index | observation name}`` of entries to overwrite.
        By default an estimate whose name is an observation name replaces that
        entry; the others are appended.
    observation_names : sequence of str, optional
        Names of the observation entries (default: ``env.unwrapped.obs_names``).
    mode : {"estimate", "truth"}
        What the controller sees in the target slots.
    truth : callable, optional
        ``truth(env) -> {name: value}``; default: ``env.unwrapped.true_outputs()``.
    rest : mapping, optional
        Input values for the estimator's start at reset (``{"speed": 0.0}``:
        the machine was at rest).
    inputs_from : {"new", "previous"}
        Read the inputs held over a step from the observation after the step
        (default; e.g. a ``speed_prev`` entry) or from the one before it.
    bounds : (float, float)
        Observation-space bounds of appended estimates (default: the RTD
        range −50..300 °C of paper 001, the estimates being temperatures);
        estimates are clipped to them.

    Raises
    ------
    ConfigError
        Unknown mode, a period mismatch, a non-Box observation space.
    UnknownNameError
        A channel cannot be found among the observation names.
    """

    def __init__(
        self,
        env: gym.Env,
        estimator: Any,
        *,
        inputs: Mapping[str, Source] | None = None,
        measured: Mapping[str, Source] | None = None,
        targets: Mapping[str, int | str] | None = None,
        observation_names: Sequence[str] | None = None,
        mode: str = "estimate",
        truth: Callable[[gym.Env], Mapping[str, float]] | None = None,
        rest: Mapping[str, float] | None = None,
        inputs_from: str = "new",
        bounds: tuple[float, float] = (-50.0, 300.0),
    ) -> None:
        gym.utils.RecordConstructorArgs.__init__(
            self,
            estimator=estimator,
            inputs=inputs,
            measured=measured,
            targets=targets,
            observation_names=observation_names,
            mode=mode,
            truth=truth,
            rest=rest,
            inputs_from=inputs_from,
            bounds=bounds,
        )
        gym.Wrapper.__init__(self, env)
        if mode not in _MODES:
            raise ConfigError(f"mode is {mode!r}; expected one of {_MODES}")
        if inputs_from not in ("new", "previous"):
            raise ConfigError(f"inputs_from is {inputs_from!r}; expected 'new' or 'previous'")
        space = env.observation_space
        if not isinstance(space, spaces.Box) or len(space.shape) != 1:
            raise ConfigError(
                f"the observation space is {space}; the virtual-sensor wrapper needs a 1-D Box"
            )
        names = observation_names
        if names is None:
            names = getattr(env.unwrapped, "obs_names", None)
        self._names = tuple(names) if names is not None else ()
        if self._names and len(self._names) != space.shape[0]:
            raise ShapeError(
                f"{len(self._names)} observation names for an observation of size {space.shape[0]}"
            )
        env_dt = getattr(env.unwrapped, "dt", None)
        est_dt = getattr(estimator, "dt", None)
        if (
            env_dt is not None
            and est_dt is not None
            and abs(float(env_dt) - float(est_dt)) > 1e-9 * max(1.0, float(env_dt))
        ):
            raise ConfigError(
                f"the estimator runs every {est_dt!r} s, the environment's control period is "
                f"{env_dt!r} s; resample it (VirtualSensor.at_period({env_dt!r}))"
            )
        self.estimator = estimator
        self.mode = mode
        self.rest = dict(rest or {})
        self.inputs_from = inputs_from
        self._truth_fn = truth
        ins = dict(inputs or {})
        meas = dict(measured or {})
        for what, given, wanted in (
            ("input", ins, estimator.input_names),
            ("measured channel", meas, estimator.measured_names),
        ):
            extra = [k for k in given if k not in wanted]
            if extra:
                raise UnknownNameError(
                    f"{what} source(s) given for {extra}, which the estimator does not use; it "
                    f"needs {list(wanted)}"
                )
        self._in_src = [self._source(n, ins.get(n, n)) for n in estimator.input_names]
        self._z_src = [self._source(n, meas.get(n, n)) for n in estimator.measured_names]
        unknown = [k for k in (rest or {}) if k not in estimator.input_names]
        if unknown:
            raise UnknownNameError(
                f"rest values given for {unknown}; estimator inputs are "
                f"{list(estimator.input_names)}"
            )
        # where every estimate goes
        tg = dict(targets or {})
        bad = [k for k in tg if k not in estimator.output_names]
        if bad:
            raise UnknownNameError(
                f"targets given for {bad}; the estimator's outputs are "
                f"{list(estimator.output_names)}"
            )
        size = space.shape[0]
        self._slots: list[int] = []
        appended: list[str] = []
        for name in estimator.output_names:
            if name in tg:
                self._slots.append(self._index(name, tg[name]))
            elif name in self._names:
                self._slots.append(self._names.index(name))
            else:
                self._slots.append(size + len(appended))
                appended.append(name)
        lo = np.concatenate([space.low, np.full(len(appended), bounds[0])]).astype(space.dtype)
        hi = np.concatenate([space.high, np.full(len(appended), bounds[1])]).astype(space.dtype)
        self.observation_space = spaces.Box(lo, hi, dtype=space.dtype)  # type: ignore[arg-type]
        self.observation_names = (*self._names, *appended) if self._names else ()
        self._prev: tuple[Any, Mapping[str, Any]] = (None, {})

    # ----------------------------------------------------------------- helpers
    def _index(self, what: str, where: int | str) -> int:
        size = self.env.observation_space.shape[0]  # type: ignore[index]
        if isinstance(where, int | np.integer) and not isinstance(where, bool):
            if not 0 <= int(where) < size:
                raise ShapeError(f"index {where} of {what!r} outside the observation (size {size})")
            return int(where)
        if isinstance(where, str):
            if where not in self._names:
                raise UnknownNameError(
                    f"{what!r}: {where!r} is not an observation name; names are "
                    f"{list(self._names) or '(none given: pass observation_names)'}"
                )
            return self._names.index(where)
        raise ConfigError(f"source of {what!r} is {where!r}; expected an index or a name")

    def _source(self, what: str, where: Source) -> Callable[[Any, Mapping[str, Any], Any], float]:
        if callable(where):
            return where
        i = self._index(what, where)

        def read(obs: Any, info: Mapping[str, Any], action: Any) -> float:
            return float(obs[i])

        return read

    @staticmethod
    def _read(srcs: Sequence[Callable[..., float]], obs: Any, info: Any, action: Any) -> NDArray:
        return np.array([f(obs, info, action) for f in srcs], dtype=float)

    def _truth(self, obs: NDArray[np.float64]) -> dict[str, float]:
        fn = self._truth_fn
        if fn is None and hasattr(self.env.unwrapped, "true_outputs"):
            fn = _true_outputs
        out: dict[str, float] = {}
        if fn is not None:
            vals = fn(self.env)
            out = {k: float(vals[k]) for k in self.estimator.output_names if k in vals}
        size = self.env.observation_space.shape[0]  # type: ignore[index]
        for name, slot in zip(self.estimator.output_names, self._slots, strict=True):
            if name not in out and slot < size:
                out[name] = float(obs[slot])
        return out

    def _observe(self, obs: Any, est: NDArray[np.float64], info: dict[str, Any]) -> Any:
        base = np.asarray(obs, dtype=float)
        truth = self._truth(base)
        size = base.shape[0]
        new = np.concatenate([base, np.zeros(len(self._slots))])[: self.observation_space.shape[0]]  # type: ignore[index]
        names = self.estimator.output_names
        estimate = {n: float(v) for n, v in zip(names, est, strict=True)}
        for name, slot in zip(names, self._slots, strict=True):
            if self.mode == "estimate":
                new[slot] = estimate[name]
            elif name in truth:
                new[slot] = truth[name]
            elif slot >= size:
                raise ConfigError(
                    f"mode 'truth' but the truth of {name!r} is unknown; pass truth=callable"
                )
        info["virtual_sensor"] = {
            "mode": self.mode,
            "estimate": estimate,
            "truth": truth,
            "error": {k: estimate[k] - truth[k] for k in estimate if k in truth},
        }
        space = self.observation_space
        return np.clip(new, space.low, space.high).astype(space.dtype)  # type: ignore[attr-defined]

    # -------------------------------------------------------------- gym API
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        """Reset the environment and start the estimator from its first readings."""
        obs, info = self.env.reset(seed=seed, options=options)
        info = dict(info)
        u = self._read(self._in_src, obs, info, None)
        z = self._read(self._z_src, obs, info, None)
        for name, value in self.rest.items():
            u[self.estimator.input_names.index(name)] = float(value)
        est = np.asarray(self.estimator.reset(u, z), dtype=float)
        self._prev = (obs, info)
        return self._observe(obs, est, info), info

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        """Step the environment, then propagate and correct the estimator."""
        obs, reward, terminated, truncated, info = self.env.step(action)
        info = dict(info)
        src_obs, src_info = (obs, info) if self.inputs_from == "new" else self._prev
        u_prev = self._read(self._in_src, src_obs, src_info, action)
        u = self._read(self._in_src, obs, info, action)
        z = self._read(self._z_src, obs, info, action)
        est = np.asarray(self.estimator.update(u_prev, u, z), dtype=float)
        self._prev = (obs, info)
        return self._observe(obs, est, info), reward, terminated, truncated, info
