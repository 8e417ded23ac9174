"""The augmentations of :class:`~thermogym.models.augmented.AugmentedModel`, one class each.

Each augmentation is an effect of the vocabulary in one physically allowed
*form*, written around a base model it cannot see inside. It acts on one of
four sides:

``input``
    transforms an exogenous column before the base model (dead time, static
    maps, play, a modulated supply, a disturbance added to a port, a lag);
``loop``
    adds a heat-flow term to a *port* (the ambient temperature input, or the
    heat input) computed from the base model's output: an extra conductance
    that grows with the temperature difference, with an input, with time, a
    heat capacity coupled to the output node, latent heat. The whole
    trajectory is found by waveform relaxation (module
    :mod:`thermogym.models.augmented`); stepping feeds the term back sample by
    sample;
``plant``
    transforms the base output (static, legacy forms; a parallel path);
``sensor``
    transforms what the sensor reads (lag, offset, drift, dead time).

Parameters whose values belong to one recording (a disturbance's course, the
supply's wander) are in the parameter group ``"local"``: the diagnosis fits
them separately in every recording; a model used elsewhere runs with them at
their neutral values. Courses over time are piecewise constant (``steps``) or
piecewise linear (``smooth``) on ``segments`` equal intervals of ``span``
seconds from the recording's start.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numba as nb
import numpy as np
from numpy.typing import NDArray
from scipy.signal import lfilter

from thermogym.errors import ConfigError, SimulationError
from thermogym.models.base import Model, Parameter

__all__ = ["AUGMENTATIONS", "KINDS", "LOCAL", "RESIDUAL_TERMS", "kind_of"]

_PROV = "fitted by thermogym diagnosis; the neutral value switches the effect off"
#: Parameter group of per-recording parameters.
LOCAL = "local"
_TEMP = ("°C", "K", "degC")
_ZERO_C = 273.15

#: Augmentation effects in application order, with their side (legacy forms).
AUGMENTATIONS: dict[str, str] = {
    "transport_delay": "input",
    "unmeasured_disturbance": "input",
    "input_nonlinearity": "input",
    "backlash": "plant",
    "supply_variation": "input",
    "missing_dynamics": "plant",
    "residual_ode": "plant",
    "input_dependent_heat_transfer": "plant",
    "nonlinear_heat_transfer": "plant",
    "time_varying_parameter": "plant",
    "phase_change": "loop",
    "sensor_lag": "sensor",
    "sensor_offset": "sensor",
    "sensor_drift": "sensor",
}

#: Terms a ``residual_ode`` augmentation may use (see the diagnosis' sparse regression).
RESIDUAL_TERMS: dict[str, str] = {
    "1": "constant heat leak",
    "e": "relaxation of the residual itself",
    "dT": "temperature rise Δ = y − r",
    "dT|dT|": "quadratic loss Δ|Δ| (radiation-like growth)",
    "dT^4/3": "natural convection Δ|Δ|^(1/3)",
    "u": "input",
    "u^2": "input squared",
    "u*dT": "input times rise (forced convection)",
    "t": "time since start [h]",
}


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


# ================================================================== input side
class _Delay(_Aug):
    effect = "transport_delay"
    form = "input dead time"

    #: name of the dead-time parameter (before the signal's name) and what it describes
    prefix = "delay_"
    described = "dead time of {} before it acts on the plant"

    def __init__(self, spec, base):
        super().__init__(spec, base)
        lo, hi = _bounds(spec, "delay", (0.0, 3600.0))
        self.history = int(spec.get("history", 0))
        if self.history < 0:
            raise ConfigError(f"transport_delay history is {self.history}; expected >= 0")
        self.params = [
            _param(
                f"{self.prefix}{self.signal}",
                0.0,
                max(0.0, lo),
                hi,
                "s",
                self.described.format(self.signal),
            )
        ]
        self.state_suffixes = tuple(f"lag{h + 1}" for h in range(self.history))
        self.x0_free = (False,) * self.history

    def init(self, p, u0, y0):
        return np.repeat(u0[:, self.col : self.col + 1], self.history, axis=1)

    def apply(self, arr, u, p, s0, dt):
        T = arr.shape[1]
        k = np.arange(T, dtype=float)
        for b in range(arr.shape[0]):
            d = p[b, 0] / dt
            if d <= 0:
                continue
            col = arr[b, :, self.col].copy()
            if self.history:
                # samples before the start come from the stored history (oldest last)
                hist = s0[b, ::-1]
                full = np.concatenate([hist, col])
                arr[b, :, self.col] = np.interp(k + self.history - d, np.arange(full.size), full)
            else:
                arr[b, :, self.col] = np.interp(k - d, k, col, left=col[0])

    def now(self, v, u, p, s, dt):
        if dt is None or self.history == 0:  # the input was constant before the start
            return v
        d = np.minimum(p[:, 0] / dt, self.history)
        seq = np.concatenate([v[:, None], s], axis=1)  # lag 0 (now), lag 1, ...
        i = np.floor(d).astype(int)
        f = d - i
        i1 = np.minimum(i + 1, self.history)
        rows = np.arange(v.shape[0])
        return (1.0 - f) * seq[rows, i] + f * seq[rows, i1]

    def check(self, p, dt):
        """Raise when stepping needs more history than the model keeps."""
        d = p[:, 0] / dt
        if np.any(d > self.history):
            raise SimulationError(
                f"{self.effect} of {self.signal!r} is {float(p[:, 0].max())!r} s = "
                f"{float(d.max()):.2f} samples but the model keeps history = {self.history} "
                "samples; rebuild it with a longer history to step it"
            )

    def advance(self, v, u, p, s, dt, v_next=None):
        if not self.history:
            return s
        return np.concatenate([v[:, None], s[:, :-1]], axis=1)


class _Disturbance(_Aug):
    """Legacy periodic disturbance with shared amplitudes (added to a port or an output)."""

    effect = "unmeasured_disturbance"
    form = "periodic, shared phase"
    state_suffixes = ("t",)
    x0_free = (False,)

    def __init__(self, spec, base):
        if str(spec.get("signal", "")) in base.output_names:
            self.side = "plant"  # a disturbance seen only in an output
        super().__init__(spec, base)
        unit = self.units.get(self.signal, "1")
        a = _bounds(spec, "amplitude", (-20.0, 20.0))
        per = _bounds(spec, "period", (600.0, 7 * 86400.0))
        sig = self.signal
        self.params = [
            _param(f"dist_sin_{sig}", 0.0, *a, unit, f"sine amplitude added to {sig}"),
            _param(f"dist_cos_{sig}", 0.0, *a, unit, f"cosine amplitude added to {sig}"),
            _param(
                f"dist_period_{sig}",
                float(np.clip(spec.get("period", per[0]), *per)),
                *per,
                "s",
                f"period of the disturbance of {sig}",
            ),
        ]

    def _wave(self, t, p):
        w = 2.0 * np.pi * t / p[:, 2:3]
        return p[:, 0:1] * np.sin(w) + p[:, 1:2] * np.cos(w)

    def apply(self, arr, u, p, s0, dt):
        t = s0[:, 0:1] + dt * np.arange(arr.shape[1])[None, :]
        arr[:, :, self.col] += self._wave(t, p)

    def now(self, v, u, p, s, dt):
        return v + self._wave(s[:, 0:1], p)[:, 0]

    def advance(self, v, u, p, s, dt, v_next=None):
        return s + dt


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


class _DisturbanceForm(_AddsCourse, _Aug, _CourseMixin):
    """An unmeasured disturbance added to a port, per recording: periodic, steps or smooth."""

    effect = "unmeasured_disturbance"
    state_suffixes = ("t",)
    x0_free = (False,)

    def __init__(self, spec, base):
        super().__init__(spec, base)
        self.form = str(spec["form"])
        unit = self.units.get(self.signal, "1")
        a = _bounds(spec, "amplitude", (-20.0, 20.0))
        sig = self.signal
        if self.form == "periodic":
            per = _bounds(spec, "period", (600.0, 7 * 86400.0))
            self.params = [
                _param(
                    f"dist_period_{sig}",
                    float(np.clip(spec.get("period", per[0]), *per)),
                    *per,
                    "s",
                    f"period of the disturbance added to {sig}",
                ),
                _param(f"dist_sin_{sig}", 0.0, *a, unit, f"sine amplitude on {sig}", LOCAL),
                _param(f"dist_cos_{sig}", 0.0, *a, unit, f"cosine amplitude on {sig}", LOCAL),
            ]
        elif self.form in ("steps", "smooth"):
            self._setup_course(spec, self.form == "smooth")
            self.params = [
                _param(f"dist_k{i}_{sig}", 0.0, *a, unit, f"disturbance on {sig}, knot {i}", LOCAL)
                for i in range(self.n_knots)
            ]
        else:
            raise ConfigError(
                f"unmeasured_disturbance form {self.form!r}; forms are periodic, steps, smooth"
            )

    def course(self, p, t):
        return self._value(t, p)

    def _value(self, t, p):
        if self.form == "periodic":
            w = 2.0 * np.pi * t / p[:, 0:1]
            return p[:, 1:2] * np.sin(w) + p[:, 2:3] * np.cos(w)
        return _course(p, t, self.span, self.smooth)


class _Supply(_Aug, _CourseMixin):
    """The supply behind an input wanders: ``u → u (1 + s(t))``, per recording."""

    effect = "supply_variation"
    state_suffixes = ("t",)
    x0_free = (False,)

    def __init__(self, spec, base):
        super().__init__(spec, base)
        self.form = str(spec.get("form", "steps"))
        if self.form not in ("steps", "smooth"):
            raise ConfigError(f"supply_variation form {self.form!r}; forms are steps, smooth")
        self._setup_course(spec, self.form == "smooth")
        lo, hi = _bounds(spec, "relative", (-0.6, 0.6))
        self.params = [
            _param(
                f"sv_k{i}_{self.signal}",
                0.0,
                lo,
                hi,
                "1",
                f"relative change of the supply behind {self.signal}, knot {i}",
                LOCAL,
            )
            for i in range(self.n_knots)
        ]

    def course(self, p, t):
        return _course(p, t, self.span, self.smooth)

    def apply(self, arr, u, p, s0, dt):
        t = s0[:, 0:1] + dt * np.arange(arr.shape[1])[None, :]
        arr[:, :, self.col] *= 1.0 + _course(p, t, self.span, self.smooth)

    def now(self, v, u, p, s, dt):
        return v * (1.0 + _course(p, s[:, 0:1], self.span, self.smooth)[:, 0])

    def advance(self, v, u, p, s, dt, v_next=None):
        return s + dt


class _InputMap(_Aug):
    """A static map of an input: power law, saturation, dead zone or monotone piecewise-linear."""

    effect = "input_nonlinearity"

    def __init__(self, spec, base):
        super().__init__(spec, base)
        self.form = str(spec.get("form", "power"))
        self.u_ref = _number(spec, "u_ref", 1.0, self.effect)
        sig = self.signal
        unit = self.units.get(sig, "1")
        if self.form == "power":
            lo, hi = _bounds(spec, "alpha", (0.2, 3.0))
            self.params = [
                _param(f"alpha_{sig}", 1.0, lo, hi, "1", f"exponent of {sig}: u_ref (u/u_ref)^α")
            ]
        elif self.form == "saturation":
            lo, hi = _bounds(spec, "c", (0.0, 20.0))
            self.params = [
                _param(
                    f"sat_{sig}",
                    0.0,
                    lo,
                    hi,
                    "1",
                    f"saturation of {sig}: u (1 + c)/(1 + c|u|/u_ref)",
                )
            ]
        elif self.form == "limit":
            # a hard limit (an actuator's current or stroke limit): u passes unchanged up to
            # the level L and no further; neutral at the top of its range (10 × the largest
            # input given), where it limits nothing
            u_max = _number(spec, "u_max", self.u_ref, self.effect)
            lo, hi = _bounds(spec, "level", (0.02 * u_max, 10.0 * u_max))
            self.params = [
                _param(
                    f"lim_{sig}",
                    hi,
                    lo,
                    hi,
                    unit,
                    f"limit of {sig}: sign(u) min(|u|, L)",
                )
            ]
        elif self.form == "dead_zone":
            lo, hi = _bounds(spec, "d", (0.0, 0.9 * self.u_ref))
            self.params = [
                _param(
                    f"dz_{sig}",
                    0.0,
                    lo,
                    hi,
                    unit,
                    f"dead zone of {sig}: nothing acts below it",
                )
            ]
        elif self.form == "piecewise_linear":
            knots = np.asarray(spec.get("knots", ()), dtype=float)
            if knots.ndim != 1 or knots.size < 3 or np.any(np.diff(knots) <= 0):
                raise ConfigError(
                    f"input_nonlinearity piecewise_linear knots {spec.get('knots')!r}; expected "
                    "at least 3 increasing input values"
                )
            self.knots = knots
            dq = np.diff(knots)
            lo, hi = _bounds(spec, "slope", (0.0, 20.0))
            # relative slopes of segments 1..K−1 (segment 0 has slope 1): a monotone map that
            # keeps the first and last knots (the gain stays the model's)
            self.params = [
                _param(
                    f"pwl{i}_{sig}",
                    1.0,
                    lo,
                    hi,
                    "1",
                    f"slope of {sig}'s map between {knots[i]:.4g} and {knots[i + 1]:.4g}, "
                    "relative to the first segment",
                )
                for i in range(1, dq.size)
            ]
        else:
            raise ConfigError(
                f"input_nonlinearity form {self.form!r}; forms are power, saturation, limit, "
                "dead_zone, "
                "piecewise_linear"
            )

    def _map(self, x, p):
        ur = self.u_ref
        if self.form == "power":
            return np.sign(x) * ur * (np.abs(x) / ur) ** p[..., 0:1]
        if self.form == "saturation":
            c = p[..., 0:1]
            return x * (1.0 + c) / (1.0 + c * np.abs(x) / ur)
        if self.form == "limit":
            return np.sign(x) * np.minimum(np.abs(x), p[..., 0:1])
        if self.form == "dead_zone":
            d = np.minimum(p[..., 0:1], 0.999 * ur)
            return np.sign(x) * np.maximum(np.abs(x) - d, 0.0) * ur / (ur - d)
        q = self.knots
        dq = np.diff(q)
        w = np.concatenate([np.ones((*p.shape[:-1], 1)), p], axis=-1) * dq  # segment rises
        tot = np.sum(w, axis=-1, keepdims=True)
        vals = q[0] + (q[-1] - q[0]) * np.concatenate(
            [np.zeros((*p.shape[:-1], 1)), np.cumsum(w, axis=-1) / tot], axis=-1
        )  # map at the knots (B, K+1)
        out = np.empty(np.broadcast_shapes(x.shape, (*vals.shape[:-1], 1)))
        xb = np.broadcast_to(x, out.shape)
        for b in range(out.shape[0]):
            vb = vals[b] if vals.ndim > 1 else vals
            s_lo = (vb[1] - vb[0]) / dq[0]
            s_hi = (vb[-1] - vb[-2]) / dq[-1]
            xv = xb[b]
            r = np.interp(xv, q, vb)
            r = np.where(xv < q[0], vb[0] + s_lo * (xv - q[0]), r)
            out[b] = np.where(xv > q[-1], vb[-1] + s_hi * (xv - q[-1]), r)
        return out

    def apply(self, arr, u, p, s0, dt):
        arr[:, :, self.col] = self._map(arr[:, :, self.col], p)

    def now(self, v, u, p, s, dt):
        return self._map(v[:, None], p)[:, 0]


class _InputPlay(_Aug):
    """Backlash between an actuator command and what acts on the plant (play of half-width c)."""

    effect = "backlash"
    form = "play on the input"
    state_suffixes = ("prev",)
    x0_free = (False,)

    def __init__(self, spec, base):
        super().__init__(spec, base)
        lo, hi = _bounds(spec, "c", (0.0, 1.0))
        self.params = [
            _param(
                f"backlash_{self.signal}",
                0.0,
                lo,
                hi,
                self.units.get(self.signal, "1"),
                f"half width of the play between the {self.signal} command and its effect",
            )
        ]

    def init(self, p, u0, y0):
        return u0[:, self.col : self.col + 1].copy()

    def apply(self, arr, u, p, s0, dt):
        y = np.ascontiguousarray(arr[:, :, self.col])
        _play(y, np.ascontiguousarray(np.maximum(p[:, 0], 0.0)), np.ascontiguousarray(s0[:, 0]))
        arr[:, :, self.col] = y

    def _step_play(self, v, p, prev):
        c = np.maximum(p[:, 0], 0.0)
        return np.where(v > prev + c, v - c, np.where(v < prev - c, v + c, prev))

    def now(self, v, u, p, s, dt):
        return self._step_play(v, p, s[:, 0])

    def advance(self, v, u, p, s, dt, v_next=None):
        return self._step_play(v, p, s[:, 0])[:, None]


class _InputLag(_Aug):
    """A heat capacity between an input and the plant (a slab the heat pump heats): a lag."""

    effect = "missing_dynamics"
    form = "lag on the input"
    state_suffixes = ("s",)
    x0_free = (True,)

    def __init__(self, spec, base):
        super().__init__(spec, base)
        lo, hi = _bounds(spec, "tau", (0.0, 86400.0))
        self.params = [
            _param(
                f"lag_in_{self.signal}",
                0.0,
                max(lo, 0.0),
                hi,
                "s",
                f"time constant of a store between {self.signal} and the plant",
            )
        ]

    def init(self, p, u0, y0):
        return u0[:, self.col : self.col + 1].copy()

    def apply(self, arr, u, p, s0, dt):
        a = _lag_coeff(p[:, 0], dt)
        x = arr[:, :, self.col]
        lagged = _lowpass(x, a, s0[:, 0])
        arr[:, :, self.col] = np.where(a[:, None] > 0, lagged, x)

    def now(self, v, u, p, s, dt):
        return np.where(p[:, 0] > 0, s[:, 0], v)

    def advance(self, v, u, p, s, dt, v_next=None):
        a = _lag_coeff(p[:, 0], dt)
        return (a * s[:, 0] + (1.0 - a) * v)[:, None]


# ================================================================== loop side
class _Loop(_Aug):
    """A heat-flow term fed back from an output to a port (ambient or heat input).

    The term is ``port += c · q`` with ``q`` in kelvin-equivalents (a loss of
    ``q`` K at the ambient port lowers the ambient the plant sees by ``q``;
    at a heat input ``c`` converts kelvin to the input's unit: it is the
    port's share of the model's gain).
    """

    side = "loop"

    def __init__(self, spec, base):
        super().__init__(spec, base)
        self.port = self._exo("port")
        if self.port is None:
            raise ConfigError(f"{self.effect} (form {self.form!r}) needs a 'port' input")
        self.ref = self._exo("reference")
        uy = self.units.get(self.signal, "1")
        self.kelvin = 0.0 if uy == "K" else _ZERO_C  # temperatures in °C unless the unit says K
        # ``scale`` converts a kelvin-equivalent loss into the port's unit (1 for an ambient)
        self.scale = _number(spec, "scale", 1.0, self.effect, positive=False)

    def reference(self, u, y0):
        """Reference temperature (B, T): the reference input, or the output's first value."""
        if self.ref is not None:
            return u[..., self.ref]
        return np.broadcast_to(y0[:, None], u.shape[:2]) if u.ndim == 3 else y0

    def term(self, y, u, p, s0, dt) -> NDArray[np.float64]:  # (B, T), port units
        raise NotImplementedError

    def term_now(self, y, u, p, s, dt) -> NDArray[np.float64]:  # (B,)
        raise NotImplementedError


