"""Parameter uncertainty and identifiability from the output Jacobian.

Covariance
----------
Near the optimum the residuals are linear in the parameters, ``e ≈ e* + J δθ``.
For ordinary least squares with one noise level this gives the classical

    Cov(θ) = s² (JᵀJ)⁻¹,   s² = Σ e² / (N − p)

(residual variance × inverse Gauss-Newton matrix). The coordinator weights
signal pairs (eq 4 of ``000_24627a5308ee07db.txt``) and the pairs have
different noise levels (a temperature in K, a stroke in mm), so
:func:`covariance_from_jacobian` uses the sandwich form for a cost
``Σ_j a_j Σ_k e_jk²`` with a noise variance ``s_j²`` per pair:

    H = Σ_j a_j J_jᵀ J_j,   M = Σ_j a_j² s_j² J_jᵀ J_j,   Cov(θ) = H⁻¹ M H⁻¹

which reduces to ``s² (JᵀJ)⁻¹`` for a single pair. Confidence intervals are
``θ ± t_{(1+γ)/2, N−p} · σ_θ`` (Student t). The intervals assume white
residuals; residuals of a model that misses physics are correlated in time and
the intervals are then too narrow (compare training and validation fits).

Identifiability
---------------
Paper 000 (appendix) reduced 209 model parameters to 5 by hand, keeping "the
most uncertain" ones; paper 002 lists a sensitivity analysis as future work.
:func:`identifiability` ranks parameters by the practical-identifiability
measures of Brun, Reichert & Künsch (2001, Water Resour. Res. 37(4)):

* importance ``δ_j = √(mean_k s_kj²)`` of the scaled sensitivity
  ``s_kj = Δθ_j ∂r_k/∂θ_j`` (``Δθ_j`` the parameter's uncertainty range or
  value): how much the parameter moves the fit within its uncertainty;
* collinearity index ``γ_K = 1 / √λ_min(ŜᵀŜ)`` of a subset K with unit-norm
  columns ``Ŝ``: how well the others can compensate a change (γ > 10-15: the
  subset is not identifiable together);

and proposes the subset greedily: most important first, each next one added
only if the subset's collinearity index stays below the limit.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import stats

from thermogym._checks import probability
from thermogym.errors import ConfigError, ShapeError
from thermogym.recording import Recording

__all__ = [
    "Identifiability",
    "ParameterUncertainty",
    "collinearity_index",
    "correlation_length",
    "covariance_from_jacobian",
    "estimate_input_noise",
    "identifiability",
    "input_noise_covariance",
    "problem_identifiability",
    "problem_uncertainty",
]


@dataclass
class ParameterUncertainty:
    """Covariance, standard errors and confidence intervals of fitted parameters.

    Attributes
    ----------
    names : tuple of str
    values : ndarray, shape (P,)
    covariance : ndarray, shape (P, P), or None
        ``None`` when the Jacobian is rank deficient.
    stderr : ndarray, shape (P,)
        NaN for parameters in the unidentifiable subspace.
    lower, upper : ndarray, shape (P,)
        Confidence interval at ``level``.
    level : float
    dof : int
        Residual degrees of freedom ``N − p``.
    correlation : ndarray or None
    identifiable : ndarray of bool
    condition : float
        Condition number of the weighted Gauss-Newton matrix with equilibrated
        columns (parameter units removed).
    noise_std : ndarray
        Residual standard deviation of every signal pair (estimated noise).
    input_covariance : ndarray or None
        Share of the covariance due to noise of the measured inputs (included
        in ``covariance``), when it was estimated.
    """

    names: tuple[str, ...]
    values: NDArray[np.float64]
    covariance: NDArray[np.float64] | None
    stderr: NDArray[np.float64]
    lower: NDArray[np.float64]
    upper: NDArray[np.float64]
    level: float
    dof: int
    correlation: NDArray[np.float64] | None
    identifiable: NDArray[np.bool_]
    condition: float
    noise_std: NDArray[np.float64] = field(default_factory=lambda: np.empty(0))
    input_covariance: NDArray[np.float64] | None = None

    def contains(self, truth: ArrayLike) -> NDArray[np.bool_]:
        """Whether each true value lies in its confidence interval."""
        t = np.asarray(truth, dtype=float)
        return (self.lower <= t) & (t <= self.upper)

    def to_dict(self) -> dict[str, Any]:
        """JSON types."""
        return {
            "names": list(self.names),
            "values": self.values.tolist(),
            "stderr": self.stderr.tolist(),
            "lower": self.lower.tolist(),
            "upper": self.upper.tolist(),
            "level": self.level,
            "dof": self.dof,
            "covariance": None if self.covariance is None else self.covariance.tolist(),
            "correlation": None if self.correlation is None else self.correlation.tolist(),
            "identifiable": self.identifiable.tolist(),
            "condition": self.condition,
            "noise_std": self.noise_std.tolist(),
            "input_covariance": (
                None if self.input_covariance is None else self.input_covariance.tolist()
            ),
        }


def correlation_length(e: ArrayLike) -> int:
    """Lag at which the autocorrelation of a residual series becomes insignificant.

    The first lag ``l`` with ``ρ_l < 2/√T`` (the 95 % band of white noise),
    computed by FFT; 1 for white residuals.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> correlation_length(rng.standard_normal(5000)) <= 3
    True
    >>> x = np.convolve(rng.standard_normal(5000), np.ones(50) / 50, mode="same")
    >>> 30 < correlation_length(x) < 80
    True
    """
    x = np.asarray(e, dtype=float)
    x = x[np.isfinite(x)]
    T = x.size
    if T < 8:
        return 1
    x = x - x.mean()
    f = np.fft.rfft(x, n=2 * T)
    ac = np.fft.irfft(f * np.conj(f))[:T]
    if ac[0] <= 0:
        return 1
    rho = ac / ac[0]
    below = np.flatnonzero(rho[1:] < 2.0 / np.sqrt(T))
    return int(below[0] + 1) if below.size else T


def covariance_from_jacobian(
    J: ArrayLike,
    e: ArrayLike,
    *,
    groups: ArrayLike | None = None,
    weights: ArrayLike | None = None,
    valid: ArrayLike | None = None,
    series: ArrayLike | None = None,
    time_index: ArrayLike | None = None,
    block: int | str | None = "auto",
    rcond: float = 1e-10,
) -> tuple[NDArray[np.float64] | None, NDArray[np.float64], int, NDArray[np.float64], float]:
    """Parameter covariance from the Jacobian of the residuals.

    With ``block=None`` (white residuals) the meat of the sandwich is
    ``M = Σ_j a_j² s_j² J_jᵀ J_j``. Residuals of dynamic models are usually
    correlated in time (noisy measured inputs, unmodelled dynamics), which
    makes that formula far too optimistic; with ``series`` given, the meat is
    then estimated by **batch means** (a heteroscedasticity and autocorrelation
    consistent estimator): the scores ``a_j e_k J_k`` are summed over blocks of
    ``b`` consecutive samples of each series and ``M = Σ_blocks G Gᵀ``. With
    ``block="auto"``, ``b`` is twice the residuals' correlation length
    (:func:`correlation_length`), at most a tenth of the series; white
    residuals give ``b = 2`` and practically the classical result.

    Parameters
    ----------
    J : array_like, shape (N, P)
        ``∂e/∂θ`` of the *unweighted* residuals.
    e : array_like, shape (N,)
        Residuals ``ŷ − y`` at the optimum.
    groups : array_like of int, shape (N,), optional
        Signal pair of every residual (one noise level per group); default one group.
    weights : array_like, shape (n_groups,), optional
        ``a_j`` of the cost ``Σ_j a_j Σ_k e_jk²`` (default 1).
    valid : array_like of bool, shape (N,), optional
        Residuals that count (missing measurements excluded).
    series : array_like of int, shape (N,), optional
        Time series of every residual (experiment × pair); needed for ``block``.
    time_index : array_like of int, shape (N,), optional
        Sample index of every residual within its series (default: the order
        of appearance).
    block : "auto", int or None
        Batch length for correlated residuals (``None``: white-noise formula).
    rcond : float
        Eigenvalues of the (column-equilibrated) Gauss-Newton matrix below
        ``rcond`` × the largest mark unidentifiable directions.

    Returns
    -------
    cov : ndarray (P, P) or None
        ``None`` when rank deficient.
    stderr : ndarray, shape (P,)
        NaN where a parameter takes part in an unidentifiable direction.
    dof : int
    noise_var : ndarray, shape (n_groups,)
    condition : float
        Of the Gauss-Newton matrix with unit-norm Jacobian columns.

    Examples
    --------
    A straight line ``y = a + b t`` with alternating residuals: the classical result.

    >>> t = np.linspace(0.0, 1.0, 11)
    >>> J = np.column_stack([np.ones_like(t), t])
    >>> e = np.where(np.arange(11) % 2 == 0, 1.0, -1.0)
    >>> cov, se, dof, s2, cond = covariance_from_jacobian(J, e, block=None)
    >>> bool(np.allclose(cov, s2[0] * np.linalg.inv(J.T @ J))), dof
    (True, 9)
    """
    Ja = np.asarray(J, dtype=float)
    ea = np.asarray(e, dtype=float).reshape(-1)
    if Ja.ndim != 2 or Ja.shape[0] != ea.size:
        raise ShapeError(f"J has shape {Ja.shape}, e has {ea.size} entries; need (N, P) and N")
    N, P = Ja.shape
    g = np.zeros(N, dtype=np.int64) if groups is None else np.asarray(groups, dtype=np.int64)
    if g.shape != (N,):
        raise ShapeError(f"groups has shape {g.shape}, expected ({N},)")
    ng = int(g.max()) + 1 if N else 1
    a = np.ones(ng) if weights is None else np.asarray(weights, dtype=float)
    if a.shape != (ng,):
        raise ShapeError(f"weights has shape {a.shape}, expected ({ng},) (one per group)")
    v = np.ones(N, dtype=bool) if valid is None else np.asarray(valid, dtype=bool)
    v = v & np.isfinite(ea) & np.isfinite(Ja).all(axis=1)
    n_valid = int(v.sum())
    dof = n_valid - P
    if dof <= 0:
        raise ShapeError(f"{n_valid} residuals for {P} parameters: no degrees of freedom left")
    if block is not None and not (block == "auto" or (isinstance(block, int) and block >= 1)):
        raise ConfigError(f"block is {block!r}, expected 'auto', a positive int or None")
    Jv, ev, gv = Ja[v], ea[v], g[v]
    # equilibrate the columns (parameters of very different magnitudes) so that the
    # rank test sees the geometry of the problem, not its units; undone at the end
    cn = np.linalg.norm(Jv, axis=0)
    d = np.where(cn > 0, 1.0 / np.where(cn > 0, cn, 1.0), 1.0)
    Js = Jv * d[None, :]
    H = np.zeros((P, P))
    M = np.zeros((P, P))
    s2 = np.full(ng, np.nan)
    for j in range(ng):
        sel = gv == j
        n_j = int(sel.sum())
        if n_j == 0 or a[j] == 0:
            continue
        # noise variance of the pair, degrees of freedom shared in proportion to its samples
        s2[j] = float(ev[sel] @ ev[sel]) / max(n_j - P * n_j / n_valid, 1.0)
        JtJ = Js[sel].T @ Js[sel]
        H += a[j] * JtJ
        M += a[j] ** 2 * s2[j] * JtJ
    if block is not None and series is not None:
        M = _batch_means_meat(Js, ev, a[gv], np.asarray(series)[v], time_index, v, block)
    lam, V = np.linalg.eigh(H)
    lmax = float(lam.max()) if lam.size else 0.0
    if lmax <= 0:
        return None, np.full(P, np.nan), dof, s2, math.inf
    cond = float(lmax / lam.min()) if lam.min() > 0 else math.inf
    weak = lam <= rcond * lmax
    inv = (V[:, ~weak] / lam[~weak]) @ V[:, ~weak].T  # H⁺ on the identifiable subspace
    cov_s = inv @ M @ inv
    cov = d[:, None] * cov_s * d[None, :]  # back to the parameters' units
    cov = 0.5 * (cov + cov.T)
    se = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    if weak.any() or (cn == 0).any():
        involved = (np.abs(V[:, weak]) > 1e-3).any(axis=1) | (cn == 0)
        se = np.where(involved, np.nan, se)
        return None, se, dof, s2, cond
    return cov, se, dof, s2, cond


def _batch_means_meat(
    Js: NDArray[np.float64],
    e: NDArray[np.float64],
    a: NDArray[np.float64],
    series: NDArray[np.int64],
    time_index: ArrayLike | None,
    valid: NDArray[np.bool_],
    block: int | str,
) -> NDArray[np.float64]:
    """``Σ_blocks G Gᵀ`` with ``G`` the summed scores ``a e J`` of a block of each series."""
    if time_index is None:
        t = np.zeros(series.size, dtype=np.int64)
        for s in np.unique(series):
            sel = series == s
            t[sel] = np.arange(int(sel.sum()))
    else:
        t = np.asarray(time_index, dtype=np.int64)[valid]
    key = np.empty(series.size, dtype=np.int64)
    uniq = np.unique(series)
    for s in uniq:
        sel = series == s
        n_s = int(sel.sum())
        if block == "auto":
            order = np.argsort(t[sel], kind="stable")
            b = 2 * correlation_length(e[sel][order])
            b = max(1, min(b, n_s // 10 if n_s >= 20 else n_s))
        else:
            b = int(block)
        key[sel] = t[sel] // b
    # one id per (series, block)
    ids = np.unique(np.stack([series, key], axis=1), axis=0, return_inverse=True)[1].ravel()
    scores = (a * e)[:, None] * Js
    G = np.zeros((int(ids.max()) + 1, Js.shape[1]))
    np.add.at(G, ids, scores)
    return G.T @ G


def _effective_weights(problem: Any, z: NDArray[np.float64]) -> NDArray[np.float64]:
    """Local weights ``a_j`` of the problem's objective on unweighted residuals."""
    w = problem.weights
    n = problem.n_samples.astype(float)
    if problem.objective == "mse":
        a = w / n  # Σ_j w_j MSE_j
    else:
        ev = problem.evaluate(np.asarray(z)[None])
        rm = ev.pair_rmse[0]
        rm = np.maximum(rm, 1e-9 * max(float(np.nanmax(rm)), 1e-300))
        # ∇ Σ_j w_j RMSE_j = Σ_j w_j / (2 N_j RMSE_j) ∇ Σ_k e_jk²   ((4) in 000)
        a = w / (n * rm)
    return a / a.max()  # a common factor cancels in the sandwich


