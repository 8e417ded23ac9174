"""True plants of the suite's own families, written from textbook heat transfer.

Three plant families that no other part of thermogym uses:

``plate``
    A black-anodised aluminium plate (150 × 150 × 2 mm) heated by a halogen
    lamp through a dimmer, cooled by the room air; a thermocouple on its back.
``tank``
    A 20-litre stirred water tank with a 2 kW immersion heater on a thyristor
    and a cooling coil fed with mains water through a valve; a PT100 in a
    thermowell.
``building``
    A two-zone house (ground floor heated by an air-to-water heat pump whose
    COP follows the Carnot limit at the outdoor temperature, first floor heated
    through the ceiling and stairwell), with measured outdoor temperature and
    global irradiance.

Each plant is a class with its design constants (the values an engineer puts
in the nominal model, :attr:`Family.design`), a batched right-hand side and a
fixed-step RK4 driver (:func:`rk4`) stepping the whole batch. Every hidden
effect is a numeric setting (an array over the batch) whose neutral value
switches it off, so one call simulates a plant with and without its effect on
the same inputs. Inputs are held over each sample (zero-order hold);
dead times shift that held signal at the sub-step resolution.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from .effects import (
    Hidden,
    apply_input_map,
    latent_capacity,
    natural_convection,
    radiation,
    radiation_conductance,
)
from .signals import SensorNoise

__all__ = [
    "FAMILIES",
    "BuildingPlant",
    "Family",
    "PlantRun",
    "PlatePlant",
    "TankPlant",
    "rk4",
]

Array = NDArray[np.float64]
WATER_C = 4186.0  # J/(kg K), specific heat of water at 40 °C


def rk4(
    rhs: Callable[[float, Array, int], Array],
    x0: Array,
    n: int,
    dt: float,
    n_sub: int,
    *,
    on_sample: Callable[[int, Array], None] | None = None,
) -> Array:
    """Fixed-step classical Runge-Kutta over ``n`` samples, the whole batch at once.

    Parameters
    ----------
    rhs : callable
        ``rhs(t, x, k) -> dx/dt`` for a batch of states ``x`` (B, n_x); ``t`` is
        the middle of the current RK4 step since the first sample [s] (where
        held and delayed inputs are read: exact for dead times that are whole
        steps), ``k`` the sample interval.
    x0 : ndarray, shape (B, n_x)
    n : int
        Samples; the state at each sample instant is returned.
    dt : float
        Sample period [s].
    n_sub : int
        RK4 steps per sample (fixed: the plants are mildly stiff at most).
    on_sample : callable, optional
        Called as ``on_sample(k, x_k)`` before the interval starting at sample
        ``k`` is integrated (a controller reading the plant there).

    Returns
    -------
    ndarray, shape (B, n, n_x)
    """
    x = np.array(x0, dtype=float)
    out = np.empty((x.shape[0], n, x.shape[1]))
    h = dt / n_sub
    for k in range(n):
        out[:, k] = x
        if on_sample is not None:
            on_sample(k, x)
        if k == n - 1:
            break
        for s in range(n_sub):
            # every stage reads the held inputs at the middle of the step, so a stage at the
            # step's end never sees the next sample's input
            t = k * dt + (s + 0.5) * h
            k1 = rhs(t, x, k)
            k2 = rhs(t, x + 0.5 * h * k1, k)
            k3 = rhs(t, x + 0.5 * h * k2, k)
            k4 = rhs(t, x + h * k3, k)
            x = x + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    return out


def held(u: Array, t: float, delay: Array, dt: float) -> Array:
    """Values of held signals ``u`` (B, T) at time ``t - delay`` (per batch element).

    A dead time looks up the zero-order-held signal at an earlier instant;
    before the first sample the first value is held.
    """
    idx = np.floor((t - delay) / dt + 1e-9).astype(int)
    idx = np.clip(idx, 0, u.shape[1] - 1)
    return u[np.arange(u.shape[0]), idx]


@dataclass
class PlantRun:
    """Noise-free result of a plant simulation on a sample grid.

    Attributes
    ----------
    outputs : dict of str to ndarray, shape (B, T)
        What a perfect sensor would read (sensor lag, offset and drift included).
    states : ndarray, shape (B, T, n_x)
    inputs : dict of str to ndarray, shape (B, T)
        The exogenous signals as they are logged (a closed loop computes some).
    """

    outputs: dict[str, Array]
    states: Array
    inputs: dict[str, Array]


@dataclass(frozen=True)
class Design:
    """A design constant of a family: value, unit, and what it is."""

    value: float
    unit: str
    description: str
    lower: float
    upper: float


class Family:
    """A plant family: signals, design constants, sensors, true-plant simulation."""

    name: ClassVar[str] = "family"
    #: Exogenous signals: name -> (role, unit, description).
    exogenous: ClassVar[dict[str, tuple[str, str, str]]] = {}
    #: Outputs: name -> (unit, description).
    outputs: ClassVar[dict[str, tuple[str, str]]] = {}
    #: The constants an engineer's nominal model starts from.
    design: ClassVar[dict[str, Design]] = {}
    #: Sensor chain of each recorded signal.
    sensors: ClassVar[dict[str, SensorNoise]] = {}
    #: Effects this family can carry.
    supports: ClassVar[tuple[str, ...]] = ()

    def draw_constants(
        self, rng: np.random.Generator, spread: tuple[float, float] = (0.1, 0.3)
    ) -> dict[str, float]:
        """True constants: each design value off by a random 10-30 % (random sign).

        The spread is what separates a real plant from its data sheet and
        handbook values (paper 000 states +200/−70 % for its loss estimates).
        """
        out = {}
        for k, d in self.design.items():
            f = 1.0 + rng.choice([-1.0, 1.0]) * rng.uniform(*spread)
            out[k] = float(np.clip(d.value * f, d.lower, d.upper))
        return out

    def design_values(self) -> dict[str, float]:
        """The design constants as plain values."""
        return {k: d.value for k, d in self.design.items()}

    def settings(self, hidden: Sequence[Hidden], active: Sequence[Sequence[str]]) -> dict[str, Any]:
        """Numeric effect settings over a batch: element b carries the effects in ``active[b]``."""
        raise NotImplementedError


def _arr(active: Sequence[Sequence[str]], h: Hidden | None, key: str, off: float = 0.0) -> Array:
    """Setting ``key`` of effect ``h`` per batch element: its value where active, else ``off``."""
    return np.array(
        [float(h.get(key, off)) if h is not None and h.effect in a else off for a in active],
        dtype=float,
    )


def _on(active: Sequence[Sequence[str]], effect: str) -> NDArray[np.bool_]:
    return np.array([effect in a for a in active], dtype=bool)


def _find(hidden: Sequence[Hidden], effect: str) -> Hidden | None:
    for h in hidden:
        if h.effect == effect:
            return h
    return None


@dataclass
class Profiles:
    """Time profiles of one recording (sample grid, unit size): drawn once per recording."""

    values: dict[str, Array] = field(default_factory=dict)

    def get(self, name: str, n: int) -> Array:
        """The profile ``name``, or zeros."""
        return self.values.get(name, np.zeros(n))


# ==================================================================================== plate
class PlatePlant(Family):
    """Lamp-heated aluminium plate with thermocouple; one lumped node (Biot ≪ 1).

    Energy balance of the plate (C = m c, ``P_max`` the lamp power the plate
    absorbs at full command, ``G`` the loss conductance to the room air)::

        C dT/dt = P_max f(u) s(t) − G (T − T_air) + q_d(t)

    ``T_air`` is the measured ambient plus any unmeasured change of the air
    around the plate. Biot number h L / k = 10 × 0.001 / 200 ≈ 5e-5, so one
    node is exact enough. Design: 2 mm aluminium (ρ = 2700 kg/m³, c = 900
    J/(kg K)): C = 0.1215 kg × 900 = 109 J/K; both faces A = 0.045 m² at a
    combined h ≈ 11 W/(m² K) give G ≈ 0.5 W/K (time constant ≈ 220 s); a 250 W
    halogen lamp at 8 cm puts about 45 W on the plate (steady rise ≈ 90 K at full
    command).
    """

    name = "plate"
    exogenous: ClassVar[dict[str, tuple[str, str, str]]] = {
        "lamp": ("input", "%", "dimmer command of the halogen lamp"),
        "T_amb": ("disturbance", "°C", "room air temperature, 1 m from the plate"),
    }
    outputs: ClassVar[dict[str, tuple[str, str]]] = {
        "T_plate": ("°C", "thermocouple on the back of the plate"),
    }
    design: ClassVar[dict[str, Design]] = {
        "C": Design(109.0, "J/K", "heat capacity of the plate", 20.0, 600.0),
        "G": Design(0.5, "W/K", "loss conductance to the room air", 0.1, 3.0),
        "P_max": Design(45.0, "W", "lamp power absorbed at full command", 5.0, 200.0),
    }
    sensors: ClassVar[dict[str, SensorNoise]] = {
        # type K thermocouple on a 16-bit logger: 0.1 K white, cold-junction wander 0.08 K
        "T_plate": SensorNoise(white=0.08, coloured=0.08, tau=240.0, resolution=0.1),
        "T_amb": SensorNoise(white=0.05, coloured=0.05, tau=600.0, resolution=0.1),
    }
    supports = (
        "nonlinear_heat_transfer",
        "input_nonlinearity",
        "time_varying_parameter",
        "unmeasured_disturbance",
        "transport_delay",
        "sensor_lag",
        "sensor_offset",
        "sensor_drift",
        "missing_dynamics",
        "phase_change",
        "supply_variation",
    )
    AREA = 0.045  # m², both faces
    T_REF = 50.0  # °C: the operating point where radiation and convection replace G,
    DT_REF = 28.0  # K: 28 K above the design ambient of 22 °C
    CP_PCM = 2000.0  # J/(kg K), solid paraffin
    L_PCM = 200e3  # J/kg, paraffin latent heat

    def settings(self, hidden: Sequence[Hidden], active: Sequence[Sequence[str]]) -> dict[str, Any]:
        """Numeric settings of the plate's hidden effects over a batch."""
        s: dict[str, Any] = {"hidden": list(hidden), "on": _on(active, "input_nonlinearity")}
        h = _find(hidden, "nonlinear_heat_transfer")
        rad = h if h is not None and h.form == "radiation" else None
        s["eps"] = _arr(active, rad, "emissivity", 0.0)
        nc = h if h is not None and h.form == "natural_convection" else None
        s["nc_share"] = _arr(active, nc, "share", 0.0)
        s["nc_exp"] = float(nc.get("exponent", 1.25)) if nc else 1.25
        s["input_map"] = _find(hidden, "input_nonlinearity")
        tv = _find(hidden, "time_varying_parameter")
        s["tv"] = _arr(active, tv, "change", 0.0)
        d = _find(hidden, "unmeasured_disturbance")
        s["dist_air"] = _arr(active, d, "amplitude_K", 0.0)
        s["dist_heat"] = _arr(active, d, "amplitude_W", 0.0)
        td = _find(hidden, "transport_delay")
        s["delay"] = _arr(active, td, "delay", 0.0)
        lag = _find(hidden, "sensor_lag")
        s["tau_s"] = _arr(active, lag, "tau", 0.0)
        off = _find(hidden, "sensor_offset")
        s["offset"] = _arr(active, off, "offset", 0.0)
        dr = _find(hidden, "sensor_drift")
        s["drift"] = _arr(active, dr, "rate", 0.0)  # K/h
        md = _find(hidden, "missing_dynamics")
        s["C_b"] = float(md.get("C_b", 1.0)) if md else 1.0
        s["G_b"] = _arr(active, md, "G_b", 0.0)
        s["g_b"] = float(md.get("g_b", 0.0)) if md else 0.0
        pc = _find(hidden, "phase_change")
        s["m_pcm"] = _arr(active, pc, "mass", 0.0)
        s["T_melt"] = float(pc.get("T_melt", 50.0)) if pc else 50.0
        s["w_melt"] = float(pc.get("width", 1.5)) if pc else 1.5
        sv = _find(hidden, "supply_variation")
        s["supply"] = _arr(active, sv, "amplitude", 0.0)
        return s

    def simulate(
        self,
        u: Mapping[str, Array],
        dt: float,
        consts: Mapping[str, Any],
        s: Mapping[str, Any],
        profiles: Profiles,
        x0: Array | None = None,
        n_sub: int = 2,
    ) -> PlantRun:
        """Simulate the plate for a batch (inputs ``u[name]`` of shape (B, T)).

        Profiles (unit size, sample grid): ``tv`` (time-varying factor),
        ``dist`` (unmeasured disturbance), ``supply`` (relative supply voltage),
        ``drift_t`` (hours since the logger started).
        """
        lamp, T_amb = np.atleast_2d(u["lamp"]), np.atleast_2d(u["T_amb"])
        B, n = lamp.shape
        C, G, P = (np.broadcast_to(np.asarray(consts[k], float), (B,)) for k in ("C", "G", "P_max"))
        eps, share, q = s["eps"], s["nc_share"], s["nc_exp"]
        # radiation and free convection replace part of G so the loss at T_REF stays G (the
        # effect changes the shape of the loss, not its size at the operating point)
        G_lin = G * (1.0 - share) - radiation_conductance(eps, self.AREA, self.T_REF, self.DT_REF)
        k_nc = G * share * self.DT_REF ** (1.0 - q)
        if np.any(G_lin < 0):
            raise ValueError(f"emissivity {eps} too large for G = {G}: negative convection")
        f_u = apply_input_map(lamp / 100.0, s["input_map"])
        f_u = np.where(s["on"][:, None], f_u, lamp / 100.0)
        tv = 1.0 + s["tv"][:, None] * profiles.get("tv", n)[None]
        air = T_amb + s["dist_air"][:, None] * profiles.get("dist", n)[None]
        qd = s["dist_heat"][:, None] * profiles.get("dist", n)[None]
        # tungsten-halogen lamp: power ∝ V^1.6 (hot-filament resistance grows with V)
        sup = (1.0 + s["supply"][:, None] * profiles.get("supply", n)[None]) ** 1.6
        C_pcm_sens = s["m_pcm"] * self.CP_PCM
        L = s["m_pcm"] * self.L_PCM
        tau_s = np.maximum(s["tau_s"], 1e-9)
        has_lag = s["tau_s"] > 0
        Gb, Cb, gb = s["G_b"], s["C_b"], s["g_b"]
        drive = P[:, None] * f_u * sup
        delay = s["delay"]

        def rhs(t: float, x: Array, k: int) -> Array:
            T, Tb, Ts = x[:, 0], x[:, 1], x[:, 2]
            Ta = air[:, k]
            dT = T - Ta
            loss = G_lin * tv[:, k] * dT + radiation(T, Ta, eps, self.AREA)
            loss = loss + tv[:, k] * natural_convection(dT, k_nc, q)
            q_in = held(drive, t, delay, dt) + qd[:, k] - Gb * (T - Tb) - loss
            Ceff = C + C_pcm_sens + latent_capacity(T, L, s["T_melt"], s["w_melt"])
            dx = np.empty_like(x)
            dx[:, 0] = q_in / Ceff
            dx[:, 1] = (Gb * (T - Tb) - gb * (Tb - Ta)) / Cb
            dx[:, 2] = np.where(has_lag, (T - Ts) / tau_s, 0.0)
            return dx

        if x0 is None:
            x0 = np.repeat(T_amb[:, :1], 3, axis=1)
        xs = rk4(rhs, x0, n, dt, n_sub)
        y = np.where(has_lag[:, None], xs[:, :, 2], xs[:, :, 0])
        y = y + s["offset"][:, None] + s["drift"][:, None] * profiles.get("drift_t", n)[None]
        return PlantRun({"T_plate": y}, xs, {"lamp": lamp, "T_amb": T_amb})

    @staticmethod
    def steady_state(u: float, T_amb: float, C: float, G: float, P_max: float) -> float:
        """Linear plant's steady temperature [°C] at command ``u`` [%] (hand calculation)."""
        return T_amb + P_max * u / 100.0 / G


