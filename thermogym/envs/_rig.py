"""Environments on a rig's true plant (``plant="rig"``): sensors and the shared engine parts.

With ``plant="rig"`` an AXT211 environment does not run the identified
model's compiled kernels: its engine steps the rig's true plant
(:class:`thermogym.rigs.base.TruePlant`) for all plants of the batch at once,
a Python-level loop over control periods around the rig's own compiled
sub-steps, and measures the observed channels through the rig's sensors
(:mod:`thermogym.rigs.sensors`: coloured noise, lags, quantisation, spikes;
a dropout holds the last value, as a controller's input module does). The
KPIs are computed from the rig's physical state by the same KPI code as on
the model. The rig is for evaluation; the model path keeps its speed.

Random numbers of the sensors come from each plant's own generator (drawn
after the episode conditions and the engine's noise block), so a
sub-environment of a vector environment is the single environment with its
seed.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from thermogym.envs._base import check_number
from thermogym.errors import ConfigError
from thermogym.rigs.sensors import N_RANDOM, Sensor, SensorStream

__all__ = ["RigSensors"]


class RigSensors:
    """The rig's sensors of an environment's observed channels, one stream per channel.

    Parameters
    ----------
    env : str
        Environment name for messages.
    rig : Rig
        The rig (its :meth:`~thermogym.rigs.base.Rig.sensor` carries the sensor effects).
    signals : sequence of str
        Rig signal measured by each channel.
    spans : sequence of (float, float)
        Observation bounds of each channel (readings are clipped to them).
    sensor_noise : bool or mapping
        True: the rig's sensors; False: exact readings; a mapping: the white
        noise σ of the named channels replaced (the rest of the sensor kept).
    channels : sequence of str
        Channel names (keys of ``sensor_noise``).
    n : int
        Number of plants.
    """

    def __init__(
        self,
        env: str,
        rig: Any,
        signals: Sequence[str],
        spans: Sequence[tuple[float, float]],
        sensor_noise: bool | Mapping[str, float],
        channels: Sequence[str],
        n: int,
    ) -> None:
        self.streams: list[SensorStream] = []
        if not isinstance(sensor_noise, bool | Mapping):
            raise ConfigError(
                f"{env}: sensor_noise is {sensor_noise!r:.60}; expected a bool or dict"
            )
        over = dict(sensor_noise) if isinstance(sensor_noise, Mapping) else {}
        unknown = [k for k in over if k not in channels]
        if unknown:
            raise ConfigError(
                f"{env}: sensor_noise names {unknown}; noisy channels are {list(channels)}"
            )
        for ch, sig, span in zip(channels, signals, spans, strict=True):
            s: Sensor = rig.sensor(sig)
            if sensor_noise is False:
                # exact readings; a sensor effect of the rig (offset, drift, lag) stays
                s = Sensor(lag=s.lag, offset=s.offset, drift=s.drift)
            if ch in over:
                s = s.replace(noise=check_number(env, f"sensor_noise[{ch!r}]", over[ch], lo=0.0))
            s = s.replace(dropout="hold", span=(float(span[0]), float(span[1])))
            self.streams.append(SensorStream(s, n))
        self.n = n

    @property
    def sensors(self) -> list[Sensor]:
        """The sensor of each channel."""
        return [st.sensor for st in self.streams]

    @staticmethod
    def draws(rng: np.random.Generator, n_ch: int) -> NDArray[np.float64]:
        """One sample's random numbers of ``n_ch`` channels (2 normal, 4 uniform each)."""
        z = np.empty((n_ch, N_RANDOM))
        z[:, :2] = rng.standard_normal((n_ch, 2))
        z[:, 2:] = rng.random((n_ch, N_RANDOM - 2))
        return z

    def start(
        self,
        rows: Sequence[int] | NDArray[np.integer[Any]],
        truth: NDArray[np.float64],
        rngs: Sequence[np.random.Generator],
    ) -> NDArray[np.float64]:
        """Start the sensors of ``rows`` on ``truth`` (len(rows), n_ch); their first readings."""
        nc = len(self.streams)
        z = np.stack([self.draws(rngs[b], nc) for b in rows])  # (rows, ch, N_RANDOM)
        z1 = np.stack([self.draws(rngs[b], nc) for b in rows])
        out = np.empty((len(rows), nc))
        for j, st in enumerate(self.streams):
            st.start(rows, truth[:, j], z[:, j])
            out[:, j] = st.first(rows, z1[:, j])
        return out

    def read(
        self,
        active: NDArray[np.bool_],
        truth: NDArray[np.float64],
        dt: float,
        rngs: Sequence[np.random.Generator],
    ) -> NDArray[np.float64]:
        """Readings (B, n_ch) of the active plants after ``dt`` with the truth (B, n_ch)."""
        nc = len(self.streams)
        z = np.zeros((self.n, nc, N_RANDOM))
        for b in np.flatnonzero(active):
            z[b] = self.draws(rngs[int(b)], nc)
        out = np.full((self.n, nc), np.nan)
        for j, st in enumerate(self.streams):
            out[:, j] = st.sample(active, truth[:, j], dt, z[:, j])
        return out
