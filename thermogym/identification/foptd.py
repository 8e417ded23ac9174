"""FOPTD transfer functions by least squares with a delay search (paper 000, section 4.1).

For every output ``j`` the discrete first-order difference equation (9)-(10)
of ``000_24627a5308ee07db.txt``::

    y[k] = a y[k−1] + Σ_i b_i u_i[k−1−d_i]                                  (9)

is fitted by linear least squares for every integer delay ``d_i`` in a range;
the delay with the smallest mean quadratic error is kept and converted to the
continuous FOPTD ``K e^{−τ s} / (T s + 1)`` with (11)-(12)::

    T = −Δt / ln a,    K_i = b_i / (1 − a),    τ_i = d_i Δt              (11)-(12)

(:func:`thermogym.models.linear.discrete_to_foptd`). "The initial temperature
of the measurements has to be subtracted" (paper 000): the fit works on
deviations from each experiment's operating point (default its first sample)
and assumes the experiment starts at rest.

The paper leaves open which "mean quadratic error" picks the delay. The
equation error of (9) is the least-squares residual itself; the *simulation*
error (the difference equation run on the inputs alone, as the model is used)
separates delays much more sharply on densely sampled data, where neighbouring
delays give nearly the same one-step residual. ``criterion="simulation"`` is
the default, ``"equation"`` the literal alternative.

When the least-squares pole of a candidate falls outside ``(0, 1)`` (an
output that has not settled within the record, plus noise: the paper's tube
sensors), that candidate is refitted by output error with the pole bounded to
``(0, 1)`` (a scalar search on the time constant up to ten record lengths, ``b`` by
least squares for each); an optimum at that bound means the output integrates
or is so far from settling that the record does not determine the gain, and no
FOPTD is returned (:class:`~thermogym.errors.IdentificationError`).

With several inputs the paper's single-input form is extended with one
``b_i`` and one delay per input sharing the pole ``a`` of the output (so
``T_ji = T_j``); the delays are searched coordinate-wise (each input over its
whole range with the others fixed, repeated until nothing changes).

Implementation note: every candidate delay needs only dot products of shifted
series (normal equations of at most ``m + 1`` unknowns) and one first-order
recursive filter (``scipy.signal.lfilter``), so a 7-output fit over hundreds of
delays takes a fraction of a second. No library offers this delay search, hence
the few lines here.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import minimize_scalar
from scipy.signal import lfilter

from thermogym.errors import ConfigError, IdentificationError
from thermogym.fitresult import FitResult
from thermogym.identification.advice import FitWarning, check_fit
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
from thermogym.models._blas import single_blas_thread
from thermogym.models.linear import FOPTDModel, discrete_to_foptd
from thermogym.recording import Recording

__all__ = [
    "CRITERIA",
    "FOPTD_OPERATING_POINTS",
    "FOPTDResult",
    "OutputFit",
    "fit_foptd",
    "fit_foptd_arrays",
]

#: Delay-selection criteria.
CRITERIA: tuple[str, ...] = ("simulation", "equation")
#: Operating-point modes of :func:`fit_foptd`: the shared ones and "estimate" (the default).
FOPTD_OPERATING_POINTS: tuple[str, ...] = ("estimate", *OPERATING_POINTS)


@dataclass
class OutputFit:
    """Least-squares result of one output.

    Attributes
    ----------
    a : float
        Pole of (9), ``0 < a < 1``.
    b : ndarray, shape (m,)
        Input coefficients of (9).
    d : ndarray of int, shape (m,)
        Delays [samples].
    loss : float
        Mean quadratic error (of the criterion) at the chosen delays.
    delay_loss : ndarray, shape (m, n_delays)
        Loss for every candidate delay of input ``i`` with the other delays at
        their chosen values (``inf`` where the least squares gave no stable
        first-order lag).
    cov : ndarray, shape (m + 1, m + 1)
        Covariance of ``(a, b)`` from the equation-error residual (optimistic
        when the residual is coloured).
    """

    a: float
    b: NDArray[np.float64]
    d: NDArray[np.int64]
    loss: float
    delay_loss: NDArray[np.float64]
    cov: NDArray[np.float64]


@dataclass
class FOPTDResult:
    """Outcome of :func:`fit_foptd`.

    Attributes
    ----------
    fit : FitResult
        The ``foptd`` FitResult (parameters, stderr, metrics, data).
    model : FOPTDModel
    K, T, tau : ndarray, shape (n_out, n_exog)
        Gains [output unit/input unit], time constants [s], delays [s].
    outputs : dict of str to OutputFit
    delays : ndarray of int
        Candidate delays [samples].
    dt : float
        Sample period [s].
    seconds : float
        Wall time of the least-squares fit and delay search [s].
    """

    fit: FitResult
    model: FOPTDModel
    K: NDArray[np.float64]
    T: NDArray[np.float64]
    tau: NDArray[np.float64]
    outputs: dict[str, OutputFit]
    delays: NDArray[np.int64]
    dt: float
    seconds: float
    extra: dict[str, Any] = field(default_factory=dict)


def _shift(x: NDArray[np.float64], s: int, hold: bool = True) -> NDArray[np.float64]:
    """``x[k − s]``; before the start ``x[0]`` (steady start) or zero (start from rest)."""
    if s <= 0:
        return x
    return np.concatenate([np.full(s, x[0] if hold else 0.0), x[:-s]])


def _evaluate(
    us: list[NDArray[np.float64]],
    ys: list[NDArray[np.float64]],
    d: NDArray[np.int64],
    criterion: str,
    hold: bool = True,
) -> tuple[float, NDArray[np.float64], NDArray[np.float64], float, int]:
    """Least squares of (9) for delays ``d``; returns loss, theta, gram, rss, rows.

    ``hold``: the inputs held at their first sample before ``t = 0`` (steady
    start); otherwise zero before ``t = 0`` (start from rest, zero input).
    """
    m = d.size
    G = np.zeros((m + 1, m + 1))
    r = np.zeros(m + 1)
    yy = 0.0
    n_rows = 0
    for u, y in zip(us, ys, strict=True):
        # rows k = 1 .. N−1:  y[k] = a y[k−1] + Σ b_i u_i[k−1−d_i]            (9)
        phi = [y[:-1]] + [_shift(u[:, i], int(d[i]), hold)[:-1] for i in range(m)]
        tgt = y[1:]
        for p_ in range(m + 1):
            r[p_] += phi[p_] @ tgt
            for q in range(p_, m + 1):
                G[p_, q] += phi[p_] @ phi[q]
        yy += float(tgt @ tgt)
        n_rows += tgt.size
    G = np.triu(G) + np.triu(G, 1).T
    scale = np.sqrt(np.maximum(np.diag(G), 1e-300))
    try:
        th = np.linalg.solve(G / np.outer(scale, scale), r / scale) / scale
    except np.linalg.LinAlgError:
        return np.inf, np.full(m + 1, np.nan), G, np.inf, n_rows
    rss = max(float(yy - 2 * th @ r + th @ G @ th), 0.0)
    a = float(th[0])
    if not (0.0 < a < 1.0) or not np.isfinite(th).all():
        # the unconstrained pole left (0, 1) (slow output that has not settled, noise):
        # the best stable lag by output error instead, the pole bounded
        th_stable = _stable_fit(us, ys, d, hold)
        if th_stable is None:
            return np.inf, np.full(m + 1, np.nan), G, np.inf, n_rows
        th = th_stable
        rss = 0.0
        for u, y in zip(us, ys, strict=True):
            # equation residual of (9) with the constrained coefficients
            x = sum(th[1 + i] * _shift(u[:, i], int(d[i]), hold) for i in range(m))
            rss += float(np.sum((y[1:] - th[0] * y[:-1] - x[:-1]) ** 2))
        G = np.full_like(G, np.nan)  # no least-squares covariance for this fit
    if criterion == "equation":
        return rss / n_rows, th, G, rss, n_rows
    return _sim_error(us, ys, d, th, hold), th, G, rss, n_rows


def _sim_error(
    us: list[NDArray[np.float64]],
    ys: list[NDArray[np.float64]],
    d: NDArray[np.int64],
    th: NDArray[np.float64],
    hold: bool,
) -> float:
    """Mean squared simulation error of (9) run on the inputs alone."""
    a, b = float(th[0]), th[1:]
    err = 0.0
    count = 0
    for u, y in zip(us, ys, strict=True):
        x = sum(b[i] * _shift(u[:, i], int(d[i]), hold) for i in range(d.size))
        y_ss = float(b @ u[0]) / (1.0 - a) if hold else 0.0  # steady state before t = 0
        ysim, _ = lfilter([0.0, 1.0], [1.0, -a], x, zi=[y_ss])
        err += float(np.sum((y - ysim) ** 2))
        count += y.size
    return err / count


def _stable_fit(
    us: list[NDArray[np.float64]],
    ys: list[NDArray[np.float64]],
    d: NDArray[np.int64],
    hold: bool,
) -> NDArray[np.float64] | None:
    """Pole-constrained output-error fit of (9): ``[a, b…]`` or None (integrating).

    For a fixed pole ``a = e^{−1/T}`` (``T`` in samples) the simulated output is
    linear in ``b``; ``T`` is searched (bounded scalar search on ``ln T``) between
    0.1 sample and 10 record lengths. An optimum at the upper bound means the
    record does not determine the gain (the output integrates, or is so far
    from settling that only ``K/T`` shows): None.
    """
    m = d.size
    y_all = np.concatenate(ys)
    n_max = max(u.shape[0] for u in us)
    lo, hi = np.log(0.1), np.log(10.0 * n_max)

    def columns(a: float) -> NDArray[np.float64]:
        cols = []
        for u in us:
            X = np.empty((u.shape[0], m))
            for i in range(m):
                x = _shift(u[:, i], int(d[i]), hold)
                x_ss = float(u[0, i]) / (1.0 - a) if hold else 0.0
                X[:, i] = lfilter([0.0, 1.0], [1.0, -a], x, zi=[x_ss])[0]
            cols.append(X)
        return np.vstack(cols)

    def solve(lnT: float) -> tuple[float, NDArray[np.float64]]:
        a = float(np.exp(-np.exp(-lnT)))
        X = columns(a)
        b = np.linalg.lstsq(X, y_all, rcond=None)[0]
        return float(np.mean((y_all - X @ b) ** 2)), np.r_[a, b]

    res = minimize_scalar(lambda v: solve(v)[0], bounds=(lo, hi), method="bounded")
    if not np.isfinite(res.fun) or res.x > hi - 1e-2 * (hi - lo):
        return None
    return solve(float(res.x))[1]


def _fit_output(
    us: list[NDArray[np.float64]],
    ys: list[NDArray[np.float64]],
    delays: NDArray[np.int64],
    criterion: str,
    name: str,
    hold: bool = True,
) -> OutputFit:
    m = us[0].shape[1]
    d = np.full(m, int(delays[0]), dtype=np.int64)
    profile = np.full((m, delays.size), np.inf)
    best = np.inf
    for _sweep in range(6):
        changed = False
        for i in range(m):
            for k, cand in enumerate(delays):
                trial = d.copy()
                trial[i] = cand
                profile[i, k] = _evaluate(us, ys, trial, criterion, hold)[0]
            k_best = int(np.argmin(profile[i]))
            val = float(profile[i, k_best])
            if np.isfinite(val) and (not np.isfinite(best) or val < best):
                changed = changed or d[i] != delays[k_best]
                d[i] = delays[k_best]
                best = val
        if m == 1 or not changed:
            break
    loss, th, G, rss, n_rows = _evaluate(us, ys, d, criterion, hold)
    if not np.isfinite(loss):
        raise IdentificationError(
            f"FOPTD of output {name!r}: no delay in {int(delays[0])}..{int(delays[-1])} samples "
            "gives a stable first-order lag (0 < a < 1); the output may not settle (drift, "
            "integrating behaviour) or not respond to the inputs — check the data, the "
            "operating point and the delay range"
        )
    dof = max(n_rows - th.size, 1)
    cov = np.full(G.shape, np.nan)  # pole-constrained fits have none
    if np.isfinite(G).all():
        try:
            cov = rss / dof * np.linalg.inv(G)
        except np.linalg.LinAlgError:
            pass
    return OutputFit(float(th[0]), th[1:].copy(), d, float(loss), profile, cov)


# ------------------------------------------------ output error with offset and initial lag
# operating_point_mode="estimate": no sample is taken as rest. For a pole a and delays d
# the simulated output is linear in the remaining unknowns,
#     y[k] = c + Σ_i b_i x_i[k] + z_e a^k,   x_i[k] = a x_i[k−1] + (u_i[k−1−d_i] − u_op_i)
# (x_i from zero, inputs held at their first sample before t = 0; c the output at rest at
# u_op; z_e the initial lag of experiment e), so c, b and z_e follow by linear least
# squares and only a is searched (a bounded scalar search on ln T). Two starts are fitted:
# "steady" ties each z_e to the steady state of the first input, z_e = Σ_i b_i u_i[0]/(1−a)
# (a recording that starts settled; c still fitted, so no single sample is taken as the
# rest level), "free" fits z_e (a recording that starts mid-transient). The free start is
# kept when it lowers the BIC: an input step right at the start has the same shape as an
# initial lag, and there the free start would trade the gain against z_e. The delays are
# picked with the pole of the equation error of (9) with a constant term; the five best
# delay candidates are then refined by the search on the pole.
def _oe_columns(
    us: list[NDArray[np.float64]], d: NDArray[np.int64], a: float, free: bool
) -> NDArray[np.float64]:
    """Design matrix ``[x_1 … x_m | 1 | a^k of experiment e …]`` of all experiments."""
    m, n_exp = d.size, len(us)
    rows = sum(u.shape[0] for u in us)
    X = np.zeros((rows, m + 1 + (n_exp if free else 0)))
    r0 = 0
    for e, u in enumerate(us):
        n = u.shape[0]
        decay = np.exp(np.arange(n, dtype=float) * np.log(a))  # a^k
        for i in range(m):
            X[r0 : r0 + n, i] = lfilter([0.0, 1.0], [1.0, -a], _shift(u[:, i], int(d[i])))
            if not free:  # the lag starts settled at u[0]: z = b u[0] / (1 − a)
                X[r0 : r0 + n, i] += decay * (u[0, i] / (1.0 - a))
        X[r0 : r0 + n, m] = 1.0
        if free:
            X[r0 : r0 + n, m + 1 + e] = decay
        r0 += n
    return X


def _oe_solve(
    us: list[NDArray[np.float64]],
    y: NDArray[np.float64],
    d: NDArray[np.int64],
    a: float,
    free: bool,
    fixed_c: bool = False,
) -> tuple[float, NDArray[np.float64], NDArray[np.float64]]:
    """Mean squared output error, ``[b…, c, z_e…]`` and the design matrix at pole ``a``.

    ``fixed_c``: the offset ``c`` is given (``y`` is already referred to it);
    its column is left out of the fit and ``c`` is returned as 0.
    """
    X = _oe_columns(us, d, a, free)
    if fixed_c:
        X[:, d.size] = 0.0  # no constant: c = 0 (the pinv below gives the zero column 0)
    # normal equations of the scaled columns (a handful of unknowns, many rows)
    G = X.T @ X
    scale = np.sqrt(np.maximum(np.diag(G), 1e-300))
    Gs = G / np.outer(scale, scale)
    rhs = (X.T @ y) / scale
    try:
        if fixed_c:  # a zero column: solve without it
            raise np.linalg.LinAlgError
        th = np.linalg.solve(Gs, rhs) / scale
        if not np.isfinite(th).all():
            raise np.linalg.LinAlgError
    except np.linalg.LinAlgError:  # collinear columns: the minimum-norm solution
        th = (np.linalg.pinv(Gs, rcond=1e-12, hermitian=True) @ rhs) / scale
    r = y - X @ th
    return float(r @ r) / y.size, th, X


def _oe_search(
    us: list[NDArray[np.float64]],
    y: NDArray[np.float64],
    d: NDArray[np.int64],
    free: bool,
    xatol: float = 1e-5,
    fixed_c: bool = False,
) -> tuple[float, float, float]:
    """Pole of the best output-error fit: ``(a, mse, curvature of the rss in ln T)``.

    ``xatol`` is the tolerance on ``ln T`` (1e-2: the time constant to 1 %).
    """
    n_max = max(u.shape[0] for u in us)
    lo, hi = np.log(0.1), np.log(10.0 * n_max)

    def loss(lnT: float) -> float:
        return _oe_solve(us, y, d, float(np.exp(-np.exp(-lnT))), free, fixed_c)[0]

    res = minimize_scalar(loss, bounds=(lo, hi), method="bounded", options={"xatol": xatol})
    x = float(res.x)
    if not np.isfinite(res.fun):
        return float("nan"), float("inf"), float("nan")
    if x > hi - 1e-2 * (hi - lo):
        # T at the bound: the record does not settle enough to tell the gain from the time
        # constant; kept (its prediction on the record is right), flagged by a nan curvature
        return float(np.exp(-np.exp(-hi))), float(loss(hi)), float("nan")
    h = 1e-3
    curv = (loss(x + h) - 2 * res.fun + loss(x - h)) / h**2 * y.size  # d²rss / d(ln T)²
    return float(np.exp(-np.exp(-x))), float(res.fun), float(curv)


def _equation_pole(
    us: list[NDArray[np.float64]], ys: list[NDArray[np.float64]], d: NDArray[np.int64]
) -> tuple[float, float]:
    """Pole and mean squared equation error of (9) with a constant term."""
    m = d.size
    G = np.zeros((m + 2, m + 2))
    r = np.zeros(m + 2)
    yy, n_rows = 0.0, 0
    for u, y in zip(us, ys, strict=True):
        # y[k] = a y[k−1] + Σ b_i u_i[k−1−d_i] + c                          (9) + constant
        phi = np.column_stack(
            [y[:-1], *(_shift(u[:, i], int(d[i]))[:-1] for i in range(m)), np.ones(y.size - 1)]
        )
        G += phi.T @ phi
        r += phi.T @ y[1:]
        yy += float(y[1:] @ y[1:])
        n_rows += y.size - 1
    scale = np.sqrt(np.maximum(np.diag(G), 1e-300))
    try:
        th = np.linalg.solve(G / np.outer(scale, scale), r / scale) / scale
    except np.linalg.LinAlgError:
        return float("nan"), float("inf")
    rss = max(float(yy - 2 * th @ r + th @ G @ th), 0.0)
    return float(th[0]), rss / n_rows


#: R² above which an initial lag counts as indistinguishable from the input response.
_COLLINEAR = 0.98


@dataclass
class _Estimated:
    fit: OutputFit
    offset: float
    lags: NDArray[np.float64]
    free: bool
    bic: float


def _prefer_free(tied: _Estimated, loose: _Estimated) -> bool:
    """Keep the free start: a lower BIC, and no gain whose sign it reverses.

    A gain that the steady start determines (more than three standard errors
    from zero) and that the free start turns round is the free start trading
    the input response against the initial lag (a step close to the start, or
    dynamics a first-order lag does not have): the initial lag is there to
    describe the start, not to reverse the input's effect.
    """
    if not loose.bic < tied.bic:
        return False
    se = np.sqrt(np.abs(np.diag(tied.fit.cov)[1:]))
    sure = np.abs(tied.fit.b) > 3.0 * np.where(np.isfinite(se), se, np.inf)
    flipped = np.sign(loose.fit.b) != np.sign(tied.fit.b)
    return not bool(np.any(sure & flipped))


@single_blas_thread  # thousands of small products: extra BLAS threads only cost (_blas)
def _fit_output_estimate(
    us: list[NDArray[np.float64]],
    ys: list[NDArray[np.float64]],
    delays: NDArray[np.int64],
    criterion: str,
    name: str,
    free: bool,
    offset: float | None = None,
) -> _Estimated:
    """FOPTD of one output by output error with an offset and a steady or free start.

    ``offset``: the output at rest at ``u_op``, given instead of fitted.
    """
    fixed_c = offset is not None
    if offset is not None:
        off = float(offset)
        ys = [yy - off for yy in ys]
    y = np.concatenate(ys)
    m = us[0].shape[1]
    if np.ptp(y) <= 1e-12 * max(1.0, float(np.abs(y).max())):
        raise IdentificationError(
            f"FOPTD: output {name!r} is constant ({float(y[0])!r}) in the training data; "
            "nothing to identify (check the column and that the inputs reach it)"
        )

    # stage 1 scores a delay by the output error at its best pole (searched to 1 % in T;
    # the equation-error criterion by the least-squares residual of (9))
    def stage1(trial: NDArray[np.int64]) -> float:
        if criterion == "equation":
            a, mse_eq = _equation_pole(us, ys, trial)
            return mse_eq if 0.0 < a < 1.0 else float("inf")
        return _oe_search(us, y, trial, free, xatol=1e-2, fixed_c=fixed_c)[1]

    d = np.full(m, int(delays[0]), dtype=np.int64)
    profile = np.full((m, delays.size), np.inf)
    best = np.inf
    # a long delay range is scanned on a coarse grid first (the profile is smooth in the
    # delay), then at full resolution around the three best coarse candidates
    stride = max(1, int(np.ceil(delays.size / 40)))
    for _sweep in range(6):
        changed = False
        for i in range(m):
            ks = list(range(0, delays.size, stride))
            if stride > 1:
                for k in ks:
                    trial = d.copy()
                    trial[i] = delays[k]
                    profile[i, k] = stage1(trial)
                top = sorted(ks, key=lambda k: profile[i, k])[:3]
                ks = sorted(
                    {j for k in top for j in range(k - stride + 1, k + stride)}
                    & set(range(delays.size)) - set(ks)
                )
            for k in ks:
                trial = d.copy()
                trial[i] = delays[k]
                profile[i, k] = stage1(trial)
            k_best = int(np.argmin(profile[i]))
            val = float(profile[i, k_best])
            if np.isfinite(val) and (not np.isfinite(best) or val < best):
                changed = changed or d[i] != delays[k_best]
                d[i] = delays[k_best]
                best = val
        if m == 1 or not changed:
            break
    # refine the pole of the best candidates (the last input's profile around d)
    last = m - 1
    order = [int(k) for k in np.argsort(profile[last]) if np.isfinite(profile[last, k])][:5]
    found: tuple[float, float, float, NDArray[np.int64]] | None = None
    for k in order:
        trial = d.copy()
        trial[last] = delays[k]
        a, mse, curv = _oe_search(us, y, trial, free, fixed_c=fixed_c)
        a_eq = _equation_pole(us, ys, trial)[0]
        if 0.0 < a_eq < 1.0:
            mse_eq = _oe_solve(us, y, trial, a_eq, free, fixed_c)[0]
            if mse_eq < mse:  # the search missed the equation-error pole's basin
                a, mse = a_eq, mse_eq
        if criterion == "simulation" and np.isfinite(mse):
            profile[last, k] = min(profile[last, k], mse)
        if np.isfinite(mse) and (found is None or mse < found[1]):
            found = (a, mse, curv, trial)
    if found is None:
        raise IdentificationError(
            f"FOPTD of output {name!r}: no delay in {int(delays[0])}..{int(delays[-1])} samples "
            "gives a stable first-order lag within ten record lengths; the output may drift or "
            "integrate, or not respond to the inputs — check the data and the delay range"
        )
    a, mse, curv, d = found
    _, th, X = _oe_solve(us, y, d, a, free, fixed_c)
    b, c = th[:m], float(th[m]) + (offset or 0.0)
    identifiable = True
    if free:
        # an initial lag is told from the gains only if the input-driven columns do not
        # already decay like a^k (an input step right at the start does): R² of the
        # regression of each experiment's a^k column on the other columns
        others = X[:, : m + 1]
        for e in range(len(us)):
            col = X[:, m + 1 + e]
            fit_c = others @ np.linalg.lstsq(others, col, rcond=None)[0]
            ss = float(np.sum((col - col.mean()) ** 2))
            r2 = 1.0 - float(np.sum((col - fit_c) ** 2)) / ss if ss > 0 else 1.0
            if r2 > _COLLINEAR:
                identifiable = False
    if free:
        z0 = th[m + 1 :]
    else:
        z0 = np.array([float(b @ u[0]) / (1.0 - a) for u in us])
    # covariance: (b, c, z) from the linear least squares at the pole; the pole from the
    # curvature of the residual sum of squares in ln T (var = 2 σ² / rss'')
    n_par = th.size + 1 + m  # with the pole and the delays
    dof = max(y.size - n_par, 1)
    s2 = mse * y.size / dof
    cov = np.full((m + 1, m + 1), np.nan)
    try:
        cb = s2 * np.linalg.pinv(X.T @ X)
        cov = np.zeros((m + 1, m + 1))
        cov[1:, 1:] = cb[:m, :m]
        var_ln = 2.0 * s2 / curv if curv > 0 else np.nan
        cov[0, 0] = (a * np.log(a)) ** 2 * var_ln  # da/d(ln T) = −a ln a
    except np.linalg.LinAlgError:
        pass
    loss = float(mse) if criterion == "simulation" else float(np.min(profile[last]))
    bic = y.size * np.log(max(mse, 1e-300)) + n_par * np.log(y.size)
    if not identifiable:
        bic = float("inf")
    return _Estimated(OutputFit(a, b.copy(), d, loss, profile, cov), c, z0, free, float(bic))


def fit_foptd_arrays(
    u: NDArray[np.float64] | Sequence[NDArray[np.float64]],
    y: NDArray[np.float64] | Sequence[NDArray[np.float64]],
    dt: float,
    *,
    delays: Sequence[int] | NDArray[np.int64] = range(0, 21),
    criterion: str = "simulation",
    start: str = "steady",
    names: Sequence[str] | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], list[OutputFit]]:
    """FOPTD parameters from deviation data (numerical core of :func:`fit_foptd`).

    Parameters
    ----------
    u : ndarray (T, m) or sequence of them
        Inputs as deviations from the operating point, one array per experiment.
    y : ndarray (T, p) or sequence of them
        Outputs as deviations, starting at rest.
    dt : float
        Sample period [s].
    delays : sequence of int
        Candidate delays [samples], ascending, >= 0.
    criterion : {"simulation", "equation"}
    start : {"steady", "rest"}
        Before ``t = 0`` the inputs held at their first sample and the outputs
        in the matching steady state, or both zero (at rest, zero input).
    names : sequence of str, optional
        Names of the outputs, for messages (default ``#0``, ``#1``, ...).

    Returns
    -------
    K, T, tau : ndarray, shape (p, m)
    fits : list of OutputFit

    Examples
    --------
    >>> from thermogym.models.linear import FOPTDModel
    >>> u = np.r_[np.zeros(5), np.ones(295)][:, None]
    >>> y = FOPTDModel(K=3.0, T=40.0, tau=7.0).simulate(u, 1.0).outputs[0]
    >>> K, T, tau, _ = fit_foptd_arrays(u, y, 1.0)
    >>> round(float(K[0, 0]), 6), round(float(T[0, 0]), 4), float(tau[0, 0])
    (3.0, 40.0, 7.0)
    """
    us = [np.asarray(v, dtype=float) for v in ([u] if isinstance(u, np.ndarray) else u)]
    ys = [np.asarray(v, dtype=float) for v in ([y] if isinstance(y, np.ndarray) else y)]
    us = [v[:, None] if v.ndim == 1 else v for v in us]
    ys = [v[:, None] if v.ndim == 1 else v for v in ys]
    if criterion not in CRITERIA:
        raise ConfigError(f"criterion is {criterion!r}; expected one of {CRITERIA}")
    if start not in ("steady", "rest"):
        raise ConfigError(f"start is {start!r}; expected 'steady' or 'rest'")
    hold = start == "steady"
    dl = np.asarray(list(delays), dtype=np.int64)
    if dl.size == 0 or (dl < 0).any() or (np.diff(dl) <= 0).any():
        raise ConfigError(f"delays {dl.tolist()[:8]}... must be ascending whole samples >= 0")
    n_min = min(v.shape[0] for v in us)
    if n_min < int(dl[-1]) + 4:
        raise IdentificationError(
            f"FOPTD: the shortest experiment has {n_min} samples, too few for delays up to "
            f"{int(dl[-1])} samples (need at least {int(dl[-1]) + 4}); lower max_delay"
        )
    p, m = ys[0].shape[1], us[0].shape[1]
    label = [str(c) for c in names] if names is not None else [f"#{j}" for j in range(p)]
    fits = [_fit_output(us, [v[:, j] for v in ys], dl, criterion, label[j], hold) for j in range(p)]
    a = np.array([f.a for f in fits])[:, None]
    b = np.stack([f.b for f in fits])
    d = np.stack([f.d for f in fits])
    K, T, tau = discrete_to_foptd(np.broadcast_to(a, (p, m)), b, d, dt)  # (11)-(12)
    return K, T, tau, fits


def _stderr(f: OutputFit, dt: float) -> tuple[float, NDArray[np.float64]]:
    """Standard errors of T and K_i by the delta method on (a, b) of (9)."""
    a, b = f.a, f.b
    la = np.log(a)
    gT = np.zeros(b.size + 1)
    gT[0] = dt / (a * la * la)  # ∂T/∂a, T = −Δt / ln a       (11)
    sT = float(np.sqrt(max(float(gT @ f.cov @ gT), 0.0)))
    sK = np.empty(b.size)
    for i in range(b.size):
        g = np.zeros(b.size + 1)
        g[0] = b[i] / (1 - a) ** 2  # ∂K/∂a, K = b / (1 − a)     (12)
        g[1 + i] = 1.0 / (1 - a)  # ∂K/∂b
        sK[i] = float(np.sqrt(max(float(g @ f.cov @ g), 0.0)))
    return sT, sK


def fit_foptd(
    recordings: Recording | Sequence[Recording],
    inputs: Sequence[str] | str,
    outputs: Sequence[str] | str,
    *,
    disturbances: Sequence[str] | None = None,
    max_delay: int | None = None,
    max_delay_s: float | None = None,
    min_delay: int = 0,
    criterion: str = "simulation",
    operating_point_mode: str = "estimate",
    offsets: Mapping[str, Any] | None = None,
    validate: Recording | Sequence[Recording] = (),
) -> FOPTDResult:
    """Fit a set of FOPTD transfer functions (paper 000, section 4.1) to recordings.

    Parameters
    ----------
    recordings : Recording or sequence
        Training experiments, uniform and finite (see
        :func:`~thermogym.identification.prepare.prepare`), each starting at
        rest.
    inputs : sequence of str
        Exogenous columns (inputs and measured disturbances).
    outputs : sequence of str
        Output columns (each gets its own FOPTD per input).
    disturbances : sequence of str, optional
        Which of ``inputs`` are disturbances (default: the recording's roles).
    max_delay : int, optional
        Largest delay searched [samples]; default ``min(N/4, 300)``.
    max_delay_s : float, optional
        The same in seconds (alternative to ``max_delay``).
    min_delay : int
        Smallest delay searched [samples].
    criterion : {"simulation", "equation"}
        Error that picks the delay (see the module docstring).
    operating_point_mode : {"estimate", "initial", "mean", "rest", "none"}
        ``"estimate"`` (default): no sample is taken as rest; the output
        offset and each experiment's initial lag are fitted with the gains
        (output error, see "Output error with offset and initial lag" in the
        source), the inputs are referred to their mean. The paper's modes
        subtract an operating point from each experiment: ``"initial"``
        (paper 000: the initial values) and ``"mean"`` take the experiment
        to start in a steady state at its first input; ``"rest"`` and
        ``"none"`` at rest with zero input (a heater switched on at ``t = 0``).
    offsets : mapping, optional
        Given operating point ``{"inputs": {NAME: VALUE}, "outputs": {NAME:
        VALUE}}`` (:func:`~thermogym.identification.linear_fit.check_offsets`):
        replaces the mode's value of each signal named, in every experiment;
        with ``"estimate"`` a given output offset is the output at rest at the
        inputs' operating point, fixed instead of fitted. Stored in the
        FitResult as given.
    validate : Recording or sequence
        Recordings for validation metrics.

    Returns
    -------
    FOPTDResult
        ``.fit`` is the FitResult: model ``foptd`` with the operating point
        (``u_op`` in its config, the offsets ``y0``: the output at rest at
        ``u_op``) and a steady start;
        :func:`~thermogym.identification.linear_fit.predict_fit` and the
        metrics simulate it with the initial state estimated from each
        recording's outputs.

    Raises
    ------
    IdentificationError
        An output gives no stable first-order lag, too few samples, constant
        input.

    Examples
    --------
    >>> from thermogym.models.linear import FOPTDModel
    >>> true = FOPTDModel(["v"], ["T1", "T2"], K=[[0.5], [0.2]], T=[[600.0], [1800.0]],
    ...                   tau=[[0.0], [300.0]])
    >>> u = np.r_[np.zeros(3), np.full(237, 20.0)]
    >>> y = 21.0 + true.simulate(u[:, None], 60.0).outputs[0]
    >>> rec = Recording(60.0 * np.arange(240), {"v": u, "T1": y[:, 0], "T2": y[:, 1]})
    >>> res = fit_foptd(rec, ["v"], ["T1", "T2"], max_delay=10)
    >>> res.K.round(4).tolist(), res.T.round(1).tolist(), res.tau.tolist()
    ([[0.5], [0.2]], [[600.0], [1800.0]], [[0.0], [300.0]])
    """
    t_start = time.perf_counter()
    inputs = [inputs] if isinstance(inputs, str) else list(inputs)
    outputs = [outputs] if isinstance(outputs, str) else list(outputs)
    if operating_point_mode not in FOPTD_OPERATING_POINTS:
        raise ConfigError(
            f"operating_point_mode is {operating_point_mode!r}; expected one of "
            f"{FOPTD_OPERATING_POINTS}"
        )
    if criterion not in CRITERIA:
        raise ConfigError(f"criterion is {criterion!r}; expected one of {CRITERIA}")
    given_offsets = check_offsets(offsets, inputs, outputs)  # refused before any work
    given = offset_arrays(given_offsets, inputs, outputs)
    exps = signal_arrays(
        recordings,
        inputs,
        outputs,
        min_samples=8,
        what="FOPTD",
        step_inputs=operating_point_mode == "rest",
    )
    vals = [validate] if isinstance(validate, Recording) else list(validate)
    dt = exps[0].dt
    n_min = min(e.u.shape[0] for e in exps)
    if max_delay is not None and max_delay_s is not None:
        raise ConfigError("give max_delay (samples) or max_delay_s (seconds), not both")
    if max_delay_s is not None:
        max_delay = int(np.floor(max_delay_s / dt + 1e-9))
    if max_delay is None:
        max_delay = max(min(n_min // 4, 300), min_delay)
    if int(max_delay) != max_delay or max_delay < min_delay or min_delay < 0:
        raise ConfigError(
            f"delay range {min_delay}..{max_delay} samples is invalid; expected whole numbers "
            "0 <= min_delay <= max_delay"
        )
    ins, dis = exogenous_roles(exps[0].recording, inputs, disturbances)
    order = [inputs.index(c) for c in ins + dis]  # model column order: inputs, disturbances
    delays = np.arange(int(min_delay), int(max_delay) + 1, dtype=np.int64)
    if operating_point_mode == "estimate":
        u_ref = np.mean(np.concatenate([e.u for e in exps]), axis=0)
        if given is not None:  # a given input offset is the reference of its input
            u_ref = np.where(np.isfinite(given[0]), given[0], u_ref)
        u_ref = u_ref[order]
        us = [e.u[:, order] - u_ref for e in exps]
        fits, y0_list, z0, starts = [], [], [], {}
        for j, name in enumerate(outputs):
            yj = [e.y[:, j] for e in exps]
            c_given = given_offsets["outputs"].get(name)
            tied = _fit_output_estimate(us, yj, delays, criterion, name, False, c_given)
            try:
                loose = _fit_output_estimate(us, yj, delays, criterion, name, True, c_given)
            except IdentificationError:
                loose = tied
            est = loose if _prefer_free(tied, loose) else tied
            fits.append(est.fit)
            y0_list.append(est.offset)
            z0.append(est.lags.tolist())
            starts[name] = "free" if est.free else "steady"
        a = np.array([f.a for f in fits])[:, None]
        b = np.stack([f.b for f in fits])
        dd = np.stack([f.d for f in fits])
        K, T, tau = discrete_to_foptd(np.broadcast_to(a, b.shape), b, dd, dt)  # (11)-(12)
        u_op, y0 = u_ref, np.array(y0_list)
        steady = True
        extra_settings: dict[str, Any] = {
            "initial_lags": dict(zip(outputs, z0, strict=True)),
            "start": starts,
        }
    else:
        us, ys, ops = [], [], []
        for e in exps:
            uo, yo = operating_point(e.u, e.y, operating_point_mode, given)
            assert yo is not None
            us.append((e.u - uo)[:, order])
            ys.append(e.y - yo)
            ops.append((uo[order], yo))
        # initial / mean: the experiment starts in a steady state at its first input;
        # rest / none: at rest with zero (deviation) input before t = 0
        steady = operating_point_mode in ("initial", "mean")
        K, T, tau, fits = fit_foptd_arrays(
            us,
            ys,
            dt,
            delays=delays,
            criterion=criterion,
            start="steady" if steady else "rest",
            names=outputs,
        )
        # operating point of the model: the mean over the experiments (output at rest there)
        u_op = np.mean([o[0] for o in ops], axis=0)
        y0 = np.mean([yo - K @ (uo - u_op) for uo, yo in ops], axis=0)
        extra_settings = {}
    # a given offset is stored as given (the means above equal it up to rounding)
    exo_names = ins + dis
    u_op = np.array([given_offsets["inputs"].get(c, u_op[i]) for i, c in enumerate(exo_names)])
    y0 = np.array([given_offsets["outputs"].get(c, y0[j]) for j, c in enumerate(outputs)])
    seconds = time.perf_counter() - t_start
    rec0 = exps[0].recording
    units = {c: rec0.units[c] for c in ins + dis + outputs if c in rec0.units}
    model = FOPTDModel(
        ins,
        outputs,
        disturbances=dis,
        units=units,
        K=K,
        T=T,
        tau=tau,
        offsets=True,
        y0=y0,
        steady_start=steady,
        u_op=u_op,
    )
    stderr: dict[str, float] = {}
    exo = ins + dis
    for name, f in zip(outputs, fits, strict=True):
        sT, sK = _stderr(f, dt)
        for i, c in enumerate(exo):
            tag = name if len(exo) == 1 else f"{name}__{c}"
            stderr[f"K_{tag}"] = float(sK[i])
            stderr[f"T_{tag}"] = sT
            stderr[f"tau_{tag}"] = float("nan")  # a discrete search, no standard error
    settings = {
        "criterion": criterion,
        "delays_samples": [int(delays[0]), int(delays[-1])],
        "dt": dt,
        "common_pole": True,
        "operating_point": {
            "mode": operating_point_mode,
            "inputs": {c: float(u_op[i]) for i, c in enumerate(exo)},
            "outputs": {c: float(y0[j]) for j, c in enumerate(outputs)},
            **({"given": given_offsets} if given is not None else {}),
        },
        **extra_settings,
        "loss": {c: f.loss for c, f in zip(outputs, fits, strict=True)},
        "seconds": seconds,
    }
    train_recs = [e.recording for e in exps]
    # the recorded ranges: what IdentifiedPlant-v0 scales actions and observations by
    settings["signal_ranges"] = signal_ranges(train_recs, exo + list(outputs))
    fit = FitResult.from_model(
        model,
        method="foptd_least_squares",
        settings=settings,
        stderr=stderr,
        data=data_entries(train_recs, vals),
        notes="paper 000 section 4.1: least squares of eq (9) per output and delay; "
        "eqs (11)-(12); standard errors from the equation-error residual (delta method)",
    )
    fit.metrics["train"] = evaluate_fit(fit, train_recs)
    if vals:
        fit.metrics["validation"] = evaluate_fit(fit, vals)
    fit.add_warnings(_warnings(fit, K, T, tau, dt, delays, n_min, outputs, exo, units))
    return FOPTDResult(
        fit=fit,
        model=model,
        K=K,
        T=T,
        tau=tau,
        outputs=dict(zip(outputs, fits, strict=True)),
        delays=delays,
        dt=dt,
        seconds=seconds,
    )


def _warnings(
    fit: FitResult,
    K: NDArray[np.float64],
    T: NDArray[np.float64],
    tau: NDArray[np.float64],
    dt: float,
    delays: NDArray[np.int64],
    n_min: int,
    outputs: Sequence[str],
    exo: Sequence[str],
    units: dict[str, str],
) -> list[FitWarning]:
    """Fits below zero, gain signs, time constants at the bound, delays at the range's edge."""
    out = check_fit(fit, units=units)
    for j, o in enumerate(outputs):
        for i, c in enumerate(exo):
            if T[j, i] >= 9.0 * n_min * dt:
                out.append(
                    FitWarning(
                        "time_constant_bound",
                        f"time constant of output {o!r} after {c!r} is {T[j, i]:.4g} s, at "
                        f"the search bound (ten record lengths): the record does not settle "
                        f"enough to tell the gain ({K[j, i]:.4g}) from the time constant",
                    )
                )
            if delays.size > 1 and round(tau[j, i] / dt) >= int(delays[-1]):
                out.append(
                    FitWarning(
                        "order_at_edge",
                        f"the delay of output {o!r} after {c!r} is {tau[j, i]:.4g} s, the "
                        f"largest searched ({int(delays[-1])} samples): the best may lie beyond; "
                        "raise the largest delay (--max-delay-s)",
                    )
                )
    return out