class _NonlinearLoss(_Loop):
    """Loss growing faster than linear in the temperature difference: radiation or convection."""

    effect = "nonlinear_heat_transfer"
    state_suffixes = ("y0",)
    x0_free = (False,)

    def __init__(self, spec, base):
        self.form = str(spec.get("form", "radiation"))
        super().__init__(spec, base)
        if self.form == "radiation":
            self.n = 4.0
        elif self.form.startswith("convection"):
            self.n = _number(spec, "exponent", 1.25, self.effect)
        else:
            raise ConfigError(
                f"nonlinear_heat_transfer form {self.form!r}; forms are radiation, convection"
            )
        # reference scales: the mean temperature [K] and rise [K] of the recordings
        self.T_ref = _number(spec, "T_ref", 320.0, self.effect)
        self.dT_ref = _number(spec, "dT_ref", 20.0, self.effect)
        lo, hi = _bounds(spec, "kappa", (-0.5, 3.0))
        what = (
            "radiation, εσA(T⁴ − T_r⁴), as a share of the linear loss"
            if self.form == "radiation"
            else f"natural convection ∝ ΔT^{self.n:g}, as a share of the linear loss"
        )
        self.params = [
            _param(
                f"kappa_{'rad' if self.form == 'radiation' else 'conv'}_{self.tag}",
                0.0,
                lo,
                hi,
                "1",
                f"{what} of {self.signal}",
            )
        ]

    def describe(self) -> str:
        return (
            "radiation (T⁴ in kelvin)"
            if self.form == "radiation"
            else (f"natural convection (ΔT^{self.n:g})")
        )

    init = _Aug.start_at_output

    def excess(self, T, r):
        """Nonlinear loss beyond its tangent at zero difference [K]."""
        d = T - r
        if self.form == "radiation":
            Tk, rk = T + self.kelvin, r + self.kelvin
            # (T⁴ − r⁴)/(4 T_ref³) − (T − r): the radiative exchange's excess over linear
            with np.errstate(over="ignore", invalid="ignore"):
                return (Tk**4 - rk**4) / (4.0 * self.T_ref**3) - d
        return np.sign(d) * np.abs(d) ** self.n / self.dT_ref ** (self.n - 1.0) - d

    def term(self, y, u, p, s0, dt):
        r = self.reference(u, s0[:, 0])
        return -self.scale * p[:, 0:1] * self.excess(y[:, :, self.col], r)

    def term_now(self, y, u, p, s, dt):
        r = u[:, self.ref] if self.ref is not None else s[:, 0]
        return -self.scale * p[:, 0] * self.excess(y[:, self.col], r)


