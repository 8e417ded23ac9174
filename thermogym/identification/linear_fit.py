"""Shared pieces of the linear identification methods (FOPTD, N4SID, RLS).

* :func:`signal_arrays` checks the recordings a method is given (through
  :func:`~thermogym.identification.prepare.check_identification_data`) and
  returns the input and output arrays of each experiment.
* An *operating point* ``(u_op, y_op)`` is what a linear model is linearised
  about: the model maps ``u − u_op`` to ``y − y_op``. ``"initial"`` takes each
  experiment's first sample (paper 000, section 4.1: "the initial temperature
  of the measurements has to be subtracted"), ``"mean"`` its means (MATLAB's
  ``detrend``), ``"none"`` zero (data already prepared, e.g. the spindle's
  temperature rises above ambient). The FitResult stores the mode and the
  training values in ``settings["operating_point"]``.
* :func:`predict_fit` simulates an ``ss`` or ``foptd`` FitResult on a
  recording the way the identification evaluated it (operating point of that
  recording, initial state estimated or zero) and :func:`evaluate_fit` turns
  that into the metrics of :mod:`thermogym.identification.metrics`.
  :func:`simulate_recording` is the same as a recording, for
  ``thermogym simulate --params fit.json``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from thermogym.errors import ConfigError, RecordingError
from thermogym.fitresult import FitResult, data_entry, load_fit
from thermogym.identification.metrics import fit_report
from thermogym.identification.prepare import check_identification_data
from thermogym.models.linear import FOPTDModel, StateSpaceModel
from thermogym.recording import Recording

__all__ = [
    "LINEAR_MODELS",
    "OPERATING_POINTS",
    "Experiment",
    "data_entries",
    "evaluate_fit",
    "exogenous_roles",
    "operating_point",
    "predict_fit",
    "signal_arrays",
    "simulate_recording",
]

#: Models :func:`predict_fit` simulates (``ss``, ``foptd`` and, through their exact
#: state-space realisation, the polynomial and SOPDT models).
LINEAR_MODELS: tuple[str, ...] = ("ss", "foptd", "sopdt", "arx", "armax", "oe", "bj")
#: Operating-point modes (see the module docstring).
OPERATING_POINTS: tuple[str, ...] = ("none", "initial", "mean", "rest")


@dataclass(frozen=True)
class Experiment:
    """Arrays of one checked recording.

    Attributes
    ----------
    u : ndarray, shape (T, m)
        Exogenous signals in the method's column order.
    y : ndarray, shape (T, p)
        Outputs.
    dt : float
        Sample period [s].
    recording : Recording
    """

    u: NDArray[np.float64]
    y: NDArray[np.float64]
    dt: float
    recording: Recording


def exogenous_roles(
    rec: Recording, exogenous: Sequence[str], disturbances: Sequence[str] | None = None
) -> tuple[list[str], list[str]]:
    """Split exogenous columns into manipulated inputs and disturbances.

    A column is a disturbance when ``disturbances`` names it, or (without
    ``disturbances``) when the recording gives it the role ``disturbance``.
    The models put inputs first, then disturbances; the relative order is kept.

    Returns
    -------
    inputs, disturbances : list of str
    """
    if disturbances is None:
        dist = [c for c in exogenous if rec.roles.get(c) == "disturbance"]
    else:
        dist = list(disturbances)
        extra = [d for d in dist if d not in exogenous]
        if extra:
            raise ConfigError(f"disturbance(s) {extra} are not among the inputs {list(exogenous)}")
    return [c for c in exogenous if c not in dist], [c for c in exogenous if c in dist]


def signal_arrays(
    recordings: Recording | Sequence[Recording],
    inputs: Sequence[str],
    outputs: Sequence[str],
    *,
    min_samples: int = 2,
    what: str = "identification",
    step_inputs: bool = False,
) -> list[Experiment]:
    """Check recordings and extract ``u`` and ``y`` of each (one sample period for all).

    ``step_inputs`` accepts inputs that are constant but non-zero (a step from
    zero at ``t = 0``, operating point ``"rest"``).

    Raises
    ------
    RecordingError, IdentificationError
        See :func:`~thermogym.identification.prepare.check_identification_data`;
        also recordings with different sample periods.
    """
    recs = [recordings] if isinstance(recordings, Recording) else list(recordings)
    if not recs:
        raise ConfigError(f"{what}: no recording given")
    if not inputs:
        raise ConfigError(f"{what}: no input column named; expected at least one")
    if not outputs:
        raise ConfigError(f"{what}: no output column named; expected at least one")
    out = []
    for rec in recs:
        dt = check_identification_data(
            rec, inputs, outputs, min_samples=min_samples, what=what, step_inputs=step_inputs
        )
        u = np.column_stack([rec[c] for c in inputs])
        y = np.column_stack([rec[c] for c in outputs])
        out.append(Experiment(u, y, dt, rec))
    dts = [e.dt for e in out]
    if max(dts) - min(dts) > 1e-9 * max(dts):
        raise RecordingError(
            f"{what}: the recordings have different sample periods {sorted(set(dts))} s; "
            "resample them to one period (thermogym.identification.prepare.resample)"
        )
    return out


def operating_point(
    u: NDArray[np.float64], y: NDArray[np.float64] | None, mode: str
) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
    """Operating point ``(u_op, y_op)`` of one experiment.

    Parameters
    ----------
    u : ndarray, shape (T, m)
    y : ndarray, shape (T, p) or None
    mode : {"none", "initial", "mean", "rest"}

    Examples
    --------
    >>> u0, y0 = operating_point(np.array([[1.0], [3.0]]), np.array([[5.0], [7.0]]), "mean")
    >>> u0.tolist(), y0.tolist()
    ([2.0], [6.0])
    """
    if mode not in OPERATING_POINTS:
        raise ConfigError(f"operating_point is {mode!r}; expected one of {OPERATING_POINTS}")

    def pick(a: NDArray[np.float64] | None, m: str) -> NDArray[np.float64] | None:
        if a is None:
            return None
        if m == "none":
            return np.zeros(a.shape[1])
        if m == "initial":
            return np.array(a[0], dtype=float)
        return np.asarray(a.mean(axis=0), dtype=float)

    if mode == "rest":  # inputs from zero, outputs from their first sample
        return pick(u, "none"), pick(y, "initial")  # type: ignore[return-value]
    return pick(u, mode), pick(y, mode)  # type: ignore[return-value]


def _settings_op(fit: FitResult) -> dict[str, Any]:
    op = fit.settings.get("operating_point")
    if not isinstance(op, Mapping) or op.get("mode") not in OPERATING_POINTS:
        raise ConfigError(
            f"FitResult of model {fit.model!r} (method {fit.method!r}) has no "
            "settings['operating_point'] {'mode', 'inputs', 'outputs'}; it was not made by "
            "thermogym's linear identification"
        )
    return dict(op)


def predict_fit(
    fit: FitResult | str | Mapping[str, Any],
    rec: Recording,
    *,
    x0: str = "fit",
    operating: str = "recording",
) -> NDArray[np.float64]:
    """Simulate a linear FitResult (``ss`` or ``foptd``) on a recording's inputs.

    Parameters
    ----------
    fit : FitResult, path or dict
        Made by :func:`~thermogym.identification.foptd.fit_foptd`,
        :func:`~thermogym.identification.n4sid.n4sid` or
        :class:`~thermogym.identification.rls.RecursiveFOPTD`.
    rec : Recording
        Uniform, with the model's exogenous columns at the model's ``dt`` (or
        an integer multiple for ``ss``), and optionally its outputs.
    x0 : {"fit", "estimate", "zero", "steady"}
        Initial state of a state-space model: ``"fit"`` uses the fit's own
        setting (``settings["x0"]``), ``"estimate"`` least squares on the
        recording's outputs (MATLAB ``compare``), ``"zero"``, or ``"steady"``
        (at rest with the first input). FOPTD models always start at rest.
    operating : {"recording", "fit"}
        Operating point: the recording's own (its first samples or means, as
        the fit's mode says; the paper's convention) or the training values
        stored in the fit. Without output columns the fit's is used.

    Returns
    -------
    ndarray, shape (T, p)
        Predicted outputs in the model's output order.

    Examples
    --------
    >>> from thermogym.models.linear import FOPTDModel
    >>> from thermogym.identification.foptd import fit_foptd
    >>> m = FOPTDModel(["u"], ["y"], K=2.0, T=20.0, tau=3.0)
    >>> u = np.r_[np.zeros(10), np.ones(190)]
    >>> y = 5.0 + m.simulate(u[:, None], 1.0).outputs[0, :, 0]
    >>> rec = Recording(np.arange(200.0), {"u": u, "y": y})
    >>> res = fit_foptd(rec, ["u"], ["y"], max_delay=10)
    >>> bool(np.allclose(predict_fit(res.fit, rec)[:, 0], y, atol=1e-6))
    True
    """
    fit = load_fit(fit)
    if fit.model not in LINEAR_MODELS:
        raise ConfigError(
            f"predict_fit handles the linear models {list(LINEAR_MODELS)}; this FitResult is "
            f"of {fit.model!r}"
        )
    op = _settings_op(fit)
    model = fit.build_model()
    theta = fit.theta(model)
    if not isinstance(model, FOPTDModel | StateSpaceModel):
        # polynomial (ARX family) and SOPDT models: their exact state-space realisation
        model = _realized(model, theta, rec.dt)
        theta = model.theta()
    exo = list(model.exogenous_names)
    outs = list(model.output_names)
    missing = [c for c in exo if c not in rec.columns]
    if missing:
        raise RecordingError(
            f"recording {rec.experiment_id!r} lacks the model's input column(s) {missing}; "
            f"it has {list(rec.columns)}"
        )
    rec.check_values(exo)
    u = np.column_stack([rec[c] for c in exo])
    has_y = all(c in rec.columns and np.isfinite(rec[c]).all() for c in outs)
    y = np.column_stack([rec[c] for c in outs]) if has_y else None
    if operating not in ("recording", "fit"):
        raise ConfigError(f"operating is {operating!r}; expected 'recording' or 'fit'")
    u_fit = np.array([op["inputs"].get(c, 0.0) for c in exo], dtype=float)
    y_fit = np.array([op["outputs"].get(c, 0.0) for c in outs], dtype=float)
    if operating == "recording" and y is not None:
        u_op, y_op = operating_point(u, y, op["mode"])
        assert y_op is not None
    else:
        u_op, y_op = u_fit, y_fit
    dt = rec.dt
    if isinstance(model, FOPTDModel):
        # y = y_op + G (u − u_op) from a steady start at u[0]; the model adds the offset
        # y0 (output at rest with zero input) to lags that start at K u[0]: y0 = y_op − K u_op
        K = model.dcgain(theta)[0]
        y0 = y_op - K @ u_op
        th = model.theta(theta, **{f"y0_{c}": float(v) for c, v in zip(outs, y0, strict=True)})
        return model.simulate(u, dt, th, t0=float(rec.time[0])).outputs[0]
    if not isinstance(model, StateSpaceModel):  # pragma: no cover - guarded above
        raise ConfigError(f"unexpected model {model.name!r}")
    du = u - u_op
    mode = fit.settings.get("x0", "estimate") if x0 == "fit" else x0
    if mode == "estimate" and y is None:
        mode = "steady"
    if mode == "estimate":
        assert y is not None
        xi = model.estimate_x0(du, y - y_op, theta)[0]
    elif mode == "zero":
        xi = np.zeros(model.n_states)
    elif mode == "steady":
        mats = model.matrices(theta)
        xi = np.linalg.solve(np.eye(model.n_states) - mats.A[0], mats.B[0] @ du[0])
    else:
        raise ConfigError(f"x0 is {x0!r}; expected 'fit', 'estimate', 'zero' or 'steady'")
    sim = model.simulate(du, dt, theta, xi, t0=float(rec.time[0]))
    return sim.outputs[0] + y_op


def _realized(model: Any, theta: NDArray[np.float64], dt: float) -> StateSpaceModel:
    """One parameter set of a linear model as a deterministic :class:`StateSpaceModel`."""
    from thermogym.models.process import discrete_realization

    r, _ = discrete_realization(model, theta, dt)
    if r.A.shape[1] == 0:  # a pure gain: one inert state
        A, B, C = np.zeros((1, 1)), np.zeros((1, r.B.shape[2])), np.zeros((r.C.shape[1], 1))
    else:
        A, B, C = r.A[0], r.B[0], r.C[0]
    return StateSpaceModel.from_matrices(
        A,
        B,
        C,
        r.D[0],
        dt=dt,
        inputs=[s.name for s in model.inputs],
        outputs=list(model.output_names),
        disturbances=[s.name for s in model.disturbances],
    )


def evaluate_fit(
    fit: FitResult | str | Mapping[str, Any],
    recordings: Recording | Sequence[Recording],
    **kwargs: Any,
) -> dict[str, Any]:
    """Metrics of a linear FitResult on recordings (summed over experiments).

    Parameters
    ----------
    fit : FitResult, path or dict
    recordings : Recording or sequence
        Each with the model's inputs and outputs.
    **kwargs
        Passed to :func:`predict_fit` (``x0``, ``operating``).

    Returns
    -------
    dict
        ``{"mnrmse": mean over experiments, "experiments": {id: fit_report}}``
        where ``fit_report`` gives NRMSE, RMSE, ξ per output and the MNRMSE.
    """
    fit = load_fit(fit)
    recs = [recordings] if isinstance(recordings, Recording) else list(recordings)
    outs = list(fit.build_model().output_names)
    per: dict[str, Any] = {}
    vals = []
    for i, rec in enumerate(recs):
        missing = [c for c in outs if c not in rec.columns]
        if missing:
            raise RecordingError(
                f"recording {rec.experiment_id!r} lacks output column(s) {missing} to compare"
            )
        yh = predict_fit(fit, rec, **kwargs)
        rep = fit_report({c: rec[c] for c in outs}, {c: yh[:, j] for j, c in enumerate(outs)})
        key = rec.experiment_id or f"recording_{i}"
        per[key] = rep
        vals.append(rep["mnrmse"])
    return {"mnrmse": float(np.mean(vals)), "experiments": per}


def simulate_recording(
    fit: FitResult | str | Mapping[str, Any], rec: Recording, **kwargs: Any
) -> Recording:
    """:func:`predict_fit` as a recording (inputs, then the predicted outputs).

    This is what ``thermogym simulate --params fit.json --inputs FILE`` needs for
    ``ss``/``foptd`` fits: the operating point and initial state the model was
    identified with are applied.
    """
    fit = load_fit(fit)
    model = fit.build_model()
    yh = predict_fit(fit, rec, **kwargs)
    cols = {c: rec[c] for c in model.exogenous_names}
    cols.update({c: yh[:, j] for j, c in enumerate(model.output_names)})
    units = {c: u for c, u in rec.units.items() if c in cols}
    for s in model.outputs:
        units.setdefault(s.name, s.unit)
    return Recording(
        rec.time,
        cols,
        units=units,
        roles={
            **{s.name: s.role for s in model.exogenous},
            **{c: "output" for c in model.output_names},
        },
        experiment_id=f"{rec.experiment_id or 'recording'}-sim",
        source=f"thermogym {fit.model} fit ({fit.method})",
        meta={"fit_fingerprint": fit.fingerprint(), "inputs_fingerprint": rec.fingerprint()},
    )


def data_entries(train: Sequence[Recording], validate: Sequence[Recording]) -> list[dict[str, Any]]:
    """:func:`thermogym.fitresult.data_entry` of training and validation recordings."""
    return [data_entry(r, "train") for r in train] + [data_entry(r, "validation") for r in validate]
