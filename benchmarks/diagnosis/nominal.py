"""Nominal models as a user would bring them: first-principles, one node, no hidden physics.

Each is a :class:`thermogym.models.base.Model` subclass with parameter specs
(nominal value from the design, bounds, units, provenance), written the way
an engineer writes a first model of the plant: the energy balance with
linear heat transfer and the inputs taken at face value. They lack exactly
the hidden effects of the cases (and nothing else): a case's true plant with
its effects switched off has this structure, with constants 10-30 % off the
nominal values.

Linear pieces are discretised exactly for inputs held over a sample
(zero-order hold), so the models run at any sample period.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import expm
from scipy.signal import lfilter

from thermogym.models.base import Model, Parameter, Signal

from .plants import BuildingPlant, Family, PlatePlant, TankPlant

__all__ = ["NOMINAL_MODELS", "BuildingModel", "PlateModel", "TankModel", "nominal_model"]

Array = NDArray[np.float64]


def _specs(family: Family) -> list[Parameter]:
    return [
        Parameter(
            k,
            d.value,
            d.lower,
            d.upper,
            d.unit,
            d.description,
            "design estimate (handbook values and data sheets)",
        )
        for k, d in family.design.items()
    ]


def _signals(family: Family) -> list[Signal]:
    sig = [Signal(k, role, unit, desc) for k, (role, unit, desc) in family.exogenous.items()]  # type: ignore[arg-type]
    sig += [Signal(k, "output", unit, desc) for k, (unit, desc) in family.outputs.items()]
    return sig


class PlateModel(Model):
    """Lamp-heated plate, one node: ``C dT/dt = P_max u/100 − G (T − T_amb)``.

    Examples
    --------
    >>> m = PlateModel()
    >>> sim = m.simulate(np.column_stack([np.full(2000, 50.0), np.full(2000, 20.0)]), 5.0)
    >>> round(float(sim.outputs[0, -1, 0]), 2)  # steady: 20 + 32 × 0.5 / 0.5
    52.0
    """

    name = "user_plate"
    version = "1"

    def __init__(self) -> None:
        super().__init__(_signals(PlatePlant), _specs(PlatePlant), ["T_plate"])

    def _validate_theta(self, theta: Array) -> None:
        self._require_positive(theta, self.param_names)

    def initial_state(self, theta: Array, u0: Array) -> Array:
        """Steady state at the first input sample."""
        _C, G, P = theta.T
        return (u0[:, 1] + P * u0[:, 0] / 100.0 / G)[:, None]

    def _simulate(self, theta, u, dt, x0, return_states):
        B, T = theta.shape[0], u.shape[1]
        y = np.empty((B, T, 1))
        for b in range(B):
            C, G, P = theta[b]
            a = np.exp(-G * dt / C)
            w = u[b, :, 1] + P * u[b, :, 0] / 100.0 / G  # the held input's steady temperature
            # T[k+1] = a T[k] + (1 - a) w[k], T[0] = x0: one IIR filter
            y[b, :, 0] = lfilter([0.0, 1.0 - a], [1.0, -a], w, zi=[x0[b, 0]])[0]
        return y, (y.copy() if return_states else None)

    def _step(self, x, u, theta, dt):
        C, G, P = (theta[:, i] for i in range(3))
        a = np.exp(-G * dt / C)
        w = u[:, 1] + P * u[:, 0] / 100.0 / G
        return (a * x[:, 0] + (1.0 - a) * w)[:, None]

    def _output(self, x, u, theta):
        return np.array(x[:, :1], dtype=float)


class TankModel(Model):
    """Stirred tank, one node: ``C dT/dt = P_max h − K_coil v (T − T_cw) − G (T − T_amb)``.

    Examples
    --------
    >>> m = TankModel()
    >>> u = np.tile([0.5, 0.5, 14.0, 20.0], (3000, 1))
    >>> T = m.simulate(u, 30.0).outputs[0, -1, 0]
    >>> bool(abs(T - (1000 + 21 * 14 + 2.5 * 20) / 23.5) < 1e-6)
    True
    """

    name = "user_tank"
    version = "1"

    def __init__(self) -> None:
        super().__init__(_signals(TankPlant), _specs(TankPlant), ["T_tank"])

    def _validate_theta(self, theta: Array) -> None:
        self._require_positive(theta, self.param_names)

    @staticmethod
    def _target(theta: Array, u: Array) -> tuple[Array, Array]:
        C, P, K, G = (theta[:, i, None] for i in range(4))
        h, v, Tc, Ta = (u[:, :, i] for i in range(4))
        g = G + K * np.clip(v, 0.0, None)
        return (P * h + K * np.clip(v, 0.0, None) * Tc + G * Ta) / g, g / C

    def initial_state(self, theta: Array, u0: Array) -> Array:
        """Steady state at the first input sample."""
        target, _ = self._target(theta, u0[:, None, :])
        return target[:, :1]

    def _simulate(self, theta, u, dt, x0, return_states):
        target, rate = self._target(theta, np.broadcast_to(u, (theta.shape[0], *u.shape[1:])))
        a = np.exp(-rate * dt)
        B, T = target.shape
        y = np.empty((B, T, 1))
        x = x0[:, 0].copy()
        # exact step for inputs held over the interval; the rate changes with the valve
        for k in range(T):
            y[:, k, 0] = x
            x = target[:, k] + (x - target[:, k]) * a[:, k]
        return y, (y.copy() if return_states else None)

    def _step(self, x, u, theta, dt):
        target, rate = self._target(theta, u[:, None, :])
        return target + (x - target) * np.exp(-rate * dt)

    def _output(self, x, u, theta):
        return np.array(x[:, :1], dtype=float)


class BuildingModel(Model):
    """Two-zone house, two nodes, heat pump with a Carnot-fraction COP.

    Examples
    --------
    >>> m = BuildingModel()
    >>> u = np.tile([0.0, 5.0, 0.0], (200, 1))
    >>> bool(np.allclose(m.simulate(u, 600.0).outputs[0, -1], 5.0))  # no heat: outdoor
    True
    """

    name = "user_building"
    version = "1"

    def __init__(self) -> None:
        super().__init__(_signals(BuildingPlant), _specs(BuildingPlant), ["T_z1", "T_z2"])

    def _validate_theta(self, theta: Array) -> None:
        self._require_positive(theta, self.param_names)

    def _matrices(self, theta: Array) -> tuple[Array, Array]:
        p = {k: theta[:, i] for i, k in enumerate(self.param_names)}
        B = theta.shape[0]
        A = np.zeros((B, 2, 2))
        A[:, 0, 0] = -(p["UA1"] + p["K12"]) / p["C1"]
        A[:, 0, 1] = p["K12"] / p["C1"]
        A[:, 1, 0] = p["K12"] / p["C2"]
        A[:, 1, 1] = -(p["UA2"] + p["K12"]) / p["C2"]
        # inputs w = [Q_hp, I_sol, T_out]
        Bm = np.zeros((B, 2, 3))
        Bm[:, 0, 0] = 1.0 / p["C1"]
        Bm[:, 0, 1] = p["gA1"] / p["C1"]
        Bm[:, 0, 2] = p["UA1"] / p["C1"]
        Bm[:, 1, 1] = p["gA2"] / p["C2"]
        Bm[:, 1, 2] = p["UA2"] / p["C2"]
        return A, Bm

    def _inputs(self, theta: Array, u: Array) -> Array:
        eta = theta[:, self.param_index("eta"), None]
        P = theta[:, self.param_index("P_el"), None]
        d, T_out, I = u[:, :, 0], u[:, :, 1], u[:, :, 2]
        cop = np.clip(
            eta * (BuildingPlant.T_SUP + 273.15) / (BuildingPlant.T_SUP - np.minimum(T_out, 25.0)),
            1.0,
            7.0,
        )
        return np.stack([cop * P * d / 100.0, I, T_out], axis=-1)

    def initial_state(self, theta: Array, u0: Array) -> Array:
        """Steady state at the first input sample."""
        A, Bm = self._matrices(theta)
        w0 = self._inputs(theta, u0[:, None, :])[:, 0]
        return -np.linalg.solve(A, np.einsum("bij,bj->bi", Bm, w0)[..., None])[..., 0]

    def _discrete(self, theta: Array, dt: float) -> tuple[Array, Array]:
        """Exact zero-order-hold discretisation: expm of the augmented matrix [[A, B], [0, 0]]."""
        A, Bm = self._matrices(theta)
        M = np.zeros((theta.shape[0], 5, 5))
        M[:, :2, :2] = A * dt
        M[:, :2, 2:] = Bm * dt
        E = expm(M)
        return E[:, :2, :2], E[:, :2, 2:]

    def _step(self, x, u, theta, dt):
        Ad, Bd = self._discrete(theta, dt)
        w = self._inputs(theta, u[:, None, :])[:, 0]
        return np.einsum("bij,bj->bi", Ad, x) + np.einsum("bij,bj->bi", Bd, w)

    def _output(self, x, u, theta):
        return np.array(x[:, :2], dtype=float)

    def _simulate(self, theta, u, dt, x0, return_states):
        B = theta.shape[0]
        w = self._inputs(theta, np.broadcast_to(u, (B, *u.shape[1:])))
        Ad, Bd = self._discrete(theta, dt)
        T = w.shape[1]
        y = np.empty((B, T, 2))
        x = x0.copy()
        for k in range(T):
            y[:, k] = x
            x = np.einsum("bij,bj->bi", Ad, x) + np.einsum("bij,bj->bi", Bd, w[:, k])
        return y, (y.copy() if return_states else None)


NOMINAL_MODELS: dict[str, type[Model]] = {
    "plate": PlateModel,
    "tank": TankModel,
    "building": BuildingModel,
}


def nominal_model(family: str) -> Model:
    """The user's own nominal model of a family."""
    return NOMINAL_MODELS[family]()
