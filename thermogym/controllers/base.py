"""One interface for every controller: bind to an environment, reset, act.

Every controller of :mod:`thermogym.controllers` follows the same life
cycle::

    ctrl = PID(kp=0.05, ti=300.0)          # settings only, no environment yet
    ctrl.bind(env)                         # resolve the observation layout by name
    obs, info = env.reset(seed=0)
    ctrl.reset()
    while not done:
        obs, reward, terminated, truncated, info = env.step(ctrl.act(obs))

:meth:`Controller.bind` looks the signals the controller needs up *by name*
in the environment's observation (``obs_names``), so one controller drives
any environment of the suite whose observation holds them; when it cannot,
the error names what is missing and what the environment offers.

Loops, commands and actions
---------------------------
A controller closes one :class:`Loop`: a measured variable (an observation
name), its set-point (an observation name or a constant) and the action
channel it drives. Environments with a natural loop have defaults
(:data:`ENV_LOOPS`); the others need ``loop=Loop(...)``.

Controllers compute a *command* ``u`` in [0, 1] per sample: the fraction of
the actuator's range (a heater duty cycle, a fraction of the speed range).
:meth:`Controller.act` converts it into the environment's action: ``2u − 1``
for the suite's symmetric ``Box(-1, 1)`` actions, ``0``/``1`` for
``Discrete(2)`` (on/off) actions. Channels no controller drives are held at
:data:`ENV_HOLD` (e.g. the strut's compensation at zero). A controller whose
command is continuous cannot drive an on/off action directly — put it behind
a :class:`~thermogym.controllers.pwm.PWM` output stage, which turns any duty
into whole on/off control periods.

Sample time
-----------
A controller computes a new command every ``sample_time`` seconds (default:
the environment's control period; it must be a whole number of control
periods) and holds it in between.
"""

from __future__ import annotations

import abc
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np
from gymnasium import spaces
from numpy.typing import ArrayLike, NDArray

from thermogym._checks import in_range, positive
from thermogym.errors import ConfigError, ShapeError, SimulationError, UnknownNameError

__all__ = [
    "ENV_HOLD",
    "ENV_LOOPS",
    "Controller",
    "Decentralized",
    "EnvInfo",
    "Loop",
    "env_info",
    "whole_periods",
]


@dataclass(frozen=True)
class Loop:
    """A control loop: measured variable, set-point and action channel.

    Parameters
    ----------
    measurement : str
        Observation name of the controlled variable.
    setpoint : str or float
        Observation name of the set-point, or a constant (unit of the
        measurement).
    channel : int
        Index of the action channel the loop drives.
    direct : bool
        ``True`` when more actuation raises the measurement (heating: every
        plant of the suite); ``False`` for cooling-like loops.

    Examples
    --------
    >>> Loop("T_zone", "T_set")
    Loop(measurement='T_zone', setpoint='T_set', channel=0, direct=True)
    """

    measurement: str
    setpoint: str | float
    channel: int = 0
    direct: bool = True

    def __post_init__(self) -> None:
        if not isinstance(self.measurement, str) or not self.measurement:
            raise ConfigError(f"Loop measurement is {self.measurement!r}; expected a name")
        if not isinstance(self.setpoint, str):
            v = self.setpoint
            if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
                raise ConfigError(
                    f"Loop setpoint is {v!r}; expected an observation name or a finite number"
                )
        if isinstance(self.channel, bool) or not isinstance(self.channel, int) or self.channel < 0:
            raise ConfigError(f"Loop channel is {self.channel!r}; expected an integer >= 0")

    def to_dict(self) -> dict[str, Any]:
        """JSON-able form (for result tables)."""
        return {
            "measurement": self.measurement,
            "setpoint": self.setpoint,
            "channel": self.channel,
            "direct": self.direct,
        }


