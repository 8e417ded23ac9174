"""Virtual test rigs: the "real" plants that stand in for devices without public data.

A rig wraps a plant model with what a test bench adds: protocols (the
experiments of the papers), sensors (noise, quantisation, sampling), spread
between specimens and, on request, physics the identified model lacks
(``effects``). A run returns :class:`RigRun` objects — arrays and metadata —
which :func:`thermogym.rigs.to_recording` turns into recordings.

Recorded metadata never names an effect: a rig with a concealed effect writes
data that carries no hint of it.
"""

from __future__ import annotations

import itertools
import math
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from thermogym.errors import ConfigError, UnknownNameError
from thermogym.models.base import Model
from thermogym.vocabulary import EFFECT_NAMES

__all__ = [
    "EFFECT_NAMES",
    "EffectSpec",
    "Protocol",
    "Rig",
    "RigRun",
    "SensorSpec",
    "parse_effect",
    "with_hidden_node",
]


@dataclass(frozen=True)
class EffectSpec:
    """An effect to include in a rig: vocabulary name and keyword settings.

    Parameters
    ----------
    name : str
        One of :data:`EFFECT_NAMES`.
    params : mapping
        Settings, e.g. ``{"tau": 60.0, "signal": "T_P"}``.
    """

    name: str
    params: Mapping[str, Any] = field(default_factory=dict)


def _value(text: str) -> Any:
    try:
        return int(text)
    except ValueError:
        pass
    try:
        return float(text)
    except ValueError:
        return text


def parse_effect(spec: str | EffectSpec) -> EffectSpec:
    """Parse ``NAME[:k=v,...]`` into an :class:`EffectSpec`.

    Examples
    --------
    >>> parse_effect("sensor_lag:tau=60,signal=T_P")
    EffectSpec(name='sensor_lag', params={'tau': 60, 'signal': 'T_P'})
    """
    if isinstance(spec, EffectSpec):
        return spec
    name, _, rest = spec.partition(":")
    name = name.strip()
    if name not in EFFECT_NAMES:
        raise UnknownNameError(f"unknown effect {name!r}; the vocabulary is {list(EFFECT_NAMES)}")
    params: dict[str, Any] = {}
    for item in filter(None, (s.strip() for s in rest.split(","))):
        if not re.match(r"^[A-Za-z_][A-Za-z0-9_]*=.+$", item):
            raise ConfigError(f"effect setting {item!r} in {spec!r} is not of the form key=value")
        k, v = item.split("=", 1)
        params[k] = _value(v)
    return EffectSpec(name, params)


@dataclass(frozen=True)
class SensorSpec:
    """How a rig measures one signal.

    Parameters
    ----------
    noise : float
        Standard deviation of white measurement noise, in the signal's unit.
    resolution : float
        Quantisation step of the recorded value (0: none).
    """

    noise: float = 0.0
    resolution: float = 0.0

    def measure(self, x: NDArray[np.float64], rng: np.random.Generator) -> NDArray[np.float64]:
        """Return ``x`` as this sensor would record it."""
        y = x + self.noise * rng.standard_normal(x.shape) if self.noise > 0 else x.copy()
        if self.resolution > 0:
            y = np.round(y / self.resolution) * self.resolution
        return y


@dataclass
class RigRun:
    """One recorded experiment of a rig, before it becomes a Recording.

    Attributes
    ----------
    experiment_id : str
    time : ndarray, shape (N,)
    columns : dict of str to ndarray
        Recorded signals (NaN where a channel has no sample).
    units, roles : dict
    meta : dict
        Protocol, conditions, seed — never the effects.
    truth : dict of str to ndarray
        Noise-free values of hidden and measured signals on ``time`` (kept for
        tests and virtual-sensor evaluation; not written to recordings).
    """

    experiment_id: str
    time: NDArray[np.float64]
    columns: dict[str, NDArray[np.float64]]
    units: dict[str, str]
    roles: dict[str, str]
    meta: dict[str, Any] = field(default_factory=dict)
    truth: dict[str, NDArray[np.float64]] = field(default_factory=dict)


@dataclass(frozen=True)
class Protocol:
    """A named experiment programme of a rig.

    Parameters
    ----------
    name : str
    description : str
    run : callable
        ``run(rig, rng, **options) -> list[RigRun]``.
    """

    name: str
    description: str
    run: Callable[..., list[RigRun]]


