"""Virtual sensors: Kalman filters and steady-state observers on identified models.

Description
-----------
Paper ``001_6d13a2cd04f5de5e.txt`` (abstract, section 3.3) writes an identified
linear model into the firmware of its sensor module so that the module computes
the spindle's *internal* temperatures (bearings, inner housing), which no
sensor can reach, from its *surface* temperatures. This module holds the
numerics of such virtual sensors:

* :class:`VirtualSensor` — a linear state-space model (``ss``,
  :class:`~thermogym.models.linear.StateSpaceModel`) split into **exogenous**
  signals (known exactly: speed, ambient temperature), **measured** outputs
  (the surface RTDs the module reads) and **hidden** outputs (the internal
  temperatures it estimates). It gives a time-varying Kalman filter built
  with filterpy (:meth:`VirtualSensor.filter`) and the steady-state observer
  the firmware runs (:meth:`VirtualSensor.observe`, :class:`SteadyStateObserver`),
  whose gain comes from the discrete algebraic Riccati equation (scipy).
* :class:`AXT211WaxUKF` — an unscented Kalman filter (filterpy) over the
  AXT211 model's step function that estimates the wax temperature ``T_P`` of
  paper ``002_dae2310635fe074e.txt`` from the valve stroke and the supply.
* Filter consistency: normalised estimation error squared (NEES), normalised
  innovation squared (NIS) and chi-square tests (:func:`consistency`).
* :func:`balanced_truncation` — model reduction for reference models and
  for fitting a model into a small target.

What the observer corrects with (a design decision)
---------------------------------------------------
In Table 6 of paper 001 the surface temperatures are *inputs* of the identified
models (3I5O: speed and two outer-housing temperatures in, five internal
temperatures out; 2I5O, 1I5O likewise) and the internal temperatures are the
*outputs*. Such a model is an input-driven estimator: the measurements already
reach the state through ``B``, and no measured output remains to form an
innovation, so its Kalman gain is zero. :class:`VirtualSensor` covers it with
``measured=()`` (the filter then only propagates the estimate's covariance).

The formulation this module recommends keeps the surface temperatures as
*measured outputs*: a model with the known signals as exogenous inputs
(speed and ambient temperature, the 1I7O model of Table 6 plus the ambient the
module's second channel group records) and all seven temperatures as outputs,
two of them measured. The Kalman filter then corrects the state with the
surface innovations — this removes a wrong initial state (a machine switched
on warm), absorbs unmeasured heat and ambient disturbances and, with
``disturbance_inputs=("speed",)`` (a random-walk input disturbance), a biased
speed-to-heat gain. The reasons: (1) an innovation is the only way an observer
can notice that its model is wrong; (2) a surface-as-input model has no place
for sensor noise on those inputs (it passes straight into the estimate);
(3) the measured-output model keeps the ambient temperature, without which an
LTI model in absolute temperatures cannot reproduce the daily swing of the room
(with ambient-subtracted data the neglected term ``C dT_amb/dt`` costs about
0.15 K on the rig). Both formulations run in the same firmware.

Equations
---------
Model (innovation form of paper 001 eq 3, discrete matrices, measured part
``z`` and hidden part ``y_h`` of the outputs)::

    x[k+1] = A x[k] + B u[k] + w[k]                  cov w = Q
    z[k]   = C_z x[k] + D_z u[k] + v[k]              cov v = R,  cov(w, v) = S
    y_h[k] = C_h x[k] + D_h u[k]

Steady-state Kalman filter (P from the DARE)::

    P = A P Aᵀ + Q − (A P C_zᵀ + S) Σ⁻¹ (A P C_zᵀ + S)ᵀ,  Σ = C_z P C_zᵀ + R
    L = P C_zᵀ Σ⁻¹                  (filter gain, x̂[k|k] = x̂[k|k−1] + L ν)
    K = (A P C_zᵀ + S) Σ⁻¹          (predictor gain)

One observer step, as the firmware runs it (``ν`` the innovation)::

    ν[k]       = z[k] − C_z x̂[k] − D_z u[k]
    ŷ_h[k|k]   = C_h x̂[k] + D_h u[k] + F ν[k],   F = C_h L
    x̂[k+1]     = A x̂[k] + B u[k] + K ν[k]

With the innovation-form noise of an identified model (``w = K_id e``,
``v = e_z``) and every output measured, this gain is the identified ``K_id``
itself (P = 0): the predictor of :meth:`StateSpaceModel.predict`.

Version History
---------------
* v1: initial release.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from enum import IntEnum
from typing import Any

import numba as nb
import numpy as np
import scipy.linalg
import scipy.optimize
import scipy.stats
from numpy.typing import ArrayLike, NDArray

from thermogym.errors import ConfigError, ParameterError, ShapeError, UnknownNameError
from thermogym.models.base import ThetaLike
from thermogym.models.linear import StateSpaceModel

__all__ = [
    "AXT211WaxUKF",
    "ConsistencyReport",
    "Estimate",
    "KalmanGains",
    "NoiseModel",
    "ObserverMatrices",
    "ObserverStatus",
    "SteadyStateObserver",
    "VirtualSensor",
    "balanced_truncation",
    "consistency",
    "innovation_covariance",
    "normalized_error_squared",
    "steady_state_gains",
]

_TEMPERATURE_UNITS = ("°C", "degC", "C", "K")


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


# ============================================================== small helpers
def _mat(name: str, value: ArrayLike, shape: tuple[int, int]) -> NDArray[np.float64]:
    a = np.asarray(value, dtype=float)
    if a.ndim == 0 and shape == (1, 1):
        a = a.reshape(1, 1)
    if a.shape != shape:
        raise ShapeError(f"{name} has shape {a.shape}, expected {shape}")
    if not np.isfinite(a).all():
        r, c = np.argwhere(~np.isfinite(a))[0]
        raise ParameterError(f"{name}[{r}, {c}] is {a[r, c]!r}; expected a finite number")
    return a


def _check_psd(name: str, M: NDArray[np.float64], *, definite: bool = False) -> None:
    if M.size == 0:
        return
    if not np.allclose(M, M.T, rtol=1e-9, atol=1e-12 * max(1.0, float(np.abs(M).max()))):
        raise ParameterError(f"{name} is not symmetric; a covariance must be")
    w = np.linalg.eigvalsh(0.5 * (M + M.T))
    tol = 1e-10 * max(1.0, float(np.abs(w).max()))
    if definite and w.min() <= 0:
        raise ParameterError(
            f"{name} has eigenvalue {w.min():.3g}; expected a positive definite covariance "
            "(every measured channel needs some noise)"
        )
    if w.min() < -tol:
        raise ParameterError(
            f"{name} has eigenvalue {w.min():.3g}; expected a positive semi-definite covariance"
        )


def _psd_sqrt_rows(P: NDArray[np.float64]) -> NDArray[np.float64]:
    """Upper factor ``U`` with ``Uᵀ U = P``: Cholesky, or eigen-clipping when P is singular."""
    try:
        return scipy.linalg.cholesky(P, lower=False)
    except (np.linalg.LinAlgError, scipy.linalg.LinAlgError):
        w, V = np.linalg.eigh(0.5 * (P + P.T))
        return (V * np.sqrt(np.clip(w, 0.0, None))).T


def _spectral_radius(A: NDArray[np.float64]) -> float:
    return float(np.abs(np.linalg.eigvals(A)).max()) if A.size else 0.0


def _names(value: Sequence[str] | str, what: str) -> tuple[str, ...]:
    if isinstance(value, str):
        return (value,)
    return tuple(str(v) for v in value)


# ================================================================ noise model
@dataclass(frozen=True)
class NoiseModel:
    """Process and measurement noise of a linear model.

    ``x[k+1] = A x + B u + w``, ``z = C_z x + D_z u + v`` with ``cov w = Q``,
    ``cov v = R`` and the cross-covariance ``E[w vᵀ] = S`` (non-zero for the
    innovation form of an identified model, where ``w = K e`` and ``v = e``).

    Parameters
    ----------
    Q : array_like, shape (n, n)
        Process noise covariance [state units², per sample].
    R : array_like, shape (q, q)
        Measurement noise covariance [measured unit²], positive definite.
    S : array_like, shape (n, q), optional
        Cross-covariance; zero when omitted.

    Examples
    --------
    >>> import numpy as np
    >>> nm = NoiseModel.from_innovation(K=[[0.5], [0.1]], Re=[[0.04]], measured=[0])
    >>> nm.Q.round(4).tolist(), nm.S.round(4).tolist()
    ([[0.01, 0.002], [0.002, 0.0004]], [[0.02], [0.004]])
    """

    Q: NDArray[np.float64]
    R: NDArray[np.float64]
    S: NDArray[np.float64] = field(default=None)  # type: ignore[assignment]

    def __post_init__(self) -> None:
        Q = np.asarray(self.Q, dtype=float)
        n = Q.shape[0] if Q.ndim == 2 else -1
        Q = _mat("Q", Q, (n, n))
        R = np.asarray(self.R, dtype=float)
        q = R.shape[0] if R.ndim == 2 else -1
        if R.size == 0:
            R = np.zeros((0, 0))
            q = 0
        R = _mat("R", R, (q, q))
        S = np.zeros((n, q)) if self.S is None else _mat("S", self.S, (n, q))
        _check_psd("Q", Q)
        _check_psd("R", R, definite=True)
        # the joint covariance [[Q, S], [Sᵀ, R]] must be a covariance too
        _check_psd("the joint noise covariance [[Q, S], [Sᵀ, R]]", np.block([[Q, S], [S.T, R]]))
        object.__setattr__(self, "Q", Q)
        object.__setattr__(self, "R", R)
        object.__setattr__(self, "S", S)

    @property
    def n_states(self) -> int:
        """Number of states ``n``."""
        return int(self.Q.shape[0])

    @property
    def n_measured(self) -> int:
        """Number of measured channels ``q``."""
        return int(self.R.shape[0])

    @classmethod
    def from_innovation(
        cls, K: ArrayLike, Re: ArrayLike, measured: Sequence[int] | NDArray[np.int64]
    ) -> NoiseModel:
        """Noise of the innovation form ``w = K e``, ``v = e_measured``.

        Parameters
        ----------
        K : array_like, shape (n, p)
            Innovation gain of the identified model (001 eq 3).
        Re : array_like, shape (p, p)
            Covariance of the innovation ``e`` over all p outputs [output unit²].
        measured : sequence of int
            Indices of the measured outputs among the p outputs.

        Returns
        -------
        NoiseModel
            ``Q = K Re Kᵀ``, ``R = Re[z, z]``, ``S = K Re[:, z]``.
        """
        Ka = np.asarray(K, dtype=float)
        if Ka.ndim != 2:
            raise ShapeError(f"K has shape {Ka.shape}, expected (n_states, n_outputs)")
        p = Ka.shape[1]
        Rea = _mat("Re", Re, (p, p))
        idx = np.asarray(measured, dtype=np.int64).reshape(-1)
        if idx.size and (idx.min() < 0 or idx.max() >= p):
            raise ShapeError(f"measured indices {idx.tolist()} outside 0..{p - 1}")
        Q = Ka @ Rea @ Ka.T
        return cls(0.5 * (Q + Q.T), Rea[np.ix_(idx, idx)], Ka @ Rea[:, idx])

    def scaled(self, process: float = 1.0, measurement: float = 1.0) -> NoiseModel:
        """Scale ``Q`` by ``process`` and ``R`` by ``measurement`` (S by their geometric mean)."""
        if not (process >= 0 and measurement > 0):
            raise ParameterError(
                f"noise scales are {process!r} and {measurement!r}; expected process >= 0 and "
                "measurement > 0"
            )
        return NoiseModel(
            self.Q * process, self.R * measurement, self.S * math.sqrt(process * measurement)
        )


@dataclass(frozen=True)
class KalmanGains:
    """Steady-state Kalman filter of a linear model (DARE solution).

    Attributes
    ----------
    P : ndarray, shape (n, n)
        Prior error covariance ``cov(x − x̂[k|k−1])``.
    P_post : ndarray, shape (n, n)
        Posterior error covariance ``cov(x − x̂[k|k])``.
    L : ndarray, shape (n, q)
        Filter gain, ``x̂[k|k] = x̂[k|k−1] + L ν``.
    K : ndarray, shape (n, q)
        Predictor gain, ``x̂[k+1|k] = A x̂[k|k−1] + B u + K ν``.
    innovation_cov : ndarray, shape (q, q)
        ``Σ = C_z P C_zᵀ + R``.
    """

    P: NDArray[np.float64]
    P_post: NDArray[np.float64]
    L: NDArray[np.float64]
    K: NDArray[np.float64]
    innovation_cov: NDArray[np.float64]


def steady_state_gains(A: ArrayLike, C: ArrayLike, noise: NoiseModel) -> KalmanGains:
    """Steady-state Kalman gains from the discrete algebraic Riccati equation.

    Parameters
    ----------
    A : array_like, shape (n, n)
        Discrete state matrix.
    C : array_like, shape (q, n)
        Measured-output matrix (``q = 0`` allowed: no measurement, the
        covariance is then the Lyapunov solution ``P = A P Aᵀ + Q``).
    noise : NoiseModel

    Returns
    -------
    KalmanGains

    Raises
    ------
    ParameterError
        The Riccati equation has no stabilising solution (``(A, C)`` not
        detectable, or ``A`` unstable without measurements).

    Examples
    --------
    >>> import numpy as np
    >>> g = steady_state_gains([[0.9]], [[1.0]], NoiseModel([[0.01]], [[0.01]]))
    >>> round(float(g.P[0, 0]), 5), round(float(g.L[0, 0]), 4)
    (0.01484, 0.5974)
    """
    Aa = np.asarray(A, dtype=float)
    n = Aa.shape[0] if Aa.ndim == 2 else -1
    Aa = _mat("A", Aa, (n, n))
    Ca = np.asarray(C, dtype=float).reshape(-1, n)
    q = Ca.shape[0]
    if noise.n_states != n or noise.n_measured != q:
        raise ShapeError(
            f"noise model is for {noise.n_states} states and {noise.n_measured} measured "
            f"channels; the model has {n} states and {q} measured channels"
        )
    Q, R, S = noise.Q, noise.R, noise.S
    if q == 0:
        rho = _spectral_radius(Aa)
        if rho >= 1.0:
            raise ParameterError(
                f"A has spectral radius {rho:.6g} >= 1 and nothing is measured: the estimate's "
                "error covariance grows without bound; measure an output or use a stable model"
            )
        P = scipy.linalg.solve_discrete_lyapunov(Aa, Q)  # P = A P Aᵀ + Q
        P = 0.5 * (P + P.T)
        z = np.zeros((n, 0))
        return KalmanGains(P, P.copy(), z, z.copy(), np.zeros((0, 0)))
    # A mode that no noise excites and that lies close to the unit circle (thermal time
    # constants of hours at second sampling: λ = 0.9999) puts eigenvalues of the DARE's
    # symplectic pencil at λ and 1/λ, which the solver refuses; a process noise of 1e-9
    # of the mean variance on every state removes that degeneracy without a visible
    # change of the gain.
    reg = 1e-9 * max(float(np.trace(Q)) / n, 1e-300)
    try:
        # P = A P Aᵀ + Q − (A P Cᵀ + S)(C P Cᵀ + R)⁻¹(A P Cᵀ + S)ᵀ   (dual of the control DARE)
        P = scipy.linalg.solve_discrete_are(Aa.T, Ca.T, Q + reg * np.eye(n), R, s=S)
    except (np.linalg.LinAlgError, ValueError) as e:
        raise ParameterError(
            "the Riccati equation of the Kalman filter has no stabilising solution: the pair "
            "(A, C_measured) is not detectable (an unstable mode does not show in the measured "
            f"outputs) or the noise model is degenerate ({e})"
        ) from e
    P = 0.5 * (P + P.T)
    Sig = Ca @ P @ Ca.T + R  # Σ = C P Cᵀ + R
    Sig = 0.5 * (Sig + Sig.T)
    L = np.linalg.solve(Sig, Ca @ P).T  # L = P Cᵀ Σ⁻¹
    K = np.linalg.solve(Sig, (Aa @ P @ Ca.T + S).T).T  # K = (A P Cᵀ + S) Σ⁻¹
    P_post = P - L @ Sig @ L.T  # P[k|k] = P − L Σ Lᵀ
    rho = _spectral_radius(Aa - K @ Ca)
    if rho >= 1.0:
        raise ParameterError(
            f"the steady-state observer A − K C has spectral radius {rho:.6g} >= 1; the model "
            "is not detectable from the measured outputs"
        )
    return KalmanGains(P, 0.5 * (P_post + P_post.T), L, K, Sig)


def innovation_covariance(
    model: StateSpaceModel,
    u: ArrayLike,
    y: ArrayLike,
    theta: ThetaLike = None,
    *,
    discard: int = 0,
) -> NDArray[np.float64]:
    """Covariance of the one-step prediction errors of a model on data.

    The identified innovation form (001 eq 3) gives ``K`` but no covariance
    of ``e``; this estimates it from the residuals ``y[k] − ŷ[k|k−1]`` of
    :meth:`StateSpaceModel.predict` (NaN samples skipped).

    Parameters
    ----------
    model : StateSpaceModel
    u : array_like, shape (T, m)
        Exogenous signals at the model's ``dt``.
    y : array_like, shape (T, p)
        Measured outputs.
    theta : parameter batch, optional
        One parameter set.
    discard : int
        Leading samples to leave out (predictor start-up transient).

    Returns
    -------
    ndarray, shape (p, p)
        ``Re`` [output unit²].

    Examples
    --------
    >>> import numpy as np
    >>> from thermogym.models.linear import StateSpaceModel
    >>> m = StateSpaceModel.from_matrices([[0.9]], [[0.1]], [[1.0]], K=[[0.5]], dt=1.0)
    >>> rng = np.random.default_rng(0)
    >>> u = rng.normal(size=(4000, 1))
    >>> y = m.simulate(u, 1.0).outputs[0] + 0.1 * rng.normal(size=(4000, 1))
    >>> bool(0.005 < innovation_covariance(m, u, y)[0, 0] < 0.05)
    True
    """
    th = model.theta(theta)
    if th.shape[0] != 1:
        raise ParameterError(f"theta holds {th.shape[0]} parameter sets; expected one")
    ya = np.asarray(y, dtype=float)
    yhat = model.predict(ya, u, th, x0="estimate")[0]
    r = (ya.reshape(yhat.shape) - yhat)[int(discard) :]
    ok = np.isfinite(r).all(axis=1)
    if ok.sum() <= r.shape[1]:
        raise ShapeError(
            f"only {int(ok.sum())} complete samples for {r.shape[1]} outputs; the innovation "
            "covariance needs more data"
        )
    r = r[ok]
    r = r - r.mean(axis=0)
    return (r.T @ r) / (r.shape[0] - 1)


# ============================================================ model reduction
def _gramian_factor(W: NDArray[np.float64]) -> NDArray[np.float64]:
    """Lower factor ``F`` with ``F Fᵀ = W`` (Cholesky, eigen-clipping if singular)."""
    W = 0.5 * (W + W.T)
    try:
        return np.linalg.cholesky(W)
    except np.linalg.LinAlgError:
        w, V = np.linalg.eigh(W)
        return V * np.sqrt(np.clip(w, 0.0, None))


def balanced_truncation(
    A: ArrayLike,
    B: ArrayLike,
    C: ArrayLike,
    D: ArrayLike | None = None,
    *,
    order: int,
    method: str = "truncate",
) -> tuple[
    NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64],
    NDArray[np.float64],
]:  # fmt: skip
    """Square-root balanced reduction of a stable discrete system.

    Written here because python-control's ``balred`` needs the Fortran
    package slycot, which thermogym does not depend on; the square-root
    method (Laub; Tombs and Sorensen) takes a few lines with scipy.

    Parameters
    ----------
    A : array_like, shape (n, n)
        Discrete state matrix, spectral radius < 1.
    B : array_like, shape (n, m)
    C : array_like, shape (p, n)
    D : array_like, shape (p, m), optional
        Feedthrough (zero when omitted).
    order : int
        Order ``r`` of the reduced model, ``1 <= r <= n``.
    method : {"truncate", "residualize"}
        ``truncate`` drops the weak balanced states (exact at high
        frequency); ``residualize`` holds them at their steady state
        (singular perturbation: exact DC gain, adds a feedthrough) —
        thermal virtual sensors need the right steady temperatures.

    Returns
    -------
    Ar, Br, Cr, Dr : ndarray
        Reduced model, shapes (r, r), (r, m), (p, r), (p, m).
    hsv : ndarray, shape (n,)
        Hankel singular values of the full system (the H∞ error bound of
        either method is ``2 Σ_{i>r} hsv_i``).

    Examples
    --------
    >>> import numpy as np
    >>> A = np.diag([0.5, 0.9, 0.99]); B = np.ones((3, 1)); C = np.ones((1, 3))
    >>> Ar, Br, Cr, Dr, hsv = balanced_truncation(A, B, C, order=3)
    >>> bool(np.allclose(np.sort(np.linalg.eigvals(Ar).real), [0.5, 0.9, 0.99]))
    True
    >>> Ar, Br, Cr, Dr, _ = balanced_truncation(A, B, C, order=1, method="residualize")
    >>> dc = Cr @ np.linalg.solve(np.eye(1) - Ar, Br) + Dr
    >>> round(float(dc[0, 0]), 9), round(float(1 / 0.5 + 1 / 0.1 + 1 / 0.01), 9)
    (112.0, 112.0)
    """
    Aa = np.asarray(A, dtype=float)
    n = Aa.shape[0] if Aa.ndim == 2 else -1
    Aa = _mat("A", Aa, (n, n))
    Ba = np.asarray(B, dtype=float)
    Ba = _mat("B", Ba, (n, Ba.shape[1] if Ba.ndim == 2 else -1))
    Ca = np.asarray(C, dtype=float)
    Ca = _mat("C", Ca, (Ca.shape[0] if Ca.ndim == 2 else -1, n))
    p, m = Ca.shape[0], Ba.shape[1]
    Da = np.zeros((p, m)) if D is None else _mat("D", D, (p, m))
    if int(order) != order or not 1 <= order <= n:
        raise ParameterError(f"order is {order!r}; expected an integer in 1..{n}")
    if method not in ("truncate", "residualize"):
        raise ConfigError(f"method is {method!r}; expected 'truncate' or 'residualize'")
    rho = _spectral_radius(Aa)
    if rho >= 1.0:
        raise ParameterError(f"A has spectral radius {rho:.6g} >= 1; balancing needs a stable A")
    Wc = scipy.linalg.solve_discrete_lyapunov(Aa, Ba @ Ba.T)  # Wc = A Wc Aᵀ + B Bᵀ
    Wo = scipy.linalg.solve_discrete_lyapunov(Aa.T, Ca.T @ Ca)  # Wo = Aᵀ Wo A + Cᵀ C
    Lc, Lo = _gramian_factor(Wc), _gramian_factor(Wo)
    U, s, Vt = np.linalg.svd(Lo.T @ Lc)
    r = int(order)
    if s[r - 1] <= 1e-14 * s[0]:
        raise ParameterError(
            f"Hankel singular value {r} is {s[r - 1]:.3g} (relative {s[r - 1] / s[0]:.3g}); the "
            f"system has fewer than {r} controllable and observable states"
        )
    if method == "truncate" or r == n:
        Si = np.diag(s[:r] ** -0.5)
        T = Lc @ Vt[:r].T @ Si  # x = T x_r
        Ti = Si @ U[:, :r].T @ Lo.T  # x_r = Ti x
        return Ti @ Aa @ T, Ti @ Ba, Ca @ T, Da.copy(), s
    k = int(np.sum(s > 1e-14 * s[0]))  # balance the minimal part only
    Si = np.diag(s[:k] ** -0.5)
    T = Lc @ Vt[:k].T @ Si
    Ti = Si @ U[:, :k].T @ Lo.T
    Ab, Bb, Cb = Ti @ Aa @ T, Ti @ Ba, Ca @ T
    A11, A12, A21, A22 = Ab[:r, :r], Ab[:r, r:], Ab[r:, :r], Ab[r:, r:]
    # weak states at their steady state: x2 = (I − A22)⁻¹ (A21 x1 + B2 u)
    E = np.eye(k - r) - A22
    X = np.linalg.solve(E, np.hstack([A21, Bb[r:]]))
    Ar = A11 + A12 @ X[:, :r]
    Br = Bb[:r] + A12 @ X[:, r:]
    Cr = Cb[:, :r] + Cb[:, r:] @ X[:, :r]
    Dr = Da + Cb[:, r:] @ X[:, r:]
    return Ar, Br, Cr, Dr, s


# ============================================================ observer numerics
@dataclass(frozen=True)
class ObserverMatrices:
    """The steady-state observer in the form the firmware runs.

    Per sample (physical units, see the module docstring)::

        ν = z − Cz x − Dz u,   ŷ = Ch x + Dh u + F ν,   x⁺ = A x + B u + G ν

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

    @property
    def dims(self) -> tuple[int, int, int, int]:
        """``(n_states, n_exogenous, n_measured, n_hidden)``."""
        return (self.A.shape[0], self.B.shape[1], self.Cz.shape[0], self.Ch.shape[0])

    def rest_state(self, u: ArrayLike, z: ArrayLike | None = None) -> NDArray[np.float64]:
        """Observer equilibrium ``x = N [u; z]`` for constant readings, shape (n,)."""
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
        return self.N @ np.concatenate([ua, za])


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
        self._nu = za - M.Cz @ self._x - M.Dz @ ua  # ν = z − Cz x − Dz u
        self._y = M.Ch @ self._x + M.Dh @ ua + M.F @ self._nu  # ŷ = Ch x + Dh u + F ν

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