#: Default loops of the suite's environments (by environment name).
ENV_LOOPS: dict[str, tuple[Loop, ...]] = {
    "AXT211Valve": (Loop("x_V", "x_ref"),),
    "AXT211Room": (Loop("T_zone", "T_set"),),
    "TCLab": (Loop("T1", "T1_set", 0), Loop("T2", "T2_set", 1)),
}
#: Command ``u`` in [0, 1] of action channels that no controller drives.
ENV_HOLD: dict[str, dict[int, float]] = {
    "StrutThermal": {1: 0.5},  # compensation a_1 = 0: no offset added to the axis
}


def _env_name(env: Any) -> str:
    u = getattr(env, "unwrapped", env)
    spec = getattr(u, "spec", None) or getattr(env, "spec", None)
    if spec is not None and getattr(spec, "id", None):
        return str(spec.id).split("/")[-1].split("-v")[0]
    name = type(u).__name__
    for suffix in ("VectorEnv", "Env"):
        if name.endswith(suffix):
            return name[: -len(suffix)]
    return name


def _attr(env: Any, name: str) -> Any:
    getter = getattr(env, "get_wrapper_attr", None)
    if getter is not None:
        try:
            return getter(name)
        except AttributeError:
            return None
    return getattr(getattr(env, "unwrapped", env), name, None)


@dataclass(frozen=True)
class EnvInfo:
    """What a controller needs to know about an environment.

    Attributes
    ----------
    name : str
        Environment name (``"AXT211Room"``).
    env_id : str or None
        Registered ID (``"thermogym/AXT211Room-v0"``) when made by ``gymnasium.make``.
    obs_names, obs_units : tuple of str
        Observation layout.
    obs_low, obs_high : ndarray
        Observation bounds.
    dt : float
        Control period [s].
    n_channels : int
        Action channels.
    discrete : bool
        ``Discrete(2)`` on/off actions (else a ``Box(-1, 1)``).
    hold : tuple of float
        Command of each channel when no controller drives it.
    fit_fingerprint : str or None
        Fingerprint of the environment's FitResult (its plant parameters).
    plant : str or None
        ``"model"`` or ``"rig"``.
    """

    name: str
    env_id: str | None
    obs_names: tuple[str, ...]
    obs_units: tuple[str, ...]
    obs_low: NDArray[np.float64]
    obs_high: NDArray[np.float64]
    dt: float
    n_channels: int
    discrete: bool
    hold: tuple[float, ...]
    fit_fingerprint: str | None = None
    plant: str | None = None

    def index(self, name: str, who: str) -> int:
        """Position of observation ``name``; :class:`UnknownNameError` naming what exists."""
        try:
            return self.obs_names.index(name)
        except ValueError:
            raise UnknownNameError(
                f"{who} needs the observation {name!r}, which {self.name} does not have; its "
                f"observation is {list(self.obs_names)}"
            ) from None

    def default_loops(self, who: str) -> tuple[Loop, ...]:
        """The environment's default loops, or a :class:`ConfigError` saying what to give."""
        loops = ENV_LOOPS.get(self.name)
        if not loops:
            raise ConfigError(
                f"{who} needs a loop, and {self.name} has no default one (no set-point in its "
                f"observation {list(self.obs_names)}); give loop=Loop(measurement=NAME, "
                "setpoint=NAME or VALUE, channel=INDEX)"
            )
        return loops

    def to_action(self, u: NDArray[np.float64]) -> Any:
        """Convert per-channel commands in [0, 1] into an action of the environment."""
        if self.discrete:
            v = float(u[0])
            if v not in (0.0, 1.0):
                raise SimulationError(
                    f"{self.name} takes on/off actions; the command is {v!r} (expected 0 or 1): "
                    "put the controller behind a PWM output stage"
                )
            return int(v)
        return np.clip(2.0 * u - 1.0, -1.0, 1.0).astype(np.float32)


