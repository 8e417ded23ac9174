"""Named controller presets per environment: what ``thermogym bench --controllers`` builds.

Each preset is a controller with settings derived from the identified linear
models shipped in ``thermogym/controllers/data/`` (made by
``scripts/make_models.py`` on the *identified model* environment) — never from
the plant it is evaluated on:

=====================  ========================================================================
name                   controller
=====================  ========================================================================
``onoff``              thermostat with hysteresis (:class:`~.onoff.OnOff`): 0.2 mm on the
                       valve stroke, 0.5 K on the room, 1 K on each TCLab sensor
``pwm-high``           open-loop PWM at 10 s / 2 min / 20 min (paper 002 section VIII) with
``pwm-medium``         the duty of the model's static inverse at that frequency: valve —
``pwm-low``            the stroke-duty table (:class:`~.feedforward.StaticMap`); room — the
                       heating curve of the N4SID model (:class:`~.feedforward.LinearFeedforward`)
``pid-high``           PI (SIMC-tuned on the identified model, the PWM half-period and half
``pid-medium``         the sample time added as delay) behind a PWM stage at that frequency,
``pid-low``            running once per PWM period; room: τ_c ≥ 1 h (a 0.44-NRMSE model)
``pid``                the environment's default PID: valve ``pid-high``, room ``pid-low``,
                       TCLab a decentralised PI per heater (1 s)
``onoff-reactive``     room only: ``onoff`` and ``pid-low`` without optimum start (they follow
``pid-reactive``       the schedule's set-point as it comes, and recover from the night
                       setback only after occupancy has begun)
``mpc``                :class:`~.mpc.MPC`: valve — tracking, 10 s samples, 40-sample horizon;
                       room — economic (heat, comfort band with the occupancy preview,
                       switching cost), 20 min samples through PWM at 20 min, 12 h horizon
``ppo``, ``sac``,      a trained policy (:class:`~.rl.RLController`): the one shipped in
``dqn``                ``controllers/policies/`` or ``options={"policy": PATH}``
``random``             uniformly random actions (seeded): the RL baseline
=====================  ========================================================================

Groups: ``pwm`` → the three ``pwm-*``; ``pid-pwm`` → the three ``pid-*``.

Room presets that follow the set-point schedule (``onoff``, ``pwm-*``,
``pid-*``) start heating ahead of occupancy by the room's recovery time
(:class:`~.schedule.OptimumStart`, 0.6 K/h), as the MPC previews the
schedule: without it every reactive controller starts the occupied day
2-4 K below the comfort band (``onoff-reactive``, ``pid-reactive``). When the
episode's ``start_day`` is not known (the environment draws it), they run
without optimum start and their settings say so.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping, Sequence
from functools import cache
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from thermogym.controllers.base import Controller, Decentralized, EnvInfo, Loop, env_info
from thermogym.controllers.feedforward import LinearFeedforward, StaticMap
from thermogym.controllers.mpc import MPC, SchedulePreview
from thermogym.controllers.onoff import OnOff
from thermogym.controllers.pid import PID, simc
from thermogym.controllers.pwm import PWM, PWM_PERIODS
from thermogym.controllers.rl import RLController
from thermogym.controllers.schedule import OptimumStart
from thermogym.errors import ConfigError, UnknownNameError
from thermogym.fitresult import FitResult, load_fit

__all__ = [
    "CONTROLLER_GROUPS",
    "CONTROLLER_NAMES",
    "RandomController",
    "build_controller",
    "data_path",
    "expand_controllers",
    "model_fit",
]

#: Preset names.
CONTROLLER_NAMES: tuple[str, ...] = (
    "onoff",
    "pwm-high",
    "pwm-medium",
    "pwm-low",
    "pid",
    "pid-high",
    "pid-medium",
    "pid-low",
    "onoff-reactive",
    "pid-reactive",
    "mpc",
    "ppo",
    "sac",
    "dqn",
    "random",
)
#: Names that stand for several presets.
CONTROLLER_GROUPS: dict[str, tuple[str, ...]] = {
    "pwm": ("pwm-high", "pwm-medium", "pwm-low"),
    "pid-pwm": ("pid-high", "pid-medium", "pid-low"),
}


def data_path(name: str) -> Path:
    """Path of a file shipped in ``thermogym/controllers/data/``."""
    return Path(str(resources.files("thermogym.controllers").joinpath("data", name)))


@cache
def model_fit(name: str) -> FitResult:
    """A shipped FitResult of ``controllers/data/`` (read once)."""
    p = data_path(name)
    if not p.exists():
        raise ConfigError(f"the controller model {p} is missing; run scripts/make_models.py")
    return load_fit(p)


@cache
def _static_table(freq: str) -> tuple[NDArray[np.float64], NDArray[np.float64], str]:
    p = data_path("axt211valve_static.json")
    d = json.loads(p.read_text(encoding="utf-8"))
    m = d["maps"][freq]
    duty, x = np.asarray(m["duty"]), np.asarray(m["x_V"])
    # a single-valued inverse: from the last duty of the shut plateau to the first of the
    # fully open one, strictly increasing strokes only
    i0 = int(np.flatnonzero(x <= x.min() + 1e-6)[-1])
    i1 = int(np.flatnonzero(x >= x.max() - 1e-6)[0])
    keep_d: list[float] = []
    keep_x: list[float] = []
    for di, xi in zip(duty[i0 : i1 + 1], x[i0 : i1 + 1], strict=True):
        if not keep_x or xi > keep_x[-1] + 1e-6:
            keep_d.append(float(di))
            keep_x.append(float(xi))
    return np.asarray(keep_x), np.asarray(keep_d), f"{p.name} ({freq})"


def expand_controllers(names: str | Sequence[str]) -> list[str]:
    """Split a comma list and expand groups (``pwm`` → three presets), keeping order.

    Examples
    --------
    >>> expand_controllers("onoff,pwm,pid")
    ['onoff', 'pwm-high', 'pwm-medium', 'pwm-low', 'pid']
    """
    items = names.split(",") if isinstance(names, str) else list(names)
    out: list[str] = []
    for raw in items:
        n = raw.strip()
        if not n:
            continue
        for m in CONTROLLER_GROUPS.get(n, (n,)):
            if m not in CONTROLLER_NAMES:
                raise UnknownNameError(
                    f"no controller preset {m!r}; presets are {list(CONTROLLER_NAMES)} and "
                    f"groups {list(CONTROLLER_GROUPS)}"
                )
            if m not in out:
                out.append(m)
    if not out:
        raise ConfigError("no controller named")
    return out


class RandomController(Controller):
    """Uniformly random commands (0/1 on on/off actions), seeded at reset: the RL baseline."""

    kind = "any"
    label = "random"

    def __init__(self, *, loop: Loop | None = None, sample_time: float | None = None) -> None:
        super().__init__(loop=loop, sample_time=sample_time)
        self._rng = np.random.default_rng(0)

    def _needs_measurement(self) -> bool:
        return False

    def _needs_setpoint(self) -> bool:
        return False

    def _reset(self, seed: int | None) -> None:
        self._rng = np.random.default_rng(seed)

    def update(self, obs: NDArray[np.float64]) -> float:
        """A random command."""
        if self.info.discrete:
            return float(self._rng.integers(0, 2))
        return float(self._rng.uniform(0.0, 1.0))

    def act(self, obs: Any) -> Any:
        """Random command on every channel."""
        self.command(obs)
        if self.info.discrete:
            return int(self._u)
        return self._rng.uniform(-1.0, 1.0, self.info.n_channels).astype(np.float32)


# ------------------------------------------------------------------ builders
def _pi(model: Any, period: float, h: float, *, tau_c_min: float = 0.0, **kw: Any) -> PID:
    # delay of the PWM stage (half a period) and of sampling (half a sample) — the half rule
    extra = period / 2.0 + h / 2.0
    f = model if not isinstance(model, str) else model_fit(model)
    g0 = simc(f, extra_delay=extra, **kw)
    theta = g0.model["tau"] + extra if g0.model else extra
    gains = simc(f, extra_delay=extra, tau_c=max(theta, tau_c_min), **kw)
    return PID(gains=gains)


def _valve(name: str, info: EnvInfo, env_kwargs: Mapping[str, Any]) -> Controller:
    if name == "onoff":
        return OnOff(hysteresis=0.2)
    freq = name.split("-")[1] if "-" in name else "high"
    if name.startswith("pwm-"):
        x, d, src = _static_table(freq)
        return PWM(freq, inner=StaticMap(x, d, source=src))
    if name.startswith("pid"):
        period = max(PWM_PERIODS[freq], info.dt)
        pid = _pi(model_fit("axt211valve_foptd.json"), period, period)
        return PWM(period, inner=pid)
    if name == "mpc":
        mpc = MPC(
            model_fit("axt211valve_foptd.json"),
            horizon=40,
            control_horizon=10,
            q=1.0,
            r_du=0.05,
            switching_cost=0.01,
            energy_cost=0.0,
            noise=(1e-4, 1e-4, 4e-4),
        )
        return PWM(max(10.0, info.dt), inner=mpc)
    raise KeyError(name)


#: Recovery rate of the room at full heat [K/h] for optimum start: the identified-model
#: room under the on/off thermostat rose 17.0 → 20.3 °C in 5 h (winter-week@1, seed 0).
ROOM_RECOVERY_K_PER_H = 0.6


def _optimum_start(ctrl: Controller, env_kwargs: Mapping[str, Any]) -> Controller:
    if env_kwargs.get("start_day") is None:
        return ctrl  # the weekday is unknown: follow the schedule as it comes
    return OptimumStart(
        ctrl, SchedulePreview.from_env_kwargs(env_kwargs), rate_K_per_h=ROOM_RECOVERY_K_PER_H
    )


def _room(name: str, info: EnvInfo, env_kwargs: Mapping[str, Any]) -> Controller:
    dist = {"T_out": "T_out", "occupied": "occupied"}
    reactive = name.endswith("-reactive")
    if reactive:
        name = {"onoff-reactive": "onoff", "pid-reactive": "pid-low"}[name]
    ctrl: Controller
    if name == "onoff":
        ctrl = OnOff(hysteresis=0.5)
    elif name.startswith("pwm-"):
        freq = name.split("-")[1]
        ff = LinearFeedforward(model_fit(f"axt211room_ss_{freq}.json"), disturbances=dist)
        ctrl = PWM(freq, inner=ff)
    elif name.startswith("pid"):
        freq = name.split("-")[1] if "-" in name else "low"
        period = max(PWM_PERIODS[freq], info.dt)
        pid = _pi(
            model_fit(f"axt211room_ss_{freq}.json"),
            period,
            period,
            tau_c_min=3600.0,
            input="duty",
            output="T_zone",
        )
        ctrl = PWM(period, inner=pid)
    else:
        ctrl = None  # type: ignore[assignment]
    if ctrl is not None:
        return ctrl if reactive else _optimum_start(ctrl, env_kwargs)
    if name == "mpc":
        try:
            preview: Any = SchedulePreview.from_env_kwargs(env_kwargs)
        except ConfigError as e:
            raise ConfigError(
                f"the room MPC previews the occupancy schedule and needs start_day: {e}"
            ) from None
        mpc = MPC(
            model_fit("axt211room_ss_low.json"),
            input="duty",
            disturbances=dist,
            horizon=36,
            q=0.0,
            r_du=0.01,
            switching_cost=0.05,
            energy_cost=0.3,
            band_weight=(5.0, 5.0),
            noise=(1e-3, 1e-2, 1e-2),
            preview=preview,
        )
        return PWM("low", inner=mpc)
    raise KeyError(name)


def _tclab(name: str, info: EnvInfo, env_kwargs: Mapping[str, Any]) -> Controller:
    if name == "onoff":
        return Decentralized([OnOff(1.0), OnOff(1.0)])
    if name == "pid":
        fit = model_fit("tclab_foptd.json")
        ctrls: list[Controller] = []
        for i in (1, 2):
            g = simc(fit, input=f"Q{i}", output=f"T{i}", input_scale=100.0, extra_delay=info.dt / 2)
            ctrls.append(PID(gains=g))
        return Decentralized(ctrls)
    raise KeyError(name)


_BUILDERS: dict[str, Callable[[str, EnvInfo, Mapping[str, Any]], Controller]] = {
    "AXT211Valve": _valve,
    "AXT211Room": _room,
    "TCLab": _tclab,
}


def _policy_path(name: str, env_name: str) -> Path:
    return Path(
        str(
            resources.files("thermogym.controllers").joinpath(
                "policies", f"{env_name.lower()}_{name}.zip"
            )
        )
    )


def build_controller(
    name: str,
    env: Any,
    *,
    env_kwargs: Mapping[str, Any] | None = None,
    options: Mapping[str, Any] | None = None,
) -> Controller:
    """Build preset ``name`` for an environment and bind it.

    Parameters
    ----------
    name : str
        A name of :data:`CONTROLLER_NAMES`.
    env : gymnasium.Env
        The environment it will drive (its layout and control period).
    env_kwargs : mapping, optional
        The keyword arguments the environment was made with (the room MPC
        reads the schedule and ``start_day`` from them).
    options : mapping, optional
        ``{"policy": PATH}`` for ``ppo``/``sac``/``dqn``.

    Returns
    -------
    Controller
        Bound to ``env``.

    Raises
    ------
    UnknownNameError
        An unknown preset.
    ConfigError
        No preset of that name for the environment (the message lists those
        that exist), or no policy for an RL preset.

    Examples
    --------
    >>> import gymnasium as gym
    >>> import thermogym.envs
    >>> env = gym.make("thermogym/AXT211Valve-v0")
    >>> ctrl = build_controller("pid", env)
    >>> type(ctrl).__name__, ctrl.period, type(ctrl.inner).__name__
    ('PWM', 10.0, 'PID')
    """
    if name not in CONTROLLER_NAMES:
        raise UnknownNameError(
            f"no controller preset {name!r}; presets are {list(CONTROLLER_NAMES)}"
        )
    info = env_info(env)
    kw = dict(env_kwargs or {})
    opts = dict(options or {})
    if name == "random":
        return RandomController().bind(env)
    if name in ("ppo", "sac", "dqn"):
        path = opts.get("policy")
        if path is None:
            path = _policy_path(name, info.name)
            if not path.exists():
                raise ConfigError(
                    f"no {name.upper()} policy is shipped for {info.name}; train one "
                    "(thermogym.controllers.rl.train) and pass its path "
                    f"(options={{'policy': PATH}}, thermogym bench --policy {name}=PATH)"
                )
        return RLController.load(path).for_env(env)
    builder = _BUILDERS.get(info.name)
    if builder is None:
        raise ConfigError(
            f"no controller presets for {info.name}; presets exist for {sorted(_BUILDERS)} "
            "(build controllers yourself with a Loop for this environment)"
        )
    try:
        ctrl = builder(name, info, kw)
    except KeyError:
        have = [n for n in CONTROLLER_NAMES if _has(builder, n, info, kw)]
        raise ConfigError(
            f"no preset {name!r} for {info.name}; it has {[*have, 'random']}"
        ) from None
    return ctrl.bind(env)


def _has(builder: Callable[..., Controller], name: str, info: EnvInfo, kw: Mapping) -> bool:
    try:
        builder(name, info, kw)
    except KeyError:
        return False
    except Exception:  # exists, but cannot be built here (e.g. needs start_day)
        return True
    return True
