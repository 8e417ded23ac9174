"""The effect catalogue: what a model may have left out, how to see it, how to add it.

Each effect of the vocabulary of DESIGN.md is an :class:`EffectEntry`:

* a **plain-language physical explanation** shown in reports;
* a **residual signature**: the pattern the nominal model's residual shows
  when this physics is missing (computed by :func:`signatures`), used to
  shortlist it, to aim it (which output, which input) and to start its
  parameters sensibly;
* a **model augmentation** with a few extra parameters whose neutral value
  switches it off: either the plant's own equations with the effect switched
  on (``phase_change`` of the AXT211, ``input_dependent_heat_transfer`` of the
  RC networks, ...; see ``physical_effects`` of each model) or a generic
  augmentation of :class:`~thermogym.models.augmented.AugmentedModel`
  around any model (sensors, delays, disturbances, extra dynamics).

================================  ==========================================================
effect                            residual signature (nominal model)
================================  ==========================================================
transport_delay                   every output driven by the input errs like ``−τ dŷ/dt``;
                                  residual correlates with the input's recent changes
sensor_lag                        one output errs like ``−τ dŷ/dt``, the others fit
sensor_offset                     one output is off by a constant in every regime
sensor_drift                      one output's error grows linearly with time in every run
unmeasured_disturbance            autocorrelated residual, independent of the inputs, with
                                  a spectral peak; the same on every output
input_nonlinearity                error depends on the input level (steady states grow
                                  more or less than in proportion)
input_dependent_heat_transfer     error depends on the input level *and* responses speed up
                                  at higher input (forced convection)
nonlinear_heat_transfer           error depends on the temperature rise (band)
backlash                          stroke error changes sign between opening and closing
phase_change                      temperature error concentrated in one temperature band
supply_variation                  power error while the heater is on, largest when cold
missing_dynamics                  autocorrelated residual correlated with the inputs'
                                  past but no single pattern above (Annex 58: add a state)
time_varying_parameter            error grows with time in a run on every output
================================  ==========================================================
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from thermogym._checks import with_unit
from thermogym.models.base import Model

__all__ = [
    "CATALOGUE",
    "Candidate",
    "Context",
    "EffectEntry",
    "candidates_for",
    "signatures",
]

_TEMP = ("°C", "K", "degC")


@dataclass
class Context:
    """What the catalogue needs to shortlist and build hypotheses.

    Attributes
    ----------
    model : Model
        The nominal model instance.
    model_name : str
    model_config : dict
    theta : ndarray, shape (P,)
        Nominal parameters (fitted).
    free : tuple of str
        Parameters the nominal fit varied (refitted with each hypothesis).
    fixed : dict
        Parameters the nominal fit held (name → value).
    outputs : tuple of str
        Compared outputs.
    units : dict
    roles : dict
        Signal → role.
    time : list of ndarray
        Per recording (training first, then validation).
    dt : list of float
    u : list of ndarray (T, n_u)
    y : list of ndarray (T, n_y)
    sim : list of ndarray (T, n_y)
        Nominal simulation.
    is_train : list of bool
    sigma, scale : dict
        Noise level and spread per output.
    share : dict
        Share of the weighted squared error per output.
    regimes : list of dict
        Located regimes (see :func:`~.locate.locate`).
    """

    model: Model
    model_name: str
    model_config: dict[str, Any]
    theta: NDArray[np.float64]
    free: tuple[str, ...]
    fixed: dict[str, float]
    outputs: tuple[str, ...]
    units: dict[str, str]
    roles: dict[str, str]
    time: list[NDArray[np.float64]]
    dt: list[float]
    u: list[NDArray[np.float64]]
    y: list[NDArray[np.float64]]
    sim: list[NDArray[np.float64]]
    is_train: list[bool]
    sigma: dict[str, float]
    scale: dict[str, float]
    share: dict[str, float]
    regimes: list[dict[str, Any]] = field(default_factory=list)

    @property
    def exogenous(self) -> tuple[str, ...]:
        """Exogenous signal names (model order)."""
        return self.model.exogenous_names

    @property
    def inputs(self) -> tuple[str, ...]:
        """Manipulated inputs."""
        return tuple(s.name for s in self.model.inputs)

    @property
    def main_input(self) -> str:
        """The first manipulated input (or the first exogenous signal)."""
        return self.inputs[0] if self.inputs else self.exogenous[0]

    @property
    def ambient(self) -> str | None:
        """The disturbance that is a temperature (the ambient), if any."""
        for s in self.model.disturbances:
            if s.unit in _TEMP:
                return s.name
        return None

    @property
    def residual(self) -> list[NDArray[np.float64]]:
        """``y − ŷ`` per recording."""
        return [y - s for y, s in zip(self.y, self.sim, strict=True)]

    def column(self, name: str) -> list[NDArray[np.float64]]:
        """An exogenous signal per recording."""
        j = list(self.exogenous).index(name)
        return [u[:, j] for u in self.u]

    @property
    def duration(self) -> float:
        """Shortest recording duration [s]."""
        return float(min(t[-1] - t[0] for t in self.time))

    @property
    def dt_min(self) -> float:
        """Shortest sample period [s]."""
        return float(min(self.dt))

    def value(self, name: str) -> float:
        """Nominal value of a parameter."""
        return float(self.theta[self.model.param_index(name)])


@dataclass
class Candidate:
    """One hypothesis to fit: an effect built into a model.

    Attributes
    ----------
    effect : str
        Vocabulary name.
    target : str
        Where it acts (a signal, ``"all outputs"``, ``"plant"``).
    model_name : str
        Registered model to build (the plant itself, or ``augmented``).
    model_config : dict
    extra : dict
        Extra parameter → ``(start, lower, upper)``.
    starts : list of dict
        Alternative starts of the extra parameters (multimodal ones).
    evidence : str
        The signature that suggested it, in words.
    prior : float
        Signature score in [0, 1] (ordering only; the fit decides).
    """

    effect: str
    target: str
    model_name: str
    model_config: dict[str, Any]
    extra: dict[str, tuple[float, float, float]]
    starts: list[dict[str, float]] = field(default_factory=list)
    evidence: str = ""
    prior: float = 0.0

    @property
    def label(self) -> str:
        """``effect (target)``."""
        return f"{self.effect} ({self.target})" if self.target else self.effect


@dataclass(frozen=True)
class EffectEntry:
    """An effect of the vocabulary: explanation, signature, augmentation.

    Attributes
    ----------
    name : str
    explanation : str
        Plain-language physics.
    signature : str
        What the residual shows when it is missing.
    augmentation : str
        The model change and its extra parameters.
    """

    name: str
    explanation: str
    signature: str
    augmentation: str


CATALOGUE: dict[str, EffectEntry] = {
    e.name: e
    for e in [
        EffectEntry(
            "none",
            "The model reproduces the recordings to within the measurement noise: the residual "
            "is white and unrelated to the inputs, or what is left is too small to matter.",
            "white residual, independent of the inputs, RMS near the noise level",
            "none",
        ),
        EffectEntry(
            "transport_delay",
            "The input acts later than recorded: a dead time in the heat path (a fluid carrying "
            "the heat, a slow contact) or an input log and a temperature log that are not on the "
            "same clock. Every response is shifted in time by the same amount.",
            "all outputs driven by the input err like −τ·dŷ/dt; the residual correlates with "
            "the input's changes a few samples earlier",
            "u_i(t) → u_i(t − τ): one parameter, the delay τ [s]",
        ),
        EffectEntry(
            "sensor_lag",
            "A sensor responds slowly: a thermocouple in a thermowell, a sensor glued to a "
            "massive part or behind a layer of paste reads the temperature of its own small "
            "heat capacity, which lags the part it should measure.",
            "one output errs like −τ·dŷ/dt (too fast in the model), the others fit",
            "first-order lag on that output: one parameter, the time constant τ [s]",
        ),
        EffectEntry(
            "sensor_offset",
            "A sensor reads a constant amount too high or too low: a calibration error, an "
            "uncompensated lead resistance of a 2-wire RTD, a cold-junction error.",
            "one output is off by the same amount in every recording and regime",
            "constant added to that output: one parameter, the offset",
        ),
        EffectEntry(
            "sensor_drift",
            "A sensor's error grows during a run: ageing, self-heating, a logger whose reference "
            "drifts as the electronics warm up.",
            "one output's error grows linearly with time since the start of each run",
            "ramp added to that output: one parameter, the drift per hour",
        ),
        EffectEntry(
            "unmeasured_disturbance",
            "Something heats or cools the plant that no sensor records: a draught, the machine "
            "hall's air conditioning cycling, sun through a window, a neighbouring machine. The "
            "recorded ambient is not what the plant sees.",
            "autocorrelated residual, independent of the inputs, with a periodic component; "
            "similar on every output",
            "a periodic disturbance a·sin(2πt/P) + b·cos(2πt/P) added to the ambient (or the "
            "output): amplitudes and period",
        ),
        EffectEntry(
            "input_nonlinearity",
            "The heat source does not grow in proportion to the input: friction losses of "
            "bearings, nuts and motors scale with a power of the speed (lubricant shear, viscous "
            "drag), so steady temperatures grow faster or slower than a linear model "
            "extrapolates from one operating point.",
            "the error depends on the input level; steady states scale with a power of the input",
            "heat ∝ u_ref·(u/u_ref)^α: one parameter, the exponent α",
        ),
        EffectEntry(
            "input_dependent_heat_transfer",
            "The heat transfer to the air grows with the input: at higher speed or feed rate "
            "the moving parts stir the air (forced convection), so the heat source grows "
            "faster than the temperature rise and steady temperatures barely increase at higher "
            "inputs, while the responses become faster.",
            "the error depends on the input level and the model is too slow at high input",
            "air conductance of the moving parts × (1 + β·u/u_ref): one parameter β",
        ),
        EffectEntry(
            "nonlinear_heat_transfer",
            "Natural convection and radiation are not linear in the temperature difference: the "
            "conductance to the air grows with ΔT (h ∝ ΔT^n, radiation ∝ T⁴), so a hot part "
            "loses heat relatively faster than a warm one and the response depends on its "
            "amplitude.",
            "the error depends on the temperature rise: too hot in the model at high "
            "temperatures, too cool at low ones",
            "loss conductance growing with the temperature difference: one parameter",
        ),
        EffectEntry(
            "backlash",
            "The linkage has play: when the motion reverses, the driving part travels through a "
            "dead band before the driven part follows, so the stroke lags on the way up and on "
            "the way down (hysteresis).",
            "the stroke error has opposite signs while opening and while closing",
            "play operator of half-width c between the drive and the driven stroke",
        ),
        EffectEntry(
            "phase_change",
            "The wax melts over a narrow temperature range: while it melts, heat goes into "
            "latent heat instead of raising its temperature, so the cartridge lingers near its "
            "melting point and the stroke starts later and more abruptly.",
            "the temperature error is concentrated in one temperature band (the melting range)",
            "latent heat L spread over a melting range around T_melt (width w): three parameters",
        ),
        EffectEntry(
            "supply_variation",
            "The supply sags under load: a transformer or a long cable with internal resistance "
            "drops part of the voltage while the heater draws current, so the heater gets less "
            "power than the recorded supply voltage implies, most when it is cold (low "
            "resistance, high current).",
            "power error while the heater is on, largest when it is cold",
            "source resistance R_s in series with the heater: one parameter",
        ),
        EffectEntry(
            "missing_dynamics",
            "The model has too few states: a heat capacity it does not include (a machine frame, "
            "a bracket, a thick wall) stores and releases heat on its own time scale, so the "
            "measured response has a slow (or fast) part the model cannot follow.",
            "autocorrelated residual that correlates with the inputs' past but shows none of "
            "the patterns above (IEA EBC Annex 58: autocorrelated residuals call for more "
            "states)",
            "an extra first-order path from the input to the output: gain and time constant",
        ),
        EffectEntry(
            "time_varying_parameter",
            "A coefficient changes during operation: a bearing's preload rises as the parts "
            "warm, lubricant is redistributed or ages, so the same input produces more (or "
            "less) heat later in a run than early in it.",
            "every output's error grows with the time since the start of a run",
            "heat sources × (1 + δ·t/1 h): one parameter, the relative change per hour δ",
        ),
    ]
}


# ------------------------------------------------------------------ signatures
def _r2(e: NDArray[np.float64], x: NDArray[np.float64]) -> tuple[float, float]:
    """R² and slope of ``e ≈ c·x`` (both centred)."""
    ok = np.isfinite(e) & np.isfinite(x)
    if ok.sum() < 5:
        return 0.0, 0.0
    ec = e[ok] - e[ok].mean()
    xc = x[ok] - x[ok].mean()
    sxx = float(xc @ xc)
    see = float(ec @ ec)
    if sxx <= 0 or see <= 0:
        return 0.0, 0.0
    c = float(xc @ ec) / sxx
    return max(0.0, min(1.0, c * c * sxx / see)), c


def signatures(ctx: Context) -> dict[str, Any]:
    """Residual signature features of the nominal model (see the module docstring).

    Returns
    -------
    dict
        Per output: ``offset`` (share of the mean square that is a constant,
        its value), ``drift`` (R² of a shared time trend and slope per hour),
        ``lag`` (R² of ``e ≈ −τ dŷ/dt``, τ), ``band`` / ``direction`` /
        ``onoff`` / ``level`` (η² from the located regimes); overall:
        ``delay`` (τ common to the outputs), ``period`` (spectral peak) and
        ``white_share``.
    """
    res = ctx.residual
    out: dict[str, Any] = {"outputs": {}}
    for j, o in enumerate(ctx.outputs):
        e = np.concatenate([r[:, j] for r in res])
        ok = np.isfinite(e)
        ms = float(np.mean(e[ok] ** 2)) if ok.any() else 0.0
        mean = float(np.mean(e[ok])) if ok.any() else 0.0
        t_h = np.concatenate([(t - t[0]) / 3600.0 for t in ctx.time])
        drift_r2, slope = _r2(e, t_h)
        dy = np.concatenate(
            [
                np.gradient(s[:, j], dt) if s.shape[0] > 1 else 0 * s[:, j]
                for s, dt in zip(ctx.sim, ctx.dt, strict=True)
            ]
        )
        lag_r2, c = _r2(e, dy)
        feats = {
            "offset": (mean * mean / ms if ms > 0 else 0.0),
            "offset_value": mean,
            "drift": drift_r2,
            "drift_per_h": slope,
            "lag": lag_r2 if c < 0 else 0.0,
            "lag_tau": -c if c < 0 else 0.0,
            "share": ctx.share.get(o, 0.0),
        }
        for reg in ctx.regimes:
            if reg["signal"] != o:
                continue
            key = {
                "temperature_band": "band",
                "opening_closing": "direction",
                "heating_cooling": "heating",
                "on_off": "onoff",
                "input_level": "level",
                "time_in_run": "time",
                "experiment": "recording",
            }.get(reg["kind"])
            if key:
                feats[key] = max(feats.get(key, 0.0), reg["eta2"])
                if key == "band":
                    worst = max(
                        reg["bins"], key=lambda d: abs(d["mean"]) if math.isfinite(d["mean"]) else 0
                    )
                    feats["band_worst"] = worst["bin"]
        out["outputs"][o] = feats
    # a delay shifts every output the same way: the lag signature on the outputs that err
    lagged = [
        (f["lag"], f["lag_tau"], f["share"]) for f in out["outputs"].values() if f["share"] > 0.05
    ]
    if lagged:
        w = np.array([s for _, _, s in lagged])
        r2 = np.array([r for r, _, _ in lagged])
        taus = np.array([t for _, t, _ in lagged])
        out["delay"] = float(np.sum(w * r2) / np.sum(w)) * float(np.mean(r2 > 0.2))
        good = taus[r2 > 0.2]
        out["delay_tau"] = float(np.median(good)) if good.size else 0.0
    else:
        out["delay"], out["delay_tau"] = 0.0, 0.0
    # spectral peak of the residual (averaged over recordings and outputs)
    best_p, best_ratio = math.nan, 0.0
    for r, dt in zip(res, ctx.dt, strict=True):
        n = r.shape[0]
        if n < 16:
            continue
        x = np.where(np.isfinite(r), r, 0.0)
        x = x - x.mean(axis=0)
        x = x * np.hanning(n)[:, None]
        P = (np.abs(np.fft.rfft(x, axis=0)) ** 2).sum(axis=1)
        f = np.fft.rfftfreq(n, dt)
        sel = (f > 1.5 / (n * dt)) & (f < 0.25 / dt)
        if sel.sum() < 4:
            continue
        k = int(np.argmax(np.where(sel, P, 0.0)))
        ratio = float(P[k] / np.median(P[sel]))
        if ratio > best_ratio:
            best_ratio, best_p = ratio, float(1.0 / f[k])
    out["period"] = best_p
    out["period_peak"] = best_ratio
    return out


# ------------------------------------------------------------------ candidates
def _top_output(ctx: Context, feats: dict[str, Any], key: str, units: Sequence[str] = ()) -> str:
    best, score = ctx.outputs[0], -1.0
    for o, f in feats["outputs"].items():
        if units and ctx.units.get(o) not in units:
            continue
        s = f.get(key, 0.0) * f["share"]
        if s > score:
            best, score = o, s
    return best


def _wrap(ctx: Context, augs: list[dict[str, Any]]) -> tuple[str, dict[str, Any]]:
    if ctx.model_name == "augmented":
        cfg = dict(ctx.model_config)
        cfg["augmentations"] = [*cfg.get("augmentations", []), *augs]
        return "augmented", cfg
    from thermogym.models.registry import model_names

    if ctx.model_name not in model_names():
        # a user's own Model instance: wrap the instance (it cannot be rebuilt by name)
        return "augmented", {"base": ctx.model, "augmentations": augs}
    return "augmented", {
        "base": ctx.model_name,
        "base_config": dict(ctx.model_config),
        "augmentations": augs,
    }


def _internal(ctx: Context, effect: str) -> tuple[str, dict[str, Any]]:
    cfg = dict(ctx.model_config)
    cfg["effects"] = [*cfg.get("effects", []), effect]
    return ctx.model_name, cfg


def _levels(ctx: Context, name: str) -> NDArray[np.float64]:
    v = np.concatenate(ctx.column(name))
    return np.unique(np.round(v[np.isfinite(v) & (v != 0)], 6))


def _u_ref(ctx: Context, name: str) -> float:
    v = np.concatenate([c for c, tr in zip(ctx.column(name), ctx.is_train, strict=True) if tr])
    nz = np.abs(v[np.isfinite(v) & (v != 0)])
    return float(np.mean(nz)) if nz.size else 1.0


def candidates_for(ctx: Context, feats: dict[str, Any]) -> list[Candidate]:
    """Every hypothesis applicable to the nominal model, with starts and evidence.

    Parameters
    ----------
    ctx : Context
    feats : dict
        From :func:`signatures`.

    Returns
    -------
    list of Candidate
        Sorted by signature score (highest first).
    """
    m = ctx.model
    internal = set(getattr(m, "physical_effects", {})) - set(ctx.model_config.get("effects", []))
    is_foptd = ctx.model_name == "foptd" or (
        ctx.model_name == "augmented" and ctx.model_config.get("base") == "foptd"
    )
    out: list[Candidate] = []
    dur = ctx.duration
    dt = ctx.dt_min
    fo = feats["outputs"]
    temp_outputs = [o for o in ctx.outputs if ctx.units.get(o) in _TEMP]
    main = ctx.main_input

    def add(c: Candidate) -> None:
        out.append(c)

    # --- sensor effects on the output whose residual shows the pattern most
    o = _top_output(ctx, feats, "lag")
    tau = float(np.clip(fo[o]["lag_tau"], dt, 0.25 * dur)) if fo[o]["lag_tau"] > 0 else 4 * dt
    name, cfg = _wrap(
        ctx, [{"effect": "sensor_lag", "signal": o, "bounds": {"tau": [0.0, 0.3 * dur]}}]
    )
    add(
        Candidate(
            "sensor_lag",
            o,
            name,
            cfg,
            {f"tau_lag_{o}": (tau, 0.0, 0.3 * dur)},
            [{f"tau_lag_{o}": v} for v in (0.5 * tau, 2 * tau, 10 * dt)],
            f"residual of {o} ≈ −τ·dŷ/dt with R² = {fo[o]['lag']:.2f}, "
            f"τ ≈ {fo[o]['lag_tau']:.3g} s",
            fo[o]["lag"] * (1 - feats["delay"]),
        )
    )
    if not is_foptd and not ctx.model_name == "augmented":
        o = _top_output(ctx, feats, "offset")
        sc = ctx.scale[o]
        name, cfg = _wrap(
            ctx, [{"effect": "sensor_offset", "signal": o, "bounds": {"offset": [-5 * sc, 5 * sc]}}]
        )
        add(
            Candidate(
                "sensor_offset",
                o,
                name,
                cfg,
                {
                    f"offset_{o}": (
                        float(np.clip(fo[o]["offset_value"], -5 * sc, 5 * sc)),
                        -5 * sc,
                        5 * sc,
                    )
                },
                [],
                f"mean residual of {o} = "
                f"{with_unit(format(fo[o]['offset_value'], '.3g'), ctx.units.get(o))}, "
                f"{100 * fo[o]['offset']:.0f} % of its mean square",
                fo[o]["offset"],
            )
        )
    o = _top_output(ctx, feats, "drift")
    sc = ctx.scale[o]
    hi = 10 * sc / max(dur / 3600.0, 1e-3)
    name, cfg = _wrap(ctx, [{"effect": "sensor_drift", "signal": o, "bounds": {"rate": [-hi, hi]}}])
    add(
        Candidate(
            "sensor_drift",
            o,
            name,
            cfg,
            {f"drift_{o}": (float(np.clip(fo[o]["drift_per_h"], -hi, hi)), -hi, hi)},
            [],
            f"residual of {o} grows by "
            f"{with_unit(format(fo[o]['drift_per_h'], '.3g'), ctx.units.get(o))}/h "
            f"(R² = {fo[o]['drift']:.2f})",
            fo[o]["drift"],
        )
    )
    # --- transport delay of the main input (an FOPTD model has its own delays)
    if not is_foptd and ctx.inputs:
        tau = (
            float(np.clip(feats["delay_tau"], dt, 0.25 * dur)) if feats["delay_tau"] > 0 else 2 * dt
        )
        name, cfg = _wrap(
            ctx,
            [{"effect": "transport_delay", "signal": main, "bounds": {"delay": [0.0, 0.25 * dur]}}],
        )
        add(
            Candidate(
                "transport_delay",
                main,
                name,
                cfg,
                {f"delay_{main}": (tau, 0.0, 0.25 * dur)},
                [{f"delay_{main}": v} for v in (0.5 * tau, 2 * tau, 3 * dt, 20 * dt)],
                f"the lag signature appears on the outputs together (score {feats['delay']:.2f}), "
                f"τ ≈ {feats['delay_tau']:.3g} s",
                feats["delay"],
            )
        )
    # --- unmeasured periodic disturbance: on the ambient if there is one, else on the output
    period = feats["period"] if math.isfinite(feats["period"]) else dur / 2
    period = float(np.clip(period, 4 * dt, 2 * dur))
    target = ctx.ambient or _top_output(ctx, feats, "share")
    amp = 10.0 if ctx.ambient else 5 * ctx.scale[target]
    name, cfg = _wrap(
        ctx,
        [
            {
                "effect": "unmeasured_disturbance",
                "signal": target,
                "period": period,
                "bounds": {"amplitude": [-amp, amp], "period": [4 * dt, 2 * dur]},
            }
        ],
    )
    add(
        Candidate(
            "unmeasured_disturbance",
            target,
            name,
            cfg,
            {
                f"dist_sin_{target}": (0.0, -amp, amp),
                f"dist_cos_{target}": (0.0, -amp, amp),
                f"dist_period_{target}": (period, 4 * dt, 2 * dur),
            },
            [
                {f"dist_period_{target}": p, f"dist_sin_{target}": s, f"dist_cos_{target}": c}
                for p in (period, 0.5 * period, 2 * period)
                for s, c in (
                    (0.2 * amp, 0.0),
                    (0.0, 0.2 * amp),
                    (-0.2 * amp, 0.0),
                    (0.0, -0.2 * amp),
                )
                if 4 * dt <= p <= 2 * dur
            ],
            f"residual spectrum peaks at a period of {feats['period'] / 3600:.3g} h "
            f"({feats['period_peak']:.1f}× its median)"
            if math.isfinite(feats["period"])
            else "no clear spectral peak",
            min(1.0, feats["period_peak"] / 50.0),
        )
    )
    # --- input nonlinearity
    level_score = max((f.get("level", 0.0) for f in fo.values()), default=0.0)
    if "input_nonlinearity" in internal:
        name, cfg = _internal(ctx, "input_nonlinearity")
        add(
            Candidate(
                "input_nonlinearity",
                "heat sources",
                name,
                cfg,
                {"alpha_u": (1.0, 0.3, 2.5)},
                [{"alpha_u": v} for v in (0.6, 1.5)],
                f"residual depends on the input level (η² up to {level_score:.2f})",
                level_score,
            )
        )
    elif ctx.inputs and _levels(ctx, main).size >= 2:
        ur = _u_ref(ctx, main)
        name, cfg = _wrap(ctx, [{"effect": "input_nonlinearity", "signal": main, "u_ref": ur}])
        add(
            Candidate(
                "input_nonlinearity",
                main,
                name,
                cfg,
                {f"alpha_{main}": (1.0, 0.2, 3.0)},
                [{f"alpha_{main}": v} for v in (0.6, 1.5)],
                f"residual depends on the level of {main} (η² up to {level_score:.2f})",
                level_score,
            )
        )
    # --- input-dependent heat transfer
    if "input_dependent_heat_transfer" in internal:
        name, cfg = _internal(ctx, "input_dependent_heat_transfer")
        add(
            Candidate(
                "input_dependent_heat_transfer",
                "moving parts",
                name,
                cfg,
                {"beta_u": (0.0, -0.5, 5.0)},
                [{"beta_u": v} for v in (0.5, 2.0)],
                f"residual depends on the input level (η² up to {level_score:.2f})",
                level_score,
            )
        )
    elif ctx.inputs and _levels(ctx, main).size >= 2 and temp_outputs:
        ur = _u_ref(ctx, main)
        augs = [
            {
                "effect": "input_dependent_heat_transfer",
                "signal": o,
                "source": main,
                "u_ref": ur,
                "share": "all",
                **({"reference": ctx.ambient} if ctx.ambient else {}),
            }
            for o in temp_outputs
        ]
        name, cfg = _wrap(ctx, augs)
        add(
            Candidate(
                "input_dependent_heat_transfer",
                "all temperatures",
                name,
                cfg,
                {"beta_all": (0.0, -0.5, 5.0)},
                [{"beta_all": v} for v in (0.5, 2.0)],
                f"residual depends on the level of {main} (η² up to {level_score:.2f})",
                level_score,
            )
        )
    # --- nonlinear heat transfer
    band_score = max((f.get("band", 0.0) for f in fo.values()), default=0.0)
    if "nonlinear_heat_transfer" in internal:
        name, cfg = _internal(ctx, "nonlinear_heat_transfer")
        pname = "n_conv" if "n_conv" in _effect_params(m, "nonlinear_heat_transfer") else "gamma_nl"
        lo, hi = _effect_bounds(m, "nonlinear_heat_transfer", pname)
        add(
            Candidate(
                "nonlinear_heat_transfer",
                "losses to the air",
                name,
                cfg,
                {pname: (_effect_neutral(m, "nonlinear_heat_transfer", pname), lo, hi)},
                [{pname: lo + f * (hi - lo)} for f in (0.4, 0.7)],
                f"residual depends on the temperature band (η² up to {band_score:.2f})",
                band_score,
            )
        )
    elif temp_outputs:
        augs = [
            {
                "effect": "nonlinear_heat_transfer",
                "signal": o,
                "share": "all",
                **({"reference": ctx.ambient} if ctx.ambient else {}),
            }
            for o in temp_outputs
        ]
        name, cfg = _wrap(ctx, augs)
        add(
            Candidate(
                "nonlinear_heat_transfer",
                "all temperatures",
                name,
                cfg,
                {"gamma_all": (0.0, -0.2, 5.0)},
                [{"gamma_all": v} for v in (0.2, 1.0)],
                f"residual depends on the temperature band (η² up to {band_score:.2f})",
                band_score,
            )
        )
    # --- time-varying parameter
    time_score = max((f.get("drift", 0.0) for f in fo.values()), default=0.0)
    spread = float(np.mean([f.get("drift", 0.0) > 0.2 for f in fo.values()]))
    if "time_varying_parameter" in internal:
        name, cfg = _internal(ctx, "time_varying_parameter")
        add(
            Candidate(
                "time_varying_parameter",
                "heat sources",
                name,
                cfg,
                {"q_drift": (0.0, -0.2, 0.5)},
                [{"q_drift": v} for v in (0.05, -0.05)],
                f"the error grows with time in a run on {100 * spread:.0f} % of the outputs",
                time_score * spread,
            )
        )
    # --- AXT211 physics: backlash, phase change, supply
    if "c_backlash" in ctx.fixed:
        stroke = [o for o in ctx.outputs if ctx.units.get(o) == "mm"]
        d = max((fo[o].get("direction", 0.0) for o in stroke), default=0.0)
        name, cfg = ctx.model_name, dict(ctx.model_config)
        add(
            Candidate(
                "backlash",
                stroke[0] if stroke else "stroke",
                name,
                cfg,
                {"c_backlash": (0.0, 0.0, 1.0)},
                [{"c_backlash": v} for v in (0.05, 0.15, 0.3)],
                f"stroke residual differs between opening and closing (η² = {d:.2f})",
                d,
            )
        )
    elif not internal and any(ctx.units.get(o) == "mm" for o in ctx.outputs):
        o = next(o for o in ctx.outputs if ctx.units.get(o) == "mm")
        sc = ctx.scale[o]
        name, cfg = _wrap(
            ctx, [{"effect": "backlash", "signal": o, "bounds": {"c": [0.0, 2 * sc]}}]
        )
        add(
            Candidate(
                "backlash",
                o,
                name,
                cfg,
                {f"backlash_{o}": (0.0, 0.0, 2 * sc)},
                [{f"backlash_{o}": v * sc} for v in (0.05, 0.2)],
                f"residual of {o} differs between opening and closing "
                f"(η² = {fo[o].get('direction', 0):.2f})",
                fo[o].get("direction", 0.0),
            )
        )
    if "phase_change" in internal:
        name, cfg = _internal(ctx, "phase_change")
        t_guess = _band_centre(fo, ctx)
        add(
            Candidate(
                "phase_change",
                "wax",
                name,
                cfg,
                {
                    "L_melt": (0.0, 0.0, 2000.0),
                    "T_melt": (t_guess, 40.0, 75.0),
                    "w_melt": (3.0, 0.5, 10.0),
                },
                [
                    {"L_melt": L, "T_melt": T, "w_melt": 3.0}
                    for L in (150.0, 500.0)
                    for T in sorted({t_guess, 50.0, 58.0, 66.0})
                ],
                f"temperature residual concentrated in one band (η² up to {band_score:.2f})",
                band_score,
            )
        )
    if "supply_variation" in internal:
        name, cfg = _internal(ctx, "supply_variation")
        on = max((f.get("onoff", 0.0) for f in fo.values()), default=0.0)
        add(
            Candidate(
                "supply_variation",
                "supply",
                name,
                cfg,
                {"R_source": (0.0, 0.0, 200.0)},
                [{"R_source": v} for v in (5.0, 20.0, 60.0)],
                f"residual differs between heater on and off (η² up to {on:.2f})",
                on,
            )
        )
    # --- missing dynamics of an RC network: a heat capacity attached at the erring nodes
    for node, o in _erring_nodes(ctx):
        net = ctx.model.arrays(ctx.theta[None])  # type: ignore[attr-defined]
        j = list(ctx.model.nodes).index(node)  # type: ignore[attr-defined]
        c_node = float(net.C[0, j])
        g_node = float(net.G[0, j].sum() + net.g_amb[0, j])
        bounds = {
            "C": [0.1 * c_node, 200 * c_node],
            "G": [0.0, 20 * g_node],
            "g": [0.0, 5 * g_node],
        }
        name, cfg = _wrap(ctx, [{"effect": "missing_dynamics", "node": node, "bounds": bounds}])
        add(
            Candidate(
                "missing_dynamics",
                f"mass at {node}",
                name,
                cfg,
                {
                    f"Cx_{node}": (5 * c_node, 0.1 * c_node, 200 * c_node),
                    f"Gx_{node}": (0.0, 0.0, 20 * g_node),
                    f"gx_{node}": (0.0, 0.0, 5 * g_node),
                },
                [
                    {
                        f"Cx_{node}": fc * c_node,
                        f"Gx_{node}": fg * g_node,
                        f"gx_{node}": fa * g_node,
                    }
                    for fc in (2.0, 10.0, 40.0)
                    for fg in (0.3, 1.0)
                    for fa in (0.0, 0.3)
                ],
                f"autocorrelated residual of {o} without a more specific pattern (Annex 58: add a "
                "state): a heat capacity the network lacks",
                0.3 * ctx.share.get(o, 0.0),
            )
        )
    # --- missing dynamics: one extra state per erring output, driven by every exogenous signal
    err = sorted(ctx.outputs, key=lambda o: -ctx.share.get(o, 0.0))
    targets = [o for o in err if ctx.share.get(o, 0.0) >= 0.15][:3] or err[:1]
    srcs = [c for c in ctx.exogenous if float(np.ptp(np.concatenate(ctx.column(c)))) > 0]
    srcs = srcs or [main]
    augs, extra, starts = [], {}, []
    spans = {c: max(float(np.ptp(np.concatenate(ctx.column(c)))), 1e-9) for c in srcs}

    def kname(o: str, c: str) -> str:
        return f"md_K_{o}" if len(srcs) == 1 else f"md_K_{o}__{c}"

    for o in targets:
        bounds: dict[str, list[float]] = {"T": [dt, 3 * dur]}
        for c in srcs:
            kmax = 10 * ctx.scale[o] / spans[c]
            bounds[f"gain_{c}"] = [-kmax, kmax]
            extra[kname(o, c)] = (0.0, -kmax, kmax)
        augs.append({"effect": "missing_dynamics", "signal": o, "sources": srcs, "bounds": bounds})
        extra[f"md_T_{o}"] = (float(np.clip(dur / 5, dt, 3 * dur)), dt, 3 * dur)
    for f in (0.03, 0.2, 1.0):
        for sgn in (1.0, -1.0):
            starts.append(
                {
                    **{f"md_T_{o}": float(np.clip(f * dur, dt, 3 * dur)) for o in targets},
                    **{
                        kname(o, main): sgn * 0.3 * ctx.scale[o] / spans.get(main, 1.0)
                        for o in targets
                        if main in srcs
                    },
                }
            )
    name, cfg = _wrap(ctx, augs)
    auto = max((1.0 - f.get("lag", 0.0)) * f["share"] for f in fo.values())
    add(
        Candidate(
            "missing_dynamics",
            ", ".join(targets),
            name,
            cfg,
            extra,
            starts,
            "autocorrelated residual without a more specific pattern (Annex 58: add a state)",
            0.3 * auto,
        )
    )
    out.sort(key=lambda c: -c.prior)
    return out


def _erring_nodes(ctx: Context) -> list[tuple[str, str]]:
    """(node, output) of measured temperature nodes of a linear RC network, most error first."""
    from thermogym.models.thermal_network import ThermalNetworkModel

    m = ctx.model
    if not isinstance(m, ThermalNetworkModel) or m.effects:
        return []
    net = m.arrays(ctx.theta[None])
    measured = []
    for o in sorted(ctx.outputs, key=lambda o: -ctx.share.get(o, 0.0)):
        if ctx.units.get(o) not in _TEMP:
            continue
        row = net.H[list(m.output_names).index(o)]
        nz = np.flatnonzero(row)
        if nz.size == 1 and row[nz[0]] == 1.0:
            measured.append((m.nodes[nz[0]], o))
    if not measured:
        return []
    # the two most erring measured nodes, then the unmeasured node coupled most strongly to the
    # most erring one (a mass may sit where no sensor is)
    out = measured[:2]
    j = list(m.nodes).index(measured[0][0])
    taken = {n for n, _ in measured}
    for k in np.argsort(-net.G[0, j]):
        if net.G[0, j, k] > 0 and m.nodes[k] not in taken:
            out.append((m.nodes[k], measured[0][1]))
            break
    return out


def _band_centre(fo: dict[str, Any], ctx: Context) -> float:
    for o, f in fo.items():
        b = f.get("band_worst")
        if b and ctx.units.get(o) in _TEMP:
            try:
                a, rest = b.split("-", 1)
                return float(np.clip(0.5 * (float(a) + float(rest.split()[0])), 40.0, 75.0))
            except (ValueError, IndexError):
                continue
    return 58.0


def _effect_params(model: Model, effect: str) -> list[str]:
    eff = getattr(model, "physical_effects", {}).get(effect)
    return [p.name for p in eff.parameters] if eff else []


def _effect_bounds(model: Model, effect: str, name: str) -> tuple[float, float]:
    eff = model.physical_effects[effect]  # type: ignore[attr-defined]
    p = next(p for p in eff.parameters if p.name == name)
    return float(p.lower), float(p.upper)


def _effect_neutral(model: Model, effect: str, name: str) -> float:
    eff = model.physical_effects[effect]  # type: ignore[attr-defined]
    return float(next(p for p in eff.parameters if p.name == name).nominal)
