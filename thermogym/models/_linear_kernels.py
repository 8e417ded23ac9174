"""Compiled loops of the state-space model (:mod:`thermogym.models.linear_ss`).

The kernels take transposed matrices (``At[b, j, i] = A[b, i, j]``) so that the
inner loops are contiguous axpy updates the compiler vectorises without
reordering a floating-point sum.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from thermogym._jitcache import module_kernels_depend_on
from thermogym.models.lti import lti_output, lti_update

__all__: list[str] = []


# ======================================================= state-space kernels
# The kernels take transposed matrices (At[b, j, i] = A[b, i, j]) so that the inner loops
# are contiguous axpy updates (x_new += A[:, j] x_j) that the compiler vectorises without
# reordering a floating-point sum.
@nb.njit(cache=True)
def _ss_simulate_kernel(At, Bt_, Ct, Dt, u, x0, nsub, y, xs, keep):  # pragma: no cover
    nb_, T = At.shape[0], u.shape[1]
    n = At.shape[1]
    p = Ct.shape[2]
    x = np.empty(n)
    xn = np.empty(n)
    zero = np.zeros(p)
    for b in range(nb_):
        ub = b if u.shape[0] > 1 else 0
        Ab, Bb, Cb, Db = At[b], Bt_[b], Ct[b], Dt[b]
        for i in range(n):
            x[i] = x0[b, i]
        for k in range(T):
            # y[k] = C x[k] + D u[k]                      (3) in 001_6d13a2cd04f5de5e.txt
            lti_output(Cb, Db, zero, x, u[ub, k], y[b, k])
            if keep:
                for i in range(n):
                    xs[b, k, i] = x[i]
            if k + 1 == T:
                break
            for _ in range(nsub):
                # x[k+1] = A x[k] + B u[k]   (e = 0)      (3) in 001_6d13a2cd04f5de5e.txt
                lti_update(Ab, Bb, x, u[ub, k], xn)
                x[:] = xn


@nb.njit(cache=True)
def _ss_predict_kernel(At, Bt_, Ct, Dt, Kt, Aht, AhBt, u, y, x0, h, out):  # pragma: no cover
    nb_, T, m = At.shape[0], u.shape[1], u.shape[2]
    n = At.shape[1]
    p = Ct.shape[2]
    xp = np.empty((T, n))
    x = np.empty(n)
    xn = np.empty(n)
    e = np.empty(p)
    yk = np.empty(p)
    P = np.empty(n)
    S = np.empty(n)
    v = np.empty(n)
    for b in range(nb_):
        ub = b if u.shape[0] > 1 else 0
        yb = b if y.shape[0] > 1 else 0
        Ab, Bb, Cb, Db, Kb, Ahb, AhBb = At[b], Bt_[b], Ct[b], Dt[b], Kt[b], Aht[b], AhBt[b]
        # one-step Kalman predictor in innovation form; x̂[k|k−1] is stored in xp[k]:
        # x̂[k+1|k] = A x̂ + B u + K (y − C x̂ − D u) = (A − K C) x̂ + (B − K D) u + K y
        # a missing (NaN) y component gives a zero innovation component.
        for i in range(n):
            x[i] = x0[b, i]
        for k in range(T):
            xp[k, :] = x
            yk[:] = 0.0
            for j in range(n):
                for i in range(p):
                    yk[i] += Cb[j, i] * x[j]
            for j in range(m):
                for i in range(p):
                    yk[i] += Db[j, i] * u[ub, k, j]
            for i in range(p):
                yi = y[yb, k, i]
                e[i] = 0.0 if math.isnan(yi) else yi - yk[i]
            xn[:] = 0.0
            for j in range(n):
                for i in range(n):
                    xn[i] += Ab[j, i] * x[j]
            for j in range(m):
                for i in range(n):
                    xn[i] += Bb[j, i] * u[ub, k, j]
            for j in range(p):
                for i in range(n):
                    xn[i] += Kb[j, i] * e[j]
            x[:] = xn
        # h-step-ahead: x̄[k|k−h] = A^{h−1} x̂[k−h+1|k−h] + S[k],
        # S[k] = Σ_{j=0}^{h−2} A^j B u[k−1−j]; for k < h−1 the data start is x0:
        # x̄ = A^k x0 + S[k] with the window still growing.
        for i in range(n):
            P[i] = x0[b, i]
            S[i] = 0.0
        for k in range(T):
            if k < h - 1:
                for i in range(n):
                    v[i] = P[i] + S[i]
            else:
                v[:] = S
                for j in range(n):
                    for i in range(n):
                        v[i] += Ahb[j, i] * xp[k - h + 1, j]
            # ŷ[k|k−h] = C x̄ + D u[k]
            yk[:] = 0.0
            for j in range(n):
                for i in range(p):
                    yk[i] += Cb[j, i] * v[j]
            for j in range(m):
                for i in range(p):
                    yk[i] += Db[j, i] * u[ub, k, j]
            out[b, k, :] = yk
            # S[k+1] = A S[k] + B u[k] (− A^{h−1} B u[k−h+1] once the window is full)
            xn[:] = 0.0
            for j in range(n):
                for i in range(n):
                    xn[i] += Ab[j, i] * S[j]
            for j in range(m):
                for i in range(n):
                    xn[i] += Bb[j, i] * u[ub, k, j]
                    if k >= h - 1:
                        xn[i] -= AhBb[j, i] * u[ub, k - h + 1, j]
            S[:] = xn
            if k < h - 1:
                xn[:] = 0.0
                for j in range(n):
                    for i in range(n):
                        xn[i] += Ab[j, i] * P[j]
                P[:] = xn


@nb.njit(cache=True)
def _obs_rows(M, A, out):  # pragma: no cover - numba
    # rows of the free response: out[k] = C A^{k0+k}, with M = C A^{k0} updated in place
    L, p, n = out.shape
    tmp = np.empty((p, n))
    for k in range(L):
        for r in range(p):
            for c in range(n):
                out[k, r, c] = M[r, c]
        for r in range(p):
            for c in range(n):
                acc = 0.0
                for j in range(n):
                    acc += M[r, j] * A[j, c]
                tmp[r, c] = acc
        for r in range(p):
            for c in range(n):
                M[r, c] = tmp[r, c]


# the kernels above inline the shared linear recursion (derived cache dependencies)
module_kernels_depend_on(globals())