def problem_uncertainty(
    problem: Any,
    z: ArrayLike,
    *,
    level: float = 0.95,
    jac: str = "auto",
    J: NDArray[np.float64] | None = None,
    r: NDArray[np.float64] | None = None,
    block: int | str | None = "auto",
    input_noise: Mapping[str, float] | None = None,
    input_prepare: Callable[[Recording], Recording] | None = None,
    n_replicates: int = 40,
    seed: int | None = 0,
) -> ParameterUncertainty:
    """Covariance and confidence intervals of a problem's parameters at ``z``.

    Parameters
    ----------
    problem : Problem
    z : array_like, shape (P,)
        Fitted optimiser vector.
    level : float
        Confidence level of the intervals.
    jac : {"auto", "fd", "exact"}
        How to obtain the Jacobian (central differences for ``"fd"``).
    J, r : ndarray, optional
        Weighted Jacobian and residuals from :meth:`Problem.jacobian` if
        already computed.
    block : "auto", int or None
        Correlated-residual correction (see :func:`covariance_from_jacobian`);
        ``None`` assumes white residuals.
    input_noise : mapping, optional
        Standard deviation of the white measurement noise of recorded
        *input* columns (``{"T_U": 0.1}``, sensor data sheet or
        :func:`estimate_input_noise`). The simulation is driven by these
        measured inputs, so their noise moves the parameters too
        (errors in variables); its share of the covariance is estimated by
        :func:`input_noise_covariance` and added.
    input_prepare : callable, optional
        Preparation applied to the inputs before simulation (e.g. a
        smoothing); applied to the perturbed replicates as well.
    n_replicates : int
        Replicates for the input-noise share.
    seed : int, optional
        Seed of the replicates.

    Returns
    -------
    ParameterUncertainty
    """
    probability("level", level, error=ConfigError, text=False)
    zz = np.asarray(z, dtype=float).reshape(-1)
    if J is None or r is None:
        r, J, _ = problem.jacobian(zz, method=jac, diff="central")
    f = problem._rfac[problem.residual_groups]  # √(w_j/N_j) of each residual row
    use = problem.residual_valid & (f > 0)
    e = np.where(use, r / np.where(f > 0, f, 1.0), 0.0)
    Je = np.where(use[:, None], J / np.where(f > 0, f, 1.0)[:, None], 0.0)
    a = _effective_weights(problem, zz)
    cov, se, dof, s2, cond = covariance_from_jacobian(
        Je,
        e,
        groups=problem.residual_groups,
        weights=a,
        valid=use,
        series=problem.residual_series,
        time_index=problem.residual_time,
        block=block,
    )
    cov_in = None
    if input_noise:
        cov_in = input_noise_covariance(
            problem,
            zz,
            Je,
            a,
            use,
            input_noise,
            prepare=input_prepare,
            n_replicates=n_replicates,
            seed=seed,
        )
        se = np.sqrt(se**2 + np.diag(cov_in))
        if cov is not None:
            cov = cov + cov_in
    t = float(stats.t.ppf(0.5 + level / 2.0, dof))
    corr = None
    if cov is not None:
        d = np.sqrt(np.diag(cov))
        with np.errstate(invalid="ignore", divide="ignore"):
            corr = cov / np.outer(d, d)
    return ParameterUncertainty(
        names=tuple(problem.names),
        values=zz.copy(),
        covariance=cov,
        stderr=se,
        lower=zz - t * se,
        upper=zz + t * se,
        level=float(level),
        dof=int(dof),
        correlation=corr,
        identifiable=np.isfinite(se),
        condition=cond,
        noise_std=np.sqrt(s2),
        input_covariance=cov_in,
    )


