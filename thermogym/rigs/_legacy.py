"""Rigs whose plant is still a model of :mod:`thermogym.models` (strut, spindle).

Transitional: the strut and spindle rigs are being rewritten on their own true
plants (:class:`thermogym.rigs.base.TruePlant`); until then they build their
plant from the identified model with the effects switched on, as every rig did
before. This module is the one place in :mod:`thermogym.rigs` that imports a
plant model; the independence test names it as the known exception, to be
removed with it.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from thermogym.errors import ConfigError
from thermogym.models.base import Model
from thermogym.rigs.base import Rig, first_order_lag
from thermogym.rigs.sensors import Sensor

__all__ = ["ModelRig", "with_hidden_node"]


class ModelRig(Rig):
    """A rig whose true plant is the identified model plus effects (transitional)."""

    #: Model the rig's plant is built on.
    model_name: str = ""

    # ------------------------------------------------------------ shared helpers
    def plant(self) -> tuple[Model, dict[str, float]]:  # type: ignore[override]
        """The true plant: a model with the physical effects and its parameter overrides.

        Model-internal effects (those in the model's ``physical_effects``) are
        switched on in the model; their settings are model parameter names, and
        settings left out take the rig's :attr:`effect_defaults`. Other effect
        settings that name a model parameter (e.g. ``backlash:c_backlash=0.3``)
        override it.
        """
        from thermogym.models.registry import get_model

        probe = get_model(self.model_name)
        internal = [
            e.name for e in self.effects if e.name in getattr(probe, "physical_effects", {})
        ]
        model = get_model(self.model_name, effects=internal) if internal else probe
        hidden = self._settings("missing_dynamics")
        if hidden is not None:
            model = with_hidden_node(
                model,
                str(hidden.get("node", "")),
                capacity=float(hidden.get("C", 20000.0)),
                conductance=float(hidden.get("G", 2.0)),
                g_air=float(hidden.get("g_air", 0.0)),
            )
        overrides: dict[str, float] = dict(self.specimen)
        for e in self.effects:
            settings = {**self.effect_defaults.get(e.name, {}), **e.params}
            for k, v in settings.items():
                if k in model.param_names:
                    overrides[k] = float(v)
        return model, overrides

    #: Default magnitudes of the effects, as model parameter names or effect settings.
    effect_defaults: ClassVar[dict[str, dict[str, Any]]] = {}

    @property
    def specimen(self) -> dict[str, float]:  # type: ignore[override]
        """Parameter overrides of this particular specimen (manufacturing spread)."""
        return self._specimen or {}  # type: ignore[return-value]

    def with_specimen(self, overrides: Mapping[str, float]) -> Rig:  # type: ignore[override]
        """A copy of this rig whose plant has the given parameter overrides."""
        other = type(self)(self.effects)
        other._specimen = dict(overrides)  # type: ignore[assignment]
        return other

    def simulate_true(
        self,
        u: NDArray[np.float64],
        dt: float,
        *,
        t0: float = 0.0,
        x0: NDArray[np.float64] | None = None,
        rng: np.random.Generator | None = None,
    ) -> tuple[dict[str, NDArray[np.float64]], NDArray[np.float64]]:
        """Simulate the true plant on a uniform grid, effects included, noise excluded.

        Parameters
        ----------
        u : ndarray, shape (T, n_u)
            Exogenous signals *as recorded* (the plant may see them delayed or
            disturbed when an effect says so).
        dt : float
            Sample period [s].
        t0 : float
            Time of the first sample [s] (time-varying effects).
        x0 : ndarray, optional
            Initial state (rest state of the model when omitted).
        rng : Generator, optional
            For effects with random phase.

        Returns
        -------
        outputs : dict
            Every model output as the sensors see it (before noise).
        states : ndarray, shape (T, n_x)
        """
        model, overrides = self.plant()
        names = list(model.exogenous_names)
        ua = np.array(u, dtype=float, copy=True)
        s = self._settings("transport_delay")
        if s is not None:
            col = names.index(s.get("signal", names[0]))
            shift = float(s.get("delay", 300.0)) / dt
            src = np.arange(ua.shape[0]) - shift
            ua[:, col] = np.interp(src, np.arange(ua.shape[0]), ua[:, col], left=ua[0, col])
        s = self._settings("unmeasured_disturbance")
        if s is not None:
            col = names.index(s.get("signal", model.disturbances[-1].name))
            t = t0 + dt * np.arange(ua.shape[0])
            phase = float(s.get("phase", 0.0))
            period = float(s.get("period", 4 * 3600.0))
            ua[:, col] += float(s.get("amplitude", 2.0)) * np.sin(2 * np.pi * t / period + phase)
        theta = model.theta(overrides)
        s = self._settings("time_varying_parameter")
        tv_name = s.get("name") if s is not None else None
        if s is not None and tv_name in model.param_names:
            # piecewise-constant parameter drift, state carried across chunks
            j = model.param_index(str(tv_name))
            rate = float(s.get("rate", 0.1))  # relative change per hour
            T = ua.shape[0]
            edges = np.unique(np.linspace(0, T, 49).astype(int))
            ys, xs = [], []
            x = x0
            for a, b in itertools.pairwise(edges):
                th = theta.copy()
                th[:, j] *= 1.0 + rate * (t0 + dt * 0.5 * (a + b)) / 3600.0
                sim = model.simulate(ua[a : min(b + 1, T)], dt, th, x, return_states=True)
                ys.append(sim.outputs[0, : b - a])
                xs.append(sim.states[0, : b - a])  # type: ignore[index]
                if b < T:
                    x = sim.states[0, b - a]  # type: ignore[index]
            y = np.concatenate(ys)
            states = np.concatenate(xs)
        else:
            sim = model.simulate(ua, dt, theta, x0, t0=t0, return_states=True)
            y, states = sim.outputs[0], sim.states[0]  # type: ignore[index]
        out = {n: y[:, i].copy() for i, n in enumerate(model.output_names)}
        for name in ("sensor_lag", "sensor_offset", "sensor_drift"):
            s = self._settings(name)
            if s is None:
                continue
            sig = str(s.get("signal", model.output_names[0]))
            if sig not in out:
                raise ConfigError(f"effect {name!r} names signal {sig!r}; outputs are {list(out)}")
            if name == "sensor_lag":
                out[sig] = first_order_lag(out[sig], float(s.get("tau", 60.0)), dt)
            elif name == "sensor_offset":
                out[sig] = out[sig] + float(s.get("offset", 1.0))
            else:
                t = dt * np.arange(len(out[sig]))
                out[sig] = out[sig] + float(s.get("rate", 0.5)) * t / 3600.0
        return out, states

    def measure(  # type: ignore[override]
        self, values: Mapping[str, NDArray[np.float64]], rng: np.random.Generator
    ) -> dict[str, NDArray[np.float64]]:
        """Apply each signal's sensor (white noise, quantisation) to noise-free values."""
        out = {}
        for name, x in values.items():
            s = self.sensors.get(name, Sensor())
            y = np.asarray(x, dtype=float)
            y = y + s.noise * rng.standard_normal(y.shape) if s.noise > 0 else y.copy()
            if s.resolution > 0:
                y = np.round(y / s.resolution) * s.resolution
            out[name] = y
        return out


def with_hidden_node(
    model: Model,
    node: str,
    *,
    capacity: float,
    conductance: float,
    g_air: float = 0.0,
) -> Model:
    """A thermal-network plant with one extra capacitive node the model does not know.

    The ``missing_dynamics`` effect of the network rigs: a heat capacity (a
    machine-frame casting, a mounting bracket, a headstock) bolted to ``node``
    through a contact conductance, optionally losing heat to the air. It adds
    one slow state to the plant; every node balance stays eq (13) of
    ``000_24627a5308ee07db.txt``::

        C_h dT_h/dt = G_h (T_node − T_h) + g_h (T_air − T_h)
        C_node dT_node/dt = ... + G_h (T_h − T_node)

    Parameters
    ----------
    model : ThermalNetworkModel
        The plant model (possibly with physical effects switched on).
    node : str
        Node the hidden mass is attached to.
    capacity : float
        Heat capacity of the hidden mass [J/K], > 0.
    conductance : float
        Contact conductance to ``node`` [W/K], > 0.
    g_air : float
        Conductance of the hidden mass to the air [W/K], >= 0.

    Returns
    -------
    ThermalNetworkModel
        Same signals, parameters and outputs; one more state, ``hidden_mass``.

    Raises
    ------
    ConfigError
        The model is not a thermal network, the node is unknown or a value is
        not physical.
    """
    from thermogym.models.thermal_network import NetworkArrays, ThermalNetworkModel

    if not isinstance(model, ThermalNetworkModel):
        raise ConfigError(
            f"effect 'missing_dynamics' adds a hidden thermal node; model {model.name!r} is "
            "not a thermal network"
        )
    cls = type(model)
    if node not in cls.nodes:
        raise ConfigError(
            f"effect 'missing_dynamics' names node {node!r}; the {model.name!r} nodes are "
            f"{list(cls.nodes)}"
        )
    for what, v, lo in (("C", capacity, 0.0), ("G", conductance, 0.0)):
        if not (math.isfinite(v) and v > lo):
            raise ConfigError(f"effect 'missing_dynamics': {what} = {v!r}, expected > 0")
    if not (math.isfinite(g_air) and g_air >= 0):
        raise ConfigError(f"effect 'missing_dynamics': g_air = {g_air!r}, expected >= 0")
    j = cls.nodes.index(node)

    class _Hidden(cls):  # type: ignore[misc, valid-type]
        nodes = (*cls.nodes, "hidden_mass")

        def network(self, theta_full: NDArray[np.float64]) -> NetworkArrays:
            net = super().network(theta_full)
            B, n = net.C.shape
            C = np.concatenate([net.C, np.full((B, 1), capacity)], axis=1)
            G = np.zeros((B, n + 1, n + 1))
            G[:, :n, :n] = net.G
            G[:, j, n] = G[:, n, j] = conductance
            g = np.concatenate([net.g_amb, np.full((B, 1), g_air)], axis=1)
            q = np.concatenate([net.q, np.zeros((B, 1, net.q.shape[2]))], axis=1)
            H = np.concatenate([net.H, np.zeros((net.H.shape[0], 1))], axis=1)
            return NetworkArrays(C, G, g, q, H, net.h0)

    _Hidden.__name__ = _Hidden.__qualname__ = cls.__name__
    return _Hidden(effects=model.effects)
