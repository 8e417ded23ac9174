"""Compiled kernels of the strut's true plant: the annulus, right-hand side, RK4.

The conductance of the air annulus around the screw (free and Taylor-Couette
convection), the heat balance of every node (conduction, convection with the
correlations of :mod:`thermogym.rigs._convection`, friction, copper and iron
losses, the thermocouple lags, the elongation) and the fixed-step RK4 that
simulates a batch of specimens. Their on-disk cache also depends on
:mod:`thermogym.rigs._convection`, whose functions they inline.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from thermogym._jitcache import cache_depends_on
from thermogym.rigs import _convection
from thermogym.rigs._convection import (
    h_free_cylinder,
    h_mixed,
    h_moving_surface,
    h_radiation,
    k_ratio_rotating_annulus,
)

__all__: list[str] = []


@nb.njit(cache=True, inline="always")
def _g_annulus(n_rpm, forced, r_i, r_o, kr_free, g_cond, g_rad):  # pragma: no cover - numba
    # the annulus around the screw per metre [W/(m K)]: its free and its rotating (Taylor-
    # Couette) convection combined as Churchill's n = 3 on their excess over conduction,
    # plus radiation
    kr = kr_free
    if forced and n_rpm > 0.0:
        a = kr_free - 1.0
        b = k_ratio_rotating_annulus(n_rpm, r_i, r_o) - 1.0
        kr = 1.0 + (a * a * a + b * b * b) ** (1.0 / 3.0)
    return kr * g_cond + g_rad


@nb.njit(cache=True)
def _rhs(
    x, v, Ta, C, ei, ej, eg, eann, A, A2, D, eps, hnat, hrad, ftype, xf, qlin, qcu, qwear,
    qvisc, tca, tcb, tcw, tctau, iw, flags, par, out, rec, record,
):  # pragma: no cover - numba  # fmt: skip
    # dx/dt into out; with record, each node's heat source [W] and air conductance [W/K]
    # into rec[0], rec[1]
    nn = C.shape[0]
    nl, fan, visc, tv, cu, tc = flags[0], flags[1], flags[2], flags[3], flags[4], flags[5]
    forced = flags[6]
    n_rpm = abs(v) / par[2]
    g_ann = _g_annulus(n_rpm, forced, par[7], par[8], par[9], par[10], par[11])
    f_ann = g_ann / (par[9] * par[10] + par[11])  # the annulus' links, over their still value
    h_ax = h_moving_surface(abs(v) / 60.0, par[1])
    f_cu = 1.0 + par[3] * (x[iw] - 20.0) if cu else 1.0
    f_wear = 1.0 + par[4] * x[x.shape[0] - 1] if tv else 1.0
    f_visc = (n_rpm / par[5]) ** (5.0 / 3.0) if visc else 0.0
    av = abs(v)
    for i in range(nn):
        s = qlin[i] * av + qcu[i] * av * f_cu + qwear[i] * av * f_wear + qvisc[i] * f_visc
        g = 0.0
        if ftype[i] == 1 and A[i] > 0.0:
            # screw under the bellows: the annulus in series with the bellows' outside
            ga = A[i] * g_ann
            gc = A2[i] * (hnat[i] + hrad[i])
            if nl:  # the bellows' own rise above the air sets its free convection
                dc = (Ta - x[i]) * ga / (ga + gc)
                gc = A2[i] * (h_free_cylinder(dc, D[i]) + h_radiation(Ta - dc, Ta, eps[i]))
            g = ga * gc / (ga + gc)
        elif A[i] > 0.0:
            d = Ta - x[i]
            if nl:
                hn = h_free_cylinder(d, D[i])
                hr = h_radiation(x[i], Ta, eps[i])
            else:
                hn = hnat[i]
                hr = hrad[i]
            hf = 0.0
            if ftype[i] == 2:
                hf = h_ax
            if fan and xf[i] > 0.0:
                hf = h_mixed(hf, h_moving_surface(xf[i] * n_rpm, par[6]))
            h = h_mixed(hn, hf) if hf > 0.0 else hn
            g = A[i] * (h + hr)
        if record:
            rec[0, i] = s
            rec[1, i] = g
        out[i] = s + g * (Ta - x[i])
    for e in range(ei.shape[0]):
        a = ei[e]
        b = ej[e]
        q = eg[e] * (x[b] - x[a])
        if eann[e]:
            q *= f_ann
        out[a] += q
        out[b] -= q
    for i in range(nn):
        out[i] /= C[i]
    for c in range(7):
        src = (1.0 - tcw[c]) * x[tca[c]] + tcw[c] * x[tcb[c]]
        out[nn + c] = (src - x[nn + c]) / tctau[c] if tc else 0.0
    out[nn + 7] = av / 60000.0  # km/s


@nb.njit(cache=True)
def _simulate(
    x0, U, dt, nsub, C, ei, ej, eg, eann, A, A2, D, eps, hnat, hrad, ftype, xf, qlin, qcu,
    qwear, qvisc, tca, tcb, tcw, tctau, wL, iw, flags, par, y, xs, keep,
):  # pragma: no cover - numba  # fmt: skip
    B, T = U.shape[0], U.shape[1]
    n = x0.shape[1]
    nn = C.shape[1]
    h = dt / nsub
    x = np.empty(n)
    k1 = np.empty(n)
    k2 = np.empty(n)
    k3 = np.empty(n)
    k4 = np.empty(n)
    tmp = np.empty(n)
    rec = np.empty((2, 1))
    tc = flags[5]
    for b in range(B):
        x[:] = x0[b]
        for k in range(T):
            for c in range(7):
                if tc:
                    y[b, k, c] = x[nn + c]
                else:
                    y[b, k, c] = (1.0 - tcw[c]) * x[tca[c]] + tcw[c] * x[tcb[c]]
            s = 0.0
            for i in range(nn):
                s += wL[i] * (x[i] - 20.0)
            y[b, k, 7] = 1e6 * 11.5e-6 * s
            if keep:
                xs[b, k, :] = x
            if k + 1 == T:
                break
            v = U[b, k, 0]
            Ta = U[b, k, 1]
            for _ in range(nsub):
                _rhs(x, v, Ta, C[b], ei, ej, eg[b], eann, A[b], A2[b], D, eps, hnat, hrad,
                     ftype, xf, qlin[b], qcu[b], qwear[b], qvisc[b], tca, tcb, tcw, tctau[b],
                     iw, flags, par, k1, rec, False)  # fmt: skip
                for i in range(n):
                    tmp[i] = x[i] + 0.5 * h * k1[i]
                _rhs(tmp, v, Ta, C[b], ei, ej, eg[b], eann, A[b], A2[b], D, eps, hnat, hrad,
                     ftype, xf, qlin[b], qcu[b], qwear[b], qvisc[b], tca, tcb, tcw, tctau[b],
                     iw, flags, par, k2, rec, False)  # fmt: skip
                for i in range(n):
                    tmp[i] = x[i] + 0.5 * h * k2[i]
                _rhs(tmp, v, Ta, C[b], ei, ej, eg[b], eann, A[b], A2[b], D, eps, hnat, hrad,
                     ftype, xf, qlin[b], qcu[b], qwear[b], qvisc[b], tca, tcb, tcw, tctau[b],
                     iw, flags, par, k3, rec, False)  # fmt: skip
                for i in range(n):
                    tmp[i] = x[i] + h * k3[i]
                _rhs(tmp, v, Ta, C[b], ei, ej, eg[b], eann, A[b], A2[b], D, eps, hnat, hrad,
                     ftype, xf, qlin[b], qcu[b], qwear[b], qvisc[b], tca, tcb, tcw, tctau[b],
                     iw, flags, par, k4, rec, False)  # fmt: skip
                for i in range(n):
                    x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])


@nb.njit(cache=True)
def _flows(
    X, U, C, ei, ej, eg, eann, A, A2, D, eps, hnat, hrad, ftype, xf, qlin, qcu, qwear, qvisc,
    tca, tcb, tcw, tctau, iw, flags, par, rec, dxdt,
):  # pragma: no cover - numba  # fmt: skip
    # per specimen: node sources and air conductances (rec), and dx/dt
    for b in range(X.shape[0]):
        _rhs(X[b], U[b, 0], U[b, 1], C[b], ei, ej, eg[b], eann, A[b], A2[b], D, eps, hnat,
             hrad, ftype, xf, qlin[b], qcu[b], qwear[b], qvisc[b], tca, tcb, tcw, tctau[b], iw,
             flags, par, dxdt[b], rec[b], True)  # fmt: skip


cache_depends_on(_rhs, _convection)
cache_depends_on(_flows, _convection)
cache_depends_on(_simulate, _convection)
