"""Exact, fast simulation of RC networks with input-dependent effects (diagnosis only).

Three effects of :data:`thermogym.models.thermal_network.NETWORK_EFFECTS`
keep a thermal network *linear in its state* for a given input value:

* ``input_nonlinearity``: the heat source ``q u`` becomes ``q u_ref (u/u_ref)^α``
  — a transformed input;
* ``time_varying_parameter``: ``q u (1 + δ t/1 h)`` — a transformed input
  (taken at the middle of each sample interval);
* ``input_dependent_heat_transfer``: the air conductance of the moving parts
  ``g (1 + β |u|/u_ref)`` — the state matrix depends on the input value only.

With the inputs held over each sample (zero-order hold), the network is then a
*switched* linear system: one exact discretisation ``(A_d(v), B_d(v))`` per
distinct input value ``v``, and the simulation is a matrix-vector recursion.
Speeds and feed rates are stepped (a handful of distinct values per
recording), so this is as fast as the nominal model and exact, where the
plant's own implementation integrates these effects by fixed-step RK4 with
many sub-steps. :class:`SwitchedNetwork` is used to *fit* candidate
hypotheses; the FitResult diagnosis writes is the plant with the effect
switched on (same parameters, same equations).
"""

from __future__ import annotations

from typing import Any

import numba as nb
import numpy as np
from numpy.typing import NDArray

from thermogym._jitcache import module_kernels_depend_on
from thermogym.errors import ConfigError
from thermogym.models.base import Model, Parameter
from thermogym.models.lti import lti_output, lti_update, transposed
from thermogym.models.thermal_network import (
    NetworkArrays,
    ThermalNetworkModel,
    _discretise,
    lti_simulate,
    network_matrices,
)

__all__ = ["FAST_EFFECTS", "SwitchedNetwork", "fast_or_none", "switched_or_none"]

#: Effects :class:`SwitchedNetwork` simulates exactly.
FAST_EFFECTS = ("input_nonlinearity", "input_dependent_heat_transfer", "time_varying_parameter")
_MAX_LEVELS = 64


