"""Noise models and steady-state Kalman gains of linear models (paper 001).

The discrete algebraic Riccati equation of the steady-state Kalman filter and the
innovation covariance of an identified model; see :mod:`thermogym.estimation.virtual_sensor`
for the equations.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from thermogym._checks import nonnegative, positive
from thermogym.errors import ParameterError, ShapeError
from thermogym.estimation._linalg import _check_psd, _mat, _spectral_radius
from thermogym.models.base import ThetaLike
from thermogym.models.linear import StateSpaceModel

__all__ = ["KalmanGains", "NoiseModel", "innovation_covariance", "steady_state_gains"]


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
    S: NDArray[np.float64] = field(default=None)  # type: ignore[assignment,arg-type]

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
        process = nonnegative("process noise scale", process, text=False)
        measurement = positive("measurement noise scale", measurement, text=False)
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
