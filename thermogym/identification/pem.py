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
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, cast

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares
from scipy.signal import lfilter

from thermogym._checks import choice, integer
from thermogym.errors import ConfigError, IdentificationError
from thermogym.fitresult import FitResult
from thermogym.identification.advice import check_fit, structure_warnings
from thermogym.identification.linear_fit import data_entries, evaluate_fit, signal_ranges
from thermogym.identification.metrics import nrmse
from thermogym.identification.n4sid import N4SIDProblem, prepare_problem
from thermogym.models._blas import blas_threads
from thermogym.models._linear_kernels import _ss_predict_kernel, _ss_simulate_kernel
from thermogym.models.base import Model
from thermogym.models.linear import StateSpaceModel
from thermogym.models.polynomial import STRUCTURES, PolynomialModel
from thermogym.models.process import SOPDTModel, discrete_realization
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


# =================================================================== data
def _regressors(
    u: NDArray[np.float64], y: NDArray[np.float64], na: int, nb: Sequence[int], nk: Sequence[int]
) -> tuple[NDArray[np.float64], NDArray[np.float64], int]:
    """ARX regression of one output: rows t ≥ L, columns −y lags then u lags."""
    L = max([na] + [k + b - 1 for k, b in zip(nk, nb, strict=True)] + [1])
    T = y.shape[0]
    cols = [-y[L - k : T - k] for k in range(1, na + 1)]
    for i, (b, k) in enumerate(zip(nb, nk, strict=True)):
        cols += [u[L - k - l : T - k - l, i] for l in range(b)]
    return np.column_stack(cols) if cols else np.zeros((T - L, 0)), y[L:], L


def arx_ls(
    us: Sequence[NDArray[np.float64]],
    ys: Sequence[NDArray[np.float64]],
    na: int,
    nb: Sequence[int],
    nk: Sequence[int],
) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
    """Least-squares ARX of one output over several experiments.

    Parameters
    ----------
    us : sequence of ndarray (T, m)
    ys : sequence of ndarray (T,)
    na : int
    nb, nk : sequence of int, one per input

    Returns
    -------
    theta : ndarray
        ``a1..a_na`` then per input ``b0..b_{nb−1}`` (the order of
        :class:`~thermogym.models.polynomial.PolynomialModel`).
    cov : ndarray
        ``σ² (ΦᵀΦ)⁻¹``.
    sigma2 : float
        Residual variance.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> u = rng.normal(size=(500, 1))
    >>> y = lfilter([0, 0.5], [1, -0.8], u[:, 0])
    >>> th, cov, s2 = arx_ls([u], [y], 1, [1], [1])
    >>> th.round(6).tolist()
    [-0.8, 0.5]
    """
    rows, rhs = [], []
    for u, y in zip(us, ys, strict=True):
        Phi, t, _ = _regressors(u, y, na, nb, nk)
        rows.append(Phi)
        rhs.append(t)
    Phi = np.vstack(rows)
    t = np.concatenate(rhs)
    if Phi.shape[0] <= Phi.shape[1]:
        raise IdentificationError(
            f"ARX with {Phi.shape[1]} parameters needs more than {Phi.shape[0]} usable samples"
        )
    th = cast(NDArray[np.float64], np.linalg.lstsq(Phi, t, rcond=None)[0])  # (numpy's stubs:
    res = t - Phi @ th  # floating[Any] for float64 in and out)
    s2 = float(res @ res / max(Phi.shape[0] - Phi.shape[1], 1))
    cov = cast(NDArray[np.float64], s2 * np.linalg.pinv(Phi.T @ Phi))
    return th, cov, s2


def _reflect(poly: NDArray[np.float64], radius: float = 0.99) -> NDArray[np.float64]:
    """Monic polynomial in q⁻¹ with its roots outside the unit circle reflected inside."""
    if poly.size <= 1:
        return poly
    r = np.roots(poly)
    big = np.abs(r) >= radius
    if not big.any():
        return poly
    r = np.where(big, radius / np.conj(r) * np.abs(r) / np.maximum(np.abs(r), 1e-12), r)
    r = np.where(np.abs(r) >= radius, r / np.abs(r) * radius, r)
    return np.real(np.poly(r))


# ============================================================ evaluation
def _as_ss(model: Model, theta: NDArray[np.float64], dt: float) -> StateSpaceModel:
    """One parameter set of a linear model as a deterministic state-space model."""
    r, _ = discrete_realization(model, theta, dt)
    n = r.A.shape[1]
    if n == 0:
        A, B, C = np.zeros((1, 1)), np.zeros((1, r.B.shape[2])), np.zeros((r.C.shape[1], 1))
    else:
        A, B, C = r.A[0], r.B[0], r.C[0]
    return StateSpaceModel.from_matrices(A, B, C, r.D[0], dt=dt)


def simulation_fit(
    model: Model,
    theta: NDArray[np.float64],
    us: Sequence[NDArray[np.float64]],
    ys: Sequence[NDArray[np.float64]],
    dt: float,
) -> tuple[float, NDArray[np.float64]]:
    """MNRMSE of a simulation with the initial state estimated (as MATLAB ``compare``).

    Returns the mean over experiments and the per-output NRMSE (mean over
    experiments), on deviation data.
    """
    with blas_threads(1):
        return _simulation_fit(model, theta, us, ys, dt)


