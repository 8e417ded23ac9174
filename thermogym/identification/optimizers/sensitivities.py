"""Exact output sensitivities ``∂y/∂θ`` of thermogym's own models (forward sensitivities).

The local methods need the Jacobian of the simulated outputs with respect to
the parameters. Finite differences (paper 002, section III-A) cost one extra
simulation per parameter (``P + 1`` per Jacobian, ``2P + 1`` central) and are
only as accurate as the step allows. Paper 002 names algorithmic
differentiation as the alternative; here the derivatives are propagated
*forward* through the same discretisation the model uses, so they are the exact
derivatives of the simulated samples (up to round-off) at the price of **one**
augmented simulation per experiment:

linear RC networks (:class:`~thermogym.models.thermal_network.ThermalNetworkModel`)
    The sensitivities ``S_i = ∂x/∂θ_i`` obey the linear ODE
    ``dS_i/dt = A S_i + (∂A/∂θ_i) x + (∂B/∂θ_i) u``; with the states this is
    one block-triangular linear system of size ``n (1 + P)``, discretised
    exactly (zero-order hold, matrix exponential) like the model itself.
    ``∂A/∂θ_i``, ``∂B/∂θ_i`` are the derivatives of the algebraic map from
    parameters to network matrices, taken by central differences (exact for
    the ratio parameters, on which the matrices depend linearly).

AXT211 (:class:`~thermogym.models.axt211.AXT211`, no physical effects)
    Discrete forward sensitivities of the model's fixed-step RK4: every stage
    ``k_s = f(x_s)`` carries ``K_s = f_x S_s + f_θ`` with hand-derived partial
    derivatives of eqs (14)-(21) of ``002_dae2310635fe074e.txt``; clamps and the
    backlash operator (20) pass the derivative of the active branch. This is
    forward-mode automatic differentiation of the RK4 map written out by hand
    (numba, one pass) — no AD library differentiates numba kernels.

The initial state's dependence on the parameters (e.g. the rest position
``x_P = −c`` of the AXT211, or a user's ``x0`` callable) is included by finite
differences of the initial-state function (no simulation).

A :class:`~thermogym.identification.simmodel.SimModel` of any other kind may
offer exact derivatives by a method ``sensitivities(theta, experiment) ->
(outputs (T, n_out), jacobian (T, n_out, P))``; :func:`sensitivity_function`
picks it up.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numba as nb
import numpy as np
from numpy.typing import NDArray
from scipy.linalg import expm

from thermogym._jitcache import module_kernels_depend_on
from thermogym.errors import ShapeError
from thermogym.identification.simmodel import ThermogymModel
from thermogym.models import axt211_dynamics as ax
from thermogym.models.axt211 import AXT211, AXT211_PARAMETERS
from thermogym.models.integrators import rk4_accumulate, rk4_finish, rk4_stage_input
from thermogym.models.thermal_network import ThermalNetworkModel, lti_simulate, network_matrices
from thermogym.recording import Recording

__all__ = ["SensitivityFn", "axt211_sensitivities", "network_sensitivities", "sensitivity_function"]

#: ``fn(theta (P,), experiment, columns=None) -> (outputs (T, n_out), d outputs / d theta
#: (T, n_out, len(columns)))``; ``columns`` selects SimModel parameters (default all)
SensitivityFn = Callable[
    [NDArray[np.float64], Recording], tuple[NDArray[np.float64], NDArray[np.float64]]
]


def sensitivity_function(sim_model: Any) -> SensitivityFn | None:
    """Exact sensitivities for ``sim_model``, or ``None`` when it has none.

    Parameters
    ----------
    sim_model : SimModel
        A :class:`ThermogymModel` around an AXT211 or a linear thermal network
        (no physical effects), or any SimModel with a ``sensitivities`` method.

    Returns
    -------
    callable or None
        ``fn(theta, experiment) -> (Y, dY)`` with ``theta`` one row of the
        SimModel's parameters, ``Y`` (T, n_out) and ``dY`` (T, n_out, P).

    Examples
    --------
    >>> from thermogym.models.strut import StrutModel
    >>> from thermogym.identification.simmodel import ThermogymModel
    >>> sensitivity_function(ThermogymModel(StrutModel(), free=["r_nut"])) is not None
    True
    """
    own = getattr(sim_model, "sensitivities", None)
    if callable(own):
        return own
    if not isinstance(sim_model, ThermogymModel):
        return None
    model = sim_model.model
    if getattr(model, "effects", ()):
        return None  # effect kernels are not differentiated
    if isinstance(model, AXT211):
        kernel: Callable[..., Any] = axt211_sensitivities
    elif isinstance(model, ThermalNetworkModel):
        kernel = network_sensitivities
    else:
        return None
    sim_cols = np.array([model.param_index(n) for n in sim_model.param_names], dtype=np.int64)
    x0spec = getattr(sim_model, "x0", "rest")

    def fn(
        theta: NDArray[np.float64],
        experiment: Recording,
        columns: NDArray[np.int64] | None = None,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        full = sim_model.full_theta(np.asarray(theta, dtype=float)[None])
        if full.shape[0] != 1:
            raise ShapeError("sensitivities take one parameter set")
        # only the derivatives asked for (SimModel parameter indices) are propagated
        cols = sim_cols if columns is None else sim_cols[np.asarray(columns, dtype=np.int64)]
        u = experiment.exogenous_array(model)
        x0, S0 = _initial_state_sensitivity(model, x0spec, full, u, experiment, cols)
        return kernel(model, full, u, experiment.dt, x0, S0, cols)

    return fn


def _initial_state_sensitivity(
    model: Any,
    spec: Any,
    full: NDArray[np.float64],
    u: NDArray[np.float64],
    exp: Recording,
    cols: NDArray[np.int64],
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Initial state and its derivative wrt the model parameters ``cols`` (forward differences)."""
    P = cols.size
    h = 1e-6 * np.maximum(np.abs(full[0, cols]), 1e-3)
    batch = np.repeat(full, P + 1, axis=0)
    batch[1 + np.arange(P), cols] += h
    if spec == "rest":
        X = model.initial_state(batch, np.repeat(u[:1], P + 1, axis=0))
    else:
        X = np.asarray(spec(model, batch, exp), dtype=float)
    n = len(model.state_names)
    if X.shape != (P + 1, n):
        raise ShapeError(
            f"the initial state function returned shape {X.shape}, expected ({P + 1}, {n})"
        )
    S0 = ((X[1:] - X[0]) / h[:, None]).T  # (n_x, P)
    return X[0].copy(), np.ascontiguousarray(S0)


