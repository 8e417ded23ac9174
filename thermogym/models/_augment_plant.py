"""Augmentations on the plant side: they transform the base model's output.

Static (Wiener) corrections of the rise and play on the output (legacy forms),
a parallel path with an extra state, and the residual ODE the diagnosis' sparse
regression writes (:data:`RESIDUAL_TERMS`, :func:`term_tag`). Indexed by
:mod:`~thermogym.models._augment_kinds`.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import lfilter

from thermogym.errors import ConfigError
from thermogym.models._augment_base import _Aug, _bounds, _lag_coeff, _number, _param
from thermogym.models._augment_input import _InputPlay

__all__ = ["RESIDUAL_TERMS", "term_tag"]

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
