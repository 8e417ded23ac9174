"""Lumped thermal RC networks: the common numerics of the spindle and strut plants.

Each capacitive node ``i`` obeys the heat balance (eq 13 of
``000_24627a5308ee07db.txt``)::

    C_i dT_i/dt = Σ_j G_ij (T_j − T_i) + g_i (T_amb − T_i) + Σ_k q_ik u_k

with heat capacities ``C`` [J/K], symmetric inter-node conductances ``G``
[W/K], conductances to the surrounding air ``g`` [W/K] (the air is a node of
infinite capacity, paper 000 section 4.2.2) and heat sources proportional to
the inputs (``q`` [W per input unit]; paper 000 section 4.2.1: heat losses
proportional to the feed rate).

Written as ``dT/dt = A T + B_u u + b_amb T_amb`` this is linear, so the nominal
network is simulated by **exact zero-order-hold discretisation** (batched
matrix exponential). Outputs are linear in the node temperatures:
``y = H T + h0`` (node temperatures, or the thermal elongation of eq 5).

Effects (off by default; see DESIGN.md vocabulary) make the network nonlinear
or time-varying; it is then integrated by a compiled fixed-step RK4 whose step
is chosen from the fastest eigenvalue::

    input_nonlinearity             q_ik u_k  →  q_ik u_ref (u_k/u_ref)^α
    input_dependent_heat_transfer  g_i → g_i (1 + β u_1/u_ref)        (masked nodes)
    nonlinear_heat_transfer        g_i → g_i (1 + γ (|ΔT|/ΔT_ref)^(1/3)) / (1 + γ)
    time_varying_parameter         q_ik → q_ik (1 + δ t / 1 h)
    unmeasured_disturbance         + Q_ext,i(t)   (extra heat, rigs only)
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numba as nb
import numpy as np
from numpy.typing import NDArray
from scipy.linalg import expm

from thermogym._jitcache import module_kernels_depend_on
from thermogym.errors import ConfigError
from thermogym.models._blas import blas_threads
from thermogym.models._effects import EffectLayout, PhysicalEffect
from thermogym.models.base import Model, Parameter, Signal, check_step_budget
from thermogym.models.lti import lti_output, lti_update, transposed

__all__ = [
    "NETWORK_EFFECTS",
    "NetworkArrays",
    "ThermalNetworkModel",
    "lti_simulate",
    "network_matrices",
]

_E = "effect parameter; the nominal value switches it off"

#: Effects every thermal network can carry, in kernel order.
NETWORK_EFFECTS: dict[str, PhysicalEffect] = {
    "input_nonlinearity": PhysicalEffect(
        "input_nonlinearity",
        "The heat source does not grow in proportion to the input: friction losses of "
        "bearings, nuts and motors scale with a power of speed (lubricant shear, viscous "
        "drag), so the steady temperatures grow faster or slower than a linear model "
        "extrapolates from one operating point.",
        (
            Parameter(
                "alpha_u", 1.0, 0.3, 2.5, "1", "exponent of heat vs input, Q ∝ u^α", _E, "effect"
            ),
        ),
    ),
    "input_dependent_heat_transfer": PhysicalEffect(
        "input_dependent_heat_transfer",
        "The heat transfer to the air grows with the input: at higher speed or feed rate the "
        "moving parts stir the air (forced convection), so the heat source grows faster than "
        "the temperature rise and the steady temperatures barely increase at higher inputs.",
        (
            Parameter(
                "beta_u",
                0.0,
                -0.5,
                5.0,
                "1",
                "relative growth of air conductance at u_ref",
                _E,
                "effect",
            ),
        ),
    ),
    "nonlinear_heat_transfer": PhysicalEffect(
        "nonlinear_heat_transfer",
        "Natural convection and radiation to the air are not linear in the temperature "
        "difference: the conductance grows with ΔT^(1/3), so a hot body loses heat "
        "relatively faster than a warm one and the response depends on its amplitude.",
        (
            Parameter(
                "gamma_nl",
                0.0,
                0.0,
                5.0,
                "1",
                "weight of the ΔT^(1/3) convection term",
                _E,
                "effect",
            ),
        ),
    ),
    "time_varying_parameter": PhysicalEffect(
        "time_varying_parameter",
        "A loss coefficient drifts during operation (bearing preload rises as the parts "
        "warm, lubricant ages or is redistributed), so the same input produces more heat "
        "later in a run than early in it.",
        (
            Parameter(
                "q_drift",
                0.0,
                -0.2,
                0.5,
                "1/h",
                "relative change of the heat sources per hour",
                _E,
                "effect",
            ),
        ),
    ),
}
_NE = 4  # number of effect parameters, kernel order: alpha, beta, gamma, drift
#: Largest node-to-air temperature difference [K] the RK4 sub-step rule bounds the loss
#: nonlinearity's stiffness for (:meth:`ThermalNetworkModel.rk4_substeps`).
DT_SPAN = 60.0


@dataclass(frozen=True)
class NetworkArrays:
    """Batched physical arrays of a thermal network.

    Attributes
    ----------
    C : ndarray, shape (B, n)
        Heat capacities [J/K].
    G : ndarray, shape (B, n, n)
        Symmetric node-to-node conductances [W/K], zero diagonal.
    g_amb : ndarray, shape (B, n)
        Conductances to the air [W/K].
    q : ndarray, shape (B, n, n_u)
        Heat per input unit [W per unit of each input].
    H : ndarray, shape (n_y, n)
        Output matrix, ``y = H T + h0``.
    h0 : ndarray, shape (B, n_y)
        Output offsets.
    """

    C: NDArray[np.float64]
    G: NDArray[np.float64]
    g_amb: NDArray[np.float64]
    q: NDArray[np.float64]
    H: NDArray[np.float64]
    h0: NDArray[np.float64]


def network_matrices(
    net: NetworkArrays,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Continuous-time matrices of the linear network.

    Returns
    -------
    A : ndarray, shape (B, n, n)
        ``C⁻¹ (G − diag(Σ_j G_ij + g_i))``.
    Bm : ndarray, shape (B, n, n_u + 1)
        ``C⁻¹ [q, g]``; the last column multiplies the air temperature.
    """
    n = net.G.shape[1]
    idx = np.arange(n)
    lap = net.G.copy()
    lap[:, idx, idx] -= net.G.sum(axis=2) + net.g_amb
    A = lap / net.C[:, :, None]
    Bm = np.concatenate([net.q, net.g_amb[:, :, None]], axis=2) / net.C[:, :, None]
    return A, Bm