# ----------------------------------------------------------------- RC networks
def network_sensitivities(
    model: ThermalNetworkModel,
    full: NDArray[np.float64],
    u: NDArray[np.float64],
    dt: float,
    x0: NDArray[np.float64],
    S0: NDArray[np.float64],
    cols: NDArray[np.int64] | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Outputs and exact output sensitivities of a linear thermal network.

    Parameters
    ----------
    model : ThermalNetworkModel
        Without physical effects.
    full : ndarray, shape (1, P_model)
        Model parameter vector.
    u : ndarray, shape (T, m)
        Exogenous signals (inputs, then the air temperature).
    dt : float
        Sample period [s].
    x0 : ndarray, shape (n,)
    S0 : ndarray, shape (n, P)
        Initial state and its derivatives wrt the parameters ``cols``.
    cols : ndarray of int, shape (P,), optional
        Model parameters to differentiate (default all).

    Returns
    -------
    y : ndarray, shape (T, n_y)
    dy : ndarray, shape (T, n_y, P)
    """
    cols = np.arange(full.shape[1]) if cols is None else np.asarray(cols, dtype=np.int64)
    P = cols.size
    net = model.arrays(full)
    A, Bm = network_matrices(net)
    n, m = A.shape[1], Bm.shape[2]
    if u.shape[1] != m:
        raise ShapeError(f"u has {u.shape[1]} columns, the network takes {m}")
    H, h0 = np.asarray(net.H, dtype=float), net.h0[0]
    ny = H.shape[0]
    # ∂(A, B, h0)/∂θ_i of the algebraic parameter map, central differences
    step = 1e-4 * np.maximum(np.abs(full[0, cols]), 1e-2)
    plus = np.repeat(full, P, axis=0)
    minus = plus.copy()
    plus[np.arange(P), cols] += step
    minus[np.arange(P), cols] -= step
    np_, nm_ = model.arrays(plus), model.arrays(minus)
    Ap, Bp = network_matrices(np_)
    Am, Bmm = network_matrices(nm_)
    dA = (Ap - Am) / (2 * step[:, None, None])
    dB = (Bp - Bmm) / (2 * step[:, None, None])
    dh0 = (np_.h0 - nm_.h0) / (2 * step[:, None])
    # per parameter: d/dt [x; S_i] = [[A, 0], [∂A/∂θ_i, A]] [x; S_i] + [B; ∂B/∂θ_i] u,
    # discretised exactly (zero-order hold) — one small matrix exponential per parameter
    k = 2 * n + m
    M = np.zeros((P, k, k))
    M[:, :n, :n] = A[0]
    M[:, :n, 2 * n :] = Bm[0]
    M[:, n : 2 * n, :n] = dA
    M[:, n : 2 * n, n : 2 * n] = A[0]
    M[:, n : 2 * n, 2 * n :] = dB
    E = expm(M * dt)
    na = n * (1 + P)
    Ad = np.zeros((na, na))
    Bd = np.zeros((na, m))
    Ad[:n, :n] = E[0, :n, :n]
    Bd[:n] = E[0, :n, 2 * n :]
    for i in range(P):
        r = slice(n * (1 + i), n * (2 + i))
        Ad[r, :n] = E[i, n : 2 * n, :n]
        Ad[r, r] = E[i, n : 2 * n, n : 2 * n]
        Bd[r] = E[i, n : 2 * n, 2 * n :]
    Ha = np.zeros((ny * (1 + P), na))
    Ha[:ny, :n] = H
    h0a = np.zeros(ny * (1 + P))
    h0a[:ny] = h0
    for i in range(P):  # H does not depend on θ in these networks (outputs are node sums)
        Ha[ny * (1 + i) : ny * (2 + i), n * (1 + i) : n * (2 + i)] = H
        h0a[ny * (1 + i) : ny * (2 + i)] = dh0[i]
    z0 = np.concatenate([x0, S0.T.ravel()])
    ya, _ = lti_simulate(Ad[None], Bd[None], Ha, h0a[None], z0[None], u[None])
    T = u.shape[0]
    y = ya[0, :, :ny]
    dy = ya[0, :, ny:].reshape(T, P, ny).transpose(0, 2, 1)
    return np.ascontiguousarray(y), np.ascontiguousarray(dy)


# ----------------------------------------------------------------------- AXT211
_NP = len(AXT211_PARAMETERS)
_C, _XMAX = ax.I_C, ax.I_XMAX
#: rows and parameters of the right-hand side's parameter derivatives (ax.rhs_partials)
_PART_ROW = np.array([r for r, _ in ax.PARTIALS], dtype=np.int64)
_PART_PAR = np.array([j for _, j in ax.PARTIALS], dtype=np.int64)


@nb.njit(cache=True, inline="always")
def _add(K, row, j, v):  # pragma: no cover - numba
    if j >= 0:
        K[row, j] += v


@nb.njit(cache=True)
def _rhs_sens(x, S, v2, TU, q, K, pos, prow, ppar):  # pragma: no cover - numba
    """f(x) of (14)-(21) and K = f_x S + f_θ (rows T_P, T_G, x_P), from ax.rhs_partials.

    Column ``pos[i]`` of S and K is the derivative wrt parameter ``i`` (−1: not tracked).
    """
    f, _R, _stopped, J, d = ax.rhs_partials(x, v2, TU, q)
    for j in range(K.shape[1]):
        K[0, j] = J[0] * S[0, j] + J[1] * S[1, j]
        K[1, j] = J[2] * S[0, j] + J[3] * S[1, j]
        K[2, j] = J[4] * S[2, j] + J[5] * S[0, j]
    for m in range(prow.shape[0]):
        _add(K, prow[m], pos[ppar[m]], d[m])
    return f


@nb.njit(cache=True)
def _axt211_sens_kernel(p, u, x0, S0, pos, h, nsub, y, dy, prow, ppar):  # pragma: no cover
    T = u.shape[0]
    NP = S0.shape[1]
    q = ax.coefficients(p)
    x = (x0[0], x0[1], x0[2])
    xV = x0[3]
    S = S0.copy()
    Ss = np.empty((3, NP))
    # zeros, not empty: stage 1 forms S + 0·K before any K is computed, and 0·NaN from
    # uninitialised memory made a whole sensitivity run NaN now and then (a CI run)
    K = np.zeros((3, NP))
    KS = np.empty((3, NP))  # the weighted stage sum of the K
    c, xmax = p[_C], p[_XMAX]
    lo, hi = -c, xmax + c
    for k in range(T):
        uk, kU, TU = u[k, 0], u[k, 1], u[k, 2]
        v = kU * uk
        v2 = v * v
        # outputs y = [P, R, T_P, T_G, x_P, x_V] as the model's (ax.outputs)
        yk = ax.outputs((x[0], x[1], x[2], xV), v2, q, 0.0)
        for j in range(6):
            y[k, j] = yk[j]
        R = yk[1]
        dRdT, dRi = ax.resistance_partials(x[0], q)
        dPdR = -v2 / (R * R)
        for j in range(NP):
            dy[k, 0, j] = dPdR * dRdT * S[0, j]
            dy[k, 1, j] = dRdT * S[0, j]
            dy[k, 2, j] = S[0, j]
            dy[k, 3, j] = S[1, j]
            dy[k, 4, j] = S[2, j]
            dy[k, 5, j] = S[3, j]
        for i in range(6):
            if pos[ax.I_R0 + i] >= 0:
                dy[k, 0, pos[ax.I_R0 + i]] += dPdR * dRi[i]
                dy[k, 1, pos[ax.I_R0 + i]] += dRi[i]
        if k + 1 == T:
            break
        for _ in range(nsub):
            # the model's RK4 (shared stage functions) on x, the same stages on S
            f = x
            fs = x
            for st in range(1, 5):
                a = 0.0 if st == 1 else (h if st == 4 else 0.5 * h)
                xs = rk4_stage_input(x, f, h, st)
                for i in range(3):
                    for j in range(NP):
                        Ss[i, j] = S[i, j] + a * K[i, j]
                f = _rhs_sens(xs, Ss, v2, TU, q, K, pos, prow, ppar)
                fs = rk4_accumulate(fs, f, st)
                w = 1.0 if (st == 1 or st == 4) else 2.0
                for i in range(3):
                    for j in range(NP):
                        KS[i, j] = K[i, j] if st == 1 else KS[i, j] + w * K[i, j]
            x = rk4_finish(x, h, fs)
            for i in range(3):
                for j in range(NP):
                    S[i, j] += h / 6.0 * KS[i, j]
            xP, xVn = ax.constrain(x[2], xV, q)
            # a clamped x_P follows the bound
            if x[2] < lo:
                for j in range(NP):
                    S[2, j] = 0.0
                _add(S, 2, pos[_C], -1.0)
            elif x[2] > hi:
                for j in range(NP):
                    S[2, j] = 0.0
                _add(S, 2, pos[_XMAX], 1.0)
                _add(S, 2, pos[_C], 1.0)
            x = (x[0], x[1], xP)
            # backlash (20): x_V = clip(x_V, x_P − c, x_P + c), then within [0, x_max]
            if xP < xV - c:
                for j in range(NP):
                    S[3, j] = S[2, j]
                _add(S, 3, pos[_C], 1.0)
                xV = xP + c
            elif xP > xV + c:
                for j in range(NP):
                    S[3, j] = S[2, j]
                _add(S, 3, pos[_C], -1.0)
                xV = xP - c
            if xV < 0.0:
                for j in range(NP):
                    S[3, j] = 0.0
            elif xV > xmax:
                for j in range(NP):
                    S[3, j] = 0.0
                _add(S, 3, pos[_XMAX], 1.0)
            xV = xVn


def axt211_sensitivities(
    model: AXT211,
    full: NDArray[np.float64],
    u: NDArray[np.float64],
    dt: float,
    x0: NDArray[np.float64],
    S0: NDArray[np.float64],
    cols: NDArray[np.int64] | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Outputs and exact RK4 sensitivities of the AXT211 (no physical effects).

    Parameters
    ----------
    model : AXT211
    full : ndarray, shape (1, 17)
        Model parameter vector.
    u : ndarray, shape (T, 3)
        ``u``, ``k_U`` [V], ``T_U`` [°C].
    dt : float
        Sample period [s].
    x0 : ndarray, shape (4,)
    S0 : ndarray, shape (4, P)
        Initial state and its derivatives wrt the parameters ``cols``.
    cols : ndarray of int, shape (P,), optional
        Model parameters to differentiate (default all 17).

    Returns
    -------
    y : ndarray, shape (T, 6)
        ``P_PTC, R_PTC, T_P, T_G, x_P, x_V``.
    dy : ndarray, shape (T, 6, P)
    """
    if full.shape[1] != _NP:
        raise ShapeError(f"AXT211 sensitivities need {_NP} parameters, got {full.shape[1]}")
    cols = np.arange(_NP) if cols is None else np.asarray(cols, dtype=np.int64)
    pos = np.full(_NP, -1, dtype=np.int64)
    pos[cols] = np.arange(cols.size)
    n = model.n_substeps(dt)
    T = u.shape[0]
    y = np.empty((T, 6))
    dy = np.empty((T, 6, cols.size))
    _axt211_sens_kernel(
        np.ascontiguousarray(full[0]),
        np.ascontiguousarray(u),
        np.ascontiguousarray(x0),
        np.ascontiguousarray(S0),
        pos,
        dt / n,
        n,
        y,
        dy,
        _PART_ROW,
        _PART_PAR,
    )
    return y, dy


# the kernels above inline compiled functions of other modules (derived cache dependencies)
module_kernels_depend_on(globals())