# ===================================================================================== tank
class TankPlant(Family):
    """Stirred water tank: immersion heater, cooling coil on mains water, losses.

    Energy balance of the well-mixed water (plus the steel of the tank)::

        C dT/dt = P_max f(h) s(t)² − φ(t) ε K_coil v (T − T_cw) − G (T − T_amb) + q_d(t)

    with the heater command h and valve command v in [0, 1]; ``K_coil`` = ṁ_max
    c_w is the coolant's capacity rate at a fully open valve; the coil's
    effectiveness ε is 1 in the nominal design (a long coil: the coolant leaves
    at the tank temperature). Design: 20 kg water (83.7 kJ/K) + 8 kg steel
    (4 kJ/K); 2 kW heater; ṁ_max = 0.6 l/min → K_coil = 42 W/K; G = 2.5 W/K
    (50 mm mineral wool on 1 m²).
    """

    name = "tank"
    exogenous: ClassVar[dict[str, tuple[str, str, str]]] = {
        "heater": ("input", "1", "thyristor command of the immersion heater (0-1)"),
        "valve": ("input", "1", "coolant valve command (0-1)"),
        "T_cw": ("disturbance", "°C", "mains water temperature at the coil inlet"),
        "T_amb": ("disturbance", "°C", "air temperature of the room"),
    }
    outputs: ClassVar[dict[str, tuple[str, str]]] = {
        "T_tank": ("°C", "PT100 in a thermowell, upper third of the tank"),
    }
    design: ClassVar[dict[str, Design]] = {
        "C": Design(87.7e3, "J/K", "heat capacity of water and tank", 20e3, 400e3),
        "P_max": Design(2000.0, "W", "heater power at full command", 300.0, 6000.0),
        "K_coil": Design(42.0, "W/K", "coolant capacity rate at a full-open valve", 5.0, 200.0),
        "G": Design(2.5, "W/K", "loss conductance to the room", 0.3, 15.0),
    }
    sensors: ClassVar[dict[str, SensorNoise]] = {
        # PT100 class A on a 4-wire transmitter: 0.02 K white, 0.03 K slow wander, 0.01 K steps
        "T_tank": SensorNoise(white=0.02, coloured=0.03, tau=900.0, resolution=0.01),
        "T_cw": SensorNoise(white=0.03, coloured=0.03, tau=900.0, resolution=0.01),
        "T_amb": SensorNoise(white=0.05, coloured=0.05, tau=1200.0, resolution=0.1),
    }
    supports = (
        "input_dependent_heat_transfer",
        "backlash",
        "input_nonlinearity",
        "phase_change",
        "missing_dynamics",
        "sensor_lag",
        "sensor_offset",
        "sensor_drift",
        "transport_delay",
        "time_varying_parameter",
        "unmeasured_disturbance",
        "supply_variation",
    )
    L_PCM = 180e3  # J/kg, paraffin (RT-series ~45 °C)
    CP_PCM = 2000.0  # J/(kg K)

    def settings(self, hidden: Sequence[Hidden], active: Sequence[Sequence[str]]) -> dict[str, Any]:
        """Numeric settings of the tank's hidden effects over a batch."""
        s: dict[str, Any] = {"hidden": list(hidden), "on": _on(active, "input_nonlinearity")}
        h = _find(hidden, "input_dependent_heat_transfer")
        # NTU at the full-open valve; 0 means an infinite coil (ε = 1)
        s["ntu0"] = _arr(active, h, "ntu_full", 0.0)
        bl = _find(hidden, "backlash")
        s["play"] = _arr(active, bl, "width", 0.0)
        s["input_map"] = _find(hidden, "input_nonlinearity")
        pc = _find(hidden, "phase_change")
        s["m_pcm"] = _arr(active, pc, "mass", 0.0)
        s["T_melt"] = float(pc.get("T_melt", 45.0)) if pc else 45.0
        s["w_melt"] = float(pc.get("width", 1.5)) if pc else 1.5
        md = _find(hidden, "missing_dynamics")
        s["G_mix"] = _arr(active, md, "G_mix", 0.0)
        s["frac_low"] = float(md.get("lower_share", 0.4)) if md else 0.4
        lag = _find(hidden, "sensor_lag")
        s["tau_s"] = _arr(active, lag, "tau", 0.0)
        off = _find(hidden, "sensor_offset")
        s["offset"] = _arr(active, off, "offset", 0.0)
        dr = _find(hidden, "sensor_drift")
        s["drift"] = _arr(active, dr, "rate", 0.0)
        td = _find(hidden, "transport_delay")
        s["out_delay"] = _arr(active, td, "delay", 0.0)
        tv = _find(hidden, "time_varying_parameter")
        s["tv"] = _arr(active, tv, "change", 0.0)
        d = _find(hidden, "unmeasured_disturbance")
        s["dist_W"] = _arr(active, d, "amplitude_W", 0.0)
        s["draw"] = _arr(active, d, "draw_kg_s", 0.0)
        sv = _find(hidden, "supply_variation")
        s["supply"] = _arr(active, sv, "amplitude", 0.0)
        return s

    def simulate(
        self,
        u: Mapping[str, Array],
        dt: float,
        consts: Mapping[str, Any],
        s: Mapping[str, Any],
        profiles: Profiles,
        x0: Array | None = None,
        n_sub: int = 2,
    ) -> PlantRun:
        """Simulate the tank for a batch (inputs of shape (B, T)).

        States: upper (or only) layer, lower layer (stratification), sensor.
        Profiles: ``tv`` (coil factor change), ``dist`` (heat), ``draw`` (0/1
        draw-off), ``supply`` (relative voltage), ``drift_t`` [h].
        """
        from .effects import backlash

        heat, valve = np.atleast_2d(u["heater"]), np.atleast_2d(u["valve"])
        T_cw, T_amb = np.atleast_2d(u["T_cw"]), np.atleast_2d(u["T_amb"])
        B, n = heat.shape
        C, P, K, G = (
            np.broadcast_to(np.asarray(consts[k], float), (B,))
            for k in ("C", "P_max", "K_coil", "G")
        )
        pos = np.where(s["play"][:, None] > 0, backlash(valve, s["play"]), valve)
        f_h = apply_input_map(heat, s["input_map"])
        f_h = np.where(s["on"][:, None], f_h, heat)
        # resistive heater: P ∝ V²
        sup = (1.0 + s["supply"][:, None] * profiles.get("supply", n)[None]) ** 2
        q_heat = P[:, None] * f_h * sup
        cap = K[:, None] * np.clip(pos, 0.0, 1.0)  # coolant capacity rate [W/K]
        # finite coil: UA ∝ ṁ^0.8 (Dittus-Boelter on the tube side) so NTU ∝ ṁ^-0.2
        ntu = s["ntu0"][:, None] * np.maximum(np.clip(pos, 0, 1), 1e-6) ** -0.2
        eff = np.where(s["ntu0"][:, None] > 0, 1.0 - np.exp(-ntu), 1.0)
        phi = 1.0 + s["tv"][:, None] * profiles.get("tv", n)[None]
        coil = phi * eff * cap
        qd = s["dist_W"][:, None] * profiles.get("dist", n)[None]
        draw = s["draw"][:, None] * WATER_C * profiles.get("draw", n)[None]  # W/K
        frac = np.where(s["G_mix"] > 0, s["frac_low"], 0.0)
        C_up, C_lo = C * (1.0 - frac), np.maximum(C * frac, 1.0)
        strat = s["G_mix"] > 0
        Gmix = s["G_mix"]
        L = s["m_pcm"] * self.L_PCM
        C_pcm = s["m_pcm"] * self.CP_PCM
        tau_s = np.maximum(s["tau_s"], 1e-9)
        has_lag = s["tau_s"] > 0

        def rhs(t: float, x: Array, k: int) -> Array:
            Tu, Tl, Ts = x[:, 0], x[:, 1], x[:, 2]
            # heater and coil sit low in the tank: in the lower layer when it is stratified
            Th = np.where(strat, Tl, Tu)
            q_h = q_heat[:, k] - coil[:, k] * (Th - T_cw[:, k]) - draw[:, k] * (Th - T_cw[:, k])
            loss_u = G * (1.0 - frac) * (Tu - T_amb[:, k])
            loss_l = G * frac * (Tl - T_amb[:, k])
            mix = Gmix * (Tl - Tu)
            Cu = C_up + C_pcm + latent_capacity(Tu, L, s["T_melt"], s["w_melt"])
            dx = np.empty_like(x)
            dx[:, 0] = np.where(
                strat, (mix - loss_u + qd[:, k]) / Cu, (q_h - loss_u + qd[:, k]) / Cu
            )
            dx[:, 1] = np.where(strat, (q_h - mix - loss_l) / C_lo, dx[:, 0])
            dx[:, 2] = np.where(has_lag, (Tu - Ts) / tau_s, 0.0)
            return dx

        if x0 is None:
            x0 = np.repeat(T_amb[:, :1], 3, axis=1)
        xs = rk4(rhs, x0, n, dt, n_sub)
        y = np.where(has_lag[:, None], xs[:, :, 2], xs[:, :, 0])
        # sampling line: the PT100 sits in a recirculation loop, `delay` s downstream
        d = s["out_delay"]
        if np.any(d > 0):
            tt = dt * np.arange(n)
            y = np.stack([np.interp(tt - d[b], tt, y[b]) for b in range(B)])
        y = y + s["offset"][:, None] + s["drift"][:, None] * profiles.get("drift_t", n)[None]
        return PlantRun(
            {"T_tank": y}, xs, {"heater": heat, "valve": valve, "T_cw": T_cw, "T_amb": T_amb}
        )

    @staticmethod
    def steady_state(
        h: float, v: float, T_cw: float, T_amb: float, P: float, K: float, G: float
    ) -> float:
        """Nominal plant's steady temperature [°C] (hand calculation of the balance)."""
        return (P * h + K * v * T_cw + G * T_amb) / (K * v + G)


