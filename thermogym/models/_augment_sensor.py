"""Augmentations on the sensor side: they transform what the sensor reads.

A first-order lag (first-order-hold exact), a dead time, a constant offset, a
linear drift and a per-recording wander of the reading. Indexed by
:mod:`~thermogym.models._augment_kinds`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.signal import lfilter

from thermogym.models._augment_base import (
    LOCAL,
    _AddsCourse,
    _Aug,
    _bounds,
    _course,
    _CourseMixin,
    _lag_coeff,
    _param,
)
from thermogym.models._augment_input import _Delay


# ================================================================== sensor side
def _foh(tau: NDArray[np.float64], dt: float):
    """Lag coefficients for a signal linear between samples (first-order hold).

    ``s[k+1] = a s[k] + b0 y[k+1] + b1 y[k]``, ``a = e^{−Δt/τ}``,
    ``b0 = 1 − (τ/Δt)(1 − a)``, ``b1 = (τ/Δt)(1 − a) − a`` (exact for a
    continuous signal that is linear over each interval, as a temperature
    sampled from a smooth course is; a zero-order hold would add half a sample
    of delay).
    """
    a = _lag_coeff(tau, dt)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.where(tau > 0, tau / dt, 0.0) * (1.0 - a)
    b0 = np.where(tau > 0, 1.0 - r, 1.0)
    b1 = np.where(tau > 0, r - a, 0.0)
    return a, b0, b1


class _Lag(_Aug):
    """A sensor's first-order lag of its (continuous) signal, first-order-hold exact."""

    effect = "sensor_lag"
    form = "first-order lag"
    side = "sensor"
    state_suffixes = ("s",)
    x0_free = (True,)

    def __init__(self, spec, base):
        super().__init__(spec, base)
        lo, hi = _bounds(spec, "tau", (0.0, 7200.0))
        self.params = [
            _param(
                f"tau_lag_{self.signal}",
                0.0,
                max(lo, 0.0),
                hi,
                "s",
                f"time constant of the {self.signal} sensor",
            )
        ]

    init = _Aug.start_at_output  # the sensor in equilibrium with its signal

    def apply(self, arr, u, p, s0, dt):
        a, b0, b1 = _foh(p[:, 0], dt)
        for b in range(arr.shape[0]):
            if a[b] == 0.0:
                continue
            x = arr[b, :, self.col]
            # s[n] = b0 y[n] + b1 y[n−1] + a s[n−1], the filter state chosen so that s[0] = s0
            arr[b, :, self.col], _ = lfilter(
                [b0[b], b1[b]], [1.0, -a[b]], x, zi=[s0[b, 0] - b0[b] * x[0]]
            )

    def now(self, v, u, p, s, dt):
        return np.where(p[:, 0] > 0, s[:, 0], v)

    def advance(self, v, u, p, s, dt, v_next=None):
        a, b0, b1 = _foh(p[:, 0], dt)
        vn = v if v_next is None else v_next
        return np.where(p[:, 0] > 0, a * s[:, 0] + b0 * vn + b1 * v, vn)[:, None]


class _OutputDelay(_Delay):
    """The sensor sees its signal after a dead time (a sample line, a clock skew)."""

    effect = "transport_delay"
    form = "output dead time"
    side = "sensor"

    prefix = "delay_out_"
    described = "dead time before the {} sensor sees its signal"

    def init(self, p, u0, y0):
        return np.repeat(y0[:, self.col : self.col + 1], self.history, axis=1)


class _Offset(_Aug):
    effect = "sensor_offset"
    form = "constant"
    side = "sensor"

    def __init__(self, spec, base):
        super().__init__(spec, base)
        unit = self.units.get(self.signal, "1")
        lo, hi = _bounds(spec, "offset", (-100.0, 100.0))
        self.params = [
            _param(
                f"offset_{self.signal}", 0.0, lo, hi, unit, f"offset of the {self.signal} sensor"
            )
        ]

    def apply(self, arr, u, p, s0, dt):
        arr[:, :, self.col] += p[:, 0:1]

    def now(self, v, u, p, s, dt):
        return v + p[:, 0]


class _SensorWander(_AddsCourse, _Aug, _CourseMixin):
    """The sensor's reading wanders, per recording: a course added to the output.

    Piecewise linear (``smooth``, the default) or constant over ``segments``
    intervals of ``span`` seconds; the knots are fitted in every recording. The
    diagnosis fits it beside a hypothesis whose course is re-estimated on the
    held-out recordings: a course the plant's physics shapes should fit them
    better than one added to the reading unshaped (coloured sensor noise).
    """

    effect = "sensor_drift"
    form = "wander"
    side = "sensor"
    state_suffixes = ("t",)
    x0_free = (False,)

    def __init__(self, spec, base):
        super().__init__(spec, base)
        self._setup_course(spec, True)
        unit = self.units.get(self.signal, "1")
        a = _bounds(spec, "amplitude", (-100.0, 100.0))
        sig = self.signal
        self.params = [
            _param(f"wander_k{i}_{sig}", 0.0, *a, unit, f"wander of {sig}, knot {i}", LOCAL)
            for i in range(self.n_knots)
        ]

    def describe(self) -> str:
        return f"wander of the reading, {self.knots_doc()}"

    def course(self, p, t):
        return self._value(t, p)

    def _value(self, t, p):
        return _course(p, t, self.span, self.smooth)


class _SensorDrift(_Aug):
    effect = "sensor_drift"
    form = "linear from the logger's start"
    side = "sensor"
    state_suffixes = ("t",)
    x0_free = (False,)

    def __init__(self, spec, base):
        super().__init__(spec, base)
        unit = self.units.get(self.signal, "1")
        lo, hi = _bounds(spec, "rate", (-50.0, 50.0))
        self.params = [
            _param(
                f"drift_{self.signal}",
                0.0,
                lo,
                hi,
                f"{unit}/h",
                f"drift of the {self.signal} sensor per hour",
            )
        ]

    def apply(self, arr, u, p, s0, dt):
        t = s0[:, 0:1] + dt * np.arange(arr.shape[1])[None, :]
        arr[:, :, self.col] += p[:, 0:1] * t / 3600.0

    def now(self, v, u, p, s, dt):
        return v + p[:, 0] * s[:, 0] / 3600.0

    def advance(self, v, u, p, s, dt, v_next=None):
        return s + dt
