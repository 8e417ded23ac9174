"""Fitting for diagnosis: the problem, per-recording parameters, least squares.

Every model the diagnosis fits — the nominal model and each hypothesis —
goes through :func:`fit_model`: bounded nonlinear least squares of the
simulation error of every fitted output in every recording
(:class:`~.experiments.Experiment`), solved by
:func:`thermogym.identification.optimizers.local.box_least_squares` (the
solver the identification optimisers share), with

* outputs weighted by the inverse of their spread in the training data (each
  output counts like its NRMSE, eq 5 of ``001_6d13a2cd04f5de5e.txt``:
  :func:`output_weights`);
* parameters scaled to their bounds (``s = (θ − lower)/(upper − lower)``);
* Jacobians by forward differences, the perturbed sets simulated as **one
  batched call** of the model (the batch dimension of
  :class:`thermogym.models.base.Model`);
* several starts drawn inside the bounds (a scrambled Sobol' sequence, seeded:
  deterministic, :func:`sobol_starts`), all evaluated in one batch, the best
  refined;
* standard errors from the Jacobian (sandwich form of
  :func:`thermogym.identification.uncertainty.covariance_from_jacobian`).

**Per-recording parameters.** A parameter in the group ``"local"`` (an
unmeasured disturbance's course, a random walk of a coefficient) is fitted
separately in every recording: the free vector holds the shared parameters,
then one block per recording. Its Jacobian columns touch one recording only
and are computed on that recording alone.

**Initial states.** With ``x0="estimate"`` (the default) each recording's
initial state is a nuisance estimated by linear least squares from the free
responses of the model to unit deviations of its states (MATLAB
``compare``'s ``x0 = 'estimate'``)::

    ŷ(θ, x_r + Φ δ) ≈ ŷ(θ, x_r) + Ψ(θ) δ,    δ = argmin ‖W (y − ŷ − Ψ δ)‖²

with ``x_r`` the model's own initial state (usually rest or steady at the
first input) and the deviations ``Φ`` those of :mod:`.initial_states`. The
free responses ``Ψ`` are simulated with the parameter set itself (in the
same batch), so they follow the fit; only a thermal network, whose
deviations spread over many nodes, takes them once at the problem's start
values. The least squares uses the samples over which the free responses
carry 99.9 % of their energy: where the initial state is no longer visible,
the samples would only let the free responses absorb model error. Directions
the data cannot see are dropped (truncated SVD). ``x0="rest"`` and
``x0="measured"`` take the initial states of those policies
(:func:`~.initial_states.initial_states`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.stats import qmc

from thermogym.errors import IdentificationError, ShapeError
from thermogym.identification.diagnosis.experiments import Experiment
from thermogym.identification.diagnosis.initial_states import (
    initial_states,
    network_directions,
    state_directions,
)
from thermogym.identification.optimizers.local import box_least_squares
from thermogym.identification.uncertainty import covariance_from_jacobian
from thermogym.models.base import Model

__all__ = [
    "LOCAL_GROUP",
    "FitOutcome",
    "FitProblem",
    "fit_model",
    "output_weights",
    "simulate_all",
    "sobol_starts",
    "unit_jacobian",
]

#: Parameter group of per-recording parameters (fitted separately in every recording).
LOCAL_GROUP = "local"

#: Share of the free responses' energy that decides the initial-state window.
_X0_ENERGY = 0.999
#: Relative singular value below which an initial-state direction counts as unobservable.
_X0_RCOND = 1e-7
_X0_POLICIES = ("rest", "measured", "estimate")


# ------------------------------------------------------------------ the problem
@dataclass
class FitProblem:
    """What :func:`fit_model` fits: a model, its free parameters, data and weights.

    Parameters
    ----------
    model : Model
    free : sequence of str
        Parameters varied. Those of the group :data:`LOCAL_GROUP` are fitted
        separately in every experiment; the others are shared.
    base : ndarray, shape (P,)
        Values of every parameter (the free ones are the start).
    lower, upper : ndarray, shape (k,)
        Bounds of the free parameters (finite), in the order of ``free``.
    experiments : sequence of Experiment
    weights : ndarray, shape (n_y,)
        Weight of each fitted output (1 / its spread).
    x0 : {"estimate", "rest", "measured"}
        Initial-state policy (module docstring).
    local_values : list of dict, optional
        Per experiment, values of local parameters that are *not* free (a
        hypothesis evaluated with its per-recording course fixed).
    """

    model: Model
    free: tuple[str, ...]
    base: NDArray[np.float64]
    lower: NDArray[np.float64]
    upper: NDArray[np.float64]
    experiments: Sequence[Experiment]
    weights: NDArray[np.float64]
    x0: str = "estimate"
    local_values: list[dict[str, float]] | None = None
    n_sims: int = 0

    def __post_init__(self) -> None:
        self.free = tuple(self.free)
        self.base = np.asarray(self.base, dtype=float).reshape(-1)
        self.lower = np.asarray(self.lower, dtype=float).reshape(-1)
        self.upper = np.asarray(self.upper, dtype=float).reshape(-1)
        k = len(self.free)
        if self.lower.shape != (k,) or self.upper.shape != (k,):
            raise ShapeError(
                f"bounds have shapes {self.lower.shape} and {self.upper.shape}; expected ({k},) "
                f"for the free parameters {list(self.free)}"
            )
        if not (np.isfinite(self.lower).all() and np.isfinite(self.upper).all()):
            raise IdentificationError(
                f"parameters {list(self.free)} need finite bounds to be fitted"
            )
        if self.x0 not in _X0_POLICIES:
            raise IdentificationError(
                f"initial-state policy {self.x0!r}; expected one of {_X0_POLICIES}"
            )
        groups = {p.name: p.group for p in self.model.parameters}
        self._is_local = np.array([groups[p] == LOCAL_GROUP for p in self.free], dtype=bool)
        self._gcols = np.array(
            [
                self.model.param_index(p)
                for p, loc in zip(self.free, self._is_local, strict=True)
                if not loc
            ],
            dtype=np.int64,
        )
        self._lcols = np.array(
            [
                self.model.param_index(p)
                for p, loc in zip(self.free, self._is_local, strict=True)
                if loc
            ],
            dtype=np.int64,
        )
        self.n_global = int(self._gcols.size)
        self.n_local = int(self._lcols.size)
        ne = len(self.experiments)
        #: length of the free vector: shared, then one block of local parameters per experiment
        self.n_free = self.n_global + ne * self.n_local
        lo_g, hi_g = self.lower[~self._is_local], self.upper[~self._is_local]
        lo_l, hi_l = self.lower[self._is_local], self.upper[self._is_local]
        self.z_lower = np.concatenate([lo_g, np.tile(lo_l, ne)])
        self.z_upper = np.concatenate([hi_g, np.tile(hi_l, ne)])
        self._out_idx = [
            np.array([self.model.output_names.index(o) for o in e.outputs])
            for e in self.experiments
        ]
        self._base_e = []
        for i in range(ne):
            b = self.base.copy()
            for name, v in (self.local_values[i] if self.local_values else {}).items():
                b[self.model.param_index(name)] = v
            self._base_e.append(b)
        self._net_dirs: list[NDArray[np.float64] | None] = [None] * ne
        self._cached = (
            network_directions(
                self.model, self.base[None], self.experiments[0].u[:1], self.experiments[0].outputs
            )
            if ne
            else None
        )
        if self._cached is not None and self.x0 == "estimate":
            for i, e in enumerate(self.experiments):
                self._net_dirs[i] = network_directions(
                    self.model, self.base[None], e.u[:1], e.outputs
                )

    # ---------------------------------------------------------------- vectors
    def start(self) -> NDArray[np.float64]:
        """Free vector of the start values (shared, then local blocks)."""
        parts = [self.base[self._gcols]]
        for i in range(len(self.experiments)):
            parts.append(self._base_e[i][self._lcols])
        return np.concatenate(parts)

    def theta_of(self, z: NDArray[np.float64], i: int) -> NDArray[np.float64]:
        """Parameter batch (B, P) of experiment ``i`` from free vectors (B, n_free)."""
        z = np.atleast_2d(z)
        th = np.repeat(self._base_e[i][None], z.shape[0], axis=0)
        th[:, self._gcols] = z[:, : self.n_global]
        if self.n_local:
            a = self.n_global + i * self.n_local
            th[:, self._lcols] = z[:, a : a + self.n_local]
        return th

    def values(self, z: NDArray[np.float64]) -> dict[str, Any]:
        """Shared parameter values and, per experiment, the local ones."""
        z = np.asarray(z, dtype=float).reshape(-1)
        names_g = [p for p, loc in zip(self.free, self._is_local, strict=True) if not loc]
        names_l = [p for p, loc in zip(self.free, self._is_local, strict=True) if loc]
        out: dict[str, Any] = dict(zip(names_g, map(float, z[: self.n_global]), strict=True))
        if self.n_local:
            out["local"] = [
                dict(
                    zip(
                        names_l,
                        map(float, z[self.n_global + i * self.n_local :][: self.n_local]),
                        strict=True,
                    )
                )
                for i in range(len(self.experiments))
            ]
        return out

    # ------------------------------------------------------------- simulation
    def simulate(self, z: NDArray[np.float64], i: int) -> NDArray[np.float64]:
        """Fitted outputs (B, T, n_fit) of experiment ``i``, initial state by the policy.

        NaN rows for parameter sets that fail.
        """
        th = self.theta_of(z, i)
        return self._simulate_theta(th, i)

    def _simulate_theta(self, th: NDArray[np.float64], i: int) -> NDArray[np.float64]:
        e = self.experiments[i]
        B = th.shape[0]
        first = {o: float(e.y[0, j]) for j, o in enumerate(e.outputs)}
        u0 = np.repeat(e.u[:1], B, axis=0)
        try:
            policy = "rest" if self.x0 == "estimate" else self.x0
            x0 = initial_states(self.model, th, u0, first, policy)
            if self.x0 != "estimate":
                sim = self.model.simulate(e.u, e.dt, th, x0, t0=float(e.time[0]), strict=False)
                self.n_sims += B
                return sim.outputs[:, :, self._out_idx[i]]
            return self._estimated(th, x0, i)
        except Exception:
            if B == 1:
                return np.full((1, e.n, len(e.outputs)), np.nan)
            # one bad set must not spoil the others: simulate them one by one
            return np.concatenate([self._simulate_theta(th[b : b + 1], i) for b in range(B)])

    def _estimated(
        self, th: NDArray[np.float64], x0: NDArray[np.float64], i: int
    ) -> NDArray[np.float64]:
        """Outputs with the least-squares initial state (module docstring)."""
        e = self.experiments[i]
        B = th.shape[0]
        dirs = self._net_dirs[i]
        if dirs is None:
            dirs = state_directions(self.model, x0[:1])
        nd = dirs.shape[0]
        if nd == 0:
            sim = self.model.simulate(e.u, e.dt, th, x0, t0=float(e.time[0]), strict=False)
            self.n_sims += B
            return sim.outputs[:, :, self._out_idx[i]]
        # every set with its rest state and its n_d deviations in one batch
        th_all = np.repeat(th, nd + 1, axis=0)
        x_all = np.repeat(x0, nd + 1, axis=0).reshape(B, nd + 1, -1)
        x_all[:, 1:, :] += dirs[None]
        sim = self.model.simulate(
            e.u, e.dt, th_all, x_all.reshape(B * (nd + 1), -1), t0=float(e.time[0]), strict=False
        )
        self.n_sims += B * (nd + 1)
        y = sim.outputs[:, :, self._out_idx[i]].reshape(B, nd + 1, e.n, -1)
        y0 = y[:, 0]
        psi = y[:, 1:] - y0[:, None]  # (B, n_d, T, n_y) free responses
        return self._project(y0, psi, i)

    def _project(
        self, y0: NDArray[np.float64], psi: NDArray[np.float64], i: int
    ) -> NDArray[np.float64]:
        e = self.experiments[i]
        w = self.weights
        out = np.array(y0, copy=True)
        for b in range(y0.shape[0]):
            P = psi[b]
            if not (np.isfinite(P).all() and np.isfinite(y0[b]).all()):
                out[b] = np.nan
                continue
            # an unstable trial set (the optimiser's search passes through them) has free
            # responses that overflow: it is a failed simulation (NaN: the flat penalty of
            # _weighted), not a numpy warning on the console
            with np.errstate(over="ignore", invalid="ignore"):
                energy = np.sum((P * w[None, None, :]) ** 2, axis=(0, 2))  # per time step
                tot = float(energy.sum())
            if not math.isfinite(tot):
                out[b] = np.nan
                continue
            if tot <= 0.0:
                continue
            c = np.cumsum(energy) / tot
            W = int(np.searchsorted(c, _X0_ENERGY)) + 1
            W = min(e.n, max(W, 3, math.ceil(0.05 * e.n)))
            ok = np.isfinite(e.y[:W])
            A = np.moveaxis(P[:, :W] * w[None, None, :], 0, -1)[ok]  # (n_valid, n_d)
            r = ((e.y[:W] - y0[b, :W]) * w[None, :])[ok]
            if A.shape[0] < A.shape[1]:
                continue
            # δ = argmin ‖W (y − ŷ − Ψ δ)‖², unobservable directions dropped (truncated SVD)
            D, *_ = np.linalg.lstsq(A, r, rcond=_X0_RCOND)
            out[b] += np.einsum("dty,d->ty", P, D)
        return out

    def residuals(self, z: NDArray[np.float64]) -> NDArray[np.float64]:
        """Weighted residual vectors (B, N) over every experiment (NaN-free)."""
        z = np.atleast_2d(z)
        parts = [self._weighted(self.simulate(z, i), i) for i in range(len(self.experiments))]
        return np.concatenate(parts, axis=1)

    def _weighted(self, yh: NDArray[np.float64], i: int) -> NDArray[np.float64]:
        e = self.experiments[i]
        r = (yh - e.y[None]) * self.weights[None, None, :]
        r = np.where(np.isfinite(e.y)[None], r, 0.0)
        bad = ~np.isfinite(r).all(axis=(1, 2))
        r[bad] = 1e3  # a failed simulation: a large, flat penalty
        return r.reshape(r.shape[0], -1)

    def jacobian(
        self,
        z: NDArray[np.float64],
        r0: NDArray[np.float64],
        h: NDArray[np.float64],
        skip: NDArray[np.bool_] | None = None,
        deadline: float | None = None,
    ) -> NDArray[np.float64]:
        """Forward-difference Jacobian (N, n_free) at ``z`` with steps ``h`` (free units).

        Shared columns are simulated on every experiment in one batch each;
        a local column only on its own experiment. Columns where ``skip`` is
        true are not computed (left zero: the caller fills them). Past
        ``deadline`` (a ``time.perf_counter()`` value) it stops between
        experiments by raising the time-limit stop of :func:`fit_model`.
        """
        ne = len(self.experiments)
        sizes = [self.experiments[i].n * len(self.experiments[i].outputs) for i in range(ne)]
        offs = np.concatenate([[0], np.cumsum(sizes)])
        J = np.zeros((int(offs[-1]), self.n_free))
        g = self.n_global
        cols = np.arange(g) if skip is None else np.flatnonzero(~skip[:g])
        if cols.size:
            Z = np.repeat(z[None], cols.size, axis=0)
            Z[np.arange(cols.size), cols] += h[cols]
            for i in range(ne):
                if deadline is not None and time.perf_counter() > deadline:
                    raise _Stop
                R = self._weighted(self.simulate(Z, i), i)
                J[offs[i] : offs[i + 1], cols] = (
                    (R - r0[None, offs[i] : offs[i + 1]]) / h[cols, None]
                ).T
        if self.n_local:
            L = self.n_local
            for i in range(ne):
                if deadline is not None and time.perf_counter() > deadline:
                    raise _Stop
                a = g + i * L
                Z = np.repeat(z[None], L, axis=0)
                Z[np.arange(L), a + np.arange(L)] += h[a : a + L]
                R = self._weighted(self.simulate(Z, i), i)
                J[offs[i] : offs[i + 1], a : a + L] = (
                    (R - r0[None, offs[i] : offs[i + 1]]) / h[a : a + L, None]
                ).T
        return J

    def residual_series(self, z: NDArray[np.float64]) -> list[NDArray[np.float64]]:
        """Unweighted residuals ``y − ŷ`` (T, n_y) per experiment at one free vector."""
        return [
            self.experiments[i].y - self.simulate(z[None], i)[0]
            for i in range(len(self.experiments))
        ]


# ------------------------------------------------------------------ fitting
@dataclass
class FitOutcome:
    """Result of :func:`fit_model`.

    Attributes
    ----------
    theta : ndarray, shape (P,)
        Every parameter at the optimum (local parameters: those of the first
        experiment; see ``local``).
    z : ndarray
        The free vector at the optimum (shared, then per-experiment blocks).
    free : tuple of str
    values : dict
        Shared free parameter → value.
    local : list of dict
        Per experiment, local parameter → value (empty without local parameters).
    stderr : dict
        Shared free parameter → standard error (NaN where not identifiable).
    covariance : ndarray or None
        Of the shared free parameters (``covariance_names``).
    covariance_names : tuple of str
    cost : float
        ``½ Σ r²`` of the weighted residuals.
    n_residuals : int
    nfev, njev : int
    seconds : float
    success : bool
    message : str
    at_bounds : list of str
        Shared free parameters that ended at a bound.
    jacobian : ndarray or None
        Weighted residual Jacobian at the optimum, columns in the units of the
        free parameters (identifiability, profile checks).
    """

    theta: NDArray[np.float64]
    z: NDArray[np.float64]
    free: tuple[str, ...]
    values: dict[str, float]
    local: list[dict[str, float]]
    stderr: dict[str, float]
    covariance: NDArray[np.float64] | None
    covariance_names: tuple[str, ...]
    cost: float
    n_residuals: int
    nfev: int
    njev: int
    seconds: float
    success: bool
    message: str
    at_bounds: list[str] = field(default_factory=list)
    jacobian: NDArray[np.float64] | None = field(default=None, repr=False)


def sobol_starts(lower: NDArray[np.float64], upper: NDArray[np.float64], n: int, seed: int = 0):
    """``n`` start points spread inside the bounds (scrambled Sobol', seeded), shape (n, k).

    Positive ranges over more than a decade are spread logarithmically (time
    constants, conductances); the others linearly.

    Examples
    --------
    >>> import numpy as np
    >>> s = sobol_starts(np.array([0.0, 1.0]), np.array([1.0, 1000.0]), 4)
    >>> s.shape, bool(((s >= [0, 1]) & (s <= [1, 1000])).all())
    ((4, 2), True)
    """
    lo, hi = np.asarray(lower, dtype=float), np.asarray(upper, dtype=float)
    k = lo.size
    if n <= 0 or k == 0:
        return np.zeros((0, k))
    m = max(1, math.ceil(math.log2(max(n, 1))))
    q = qmc.Sobol(k, scramble=True, seed=seed).random_base2(m)[:n]
    logs = (lo > 0) & (hi / np.where(lo > 0, lo, 1.0) > 10.0)
    out = lo + q * (hi - lo)
    if logs.any():
        out[:, logs] = np.exp(np.log(lo[logs]) + q[:, logs] * (np.log(hi[logs]) - np.log(lo[logs])))
    return out


def fit_model(
    problem: FitProblem,
    *,
    start: NDArray[np.float64] | None = None,
    starts: Sequence[NDArray[np.float64]] = (),
    n_random: int = 0,
    n_refine: int = 1,
    max_nfev: int = 60,
    xtol: float = 1e-8,
    ftol: float = 1e-8,
    deadline: float | None = None,
    seed: int = 0,
    covariance: bool = True,
    frozen: Sequence[str] = (),
    frozen_columns: NDArray[np.float64] | None = None,
) -> FitOutcome:
    """Bounded least squares of the weighted simulation error (see the module docstring).

    Parameters
    ----------
    problem : FitProblem
    start : ndarray, shape (n_free,), optional
        Start (default: ``problem.start()``).
    starts : sequence of ndarray
        Further starts of the shared parameters (local blocks as ``start``).
    n_random : int
        Further starts of the shared parameters drawn inside their bounds
        (:func:`sobol_starts`).
    n_refine : int
        How many of the best starts (one batched evaluation of all) are refined.
    max_nfev : int
        Largest number of cost evaluations of one refinement.
    xtol, ftol : float
        Convergence tolerances (scaled parameters, relative cost).
    deadline : float, optional
        ``time.perf_counter()`` value after which refinements stop.
    seed : int
        Of the random starts.
    covariance : bool
        Compute the Jacobian and covariance at the optimum.
    frozen : sequence of str
        Shared free parameters whose Jacobian columns are computed once, at
        the first point, and reused (a quasi-Newton shortcut for a screening
        fit whose other parameters start at their optimum: each iteration
        then simulates only the remaining columns).
    frozen_columns : ndarray, shape (n_residuals, len(frozen)), optional
        Those columns already computed (in the unit coordinates of the
        bounds, :func:`unit_jacobian`): the first point computes none of them.

    Returns
    -------
    FitOutcome
    """
    t0 = time.perf_counter()
    lo, hi = problem.z_lower, problem.z_upper
    span = np.where(hi > lo, hi - lo, 1.0)
    k = problem.n_free
    z_start = problem.start() if start is None else np.asarray(start, dtype=float)
    cands = [z_start]
    g = problem.n_global
    extra = [np.asarray(s, dtype=float).reshape(-1) for s in starts]
    if n_random and g:
        extra += list(sobol_starts(lo[:g], hi[:g], n_random, seed))
    for s in extra:
        c = z_start.copy()
        c[: min(g, s.size)] = s[:g]
        cands.append(c)
    cands = [np.clip(c, lo, hi) for c in cands]
    if k == 0:
        r = problem.residuals(z_start[None])[0]
        return _outcome(problem, z_start, r, None, 1, 0, t0, True, "nothing to fit", False)
    if len(cands) > 1:
        R = problem.residuals(np.array(cands))
        with np.errstate(over="ignore"):  # a start far off overflows: an infinite cost, last
            costs = 0.5 * np.sum(R**2, axis=1)
        order = [int(i) for i in np.argsort(costs, kind="stable")]
        cands = [cands[i] for i in order[: max(1, n_refine)]]
    best: dict[str, Any] = {"z": cands[0], "cost": math.inf, "r": None}
    nfev_total, njev_total = 0, 0
    message, success = "", False
    names_g = [p for p, loc in zip(problem.free, problem._is_local, strict=True) if not loc]
    skip = np.array([p in frozen for p in names_g] + [False] * (k - g), dtype=bool)
    kept: dict[str, NDArray[np.float64]] = {}
    for c0 in cands:
        n_res = sum(e.n * len(e.outputs) for e in problem.experiments)
        if (
            frozen_columns is not None
            and "J" not in kept
            and np.shape(frozen_columns) == (n_res, int(skip.sum()))
        ):
            kept["frozen"] = np.asarray(frozen_columns, dtype=float)
        fun, jac = _objective(problem, lo, span, best, deadline, skip if skip.any() else None, kept)
        try:
            res = box_least_squares(
                fun, jac, (c0 - lo) / span, max_nfev=max_nfev, xtol=xtol, ftol=ftol
            )
            nfev_total += res.nfev
            njev_total += res.njev
            message, success = res.message, res.success
        except _Stop:
            message, success = STOPPED, False
            break
    z_opt = best["z"]
    r = best["r"] if best["r"] is not None else problem.residuals(z_opt[None])[0]
    # a fit the time limit stopped is reported without the covariance's Jacobian (P + 1 more
    # simulations of every recording, past the limit); its intervals say so (NaN)
    return _outcome(
        problem,
        z_opt,
        r,
        None,
        nfev_total,
        njev_total,
        t0,
        success,
        message,
        covariance and message != STOPPED,
    )


#: FitOutcome message of a refinement the time limit stopped.
STOPPED = "stopped at the time limit"
#: Forward-difference step of the Jacobian, in the unit coordinates of the bounds.
_H_UNIT = 1e-6


def unit_jacobian(problem: FitProblem, z: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    """The Jacobian :func:`fit_model` computes, at ``z`` (default: the start), in unit coordinates.

    Column ``j`` is ``∂r/∂s_j`` with ``s = (z − lower) / (upper − lower)``: the
    columns a screening fit takes as given (``frozen_columns``).
    """
    lo, hi = problem.z_lower, problem.z_upper
    span = np.where(hi > lo, hi - lo, 1.0)
    z = problem.start() if z is None else np.asarray(z, dtype=float)
    s = (z - lo) / span
    steps = np.where(s + _H_UNIT <= 1.0, _H_UNIT, -_H_UNIT)
    r0 = problem.residuals(z[None])[0]
    return problem.jacobian(z, r0, steps * span) * span[None, :]


class _Stop(Exception):
    """The time limit passed during a refinement."""


def _objective(
    problem: FitProblem,
    lo: NDArray[np.float64],
    span: NDArray[np.float64],
    best: dict[str, Any],
    deadline: float | None,
    skip: NDArray[np.bool_] | None = None,
    kept: dict[str, NDArray[np.float64]] | None = None,
) -> tuple[Any, Any]:
    """Residuals and Jacobian in unit coordinates, cached, tracking the best point in ``best``.

    Columns where ``skip`` is true are computed at the first Jacobian only and
    kept in ``kept`` (shared between refinements).
    """
    cache: dict[bytes, NDArray[np.float64]] = {}
    h_unit = _H_UNIT

    def fun(s: NDArray[np.float64]) -> NDArray[np.float64]:
        key = s.tobytes()
        if key not in cache:
            if deadline is not None and time.perf_counter() > deadline and cache:
                raise _Stop
            if len(cache) > 4:
                cache.clear()
            z = lo + np.clip(s, 0.0, 1.0) * span
            r = problem.residuals(z[None])[0]
            cache[key] = r
            c = 0.5 * float(r @ r)
            if c < best["cost"]:
                best.update(z=z, cost=c, r=r)
        return cache[key]

    def jac(s: NDArray[np.float64]) -> NDArray[np.float64]:
        r0 = fun(s)
        steps = np.where(s + h_unit <= 1.0, h_unit, -h_unit)
        z = lo + np.clip(s, 0.0, 1.0) * span
        if skip is None or kept is None:
            return problem.jacobian(z, r0, steps * span, deadline=deadline) * span[None, :]
        if "J" not in kept and "frozen" in kept:
            J = problem.jacobian(z, r0, steps * span, skip=skip, deadline=deadline) * span[None, :]
            J[:, skip] = kept["frozen"]
            kept["J"] = J
            return J.copy()
        if "J" not in kept:
            kept["J"] = problem.jacobian(z, r0, steps * span, deadline=deadline) * span[None, :]
            return kept["J"].copy()
        J = problem.jacobian(z, r0, steps * span, skip=skip, deadline=deadline) * span[None, :]
        J[:, skip] = kept["J"][:, skip]
        return J

    return fun, jac


def _outcome(
    problem: FitProblem,
    z: NDArray[np.float64],
    r: NDArray[np.float64],
    J: NDArray[np.float64] | None,
    nfev: int,
    njev: int,
    t0: float,
    success: bool,
    message: str,
    covariance: bool,
) -> FitOutcome:
    lo, hi = problem.z_lower, problem.z_upper
    g = problem.n_global
    names_g = tuple(p for p, loc in zip(problem.free, problem._is_local, strict=True) if not loc)
    cov, se = None, np.full(g, np.nan)
    if covariance and problem.n_free:
        span = np.where(hi > lo, hi - lo, 1.0)
        steps = np.where(z + 1e-6 * span <= hi, 1e-6 * span, -1e-6 * span)
        J = problem.jacobian(z, r, steps)
        valid = np.any(J != 0.0, axis=1) | (r != 0.0)
        cov_full, se_full = _covariance(J[valid], r[valid])
        se = se_full[:g]
        cov = None if cov_full is None else cov_full[:g, :g]
    at = [
        p
        for p, x, a, b in zip(names_g, z[:g], lo[:g], hi[:g], strict=True)
        if x <= a + 1e-6 * (b - a) or x >= b - 1e-6 * (b - a)
    ]
    vals = problem.values(z)
    local = vals.pop("local", [])
    return FitOutcome(
        theta=problem.theta_of(z[None], 0)[0],
        z=np.asarray(z, dtype=float),
        free=problem.free,
        values={k: float(v) for k, v in vals.items()},
        local=local,
        stderr={p: float(v) for p, v in zip(names_g, se, strict=True)},
        covariance=cov,
        covariance_names=names_g,
        cost=0.5 * float(r @ r),
        n_residuals=int(r.size),
        nfev=nfev,
        njev=njev,
        seconds=time.perf_counter() - t0,
        success=success,
        message=message,
        at_bounds=at,
        jacobian=J,
    )


def _covariance(J: NDArray[np.float64], r: NDArray[np.float64]) -> tuple[Any, NDArray[np.float64]]:
    try:
        cov, se, *_ = covariance_from_jacobian(J, r, block=None)
    except ShapeError:
        return None, np.full(J.shape[1], np.nan)
    return cov, se


def output_weights(experiments: Sequence[Experiment]) -> NDArray[np.float64]:
    """Inverse spread of each fitted output over the experiments (NRMSE weighting)."""
    y = np.concatenate([e.y for e in experiments], axis=0)
    sd = np.nanstd(y, axis=0)
    scale = np.where(np.isfinite(sd) & (sd > 0), sd, 1.0)
    return 1.0 / scale


def simulate_all(
    model: Model,
    theta: NDArray[np.float64],
    experiments: Sequence[Experiment],
    x0: str = "estimate",
    weights: NDArray[np.float64] | None = None,
    local: Sequence[Mapping[str, float]] | None = None,
) -> list[NDArray[np.float64]]:
    """Simulated fitted outputs (T, n_fit) of one parameter set on every experiment."""
    if not experiments:
        return []
    pb = FitProblem(
        model,
        (),
        np.asarray(theta, dtype=float).reshape(-1),
        np.zeros(0),
        np.zeros(0),
        experiments,
        np.ones(len(experiments[0].outputs)) if weights is None else weights,
        x0,
        local_values=[dict(v) for v in local] if local else None,
    )
    z = np.zeros((1, 0))
    return [pb.simulate(z, i)[0] for i in range(len(experiments))]
