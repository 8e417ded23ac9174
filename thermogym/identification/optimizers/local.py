"""Local grey-box fitting: Gauss-Newton / Levenberg-Marquardt / trust region with bounds.

Section III of ``002_dae2310635fe074e.txt``: the parameters minimise the
least-squares cost (7) subject to bounds (8). The solver is
:func:`scipy.optimize.least_squares` — ``"trf"`` (trust-region reflective, a
Levenberg-Marquardt-type trust region that respects bounds; default),
``"dogbox"`` (dogleg in a box) or ``"lm"`` (MINPACK Levenberg-Marquardt, no
bounds: parameters are clipped to them).

The Jacobian is supplied by :func:`residual_jacobian`:

* ``"fd"`` — finite differences on the model's fixed-step solver (section
  III-A: a fixed step keeps the perturbed simulations consistent, eqs 9-11);
  the ``P`` (or ``2P``) perturbed parameter sets are simulated as **one
  batch**, i.e. one ``SimModel.simulate`` call per experiment;
* ``"exact"`` — forward sensitivities of thermogym's models
  (:mod:`~thermogym.identification.optimizers.sensitivities`): one augmented
  simulation per experiment instead of ``P + 1``.

The solver works in unit coordinates (each parameter scaled to [0, 1] across
its bounds, log-scaled where asked), which equalises the parameters'
magnitudes (C_P ≈ 18 J/K next to kP_a ≈ −0.02).
"""

from __future__ import annotations

import inspect
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import least_squares

from thermogym.errors import ConfigError, IdentificationError
from thermogym.identification.optimizers.base import Tracker
from thermogym.identification.problem import Problem
from thermogym.models._blas import blas_threads

__all__ = ["LEAST_SQUARES_OPTIONS", "residual_jacobian", "run_least_squares"]

_JAC_METHODS = ("auto", "fd", "exact")
_DIFFS = ("forward", "central")
_SOLVERS = ("trf", "dogbox", "lm")