def estimate_input_noise(
    recordings: Sequence[Recording], columns: Sequence[str]
) -> dict[str, float]:
    """White-noise level of slowly varying measured inputs, from their first differences.

    For a signal that changes little from one sample to the next, the first
    difference is dominated by the sensor noise: ``σ ≈ 1.4826 · MAD(Δx) / √2``
    (median absolute deviation, robust to the signal's own steps).

    Parameters
    ----------
    recordings : sequence of Recording
    columns : sequence of str
        Columns to assess (e.g. ``["k_U", "T_U"]``; not manipulated inputs
        such as a PWM command, whose steps are not noise).

    Returns
    -------
    dict
        Column → estimated noise standard deviation (pooled over the recordings).

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> rec = Recording(np.arange(5000.0), {"T_U": 25.0 + 0.1 * rng.standard_normal(5000)})
    >>> round(estimate_input_noise([rec], ["T_U"])["T_U"], 2)
    0.1
    """
    out = {}
    for c in columns:
        d = []
        for rec in recordings:
            if c not in rec:
                raise ConfigError(
                    f"recording {rec.experiment_id!r} has no column {c!r}; columns are "
                    f"{list(rec.columns)}"
                )
            x = np.asarray(rec[c], dtype=float)
            dx = np.diff(x[np.isfinite(x)])
            d.append(dx)
        dd = np.concatenate(d) if d else np.empty(0)
        if dd.size < 10:
            raise ConfigError(f"too few samples of {c!r} to estimate its noise")
        mad = float(np.median(np.abs(dd - np.median(dd))))
        out[c] = 1.4826 * mad / math.sqrt(2.0)
    return out