class _ForcedLoss(_Loop):
    """A conductance that grows with an input (forced convection, a flow): κ (u/u_ref)^m."""

    effect = "input_dependent_heat_transfer"
    form = "conductance ∝ input^m"
    state_suffixes = ("y0",)
    x0_free = (False,)

    def __init__(self, spec, base):
        super().__init__(spec, base)
        self.src = self._exo("source")
        if self.src is None:
            raise ConfigError("input_dependent_heat_transfer needs a 'source' input")
        self.u_ref = _number(spec, "u_ref", 1.0, self.effect)
        lo, hi = _bounds(spec, "kappa", (-1.0, 5.0))
        mlo, mhi = _bounds(spec, "m", (0.2, 2.0))
        src = self.exo[self.src]
        self.params = [
            _param(
                f"kappa_fc_{self.tag}",
                0.0,
                lo,
                hi,
                "1",
                f"conductance growing with {src}, at u_ref = {self.u_ref:.4g}, as a share of the "
                "linear loss",
            ),
            _param(
                f"m_fc_{self.tag}", 0.8, mlo, mhi, "1", f"exponent of {src} in that conductance"
            ),
        ]

    def describe(self) -> str:
        return f"conductance ∝ {self.exo[self.src]}^m"

    init = _Aug.start_at_output

    def term(self, y, u, p, s0, dt):
        r = self.reference(u, s0[:, 0])
        g = (np.abs(u[..., self.src]) / self.u_ref) ** p[:, 1:2]
        return -self.scale * p[:, 0:1] * g * (y[:, :, self.col] - r)

    def term_now(self, y, u, p, s, dt):
        r = u[:, self.ref] if self.ref is not None else s[:, 0]
        g = (np.abs(u[:, self.src]) / self.u_ref) ** p[:, 1]
        return -self.scale * p[:, 0] * g * (y[:, self.col] - r)


