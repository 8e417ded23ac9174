"""Python reference of the firmware's RTD conversion (paper 001, eqs 1-2).

Double-precision, independent of the C code: the temperature is found by
bisection on the full Callendar-Van Dusen relation of DIN EN 60751, not by the closed-form inverse
the firmware uses, so the host test compares two different computations.
The converter assumptions are those of ``thermogym/firmware/c/rtd.h``:

* AD7794, N = 24 bit, bipolar coding (the paper's eq 1 is the datasheet's
  bipolar transfer function; its ``2^N`` stands for ``2^(N−1)``), gain 2;
* ratiometric reference through R_ref = 5110 Ω, so
  ``R = (Code/2^(N−1) − 1) R_ref / GAIN`` (unipolar: ``Code R_ref / (2^N GAIN)``);
* Pt1000 (R0 = 1000 Ω), A = 3.9083e-3 /°C, B = −5.775e-7 /°C²,
  C = −4.183e-12 /°C⁴ below 0 °C; range −50..300 °C (paper Table 2).

Statuses (same codes as ``rtd_status`` in C): 0 OK, 3 below range, 4 above
range, 5 open circuit (full-scale code), 6 short circuit (zero or negative
input), 2 not finite.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from thermogym._checks import positive
from thermogym.errors import ParameterError

__all__ = [
    "CVD_A",
    "CVD_B",
    "CVD_C",
    "RTD_OK",
    "AdcConfig",
    "code_to_resistance",
    "code_to_temperature",
    "resistance_to_code",
    "resistance_to_temperature",
    "temperature_to_resistance",
]

CVD_A = 3.9083e-3  # 1/°C, DIN EN 60751
CVD_B = -5.775e-7  # 1/°C², DIN EN 60751
CVD_C = -4.183e-12  # 1/°C⁴, T < 0 °C only
T_MIN, T_MAX = -50.0, 300.0  # measurement range, 001 Table 2
RTD_OK, RTD_NAN, RTD_BELOW, RTD_ABOVE, RTD_OPEN, RTD_SHORT = 0, 2, 3, 4, 5, 6


@dataclass(frozen=True)
class AdcConfig:
    """AD7794 channel set-up (defaults: paper 001 section 2.1 and the assumptions above).

    Attributes
    ----------
    bits : int
        Resolution N [bit].
    bipolar : bool
        Bipolar (offset-binary) coding.
    gain : float
        PGA gain.
    r_ref : float
        Reference resistor [Ω].
    r0 : float
        RTD resistance at 0 °C [Ω].
    """

    bits: int = 24
    bipolar: bool = True
    gain: float = 2.0
    r_ref: float = 5110.0
    r0: float = 1000.0

    def __post_init__(self) -> None:
        if not 2 <= self.bits <= 31:
            raise ParameterError(f"bits is {self.bits!r}; expected 2..31")
        for name in ("gain", "r_ref", "r0"):
            positive(name, getattr(self, name), text=False)


def temperature_to_resistance(t_degc: ArrayLike, r0: float = 1000.0) -> NDArray[np.float64]:
    """Callendar-Van Dusen resistance, eq (2) of 001 with C below 0 °C [Ω].

    Examples
    --------
    >>> float(temperature_to_resistance(0.0)), round(float(temperature_to_resistance(100.0)), 3)
    (1000.0, 1385.055)
    """
    t = np.asarray(t_degc, dtype=float)
    x = CVD_A * t + CVD_B * t * t
    x = np.where(t < 0, x + CVD_C * (t - 100.0) * t**3, x)
    return r0 * (1.0 + x)


def resistance_to_temperature(
    r_ohm: ArrayLike, r0: float = 1000.0
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Temperature [°C] and status for resistances, by bisection on eq (2).

    The forward relation is monotonic below its vertex (≈ 3383 °C); 64 halvings
    of the bracket [−260 °C, vertex] give the root to round-off, for every
    element at once.

    Examples
    --------
    >>> t, st = resistance_to_temperature([1385.055, 803.063])
    >>> t.round(3).tolist(), st.tolist()
    ([100.0, -50.0], [0, 0])
    """
    r = np.atleast_1d(np.asarray(r_ohm, dtype=float))
    t = np.full(r.shape, np.nan)
    st = np.zeros(r.shape, dtype=np.int64)
    vertex = -CVD_A / (2 * CVD_B)
    fin = np.isfinite(r)
    st[~fin] = RTD_NAN
    st[fin & (r <= 0)] = RTD_SHORT
    top = fin & (r >= float(temperature_to_resistance(vertex, r0)))
    t[top], st[top] = vertex, RTD_ABOVE
    todo = fin & (r > 0) & ~top
    lo = np.full(int(todo.sum()), -260.0)
    hi = np.full(lo.shape, vertex)
    target = r[todo]
    for _ in range(64):
        mid = 0.5 * (lo + hi)
        below = temperature_to_resistance(mid, r0) < target
        lo = np.where(below, mid, lo)
        hi = np.where(below, hi, mid)
    tt = 0.5 * (lo + hi)
    t[todo] = tt
    st[todo] = np.where(tt < T_MIN, RTD_BELOW, np.where(tt > T_MAX, RTD_ABOVE, RTD_OK))
    return t, st


