"""Small test plants for the diagnosis, written independently of the augmentations.

:class:`NodeModel` is a user's own one-node model (a heated block:
``C dT/dt = P u/100 − G (T − T_a)``), exact for held inputs. :func:`node_truth`
simulates the *true* block with hidden effects by fixed-step RK4 on its own
ODE (radiation, natural convection, an input dead time, a sensor lag, a
coupled mass, a power-law input, a drifting conductance, ...), then adds
white and Gauss-Markov (coloured) sensor noise. Nothing here imports the
diagnosis or :mod:`thermogym.models.augmented`.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.signal import lfilter

from thermogym.models.base import Model, Parameter, Signal
from thermogym.recording import Recording

SIGMA_SB = 5.670374419e-8

#: True constants of the block (its design values below are off by a few ten per cent).
TRUE = {"C": 800.0, "G": 2.0, "P": 120.0}
DESIGN = {"C": 1000.0, "G": 1.6, "P": 140.0}


class NodeModel(Model):
    """A user's one-node model: ``C dT/dt = P u/100 − G (T − T_a)`` (exact ZOH)."""

    name = "user_node"
    version = "1"

    def __init__(self, design: Mapping[str, float] | None = None) -> None:
        d = {**DESIGN, **(design or {})}
        params = [
            Parameter("C", d["C"], 100.0, 5000.0, "J/K", "heat capacity", "design"),
            Parameter("G", d["G"], 0.2, 10.0, "W/K", "loss conductance", "design"),
            Parameter("P", d["P"], 20.0, 500.0, "W", "heater power at 100 %", "design"),
        ]
        signals = [
            Signal("u", "input", "%", "heater command"),
            Signal("T_a", "disturbance", "°C", "ambient temperature"),
            Signal("T", "output", "°C", "block temperature"),
        ]
        super().__init__(signals, params, ["T"])

    def _validate_theta(self, theta: NDArray[np.float64]) -> None:
        self._require_positive(theta, self.param_names)

    def initial_state(self, theta, u0):
        _, G, P = theta.T
        return (u0[:, 1] + P * u0[:, 0] / 100.0 / G)[:, None]

    def _simulate(self, theta, u, dt, x0, return_states):
        B, T = theta.shape[0], u.shape[1]
        y = np.empty((B, T, 1))
        for b in range(B):
            C, G, P = theta[b]
            a = np.exp(-G * dt / C)
            ub = u[b if u.shape[0] > 1 else 0]
            w = ub[:, 1] + P * ub[:, 0] / 100.0 / G
            y[b, :, 0] = lfilter([0.0, 1.0 - a], [1.0, -a], w, zi=[x0[b, 0]])[0]
        return y, (y.copy() if return_states else None)

    def _step(self, x, u, theta, dt):
        C, G, P = (theta[:, i] for i in range(3))
        a = np.exp(-G * dt / C)
        return (a * x[:, 0] + (1.0 - a) * (u[:, 1] + P * u[:, 0] / 100.0 / G))[:, None]

    def _output(self, x, u, theta):
        return np.array(x[:, :1], dtype=float)


def gauss_markov(n: int, dt: float, sigma: float, tau: float, rng) -> NDArray[np.float64]:
    """First-order Gauss-Markov noise of standard deviation ``sigma``, correlation time ``tau``."""
    a = np.exp(-dt / tau)
    w = rng.standard_normal(n) * sigma * np.sqrt(1 - a * a)
    x0 = rng.standard_normal() * sigma
    return lfilter([1.0], [1.0, -a], w, zi=[a * x0])[0]


