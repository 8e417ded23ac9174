"""Machinery shared by every thermogym environment, single and vectorised.

Design
------
Each plant has an :class:`Engine`: the batched state of ``B`` copies of the
plant (states, kernel parameters, disturbance tables, KPI accumulators,
pre-drawn sensor noise) and one compiled *step kernel* that advances all of
them, measures, accumulates the KPIs and computes the rewards in a single
call. The kernel calls the models' own compiled step functions
(:mod:`thermogym.models`), so environment and identification run the same
equations. :class:`ThermoEnv` is a Gymnasium environment around an engine
with ``B = 1``; :class:`ThermoVectorEnv` a native vector environment around
one with ``B = num_envs`` — every sub-environment is the same computation as
a single environment with the same seed, only batched.

Per step, the Python side does no validation beyond what the kernel reports,
allocates only the returned observation and info, and calls one kernel: that
is what keeps a single environment faster than Gymnasium's ``Pendulum-v1``.

Randomness
----------
Every draw comes from the environment's ``np_random`` (one generator per
sub-environment in the vector version, seeded ``seed + i`` like Gymnasium's
``SyncVectorEnv``), in a fixed order at reset: parameters (domain
randomisation), episode conditions (disturbances, set-points), then a block of
:data:`NOISE_BLOCK` standard normal vectors for the sensors, refilled from the
same generator when used up.
"""

from __future__ import annotations

import logging
import math
import os
import tempfile
from collections.abc import Callable, Mapping, Sequence
from dataclasses import fields
from pathlib import Path
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode
from gymnasium.vector.utils import batch_space
from numpy.typing import NDArray

from thermogym._checks import in_range
from thermogym.envs._plant import ParamsLike, Plant, is_overrides, load_params, make_sampler
from thermogym.errors import ConfigError, ShapeError, SimulationError
from thermogym.fitresult import FitResult

__all__ = [
    "NOISE_BLOCK",
    "Engine",
    "ThermoEnv",
    "ThermoVectorEnv",
    "check_number",
    "check_range",
    "parse_weights",
]

log = logging.getLogger("thermogym.envs")

#: Sensor-noise vectors drawn per refill (per sub-environment).
NOISE_BLOCK = 128
# columns of Engine.ctr
C_K, C_CUR, C_NTP, C_STATUS = 0, 1, 2, 3
# columns of Engine.out
O_REW, O_TERM, O_TRUNC = 0, 1, 2
# kernel status codes (returned by the step kernels)
ST_OK, ST_BAD_ACTION, ST_GROW = 0, 1, 2


# ------------------------------------------------------------------ arguments
def check_number(
    env: str,
    name: str,
    value: Any,
    *,
    lo: float = -math.inf,
    hi: float = math.inf,
    lo_open: bool = False,
) -> float:
    """Return ``value`` as a float, or raise :class:`ConfigError` naming ``env`` and it."""
    return in_range(f"{env}: {name}", value, lo, hi, lo_open=lo_open, error=ConfigError, text=False)


def check_range(
    env: str, name: str, value: Any, *, lo: float = -math.inf, hi: float = math.inf
) -> tuple[float, float]:
    """A fixed value ``v`` or a range ``(lo, hi)`` drawn uniformly per episode."""
    if isinstance(value, Sequence) and not isinstance(value, str):
        if len(value) != 2:
            raise ConfigError(
                f"{env}: {name} is {value!r}; expected a number or a (low, high) pair"
            )
        a = check_number(env, f"{name}[0]", value[0], lo=lo, hi=hi)
        b = check_number(env, f"{name}[1]", value[1], lo=lo, hi=hi)
        if a > b:
            raise ConfigError(f"{env}: {name} is {value!r}; expected low <= high")
        return a, b
    v = check_number(env, name, value, lo=lo, hi=hi)
    return v, v


def draw(rng: np.random.Generator, r: tuple[float, float]) -> float:
    """A value of a :func:`check_range` pair (no draw for a fixed value)."""
    return r[0] if r[0] == r[1] else float(rng.uniform(r[0], r[1]))