def _simulation_fit(model, theta, us, ys, dt):  # type: ignore[no-untyped-def]
    ss = _as_ss(model, theta, dt)
    per = []
    for u, y in zip(us, ys, strict=True):
        try:
            x0 = ss.estimate_x0(u, y)
            yh = ss.simulate(u, dt, None, x0, strict=False).outputs[0]
        except Exception:
            per.append(np.full(y.shape[1], -np.inf))
            continue
        with np.errstate(all="ignore"):  # an unstable candidate overflows: scored -inf
            f = np.atleast_1d(nrmse(y.T, yh.T))
        per.append(np.where(np.isfinite(f), f, -np.inf))
    p = np.mean(np.stack(per), axis=0)
    return float(np.mean(p)), p


# ======================================================== the PEM solver
@dataclass
class _Data:
    us: list[NDArray[np.float64]]
    ys: list[NDArray[np.float64]]  # (T, p) each
    dt: float
    offset: bool = False  # a constant output offset per experiment besides x0 (see below)


def _offset(mode: str) -> bool:
    """Whether simulation-error fits about operating point ``mode`` estimate an output offset.

    Only about a record's mean: the mean of a record that does not average to
    equilibrium (it starts from rest, or ends in a transient) is not the
    model's rest value, and the difference is a constant the initial state
    cannot hold. The other modes subtract a rest value (``"rest"``,
    ``"initial"``) or nothing (``"none"``): there the level carries the static
    gain, and a free offset lets the model trade the one against the other.
    """
    return mode == "mean"


def _residual_batch(
    model: Model, theta: NDArray[np.float64], data: _Data, focus: str
) -> NDArray[np.float64]:
    """Errors of a batch of parameter sets, initial states projected out, shape (B, N)."""
    Bt = theta.shape[0]
    r, _H = discrete_realization(model, theta, data.dt)
    n = r.A.shape[1]
    p = r.C.shape[1]
    At, Bt_, Ct, Dt = (np.ascontiguousarray(np.swapaxes(a, 1, 2)) for a in (r.A, r.B, r.C, r.D))
    Kt = np.ascontiguousarray(np.swapaxes(r.K, 1, 2))
    out = []
    for u, y in zip(data.us, data.ys, strict=True):
        T = u.shape[0]
        ub = np.ascontiguousarray(u[None])
        yb = np.ascontiguousarray(y[None])
        # forced response from x = 0, and the free responses of the n unit states
        forced = np.empty((Bt, T, p))
        if focus == "simulation":
            _ss_simulate_kernel(
                At, Bt_, Ct, Dt, ub, np.zeros((Bt, n)), 1, forced, np.empty((1, 1, 1)), False
            )
        else:
            _predict(r, At, Bt_, Ct, Dt, Kt, ub, yb, np.zeros((Bt, n)), forced)
        e = y[None] - forced  # (B, T, p)
        if n:
            eye = np.tile(np.eye(n), (Bt, 1))  # (B·n, n)
            rep = lambda a: np.repeat(a, n, axis=0)  # noqa: E731
            free = np.empty((Bt * n, T, p))
            zu = np.zeros((1, T, u.shape[1]))
            if focus == "simulation":
                _ss_simulate_kernel(
                    rep(At),
                    rep(Bt_),
                    rep(Ct),
                    rep(Dt),
                    zu,
                    eye,
                    1,
                    free,
                    np.empty((1, 1, 1)),
                    False,
                )
            else:
                zy = np.zeros((1, T, p))
                rr = type(r)(*(rep(a) for a in r))
                _predict(rr, rep(At), rep(Bt_), rep(Ct), rep(Dt), rep(Kt), zu, zy, eye, free)
            O = free.reshape(Bt, n, T * p).transpose(0, 2, 1)  # (B, T·p, n)
        else:
            O = np.zeros((Bt, T * p, 0))
        if focus == "simulation" and data.offset:
            # about a record's mean (only, see _offset): a constant output offset per
            # experiment is projected out with the initial state. Not about a rest value:
            # a free offset there lets the model trade its static gain against it on
            # records dominated by one slow transient (the TCLab MIMO runs, "rest": the
            # refined state space fell from 82 % to 27-58 % held-out, the OE model chosen
            # by `identify auto` to 43 %).
            off = np.tile(np.eye(p), (T, 1))  # (T·p, p)
            O = np.concatenate([O, np.broadcast_to(off, (Bt, T * p, p))], axis=2)
        if O.shape[2]:
            with np.errstate(all="ignore"):
                for b in range(Bt):
                    Ob = O[b]
                    eb = e[b].reshape(-1)
                    if not (np.isfinite(Ob).all() and np.isfinite(eb).all()):
                        continue
                    x0 = np.linalg.lstsq(Ob, eb, rcond=1e-10)[0]
                    e[b] = (eb - Ob @ x0).reshape(T, p)
        out.append(e.reshape(Bt, -1))
    res = np.concatenate(out, axis=1)
    bad = ~np.isfinite(res)
    if bad.any():  # an unstable parameter set: a large error the solver steps back from
        res[bad] = 1e8
    return np.clip(res, -1e8, 1e8)