def _zoh(
    A: NDArray[np.float64], Bm: NDArray[np.float64], dt: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Exact ZOH discretisation of a batch of ``(A, B)`` pairs (``thermal_network._discretise``)."""
    return _discretise(A, Bm, dt)


@nb.njit(cache=True)
def _switched_kernel(At, Bt, Ht, h0, x0, U, seg, y):  # pragma: no cover - numba
    # transposed matrices per level (thermogym.models.lti); y = H x + h0
    B, T = y.shape[0], y.shape[1]
    n = At.shape[2]
    x = np.empty(n)
    xn = np.empty(n)
    no_u = np.empty(0)
    no_D = np.empty((0, Ht.shape[1]))
    for b in range(B):
        x[:] = x0[b]
        ub = U[b if U.shape[0] > 1 else 0]
        for k in range(T):
            lti_output(Ht, no_D, h0[b], x, no_u, y[b, k])
            if k + 1 == T:
                break
            lv = seg[b if seg.shape[0] > 1 else 0, k]
            lti_update(At[b, lv], Bt[b, lv], x, ub[k], xn)
            x[:] = xn


class SwitchedNetwork(Model):
    """A thermal-network plant with fast-path effects, simulated as a switched LTI system.

    Parameters
    ----------
    plant : ThermalNetworkModel
        The plant built with ``effects`` drawn from :data:`FAST_EFFECTS`.

    Raises
    ------
    ConfigError
        The plant is not a network or carries an effect that is not linear in
        the state (``nonlinear_heat_transfer``).
    """

    def __init__(self, plant: ThermalNetworkModel) -> None:
        if not isinstance(plant, ThermalNetworkModel):
            raise ConfigError(f"{plant.name!r} is not a thermal network")
        bad = [e for e in plant.effects if e not in FAST_EFFECTS]
        if bad:
            raise ConfigError(f"effects {bad} are not linear in the state; use the plant itself")
        self.plant = plant
        self.name = plant.name
        self.version = plant.version
        self.max_step = plant.max_step
        super().__init__(plant.signals, plant.parameters, plant.state_names)

    def config(self) -> dict[str, Any]:
        """The plant's constructor arguments."""
        return self.plant.config()

    def initial_state(self, theta, u0):  # noqa: D102
        return self.plant.initial_state(theta, u0)

    def _validate_theta(self, theta):
        self.plant._validate_theta(theta)

    def _output(self, x, u, theta):
        return self.plant._output(x, u, theta)

    def _step(self, x, u, theta, dt):
        return self.plant._step(x, u, theta, dt)

    def _simulate(self, theta, u, dt, x0, return_states):
        p = self.plant
        full = p.full_theta(theta)
        eff = p.effect_values(full)  # alpha, beta, gamma, drift per set
        B, T = theta.shape[0], u.shape[1]
        nu = len(p.inputs)
        ub = np.array(np.broadcast_to(u, (B, *u.shape[1:])), dtype=float, copy=True)
        t_mid = dt * (np.arange(T) + 0.5)
        for b in range(B):
            a, d = eff[b, 0], eff[b, 3]
            for k in range(nu):
                v = np.abs(ub[b, :, k])
                if a != 1.0:
                    # q u → q u_ref (u/u_ref)^α (the network kernel's input nonlinearity)
                    v = np.where(v > 0, p.u_ref * (v / p.u_ref) ** a, 0.0)
                if d != 0.0:
                    v = v * (1.0 + d * t_mid / 3600.0)  # q (1 + δ t/1 h), mid-interval
                ub[b, :, k] = v
        net = p.network(full)
        mask = p.forced_mask.astype(float)
        # the conductance factor depends on |u_1| only: one discretisation per distinct level
        levels = np.unique(np.round(np.abs(np.asarray(u)[..., 0]), 9))
        if levels.size > _MAX_LEVELS:
            return p._simulate(theta, u, dt, x0, return_states)
        seg = np.searchsorted(levels, np.round(np.abs(np.asarray(u)[:, :, 0]), 9))
        n, m = net.C.shape[1], net.q.shape[2] + 1
        # every level of every parameter set in one batched matrix exponential
        L = levels.size
        forced = 1.0 + eff[:, None, 1:2] * levels[None, :, None] / p.u_ref * mask[None, None, :]
        g = (net.g_amb[:, None, :] * forced).reshape(B * L, n)

        def rep(a):
            return np.repeat(a, L, axis=0)

        A, Bm = network_matrices(
            NetworkArrays(rep(net.C), rep(net.G), g, rep(net.q), net.H, net.h0)
        )
        Ad, Bd = _zoh(A, Bm, dt)
        Ad, Bd = Ad.reshape(B, L, n, n), Bd.reshape(B, L, n, m)
        y = np.empty((B, T, net.H.shape[0]))
        _switched_kernel(
            transposed(Ad),
            transposed(Bd),
            transposed(net.H),
            np.ascontiguousarray(net.h0),
            np.ascontiguousarray(x0),
            np.ascontiguousarray(ub),
            np.ascontiguousarray(seg.astype(np.int64)),
            y,
        )
        if return_states:
            return p._simulate(theta, u, dt, x0, True)
        return y, None


def switched_or_none(model: Model) -> Model | None:
    """A :class:`SwitchedNetwork` for a network plant whose effects allow it, else None."""
    if isinstance(model, ThermalNetworkModel) and all(e in FAST_EFFECTS for e in model.effects):
        return SwitchedNetwork(model)
    return None


def fast_or_none(model: Model) -> Model | None:
    """The fastest faithful simulator of a network plant for fitting, else None.

    :class:`SwitchedNetwork` (exact) for the effects linear in the state; a plant
    with ``nonlinear_heat_transfer`` is fitted on its own RK4 kernel, whose sub-step
    rule bounds the loss nonlinearity's stiffness by γ
    (:meth:`~thermogym.models.thermal_network.ThermalNetworkModel.rk4_substeps`).
    """
    return switched_or_none(model)


class ExtraNodeNetwork(Model):
    """An RC-network plant with one heat capacity attached to a node: a missing state.

    The ``missing_dynamics`` hypothesis of a thermal network (IEA EBC Annex 58:
    autocorrelated residuals call for more states): a mass the model does not
    include — a machine-frame bracket, a headstock casting, a thick wall —
    attached to ``node`` through a contact conductance and losing heat to the
    air. Its three parameters (capacity, contact and air conductance) follow
    the plant's own; the node balance is eq (13) of paper 000::

        C_x dT_x/dt = G_x (T_node − T_x) + g_x (T_air − T_x)

    Simulated by exact zero-order-hold discretisation (the plant must be
    linear: no effects switched on).

    Parameters
    ----------
    plant : ThermalNetworkModel
    node : str
        Node the mass is attached to.
    bounds : mapping, optional
        ``{"C": [lo, hi], "G": [...], "g": [...]}``.
    """

    def __init__(self, plant: Model, node: str, bounds: Any = None) -> None:
        if not isinstance(plant, ThermalNetworkModel):
            raise ConfigError(f"an extra node needs a thermal network, not {plant.name!r}")
        if plant.effects:
            raise ConfigError(
                f"an extra node is added to the linear network only; {plant.name!r} carries "
                f"{list(plant.effects)}"
            )
        if node not in plant.nodes:
            raise ConfigError(
                f"missing_dynamics names node {node!r}; the {plant.name!r} nodes are "
                f"{list(plant.nodes)}"
            )
        self.plant, self.node = plant, node
        self._j = plant.nodes.index(node)
        self.name, self.version, self.max_step = plant.name, plant.version, plant.max_step
        b = dict(bounds or {})
        prov = "fitted by thermogym diagnosis; G_x = 0 switches the extra mass off"

        def prm(name: str, v: float, lo: float, hi: float, unit: str, what: str) -> Parameter:
            lo, hi = (float(x) for x in b.get(name.split("_")[0], (lo, hi)))
            return Parameter(
                f"{name}_{node}", min(max(v, lo), hi), lo, hi, unit, what, prov, "augmentation"
            )

        extra = (
            prm("Cx", 10000.0, 10.0, 1e7, "J/K", f"heat capacity of a mass attached to {node}"),
            prm("Gx", 0.0, 0.0, 1000.0, "W/K", f"contact conductance of that mass to {node}"),
            prm("gx", 0.0, 0.0, 100.0, "W/K", "conductance of that mass to the air"),
        )
        self._nb = len(plant.parameters)
        super().__init__(
            plant.signals, (*plant.parameters, *extra), (*plant.state_names, f"mass_at_{node}")
        )

    def config(self) -> dict[str, Any]:
        """The plant's constructor arguments."""
        return self.plant.config()

    def _validate_theta(self, theta):
        self.plant._validate_theta(np.ascontiguousarray(theta[:, : self._nb]))
        self._require_positive(theta, [f"Cx_{self.node}"])

    def initial_state(self, theta, u0):
        x = self.plant.initial_state(np.ascontiguousarray(theta[:, : self._nb]), u0)
        return np.column_stack([x, np.atleast_2d(u0)[:, -1]])

    def arrays(self, theta) -> NetworkArrays:
        """The plant's arrays with the extra node appended."""
        net = self.plant.arrays(np.ascontiguousarray(theta[:, : self._nb]))
        B, n = net.C.shape
        C = np.concatenate([net.C, theta[:, self._nb : self._nb + 1]], axis=1)
        G = np.zeros((B, n + 1, n + 1))
        G[:, :n, :n] = net.G
        G[:, self._j, n] = G[:, n, self._j] = theta[:, self._nb + 1]
        g = np.concatenate([net.g_amb, theta[:, self._nb + 2 : self._nb + 3]], axis=1)
        q = np.concatenate([net.q, np.zeros((B, 1, net.q.shape[2]))], axis=1)
        H = np.concatenate([net.H, np.zeros((net.H.shape[0], 1))], axis=1)
        return NetworkArrays(C, G, g, q, H, net.h0)

    def _discrete(self, theta, dt):
        net = self.arrays(theta)
        A, Bm = network_matrices(net)
        Ad, Bd = _zoh(A, Bm, dt)
        return Ad, Bd, net

    def _simulate(self, theta, u, dt, x0, return_states):
        Ad, Bd, net = self._discrete(theta, dt)
        B = theta.shape[0]
        U = np.ascontiguousarray(np.broadcast_to(u, (B, *u.shape[1:])))
        return lti_simulate(Ad, Bd, net.H, net.h0, x0, U, return_states)

    def _step(self, x, u, theta, dt):
        Ad, Bd, _ = self._discrete(theta, dt)
        return np.einsum("bij,bj->bi", Ad, x) + np.einsum("bij,bj->bi", Bd, u)

    def _output(self, x, u, theta):
        net = self.arrays(theta)
        return np.einsum("ij,bj->bi", net.H, x) + net.h0


# the kernels above inline compiled functions of other modules (derived cache dependencies)
module_kernels_depend_on(globals())