def parse_weights(
    env: str, given: Mapping[str, float] | None, defaults: Mapping[str, float]
) -> dict[str, float]:
    """Merge reward weights over the defaults; unknown names raise :class:`ConfigError`."""
    out = dict(defaults)
    if given is None:
        return out
    if not isinstance(given, Mapping):
        raise ConfigError(f"{env}: reward_weights is {given!r:.60}; expected a dict")
    unknown = [k for k in given if k not in defaults]
    if unknown:
        raise ConfigError(
            f"{env}: unknown reward weight(s) {unknown}; weights are {list(defaults)}"
        )
    for k, v in given.items():
        out[k] = check_number(env, f"reward_weights[{k!r}]", v)
    return out


def parse_noise(
    env: str,
    sensor_noise: bool | Mapping[str, float],
    channels: Sequence[str],
    defaults: Mapping[str, tuple[float, float]],
    rig_sensors: Mapping[str, Any] | None,
    rig_names: Mapping[str, str] | None = None,
) -> NDArray[np.float64]:
    """Sensor noise σ and quantisation step per channel, shape (2, n_channels).

    ``defaults[channel] = (sigma, resolution)``; on the rig the rig's sensor of
    the signal ``rig_names.get(channel, channel)`` is used when it has one.
    ``sensor_noise=False`` removes noise (quantisation too); a dict overrides
    σ per channel.
    """
    out = np.zeros((2, len(channels)))
    if sensor_noise is False:
        return out
    for j, ch in enumerate(channels):
        sig, res = defaults[ch]
        spec = (rig_sensors or {}).get((rig_names or {}).get(ch, ch))
        if spec is not None:
            sig, res = spec.noise, spec.resolution
        out[0, j], out[1, j] = sig, res
    if isinstance(sensor_noise, Mapping):
        unknown = [k for k in sensor_noise if k not in channels]
        if unknown:
            raise ConfigError(
                f"{env}: sensor_noise names {unknown}; noisy channels are {list(channels)}"
            )
        for k, v in sensor_noise.items():
            out[0, list(channels).index(k)] = check_number(env, f"sensor_noise[{k!r}]", v, lo=0.0)
    elif sensor_noise is not True:
        raise ConfigError(f"{env}: sensor_noise is {sensor_noise!r:.60}; expected a bool or dict")
    return out


def steps_of(env: str, name: str, seconds: float, period: float) -> int:
    """Whole number of control periods in ``seconds`` (at least 1)."""
    n = seconds / period
    k = round(n)
    if k < 1 or abs(n - k) > 1e-9 * max(1.0, n):
        raise ConfigError(
            f"{env}: {name} = {seconds!r} s is not a positive whole number of control "
            f"periods of {period!r} s"
        )
    return int(k)


