"""The hidden effects' physical forms, written for this suite only.

Each function is one physical law or sensor error, with its source in the
docstring. Plants call them inside their equations (heat-transfer laws, input
maps, latent heat) or on their sampled outputs (sensor lag of a rig signal,
offsets, clock skew). None of this code is shared with the diagnosis or with
``thermogym.models.augmented``: a reviewer must not find one function that
both makes an effect and explains it.

The :class:`Hidden` record is a case's ground truth: vocabulary name, form,
settings, where it acts, and its size in physical words.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from thermogym.vocabulary import EFFECT_NAMES

__all__ = [
    "FORMS",
    "SIGMA_SB",
    "Hidden",
    "apply_input_map",
    "backlash",
    "clock_skew",
    "dead_zone",
    "first_order_lag",
    "latent_capacity",
    "natural_convection",
    "phase_angle_power",
    "piecewise_linear",
    "power_law",
    "radiation",
    "radiation_conductance",
    "saturation",
]

Array = NDArray[np.float64]

#: Stefan-Boltzmann constant [W/(m² K⁴)] (CODATA 2018).
SIGMA_SB = 5.670374419e-8
_K = 273.15

#: The forms each effect takes in this suite (issue 15, item 4, plus the mechanical ones).
FORMS: dict[str, tuple[str, ...]] = {
    "input_nonlinearity": ("power_law", "saturation", "dead_zone", "piecewise_linear"),
    "nonlinear_heat_transfer": ("radiation", "natural_convection"),
    "time_varying_parameter": ("ramp", "step", "random_walk"),
    "unmeasured_disturbance": ("periodic", "steps", "smooth"),
    "transport_delay": ("input_dead_time", "output_dead_time", "clock_skew"),
    "sensor_lag": ("first_order",),
    "sensor_offset": ("constant",),
    "sensor_drift": ("linear",),
    "missing_dynamics": ("extra_state",),
    "input_dependent_heat_transfer": ("flow_dependent", "speed_dependent", "rig"),
    "supply_variation": ("steps", "smooth", "rig"),
    "phase_change": ("latent_heat", "rig"),
    "backlash": ("play", "rig"),
}


@dataclass(frozen=True)
class Hidden:
    """One hidden effect of a case: the ground truth the diagnosis should name.

    Parameters
    ----------
    effect : str
        Vocabulary name (:data:`thermogym.vocabulary.EFFECT_NAMES`).
    form : str
        The functional form (:data:`FORMS`).
    params : mapping
        The settings the plant reads (SI units).
    where : str
        The signal, node or parameter it acts on.
    size : str
        Its magnitude in physical words (for the tables).
    """

    effect: str
    form: str
    params: Mapping[str, Any] = field(default_factory=dict)
    where: str = ""
    size: str = ""

    def __post_init__(self) -> None:
        if self.effect not in EFFECT_NAMES:
            raise ValueError(f"effect {self.effect!r} is not in the vocabulary {EFFECT_NAMES}")
        if self.form not in FORMS.get(self.effect, ()):
            raise ValueError(
                f"form {self.form!r} of {self.effect!r}; expected one of "
                f"{FORMS.get(self.effect, ())}"
            )

    def get(self, key: str, default: Any = None) -> Any:
        """A setting, or ``default``."""
        return self.params.get(key, default)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready record."""
        return {
            "effect": self.effect,
            "form": self.form,
            "params": {k: _jsonable(v) for k, v in self.params.items()},
            "where": self.where,
            "size": self.size,
        }


def _jsonable(v: Any) -> Any:
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, tuple):
        return list(v)
    return v


# ------------------------------------------------------------------------ input maps
def power_law(u: Array, exponent: float) -> Array:
    """``u**n`` on the normalised command ``u`` in [0, 1] (full scale kept).

    A heater or lamp behind a phase-angle dimmer, a pump's flow against a
    system curve: the delivered share grows as a power of the command.
    """
    return np.clip(u, 0.0, None) ** exponent


def saturation(u: Array, level: float) -> Array:
    """``min(u, level)``: a driver that cannot deliver more than ``level`` of full scale."""
    return np.minimum(np.asarray(u, dtype=float), level)


def dead_zone(u: Array, width: float) -> Array:
    """Nothing below ``width``, then linear to full scale: ``max(u - d, 0) / (1 - d)``.

    A thyristor or heat pump that does not fire below a minimum command.
    """
    return np.clip(np.asarray(u, dtype=float) - width, 0.0, None) / (1.0 - width)


def piecewise_linear(u: Array, knots_u: Any, knots_y: Any) -> Array:
    """A monotone map through measured knots (linear in between, held outside).

    Raises
    ------
    ValueError
        Knots not increasing.
    """
    ku, ky = np.asarray(knots_u, dtype=float), np.asarray(knots_y, dtype=float)
    if np.any(np.diff(ku) <= 0) or np.any(np.diff(ky) < 0):
        raise ValueError(f"piecewise-linear knots must be increasing: {ku}, {ky}")
    return np.interp(u, ku, ky)


def phase_angle_power(u: Array) -> Array:
    """Share of full power a phase-angle controller delivers to a resistive load.

    With the firing delay ``α = π (1 - u)`` for a command ``u`` in [0, 1], the
    RMS power of a sine chopped at α is ``P/P_max = 1 - α/π + sin(2α)/(2π)``
    (integral of sin² from α to π over π/2): an S-curve, flat at both ends.
    """
    a = math.pi * (1.0 - np.clip(u, 0.0, 1.0))
    return 1.0 - a / math.pi + np.sin(2.0 * a) / (2.0 * math.pi)


