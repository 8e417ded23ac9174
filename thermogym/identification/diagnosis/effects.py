"""The effect catalogue: what a model may have left out, in which forms, how to add it.

Each effect of the vocabulary of DESIGN.md is one :class:`Effect` object:

* a **plain-language physical explanation** shown in reports;
* a **residual signature** (what the nominal model's residual shows when this
  physics is missing), quoted as evidence and used to order the screening;
* :meth:`Effect.propose`: the candidates for *this* model and data — the
  effect in each physically allowed form, on every signal it can act on, as
  augmentation specs around the model
  (:class:`~thermogym.models.augmented.AugmentedModel`) or as the plant's own
  equations with the effect switched on (``physical_effects``), built by the
  effect's proposer (:mod:`.proposers`);
* :meth:`Effect.experiment`: the experiment that would identify a parameter
  the data leave undetermined.

:func:`candidates_for` gathers the candidates of every effect of the
catalogue, highest signature score first.

================================  ==============================  ===========================
effect                            forms                           residual signature
================================  ==============================  ===========================
transport_delay                   input / output dead time        cross-correlation with an
                                                                  input's changes peaks late
sensor_lag                        first-order lag                 ``e ≈ −τ dŷ/dt`` on one output
sensor_offset / sensor_drift      constant / linear in time       constant / growing error
unmeasured_disturbance            periodic, steps, smooth,        autocorrelated, input-free;
                                  events (times read from the     events: sharp runs of the
                                  residual, :mod:`.events`)       inverse-filtered residual
input_nonlinearity                power, saturation, hard limit,  error depends on the input
                                  dead zone, monotone piecewise-  level
                                  linear
input_dependent_heat_transfer     conductance ∝ input^m           level and speed of response
nonlinear_heat_transfer           radiation (T⁴), convection      error depends on the
                                  (ΔT^1.25)                       temperature band
time_varying_parameter            ramp, step, random walk         error grows within a run
missing_dynamics                  extra node, input lag,          autocorrelated, input-driven
                                  parallel path
phase_change                      latent heat (Gaussian range)    error in one temperature band
supply_variation                  steps, smooth                   error ∝ input, varies in time
backlash                          play on an input or output      error flips with direction
================================  ==============================  ===========================
"""

from __future__ import annotations

from dataclasses import dataclass

from thermogym.identification.diagnosis.context import Context, signatures
from thermogym.identification.diagnosis.hypothesis import Candidate
from thermogym.identification.diagnosis.proposers import propose

__all__ = ["CATALOGUE", "Context", "Effect", "EffectEntry", "candidates_for", "signatures"]


