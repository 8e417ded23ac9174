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

``solver="normal"`` is :func:`box_least_squares`, a Levenberg-Marquardt on the
``k × k`` normal equations projected onto the unit box. It is the solver the
mismatch diagnosis uses for every fit (one solver for both): with a few hundred
thousand residuals and ~20 parameters, one product ``JᵀJ`` per Jacobian costs
far less than the SVD or LSMR iterations scipy's trust regions run on the full
``m × k`` Jacobian at every step.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares

from thermogym.errors import ConfigError, IdentificationError
from thermogym.identification.jacobian import _JAC_METHODS, _residuals, residual_jacobian
from thermogym.identification.optimizers.base import Tracker
from thermogym.identification.problem import Problem

__all__ = ["LEAST_SQUARES_OPTIONS", "BoxResult", "box_least_squares", "run_least_squares"]

_SOLVERS = ("trf", "dogbox", "lm", "normal")


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
    solver : {"trf", "dogbox", "lm", "normal"}
        scipy's trust-region reflective, dogleg or MINPACK solver, or
        :func:`box_least_squares` (``"normal"``: normal equations, for many
        residuals and few parameters).
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
    if solver == "normal":
        if loss != "linear":
            raise ConfigError("solver 'normal' supports only loss='linear'")
        out = box_least_squares(fun, jacobian, u0, max_nfev=10**9, xtol=xtol, ftol=ftol)
        return {
            "status": 1 if out.success else 0,
            "message": out.message,
            "nfev": out.nfev,
            "njev": out.njev,
        }
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


@dataclass(frozen=True)
class BoxResult:
    """Outcome of :func:`box_least_squares`.

    Attributes
    ----------
    s : ndarray, shape (k,)
        Best point found, in the unit box.
    cost : float
        ``½ Σ r²`` at ``s``.
    nfev, njev : int
        Residual and Jacobian evaluations.
    success : bool
        Converged (as opposed to stopped by ``max_nfev``).
    message : str
    """

    s: NDArray[np.float64]
    cost: float
    nfev: int
    njev: int
    success: bool
    message: str


def box_least_squares(
    fun: Callable[[NDArray[np.float64]], NDArray[np.float64]],
    jac: Callable[[NDArray[np.float64]], NDArray[np.float64]],
    s0: NDArray[np.float64],
    *,
    max_nfev: int = 60,
    xtol: float = 1e-8,
    ftol: float = 1e-8,
) -> BoxResult:
    """Levenberg-Marquardt on the normal equations, projected onto the unit box.

    Minimises ``½ ‖r(s)‖²`` over ``s ∈ [0, 1]^k`` (parameters scaled to their
    bounds). Each iteration solves ``(JᵀJ + λ diag(JᵀJ)) δ = −Jᵀr`` (Marquardt's
    scaling), clips the step to the box and holds the parameters at a bound
    whose gradient points outwards; ``λ`` falls by 3 after a successful step
    and grows by 4 after a failed one. Written here rather than calling
    :func:`scipy.optimize.least_squares`: for ``m`` of 10⁵-10⁶ residuals and
    ``k`` ~ 20 parameters, one ``JᵀJ`` per Jacobian is far cheaper than the
    SVD (or LSMR iterations) scipy's trust regions run on ``J`` at every step.

    Parameters
    ----------
    fun : callable
        ``s -> r`` (m,); a non-finite cost rejects the step.
    jac : callable
        ``s -> J`` (m, k).
    s0 : ndarray, shape (k,)
        Start (clipped into the box); its residuals must be finite.
    max_nfev : int
        Largest number of residual evaluations.
    xtol, ftol : float
        Stop when a (nearly Gauss-Newton) step moves no coordinate by more
        than ``xtol`` or lowers the cost by less than the relative ``ftol``.

    Returns
    -------
    BoxResult

    Examples
    --------
    A line through three points, the slope bounded to [0, 1]:

    >>> import numpy as np
    >>> t = np.array([0.0, 1.0, 2.0])
    >>> y = np.array([1.0, 3.0, 5.0])
    >>> res = box_least_squares(lambda s: s[0] + s[1] * t - y,
    ...                         lambda s: np.column_stack([np.ones(3), t]), np.zeros(2))
    >>> res.s.round(6).tolist()
    [1.0, 1.0]
    """
    s = np.clip(np.asarray(s0, dtype=float), 0.0, 1.0)
    r = fun(s)
    cost = 0.5 * float(r @ r)
    nfev, njev = 1, 0
    if not math.isfinite(cost):
        return BoxResult(s, cost, nfev, njev, False, "the start's residuals are not finite")
    lam = 1e-3
    k = s.size
    while nfev < max_nfev:
        J = jac(s)
        njev += 1
        g = J.T @ r
        H = J.T @ J
        d = np.diag(H).copy()
        free = ~(((s <= 0.0) & (g > 0)) | ((s >= 1.0) & (g < 0)))
        if not free.any():
            return BoxResult(s, cost, nfev, njev, True, "every parameter at a bound")
        improved = False
        while nfev < max_nfev:
            A = H[np.ix_(free, free)] + lam * np.diag(d[free] + 1e-12 * (d.max() + 1e-300))
            try:
                step_f = -np.linalg.solve(A, g[free])
            except np.linalg.LinAlgError:
                lam *= 10.0
                if lam > 1e10:
                    return BoxResult(s, cost, nfev, njev, True, "singular normal equations")
                continue
            step = np.zeros(k)
            step[free] = step_f
            s_new = np.clip(s + step, 0.0, 1.0)
            r_new = fun(s_new)
            nfev += 1
            c_new = 0.5 * float(r_new @ r_new)
            if math.isfinite(c_new) and c_new < cost:
                dx = float(np.max(np.abs(s_new - s)))
                rel = (cost - c_new) / max(cost, 1e-300)
                s, r, cost = s_new, r_new, c_new
                # a tiny step only means convergence when it is a (nearly) Gauss-Newton step
                gn = lam < 1e-2
                lam = max(lam / 3.0, 1e-9)
                improved = True
                if gn and (rel < ftol or dx < xtol):
                    return BoxResult(s, cost, nfev, njev, True, "converged")
                break
            lam *= 4.0
            if lam > 1e10:
                return BoxResult(s, cost, nfev, njev, True, "no further decrease")
        if not improved:
            break
    return BoxResult(s, cost, nfev, njev, False, "largest number of evaluations reached")
