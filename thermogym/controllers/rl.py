"""Reinforcement learning: train stable-baselines3 policies, drive environments with them.

Training (:func:`train`)
------------------------
:class:`RLConfig` is the whole experiment: algorithm (PPO and SAC for the
continuous duty, DQN for on/off actions), environment ID and keyword
arguments, budget, seeds, evaluation and checkpoint frequencies. The run
writes into ``config.out``::

    policy.zip            the final policy (stable-baselines3 format)
    policy.json           provenance: what it was trained on (below)
    best/best_model.zip   the best policy of the periodic evaluations
    checkpoints/          periodic checkpoints
    evaluations.npz       the evaluation curve (EvalCallback)
    tb/                   TensorBoard logs

``policy.json`` records the environment ID and version, its keyword
arguments, the fingerprint of the FitResult of the plant it was trained on,
the observation names and bounds, the control period, the action kind, the
algorithm and its settings, seeds, budget, wall time, the package and library
versions, and the final evaluation against a random policy on the same
seeds. Observations are scaled to [-1, 1] by the environment's observation
bounds (:class:`ScaledObservation`), a fixed map that travels with the
policy (no running statistics to save).

Deployment (:class:`RLController`)
----------------------------------
``RLController.load(path)`` reads a policy and its provenance and drives any
environment whose observation holds the names the policy was trained on.
The policy decides once per *its* control period; on an environment with a
shorter control period its duty is applied by a PWM stage of that period
(exactly what the training environment did inside one period) — use
:meth:`RLController.for_env`. The ``u_prev`` entry (last applied duty) is the
policy's own last decision, as in training. A policy evaluated on a plant
with another FitResult fingerprint (the rig, a refreshed identification) is
logged once: that is the sim-to-real gap the benchmark measures.
"""

from __future__ import annotations

import json
import logging
import math
import os
import time
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

import thermogym.envs  # noqa: F401 - registers the environments
from thermogym import __version__
from thermogym._fileio import atomic_write_text
from thermogym.controllers.base import Controller, EnvInfo, Loop, env_info
from thermogym.controllers.pwm import PWM
from thermogym.errors import ConfigError, UnknownNameError

__all__ = [
    "ALGORITHMS",
    "RLConfig",
    "RLController",
    "ScaledObservation",
    "TrainResult",
    "evaluate",
    "train",
]

log = logging.getLogger("thermogym.controllers")

#: Algorithms and the action space they need.
ALGORITHMS = {"ppo": "any", "sac": "continuous", "dqn": "discrete"}


class ScaledObservation(gym.ObservationWrapper):
    """Scale a ``Box`` observation to [-1, 1] by its bounds (clipped).

    ``o' = 2 (o − low) / (high − low) − 1``; entries with infinite bounds
    are passed through unchanged.

    Examples
    --------
    >>> env = ScaledObservation(gym.make("thermogym/AXT211Valve-v0"))
    >>> obs, _ = env.reset(seed=0)
    >>> bool(np.all(np.abs(obs) <= 1.0))
    True
    """

    def __init__(self, env: gym.Env[Any, Any]) -> None:
        super().__init__(env)
        space = env.observation_space
        if not isinstance(space, spaces.Box):
            raise ConfigError(f"ScaledObservation needs a Box observation; got {space}")
        self.low = np.asarray(space.low, dtype=np.float64)
        self.high = np.asarray(space.high, dtype=np.float64)
        self._finite = np.isfinite(self.low) & np.isfinite(self.high) & (self.high > self.low)
        lo = np.where(self._finite, -1.0, space.low).astype(np.float32)
        hi = np.where(self._finite, 1.0, space.high).astype(np.float32)
        self.observation_space = spaces.Box(lo, hi, dtype=np.float32)

    def observation(self, observation: Any) -> NDArray[np.float32]:
        """The scaled observation."""
        return scale_obs(np.asarray(observation, np.float64), self.low, self.high, self._finite)


