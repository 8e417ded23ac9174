"""The prediction-error solver: residuals with the initial states projected out.

A batch of parameter sets is simulated (or run through its one-step Kalman
predictor) in one compiled call of the models' linear kernels; the initial
state of each experiment is eliminated by linear least squares at every
evaluation (variable projection); ``scipy.optimize.least_squares`` minimises
the error with a batched finite-difference Jacobian. :func:`simulation_fit`
scores a fitted model by its simulation fit (as MATLAB ``compare``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares

from thermogym.errors import IdentificationError
from thermogym.identification.metrics import nrmse
from thermogym.models._blas import blas_threads
from thermogym.models._linear_kernels import _ss_predict_kernel, _ss_simulate_kernel
from thermogym.models.base import Model
from thermogym.models.linear import StateSpaceModel
from thermogym.models.process import discrete_realization

if TYPE_CHECKING:
    from thermogym.identification.n4sid import N4SIDProblem

__all__ = ["simulation_fit"]


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


@dataclass
class _Data:
    us: list[NDArray[np.float64]]
    ys: list[NDArray[np.float64]]  # (T, p) each
    dt: float
    offset: bool = False  # a constant output offset per experiment besides x0 (see below)


def _offset(prob: N4SIDProblem) -> bool:
    """Whether simulation-error fits of an N4SIDProblem estimate an output offset.

    Only about a record's mean: the mean of a record that does not average to
    equilibrium (it starts from rest, or ends in a transient) is not the
    model's rest value, and the difference is a constant the initial state
    cannot hold. The other modes subtract a rest value (``"rest"``,
    ``"initial"``) or nothing (``"none"``): there the level carries the static
    gain, and a free offset lets the model trade the one against the other.
    Nor when an output offset is given: the user has fixed the output level.
    """
    return bool(prob.mode == "mean" and not prob.offsets["outputs"])


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
    jtj: NDArray[np.float64] | None = None  # JᵀJ at the end point (the Fisher information / σ²)
    at_limit: bool = False  # stopped by max_nfev, not by a convergence test


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
    jtj = J.T @ J
    cov = s2 * np.linalg.pinv(jtj)
    return _Solution(
        th, cov, s2, float(sol.cost), int(sol.nfev), str(sol.message), jtj, sol.status == 0
    )