class _VaryingLoss(_Loop, _CourseMixin):
    """A loss conductance that changes with time: ramp, step, or smooth random walk."""

    effect = "time_varying_parameter"
    state_suffixes = ("y0", "t")
    x0_free = (False, False)

    def __init__(self, spec, base):
        self.form = str(spec.get("form", "ramp"))
        super().__init__(spec, base)
        sig = self.tag
        if self.form == "ramp":
            lo, hi = _bounds(spec, "rate", (-0.5, 0.5))
            self.params = [
                _param(
                    f"tv_ramp_{sig}",
                    0.0,
                    lo,
                    hi,
                    "1/h",
                    f"change per hour of {self.signal}'s loss conductance (share of the linear "
                    "loss) since the recording's start",
                )
            ]
        elif self.form == "step":
            lo, hi = _bounds(spec, "size", (-0.8, 2.0))
            self.span = _number(spec, "span", 86400.0, self.effect)
            self.params = [
                _param(
                    f"tv_step_{sig}",
                    0.0,
                    lo,
                    hi,
                    "1",
                    f"step of {self.signal}'s loss conductance (share of the linear loss)",
                    LOCAL,
                ),
                _param(
                    f"tv_at_{sig}",
                    0.5,
                    0.02,
                    0.98,
                    "1",
                    "time of the step, as a share of the span",
                    LOCAL,
                ),
            ]
        elif self.form == "random_walk":
            self._setup_course(spec, True)
            lo, hi = _bounds(spec, "size", (-0.8, 2.0))
            self.params = [
                _param(
                    f"tv_k{i}_{sig}",
                    0.0,
                    lo,
                    hi,
                    "1",
                    f"change of {self.signal}'s loss conductance, knot {i}",
                    LOCAL,
                )
                for i in range(self.n_knots)
            ]
        else:
            raise ConfigError(
                f"time_varying_parameter form {self.form!r}; forms are ramp, step, random_walk"
            )

    def describe(self) -> str:
        return {"ramp": "ramp", "step": "step", "random_walk": "smooth random walk"}[self.form]

    def init(self, p, u0, y0):
        return np.column_stack([y0[:, self.col], np.zeros(p.shape[0])])

    def course(self, p, t):
        return None if self.form == "ramp" else self._factor(t, p)

    def _factor(self, t, p):
        if self.form == "ramp":
            return p[:, 0:1] * t / 3600.0
        if self.form == "step":
            # a smooth step (one sample wide at the scale of the span/200): differentiable in time
            w = self.span / 200.0
            return p[:, 0:1] / (1.0 + np.exp(-np.clip((t - p[:, 1:2] * self.span) / w, -50, 50)))
        return _course(p, t, self.span, True)

    def term(self, y, u, p, s0, dt):
        t = s0[:, 1:2] + dt * np.arange(y.shape[1])[None, :]
        r = self.reference(u, s0[:, 0])
        return -self.scale * self._factor(t, p) * (y[:, :, self.col] - r)

    def term_now(self, y, u, p, s, dt):
        r = u[:, self.ref] if self.ref is not None else s[:, 0]
        return -self.scale * self._factor(s[:, 1:2], p)[:, 0] * (y[:, self.col] - r)

    def advance(self, v, u, p, s, dt, v_next=None):
        out = s.copy()
        out[:, 1] += dt
        return out