def scale_obs(
    o: NDArray[np.float64], low: NDArray[np.float64], high: NDArray[np.float64], finite: Any
) -> NDArray[np.float32]:
    """``2 (o − low)/(high − low) − 1`` clipped to [-1, 1] where the bounds are finite."""
    span = np.where(finite, high - low, 1.0)
    s = np.where(finite, np.clip(2.0 * (o - low) / span - 1.0, -1.0, 1.0), o)
    return s.astype(np.float32)


@dataclass
class RLConfig:
    """One RL training run (every field is saved with the policy)."""

    algo: str = "ppo"
    """``"ppo"`` (continuous or on/off actions), ``"sac"`` (continuous), ``"dqn"`` (on/off)."""
    env_id: str = "thermogym/AXT211Valve-v0"
    """Registered environment ID to train on."""
    env_kwargs: dict[str, Any] = field(default_factory=dict)
    """Keyword arguments of ``gymnasium.make`` (the identified model: ``params``; the
    control period, episode length, scenario conditions)."""
    total_timesteps: int = 100_000
    """Training budget in environment steps (all parallel environments together)."""
    seed: int = 0
    """Seed of the algorithm, the networks and the training environments (``seed + i``)."""
    n_envs: int = 4
    """Parallel training environments (in this process, ``DummyVecEnv``)."""
    algo_kwargs: dict[str, Any] = field(default_factory=dict)
    """Keyword arguments of the stable-baselines3 algorithm (``learning_rate``, ``n_steps``...)."""
    policy_kwargs: dict[str, Any] = field(default_factory=dict)
    """``policy_kwargs`` of the algorithm (``net_arch``...)."""
    eval_freq: int = 10_000
    """Evaluate every this many steps (0: no periodic evaluation)."""
    n_eval_episodes: int = 5
    """Episodes per evaluation (seeds ``eval_seed + i``)."""
    eval_seed: int = 10_000
    """First seed of the evaluation episodes (disjoint from the training seeds)."""
    checkpoint_freq: int = 0
    """Save a checkpoint every this many steps (0: none)."""
    out: str = "rl-run"
    """Output folder (policy, provenance, checkpoints, logs)."""
    tensorboard: bool = True
    """Write TensorBoard logs to ``out/tb``."""
    torch_threads: int = 1
    """Torch CPU threads (1 keeps runs reproducible and the machine shared)."""
    verbose: int = 0
    """stable-baselines3 verbosity."""

    def __post_init__(self) -> None:
        if self.algo not in ALGORITHMS:
            raise ConfigError(
                f"RLConfig: algo is {self.algo!r}; expected one of {list(ALGORITHMS)}"
            )
        for name in ("total_timesteps", "n_envs", "n_eval_episodes"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise ConfigError(f"RLConfig: {name} is {v!r}; expected an integer >= 1")
        for name in ("eval_freq", "checkpoint_freq"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 0:
                raise ConfigError(f"RLConfig: {name} is {v!r}; expected an integer >= 0")


@dataclass
class TrainResult:
    """Outcome of :func:`train`.

    Attributes
    ----------
    policy_path : Path
        ``out/policy.zip``.
    meta : dict
        The provenance written to ``out/policy.json``.
    seconds : float
        Wall time of training.
    """

    policy_path: Path
    meta: dict[str, Any]
    seconds: float


def _make_env(env_id: str, kwargs: Mapping[str, Any]) -> gym.Env[Any, Any]:
    return ScaledObservation(gym.make(env_id, **dict(kwargs)))


def _algo_class(algo: str) -> Any:
    import stable_baselines3 as sb3

    return {"ppo": sb3.PPO, "sac": sb3.SAC, "dqn": sb3.DQN}[algo]


def evaluate(
    policy: Any,
    env_id: str,
    env_kwargs: Mapping[str, Any],
    seeds: list[int] | range,
) -> dict[str, Any]:
    """Mean return and KPIs of a policy (or ``"random"``) on episodes with the given seeds.

    Parameters
    ----------
    policy : stable-baselines3 model, RLController or "random"
    env_id : str
    env_kwargs : mapping
    seeds : list of int

    Returns
    -------
    dict
        ``return_mean``, ``return_std``, ``returns``, ``kpis`` (mean per KPI).
    """
    rets, kpis = [], []
    for s in seeds:
        env = gym.make(env_id, **dict(env_kwargs))
        if isinstance(policy, RLController):
            ctrl = policy.for_env(env)
        obs, _ = env.reset(seed=int(s))
        rng = np.random.default_rng(int(s))
        if isinstance(policy, RLController):
            ctrl.reset(seed=int(s))
        wrapped = None if policy == "random" or isinstance(policy, RLController) else policy
        sc = ScaledObservation(env) if wrapped is not None else None
        total, done = 0.0, False
        info: dict[str, Any] = {}
        while not done:
            if policy == "random":
                a = _random_action(env.action_space, rng)
            elif isinstance(policy, RLController):
                a = ctrl.act(obs)
            else:
                a, _ = wrapped.predict(sc.observation(obs), deterministic=True)  # type: ignore[union-attr]
            obs, r, term, trunc, info = env.step(a)
            total += float(r)
            done = term or trunc
        rets.append(total)
        kpis.append(info.get("kpis", {}))
    keys = kpis[0].keys() if kpis else []
    return {
        "return_mean": float(np.mean(rets)),
        "return_std": float(np.std(rets)),
        "returns": rets,
        "kpis": {k: float(np.mean([d[k] for d in kpis])) for k in keys},
    }


def _random_action(space: spaces.Space[Any], rng: np.random.Generator) -> Any:
    if isinstance(space, spaces.Discrete):
        return int(rng.integers(0, space.n))
    assert isinstance(space, spaces.Box)
    return rng.uniform(space.low, space.high).astype(np.float32)


def train(config: RLConfig) -> TrainResult:
    """Train a policy as configured; save it with its provenance (see the module docstring).

    Parameters
    ----------
    config : RLConfig

    Returns
    -------
    TrainResult

    Raises
    ------
    ConfigError
        An algorithm that does not fit the environment's actions (DQN on
        continuous actions, SAC on on/off actions).
    """
    import stable_baselines3 as sb3
    import torch
    from stable_baselines3.common.callbacks import CallbackList, CheckpointCallback, EvalCallback
    from stable_baselines3.common.monitor import Monitor
    from stable_baselines3.common.vec_env import DummyVecEnv

    cfg = config
    torch.set_num_threads(max(1, int(cfg.torch_threads)))
    out = Path(cfg.out)
    out.mkdir(parents=True, exist_ok=True)
    probe = gym.make(cfg.env_id, **cfg.env_kwargs)
    discrete = isinstance(probe.action_space, spaces.Discrete)
    need = ALGORITHMS[cfg.algo]
    if (need == "discrete" and not discrete) or (need == "continuous" and discrete):
        raise ConfigError(
            f"{cfg.algo.upper()} needs {need} actions; {cfg.env_id} with {cfg.env_kwargs} has "
            f"{probe.action_space} (action_mode='onoff' gives on/off actions)"
        )
    info = env_info(probe)

    def factory(i: int) -> Any:
        def make() -> gym.Env[Any, Any]:
            return Monitor(_make_env(cfg.env_id, cfg.env_kwargs))

        return make

    venv = DummyVecEnv([factory(i) for i in range(cfg.n_envs)])
    venv.seed(cfg.seed)
    cls = _algo_class(cfg.algo)
    kwargs = dict(cfg.algo_kwargs)
    model = cls(
        "MlpPolicy",
        venv,
        seed=cfg.seed,
        device="cpu",
        verbose=cfg.verbose,
        policy_kwargs=dict(cfg.policy_kwargs) or None,
        tensorboard_log=str(out / "tb") if cfg.tensorboard else None,
        **kwargs,
    )
    callbacks: list[Any] = []
    if cfg.eval_freq:
        eval_env = DummyVecEnv([lambda: Monitor(_make_env(cfg.env_id, cfg.env_kwargs))])
        eval_env.seed(cfg.eval_seed)
        callbacks.append(
            EvalCallback(
                eval_env,
                n_eval_episodes=cfg.n_eval_episodes,
                eval_freq=max(1, cfg.eval_freq // cfg.n_envs),
                log_path=str(out),
                best_model_save_path=str(out / "best"),
                deterministic=True,
                verbose=cfg.verbose,
            )
        )
    if cfg.checkpoint_freq:
        callbacks.append(
            CheckpointCallback(
                save_freq=max(1, cfg.checkpoint_freq // cfg.n_envs),
                save_path=str(out / "checkpoints"),
                name_prefix=cfg.algo,
            )
        )
    t0 = time.perf_counter()
    model.learn(
        total_timesteps=cfg.total_timesteps,
        callback=CallbackList(callbacks) if callbacks else None,
        tb_log_name=cfg.algo,
        progress_bar=False,
    )
    seconds = time.perf_counter() - t0
    policy_path = out / "policy.zip"
    model.save(str(policy_path))
    eval_seeds = list(range(cfg.eval_seed, cfg.eval_seed + cfg.n_eval_episodes))
    trained = evaluate(model, cfg.env_id, cfg.env_kwargs, eval_seeds)
    rand = evaluate("random", cfg.env_id, cfg.env_kwargs, eval_seeds)
    fit = getattr(probe.unwrapped, "fit", None)
    meta = {
        "format": "thermogym-policy",
        "algo": cfg.algo,
        "env_id": cfg.env_id,
        "env_version": cfg.env_id.rsplit("-", 1)[-1],
        "env_name": info.name,
        "env_kwargs": cfg.env_kwargs,
        "fit_fingerprint": fit.fingerprint() if fit is not None else None,
        "plant": info.plant,
        "obs_names": list(info.obs_names),
        "obs_low": info.obs_low.tolist(),
        "obs_high": info.obs_high.tolist(),
        "control_period_s": info.dt,
        "discrete": discrete,
        "config": asdict(cfg),
        "seconds": seconds,
        "timesteps": cfg.total_timesteps,
        "evaluation": {"seeds": eval_seeds, "policy": trained, "random": rand},
        "package_version": __version__,
        "stable_baselines3_version": sb3.__version__,
        "torch_version": torch.__version__,
    }
    atomic_write_text(out / "policy.json", json.dumps(meta, indent=1, default=str) + "\n")
    return TrainResult(policy_path, meta, seconds)


class RLController(Controller):
    """A trained stable-baselines3 policy behind the controller interface.

    Parameters
    ----------
    model : stable-baselines3 model
        The policy (``predict`` is called with ``deterministic=True``).
    meta : dict
        Provenance (``policy.json``): observation names and bounds, control
        period, action kind, FitResult fingerprint.
    path : str, optional
        Where it was loaded from (recorded in the settings).
    """

    label = "rl"

    def __init__(self, model: Any, meta: Mapping[str, Any], *, path: str | None = None) -> None:
        super().__init__(sample_time=float(meta["control_period_s"]))
        self.model = model
        self.meta = dict(meta)
        self.path = path
        self.kind = "binary" if meta.get("discrete") else "continuous"  # type: ignore[misc]
        self._low = np.asarray(meta["obs_low"], dtype=np.float64)
        self._high = np.asarray(meta["obs_high"], dtype=np.float64)
        self._finite = np.isfinite(self._low) & np.isfinite(self._high) & (self._high > self._low)
        self._warned = False

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> RLController:
        """Load ``policy.zip`` (or a folder holding it) and its ``policy.json``.

        Raises
        ------
        ConfigError
            Missing files or a provenance file that is not a thermogym policy.
        """
        p = Path(path)
        if p.is_dir():
            p = p / "policy.zip"
        meta_path = p.with_suffix(".json")
        if not p.exists():
            raise ConfigError(f"no policy at {p}")
        if not meta_path.exists():
            raise ConfigError(
                f"policy {p} has no provenance file {meta_path.name}; policies trained by "
                "thermogym.controllers.rl.train carry one"
            )
        meta = json.loads(meta_path.read_text(encoding="utf-8"))
        if meta.get("format") != "thermogym-policy" or meta.get("algo") not in ALGORITHMS:
            raise ConfigError(f"{meta_path} is not a thermogym policy provenance file")
        import torch

        torch.set_num_threads(1)
        model = _algo_class(meta["algo"]).load(str(p), device="cpu")
        return cls(model, meta, path=str(p))

    def _needs_measurement(self) -> bool:
        return False

    def _needs_setpoint(self) -> bool:
        return False

    def _default_loop(self, info: EnvInfo) -> Any:
        return Loop("(policy)", 0.0, 0)

    def _bind(self, info: EnvInfo) -> None:
        who = f"{self.meta['algo'].upper()} policy on {info.name}"
        names = list(self.meta["obs_names"])
        trained_on = self.meta.get("env_name")
        if trained_on and trained_on != info.name:
            log.info("%s: trained on %s", who, trained_on)
        missing = [n for n in names if n not in info.obs_names and n != "u_prev"]
        if missing:
            raise UnknownNameError(
                f"{who}: the policy observes {missing}, which the environment does not give; "
                f"its observation is {list(info.obs_names)}"
            )
        self._idx = np.array(
            [info.obs_names.index(n) if n in info.obs_names else -1 for n in names]
        )
        self._i_prev = names.index("u_prev") if "u_prev" in names else -1
        if info.n_channels != 1 and not self.meta.get("discrete"):
            n_act = self.model.action_space.shape[0]
            if n_act != info.n_channels:
                raise ConfigError(
                    f"{who}: the policy has {n_act} action(s), the environment {info.n_channels}"
                )
        fp = self.meta.get("fit_fingerprint")
        if fp and info.fit_fingerprint and fp != info.fit_fingerprint and not self._warned:
            log.info(
                "%s: trained on plant parameters %s…, runs on %s… (%s)",
                who,
                fp[:12],
                info.fit_fingerprint[:12],
                info.plant,
            )
            self._warned = True

    def _reset(self, seed: int | None) -> None:
        self._last = 0.0

    def policy_observation(self, obs: NDArray[np.float64]) -> NDArray[np.float32]:
        """The (scaled) observation the policy was trained on, from an environment observation."""
        o = np.where(self._idx >= 0, obs[np.maximum(self._idx, 0)], 0.0)
        if self._i_prev >= 0:
            o[self._i_prev] = self._last  # the policy's own last decision, as in training
        return scale_obs(o, self._low, self._high, self._finite)

    def update(self, obs: NDArray[np.float64]) -> float:
        """The policy's decision (a duty, or 0/1)."""
        a, _ = self.model.predict(self.policy_observation(obs), deterministic=True)
        if self.meta.get("discrete"):
            u = float(int(np.asarray(a).reshape(-1)[0]))
        else:
            u = 0.5 * (float(np.clip(np.asarray(a, dtype=float).reshape(-1)[0], -1, 1)) + 1.0)
        self._last = u
        return u

    def for_env(self, env: Any) -> Controller:
        """Bound controller for ``env``: itself, or behind a PWM stage of its control period.

        The policy decides every ``control_period_s`` of its training
        environment, which applied a continuous decision as PWM within that
        period; on an environment with a shorter control period the same is
        done by :class:`~thermogym.controllers.pwm.PWM`.
        """
        info = env_info(env)
        tc = float(self.meta["control_period_s"])
        if math.isclose(tc, info.dt) or self.meta.get("discrete"):
            return self.bind(env)
        return PWM(tc, inner=self).bind(env)

    def _settings(self) -> dict[str, Any]:
        m = self.meta
        return {
            "algo": m.get("algo"),
            "policy": self.path,
            "trained_env": m.get("env_id"),
            "trained_env_kwargs": m.get("env_kwargs"),
            "fit_fingerprint": m.get("fit_fingerprint"),
            "timesteps": m.get("timesteps"),
            "control_period_s": m.get("control_period_s"),
        }