def _predict(r, At, Bt_, Ct, Dt, Kt, u, y, x0, out):  # type: ignore[no-untyped-def]
    """One-step Kalman predictor of a batch (the kernel of StateSpaceModel.predict)."""
    Bt, n = r.A.shape[0], r.A.shape[1]
    # horizon 1: A^{h−1} = I and A^{h−1} B = B (transposed, as the kernel takes them)
    eye = np.ascontiguousarray(np.broadcast_to(np.eye(n), (Bt, n, n)))
    _ss_predict_kernel(At, Bt_, Ct, Dt, Kt, eye, Bt_, u, y, np.ascontiguousarray(x0), 1, out)


@dataclass
class _Solution:
    theta: NDArray[np.float64]
    cov: NDArray[np.float64]
    sigma2: float
    cost: float
    nfev: int
    status: str


def _solve(
    model: Model,
    theta0: NDArray[np.float64],
    free: NDArray[np.int64],
    data: _Data,
    focus: str,
    *,
    lower: NDArray[np.float64] | None = None,
    upper: NDArray[np.float64] | None = None,
    max_nfev: int = 100,
) -> _Solution:
    """Minimise the prediction/simulation error over the parameters ``free``."""
    base = model.theta(theta0)[0].copy()
    x0 = base[free].copy()
    lo = np.full(free.size, -np.inf) if lower is None else lower
    hi = np.full(free.size, np.inf) if upper is None else upper
    x0 = np.minimum(np.maximum(x0, lo), hi)
    scale = np.maximum(np.abs(x0), 1e-3)

    def full(xs: NDArray[np.float64]) -> NDArray[np.float64]:
        th = np.repeat(base[None], xs.shape[0], axis=0)
        th[:, free] = xs
        return th

    def fun(x: NDArray[np.float64]) -> NDArray[np.float64]:
        return _residual_batch(model, full(x[None]), data, focus)[0]

    def jac(x: NDArray[np.float64]) -> NDArray[np.float64]:
        # forward differences, all perturbed sets simulated in one batched call
        h = 1e-6 * np.maximum(np.abs(x), scale)
        step = np.where(x + h > hi, -h, h)
        X = np.repeat(x[None], free.size + 1, axis=0)
        X[1:] += np.diag(step)
        R = _residual_batch(model, full(X), data, focus)
        return ((R[1:] - R[0]) / step[:, None]).T

    try:
        with blas_threads(1):  # small matrices: extra BLAS threads only spin
            sol = least_squares(
                fun,
                x0,
                jac=jac,
                bounds=(lo, hi),
                x_scale=scale,
                method="trf",
                max_nfev=max_nfev,
                xtol=1e-10,
                ftol=1e-10,
            )
    except ValueError as e:
        raise IdentificationError(f"prediction-error minimisation failed: {e}") from e
    th = full(sol.x[None])[0]
    N = sol.fun.size
    s2 = float(sol.fun @ sol.fun / max(N - free.size, 1))
    J = sol.jac
    cov = s2 * np.linalg.pinv(J.T @ J)
    return _Solution(th, cov, s2, float(sol.cost), int(sol.nfev), str(sol.message))


# ======================================================= initial values
def _hannan_rissanen(
    u: Sequence[NDArray[np.float64]],
    y: Sequence[NDArray[np.float64]],
    na: int,
    nb: Sequence[int],
    nk: Sequence[int],
    nc: int,
) -> NDArray[np.float64]:
    """ARMAX start: long-ARX innovations as extra regressors (Hannan-Rissanen)."""
    nlong = max(na, nc, *nb) * 3 + 2
    th, _, _ = arx_ls(u, y, nlong, [nlong] * len(nb), nk)
    es = []
    for ue, ye in zip(u, y, strict=True):
        Phi, t, L = _regressors(ue, ye, nlong, [nlong] * len(nb), nk)
        es.append(np.r_[np.zeros(L), t - Phi @ th])
    # regress y on −y lags, u lags and ê lags: an ARX with ê as an extra input
    ue2 = [np.column_stack([ue, ee]) for ue, ee in zip(u, es, strict=True)]
    th2, _, _ = arx_ls(ue2, y, na, [*nb, nc], [*nk, 1])
    a = th2[:na]
    c = th2[-nc:] if nc else np.zeros(0)
    c = _reflect(np.r_[1.0, c])[1:]
    return np.r_[a, th2[na : len(th2) - nc], c]


def _steiglitz_mcbride(
    u: Sequence[NDArray[np.float64]],
    y: Sequence[NDArray[np.float64]],
    nf: int,
    nb: Sequence[int],
    nk: Sequence[int],
    iterations: int = 5,
) -> tuple[NDArray[np.float64], list[NDArray[np.float64]]]:
    """OE start with one common denominator: ARX, then LS on data prefiltered by 1/F."""
    th, _, _ = arx_ls(u, y, nf, nb, nk)
    F = _reflect(np.r_[1.0, th[:nf]])
    bs = th[nf:]
    for _ in range(iterations):
        uf = [lfilter([1.0], F, ue, axis=0) for ue in u]
        yf = [lfilter([1.0], F, ye) for ye in y]
        th, _, _ = arx_ls(uf, yf, nf, nb, nk)
        Fn = _reflect(np.r_[1.0, th[:nf]])
        if not np.all(np.isfinite(Fn)):
            break
        F, bs = Fn, th[nf:]
    splits = np.cumsum(nb)[:-1]
    return F, np.split(bs, splits)