def _discretise(
    A: NDArray[np.float64], Bm: NDArray[np.float64], dt: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    # Exact ZOH: expm([[A, B], [0, 0]] dt) = [[Ad, Bd], [0, I]] (batched over the first axis).
    B, n, m = Bm.shape
    M = np.zeros((B, n + m, n + m))
    M[:, :n, :n] = A * dt
    M[:, :n, n:] = Bm * dt
    # Small matrices: multithreaded BLAS only adds overhead (10x slower measured on 20x20
    # batches), so the matrix exponential runs on one thread (the limiter reuses one
    # threadpoolctl controller: an identification or diagnosis discretises thousands of times).
    with blas_threads(1):
        E = expm(M)
    return np.ascontiguousarray(E[:, :n, :n]), np.ascontiguousarray(E[:, :n, n:])


@nb.njit(cache=True)
def _lti_kernel(At, Bt, Ht, h0, x0, U, y, xs, keep):  # pragma: no cover - numba
    # transposed matrices (thermogym.models.lti); y = H x + h0 has no feedthrough
    Bn, T = U.shape[0], U.shape[1]
    n = At.shape[1]
    x = np.empty(n)
    xn = np.empty(n)
    no_u = np.empty(0)
    no_D = np.empty((0, Ht.shape[1]))
    for b in range(Bn):
        x[:] = x0[b]
        for k in range(T):
            lti_output(Ht, no_D, h0[b], x, no_u, y[b, k])
            if keep:
                xs[b, k, :] = x
            lti_update(At[b], Bt[b], x, U[b, k], xn)
            x[:] = xn


def lti_simulate(
    Ad: NDArray[np.float64],
    Bd: NDArray[np.float64],
    H: NDArray[np.float64],
    h0: NDArray[np.float64],
    x0: NDArray[np.float64],
    U: NDArray[np.float64],
    return_states: bool = False,
) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
    """Simulate a batch of discrete LTI systems ``x⁺ = Ad x + Bd u``, ``y = H x + h0``.

    Parameters
    ----------
    Ad : ndarray, shape (B, n, n)
    Bd : ndarray, shape (B, n, m)
    H : ndarray, shape (n_y, n)
    h0 : ndarray, shape (B, n_y)
    x0 : ndarray, shape (B, n)
    U : ndarray, shape (B, T, m)
    return_states : bool

    Returns
    -------
    y : ndarray, shape (B, T, n_y)
    xs : ndarray, shape (B, T, n) or None
    """
    B, T = U.shape[0], U.shape[1]
    y = np.empty((B, T, H.shape[0]))
    xs = np.empty((B, T, Ad.shape[1])) if return_states else np.empty((1, 1, Ad.shape[1]))
    _lti_kernel(
        transposed(Ad),
        transposed(Bd),
        transposed(H),
        np.ascontiguousarray(h0),
        np.ascontiguousarray(x0),
        np.ascontiguousarray(U),
        y,
        xs,
        return_states,
    )
    return y, (xs if return_states else None)


@nb.njit(cache=True)
def _rhs(T, t, u, Tamb, Qx, C, G, gamb, q, eff, u_ref, dT_ref, mask, out):
    n, nu = q.shape[0], q.shape[1]
    alpha, beta, gamma, drift = eff[0], eff[1], eff[2], eff[3]
    growth = 1.0 + drift * t / 3600.0
    forced = 1.0 + beta * abs(u[0]) / u_ref
    for i in range(n):
        s = Qx[i]
        for j in range(n):
            if G[i, j] != 0.0:
                s += G[i, j] * (T[j] - T[i])
        g = gamb[i]
        if mask[i]:
            g *= forced
        d = Tamb - T[i]
        if gamma != 0.0:
            g *= (1.0 + gamma * (abs(d) / dT_ref) ** (1.0 / 3.0)) / (1.0 + gamma)
        s += g * d
        for k in range(nu):
            uk = abs(u[k])
            if alpha != 1.0 and uk > 0.0:
                uk = u_ref * (uk / u_ref) ** alpha
            s += q[i, k] * uk * growth
        out[i] = s / C[i]


@nb.njit(cache=True)
def _rk4_kernel(
    C, G, gamb, q, eff, u_ref, dT_ref, mask, H, h0, x0, U, Qx, t0, dt, nsub, y, xs, keep
):
    Bn, T = U.shape[0], U.shape[1]
    n, nu, ny = C.shape[1], q.shape[2], H.shape[0]
    h = dt / nsub
    x = np.empty(n)
    k1 = np.empty(n)
    k2 = np.empty(n)
    k3 = np.empty(n)
    k4 = np.empty(n)
    tmp = np.empty(n)
    has_q = Qx.shape[1] > 1
    qk = np.zeros(n)
    for b in range(Bn):
        x[:] = x0[b]
        bq = b if Qx.shape[0] > 1 else 0
        for k in range(T):
            for i in range(ny):
                s = h0[b, i]
                for j in range(n):
                    s += H[i, j] * x[j]
                y[b, k, i] = s
            if keep:
                xs[b, k, :] = x
            if k + 1 == T:
                break
            u = U[b, k, :nu]
            Ta = U[b, k, nu]
            if has_q:
                qk[:] = Qx[bq, k]
            for s_ in range(nsub):
                t = t0 + k * dt + s_ * h
                _rhs(x, t, u, Ta, qk, C[b], G[b], gamb[b], q[b], eff[b], u_ref, dT_ref, mask, k1)
                for i in range(n):
                    tmp[i] = x[i] + 0.5 * h * k1[i]
                _rhs(
                    tmp,
                    t + 0.5 * h,
                    u,
                    Ta,
                    qk,
                    C[b],
                    G[b],
                    gamb[b],
                    q[b],
                    eff[b],
                    u_ref,
                    dT_ref,
                    mask,
                    k2,
                )
                for i in range(n):
                    tmp[i] = x[i] + 0.5 * h * k2[i]
                _rhs(
                    tmp,
                    t + 0.5 * h,
                    u,
                    Ta,
                    qk,
                    C[b],
                    G[b],
                    gamb[b],
                    q[b],
                    eff[b],
                    u_ref,
                    dT_ref,
                    mask,
                    k3,
                )
                for i in range(n):
                    tmp[i] = x[i] + h * k3[i]
                _rhs(
                    tmp,
                    t + h,
                    u,
                    Ta,
                    qk,
                    C[b],
                    G[b],
                    gamb[b],
                    q[b],
                    eff[b],
                    u_ref,
                    dT_ref,
                    mask,
                    k4,
                )
                for i in range(n):
                    x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])