class _ExtraNode(_Loop):
    """A heat capacity coupled to the output's node: ``τ dz/dt = y − z``, heat ``κ (z − y)``."""

    effect = "missing_dynamics"
    form = "extra node at the output"
    state_suffixes = ("z",)
    x0_free = (True,)

    def __init__(self, spec, base):
        super().__init__(spec, base)
        lo, hi = _bounds(spec, "tau", (1.0, 1e6))
        klo, khi = _bounds(spec, "kappa", (0.0, 3.0))
        self.params = [
            _param(
                f"xn_tau_{self.signal}",
                float(np.clip(spec.get("tau", 3600.0), lo, hi)),
                lo,
                hi,
                "s",
                f"time constant of a mass coupled to {self.signal}'s node",
            ),
            _param(
                f"xn_kappa_{self.signal}",
                0.0,
                klo,
                khi,
                "1",
                f"coupling of that mass, as a share of the linear loss of {self.signal}",
            ),
        ]

    init = _Aug.start_at_output

    def _z(self, y, p, s0, dt):
        a = _lag_coeff(p[:, 0], dt)
        return _lowpass(y[:, :, self.col], a, s0[:, 0])

    def term(self, y, u, p, s0, dt):
        return self.scale * p[:, 1:2] * (self._z(y, p, s0, dt) - y[:, :, self.col])

    def term_now(self, y, u, p, s, dt):
        return self.scale * p[:, 1] * (s[:, 0] - y[:, self.col])

    def advance(self, v, u, p, s, dt, v_next=None):
        a = _lag_coeff(p[:, 0], dt)
        return (a * s[:, 0] + (1.0 - a) * v)[:, None]