def input_noise_covariance(
    problem: Any,
    z: NDArray[np.float64],
    Je: NDArray[np.float64],
    a: NDArray[np.float64],
    use: NDArray[np.bool_],
    input_noise: Mapping[str, float],
    *,
    prepare: Callable[[Recording], Recording] | None = None,
    n_replicates: int = 40,
    seed: int | None = 0,
) -> NDArray[np.float64]:
    """Covariance share of the parameters due to noise of the measured inputs.

    To first order the fitted parameters move by ``δθ = −H⁻¹ Σ_j a_j J_jᵀ δy_j``
    when the simulated outputs move by ``δy`` (``H = Σ_j a_j J_jᵀ J_j``). The
    outputs move when the measured inputs that drive the simulation carry
    noise. Replicates of that noise (white, the given level, then
    ``prepare``) are added to the recorded inputs and simulated at ``z``;
    the spread of the resulting ``δθ`` estimates the share.

    Parameters
    ----------
    problem : Problem
    z : ndarray, shape (P,)
    Je : ndarray, shape (N, P)
        Jacobian of the unweighted residuals.
    a : ndarray, shape (n_pairs,)
        Effective weights of the pairs.
    use : ndarray of bool, shape (N,)
        Residuals that count.
    input_noise : mapping
        Column → noise standard deviation.
    prepare : callable, optional
        Applied to every perturbed recording (the same preparation as the data).
    n_replicates : int
    seed : int, optional

    Returns
    -------
    ndarray, shape (P, P)
    """
    if n_replicates < 2:
        raise ConfigError(f"n_replicates is {n_replicates!r}, expected >= 2")
    rng = np.random.default_rng(seed)
    g = problem.residual_groups
    w = a[g] * use
    H = Je.T @ (w[:, None] * Je)
    Hinv = np.linalg.pinv(H)
    for c in input_noise:
        for e in problem.experiments:
            if c not in e:
                raise ConfigError(
                    f"input_noise names column {c!r}, which experiment {e.experiment_id!r} lacks"
                )
    f = problem._rfac[g]
    base_prep = [prepare(e) if prepare is not None else e for e in problem.experiments]
    r0 = problem.with_experiments(base_prep).evaluate(z[None], residuals=True).residuals[0]
    deltas = []
    for _ in range(n_replicates):
        recs = []
        for e in problem.experiments:
            cols = {
                c: np.asarray(e[c], dtype=float) + s * rng.standard_normal(e.n_samples)
                for c, s in input_noise.items()
            }
            pe = e.with_columns(cols)
            recs.append(prepare(pe) if prepare is not None else pe)
        ev = problem.with_experiments(recs).evaluate(z[None], residuals=True)
        if not ev.ok[0]:
            continue
        dy = np.where(use, (ev.residuals[0] - r0) / np.where(f > 0, f, 1.0), 0.0)
        deltas.append(-Hinv @ (Je.T @ (w * dy)))
    if len(deltas) < 2:
        raise ConfigError("the input-noise replicates failed to simulate")
    D = np.array(deltas)
    return D.T @ D / len(deltas)