def code_to_resistance(
    code: ArrayLike, cfg: AdcConfig | None = None
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Resistance [Ω] and status for ADC codes (eq 1, ratiometric).

    Examples
    --------
    >>> r, st = code_to_resistance([2**23 + 2**22, 2**24 - 1])
    >>> r.tolist(), st.tolist()
    ([1277.5, nan], [0, 5])
    """
    c = cfg or AdcConfig()
    k = np.atleast_1d(np.asarray(code, dtype=np.int64))
    full = (1 << c.bits) - 1
    r = np.full(k.shape, np.nan)
    st = np.zeros(k.shape, dtype=np.int64)
    if c.bipolar:
        mid = 1 << (c.bits - 1)
        ok = (k > mid) & (k < full)
        r[ok] = (k[ok] - mid) * c.r_ref / (c.gain * mid)
        st[k <= mid] = RTD_SHORT
    else:
        ok = (k > 0) & (k < full)
        r[ok] = k[ok] * c.r_ref / (c.gain * (1 << c.bits))
        st[k <= 0] = RTD_SHORT
    st[k >= full] = RTD_OPEN
    return r, st


def resistance_to_code(r_ohm: ArrayLike, cfg: AdcConfig | None = None) -> NDArray[np.int64]:
    """The ADC code a resistance gives (nearest integer, clipped to the code range)."""
    c = cfg or AdcConfig()
    r = np.asarray(r_ohm, dtype=float)
    if c.bipolar:
        mid = 1 << (c.bits - 1)
        code = np.rint(mid + r * c.gain * mid / c.r_ref)
    else:
        code = np.rint(r * c.gain * (1 << c.bits) / c.r_ref)
    return np.clip(code, 0, (1 << c.bits) - 1).astype(np.int64)


def code_to_temperature(
    code: ArrayLike, cfg: AdcConfig | None = None
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Temperature [°C] and status for ADC codes: eq (1) then eq (2).

    Examples
    --------
    >>> cfg = AdcConfig()
    >>> code = resistance_to_code(temperature_to_resistance(25.0), cfg)
    >>> t, st = code_to_temperature(code, cfg)
    >>> round(float(t[0]), 3), int(st[0])
    (25.0, 0)
    """
    c = cfg or AdcConfig()
    r, st = code_to_resistance(code, c)
    t = np.full(r.shape, np.nan)
    ok = st == RTD_OK
    if ok.any():
        t_ok, st_ok = resistance_to_temperature(r[ok], c.r0)
        t[ok], st[ok] = t_ok, st_ok
    return t, st