# --------------------------------------------------------------------- engine
class Engine:
    """Batched plants with their step kernel (subclass per plant).

    Subclasses set the class attributes, allocate their own arrays in
    ``__init__`` (after calling this one), and implement :meth:`_kernel`,
    :meth:`_reset_row`, :meth:`_set_theta_row` and :meth:`kpis`.

    Parameters
    ----------
    B : int
        Number of plants.
    plant : Plant
        Resolved dynamics.
    n_acc : int
        Floats per plant for KPI accumulators and trackers.
    tp_capacity : int
        Initial capacity of the turning-point buffer per plant (0: none).
    """

    name: ClassVar[str] = "engine"
    obs_names: tuple[str, ...] = ()
    obs_units: tuple[str, ...] = ()
    sig_names: tuple[str, ...] = ()
    sig_units: tuple[str, ...] = ()
    noise_channels: tuple[str, ...] = ()
    #: Panels of the rendered figure: (y label, signal names).
    panels: tuple[tuple[str, tuple[str, ...]], ...] = ()

    _dt: float
    _horizon: int

    def __init__(self, B: int, plant: Plant, n_acc: int, tp_capacity: int = 0) -> None:
        self.B = int(B)
        self.plant = plant
        self.model = plant.model
        self.base_theta = plant.theta.copy()
        self.theta = np.repeat(plant.theta, self.B, axis=0)
        self._theta_ok = np.zeros(self.B, dtype=np.bool_)
        self.sampler: Callable[[np.random.Generator], NDArray[np.float64]] | None = None
        self.ctr = np.zeros((self.B, 4), dtype=np.int64)
        self.out = np.zeros((self.B, 3))
        self.acc = np.zeros((self.B, n_acc))
        self.tpbuf = np.zeros((self.B, max(tp_capacity, 1)))
        self.noise = np.zeros((self.B, NOISE_BLOCK, max(len(self.noise_channels), 1)))
        self.obs = np.zeros((self.B, len(self.obs_names)), dtype=np.float32)
        self.sig = np.zeros((self.B, len(self.sig_names)))
        self.active = np.ones(self.B, dtype=np.bool_)
        self.done = np.ones(self.B, dtype=np.bool_)
        self.act = np.zeros((self.B, self.n_act()))
        #: Step one plant per thread (numba prange); off by default: on a machine shared with
        #: other work, thread hand-offs cost more than they save (measured 7x slower at load 8
        #: on 2 cores), on idle cores it scales with their number.
        self.parallel = False

    # ---- to implement
    def n_act(self) -> int:
        """Action dimension (1 for on/off modes)."""
        return 1

    def action_space(self) -> spaces.Space[Any]:
        """Single-plant action space."""
        raise NotImplementedError

    def observation_space(self) -> spaces.Box[np.float32]:
        """Single-plant observation space (sensor ranges)."""
        lo, hi = self.obs_bounds()
        return spaces.Box(lo, hi, dtype=np.float32)

    def obs_bounds(self) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
        """Lower and upper observation bounds."""
        raise NotImplementedError

    def _kernel(self, mode: int) -> int:
        """Run the compiled step (mode 0) or observe (mode 1) for active rows; status."""
        raise NotImplementedError

    def _reset_row(self, b: int, rng: np.random.Generator) -> None:
        """Draw episode conditions and set the initial state of plant ``b``."""
        raise NotImplementedError

    def _set_theta_row(self, b: int, theta: NDArray[np.float64]) -> None:
        """Install parameter set ``theta`` (1, P) for plant ``b`` (kernel layout)."""
        raise NotImplementedError

    def kpis(self, b: int) -> dict[str, float]:
        """KPIs of plant ``b`` so far (units in the names)."""
        raise NotImplementedError

    def trip_reason(self, b: int) -> str:
        """Why plant ``b`` terminated (a safety trip)."""
        return "safety trip"

    @property
    def dt(self) -> float:
        """Control period [s] (subclasses set ``_dt``)."""
        return self._dt

    @property
    def horizon(self) -> int:
        """Episode length in control steps (subclasses set ``_horizon``)."""
        return self._horizon

    # ---- shared
    def _period(self, env: str, cfg: Any) -> float:
        """Check ``cfg.control_period`` and ``cfg.episode_s``; set ``_dt`` and ``_horizon``.

        Returns the control period [s].
        """
        T = check_number(env, "control_period", cfg.control_period, lo=0.0, lo_open=True)
        self._dt = T
        self._horizon = steps_of(env, "episode_s", check_number(env, "episode_s", cfg.episode_s), T)
        return T

    def _call(self, kernels: tuple[Any, Any], mode: int, *arrays: Any) -> int:
        """Run ``kernels`` (serial, parallel; :func:`~thermogym.envs._kernels.plant_loops`).

        The parallel loop when :attr:`parallel` is set and there are several
        plants; the arguments after :attr:`active` and ``mode`` are ``arrays``.
        """
        kernel = kernels[1] if self.parallel and self.B > 1 else kernels[0]
        return int(kernel(self.active, mode, *arrays))

    def _steps_done(self, b: int) -> int:
        """Control steps of plant ``b``'s episode so far (at least 1, a divisor of averages)."""
        return max(int(self.ctr[b, C_K]), 1)

    def _episode_h(self, b: int) -> float:
        """Length of plant ``b``'s episode so far [h]."""
        return float(self.ctr[b, C_K] * self._dt / 3600.0)

    def set_theta(
        self, rows: Sequence[int] | NDArray[np.int64], theta: NDArray[np.float64]
    ) -> None:
        """Install a parameter set (1, P) or one per row (len(rows), P) from now on."""
        th = np.atleast_2d(np.asarray(theta, dtype=float))
        for i, b in enumerate(rows):
            row = th[i : i + 1] if th.shape[0] > 1 else th
            if self._theta_ok[b] and np.array_equal(self.theta[b], row[0]):
                continue  # kernel arrays are already those of this parameter set
            self.theta[b] = row[0]
            self._set_theta_row(int(b), row)
            self._theta_ok[b] = True

    def refill(self, b: int, rng: np.random.Generator) -> None:
        """Draw a new block of sensor noise for plant ``b``."""
        self.noise[b] = rng.standard_normal(self.noise.shape[1:])
        self.ctr[b, C_CUR] = 0

    def reset_rows(self, rows: Sequence[int], rngs: Sequence[np.random.Generator]) -> None:
        """Start a new episode for ``rows``; ``rngs[b]`` is plant ``b``'s generator."""
        for b in rows:
            rng = rngs[b]
            theta = self.sampler(rng) if self.sampler is not None else self.base_theta
            self.set_theta([b], theta)
            self.acc[b] = 0.0
            self.ctr[b] = 0
            self.out[b] = 0.0
            self._reset_row(b, rng)
            self.refill(b, rng)
            self.done[b] = False
        self._run_rows(rows, 1)

    def _run_rows(self, rows: Sequence[int], mode: int) -> None:
        if len(rows) == self.B:
            self.active[:] = True
        else:
            self.active[:] = False
            self.active[list(rows)] = True
        self._run(mode)

    def step(self, rngs: Sequence[np.random.Generator], active: NDArray[np.bool_] | None) -> None:
        """Advance the active plants by one control period (actions in :attr:`act`)."""
        if self.B == 1:  # a single environment: scalar indexing (cheaper per step)
            if self.ctr[0, C_CUR] >= NOISE_BLOCK:
                self.refill(0, rngs[0])
            self.active[0] = True if active is None else bool(active[0])
            self._run(0)
            return
        cur = self.ctr[:, C_CUR]
        if cur.max() >= NOISE_BLOCK:
            # only plants that step now: a plant about to be reset draws nothing more here
            full = cur >= NOISE_BLOCK if active is None else (cur >= NOISE_BLOCK) & active
            for b in np.flatnonzero(full):
                self.refill(int(b), rngs[int(b)])
        if active is None:
            self.active[:] = True
        else:
            self.active[:] = active
        self._run(0)

    def _run(self, mode: int) -> None:
        status = self._kernel(mode)
        while status == ST_GROW:
            # a turning-point buffer is full: the kernel stepped nothing; grow it, run again
            self.tpbuf = np.concatenate([self.tpbuf, np.zeros_like(self.tpbuf)], axis=1)
            status = self._kernel(mode)
        if status == ST_OK:
            return
        b = int(np.argmax(self.ctr[:, C_STATUS] != 0))
        self.ctr[:, C_STATUS] = 0
        raise ShapeError(
            f"{self.name}: action {self.act[b].tolist()} of plant {b} is invalid; "
            f"expected a value of {self.action_space()}"
        )

    def true_outputs(self, b: int = 0) -> dict[str, float]:
        """Noise-free signals of plant ``b`` after the last step (names in :attr:`sig_names`)."""
        return dict(zip(self.sig_names, self.sig[b].tolist(), strict=True))

    def apply_fit(self, fit: ParamsLike, rows: Sequence[int] | None = None) -> dict[str, Any]:
        """Use the parameters of ``fit`` from now on (and for following episodes).

        Returns a record of the change: old and new FitResult fingerprints and
        the parameters whose values changed.
        """
        if is_overrides(fit):  # {"C_P": 20}: these values on top of the running parameters
            theta = self.model.theta(self.base_theta, **dict(fit))  # type: ignore[arg-type]
            new: FitResult | None = FitResult.from_model(
                self.model,
                theta[0],
                method=f"{self.plant.fit.method or 'nominal'} with overrides",
                notes=f"parameters set by the caller: {sorted(fit)}",  # type: ignore[arg-type]
            )
        else:
            new = load_params(fit, [self.model.name], self.name)
        if new is None:
            raise ConfigError(f"{self.name}: no parameters given (None) to apply")
        if new.model_config != self.plant.fit.model_config:
            raise ConfigError(
                f"{self.name}: the new FitResult has model_config {new.model_config}, the "
                f"running model {self.plant.fit.model_config}; a different model structure "
                "needs a new environment"
            )
        theta = new.theta(self.model)
        old = self.plant.fit
        changed = {
            n: (float(old.parameters.get(n, math.nan)), float(v))
            for n, v in zip(self.model.param_names, theta[0], strict=True)
            if not old.parameters.get(n) == float(v)
        }
        self.plant.fit = new
        self.base_theta = theta
        sampler_spec = getattr(self, "_sampler_spec", None)
        if self.sampler is not None and sampler_spec:
            self.sampler = make_sampler(new, self.model, **sampler_spec)
        self.set_theta(range(self.B) if rows is None else rows, theta)
        return {
            "old_fingerprint": old.fingerprint(),
            "new_fingerprint": new.fingerprint(),
            "changed": changed,
        }

    def randomize(self, method: str | None, **kwargs: Any) -> None:
        """Sample parameters per episode (see :func:`~thermogym.envs._plant.make_sampler`)."""
        if method is None:
            self.sampler = None
            self._sampler_spec: dict[str, Any] | None = None
            return
        self._sampler_spec = {"method": method, **kwargs}
        self.sampler = make_sampler(self.plant.fit, self.model, method, **kwargs)