# =========================================================== public API
@dataclass
class PEMResult:
    """Outcome of :func:`pem`, :func:`sopdt` or :func:`refine`.

    Attributes
    ----------
    fit : FitResult
    model : Model
    theta : ndarray, shape (1, P)
    seconds : float
    selection : dict, optional
        The cross-validation that chose orders and delays.
    """

    fit: FitResult
    model: Model
    theta: NDArray[np.float64]
    seconds: float
    selection: dict[str, Any] = field(default_factory=dict)


def _problem(
    recordings: Recording | Sequence[Recording],
    inputs: Sequence[str] | str,
    outputs: Sequence[str] | str,
    disturbances: Sequence[str] | None,
    operating_point_mode: str,
) -> N4SIDProblem:
    return prepare_problem(
        recordings,
        inputs,
        outputs,
        disturbances=disturbances,
        operating_point_mode=operating_point_mode,
        min_samples=8,
    )


def _orders_arg(name: str, value: Any, shape: tuple[int, ...], lo: int) -> NDArray[np.int64]:
    a = np.asarray(value)
    try:
        a = np.broadcast_to(a, shape)
    except ValueError:
        raise ConfigError(
            f"{name} has shape {np.shape(value)}; expected a whole number or {shape}"
        ) from None
    return np.array(
        [integer(name, v, lo=lo, error=ConfigError) for v in a.ravel()], dtype=np.int64
    ).reshape(shape)


def _fit_family(
    family: str,
    prob: N4SIDProblem,
    *,
    na: Any,
    nb: Any,
    nc: Any,
    nd: Any,
    nf: Any,
    nk: Any,
    focus: str,
    max_nfev: int,
) -> tuple[PolynomialModel, NDArray[np.float64], NDArray[np.float64], dict[str, Any]]:
    """Fit one polynomial family with fixed orders on deviation data: model, θ, cov, info."""
    p, m = len(prob.outputs), len(prob.inputs) + len(prob.disturbances)
    o = {
        "na": _orders_arg("na", na, (p,), 0),
        "nb": _orders_arg("nb", nb, (p, m), 1),
        "nc": _orders_arg("nc", nc, (p,), 0),
        "nd": _orders_arg("nd", nd, (p,), 0),
        "nf": _orders_arg("nf", nf, (p, m), 0),
        "nk": _orders_arg("nk", nk, (p, m), 0),
    }
    has = STRUCTURES[family]
    kw = {k: v for k, v in o.items() if k in ("nb", "nk") or k[1] in has}
    model = PolynomialModel(
        prob.inputs,
        prob.outputs,
        structure=family,
        disturbances=prob.disturbances,
        units=prob.units,
        dt=prob.dt,
        **{k: v.tolist() for k, v in kw.items()},
    )
    P = len(model.param_names)
    theta = np.zeros(P)
    cov = np.zeros((P, P))
    info: dict[str, Any] = {"outputs": {}}
    for j, out in enumerate(prob.outputs):
        ys = [y[:, j] for y in prob.ys]
        nbj, nkj = o["nb"][j].tolist(), o["nk"][j].tolist()
        if family == "arx":
            th, cj, s2 = arx_ls(prob.us, ys, int(o["na"][j]), nbj, nkj)
            info["outputs"][out] = {"sigma2": s2, "method": "least squares"}
        else:
            sub = PolynomialModel(
                prob.inputs,
                [out],
                structure=family,
                disturbances=prob.disturbances,
                dt=prob.dt,
                **{k: v[j : j + 1].tolist() for k, v in kw.items()},
            )
            th0 = _start(family, prob.us, ys, o, j)
            data = _Data(list(prob.us), [y[:, None] for y in ys], prob.dt, _offset(prob.mode))
            sol = _solve(sub, th0, np.arange(th0.size), data, focus, max_nfev=max_nfev)
            th, cj = sol.theta, sol.cov
            info["outputs"][out] = {"sigma2": sol.sigma2, "nfev": sol.nfev, "status": sol.status}
        cols = _columns(model, j)
        theta[cols] = th
        cov[np.ix_(cols, cols)] = cj
    return model, theta[None], cov, info


def _columns(model: PolynomialModel, j: int) -> NDArray[np.int64]:
    """Theta columns of output ``j`` in the sub-model's order (a, b/f per input, c, d)."""
    cols = list(model._ia[j])
    for i in range(model.n_inputs):
        cols += model._ib[j][i] + model._if[j][i]
    cols += model._ic[j] + model._id[j]
    return np.array(cols, dtype=np.int64)


def _start(family: str, us, ys, o, j) -> NDArray[np.float64]:  # type: ignore[no-untyped-def]
    nb, nk = o["nb"][j].tolist(), o["nk"][j].tolist()
    if family == "armax":
        return _hannan_rissanen(us, ys, int(o["na"][j]), nb, nk, int(o["nc"][j]))
    nfs = o["nf"][j].tolist()
    nfc = max(nfs)
    F, bs = _steiglitz_mcbride(us, ys, nfc, nb, nk)
    parts = []
    for i, b in enumerate(bs):
        parts += [b, F[1 : nfs[i] + 1] if nfs[i] <= nfc else np.zeros(nfs[i])]
    th = np.concatenate(parts)
    if family == "oe":
        return th
    # BJ: an ARMA(nd, nc) of the OE residuals by Hannan-Rissanen
    nc, nd = int(o["nc"][j]), int(o["nd"][j])
    res = []
    for u, y in zip(us, ys, strict=True):
        yh = sum(
            lfilter(np.r_[np.zeros(k), b], F, u[:, i])
            for i, (b, k) in enumerate(zip(bs, nk, strict=True))
        )
        res.append(y - yh)
    dummy = [np.zeros((r.size, 0)) for r in res]
    if nd == 0 and nc == 0:
        return th
    arma = _hannan_rissanen(dummy, res, nd, [], [], nc) if nd else np.zeros(0)
    if nd == 0:
        c = np.zeros(nc)
        d = np.zeros(0)
    else:
        d = _reflect(np.r_[1.0, arma[:nd]])[1:]
        c = arma[nd:]
    return np.r_[th, c, d]


