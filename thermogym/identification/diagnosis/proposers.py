"""Hypothesis proposers: the candidates of each effect for one model and its data.

:meth:`.effects.Effect.propose` asks :func:`propose` for the candidates of an
effect of the catalogue: the effect in each physically allowed form, on every
signal it can act on (the most erring outputs first, at most two), as
augmentation specs around the model
(:class:`~thermogym.models.augmented.AugmentedModel`) or as the plant's own
equations with the effect switched on (``physical_effects``). Bounds and
neutral values are those of the parameter specifications (the augmentation's,
the plant's physical effect's); a proposer only scales the ranges to the data
(a dead time at most a quarter of a recording, an input's reference level),
draws starts inside them (scrambled Sobol', seeded) and quotes the residual
signature (:func:`.context.signatures`) as the candidate's evidence and prior.

Beside the catalogue: :func:`course_baseline` (a per-recording course on the
most erring output's reading, the baseline of a hypothesis whose course is
re-estimated on held-out recordings) and :func:`generic_fix` (an extra
first-order path from the inputs, a generic linear fix of a given size).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from thermogym.identification.diagnosis.context import Context
from thermogym.identification.diagnosis.events import Event, find_events, input_steps
from thermogym.identification.diagnosis.fit import sobol_starts
from thermogym.identification.diagnosis.hypothesis import Candidate
from thermogym.models.thermal_network import ThermalNetworkModel

__all__ = ["course_baseline", "generic_fix", "propose"]

#: Most outputs one effect is proposed on (the most erring first).
_MAX_TARGETS = 2
#: Random starts of the extra parameters besides the neutral values.
_N_STARTS = 3


# ------------------------------------------------------------------ helpers
def _starts(bounds: dict[str, tuple[float, float]], n: int = _N_STARTS, seed: int = 0):
    """Starts drawn inside the bounds (scrambled Sobol'): never a value a rig used."""
    names = list(bounds)
    if not names:
        return ()
    lo = np.array([bounds[p][0] for p in names])
    hi = np.array([bounds[p][1] for p in names])
    pts = sobol_starts(lo, hi, n, seed)
    return tuple({p: float(v) for p, v in zip(names, row, strict=True)} for row in pts)


def _fo(ctx: Context) -> dict[str, Any]:
    return ctx.features.get("outputs", {})


def _has_own(ctx: Context, prefix: str, signal: str) -> bool:
    """Whether the nominal model has its own parameter ``<prefix>_<signal>`` (a fitted offset)."""
    return any(p in ctx.model.param_names for p in (f"{prefix}_{signal}",))


def _targets(ctx: Context, temperature: bool = False) -> list[str]:
    outs = (
        ctx.temperature_outputs
        if temperature
        else sorted(ctx.outputs, key=lambda o: -ctx.share.get(o, 0.0))
    )
    return outs[:_MAX_TARGETS]


def _port(ctx: Context, output: str) -> tuple[str, float] | None:
    """Port of a loop term on ``output`` and the scale from kelvin to the port's unit.

    A loop term is a heat flow at the output's node, so it enters where the
    model's response is that node's own: the ambient (the surroundings'
    temperature) when a kelvin there moves the output by at least 0.2 K at
    steady state (a direct thermal path), else the manipulated input with the
    largest effect. The input instead of the ambient when it reaches this
    output's node before the others by more than twice the ambient's margin
    (:meth:`.Context.locality`: a heater in one zone of a house whose every
    zone the outdoor air reaches at once), or when the model's response to the
    ambient takes more than twice as long (a generic model whose ambient
    channel has a dead time or a lag of its own). Neither may act through a
    conductance an input sets (a coolant inlet behind a valve, the valve
    itself): a heat flow entered there would scale with that input.
    """
    port: tuple[str, float] | None = ctx.memo(("port", output), lambda: _choose_port(ctx, output))
    return port


def _choose_port(ctx: Context, output: str) -> tuple[str, float] | None:
    best = _heat_input(ctx, output)
    amb = _ambient_port(ctx, output)
    if amb is None:
        return best
    if best is None:
        return amb
    # several zones: the port that reaches this output's node first
    la, li = ctx.locality(amb[0], output), ctx.locality(best[0], output)
    if math.isfinite(li) and li > 2.0 * la:
        return best
    if ctx.response_time(amb[0], output) <= 2.0 * ctx.response_time(best[0], output):
        return amb
    return best


def _ambient_port(ctx: Context, output: str) -> tuple[str, float] | None:
    """The surroundings as a port, with 1/gain: a direct path (gain ≥ 0.2) behind no valve."""
    amb = ctx.ambient
    if amb is None or amb in {ctx.sets_conductance(i, output) for i in ctx.inputs}:
        return None
    g = ctx.port_gain(amb, output)
    return (amb, 1.0 / g) if math.isfinite(g) and g >= 0.2 else None


def _heat_input(ctx: Context, output: str) -> tuple[str, float] | None:
    """The manipulated input that moves ``output`` most and sets no conductance, with 1/gain."""
    best: tuple[str, float] | None = None
    for i in ctx.inputs:
        if ctx.sets_conductance(i, output) is not None:
            continue
        g = ctx.port_gain(i, output)
        if math.isfinite(g) and abs(g) > 1e-9:
            rel = abs(g) * ctx.u_ref(i)
            if best is None or rel > best[1]:
                best = (i, rel)
    if best is None:
        return None
    return best[0], 1.0 / ctx.port_gain(best[0], output)


def _loop_spec(ctx: Context, output: str, **spec: Any) -> dict[str, Any] | None:
    p = _port(ctx, output)
    if p is None:
        return None
    port, scale = p
    out = {"signal": output, "port": port, "scale": scale, **spec}
    if ctx.ambient is not None:
        out["reference"] = ctx.ambient
    return out


def _assumption(ctx: Context) -> str:
    return " (outputs without a unit taken as °C)" if ctx.assumed_celsius else ""


# ------------------------------------------------------------------ proposers
def _sensor_offset(ctx: Context) -> list[Candidate]:
    out = []
    fo = _fo(ctx)
    for o in _targets(ctx):
        if _has_own(ctx, "offset", o) or _has_own(ctx, "y0", o):
            continue  # the model fits its own offset
        sc = ctx.scale[o]
        f = fo.get(o, {})
        spec = {"effect": "sensor_offset", "signal": o, "bounds": {"offset": [-5 * sc, 5 * sc]}}
        out.append(
            Candidate(
                "sensor_offset",
                "constant",
                o,
                (spec,),
                starts=_starts({f"offset_{o}": (-2 * sc, 2 * sc)}, 2),
                evidence=f"mean residual of {o} = {f.get('offset_value', 0.0):.3g} "
                f"{ctx.units.get(o, '')}, {100 * f.get('offset', 0.0):.0f} % of its mean square",
                prior=f.get("offset", 0.0),
            )
        )
    return out


def _sensor_drift(ctx: Context) -> list[Candidate]:
    out = []
    fo = _fo(ctx)
    for o in _targets(ctx):
        sc = ctx.scale[o]
        hi = 10 * sc / max(ctx.duration / 3600.0, 1e-3)
        f = fo.get(o, {})
        spec = {"effect": "sensor_drift", "signal": o, "bounds": {"rate": [-hi, hi]}}
        out.append(
            Candidate(
                "sensor_drift",
                "linear from the logger's start",
                o,
                (spec,),
                starts=_starts({f"drift_{o}": (-0.2 * hi, 0.2 * hi)}, 2),
                evidence=f"residual of {o} grows by {f.get('drift_per_h', 0.0):.3g} "
                f"{ctx.units.get(o, '')}/h (R² = {f.get('drift', 0.0):.2f})",
                prior=f.get("drift", 0.0),
            )
        )
    return out


def _sensor_lag(ctx: Context) -> list[Candidate]:
    out = []
    fo = _fo(ctx)
    hi = 0.3 * ctx.duration
    for o in _targets(ctx):
        f = fo.get(o, {})
        spec = {"effect": "sensor_lag", "signal": o, "bounds": {"tau": [0.0, hi]}}
        guess = f.get("lag_tau", 0.0)
        starts = list(_starts({f"tau_lag_{o}": (ctx.dt_min, 0.1 * hi)}, 2))
        if 0 < guess < hi:
            starts.insert(0, {f"tau_lag_{o}": float(guess)})
        out.append(
            Candidate(
                "sensor_lag",
                "first-order lag",
                o,
                (spec,),
                starts=tuple(starts),
                evidence=f"residual of {o} ≈ −τ·dŷ/dt with R² = {f.get('lag', 0.0):.2f}, "
                f"τ ≈ {guess:.3g} s",
                prior=f.get("lag", 0.0),
            )
        )
    return out


def _transport_delay(ctx: Context) -> list[Candidate]:
    out: list[Candidate] = []
    fo = _fo(ctx)
    hi = 0.25 * ctx.duration
    if any(p.startswith("tau_") for p in ctx.model.param_names) and ctx.spec.name == "foptd":
        return out  # an FOPTD set fits its own dead times
    top = _targets(ctx)
    for name in ctx.exogenous:
        if not ctx.varies(name):
            continue
        peaks = [fo.get(o, {}).get("xcorr", {}).get(name, {}) for o in top]
        lag = max((p.get("peak_lag_s", 0.0) for p in peaks), default=0.0)
        height = max((p.get("height", 0.0) for p in peaks), default=0.0)
        starts = list(_starts({f"delay_{name}": (ctx.dt_min, 0.2 * hi)}, 2))
        if 0 < lag < hi:
            starts.insert(0, {f"delay_{name}": float(lag)})
        spec = {
            "effect": "transport_delay",
            "signal": name,
            "form": "input",
            "bounds": {"delay": [0.0, hi]},
        }
        out.append(
            Candidate(
                "transport_delay",
                "input dead time",
                name,
                (spec,),
                starts=tuple(starts),
                evidence=f"residual correlates with the changes of {name} {lag:.3g} s earlier "
                f"(|r| = {height:.2f})",
                prior=height,
            )
        )
    for o in top:
        f = fo.get(o, {})
        peaks = list(f.get("xcorr", {}).values())
        lag = max((p.get("peak_lag_s", 0.0) for p in peaks), default=0.0)
        height = max((p.get("height", 0.0) for p in peaks), default=0.0)
        starts = list(_starts({f"delay_out_{o}": (ctx.dt_min, 0.2 * hi)}, 2))
        if 0 < lag < hi:
            starts.insert(0, {f"delay_out_{o}": float(lag)})
        spec = {
            "effect": "transport_delay",
            "signal": o,
            "form": "output",
            "bounds": {"delay": [0.0, hi]},
        }
        out.append(
            Candidate(
                "transport_delay",
                "output dead time",
                o,
                (spec,),
                starts=tuple(starts),
                evidence=f"residual of {o} correlates with input changes {lag:.3g} s earlier "
                f"(|r| = {height:.2f})",
                prior=height,
            )
        )
    return out


def _manipulated(ctx: Context) -> list[str]:
    return [i for i in ctx.inputs if ctx.varies(i)]


def _input_nonlinearity(ctx: Context) -> list[Candidate]:
    out = []
    fo = _fo(ctx)
    level = max((f.get("level", 0.0) for f in fo.values()), default=0.0)
    for i in _manipulated(ctx):
        v = np.concatenate(ctx.column(i, True))
        v = v[np.isfinite(v)]
        if np.unique(np.round(v, 9)).size < 3:
            continue  # two levels cannot show the shape of a map
        ur = ctx.u_ref(i)
        lo_u, hi_u = float(np.min(v)), float(np.max(v))
        ev = f"residual depends on the level of {i} (η² up to {level:.2f})"
        u_max = max(abs(lo_u), abs(hi_u)) or ur
        forms: list[tuple[str, str, dict[str, Any], dict[str, tuple[float, float]]]] = [
            ("power", "power law", {}, {f"alpha_{i}": (0.5, 2.0)}),
            ("saturation", "saturation", {}, {f"sat_{i}": (0.2, 3.0)}),
            (
                "limit",
                "hard limit",
                {"u_max": u_max},
                {f"lim_{i}": (0.2 * u_max, 0.9 * u_max)},
            ),
            (
                "dead_zone",
                "dead zone",
                {"bounds": {"d": [0.0, 0.8 * ur]}},
                {f"dz_{i}": (0.05 * ur, 0.5 * ur)},
            ),
        ]
        knots = np.linspace(lo_u, hi_u, 5)
        if np.all(np.diff(knots) > 0):
            forms.append(
                (
                    "piecewise_linear",
                    "monotone piecewise-linear",
                    {"knots": knots.tolist()},
                    {f"pwl{k}_{i}": (0.3, 3.0) for k in range(1, 4)},
                )
            )
        across = _conductance_of(ctx, i)
        if across is not None:
            # ``i`` sets a conductance (a flow through a coil, a fan): its effect scales
            # with a temperature difference. A concave power law of it is a heat-transfer
            # coefficient growing less than in proportion with the flow (Dittus-Boelter,
            # UA ∝ ṁ^0.8; a coil's effectiveness falling as the flow rises), a physics
            # every coil has; a convex one is the actuator's characteristic (an
            # equal-percentage valve). The data cannot tell a concave valve
            # characteristic from the former without a flow measurement: the evidence
            # says so.
            forms[0] = (
                "power",
                "power law (convex)",
                {"bounds": {"alpha": [1.0, 3.0]}},
                {f"alpha_{i}": (1.05, 2.5)},
            )
            spec = {
                "effect": "input_nonlinearity",
                "signal": i,
                "form": "power",
                "u_ref": ur,
                "bounds": {"alpha": [0.2, 1.0]},
            }
            out.append(
                Candidate(
                    "input_dependent_heat_transfer",
                    f"conductance set by {i} ∝ {i}^α, α < 1 (across {across})",
                    i,
                    (spec,),
                    starts=_starts({f"alpha_{i}": (0.4, 0.95)}, 2),
                    evidence=ev
                    + f"; {i} acts across the {across} temperature difference (a concave "
                    f"characteristic of {i} itself gives the same model: measure the flow "
                    "to tell them apart)",
                    prior=level,
                )
            )
        for form, words, extra, box in forms:
            spec = {"effect": "input_nonlinearity", "signal": i, "form": form, "u_ref": ur, **extra}
            out.append(
                Candidate(
                    "input_nonlinearity",
                    words,
                    i,
                    (spec,),
                    starts=_starts(box, 2),
                    evidence=ev,
                    prior=level,
                )
            )
    return out


def _conductance_of(ctx: Context, name: str) -> str | None:
    """The temperature across which input ``name`` sets a conductance on the first target."""
    for o in _targets(ctx, temperature=True)[:1]:
        return ctx.sets_conductance(name, o)
    return None


def _backlash(ctx: Context) -> list[Candidate]:
    out = []
    fo = _fo(ctx)
    d = max((f.get("direction", 0.0) for f in fo.values()), default=0.0)
    for i in _manipulated(ctx):
        if ctx.reversals(i) < 4:
            continue
        v = np.concatenate(ctx.column(i, True))
        span = float(np.ptp(v))
        spec = {
            "effect": "backlash",
            "signal": i,
            "form": "input",
            "bounds": {"c": [0.0, 0.3 * span]},
        }
        out.append(
            Candidate(
                "backlash",
                "play on the input",
                i,
                (spec,),
                starts=_starts({f"backlash_{i}": (0.01 * span, 0.15 * span)}, 2),
                evidence=f"{i} reverses {ctx.reversals(i)} times; residual differs between "
                f"rising and falling (η² up to {d:.2f})",
                prior=d,
            )
        )
    for o in ctx.outputs:
        if ctx.units.get(o) != "mm" or _has_own(ctx, "backlash", o):
            continue
        sc = ctx.scale[o]
        spec = {"effect": "backlash", "signal": o, "bounds": {"c": [0.0, 2 * sc]}}
        out.append(
            Candidate(
                "backlash",
                "play on the output",
                o,
                (spec,),
                starts=_starts({f"backlash_{o}": (0.02 * sc, 0.4 * sc)}, 2),
                evidence=f"residual of {o} differs between opening and closing "
                f"(η² = {fo.get(o, {}).get('direction', 0.0):.2f})",
                prior=fo.get(o, {}).get("direction", 0.0),
            )
        )
    return out


def _supply_variation(ctx: Context) -> list[Candidate]:
    """A course multiplying an input's effect within each run.

    On a power input that is the supply (mains voltage, a source resistance);
    on an input that sets a conductance (:meth:`.Context.sets_conductance`: a
    valve on a coil) it is that conductance changing over time (fouling, an air
    lock, a pump losing head): named ``time_varying_parameter``.
    """
    out = []
    on = max((f.get("onoff", 0.0) for f in _fo(ctx).values()), default=0.0)
    for i in _manipulated(ctx):
        across = _conductance_of(ctx, i)
        forms = [("steps", "steps"), ("smooth", "smooth wander")]
        if across is not None:
            forms.append(("ramp", "ramp"))
        for form, words in forms:
            spec: dict[str, Any] = {"effect": "supply_variation", "signal": i, "form": form}
            if form != "ramp":
                spec.update(span=ctx.span, segments=6)
            if across is None:
                out.append(
                    Candidate(
                        "supply_variation",
                        words,
                        i,
                        (spec,),
                        evidence=f"residual changes with {i} on and off (η² up to {on:.2f}) "
                        "and over a run",
                        prior=0.5 * on,
                    )
                )
            else:
                out.append(
                    Candidate(
                        "time_varying_parameter",
                        f"conductance set by {i} (across {across}): "
                        + {"steps": "steps", "smooth": "smooth random walk"}.get(form, form),
                        i,
                        (spec,),
                        starts=_starts({f"sv_ramp_{i}": (-0.1, 0.1)}, 2) if form == "ramp" else (),
                        evidence=f"residual changes with {i} and over a run",
                        prior=0.5 * on,
                    )
                )
    return out


def _unmeasured_disturbance(ctx: Context) -> list[Candidate]:
    """The disturbance at the loop-term port, at the heat input and at the surroundings.

    The ambient's path reaches every node in fixed proportions (the outdoor air,
    the room around a plate); a heat flow into one zone (a party wall,
    occupants) enters where the heat input does.
    """
    o = _targets(ctx)[0]
    out: list[Candidate] = []
    seen: set[str] = set()
    for p in (_port(ctx, o), _heat_input(ctx, o), _ambient_port(ctx, o)):
        if p is not None and p[0] not in seen:
            seen.add(p[0])
            out += _disturbance_at(ctx, o, *p, events=not any(c.recorded for c in out))
    return out


def _disturbance_at(
    ctx: Context, o: str, port: str, scale: float, events: bool = True
) -> list[Candidate]:
    """Periodic, steps and smooth courses at ``port``, and ``events`` when asked.

    Events are read at the first port that reads any: their times are the
    residual's, and that port is where the loop terms enter.
    """
    feats = ctx.features
    amp = 10.0 * ctx.scale[o] * abs(scale)
    dur = ctx.duration
    dt = ctx.dt_min
    period = feats.get("period", math.nan)
    per_lo, per_hi = 8 * dt, 2 * dur
    out = []
    ev_p = (
        f"residual spectrum peaks at a period of {period / 3600:.3g} h "
        f"({feats.get('period_peak', 0.0):.1f}× its median)"
        if math.isfinite(period)
        else "no clear spectral peak"
    )
    p0 = float(np.clip(period if math.isfinite(period) else dur / 2, per_lo, per_hi))
    spec = {
        "effect": "unmeasured_disturbance",
        "signal": port,
        "form": "periodic",
        "period": p0,
        "bounds": {"amplitude": [-amp, amp], "period": [per_lo, per_hi]},
    }
    out.append(
        Candidate(
            "unmeasured_disturbance",
            "periodic",
            port,
            (spec,),
            starts=tuple(
                {f"dist_period_{port}": float(np.clip(f * p0, per_lo, per_hi))} for f in (0.5, 2.0)
            ),
            evidence=ev_p,
            prior=min(1.0, feats.get("period_peak", 0.0) / 50.0),
        )
    )
    for form, words in (("steps", "steps"), ("smooth", "smooth")):
        spec = {
            "effect": "unmeasured_disturbance",
            "signal": port,
            "form": form,
            "span": ctx.span,
            "segments": 6,
            "bounds": {"amplitude": [-amp, amp]},
        }
        out.append(
            Candidate(
                "unmeasured_disturbance",
                words,
                port,
                (spec,),
                evidence="autocorrelated residual unrelated to the inputs",
                prior=0.2,
            )
        )
    ev = _events_candidate(ctx, o, port, amp) if events else None
    if ev is not None:
        out.append(ev)
    return out


def _events_candidate(ctx: Context, o: str, port: str, amp: float) -> Candidate | None:
    """Disturbance events at ``port`` at the times the residual of ``o`` shows them.

    The times are read from every recording's residual (:mod:`.events`; the
    held-out recordings' too, as a course's knots are fitted there); the
    amplitudes of the negative and positive events are fitted per recording.
    None when the training residual shows no events or is not sparse.
    """
    j = list(ctx.outputs).index(o)
    t_half = ctx.response_time(port, o)
    # half-response within the step's own sample: no lag to undo (tau 0); never: an integrator
    tau = t_half / math.log(2.0) if math.isfinite(t_half) else math.inf
    gain = ctx.port_gain(port, o)
    flip = -1 if math.isfinite(gain) and gain < 0 else 1
    manip = [list(ctx.exogenous).index(i) for i in _manipulated(ctx)]
    found: list[list[Event]] = []
    for r, u, dt, tr in zip(ctx.residual, ctx.u, ctx.dt, ctx.is_train, strict=True):
        steps = input_steps(u[:, manip]) if manip else None
        ev = find_events(r[:, j], dt, tau, steps, noise=ctx.sigma.get(o, 0.0))
        if ev is None and tr:
            return None  # training that is not sparse: a course of time, not events
        found.append(ev or [])  # a held-out recording that is not sparse: none read there
    train = [ev for ev, tr in zip(found, ctx.is_train, strict=True) if tr]
    signs = "".join(
        c for c, s in (("-", -1), ("+", 1)) if any(e.sign * flip == s for ev in train for e in ev)
    )
    if not signs:
        return None
    # held-out events of a sign training never showed have no amplitude: not read
    found = [[e for e in ev if ("-" if e.sign * flip < 0 else "+") in signs] for ev in found]
    k_max = max(1, max(len(ev) for ev in found))
    recorded, n_read = [], []
    for ev, dt in zip(found, ctx.dt, strict=True):
        vals: dict[str, float] = {}
        for k in range(k_max):
            e = ev[k] if k < len(ev) else None
            # edges half a sample before the first and after the last sample on: the
            # course's clock (k·Δt, or summed Δt step by step) falls clear of them
            vals[f"dist_on{k}_{port}"] = max(e.start - 0.5, 0.0) * dt if e else 0.0
            vals[f"dist_off{k}_{port}"] = (e.stop - 0.5) * dt if e else 0.0
            vals[f"dist_sg{k}_{port}"] = float(e.sign * flip) if e else 0.0
        recorded.append(vals)
        n_read.append(2 * len(ev))
    spec = {
        "effect": "unmeasured_disturbance",
        "signal": port,
        "form": "events",
        "events": k_max,
        "signs": signs,
        "span": ctx.span,
        "bounds": {"amplitude": [-amp, amp]},
    }
    n_tr = sum(len(ev) for ev in train)
    return Candidate(
        "unmeasured_disturbance",
        "events",
        port,
        (spec,),
        evidence=f"{n_tr} sharp changes of {o}'s residual in the training recordings, "
        "none at a step of an input (on-periods read from the residual)",
        prior=0.4,
        recorded=tuple(recorded),
        n_recorded=tuple(n_read),
    )


def _nonlinear_heat_transfer(ctx: Context) -> list[Candidate]:
    out = []
    fo = _fo(ctx)
    for o in _targets(ctx, temperature=True):
        lo, hi = ctx.output_range(o)
        amb = ctx.ambient
        ref = float(np.nanmean(np.concatenate(ctx.column(amb)))) if amb else lo
        T_ref = 0.5 * (lo + hi) + (0.0 if ctx.units.get(o) == "K" else 273.15)
        dT_ref = max(abs(0.5 * (lo + hi) - ref), 1.0)
        band = fo.get(o, {}).get("band", 0.0)
        for form, words, extra in (
            ("radiation", "radiation (T⁴ in kelvin)", {"T_ref": T_ref}),
            ("convection", "natural convection (ΔT^1.25)", {"exponent": 1.25, "dT_ref": dT_ref}),
        ):
            spec = _loop_spec(ctx, o, effect="nonlinear_heat_transfer", form=form, **extra)
            if spec is None:
                continue
            tag = "rad" if form == "radiation" else "conv"
            out.append(
                Candidate(
                    "nonlinear_heat_transfer",
                    words + _assumption(ctx),
                    o,
                    (spec,),
                    starts=_starts({f"kappa_{tag}_{o}": (0.05, 1.0)}, 2),
                    evidence=f"residual of {o} depends on the temperature band (η² up to "
                    f"{band:.2f})",
                    prior=band,
                )
            )
    return out


def _input_dependent(ctx: Context) -> list[Candidate]:
    out = []
    fo = _fo(ctx)
    level = max((f.get("level", 0.0) for f in fo.values()), default=0.0)
    targets = _targets(ctx, temperature=True)[:1]
    for o in targets:
        refs: list[str | None] = [*ctx.temperature_inputs] or [None]
        for src in _manipulated(ctx):
            for ref in refs:
                spec = _loop_spec(
                    ctx,
                    o,
                    effect="input_dependent_heat_transfer",
                    form="power",
                    source=src,
                    u_ref=ctx.u_ref(src),
                )
                if spec is None:
                    continue
                if ref is None:
                    spec.pop("reference", None)
                else:
                    spec["reference"] = ref
                where = f"{o}–{ref}" if ref else o
                out.append(
                    Candidate(
                        "input_dependent_heat_transfer",
                        f"conductance ∝ {src}^m",
                        where,
                        (spec,),
                        starts=_starts({f"kappa_fc_{o}": (0.05, 1.0), f"m_fc_{o}": (0.4, 1.5)}, 2),
                        evidence=f"residual depends on the level of {src} (η² up to {level:.2f})",
                        prior=level,
                    )
                )
    return out


def _time_varying(ctx: Context) -> list[Candidate]:
    out = []
    fo = _fo(ctx)
    for o in _targets(ctx, temperature=True)[:1]:
        f = fo.get(o, {})
        drift = max(f.get("drift", 0.0), f.get("time", 0.0))
        for form, words, extra, box in (
            ("ramp", "ramp", {}, {f"tv_ramp_{o}": (-0.1, 0.1)}),
            ("step", "step", {"span": ctx.span}, {}),
            ("random_walk", "smooth random walk", {"span": ctx.span, "segments": 6}, {}),
        ):
            spec = _loop_spec(ctx, o, effect="time_varying_parameter", form=form, **extra)
            if spec is None:
                continue
            out.append(
                Candidate(
                    "time_varying_parameter",
                    f"loss conductance: {words}",
                    o,
                    (spec,),
                    starts=_starts(box, 2) if box else (),
                    evidence=f"the error of {o} changes within a run (R² of a trend "
                    f"{f.get('drift', 0.0):.2f})",
                    prior=drift,
                )
            )
    return out


def _missing_dynamics(ctx: Context) -> list[Candidate]:
    out = []
    fo = _fo(ctx)
    dur = ctx.duration
    dt = ctx.dt_min
    for o in _targets(ctx, temperature=True):
        spec = _loop_spec(
            ctx,
            o,
            effect="missing_dynamics",
            form="extra_node",
            bounds={"tau": [dt, 3 * dur]},
            tau=float(np.clip(dur / 10, dt, 3 * dur)),
        )
        if spec is None:
            continue
        out.append(
            Candidate(
                "missing_dynamics",
                "mass coupled to the node",
                o,
                (spec,),
                starts=_starts({f"xn_tau_{o}": (2 * dt, dur), f"xn_kappa_{o}": (0.1, 1.5)}, 3),
                evidence=f"autocorrelated residual of {o} without a more specific pattern",
                prior=0.3 * fo.get(o, {}).get("share", 0.0),
            )
        )
    for i in _manipulated(ctx):
        spec = {
            "effect": "missing_dynamics",
            "signal": i,
            "form": "input_lag",
            "bounds": {"tau": [0.0, dur]},
        }
        out.append(
            Candidate(
                "missing_dynamics",
                f"store between {i} and the plant",
                i,
                (spec,),
                starts=_starts({f"lag_in_{i}": (2 * dt, 0.2 * dur)}, 2),
                evidence=f"the response to {i} is slower than the model's",
                prior=0.2,
            )
        )
    out += _parallel_path(ctx)
    out += _network_node(ctx)
    return out


def _parallel_path(ctx: Context, n_params: int | None = None) -> list[Candidate]:
    """One extra state per erring output driven by the exogenous signals (a generic fix)."""
    dur, dt = ctx.duration, ctx.dt_min
    fo = _fo(ctx)
    o = _targets(ctx)[0]
    srcs = [c for c in ctx.exogenous if ctx.varies(c)] or [ctx.main_input]
    if n_params is not None:
        srcs = srcs[: max(1, n_params - 1)]
    spans = {c: max(float(np.ptp(np.concatenate(ctx.column(c)))), 1e-9) for c in srcs}
    bounds: dict[str, list[float]] = {"T": [dt, 3 * dur]}
    box: dict[str, tuple[float, float]] = {f"md_T_{o}": (2 * dt, dur)}
    for c in srcs:
        kmax = 10 * ctx.scale[o] / spans[c]
        bounds[f"gain_{c}"] = [-kmax, kmax]
        name = f"md_K_{o}" if len(srcs) == 1 else f"md_K_{o}__{c}"
        box[name] = (-0.3 * kmax, 0.3 * kmax)
    spec = {
        "effect": "missing_dynamics",
        "signal": o,
        "sources": srcs,
        "bounds": bounds,
        "T": float(np.clip(dur / 5, dt, 3 * dur)),
    }
    auto = max(((1.0 - f.get("lag", 0.0)) * f.get("share", 0.0) for f in fo.values()), default=0)
    return [
        Candidate(
            "missing_dynamics",
            "extra first-order path from the inputs",
            o,
            (spec,),
            starts=_starts(box, 3),
            evidence="autocorrelated residual without a more specific pattern (Annex 58: add a "
            "state)",
            prior=0.3 * auto,
        )
    ]


def _network_node(ctx: Context) -> list[Candidate]:
    """A heat capacity at a measured node of a linear RC network (fast exact simulation)."""
    m = ctx.model
    if not isinstance(m, ThermalNetworkModel) or m.effects:
        return []
    net = m.arrays(ctx.theta[None])
    out = []
    for o in ctx.temperature_outputs[:2]:
        row = net.H[list(m.output_names).index(o)]
        nz = np.flatnonzero(row)
        if not (nz.size == 1 and row[nz[0]] == 1.0):
            continue
        j = int(nz[0])
        node = m.nodes[j]
        c_node = float(net.C[0, j])
        g_node = float(net.G[0, j].sum() + net.g_amb[0, j])
        bounds = {
            "C": [0.1 * c_node, 200 * c_node],
            "G": [0.0, 20 * g_node],
            "g": [0.0, 5 * g_node],
        }
        spec = {"effect": "missing_dynamics", "node": node, "bounds": bounds}
        out.append(
            Candidate(
                "missing_dynamics",
                "heat capacity at a node",
                f"mass at {node}",
                (spec,),
                starts=_starts(
                    {f"Cx_{node}": (c_node, 50 * c_node), f"Gx_{node}": (0.1 * g_node, 2 * g_node)},
                    3,
                ),
                evidence=f"autocorrelated residual of {o}: a heat capacity the network lacks",
                prior=0.3 * ctx.share.get(o, 0.0),
            )
        )
    return out


#: Largest latent heat a phase-change candidate may have, in multiples of its node's
#: sensible heat over the recorded temperature range.
_LATENT_SHARE = 3.0


def _phase_change(ctx: Context) -> list[Candidate]:
    out = []
    fo = _fo(ctx)
    for o in _targets(ctx, temperature=True)[:1]:
        lo, hi = ctx.output_range(o)
        if hi - lo <= 2.0:
            continue
        band = fo.get(o, {}).get("band", 0.0)
        port = _port(ctx, o)
        if port is None:
            continue
        # The latent heat is κ seconds of the node's linear loss per kelvin, κ·G joules. The
        # node's sensible heat over the recorded range is C·(hi − lo) = τ·G·(hi − lo), with τ
        # the port's time constant (half-response time / ln 2; the shortest recording when
        # the response is slower). A latent heat up to three times that sensible heat: a
        # material that stores more than that would dominate the recording.
        t_half = ctx.response_time(port[0], o)
        tau = min(t_half / math.log(2.0), ctx.duration) if math.isfinite(t_half) else ctx.duration
        kmax = _LATENT_SHARE * max(tau, ctx.dt_min) * (hi - lo)
        spec = _loop_spec(
            ctx,
            o,
            effect="phase_change",
            form="latent_heat",
            T_melt=0.5 * (lo + hi),
            bounds={
                "T_melt": [lo, hi],
                "width": [0.3, max(0.5, 0.25 * (hi - lo))],
                "kappa": [0.0, kmax],
            },
        )
        if spec is None:
            continue
        out.append(
            Candidate(
                "phase_change",
                "latent heat (Gaussian melting range)",
                o,
                (spec,),
                # κ spans decades (a few grams of wax on a plate to a tank of PCM balls):
                # its starts are spread on a log scale, from 1e-4 to 0.3 of the bound
                starts=tuple(
                    {f"pc_kappa_{o}": math.exp(st["log_kappa"]), f"pc_T_{o}": st["T"]}
                    for st in _starts(
                        {"log_kappa": (math.log(1e-4 * kmax), math.log(0.3 * kmax)), "T": (lo, hi)},
                        8,
                    )
                ),
                evidence=f"residual of {o} concentrated in a temperature band (η² up to "
                f"{band:.2f})",
                prior=band,
            )
        )
    return out


def _internal(ctx: Context, effect: str) -> list[Candidate]:
    """The plant's own equations with ``effect`` switched on (bounds from its specification)."""
    m = ctx.model
    avail = getattr(m, "physical_effects", {}) or {}
    on = set(getattr(m, "effects", ()) or ())
    if effect not in avail or effect in on or not ctx.spec.registered:
        return []
    eff = avail[effect]
    box = {p.name: (p.lower, p.upper) for p in eff.parameters}
    fo = _fo(ctx)
    prior = max((f.get("level", 0.0) + f.get("band", 0.0) for f in fo.values()), default=0.0)
    return [
        Candidate(
            effect,
            "the plant's own equations",
            "plant",
            (),
            (effect,),
            starts=_starts(box, 4),
            evidence=eff.explanation[:160],
            prior=min(1.0, prior),
        )
    ]


_PROPOSERS = {
    "sensor_offset": _sensor_offset,
    "sensor_drift": _sensor_drift,
    "sensor_lag": _sensor_lag,
    "transport_delay": _transport_delay,
    "input_nonlinearity": _input_nonlinearity,
    "backlash": _backlash,
    "supply_variation": _supply_variation,
    "unmeasured_disturbance": _unmeasured_disturbance,
    "nonlinear_heat_transfer": _nonlinear_heat_transfer,
    "input_dependent_heat_transfer": _input_dependent,
    "time_varying_parameter": _time_varying,
    "missing_dynamics": _missing_dynamics,
    "phase_change": _phase_change,
}


def propose(ctx: Context, effect: str) -> list[Candidate]:
    """Candidates of ``effect`` for the nominal model and data of ``ctx``.

    Its augmentations around the model, then the plant's own equations with
    the effect switched on (where the plant has it and it is off).
    """
    fn = _PROPOSERS.get(effect)
    out = fn(ctx) if fn else []
    out += _internal(ctx, effect)
    return out


def course_baseline(ctx: Context, n_knots: int) -> Candidate:
    """A course of ``n_knots`` per recording added to the most erring output's reading.

    The baseline of a hypothesis whose course is re-estimated on every held-out
    recording: unshaped by the plant, it follows coloured sensor noise as well
    as any course can. Not a candidate of the catalogue.
    """
    o = max(ctx.outputs, key=lambda x: ctx.share.get(x, 0.0))
    amp = 20.0 * float(ctx.scale.get(o, 1.0))
    spec = {
        "effect": "sensor_drift",
        "signal": o,
        "form": "wander",
        "span": ctx.span,
        "segments": max(1, n_knots - 1),
        "bounds": {"amplitude": [-amp, amp]},
    }
    return Candidate(
        "sensor_drift",
        "wander of the reading (a generic course)",
        o,
        (spec,),
        evidence="baseline of a per-recording course",
    )


def generic_fix(ctx: Context, n_params: int) -> Candidate:
    """A generic linear fix with about ``n_params`` parameters (an extra state)."""
    return _parallel_path(ctx, max(2, n_params))[0]