# ============================================================== the sensor
def _input_referred_q(
    A: NDArray[np.float64],
    B: NDArray[np.float64],
    C: NDArray[np.float64],
    D: NDArray[np.float64],
    process_std: float,
) -> NDArray[np.float64]:
    """Process noise that enters like the exogenous signals, scaled at the outputs.

    ``Q = α B W Bᵀ`` with ``W = diag(1/g_j²)``, ``g_j`` the largest DC gain of
    input ``j`` (so every input disturbs the outputs alike, whatever its unit),
    and ``α`` such that one sample of noise moves the outputs by
    ``process_std`` on average. Independent of the state coordinates and
    confined to the controllable subspace — an unmeasured heat flow or ambient
    error acts exactly there.
    """
    if not (np.isfinite(process_std) and process_std >= 0):
        raise ParameterError(f"process_std is {process_std!r}; expected >= 0")
    n, m = B.shape
    try:
        G = C @ np.linalg.solve(np.eye(n) - A, B) + D
        g = np.abs(G).max(axis=0)
    except np.linalg.LinAlgError:
        g = np.full(m, np.nan)
    alt = np.linalg.norm(C @ B, axis=0)
    g = np.where(np.isfinite(g) & (g > 0), g, alt)
    w = np.where(g > 0, 1.0 / np.where(g > 0, g, 1.0) ** 2, 0.0)
    Q0 = (B * w) @ B.T
    scale = float(np.mean(np.diag(C @ Q0 @ C.T)))
    if not scale > 0:
        return np.zeros((n, n))
    Q = process_std**2 * Q0 / scale
    return 0.5 * (Q + Q.T)