def _fitresult(
    model: Model,
    theta: NDArray[np.float64],
    cov: NDArray[np.float64] | None,
    prob: N4SIDProblem,
    validate: Sequence[Recording],
    *,
    method: str,
    settings: dict[str, Any],
    notes: str,
) -> FitResult:
    exo = prob.inputs + prob.disturbances
    st = dict(settings)
    st["operating_point"] = {
        "mode": st.get("operating_point_mode", "mean"),
        "inputs": {c: float(np.mean([op[0][k] for op in prob.ops])) for k, c in enumerate(exo)},
        "outputs": {
            c: float(np.mean([op[1][k] for op in prob.ops])) for k, c in enumerate(prob.outputs)
        },
    }
    st.setdefault("x0", "estimate")
    if isinstance(model, StateSpaceModel):  # the state space carries its operating point
        model = StateSpaceModel(
            **{
                **model.config(),
                "u_op": [st["operating_point"]["inputs"][c] for c in exo],
                "y_op": [st["operating_point"]["outputs"][c] for c in prob.outputs],
            }
        )
    st["signal_ranges"] = signal_ranges(prob.recordings, exo + prob.outputs)
    kwargs: dict[str, Any] = {}
    if cov is not None:
        se = np.sqrt(np.clip(np.diag(cov), 0.0, None))
        kwargs["stderr"] = dict(zip(model.param_names, se.tolist(), strict=True))
        kwargs["covariance"] = (0.5 * (cov + cov.T)).tolist()
        kwargs["covariance_names"] = list(model.param_names)
    th = theta[0]
    bounds = {
        n: [float(v - 10 * abs(v) - 1), float(v + 10 * abs(v) + 1)]
        for n, v in zip(model.param_names, th, strict=True)
    }
    for prm in model.parameters:  # keep the model's physical bounds (time constants > 0, ...)
        if prm.lower >= 0 and bounds[prm.name][0] < 0:
            bounds[prm.name][0] = (
                0.0
                if prm.unit == "s" and prm.name.startswith("tau")
                else (float(th[model.param_index(prm.name)]) / 1000.0)
            )
    fit = FitResult.from_model(
        model,
        th,
        method=method,
        settings=st,
        bounds=bounds,
        data=data_entries(prob.recordings, list(validate)),
        notes=notes,
        **kwargs,
    )
    fit.metrics["train"] = evaluate_fit(fit, prob.recordings)
    if validate:
        fit.metrics["validation"] = evaluate_fit(fit, list(validate))
    return fit


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
    prob = _problem(recordings, inputs, outputs, disturbances, operating_point_mode)
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


def _advise(
    fit: FitResult, prob: N4SIDProblem, expect: Mapping[str, int] | None, **kw: Any
) -> None:
    """Store the warnings of :mod:`.advice` in ``fit`` (the command line prints them)."""
    record_s = max(u.shape[0] for u in prob.us) * prob.dt
    fit.add_warnings(
        check_fit(fit, units=prob.units, expect=expect)
        + structure_warnings(fit, record_s=record_s, **kw)
    )


# ==================================================== cross-validation
def _fold_problems(prob: N4SIDProblem, k: int) -> list[tuple[list, list]]:  # type: ignore[type-arg]
    """``k`` folds of deviation data: experiments round robin, or one cut in parts."""
    k = integer("folds", k, lo=2, error=ConfigError)
    if len(prob.us) >= k:
        return [(prob.us[f::k], prob.ys[f::k]) for f in range(k)]
    if len(prob.us) == 1:
        T = prob.us[0].shape[0]
        edges = np.linspace(0, T, k + 1).round().astype(int)
        return [([prob.us[0][a:b]], [prob.ys[0][a:b]]) for a, b in itertools.pairwise(edges)]
    raise ConfigError(
        f"{k} folds from {len(prob.us)} recordings: give 1 or at least {k} recordings"
    )


def _sub_problem(prob: N4SIDProblem, us: list, ys: list) -> N4SIDProblem:  # type: ignore[type-arg]
    return N4SIDProblem(
        prob.inputs,
        prob.disturbances,
        prob.outputs,
        us,
        ys,
        prob.ops[: len(us)],
        prob.dt,
        prob.units,
        prob.recordings,
        prob.mode,
    )


def _cv_score(fold_data, fit_fn, dt) -> tuple[float, NDArray[np.float64]]:  # type: ignore[no-untyped-def]
    """Mean over ordered fold pairs (i ≠ j) of the simulation fit of model i on fold j."""
    k = len(fold_data)
    scores, per = [], []
    for i in range(k):
        try:
            model, theta = fit_fn(*fold_data[i])
        except (IdentificationError, np.linalg.LinAlgError, ValueError):
            return -np.inf, np.array([-np.inf])
        for j in range(k):
            if j == i:
                continue
            s, pj = simulation_fit(model, theta, fold_data[j][0], fold_data[j][1], dt)
            scores.append(s)
            per.append(pj)
    return float(np.mean(scores)), np.mean(np.stack(per), axis=0)