# ---------------------------------------------------------------- identifiability
def collinearity_index(S: ArrayLike) -> float:
    """Collinearity index ``1/√λ_min(ŜᵀŜ)`` of sensitivity columns (Brun et al. 2001).

    Parameters
    ----------
    S : array_like, shape (N, K)
        Sensitivity columns (normalised to unit length here).

    Returns
    -------
    float
        1 for orthogonal columns; ``inf`` for linearly dependent ones.

    Examples
    --------
    >>> collinearity_index([[1.0, 0.0], [0.0, 1.0]])
    1.0
    >>> collinearity_index([[1.0, 1.0], [1.0, 1.0]])
    inf
    """
    Sa = np.asarray(S, dtype=float)
    norms = np.linalg.norm(Sa, axis=0)
    if np.any(norms == 0):
        return math.inf
    Sn = Sa / norms
    lam = float(np.linalg.eigvalsh(Sn.T @ Sn).min())
    return math.inf if lam <= 1e-14 else float(1.0 / math.sqrt(lam))


@dataclass
class Identifiability:
    """Ranking of parameters by importance and the proposed subset to fit.

    Attributes
    ----------
    names : tuple of str
        Candidate parameters.
    importance : ndarray, shape (P,)
        ``δ_msqr`` of the scaled sensitivities (criterion units).
    relative : ndarray, shape (P,)
        Importance relative to the largest.
    order : list of int
        Candidates from most to least important.
    selected : list of str
        The proposed parameters to fit.
    collinearity : dict
        Collinearity index of the proposed subset when each parameter was
        considered (``name -> γ``).
    reasons : dict
        Why each parameter was or was not proposed.
    singular_values : ndarray
        Of the scaled, unit-norm sensitivity matrix (all candidates).
    """

    names: tuple[str, ...]
    importance: NDArray[np.float64]
    relative: NDArray[np.float64]
    order: list[int]
    selected: list[str]
    collinearity: dict[str, float]
    reasons: dict[str, str]
    singular_values: NDArray[np.float64]

    def table(self) -> list[dict[str, Any]]:
        """Rows in ranking order (name, importance, relative, γ, selected, reason)."""
        return [
            {
                "rank": r + 1,
                "name": self.names[i],
                "importance": float(self.importance[i]),
                "relative": float(self.relative[i]),
                "collinearity": self.collinearity.get(self.names[i], math.nan),
                "selected": self.names[i] in self.selected,
                "reason": self.reasons[self.names[i]],
            }
            for r, i in enumerate(self.order)
        ]

    def to_dict(self) -> dict[str, Any]:
        """JSON types."""
        return {
            "selected": list(self.selected),
            "ranking": self.table(),
            "singular_values": self.singular_values.tolist(),
        }

    def __str__(self) -> str:
        lines = [f"{'rank':>4}  {'parameter':<16} {'importance':>11} {'rel':>6} {'gamma':>8}  note"]
        for row in self.table():
            g = row["collinearity"]
            lines.append(
                f"{row['rank']:>4}  {row['name']:<16} {row['importance']:>11.4g} "
                f"{row['relative']:>6.3f} {g:>8.3g}  {'*' if row['selected'] else ' '} "
                f"{row['reason']}"
            )
        return "\n".join(lines)