class VirtualSensor:
    """Kalman virtual sensor on an identified linear state-space model.

    Parameters
    ----------
    model : StateSpaceModel
        The identified model (``ss``), e.g. built from a FitResult.
    theta : parameter batch, optional
        One parameter set (the FitResult's); nominal when omitted.
    measured : sequence of str
        Model outputs the sensor measures at run time (e.g. the surface
        temperatures). Empty for the Table 6 models, whose measurements are
        inputs.
    hidden : sequence of str, optional
        Outputs to estimate; every output that is not measured by default.
    reference : str, optional
        A signal the model's temperatures are relative to (``"T_amb"`` for a
        model identified on ambient-subtracted data). The sensor then takes
        the absolute temperatures and the reference as an extra exogenous
        channel and returns absolute estimates; the transformation is exact.
    referenced : sequence of str, optional
        Signals expressed relative to ``reference``; by default every model
        signal whose unit is a temperature.
    noise : NoiseModel, optional
        Noise of the model's states and measured channels. By default: from
        the model's innovation gain ``K`` with ``Re = diag(measurement_std²)``
        when the model has one, otherwise process noise entering like the
        exogenous signals (``Q ∝ B W Bᵀ``, each input weighted by its DC gain),
        scaled to move the outputs by ``process_std`` per sample, and
        ``R = diag(measurement_std²)``.
        :meth:`tuned` scales it to be consistent with data.
    measurement_std : float or mapping
        Measurement noise standard deviation [output unit] (one value, or per
        output name). Default 0.05, the RTD accuracy of 001 Table 2.
    process_std : float
        See ``noise`` [output unit per sample].
    disturbance_inputs : sequence of str
        Exogenous signals that get a random-walk input disturbance state
        (offset-free estimation of a biased input gain, e.g. ``"speed"``).
    disturbance_std : float or mapping
        Random-walk step of each disturbance [input unit per sample].
    ranges : mapping, optional
        ``{channel: (lower, upper)}``: valid ranges of exogenous and measured
        channels; samples outside are rejected by the observer. Temperatures
        default to the RTD range −50..300 °C (001 Table 2), others to ±inf.

    Raises
    ------
    UnknownNameError
        A measured, hidden, reference or disturbance name is not a model signal.
    ConfigError
        Contradicting names (an output both measured and hidden, ...).
    ParameterError
        The model with these measurements is not detectable.

    Examples
    --------
    >>> import numpy as np
    >>> from thermogym.models.linear import StateSpaceModel
    >>> m = StateSpaceModel.from_matrices(
    ...     [[0.99, 0.0], [0.005, 0.995]], [[0.01], [0.0]], [[1.0, 0.0], [0.0, 1.0]],
    ...     dt=1.0, inputs=["P"], outputs=["T_core", "T_surface"])
    >>> vs = VirtualSensor(m, measured=["T_surface"], measurement_std=0.05)
    >>> vs.hidden_names, vs.measured_names, vs.exogenous_names
    (('T_core',), ('T_surface',), ('P',))
    >>> u = np.ones((3000, 1))
    >>> truth = m.simulate(u, 1.0).outputs[0]
    >>> est = vs.observe(u, truth[:, 1:] + 0.05 * np.random.default_rng(1).normal(size=(3000, 1)))
    >>> bool(abs(est["T_core"][-1] - truth[-1, 0]) < 0.1)
    True
    """

    def __init__(
        self,
        model: StateSpaceModel,
        theta: ThetaLike = None,
        *,
        measured: Sequence[str] | str = (),
        hidden: Sequence[str] | str | None = None,
        reference: str | None = None,
        referenced: Sequence[str] | None = None,
        noise: NoiseModel | None = None,
        measurement_std: float | Mapping[str, float] = 0.05,
        process_std: float = 1e-3,
        disturbance_inputs: Sequence[str] | str = (),
        disturbance_std: float | Mapping[str, float] = 1.0,
        ranges: Mapping[str, tuple[float, float]] | None = None,
    ) -> None:
        if not isinstance(model, StateSpaceModel):
            raise ConfigError(
                f"a virtual sensor needs a linear state-space model ('ss'), got "
                f"{type(model).__name__} {getattr(model, 'name', '')!r}"
            )
        th = model.theta(theta)
        if th.shape[0] != 1:
            raise ParameterError(f"theta holds {th.shape[0]} parameter sets; expected one")
        mats = model.matrices(th)
        A, B, C, D = mats.A[0], mats.B[0], mats.C[0], mats.D[0]
        outs = list(model.output_names)
        exo = list(model.exogenous_names)
        units = {s.name: s.unit for s in model.signals}
        self.model = model
        self.theta = th
        self.dt = float(model.dt)

        meas = _names(measured, "measured")
        for nme in meas:
            if nme not in outs:
                raise UnknownNameError(
                    f"measured channel {nme!r} is not an output of the model; outputs are {outs}"
                )
        if len(set(meas)) != len(meas):
            raise ConfigError(f"measured channels {list(meas)} repeat a name")
        hid = tuple(o for o in outs if o not in meas) if hidden is None else _names(hidden, "")
        for nme in hid:
            if nme not in outs:
                raise UnknownNameError(
                    f"hidden channel {nme!r} is not an output of the model; outputs are {outs}"
                )
            if nme in meas:
                raise ConfigError(f"output {nme!r} is both measured and hidden")
        if not hid:
            raise ConfigError("nothing to estimate: every output is measured; leave one hidden")
        iz = [outs.index(o) for o in meas]
        ih = [outs.index(o) for o in hid]

        # ------------------------------------------------ reference transform
        if reference is not None:
            if reference in exo or reference in outs:
                raise ConfigError(
                    f"reference {reference!r} is already a signal of the model; a reference is "
                    "the signal the model's data were made relative to"
                )
            if referenced is None:
                rel = [s for s in exo + outs if units.get(s) in _TEMPERATURE_UNITS]
                if not rel:
                    raise ConfigError(
                        f"reference {reference!r} given but no model signal has a temperature "
                        "unit; name the relative signals with referenced=[...]"
                    )
            else:
                rel = list(referenced)
                bad = [s for s in rel if s not in exo + outs]
                if bad:
                    raise UnknownNameError(
                        f"referenced signal(s) {bad} are not model signals {exo + outs}"
                    )
            # θ = T − T_ref: B θ_u = B T_u − (Σ_referenced B_j) T_ref; y = θ_y + T_ref
            ju = [exo.index(s) for s in rel if s in exo]
            b_ref = -B[:, ju].sum(axis=1, keepdims=True)
            d_ref = -D[:, ju].sum(axis=1, keepdims=True)
            for s in rel:
                if s in outs:
                    d_ref[outs.index(s), 0] += 1.0
            B = np.hstack([B, b_ref])
            D = np.hstack([D, d_ref])
            exo = [*exo, reference]
            units[reference] = next((units[s] for s in rel if s in units), "°C")
        self.reference = reference

        # ------------------------------------------------ noise model
        n0 = A.shape[0]
        stds = np.array(
            [
                float(measurement_std.get(o, 0.05))  # type: ignore[union-attr]
                if isinstance(measurement_std, Mapping)
                else float(measurement_std)
                for o in outs
            ]
        )
        if (stds <= 0).any() or not np.isfinite(stds).all():
            raise ParameterError(f"measurement_std is {measurement_std!r}; expected > 0")
        if noise is None:
            if model.has_K:
                noise = NoiseModel.from_innovation(mats.K[0], np.diag(stds**2), iz)
            else:
                noise = NoiseModel(
                    _input_referred_q(A, B, C, D, process_std), np.diag(stds[iz] ** 2)
                )
        if noise.n_states != n0 or noise.n_measured != len(iz):
            raise ShapeError(
                f"noise model is for {noise.n_states} states and {noise.n_measured} measured "
                f"channels; the model has {n0} states and {len(iz)} measured"
            )
        Q, R, S = noise.Q, noise.R, noise.S

        # ------------------------------------------------ disturbance states
        dist = _names(disturbance_inputs, "disturbance_inputs")
        for d in dist:
            if d not in exo:
                raise UnknownNameError(
                    f"disturbance input {d!r} is not an exogenous signal; they are {exo}"
                )
        if dist:
            jd = [exo.index(d) for d in dist]
            r = len(jd)
            # x_d[k+1] = x_d[k] + ε (random walk), acting like the input: x⁺ = A x + B_d x_d
            A = np.block([[A, B[:, jd]], [np.zeros((r, n0)), np.eye(r)]])
            B = np.vstack([B, np.zeros((r, B.shape[1]))])
            C = np.hstack([C, D[:, jd]])
            dstd = np.array(
                [
                    float(disturbance_std.get(d, 1.0))  # type: ignore[union-attr]
                    if isinstance(disturbance_std, Mapping)
                    else float(disturbance_std)
                    for d in dist
                ]
            )
            Q = scipy.linalg.block_diag(Q, np.diag(dstd**2))
            S = np.vstack([S, np.zeros((r, S.shape[1]))])
            noise = NoiseModel(Q, R, S)
        self.disturbance_inputs = dist

        self._A, self._B = A, B
        self._Cz, self._Dz = C[iz], D[iz]
        self._Ch, self._Dh = C[ih], D[ih]
        self.noise = noise
        self.gains = steady_state_gains(A, self._Cz, noise)
        self.exogenous_names = tuple(exo)
        self.measured_names = tuple(meas)
        self.hidden_names = tuple(hid)
        self.units = {k: units.get(k, "1") for k in (*exo, *meas, *hid)}

        chans = (*exo, *meas)
        rng_map = dict(ranges or {})
        unknown = [k for k in rng_map if k not in chans]
        if unknown:
            raise UnknownNameError(
                f"ranges given for {unknown}, which are not exogenous or measured channels "
                f"{list(chans)}"
            )
        lo, hi = np.full(len(chans), -np.inf), np.full(len(chans), np.inf)
        for j, ch in enumerate(chans):
            if ch in rng_map:
                a, b = (float(v) for v in rng_map[ch])
                if not a < b:
                    raise ParameterError(
                        f"range of {ch!r} is ({a!r}, {b!r}); expected lower < upper"
                    )
                lo[j], hi[j] = a, b
            elif self.units[ch] in _TEMPERATURE_UNITS:
                lo[j], hi[j] = -50.0, 300.0  # RTD measurement range, 001 Table 2
        self._lower, self._upper = lo, hi

    # ---------------------------------------------------------------- matrices
    @property
    def n_states(self) -> int:
        """Observer order (model order plus disturbance states)."""
        return int(self._A.shape[0])

    def observer_matrices(self) -> ObserverMatrices:
        """The steady-state observer (what the firmware exports)."""
        g = self.gains
        A, B, Cz, Dz, Ch, Dh = self._A, self._B, self._Cz, self._Dz, self._Ch, self._Dh
        G, F = g.K, Ch @ g.L
        n = A.shape[0]
        # equilibrium of x⁺ = (A − G Cz) x + (B − G Dz) u + G z
        Ao = A - G @ Cz
        N: NDArray[np.float64] | None
        try:
            N = np.linalg.solve(np.eye(n) - Ao, np.hstack([B - G @ Dz, G]))
            if not np.isfinite(N).all() or np.linalg.cond(np.eye(n) - Ao) > 1e12:
                N = None
        except np.linalg.LinAlgError:
            N = None
        if N is None:
            # the model's own equilibrium for u, disturbance states at zero, z unused
            r = len(self.disturbance_inputs)
            nb_ = n - r
            try:
                Xb = np.linalg.solve(np.eye(nb_) - A[:nb_, :nb_], B[:nb_])
                if np.isfinite(Xb).all() and np.linalg.cond(np.eye(nb_) - A[:nb_, :nb_]) < 1e12:
                    N = np.zeros((n, B.shape[1] + Cz.shape[0]))
                    N[:nb_, : B.shape[1]] = Xb
            except np.linalg.LinAlgError:
                N = None
        return ObserverMatrices(
            A.copy(),
            B.copy(),
            G.copy(),
            Cz.copy(),
            Dz.copy(),
            Ch.copy(),
            Dh.copy(),
            F,
            N,
            self.exogenous_names,
            self.measured_names,
            self.hidden_names,
            self._lower.copy(),
            self._upper.copy(),
            self.dt,
            dict(self.units),
        )

    def step_observer(self) -> SteadyStateObserver:
        """A fresh step-wise steady-state observer (firmware twin, env use)."""
        return SteadyStateObserver(self.observer_matrices())

    def rest_state(self, u: ArrayLike, z: ArrayLike | None = None) -> NDArray[np.float64]:
        """Observer equilibrium for constant readings ``(u, z)``, shape (n,)."""
        return self.observer_matrices().rest_state(u, z)

    # ------------------------------------------------------------------- data
    def arrays(self, data: Any) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Exogenous and measured arrays from a mapping of columns (e.g. a Recording).

        Returns
        -------
        u : ndarray, shape (T, m)
        z : ndarray, shape (T, q)
        """
        need = (*self.exogenous_names, *self.measured_names)
        missing = [c for c in need if c not in data]
        if missing:
            raise UnknownNameError(
                f"data lack column(s) {missing}; the virtual sensor needs exogenous "
                f"{list(self.exogenous_names)} and measured {list(self.measured_names)}"
            )
        cols = [np.asarray(data[c], dtype=float) for c in need]
        T = cols[0].shape[0] if cols else 0
        if any(c.shape != (T,) for c in cols):
            raise ShapeError("columns have different lengths or are not 1-D")
        m = len(self.exogenous_names)
        u = np.column_stack(cols[:m]) if m else np.zeros((T, 0))
        z = np.column_stack(cols[m:]) if len(cols) > m else np.zeros((T, 0))
        return u, z

    def _uz(
        self, u: ArrayLike, z: ArrayLike | None
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        m, q = len(self.exogenous_names), len(self.measured_names)
        ua = np.asarray(u, dtype=float)
        if ua.ndim == 1 and m == 1:
            ua = ua[:, None]
        if ua.ndim != 2 or ua.shape[1] != m:
            raise ShapeError(
                f"u has shape {ua.shape}, expected (T, {m}) with columns "
                f"{list(self.exogenous_names)}"
            )
        T = ua.shape[0]
        if z is None:
            za = np.zeros((T, 0))
        else:
            za = np.asarray(z, dtype=float)
            if za.ndim == 1 and q == 1:
                za = za[:, None]
        if za.shape != (T, q):
            raise ShapeError(
                f"z has shape {za.shape}, expected ({T}, {q}) with columns "
                f"{list(self.measured_names)}"
            )
        if T < 1:
            raise ShapeError("no samples")
        return np.ascontiguousarray(ua), np.ascontiguousarray(za)

    def rest_inputs(
        self, u0: ArrayLike, rest: Mapping[str, float | str] | None = None
    ) -> NDArray[np.float64]:
        """Exogenous sample ``u0`` with the channels named in ``rest`` replaced.

        A record that starts when the machine is switched on has the new speed
        in its first sample but temperatures of a machine at rest; the rest
        state must then be taken with ``rest={"speed": 0.0}``. A value may
        name another exogenous channel: ``{"T_front_outer_housing": "T_amb"}``
        takes the ambient's first sample (a machine at rest is at ambient
        temperature — and a model whose steady state is sensitive to the
        difference of two surface readings does not amplify their noise).
        """
        ua = np.array(u0, dtype=float).reshape(-1)
        first = ua.copy()
        for name, value in (rest or {}).items():
            if name not in self.exogenous_names:
                raise UnknownNameError(
                    f"rest value given for {name!r}, which is not an exogenous channel "
                    f"{list(self.exogenous_names)}"
                )
            if isinstance(value, str):
                if value not in self.exogenous_names:
                    raise UnknownNameError(
                        f"rest value of {name!r} names {value!r}, which is not an exogenous "
                        f"channel {list(self.exogenous_names)}"
                    )
                ua[self.exogenous_names.index(name)] = first[self.exogenous_names.index(value)]
            else:
                ua[self.exogenous_names.index(name)] = float(value)
        return ua

    def _x0(
        self,
        x0: ArrayLike | str | None,
        u: NDArray,
        z: NDArray,
        rest: Mapping[str, float | str] | None = None,
    ) -> NDArray[np.float64]:
        n = self.n_states
        if x0 is None or (isinstance(x0, str) and x0 == "rest"):
            u0 = self.rest_inputs(u[0], rest)
            v = np.concatenate([u0, z[0]])
            if not np.isfinite(v).all():
                raise ShapeError(
                    "the first sample has a non-finite channel; the rest state needs a valid "
                    "first sample (trim the data or give x0)"
                )
            return self.rest_state(u0, z[0])
        if isinstance(x0, str):
            raise ConfigError(f"x0 is {x0!r}; expected 'rest' or an array of {n} states")
        xa = np.asarray(x0, dtype=float).reshape(-1)
        if xa.shape != (n,):
            raise ShapeError(f"x0 has shape {xa.shape}, expected ({n},)")
        return xa

    # ---------------------------------------------------------------- running
    def observe(
        self,
        u: ArrayLike,
        z: ArrayLike | None = None,
        *,
        x0: ArrayLike | str | None = "rest",
        rest: Mapping[str, float | str] | None = None,
    ) -> Estimate:
        """Run the steady-state observer over a series (compiled; firmware semantics).

        Parameters
        ----------
        u : array_like, shape (T, m)
            Exogenous channels in :attr:`exogenous_names` order.
        z : array_like, shape (T, q)
            Measured channels in :attr:`measured_names` order.
        x0 : "rest" or array_like, shape (n,)
            Initial state; ``"rest"``: the equilibrium at the first sample.
        rest : mapping, optional
            Exogenous values to take for the rest state instead of the first
            sample's (:meth:`rest_inputs`), e.g. ``{"speed": 0.0}``; a value
            may name another exogenous channel.

        Returns
        -------
        Estimate
            Hidden estimates with the constant steady-state covariance
            ``C_h P[k|k] C_hᵀ``; invalid samples hold the last estimate.
        """
        ua, za = self._uz(u, z)
        M = self.observer_matrices()
        x = self._x0(x0, ua, za, rest)
        T = ua.shape[0]
        n, _, q, p = M.dims
        y = np.empty((T, p))
        xs = np.empty((T, n))
        nus = np.empty((T, q))
        status = np.empty(T, dtype=np.int8)
        y0 = M.Ch @ x + M.Dh @ np.nan_to_num(ua[0])
        _observer_kernel(
            M.A, M.B, M.G, M.Cz, M.Dz, M.Ch, M.Dh, M.F,
            M.lower, M.upper, ua, za, x, y0, y, xs, nus, status,
        )  # fmt: skip
        covh = self._Ch @ self.gains.P_post @ self._Ch.T
        return Estimate(
            self.hidden_names,
            y,
            np.broadcast_to(covh, (T, p, p)),
            xs,
            nus,
            np.broadcast_to(self.gains.innovation_cov, (T, q, q)),
            status,
            self.measured_names,
        )

    def kalman_filter(self, x0: ArrayLike, P0: ArrayLike | None = None) -> Any:
        """A filterpy :class:`~filterpy.kalman.KalmanFilter` for this model.

        The cross-covariance ``S`` of the innovation form is removed by the
        usual decorrelation, ``x⁺ = (A − S R⁻¹ C_z) x + (B − S R⁻¹ D_z) u +
        S R⁻¹ z + w̃`` with ``cov w̃ = Q − S R⁻¹ Sᵀ``, so the filter's control
        input is ``[u; z_prev]`` (see :meth:`filter`). ``H = C_z``; the
        measurement passed to ``update`` must have ``D_z u`` subtracted.

        Parameters
        ----------
        x0 : array_like, shape (n,)
        P0 : array_like, shape (n, n), optional
            Default: the steady-state prior covariance.
        """
        from filterpy.kalman import KalmanFilter

        n, m, q = self.n_states, len(self.exogenous_names), len(self.measured_names)
        kf = KalmanFilter(dim_x=n, dim_z=max(q, 1), dim_u=m + q)
        R, S = self.noise.R, self.noise.S
        SRi = np.linalg.solve(R, S.T).T if q else np.zeros((n, 0))
        kf.F = self._A - SRi @ self._Cz
        kf.B = np.hstack([self._B - SRi @ self._Dz, SRi])
        Qt = self.noise.Q - SRi @ S.T
        kf.Q = 0.5 * (Qt + Qt.T)
        if q:
            kf.H = self._Cz.copy()
            kf.R = R.copy()
        kf.x = np.asarray(x0, dtype=float).reshape(n, 1).copy()
        kf.P = np.array(self.gains.P if P0 is None else P0, dtype=float).reshape(n, n)
        return kf

    def filter(
        self,
        u: ArrayLike,
        z: ArrayLike | None = None,
        *,
        x0: ArrayLike | str | None = "rest",
        P0: ArrayLike | None = None,
        rest: Mapping[str, float | str] | None = None,
    ) -> Estimate:
        """Run the time-varying Kalman filter (filterpy) over a series.

        Missing measured samples (NaN) are skipped channel by channel (the
        update uses the available rows of ``C_z``, ``R`` and ``S``); the
        exogenous channels must be finite. The covariance update is
        filterpy's Joseph form.

        Parameters
        ----------
        u : array_like, shape (T, m)
        z : array_like, shape (T, q)
        x0 : "rest" or array_like, shape (n,)
        P0 : array_like, shape (n, n), optional
            Initial prior covariance; the steady-state one by default (the
            filter then equals :meth:`observe` when no sample is missing).
        rest : mapping, optional
            As :meth:`observe`.

        Returns
        -------
        Estimate
        """
        ua, za = self._uz(u, z)
        if not np.isfinite(ua).all():
            k = int(np.argwhere(~np.isfinite(ua))[0][0])
            raise ShapeError(
                f"exogenous channel is not finite at sample {k}; the Kalman filter needs every "
                "exogenous sample (prepare the data), missing measurements are fine"
            )
        x = self._x0(x0, ua, np.nan_to_num(za), rest)
        kf = self.kalman_filter(x, P0)
        T = ua.shape[0]
        n, m, q, p = self.n_states, ua.shape[1], za.shape[1], len(self.hidden_names)
        R, S, Q = self.noise.R, self.noise.S, self.noise.Q
        cache: dict[bytes, tuple[Any, ...]] = {}

        def pattern(ok: NDArray[np.bool_]) -> tuple[Any, ...]:
            key = ok.tobytes()
            hit = cache.get(key)
            if hit is None:
                idx = np.flatnonzero(ok)
                Ra = R[np.ix_(idx, idx)]
                Sa = S[:, idx]
                SRi = np.linalg.solve(Ra, Sa.T).T if idx.size else np.zeros((n, 0))
                F = self._A - SRi @ self._Cz[idx]
                Bf = np.zeros((n, m + q))
                Bf[:, :m] = self._B - SRi @ self._Dz[idx]
                Bf[:, m + idx] = SRi
                Qt = Q - SRi @ Sa.T
                hit = (idx, Ra, self._Cz[idx], F, Bf, 0.5 * (Qt + Qt.T))
                cache[key] = hit
            return hit

        xs = np.empty((T, n))
        y = np.empty((T, p))
        cov = np.empty((T, p, p))
        nus = np.full((T, q), np.nan)
        sig = np.full((T, q, q), np.nan)
        status = np.zeros(T, dtype=np.int8)
        for k in range(T):
            ok = np.isfinite(za[k])
            idx, Ra, Ha, F, Bf, Qt = pattern(ok)
            if idx.size:
                zk = (za[k, idx] - self._Dz[idx] @ ua[k]).reshape(-1, 1)
                kf.update(zk, R=Ra, H=Ha)
                nus[k, idx] = kf.y.reshape(-1)
                sig[k][np.ix_(idx, idx)] = kf.S
            else:
                if q:
                    status[k] = ObserverStatus.NOT_FINITE
                kf.update(None)
            xk = kf.x.reshape(-1)
            xs[k] = xk
            y[k] = self._Ch @ xk + self._Dh @ ua[k]  # ŷ[k|k] = C_h x̂[k|k] + D_h u
            cov[k] = self._Ch @ kf.P @ self._Ch.T
            uz = np.concatenate([ua[k], np.where(ok, za[k], 0.0)]).reshape(-1, 1)
            # x⁺ = F̃ x + B̃ [u; z],  P⁺ = F̃ P F̃ᵀ + Q̃
            kf.predict(u=uz, B=Bf, F=F, Q=Qt)
        return Estimate(self.hidden_names, y, cov, xs, nus, sig, status, self.measured_names)

    def estimate(self, data: Any, *, method: str = "kalman", **kwargs: Any) -> Estimate:
        """Estimate from a mapping of columns (a Recording): ``filter`` or ``observe``."""
        u, z = self.arrays(data)
        if method == "kalman":
            return self.filter(u, z, **kwargs)
        if method == "observer":
            return self.observe(u, z, **kwargs)
        raise ConfigError(f"method is {method!r}; expected 'kalman' or 'observer'")

    def at_period(self, period: float) -> VirtualSensor:
        """The same sensor sampled every ``period`` = k · dt (inputs held over it).

        For an environment whose control period is a multiple of the model's
        sample period: ``A_k = A^k``, ``B_k = Σ_{i<k} A^i B`` (exact for a held
        input), ``Q_k = Σ_{i<k} A^i Q A^iᵀ``, ``S_k = A^{k−1} S``; the gains
        are recomputed for the slower measurements.

        Parameters
        ----------
        period : float
            New sample period [s], an integer multiple of :attr:`dt`.

        Returns
        -------
        VirtualSensor
        """
        r = period / self.dt
        k = round(r)
        if not (np.isfinite(r) and k >= 1 and abs(r - k) <= 1e-9 * max(r, 1.0)):
            raise ParameterError(
                f"period {period!r} s is not an integer multiple of the model's dt = {self.dt!r} s"
            )
        if k == 1:
            return self
        n, m = self._B.shape
        E = np.zeros((n + m, n + m))
        E[:n, :n], E[:n, n:], E[n:, n:] = self._A, self._B, np.eye(m)
        Ek = np.linalg.matrix_power(E, k)
        Q = self.noise.Q
        Qk = np.zeros_like(Q)
        Ai = np.eye(n)
        for _ in range(k):  # Q_k = Σ A^i Q A^iᵀ
            Qk += Ai @ Q @ Ai.T
            Ai = self._A @ Ai
        Sk = np.linalg.matrix_power(self._A, k - 1) @ self.noise.S
        new = object.__new__(VirtualSensor)
        new.__dict__.update(self.__dict__)
        new._A, new._B = Ek[:n, :n], Ek[:n, n:]
        new.dt = float(period)
        noise = NoiseModel(0.5 * (Qk + Qk.T), self.noise.R, Sk)
        new.noise = noise
        new.gains = steady_state_gains(new._A, new._Cz, noise)
        return new

    # ----------------------------------------------------------------- tuning
    def with_noise(self, noise: NoiseModel) -> VirtualSensor:
        """A copy of this sensor with another noise model (same model and channels)."""
        new = object.__new__(VirtualSensor)
        new.__dict__.update(self.__dict__)
        if noise.n_states != self.n_states or noise.n_measured != len(self.measured_names):
            raise ShapeError(
                f"noise model is for {noise.n_states} states / {noise.n_measured} measured; "
                f"the sensor has {self.n_states} / {len(self.measured_names)}"
            )
        new.noise = noise
        new.gains = steady_state_gains(self._A, self._Cz, noise)
        return new

    def tuned(
        self,
        u: ArrayLike,
        z: ArrayLike | None = None,
        *,
        hidden_truth: ArrayLike | None = None,
        truth_std: float | Sequence[float] = 0.0,
        rest: Mapping[str, float | str] | None = None,
        bounds: tuple[float, float] = (1e-6, 1e8),
        discard: int = 0,
    ) -> tuple[VirtualSensor, float]:
        """Scale the process noise until the filter is consistent on calibration data.

        A consistent filter's NIS averages the number of measured channels and
        its NEES the number of estimated ones (Bar-Shalom et al., *Estimation
        with Applications to Tracking and Navigation*, 5.4). A single factor
        ``α`` on ``Q`` (and ``S``) is searched on a log scale so that the mean
        NEES of the hidden estimates equals their number when ``hidden_truth``
        is given (identification data record the internal temperatures), else
        the mean NIS equals the number of measured channels. Use training
        data, never the held-out runs.

        Parameters
        ----------
        u, z : array_like
            Calibration series (exogenous, measured).
        hidden_truth : array_like, shape (T, p), optional
            The hidden signals recorded on the calibration data.
        truth_std : float or sequence of float
            Noise std of the recorded hidden signals [their unit]; added to the
            estimate's covariance in the NEES (the recording is not the truth).
        rest : mapping, optional
            Rest-state inputs at the start (:meth:`observe`).
        bounds : (float, float)
            Search range of ``α``.
        discard : int
            Leading samples left out of the mean (start-up transient).

        Returns
        -------
        sensor : VirtualSensor
            The tuned copy.
        alpha : float
            The factor found.
        """
        q = len(self.measured_names)
        ua, za = self._uz(u, z)
        truth = None
        if hidden_truth is not None:
            truth = np.asarray(hidden_truth, dtype=float)
            if truth.ndim == 1:
                truth = truth[:, None]
            if truth.shape != (ua.shape[0], len(self.hidden_names)):
                raise ShapeError(
                    f"hidden_truth has shape {truth.shape}, expected "
                    f"({ua.shape[0]}, {len(self.hidden_names)}) for {list(self.hidden_names)}"
                )
        elif q == 0:
            raise ConfigError(
                "nothing is measured, so the NIS is undefined: give hidden_truth (the recorded "
                "hidden signals of the calibration data) to tune on the NEES"
            )
        dof = len(self.hidden_names) if truth is not None else q
        tstd = np.broadcast_to(np.asarray(truth_std, dtype=float), (len(self.hidden_names),))
        extra = np.diag(tstd**2)

        def mean_stat(log_a: float) -> float:
            try:
                s = self.with_noise(self.noise.scaled(process=math.exp(log_a)))
            except ParameterError:
                return math.inf
            est = s.observe(ua, za, rest=rest)
            v = est.nees(truth, extra) if truth is not None else est.nis()
            return float(np.nanmean(v[int(discard) :]))

        def objective(log_a: float) -> float:
            m = mean_stat(log_a)
            return math.log(m / dof) ** 2 if np.isfinite(m) and m > 0 else 1e6

        lo, hi = (math.log(b) for b in bounds)
        res = scipy.optimize.minimize_scalar(objective, bounds=(lo, hi), method="bounded")
        alpha = math.exp(float(res.x))
        return self.with_noise(self.noise.scaled(process=alpha)), alpha

    def __repr__(self) -> str:
        return (
            f"<VirtualSensor n={self.n_states}: exogenous {list(self.exogenous_names)}, measured "
            f"{list(self.measured_names)}, hidden {list(self.hidden_names)}, dt={self.dt:g} s>"
        )


# ============================================================== consistency
def normalized_error_squared(err: ArrayLike, cov: ArrayLike) -> NDArray[np.float64]:
    """``eᵀ P⁻¹ e`` per sample: NEES for estimation errors, NIS for innovations.

    Parameters
    ----------
    err : array_like, shape (T, d)
        Errors (truth − estimate) or innovations; rows with NaN give NaN.
    cov : array_like, shape (T, d, d) or (d, d)
        Their covariance.

    Returns
    -------
    ndarray, shape (T,)
        NaN where an error or covariance is not finite; ``inf`` where the
        covariance is singular and the error lies outside its range.

    Examples
    --------
    >>> normalized_error_squared([[1.0, 2.0]], [[1.0, 0.0], [0.0, 4.0]]).tolist()
    [2.0]
    """
    e = np.asarray(err, dtype=float)
    if e.ndim == 1:
        e = e[:, None]
    T, d = e.shape
    P = np.asarray(cov, dtype=float)
    if P.shape == (d, d):
        P = np.broadcast_to(P, (T, d, d))
    if P.shape != (T, d, d):
        raise ShapeError(f"cov has shape {np.shape(cov)}, expected ({T}, {d}, {d}) or ({d}, {d})")
    out = np.full(T, np.nan)
    ok = np.isfinite(e).all(axis=1) & np.isfinite(P).all(axis=(1, 2))
    if d == 0:
        return out
    idx = np.flatnonzero(ok)
    if idx.size:
        try:
            sol = np.linalg.solve(P[idx], e[idx][:, :, None])[:, :, 0]
            out[idx] = np.einsum("ti,ti->t", e[idx], sol)
        except np.linalg.LinAlgError:
            # a singular covariance (a state known exactly): pseudo-inverse; an error
            # outside its range is infinitely unlikely
            for t in idx:
                Pi = np.linalg.pinv(P[t])
                et = e[t]
                resid = et - P[t] @ (Pi @ et)
                scale = max(float(np.abs(et).max()), 1e-300)
                out[t] = np.inf if np.abs(resid).max() > 1e-9 * scale else float(et @ Pi @ et)
    return out


@dataclass(frozen=True)
class ConsistencyReport:
    """Chi-square consistency test of a NEES or NIS series.

    Attributes
    ----------
    mean : float
        Average of the series (ANEES / ANIS); a consistent filter gives ``dof``.
    dof : int
        Degrees of freedom (dimension of the error).
    n_samples : int
        Finite samples used.
    n_effective : float
        Effective number of independent samples (the series is autocorrelated;
        batch-means estimate of the integrated autocorrelation time).
    mean_bounds : (float, float)
        Two-sided ``1 − alpha`` interval of the mean for a consistent filter,
        ``χ²(N_eff·dof) / N_eff``.
    fraction_inside : float
        Share of samples inside the per-sample interval ``χ²_dof(alpha/2 ..
        1 − alpha/2)``; ``1 − alpha`` for a consistent filter.
    consistent : bool
        ``mean`` lies inside ``mean_bounds``.
    alpha : float
    """

    mean: float
    dof: int
    n_samples: int
    n_effective: float
    mean_bounds: tuple[float, float]
    fraction_inside: float
    consistent: bool
    alpha: float

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {
            "mean": self.mean,
            "dof": self.dof,
            "n_samples": self.n_samples,
            "n_effective": self.n_effective,
            "mean_bounds": list(self.mean_bounds),
            "fraction_inside": self.fraction_inside,
            "consistent": self.consistent,
            "alpha": self.alpha,
        }


def consistency(values: ArrayLike, dof: int, *, alpha: float = 0.05) -> ConsistencyReport:
    """Chi-square test of a NEES/NIS series (Bar-Shalom et al., 5.4.2).

    Parameters
    ----------
    values : array_like, shape (T,)
        NEES or NIS values (NaN ignored, ``inf`` fails the test).
    dof : int
        Dimension of the error vector.
    alpha : float
        Significance level of the two-sided tests.

    Returns
    -------
    ConsistencyReport

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> e = rng.normal(size=(5000, 2))
    >>> rep = consistency(normalized_error_squared(e, np.eye(2)), dof=2)
    >>> rep.consistent, bool(0.94 < rep.fraction_inside < 0.97)
    (True, True)
    """
    v = np.asarray(values, dtype=float).reshape(-1)
    v = v[~np.isnan(v)]  # inf (an impossible error) stays and fails the test
    if int(dof) != dof or dof < 1:
        raise ParameterError(f"dof is {dof!r}; expected a positive integer")
    if not 0 < alpha < 1:
        raise ParameterError(f"alpha is {alpha!r}; expected 0 < alpha < 1")
    N = v.size
    if N < 2:
        raise ShapeError(f"{N} finite values; the consistency test needs at least 2")
    mean = float(v.mean())
    if not np.isfinite(mean):
        return ConsistencyReport(mean, int(dof), N, float(N), (0.0, 0.0), 0.0, False, alpha)
    # integrated autocorrelation time by batch means (batches of √N samples)
    b = max(1, int(math.sqrt(N)))
    nb_ = N // b
    var = float(v.var())
    if nb_ >= 2 and var > 0:
        bm = v[: nb_ * b].reshape(nb_, b).mean(axis=1)
        tau = max(1.0, b * float(bm.var(ddof=1)) / var)
    else:
        tau = 1.0
    n_eff = N / tau
    k = n_eff * dof
    lo = float(scipy.stats.chi2.ppf(alpha / 2, k)) / n_eff
    hi = float(scipy.stats.chi2.ppf(1 - alpha / 2, k)) / n_eff
    plo = float(scipy.stats.chi2.ppf(alpha / 2, dof))
    phi = float(scipy.stats.chi2.ppf(1 - alpha / 2, dof))
    inside = float(np.mean((v >= plo) & (v <= phi)))
    return ConsistencyReport(mean, int(dof), N, n_eff, (lo, hi), inside, lo <= mean <= hi, alpha)


# ===================================================================== AXT211
#: Sensor noise of the AXT211 test bench (thermogym.rigs.axt211), used as defaults.
_AXT211_MEAS_STD = {
    "P_PTC": 0.01,
    "R_PTC": 0.5,
    "T_P": 0.1,
    "T_G": 0.1,
    "x_P": 0.005,
    "x_V": 0.005,
}


class AXT211WaxUKF:
    """Unscented Kalman filter for the AXT211 wax temperature T_P (paper 002).

    The state ``[T_P, T_G, x_P, x_V]`` of :class:`~thermogym.models.axt211.AXT211`
    is propagated by the model's own step function (RK4 of eqs 17-21, batched
    over the sigma points in one call); measured are the valve stroke ``x_V``
    (LVDT) and what the supply side sees — the PTC power ``P_PTC`` (eq 15,
    from supply voltage and current); the control input ``u``, the supply
    voltage ``k_U`` and the environment ``T_U`` are exogenous. The stroke
    tells ``T_P`` while the valve moves (eq 19: the quasi-static stroke is
    ``k_P (T_P − T_P0)``), the power while the heater is on (eq 14-15:
    ``R_PTC(T_P)``); with the valve closed and the heater off the filter
    predicts.

    Specimen spread (paper 002 section VIII: the start temperature ``T_P0``
    and the stroke gain vary between actuators) makes the stroke a biased
    measure of ``T_P``: with ``parameters={"T_P0": 1.5}`` those model
    parameters join the state as slow random walks (prior std 1.5 K) and the
    power measurement, which sees ``T_P`` through ``R_PTC`` independently of
    the mechanics, lets the filter learn them.

    Sigma points: Van der Merwe's scaled set (filterpy) with ``alpha = 1``,
    ``beta = 2``, ``kappa = 0`` — a spread of ``±√n σ`` that stays inside the
    model's valid region; covariances are symmetrised after every update and
    a singular one falls back to an eigen factorisation.

    Parameters
    ----------
    model : AXT211, optional
        The model (nominal AXT211 when omitted); effects allowed.
    theta : parameter batch, optional
        One parameter set (a FitResult's).
    dt : float
        Sample period [s].
    measured : sequence of str
        Model outputs used as measurements (default ``("x_V", "P_PTC")``).
    measurement_std : mapping, optional
        Noise std per measured output [its unit]; the rig's sensors by default.
    process_std : sequence of 4 float
        Process noise std of ``T_P`` [K], ``T_G`` [K], ``x_P`` [mm], ``x_V``
        [mm] per sample (model error the filter allows).
    parameters : mapping, optional
        ``{model parameter: prior std}`` estimated jointly with the state
        (random walks whose step is ``drift`` × prior std per sample).
    drift : float
        Relative random-walk step of the estimated parameters per sample.
    alpha, beta, kappa : float
        Sigma-point parameters.

    Examples
    --------
    >>> import numpy as np
    >>> from thermogym.models import AXT211
    >>> m = AXT211()
    >>> u = np.column_stack([np.ones(600), np.full(600, 24.0), np.full(600, 25.0)])
    >>> sim = m.simulate(u, 1.0)
    >>> z = np.column_stack([sim.output("x_V")[0], sim.output("P_PTC")[0]])
    >>> est = AXT211WaxUKF(m).run(u, z, x0=[35.0, 25.0, -0.1, 0.0])
    >>> bool(abs(est["T_P"][-1] - sim.output("T_P")[0, -1]) < 1.0)
    True
    """

    exogenous_names: tuple[str, ...] = ("u", "k_U", "T_U")
    output_names: tuple[str, ...] = ("T_P", "T_G", "x_P", "x_V")

    def __init__(
        self,
        model: Any = None,
        theta: ThetaLike = None,
        *,
        dt: float = 1.0,
        measured: Sequence[str] = ("x_V", "P_PTC"),
        measurement_std: Mapping[str, float] | None = None,
        process_std: Sequence[float] = (0.05, 0.02, 0.01, 0.002),
        parameters: Mapping[str, float] | None = None,
        drift: float = 1e-3,
        alpha: float = 1.0,
        beta: float = 2.0,
        kappa: float = 0.0,
    ) -> None:
        from thermogym.models.axt211 import AXT211

        self.model = AXT211() if model is None else model
        if not isinstance(self.model, AXT211):
            raise ConfigError(
                f"AXT211WaxUKF needs an AXT211 model, got {type(self.model).__name__}"
            )
        th = self.model.theta(theta)
        if th.shape[0] != 1:
            raise ParameterError(f"theta holds {th.shape[0]} parameter sets; expected one")
        self.theta = th
        if not (np.isfinite(dt) and dt > 0):
            raise ParameterError(f"dt is {dt!r}; expected a positive sample period in seconds")
        self.dt = float(dt)
        outs = list(self.model.output_names)
        self.measured_names = _names(measured, "measured")
        if not self.measured_names:
            raise ConfigError("AXT211WaxUKF needs at least one measured output (e.g. 'x_V')")
        for nme in self.measured_names:
            if nme not in outs:
                raise UnknownNameError(
                    f"measured {nme!r} is not an AXT211 output; outputs are {outs}"
                )
        self._iz = np.array([outs.index(nme) for nme in self.measured_names])
        stds = {**_AXT211_MEAS_STD, **dict(measurement_std or {})}
        unknown = [k for k in (measurement_std or {}) if k not in outs]
        if unknown:
            raise UnknownNameError(f"measurement_std names {unknown}, not AXT211 outputs {outs}")
        self.R = np.diag([float(stds[nme]) ** 2 for nme in self.measured_names])
        ps = np.asarray(process_std, dtype=float).reshape(-1)
        if ps.shape != (4,) or (ps < 0).any():
            raise ParameterError(f"process_std is {process_std!r}; expected 4 values >= 0")
        pars = dict(parameters or {})
        for name, std in pars.items():
            if name not in self.model.param_names:
                raise UnknownNameError(
                    f"parameter {name!r} is not an AXT211 parameter; parameters are "
                    f"{list(self.model.param_names)}"
                )
            if not (np.isfinite(std) and std > 0):
                raise ParameterError(f"prior std of {name!r} is {std!r}; expected > 0")
        if not (np.isfinite(drift) and drift >= 0):
            raise ParameterError(f"drift is {drift!r}; expected >= 0")
        self.parameter_names = tuple(pars)
        self._ip = np.array([self.model.param_index(n) for n in pars], dtype=np.int64)
        self._prior = np.array(list(pars.values()), dtype=float)
        self.output_names = (*AXT211WaxUKF.output_names, *self.parameter_names)
        self._nx = 4 + len(pars)
        self.Q = np.diag(np.concatenate([ps**2, (drift * self._prior) ** 2]))
        self._points = (float(alpha), float(beta), float(kappa))
        self._theta_batch: dict[int, NDArray[np.float64]] = {}
        self._kf: Any = None
        self._innovation: tuple[NDArray, NDArray] = (np.zeros(0), np.zeros((0, 0)))

    # ----------------------------------------------------------- filterpy glue
    def _fx_batch(self, sigmas: NDArray[np.float64], dt: float, u: NDArray) -> NDArray:
        # one compiled RK4 call for every sigma point: x⁺ = Φ(x, u, Δt)
        sig = np.array(sigmas, dtype=float)
        B = sig.shape[0]
        ub = np.repeat(u[None, :], B, axis=0)
        th = self._theta_batch.get(B)
        if th is None:
            th = self._theta_batch[B] = np.repeat(self.theta, B, axis=0)
        if self._ip.size:
            th = th.copy()
            th[:, self._ip] = sig[:, 4:]  # each sigma point carries its own parameters
        out = sig.copy()
        out[:, :4] = self.model._step(np.ascontiguousarray(sig[:, :4]), ub, th, dt)
        return out  # the parameters are random walks: unchanged in the mean

    def _hx(self, x: NDArray[np.float64], u: NDArray[np.float64], idx: NDArray) -> NDArray:
        xa = np.asarray(x, dtype=float)
        th = self.theta
        if self._ip.size:
            th = th.copy()
            th[0, self._ip] = xa[4:]
        y = self.model._output(xa[None, :4], u[None, :], th)[0]
        return y[idx]

    def _make(self, x0: NDArray[np.float64], P0: NDArray[np.float64]) -> Any:
        from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter

        outer = self

        class _BatchedUKF(UnscentedKalmanFilter):  # type: ignore[misc]
            def compute_process_sigmas(self, dt, fx=None, **fx_args):
                sigmas = self.points_fn.sigma_points(self.x, self.P)
                self.sigmas_f = outer._fx_batch(sigmas, dt, fx_args["u"])

        a, b, k = self._points
        pts = MerweScaledSigmaPoints(self._nx, alpha=a, beta=b, kappa=k, sqrt_method=_psd_sqrt_rows)
        kf = _BatchedUKF(
            dim_x=self._nx,
            dim_z=len(self.measured_names),
            dt=self.dt,
            hx=lambda x, u, idx: self._hx(x, u, idx),
            fx=lambda x, dt, u: self._fx_batch(np.asarray(x)[None, :], dt, u)[0],
            points=pts,
        )
        kf.x = x0.astype(float).copy()
        kf.P = P0.astype(float).copy()
        kf.Q = self.Q.copy()
        kf.R = self.R.copy()
        return kf

    def _correct(self, u: NDArray, z: NDArray) -> NDArray:
        kf = self._kf
        ok = np.isfinite(z)
        nu = np.full(z.shape, np.nan)
        S = np.full((z.size, z.size), np.nan)
        if ok.any():
            idx = self._iz[ok]
            kf.update(z[ok], R=self.R[np.ix_(ok, ok)], u=u, idx=idx)
            kf.P = 0.5 * (kf.P + kf.P.T)
            nu[ok] = kf.y
            S[np.ix_(ok, ok)] = kf.S
        else:
            kf.update(None)
        self._innovation = (nu, S)
        return np.asarray(kf.x, dtype=float).copy()

    def _check_uz(self, u: ArrayLike, z: ArrayLike) -> tuple[NDArray, NDArray]:
        ua = np.asarray(u, dtype=float).reshape(-1)
        za = np.asarray(z, dtype=float).reshape(-1)
        if ua.shape != (3,) or za.shape != (len(self.measured_names),):
            raise ShapeError(
                f"u has shape {ua.shape} and z {za.shape}; expected (3,) for {self.exogenous_names}"
                f" and ({len(self.measured_names)},) for {self.measured_names}"
            )
        if not np.isfinite(ua).all():
            raise ShapeError(f"exogenous sample {ua.tolist()} is not finite; the UKF needs u")
        return ua, za

    # --------------------------------------------------------------- stepping
    @property
    def input_names(self) -> tuple[str, ...]:
        """Exogenous channels (step-estimator protocol)."""
        return self.exogenous_names

    def rest_state(self, u: ArrayLike) -> NDArray[np.float64]:
        """Rest state for exogenous ``u = [u, k_U, T_U]`` (and the parameters' values)."""
        ua = np.asarray(u, dtype=float).reshape(1, 3)
        x = self.model.initial_state(self.theta, ua)[0]
        return np.concatenate([x, self.theta[0, self._ip]])

    def reset(
        self,
        u: ArrayLike,
        z: ArrayLike,
        *,
        x0: ArrayLike | None = None,
        P0: ArrayLike | None = None,
    ) -> NDArray[np.float64]:
        """Start the filter and correct with the first sample; return ``x̂[0|0]``.

        Parameters
        ----------
        u : array_like, shape (3,)
        z : array_like, shape (q,)
        x0 : array_like, shape (4,) or (4 + k,), optional
            Initial state (the parameters' nominal values appended when only
            the 4 states are given); the rest state at ``u`` by default.
        P0 : array_like, shape (4 + k, 4 + k), optional
            Initial covariance; by default (10 K)² on the temperatures, (0.2
            mm)² on the strokes (the actuator may be warm from earlier use) and
            the priors of the estimated parameters.
        """
        ua, za = self._check_uz(u, z)
        n = self._nx
        if x0 is None:
            x = self.rest_state(ua)
        else:
            x = np.asarray(x0, dtype=float).reshape(-1)
            if x.shape == (4,):
                x = np.concatenate([x, self.theta[0, self._ip]])
            if x.shape != (n,):
                raise ShapeError(f"x0 has shape {x.shape}, expected (4,) or ({n},)")
        if P0 is None:
            P = np.diag(np.concatenate([[100.0, 100.0, 0.04, 0.04], self._prior**2]))
        else:
            P = np.asarray(P0, dtype=float)
        if P.shape != (n, n):
            raise ShapeError(f"P0 has shape {P.shape}, expected ({n}, {n})")
        self._kf = self._make(x, P)
        return self._correct(ua, za)

    def update(self, u_prev: ArrayLike, u: ArrayLike, z: ArrayLike) -> NDArray[np.float64]:
        """Predict over one step with ``u_prev``, correct with ``z``; return ``x̂[k|k]``."""
        if self._kf is None:
            raise ParameterError("update() before reset(); reset the filter first")
        up = np.asarray(u_prev, dtype=float).reshape(-1)
        ua, za = self._check_uz(u, z)
        if up.shape != (3,) or not np.isfinite(up).all():
            raise ShapeError(f"u_prev is {up.tolist()}; expected 3 finite values")
        self._kf.predict(u=up)
        return self._correct(ua, za)

    def run(
        self,
        u: ArrayLike,
        z: ArrayLike,
        *,
        x0: ArrayLike | None = None,
        P0: ArrayLike | None = None,
    ) -> Estimate:
        """Filter a whole series.

        Parameters
        ----------
        u : array_like, shape (T, 3)
            ``u``, ``k_U`` [V], ``T_U`` [°C] at the filter's ``dt``.
        z : array_like, shape (T, q)
            Measured outputs; NaN samples are skipped.
        x0, P0 : optional
            As :meth:`reset`.

        Returns
        -------
        Estimate
            The four states (``T_P`` first) and the estimated parameters,
            with their covariance.
        """
        ua = np.asarray(u, dtype=float)
        za = np.asarray(z, dtype=float)
        q = len(self.measured_names)
        if za.ndim == 1 and q == 1:
            za = za[:, None]
        if ua.ndim != 2 or ua.shape[1] != 3 or za.shape != (ua.shape[0], q):
            raise ShapeError(
                f"u has shape {ua.shape} and z {za.shape}; expected (T, 3) and (T, {q})"
            )
        T = ua.shape[0]
        n = self._nx
        xs = np.empty((T, n))
        cov = np.empty((T, n, n))
        nus = np.full((T, q), np.nan)
        sig = np.full((T, q, q), np.nan)
        status = np.zeros(T, dtype=np.int8)
        for k in range(T):
            if k == 0:
                self.reset(ua[0], za[0], x0=x0, P0=P0)
            else:
                self.update(ua[k - 1], ua[k], za[k])
            if not np.isfinite(za[k]).any():
                status[k] = ObserverStatus.NOT_FINITE
            xs[k] = self._kf.x
            cov[k] = self._kf.P
            nus[k], sig[k] = self._innovation
        return Estimate(
            self.output_names, xs, cov, xs.copy(), nus, sig, status, self.measured_names
        )
