"""Augmentations on the loop side: heat-flow terms fed back from an output to a port.

Each adds a term to a *port* (the ambient temperature input, or the heat input)
computed from the base model's output: an extra conductance that grows with the
temperature difference, with an input, with time, a heat capacity coupled to
the output node, latent heat. The whole trajectory is found by waveform
relaxation (module :mod:`thermogym.models.augmented`); stepping feeds the term
back sample by sample. Indexed by :mod:`~thermogym.models._augment_kinds`.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from thermogym.errors import ConfigError
from thermogym.models._augment_base import (
    LOCAL,
    _Aug,
    _bounds,
    _course,
    _CourseMixin,
    _lag_coeff,
    _lowpass,
    _number,
    _param,
)

_ZERO_C = 273.15


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