def _exact_jacobian(
    problem: Problem, z: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    fn = problem.sensitivity_function()
    if fn is None:  # pragma: no cover - guarded by the caller
        raise ConfigError(f"model {problem.model.name!r} has no exact sensitivities")
    th = problem.theta(z)[0]
    D = problem.theta_jacobian  # ∂θ/∂z
    moved = np.flatnonzero(np.any(D != 0, axis=1))  # SimModel parameters z moves
    rs, Js = [], []
    for e, y, m in zip(problem.experiments, problem._y, problem._m, strict=True):
        with blas_threads(problem.blas_threads):
            Y, dY = _call_sensitivities(fn, th, e, moved)
        problem.counters.sensitivity_runs += 1
        yh = Y[:, problem._out_cols]
        dyh = dY[:, problem._out_cols, :] @ D[moved]  # (T, n_pairs, P) by the chain rule
        if not (np.isfinite(yh).all() and np.isfinite(dyh).all()):
            raise IdentificationError(
                f"model {problem.model.name!r}: the sensitivity simulation on experiment "
                f"{e.experiment_id!r} became non-finite at {problem.as_dict(z)}"
            )
        f = problem._rfac
        rs.append((np.where(m, yh - y, 0.0) * f).ravel())
        Js.append((np.where(m[:, :, None], dyh, 0.0) * f[None, :, None]).reshape(-1, z.size))
    return np.concatenate(rs), np.concatenate(Js, axis=0)


def _call_sensitivities(
    fn: Any, th: NDArray[np.float64], e: Any, moved: NDArray[np.int64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Call a sensitivity function for the moved parameters (all when it takes no columns)."""
    try:
        takes_columns = "columns" in inspect.signature(fn).parameters
    except (TypeError, ValueError):  # pragma: no cover - builtins without a signature
        takes_columns = False
    if takes_columns:
        return fn(th, e, columns=moved)
    Y, dY = fn(th, e)  # a SimModel's own sensitivities(theta, experiment)
    return Y, np.asarray(dY)[:, :, moved]


def residual_jacobian(
    problem: Problem,
    z: ArrayLike,
    *,
    method: str = "auto",
    diff: str = "forward",
    step: float | None = None,
    r0: NDArray[np.float64] | None = None,
    tracker: Tracker | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64], int]:
    """Weighted residuals and Jacobian ``∂r/∂z`` at ``z`` (see :meth:`Problem.jacobian`).

    Parameters
    ----------
    problem : Problem
    z : array_like, shape (P,)
    method : {"auto", "fd", "exact"}
    diff : {"forward", "central"}
    step : float, optional
        Finite-difference step in unit coordinates.
    r0 : ndarray, optional
        Residuals at ``z`` if known.
    tracker : Tracker, optional
        Evaluate through it (counts, best, stop criteria).

    Returns
    -------
    r : ndarray, shape (N,)
    J : ndarray, shape (N, P)
    n_sim : int
        Parameter sets simulated (each on every experiment); for ``"exact"``
        the number of sensitivity simulations per experiment (1).
    """
    if method not in _JAC_METHODS:
        raise ConfigError(f"jac is {method!r}, expected one of {_JAC_METHODS}")
    if diff not in _DIFFS:
        raise ConfigError(f"diff is {diff!r}, expected one of {_DIFFS}")
    z = np.asarray(z, dtype=float).reshape(-1)
    P = problem.n_params
    if method == "exact" and problem.sensitivity_function() is None:
        raise ConfigError(
            f"exact gradients are not available for model {problem.model.name!r} (thermogym's "
            "AXT211 and linear RC networks without physical effects have them, or a SimModel "
            "with a sensitivities() method); use jac='fd'"
        )
    if method in ("exact", "auto") and problem.sensitivity_function() is not None:
        r, J = _exact_jacobian(problem, z)
        return r, J, 1
    h = step if step is not None else (1e-7 if diff == "forward" else 1e-5)
    if not (np.isfinite(h) and 0 < h < 0.5):
        raise ConfigError(f"fd_step is {h!r}, expected a step in unit coordinates in (0, 0.5)")
    u0 = problem.to_unit(z)
    eye = np.eye(P)
    # step towards the interior when a bound is near
    sign = np.where(u0 + h <= 1.0, 1.0, -1.0)
    plus = problem.from_unit(u0[None] + h * sign[:, None] * eye)
    minus = (
        problem.from_unit(u0[None] - h * sign[:, None] * eye)
        if diff == "central"
        else np.repeat(z[None], P, axis=0)
    )
    need0 = r0 is None
    parts = ([z[None]] if need0 else []) + [plus] + ([minus] if diff == "central" else [])
    batch = np.concatenate(parts, axis=0)
    # ONE batched evaluation for every perturbed set (and the centre when needed)
    evaluate = tracker.evaluate if tracker is not None else problem.evaluate
    ev = evaluate(batch, residuals=True)
    R = _residuals(ev)
    k = 1 if need0 else 0
    if need0:
        if not ev.ok[0]:
            raise IdentificationError(
                f"model {problem.model.name!r} fails at {problem.as_dict(z)}: {ev.errors[0]}"
            )
        r0 = R[0]
    r0 = np.asarray(r0, dtype=float)
    Rp, okp = R[k : k + P], ev.ok[k : k + P]
    if diff == "central":
        Rm, okm = R[k + P : k + 2 * P], ev.ok[k + P : k + 2 * P]
    else:
        Rm, okm = np.repeat(r0[None], P, axis=0), np.ones(P, dtype=bool)
    for i in np.flatnonzero(~(okp & okm)):
        # a failed perturbation: take the one-sided difference on the side that simulates
        if diff == "central" and (okp[i] or okm[i]):
            if okp[i]:
                Rm[i], minus[i] = r0, z
            else:
                Rp[i], plus[i] = r0, z
            continue
        other = problem.from_unit(u0 - h * sign[i] * eye[i])
        ev2 = evaluate(other[None], residuals=True)
        if not ev2.ok[0]:
            raise IdentificationError(
                f"model {problem.model.name!r} fails on both sides of {problem.as_dict(z)} in "
                f"parameter {problem.names[i]!r}: {ev2.errors[0]}"
            )
        Rp[i], plus[i] = r0, z
        Rm[i], minus[i] = _residuals(ev2)[0], other
    dz = np.einsum("ij,ij->i", plus - minus, eye)
    J = ((Rp - Rm) / dz[:, None]).T
    return r0.copy(), J, batch.shape[0]


def _residuals(ev: Any) -> NDArray[np.float64]:
    if ev.residuals is None:  # pragma: no cover - evaluate(residuals=True) always sets them
        raise IdentificationError("residuals were not computed")
    return ev.residuals


#: Options of the local method and their defaults.
LEAST_SQUARES_OPTIONS: dict[str, Any] = {
    "jac": "auto",
    "diff": "forward",
    "fd_step": None,
    "solver": "trf",
    "loss": "linear",
    "ftol": 1e-8,
    "xtol": 1e-8,
    "gtol": 1e-8,
}


def run_least_squares(
    problem: Problem,
    tracker: Tracker,
    rng: np.random.Generator,
    *,
    start: NDArray[np.float64] | None = None,
    jac: str = "auto",
    diff: str = "forward",
    fd_step: float | None = None,
    solver: str = "trf",
    loss: str = "linear",
    ftol: float = 1e-8,
    xtol: float = 1e-8,
    gtol: float = 1e-8,
) -> dict[str, Any]:
    """Bounded nonlinear least squares from ``start`` (paper 002, eqs 7-8).

    One iteration is one Jacobian evaluation. Stop criteria of the tracker end
    the run (the best point is kept by the tracker).

    Parameters
    ----------
    problem : Problem
    tracker : Tracker
        With ``cost="mse"``.
    rng : numpy.random.Generator
        Unused (the method is deterministic); kept for a uniform signature.
    start : ndarray, optional
        Start vector (default: the problem's start values).
    jac, diff, fd_step
        See :func:`residual_jacobian`.
    solver : {"trf", "dogbox", "lm"}
    loss : str
        scipy loss (``"linear"`` is least squares; ``"soft_l1"``, ``"huber"``
        are robust to outliers, but then the covariance is approximate).
    ftol, xtol, gtol : float
        Convergence tolerances of :func:`scipy.optimize.least_squares`.

    Returns
    -------
    dict
        ``status``, ``message``, ``nfev``, ``njev`` of scipy.
    """
    del rng
    if solver not in _SOLVERS:
        raise ConfigError(f"solver is {solver!r}, expected one of {_SOLVERS}")
    if jac not in _JAC_METHODS:
        raise ConfigError(f"jac is {jac!r}, expected one of {_JAC_METHODS}")
    if jac == "exact" and problem.sensitivity_function() is None:
        residual_jacobian(problem, problem.start, method="exact")  # raises the explanation
    z0 = problem.start.copy() if start is None else np.asarray(start, dtype=float)
    u0 = problem.to_unit(z0)
    N = problem.n_residuals
    cache: dict[bytes, NDArray[np.float64]] = {}

    def fun(u: NDArray[np.float64]) -> NDArray[np.float64]:
        key = u.tobytes()
        if key in cache:
            return cache[key]
        z = problem.from_unit(u)
        ev = tracker.evaluate(z, residuals=True)
        if not ev.ok[0]:
            if not cache:
                raise IdentificationError(
                    f"model {problem.model.name!r} fails at the start {problem.as_dict(z)}: "
                    f"{ev.errors[0]}"
                )
            r = np.full(N, np.inf)  # the trust region shrinks and tries a shorter step
        else:
            r = _residuals(ev)[0]
        if len(cache) > 8:
            cache.clear()
        cache[key] = r
        return r

    def jacobian(u: NDArray[np.float64]) -> NDArray[np.float64]:
        z = problem.from_unit(u)
        r0 = cache.get(u.tobytes())
        r, Jz, _ = residual_jacobian(
            problem, z, method=jac, diff=diff, step=fd_step, r0=r0, tracker=tracker
        )
        Ju = Jz * problem.unit_jacobian(z)[None, :]
        tracker.end_iteration(current=float(r @ r))
        return Ju

    kw: dict[str, Any] = {"ftol": ftol, "xtol": xtol, "gtol": gtol, "loss": loss}
    if solver == "lm":
        if loss != "linear":
            raise ConfigError("solver 'lm' supports only loss='linear'")
        res = least_squares(fun, u0, jac=jacobian, method="lm", x_scale=1.0, **kw)
    else:
        res = least_squares(
            fun, u0, jac=jacobian, bounds=(0.0, 1.0), method=solver, x_scale=1.0, **kw
        )
    return {
        "status": int(res.status),
        "message": str(res.message),
        "nfev": int(res.nfev),
        "njev": int(res.njev or 0),
    }