@dataclass(frozen=True)
class Effect:
    """An effect of the vocabulary: explanation, signature, augmentation, candidates.

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

    def propose(self, ctx: Context) -> list[Candidate]:
        """Candidates of this effect for the nominal model and data of ``ctx``."""
        return propose(ctx, self.name)

    def experiment(self, param: str, ctx: Context | None = None) -> str:
        """The experiment that would identify ``param`` when these data do not."""
        return _EXPERIMENTS.get(self.name, "a richer excitation of the inputs")


#: Old name of :class:`Effect` (kept for code that imports it).
EffectEntry = Effect


def _e(name: str, explanation: str, signature: str, augmentation: str) -> Effect:
    return Effect(name, explanation, signature, augmentation)


CATALOGUE: dict[str, Effect] = {
    e.name: e
    for e in [
        _e(
            "none",
            "The model reproduces the recordings to within the measurement noise: what is left "
            "is the sensors' own (possibly coloured) noise.",
            "no hypothesis lowers the held-out error beyond the (coloured) noise and the "
            "information criterion's penalty",
            "none",
        ),
        _e(
            "parameter_error",
            "The model's own parameters are off (a design value, a handbook estimate, a worn "
            "part): re-calibrating the parameters the data can identify explains the mismatch; "
            "no physics is missing.",
            "the given parameters fit worse on held-out data than re-calibrated ones, and no "
            "further effect improves on the re-calibrated model",
            "none: the model's identifiable parameters re-calibrated",
        ),
        _e(
            "transport_delay",
            "An input acts later than recorded: a dead time in the heat path (a fluid carrying "
            "the heat, a sample line in front of a sensor) or an input log and a temperature "
            "log that are not on the same clock. The response is shifted in time without being "
            "smoothed.",
            "the residual's cross-correlation with an input's changes peaks at a lag of the dead "
            "time and stays narrow",
            "u_i(t) → u_i(t − τ) (input dead time) or y_j(t) → y_j(t − τ) (output dead time): "
            "one parameter τ [s]",
        ),
        _e(
            "sensor_lag",
            "A sensor responds slowly: a thermocouple in a thermowell, a sensor glued to a "
            "massive part or behind a layer of paste reads the temperature of its own small "
            "heat capacity, which lags the part it should measure.",
            "one output errs like −τ·dŷ/dt (too fast in the model); the cross-correlation with "
            "the input's changes is smeared rather than shifted",
            "first-order lag on that output: one parameter, the time constant τ [s]",
        ),
        _e(
            "sensor_offset",
            "A sensor reads a constant amount too high or too low: a calibration error, an "
            "uncompensated lead resistance of a 2-wire RTD, a cold-junction error.",
            "one output is off by the same amount in every recording and regime",
            "constant added to that output: one parameter, the offset",
        ),
        _e(
            "sensor_drift",
            "A sensor's error grows during a run: ageing, self-heating, a logger whose reference "
            "drifts as the electronics warm up.",
            "one output's error grows linearly with time since the start of each run",
            "ramp added to that output: one parameter, the drift per hour",
        ),
        _e(
            "unmeasured_disturbance",
            "Something heats or cools the plant that no sensor records: a draught, air "
            "conditioning cycling, sun through a window, occupants, an unlogged draw-off. The "
            "recorded ambient is not what the plant sees.",
            "autocorrelated residual unrelated to the inputs (periodic, in steps, or slow), or "
            "sharp jumps at times no input explains (events)",
            "a course added to the plant's ambient (or heat input) in every recording: "
            "periodic (period shared, phase per recording), steps or smooth (per recording), or "
            "events: on-periods at the times the residual shows, one size per recording",
        ),
        _e(
            "input_nonlinearity",
            "The input does not act in proportion to its value: a phase-angle dimmer, a "
            "thyristor, a heat pump's modulation or friction losses that scale with a power of "
            "the speed make steady states grow more or less than a linear model extrapolates.",
            "the error depends on the input's level",
            "a static map of the input: power law (α), saturation (c), dead zone (d) or a "
            "monotone piecewise-linear map (slopes)",
        ),
        _e(
            "input_dependent_heat_transfer",
            "A heat-transfer coefficient grows with an input: a fan or a moving part stirs the "
            "air (forced convection), a coolant flow raises a coil's conductance (Dittus-Boelter: "
            "UA ∝ ṁ^0.8), so responses speed up and steady states flatten at high input.",
            "the error depends on the input level and the model is too slow at high input",
            "a conductance κ (u/u_ref)^m between the node and a reference temperature",
        ),
        _e(
            "nonlinear_heat_transfer",
            "Natural convection and radiation are not linear in the temperature difference: "
            "radiation exchanges εσA(T⁴ − T_a⁴) in kelvin, natural convection grows as ΔT^1.25 "
            "(laminar) to ΔT^1.33 (turbulent), so a hot part loses heat relatively faster and "
            "its response depends on its amplitude and on the ambient's absolute level.",
            "the error depends on the temperature band: too hot in the model at high "
            "temperatures, too cool at low ones",
            "a loss beyond linear, fed back from the node temperature: radiation or convection, "
            "one parameter κ (its size against the linear loss)",
        ),
        _e(
            "backlash",
            "A mechanical transmission has play: when the motion reverses, the driving part "
            "travels through a dead band before the driven part follows (a valve stem, a "
            "linkage), so the effect lags on the way up and on the way down (hysteresis).",
            "the error has opposite signs while the input rises and while it falls",
            "play operator of half-width c on the input (or on a stroke output)",
        ),
        _e(
            "phase_change",
            "A material melts or solidifies over a narrow temperature range: while it melts, "
            "heat goes into latent heat instead of raising its temperature, so the temperature "
            "lingers near the melting point.",
            "the temperature error is concentrated in one temperature band",
            "latent heat as an apparent heat capacity κ g(T) around T_melt (width w)",
        ),
        _e(
            "supply_variation",
            "The supply behind an input differs from what the log implies: mains voltage steps "
            "and wander (a lamp's power ∝ V^1.6, a heater's ∝ V²), a source resistance, a "
            "pressure change behind a valve.",
            "the error is proportional to the input and changes over a run",
            "the input times (1 + s(t)), s in steps or smooth, per recording",
        ),
        _e(
            "missing_dynamics",
            "The model has too few states: a heat capacity it does not include (a holder, a "
            "frame, a floor slab, a second layer of fluid) stores and releases heat on its own "
            "time scale, so the response has a slow or a fast part the model cannot follow.",
            "autocorrelated residual that correlates with the inputs' past but shows none of "
            "the patterns above (IEA EBC Annex 58: autocorrelated residuals call for more states)",
            "a mass coupled to the output's node, a store between an input and the plant, or an "
            "extra first-order path from the inputs",
        ),
        _e(
            "time_varying_parameter",
            "A coefficient changes during operation: fouling or an air lock lowers a coil's "
            "conductance, a window opened changes a loss, wind, a bearing's preload rises as "
            "parts warm, so the same input produces different temperatures later in a run.",
            "the error grows or jumps within a run",
            "the loss conductance changes with time: a ramp, a step or a smooth random walk",
        ),
    ]
}

_EXPERIMENTS: dict[str, str] = {
    "transport_delay": "fast steps of the input (faster than the dead time)",
    "sensor_lag": "fast steps of the inputs (faster than the sensor's time constant)",
    "sensor_offset": "a reference reading of the sensor (a calibration point)",
    "sensor_drift": "a longer recording, or a reference reading at its end",
    "unmeasured_disturbance": "a recording of the suspected heat flow or ambient",
    "input_nonlinearity": "steps to several levels of the input across its range",
    "input_dependent_heat_transfer": "a second level of the input (a second feed rate, speed or "
    "flow)",
    "nonlinear_heat_transfer": "runs over a wider temperature range (and a second ambient)",
    "backlash": "input reversals of several sizes",
    "phase_change": "slow heating and cooling through the suspected melting range",
    "supply_variation": "a recording of the supply (voltage, pressure)",
    "missing_dynamics": "longer steps (slow modes) or faster ones (fast modes)",
    "time_varying_parameter": "the same test repeated at the start and the end of the run",
    "parameter_error": "steps of the inputs that excite the parameter's time scale",
}


def candidates_for(ctx: Context, effects: list[str] | None = None) -> list[Candidate]:
    """Every candidate the catalogue proposes for ``ctx``, highest signature score first.

    Parameters
    ----------
    ctx : Context
    effects : list of str, optional
        Only these effects (default: all).
    """
    if not ctx.features:
        ctx.features = signatures(ctx)
    out: list[Candidate] = []
    for eff in CATALOGUE.values():
        out += eff.propose(ctx)
    # a proposer may name a candidate by the physics the model's structure gives it (a
    # course on a valve is a conductance changing over time): filter on the name it got
    if effects is not None:
        out = [c for c in out if c.effect in effects]
    out.sort(key=lambda c: -c.prior)
    return out