class ThermalNetworkModel(Model):
    """Base class of the lumped RC-network plants (spindle, strut).

    Subclasses provide the node list, the parameters, :meth:`network` (physical
    arrays for a batch of full parameter vectors), the reference input
    ``u_ref`` used to normalise the effects, and the nodes whose air
    conductance grows with the input (forced convection).

    Parameters
    ----------
    effects : sequence of str
        Effects from :data:`NETWORK_EFFECTS` to include.
    """

    #: Node names (capacitive nodes; the air is the boundary).
    nodes: tuple[str, ...] = ()
    #: Input value at which effects are normalised (e.g. 6000 rpm).
    u_ref: float = 1.0
    #: Temperature difference normalising nonlinear heat transfer [K].
    dT_ref: float = 10.0
    physical_effects = NETWORK_EFFECTS

    def __init__(
        self,
        signals: tuple[Signal, ...],
        base_parameters: tuple[Parameter, ...],
        effects: tuple[str, ...] | list[str] = (),
    ) -> None:
        self._layout = EffectLayout(base_parameters, NETWORK_EFFECTS, effects, self.name)
        self._n_base = len(base_parameters)
        super().__init__(signals, self._layout.public, self.nodes)
        #: 1 for the nodes of :meth:`forced_nodes` (input-dependent heat transfer), per node.
        self.forced_mask = np.array([n in self.forced_nodes() for n in self.nodes])
        self._disc_cache: dict[Any, Any] = {}

    @property
    def effects(self) -> tuple[str, ...]:
        """Effects this instance includes."""
        return self._layout.selected

    def config(self) -> dict[str, Any]:
        """Constructor arguments (stored in FitResults)."""
        return {"effects": list(self._layout.selected)} if self._layout.selected else {}

    def forced_nodes(self) -> tuple[str, ...]:
        """Nodes whose air conductance grows with the input (input-dependent heat transfer)."""
        return ()

    def network(self, theta_full: NDArray[np.float64]) -> NetworkArrays:
        """Physical arrays for a batch of *full* parameter vectors (base + effects)."""
        raise NotImplementedError

    def arrays(self, theta: NDArray[np.float64]) -> NetworkArrays:
        """Physical arrays for a public parameter batch."""
        return self.network(self._layout.full_theta(self.theta(theta)))

    def full_theta(self, theta: NDArray[np.float64]) -> NDArray[np.float64]:
        """Kernel parameter vectors (B, P_full): base, then every effect (absent ones neutral)."""
        return self._layout.full_theta(theta)

    def effect_values(self, full: NDArray[np.float64]) -> NDArray[np.float64]:
        """Effect values (alpha, beta, gamma, drift) per set of full vectors, shape (B, 4)."""
        return np.ascontiguousarray(full[:, self._n_base : self._n_base + _NE])

    def is_linear(self, full: NDArray[np.float64]) -> bool:
        """Whether every set of full vectors ``full`` has its effects switched off."""
        e = self.effect_values(full)
        return bool(np.all(e[:, 0] == 1.0) and np.all(e[:, 1:] == 0.0))

    def integrate(
        self,
        net: NetworkArrays,
        eff: NDArray[np.float64],
        x0: NDArray[np.float64],
        u: NDArray[np.float64],
        dt: float,
        nsub: int,
        *,
        q_ext: NDArray[np.float64] | None = None,
        t0: float = 0.0,
        return_states: bool = False,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
        """RK4 integration of the (nonlinear) network ``net`` with effect values ``eff``.

        Parameters
        ----------
        net : NetworkArrays
            Physical arrays of B sets (:meth:`network`).
        eff : ndarray, shape (B, 4)
            :meth:`effect_values`.
        x0 : ndarray, shape (B, n)
        u : ndarray, shape (B, T, n_u + 1)
        dt : float
            Sample period [s].
        nsub : int
            RK4 sub-steps per sample.
        q_ext : ndarray, shape (B or 1, T, n), optional
            Extra heat into each node [W].
        t0 : float
            Time of the first sample [s].
        return_states : bool

        Returns
        -------
        y : ndarray, shape (B, T, n_y)
        xs : ndarray, shape (B, T, n), or None
        """
        B, T = u.shape[0], u.shape[1]
        y = np.empty((B, T, net.H.shape[0]))
        xs = np.empty((B, T, len(self.nodes))) if return_states else np.empty((1, 1, 1))
        qx = np.zeros((1, 1, 1)) if q_ext is None else np.ascontiguousarray(q_ext, dtype=float)
        _rk4_kernel(
            np.ascontiguousarray(net.C),
            np.ascontiguousarray(net.G),
            np.ascontiguousarray(net.g_amb),
            np.ascontiguousarray(net.q),
            np.ascontiguousarray(eff, dtype=float),
            float(self.u_ref),
            float(self.dT_ref),
            self.forced_mask,
            np.ascontiguousarray(net.H),
            np.ascontiguousarray(net.h0),
            np.ascontiguousarray(x0),
            np.ascontiguousarray(u),
            qx,
            float(t0),
            float(dt),
            int(nsub),
            y,
            xs,
            return_states,
        )
        return y, (xs if return_states else None)

    def steady_state(
        self, theta: NDArray[np.float64], u: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """Steady node temperatures of the linear network for constant exogenous ``u``.

        Parameters
        ----------
        theta : ndarray, shape (B, P)
        u : ndarray, shape (B, n_u + 1)
            Inputs then the air temperature.

        Returns
        -------
        ndarray, shape (B, n)
        """
        net = self.network(self._layout.full_theta(theta))
        A, Bm = network_matrices(net)
        return -np.linalg.solve(A, np.einsum("bij,bj->bi", Bm, u)[:, :, None])[:, :, 0]

    def initial_state(self, theta, u0):  # noqa: D102
        # Rest: every node at the air temperature (the last exogenous column).
        return np.repeat(u0[:, -1:], len(self.nodes), axis=1).astype(float)

    def rk4_substeps(
        self,
        net: NetworkArrays,
        dt: float,
        u_max: float = 0.0,
        eff: NDArray[np.float64] | None = None,
    ) -> int:
        """Fixed RK4 sub-steps per sample from the fastest eigenvalue (stability + accuracy).

        The step keeps ``h ρ ≤ 1`` (RK4 is stable up to ``h|λ|`` = 2.78 on the negative
        real axis), with ``ρ`` the spectral radius of the linear network times the largest
        factor by which the effects can raise the local stiffness:

        * forced convection multiplies the moving nodes' air conductance by
          ``1 + β |u|/u_ref``;
        * the loss ``g Δ (1 + γ (|Δ|/ΔT_ref)^(1/3)) / (1 + γ)`` has the slope
          ``g (1 + 4/3 γ (|Δ|/ΔT_ref)^(1/3)) / (1 + γ)``, bounded here for
          ``|Δ| ≤`` :data:`DT_SPAN` (at most ``4/3 (ΔT_span/ΔT_ref)^(1/3)`` ≈ 2.4 for
          any γ; beyond that span the factor grows only as the cube root).

        Parameters
        ----------
        net : NetworkArrays
        dt : float
            Sample period [s].
        u_max : float
            Largest input magnitude of the run.
        eff : ndarray, shape (B, 4), optional
            :meth:`effect_values`; without it the bound takes β at its upper bound (5)
            and no loss nonlinearity (the rule the vector environments step with).

        Returns
        -------
        int
        """
        A, _ = network_matrices(net)
        rho = max(float(np.max(np.abs(np.linalg.eigvals(a)))) for a in A)
        if eff is None:
            beta, loss = 5.0, 1.0
        else:
            e = np.atleast_2d(np.asarray(eff, dtype=float))
            beta = max(0.0, float(np.max(e[:, 1])))
            gam = np.maximum(e[:, 2], 0.0)
            s = (DT_SPAN / self.dT_ref) ** (1.0 / 3.0)
            loss = max(1.0, float(np.max((1.0 + 4.0 / 3.0 * gam * s) / (1.0 + gam))))
        scale = (1.0 + beta * max(0.0, u_max) / self.u_ref) * loss
        return max(1, math.ceil(dt * rho * scale))

    def simulate_network(
        self,
        theta: NDArray[np.float64],
        u: NDArray[np.float64],
        dt: float,
        x0: NDArray[np.float64],
        *,
        q_ext: NDArray[np.float64] | None = None,
        force_rk4: bool = False,
        t0: float = 0.0,
        return_states: bool = False,
        substeps: int | None = None,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
        """Simulate validated arrays, exactly when linear and by RK4 otherwise.

        Parameters
        ----------
        theta : ndarray, shape (B, P)
        u : ndarray, shape (B, T, n_u + 1)
        dt : float
        x0 : ndarray, shape (B, n)
        q_ext : ndarray, shape (B or 1, T, n), optional
            Extra heat into each node [W] (unmeasured disturbance).
        force_rk4 : bool
            Integrate by RK4 even when the network is linear (used by tests).
        t0 : float
            Time of the first sample [s] (for time-varying effects).
        return_states : bool
        substeps : int, optional
            RK4 sub-steps per sample; default :meth:`rk4_substeps` (a caller with a
            tighter bound for its effects passes its own).

        Returns
        -------
        y : ndarray, shape (B, T, n_y)
        xs : ndarray or None
        """
        full = self._layout.full_theta(theta)
        if self.is_linear(full) and q_ext is None and not force_rk4:
            Ad, Bd, net = self.discrete(theta, dt)  # the network is built on a cache miss only
            return lti_simulate(Ad, Bd, net.H, net.h0, x0, u, return_states)
        net = self.network(full)
        if substeps is None:
            u_max = float(np.max(np.abs(u[:, :, 0])))
            nsub = self.rk4_substeps(net, dt, u_max, self.effect_values(full))
        elif isinstance(substeps, int | np.integer) and substeps >= 1:
            nsub = int(substeps)
        else:
            raise ConfigError(f"substeps is {substeps!r}; expected an integer of at least 1")
        check_step_budget(self.name, nsub, u.shape[1], dt)
        return self.integrate(
            net, self.effect_values(full), x0, u, dt, nsub, q_ext=q_ext, t0=t0,
            return_states=return_states,
        )  # fmt: skip

    def _simulate(self, theta, u, dt, x0, return_states):
        return self.simulate_network(theta, u, dt, x0, return_states=return_states)

    def discrete(
        self, theta: NDArray[np.float64], dt: float
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NetworkArrays]:
        """Exact ZOH matrices ``(Ad, Bd)`` of the linear network, cached per (theta, dt)."""
        key = (theta.tobytes(), theta.shape, float(dt))
        hit = self._disc_cache.get(key)
        if hit is None:
            net = self.network(self._layout.full_theta(theta))
            A, Bm = network_matrices(net)
            hit = (*_discretise(A, Bm, dt), net)
            if len(self._disc_cache) > 16:
                self._disc_cache.clear()
            self._disc_cache[key] = hit
        return hit

    def _step(self, x, u, theta, dt):
        full = self._layout.full_theta(theta)
        if self.is_linear(full):
            Ad, Bd, _ = self.discrete(theta, dt)
            return np.einsum("bij,bj->bi", Ad, x) + np.einsum("bij,bj->bi", Bd, u)
        _, xs = self.simulate_network(
            theta, np.repeat(u[:, None, :], 2, axis=1), dt, x, return_states=True
        )
        return xs[:, 1, :].copy()  # type: ignore[index]

    def _output(self, x, u, theta):
        net = self.network(self._layout.full_theta(theta))
        return np.einsum("ij,bj->bi", net.H, x) + net.h0


# the kernels above inline compiled functions of other modules (derived cache dependencies)
module_kernels_depend_on(globals())
