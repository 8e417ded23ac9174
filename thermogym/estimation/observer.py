"""The steady-state observer the firmware runs, and the result of an estimation run.

One observer step (``ν`` the innovation)::

    ν[k]       = z[k] − z_0 − C_z x̂[k] − D_z u[k]
    ŷ_h[k|k]   = y_0 + C_h x̂[k] + D_h u[k] + F ν[k],   F = C_h L
    x̂[k+1]     = A x̂[k] + B u[k] + K ν[k]

``z_0``, ``y_0`` are the constant output terms of a model identified about an
operating point (zero for a model without one).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import IntEnum
from typing import Any

import numba as nb
import numpy as np
from numpy.typing import ArrayLike, NDArray

from thermogym.errors import ParameterError, ShapeError, UnknownNameError
from thermogym.estimation.consistency import normalized_error_squared

__all__ = ["Estimate", "ObserverMatrices", "ObserverStatus", "SteadyStateObserver"]


class ObserverStatus(IntEnum):
    """Status of one observer step; the C firmware returns the same codes.

    Attributes
    ----------
    OK : 0
        The step used the sample.
    BAD_ARGUMENT : 1
        A required argument is missing (C: a NULL pointer).
    NOT_FINITE : 2
        An input or measured channel is NaN or infinite; the estimate holds
        its last valid value and the state does not move.
    OUT_OF_RANGE : 3
        A channel lies outside its configured range; handled as NOT_FINITE.
    NOT_READY : 4
        The observer was not initialised.
    """

    OK = 0
    BAD_ARGUMENT = 1
    NOT_FINITE = 2
    OUT_OF_RANGE = 3
    NOT_READY = 4


# ============================================================ observer numerics
@dataclass(frozen=True)
class ObserverMatrices:
    """The steady-state observer in the form the firmware runs.

    Per sample (physical units, see the module docstring)::

        ν = z − z0 − Cz x − Dz u,   ŷ = y0 + Ch x + Dh u + F ν,   x⁺ = A x + B u + G ν

    Attributes
    ----------
    A, B, G, Cz, Dz, Ch, Dh, F : ndarray
        Shapes (n, n), (n, m), (n, q), (q, n), (q, m), (p, n), (p, m), (p, q).
    N : ndarray, shape (n, m + q) or None
        Rest-state map: ``x_rest = N [u; z]`` is the observer's equilibrium
        for constant readings; when ``I − A + G Cz`` is singular (a barely
        detectable disturbance state), the model's equilibrium for ``u`` with
        the disturbance states at zero; None when neither exists.
    exogenous, measured, hidden : tuple of str
        Channel names.
    lower, upper : ndarray, shape (m + q,)
        Valid range of every exogenous then measured channel.
    dt : float
        Sample period [s].
    units : dict
        Unit of every channel.
    z0, y0 : ndarray, shape (q,) and (p,), optional
        Constant output terms of the measured and hidden channels (a model
        identified about an operating point); zero when None.
    """

    A: NDArray[np.float64]
    B: NDArray[np.float64]
    G: NDArray[np.float64]
    Cz: NDArray[np.float64]
    Dz: NDArray[np.float64]
    Ch: NDArray[np.float64]
    Dh: NDArray[np.float64]
    F: NDArray[np.float64]
    N: NDArray[np.float64] | None
    exogenous: tuple[str, ...]
    measured: tuple[str, ...]
    hidden: tuple[str, ...]
    lower: NDArray[np.float64]
    upper: NDArray[np.float64]
    dt: float
    units: dict[str, str]
    z0: NDArray[np.float64] | None = None
    y0: NDArray[np.float64] | None = None

    @property
    def z_const(self) -> NDArray[np.float64]:
        """``z0`` (zeros when None), shape (q,)."""
        q = self.Cz.shape[0]
        return np.zeros(q) if self.z0 is None else np.asarray(self.z0, dtype=float)

    @property
    def y_const(self) -> NDArray[np.float64]:
        """``y0`` (zeros when None), shape (p,)."""
        p = self.Ch.shape[0]
        return np.zeros(p) if self.y0 is None else np.asarray(self.y0, dtype=float)

    @property
    def dims(self) -> tuple[int, int, int, int]:
        """``(n_states, n_exogenous, n_measured, n_hidden)``."""
        return (self.A.shape[0], self.B.shape[1], self.Cz.shape[0], self.Ch.shape[0])

    def rest_state(self, u: ArrayLike, z: ArrayLike | None = None) -> NDArray[np.float64]:
        """Observer equilibrium ``x = N [u; z − z0]`` for constant readings, shape (n,)."""
        _, m, q, _ = self.dims
        if self.N is None:
            raise ParameterError(
                "the observer has no equilibrium (I − A + G C_z is singular, an integrating "
                "mode); give the initial state explicitly"
            )
        ua = np.asarray(u, dtype=float).reshape(-1)
        za = np.zeros(0) if z is None else np.asarray(z, dtype=float).reshape(-1)
        if ua.shape != (m,) or za.shape != (q,):
            raise ShapeError(f"u has shape {ua.shape} and z {za.shape}; expected ({m},), ({q},)")
        return self.N @ np.concatenate([ua, za - self.z_const])


@nb.njit(cache=True)
def _observer_kernel(A, B, G, Cz, Dz, Ch, Dh, F, lo, hi, u, z, x0, y0, y, xs, nus, status):
    # pragma: no cover - numba
    T, m = u.shape
    n, q, p = A.shape[0], Cz.shape[0], Ch.shape[0]
    x = x0.copy()
    xn = np.empty(n)
    nu = np.zeros(q)
    ylast = y0.copy()
    for k in range(T):
        # validity: every channel finite and inside its range, else hold (firmware semantics)
        code = 0
        for j in range(m + q):
            v = u[k, j] if j < m else z[k, j - m]
            if not math.isfinite(v):
                code = 2
                break
            if v < lo[j] or v > hi[j]:
                code = 3
                break
        status[k] = code
        if code != 0:
            for i in range(p):
                y[k, i] = ylast[i]
            for i in range(n):
                xs[k, i] = x[i]
            for i in range(q):
                nus[k, i] = np.nan
            continue
        # ν = z − Cz x − Dz u
        for i in range(q):
            s = z[k, i]
            for j in range(n):
                s -= Cz[i, j] * x[j]
            for j in range(m):
                s -= Dz[i, j] * u[k, j]
            nu[i] = s
            nus[k, i] = s
        # ŷ = Ch x + Dh u + F ν
        for i in range(p):
            s = 0.0
            for j in range(n):
                s += Ch[i, j] * x[j]
            for j in range(m):
                s += Dh[i, j] * u[k, j]
            for j in range(q):
                s += F[i, j] * nu[j]
            y[k, i] = s
            ylast[i] = s
        for i in range(n):
            xs[k, i] = x[i]
        # x⁺ = A x + B u + G ν
        for i in range(n):
            s = 0.0
            for j in range(n):
                s += A[i, j] * x[j]
            for j in range(m):
                s += B[i, j] * u[k, j]
            for j in range(q):
                s += G[i, j] * nu[j]
            xn[i] = s
        for i in range(n):
            x[i] = xn[i]


class SteadyStateObserver:
    """Step-wise steady-state observer: the Python twin of the C firmware.

    ``reset(u, z)`` starts at the observer equilibrium for the current
    readings; ``step(u, z)`` uses one sample and returns the hidden estimate.
    Invalid samples (NaN, infinite, out of range) leave the state where it is
    and return the last valid estimate with a status saying so. For
    environments, :meth:`update` splits a step into the propagation with the
    input held over the last interval and the correction with the new sample.

    Parameters
    ----------
    matrices : ObserverMatrices

    Examples
    --------
    >>> import numpy as np
    >>> from thermogym.estimation import VirtualSensor
    >>> from thermogym.models.linear import StateSpaceModel
    >>> m = StateSpaceModel.from_matrices([[0.9]], [[0.1]], [[1.0], [2.0]], dt=1.0,
    ...                                   inputs=["u"], outputs=["a", "b"])
    >>> obs = VirtualSensor(m, measured=["a"], measurement_std=0.1).step_observer()
    >>> obs.reset([1.0], [1.0]).round(6).tolist()
    [2.0]
    >>> y, status = obs.step([1.0], [float("nan")])
    >>> y.round(6).tolist(), status.name
    ([2.0], 'NOT_FINITE')
    """

    def __init__(self, matrices: ObserverMatrices) -> None:
        self.matrices = matrices
        n, _, q, p = matrices.dims
        self._x = np.zeros(n)
        self._nu = np.zeros(q)
        self._y = np.zeros(p)
        self._ready = False

    @property
    def dt(self) -> float:
        """Sample period [s]."""
        return float(self.matrices.dt)

    @property
    def input_names(self) -> tuple[str, ...]:
        """Exogenous channels."""
        return self.matrices.exogenous

    @property
    def measured_names(self) -> tuple[str, ...]:
        """Measured channels."""
        return self.matrices.measured

    @property
    def output_names(self) -> tuple[str, ...]:
        """Estimated (hidden) channels."""
        return self.matrices.hidden

    @property
    def state(self) -> NDArray[np.float64]:
        """Current prior state estimate ``x̂[k|k−1]`` (a copy)."""
        return self._x.copy()

    @property
    def estimate(self) -> NDArray[np.float64]:
        """Last valid hidden estimate (a copy)."""
        return self._y.copy()

    def _check(self, u: ArrayLike, z: ArrayLike | None) -> tuple[Any, Any, ObserverStatus]:
        M = self.matrices
        _, m, q, _ = M.dims
        ua = np.asarray(u, dtype=float).reshape(-1)
        za = np.zeros(0) if z is None else np.asarray(z, dtype=float).reshape(-1)
        if ua.shape != (m,) or za.shape != (q,):
            raise ShapeError(
                f"u has shape {ua.shape} and z {za.shape}; expected ({m},) for "
                f"{list(M.exogenous)} and ({q},) for {list(M.measured)}"
            )
        v = np.concatenate([ua, za])
        if not np.isfinite(v).all():
            return ua, za, ObserverStatus.NOT_FINITE
        if (v < M.lower).any() or (v > M.upper).any():
            return ua, za, ObserverStatus.OUT_OF_RANGE
        return ua, za, ObserverStatus.OK

    def _correct(self, ua: NDArray[np.float64], za: NDArray[np.float64]) -> None:
        M = self.matrices
        self._nu = za - M.z_const - M.Cz @ self._x - M.Dz @ ua  # ν = z − z0 − Cz x − Dz u
        self._y = M.y_const + M.Ch @ self._x + M.Dh @ ua + M.F @ self._nu  # ŷ = y0 + Ch x + …

    def reset(self, u: ArrayLike, z: ArrayLike | None = None) -> NDArray[np.float64]:
        """Start at the equilibrium for readings ``(u, z)``; return the estimate there.

        Raises
        ------
        ParameterError
            A reading is invalid (a reset needs one valid sample).
        """
        ua, za, st = self._check(u, z)
        if st != ObserverStatus.OK:
            raise ParameterError(
                f"reset needs valid readings; got status {st.name} for u={ua.tolist()}, "
                f"z={za.tolist()}"
            )
        self._x = self.matrices.rest_state(ua, za)
        self._correct(ua, za)
        self._ready = True
        return self._y.copy()

    def step(
        self, u: ArrayLike, z: ArrayLike | None = None
    ) -> tuple[NDArray[np.float64], ObserverStatus]:
        """Use the sample ``(u[k], z[k])``: return ``ŷ[k|k]`` and advance to ``k + 1``."""
        if not self._ready:
            return self._y.copy(), ObserverStatus.NOT_READY
        ua, za, st = self._check(u, z)
        if st != ObserverStatus.OK:
            return self._y.copy(), st
        M = self.matrices
        self._correct(ua, za)
        self._x = M.A @ self._x + M.B @ ua + M.G @ self._nu  # x⁺ = A x + B u + G ν
        return self._y.copy(), st

    def update(
        self, u_prev: ArrayLike, u: ArrayLike, z: ArrayLike | None = None
    ) -> NDArray[np.float64]:
        """Propagate with ``u_prev`` (held over the last step), then correct with ``z``.

        Equivalent to ``step(u_prev, z_prev)`` followed by the output part of
        ``step(u, z)``; environments call it once per ``env.step``. An invalid
        ``u_prev`` leaves the state where it is, an invalid ``(u, z)`` skips
        the correction; either way the last valid estimate is returned.
        """
        if not self._ready:
            raise ParameterError("update() before reset(); reset the observer first")
        M = self.matrices
        up = np.asarray(u_prev, dtype=float).reshape(-1)
        if up.shape != (M.dims[1],):
            raise ShapeError(f"u_prev has shape {up.shape}, expected ({M.dims[1]},)")
        m = M.dims[1]
        if np.isfinite(up).all() and (up >= M.lower[:m]).all() and (up <= M.upper[:m]).all():
            self._x = M.A @ self._x + M.B @ up + M.G @ self._nu  # x⁺ = A x + B u + G ν
        self._nu = np.zeros_like(self._nu)
        ua, za, st = self._check(u, z)
        if st == ObserverStatus.OK:
            self._correct(ua, za)
        return self._y.copy()


@dataclass(frozen=True)
class Estimate:
    """Output of a filter run over a series.

    Attributes
    ----------
    names : tuple of str
        Estimated signals (columns of ``values``).
    values : ndarray, shape (T, p)
        Estimates ``ŷ[k|k]``.
    cov : ndarray, shape (T, p, p)
        Their error covariance (a read-only broadcast view when constant).
    states : ndarray, shape (T, n)
        State estimates.
    innovations : ndarray, shape (T, q)
        ``ν[k]`` (NaN where the channel was not used).
    innovation_cov : ndarray, shape (T, q, q)
        Innovation covariance ``Σ[k]`` (for the NIS).
    status : ndarray of int8, shape (T,)
        :class:`ObserverStatus` of every sample.
    measured : tuple of str
        Names of the innovation channels.
    """

    names: tuple[str, ...]
    values: NDArray[np.float64]
    cov: NDArray[np.float64]
    states: NDArray[np.float64]
    innovations: NDArray[np.float64]
    innovation_cov: NDArray[np.float64]
    status: NDArray[np.int8]
    measured: tuple[str, ...] = ()

    @property
    def std(self) -> NDArray[np.float64]:
        """Standard deviations of the estimates, shape (T, p)."""
        return np.sqrt(np.clip(np.diagonal(self.cov, axis1=1, axis2=2), 0.0, None))

    def __getitem__(self, name: str) -> NDArray[np.float64]:
        """The estimate of one signal, shape (T,)."""
        try:
            return self.values[:, self.names.index(name)]
        except ValueError:
            raise UnknownNameError(
                f"no estimate {name!r}; estimates are {list(self.names)}"
            ) from None

    def nees(self, truth: ArrayLike, extra_cov: ArrayLike | None = None) -> NDArray[np.float64]:
        """NEES of the estimates against ``truth`` of shape (T, p).

        ``extra_cov`` (p, p) is added to the estimate's covariance, e.g. the
        noise of a *recorded* truth.
        """
        cov = self.cov if extra_cov is None else self.cov + np.asarray(extra_cov, dtype=float)
        return normalized_error_squared(np.asarray(truth, dtype=float) - self.values, cov)

    def nis(self) -> NDArray[np.float64]:
        """NIS of the innovations, shape (T,) (NaN where none was formed)."""
        return normalized_error_squared(self.innovations, self.innovation_cov)
