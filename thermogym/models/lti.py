"""The one linear recursion of the package: ``x⁺ = A x + B u``, ``y = h₀ + C x + D u``.

Every discrete linear simulation (state-space models, N4SID's simulations, thermal
networks discretised exactly, switched networks, the machine-tool environments' linear
plants) steps through :func:`lti_update` and reads outputs through :func:`lti_output`.

Both take *transposed* matrices (``At[j, i] = A[i, j]``): the inner loops are then
contiguous updates ``x⁺ += A[:, j] x_j`` that the compiler vectorises without reordering
a floating-point sum. The sum over ``j`` runs in ascending order, the input terms after
the state terms, so results equal a row-by-row dot product bit for bit.
"""

from __future__ import annotations

import numba as nb
import numpy as np
from numpy.typing import NDArray

__all__ = ["lti_output", "lti_update", "transposed"]


@nb.njit(cache=True, inline="always")
def lti_update(At, Bt, x, u, xn):  # type: ignore[no-untyped-def]  # pragma: no cover - numba
    """``xn ← A x + B u`` with ``At = Aᵀ`` (n, n) and ``Bt = Bᵀ`` (m, n); ``xn`` is not ``x``."""
    n = xn.shape[0]
    for i in range(n):
        xn[i] = 0.0
    for j in range(x.shape[0]):
        xj = x[j]
        for i in range(n):
            xn[i] += At[j, i] * xj
    for j in range(u.shape[0]):
        uj = u[j]
        for i in range(n):
            xn[i] += Bt[j, i] * uj


@nb.njit(cache=True, inline="always")
def lti_output(Ct, Dt, h0, x, u, y):  # type: ignore[no-untyped-def]  # pragma: no cover - numba
    """``y ← h₀ + C x + D u`` with ``Ct = Cᵀ`` (n, p) and ``Dt = Dᵀ`` (m, p).

    Pass ``Dt`` of shape (0, p) and an empty ``u`` for outputs without feedthrough.
    """
    p = y.shape[0]
    for i in range(p):
        y[i] = h0[i]
    for j in range(x.shape[0]):
        xj = x[j]
        for i in range(p):
            y[i] += Ct[j, i] * xj
    for j in range(u.shape[0]):
        uj = u[j]
        for i in range(p):
            y[i] += Dt[j, i] * uj


def transposed(M: NDArray[np.float64]) -> NDArray[np.float64]:
    """The last two axes of ``M`` swapped, C-contiguous (the layout of the kernels above).

    Examples
    --------
    >>> import numpy as np
    >>> transposed(np.arange(6.0).reshape(2, 3)).tolist()
    [[0.0, 3.0], [1.0, 4.0], [2.0, 5.0]]
    """
    return np.ascontiguousarray(np.swapaxes(np.asarray(M, dtype=float), -1, -2))