def identifiability(
    J: ArrayLike,
    names: tuple[str, ...] | list[str],
    scale: ArrayLike,
    *,
    max_collinearity: float = 10.0,
    min_importance: float = 0.05,
    max_params: int | None = None,
) -> Identifiability:
    """Rank parameters and propose an identifiable subset (Brun et al. 2001).

    Parameters
    ----------
    J : array_like, shape (N, P)
        Jacobian of the (weighted) residuals with respect to the parameters.
    names : sequence of str
    scale : array_like, shape (P,)
        ``Δθ_j``: the uncertainty of each parameter (its search range or value).
    max_collinearity : float
        Largest collinearity index of the proposed subset (10-15 usual).
    min_importance : float
        Parameters below this fraction of the largest importance are not proposed.
    max_params : int, optional
        Largest subset size.

    Returns
    -------
    Identifiability

    Examples
    --------
    Two parameters with the same effect cannot both be identified:

    >>> t = np.linspace(0, 1, 50)
    >>> J = np.column_stack([t, 2 * t, np.cos(3 * t)])
    >>> idf = identifiability(J, ["a", "b", "c"], [1.0, 1.0, 1.0])
    >>> idf.selected
    ['b', 'c']
    """
    Ja = np.asarray(J, dtype=float)
    sc = np.abs(np.asarray(scale, dtype=float))
    P = Ja.shape[1] if Ja.ndim == 2 else -1
    if Ja.ndim != 2 or len(names) != P or sc.shape != (P,):
        raise ShapeError(
            f"J has shape {Ja.shape}, {len(names)} names and scale {sc.shape}; they must agree"
        )
    if max_collinearity <= 1:
        raise ConfigError(f"max_collinearity is {max_collinearity!r}, expected > 1")
    S = Ja * sc[None, :]
    N = max(Ja.shape[0], 1)
    imp = np.sqrt((S**2).sum(axis=0) / N)
    top = float(imp.max()) if imp.size else 0.0
    rel = imp / top if top > 0 else np.zeros_like(imp)
    order = [int(i) for i in np.argsort(-imp, kind="stable")]
    norms = np.linalg.norm(S, axis=0)
    Sn = S / np.where(norms > 0, norms, 1.0)
    sv = np.linalg.svd(Sn, compute_uv=False) if Sn.size else np.empty(0)
    selected: list[int] = []
    gam: dict[str, float] = {}
    why: dict[str, str] = {}
    for i in order:
        n = names[i]
        if rel[i] < min_importance:
            why[n] = f"insensitive (importance below {min_importance:g} of the largest)"
            continue
        if max_params is not None and len(selected) >= max_params:
            why[n] = f"subset full ({max_params} parameters)"
            continue
        g = collinearity_index(S[:, [*selected, i]])
        gam[n] = g
        if g <= max_collinearity:
            selected.append(i)
            why[n] = "proposed"
        else:
            # the selected parameter it is most collinear with
            c = np.abs(Sn[:, selected].T @ Sn[:, i]) if selected else np.zeros(0)
            partner = names[selected[int(np.argmax(c))]] if c.size else "?"
            why[n] = (
                f"collinear (γ = {g:.3g} > {max_collinearity:g}), mostly with {partner!r} "
                f"(|cos| = {float(c.max()) if c.size else 0.0:.3f})"
            )
    return Identifiability(
        names=tuple(names),
        importance=imp,
        relative=rel,
        order=order,
        selected=[names[i] for i in selected],
        collinearity=gam,
        reasons=why,
        singular_values=sv,
    )


