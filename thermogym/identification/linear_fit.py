"""Shared pieces of the linear identification methods (FOPTD, N4SID, RLS).

* :func:`signal_arrays` checks the recordings a method is given (through
  :func:`~thermogym.identification.prepare.check_identification_data`) and
  returns the input and output arrays of each experiment.
* An *operating point* ``(u_op, y_op)`` is what a linear model is linearised
  about: the model maps ``u − u_op`` to ``y − y_op``. ``"initial"`` takes each
  experiment's first sample (paper 000, section 4.1: "the initial temperature
  of the measurements has to be subtracted"), ``"mean"`` its means (MATLAB's
  ``detrend``), ``"none"`` zero (data already prepared, e.g. the spindle's
  temperature rises above ambient). Given *offsets* (:func:`check_offsets`,
  ``offsets={"inputs": {"P": 0.0}, "outputs": {"T": 20.0}}``) replace the
  mode's values of the signals they name, in every experiment; the others
  keep the mode's (mode ``"none"`` with offsets: the given values, zero for
  the rest). The FitResult stores the mode, the training values and the
  given offsets (``"given"``) in ``settings["operating_point"]``.
* :func:`predict` simulates (or predicts ``k_step`` ahead) an ``ss`` or
  ``foptd`` FitResult on a recording: the model's own operating point (stored
  in the fit's ``model_config``; older ``ss`` fits keep it in the settings) or
  the recording's, and the initial state ``x0`` = ``"estimate"`` (least
  squares on the recording's outputs), ``"steady"`` or ``"zero"``
  (``"auto"``: estimate when the outputs are there). Every command that shows
  a linear fit on data goes through it, so they agree; the diagnosis and other
  callers use it too. :func:`predict_fit` returns just the outputs,
  :func:`evaluate_fit` the metrics of :mod:`thermogym.identification.metrics`,
  :func:`simulate_recording` a recording (``thermogym simulate --params``).
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from thermogym.errors import ConfigError, IdentificationError, RecordingError
from thermogym.fitresult import FitResult, data_entry, load_fit
from thermogym.identification.metrics import fit_report
from thermogym.identification.prepare import check_identification_data
from thermogym.models.linear import X0_MODES, FOPTDModel, StateSpaceModel
from thermogym.models.process import discrete_realization
from thermogym.recording import Recording

__all__ = [
    "LINEAR_MODELS",
    "OPERATING_CHOICES",
    "OPERATING_POINTS",
    "X0_CHOICES",
    "Experiment",
    "Prediction",
    "check_offsets",
    "data_entries",
    "evaluate_fit",
    "exogenous_roles",
    "fit_model",
    "offset_arrays",
    "operating_point",
    "predict",
    "predict_fit",
    "signal_arrays",
    "signal_ranges",
    "simulate_recording",
]

#: Models :func:`predict` simulates: ``ss``, ``foptd`` and, through their exact
#: state-space realisation at the recording's period, the polynomial (ARX family)
#: and SOPDT models of :mod:`thermogym.identification.pem`.
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


def recording_list(recordings: Any, what: str) -> list[Recording]:
    """``recordings`` (one Recording or an iterable of them) as a list, or a clear error.

    A file name is the usual mistake: it would otherwise be taken apart into
    its characters.
    """
    if isinstance(recordings, Recording):
        return [recordings]
    if isinstance(recordings, str | bytes | os.PathLike) or not hasattr(recordings, "__iter__"):
        raise RecordingError(
            f"{what}: the recordings are a {type(recordings).__name__} "
            f"({repr(recordings)[:60]}); expected a Recording or a list of them (read files "
            "with thermogym.recording.read_recording)"
        )
    return list(recordings)


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
        also recordings with different sample periods, and an output that is
        constant in every recording.
    """
    recs = recording_list(recordings, what)
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
    for j, c in enumerate(outputs):  # a dead sensor or a wrong column: no method can fit it
        y = np.concatenate([e.y[:, j] for e in out])
        if np.ptp(y) <= 1e-12 * max(1.0, float(np.abs(y).max())):
            raise IdentificationError(
                f"{what}: output {c!r} is constant ({float(y[0]):g}) in every recording given; "
                "nothing to identify (check the column and that the inputs reach it)"
            )
    return out


