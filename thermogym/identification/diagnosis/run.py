"""``diagnose``: a pipeline of named stages from a nominal model to the physics it misses.

::

    nominal          resolve the model; estimate every recording's initial state; rank the
                     parameters by identifiability; re-calibrate the identifiable ones from
                     their given values and from points drawn in their bounds (nominal.py)
    baseline         a plain second-order ARX on the same training data; a nominal model
                     worse than it on held-out data is reported inadequate first
    detection        residual whiteness / input-independence tests and materiality, per
                     output, on training and held-out data (residuals.py); the AR noise
                     model every later comparison uses (scoring.py)
    location         outputs, time windows, operating regimes carrying the error (locate.py)
    parameters       parameter or physics: the given parameters against the re-calibrated
                     ones on held-out data (an information criterion under coloured noise)
    hypotheses       the catalogue proposes every effect in each of its forms (effects.py)
    selection        screening, joint refits, forward selection stopped by held-out
                     improvement and the information criterion (select.py); a generic extra
                     state with as many parameters beside each kept effect
    identifiability  an interval for every reported parameter, or the experiment that
                     would identify it (identify.py)
    report           named effects, their forms and shares, fits before and after,
                     the augmented model's FitResult (report.py)

The stages are in :mod:`.stages_nominal` (nominal to parameters),
:mod:`.stages_hypotheses` (hypotheses, selection, identifiability) and
:mod:`.stages_report`; what they hand on to each other in :mod:`.run_state`.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from thermogym._checks import probability
from thermogym.errors import ConfigError, UnknownNameError
from thermogym.fitresult import FitResult
from thermogym.identification.diagnosis.effects import CATALOGUE
from thermogym.identification.diagnosis.nominal import resolve_model
from thermogym.identification.diagnosis.report import DiagnosisReport
from thermogym.identification.diagnosis.run_state import _Run
from thermogym.identification.diagnosis.stages_hypotheses import (
    _stage_hypotheses,
    _stage_identifiability,
    _stage_selection,
)
from thermogym.identification.diagnosis.stages_nominal import INADEQUATE_MARGIN as INADEQUATE_MARGIN
from thermogym.identification.diagnosis.stages_nominal import (
    _stage_baseline,
    _stage_detection,
    _stage_location,
    _stage_nominal,
    _stage_parameters,
)
from thermogym.identification.diagnosis.stages_report import ALTERNATIVE_DIC as ALTERNATIVE_DIC
from thermogym.identification.diagnosis.stages_report import _stage_report
from thermogym.models.base import Model
from thermogym.recording import Recording

__all__ = ["STAGES", "X0_POLICIES", "diagnose", "resolve_model"]

#: Initial-state choices of :func:`diagnose` (``auto``: ``estimate``, or ``rest`` when every
#: input is constant in every training recording); the policies of :class:`.fit.FitProblem`.
X0_POLICIES: tuple[str, ...] = ("auto", "estimate", "rest", "measured")

#: The pipeline's stages, in order.
STAGES = (
    "nominal",
    "baseline",
    "detection",
    "location",
    "parameters",
    "hypotheses",
    "selection",
    "identifiability",
    "report",
)


# ------------------------------------------------------------------ diagnose
def diagnose(
    model: str | Model,
    train: Recording | Sequence[Recording],
    validate: Recording | Sequence[Recording],
    *,
    params: FitResult | str | Mapping[str, Any] | None = None,
    model_config: Mapping[str, Any] | None = None,
    inputs: Sequence[str] | None = None,
    outputs: Sequence[str] | None = None,
    candidates: Sequence[str] | None = None,
    dt: float | None = None,
    alpha: float = 0.01,
    max_lag: int = 25,
    min_snr: float = 0.5,
    min_rel: float = 0.002,
    scheme: str = "auto",
    max_effects: int = 3,
    max_candidates: int | None = None,
    max_nfev: int = 25,
    sparse: bool = True,
    time_limit: float | None = None,
    progress: Callable[[str], None] | None = None,
    min_explained: float | None = None,
    x0: str = "auto",
) -> DiagnosisReport:
    """Locate a model mismatch, name the missing physics, model it, show the fit improve.

    Parameters
    ----------
    model : str or Model
        The nominal model: a registered thermogym model (``axt211``,
        ``strut``, ``spindle``, ...), ``foptd`` or ``ss:ORDER`` for any
        recording (with ``inputs`` and ``outputs``), or a model instance
        (a user's own :class:`~thermogym.models.base.Model`).
    train : Recording or sequence
        Training recordings (uniformly sampled; slightly uneven time stamps
        are resampled).
    validate : Recording or sequence
        Held-out recordings, at least one.
    params : FitResult, path or dict, optional
        Given parameters of the nominal model (its design values when
        omitted); a FitResult's operating point is honoured. The identifiable
        ones are re-calibrated on ``train``; whether that was needed is the
        ``parameter_error`` question.
    model_config : mapping, optional
        Constructor arguments of a registered model.
    inputs, outputs : sequence of str, optional
        Generic models: exogenous and output columns. Plant models: the
        outputs to compare (default: every model output in the recordings).
    candidates : sequence of str, optional
        Effects to consider (default: every effect of the vocabulary).
    dt : float, optional
        Average the recordings onto this period [s] first. By default their
        own period, unless they hold more than 20,000 samples in all: then the
        longest multiple of it within a twentieth of the nominal model's
        fastest half-response (a day at 1 Hz of a block whose half-response
        takes 7 minutes is searched on a 21 s grid; the report says so).
        Effects faster than that grid are then out of sight: give the
        recordings' own period to keep it.
    alpha : float
        Significance level of the residual tests (Bonferroni over outputs and tests).
    max_lag : int
        Lags of the residual tests [samples].
    min_snr, min_rel : float
        Materiality of a mismatch: systematic residual at least ``min_snr`` ×
        the noise level and ``min_rel`` × the output's spread.
    scheme : {"auto", "split", "crossfit"}
        How hypotheses are scored on held-out data (:mod:`.select`).
    max_effects : int
        Most effects a combination holds.
    max_candidates : int, optional
        Most candidates screened (highest signature score first; default all).
    max_nfev : int
        Cost evaluations of a joint refit.
    sparse : bool
        Try a sparse regression of the residual's dynamics when nothing in
        the catalogue explains a mismatch.
    time_limit : float, optional
        Seconds the whole run may take: fits stop early enough (a margin of
        10 % of it, at most 5 s) for the report to be finished within it, and
        the report says what was left out (``complete``, ``incomplete``).
    progress : callable, optional
        Called with a line of text at each stage.
    min_explained : float, optional
        Ignored (the information criterion decides); kept for old callers.
    x0 : {"auto", "estimate", "rest", "measured"}
        Initial state of every recording in every fit and score:
        ``"estimate"`` least squares on the recording's outputs (as MATLAB's
        ``compare``; the free responses of the model to unit deviations of
        its states), ``"rest"`` the model's own initial state (a plant at
        rest; an identified ``ss``/``foptd`` per its ``steady_start``:
        settled at the first input, else zero at the operating point),
        ``"measured"`` measured temperature states from their first samples
        (:func:`~.initial_states.initial_states`). ``"auto"`` (default):
        ``"estimate"``, or ``"rest"`` for a generic model whose inputs are
        constant in every training recording (the initial state cannot be
        told from the input's effect there; a note says so). The policy used
        is in the FitResults' ``settings["x0"]``.

    Returns
    -------
    DiagnosisReport

    Raises
    ------
    ConfigError
        No training or no validation recording, unknown option.
    RecordingError
        Recordings of another model (missing columns named), too short,
        unusable samples.

    Examples
    --------
    The strut model's own step tests (train at 20 m/min, validate at 25 and 30), the
    nut's thermocouple reading 1 K high (the virtual rig is a richer plant than the
    model: its recordings show more than this one effect):

    >>> import numpy as np
    >>> from thermogym.models.registry import get_model
    >>> from thermogym.recording import Recording
    >>> m = get_model("strut")
    >>> rng = np.random.default_rng(0)
    >>> def steps(v, n=49, dt=150.0):
    ...     u = np.column_stack([np.full(n, v), np.full(n, 21.0)])
    ...     u[0, 0] = 0.0
    ...     y = m.simulate(u, dt, {"T_ref": 21.0}).outputs[0]
    ...     cols = {"feed_rate": u[:, 0], "T_air": u[:, 1]}
    ...     cols |= {k: y[:, j] + rng.normal(0, 0.05, n) for j, k in enumerate(m.output_names)}
    ...     cols["T_nut"] = cols["T_nut"] + 1.0  # the nut's sensor reads 1 K high
    ...     return Recording(dt * np.arange(n), cols)
    >>> rep = diagnose("strut", [steps(20.0)], [steps(25.0), steps(30.0)],
    ...                candidates=["sensor_offset", "sensor_lag"])
    >>> rep.best["effect"], rep.best["target"]
    ('sensor_offset', 'T_nut')
    >>> round(rep.best["params"]["offset_T_nut"]["value"], 1)
    1.0
    """
    del min_explained
    say = progress or (lambda s: None)
    tr_list = [train] if isinstance(train, Recording) else list(train or [])
    va_list = [validate] if isinstance(validate, Recording) else list(validate or [])
    if not tr_list:
        raise ConfigError("no training recordings: diagnosis fits the nominal model on them")
    if not va_list:
        raise ConfigError(
            "no validation recordings: diagnosis ranks hypotheses by their fit on held-out "
            "data; give at least one recording not used for training (--validate)"
        )
    if scheme not in ("auto", "split", "crossfit"):
        raise ConfigError(f"scheme is {scheme!r}; expected 'auto', 'split' or 'crossfit'")
    alpha = probability("alpha", alpha, error=ConfigError)  # a test level in (0, 1)
    if candidates is not None:
        unknown = [c for c in candidates if c not in CATALOGUE or c in ("none", "parameter_error")]
        if unknown:
            raise UnknownNameError(
                f"unknown effect(s) {unknown}; the vocabulary is "
                f"{[k for k in CATALOGUE if k not in ('none', 'parameter_error')]}"
            )
    if x0 not in X0_POLICIES:
        raise ConfigError(f"x0 is {x0!r}; expected one of {list(X0_POLICIES)}")
    if not (isinstance(max_effects, int) and max_effects >= 1):
        raise ConfigError(f"max_effects is {max_effects!r}; expected a whole number >= 1")
    opts = dict(
        params=params,
        model_config=model_config,
        inputs=inputs,
        outputs=outputs,
        candidates=candidates,
        dt=dt,
        alpha=alpha,
        max_lag=max_lag,
        min_snr=min_snr,
        min_rel=min_rel,
        scheme=scheme,
        max_effects=max_effects,
        max_candidates=max_candidates,
        max_nfev=max_nfev,
        sparse=sparse,
        time_limit=time_limit,
        model=model,
        x0=x0,
    )
    st = _Run(opts, say, time.perf_counter(), tr_list, va_list)
    st.x0 = "estimate" if x0 == "auto" else x0  # "auto" may still become "rest" (nominal stage)
    for name in STAGES:
        t = time.perf_counter()
        out = _STAGE_FUNCS[name](st)
        st.seconds[name] = time.perf_counter() - t
        if isinstance(out, DiagnosisReport):
            return out
    raise AssertionError("the report stage returns the report")  # pragma: no cover


_STAGE_FUNCS: dict[str, Callable[[_Run], Any]] = {
    "nominal": _stage_nominal,
    "baseline": _stage_baseline,
    "detection": _stage_detection,
    "location": _stage_location,
    "parameters": _stage_parameters,
    "hypotheses": _stage_hypotheses,
    "selection": _stage_selection,
    "identifiability": _stage_identifiability,
    "report": _stage_report,
}
