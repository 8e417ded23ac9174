"""Compiled loops of the N4SID identification: ``C A^k``, simulation, state sequences.

The linear recursion is the package's (:mod:`thermogym.models.lti`), compiled
here with ``fastmath``; :func:`simulate_ss` is the deterministic simulation the
identified models are compared and fitted with.
"""

from __future__ import annotations

import numba as nb
import numpy as np
from numpy.typing import NDArray

from thermogym._jitcache import module_kernels_depend_on
from thermogym.models.lti import lti_output, lti_update

__all__ = ["simulate_ss"]


@nb.njit(cache=True)
def _obs_seq(A, C, N):  # pragma: no cover - numba
    """C A^k for k = 0..N−1, shape (N, p, n)."""
    p, n = C.shape
    out = np.empty((N, p, n))
    M = C.copy()
    tmp = np.empty((p, n))
    for k in range(N):
        out[k] = M
        for r in range(p):
            for c in range(n):
                acc = 0.0
                for j in range(n):
                    acc += M[r, j] * A[j, c]
                tmp[r, c] = acc
        M[:, :] = tmp
    return out


@nb.njit(cache=True, fastmath=True)
def _sim(A, B, C, D, u, x0):  # pragma: no cover - numba
    """y[k] = C x + D u, x[k+1] = A x + B u; returns y, shape (T, p).

    The package's linear recursion (:mod:`thermogym.models.lti`) compiled with
    ``fastmath`` (reassociated sums, SIMD); results differ from the strict order
    only in the last bits.
    """
    T = u.shape[0]
    y = np.empty((T, C.shape[0]))
    At, Bt, Ct, Dt = A.T.copy(), B.T.copy(), C.T.copy(), D.T.copy()
    zero = np.zeros(C.shape[0])
    x = x0.copy()
    xn = np.empty(A.shape[0])
    for k in range(T):
        lti_output(Ct, Dt, zero, x, u[k], y[k])
        lti_update(At, Bt, x, u[k], xn)
        x, xn = xn, x
    return y


@nb.njit(cache=True, fastmath=True)
def _states(A, B, u, x0):  # pragma: no cover - numba
    """x[k] for k = 0..T−1 with x[k+1] = A x[k] + B u[k]; shape (T, n)."""
    T = u.shape[0]
    X = np.empty((T, A.shape[0]))
    At, Bt = A.T.copy(), B.T.copy()
    x = x0.copy()
    xn = np.empty(A.shape[0])
    for k in range(T):
        X[k] = x
        lti_update(At, Bt, x, u[k], xn)
        x, xn = xn, x
    return X


def simulate_ss(
    A: NDArray[np.float64],
    B: NDArray[np.float64],
    C: NDArray[np.float64],
    D: NDArray[np.float64],
    u: NDArray[np.float64],
    x0: NDArray[np.float64] | None = None,
) -> NDArray[np.float64]:
    """Deterministic simulation of ``(A, B, C, D)`` (compiled loop), shape (T, p)."""
    x = np.zeros(A.shape[0]) if x0 is None else np.asarray(x0, dtype=float)
    return _sim(
        np.ascontiguousarray(A),
        np.ascontiguousarray(B),
        np.ascontiguousarray(C),
        np.ascontiguousarray(D),
        np.ascontiguousarray(u, dtype=float),
        np.ascontiguousarray(x, dtype=float),
    )


# the kernels above inline the shared linear recursion (derived cache dependencies)
module_kernels_depend_on(globals())
