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

from thermogym.errors import ShapeError
from thermogym.identification.simmodel import ThermogymModel
from thermogym.models.axt211 import AXT211, AXT211_PARAMETERS
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
_IX = {p.name: i for i, p in enumerate(AXT211_PARAMETERS)}
_NP = len(AXT211_PARAMETERS)
_CP, _LPG, _CG, _LGU = _IX["C_P"], _IX["lambda_PG"], _IX["C_G"], _IX["lambda_GU"]
_T0, _KA, _KB, _KC = _IX["T_P0"], _IX["kP_a"], _IX["kP_b"], _IX["kP_c"]
_TAU, _XMAX, _C = _IX["tau_P"], _IX["x_max"], _IX["c_backlash"]
_T_LO, _T_HI = 30.0, 101.0  # validated range of the PTC polynomial (14)


@nb.njit(cache=True)
def _ptc(TP, p, dR):  # pragma: no cover - numba
    """R(T_P) of (14) with its derivative wrt T_P; dR[i] = ∂R/∂R_i."""
    Tc = min(max(TP, _T_LO), _T_HI)
    tau = (Tc - 65.0) / 35.0
    R = 0.0
    dRdtau = 0.0
    pw = 1.0
    for i in range(6):
        R += p[i] * pw
        dR[i] = pw
        if i < 5:
            dRdtau += (i + 1) * p[i + 1] * pw
        pw *= tau
    if TP > _T_HI:
        slope = dRdtau / 35.0
        ext = TP - _T_HI
        R += slope * ext
        pw = 1.0
        for i in range(1, 6):
            dR[i] += ext * i * pw / 35.0
            pw *= tau
        return R, slope
    if TP < _T_LO:
        return R, 0.0
    return R, dRdtau / 35.0


@nb.njit(cache=True)
def _rhs_sens(x, S, v2, TU, p, lo, hi, f, K, dR, pos):  # pragma: no cover - numba
    """f(x) of (17)-(19) and K = f_x S + f_θ (rows T_P, T_G, x_P).

    Column ``pos[i]`` of S and K is the derivative wrt parameter ``i`` (−1: not tracked).
    """
    TP, TG, xP = x[0], x[1], x[2]
    R, dRdT = _ptc(TP, p, dR)
    Pw = v2 / R  # (15)
    dPdT = -Pw / R * dRdT
    CP, lPG, CG, lGU = p[_CP], p[_LPG], p[_CG], p[_LGU]
    q = lPG * (TP - TG)
    f0 = (Pw - q) / CP  # (17)
    f1 = (q - lGU * (TG - TU)) / CG  # (18)
    xpos = max(xP, 0.0)
    kk = (p[_KA] * xpos + p[_KB]) * xpos + p[_KC]  # (21)
    d0 = TP - p[_T0]
    tau = p[_TAU]
    f2 = (kk * d0 - xP) / tau  # (19)
    stopped = (xP >= hi and f2 > 0.0) or (xP <= lo and f2 < 0.0)
    if stopped:
        f2 = 0.0
    f[0], f[1], f[2] = f0, f1, f2
    a_T, a_G = (dPdT - lPG) / CP, lPG / CP
    b_T, b_G = lPG / CG, -(lPG + lGU) / CG
    dk = (2.0 * p[_KA] * xpos + p[_KB]) if xP > 0.0 else 0.0
    c_x, c_T = (dk * d0 - 1.0) / tau, kk / tau
    for j in range(K.shape[1]):
        K[0, j] = a_T * S[0, j] + a_G * S[1, j]
        K[1, j] = b_T * S[0, j] + b_G * S[1, j]
        K[2, j] = 0.0 if stopped else c_x * S[2, j] + c_T * S[0, j]
    for i in range(6):
        if pos[i] >= 0:
            K[0, pos[i]] += -Pw / R * dR[i] / CP
    _add(K, 0, pos[_CP], -f0 / CP)
    _add(K, 0, pos[_LPG], -(TP - TG) / CP)
    _add(K, 1, pos[_LPG], (TP - TG) / CG)
    _add(K, 1, pos[_LGU], -(TG - TU) / CG)
    _add(K, 1, pos[_CG], -f1 / CG)
    if not stopped:
        _add(K, 2, pos[_T0], -kk / tau)
        _add(K, 2, pos[_KA], xpos * xpos * d0 / tau)
        _add(K, 2, pos[_KB], xpos * d0 / tau)
        _add(K, 2, pos[_KC], d0 / tau)
        _add(K, 2, pos[_TAU], -f2 / tau)