def check_offsets(
    offsets: Mapping[str, Any] | None, inputs: Sequence[str], outputs: Sequence[str]
) -> dict[str, dict[str, float]]:
    """Given operating-point offsets, checked against a fit's signals.

    Parameters
    ----------
    offsets : mapping or None
        ``{"inputs": {NAME: VALUE}, "outputs": {NAME: VALUE}}`` (either part
        may be left out); the values in the signals' units.
    inputs, outputs : sequence of str
        The fit's exogenous and output columns.

    Returns
    -------
    dict
        ``{"inputs": {...}, "outputs": {...}}`` with float values (empty
        dicts for ``None``).

    Raises
    ------
    ConfigError
        An unknown key, a name that is not among ``inputs``/``outputs``, or
        a value that is not a finite number.

    Examples
    --------
    >>> check_offsets({"outputs": {"T": 20}}, ["P"], ["T"])
    {'inputs': {}, 'outputs': {'T': 20.0}}
    >>> check_offsets({"outputs": {"T": "warm"}}, ["P"], ["T"])
    Traceback (most recent call last):
    ...
    thermogym.errors.ConfigError: output offset of 'T' is 'warm'; expected a finite number
    """
    out: dict[str, dict[str, float]] = {"inputs": {}, "outputs": {}}
    if offsets is None:
        return out
    if not isinstance(offsets, Mapping):
        raise ConfigError(
            f"offsets is a {type(offsets).__name__}; expected a mapping "
            '{"inputs": {NAME: VALUE}, "outputs": {NAME: VALUE}}'
        )
    extra = [k for k in offsets if k not in out]
    if extra:
        raise ConfigError(f"offsets has key(s) {extra}; expected 'inputs' and/or 'outputs'")
    for part, names, what in (("inputs", inputs, "input"), ("outputs", outputs, "output")):
        given = offsets.get(part) or {}
        if not isinstance(given, Mapping):
            raise ConfigError(
                f"offsets[{part!r}] is a {type(given).__name__}; expected a mapping NAME -> value"
            )
        for name, value in given.items():
            if name not in names:
                raise ConfigError(
                    f"{what} offset names {name!r}, which is not an {what} of the fit; "
                    f"expected one of {list(names)}"
                )
            try:
                v = float(value)
            except (TypeError, ValueError):
                v = float("nan")
            if isinstance(value, bool) or not np.isfinite(v):
                raise ConfigError(
                    f"{what} offset of {name!r} is {value!r}; expected a finite number"
                )
            out[part][str(name)] = v
    return out


def offset_arrays(
    offsets: Mapping[str, Any] | None, inputs: Sequence[str], outputs: Sequence[str]
) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None:
    """Given offsets as arrays in column order, NaN where none is given (``None``: none).

    Examples
    --------
    >>> offset_arrays({"inputs": {"b": 1.0}}, ["a", "b"], ["y"])
    (array([nan,  1.]), array([nan]))
    """
    chk = check_offsets(offsets, inputs, outputs)
    if not chk["inputs"] and not chk["outputs"]:
        return None
    u = np.array([chk["inputs"].get(c, np.nan) for c in inputs], dtype=float)
    y = np.array([chk["outputs"].get(c, np.nan) for c in outputs], dtype=float)
    return u, y