def node_truth(
    u: NDArray[np.float64],
    ta: NDArray[np.float64],
    dt: float,
    *,
    effects: Mapping[str, Any] = (),
    consts: Mapping[str, float] | None = None,
    T0: float | None = None,
    sub: int = 2,
) -> NDArray[np.float64]:
    """True block temperature (noise-free) with hidden effects, by RK4 with ``sub`` steps.

    ``effects`` keys: ``radiation`` (emissivity·area [m²]), ``convection`` (coefficient
    [W/K^1.25]), ``delay`` (input dead time [s]), ``power`` (exponent of the command),
    ``mass`` (``(C2, G2)``: a mass coupled to the block), ``ramp`` (relative change of G
    per hour), ``disturbance`` (amplitude [W], period [s] of a heat flow), ``forced``
    (extra conductance [W/K] at full command, growing as the command^0.8: a fan), ``offset``,
    ``lag`` (sensor time constant [s]), ``drift`` (K/h), ``draws`` (``(G_d, T_c)``: water
    drawn off through a conductance G_d [W/K] to cold water at T_c while ``draw_on`` [0/1
    per sample] is 1).
    """
    e = dict(effects or {})
    c = {**TRUE, **(consts or {})}
    C, G, P = c["C"], c["G"], c["P"]
    n = u.size
    if e.get("delay"):
        k = np.arange(n, dtype=float)
        u = np.interp(k - e["delay"] / dt, k, u, left=u[0])
    cmd = u.copy()
    if e.get("power"):
        cmd = 100.0 * (np.clip(cmd, 0, None) / 100.0) ** e["power"]
    C2, G2 = e.get("mass", (0.0, 0.0))

    tau_s = e.get("lag", 0.0)

    def rhs(t, x, q, ta_k):
        T, T2, Ts = x
        g = G * (1.0 + e.get("ramp", 0.0) * t / 3600.0)
        loss = g * (T - ta_k)
        if e.get("radiation"):
            loss += e["radiation"] * SIGMA_SB * ((T + 273.15) ** 4 - (ta_k + 273.15) ** 4)
        if e.get("forced"):
            loss += e["forced"] * (max(u_now[0], 0.0) / 100.0) ** 0.8 * (T - ta_k)
        if e.get("convection"):
            d = T - ta_k
            loss += e["convection"] * np.sign(d) * abs(d) ** 1.25
        if e.get("disturbance"):
            amp, per = e["disturbance"]
            loss -= amp * np.sin(2 * np.pi * t / per)
        if e.get("draws") and draw_now[0]:
            g_d, t_c = e["draws"]
            loss += g_d * (T - t_c)
        flow2 = G2 * (T - T2) if C2 else 0.0
        dT = (q - loss - flow2) / C
        dT2 = flow2 / C2 if C2 else 0.0
        dTs = (T - Ts) / tau_s if tau_s else 0.0  # the sensor's own heat capacity
        return np.array([dT, dT2, dTs])

    u_now = [0.0]
    draw_now = [0.0]
    draw_on = np.asarray(e.get("draw_on", np.zeros(n)), dtype=float)
    T = np.empty(n)
    start = T0 if T0 is not None else ta[0]
    x = np.array([start, start, start])
    h = dt / sub
    for k in range(n):
        T[k] = x[2] if tau_s else x[0]
        q = P * cmd[k] / 100.0
        u_now[0] = u[k]
        draw_now[0] = draw_on[k]
        for s in range(sub):
            t = k * dt + s * h
            k1 = rhs(t, x, q, ta[k])
            k2 = rhs(t + h / 2, x + h / 2 * k1, q, ta[k])
            k3 = rhs(t + h / 2, x + h / 2 * k2, q, ta[k])
            k4 = rhs(t + h, x + h * k3, q, ta[k])
            x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    if e.get("offset"):
        T = T + e["offset"]
    if e.get("drift"):
        T = T + e["drift"] * dt * np.arange(n) / 3600.0
    return T


def node_recordings(
    seed: int,
    *,
    effects: Mapping[str, Any] = (),
    consts: Mapping[str, float] | None = None,
    n_train: int = 2,
    n_val: int = 2,
    hours: float = 2.0,
    dt: float = 5.0,
    white: float = 0.05,
    coloured: float = 0.08,
    tau_noise: float = 300.0,
    hold: tuple[float, float] = (120.0, 900.0),
    train_levels: tuple[float, ...] | None = None,
) -> tuple[list[Recording], list[Recording]]:
    """Training and held-out recordings of the true block: random command levels.

    Each recording starts after 30 min of unrecorded operation (not at rest)
    and carries white plus coloured sensor noise. ``train_levels``: the
    training recordings cycle through these command levels only. With
    ``draws`` among the effects, each recording has its own draw-offs of
    two minutes every 15 to 40 minutes, at random times.
    """
    rng = np.random.default_rng(seed)
    recs = []
    warm = int(1800 / dt)
    n = int(hours * 3600 / dt)
    for r in range(n_train + n_val):
        levels, k = [], 0
        while k < warm + n:
            m = int(rng.uniform(*hold) / dt)
            if train_levels is not None and r < n_train:
                v = float(train_levels[len(levels) % len(train_levels)])
            else:
                v = rng.uniform(0.0, 100.0)
            levels.append(np.full(m, v))
            k += m
        u = np.concatenate(levels)[: warm + n]
        t = np.arange(warm + n) * dt
        ta = 21.0 + 1.5 * np.sin(2 * np.pi * (t + 3000 * r) / 7200.0)
        eff = dict(effects or {})
        if eff.get("draws"):
            on = np.zeros(warm + n)
            k = int(rng.uniform(300.0, 1500.0) / dt)
            while k < on.size:
                on[k : k + int(120.0 / dt)] = 1.0
                k += int(rng.uniform(900.0, 2400.0) / dt)
            eff["draw_on"] = on
        T = node_truth(u, ta, dt, effects=eff, consts=consts)
        y = T[warm:] + white * rng.standard_normal(n)
        y = y + gauss_markov(n, dt, coloured, tau_noise, rng)
        recs.append(
            Recording(
                t[warm:] + 3600.0 * (1 + r),
                {"u": u[warm:], "T_a": ta[warm:], "T": y},
                units={"u": "%", "T_a": "°C", "T": "°C"},
                roles={"u": "input", "T_a": "disturbance", "T": "output"},
                experiment_id=f"node-{seed}-{r}",
            )
        )
    return recs[:n_train], recs[n_train:]
