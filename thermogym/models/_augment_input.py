"""Augmentations on the input side: they transform an exogenous column before the base model.

Dead time, a periodic or per-recording disturbance added to a port, a modulated
supply, static input maps, play between a command and its effect, a lag (a
store between an input and the plant). Indexed by
:mod:`~thermogym.models._augment_kinds`.
"""

from __future__ import annotations

import numpy as np

from thermogym.errors import ConfigError, SimulationError
from thermogym.models._augment_base import (
    LOCAL,
    RECORDED,
    _AddsCourse,
    _Aug,
    _bounds,
    _course,
    _CourseMixin,
    _lag_coeff,
    _lowpass,
    _number,
    _param,
    _play,
)


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


class _DisturbanceForm(_AddsCourse, _Aug, _CourseMixin):
    """An unmeasured disturbance added to a port, per recording.

    ``periodic``, ``steps`` and ``smooth`` are courses of the recording's time;
    ``events`` are short on-periods at times read from the recording (a draw-off,
    a door left open, a crowd): ``d(t) = A_s`` while an event of sign ``s`` is
    on, else 0. The on and off times and the sign of each of ``events`` slots
    are :data:`RECORDED` parameters (a slot with off <= on is empty); the
    amplitudes of the negative and the positive events (``signs``: ``"-"``,
    ``"+"`` or ``"-+"``) are fitted in every recording.
    """

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
        elif self.form == "events":
            self.n_events = int(spec.get("events", 8))
            if not 1 <= self.n_events <= 64:
                raise ConfigError(
                    f"unmeasured_disturbance events is {self.n_events}; expected 1-64"
                )
            self.signs = str(spec.get("signs", "-+"))
            if (
                not self.signs
                or set(self.signs) - {"-", "+"}
                or len(set(self.signs)) < len(self.signs)
            ):
                raise ConfigError(
                    f"unmeasured_disturbance signs is {self.signs!r}; expected '-', '+' or '-+'"
                )
            span = _number(spec, "span", 86400.0, self.effect)
            self.params = [
                _param(f"dist_ev{w}_{sig}", 0.0, *a, unit, f"{w} events on {sig}", LOCAL)
                for s, w in (("-", "neg"), ("+", "pos"))
                if s in self.signs
            ]
            for k in range(self.n_events):
                self.params += [
                    _param(f"dist_on{k}_{sig}", 0.0, 0.0, span, "s", f"event {k} on", RECORDED),
                    _param(f"dist_off{k}_{sig}", 0.0, 0.0, span, "s", f"event {k} off", RECORDED),
                    _param(f"dist_sg{k}_{sig}", 0.0, -1.0, 1.0, "1", f"event {k} sign", RECORDED),
                ]
        else:
            raise ConfigError(
                f"unmeasured_disturbance form {self.form!r}; forms are periodic, steps, smooth, "
                "events"
            )

    def describe(self) -> str:
        if self.form == "events":
            return f"events: up to {self.n_events} on-periods per recording, read from the data"
        return super().describe()

    def course(self, p, t):
        return self._value(t, p)

    def _value(self, t, p):
        if self.form == "periodic":
            w = 2.0 * np.pi * t / p[:, 0:1]
            return p[:, 1:2] * np.sin(w) + p[:, 2:3] * np.cos(w)
        if self.form == "events":
            return self._events(t, p)
        return _course(p, t, self.span, self.smooth)

    def _events(self, t, p):
        present = [s for s in "-+" if s in self.signs]  # the amplitudes' order in p
        na = len(present)
        amp = {s: p[:, j : j + 1] for j, s in enumerate(present)}
        slots = p[:, na:]
        if p.shape[0] == 1 or (np.all(slots == slots[:1]) and np.all(t == t[:1])):
            # the usual case: the times are the recording's, the same in every set of the
            # batch (only the amplitudes vary): one indicator per sign over the samples
            t0, on_off = t[0], slots[0].reshape(-1, 3)
            out = np.zeros(np.broadcast_shapes(t.shape, (p.shape[0], 1)))
            for s, a in amp.items():
                ind = np.zeros(t0.shape)
                for on, off, sg in on_off:
                    if off > on and (sg < 0 if s == "-" else sg > 0):
                        ind[(t0 >= on) & (t0 < off)] = 1.0
                out = out + a * ind[None, :]
            return out
        out = np.zeros(np.broadcast_shapes(t.shape, (p.shape[0], 1)))
        for k in range(self.n_events):  # a slot at a time: (B, T) arrays, not (B, T, K)
            on, off, sg = (p[:, na + 3 * k + j, None] for j in range(3))
            inside = (t >= on) & (t < off)
            for s, a in amp.items():
                hit = inside & ((sg < 0) if s == "-" else (sg > 0))
                out = out + np.where(hit, a, 0.0)
        return out


class _Supply(_Aug, _CourseMixin):
    """The supply behind an input wanders: ``u → u (1 + s(t))``.

    ``steps`` and ``smooth``: a course per recording; ``ramp``: ``s(t) = r t``
    from each recording's start with one rate ``r`` [1/h] for all (the
    conductance a valve sets fouling at a steady pace).
    """

    effect = "supply_variation"
    state_suffixes = ("t",)
    x0_free = (False,)

    def __init__(self, spec, base):
        super().__init__(spec, base)
        self.form = str(spec.get("form", "steps"))
        if self.form not in ("steps", "smooth", "ramp"):
            raise ConfigError(f"supply_variation form {self.form!r}; forms are steps, smooth, ramp")
        if self.form == "ramp":
            lo, hi = _bounds(spec, "rate", (-0.5, 0.5))
            self.params = [
                _param(
                    f"sv_ramp_{self.signal}",
                    0.0,
                    lo,
                    hi,
                    "1/h",
                    f"relative change per hour of the supply behind {self.signal} since the "
                    "recording's start",
                )
            ]
            return
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
        return None if self.form == "ramp" else self._factor(p, t)

    def _factor(self, p, t):
        if self.form == "ramp":
            return p[:, 0:1] * t / 3600.0
        return _course(p, t, self.span, self.smooth)

    def apply(self, arr, u, p, s0, dt):
        t = s0[:, 0:1] + dt * np.arange(arr.shape[1])[None, :]
        arr[:, :, self.col] *= 1.0 + self._factor(p, t)

    def now(self, v, u, p, s, dt):
        return v * (1.0 + self._factor(p, s[:, 0:1])[:, 0])

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