def operating_point(
    u: NDArray[np.float64],
    y: NDArray[np.float64] | None,
    mode: str,
    given: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
    """Operating point ``(u_op, y_op)`` of one experiment.

    Parameters
    ----------
    u : ndarray, shape (T, m)
    y : ndarray, shape (T, p) or None
    mode : {"none", "initial", "mean", "rest"}
    given : (ndarray (m,), ndarray (p,)), optional
        Given offsets (:func:`offset_arrays`): a finite entry replaces the
        mode's value of its signal.

    Examples
    --------
    >>> u0, y0 = operating_point(np.array([[1.0], [3.0]]), np.array([[5.0], [7.0]]), "mean")
    >>> u0.tolist(), y0.tolist()
    ([2.0], [6.0])
    >>> given = (np.array([0.0]), np.array([np.nan]))  # the input's given, the output's not
    >>> u0, y0 = operating_point(np.array([[1.0], [3.0]]), np.array([[5.0], [7.0]]), "mean", given)
    >>> u0.tolist(), y0.tolist()
    ([0.0], [6.0])
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
        u_op, y_op = pick(u, "none"), pick(y, "initial")
    else:
        u_op, y_op = pick(u, mode), pick(y, mode)
    if given is not None:  # the given offsets replace the mode's values of their signals
        gu, gy = given
        assert u_op is not None
        u_op = np.where(np.isfinite(gu), gu, u_op)
        if y_op is not None:
            y_op = np.where(np.isfinite(gy), gy, y_op)
    return u_op, y_op  # type: ignore[return-value]


def _settings_op(fit: FitResult) -> dict[str, Any] | None:
    op = fit.settings.get("operating_point")
    if not isinstance(op, Mapping):
        return None
    return dict(op)


#: Initial-state choices of :func:`predict`: "auto" is "estimate" when the recording
#: has the outputs, else "steady".
X0_CHOICES: tuple[str, ...] = ("auto", *X0_MODES)
#: Operating-point choices of :func:`predict`.
OPERATING_CHOICES: tuple[str, ...] = ("auto", "fit", "recording")


@dataclass(frozen=True)
class Prediction:
    """Outputs of a fitted linear model on a recording, and how they were obtained.

    Attributes
    ----------
    outputs : ndarray, shape (T, p)
        Predicted outputs in the model's output order (absolute units).
    output_names : tuple of str
    x0 : str
        Initial-state mode used: ``"zero"``, ``"steady"`` or ``"estimate"``.
    state0 : ndarray, shape (n_x,)
        The initial state used.
    u_op, y_op : ndarray
        Operating point applied (absolute units).
    operating : str
        ``"fit"`` (the FitResult's) or ``"recording"`` (the recording's own).
    horizon : int or None
        Prediction horizon in samples (``None``: simulation).
    note : str
        How a requested horizon was treated, when not as asked.
    """

    outputs: NDArray[np.float64]
    output_names: tuple[str, ...]
    x0: str
    state0: NDArray[np.float64]
    u_op: NDArray[np.float64]
    y_op: NDArray[np.float64]
    operating: str
    horizon: int | None = None
    note: str = ""


def fit_model(
    fit: FitResult | str | Mapping[str, Any],
    *,
    u_op: NDArray[np.float64] | None = None,
    y_op: NDArray[np.float64] | None = None,
    dt: float | None = None,
    noise_model: bool = False,
) -> tuple[FOPTDModel | StateSpaceModel, NDArray[np.float64]]:
    """The model of an ``ss`` or ``foptd`` FitResult with its operating point, and theta.

    :meth:`FitResult.build_model` already applies the operating point stored
    in the fit (older ``ss`` fits keep it in ``settings["operating_point"]``
    and get it from there); ``u_op``/``y_op`` replace it (FOPTD: ``y_op``
    becomes the offsets ``y0``).

    A polynomial (``arx``, ``armax``, ``oe``, ``bj``) or ``sopdt`` fit is
    returned as its exact deterministic state-space realisation at period
    ``dt`` (default: the model's own, or the training period stored in the
    fit), with the operating point of ``settings["operating_point"]``;
    ``noise_model=True`` keeps the innovation gain ``K`` of an ARX, ARMAX or
    BJ fit at its own period (its noise model, for k-step predictions; the
    simulation and the initial-state estimate do not use ``K``).

    Returns
    -------
    model : FOPTDModel or StateSpaceModel
    theta : ndarray, shape (1, P)
    """
    fit = load_fit(fit)
    if fit.model not in LINEAR_MODELS:
        raise ConfigError(
            f"this needs a FitResult of a linear model {list(LINEAR_MODELS)}; this one is "
            f"{fit.model!r}"
        )
    model = fit.build_model()
    theta = fit.theta(model)
    if not isinstance(model, FOPTDModel | StateSpaceModel):
        return _realized(fit, model, theta, dt, u_op, y_op, noise_model=noise_model)
    if u_op is None and y_op is None:
        return model, theta  # type: ignore[return-value]
    cfg = dict(model.config())
    if u_op is not None:
        cfg["u_op"] = np.asarray(u_op, dtype=float).tolist()
    if isinstance(model, StateSpaceModel):
        if y_op is not None:
            cfg["y_op"] = np.asarray(y_op, dtype=float).tolist()
        return StateSpaceModel(**cfg), theta
    assert isinstance(model, FOPTDModel)
    new = FOPTDModel(**{**cfg, "offsets": True, "y0": cfg.get("y0", 0.0)})
    params = dict(zip(model.param_names, theta[0].tolist(), strict=True))
    if y_op is not None:
        for c, v in zip(model.output_names, np.asarray(y_op, dtype=float), strict=True):
            params[f"y0_{c}"] = float(v)
    return new, new.theta(params)


def _realized(
    fit: FitResult,
    model: Any,
    theta: NDArray[np.float64],
    dt: float | None,
    u_op: NDArray[np.float64] | None,
    y_op: NDArray[np.float64] | None,
    *,
    noise_model: bool = False,
) -> tuple[StateSpaceModel, NDArray[np.float64]]:
    """A polynomial or SOPDT fit as a :class:`StateSpaceModel` (with ``K`` if ``noise_model``)."""
    period = dt or getattr(model, "dt", None) or fit.settings.get("dt")
    if period is None:
        raise ConfigError(f"the {fit.model} fit stores no sample period; give dt")
    r, _ = discrete_realization(model, theta, float(period))
    if r.A.shape[1] == 0:  # a pure gain: one inert state
        A, B, C = np.zeros((1, 1)), np.zeros((1, r.B.shape[2])), np.zeros((r.C.shape[1], 1))
    else:
        A, B, C = r.A[0], r.B[0], r.C[0]
    # the noise model (ARX 1/A, ARMAX C/A, BJ C/D) is the realisation's innovation gain; it is
    # zero for OE and SOPDT and away from the model's own period (discrete_realization)
    K = r.K[0] if noise_model and r.A.shape[1] > 0 and np.any(r.K[0] != 0) else None
    op = fit.settings.get("operating_point") or {}
    exo, outs = list(model.exogenous_names), list(model.output_names)
    if u_op is None:
        u_op = np.array([float(op.get("inputs", {}).get(c, 0.0)) for c in exo])
    if y_op is None:
        y_op = np.array([float(op.get("outputs", {}).get(c, 0.0)) for c in outs])
    ss = StateSpaceModel.from_matrices(
        A,
        B,
        C,
        r.D[0],
        K,
        dt=float(period),
        inputs=[s.name for s in model.inputs],
        outputs=outs,
        disturbances=[s.name for s in model.disturbances],
        units={s.name: s.unit for s in model.signals},
        u_op=np.asarray(u_op, dtype=float),
        y_op=np.asarray(y_op, dtype=float),
    )
    return ss, ss.theta()


def predict(
    fit: FitResult | str | Mapping[str, Any],
    rec: Recording,
    *,
    x0: str = "auto",
    operating: str = "auto",
    k_step: int | None = None,
) -> Prediction:
    """Simulate a linear FitResult (``ss`` or ``foptd``) on a recording's inputs.

    Every command that shows a linear fit on data goes through here, so
    identify, simulate, compare, resid and the diagnosis give the same
    prediction of the same fit.

    Parameters
    ----------
    fit : FitResult, path or dict
        Made by :func:`~thermogym.identification.foptd.fit_foptd`,
        :func:`~thermogym.identification.n4sid.n4sid`,
        :class:`~thermogym.identification.rls.RecursiveFOPTD`, or any
        ``ss``/``foptd`` FitResult.
    rec : Recording
        Uniform, with the model's exogenous columns (any positive sample
        period), and optionally its outputs.
    x0 : {"auto", "estimate", "steady", "zero"}
        Initial state: ``"estimate"`` least squares on the recording's outputs
        (MATLAB ``compare``), ``"steady"`` (settled at the first input),
        ``"zero"`` (at rest at the operating point); ``"auto"``: estimate when
        the recording has every output, else steady.
    operating : {"auto", "fit", "recording"}
        Operating point: the FitResult's, or the recording's own as the fit's
        mode defines it (its first samples or means: the paper-000 convention
        of referring every experiment to its initial values). ``"auto"``:
        the recording's for fits made in the modes ``"initial"`` and
        ``"rest"`` (the model describes deviations from each experiment's
        start), the fit's otherwise. Offsets given to the identification
        (``settings["operating_point"]["given"]``) are kept either way.
        Fits whose offsets were estimated (mode ``"estimate"``) and
        recordings without outputs always use the fit's.
    k_step : int, optional
        Predict ``k_step`` samples ahead from the measured outputs (MATLAB
        ``compare(data, sys, k)``) with the state-space innovation gain; a
        model without a noise model (FOPTD, ``ss`` without ``K``) predicts as
        it simulates (an output-error structure), and ``note`` says so.
        Default: simulation (infinite horizon).

    Returns
    -------
    Prediction

    Examples
    --------
    >>> from thermogym.models.linear import FOPTDModel
    >>> from thermogym.identification.foptd import fit_foptd
    >>> m = FOPTDModel(["u"], ["y"], K=2.0, T=20.0, tau=3.0)
    >>> u = np.r_[np.zeros(10), np.ones(190)]
    >>> y = 5.0 + m.simulate(u[:, None], 1.0).outputs[0, :, 0]
    >>> rec = Recording(np.arange(200.0), {"u": u, "y": y})
    >>> res = fit_foptd(rec, ["u"], ["y"], max_delay=10)
    >>> p = predict(res.fit, rec)
    >>> p.x0, bool(np.allclose(p.outputs[:, 0], y, atol=1e-6))
    ('estimate', True)
    """
    fit = load_fit(fit)
    if x0 == "fit":  # the older spelling: the fit's own setting
        x0 = str(fit.settings.get("x0", "auto"))
    if x0 not in X0_CHOICES:
        raise ConfigError(f"x0 is {x0!r}; expected one of {list(X0_CHOICES)}")
    if operating not in OPERATING_CHOICES:
        raise ConfigError(f"operating is {operating!r}; expected one of {list(OPERATING_CHOICES)}")
    noise = k_step is not None  # the k-step predictor of a polynomial fit uses its noise model
    model, theta = fit_model(fit, dt=rec.dt, noise_model=noise)
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
    op = _settings_op(fit)
    used = "fit"
    mode_op = op.get("mode") if op else None
    if operating == "auto":
        operating = "recording" if mode_op in ("initial", "rest") else "fit"
    if operating == "recording" and y is not None and mode_op in OPERATING_POINTS:
        # the recording's own operating point, the fit's given offsets kept
        given = offset_arrays(op.get("given") if op else None, exo, outs)
        u_rec, y_rec = operating_point(u, y, str(mode_op), given)
        model, theta = fit_model(fit, u_op=u_rec, y_op=y_rec, dt=rec.dt, noise_model=noise)
        used = "recording"
    mode = x0
    if mode == "auto":
        mode = "estimate" if y is not None else "steady"
    if mode == "estimate" and y is None:
        raise RecordingError(
            f"x0='estimate' needs the output column(s) {outs} in recording "
            f"{rec.experiment_id!r}; it has {list(rec.columns)} (use x0='steady' or 'zero')"
        )
    horizon: int | None = None
    note = ""
    if k_step is not None:
        if isinstance(k_step, bool) or int(k_step) != k_step or k_step < 1:
            raise ConfigError(f"k_step is {k_step!r}; expected a whole number of samples >= 1")
        horizon = int(k_step)
        if y is None:
            raise RecordingError(
                f"a {horizon}-step prediction needs the measured outputs {outs} in recording "
                f"{rec.experiment_id!r}"
            )
        if not (isinstance(model, StateSpaceModel) and model.has_K):
            note = (
                f"{fit.model} fit without a noise model: its {horizon}-step prediction is its "
                "simulation (output-error structure)"
            )
        elif model.dt is not None and abs(model.dt - rec.dt) > 1e-9 * model.dt:
            raise RecordingError(
                f"a {horizon}-step prediction runs at the model's period {model.dt!r} s; "
                f"recording {rec.experiment_id!r} is sampled at {rec.dt!r} s (resample it)"
            )
        else:
            xi = model.start_state(mode, u, rec.dt, theta, y=y if mode == "estimate" else None)
            yk = model.predict(y, u, theta, x0=xi, horizon=horizon)[0]
            u_op, y_op = (a[0] for a in model.operating_point(theta))
            return Prediction(yk, tuple(outs), mode, xi[0], u_op, y_op, used, horizon)
    sim = model.simulate(
        u,
        rec.dt,
        theta,
        mode,
        y=y if mode == "estimate" else None,
        return_states=True,
        t0=float(rec.time[0]),
    )
    assert sim.states is not None
    u_op, y_op = (a[0] for a in model.operating_point(theta))
    return Prediction(
        sim.outputs[0], tuple(outs), mode, sim.states[0, 0].copy(), u_op, y_op, used, horizon, note
    )


def predict_fit(
    fit: FitResult | str | Mapping[str, Any],
    rec: Recording,
    *,
    x0: str = "auto",
    operating: str = "auto",
) -> NDArray[np.float64]:
    """Predicted outputs, shape (T, p), of :func:`predict`.

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
    return predict(fit, rec, x0=x0, operating=operating).outputs


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
    recs = recording_list(recordings, "evaluation")
    outs = list(fit.build_model().output_names)
    per: dict[str, Any] = {}
    vals: list[Any] = []  # each recording's MNRMSE
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


def signal_ranges(recordings: Sequence[Recording], names: Sequence[str]) -> dict[str, list[float]]:
    """Smallest and largest value of each named column over the recordings.

    Stored in FitResults as ``settings["signal_ranges"]``: environments scale
    actions and observations from them.

    Examples
    --------
    >>> rec = Recording(np.arange(3.0), {"u": np.array([1.0, 4.0, 2.0])})
    >>> signal_ranges([rec], ["u"])
    {'u': [1.0, 4.0]}
    """
    out = {}
    for c in names:
        v = np.concatenate([np.asarray(r[c], dtype=float) for r in recordings])
        v = v[np.isfinite(v)]
        out[c] = [float(v.min()), float(v.max())] if v.size else [float("nan")] * 2
    return out
