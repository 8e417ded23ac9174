"""Local grey-box fitting: Gauss-Newton / Levenberg-Marquardt / trust region with bounds.

Section III of ``002_dae2310635fe074e.txt``: the parameters minimise the
least-squares cost (7) subject to bounds (8). The solver is
:func:`scipy.optimize.least_squares` — ``"trf"`` (trust-region reflective, a
Levenberg-Marquardt-type trust region that respects bounds; default),
``"dogbox"`` (dogleg in a box) or ``"lm"`` (MINPACK Levenberg-Marquardt, no
bounds: parameters are clipped to them).

The Jacobian is supplied by
:func:`~thermogym.identification.jacobian.residual_jacobian`:

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

from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares

from thermogym.errors import ConfigError, IdentificationError
from thermogym.identification.jacobian import _JAC_METHODS, _residuals, residual_jacobian
from thermogym.identification.optimizers.base import Tracker
from thermogym.identification.problem import Problem

__all__ = ["LEAST_SQUARES_OPTIONS", "run_least_squares"]

_SOLVERS = ("trf", "dogbox", "lm")


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
        See :func:`~thermogym.identification.jacobian.residual_jacobian`.
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