class _Latent(_Loop):
    """Latent heat over a melting range: an apparent heat capacity ``κ g(T) dT/dt`` taken out."""

    effect = "phase_change"
    form = "latent heat (Gaussian melting range)"
    state_suffixes = ("yprev",)
    x0_free = (False,)

    def __init__(self, spec, base):
        super().__init__(spec, base)
        tlo, thi = _bounds(spec, "T_melt", (0.0, 100.0))
        wlo, whi = _bounds(spec, "width", (0.5, 10.0))
        klo, khi = _bounds(spec, "kappa", (0.0, 5e4))
        sig = self.signal
        self.params = [
            _param(
                f"pc_kappa_{sig}",
                0.0,
                klo,
                khi,
                "s",
                f"latent heat at {sig}'s node, as seconds of its linear loss per kelvin",
            ),
            _param(
                f"pc_T_{sig}",
                float(np.clip(spec.get("T_melt", 0.5 * (tlo + thi)), tlo, thi)),
                tlo,
                thi,
                self.units.get(sig, "1"),
                "centre of the melting range",
            ),
            _param(f"pc_w_{sig}", float(np.clip(2.0, wlo, whi)), wlo, whi, "K", "melting width"),
        ]

    def init(self, p, u0, y0):
        return y0[:, self.col : self.col + 1].copy()

    def _g(self, T, p):
        z = (T - p[:, 1:2]) / p[:, 2:3]
        return np.exp(-0.5 * z * z) / (math.sqrt(2.0 * math.pi) * p[:, 2:3])

    def term(self, y, u, p, s0, dt):
        T = y[:, :, self.col]
        dT = np.diff(T, axis=1, prepend=s0[:, 0:1]) / dt  # backward difference
        return -self.scale * p[:, 0:1] * self._g(T, p) * dT

    def term_now(self, y, u, p, s, dt):
        T = y[:, self.col]
        dT = (T - s[:, 0]) / (dt if dt else 1.0)
        return -self.scale * p[:, 0] * self._g(T[:, None], p)[:, 0] * dT

    def advance(self, v, u, p, s, dt, v_next=None):
        return v[:, None].copy()


# ================================================================== plant side
class _ParallelPath(_Aug):
    effect = "missing_dynamics"
    form = "parallel path (extra state)"
    side = "plant"

    def __init__(self, spec, base):
        super().__init__(spec, base)
        srcs = spec.get("sources") or [spec.get("source", self.exo[0])]
        srcs = [str(x) for x in srcs]
        bad = [x for x in srcs if x not in self.exo]
        if bad:
            raise ConfigError(
                f"missing_dynamics sources {bad} are not exogenous signals; they are {self.exo}"
            )
        self.srcs = [self.exo.index(x) for x in srcs]
        uy = self.units.get(self.signal, "1")
        k = _bounds(spec, "gain", (-1e6, 1e6))
        tt = _bounds(spec, "T", (1.0, 1e7))
        sig = self.signal
        self.params = [
            _param(
                f"md_T_{sig}",
                float(np.clip(spec.get("T", 3600.0), *tt)),
                *tt,
                "s",
                f"time constant of the extra state seen in {sig}",
            ),
            *[
                _param(
                    f"md_K_{sig}" + ("" if len(srcs) == 1 else f"__{x}"),
                    0.0,
                    *_bounds(spec, f"gain_{x}", k),
                    f"{uy}/{self.units.get(x, '1')}",
                    f"gain of the extra path {x} → {sig}",
                )
                for x in srcs
            ],
        ]
        self.state_suffixes = ("z", *[f"u0_{self.exo[i]}" for i in self.srcs])
        self.x0_free = (True, *[False] * len(self.srcs))

    def init(self, p, u0, y0):
        return np.column_stack([np.zeros(p.shape[0]), *[u0[:, i] for i in self.srcs]])

    def apply(self, arr, u, p, s0, dt):
        a = _lag_coeff(p[:, 0], dt)
        for b in range(arr.shape[0]):
            ub = u[b if u.shape[0] > 1 else 0]
            x = np.zeros(ub.shape[0])
            for j, i in enumerate(self.srcs):
                x += p[b, 1 + j] * (ub[:, i] - s0[b, 1 + j])
            # z[k+1] = a z[k] + (1 − a) Σ K_i (u_i[k] − u_i0): exact ZOH of T dz/dt = Σ K Δu − z
            z, _ = lfilter([0.0, 1.0 - a[b]], [1.0, -a[b]], x, zi=[s0[b, 0]])
            arr[b, :, self.col] += z

    def now(self, v, u, p, s, dt):
        return v + s[:, 0]

    def advance(self, v, u, p, s, dt, v_next=None):
        a = _lag_coeff(p[:, 0], dt)
        drive = np.zeros(s.shape[0])
        for j, i in enumerate(self.srcs):
            drive += p[:, 1 + j] * (u[:, i] - s[:, 1 + j])
        out = s.copy()
        out[:, 0] = a * s[:, 0] + (1.0 - a) * drive
        return out