def env_info(env: Any, *, obs_names: Sequence[str] | None = None) -> EnvInfo:
    """Describe a (possibly wrapped) thermogym environment for binding.

    Parameters
    ----------
    env : gymnasium.Env
        A single (not vectorised) environment.
    obs_names : sequence of str, optional
        Names of the observation entries when a wrapper changed the layout
        without telling (default: ``obs_names`` of the wrapper chain).

    Returns
    -------
    EnvInfo

    Raises
    ------
    ConfigError
        A vector environment, an observation that is not a 1-D ``Box``, an
        action space other than ``Box(-1, 1, (n,))`` or ``Discrete(2)``, or
        observation names that do not match the observation size.

    Examples
    --------
    >>> import gymnasium as gym
    >>> import thermogym.envs
    >>> info = env_info(gym.make("thermogym/AXT211Valve-v0", action_mode="onoff"))
    >>> info.name, info.dt, info.discrete, info.obs_names[:2]
    ('AXT211Valve', 10.0, True, ('x_V', 'T_G'))
    """
    if isinstance(env, EnvInfo):
        return env
    if hasattr(env, "num_envs") and not hasattr(env, "unwrapped"):
        raise ConfigError("controllers drive single environments; got a vector environment")
    name = _env_name(env)
    obs_space = env.observation_space
    if not isinstance(obs_space, spaces.Box) or len(obs_space.shape) != 1:
        raise ConfigError(f"{name}: observation space {obs_space} is not a 1-D Box")
    names = tuple(obs_names) if obs_names is not None else _attr(env, "obs_names")
    if names is None:
        raise ConfigError(
            f"{name} does not name its observation entries; pass obs_names=[...] "
            f"({obs_space.shape[0]} names)"
        )
    names = tuple(str(n) for n in names)
    if len(names) != obs_space.shape[0]:
        raise ShapeError(
            f"{name}: {len(names)} observation names {list(names)} for an observation of "
            f"size {obs_space.shape[0]}; a wrapper changed the layout: pass obs_names=[...]"
        )
    units = _attr(env, "obs_units")
    units = tuple(units) if units is not None and len(units) == len(names) else ("",) * len(names)
    act = env.action_space
    if isinstance(act, spaces.Discrete):
        if act.n != 2:
            raise ConfigError(f"{name}: action space {act}; controllers take Discrete(2) on/off")
        n, discrete = 1, True
    elif isinstance(act, spaces.Box) and len(act.shape) == 1:
        if not (np.allclose(act.low, -1.0) and np.allclose(act.high, 1.0)):
            raise ConfigError(
                f"{name}: action space {act}; controllers expect the suite's Box(-1, 1, (n,))"
            )
        n, discrete = int(act.shape[0]), False
    else:
        raise ConfigError(f"{name}: action space {act}; expected Box(-1, 1, (n,)) or Discrete(2)")
    dt = _attr(env, "dt")
    if dt is None:
        raise ConfigError(f"{name} does not give its control period (attribute dt)")
    hold = [0.0] * n
    for ch, v in ENV_HOLD.get(name, {}).items():
        if ch < n:
            hold[ch] = v
    fit = _attr(env, "fit")
    spec = getattr(env.unwrapped, "spec", None)
    return EnvInfo(
        name=name,
        env_id=None if spec is None else str(spec.id),
        obs_names=names,
        obs_units=units,
        obs_low=np.asarray(obs_space.low, dtype=np.float64),
        obs_high=np.asarray(obs_space.high, dtype=np.float64),
        dt=float(dt),
        n_channels=n,
        discrete=discrete,
        hold=tuple(hold),
        fit_fingerprint=None if fit is None else fit.fingerprint(),
        plant=_attr(env, "plant_kind"),
    )


def whole_periods(who: str, name: str, seconds: float, dt: float) -> int:
    """``seconds / dt`` as a whole number >= 1, or a :class:`ConfigError` naming it."""
    seconds = positive(f"{who}: {name}", seconds, unit="s", error=ConfigError, text=False)
    n = seconds / dt
    k = round(n)
    if k < 1 or abs(n - k) > 1e-9 * max(1.0, n):
        raise ConfigError(
            f"{who}: {name} = {seconds!r} s is not a whole number of control periods of {dt!r} s"
        )
    return int(k)


