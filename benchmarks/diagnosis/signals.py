"""Sensor noise, excitation signals and time profiles of the generalisation suite.

Everything random draws from a passed :class:`numpy.random.Generator`, so a
case is reproducible from its seed.

Sensor noise is white plus coloured: a first-order Gauss-Markov process
(exponentially correlated, what thermocouple amplifiers, cold-junction
compensation and local air currents add) and, where a channel has it, a slow
1/f-like wander, then quantisation to the logger's resolution.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.signal import lfilter

__all__ = [
    "SensorNoise",
    "effect_share",
    "gauss_markov",
    "periodic",
    "quantise",
    "ramp_profile",
    "random_levels",
    "random_telegraph",
    "smooth_random",
    "step_profile",
]

Array = NDArray[np.float64]


def gauss_markov(rng: np.random.Generator, n: int, dt: float, sigma: float, tau: float) -> Array:
    """Stationary first-order Gauss-Markov noise (exact discretisation).

    ``x[k+1] = a x[k] + sigma sqrt(1 - a²) w[k]`` with ``a = exp(-dt/tau)``; the
    first sample is drawn from the stationary distribution, so the process has
    standard deviation ``sigma`` and correlation time ``tau`` [s] throughout.
    """
    if sigma <= 0 or n == 0:
        return np.zeros(n)
    a = math.exp(-dt / tau)
    w = rng.standard_normal(n)
    w[0] *= sigma
    w[1:] *= sigma * math.sqrt(1.0 - a * a)
    # scipy's lfilter is the recursion x[k] = a x[k-1] + w[k] in C
    return lfilter([1.0], [1.0, -a], w)


def quantise(y: Array, step: float) -> Array:
    """Round to the logger resolution ``step`` (no rounding for ``step <= 0``)."""
    if step <= 0:
        return np.asarray(y, dtype=float).copy()
    return np.round(np.asarray(y, dtype=float) / step) * step


@dataclass(frozen=True)
class SensorNoise:
    """A channel's measurement chain: white + Gauss-Markov noise, then quantisation.

    Parameters
    ----------
    white : float
        Standard deviation of white noise, in the signal's unit.
    coloured : float
        Standard deviation of the Gauss-Markov part.
    tau : float
        Correlation time of the Gauss-Markov part [s].
    resolution : float
        Quantisation step of the logger (0: none).
    """

    white: float = 0.0
    coloured: float = 0.0
    tau: float = 300.0
    resolution: float = 0.0

    def apply(self, y: Array, dt: float, rng: np.random.Generator) -> Array:
        """Return ``y`` as the logger records it (sampled every ``dt`` seconds)."""
        y = np.asarray(y, dtype=float)
        n = y.shape[0]
        out = (
            y
            + self.white * rng.standard_normal(n)
            + gauss_markov(rng, n, dt, self.coloured, self.tau)
        )
        return quantise(out, self.resolution)


# ----------------------------------------------------------------------------- excitation
def random_levels(
    rng: np.random.Generator,
    n: int,
    dt: float,
    levels: tuple[float, float],
    dwell: tuple[float, float],
    *,
    p_zero: float = 0.0,
) -> Array:
    """Piecewise-constant signal: uniform levels held for uniform random dwell times.

    Parameters
    ----------
    levels : (lo, hi)
        Range of the levels.
    dwell : (shortest, longest)
        Hold time of each level [s].
    p_zero : float
        Probability that a level is ``lo`` exactly (an "off" period).
    """
    u = np.empty(n)
    k = 0
    while k < n:
        m = max(1, round(rng.uniform(*dwell) / dt))
        v = levels[0] if rng.random() < p_zero else rng.uniform(*levels)
        u[k : k + m] = v
        k += m
    return u


def random_telegraph(
    rng: np.random.Generator, n: int, dt: float, dwell: tuple[float, float]
) -> Array:
    """0/1 signal switching after uniform random dwell times [s] (a PRBS-like test input)."""
    u = np.empty(n)
    k, v = 0, float(rng.integers(0, 2))
    while k < n:
        m = max(1, round(rng.uniform(*dwell) / dt))
        u[k : k + m] = v
        v = 1.0 - v
        k += m
    return u


# ------------------------------------------------------------------------------- profiles
def periodic(t: Array, period: float, phase: float, *, sharpness: float = 0.0) -> Array:
    """Unit-amplitude periodic profile: a sine, or a rounded square wave.

    ``sharpness`` > 0 squares the sine through ``tanh(s sin)/tanh(s)`` (an
    on/off cycle with finite switching, like an air-conditioning compressor).
    """
    s = np.sin(2.0 * np.pi * np.asarray(t) / period + phase)
    if sharpness > 0:
        return np.tanh(sharpness * s) / math.tanh(sharpness)
    return s


def step_profile(t: Array, t_step: float, width: float = 0.0) -> Array:
    """0 → 1 at ``t_step`` [s]; a smooth (logistic) edge of ``width`` seconds when > 0."""
    t = np.asarray(t, dtype=float)
    if width <= 0:
        return (t >= t_step).astype(float)
    return 0.5 * (1.0 + np.tanh((t - t_step) / (0.5 * width)))


def ramp_profile(t: Array, t_start: float, t_end: float) -> Array:
    """0 before ``t_start``, rising linearly to 1 at ``t_end``, then held."""
    t = np.asarray(t, dtype=float)
    return np.clip((t - t_start) / (t_end - t_start), 0.0, 1.0)


def smooth_random(rng: np.random.Generator, t: Array, tau: float, *, walk: bool = False) -> Array:
    """A smooth random profile of unit RMS (zero mean) on the time grid ``t``.

    Two cascaded first-order filters of correlation time ``tau`` [s] shape
    white noise into a smooth signal (no corners at the sample level). With
    ``walk`` the smooth signal is integrated (a smooth random walk) and starts
    at 0: a drift that wanders rather than oscillates.
    """
    t = np.asarray(t, dtype=float)
    n = t.size
    dt = float(t[1] - t[0]) if n > 1 else 1.0
    a = math.exp(-dt / tau)
    # burn-in of 5 tau so the filtered process is stationary at t[0]
    pre = min(int(5 * tau / dt), 20000)
    w = rng.standard_normal(n + pre)
    x = lfilter([1.0 - a], [1.0, -a], lfilter([1.0 - a], [1.0, -a], w))[pre:]
    if walk:
        x = np.cumsum(x - x.mean())
        x -= x[0]
        rms = math.sqrt(float(np.mean(x * x)))
        return x / rms if rms > 0 else x
    x -= x.mean()
    rms = float(np.std(x))
    return x / rms if rms > 0 else x


def effect_share(y_on: Array, y_off: Array) -> tuple[float, float]:
    """An effect's share of the output's power and its RMS size.

    ``share = ms(Δ) / (ms(Δ) + var(y_off))`` with ``Δ = y_on − y_off`` on the
    noise-free data, the plant's own constants, before any refit: 0 for no
    effect, ½ when the effect is as large as the output's own variation,
    towards 1 when it dominates. ``rms`` is ``sqrt(ms(Δ))`` in the output's unit.
    """
    ms = float(np.mean((np.asarray(y_on) - np.asarray(y_off)) ** 2))
    v = float(np.var(y_off))
    return (ms / (ms + v) if ms + v > 0 else 0.0), math.sqrt(ms)