@nb.njit(cache=True, inline="always")
def _add(K, row, j, v):  # pragma: no cover - numba
    if j >= 0:
        K[row, j] += v


@nb.njit(cache=True)
def _axt211_sens_kernel(p, u, x0, S0, pos, h, nsub, y, dy):  # pragma: no cover - numba
    T = u.shape[0]
    NP = S0.shape[1]
    x = x0.copy()
    S = S0.copy()
    xs = np.empty(4)
    Ss = np.empty((4, NP))
    f = np.empty((4, 3))
    K = np.empty((4, 3, NP))
    dR = np.empty(6)
    c, xmax = p[_C], p[_XMAX]
    lo, hi = -c, xmax + c
    for k in range(T):
        uk, kU, TU = u[k, 0], u[k, 1], u[k, 2]
        v2 = (kU * uk) * (kU * uk)
        # outputs y = [P, R, T_P, T_G, x_P, x_V]
        R, dRdT = _ptc(x[0], p, dR)
        Pw = v2 / R
        y[k, 0], y[k, 1], y[k, 2], y[k, 3], y[k, 4], y[k, 5] = Pw, R, x[0], x[1], x[2], x[3]
        for j in range(NP):
            dy[k, 0, j] = -Pw / R * dRdT * S[0, j]
            dy[k, 1, j] = dRdT * S[0, j]
            dy[k, 2, j] = S[0, j]
            dy[k, 3, j] = S[1, j]
            dy[k, 4, j] = S[2, j]
            dy[k, 5, j] = S[3, j]
        for i in range(6):
            if pos[i] >= 0:
                dy[k, 0, pos[i]] += -Pw / R * dR[i]
                dy[k, 1, pos[i]] += dR[i]
        if k + 1 == T:
            break
        for _ in range(nsub):
            # classical RK4 on (x, S): stage s at x + a_s h k_{s-1}, S + a_s h K_{s-1}
            for s in range(4):
                a = 0.0 if s == 0 else (0.5 * h if s < 3 else h)
                for i in range(3):
                    xs[i] = x[i] + (a * f[s - 1, i] if s > 0 else 0.0)
                    for j in range(NP):
                        Ss[i, j] = S[i, j] + (a * K[s - 1, i, j] if s > 0 else 0.0)
                _rhs_sens(xs, Ss, v2, TU, p, lo, hi, f[s], K[s], dR, pos)
            for i in range(3):
                x[i] += h / 6.0 * (f[0, i] + 2.0 * f[1, i] + 2.0 * f[2, i] + f[3, i])
                for j in range(NP):
                    S[i, j] += (
                        h / 6.0 * (K[0, i, j] + 2.0 * K[1, i, j] + 2.0 * K[2, i, j] + K[3, i, j])
                    )
            # x_P stays in [−c, x_max + c]; a clamped x_P follows the bound
            if x[2] < lo:
                x[2] = lo
                for j in range(NP):
                    S[2, j] = 0.0
                _add(S, 2, pos[_C], -1.0)
            elif x[2] > hi:
                x[2] = hi
                for j in range(NP):
                    S[2, j] = 0.0
                _add(S, 2, pos[_XMAX], 1.0)
                _add(S, 2, pos[_C], 1.0)
            # backlash (20): x_V = clip(x_V, x_P − c, x_P + c), then within [0, x_max]
            if x[3] < x[2] - c:
                x[3] = x[2] - c
                for j in range(NP):
                    S[3, j] = S[2, j]
                _add(S, 3, pos[_C], -1.0)
            elif x[3] > x[2] + c:
                x[3] = x[2] + c
                for j in range(NP):
                    S[3, j] = S[2, j]
                _add(S, 3, pos[_C], 1.0)
            if x[3] < 0.0:
                x[3] = 0.0
                for j in range(NP):
                    S[3, j] = 0.0
            elif x[3] > xmax:
                x[3] = xmax
                for j in range(NP):
                    S[3, j] = 0.0
                _add(S, 3, pos[_XMAX], 1.0)


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
    )
    return y, dy