def _num(who: str, name: str, v: Any, *, lo: float = -math.inf, hi: float = math.inf) -> float:
    """``v`` as a finite float in ``[lo, hi]``, or a :class:`ConfigError` naming ``who``."""
    return in_range(f"{who}: {name}", v, lo, hi, error=ConfigError, text=False)


class Controller(abc.ABC):
    """Base class: binding by observation names, sample-and-hold, action conversion.

    Subclasses implement :meth:`update` (one sample: observation → command
    ``u`` in [0, 1]), optionally :meth:`_bind` (resolve what they need; raise
    naming what is missing) and :meth:`_reset`, and describe themselves in
    :meth:`settings`.

    Parameters
    ----------
    loop : Loop, optional
        The loop to close (default: the environment's first default loop).
    sample_time : float, optional
        Seconds between two commands (default: the control period); a whole
        number of control periods.

    Attributes
    ----------
    kind : {"continuous", "binary", "any"}
        The command the controller produces: any value in [0, 1], only 0/1,
        or an action already fitting any environment (output stages).
    """

    kind: ClassVar[str] = "continuous"
    #: Short name used in result tables.
    label: ClassVar[str] = "controller"

    def __init__(self, *, loop: Loop | None = None, sample_time: float | None = None) -> None:
        if loop is not None and not isinstance(loop, Loop):
            raise ConfigError(f"{type(self).__name__}: loop is {loop!r:.60}; expected a Loop")
        if sample_time is not None:
            positive(
                f"{type(self).__name__}: sample_time",
                sample_time,
                unit="s",
                error=ConfigError,
                text=False,
            )
        self.loop = loop
        self.sample_time = sample_time
        self._info: EnvInfo | None = None
        self._loop: Loop | None = None
        self._every = 1
        self._k = 0
        self._u = 0.0
        self.h = float("nan")
        self._i_y = -1
        self._i_r = -1

    # ------------------------------------------------------------------ binding
    @property
    def info(self) -> EnvInfo:
        """The environment description the controller is bound to."""
        if self._info is None:
            raise ConfigError(f"{type(self).__name__} is not bound; call bind(env) first")
        return self._info

    @property
    def bound_loop(self) -> Loop:
        """The loop in use after binding."""
        if self._loop is None:
            raise ConfigError(f"{type(self).__name__} is not bound; call bind(env) first")
        return self._loop

    def bind(
        self,
        env: Any,
        *,
        obs_names: Sequence[str] | None = None,
        sample_time: float | None = None,
        inner: bool = False,
    ) -> Controller:
        """Resolve the observation layout and action space of ``env``; return ``self``.

        Parameters
        ----------
        env : gymnasium.Env or EnvInfo
            The environment (possibly wrapped).
        obs_names : sequence of str, optional
            Observation names when a wrapper hides them.
        sample_time : float, optional
            Overrides the controller's own sample time (output stages use it
            to run an inner controller once per PWM period).
        inner : bool
            Bound as the inner controller of an output stage: its command
            may be continuous even when the environment takes on/off actions.

        Raises
        ------
        UnknownNameError
            An observation the controller needs is missing (named, with the
            environment's observation).
        ConfigError
            No loop for this environment, a sample time that is not a whole
            number of control periods, or a continuous command for on/off
            actions (use a PWM output stage).
        """
        info = env_info(env, obs_names=obs_names)
        who = f"{type(self).__name__} on {info.name}"
        h = sample_time if sample_time is not None else self.sample_time
        self._every = 1 if h is None else whole_periods(who, "sample_time", h, info.dt)
        self.h = info.dt * self._every
        loop = self.loop or self._default_loop(info)
        if loop.channel >= info.n_channels:
            raise ConfigError(
                f"{who}: loop channel {loop.channel} does not exist; the environment has "
                f"{info.n_channels} action channel(s)"
            )
        if info.discrete and self.kind == "continuous" and not inner:
            raise ConfigError(
                f"{who}: {type(self).__name__} computes a continuous command and the environment "
                "takes on/off actions (action_mode='onoff'); put it behind a PWM output stage, "
                f"e.g. PWM(period=..., inner={type(self).__name__}(...))"
            )
        self._info = info
        self._loop = loop
        self._i_y = info.index(loop.measurement, who) if self._needs_measurement() else -1
        self._i_r = (
            info.index(loop.setpoint, who)
            if isinstance(loop.setpoint, str) and self._needs_setpoint()
            else -1
        )
        self._bind(info)
        self.reset()
        return self

    def _default_loop(self, info: EnvInfo) -> Loop:
        if not (self._needs_measurement() or self._needs_setpoint()) and info.name not in ENV_LOOPS:
            return Loop("(none)", 0.0, 0)  # open loop: only the channel matters
        return info.default_loops(type(self).__name__)[0]

    def _needs_measurement(self) -> bool:
        return True

    def _needs_setpoint(self) -> bool:
        return True

    def _bind(self, info: EnvInfo) -> None:
        """Subclass hook: resolve further names, check the environment."""
        return None

    # ---------------------------------------------------------------- signals
    def measurement(self, obs: NDArray[np.float64]) -> float:
        """The measured variable of the loop in ``obs``."""
        return float(obs[self._i_y])

    def setpoint(self, obs: NDArray[np.float64]) -> float:
        """The set-point of the loop in ``obs`` (or the constant one)."""
        if self._i_r >= 0:
            return float(obs[self._i_r])
        return float(self.bound_loop.setpoint)  # type: ignore[arg-type]

    # ------------------------------------------------------------- life cycle
    def reset(self, *, seed: int | None = None) -> None:
        """Forget the episode: internal states back to their initial values."""
        self._k = 0
        self._u = 0.0
        self._reset(seed)

    def _reset(self, seed: int | None) -> None:
        """Subclass hook of :meth:`reset`."""
        return None

    @abc.abstractmethod
    def update(self, obs: NDArray[np.float64]) -> float:
        """One sample: the command ``u`` in [0, 1] from the observation."""

    def command(self, obs: ArrayLike) -> float:
        """The command of this control period (sample-and-hold at ``sample_time``)."""
        if self._info is None:
            raise ConfigError(f"{type(self).__name__} is not bound; call bind(env) first")
        o = np.asarray(obs, dtype=np.float64)
        if o.shape != (len(self._info.obs_names),):
            raise ShapeError(
                f"{type(self).__name__}: observation of shape {o.shape}; {self._info.name} "
                f"gives ({len(self._info.obs_names)},)"
            )
        if self._k % self._every == 0:
            u = float(self.update(o))
            if not math.isfinite(u):
                raise SimulationError(
                    f"{type(self).__name__}: the command is {u!r} at step {self._k}; "
                    f"observation {o.tolist()}"
                )
            self._u = min(max(u, 0.0), 1.0)
        self._k += 1
        return self._u

    def act(self, obs: ArrayLike) -> Any:
        """The action for ``obs`` (one call per environment step)."""
        u = self.command(obs)
        full = np.array(self.info.hold, dtype=np.float64)
        full[self.bound_loop.channel] = u
        return self.info.to_action(full)

    # ---------------------------------------------------------- description
    def settings(self) -> dict[str, Any]:
        """JSON-able settings (recorded with every benchmark result)."""
        out: dict[str, Any] = {"type": type(self).__name__}
        if self.loop is not None:
            out["loop"] = self.loop.to_dict()
        if self.sample_time is not None:
            out["sample_time_s"] = self.sample_time
        out.update(self._settings())
        return out

    def _settings(self) -> dict[str, Any]:
        return {}

    def stats(self) -> dict[str, float]:
        """Counters of the episode so far (e.g. solver failures); empty by default."""
        return {}

    def __repr__(self) -> str:
        s = self.settings()
        s.pop("type", None)
        inner = ", ".join(f"{k}={v!r}" for k, v in s.items())
        return f"{type(self).__name__}({inner})"


