"""A plant model plus the physics diagnosis found missing: the ``augmented`` model.

Description
-----------
:class:`AugmentedModel` wraps any registered base model (a thermogym plant,
``foptd``, ``ss``, ...) and adds *augmentations*: effects of the vocabulary of
DESIGN.md written around the base model, each with a few parameters whose
neutral value switches it off. Effects a plant's own equations can include
(``phase_change`` of the AXT211, ``input_dependent_heat_transfer`` of the RC
networks, ...) are not wrapped: they are switched on in the base model through
``base_config = {"effects": [...]}``.

The augmentations act in three places, in this order::

    u  ──input side──►  base model  ──plant side──►  y_true  ──sensor side──►  y

==========================  ======  ========================================================
augmentation                side    equation (``k`` sample, ``Δt`` period, ``t = kΔt``)
==========================  ======  ========================================================
transport_delay             input   ``u_i(t) → u_i(t − τ)`` (linear interpolation)
unmeasured_disturbance      input   ``u_i += a sin(2πt/P) + b cos(2πt/P)``
input_nonlinearity          input   ``u_i → u_ref (|u_i|/u_ref)^α sign(u_i)``
residual_ode                plant   ``y_j += e``, ``de/dt = Σ c_m φ_m`` (sparse regression)
missing_dynamics            plant   ``y_j += z``, ``T dz/dt = Σ_s K_s (u_s − u_s(0)) − z``
input_dependent_heat_transfer plant ``Δ → Δ / (1 + β |u_s|/u_ref)``, ``Δ = y_j − r``
nonlinear_heat_transfer     plant   ``Δ → 2Δ / (1 + √(1 + 4γ|Δ|/ΔT_ref))``, ``Δ = y_j − r``
time_varying_parameter      plant   ``Δ → Δ (1 + δ t / 1 h)``, ``Δ = y_j − r``
backlash                    plant   ``y_j → play(y_j)`` of half-width ``c``
sensor_lag                  sensor  ``s[k+1] = a s[k] + (1 − a) y_j[k]``, ``a = e^{−Δt/τ}``
sensor_offset               sensor  ``y_j += b``
sensor_drift                sensor  ``y_j += r t / 1 h``
==========================  ======  ========================================================

``r`` is the reference of a heat-transfer deviation: the exogenous column
named by ``reference`` (e.g. the ambient temperature) or, without one, the
base output's value at the start. ``nonlinear_heat_transfer`` is the exact
steady-state inverse of a loss conductance growing linearly with the
temperature rise, ``g = g₀ (1 + γ |Δ| / ΔT_ref)`` (a static, Wiener-type
correction: exact at steady state, the base model keeps the dynamics).

Each augmentation is given as a dict ``{"effect": NAME, "signal": COLUMN,
...}``; its parameters are named ``<prefix>_<signal>`` (``tau_lag_T_nut``,
``delay_feed_rate``, ...) and appended to the base parameters.

Step-wise use (environments): :meth:`AugmentedModel.step` and
:meth:`AugmentedModel.output` carry the augmentations' states (lag values,
delay history, elapsed time) after the base states, so stepping reproduces
:meth:`AugmentedModel.simulate`. A ``transport_delay`` needs ``history``
samples of memory (set when the model is built by diagnosis).

The model is registered as ``augmented`` (see :func:`register`), so
``FitResult.build_model()`` rebuilds it from ``model_config``::

    {"base": "strut", "base_config": {}, "augmentations": [
        {"effect": "sensor_lag", "signal": "T_nut"}]}

Version History
---------------
* v1: initial release.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numba as nb
import numpy as np
from numpy.typing import NDArray
from scipy.signal import lfilter

from thermogym.errors import ConfigError, ParameterError, ShapeError, SimulationError
from thermogym.models.base import Model, Parameter

__all__ = ["AUGMENTATIONS", "RESIDUAL_TERMS", "AugmentedModel", "register"]

_PROV = "fitted by thermogym diagnosis; the neutral value switches the effect off"

#: Augmentation names in application order, with their side.
AUGMENTATIONS: dict[str, str] = {
    "transport_delay": "input",
    "unmeasured_disturbance": "input",
    "input_nonlinearity": "input",
    "residual_ode": "plant",
    "missing_dynamics": "plant",
    "input_dependent_heat_transfer": "plant",
    "nonlinear_heat_transfer": "plant",
    "time_varying_parameter": "plant",
    "backlash": "plant",
    "sensor_lag": "sensor",
    "sensor_offset": "sensor",
    "sensor_drift": "sensor",
}

#: Terms a ``residual_ode`` augmentation may use (see :mod:`.sindy`).
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
def _param(name: str, neutral: float, lo: float, hi: float, unit: str, what: str) -> Parameter:
    return Parameter(name, neutral, lo, hi, unit, what, _PROV, "augmentation")


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


def _positive(spec: Mapping[str, Any], key: str, default: float, effect: str) -> float:
    # a positive finite setting of an augmentation, with an error naming it
    v = spec.get(key, default)
    try:
        x = float(v)
    except (TypeError, ValueError):
        x = math.nan
    if not (math.isfinite(x) and x > 0):
        raise ConfigError(f"{effect} {key} is {v!r}; expected a number > 0")
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


class _Aug:
    """One augmentation: parameters, states, whole-trajectory and step-wise maps."""

    effect = ""
    state_suffixes: tuple[str, ...] = ()

    def __init__(self, spec: Mapping[str, Any], base: Model) -> None:
        self.spec = dict(spec)
        self.signal = str(spec.get("signal", ""))
        side = AUGMENTATIONS[self.effect]
        if self.effect == "unmeasured_disturbance" and self.signal in base.output_names:
            side = "plant"  # a disturbance seen only in an output (no exogenous column for it)
        self.side = side
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
        self.params: list[Parameter] = []

    @property
    def n_states(self) -> int:
        return len(self.state_suffixes)

    def state_names(self) -> list[str]:
        return [f"{self.effect}_{self.signal}_{s}" for s in self.state_suffixes]

    def _ref(self, u: NDArray[np.float64], fallback: NDArray[np.float64]) -> NDArray[np.float64]:
        ref = self.spec.get("reference")
        if ref:
            return u[..., self.exo.index(str(ref))]
        return fallback

    def check_reference(self) -> None:
        ref = self.spec.get("reference")
        if ref and ref not in self.exo:
            raise ConfigError(
                f"augmentation {self.effect!r}: reference {ref!r} is not an exogenous signal; "
                f"they are {self.exo}"
            )

    def start_at_output(
        self, p: NDArray[np.float64], u0: NDArray[np.float64], y0: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """:meth:`init` of an effect whose one state starts at its output's first value."""
        return y0[:, self.col : self.col + 1].copy()

    # whole trajectory: arr is u (input side) or y (plant/sensor side), (B, T, ·)
    def init(
        self, p: NDArray[np.float64], u0: NDArray[np.float64], y0: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        return np.zeros((p.shape[0], self.n_states))

    def apply(
        self,
        arr: NDArray[np.float64],
        u: NDArray[np.float64],
        p: NDArray[np.float64],
        s0: NDArray[np.float64],
        dt: float,
    ) -> None:
        raise NotImplementedError

    # step-wise: v is the current value (B,), returns the transformed value
    def now(
        self,
        v: NDArray[np.float64],
        u: NDArray[np.float64],
        p: NDArray[np.float64],
        s: NDArray[np.float64],
        dt: float,
    ) -> NDArray[np.float64]:
        raise NotImplementedError

    def advance(
        self,
        v: NDArray[np.float64],
        u: NDArray[np.float64],
        p: NDArray[np.float64],
        s: NDArray[np.float64],
        dt: float,
    ) -> NDArray[np.float64]:
        return s


class _Delay(_Aug):
    effect = "transport_delay"

    def __init__(self, spec, base):
        super().__init__(spec, base)
        hi = _bounds(spec, "delay", (0.0, 3600.0))
        self.history = int(spec.get("history", 0))
        if self.history < 0:
            raise ConfigError(f"transport_delay history is {self.history}; expected >= 0")
        self.params = [
            _param(
                f"delay_{self.signal}",
                0.0,
                max(0.0, hi[0]),
                hi[1],
                "s",
                f"transport delay of {self.signal}",
            )
        ]
        self.state_suffixes = tuple(f"lag{h + 1}" for h in range(self.history))

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
        """Raise when stepping needs more input history than the model keeps."""
        d = p[:, 0] / dt
        if np.any(d > self.history):
            raise SimulationError(
                f"transport_delay of {self.signal!r} is {float(p[:, 0].max())!r} s = "
                f"{float(d.max()):.2f} samples but the model keeps history = {self.history} "
                "samples; rebuild it with a longer history to step it"
            )

    def advance(self, v, u, p, s, dt):
        if not self.history:
            return s
        return np.concatenate([v[:, None], s[:, :-1]], axis=1)


class _Disturbance(_Aug):
    effect = "unmeasured_disturbance"
    state_suffixes = ("t",)

    def __init__(self, spec, base):
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

    def init(self, p, u0, y0):
        return np.zeros((p.shape[0], 1))

    def apply(self, arr, u, p, s0, dt):
        t = s0[:, 0:1] + dt * np.arange(arr.shape[1])[None, :]
        arr[:, :, self.col] += self._wave(t, p)

    def now(self, v, u, p, s, dt):
        return v + self._wave(s[:, 0:1], p)[:, 0]

    def advance(self, v, u, p, s, dt):
        return s + dt


class _InputPower(_Aug):
    effect = "input_nonlinearity"

    def __init__(self, spec, base):
        super().__init__(spec, base)
        self.u_ref = _positive(spec, "u_ref", 1.0, self.effect)
        lo, hi = _bounds(spec, "alpha", (0.2, 3.0))
        self.params = [
            _param(
                f"alpha_{self.signal}",
                1.0,
                lo,
                hi,
                "1",
                f"exponent of the effect of {self.signal}, u_ref (u/u_ref)^α",
            )
        ]

    def _map(self, x, a):
        return np.sign(x) * self.u_ref * (np.abs(x) / self.u_ref) ** a

    def apply(self, arr, u, p, s0, dt):
        arr[:, :, self.col] = self._map(arr[:, :, self.col], p[:, 0:1])

    def now(self, v, u, p, s, dt):
        return self._map(v, p[:, 0])


class _ParallelPath(_Aug):
    effect = "missing_dynamics"

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
            # (transposed direct form: zi is z[0] itself)
            z, _ = lfilter([0.0, 1.0 - a[b]], [1.0, -a[b]], x, zi=[s0[b, 0]])
            arr[b, :, self.col] += z

    def now(self, v, u, p, s, dt):
        return v + s[:, 0]

    def advance(self, v, u, p, s, dt):
        a = _lag_coeff(p[:, 0], dt)
        drive = np.zeros(s.shape[0])
        for j, i in enumerate(self.srcs):
            drive += p[:, 1 + j] * (u[:, i] - s[:, 1 + j])
        out = s.copy()
        out[:, 0] = a * s[:, 0] + (1.0 - a) * drive
        return out


class _Saturating(_Aug):
    effect = "nonlinear_heat_transfer"
    state_suffixes = ("ref",)

    def __init__(self, spec, base):
        super().__init__(spec, base)
        self.check_reference()
        self.dT_ref = _positive(spec, "dT_ref", 10.0, self.effect)
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

    init = _Aug.start_at_output

    def _map(self, d, g):
        # inverse of Δ_lin = Δ (1 + γ|Δ|/ΔT_ref): Δ = 2Δ_lin / (1 + sqrt(1 + 4γ|Δ_lin|/ΔT_ref))
        root = np.sqrt(np.maximum(1.0 + 4.0 * g * np.abs(d) / self.dT_ref, 1e-6))
        return 2.0 * d / (1.0 + root)

    def apply(self, arr, u, p, s0, dt):
        ref = self._ref(u, s0[:, 0:1])
        y = arr[:, :, self.col]
        arr[:, :, self.col] = ref + self._map(y - ref, p[:, 0:1])

    def now(self, v, u, p, s, dt):
        ref = self._ref(u, s[:, 0])
        return ref + self._map(v - ref, p[:, 0])


class _ForcedLoss(_Aug):
    effect = "input_dependent_heat_transfer"
    state_suffixes = ("ref",)

    def __init__(self, spec, base):
        super().__init__(spec, base)
        self.check_reference()
        src = str(spec.get("source", self.exo[0]))
        if src not in self.exo:
            raise ConfigError(
                f"input_dependent_heat_transfer source {src!r} is not an exogenous signal; "
                f"they are {self.exo}"
            )
        self.src = self.exo.index(src)
        self.u_ref = _positive(spec, "u_ref", 1.0, self.effect)
        lo, hi = _bounds(spec, "beta", (-0.5, 5.0))
        self.params = [
            _param(
                f"beta_{self.tag}",
                0.0,
                lo,
                hi,
                "1",
                f"growth of the loss conductance with {src} per u_ref = {self.u_ref:g}",
            )
        ]

    init = _Aug.start_at_output

    def _factor(self, u, p):
        return np.maximum(1.0 + p * np.abs(u) / self.u_ref, 1e-3)

    def apply(self, arr, u, p, s0, dt):
        # steady state of a loss conductance g₀ (1 + β u/u_ref): the rise divides by the factor
        ref = self._ref(u, s0[:, 0:1])
        y = arr[:, :, self.col]
        arr[:, :, self.col] = ref + (y - ref) / self._factor(u[:, :, self.src], p[:, 0:1])

    def now(self, v, u, p, s, dt):
        ref = self._ref(u, s[:, 0])
        return ref + (v - ref) / self._factor(u[:, self.src], p[:, 0])


class _Drifting(_Aug):
    effect = "time_varying_parameter"
    state_suffixes = ("ref", "t")

    def __init__(self, spec, base):
        super().__init__(spec, base)
        self.check_reference()
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

    def apply(self, arr, u, p, s0, dt):
        t = s0[:, 1:2] + dt * np.arange(arr.shape[1])[None, :]
        ref = self._ref(u, s0[:, 0:1])
        y = arr[:, :, self.col]
        arr[:, :, self.col] = ref + (y - ref) * (1.0 + p[:, 0:1] * t / 3600.0)

    def now(self, v, u, p, s, dt):
        ref = self._ref(u, s[:, 0])
        return ref + (v - ref) * (1.0 + p[:, 0] * s[:, 1] / 3600.0)

    def advance(self, v, u, p, s, dt):
        out = s.copy()
        out[:, 1] += dt
        return out


class _Play(_Aug):
    effect = "backlash"
    state_suffixes = ("prev",)

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

    def apply(self, arr, u, p, s0, dt):
        y = np.ascontiguousarray(arr[:, :, self.col])
        _play(y, np.ascontiguousarray(np.maximum(p[:, 0], 0.0)), np.ascontiguousarray(s0[:, 0]))
        arr[:, :, self.col] = y

    def _step_play(self, v, p, prev):
        c = np.maximum(p[:, 0], 0.0)
        return np.where(v > prev + c, v - c, np.where(v < prev - c, v + c, prev))

    def now(self, v, u, p, s, dt):
        return self._step_play(v, p, s[:, 0])

    def advance(self, v, u, p, s, dt):
        return self._step_play(v, p, s[:, 0])[:, None]


class _ResidualODE(_Aug):
    effect = "residual_ode"
    state_suffixes = ("e", "ref", "t")

    def __init__(self, spec, base):
        super().__init__(spec, base)
        self.check_reference()
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
                f"c_{_term_tag(t)}_{self.signal}",
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
        out = []
        for term in self.terms:
            out.append(
                {
                    "1": lambda: np.ones_like(y),
                    "e": lambda: e,
                    "dT": lambda: d,
                    "dT|dT|": lambda: d * np.abs(d) / 10.0,
                    "dT^4/3": lambda: d * np.abs(d) ** (1.0 / 3.0),
                    "u": lambda: u,
                    "u^2": lambda: u * u,
                    "u*dT": lambda: u * d,
                    "t": lambda: t_h * np.ones_like(y),
                }[term]()
            )
        return np.stack(out, axis=-1)

    def apply(self, arr, u, p, s0, dt):
        B, T = arr.shape[0], arr.shape[1]
        ui = np.broadcast_to(u[:, :, self.exo.index(self.input)], (B, T))
        ref = self._ref(np.broadcast_to(u, (B, *u.shape[1:])), s0[:, 1:2])
        y = arr[:, :, self.col].copy()
        e = s0[:, 0].copy()
        t0 = s0[:, 2]
        for k in range(T):
            arr[:, k, self.col] += e
            if k + 1 < T:
                th = (t0 + k * dt) / 3600.0
                r = ref[:, k] if np.ndim(ref) == 2 and ref.shape[1] == T else ref[:, 0]
                f = self.features(y[:, k], ui[:, k], e, r, th)
                # explicit Euler: e[k+1] = e[k] + Δt Σ c_m φ_m[k]
                e = e + dt * np.einsum("bm,bm->b", f, p)

    def now(self, v, u, p, s, dt):
        return v + s[:, 0]

    def advance(self, v, u, p, s, dt):
        ref = self._ref(u, s[:, 1])
        f = self.features(v, u[:, self.exo.index(self.input)], s[:, 0], ref, s[:, 2] / 3600.0)
        out = s.copy()
        out[:, 0] = s[:, 0] + dt * np.einsum("bm,bm->b", f, p)
        out[:, 2] += dt
        return out


def _term_tag(term: str) -> str:
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


class _Lag(_Aug):
    effect = "sensor_lag"
    state_suffixes = ("s",)

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

    init = _Aug.start_at_output

    def apply(self, arr, u, p, s0, dt):
        a = _lag_coeff(p[:, 0], dt)
        for b in range(arr.shape[0]):
            if a[b] == 0.0:
                continue
            x = arr[b, :, self.col]
            # s[k+1] = a s[k] + (1 − a) y[k], s[0] = s0: the exact lag of a held signal
            s, _ = lfilter([0.0, 1.0 - a[b]], [1.0, -a[b]], x, zi=[s0[b, 0]])
            arr[b, :, self.col] = s

    def now(self, v, u, p, s, dt):
        return np.where(p[:, 0] > 0, s[:, 0], v)

    def advance(self, v, u, p, s, dt):
        a = _lag_coeff(p[:, 0], dt)
        return (a * s[:, 0] + (1.0 - a) * v)[:, None]


class _Offset(_Aug):
    effect = "sensor_offset"

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


class _SensorDrift(_Aug):
    effect = "sensor_drift"
    state_suffixes = ("t",)

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

    def init(self, p, u0, y0):
        return np.zeros((p.shape[0], 1))

    def apply(self, arr, u, p, s0, dt):
        t = s0[:, 0:1] + dt * np.arange(arr.shape[1])[None, :]
        arr[:, :, self.col] += p[:, 0:1] * t / 3600.0

    def now(self, v, u, p, s, dt):
        return v + p[:, 0] * s[:, 0] / 3600.0

    def advance(self, v, u, p, s, dt):
        return s + dt


_KINDS: dict[str, type[_Aug]] = {
    c.effect: c
    for c in (
        _Delay,
        _Disturbance,
        _InputPower,
        _ResidualODE,
        _ParallelPath,
        _ForcedLoss,
        _Saturating,
        _Drifting,
        _Play,
        _Lag,
        _Offset,
        _SensorDrift,
    )
}


class AugmentedModel(Model):
    """A base model with effects the diagnosis added around it.

    Parameters
    ----------
    base : str or Model
        Registered name of the base model, or a model instance (a user's own
        :class:`~thermogym.models.base.Model`; its FitResult then names the
        instance's ``name`` and ``config()``, which rebuild it only where that
        model is registered).
    base_config : dict, optional
        Constructor arguments of a base model given by name (e.g. its ``effects``).
    augmentations : sequence of dict
        ``{"effect": NAME, "signal": COLUMN, ...}`` for each added effect (see
        the module docstring); optional keys: ``sources`` (missing_dynamics),
        ``u_ref`` (input_nonlinearity), ``dT_ref`` and ``reference``
        (heat-transfer deviations), ``history`` (transport_delay, samples),
        ``terms`` and ``input`` (residual_ode), ``bounds`` ({suffix: [lo, hi]}).

    Raises
    ------
    ConfigError
        Unknown augmentation, signal, option, or a parameter name that clashes
        with the base model's.

    Examples
    --------
    >>> import numpy as np
    >>> from thermogym.models.augmented import AugmentedModel
    >>> m = AugmentedModel("foptd", {"inputs": ["u"], "outputs": ["y"], "T": 100.0},
    ...                    [{"effect": "sensor_offset", "signal": "y"}])
    >>> m.param_names
    ('K_y', 'T_y', 'tau_y', 'offset_y')
    >>> sim = m.simulate(np.ones((50, 1)), 1.0, {"offset_y": 2.0})
    >>> float(sim.output("y")[0, 0])
    2.0
    """

    name = "augmented"
    version = "1"

    def __init__(
        self,
        base: str | Model,
        base_config: Mapping[str, Any] | None = None,
        augmentations: Sequence[Mapping[str, Any]] = (),
    ) -> None:
        from thermogym.models.registry import get_model

        if isinstance(base, Model):
            if isinstance(base, AugmentedModel):
                raise ConfigError("an augmented model cannot wrap another augmented model")
            if base_config:
                raise ConfigError(
                    "base_config is given with a model instance; configure the instance itself"
                )
            self._base_name = base.name
            self._base_config = dict(base.config())
            self.base = base
        else:
            if base == self.name:
                raise ConfigError("an augmented model cannot wrap another augmented model")
            self._base_name = str(base)
            self._base_config = dict(base_config or {})
            self.base = get_model(self._base_name, **self._base_config)
        self.max_step = self.base.max_step
        augmentations = list(augmentations)
        # missing dynamics of an RC network as an extra heat capacity at a node (fastnet)
        nodal = [s for s in augmentations if isinstance(s, Mapping) and s.get("node")]
        if len(nodal) > 1:
            raise ConfigError("at most one extra node (missing_dynamics with 'node') per model")
        if nodal:
            from thermogym.models.fastnet import ExtraNodeNetwork

            spec = nodal[0]
            if spec.get("effect") != "missing_dynamics":
                raise ConfigError(f"'node' belongs to missing_dynamics, not {spec.get('effect')!r}")
            self.base = ExtraNodeNetwork(self.base, str(spec["node"]), spec.get("bounds"))
            augmentations = [s for s in augmentations if s is not spec]
        self._nodal = [dict(s) for s in nodal]
        augs: list[_Aug] = []
        for i, spec in enumerate(augmentations):
            if not isinstance(spec, Mapping) or "effect" not in spec:
                raise ConfigError(
                    f"augmentation {i} is {spec!r:.80}; expected a dict with 'effect'"
                )
            kind = _KINDS.get(str(spec["effect"]))
            if kind is None:
                raise ConfigError(
                    f"augmentation {i} has effect {spec['effect']!r}; augmentations are "
                    f"{list(_KINDS)} (effects a plant includes itself go into base_config)"
                )
            augs.append(kind(spec, self.base))
        order = list(AUGMENTATIONS)
        sides = ("input", "plant", "sensor")
        self._augs = sorted(augs, key=lambda a: (sides.index(a.side), order.index(a.effect)))
        self._specs = [dict(a.spec) for a in self._augs]
        params = list(self.base.parameters)
        index = {p.name: i for i, p in enumerate(params)}
        owner: dict[str, str] = {}
        self._nb = len(self.base.parameters)
        self._nx = len(self.base.state_names)
        states = list(self.base.state_names)
        self._slices: list[tuple[NDArray[np.int64], slice]] = []
        j = self._nx
        for a in self._augs:
            cols = []
            for prm in a.params:
                if prm.name in index:
                    # a shared parameter: only the same effect with a 'share' tag uses a name twice
                    if owner.get(prm.name) != a.effect or not a.spec.get("share"):
                        raise ConfigError(
                            f"augmentation parameter {prm.name!r} clashes with the base model's "
                            "or appears twice (each effect once per signal, or one 'share' tag)"
                        )
                else:
                    index[prm.name] = len(params)
                    owner[prm.name] = a.effect
                    params.append(prm)
                cols.append(index[prm.name])
            self._slices.append((np.array(cols, dtype=np.int64), slice(j, j + a.n_states)))
            j += a.n_states
            states.extend(a.state_names())
        super().__init__(self.base.signals, params, states)

    # ----------------------------------------------------------------- metadata
    @property
    def augmentations(self) -> list[dict[str, Any]]:
        """The augmentation specs, in application order (an extra node first)."""
        return [*(dict(s) for s in self._nodal), *(dict(s) for s in self._specs)]

    @property
    def effects(self) -> tuple[str, ...]:
        """Effects this model adds, wrapped ones first, then the base model's own."""
        own = tuple(getattr(self.base, "effects", ()))
        nodal = ["missing_dynamics"] if self._nodal else []
        return tuple(dict.fromkeys(nodal + [a.effect for a in self._augs] + list(own)))

    def config(self) -> dict[str, Any]:
        """Constructor arguments (stored in FitResults)."""
        return {
            "base": self._base_name,
            "base_config": dict(self._base_config),
            "augmentations": self.augmentations,
        }

    def _validate_theta(self, theta: NDArray[np.float64]) -> None:
        self.base._validate_theta(np.ascontiguousarray(theta[:, : self._nb]))
        for a, (ps, _) in zip(self._augs, self._slices, strict=True):
            for j, prm in enumerate(a.params):
                col = theta[:, ps][:, j]
                if prm.lower >= 0 and (col < 0).any():
                    raise ParameterError(
                        f"parameter {prm.name!r} is {float(col.min())!r}; it must be >= 0"
                    )
                if prm.unit == "s" and prm.lower > 0 and (col <= 0).any():
                    raise ParameterError(
                        f"parameter {prm.name!r} is {float(col.min())!r} s; it must be positive"
                    )

    # ------------------------------------------------------------------ numerics
    def _input_now(self, x, u, theta, dt):
        ue = np.array(u, dtype=float, copy=True)
        for a, (ps, ss) in zip(self._augs, self._slices, strict=True):
            if a.side == "input":
                ue[:, a.col] = a.now(ue[:, a.col], u, theta[:, ps], x[:, ss], dt)
        return ue

    def augment_state(
        self,
        x_base: NDArray[np.float64],
        theta: NDArray[np.float64],
        u0: NDArray[np.float64],
    ) -> NDArray[np.float64]:
        """Full initial state from a base state: the augmentations start at rest.

        Parameters
        ----------
        x_base : ndarray, shape (B, n_base_states)
        theta : ndarray, shape (B, P)
        u0 : ndarray, shape (B, n_u)
            Exogenous signals at the first sample.

        Returns
        -------
        ndarray, shape (B, n_states)
        """
        th = np.atleast_2d(theta)
        xb = np.atleast_2d(np.asarray(x_base, dtype=float))
        u0 = np.atleast_2d(np.asarray(u0, dtype=float))
        B = max(th.shape[0], xb.shape[0], u0.shape[0])
        th, xb, u0 = (np.broadcast_to(a, (B, *a.shape[1:])) for a in (th, xb, u0))
        x = np.zeros((B, len(self.state_names)))
        x[:, : self._nx] = xb
        # input-side states first (delay history holds u0), then the base output at rest
        for a, (ps, ss) in zip(self._augs, self._slices, strict=True):
            if a.side == "input":
                x[:, ss] = a.init(th[:, ps], u0, np.zeros((B, 0)))
        ue = self._input_now(x, u0, th, None)
        y = self.base._output(np.ascontiguousarray(xb), ue, np.ascontiguousarray(th[:, : self._nb]))
        for a, (ps, ss) in zip(self._augs, self._slices, strict=True):
            if a.side != "input":
                x[:, ss] = a.init(th[:, ps], u0, y)
                y = y.copy()
                y[:, a.col] = a.now(y[:, a.col], u0, th[:, ps], x[:, ss], 1.0)
        return x

    def initial_state(
        self, theta: NDArray[np.float64], u0: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """The base model's initial state with the augmentations at rest."""
        th = np.atleast_2d(theta)
        xb = self.base.initial_state(np.ascontiguousarray(th[:, : self._nb]), np.atleast_2d(u0))
        return self.augment_state(xb, th, u0)

    def _simulate(self, theta, u, dt, x0, return_states):
        B, T = theta.shape[0], u.shape[1]
        tb = np.ascontiguousarray(theta[:, : self._nb])
        entering: list[NDArray[np.float64] | None] = [None] * len(self._augs)
        ue = u
        if any(a.side == "input" for a in self._augs):
            ue = np.array(np.broadcast_to(u, (B, *u.shape[1:])), dtype=float, copy=True)
            for i, (a, (ps, ss)) in enumerate(zip(self._augs, self._slices, strict=True)):
                if a.side == "input":
                    if return_states:
                        entering[i] = ue[:, :, a.col].copy()
                    a.apply(ue, u, theta[:, ps], x0[:, ss], dt)
            self.base._exog_batch(ue)  # the transformed inputs must stay finite
        y, xs = self.base._simulate(
            tb, ue, dt, np.ascontiguousarray(x0[:, : self._nx]), return_states
        )
        y = np.array(y, dtype=float, copy=True)
        uu = np.asarray(u)
        for i, (a, (ps, ss)) in enumerate(zip(self._augs, self._slices, strict=True)):
            if a.side != "input":
                if return_states:
                    entering[i] = y[:, :, a.col].copy()
                a.apply(y, uu, theta[:, ps], x0[:, ss], dt)
        if not return_states:
            return y, None
        # augmentation states along the trajectory, stepped from the values entering them
        full = np.empty((B, T, len(self.state_names)))
        full[:, :, : self._nx] = xs
        x = np.array(x0, dtype=float, copy=True)
        ub = np.broadcast_to(uu, (B, *uu.shape[1:]))
        for k in range(T):
            full[:, k, self._nx :] = x[:, self._nx :]
            for i, (a, (ps, ss)) in enumerate(zip(self._augs, self._slices, strict=True)):
                x[:, ss] = a.advance(entering[i][:, k], ub[:, k], theta[:, ps], x[:, ss], dt)
        return y, full

    def _step(self, x, u, theta, dt):
        th, x, u = (
            np.ascontiguousarray(
                np.broadcast_to(a, (max(len(theta), len(x), len(u)), *a.shape[1:]))
            )
            for a in (theta, x, u)
        )
        if x.shape[1] != len(self.state_names):
            raise ShapeError(f"x has shape {x.shape}, expected (B, {len(self.state_names)})")
        for a, (ps, _) in zip(self._augs, self._slices, strict=True):
            if isinstance(a, _Delay):
                a.check(th[:, ps], dt)
        ue = self._input_now(x, u, th, dt)
        xb = x[:, : self._nx]
        tb = th[:, : self._nb]
        y = self.base._output(xb, ue, tb)
        xn = x.copy()
        xn[:, : self._nx] = self.base._step(xb, ue, tb, dt)
        for a, (ps, ss) in zip(self._augs, self._slices, strict=True):
            side = a.side
            if side == "input":
                xn[:, ss] = a.advance(u[:, a.col], u, th[:, ps], x[:, ss], dt)
                continue
            v = y[:, a.col]
            y = y.copy()
            y[:, a.col] = a.now(v, u, th[:, ps], x[:, ss], dt)
            # the state moves with the value entering the augmentation
            xn[:, ss] = a.advance(v, u, th[:, ps], x[:, ss], dt)
        return xn

    def _output(self, x, u, theta):
        th, x, u = (
            np.ascontiguousarray(
                np.broadcast_to(a, (max(len(theta), len(x), len(u)), *a.shape[1:]))
            )
            for a in (theta, x, u)
        )
        ue = self._input_now(x, u, th, 1.0)
        y = np.array(self.base._output(x[:, : self._nx], ue, th[:, : self._nb]), copy=True)
        for a, (ps, ss) in zip(self._augs, self._slices, strict=True):
            if a.side != "input":
                y[:, a.col] = a.now(y[:, a.col], u, th[:, ps], x[:, ss], 1.0)
        return y


def register() -> None:
    """Register :class:`AugmentedModel` as ``augmented`` in the model registry.

    The registry registers it with the built-in models; this function is kept
    for code that registers explicitly (idempotent).
    """
    from thermogym.models.registry import model_names, register_model

    if "augmented" not in model_names():  # model_names() loads the built-in models first
        register_model("augmented", AugmentedModel)


#: Read by :mod:`thermogym.models.registry` with the other built-in models.
MODELS: dict[str, type[Model]] = {"augmented": AugmentedModel}
