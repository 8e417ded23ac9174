"""N4SID subspace identification of MIMO state-space models (paper 001, section 2.3.3).

Identifies the innovation form, eq (3) of ``001_6d13a2cd04f5de5e.txt``::

    x[k+1] = A x[k] + B u[k] + K e[k],    y[k] = C x[k] + D u[k] + e[k]   (3)

from one or several experiments, as MATLAB's ``n4sid`` does for the paper.

Algorithm
---------
1. *Scaling and operating point.* Each experiment's operating point is
   subtracted (``"none"`` by default: prepared spindle data are temperature
   rises above ambient) and every channel is divided by its RMS, so that a
   speed in rpm and temperatures in K weigh alike in the projections.
2. *Decimation.* Slow thermal plants sampled at 1 Hz have time constants of
   hours: a block Hankel matrix of a few dozen rows then spans seconds, the
   state is barely visible in it and the model is poor (on two rig days of
   the spindle, speed and ambient as inputs, an order-12 model identified at
   1 Hz validated at 99.2 %, the same identified at 1 min at 99.6 %, the
   noise floor of the data). ``decimate="auto"`` estimates the dominant time
   constant with a first-order ARX fit and keeps about 200 samples per time
   constant. Inputs and outputs are averaged over blocks of ``r`` samples
   (:func:`decimate_data`): with inputs held within a block this is an exact
   state-space model at ``r·dt`` with the same states, and the averaging cuts
   the noise without looking ahead. The dynamics are converted back exactly
   (``d2c_zoh`` → ``c2d_zoh``) and ``C``, ``D`` re-estimated on every sample,
   so FitResults always run at the recording's ``dt``.
3. *One decomposition.* The block Hankel matrix of past and future inputs and
   outputs (``2·i`` block rows, the columns of all experiments side by side,
   never across an experiment boundary) is reduced to its triangular factor
   ``H = L Qᵀ`` block by block (QR of ``[R; H_chunk]``), so memory does not
   grow with the number of samples. Every projection after that is an
   operation on the rows of ``L`` (``2i(m+p)`` columns wide):

   * the oblique projection ``O_i = Y_f /_{U_f} W_p`` (Van Overschee and
     De Moor 1996, Theorem 2) and ``O_{i+1}`` of the shifted partition;
   * the weighted matrix ``W₁ O_i W₂`` — ``"moesp"`` (``W₂ = Π_{U_f⊥}``,
     default), ``"cva"`` or ``"n4sid"`` (no weighting) — and its SVD. The
     singular values are those MATLAB's ``n4sid`` plots for the order choice.

4. *Every order from it.* For order ``n``: ``Γ = W₁⁻¹ U₁ S₁^{1/2}``;
   ``C`` = first block row of ``Γ``, ``A`` from the shift invariance
   ``Γ_↑ A = Γ_↓`` (least squares); unstable eigenvalues are mirrored into
   the unit circle in the real Schur form (``stable=True``). ``B``, ``D`` and
   each experiment's initial state then follow by linear least squares on the
   (decimated) data, i.e. minimising the *simulation* error given ``A`` and
   ``C`` (MATLAB's ``Focus="simulation"``); regressors are FFT convolutions of
   the inputs with ``C A^k``. ``bd="subspace"`` instead takes ``B``, ``D``
   from the state-sequence regression on ``L`` alone (no second pass over the
   data: for data that arrives in chunks). ``K`` is the Kalman gain of the
   state-sequence residual covariances (discrete Riccati equation).

Nothing is recomputed per order but these small matrices and the regression,
so a sweep over orders 1..30 with cross-validation costs seconds
(:mod:`thermogym.identification.crossval`).

References: P. Van Overschee, B. De Moor, *Subspace Identification for Linear
Systems*, Kluwer 1996 (algorithms 1-3, section 4.3); M. Verhaegen, V. Verdult,
*Filtering and System Identification*, CUP 2007 (PO-MOESP, chapter 9). The
implementation is written here because no maintained Python library does the
chunked one-decomposition, all-orders sweep: SIPPY and nfoursid form the full
Hankel matrices (``benchmarks/n4sid.py`` measures both).

This module checks the data and writes the FitResult; the steps live beside
it: decimation in ``_n4sid_decimation``, the Hankel reduction and the
decomposition in ``_n4sid_decomposition``, the least-squares steps that
complete a system of one order in ``_n4sid_system``, and the compiled loops in
``_n4sid_kernels``. Every name is importable from here.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from thermogym.errors import ConfigError
from thermogym.fitresult import FitResult
from thermogym.identification._n4sid_decimation import auto_decimation, decimate_data
from thermogym.identification._n4sid_decomposition import (
    WEIGHTINGS,
    HankelAccumulator,
    N4SIDDecomposition,
    decomposition_from_accumulator,
    n4sid_decompose,
)
from thermogym.identification._n4sid_kernels import simulate_ss
from thermogym.identification._n4sid_system import StateSpaceFit
from thermogym.identification.advice import check_fit
from thermogym.identification.linear_fit import (
    OPERATING_POINTS,
    check_offsets,
    data_entries,
    evaluate_fit,
    exogenous_roles,
    offset_arrays,
    operating_point,
    signal_arrays,
    signal_ranges,
)
from thermogym.models.linear import StateSpaceModel
from thermogym.recording import Recording

__all__ = [
    "WEIGHTINGS",
    "HankelAccumulator",
    "N4SIDDecomposition",
    "N4SIDProblem",
    "N4SIDResult",
    "StateSpaceFit",
    "auto_decimation",
    "decimate_data",
    "decomposition_from_accumulator",
    "n4sid",
    "n4sid_decompose",
    "prepare_problem",
    "simulate_ss",
    "system_fitresult",
]


@dataclass
class N4SIDResult:
    """Outcome of :func:`n4sid`.

    Attributes
    ----------
    fit : FitResult
        The ``ss`` FitResult.
    system : StateSpaceFit
    decomposition : N4SIDDecomposition
    order : int
    order_source : str
        ``"given"`` or ``"singular values"``.
    seconds : float
    """

    fit: FitResult
    system: StateSpaceFit
    decomposition: N4SIDDecomposition
    order: int
    order_source: str
    seconds: float


@dataclass(frozen=True)
class N4SIDProblem:
    """Checked training data of an N4SID call (names, arrays, operating points)."""

    inputs: list[str]
    disturbances: list[str]
    outputs: list[str]
    us: list[NDArray[np.float64]]
    ys: list[NDArray[np.float64]]
    ops: list[tuple[NDArray[np.float64], NDArray[np.float64]]]
    dt: float
    units: dict[str, str]
    recordings: list[Recording]
    mode: str = "none"  # the operating-point mode that made the deviations
    #: given offsets ``{"inputs": {...}, "outputs": {...}}`` (replace the mode's values)
    offsets: dict[str, dict[str, float]] = field(
        default_factory=lambda: {"inputs": {}, "outputs": {}}
    )

    def stored_operating_point(self) -> dict[str, Any]:
        """``settings["operating_point"]`` of a fit made from this problem.

        The mean over the experiments of what was subtracted; a given offset
        is stored as given.
        """
        exo = self.inputs + self.disturbances
        u_op = np.mean([op[0] for op in self.ops], axis=0)
        y_op = np.mean([op[1] for op in self.ops], axis=0)
        out: dict[str, Any] = {
            "mode": self.mode,
            "inputs": {c: self.offsets["inputs"].get(c, float(u_op[k])) for k, c in enumerate(exo)},
            "outputs": {
                c: self.offsets["outputs"].get(c, float(y_op[k]))
                for k, c in enumerate(self.outputs)
            },
        }
        if self.offsets["inputs"] or self.offsets["outputs"]:
            out["given"] = {k: dict(v) for k, v in self.offsets.items()}
        return out


def prepare_problem(
    recordings: Recording | Sequence[Recording],
    inputs: Sequence[str] | str,
    outputs: Sequence[str] | str,
    *,
    disturbances: Sequence[str] | None = None,
    operating_point_mode: str = "none",
    min_samples: int = 8,
    step_inputs: bool | None = None,
    offsets: Mapping[str, Any] | None = None,
    what: str = "N4SID",
) -> N4SIDProblem:
    """Check recordings and return deviation arrays in model column order.

    ``step_inputs`` accepts an input held constant at a non-zero value (a step
    from zero at ``t = 0``); default: with operating point ``"rest"`` only.
    ``offsets`` are given operating-point values that replace the mode's
    (:func:`~thermogym.identification.linear_fit.check_offsets`). ``what``
    names the method in messages.
    """
    inputs = [inputs] if isinstance(inputs, str) else list(inputs)
    outputs = [outputs] if isinstance(outputs, str) else list(outputs)
    if operating_point_mode not in OPERATING_POINTS:
        raise ConfigError(
            f"operating_point_mode is {operating_point_mode!r}; expected one of {OPERATING_POINTS}"
        )
    given_offsets = check_offsets(offsets, inputs, outputs)  # refused before any work
    given = offset_arrays(given_offsets, inputs, outputs)
    exps = signal_arrays(
        recordings,
        inputs,
        outputs,
        min_samples=min_samples,
        what=what,
        step_inputs=operating_point_mode == "rest" if step_inputs is None else step_inputs,
    )
    ins, dis = exogenous_roles(exps[0].recording, inputs, disturbances)
    order = [inputs.index(c) for c in ins + dis]
    us, ys, ops = [], [], []
    for e in exps:
        u_op, y_op = operating_point(e.u, e.y, operating_point_mode, given)
        assert y_op is not None
        us.append((e.u - u_op)[:, order])
        ys.append(e.y - y_op)
        ops.append((u_op[order], y_op))
    rec0 = exps[0].recording
    units = {c: rec0.units[c] for c in ins + dis + outputs if c in rec0.units}
    return N4SIDProblem(
        ins,
        dis,
        outputs,
        us,
        ys,
        ops,
        exps[0].dt,
        units,
        [e.recording for e in exps],
        operating_point_mode,
        given_offsets,
    )


def system_fitresult(
    system: StateSpaceFit,
    prob: N4SIDProblem,
    *,
    settings: dict[str, Any],
    validate: Sequence[Recording] = (),
    feedthrough: bool = False,
    noise_model: bool = True,
    arrays: dict[str, Any] | None = None,
    metrics: bool = True,
) -> FitResult:
    """The ``ss`` FitResult of an identified system (with train/validation metrics)."""
    model = system.model(
        prob.inputs,
        prob.outputs,
        disturbances=prob.disturbances,
        units=prob.units,
        feedthrough=feedthrough,
        noise_model=noise_model,
    )
    exo = prob.inputs + prob.disturbances
    st = dict(settings)
    st["operating_point"] = {
        **prob.stored_operating_point(),
        "mode": st.get("operating_point_mode", "none"),
    }
    u_op = np.array([st["operating_point"]["inputs"][c] for c in exo])
    y_op = np.array([st["operating_point"]["outputs"][c] for c in prob.outputs])
    if prob.recordings:  # the recorded ranges: what IdentifiedPlant-v0 scales by
        st.setdefault("signal_ranges", signal_ranges(prob.recordings, exo + prob.outputs))
    # the model itself carries the operating point: every simulation path applies it
    model = StateSpaceModel(**{**model.config(), "u_op": u_op.tolist(), "y_op": y_op.tolist()})
    arr = {
        "x0_train": [x.tolist() for x in system.x0],
        "eigenvalues_abs": np.abs(np.linalg.eigvals(system.A)).tolist(),
        **(arrays or {}),
    }
    fit = FitResult.from_model(
        model,
        method="n4sid",
        settings=st,
        arrays=arr,
        data=data_entries(prob.recordings, list(validate)),
        notes="paper 001 section 2.3.3: N4SID subspace identification, innovation form (3)",
    )
    if metrics:
        fit.metrics["train"] = evaluate_fit(fit, prob.recordings)
        if validate:
            fit.metrics["validation"] = evaluate_fit(fit, list(validate))
        fit.add_warnings(check_fit(fit, units=prob.units))
    return fit


def n4sid(
    recordings: Recording | Sequence[Recording],
    inputs: Sequence[str] | str,
    outputs: Sequence[str] | str,
    order: int | None = None,
    *,
    orders: Sequence[int] = range(1, 11),
    disturbances: Sequence[str] | None = None,
    horizon: int | None = None,
    decimate: int | str = "auto",
    weighting: str = "moesp",
    feedthrough: bool = False,
    x0: str = "estimate",
    bd: str = "regression",
    stable: bool = True,
    noise_model: bool = True,
    operating_point_mode: str = "none",
    offsets: Mapping[str, Any] | None = None,
    validate: Recording | Sequence[Recording] = (),
) -> N4SIDResult:
    """Identify a MIMO state-space model by N4SID (paper 001, section 2.3.3).

    Parameters
    ----------
    recordings : Recording or sequence
        Training experiments (uniform, finite: prepare them first).
    inputs : sequence of str
        Exogenous columns (manipulated inputs and measured disturbances).
    outputs : sequence of str
    order : int, optional
        Model order; chosen from the singular values over ``orders`` when
        omitted (:meth:`N4SIDDecomposition.suggest_order`; for a
        cross-validated order see
        :func:`thermogym.identification.crossval.cross_validate_order`).
    orders : sequence of int
        Candidate orders for the singular-value choice.
    disturbances : sequence of str, optional
        Which inputs are disturbances (default: the recording's roles).
    horizon, decimate, weighting
        See :func:`n4sid_decompose`.
    feedthrough : bool
        Estimate ``D``.
    x0 : {"estimate", "zero"}
        Estimate the initial state of each experiment (stored in the
        FitResult's ``arrays["x0_train"]`` and used for its metrics).
    bd : {"regression", "subspace"}
    stable : bool
        Project unstable poles into the unit circle.
    noise_model : bool
        Estimate the Kalman gain ``K`` (innovation form).
    operating_point_mode : {"none", "initial", "mean", "rest"}
    offsets : mapping, optional
        Given operating point, ``{"inputs": {NAME: VALUE}, "outputs":
        {NAME: VALUE}}``: replaces the mode's value of each signal named (in
        every experiment) and is stored in the FitResult as given
        (:func:`~thermogym.identification.linear_fit.check_offsets`).
    validate : Recording or sequence
        Validation recordings for the FitResult's metrics.

    Returns
    -------
    N4SIDResult

    Raises
    ------
    IdentificationError
        Too few samples for horizon and order, constant input, NaN data.

    Examples
    --------
    >>> from thermogym.models.linear import StateSpaceModel
    >>> true = StateSpaceModel.from_continuous([[-1 / 300, 0.0], [1 / 600, -1 / 600]],
    ...                                        [[1 / 300], [0.0]], [[1, 0], [0, 1]], dt=10.0,
    ...                                        inputs=["P"], outputs=["T1", "T2"])
    >>> u = np.repeat(np.random.default_rng(0).integers(0, 2, 200), 20)[:, None].astype(float)
    >>> y = true.simulate(u, 10.0).outputs[0]
    >>> rec = Recording(10.0 * np.arange(u.shape[0]), {"P": u[:, 0], "T1": y[:, 0],
    ...                 "T2": y[:, 1]})
    >>> res = n4sid(rec, ["P"], ["T1", "T2"], order=2)
    >>> res.fit.metrics["train"]["mnrmse"] > 0.999
    True
    """
    t0 = time.perf_counter()
    prob = prepare_problem(
        recordings,
        inputs,
        outputs,
        disturbances=disturbances,
        operating_point_mode=operating_point_mode,
        offsets=offsets,
    )
    vals = [validate] if isinstance(validate, Recording) else list(validate)
    max_order = int(order) if order is not None else max(orders)
    dec = n4sid_decompose(
        prob.us,
        prob.ys,
        prob.dt,
        horizon=horizon,
        max_order=max_order,
        decimate=decimate,
        weighting=weighting,
    )
    if order is None:
        order = dec.suggest_order(orders)
        source = "singular values"
    else:
        source = "given"
    system = dec.system(
        order, x0=x0, bd=bd, feedthrough=feedthrough, stable=stable, noise_model=noise_model
    )
    seconds = time.perf_counter() - t0
    settings = {
        "order": int(order),
        "order_source": source,
        "horizon": dec.horizon,
        "decimate": dec.decimate,
        "dt": dec.dt,
        "dt_identification": dec.dt * dec.decimate,
        "dominant_time_constant_s": dec.info.get("dominant_tau_s"),
        "weighting": weighting,
        "feedthrough": bool(feedthrough),
        "x0": x0,
        "bd": bd,
        "stable": bool(stable),
        "noise_model": bool(noise_model),
        "noise_model_status": system.info.get("noise_model"),
        "eigenvalues_moved": system.info.get("eigenvalues_moved", 0),
        "operating_point_mode": operating_point_mode,
        "u_scale": dec.u_scale.tolist(),
        "y_scale": dec.y_scale.tolist(),
        "seconds": seconds,
    }
    fit = system_fitresult(
        system,
        prob,
        settings=settings,
        validate=vals,
        feedthrough=feedthrough,
        noise_model=noise_model,
        arrays={"singular_values": dec.singular_values.tolist()},
    )
    return N4SIDResult(fit, system, dec, int(order), source, seconds)
