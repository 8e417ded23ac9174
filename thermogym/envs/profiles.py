"""Disturbance and set-point profiles of the environments (pure numerics, seeded).

All randomness comes from the generator passed in (the environment's
``np_random``).

Synthetic weather (:func:`synthetic_weather`)
---------------------------------------------
Hourly outdoor temperature and solar gains for a site in central Europe,
chosen here to give realistic heating-season conditions without shipping a
weather file::

    T_out(t) = T_mean − A_year cos(2π (d − 20)/365) + A_day cos(2π (h − 15)/24) + a(t)
    a(t+1 h) = φ a(t) + σ √(1 − φ²) ε,   φ = exp(−1 h / τ)          (weather anomaly)
    Q_sol(t) = Q_peak c(d) max(0, sin(π (h − h_rise) / L(d)))
    L(d) = 12 h − 4 h cos(2π (d + 10)/365)                           (day length)

with ``d`` the day of the year (0 = 1 January, coldest about 20 January),
``h`` the hour of the day, daily maximum at 15:00, ``h_rise = 12 − L/2``, and
a cloudiness factor ``c(d)`` drawn uniformly in [0.15, 1] per day. Defaults:
``T_mean`` 9 °C, ``A_year`` 9 K (January ≈ 0 °C, July ≈ 18 °C), ``A_day`` 4 K,
anomaly σ 3 K with τ = 48 h, ``Q_peak`` 400 W of solar gains into the room
through its window (about 3 m² south-facing glazing).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

__all__ = ["ambient_day", "random_levels", "synthetic_weather"]

HOUR = 3600.0
DAY = 86400.0


def synthetic_weather(
    rng: np.random.Generator,
    start_hour: int,
    n_hours: int,
    *,
    mean_C: float = 9.0,
    year_amp_K: float = 9.0,
    day_amp_K: float = 4.0,
    anomaly_sd_K: float = 3.0,
    anomaly_tau_h: float = 48.0,
    solar_peak_W: float = 400.0,
) -> NDArray[np.float64]:
    """Hourly outdoor temperature [°C] and solar gains [W] (module docstring model).

    Parameters
    ----------
    rng : numpy.random.Generator
    start_hour : int
        Absolute hour of the first value (0 = 1 January 00:00).
    n_hours : int
        Number of hourly values.

    Returns
    -------
    ndarray, shape (2, n_hours)
        Rows ``T_out`` [°C] and ``Q_sol`` [W].

    Examples
    --------
    >>> w = synthetic_weather(np.random.default_rng(0), 0, 24 * 31)
    >>> bool(-10.0 < w[0].mean() < 8.0), bool(w[1].min() >= 0.0)
    (True, True)
    """
    H = start_hour + np.arange(n_hours, dtype=float)
    d = np.floor(H / 24.0)
    h = H - 24.0 * d
    doy = np.mod(d, 365.0)
    phi = math.exp(-1.0 / anomaly_tau_h)
    eps = rng.standard_normal(n_hours)
    a = np.empty(n_hours)
    prev = anomaly_sd_K * eps[0]  # stationary start
    a[0] = prev
    s = anomaly_sd_K * math.sqrt(1.0 - phi * phi)
    for i in range(1, n_hours):
        prev = phi * prev + s * eps[i]
        a[i] = prev
    T = (
        mean_C
        - year_amp_K * np.cos(2 * np.pi * (doy - 20.0) / 365.0)
        + day_amp_K * np.cos(2 * np.pi * (h - 15.0) / 24.0)
        + a
    )
    days = d - d[0]
    clouds = rng.uniform(0.15, 1.0, int(days[-1]) + 1)
    L = 12.0 - 4.0 * np.cos(2 * np.pi * (doy + 10.0) / 365.0)
    rise = 12.0 - L / 2.0
    sol = solar_peak_W * clouds[days.astype(int)] * np.maximum(np.sin(np.pi * (h - rise) / L), 0)
    sol[(h < rise) | (h > rise + L)] = 0.0
    return np.vstack([T, sol])


def random_levels(rng: np.random.Generator, n: int, lo: float, hi: float) -> NDArray[np.float64]:
    """``n`` set-point levels drawn uniformly in ``[lo, hi]``."""
    return rng.uniform(lo, hi, n) if hi > lo else np.full(n, lo)


def ambient_day(
    rng: np.random.Generator,
    t: NDArray[np.float64],
    *,
    start_clock_h: float = 8.0,
    mean_C: float = 24.0,
    swing_K: float = 1.5,
    wander_K: float = 0.5,
) -> NDArray[np.float64]:
    """Workshop air temperature: a daily cycle peaking at 15:00 plus a slow wander.

    Parameters
    ----------
    rng : numpy.random.Generator
    t : ndarray
        Times since the start [s] (uniform).
    start_clock_h : float
        Clock time of ``t = 0`` [h].
    mean_C, swing_K : float
        Daily mean and amplitude [°C, K] (001 Fig. 5 shows a swing of about 3 K).
    wander_K : float
        Standard deviation of the slow (τ = 2 h) random wander [K].
    """
    clock = start_clock_h + t / HOUR
    dt = float(t[1] - t[0]) if t.size > 1 else HOUR
    phi = math.exp(-dt / (2 * HOUR))
    eps = rng.standard_normal(t.size)
    w = np.empty(t.size)
    prev = wander_K * eps[0]
    w[0] = prev
    s = wander_K * math.sqrt(1.0 - phi * phi)
    for i in range(1, t.size):
        prev = phi * prev + s * eps[i]
        w[i] = prev
    return mean_C + swing_K * np.cos(2 * np.pi * (clock - 15.0) / 24.0) + w