# ----------------------------------------------------------------- rendering
def _render(env: Any, history: list[NDArray[np.float64]], mode: str) -> Any:
    from thermogym.envs import envplots  # matplotlib only when rendering

    e: Engine = env._e
    data = np.array(history) if history else np.zeros((0, len(e.sig_names)))
    fig = envplots.episode_figure(
        title=f"{env.spec.id if env.spec else type(env).__name__}",
        time_s=e.dt * np.arange(data.shape[0], dtype=np.float64),
        names=e.sig_names,
        units=e.sig_units,
        data=data,
        panels=e.panels,
    )
    if mode == "rgb_array":
        return envplots.to_rgb(fig)
    path = env._render_path
    if path is None:
        folder = Path(tempfile.gettempdir()) / "thermogym-renders"
        folder.mkdir(parents=True, exist_ok=True)
        path = folder / f"{type(env).__name__}.png"
    envplots.save(fig, path)
    if not env._render_logged:
        log.info("%s: episode figure written to %s", type(env).__name__, path)
        env._render_logged = True
    return None


# ------------------------------------------------------------- single envs
def _action_array(
    name: str, action: Any, shape: tuple[int, ...], space: Any, *, batched: bool = False
) -> NDArray[np.float64]:
    """``action`` as float64 of exactly ``shape``, or a :class:`ShapeError` naming both.

    An action is never broadcast or reshaped into the space: a (1,) action for
    a (2,) space (TCLab's two heaters) would otherwise drive both inputs with
    one value. A scalar is accepted for a one-element action (and ``(N,)`` for
    ``N`` sub-environments of one action each).
    """
    what = "actions" if batched else "action"
    try:
        a = np.asarray(action, dtype=np.float64)
    except (ValueError, TypeError) as err:
        raise ShapeError(
            f"{name}: {what} {action!r:.60} cannot be read as numbers; expected an array of "
            f"shape {shape} for the action space {space}"
        ) from err
    one = shape[-1:] == (1,)
    if a.shape == shape or (one and a.shape == shape[:-1]):
        return a.reshape(shape)
    raise ShapeError(
        f"{name}: {what} of shape {a.shape}, expected {shape} for the action space {space} "
        "(an action is never broadcast)"
    )


