"""Unscented Kalman filter for the AXT211 wax temperature (paper 002)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter
from numpy.typing import ArrayLike, NDArray

from thermogym._checks import nonnegative, positive
from thermogym.errors import ConfigError, ParameterError, ShapeError, UnknownNameError
from thermogym.estimation._linalg import _names, _psd_sqrt_rows
from thermogym.estimation.observer import Estimate, ObserverStatus
from thermogym.models.axt211 import AXT211
from thermogym.models.base import ThetaLike

__all__ = ["AXT211WaxUKF"]

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
        self.model = AXT211() if model is None else model
        if not isinstance(self.model, AXT211):
            raise ConfigError(
                f"AXT211WaxUKF needs an AXT211 model, got {type(self.model).__name__}"
            )
        th = self.model.theta(theta)
        if th.shape[0] != 1:
            raise ParameterError(f"theta holds {th.shape[0]} parameter sets; expected one")
        self.theta = th
        self.dt = positive("dt", dt, unit="s", text=False)
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
            positive(f"prior std of {name!r}", std, text=False)
        nonnegative("drift", drift, text=False)
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
