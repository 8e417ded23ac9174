"""Weighted residuals and their Jacobian for grey-box fitting (paper 002, section III).

:meth:`Problem.jacobian <thermogym.identification.problem.Problem.jacobian>` and
the local optimiser (:mod:`~thermogym.identification.optimizers.local`) both
take the Jacobian ``∂r/∂z`` of the weighted residuals from here:

* ``"fd"`` — finite differences on the model's fixed-step solver (section
  III-A: a fixed step keeps the perturbed simulations consistent, eqs 9-11);
  the ``P`` (or ``2P``) perturbed parameter sets are simulated as **one
  batch**, i.e. one ``SimModel.simulate`` call per experiment;
* ``"exact"`` — forward sensitivities of thermogym's models
  (:mod:`~thermogym.identification.optimizers.sensitivities`): one augmented
  simulation per experiment instead of ``P + 1``.

It reads the problem through its public attributes and a few of its arrays and
never imports :mod:`thermogym.identification.problem` at run time (only for
type checking), so the problem can call it without an import cycle.
"""

from __future__ import annotations

import inspect
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from thermogym._checks import in_range
from thermogym.errors import ConfigError, IdentificationError
from thermogym.models._blas import blas_threads

if TYPE_CHECKING:
    from thermogym.identification.optimizers.base import Tracker
    from thermogym.identification.problem import Problem

__all__ = ["residual_jacobian"]

_JAC_METHODS = ("auto", "fd", "exact")
_DIFFS = ("forward", "central")


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
    # a step in unit coordinates (each parameter scaled to [0, 1] across its bounds)
    in_range("fd_step", h, 0.0, 0.5, lo_open=True, hi_open=True, error=ConfigError, text=False)
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