def problem_identifiability(
    problem: Any,
    z: ArrayLike | None = None,
    *,
    scale: str = "range",
    jac: str = "auto",
    J: NDArray[np.float64] | None = None,
    **kwargs: Any,
) -> Identifiability:
    """Rank a problem's free parameters at ``z`` (default: the start values).

    Parameters
    ----------
    problem : Problem
        With every candidate parameter free.
    z : array_like, optional
    scale : {"range", "value"}
        ``Δθ``: the search range (upper − lower; "how uncertain", as paper
        000's choice of the most uncertain parameters) or ``|θ|``.
    jac : {"auto", "fd", "exact"}
    J : ndarray, optional
        Weighted residual Jacobian if already computed.
    **kwargs
        :func:`identifiability` options.

    Examples
    --------
    >>> from thermogym.rigs import run_experiment
    >>> from thermogym.models.strut import StrutModel
    >>> from thermogym.identification.problem import Problem
    >>> recs = run_experiment("strut", "steps", feed_rates=[20.0], seed=0)
    >>> pb = Problem(StrutModel(), recs, pairs=["T_nut"], fixed={"T_ref": 20.0})
    >>> problem_identifiability(pb).selected[0]
    'r_nut'
    """
    zz = problem.start if z is None else np.asarray(z, dtype=float).reshape(-1)
    if scale == "range":
        d = problem.upper - problem.lower
    elif scale == "value":
        d = np.abs(zz)
    else:
        raise ConfigError(f"scale is {scale!r}, expected 'range' or 'value'")
    if J is None:
        _, J, _ = problem.jacobian(zz, method=jac, diff="central")
    return identifiability(J, tuple(problem.names), d, **kwargs)