def apply_input_map(u: Array, h: Hidden | None) -> Array:
    """Apply an ``input_nonlinearity`` effect's map to a normalised command (identity if none)."""
    if h is None:
        return np.asarray(u, dtype=float)
    if h.form == "power_law":
        return power_law(u, float(h.params["exponent"]))
    if h.form == "saturation":
        return saturation(u, float(h.params["level"]))
    if h.form == "dead_zone":
        return dead_zone(u, float(h.params["width"]))
    if h.form == "piecewise_linear":
        return piecewise_linear(u, h.params["knots_u"], h.params["knots_y"])
    raise ValueError(f"input map form {h.form!r}")


# ---------------------------------------------------------------- heat-transfer laws
def radiation(T: Array, T_amb: Array, emissivity: Any, area: float) -> Array:
    """Net radiation of a grey surface to large surroundings [W].

    ``q = ε σ A (T⁴ - T_amb⁴)`` with absolute temperatures (Stefan-Boltzmann;
    Incropera, Fundamentals of Heat and Mass Transfer, eq. 1.7).
    """
    return emissivity * SIGMA_SB * area * ((T + _K) ** 4 - (T_amb + _K) ** 4)


def radiation_conductance(emissivity: Any, area: float, T_ref: float, dT_ref: float) -> Any:
    """Secant radiation conductance [W/K]: the net radiation at ``T_ref`` over ``dT_ref``.

    ``ε σ A (T_ref⁴ − (T_ref − ΔT_ref)⁴) / ΔT_ref`` (absolute temperatures): the
    conductance that gives the same heat flow as radiation at that operating point.
    """
    return radiation(T_ref, T_ref - dT_ref, emissivity, area) / dT_ref


def natural_convection(dT: Array, coefficient: Any, exponent: float) -> Array:
    """Free convection ``q = k |ΔT|^n sign(ΔT)`` [W].

    ``n`` = 1.25 for laminar and 1.33 for turbulent free convection from a
    plate (Nu ∝ Ra^(1/4) or Ra^(1/3); Incropera ch. 9, the simplified air
    correlations h = 1.42 (ΔT/L)^(1/4), h = 1.31 ΔT^(1/3)).
    """
    return coefficient * np.abs(dT) ** exponent * np.sign(dT)


def latent_capacity(T: Array, latent: Any, T_melt: float, width: float) -> Array:
    """Apparent heat capacity of melting [J/K]: latent heat spread as a Gaussian in T.

    The apparent-heat-capacity method for phase-change materials: the
    latent heat ``L`` [J] is released over a melting range of standard
    deviation ``width`` [K] around ``T_melt`` [°C]; its integral over T is L.
    """
    z = (T - T_melt) / width
    return latent / (width * math.sqrt(2.0 * math.pi)) * np.exp(-0.5 * z * z)


# ------------------------------------------------------------------ mechanisms, sensors
def backlash(u: Array, width: Any, y0: Any = None) -> Array:
    """Play operator: the output follows the input only after taking up a play of ``width``.

    ``y[k] = clip(y[k-1], u[k] - w/2, u[k] + w/2)`` (a valve stem with
    clearance in its linkage); ``u`` has shape (T,) or (B, T).
    """
    ua = np.atleast_2d(np.asarray(u, dtype=float))
    half = 0.5 * np.broadcast_to(np.asarray(width, dtype=float), (ua.shape[0],))
    y = np.empty_like(ua)
    prev = ua[:, 0].copy() if y0 is None else np.broadcast_to(y0, (ua.shape[0],)).astype(float)
    # the play operator has memory: a loop over time, vectorised over the batch
    for k in range(ua.shape[1]):
        prev = np.clip(prev, ua[:, k] - half, ua[:, k] + half)
        y[:, k] = prev
    return y.reshape(np.shape(u))


def first_order_lag(x: Array, tau: float, dt: float, y0: float | None = None) -> Array:
    """A sensor's first-order lag of a sampled signal, exact for a signal linear between samples.

    ``τ dy/dt = x(t) - y``; with ``x`` linear over each interval and
    ``a = exp(-dt/τ)``:
    ``y[k+1] = a y[k] + x[k+1] - a x[k] - (x[k+1] - x[k]) (τ/dt)(1 - a)``.
    The sensor starts at ``y0`` (default: the signal's first value).
    """
    x = np.asarray(x, dtype=float)
    a = math.exp(-dt / tau)
    c = (tau / dt) * (1.0 - a)
    y = np.empty_like(x)
    y[0] = x[0] if y0 is None else y0
    # y[k+1] - a y[k] = (1 - c) x[k+1] + (c - a) x[k]: an IIR filter, run as one
    from scipy.signal import lfilter

    drive = (1.0 - c) * x[1:] + (c - a) * x[:-1]
    if x.size > 1:
        y[1:], _ = lfilter([1.0], [1.0, -a], drive, zi=[a * y[0]])
    return y


def clock_skew(t: Array, x: Array, skew: float) -> Array:
    """What a logger whose clock runs ``skew`` seconds behind records of a held signal.

    The logger writes at its time stamp ``t_k`` the value the signal had at
    ``t_k + skew`` (sample-and-hold signal, so the value is the one held at that
    instant; held at the ends). Seen from the recording, the plant responds
    to the logged signal ``skew`` seconds late: a transport delay.
    """
    t = np.asarray(t, dtype=float)
    x = np.asarray(x, dtype=float)
    idx = np.searchsorted(t, t + skew, side="right") - 1
    return x[np.clip(idx, 0, t.size - 1)]