class Decentralized(Controller):
    """Several single-loop controllers, one per action channel (e.g. TCLab's two heaters).

    Parameters
    ----------
    controllers : sequence of Controller
        Each with its own loop; default loops are taken in order from the
        environment's :data:`ENV_LOOPS` for those without one.

    Examples
    --------
    >>> import gymnasium as gym
    >>> import thermogym.envs
    >>> from thermogym.controllers import OnOff
    >>> env = gym.make("thermogym/TCLab-v0")
    >>> ctrl = Decentralized([OnOff(1.0), OnOff(1.0)]).bind(env)
    >>> obs, _ = env.reset(seed=0)
    >>> ctrl.act(obs).tolist()  # both sensors below their set-points: both heaters on
    [1.0, 1.0]
    """

    kind = "any"
    label = "decentralized"

    def __init__(self, controllers: Sequence[Controller]) -> None:
        super().__init__()
        ctrls = list(controllers)
        if not ctrls or not all(isinstance(c, Controller) for c in ctrls):
            raise ConfigError("Decentralized needs a non-empty list of controllers")
        self.controllers = ctrls

    def bind(
        self,
        env: Any,
        *,
        obs_names: Sequence[str] | None = None,
        sample_time: float | None = None,
        inner: bool = False,
    ) -> Controller:
        """Bind every controller to its loop (default loops in order)."""
        info = env_info(env, obs_names=obs_names)
        defaults = ENV_LOOPS.get(info.name, ())
        used = set()
        for i, c in enumerate(self.controllers):
            if c.loop is None:
                if i >= len(defaults):
                    raise ConfigError(
                        f"Decentralized on {info.name}: controller {i} has no loop and the "
                        f"environment has {len(defaults)} default loop(s); give loop=Loop(...)"
                    )
                c.loop = defaults[i]
            if c.loop.channel in used:
                raise ConfigError(
                    f"Decentralized on {info.name}: two controllers drive channel {c.loop.channel}"
                )
            used.add(c.loop.channel)
            c.bind(info, inner=inner)
        self._info = info
        self._loop = self.controllers[0].loop
        self.h = info.dt
        self.reset()
        return self

    def reset(self, *, seed: int | None = None) -> None:
        """Reset every controller."""
        super().reset(seed=seed)
        for c in self.controllers:
            if c._info is not None:
                c.reset(seed=seed)

    def update(self, obs: NDArray[np.float64]) -> float:  # pragma: no cover - not used
        """Not used: :meth:`act` combines the channels."""
        raise NotImplementedError

    def act(self, obs: ArrayLike) -> Any:
        """Every controller's command on its channel; the others held."""
        full = np.array(self.info.hold, dtype=np.float64)
        for c in self.controllers:
            full[c.bound_loop.channel] = c.command(obs)
        return self.info.to_action(full)

    def _settings(self) -> dict[str, Any]:
        return {"controllers": [c.settings() for c in self.controllers]}

    def stats(self) -> dict[str, float]:
        """Stats of every controller, prefixed by its channel."""
        out: dict[str, float] = {}
        for c in self.controllers:
            out.update({f"ch{c.bound_loop.channel}_{k}": v for k, v in c.stats().items()})
        return out


@dataclass
class _Counter:
    """Episode counters a controller reports in :meth:`Controller.stats`."""

    values: dict[str, float] = field(default_factory=dict)

    def add(self, name: str, v: float = 1.0) -> None:
        self.values[name] = self.values.get(name, 0.0) + v

    def clear(self) -> None:
        self.values.clear()


def settings_of(obj: Mapping[str, Any]) -> dict[str, Any]:
    """A copy of a settings mapping with NumPy scalars turned into Python numbers."""
    out: dict[str, Any] = {}
    for k, v in obj.items():
        if isinstance(v, np.generic):
            v = v.item()
        elif isinstance(v, np.ndarray):
            v = v.tolist()
        out[k] = v
    return out