def select_orders(
    prob: N4SIDProblem,
    family: str,
    given: dict[str, Any] | None = None,
    *,
    max_order: int = 6,
    max_delay: int = 10,
    folds: int = 2,
    tolerance: float = 1e-3,
    focus: str = "simulation",
    max_nfev: int = 60,
) -> dict[str, Any]:
    """Orders and delays of a polynomial family by k-fold cross-validation.

    1. Delays ``nk`` per input (when not given): ARX models of order
       ``min(2, max_order)`` on each fold, every input's delay scanned over
       ``0..max_delay`` in turn (two passes), scored by the simulation fit on
       the other folds. For ARX itself (cheap) the delays are searched so at
       every order ``n`` and the order chosen over each order's best delays.
    2. Order ``n = 1..max_order`` of the family with the polynomials tied
       (ARX ``na = nb = n``; ARMAX also ``nc = n``; OE ``nb = nf = n``; BJ
       ``nb = nf = n``, ``nc = nd = min(n, 2)``), scored the same way; the
       smallest ``n`` within ``tolerance`` of the best is kept (the rule of
       :class:`~thermogym.identification.crossval.OrderCV`).

    Returns
    -------
    dict
        ``orders`` (na, nb, nc, nd, nf, nk as lists), ``delay_scores``,
        ``order_scores`` (VA per order), ``best_order``, ``chosen_order``.
    """
    given = dict(given or {})
    fd = _fold_problems(prob, folds)
    p, m = len(prob.outputs), len(prob.inputs) + len(prob.disturbances)
    out: dict[str, Any] = {"folds": len(fd), "tolerance": tolerance}

    def arx_fit(n: int, nk: NDArray[np.int64]) -> Callable[..., Any]:
        def fit(us, ys):  # type: ignore[no-untyped-def]
            sub = _sub_problem(prob, us, ys)
            mdl, th, _, _ = _fit_family(
                "arx",
                sub,
                na=n,
                nb=n,
                nc=0,
                nd=0,
                nf=0,
                nk=nk,
                focus="prediction",
                max_nfev=max_nfev,
            )
            return mdl, th

        return fit

    def delay_search(n0: int) -> tuple[NDArray[np.int64], float, dict[str, list[float]]]:
        # each input's delay over 0..max_delay in turn, the others fixed (two passes)
        nk = np.ones((p, m), dtype=np.int64)
        scores: dict[str, list[float]] = {}
        best = _cv_score(fd, arx_fit(n0, nk), prob.dt)[0]
        for _ in range(2):
            changed = False
            for i in range(m):
                row = []
                for d in range(0, max_delay + 1):
                    trial = nk.copy()
                    trial[:, i] = d
                    row.append(_cv_score(fd, arx_fit(n0, trial), prob.dt)[0])
                scores[f"input {i}"] = row
                d_best = int(np.argmax(row))
                if row[d_best] > best + 1e-9 and d_best != nk[0, i]:
                    nk[:, i] = d_best
                    best = row[d_best]
                    changed = True
            if not changed:
                break
        return nk, best, scores

    if given.get("nk") is not None:
        nk = _orders_arg("nk", given["nk"], (p, m), 0)
    elif family == "arx" and given.get("na") is None and given.get("nb") is None:
        # ARX is cheap: the delays searched anew at every order, the order by the
        # parsimonious rule over each order's best delays
        per = [delay_search(n) for n in range(1, max_order + 1)]
        va_a = np.array([q[1] for q in per])
        safe = np.where(np.isfinite(va_a), va_a, -np.inf)
        if not np.isfinite(safe).any():
            raise IdentificationError(
                f"cross-validation of ARX orders 1..{max_order}: no candidate could be fitted "
                "and simulated on the other fold"
            )
        chosen = int(np.argmax(safe >= safe.max() - tolerance)) + 1
        nk = per[chosen - 1][0]
        out.update(
            {
                "orders": {
                    "nk": nk.tolist(),
                    "na": chosen,
                    "nb": chosen,
                    "nc": 0,
                    "nd": 0,
                    "nf": 0,
                },
                "order_scores": va_a.tolist(),
                "best_order": int(np.argmax(safe)) + 1,
                "chosen_order": chosen,
                "delays_per_order": [q[0].tolist() for q in per],
            }
        )
        return out
    else:
        nk, _, scores = delay_search(min(2, max_order))
        out["delay_scores"] = scores
    out_orders: dict[str, Any] = {"nk": nk.tolist()}

    def tied(n: int) -> dict[str, Any]:
        o = {"na": 0, "nb": n, "nc": 0, "nd": 0, "nf": 0}
        if family in ("arx", "armax"):
            o["na"] = n
        if family == "armax":
            o["nc"] = n
        if family in ("oe", "bj"):
            o["nf"] = n
        if family == "bj":
            o["nc"] = o["nd"] = min(n, 2)
        return {k: (given[k] if given.get(k) is not None else v) for k, v in o.items()}

    va = []
    for n in range(1, max_order + 1):
        o = tied(n)

        def fit(us, ys, o=o):  # type: ignore[no-untyped-def]
            sub = _sub_problem(prob, us, ys)
            mdl, th, _, _ = _fit_family(family, sub, **o, nk=nk, focus=focus, max_nfev=max_nfev)
            return mdl, th

        va.append(_cv_score(fd, fit, prob.dt)[0])
    va_a = np.array(va)
    safe = np.where(np.isfinite(va_a), va_a, -np.inf)
    if not np.isfinite(safe).any():
        raise IdentificationError(
            f"cross-validation of {family.upper()} orders 1..{max_order}: no candidate could be "
            "fitted and simulated on the other fold"
        )
    best_n = int(np.argmax(safe)) + 1
    chosen = int(np.argmax(safe >= safe.max() - tolerance)) + 1
    out_orders.update(tied(chosen))
    out.update(
        {
            "orders": out_orders,
            "order_scores": va_a.tolist(),
            "best_order": best_n,
            "chosen_order": chosen,
        }
    )
    return out


