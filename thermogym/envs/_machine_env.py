"""Plumbing shared by the machine-tool environments (spindle, strut): settings and engine.

:class:`MachineConfig` holds the keyword arguments every machine-tool
environment takes (the plant: a model's FitResult or the rig's true plant; the
control period and episode length; sensor noise, reward weights and domain
randomisation); each environment's config adds its own. :class:`MachineEngine`
is the part of their engines that is not their task: the checks of those
settings, the plant (:func:`~thermogym.envs._network.network_plant`), the
sensors, and the call of the compiled step kernel, after the rig's or a
nonlinear network's step where one runs. Rewards, KPIs, actions and
observations stay in each environment's module (its row kernel).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from thermogym.envs._base import C_K, parse_noise, parse_weights
from thermogym.envs._kernels import meas_array
from thermogym.envs._network import LTIEngine, network_plant
from thermogym.envs._plant import ParamsLike
from thermogym.errors import ConfigError

__all__ = ["MachineConfig", "MachineEngine"]


@dataclass
class MachineConfig:
    """Keyword arguments shared by the machine-tool environments (spindle, strut)."""

    params: ParamsLike = None
    """FitResult of the environment's model (see the environment's config)."""
    plant: str = "model"
    """``"model"`` or ``"rig"`` (the rig's true plant)."""
    rig_effects: Sequence[str] = ()
    """Effects of the rig (``plant="rig"``)."""
    specimen_seed: int | None = None
    """``plant="rig"``: seed of the rig's specimen drawn from its spread (None: the rig's own)."""
    control_period: float = 60.0
    """Control period [s]."""
    episode_s: float = 8 * 3600.0
    """Episode length [s]."""
    sensor_noise: bool | Mapping[str, float] = True
    """Sensor noise; False: exact; a dict overrides σ per observed channel."""
    reward_weights: Mapping[str, float] | None = None
    """Overrides of the environment's ``DEFAULT_WEIGHTS``."""
    randomize: str | None = None
    """Domain randomisation per episode."""
    randomize_kwargs: Mapping[str, Any] | None = None
    """``scale``, ``names``, ``bounds`` of the randomisation."""


class MachineEngine(LTIEngine):
    """Engine of a machine-tool environment: a linear model's or the rig's plant.

    Subclasses set the class attributes, check their own settings in
    :meth:`_settings` and implement :meth:`_manipulated` (the manipulated input
    of an action), the row kernel's arrays (:attr:`kernels`, :attr:`cfgv`) and
    their KPIs.

    Parameters
    ----------
    B : int
        Number of plants.
    cfg : MachineConfig
        The environment's settings.
    """

    #: Model names the environment accepts (``params``) and the default model.
    models: ClassVar[tuple[str, ...]] = ()
    default_model: ClassVar[Any] = None
    #: The rig of ``plant="rig"`` and the rig effects it can step control period by period.
    rig_name: ClassVar[str] = ""
    stepwise_effects: ClassVar[tuple[str, ...]] = ()
    #: Model outputs the environment needs (kernel order) and its (input, ambient) signals.
    plant_outputs: ClassVar[tuple[str, ...]] = ()
    plant_inputs: ClassVar[tuple[str, str]] = ("", "")
    #: Sensors of :attr:`noise_channels`: (σ, resolution).
    sensor_table: ClassVar[dict[str, tuple[float, float]]] = {}
    default_weights: ClassVar[dict[str, float]] = {}
    #: Accumulator floats per plant.
    n_accumulators: ClassVar[int] = 0
    #: The row kernel's loops (serial, parallel), from :func:`thermogym.envs._kernels.plant_loops`.
    kernels: ClassVar[tuple[Any, Any]]

    cfgv: NDArray[np.float64]

    def __init__(self, B: int, cfg: MachineConfig) -> None:
        env = self.name
        self.cfg = cfg
        T = self._period(env, cfg)
        self._settings(env, cfg)
        #: Reward weights (:attr:`default_weights` with the config's overrides).
        self.weights = parse_weights(env, cfg.reward_weights, self.default_weights)
        if cfg.plant == "rig" and cfg.randomize is not None:
            raise ConfigError(
                f"{env}: randomize is not available with plant='rig': the rig's true plant is "
                "not a model with parameters (its specimen is set by specimen_seed)"
            )
        plant = network_plant(
            env,
            params=cfg.params,
            plant=cfg.plant,
            models=self.models,
            default=self.default_model,
            rig=self.rig_name,
            rig_effects=cfg.rig_effects,
            stepwise_effects=self.stepwise_effects,
            specimen_seed=cfg.specimen_seed,
        )
        super().__init__(B, plant, self.plant_outputs, self.plant_inputs, T, self.n_accumulators)
        ch = self.noise_channels
        sens = parse_noise(env, cfg.sensor_noise, ch, self.sensor_table, plant.sensors)
        lo, hi = self.obs_bounds()
        off, drift = plant.sensor_errors(ch, len(lo))
        self.meas = meas_array(sens, lo, hi, off, drift)
        #: The ambient over the episode, one row per plant (drawn at reset).
        self.ambient_tab = np.zeros((B, self._horizon + 1))

    def _settings(self, env: str, cfg: Any) -> None:
        """Check the environment's own settings (before the plant is resolved)."""

    def _manipulated(self, a: NDArray[np.float64]) -> NDArray[np.float64]:
        """The manipulated input of the actions ``a[:, 0]`` clipped to [-1, 1], shape (B,)."""
        raise NotImplementedError

    def _kernel(self, mode: int) -> int:
        if mode == 0 and not self.all_linear:
            a = np.clip(self.act[:, 0], -1.0, 1.0)
            rows = np.arange(self.B)
            u = np.column_stack(
                [
                    self._manipulated(a),
                    self.ambient_tab[rows, np.minimum(self.ctr[:, C_K], self._horizon)],
                ]
            )
            self.advance_nonlinear(u)
        return self._call(
            self.kernels, mode, self.act, self.linear, self.x, self.At, self.Bt, self.Ct, self.Dt,
            self.h0, self.ambient_tab, self.acc, self.ctr, self.noise, self.meas, self.cfgv,
            self.obs, self.out, self.sig, self.scratch,
        )  # fmt: skip
