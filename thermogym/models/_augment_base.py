"""Common ground of the augmentation kinds: the base class, parameter and course helpers.

An augmentation (:class:`_Aug`) is an effect of the vocabulary in one
physically allowed *form*, written around a base model it cannot see inside;
the kinds themselves are in :mod:`~thermogym.models._augment_input`,
:mod:`~thermogym.models._augment_loop`, :mod:`~thermogym.models._augment_plant`
and :mod:`~thermogym.models._augment_sensor`, indexed by
:mod:`~thermogym.models._augment_kinds`.

Parameters whose values belong to one recording (a disturbance's course, the
supply's wander) are in the parameter group ``"local"`` (:data:`LOCAL`): the
diagnosis fits them separately in every recording; a model used elsewhere runs
with them at their neutral values. Parameters in the group ``"recorded"``
(:data:`RECORDED`: the times of disturbance events read from a recording's
residual) also belong to one recording, but are never fitted: the diagnosis
hands their values in per recording, and counts them as what they cost.
Courses over time (:class:`_CourseMixin`)
are piecewise constant (``steps``) or piecewise linear (``smooth``) on
``segments`` equal intervals of ``span`` seconds from the recording's start.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numba as nb
import numpy as np
from numpy.typing import NDArray
from scipy.signal import lfilter

from thermogym.errors import ConfigError
from thermogym.models.base import Model, Parameter

__all__ = ["LOCAL", "RECORDED"]

_PROV = "fitted by thermogym diagnosis; the neutral value switches the effect off"
#: Parameter group of per-recording parameters.
LOCAL = "local"
#: Parameter group of per-recording values read from the data (never fitted).
RECORDED = "recorded"
_TEMP = ("°C", "K", "degC")


# ------------------------------------------------------------------ helpers
def _param(
    name: str, neutral: float, lo: float, hi: float, unit: str, what: str, group: str = ""
) -> Parameter:
    return Parameter(name, neutral, lo, hi, unit, what, _PROV, group or "augmentation")


def _bounds(spec: Mapping[str, Any], key: str, default: tuple[float, float]) -> tuple[float, float]:
    b = dict(spec.get("bounds") or {}).get(key)
    if b is None:
        return default
    try:
        lo, hi = float(b[0]), float(b[1])
    except (TypeError, ValueError, IndexError) as e:
        raise ConfigError(f"augmentation bounds[{key!r}] is {b!r}; expected [lower, upper]") from e
    if not lo <= hi:
        raise ConfigError(f"augmentation bounds[{key!r}] is [{lo}, {hi}]; expected lower <= upper")
    return lo, hi


def _number(spec: Mapping[str, Any], key: str, default: float, effect: str, positive=True) -> float:
    v = spec.get(key, default)
    try:
        x = float(v)
    except (TypeError, ValueError):
        x = math.nan
    if not math.isfinite(x) or (positive and x <= 0):
        raise ConfigError(
            f"{effect} {key} is {v!r}; expected a {'positive ' if positive else ''}number"
        )
    return x


@nb.njit(cache=True)
def _play(y: NDArray[np.float64], c: NDArray[np.float64], prev0: NDArray[np.float64]) -> None:
    # backlash (play) operator of half-width c, in place, one row per batch member
    B, T = y.shape
    for b in range(B):
        prev = prev0[b]
        for k in range(T):
            v = y[b, k]
            if v > prev + c[b]:
                prev = v - c[b]
            elif v < prev - c[b]:
                prev = v + c[b]
            y[b, k] = prev


def _lag_coeff(tau: NDArray[np.float64], dt: float) -> NDArray[np.float64]:
    with np.errstate(divide="ignore", over="ignore"):
        return np.where(tau > 0, np.exp(-dt / np.where(tau > 0, tau, 1.0)), 0.0)


def _lowpass(x: NDArray[np.float64], a: NDArray[np.float64], s0: NDArray[np.float64]):
    """``s[k+1] = a s[k] + (1 − a) x[k]``, ``s[0] = s0`` per row (exact lag of a held signal)."""
    out = np.empty_like(x)
    for b in range(x.shape[0]):
        if a[b] == 0.0:
            out[b, 0] = s0[b]
            out[b, 1:] = x[b, :-1]
            continue
        out[b], _ = lfilter([0.0, 1.0 - a[b]], [1.0, -a[b]], x[b], zi=[s0[b]])
    return out


def _course(p: NDArray[np.float64], t: NDArray[np.float64], span: float, smooth: bool):
    """Value of a piecewise course at times ``t`` (B, T) from knot values ``p`` (B, K)."""
    K = p.shape[1]
    if smooth:  # K knots at 0, span/(K−1), ..., span; held beyond
        x = np.clip(t / span * (K - 1), 0.0, K - 1)
        i = np.minimum(np.floor(x).astype(int), K - 2)
        f = x - i
        rows = np.arange(p.shape[0])[:, None]
        return (1.0 - f) * p[rows, i] + f * p[rows, i + 1]
    i = np.clip(np.floor(t / span * K).astype(int), 0, K - 1)
    rows = np.arange(p.shape[0])[:, None]
    return p[rows, i]


class _Aug:
    """One augmentation: parameters, states, whole-trajectory and step-wise maps."""

    effect = ""
    form = ""
    side = "input"
    state_suffixes: tuple[str, ...] = ()
    #: per state: may its initial value be estimated from data (a physical lag, a mass)?
    x0_free: tuple[bool, ...] = ()

    def __init__(self, spec: Mapping[str, Any], base: Model) -> None:
        self.spec = dict(spec)
        self.signal = str(spec.get("signal", ""))
        side = self.side
        names = base.exogenous_names if side == "input" else base.output_names
        if self.signal not in names:
            kind = "exogenous signals" if side == "input" else "outputs"
            raise ConfigError(
                f"augmentation {self.effect!r} names signal {self.signal!r}; the {kind} of "
                f"model {base.name!r} are {list(names)}"
            )
        self.col = list(names).index(self.signal)
        #: name part of the parameters: the signal, or a shared tag (one parameter, many signals)
        self.tag = str(spec.get("share") or self.signal)
        self.units = {s.name: s.unit for s in base.signals}
        self.exo = list(base.exogenous_names)
        self.outs = list(base.output_names)
        self.params: list[Parameter] = []

    @property
    def n_states(self) -> int:
        return len(self.state_suffixes)

    def state_names(self) -> list[str]:
        return [f"{self.effect}_{self.signal}_{s}" for s in self.state_suffixes]

    def describe(self) -> str:
        """The form in words (reports)."""
        return self.form or "as written"

    def course(self, p: NDArray[np.float64], t: NDArray[np.float64]) -> NDArray[np.float64] | None:
        """The per-recording course at times ``t`` (B, T) since the start, or None."""
        return None

    def _exo(self, key: str, default: str | None = None) -> int | None:
        name = self.spec.get(key, default)
        if not name:
            return None
        if name not in self.exo:
            raise ConfigError(
                f"augmentation {self.effect!r}: {key!r} {name!r} is not an exogenous signal; "
                f"they are {self.exo}"
            )
        return self.exo.index(str(name))

    def start_at_output(
        self, p: NDArray[np.float64], u0: NDArray[np.float64], y0: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """:meth:`init` of an effect whose one state starts at its output's first value."""
        return y0[:, self.col : self.col + 1].copy()

    def init(
        self, p: NDArray[np.float64], u0: NDArray[np.float64], y0: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        return np.zeros((p.shape[0], self.n_states))

    def apply(self, arr, u, p, s0, dt) -> None:
        raise NotImplementedError

    def now(self, v, u, p, s, dt):
        raise NotImplementedError

    def advance(self, v, u, p, s, dt, v_next=None):
        return s


class _CourseMixin:
    """A piecewise course over time: ``segments`` intervals of ``span`` seconds."""

    effect: str  # the effect's name, set by the class this is mixed into

    def _setup_course(self, spec, smooth_default: bool) -> None:
        self.span = _number(spec, "span", 86400.0, self.effect)
        self.segments = int(spec.get("segments", 6))
        if not 1 <= self.segments <= 64:
            raise ConfigError(f"{self.effect} segments is {self.segments}; expected 1-64")
        self.smooth = bool(spec.get("smooth", smooth_default))
        self.n_knots = self.segments + 1 if self.smooth else self.segments

    def knots_doc(self) -> str:
        kind = "piecewise linear" if self.smooth else "piecewise constant"
        return f"{kind} over {self.segments} intervals of {self.span / self.segments:.4g} s"


class _AddsCourse:
    """Adds ``self._value(t, p)``, a per-recording course in time, to the augmented column.

    The state is the time since the recording's start.
    """

    col: int

    def _value(self, t, p):  # the course at times t (B, T) since the start
        raise NotImplementedError

    def apply(self, arr, u, p, s0, dt):
        t = s0[:, 0:1] + dt * np.arange(arr.shape[1])[None, :]
        arr[:, :, self.col] += self._value(t, p)

    def now(self, v, u, p, s, dt):
        return v + self._value(s[:, 0:1], p)[:, 0]

    def advance(self, v, u, p, s, dt, v_next=None):
        return s + dt