# ================================================================ SOPDT
def sopdt(
    recordings: Recording | Sequence[Recording],
    inputs: Sequence[str] | str,
    outputs: Sequence[str] | str,
    *,
    max_delay_s: float | None = None,
    disturbances: Sequence[str] | None = None,
    operating_point_mode: str = "mean",
    validate: Recording | Sequence[Recording] = (),
    max_nfev: int = 100,
    expect: Mapping[str, int] | None = None,
) -> PEMResult:
    """Second-order-plus-dead-time model by minimising the simulation error.

    Starting values from the FOPTD fit of
    :func:`~thermogym.identification.foptd.fit_foptd` (``T1 = 0.8 T``,
    ``T2 = 0.2 T``, same gain and delay) and from a long-lag start
    (``T1 = T2 = T/2``, delay halved); the better end point is kept. Delays
    are searched continuously in ``[0, max_delay_s]``.

    Parameters
    ----------
    recordings, inputs, outputs, disturbances, operating_point_mode, validate
        As :func:`pem`.
    max_delay_s : float, optional
        Largest delay [s] (default: a tenth of the longest experiment).
    max_nfev : int
    expect : mapping, optional
        Declared gain signs, as :func:`pem`.

    Returns
    -------
    PEMResult
        With the warnings of :mod:`~thermogym.identification.advice`.

    Examples
    --------
    >>> from thermogym.models.process import SOPDTModel
    >>> true = SOPDTModel(["P"], ["T"], K=0.5, T1=80.0, T2=15.0, tau=6.0)
    >>> u = np.repeat(np.random.default_rng(2).choice([0.0, 10.0], 12), 100)
    >>> y = 20.0 + true.simulate(u[:, None], 1.0).outputs[0, :, 0]
    >>> rec = Recording(np.arange(u.size, dtype=float), {"P": u, "T": y})
    >>> res = sopdt(rec, ["P"], ["T"], operating_point_mode="rest")
    >>> [round(res.fit.parameters[k], 1) for k in ("K_T", "T1_T", "T2_T", "tau_T")]
    [0.5, 80.0, 15.0, 6.0]
    """
    t0 = time.perf_counter()
    prob = _problem(recordings, inputs, outputs, disturbances, operating_point_mode)
    vals = [validate] if isinstance(validate, Recording) else list(validate)
    final, th, cov, info = _sopdt_fit(prob, max_delay_s, max_nfev)
    settings = {
        "dt": prob.dt,  # the training period: the default period of the realisation
        "operating_point_mode": operating_point_mode,
        "focus": "simulation",
        **info,
        "seconds": time.perf_counter() - t0,
    }
    fit = _fitresult(
        final,
        th[None],
        cov,
        prob,
        vals,
        method="sopdt",
        settings=settings,
        notes="second-order plus dead time by simulation-error minimisation",
    )
    _advise(fit, prob, expect)
    return PEMResult(fit, final, th[None], time.perf_counter() - t0)


