"""Model predictive control on an identified linear model (OSQP).

At every sample the controller estimates the plant state from the
measurement, predicts the output over ``N`` samples with the identified
linear model (:class:`~thermogym.controllers.linmodel.LinearPlant`) and
solves a quadratic programme for the input moves; the first move is applied
(receding horizon). The command is a duty in [0, 1]: on an environment whose
control period is shorter than the MPC's sample time, or with on/off actions,
put it behind a :class:`~thermogym.controllers.pwm.PWM` stage with
``period = sample_time``.

Optimisation problem
--------------------
Decision variables: moves ``u_0 … u_{Nu−1}`` (held after ``Nu``), band
slacks ``s⁻_i, s⁺_i ≥ 0`` and move magnitudes ``t_j ≥ |Δu_j|``::

    min  Σ_i q (ŷ_i − r_i)²                         tracking
       + Σ_j r_Δ Δu_j² + w_sw Σ_j t_j               move suppression, switching cost
       + c_u Σ_i u_i                                 energy (linear in the duty)
       + Σ_i ρ₁ (s⁻_i + s⁺_i) + ρ₂ (s⁻_i² + s⁺_i²)   soft output band
    s.t. u_min ≤ u_j ≤ u_max,   |Δu_j| ≤ Δu_max       actuator limits
         ŷ_i + s⁻_i ≥ lo_i,     ŷ_i − s⁺_i ≤ hi_i      comfort band (where given)
         −t_j ≤ Δu_j ≤ t_j

The switching-cost term ``w_sw Σ|Δu|`` is the convex (ℓ1) stand-in for the
number of actuator switchings: it makes the optimal move sequence sparse, so
the duty changes rarely and in steps — what lengthens the life of a wax
actuator. Predictions ``ŷ = Φ x̂ + Γ M u + Ψ d + w`` are condensed (the
states are eliminated); OSQP (Stellato et al., *Math. Prog. Comp.* 12, 2020)
solves the QP, warm-started from the previous one.

Offset-free estimation
----------------------
The model is augmented with an integrating output disturbance ``w``
(``y = C x + w``), estimated with the plant state by a steady-state Kalman
filter (gain from the discrete algebraic Riccati equation): model errors and
unmeasured disturbances end up in ``w`` and the loop has no steady error
(Pannocchia & Rawlings, *AIChE J.* 49, 2003). The first estimate is the
steady state that explains the first measurement (a plant at rest).

Previews
--------
``preview(obs, t, n, h)`` gives the reference and the band over the horizon;
the default holds the current set-point. :class:`SchedulePreview` knows the
occupancy schedule of ``AXT211Room`` (set-points and comfort band), so the
MPC preheats before the occupants arrive.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import osqp
import scipy.linalg
import scipy.sparse as sp
from numpy.typing import NDArray

from thermogym.controllers.base import Controller, EnvInfo, Loop, _num
from thermogym.controllers.linmodel import LinearPlant, linear_plant
from thermogym.envs.axt211_room import RoomConfig
from thermogym.errors import ConfigError, ParameterError

__all__ = ["MPC", "PreviewData", "SchedulePreview"]


@dataclass(frozen=True)
class PreviewData:
    """Reference and soft band over the horizon (samples 1..N ahead).

    Attributes
    ----------
    r : ndarray, shape (N,)
        Reference of the controlled output.
    lo, hi : ndarray, shape (N,), optional
        Soft lower / upper limits (``±inf`` where none).
    d : mapping, optional
        ``{model disturbance: values (N,)}`` over the next N sample intervals
        (from now); disturbances not given are held at their measured value.
    """

    r: NDArray[np.float64]
    lo: NDArray[np.float64] | None = None
    hi: NDArray[np.float64] | None = None
    d: Mapping[str, NDArray[np.float64]] | None = None


Preview = Callable[[NDArray[np.float64], float, int, float], PreviewData]


class SchedulePreview:
    """Set-point and comfort band of the ``AXT211Room`` occupancy schedule.

    Parameters
    ----------
    start_day : int
        Day of the year at the episode start (0 = 1 January, a Monday), as
        the environment's ``start_day``.
    start_hour : float
        Clock time at the start [h].
    occupied_hours : (float, float)
        Occupancy from/to [h] on occupied days.
    occupied_days : int
        Occupied days per week from Monday.
    setpoints_C : (float, float)
        Set-point occupied / unoccupied [°C].
    comfort_band_C : (float, float)
        Band while occupied [°C].
    setback_band_C : (float, float)
        Band while unoccupied [°C].
    margin_K : float
        The band is tightened by this margin (sensor noise, model error).
    occupancy_name : str
        Name of the occupancy disturbance in the MPC's model (its preview is
        given when the model has it).

    Notes
    -----
    The defaults are those of :class:`thermogym.envs.axt211_room.RoomConfig`;
    :meth:`from_env_kwargs` takes an environment's keyword arguments.
    """

    def __init__(
        self,
        start_day: int,
        start_hour: float = 0.0,
        *,
        occupied_hours: tuple[float, float] = (7.0, 18.0),
        occupied_days: int = 5,
        setpoints_C: tuple[float, float] = (21.0, 17.0),
        comfort_band_C: tuple[float, float] = (20.0, 24.0),
        setback_band_C: tuple[float, float] = (16.0, 28.0),
        margin_K: float = 0.3,
        occupancy_name: str = "occupied",
    ) -> None:
        self.occupancy_name = occupancy_name
        self.t0 = float(start_day) * 86400.0 + float(start_hour) * 3600.0
        self.occ = (float(occupied_hours[0]), float(occupied_hours[1]))
        self.days = int(occupied_days)
        self.sp = (float(setpoints_C[0]), float(setpoints_C[1]))
        self.band = (float(comfort_band_C[0]), float(comfort_band_C[1]))
        self.setback = (float(setback_band_C[0]), float(setback_band_C[1]))
        self.margin = _num("SchedulePreview", "margin_K", margin_K, lo=0.0)

    @classmethod
    def from_env_kwargs(cls, kwargs: Mapping[str, Any], **extra: Any) -> SchedulePreview:
        """Build from ``AXT211Room`` keyword arguments (``start_day`` required)."""
        if kwargs.get("start_day") is None:
            raise ConfigError(
                "SchedulePreview needs the episode's start_day (the environment draws it when "
                "not given, and the schedule depends on the weekday)"
            )
        base = RoomConfig()
        names = (
            "occupied_hours",
            "occupied_days",
            "setpoints_C",
            "comfort_band_C",
            "setback_band_C",
        )
        kw = {n: kwargs.get(n, getattr(base, n)) for n in names}
        return cls(int(kwargs["start_day"]), float(kwargs.get("start_hour", 0.0)), **kw, **extra)

    def occupied(self, t: NDArray[np.floating[Any]]) -> NDArray[np.bool_]:
        """Occupancy at episode times ``t`` [s] (same rule as the environment)."""
        ta = self.t0 + t
        day = np.floor(ta / 86400.0)
        hour = (ta - 86400.0 * day) / 3600.0
        return ((day % 7) < self.days) & (hour >= self.occ[0]) & (hour < self.occ[1])

    def __call__(self, obs: NDArray[np.float64], t: float, n: int, h: float) -> PreviewData:
        """Reference and band at the ends of the next ``n`` samples."""
        ts = t + h * np.arange(1, n + 1)
        occ = self.occupied(ts)
        r = np.where(occ, self.sp[0], self.sp[1])
        lo = np.where(occ, self.band[0], self.setback[0]) + self.margin
        hi = np.where(occ, self.band[1], self.setback[1]) - self.margin
        # occupancy during the intervals starting now (internal gains), for models that have it
        occ_now = self.occupied(t + h * np.arange(n)).astype(float)
        return PreviewData(r, lo, hi, {self.occupancy_name: occ_now})


class MPC(Controller):
    """Linear MPC with actuator limits, a switching cost and a soft output band.

    Parameters
    ----------
    model : LinearPlant, FOPTDModel, StateSpaceModel or FitResult
        Identified linear model (see :func:`~thermogym.controllers.linmodel.linear_plant`).
    horizon : int
        Prediction horizon ``N`` [samples].
    control_horizon : int, optional
        Free moves ``Nu`` (default ``N``); the input is held after them.
    input : str, optional
        The model's manipulated input (default: its first exogenous signal);
        its unit is the command's ([0, 1] duty), scaled by ``input_scale``.
    input_scale : float
        Model-input units per unit command (e.g. 100 for a model in %).
    output : str, optional
        The model output that is the loop's measurement (default: the only one).
    disturbances : mapping, optional
        ``{model disturbance: observation name}`` of measured disturbances
        (held constant over the horizon); the others stay at their operating
        point.
    q : float
        Weight of the squared tracking error [1/unit²].
    r_du : float
        Weight of squared moves (command units).
    switching_cost : float
        Weight of ``Σ|Δu|`` (ℓ1 switching cost).
    energy_cost : float
        Weight of ``Σ u`` (command is proportional to heater energy).
    band_weight : (float, float)
        ``(ρ₁, ρ₂)`` linear and quadratic weights of band violations.
    u_min, u_max : float
        Command limits (within [0, 1]).
    du_max : float, optional
        Largest move per sample.
    noise : (float, float, float)
        Kalman filter variances ``(q_x, q_w, r)``: state, output disturbance
        and measurement [unit²].
    preview : callable, optional
        ``preview(obs, t, N, h) -> PreviewData`` (default: hold the set-point).
    solver_settings : mapping, optional
        OSQP settings overriding the defaults.
    loop, sample_time
        See :class:`~thermogym.controllers.base.Controller`.

    Examples
    --------
    >>> import gymnasium as gym
    >>> import thermogym.envs
    >>> from thermogym.models.linear import FOPTDModel
    >>> model = FOPTDModel(["duty"], ["x_V"], K=20.0, T=200.0, tau=10.0, offsets=True, y0=-7.0)
    >>> env = gym.make("thermogym/AXT211Valve-v0", setpoint=2.0, sensor_noise=False)
    >>> mpc = MPC(model, horizon=30, sample_time=30.0, q=1.0, r_du=0.1).bind(env)
    >>> obs, _ = env.reset(seed=0)
    >>> for _ in range(360):
    ...     obs, *_ = env.step(mpc.act(obs))
    >>> abs(env.unwrapped.true_outputs()["x_V"] - 2.0) < 0.1
    True
    """

    label = "mpc"

    def __init__(
        self,
        model: Any,
        *,
        horizon: int = 30,
        control_horizon: int | None = None,
        input: str | None = None,
        input_scale: float = 1.0,
        output: str | None = None,
        disturbances: Mapping[str, str] | None = None,
        q: float = 1.0,
        r_du: float = 0.01,
        switching_cost: float = 0.0,
        energy_cost: float = 0.0,
        band_weight: tuple[float, float] = (100.0, 100.0),
        u_min: float = 0.0,
        u_max: float = 1.0,
        du_max: float | None = None,
        noise: tuple[float, float, float] = (1e-4, 1e-3, 1e-2),
        preview: Preview | None = None,
        solver_settings: Mapping[str, Any] | None = None,
        loop: Loop | None = None,
        sample_time: float | None = None,
    ) -> None:
        super().__init__(loop=loop, sample_time=sample_time)
        who = "MPC"
        self.source = model
        if isinstance(horizon, bool) or not isinstance(horizon, int) or horizon < 1:
            raise ConfigError(f"{who}: horizon is {horizon!r}; expected an integer >= 1")
        nu = horizon if control_horizon is None else control_horizon
        if isinstance(nu, bool) or not isinstance(nu, int) or not 1 <= nu <= horizon:
            raise ConfigError(
                f"{who}: control_horizon is {control_horizon!r}; expected 1..horizon ({horizon})"
            )
        self.N, self.Nu = int(horizon), int(nu)
        self.input = input
        self.input_scale = _num(who, "input_scale", input_scale)
        if self.input_scale == 0:
            raise ConfigError(f"{who}: input_scale is 0")
        self.output = output
        self.dist_map = dict(disturbances or {})
        self.q = _num(who, "q", q, lo=0.0)
        self.r_du = _num(who, "r_du", r_du, lo=0.0)
        self.switching_cost = _num(who, "switching_cost", switching_cost, lo=0.0)
        self.energy_cost = _num(who, "energy_cost", energy_cost)
        if len(band_weight) != 2:
            raise ConfigError(f"{who}: band_weight is {band_weight!r}; expected (rho1, rho2)")
        self.rho1 = _num(who, "band_weight[0]", band_weight[0], lo=0.0)
        self.rho2 = _num(who, "band_weight[1]", band_weight[1], lo=0.0)
        self.u_min = _num(who, "u_min", u_min, lo=0.0, hi=1.0)
        self.u_max = _num(who, "u_max", u_max, lo=0.0, hi=1.0)
        if self.u_min >= self.u_max:
            raise ConfigError(f"{who}: u_min {u_min!r} >= u_max {u_max!r}")
        self.du_max = None if du_max is None else _num(who, "du_max", du_max, lo=0.0)
        if len(noise) != 3 or any(not (isinstance(v, int | float) and v > 0) for v in noise):
            raise ConfigError(f"{who}: noise is {noise!r}; expected three variances > 0")
        self.noise = tuple(float(v) for v in noise)
        self.preview = preview
        self.solver_settings = dict(solver_settings or {})
        self.plant: LinearPlant | None = None
        self._prob: Any = None
        self._fails = 0
        self._solves = 0
        self._iters = 0

    # ------------------------------------------------------------------ set-up
    def _bind(self, info: EnvInfo) -> None:
        who = f"MPC on {info.name}"
        # FOPTD sets are discretised exactly at the sample time; state spaces resampled
        base = linear_plant(
            self.source, input=self.input, disturbances=list(self.dist_map), dt=self.h
        )
        outs = base.outputs
        if self.output is None:
            if len(outs) != 1:
                raise ConfigError(f"{who}: the model has outputs {list(outs)}; give output=")
            j = 0
        elif self.output in outs:
            j = outs.index(self.output)
        else:
            raise ConfigError(
                f"{who}: the model has no output {self.output!r}; it has {list(outs)}"
            )
        if np.any(base.D_u != 0):
            raise ConfigError(
                f"{who}: the model has a direct feedthrough of the input; MPC needs D_u = 0"
            )
        self.plant = base
        self._j = j
        self._i_d = [info.index(self.dist_map[d], who) for d in base.disturbances]
        self._build()

    def _build(self) -> None:
        lp = self.plant
        assert lp is not None
        N, Nu = self.N, self.Nu
        n = lp.n_states
        s = self.input_scale
        A, B, E = lp.A, lp.B[:, 0] * s, lp.E  # B per unit command
        c = lp.C[self._j]
        # condensed prediction: y_i = c A^i x + Σ_{j<i} c A^{i−1−j} (B u_j + E d_j) (i = 1..N)
        Phi = np.zeros((N, n))
        imp = np.zeros(N)  # c A^i B
        impE = np.zeros((N, E.shape[1]))  # c A^i E
        Ak = np.eye(n)
        for i in range(N):
            imp[i] = c @ Ak @ B
            impE[i] = c @ Ak @ E
            Ak = A @ Ak
            Phi[i] = c @ Ak
        Gam = np.zeros((N, N))
        H = np.zeros((E.shape[1], N, N))  # per disturbance: effect of d_j on y_i
        for i in range(N):
            Gam[i, : i + 1] = imp[i::-1]
            H[:, i, : i + 1] = impE[i::-1].T
        M = np.zeros((N, Nu))
        for i in range(N):
            M[i, min(i, Nu - 1)] = 1.0
        G = Gam @ M
        Dm = np.eye(Nu) - np.eye(Nu, k=-1)  # Δu_j = u_j − u_{j−1}
        self._Phi, self._H, self._G, self._M, self._Dm = Phi, H, G, M, Dm
        # P over z = [u (Nu), s⁻ (N), s⁺ (N), t (Nu)]
        Puu = 2.0 * (self.q * G.T @ G + self.r_du * Dm.T @ Dm) + 1e-9 * np.eye(Nu)
        Pss = 2.0 * self.rho2 * np.eye(2 * N) + 1e-9 * np.eye(2 * N)
        Ptt = 1e-9 * np.eye(Nu)
        P = sp.block_diag([Puu, Pss, Ptt], format="csc")
        self._nz = nz = 2 * Nu + 2 * N
        Iu, IN = sp.eye(Nu), sp.eye(N)
        Z = sp.csc_matrix
        rows = [
            sp.hstack([Iu, Z((Nu, 2 * N)), Z((Nu, Nu))]),  # limits
            sp.hstack([sp.csc_matrix(Dm), Z((Nu, 2 * N)), -Iu]),  # Δu − t ≤ 0
            sp.hstack([sp.csc_matrix(-Dm), Z((Nu, 2 * N)), -Iu]),  # −Δu − t ≤ 0
            sp.hstack([sp.csc_matrix(G), IN, Z((N, N)), Z((N, Nu))]),  # ŷ + s⁻ ≥ lo
            sp.hstack([sp.csc_matrix(G), Z((N, N)), -IN, Z((N, Nu))]),  # ŷ − s⁺ ≤ hi
            sp.hstack([Z((2 * N + Nu, Nu)), sp.eye(2 * N + Nu)]),  # s, t ≥ 0
            sp.hstack([sp.csc_matrix(Dm), Z((Nu, 2 * N + Nu))]),  # |Δu| ≤ Δu_max
        ]
        Acon = sp.vstack(rows, format="csc")
        self._P, self._A = P, Acon
        self._lin_s = np.concatenate([np.full(2 * N, self.rho1), np.full(Nu, self.switching_cost)])
        settings = {
            "verbose": False,
            "eps_abs": 1e-4,
            "eps_rel": 1e-4,
            "max_iter": 20000,
            "polishing": True,
            "warm_starting": True,
        }
        settings.update(self.solver_settings)

        self._prob = osqp.OSQP()
        l0, u0 = self._bounds(np.zeros(N), None, None, 0.0)
        self._prob.setup(P, np.zeros(nz), Acon, l0, u0, **settings)
        # Kalman filter of the model augmented with an output disturbance w
        p = lp.C.shape[0]
        Aa = np.block([[A, np.zeros((n, p))], [np.zeros((p, n)), np.eye(p)]])
        Ca = np.hstack([lp.C, np.eye(p)])
        qx, qw, rr = self.noise
        Q = np.diag(np.concatenate([np.full(n, qx), np.full(p, qw)]))
        R = rr * np.eye(p)
        try:
            Pk = scipy.linalg.solve_discrete_are(Aa.T, Ca.T, Q, R)
        except (np.linalg.LinAlgError, ValueError) as e:
            raise ParameterError(f"MPC: no steady-state Kalman filter for the model ({e})") from e
        self._L = Pk @ Ca.T @ np.linalg.inv(Ca @ Pk @ Ca.T + R)  # filter (current) gain
        self._Aa, self._Ca = Aa, Ca
        self._Ba = np.concatenate([B, np.zeros(p)])
        self._Ea = np.vstack([E, np.zeros((p, E.shape[1]))])

    def _bounds(
        self,
        f: NDArray[np.float64],
        lo: NDArray[np.float64] | None,
        hi: NDArray[np.float64] | None,
        du_prev: float,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        lp = self.plant
        assert lp is not None
        N, Nu = self.N, self.Nu
        inf = np.inf
        u_off = lp.u_op / self.input_scale  # commands are absolute; the model uses deviations
        e0 = np.zeros(Nu)
        e0[0] = du_prev
        dmax = inf if self.du_max is None else self.du_max
        lo_y = np.full(N, -inf) if lo is None else np.where(np.isfinite(lo), lo - f, -inf)
        hi_y = np.full(N, inf) if hi is None else np.where(np.isfinite(hi), hi - f, inf)
        low = np.concatenate(
            [
                np.full(Nu, self.u_min - u_off),
                np.full(Nu, -inf),
                np.full(Nu, -inf),
                lo_y,
                np.full(N, -inf),
                np.zeros(2 * N + Nu),
                e0 - dmax,
            ]
        )
        up = np.concatenate(
            [
                np.full(Nu, self.u_max - u_off),
                e0,
                -e0,
                np.full(N, inf),
                hi_y,
                np.full(2 * N + Nu, inf),
                e0 + dmax,
            ]
        )
        return low, up

    def _reset(self, seed: int | None) -> None:
        self._xi: NDArray[np.float64] | None = None
        self._u_prev = self.u_min  # a plant at rest with the least input before the start
        self._d_prev: NDArray[np.float64] | None = None
        self._plan: NDArray[np.float64] | None = None
        self._n = 0
        self._fails = 0
        self._solves = 0
        self._iters = 0

    # ---------------------------------------------------------------- samples
    def _disturbances(self, obs: NDArray[np.float64]) -> NDArray[np.float64]:
        lp = self.plant
        assert lp is not None
        return np.array([obs[i] for i in self._i_d], dtype=float) - lp.d_op

    def estimate(self, obs: NDArray[np.float64]) -> NDArray[np.float64]:
        """Update the state estimate with the measurement in ``obs``; return ``[x; w]``."""
        lp = self.plant
        assert lp is not None
        y = np.zeros(lp.C.shape[0])
        y[self._j] = self.measurement(obs)
        d = self._disturbances(obs)
        n = lp.n_states
        s = self.input_scale
        if self._xi is None:
            # a plant at rest that explains the first measurement: steady state of the
            # equivalent constant input, no output disturbance
            Gu, Gd = lp.dc_gain()
            g = float(Gu[self._j, 0]) * s
            u_eq = (y[self._j] - lp.y_op[self._j] - float(Gd[self._j] @ d)) / g if g else 0.0
            x0 = np.linalg.solve(np.eye(n) - lp.A, lp.B[:, 0] * s * u_eq + lp.E @ d)
            self._xi = np.concatenate([x0, np.zeros(lp.C.shape[0])])
            return self._xi
        u_dev = self._u_prev - lp.u_op / s
        assert self._d_prev is not None
        xm = self._Aa @ self._xi + self._Ba * u_dev + self._Ea @ self._d_prev
        yhat = self._Ca @ xm + lp.D_d @ self._d_prev + lp.y_op
        innov = y - yhat
        if lp.C.shape[0] > 1:  # only the loop's output is measured
            mask = np.zeros_like(innov)
            mask[self._j] = 1.0
            innov = innov * mask
        self._xi = xm + self._L @ innov
        return self._xi

    def update(self, obs: NDArray[np.float64]) -> float:
        """Estimate, solve the QP, return the first move (a duty in [0, 1])."""
        lp = self.plant
        assert lp is not None
        xi = self.estimate(obs)
        d = self._disturbances(obs)
        self._d_prev = d
        n = lp.n_states
        x, w = xi[:n], xi[n:]
        t = self._n * self.h
        self._n += 1
        if self.preview is None:
            pv = PreviewData(np.full(self.N, self.setpoint(obs)))
        else:
            pv = self.preview(obs, t, self.N, self.h)
        s = self.input_scale
        u_off = lp.u_op / s
        # disturbance trajectories: previewed ones, the others held at their measured value
        dtraj = np.repeat(d[:, None], self.N, axis=1)
        for name, vals in (pv.d or {}).items():
            if name in lp.disturbances:
                v = np.asarray(vals, dtype=float).reshape(-1)
                if v.shape != (self.N,):
                    raise ConfigError(
                        f"MPC: preview of {name!r} has shape {v.shape}; expected ({self.N},)"
                    )
                dtraj[lp.disturbances.index(name)] = v - lp.d_op[lp.disturbances.index(name)]
        # free response (inputs at the operating point) in absolute output units
        f = (
            self._Phi @ x
            + np.einsum("lij,lj->i", self._H, dtraj)
            + float(lp.D_d[self._j] @ d)
            + w[self._j]
            + lp.y_op[self._j]
        )
        du_prev = self._u_prev - u_off
        qv = np.zeros(self._nz)
        G, M, Dm = self._G, self._M, self._Dm
        e0 = np.zeros(self.Nu)
        e0[0] = du_prev
        qv[: self.Nu] = (
            2.0 * self.q * G.T @ (f - pv.r) - 2.0 * self.r_du * Dm.T @ e0
            + self.energy_cost * M.sum(axis=0)
        )  # fmt: skip
        qv[self.Nu :] = self._lin_s
        low, up = self._bounds(f, pv.lo, pv.hi, du_prev)
        self._prob.update(q=qv, l=low, u=up)
        res = self._prob.solve(raise_error=False)
        self._solves += 1
        status = str(getattr(res.info, "status", ""))
        self._iters += int(getattr(res.info, "iter", 0))
        if res.x is None or not np.all(np.isfinite(res.x)) or "solved" not in status:
            self._fails += 1
            if self._plan is not None and self._plan.size > 1:
                self._plan = np.append(self._plan[1:], self._plan[-1])
                u = float(self._plan[0])
            else:
                u = self._u_prev
        else:
            self._plan = res.x[: self.Nu] + u_off
            u = float(self._plan[0])
        # the solver meets the constraints to its tolerance; the applied move meets them exactly
        if self.du_max is not None:
            u = min(max(u, self._u_prev - self.du_max), self._u_prev + self.du_max)
        u = min(max(u, self.u_min), self.u_max)
        self._u_prev = u
        return u

    @property
    def plan(self) -> NDArray[np.float64] | None:
        """The optimal move sequence of the last solve (commands)."""
        return None if self._plan is None else self._plan.copy()

    def _settings(self) -> dict[str, Any]:
        lp = self.plant
        out: dict[str, Any] = {
            "horizon": self.N,
            "control_horizon": self.Nu,
            "q": self.q,
            "r_du": self.r_du,
            "switching_cost": self.switching_cost,
            "energy_cost": self.energy_cost,
            "band_weight": [self.rho1, self.rho2],
            "u_limits": [self.u_min, self.u_max],
            "noise": list(self.noise),
        }
        if self.du_max is not None:
            out["du_max"] = self.du_max
        if self.input_scale != 1.0:
            out["input_scale"] = self.input_scale
        if self.dist_map:
            out["disturbances"] = dict(self.dist_map)
        if self.preview is not None:
            out["preview"] = type(self.preview).__name__
        if lp is not None:
            out["model"] = {
                "source": lp.source,
                "states": lp.n_states,
                "dt": lp.dt,
                "fingerprint": lp.fingerprint,
            }
        return out

    def stats(self) -> dict[str, float]:
        """``qp_solves``, ``qp_failures`` and mean OSQP iterations of the episode."""
        return {
            "qp_solves": float(self._solves),
            "qp_failures": float(self._fails),
            "qp_iterations_mean": self._iters / self._solves if self._solves else 0.0,
        }
