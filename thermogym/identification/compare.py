"""Several fitted models on one recording, and their residual tests (MATLAB ``compare``, ``resid``).

:func:`compare` simulates (or predicts ``k`` samples ahead) every FitResult
on one recording and gives the fit of each output (NRMSE fit, 001 eq 5; see
:mod:`thermogym.identification.metrics` for the name and scale).
Linear fits (``ss``, ``foptd``, the polynomial families ``arx``, ``armax``,
``oe``, ``bj`` and ``sopdt``) go through
:func:`~thermogym.identification.linear_fit.predict` (their operating point,
the initial state chosen by ``x0``); any other FitResult is simulated from
its model's own initial state.

:func:`resid` runs Ljung's whiteness and input cross-correlation tests on the
residuals ``y − ŷ`` of one fit, with the tests of the diagnosis
(:func:`thermogym.identification.residuals.residual_tests`): the
same statistics, not a copy.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from thermogym._checks import integer, probability
from thermogym.errors import ConfigError, RecordingError
from thermogym.fitresult import FitResult, load_fit
from thermogym.identification.linear_fit import LINEAR_MODELS, X0_CHOICES, predict
from thermogym.identification.metrics import nrmse
from thermogym.identification.residuals import residual_tests
from thermogym.recording import Recording

__all__ = ["Comparison", "ModelPrediction", "compare", "predict_any", "resid"]


@dataclass
class ModelPrediction:
    """One fitted model on the recording.

    Attributes
    ----------
    label : str
        Name shown in tables and legends.
    outputs : dict of str to ndarray
        Predicted outputs (those the recording measures), shape (T,) each.
    fits : dict of str to float
        NRMSE fit per output (fraction).
    x0 : str
        Initial state used: ``"estimate"``, ``"steady"``, ``"zero"`` or
        ``"model"`` (a non-linear model's own initial state).
    horizon : int or None
        Prediction horizon [samples]; ``None``: simulation.
    note : str
        What was done differently from what was asked (e.g. a k-step
        prediction of a model without a noise model is its simulation).
    """

    label: str
    outputs: dict[str, NDArray[np.float64]]
    fits: dict[str, float]
    x0: str
    horizon: int | None = None
    note: str = ""

    @property
    def mean_fit(self) -> float:
        """Mean fit over the outputs (MNRMSE, 001 eq 6)."""
        vals = [v for v in self.fits.values() if np.isfinite(v)]
        return float(np.mean(vals)) if vals else float("nan")


@dataclass
class Comparison:
    """Outcome of :func:`compare`.

    Attributes
    ----------
    recording : Recording
    outputs : list of str
        Outputs compared (measured in the recording and predicted by a model).
    models : list of ModelPrediction
    """

    recording: Recording
    outputs: list[str]
    models: list[ModelPrediction] = field(default_factory=list)

    def table(self) -> list[dict[str, Any]]:
        """One row per model: label, fit per output, mean fit (fractions)."""
        return [
            {
                "model": m.label,
                **{o: m.fits.get(o, float("nan")) for o in self.outputs},
                "mean": m.mean_fit,
            }
            for m in self.models
        ]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (fits as fractions, the API's scale)."""
        return {
            "recording": self.recording.experiment_id,
            "outputs": self.outputs,
            "models": [
                {
                    "label": m.label,
                    "fit": m.fits,
                    "mean_fit": m.mean_fit,
                    "x0": m.x0,
                    "horizon": m.horizon,
                    "note": m.note,
                }
                for m in self.models
            ],
        }


def predict_any(
    fit: FitResult | str | os.PathLike[str] | Mapping[str, Any],
    rec: Recording,
    *,
    x0: str = "auto",
    k_step: int | None = None,
) -> tuple[dict[str, NDArray[np.float64]], str, int | None, str]:
    """Outputs of any FitResult on a recording's inputs.

    Returns
    -------
    outputs : dict of str to ndarray
        Every model output, shape (T,).
    x0 : str
        Initial state used.
    horizon : int or None
    note : str
    """
    fit = load_fit(fit)
    if x0 not in X0_CHOICES:
        raise ConfigError(f"x0 is {x0!r}; expected one of {list(X0_CHOICES)}")
    if fit.model in LINEAR_MODELS:
        # ss, foptd, the polynomial families and SOPDT: about the fit's operating point,
        # initial state as asked
        p = predict(fit, rec, x0=x0, k_step=k_step)
        out = {c: p.outputs[:, j] for j, c in enumerate(p.output_names)}
        return out, p.x0, p.horizon, p.note
    if x0 != "auto":
        raise ConfigError(
            f"x0={x0!r} applies to linear fits {list(LINEAR_MODELS)}; the {fit.model!r} model "
            "starts in its own initial state"
        )
    model = fit.build_model()
    theta = fit.theta(model)
    rec.validate_for(model, outputs=False)
    rec.check_values([s.name for s in model.exogenous])
    sim = model.simulate(rec.exogenous_array(model), rec.dt, theta, t0=float(rec.time[0]))
    note = ""
    if k_step is not None:
        note = (
            f"the {fit.model!r} model has no noise model: its {int(k_step)}-step prediction is "
            "its simulation"
        )
    out = {c: sim.outputs[0, :, j] for j, c in enumerate(model.output_names)}
    return out, "model", None, note


def _label(fit: FitResult, given: str | None, i: int) -> str:
    if given:
        return given
    return f"{i + 1}: {fit.model} ({fit.method})" if fit.method else f"{i + 1}: {fit.model}"


def compare(
    fits: Sequence[FitResult | str | os.PathLike[str] | Mapping[str, Any]],
    rec: Recording,
    *,
    x0: str = "auto",
    k_step: int | None = None,
    labels: Sequence[str] | None = None,
) -> Comparison:
    """Fit of several FitResults on one recording (MATLAB ``compare``).

    Parameters
    ----------
    fits : sequence of FitResult, path or dict
    rec : Recording
        With the models' inputs and (some of) their outputs.
    x0 : {"auto", "estimate", "steady", "zero"}
        Initial state of linear fits (see
        :func:`~thermogym.identification.linear_fit.predict`).
    k_step : int, optional
        Prediction horizon [samples]; default simulation.
    labels : sequence of str, optional
        One name per fit (default: number, model and method).

    Returns
    -------
    Comparison

    Raises
    ------
    RecordingError
        No model output is measured in the recording.

    Examples
    --------
    >>> from thermogym.models.linear import FOPTDModel
    >>> from thermogym.identification.foptd import fit_foptd
    >>> m = FOPTDModel(["u"], ["y"], K=2.0, T=20.0, tau=3.0)
    >>> u = np.r_[np.zeros(10), np.ones(190)]
    >>> y = 5 + m.simulate(u[:, None], 1.0).outputs[0, :, 0]
    >>> rec = Recording(np.arange(200.0), {"u": u, "y": y})
    >>> c = compare([fit_foptd(rec, ["u"], ["y"], max_delay=10).fit], rec)
    >>> round(c.models[0].fits["y"], 6)
    1.0
    """
    if not fits:
        raise ConfigError("compare needs at least one FitResult")
    if labels is not None and len(labels) != len(fits):
        raise ConfigError(f"{len(labels)} labels for {len(fits)} fits; give one label per fit")
    loaded = [load_fit(f) for f in fits]
    result = Comparison(rec, [])
    for i, fit in enumerate(loaded):
        outs, used, horizon, note = predict_any(fit, rec, x0=x0, k_step=k_step)
        measured = {c: v for c, v in outs.items() if c in rec.columns}
        scores = {c: float(nrmse(rec[c], v)) for c, v in measured.items()}
        label = _label(fit, labels[i] if labels else None, i)
        result.models.append(ModelPrediction(label, measured, scores, used, horizon, note))
        for c in measured:
            if c not in result.outputs:
                result.outputs.append(c)
    if not result.outputs:
        raise RecordingError(
            f"recording {rec.experiment_id!r} measures none of the models' outputs; it has "
            f"{list(rec.columns)}"
        )
    return result


def resid(
    fit: FitResult | str | os.PathLike[str] | Mapping[str, Any],
    rec: Recording,
    *,
    x0: str = "auto",
    k_step: int | None = None,
    max_lag: int = 25,
    alpha: float = 0.01,
) -> dict[str, Any]:
    """Whiteness and input cross-correlation tests of a fit's residuals (MATLAB ``resid``).

    Parameters
    ----------
    fit : FitResult, path or dict
    rec : Recording
    x0 : str
        Initial state of linear fits.
    k_step : int, optional
        Residuals of the ``k``-step prediction (1: the one-step prediction
        errors MATLAB's ``resid`` tests for models with a noise model);
        default the simulation residuals.
    max_lag : int
        Largest lag M [samples] (MATLAB's default 25).
    alpha : float
        Level of the confidence bounds and of the verdicts, in (0, 1).

    Returns
    -------
    dict
        Output name → :class:`~thermogym.identification.residuals.ResidualTest`.
    """
    max_lag = integer("max_lag", max_lag, lo=1, error=ConfigError)
    alpha = probability("alpha", alpha, error=ConfigError)
    fit = load_fit(fit)
    outs, _, _, _ = predict_any(fit, rec, x0=x0, k_step=k_step)
    model = fit.build_model()
    inputs = {c: np.asarray(rec[c], dtype=float) for c in model.exogenous_names}
    tests = {}
    for c, yh in outs.items():
        if c not in rec.columns:
            continue
        e = np.asarray(rec[c], dtype=float) - yh
        tests[c] = residual_tests(
            [e], [inputs], signal=c, measured=[rec[c]], max_lag=max_lag, alpha=alpha
        )
    if not tests:
        raise RecordingError(
            f"recording {rec.experiment_id!r} measures none of the model's outputs "
            f"{list(model.output_names)}"
        )
    return tests