class ThermoEnv(gym.Env[NDArray[np.float32], Any]):
    """A Gymnasium environment around an :class:`Engine` with one plant.

    Common keyword arguments: ``render_mode`` — ``"rgb_array"`` (``render()``
    returns the figure of the episode so far as an RGB array) or ``"human"``
    (the figure is written as a PNG to ``render_path``, default
    ``<tempdir>/thermogym-renders/<Env>.png``, at the end of every episode and
    on ``render()``; thermal episodes are too long to redraw at every step);
    ``record`` — keep the noise-free signals of every step for
    :meth:`history` (on with a render mode). Subclasses build the engine in
    ``__init__`` and call :meth:`_setup`.
    """

    # gymnasium declares metadata an instance attribute (a class default here)
    metadata: dict[str, Any] = {"render_modes": ["rgb_array", "human"], "render_fps": 4}  # noqa: RUF012
    #: Environment name used in messages (set by each environment class).
    env_name: ClassVar[str] = ""
    #: Configuration dataclass of the keyword arguments (set by each environment class).
    config_cls: ClassVar[type]
    #: Engine class, built as ``engine_cls(num_plants, config)``.
    engine_cls: Callable[[int, Any], Engine]
    _e: Engine

    def __init__(
        self,
        *,
        render_mode: str | None = None,
        render_path: str | None = None,
        record: bool | None = None,
        **kwargs: Any,
    ) -> None:
        cfg = build_config(self.config_cls, self.env_name, kwargs)
        self._setup(
            self.engine_cls(1, cfg),
            render_mode=render_mode,
            render_path=render_path,
            record=record,
            randomize=cfg.randomize,
            randomize_kwargs=cfg.randomize_kwargs,
        )

    def _setup(
        self,
        engine: Engine,
        *,
        render_mode: str | None,
        render_path: str | os.PathLike[str] | None,
        record: bool | None,
        randomize: str | None,
        randomize_kwargs: Mapping[str, Any] | None,
    ) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ConfigError(
                f"{engine.name}: render_mode is {render_mode!r}; expected None or one of "
                f"{self.metadata['render_modes']}"
            )
        self._e = engine
        self.render_mode = render_mode
        self._render_path = None if render_path is None else Path(render_path)
        self._render_logged = False
        self._record = bool(render_mode is not None if record is None else record)
        self._history: list[NDArray[np.float64]] = []
        self.observation_space = engine.observation_space()
        self.action_space = engine.action_space()
        engine.randomize(randomize, **dict(randomize_kwargs or {}))
        self._rngs: list[np.random.Generator] = []

    # ---- introspection used by controllers and wrappers
    @property
    def obs_names(self) -> tuple[str, ...]:
        """Names of the observation entries, in order (stable per env version)."""
        return self._e.obs_names

    @property
    def obs_units(self) -> tuple[str, ...]:
        """Units of the observation entries."""
        return self._e.obs_units

    @property
    def model(self) -> Any:
        """The plant model whose step kernels the environment runs."""
        return self._e.model

    @property
    def theta(self) -> NDArray[np.float64]:
        """Parameter set of the running episode, shape (1, P)."""
        return self._e.theta[:1].copy()

    @property
    def fit(self) -> Any:
        """The FitResult the parameters come from."""
        return self._e.plant.fit

    @property
    def dt(self) -> float:
        """Control period [s]."""
        return self._e.dt

    @property
    def horizon(self) -> int:
        """Episode length in control steps."""
        return self._e.horizon

    @property
    def plant_kind(self) -> str:
        """``"model"`` or ``"rig"``."""
        return self._e.plant.kind

    def kpis(self) -> dict[str, float]:
        """KPIs of the running episode so far."""
        return self._e.kpis(0)

    def true_outputs(self) -> dict[str, float]:
        """Noise-free plant signals after the last step (including hidden ones)."""
        return self._e.true_outputs(0)

    def history(self) -> dict[str, NDArray[np.float64]]:
        """Recorded episode so far (``record=True`` or a render mode): signal -> array."""
        data = np.array(self._history) if self._history else np.zeros((0, len(self._e.sig_names)))
        out = {"time": self._e.dt * np.arange(data.shape[0], dtype=np.float64)}
        out.update({n: data[:, j] for j, n in enumerate(self._e.sig_names)})
        return out

    def set_parameters(self, params: ParamsLike) -> dict[str, Any]:
        """Use the parameters of a FitResult (object, path or dict) from now on.

        The state is kept, so a call between steps changes the dynamics from the
        next step on; the change (fingerprints and changed values) is returned.
        """
        return self._e.apply_fit(params)

    def set_randomization(self, method: str | None, **kwargs: Any) -> None:
        """Sample parameters at every reset (``"covariance"``, ``"bounds"``, ``"relative"``)."""
        self._e.randomize(method, **kwargs)

    # ---- Gymnasium API
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[NDArray[np.float32], dict[str, Any]]:
        """Start an episode; ``options`` may hold ``{"params": FitResult-like}``."""
        super().reset(seed=seed)
        if options:
            unknown = [k for k in options if k not in ("params",)]
            if unknown:
                raise ConfigError(
                    f"{self._e.name}: unknown reset option(s) {unknown}; options are ['params']"
                )
            if options.get("params") is not None:
                self._e.apply_fit(options["params"])
        self._rngs = [self.np_random]
        self._e.reset_rows([0], self._rngs)
        self._history = []
        if self._record:
            self._history.append(self._e.sig[0].copy())
        return self._e.obs[0].copy(), {"time_s": 0.0}

    def step(self, action: Any) -> tuple[NDArray[np.float32], float, bool, bool, dict[str, Any]]:
        """Apply ``action`` for one control period."""
        e = self._e
        if e.done[0]:
            raise SimulationError(
                f"{e.name}: the episode is over (step {int(e.ctr[0, C_K])} of {e.horizon}); "
                "call reset() before step()"
            )
        e.act[0] = _action_array(e.name, action, e.act.shape[1:], self.action_space)
        e.step(self._rngs, None)
        rew, term, trunc = e.out[0].tolist()  # Python floats in one call (cheaper per step)
        terminated = term > 0.5
        truncated = trunc > 0.5
        info: dict[str, Any] = {"time_s": float(e.ctr[0, C_K]) * e._dt}
        if self._record:
            self._history.append(e.sig[0].copy())
        if terminated or truncated:
            e.done[0] = True
            info["kpis"] = e.kpis(0)
            if terminated:
                info["trip"] = e.trip_reason(0)
            if self.render_mode == "human":
                self.render()
        return e.obs[0].copy(), rew, terminated, truncated, info

    def render(self) -> Any:
        """Plot the episode so far: an RGB array, or a PNG (``"human"``)."""
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; nothing is drawn")
            return None
        return _render(self, self._history, self.render_mode)

    def close(self) -> None:
        """Nothing to release (figures are closed after every render)."""
        self._history = []