# ================================================================================= building
class BuildingPlant(Family):
    """Two-zone house heated by an air-to-water heat pump (lumped RC, 2 nodes).

    ::

        C1 dT1/dt = Q_hp + gA1 I + q1(t) − UA1 (1 + δ(t)) (T1 − T_out) − K12 (T1 − T2)
        C2 dT2/dt =        gA2 I        − UA2 (T2 − T_out)            − K12 (T2 − T1)
        Q_hp = COP(T_out) P_el,max f(d),   COP = η (T_sup + 273.15) / (T_sup − T_out)

    (a fraction η of the Carnot COP at a supply temperature T_sup, the form
    heat-pump data sheets follow; EN 14825 reports COP ≈ 3-4.5 at 2-7 °C for
    35 °C supply). The heat pump is driven by a PI thermostat on the
    ground-floor sensor with a night set-back, so the recordings are closed
    loop. Design: 140 m² house, C1 = 14 MJ/K, C2 = 9 MJ/K (air, furniture,
    inner leaves of the walls), UA1 = 95 W/K, UA2 = 60 W/K, K12 = 250 W/K
    (open stair, timber floor), south glazing gA1 = 3.0 m², gA2 = 2.2 m²,
    2.2 kW compressor, η = 0.45, T_sup = 35 °C.
    """

    name = "building"
    exogenous: ClassVar[dict[str, tuple[str, str, str]]] = {
        "hp_demand": ("input", "%", "heat-pump modulation demand of the thermostat"),
        "T_out": ("disturbance", "°C", "outdoor air temperature"),
        "I_sol": ("disturbance", "W/m2", "global irradiance on the south facade"),
    }
    outputs: ClassVar[dict[str, tuple[str, str]]] = {
        "T_z1": ("°C", "ground-floor room sensor (thermostat)"),
        "T_z2": ("°C", "first-floor room sensor"),
    }
    design: ClassVar[dict[str, Design]] = {
        "C1": Design(14e6, "J/K", "ground-floor heat capacity", 2e6, 80e6),
        "C2": Design(9e6, "J/K", "first-floor heat capacity", 1e6, 60e6),
        "UA1": Design(95.0, "W/K", "ground-floor envelope conductance", 20.0, 400.0),
        "UA2": Design(60.0, "W/K", "first-floor envelope conductance", 15.0, 300.0),
        "K12": Design(250.0, "W/K", "conductance between the floors", 20.0, 1000.0),
        "gA1": Design(3.0, "m2", "ground-floor solar aperture", 0.2, 15.0),
        "gA2": Design(2.2, "m2", "first-floor solar aperture", 0.2, 15.0),
        "P_el": Design(2200.0, "W", "compressor power at full demand", 500.0, 8000.0),
        "eta": Design(0.45, "1", "fraction of the Carnot COP", 0.2, 0.7),
    }
    sensors: ClassVar[dict[str, SensorNoise]] = {
        # room sensors: 0.05 K white, local air currents and sun patches 0.1 K over 1-2 h
        "T_z1": SensorNoise(white=0.04, coloured=0.08, tau=3600.0, resolution=0.05),
        "T_z2": SensorNoise(white=0.04, coloured=0.08, tau=5400.0, resolution=0.05),
        "T_out": SensorNoise(white=0.1, coloured=0.2, tau=3600.0, resolution=0.1),
        "I_sol": SensorNoise(white=1.5, coloured=2.0, tau=1800.0, resolution=1.0),
        "q_hp": SensorNoise(white=30.0, coloured=40.0, tau=3600.0, resolution=10.0),
    }
    supports = (
        "missing_dynamics",
        "unmeasured_disturbance",
        "time_varying_parameter",
        "transport_delay",
        "sensor_lag",
        "sensor_offset",
        "sensor_drift",
        "input_nonlinearity",
    )
    T_SUP = 35.0

    def settings(self, hidden: Sequence[Hidden], active: Sequence[Sequence[str]]) -> dict[str, Any]:
        """Numeric settings of the building's hidden effects over a batch."""
        s: dict[str, Any] = {"hidden": list(hidden), "on": _on(active, "input_nonlinearity")}
        md = _find(hidden, "missing_dynamics")
        s["C_m"] = float(md.get("C_m", 1.0)) if md else 1.0
        s["K_m"] = _arr(active, md, "K_m", 0.0)
        d = _find(hidden, "unmeasured_disturbance")
        s["dist_W"] = _arr(active, d, "amplitude_W", 0.0)
        tv = _find(hidden, "time_varying_parameter")
        s["tv"] = _arr(active, tv, "change", 0.0)
        td = _find(hidden, "transport_delay")
        s["delay"] = _arr(active, td, "delay", 0.0)
        lag = _find(hidden, "sensor_lag")
        s["tau_s"] = _arr(active, lag, "tau", 0.0)
        s["lag_signal"] = lag.where if lag else "T_z1"
        off = _find(hidden, "sensor_offset")
        s["offset"] = _arr(active, off, "offset", 0.0)
        s["offset_signal"] = off.where if off else "T_z2"
        dr = _find(hidden, "sensor_drift")
        s["drift"] = _arr(active, dr, "rate", 0.0)
        s["drift_signal"] = dr.where if dr else "T_z2"
        s["input_map"] = _find(hidden, "input_nonlinearity")
        return s

    def cop(self, T_out: Array, eta: Any) -> Array:
        """Heat-pump COP at the outdoor temperature: a fraction of Carnot, capped at 7."""
        return np.clip(
            eta * (self.T_SUP + 273.15) / (self.T_SUP - np.minimum(T_out, 25.0)), 1.0, 7.0
        )

    def simulate(
        self,
        u: Mapping[str, Array],
        dt: float,
        consts: Mapping[str, Any],
        s: Mapping[str, Any],
        profiles: Profiles,
        x0: Array | None = None,
        n_sub: int = 1,
        setpoint: Array | None = None,
        rng: np.random.Generator | None = None,
    ) -> PlantRun:
        """Simulate the house for a batch; the thermostat closes the loop on ``T_z1``.

        ``u`` holds ``T_out`` and ``I_sol`` (B, T); ``hp_demand`` is computed
        by a PI thermostat following ``setpoint`` (T,) from the sensor reading
        (lag and offset included, plus white noise from ``rng``), unless ``u``
        holds ``hp_demand`` itself.
        """
        T_out, I = np.atleast_2d(u["T_out"]), np.atleast_2d(u["I_sol"])
        B, n = T_out.shape
        c = {k: np.broadcast_to(np.asarray(consts[k], float), (B,)) for k in self.design}
        Q1d = s["dist_W"][:, None] * profiles.get("dist", n)[None]
        ua1 = c["UA1"][:, None] * (1.0 + s["tv"][:, None] * profiles.get("tv", n)[None])
        cop = self.cop(T_out, c["eta"][:, None])
        demand = np.zeros((B, n)) if "hp_demand" not in u else np.atleast_2d(u["hp_demand"]).copy()
        closed = "hp_demand" not in u
        imap = s["input_map"]
        Km, Cm = s["K_m"], s["C_m"]
        tau_s = np.maximum(s["tau_s"], 1e-9)
        has_lag = s["tau_s"] > 0
        lag_z1 = s["lag_signal"] == "T_z1"
        delay = s["delay"]
        on = s["on"]
        q_hp = np.zeros((B, n))  # thermal output of the heat pump, logged by a heat meter

        def q_of(d: Array, k: int) -> Array:
            f = apply_input_map(d / 100.0, imap)
            f = np.where(on, f, d / 100.0)
            return cop[:, k] * c["P_el"] * f

        def rhs(t: float, x: Array, k: int) -> Array:
            T1, T2, Tm, Ts = x[:, 0], x[:, 1], x[:, 2], x[:, 3]
            d = held(demand, t, delay, dt)
            Q = q_of(d, k)
            # with a heavy slab (missing dynamics) the heat pump heats the slab, not the air
            to_air = np.where(Km > 0, Km * (Tm - T1), Q)
            dx = np.empty_like(x)
            dx[:, 0] = (
                to_air
                + c["gA1"] * I[:, k]
                + Q1d[:, k]
                - ua1[:, k] * (T1 - T_out[:, k])
                - c["K12"] * (T1 - T2)
            ) / c["C1"]
            dx[:, 1] = (
                c["gA2"] * I[:, k] - c["UA2"] * (T2 - T_out[:, k]) - c["K12"] * (T2 - T1)
            ) / c["C2"]
            dx[:, 2] = np.where(Km > 0, (Q - Km * (Tm - T1)) / Cm, 0.0)
            src = np.where(lag_z1, T1, T2)
            dx[:, 3] = np.where(has_lag, (src - Ts) / tau_s, 0.0)
            return dx

        integ = np.zeros(B)
        kp, ti = 60.0, 6 * 3600.0  # % per K, s: a slow PI, as room thermostats are tuned
        noise = rng if rng is not None else np.random.default_rng(0)

        def thermostat(k: int, x: Array) -> None:
            nonlocal integ
            if closed:
                y1 = np.where(has_lag & lag_z1, x[:, 3], x[:, 0])
                if s["offset_signal"] == "T_z1":
                    y1 = y1 + s["offset"]
                y1 = y1 + 0.04 * noise.standard_normal(B)
                e = setpoint[k] - y1
                raw = kp * e + integ
                d = np.clip(raw, 0.0, 100.0)
                integ = np.where(raw == d, integ + kp * dt / ti * e, integ)
                demand[:, k] = d
            # the heat meter sits at the heat pump: it logs the output as produced (a dead
            # time is the water's way to the house, after the meter)
            q_hp[:, k] = q_of(demand[:, k], k)

        if x0 is None:
            x0 = np.column_stack(
                [np.full(B, 20.0), np.full(B, 19.0), np.full(B, 21.0), np.full(B, 20.0)]
            )
        xs = rk4(rhs, x0, n, dt, n_sub, on_sample=thermostat)
        y1 = np.where((has_lag & lag_z1)[:, None], xs[:, :, 3], xs[:, :, 0])
        y2 = np.where((has_lag & ~lag_z1)[:, None], xs[:, :, 3], xs[:, :, 1])
        ys = {"T_z1": y1, "T_z2": y2}
        for key, sig in (("offset", s["offset_signal"]), ("drift", s["drift_signal"])):
            shape = np.ones(n) if key == "offset" else profiles.get("drift_t", n)
            ys[sig] = ys[sig] + s[key][:, None] * shape[None]
        return PlantRun(
            ys,
            xs,
            {"hp_demand": demand, "T_out": T_out, "I_sol": I, "q_hp": q_hp},
        )


FAMILIES: dict[str, Family] = {f.name: f for f in (PlatePlant(), TankPlant(), BuildingPlant())}
