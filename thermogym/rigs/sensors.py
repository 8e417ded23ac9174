"""Sensors of the virtual rigs: what lies between a true signal and its recorded value.

A :class:`Sensor` turns a noise-free signal into the values a data-acquisition
chain records, in this order (every stage is off at its default)::

    y_lag   = first-order lag of the truth, time constant ``lag``      (sensor mass, filter)
    y       = y_lag + offset + drift·t + e_white + e_coloured           (electronics, drift)
    y       = y + spike                                                 (rare glitches)
    y       = quantise(y, resolution), clipped to ``span``              (ADC)
    y       = NaN or the last value during a dropout                    (lost samples)

* white noise: independent normal values, standard deviation ``noise``;
* coloured noise: an Ornstein-Uhlenbeck process with standard deviation
  ``colored`` and correlation time ``colored_tau`` (slow wander of a
  cold-junction compensation, of an amplifier's offset, of an LVDT's carrier
  with its temperature), sampled exactly on any time grid:
  ``e_k = a e_{k-1} + colored·sqrt(1 − a²) n_k``, ``a = exp(−Δt/τ_c)``,
  started from its stationary distribution;
* lag: the exact response of ``τ dy/dt = x − y`` to a truth that is linear
  between samples (first-order hold), the sensor starting in equilibrium;
* spikes: a Poisson process with ``spike_rate`` events per hour, each a
  single-sample error of random sign and size ``spike_size · U(0.5, 1.5)``
  (electromagnetic interference of a switching heater, a loose connector);
* dropouts: a Poisson process with ``dropout_rate`` starts per hour, each
  lasting an exponentially distributed time of mean ``dropout_s``; the
  recorder writes NaN (``dropout="nan"``: a lost radio packet, an open
  circuit) or repeats its last value (``dropout="hold"``: a logger that keeps
  its register when a conversion fails).

Two ways to use a sensor: :meth:`Sensor.measure` for a whole recording (any
batch shape, any increasing time grid), and :class:`SensorStream` for an
environment that measures one sample per control period (vectorised over
plants, random numbers drawn beforehand so that each plant's draws come from
its own generator).

Randomness comes only from the generator passed in; each call draws its
numbers in a fixed order (white, coloured, spikes, dropouts), all of them
whether a stage is active or not, so that switching a stage off leaves the
other stages' noise unchanged for a given seed.

Examples
--------
>>> import numpy as np
>>> s = Sensor(noise=0.1, resolution=0.01)
>>> y = s.measure(np.full(1000, 20.0), np.random.default_rng(0), time=np.arange(1000.0))
>>> bool(0.08 < y.std() < 0.12), bool(np.allclose(y * 100, np.round(y * 100)))
(True, True)
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numba as nb
import numpy as np
from numpy.typing import ArrayLike, NDArray

from thermogym._checks import choice, nonnegative, positive
from thermogym.errors import ShapeError

__all__ = ["N_RANDOM", "Sensor", "SensorSpec", "SensorStream"]

#: Random numbers a sensor uses per sample: white, coloured (normal), spike event, spike
#: size, dropout start, dropout length (uniform in [0, 1)).
N_RANDOM = 6


@dataclass(frozen=True)
class Sensor:
    """How a rig measures one signal (see the module docstring for the chain).

    Parameters
    ----------
    noise : float
        Standard deviation of the white noise, in the signal's unit.
    resolution : float
        Quantisation step of the recorded value (0: none).
    colored : float
        Standard deviation of the coloured (Ornstein-Uhlenbeck) noise.
    colored_tau : float
        Its correlation time [s].
    lag : float
        Time constant of the sensor's first-order lag [s] (0: none).
    spike_rate : float
        Spikes per hour.
    spike_size : float
        Typical spike magnitude (each is ``± spike_size · U(0.5, 1.5)``).
    dropout_rate : float
        Dropout starts per hour.
    dropout_s : float
        Mean dropout duration [s].
    dropout : {"nan", "hold"}
        What the recorder writes during a dropout.
    offset : float
        Constant error (calibration), in the signal's unit.
    drift : float
        Error growing with time, per hour.
    span : (float, float)
        Measuring range; readings are clipped to it.
    source : str
        Where the figures come from (datasheet, paper section).
    """

    noise: float = 0.0
    resolution: float = 0.0
    colored: float = 0.0
    colored_tau: float = 600.0
    lag: float = 0.0
    spike_rate: float = 0.0
    spike_size: float = 0.0
    dropout_rate: float = 0.0
    dropout_s: float = 0.0
    dropout: str = "nan"
    offset: float = 0.0
    drift: float = 0.0
    span: tuple[float, float] = (-math.inf, math.inf)
    source: str = ""

    def __post_init__(self) -> None:
        for name in (
            "noise", "resolution", "colored", "lag", "spike_rate", "spike_size",
            "dropout_rate", "dropout_s",
        ):  # fmt: skip
            nonnegative(f"Sensor.{name}", getattr(self, name))
        if self.colored > 0:
            positive("Sensor.colored_tau", self.colored_tau, unit="s")
        choice("Sensor.dropout", self.dropout, ("nan", "hold"))
        if not (len(self.span) == 2 and self.span[0] < self.span[1]):
            raise ShapeError(f"Sensor.span = {self.span!r}, expected (low, high) with low < high")

    def replace(self, **changes: Any) -> Sensor:
        """A copy with some settings changed (e.g. ``noise=0``)."""
        return dataclasses.replace(self, **changes)

    def ideal(self) -> Sensor:
        """The same sensor without any error (truth in, truth out)."""
        return Sensor(span=self.span, source=self.source)

    @property
    def _settings(self) -> NDArray[np.float64]:
        return np.array(
            [
                self.noise, self.resolution, self.colored, self.colored_tau, self.lag,
                self.spike_rate, self.spike_size, self.dropout_rate, self.dropout_s,
                1.0 if self.dropout == "hold" else 0.0, self.offset, self.drift,
                self.span[0], self.span[1],
            ]
        )  # fmt: skip

    def measure(
        self,
        values: ArrayLike,
        rng: np.random.Generator,
        time: ArrayLike | None = None,
    ) -> NDArray[np.float64]:
        """Record ``values`` as this sensor would.

        Parameters
        ----------
        values : array_like, shape (..., T)
            Noise-free signal, the last axis along ``time``.
        rng : Generator
            Source of every random draw.
        time : array_like, shape (T,), optional
            Strictly increasing sample times [s]; needed when a lag, coloured
            noise, spikes, dropouts or drift are set (default: 1 s samples).

        Returns
        -------
        ndarray
            Same shape as ``values``.
        """
        x = np.array(values, dtype=float, copy=True)
        if x.ndim == 0:
            x = x[None]
        T = x.shape[-1]
        if time is None:
            t = np.arange(T, dtype=float)
        else:
            t = np.asarray(time, dtype=float)
            if t.shape != (T,):
                raise ShapeError(f"time has shape {t.shape}, expected ({T},) as the values")
            if T > 1 and not np.all(np.diff(t) > 0):
                raise ShapeError("time must increase strictly")
        flat = x.reshape(-1, T)
        z_n = rng.standard_normal((2, flat.shape[0], T))
        z_u = rng.random((4, flat.shape[0], T))
        out = np.empty_like(flat)
        _measure_series(flat, t, self._settings, z_n, z_u, out)
        return out.reshape(x.shape) if np.ndim(values) else out.reshape(())


@nb.njit(cache=True)
def _quantise_clip(y: float, s: NDArray[np.float64]) -> float:
    if s[1] > 0.0:
        y = round(y / s[1]) * s[1]
    return min(max(y, s[12]), s[13])


@nb.njit(cache=True)
def _measure_series(x, t, s, z_n, z_u, out):  # pragma: no cover - numba
    # the chain of the module docstring over each row of x (rows independent)
    noise, col, tau_c, lag = s[0], s[2], s[3], s[4]
    srate, ssize, drate, dmean, hold, off, drift = s[5], s[6], s[7], s[8], s[9], s[10], s[11]
    B, T = x.shape
    for b in range(B):
        y_lag = x[b, 0]
        e_c = col * z_n[1, b, 0]  # stationary start
        drop_left = 0.0
        last = math.nan
        for k in range(T):
            dt = t[k] - t[k - 1] if k > 0 else 0.0
            if k > 0:
                if lag > 0.0:
                    # τ dy/dt = x − y, x linear between samples (first-order hold), exact
                    a = math.exp(-dt / lag)
                    y_lag = (
                        a * y_lag
                        + (1.0 - a) * x[b, k - 1]
                        + (x[b, k] - x[b, k - 1]) * (1.0 - lag / dt * (1.0 - a))
                    )
                else:
                    y_lag = x[b, k]
                if col > 0.0:
                    a = math.exp(-dt / tau_c)
                    e_c = a * e_c + col * math.sqrt(1.0 - a * a) * z_n[1, b, k]
            y = y_lag + off + drift * (t[k] - t[0]) / 3600.0 + noise * z_n[0, b, k] + e_c
            p_hit = 1.0 - math.exp(-srate * dt / 3600.0) if srate > 0.0 else 0.0
            if k > 0 and z_u[0, b, k] < p_hit:
                # given a spike, z/p is uniform in [0, 1): its half decides the sign
                mag = ssize * (0.5 + z_u[1, b, k])
                y += mag if z_u[0, b, k] < 0.5 * p_hit else -mag
            y = _quantise_clip(y, s)
            if drop_left > 0.0:
                drop_left -= dt
            if drop_left <= 0.0 and drate > 0.0 and k > 0:
                if z_u[2, b, k] < 1.0 - math.exp(-drate * dt / 3600.0):
                    drop_left = -dmean * math.log(1.0 - z_u[3, b, k])
            if drop_left > 0.0:
                y = last if hold > 0.0 else math.nan
            else:
                last = y
            out[b, k] = y


class SensorStream:
    """Sample by sample measurement of one signal on ``B`` plants (environments).

    The state of each plant's sensor (lag output, coloured noise, dropout,
    last value, elapsed time) is kept between calls. Random numbers are passed
    in (``N_RANDOM`` per plant and sample), drawn by the caller from each
    plant's own generator.

    Parameters
    ----------
    sensor : Sensor
    n : int
        Number of plants.

    Examples
    --------
    >>> import numpy as np
    >>> s = SensorStream(Sensor(lag=10.0), 2)
    >>> z = np.zeros((2, N_RANDOM))
    >>> s.start([0, 1], np.array([20.0, 20.0]), z)
    >>> # truth rising linearly from 20 to 30 °C over the 10 s: a lagged ramp
    >>> s.sample(np.array([True, True]), np.array([30.0, 30.0]), 10.0, z).round(2).tolist()
    [23.68, 23.68]
    """

    def __init__(self, sensor: Sensor, n: int) -> None:
        self.sensor = sensor
        self._s = sensor._settings
        self.y_lag = np.zeros(n)
        self.x_prev = np.zeros(n)
        self.e_c = np.zeros(n)
        self.drop_left = np.zeros(n)
        self.last = np.full(n, math.nan)
        self.elapsed = np.zeros(n)

    def start(self, rows: ArrayLike, x0: NDArray[np.float64], z: NDArray[np.float64]) -> None:
        """First sample of ``rows`` (sensor in equilibrium with the truth ``x0`` of those rows).

        ``z`` holds the random numbers of those rows, shape (len(rows), N_RANDOM).
        """
        r = np.asarray(rows, dtype=np.int64)
        self.y_lag[r] = x0
        self.x_prev[r] = x0
        self.e_c[r] = self.sensor.colored * z[:, 1]
        self.drop_left[r] = 0.0
        self.elapsed[r] = 0.0
        self.last[r] = math.nan

    def first(self, rows: ArrayLike, z: NDArray[np.float64]) -> NDArray[np.float64]:
        """The reading of ``rows`` right after :meth:`start` (no time has passed)."""
        r = np.asarray(rows, dtype=np.int64)
        y = self._reading(r, z)
        self.last[r] = y
        return y

    def _reading(self, r: NDArray[np.int64], z: NDArray[np.float64]) -> NDArray[np.float64]:
        s = self.sensor
        y = self.y_lag[r] + s.offset + s.drift * self.elapsed[r] / 3600.0 + s.noise * z[:, 0]
        y = y + self.e_c[r]
        if s.resolution > 0:
            y = np.round(y / s.resolution) * s.resolution
        return np.clip(y, s.span[0], s.span[1])

    def sample(
        self,
        active: NDArray[np.bool_],
        x: NDArray[np.float64],
        dt: float,
        z: NDArray[np.float64],
    ) -> NDArray[np.float64]:
        """Readings of the ``active`` plants after ``dt`` seconds with the truth now ``x``.

        ``x`` and ``z`` are given for every plant (shape (B,) and (B, N_RANDOM));
        inactive plants keep their state and get NaN.
        """
        out = np.full(x.shape[0], math.nan)
        _stream_step(
            self._s, np.asarray(active, dtype=np.bool_), np.asarray(x, dtype=float), float(dt),
            np.asarray(z, dtype=float), self.y_lag, self.x_prev, self.e_c, self.drop_left,
            self.last, self.elapsed, out,
        )  # fmt: skip
        return out


@nb.njit(cache=True)
def _stream_step(
    s, active, x, dt, z, y_lag, x_prev, e_c, drop_left, last, elapsed, out
):  # pragma: no cover - numba
    # one sample of the chain of the module docstring for every active plant
    noise, col, tau_c, lag = s[0], s[2], s[3], s[4]
    srate, ssize, drate, dmean, hold, off, drift = s[5], s[6], s[7], s[8], s[9], s[10], s[11]
    a_lag = math.exp(-dt / lag) if lag > 0.0 else 0.0
    a_col = math.exp(-dt / tau_c) if col > 0.0 else 0.0
    p_hit = 1.0 - math.exp(-srate * dt / 3600.0)
    p_drop = 1.0 - math.exp(-drate * dt / 3600.0)
    for b in range(x.shape[0]):
        if not active[b]:
            continue
        if lag > 0.0:
            y_lag[b] = (
                a_lag * y_lag[b]
                + (1.0 - a_lag) * x_prev[b]
                + (x[b] - x_prev[b]) * (1.0 - lag / dt * (1.0 - a_lag))
            )
        else:
            y_lag[b] = x[b]
        x_prev[b] = x[b]
        if col > 0.0:
            e_c[b] = a_col * e_c[b] + col * math.sqrt(1.0 - a_col * a_col) * z[b, 1]
        elapsed[b] += dt
        y = y_lag[b] + off + drift * elapsed[b] / 3600.0 + noise * z[b, 0] + e_c[b]
        if z[b, 2] < p_hit:
            mag = ssize * (0.5 + z[b, 3])
            y += mag if z[b, 2] < 0.5 * p_hit else -mag
        y = _quantise_clip(y, s)
        left = drop_left[b] - dt
        if left <= 0.0 and z[b, 4] < p_drop:
            left = -dmean * math.log(1.0 - z[b, 5])
        drop_left[b] = left
        if left > 0.0:
            y = last[b] if hold > 0.0 else math.nan
        else:
            last[b] = y
        out[b] = y


#: The name the rigs used before coloured noise, lags, spikes and dropouts existed
#: (``SensorSpec(noise, resolution)`` still means the same).
SensorSpec = Sensor