# ------------------------------------------------------------- vector envs
class ThermoVectorEnv(gym.vector.VectorEnv):
    """A native vector environment: ``num_envs`` plants stepped by one kernel call.

    Sub-environment ``i`` is seeded ``seed + i`` and behaves exactly like a
    single environment reset with that seed. Autoreset follows
    ``autoreset_mode`` (Gymnasium's ``NEXT_STEP`` by default: the step after
    an episode ends resets that sub-environment and ignores its action).
    ``parallel=True`` steps one plant per thread (numba ``prange``; same
    results): worth it on idle cores, harmful on a busy shared machine.
    """

    #: The single environment class whose configuration and engine this vector env uses.
    single_env_cls: ClassVar[type[ThermoEnv]]
    _e: Engine

    def __init__(
        self,
        num_envs: int = 1,
        *,
        autoreset_mode: str = "NextStep",
        parallel: bool = False,
        **kwargs: Any,
    ) -> None:
        env = self.single_env_cls
        n = int(check_number(env.env_name, "num_envs", num_envs, lo=1))
        cfg = build_config(env.config_cls, env.env_name, kwargs)
        self._setup(
            env.engine_cls(n, cfg),
            env,
            autoreset_mode=autoreset_mode,
            randomize=cfg.randomize,
            randomize_kwargs=cfg.randomize_kwargs,
            parallel=parallel,
        )

    def _setup(
        self,
        engine: Engine,
        single_env_cls: type,
        *,
        autoreset_mode: str | AutoresetMode,
        randomize: str | None,
        randomize_kwargs: Mapping[str, Any] | None,
        parallel: bool = False,
    ) -> None:
        if not isinstance(parallel, bool):
            raise ConfigError(f"{engine.name}: parallel is {parallel!r}; expected True or False")
        engine.parallel = parallel
        try:
            mode = AutoresetMode(autoreset_mode)
        except ValueError:
            raise ConfigError(
                f"{engine.name}: autoreset_mode is {autoreset_mode!r}; expected one of "
                f"{[m.value for m in AutoresetMode]}"
            ) from None
        self.metadata = {"autoreset_mode": mode, "render_modes": []}
        self.render_mode = None
        self._e = engine
        self.num_envs = engine.B
        self.single_observation_space = engine.observation_space()
        self.single_action_space = engine.action_space()
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        engine.randomize(randomize, **dict(randomize_kwargs or {}))
        self._rngs: list[np.random.Generator] = []
        self._needs_reset = np.zeros(self.num_envs, dtype=np.bool_)
        self._single_env_cls = single_env_cls

    @property
    def obs_names(self) -> tuple[str, ...]:
        """Names of the observation entries (columns of the observation batch)."""
        return self._e.obs_names

    @property
    def dt(self) -> float:
        """Control period [s]."""
        return self._e.dt

    @property
    def horizon(self) -> int:
        """Episode length in control steps."""
        return self._e.horizon

    @property
    def model(self) -> Any:
        """The plant model."""
        return self._e.model

    def kpis(self, i: int) -> dict[str, float]:
        """KPIs of sub-environment ``i`` so far."""
        return self._e.kpis(i)

    def set_parameters(self, params: ParamsLike) -> dict[str, Any]:
        """Use the parameters of a FitResult in every sub-environment from now on."""
        return self._e.apply_fit(params)

    def set_randomization(self, method: str | None, **kwargs: Any) -> None:
        """Sample parameters at every reset of a sub-environment."""
        self._e.randomize(method, **kwargs)

    def reset(
        self,
        *,
        seed: int | list[int | None] | None = None,
        options: dict[str, Any] | None = None,
    ) -> tuple[NDArray[np.float32], dict[str, Any]]:
        """Reset every sub-environment (``seed + i``, or one seed each)."""
        if options:
            unknown = [k for k in options if k not in ("params",)]
            if unknown:
                raise ConfigError(f"{self._e.name}: unknown reset option(s) {unknown}")
            if options.get("params") is not None:
                self._e.apply_fit(options["params"])
        n = self.num_envs
        if seed is None:
            seeds: list[int | None] = [None] * n
        elif isinstance(seed, int | np.integer):
            seeds = [int(seed) + i for i in range(n)]
        else:
            seeds = list(seed)
            if len(seeds) != n:
                raise ConfigError(f"{len(seeds)} seeds given for {n} sub-environments")
        if seed is not None or not self._rngs:
            self._rngs = [seeding.np_random(s)[0] for s in seeds]
            self._np_random = self._rngs[0]
        self._e.reset_rows(range(n), self._rngs)
        self._needs_reset[:] = False
        return self._e.obs.copy(), {}

    def step(
        self, actions: Any
    ) -> tuple[
        NDArray[np.float32], NDArray[np.float64], NDArray[np.bool_], NDArray[np.bool_], dict
    ]:
        """Step every sub-environment; those that ended last step are reset (NEXT_STEP)."""
        e = self._e
        e.act[:] = _action_array(e.name, actions, e.act.shape, self.action_space, batched=True)
        mode = self.metadata["autoreset_mode"]
        resets = self._needs_reset
        any_reset = bool(resets.any()) and mode == AutoresetMode.NEXT_STEP
        if mode == AutoresetMode.DISABLED and e.done.any():
            b = int(np.argmax(e.done))
            raise SimulationError(
                f"{e.name}: sub-environment {b} ended; with autoreset disabled, call reset()"
            )
        e.step(self._rngs, ~resets if any_reset else None)
        rew = e.out[:, O_REW].copy()
        term = e.out[:, O_TERM] > 0.5
        trunc = e.out[:, O_TRUNC] > 0.5
        if any_reset:
            rows = np.flatnonzero(resets)
            rew[rows] = 0.0
            term[rows] = False
            trunc[rows] = False
        done = term | trunc
        infos: dict[str, Any] = {}
        if done.any():
            rows = np.flatnonzero(done)
            e.done[rows] = True
            k = [e.kpis(int(b)) for b in rows]
            infos["kpis"] = {
                name: _column(rows, [d[name] for d in k], self.num_envs) for name in k[0]
            }
            infos["_kpis"] = done.copy()
        obs = e.obs.copy()
        if mode == AutoresetMode.SAME_STEP and done.any():
            rows = np.flatnonzero(done)
            infos["final_obs"] = np.array([obs[i] if done[i] else None for i in range(len(obs))])
            infos["_final_obs"] = done.copy()
            e.reset_rows(list(rows), self._rngs)
            obs = e.obs.copy()
        if any_reset:
            e.reset_rows(list(np.flatnonzero(resets)), self._rngs)
            obs = e.obs.copy()
        self._needs_reset = done if mode == AutoresetMode.NEXT_STEP else np.zeros_like(done)
        return obs, rew, term, trunc, infos


def _column(rows: NDArray[np.int64], values: list[float], n: int) -> NDArray[np.float64]:
    out = np.zeros(n)
    out[rows] = values
    return out


# ------------------------------------------------------------- configuration
def build_config(cfg_cls: type, env: str, kwargs: Mapping[str, Any]) -> Any:
    """Instantiate the keyword-argument dataclass of an environment.

    Raises
    ------
    TypeError
        An unknown keyword argument (named, with the accepted ones).
    """
    names = [f.name for f in fields(cfg_cls)]
    unknown = [k for k in kwargs if k not in names]
    if unknown:
        raise TypeError(
            f"{env}: unknown keyword argument(s) {unknown}; accepted are {sorted(names)}"
        )
    cfg = cfg_cls(**kwargs)
    return cfg
