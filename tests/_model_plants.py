"""Recordings from the identified models themselves, for tests whose truth must lie in the model.

The virtual rigs are plants of their own, richer than the models
(:mod:`thermogym.rigs`). Tests of the identification, diagnosis and estimation
machinery need data whose answer is known in the model's own terms (true
ratio parameters, one concealed effect in the model's vocabulary, the model's
internal temperatures): these helpers simulate the model, with the rig's
protocols and sensor noise, and are no rig.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from thermogym.errors import ConfigError
from thermogym.models.base import Model
from thermogym.models.registry import get_model
from thermogym.recording import Recording, write_recording
from thermogym.rigs.base import first_order_lag, parse_effect
from thermogym.rigs.spindle import ambient_profile
from thermogym.rigs.strut import STEP_TESTS, TEMPERATURES

_STRUT_DEFAULTS = {
    "input_dependent_heat_transfer": {"beta_u": 2.0},
    "sensor_offset": {"signal": "T_nut", "offset": 1.0},
    "sensor_lag": {"signal": "T_nut", "tau": 300.0},
}


def _noisy(x: np.ndarray, rng: np.random.Generator, sigma: float, res: float) -> np.ndarray:
    y = x + sigma * rng.standard_normal(x.shape)
    return np.round(y / res) * res


def model_strut_steps(
    seed: int = 0,
    effects: Sequence[str] = (),
    specimen: Mapping[str, float] | None = None,
    feed_rates: Sequence[float] = (20.0, 25.0, 30.0),
) -> list[Recording]:
    """The strut model's step tests (paper 000 protocol), thermocouples σ 0.05 K, 0.01 K steps.

    ``effects``: ``input_dependent_heat_transfer`` (in the model, β_u = 2 by
    default), ``sensor_offset`` and ``sensor_lag`` (``NAME:k=v`` settings).
    """
    rng = np.random.default_rng(seed)
    specs = {e.name: {**_STRUT_DEFAULTS[e.name], **e.params} for e in map(parse_effect, effects)}
    internal = [n for n in specs if n == "input_dependent_heat_transfer"]
    model = get_model("strut", effects=internal)
    over: dict[str, float] = {"T_ref": 20.0, **dict(specimen or {})}
    if internal:
        over["beta_u"] = float(specs["input_dependent_heat_transfer"]["beta_u"])
    theta = model.theta(over)
    recs = []
    for v in feed_rates:
        duration, period = STEP_TESTS.get(float(v), (120.0, 150.0))
        n = round(duration * 60.0 / period) + 1
        t = period * np.arange(n)
        air = 21.0 + 0.3 * np.sin(2 * np.pi * t / (6 * 3600.0) + rng.uniform(0, 2 * np.pi))
        u = np.column_stack([np.full(n, float(v)), air])
        u[0, 0] = 0.0
        x0 = np.full((1, len(model.state_names)), air[0])
        if float(v) == 25.0:  # the drive had not cooled down (000 section 4.1)
            x0[0, model.state_names.index("drive")] += 3.0
            x0[0, model.state_names.index("motor_flange")] += 1.8
        y = model.simulate(u, period, theta, x0).outputs[0]
        out = {k: y[:, i] for i, k in enumerate(model.output_names)}
        s = specs.get("sensor_lag")
        if s is not None:
            out[s["signal"]] = first_order_lag(out[s["signal"]], float(s["tau"]), period)
        s = specs.get("sensor_offset")
        if s is not None:
            out[s["signal"]] = out[s["signal"]] + float(s["offset"])
        cols: dict[str, Any] = {"feed_rate": u[:, 0].copy(), "T_air": _noisy(air, rng, 0.05, 0.01)}
        for k in TEMPERATURES:
            cols[k] = _noisy(out[k], rng, 0.05, 0.01)
        cols["dL_um"] = _noisy(out["dL_um"], rng, 0.5, 0.1)
        units = {"feed_rate": "m/min", "T_air": "°C", "dL_um": "µm"} | dict.fromkeys(
            TEMPERATURES, "°C"
        )
        roles = {"feed_rate": "input", "T_air": "disturbance"} | dict.fromkeys(
            (*TEMPERATURES, "dL_um"), "output"
        )
        recs.append(
            Recording(
                t,
                cols,
                units=units,
                roles=roles,
                experiment_id=f"strut-step-{v:g}",
                meta={"feed_rate_m_min": float(v), "period_s": period},
            )
        )
    return recs


def write_model_strut(folder: Path, **kw: Any) -> list[Path]:
    """:func:`model_strut_steps` written as CSV files ``strut-step-<v>.csv``."""
    folder.mkdir(parents=True, exist_ok=True)
    return [write_recording(r, folder / f"{r.experiment_id}.csv") for r in model_strut_steps(**kw)]


def model_spindle_day(
    speed: float, seed: int = 0, *, offset: Mapping[str, float] | None = None
) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """A run-in day of the spindle model (1 Hz, RTDs σ 0.02 K): heat until settled, cool.

    Returns the recorded columns and the noise-free truth (``speed``, ``T_amb``
    and every output), as a rig's run would.
    """
    rng = np.random.default_rng(seed)
    model = get_model("spindle")
    n = 24 * 3600
    t = np.arange(float(n))
    amb = ambient_profile(t, rng)
    u = np.column_stack([np.full(n, float(speed)), amb])
    theta = model.theta()

    def sim(u: np.ndarray) -> np.ndarray:
        return model.simulate(u, 1.0, theta).outputs[0]

    y = sim(u)
    rise = y - amb[:, None]
    w = 3 * 3600
    settled = np.nonzero(np.abs(rise[w:] - rise[:-w]).max(axis=1) < 1.0)[0]
    stop = int(min(settled[0] + w if settled.size else n, 20 * 3600))
    u[stop:, 0] = 0.0
    y = sim(u)
    truth = {"speed": u[:, 0].copy(), "T_amb": amb} | {
        k: y[:, i] for i, k in enumerate(model.output_names)
    }
    cols = {"speed": u[:, 0].copy(), "T_amb": _noisy(amb, rng, 0.02, 0.001)}
    for k in model.output_names:
        cols[k] = _noisy(truth[k] + (offset or {}).get(k, 0.0), rng, 0.02, 0.001)
    return cols, truth


def with_hidden_node(
    model: Model,
    node: str,
    *,
    capacity: float,
    conductance: float,
    g_air: float = 0.0,
) -> Model:
    """A thermal-network plant with one extra capacitive node the model does not know.

    (Formerly the ``missing_dynamics`` of the model-backed network rigs.) A heat capacity (a
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


def model_axt211_step(
    voltage: float = 24.0,
    ambient: float = 25.0,
    *,
    on_s: int = 900,
    off_s: int = 900,
    seed: int = 0,
) -> Recording:
    """A power step of the AXT211 model itself at 1 s (on, then off); thermocouples σ 0.1 K."""
    rng = np.random.default_rng(seed)
    model = get_model("axt211")
    n = on_s + off_s
    u = np.column_stack(
        [np.r_[np.ones(on_s), np.zeros(off_s)], np.full(n, voltage), np.full(n, ambient)]
    )
    y = model.simulate(u, 1.0, model.theta()).outputs[0]
    cols: dict[str, Any] = {"u": u[:, 0], "k_U": u[:, 1], "T_U": u[:, 2]}
    for i, k in enumerate(model.output_names):
        cols[k] = y[:, i] + (0.1 * rng.standard_normal(n) if k.startswith("T_") else 0.0)
    return Recording(np.arange(float(n)), cols, experiment_id=f"axt211-step-{voltage:g}V")