class _StaticRise(_Aug):
    """Legacy static (Wiener) corrections of the rise ``Δ = y − r``: exact at steady state."""

    side = "plant"
    state_suffixes: tuple[str, ...] = ("ref",)
    x0_free: tuple[bool, ...] = (False,)

    def __init__(self, spec, base):
        super().__init__(spec, base)
        self.ref = self._exo("reference")

    init = _Aug.start_at_output

    def _r(self, u, fallback):
        return u[..., self.ref] if self.ref is not None else fallback

    def apply(self, arr, u, p, s0, dt):
        ref = self._r(u, s0[:, 0:1])
        y = arr[:, :, self.col]
        arr[:, :, self.col] = ref + self._map(y - ref, u, p, s0, dt, arr.shape[1])

    def now(self, v, u, p, s, dt):
        ref = self._r(u, s[:, 0])
        return ref + self._map_now(v - ref, u, p, s)


class _Saturating(_StaticRise):
    effect = "nonlinear_heat_transfer"
    form = "static: conductance ∝ (1 + γ|ΔT|)"

    def __init__(self, spec, base):
        super().__init__(spec, base)
        self.dT_ref = _number(spec, "dT_ref", 10.0, self.effect)
        lo, hi = _bounds(spec, "gamma", (-0.2, 5.0))
        self.params = [
            _param(
                f"gamma_{self.tag}",
                0.0,
                lo,
                hi,
                "1",
                f"growth of the loss conductance of {self.signal} per ΔT_ref = {self.dT_ref:g} K",
            )
        ]

    def _f(self, d, g):
        # inverse of Δ_lin = Δ (1 + γ|Δ|/ΔT_ref): Δ = 2Δ_lin / (1 + sqrt(1 + 4γ|Δ_lin|/ΔT_ref))
        root = np.sqrt(np.maximum(1.0 + 4.0 * g * np.abs(d) / self.dT_ref, 1e-6))
        return 2.0 * d / (1.0 + root)

    def _map(self, d, u, p, s0, dt, T):
        return self._f(d, p[:, 0:1])

    def _map_now(self, d, u, p, s):
        return self._f(d, p[:, 0])


class _StaticForced(_StaticRise):
    effect = "input_dependent_heat_transfer"
    form = "static: conductance ∝ (1 + β|u|)"

    def __init__(self, spec, base):
        super().__init__(spec, base)
        self.src = self._exo("source", self.exo[0])
        self.u_ref = _number(spec, "u_ref", 1.0, self.effect)
        lo, hi = _bounds(spec, "beta", (-0.5, 5.0))
        self.params = [
            _param(
                f"beta_{self.tag}",
                0.0,
                lo,
                hi,
                "1",
                f"growth of the loss conductance with {self.exo[self.src]} per u_ref = "
                f"{self.u_ref:g}",
            )
        ]

    def _map(self, d, u, p, s0, dt, T):
        return d / np.maximum(1.0 + p[:, 0:1] * np.abs(u[..., self.src]) / self.u_ref, 1e-3)

    def _map_now(self, d, u, p, s):
        return d / np.maximum(1.0 + p[:, 0] * np.abs(u[:, self.src]) / self.u_ref, 1e-3)


class _StaticDrift(_StaticRise):
    effect = "time_varying_parameter"
    form = "static: rise × (1 + δ t)"
    state_suffixes = ("ref", "t")
    x0_free = (False, False)

    def __init__(self, spec, base):
        super().__init__(spec, base)
        lo, hi = _bounds(spec, "rate", (-0.5, 0.5))
        self.params = [
            _param(
                f"tv_rate_{self.tag}",
                0.0,
                lo,
                hi,
                "1/h",
                f"relative change per hour of the rise of {self.signal}",
            )
        ]

    def init(self, p, u0, y0):
        return np.column_stack([y0[:, self.col], np.zeros(p.shape[0])])

    def _map(self, d, u, p, s0, dt, T):
        t = s0[:, 1:2] + dt * np.arange(T)[None, :]
        return d * (1.0 + p[:, 0:1] * t / 3600.0)

    def _map_now(self, d, u, p, s):
        return d * (1.0 + p[:, 0] * s[:, 1] / 3600.0)

    def advance(self, v, u, p, s, dt, v_next=None):
        out = s.copy()
        out[:, 1] += dt
        return out


class _OutputPlay(_Aug):
    effect = "backlash"
    form = "play on the output"
    side = "plant"
    state_suffixes = ("prev",)
    x0_free = (False,)

    def __init__(self, spec, base):
        super().__init__(spec, base)
        unit = self.units.get(self.signal, "1")
        lo, hi = _bounds(spec, "c", (0.0, 1.0))
        self.params = [
            _param(
                f"backlash_{self.signal}",
                0.0,
                lo,
                hi,
                unit,
                f"half width of the play in {self.signal}",
            )
        ]

    init = _Aug.start_at_output
    apply = _InputPlay.apply
    _step_play = _InputPlay._step_play
    now = _InputPlay.now
    advance = _InputPlay.advance