def _sopdt_fit(
    prob: N4SIDProblem, max_delay_s: float | None, max_nfev: int
) -> tuple[SOPDTModel, NDArray[np.float64], NDArray[np.float64], dict[str, Any]]:
    """SOPDT of a problem's deviation data: model, θ, covariance, info."""
    dt = prob.dt
    span = max(u.shape[0] for u in prob.us) * dt
    if max_delay_s is None:
        max_delay_s = 0.1 * span
    K0, T10, T20, tau0 = _sopdt_start(prob, max_delay_s, span)
    model = SOPDTModel(
        prob.inputs,
        prob.outputs,
        disturbances=prob.disturbances,
        units=prob.units,
        K=K0,
        T1=T10,
        T2=T20,
        tau=tau0,
    )
    # one output at a time: the outputs share no parameter (MISO fits, as the polynomials)
    th = model.nominal.copy()
    cov = np.zeros((th.size, th.size))
    nfev, s2s = 0, []
    m = model.n_inputs
    for jo, out in enumerate(prob.outputs):
        sub = SOPDTModel(prob.inputs, [out], disturbances=prob.disturbances,
                         K=K0[jo : jo + 1], T1=T10[jo : jo + 1], T2=T20[jo : jo + 1],
                         tau=tau0[jo : jo + 1])  # fmt: skip
        names = sub.param_names
        lo = np.array(
            [-np.inf if n.startswith("K_") else (0.0 if n.startswith("tau_") else dt / 20)
             for n in names]
        )  # fmt: skip
        hi = np.array([max_delay_s if n.startswith("tau_") else np.inf for n in names])
        data = _Data(list(prob.us), [y[:, jo : jo + 1] for y in prob.ys], dt, _offset(prob.mode))
        best: _Solution | None = None
        Tsum = T10[jo] + T20[jo]
        for t1, t2, tau in (
            (T10[jo], T20[jo], tau0[jo]),
            (0.8 * Tsum, 0.2 * Tsum, tau0[jo]),
            (0.5 * Tsum, 0.5 * Tsum, 0.5 * tau0[jo]),
        ):
            ths = sub.nominal.copy()
            ths[sub._idx["T1"].ravel()] = np.ravel(t1)
            ths[sub._idx["T2"].ravel()] = np.ravel(t2)
            ths[sub._idx["tau"].ravel()] = np.ravel(np.minimum(tau, max_delay_s))
            sol = _solve(sub, ths, np.arange(ths.size), data, "simulation", lower=lo, upper=hi,
                         max_nfev=max_nfev)  # fmt: skip
            nfev += sol.nfev
            if best is None or sol.cost < best.cost:
                best = sol
        assert best is not None
        cols = np.arange(jo * 4 * m, (jo + 1) * 4 * m)  # K, T1, T2, tau per input of output jo
        th[cols] = best.theta
        cov[np.ix_(cols, cols)] = best.cov
        s2s.append(best.sigma2)
    # convention T1 >= T2 (the model is symmetric in them)
    for j in range(len(prob.outputs)):
        for i in range(model.n_inputs):
            a, b = model._idx["T1"][j, i], model._idx["T2"][j, i]
            if th[b] > th[a]:
                th[a], th[b] = th[b], th[a]
                cov[[a, b]] = cov[[b, a]]
                cov[:, [a, b]] = cov[:, [b, a]]
    final = SOPDTModel(
        prob.inputs,
        prob.outputs,
        disturbances=prob.disturbances,
        units=prob.units,
        **{
            k: v[0]
            for k, v in zip(("K", "T1", "T2", "tau"), model.pair_parameters(th[None]), strict=True)
        },
    )
    return final, th, cov, {"max_delay_s": max_delay_s, "nfev": nfev, "sigma2": s2s}


def _sopdt_start(
    prob: N4SIDProblem, max_delay_s: float, span: float
) -> tuple[NDArray[np.float64], ...]:
    """Starting K, T1, T2, tau (p, m) from second-order ARX models, delay scanned."""
    dt = prob.dt
    p, m = len(prob.outputs), len(prob.inputs) + len(prob.disturbances)
    K, T1, T2, tau = (np.zeros((p, m)) for _ in range(4))
    dmax = int(min(max_delay_s / dt, max(u.shape[0] for u in prob.us) // 4))
    for j in range(p):
        ys = [y[:, j] for y in prob.ys]
        best = None
        for d in range(0, dmax + 1):
            try:
                th, _, s2 = arx_ls(prob.us, ys, 2, [2] * m, [d + 1] * m)
            except IdentificationError:
                break
            if best is None or s2 < best[0]:
                best = (s2, th, d)
        if best is None:
            raise IdentificationError(f"SOPDT of {prob.outputs[j]!r}: too few samples for a start")
        _, th, d = best
        A = np.r_[1.0, th[:2]]
        lam = np.roots(A)
        Ts = sorted(
            (-dt / np.log(abs(l.real)) for l in lam if abs(l.imag) < 1e-9 and 0 < l.real < 1),
            reverse=True,
        )
        t1 = Ts[0] if Ts else span / 10
        t2 = Ts[1] if len(Ts) > 1 else t1 / 5
        for i in range(m):
            b = th[2 + 2 * i : 4 + 2 * i]
            K[j, i] = b.sum() / A.sum() if abs(A.sum()) > 1e-12 else 0.0
        T1[j] = np.clip(t1, dt, 10 * span)
        T2[j] = np.clip(t2, dt / 10, 10 * span)
        tau[j] = d * dt
    return K, T1, T2, tau


# ======================================================= N4SID refinement
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
        settings under ``"n4sid"``.
    """
    from thermogym.fitresult import load_fit

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
    prob = _problem(recordings, list(ins) + list(dis), list(outs), list(dis), mode)
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
    data = _Data(list(prob.us), list(prob.ys), prob.dt, _offset(prob.mode))
    before = float(np.sum(_residual_batch(model, th0[None], data, focus) ** 2))
    sol = _solve(model, th0, np.arange(th0.size), data, focus, max_nfev=max_nfev)
    th = sol.theta
    if not np.all(np.abs(np.linalg.eigvals(model.matrices(th[None]).A[0])) < 1.0) or (
        sol.cost * 2 > before
    ):
        th = th0  # an unstable or worse end point: keep the N4SID model
        status = "kept the N4SID model (refinement did not improve it stably)"
    else:
        status = sol.status
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
        "order": base.n_states,
        "feedthrough": base.has_D,
    }
    out = _fitresult(
        final,
        final.nominal[None],
        None,
        prob,
        vals,
        method="ssest",
        settings=settings,
        notes="N4SID start refined by prediction-error minimisation (as ssest)",
    )
    return PEMResult(out, final, final.nominal[None], time.perf_counter() - t0)
