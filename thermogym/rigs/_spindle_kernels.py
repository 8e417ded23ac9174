"""Compiled kernels of the spindle's true plant: bearing friction, right-hand side, RK4.

The SKF frictional moment of each bearing at the rings' temperatures, the heat
balance of every node (conduction, convection with the correlations of
:mod:`thermogym.rigs._convection`, friction and belt heat, the RTD lags) and
the fixed-step RK4 that simulates a batch of specimens. Their on-disk cache
also depends on :mod:`thermogym.rigs._convection`, whose functions they inline.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from thermogym._jitcache import cache_depends_on
from thermogym.rigs import _convection
from thermogym.rigs._convection import (
    h_free_cylinder,
    h_mixed,
    h_moving_surface,
    h_radiation,
    h_rotating_disk,
    h_rotating_shaft,
    k_ratio_rotating_annulus,
)

__all__: list[str] = []


@nb.njit(cache=True, inline="always")
def _viscosity(T, par):  # pragma: no cover - numba
    # base-oil viscosity [mm²/s] at T [°C], ASTM D341 (Walther) through ν40 and ν100
    z = par[1] - par[2] * math.log10(T + 273.15)
    return 10.0 ** (10.0**z) - 0.7


@nb.njit(cache=True, inline="always")
def _skf_moment(n, nu, dm, wall, Fa, Fg, rolling_scale):  # pragma: no cover - numba
    # SKF frictional moment [N mm] of a single-row angular contact ball bearing under the
    # axial load Fa [N], no radial load, Fg [N] the balls' centrifugal load (the concealed
    # input_nonlinearity; 0 otherwise): rolling M_rr = φ_ish φ_rs G_rr (ν n)^0.6, sliding
    # M_sl = G_sl μ_sl (module docstring); rolling_scale multiplies M_rr
    if n <= 0.0:
        return 0.0
    g_rr = 5.03e-7 * dm**1.97 * (Fg + 1.97 * Fa) ** 0.54
    ish = 1.0 / (1.0 + 1.84e-9 * (n * dm) ** 1.28 * nu**0.64)
    rs = math.exp(-6e-8 * nu * n * 2.0 * dm * math.sqrt(4.4 / (2.0 * wall)))
    m_rr = rolling_scale * ish * rs * g_rr * (nu * n) ** 0.6
    g_sl = 1.30e-2 * dm**0.26 * (Fg ** (4.0 / 3.0) + 0.68 * Fa ** (4.0 / 3.0))
    bl = math.exp(-2.6e-8 * (n * nu) ** 1.4 * dm)
    return m_rr + g_sl * (bl * 0.15 + (1.0 - bl) * 0.05)


@nb.njit(cache=True)
def _friction(x, n, bir, bor, bpar, flags, par, k):  # pragma: no cover - numba
    # friction power of bearing k [W]
    tv, law, visc = flags[1], flags[2], flags[3]
    Ti = x[bir[k]]
    To = x[bor[k]]
    nu = _viscosity(0.5 * (Ti + To), par) if visc else par[9]
    churn = 1.0 + par[6] * x[x.shape[0] - 1] if tv else 1.0
    F = bpar[k, 2] + bpar[k, 3] * (Ti - To)
    if F < 0.0:
        F = 0.0
    Fg = par[3] * (n / 1000.0) ** 2
    # the law off: the moment at n_ref for every speed (heat in proportion to the speed)
    m = _skf_moment(n if law else par[0], nu, bpar[k, 1], bpar[k, 4], F, Fg, churn)
    return bpar[k, 0] * m * 1e-3 * n * 2.0 * math.pi / 60.0


@nb.njit(cache=True)
def _bearing_power(x, n, bir, bor, bpar, flags, par, out):  # pragma: no cover - numba
    for b in range(x.shape[0]):
        for k in range(4):
            out[b, k] = _friction(x[b], n, bir, bor, bpar[b], flags, par, k) if n > 0 else 0.0


@nb.njit(cache=True)
def _rhs(
    x, n, Ta, C, ei, ej, eg, eann, A, gb, D, eps, hnat, hrad, ftype, bir, bor, bpar, qbelt,
    ipul, rtd, tau, flags, par, out, rec, record,
):  # pragma: no cover - numba  # fmt: skip
    # dx/dt into out; with record, each node's heat source [W] and conductance to the
    # ambient [W/K] into rec[0], rec[1]
    nn = C.shape[0]
    nl, tv, part, lag = flags[0], flags[1], flags[4], flags[5]
    n = abs(n)
    f_gap = k_ratio_rotating_annulus(n, par[10], par[11]) if flags[6] else 1.0
    for i in range(nn):
        g = gb[i]
        if A[i] > 0.0:
            d = Ta - x[i]
            if nl:
                hn = h_free_cylinder(d, D[i])
                hr = h_radiation(x[i], Ta, eps[i])
            else:
                hn = hnat[i]
                hr = hrad[i]
            if ftype[i] == 1:
                h = h_mixed(hn, h_rotating_shaft(n, D[i]))
            elif ftype[i] == 3:  # pulley: rim as a rotating cylinder, faces as rotating disks
                hf = par[12] * h_rotating_shaft(n, D[i]) + (1.0 - par[12]) * h_rotating_disk(
                    n, par[13]
                )
                h = h_mixed(hn, hf)
            elif ftype[i] == 2:
                h = h_mixed(hn, h_moving_surface(par[4] * n, par[5]))
            else:
                h = hn
            g += A[i] * (h + hr)
        out[i] = g * (Ta - x[i])
        if record:
            rec[0, i] = 0.0
            rec[1, i] = g
    for e in range(ei.shape[0]):
        a = ei[e]
        b = ej[e]
        q = eg[e] * (x[b] - x[a])
        if eann[e]:
            q *= f_gap
        out[a] += q
        out[b] -= q
    if n > 0.0:
        share = 0.5 if part else 0.0
        for k in range(4):
            p = _friction(x, n, bir, bor, bpar, flags, par, k)
            out[bir[k]] += share * p
            out[bor[k]] += (1.0 - share) * p
            if record:
                rec[0, bir[k]] += share * p
                rec[0, bor[k]] += (1.0 - share) * p
        out[ipul] += qbelt * n
        if record:
            rec[0, ipul] += qbelt * n
    for i in range(nn):
        out[i] /= C[i]
    for c in range(7):
        out[nn + c] = (x[rtd[c]] - x[nn + c]) / tau[c] if lag else 0.0
    g = x[nn + 7]
    if tv:
        out[nn + 7] = -g / par[7] if n > 0.0 else (1.0 - g) / par[8]
    else:
        out[nn + 7] = 0.0


@nb.njit(cache=True)
def _simulate(
    x0, U, dt, nsub, C, ei, ej, eg, eann, A, gb, D, eps, hnat, hrad, ftype, bir, bor, bpar,
    qbelt, ipul, rtd, tau, flags, par, y, xs, keep,
):  # pragma: no cover - numba  # fmt: skip
    B, T = U.shape[0], U.shape[1]
    n_x = x0.shape[1]
    nn = C.shape[1]
    h = dt / nsub
    x = np.empty(n_x)
    k1 = np.empty(n_x)
    k2 = np.empty(n_x)
    k3 = np.empty(n_x)
    k4 = np.empty(n_x)
    tmp = np.empty(n_x)
    rec = np.empty((2, 1))
    lag = flags[5]
    for b in range(B):
        x[:] = x0[b]
        for k in range(T):
            for c in range(7):
                y[b, k, c] = x[nn + c] if lag else x[rtd[c]]
            if keep:
                xs[b, k, :] = x
            if k + 1 == T:
                break
            n = U[b, k, 0]
            Ta = U[b, k, 1]
            for _ in range(nsub):
                _rhs(x, n, Ta, C[b], ei, ej, eg[b], eann, A[b], gb[b], D, eps, hnat, hrad,
                     ftype, bir, bor, bpar[b], qbelt[b], ipul, rtd, tau[b], flags, par, k1,
                     rec, False)  # fmt: skip
                for i in range(n_x):
                    tmp[i] = x[i] + 0.5 * h * k1[i]
                _rhs(tmp, n, Ta, C[b], ei, ej, eg[b], eann, A[b], gb[b], D, eps, hnat, hrad,
                     ftype, bir, bor, bpar[b], qbelt[b], ipul, rtd, tau[b], flags, par, k2,
                     rec, False)  # fmt: skip
                for i in range(n_x):
                    tmp[i] = x[i] + 0.5 * h * k2[i]
                _rhs(tmp, n, Ta, C[b], ei, ej, eg[b], eann, A[b], gb[b], D, eps, hnat, hrad,
                     ftype, bir, bor, bpar[b], qbelt[b], ipul, rtd, tau[b], flags, par, k3,
                     rec, False)  # fmt: skip
                for i in range(n_x):
                    tmp[i] = x[i] + h * k3[i]
                _rhs(tmp, n, Ta, C[b], ei, ej, eg[b], eann, A[b], gb[b], D, eps, hnat, hrad,
                     ftype, bir, bor, bpar[b], qbelt[b], ipul, rtd, tau[b], flags, par, k4,
                     rec, False)  # fmt: skip
                for i in range(n_x):
                    x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])


@nb.njit(cache=True)
def _flows(
    X, U, C, ei, ej, eg, eann, A, gb, D, eps, hnat, hrad, ftype, bir, bor, bpar, qbelt, ipul,
    rtd, tau, flags, par, rec, dxdt,
):  # pragma: no cover - numba  # fmt: skip
    for b in range(X.shape[0]):
        _rhs(X[b], U[b, 0], U[b, 1], C[b], ei, ej, eg[b], eann, A[b], gb[b], D, eps, hnat, hrad,
             ftype, bir, bor, bpar[b], qbelt[b], ipul, rtd, tau[b], flags, par, dxdt[b], rec[b],
             True)  # fmt: skip


for _k in (_rhs, _simulate, _flows):
    cache_depends_on(_k, _convection)