class _ResidualODE(_Aug):
    effect = "residual_ode"
    form = "sparse regression"
    side = "plant"
    state_suffixes = ("e", "ref", "t")
    x0_free = (False, False, False)

    def __init__(self, spec, base):
        super().__init__(spec, base)
        self.ref = self._exo("reference")
        self.terms = [str(t) for t in spec.get("terms", ())]
        if not self.terms:
            raise ConfigError("residual_ode needs a non-empty list of terms")
        self.input = str(spec.get("input", self.exo[0]))
        if self.input not in self.exo:
            raise ConfigError(f"residual_ode input {self.input!r} is not one of {self.exo}")
        bad = [t for t in self.terms if t not in RESIDUAL_TERMS]
        if bad:
            raise ConfigError(f"residual_ode terms {bad} unknown; terms are {list(RESIDUAL_TERMS)}")
        self.params = [
            _param(
                f"c_{term_tag(t)}_{self.signal}",
                0.0,
                -1e9,
                1e9,
                "per s",
                f"coefficient of term {t!r} in de/dt of {self.signal}",
            )
            for t in self.terms
        ]

    def init(self, p, u0, y0):
        return np.column_stack([np.zeros(p.shape[0]), y0[:, self.col], np.zeros(p.shape[0])])

    def features(self, y, u, e, ref, t_h):
        """Term values (..., n_terms) for base output ``y``, input ``u``, residual ``e``."""
        d = y - ref
        table = {
            "1": lambda: np.ones_like(y),
            "e": lambda: e,
            "dT": lambda: d,
            "dT|dT|": lambda: d * np.abs(d) / 10.0,
            "dT^4/3": lambda: d * np.abs(d) ** (1.0 / 3.0),
            "u": lambda: u,
            "u^2": lambda: u * u,
            "u*dT": lambda: u * d,
            "t": lambda: t_h * np.ones_like(y),
        }
        return np.stack([table[t]() for t in self.terms], axis=-1)

    def apply(self, arr, u, p, s0, dt):
        B, T = arr.shape[0], arr.shape[1]
        ui = np.broadcast_to(u[:, :, self.exo.index(self.input)], (B, T))
        ub = np.broadcast_to(u, (B, *u.shape[1:]))
        ref = ub[:, :, self.ref] if self.ref is not None else np.repeat(s0[:, 1:2], T, axis=1)
        y = arr[:, :, self.col].copy()
        e = s0[:, 0].copy()
        t0 = s0[:, 2]
        for k in range(T):
            arr[:, k, self.col] += e
            if k + 1 < T:
                f = self.features(y[:, k], ui[:, k], e, ref[:, k], (t0 + k * dt) / 3600.0)
                # explicit Euler: e[k+1] = e[k] + Δt Σ c_m φ_m[k]
                e = e + dt * np.einsum("bm,bm->b", f, p)

    def now(self, v, u, p, s, dt):
        return v + s[:, 0]

    def advance(self, v, u, p, s, dt, v_next=None):
        ref = u[:, self.ref] if self.ref is not None else s[:, 1]
        f = self.features(v, u[:, self.exo.index(self.input)], s[:, 0], ref, s[:, 2] / 3600.0)
        out = s.copy()
        out[:, 0] = s[:, 0] + dt * np.einsum("bm,bm->b", f, p)
        out[:, 2] += dt
        return out


def term_tag(term: str) -> str:
    """Parameter-name tag of a residual-ODE term."""
    return {
        "1": "const",
        "e": "e",
        "dT": "dT",
        "dT|dT|": "dT2",
        "dT^4/3": "dT43",
        "u": "u",
        "u^2": "u2",
        "u*dT": "udT",
        "t": "t",
    }[term]


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


#: (effect, form) → class; form ``""`` is the effect's legacy (or only) form.
KINDS: dict[tuple[str, str], type[_Aug]] = {
    ("transport_delay", ""): _Delay,
    ("transport_delay", "input"): _Delay,
    ("transport_delay", "output"): _OutputDelay,
    ("unmeasured_disturbance", ""): _Disturbance,
    ("unmeasured_disturbance", "periodic"): _DisturbanceForm,
    ("unmeasured_disturbance", "steps"): _DisturbanceForm,
    ("unmeasured_disturbance", "smooth"): _DisturbanceForm,
    ("supply_variation", "steps"): _Supply,
    ("supply_variation", "smooth"): _Supply,
    ("supply_variation", ""): _Supply,
    ("input_nonlinearity", ""): _InputMap,
    ("input_nonlinearity", "power"): _InputMap,
    ("input_nonlinearity", "saturation"): _InputMap,
    ("input_nonlinearity", "limit"): _InputMap,
    ("input_nonlinearity", "dead_zone"): _InputMap,
    ("input_nonlinearity", "piecewise_linear"): _InputMap,
    ("backlash", ""): _OutputPlay,
    ("backlash", "output"): _OutputPlay,
    ("backlash", "input"): _InputPlay,
    ("missing_dynamics", ""): _ParallelPath,
    ("missing_dynamics", "parallel"): _ParallelPath,
    ("missing_dynamics", "input_lag"): _InputLag,
    ("missing_dynamics", "extra_node"): _ExtraNode,
    ("residual_ode", ""): _ResidualODE,
    ("input_dependent_heat_transfer", ""): _StaticForced,
    ("input_dependent_heat_transfer", "power"): _ForcedLoss,
    ("nonlinear_heat_transfer", ""): _Saturating,
    ("nonlinear_heat_transfer", "radiation"): _NonlinearLoss,
    ("nonlinear_heat_transfer", "convection"): _NonlinearLoss,
    ("time_varying_parameter", ""): _StaticDrift,
    ("time_varying_parameter", "ramp"): _VaryingLoss,
    ("time_varying_parameter", "step"): _VaryingLoss,
    ("time_varying_parameter", "random_walk"): _VaryingLoss,
    ("phase_change", ""): _Latent,
    ("phase_change", "latent_heat"): _Latent,
    ("sensor_lag", ""): _Lag,
    ("sensor_offset", ""): _Offset,
    ("sensor_drift", ""): _SensorDrift,
    ("sensor_drift", "wander"): _SensorWander,
}


def kind_of(spec: Mapping[str, Any]) -> type[_Aug]:
    """The augmentation class of a spec ``{"effect": ..., "form": ...}``.

    Raises
    ------
    ConfigError
        Unknown effect or form (the message lists what exists).
    """
    effect = str(spec.get("effect"))
    form = str(spec.get("form", ""))
    kind = KINDS.get((effect, form))
    if kind is None:
        forms = sorted({f for e, f in KINDS if e == effect and f})
        if not forms and (effect, "") not in KINDS:
            raise ConfigError(
                f"augmentation effect {effect!r}; augmentations are "
                f"{sorted({e for e, _ in KINDS})} (effects a plant includes itself go into "
                "base_config)"
            )
        raise ConfigError(f"{effect} form {form!r}; its forms are {forms}")
    return kind