class Rig:
    """Base class of the virtual test rigs.

    Parameters
    ----------
    effects : sequence of str or EffectSpec
        Physics to add to the plant beyond the nominal model.
    """

    name: str = "rig"
    #: Model the rig's plant is built on.
    model_name: str = ""
    #: Protocols by name.
    protocols: ClassVar[dict[str, Protocol]] = {}
    #: Sensors by recorded signal.
    sensors: ClassVar[dict[str, SensorSpec]] = {}
    #: Effects this rig can carry.
    supported_effects: tuple[str, ...] = ()

    def __init__(self, effects: Sequence[str | EffectSpec] = ()) -> None:
        self.effects = tuple(parse_effect(e) for e in effects)
        bad = [e.name for e in self.effects if e.name not in self.supported_effects]
        if bad:
            raise UnknownNameError(
                f"rig {self.name!r} cannot carry effect(s) {bad}; it supports "
                f"{list(self.supported_effects)}"
            )

    def effect(self, name: str) -> EffectSpec | None:
        """The requested effect called ``name``, if any."""
        for e in self.effects:
            if e.name == name:
                return e
        return None

    def run(self, protocol: str, *, seed: int = 0, **options: Any) -> list[RigRun]:
        """Run a protocol and return its recorded experiments.

        Parameters
        ----------
        protocol : str
            Name in :attr:`protocols`.
        seed : int
            Seed of every random draw (noise, ambient, specimen spread).
        **options
            Protocol options (e.g. ``speeds=[4000]``).
        """
        try:
            proto = self.protocols[protocol]
        except KeyError:
            raise UnknownNameError(
                f"rig {self.name!r} has no protocol {protocol!r}; protocols are "
                f"{list(self.protocols)}"
            ) from None
        import inspect

        accepted = [
            n
            for n, prm in inspect.signature(proto.run).parameters.items()
            if prm.kind == prm.KEYWORD_ONLY
        ]
        unknown = [k for k in options if k not in accepted]
        if unknown:
            raise ConfigError(
                f"protocol {protocol!r} of rig {self.name!r} has no option(s) {unknown}; "
                f"options are {accepted}"
            )
        rng = np.random.default_rng(seed)
        runs = proto.run(self, rng, **options)
        for r in runs:
            r.meta.setdefault("rig", self.name)
            r.meta.setdefault("protocol", protocol)
            r.meta.setdefault("seed", seed)
        return runs

    # ------------------------------------------------------------ shared helpers
    def plant(self) -> tuple[Model, dict[str, float]]:
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
    def specimen(self) -> dict[str, float]:
        """Parameter overrides of this particular specimen (manufacturing spread)."""
        return getattr(self, "_specimen", {})

    def with_specimen(self, overrides: Mapping[str, float]) -> Rig:
        """A copy of this rig whose plant has the given parameter overrides."""
        other = type(self)(self.effects)
        other._specimen = dict(overrides)  # type: ignore[attr-defined]
        return other

    def _settings(self, name: str) -> dict[str, Any] | None:
        e = self.effect(name)
        if e is None:
            return None
        return {**self.effect_defaults.get(name, {}), **e.params}

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

    def measure(
        self, values: Mapping[str, NDArray[np.float64]], rng: np.random.Generator
    ) -> dict[str, NDArray[np.float64]]:
        """Apply each signal's sensor (noise, quantisation) to noise-free values."""
        return {
            name: self.sensors.get(name, SensorSpec()).measure(np.asarray(x, dtype=float), rng)
            for name, x in values.items()
        }


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


def first_order_lag(x: NDArray[np.float64], tau: float, dt: float) -> NDArray[np.float64]:
    """Exact discrete first-order lag of a sampled signal (held between samples).

    Parameters
    ----------
    x : ndarray, shape (T,)
    tau : float
        Time constant [s].
    dt : float
        Sample period [s].
    """
    from scipy.signal import lfilter

    a = math.exp(-dt / tau)
    # y[k+1] = a y[k] + (1 − a) x[k], y[0] = x[0] (the sensor starts in equilibrium); in
    # scipy's transposed direct form the initial condition zi is y[0] itself
    y, _ = lfilter([0.0, 1.0 - a], [1.0, -a], x, zi=[x[0]])
    return y
