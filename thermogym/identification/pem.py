"""Prediction-error identification: ARX, ARMAX, OE, BJ, SOPDT and N4SID refinement.

What MATLAB's ``arx``, ``armax``, ``oe``, ``bj``, ``procest`` (``P2D``) and
``ssest`` do, for models that every thermogym tool then runs
(:mod:`thermogym.models.polynomial`, :mod:`thermogym.models.process`,
:class:`~thermogym.models.linear.StateSpaceModel`).

Method
------
* **ARX** is linear in its parameters: least squares on the regression
  ``y(t) = −Σ a_k y(t−k) + Σ_i Σ_l b_il u_i(t−nk_i−l) + e(t)`` (its
  prediction-error estimate exactly), covariance ``σ² (ΦᵀΦ)⁻¹``.
* **ARMAX, OE, BJ, SOPDT, state space**: the prediction-error criterion
  ``V(θ) = Σ_t ε(t, θ)²`` is minimised by ``scipy.optimize.least_squares``
  (trust-region reflective, bounds where a parameter has a sign). The error
  ``ε`` is the one-step prediction error of the model's Kalman predictor
  (``focus="prediction"``: ARMAX, BJ, as MATLAB) or the simulation error
  (``focus="simulation"``: OE, SOPDT and by default the refinement of
  N4SID, because what users do with these models — environments,
  controllers — is simulate them). In both the initial state of each
  experiment is eliminated by linear least squares at every evaluation
  (variable projection), so data need not start at rest. The Jacobian is
  taken by finite differences on a *batch* of parameter sets simulated in one
  compiled call (the batched kernels of :mod:`thermogym.models`). The
  parameter covariance is ``σ² (JᵀJ)⁺`` at the optimum.
* **Starting values**: ARMAX by Hannan-Rissanen (a long ARX gives the
  innovations, then one least squares with them as regressors); OE from ARX
  refined by Steiglitz-McBride iterations; BJ from the OE fit plus an ARMA
  noise model of its residuals; SOPDT from the FOPTD fit; state space from
  N4SID. Unstable starting polynomials are reflected into the unit circle.
* **Orders and delays** are chosen by cross-validation (:func:`select_orders`):
  the delays per input by ARX (all structures share them, as MATLAB's
  ``delayest``), then the order of each family on the other fold's
  simulation fit (MNRMSE, eq 6 of paper 001), the smallest order within
  ``tolerance`` of the best.

Why written here: SIPPY (LGPL-3.0; installed as a benchmark peer) exits the
interpreter (``sys.exit``) on bad input, prints warnings, solves OE/BJ with
CasADi/IPOPT, returns no parameter covariance and evaluates no initial state;
python-control has no identification. scipy's ``least_squares`` is the
well-kept solver underneath; the model structure, predictors and
cross-validation are thermogym's own so that every fit is a FitResult the
rest of the package runs.

This module holds :func:`pem` and :func:`refine`; the parts live beside it:
the solver in ``_pem_solver``, ARX and the starting values in ``_pem_arx``,
the fit of one family and its FitResult in ``_pem_fit``, the order selection
in ``_pem_orders`` and SOPDT in ``_pem_sopdt``. Every public name is
importable from here.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from thermogym._checks import choice, integer
from thermogym.errors import ConfigError
from thermogym.fitresult import FitResult, load_fit
from thermogym.identification._pem_arx import arx_ls
from thermogym.identification._pem_fit import (
    PEMResult,
    _advise,
    _fit_family,
    _fitresult,
    _orders_arg,
    _problem,
)
from thermogym.identification._pem_orders import select_orders
from thermogym.identification._pem_solver import (
    _Data,
    _offset,
    _residual_batch,
    _solve,
    simulation_fit,
)
from thermogym.identification._pem_sopdt import sopdt
from thermogym.identification.advice import structure_warnings
from thermogym.identification.linear_fit import signal_ranges
from thermogym.models.linear import StateSpaceModel
from thermogym.models.polynomial import STRUCTURES
from thermogym.recording import Recording

__all__ = [
    "FAMILIES",
    "FOCUS",
    "PEMResult",
    "arx_ls",
    "pem",
    "refine",
    "select_orders",
    "signal_ranges",
    "simulation_fit",
    "sopdt",
]

#: Families :func:`pem` identifies.
FAMILIES: tuple[str, ...] = ("arx", "armax", "oe", "bj")


#: Criteria of the iterative fits.
FOCUS: tuple[str, ...] = ("prediction", "simulation")


_DEFAULT_FOCUS = {
    "arx": "prediction",
    "armax": "prediction",
    "oe": "simulation",
    "bj": "prediction",
    "sopdt": "simulation",
    "ss": "simulation",
}


def pem(
    recordings: Recording | Sequence[Recording],
    inputs: Sequence[str] | str,
    outputs: Sequence[str] | str,
    family: str = "arx",
    *,
    na: Any = None,
    nb: Any = None,
    nc: Any = None,
    nd: Any = None,
    nf: Any = None,
    nk: Any = None,
    max_order: int = 6,
    max_delay: int = 10,
    folds: int = 2,
    tolerance: float = 1e-3,
    focus: str | None = None,
    disturbances: Sequence[str] | None = None,
    operating_point_mode: str = "mean",
    offsets: Mapping[str, Any] | None = None,
    validate: Recording | Sequence[Recording] = (),
    max_nfev: int = 60,
    expect: Mapping[str, int] | None = None,
) -> PEMResult:
    """Identify an ARX, ARMAX, OE or BJ model by the prediction-error method.

    Orders or delays left ``None`` are chosen by ``folds``-fold
    cross-validation on the training data (:func:`select_orders`); given ones
    are used as they are.

    Parameters
    ----------
    recordings : Recording or sequence
        Training experiments (uniform, finite).
    inputs, outputs : sequence of str
        Exogenous and output columns.
    family : {"arx", "armax", "oe", "bj"}
    na, nb, nc, nd, nf, nk : int or array_like, optional
        Orders (per output, or per output × input for ``nb``, ``nf``,
        ``nk``), as MATLAB's ``[na nb nc nd nf nk]``.
    max_order : int
        Largest order tried by the cross-validation.
    max_delay : int
        Largest input delay tried [samples].
    folds : int
        Folds of the cross-validation (recordings dealt round robin; a single
        recording is cut in ``folds`` parts).
    tolerance : float
        The smallest order within ``tolerance`` (MNRMSE fraction) of the best.
    focus : {"prediction", "simulation"}, optional
        Criterion (default: prediction for ARX/ARMAX/BJ, simulation for OE).
    disturbances : sequence of str, optional
        Which inputs are disturbances (default: the recording's roles).
    operating_point_mode : {"mean", "initial", "rest", "none"}
        Subtracted from each experiment (MATLAB's ``detrend`` is ``"mean"``).
    offsets : mapping, optional
        Given operating point ``{"inputs": {NAME: VALUE}, "outputs": {NAME:
        VALUE}}``: replaces the mode's value of each signal named and is
        stored in the FitResult as given (see
        :func:`~thermogym.identification.n4sid.n4sid`).
    validate : Recording or sequence
        Recordings for the FitResult's validation metrics.
    max_nfev : int
        Most residual evaluations of the iterative fits.
    expect : mapping, optional
        Declared gain signs for the ``gain_sign`` warning
        (:func:`~thermogym.identification.advice.parse_expect_sign`).

    Returns
    -------
    PEMResult
        Its FitResult holds the warnings of
        :mod:`~thermogym.identification.advice` (fit below zero, gain sign,
        order or delay at the edge of the search, flat cross-validation).

    Examples
    --------
    An OE system ``y = 0.5 q⁻² / (1 − 0.9 q⁻¹) u`` with white measurement noise:

    >>> from thermogym.models.polynomial import PolynomialModel
    >>> true = PolynomialModel(["u"], ["y"], structure="oe", nb=1, nf=1, nk=2)
    >>> th = true.theta({"b0_y": 0.5, "f1_y": -0.9})
    >>> rng = np.random.default_rng(1)
    >>> u = np.repeat(rng.choice([-1.0, 1.0], 100), 10)
    >>> y = true.simulate(u[:, None], 1.0, th).outputs[0, :, 0] + 0.1 * rng.normal(size=1000)
    >>> rec = Recording(np.arange(1000.0), {"u": u, "y": y})
    >>> res = pem(rec, ["u"], ["y"], "oe", nb=1, nf=1, nk=2)
    >>> [round(res.fit.parameters[k], 2) for k in ("b0_y", "f1_y")]
    [0.5, -0.9]
    """
    t0 = time.perf_counter()
    family = choice("family", family, FAMILIES, error=ConfigError)
    focus = (
        _DEFAULT_FOCUS[family]
        if focus is None
        else choice("focus", focus, FOCUS, error=ConfigError)
    )
    integer("max_order", max_order, lo=1, error=ConfigError)
    integer("max_delay", max_delay, lo=0, error=ConfigError)
    prob = _problem(
        recordings, inputs, outputs, disturbances, operating_point_mode, offsets, family.upper()
    )
    vals = [validate] if isinstance(validate, Recording) else list(validate)
    given = {"na": na, "nb": nb, "nc": nc, "nd": nd, "nf": nf, "nk": nk}
    has = STRUCTURES[family]
    for k, v in given.items():
        if v is not None and k not in ("nb", "nk") and k[1] not in has:
            raise ConfigError(
                f"{family.upper()} has no {k[1].upper()} polynomial; {k} must not be given"
            )
    p_, m_ = len(prob.outputs), len(prob.inputs) + len(prob.disturbances)
    for k, v in given.items():  # check given orders before any fitting
        if v is not None:
            shape = (p_, m_) if k in ("nb", "nf", "nk") else (p_,)
            _orders_arg(k, v, shape, 1 if k == "nb" else 0)
    need = [k for k in ("nb", "nk", *(f"n{x}" for x in has)) if given[k] is None]
    selection: dict[str, Any] = {}
    if need:
        sel = select_orders(
            prob,
            family,
            given,
            max_order=max_order,
            max_delay=max_delay,
            folds=folds,
            tolerance=tolerance,
            focus=focus,
            max_nfev=max_nfev,
        )
        given.update({k: sel["orders"][k] for k in need})
        selection = sel
    for k in ("na", "nc", "nd", "nf"):
        if given[k] is None:
            given[k] = 0
    model, theta, cov, info = _fit_family(family, prob, **given, focus=focus, max_nfev=max_nfev)  # type: ignore[arg-type]
    seconds = time.perf_counter() - t0
    settings = {
        "family": family,
        "orders": model.orders.to_dict(),
        "order_source": "cross-validation" if need else "given",
        "chosen_by_cv": need,
        "focus": "least squares" if family == "arx" else focus,
        "operating_point_mode": operating_point_mode,
        "fit_info": info,
        "seconds": seconds,
    }
    if selection:
        settings["cross_validation"] = selection
    fit = _fitresult(
        model,
        theta,
        cov,
        prob,
        vals,
        method=family,
        settings=settings,
        notes=f"{family.upper()} by the prediction-error method (thermogym.identification.pem)",
    )
    _advise(fit, prob, expect, max_delay=max_delay)
    return PEMResult(fit, model, theta, time.perf_counter() - t0, selection)


def _ss_covariance(
    model: StateSpaceModel,
    theta: NDArray[np.float64],
    jtj: NDArray[np.float64] | None,
    sigma2: float,
) -> NDArray[np.float64] | None:
    """Covariance of a fully parametrised state space at a PEM optimum, σ² (JᵀJ)⁻¹.

    Every entry of ``A``, ``B``, ``C`` (``D``, ``K``) is a parameter, so the
    realisation is not unique: ``T A T⁻¹, T B, C T⁻¹, D, T K`` fits as well
    for any invertible ``T``, and ``JᵀJ`` is singular along the ``n²``
    directions ``δA = E A − A E``, ``δB = E B``, ``δC = −C E``, ``δK = E K``.
    The inverse is taken on the complement of those directions (the local
    coordinates of McKelvey, Helmersson and Ribarits 2004, which MATLAB's
    ``ssest`` uses for its free parametrisation): a draw from it changes the
    input-output behaviour only as the data allow, and moves nothing along
    the similarity directions, whose spread the data do not determine.
    ``None`` when the solver gave no ``JᵀJ`` or the complement is singular.
    """
    if jtj is None:
        return None
    mats = model.matrices(theta[None])
    A, B, C = mats.A[0], mats.B[0], mats.C[0]
    n, P = A.shape[0], theta.size
    sl = model._sl
    tangents = np.zeros((P, n * n))
    for k in range(n * n):
        E = np.zeros((n, n))
        E[k // n, k % n] = 1.0
        tangents[sl["A"], k] = (E @ A - A @ E).ravel()
        tangents[sl["B"], k] = (E @ B).ravel()
        tangents[sl["C"], k] = (-C @ E).ravel()
        if "K" in sl:
            tangents[sl["K"], k] = (E @ mats.K[0]).ravel()
    U, S, _ = np.linalg.svd(tangents, full_matrices=True)
    rank = int(np.sum(S > S.max() * 1e-10)) if S.size else 0
    N = U[:, rank:]  # orthonormal basis of the identifiable directions
    M = N.T @ jtj @ N
    w = np.linalg.eigvalsh(M)
    if not N.shape[1] or w.min() <= w.max() * 1e-12:
        return None  # some behaviour the data do not determine: no honest covariance
    cov = sigma2 * N @ np.linalg.solve(M, N.T)
    return 0.5 * (cov + cov.T)


def refine(
    fit: FitResult,
    recordings: Recording | Sequence[Recording],
    *,
    focus: str = "simulation",
    validate: Recording | Sequence[Recording] = (),
    max_nfev: int = 40,
) -> PEMResult:
    """Refine a state-space FitResult by prediction-error minimisation (MATLAB ``ssest``).

    Every entry of ``A``, ``B``, ``C`` (and ``D`` when the model has it) is
    free, starting from ``fit`` (an N4SID result); the error is the
    simulation error (``focus="simulation"``, ``K`` dropped) or the one-step
    prediction error with ``K`` free too. The training data are those of
    ``fit``'s identification, with its operating point mode.

    Parameters
    ----------
    fit : FitResult
        Of model ``ss``.
    recordings : Recording or sequence
        Training data (the ones the fit was made from).
    focus : {"simulation", "prediction"}
    validate : Recording or sequence
    max_nfev : int

    Returns
    -------
    PEMResult
        A FitResult of method ``"ssest"`` whose settings keep the N4SID
        settings under ``"n4sid"``, with the parameter covariance of the
        prediction-error fit at its optimum (none when the N4SID start is
        kept because the refinement did not improve it stably).
    """
    t0 = time.perf_counter()
    fit = load_fit(fit)
    focus = choice("focus", focus, FOCUS, error=ConfigError)
    if fit.model != "ss":
        raise ConfigError(f"refine takes a state-space ('ss') FitResult; this one is {fit.model!r}")
    base = fit.build_model()
    assert isinstance(base, StateSpaceModel)
    mode = fit.settings.get(
        "operating_point_mode", fit.settings.get("operating_point", {}).get("mode", "none")
    )
    ins, dis, outs, units = base._cfg_names
    given = (fit.settings.get("operating_point") or {}).get("given")  # kept as given
    prob = _problem(recordings, list(ins) + list(dis), list(outs), list(dis), mode, given)
    vals = [validate] if isinstance(validate, Recording) else list(validate)
    mats = base.matrices(fit.theta(base))
    keep_k = focus == "prediction" and base.has_K
    model = StateSpaceModel.from_matrices(
        mats.A[0],
        mats.B[0],
        mats.C[0],
        mats.D[0] if base.has_D else None,
        mats.K[0] if keep_k else None,
        dt=base.dt,
        inputs=list(ins),
        outputs=list(outs),
        disturbances=list(dis),
        units=units,
    )
    th0 = model.nominal
    data = _Data(list(prob.us), list(prob.ys), prob.dt, _offset(prob))
    before = float(np.sum(_residual_batch(model, th0[None], data, focus) ** 2))
    sol = _solve(model, th0, np.arange(th0.size), data, focus, max_nfev=max_nfev)
    th = sol.theta
    if not np.all(np.abs(np.linalg.eigvals(model.matrices(th[None]).A[0])) < 1.0) or (
        sol.cost * 2 > before
    ):
        th = th0  # an unstable or worse end point: keep the N4SID model
        status = "kept the N4SID model (refinement did not improve it stably)"
        cov = None  # the N4SID start is no minimum of the error: no covariance from there
    else:
        status = sol.status
        cov = _ss_covariance(model, th, sol.jtj, sol.sigma2)
    mats = model.matrices(th[None])
    final = StateSpaceModel.from_matrices(
        mats.A[0],
        mats.B[0],
        mats.C[0],
        mats.D[0] if base.has_D else None,
        mats.K[0] if keep_k else None,
        dt=base.dt,
        inputs=list(ins),
        outputs=list(outs),
        disturbances=list(dis),
        units=units,
    )
    settings = {
        "focus": focus,
        "operating_point_mode": mode,
        "x0": "estimate",
        "n4sid": {k: v for k, v in fit.settings.items() if k not in ("operating_point",)},
        "cost_before": before,
        "cost_after": float(np.sum(_residual_batch(final, final.nominal[None], data, focus) ** 2)),
        "status": status,
        "nfev": sol.nfev,
        # the solver's end point kept although it stopped at max_nfev: warned (advice)
        "evaluation_limit_reached": bool(sol.at_limit and th is not th0),
        "order": base.n_states,
        "feedthrough": base.has_D,
    }
    out = _fitresult(
        final,
        final.nominal[None],
        cov,
        prob,
        vals,
        method="ssest",
        settings=settings,
        notes="N4SID start refined by prediction-error minimisation (as ssest)",
    )
    out.add_warnings(structure_warnings(out))  # a refinement stopped at its evaluation limit
    return PEMResult(out, final, final.nominal[None], time.perf_counter() - t0)
