"""AXT211 test rig: climate chamber, LVDT, thermocouples, power meter (paper 002, section IV).

The true plant
--------------
:class:`AXT211Plant` is a SAUTER AXT211 thermal actuator on a VUL015F310
valve written from its physics (``002_dae2310635fe074e.txt`` sections V-VIII),
not from the identified grey-box model (:mod:`thermogym.models.axt211`, eqs
14-21), which it shares only signal names with. A PTC pill heats a brass
cartridge holding a paraffin charge; the charge melts over a temperature range
and its volume growth pushes a piston against a return spring; the piston moves
the valve stem through a play; a plastic housing loses the heat to the air.

States: PTC temperature ``T_h``, cartridge temperature ``T_w``, melted fraction
``φ``, housing ``T_g``, valve neck ``T_v`` [°C]; piston stroke ``x_p`` and its
friction state ``m`` (−1, 0 stuck, +1); stem stroke ``x_v`` [mm]; electrical
energy ``E`` [J]. Inputs: ``u`` (heater command, the supply fraction), ``k_U``
(no-load supply voltage) [V], ``T_U`` (air around the actuator) [°C].

Equations (sub-steps of at most 0.5 s; heat by the midpoint rule, the piston
exactly between friction events; :mod:`thermogym.rigs._axt211_physics`)::

    R(T_h)  = R_min e^{ln(R_ratio) σ((T_h − T_c)/w_ptc)} (1 + a_ntc max(T_ref − 30 − T_h, 0)),
              σ((T_ref − T_c)/w_ptc) = ln 2 / ln R_ratio   (R(T_ref) = 2 R_min)
    P       = (k_U u R / (R + R_src))² / R
    C_h Ṫ_h = P − G_hw (T_h − T_w) − G_hg (T_h − T_g)
    C_w Ṫ_w = G_hw (T_h − T_w) − G_wg (T_w − T_g) − G_wv (T_w − T_v) − L φ̇
    φ̇       = (φ_m(T_w) − φ)/τ_m if φ < φ_m;  (φ_s(T_w) − φ)/τ_m if φ > φ_s;  else 0
              φ_m = σ((T_w − T_m)/w_m),  φ_s = σ((T_w − T_m + ΔT_hys)/w_m)
    C_g Ṫ_g = G_hg (T_h − T_g) + G_wg (T_w − T_g) − Q_conv − Q_rad
    Q_conv  = c A_g L_g^{−n} |T_g − T_U|^{1+n} sgn(T_g − T_U),  n = 1/4
    Q_rad   = ε σ_SB A_g ((T_g + 273.15)⁴ − (T_U + 273.15)⁴)
    C_v Ṫ_v = G_wv (T_w − T_v) − G_va (T_v − T_U)
    x_free  = S_melt φ + β (T_w − 20 °C)
    F_net   = k_c (x_free − x_p) − F_0 − k_s x_p − k_ol max(x_p − x_max − 2c, 0)
    b_v ẋ_p = F_net − m F_d while moving; stuck while |F_net| <= F_st
    x_v     = play_c(x_p − c) in [0, x_max]                 (the operator of eq 20)

What the rig has that the identified model lacks
------------------------------------------------
:data:`AXT211_EXTRAS`; each row is switched off by ``AXT211Plant(off=[name])``
(``get_rig("axt211", off=[...])``), and tests check each one's sign and size:

{extras}

Every physical parameter has a manufacturing spread (:data:`AXT211_PARAMETERS`;
paper 002 section VIII: "high standard deviation, originated mainly from wax
cartridge manufacture"), except the convection exponent ``n_conv``, which is
the law of laminar free convection and the same on every specimen; specimens
of one production date share a shift of the melting temperature and of the
charge (:func:`specimen_spread`).

Nominal values were chosen (the paper publishes none) so that the plant shows
what paper 002 states: at 24 V and 25 °C the valve starts to move when the
cartridge is at about 60 °C and reaches 4.5 mm after about 5 minutes (section
V); the stroke gain is small at 60 °C and largest at 68 °C (Fig. 3, here the
centre of the melting range); closing is slower than opening (16); 50 % PWM at
high and medium frequency holds the valve in its steep middle range where
specimens differ, on-off operation drives every specimen to its end stops
(section VIII, Fig. 8).

Protocols
---------
``steps``
    Power on for 30 min, off for 60 min, at supply voltages 19, 24, 29 V and
    chamber temperatures 0, 25, 50 °C (the valid ranges of section I).
``pwm``
    The input of section VIII: step 0 → 1 for 1 h, then PWM with 50 % duty at
    high frequency for 2 h, medium for 1.5 h, low for 1.5 h. The paper does not
    give the frequencies; periods of 10 s, 2 min and 20 min are used here (the
    low one is the "on-off operation" the manufacturer recommends).
``spread``
    The ``pwm`` input applied to 15 actuators from three production dates
    (section VIII, Fig. 8), each a specimen drawn from the spread.
``staircase``
    Closed-loop control of the wax temperature through set-points 52 → 70 °C in
    2 °C steps every 30 min, then back down (section VI-C, Fig. 3): shows the
    stroke gain and the hysteresis.

Rig hardware (section IV) and its sensors
-----------------------------------------
Climate chamber (Binder KB 53): the air follows its set-point with a slow
fluctuation of 0.15 K (the chamber's datasheet gives ±0.1-0.3 K); the supply
(24 V transformer) wanders by 0.1 V with the mains. Thermocouples on the
cartridge and the housing (Fluke Hydra): 0.08 K white + 0.05 K coloured noise,
3 s (cartridge) and 5 s (housing) lag, 0.01 K resolution, a 3 K spike about
every 5 h and a held sample now and then. LVDT (Micro-Epsilon): 4 µm white +
3 µm coloured (carrier drift), 1 µm resolution. Power meter 10 mW; R_PTC from
voltage and current (NaN while the heater is off: no current); supply 20 mV.
Sampling 1 s.

Concealed effects (``effect_defaults``; the rig's own physics): a worn rod
coupling with 0.25 mm play (``backlash``); a paraffin grade with twice the
latent heat over a narrower range (``phase_change``); a 15 Ω source
resistance, an undersized transformer shared by several actuators
(``supply_variation``); an actuator in a draught, turbulent convection with
h ∝ ΔT^(1/3) and 2.5× the coefficient (``nonlinear_heat_transfer``); a
thermocouple lagging 45 s (``sensor_lag``), reading 1.5 K high
(``sensor_offset``) or drifting 0.5 K/h (``sensor_drift``); a 3 K, 1 h air
cycle around the actuator the chamber sensor does not see
(``unmeasured_disturbance``); the housing's convection growing 10 %/h as the
chamber's fan speeds up (``time_varying_parameter``); a 20 s delay of the
heater command in a relay module (``transport_delay``).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from thermogym.rigs import _axt211_physics as _ph
from thermogym.rigs.base import (
    ExtraPhysics,
    PhysicalParameter,
    PlantRun,
    Protocol,
    Rig,
    RigRun,
    Specimens,
    TruePlant,
    Turns,
    extras_table,
)
from thermogym.rigs.sensors import N_RANDOM, Sensor, SensorStream

__all__ = [
    "AXT211_EXTRAS",
    "AXT211_PARAMETERS",
    "AXT211Plant",
    "AXT211Rig",
    "pwm_profile",
    "specimen_spread",
]

_CH = "chosen here (paper 002 publishes no values) to reproduce what sections V-VIII state"
_PP = PhysicalParameter

#: Physical parameters of the AXT211 true plant (order = kernel order), with their spread.
AXT211_PARAMETERS: tuple[PhysicalParameter, ...] = (
    _PP("R_min", 81.0, "Ohm", "PTC minimum resistance", "chosen: ~6 W cold at 24 V",
        0.10, "relative", "PTC datasheets: R_25 ±25 % (≈ 2.5 σ)", 20.0, 300.0),
    _PP("T_ref", 97.0, "°C", "PTC reference temperature (R = 2 R_min)",
        "chosen: self-regulation above the full-stroke temperature", 2.0, "absolute",
        "PTC datasheets: T_ref ±5 K", 60.0, 140.0),
    _PP("w_ptc", 5.0, "K", "width of the PTC's switching step (ln R logistic)",
        "PTC datasheets: 10-25 %/K slope near T_ref", 0.10, "relative", "chosen", 1.0, 20.0),
    _PP("R_ratio", 1000.0, "1", "R_max / R_min of the PTC", "PTC datasheets: 10³-10⁴",
        0.25, "relative", "PTC datasheets: R_max is a minimum, pieces exceed it", 10.0, 1e5),
    _PP("a_ntc", 0.006, "1/K", "NTC slope below the PTC's minimum",
        "PTC datasheets: R_25 ≈ 1.2-1.4 R_min", 0.15, "relative", "chosen", 0.0, 0.05),
    _PP("R_src", 1.0, "Ohm", "supply source resistance (transformer + cable)",
        "24 V / 50 VA safety transformer, ~5 % regulation, plus 2 × 10 m of 0.75 mm²", 0.2,
        "relative", "installation", 0.0, 50.0),
    _PP("C_h", 3.0, "J/K", "heat capacity of the PTC pill, contacts and spreader",
        "~3 g ceramic + 2 g aluminium", 0.08, "relative", "chosen", 0.5, 20.0),
    _PP("C_w", 10.0, "J/K", "sensible heat capacity of cartridge, charge and piston",
        "brass cup ~15 g (5.7 J/K) + 1.2 g paraffin (2.5 J/K) + piston", 0.05, "relative",
        "chosen", 5.0, 60.0),
    _PP("L_w", 220.0, "J", "latent heat of the paraffin charge",
        "1.16 g × 190 J/g (paraffin heat of fusion, 150-250 J/g)", 0.06, "relative",
        "charge mass and wax grade", 0.0, 2000.0),
    _PP("T_m", 68.0, "°C", "centre of the melting range (largest stroke gain)",
        "paper 002 Fig. 3: gain largest at 68 °C", 0.6, "absolute",
        "paper 002 VIII: spread from the cartridge manufacture", 55.0, 80.0),
    _PP("w_m", 3.0, "K", "width of the melting range (logistic scale)",
        "paper 002 V-VI: stroke from ~60 °C, gain small at 60 °C", 0.10, "relative",
        "wax blend", 0.5, 8.0),
    _PP("dT_hys", 1.5, "K", "solidification below melting (hysteresis)",
        "paraffin DSC: crystallisation 1-3 K below melting", 0.3, "absolute", "wax blend",
        0.0, 5.0),
    _PP("tau_m", 12.0, "s", "time constant of the melt front", _CH, 0.2, "relative",
        "charge geometry", 1.0, 120.0),
    _PP("C_g", 45.0, "J/K", "heat capacity of housing, insert and air", "~35 g PA/PC + metal",
        0.05, "relative", "chosen", 10.0, 200.0),
    _PP("C_v", 70.0, "J/K", "heat capacity of the valve neck (adaptor ring + bonnet)",
        "~180 g brass × 0.38 J/(g K)", 0.05, "relative", "chosen", 10.0, 400.0),
    _PP("G_hw", 0.40, "W/K", "contact conductance PTC → cartridge",
        "~1 cm² pressed contact, h ≈ 4000 W/(m²K)", 0.15, "relative", "assembly", 0.05, 2.0),
    _PP("G_hg", 0.02, "W/K", "PTC → housing (contact springs, air)", _CH, 0.20, "relative",
        "assembly", 0.0, 0.2),
    _PP("G_wg", 0.08, "W/K", "cartridge → housing (air gap, insert)", _CH, 0.10, "relative",
        "assembly", 0.01, 0.5),
    _PP("G_wv", 0.03, "W/K", "cartridge → valve neck (threaded adaptor)", _CH, 0.15,
        "relative", "mounting torque", 0.0, 0.5),
    _PP("G_va", 0.08, "W/K", "valve neck → surroundings (body, pipes)", _CH, 0.15,
        "relative", "installation", 0.005, 1.0),
    _PP("A_g", 0.0095, "m²", "housing surface", "AXT211 housing ~44 × 60 mm", 0.03,
        "relative", "moulding", 0.002, 0.05),
    _PP("L_g", 0.06, "m", "housing height (convection length)", "AXT211 housing", 0.005,
        "relative", "moulding and mounting height, ±0.3 mm", 0.01, 0.5),
    _PP("c_conv", 1.42, "W/(m^1.75 K^1.25)", "natural convection coefficient",
        "Holman, Heat Transfer: h = 1.42 (ΔT/L)^1/4, laminar vertical plate in air", 0.10,
        "relative", "air flow around the mounting", 0.3, 10.0),
    _PP("n_conv", 0.25, "1", "convection exponent (h ∝ ΔT^n)", "laminar natural convection",
        0.0, "relative", "a law of laminar free convection, not a property of a specimen",
        0.0, 1.0),
    _PP("eps", 0.90, "1", "emissivity of the housing", "polymer surfaces 0.85-0.95", 0.02,
        "absolute", "surface", 0.1, 1.0),
    _PP("S_melt", 6.0, "mm", "stroke of the melting charge's volume growth",
        "~12 % volume change of 1.3 cm³ paraffin over a 6 mm piston", 0.03, "relative",
        "paper 002 VIII: charge filling", 3.0, 9.0),
    _PP("beta_x", 0.010, "mm/K", "stroke per kelvin of the charge's thermal expansion",
        "paraffin ~1e-3 1/K volumetric", 0.10, "relative", "chosen", 0.0, 0.05),
    _PP("k_c", 150.0, "N/mm", "stiffness of charge and rubber plug", _CH, 0.10, "relative",
        "plug rubber", 20.0, 2000.0),
    _PP("F_0", 90.0, "N", "return-spring preload (actuator + valve)",
        "AXT211 thrust 100 N class; valve spring", 0.08, "relative", "spring tolerance", 0.0,
        300.0),
    _PP("k_s", 8.0, "N/mm", "return-spring rate", "spring tolerance", 0.05, "relative",
        "spring tolerance", 0.0, 100.0),
    _PP("F_st", 12.0, "N", "static friction (stem gland, piston seal)", "O-ring seals", 0.30,
        "relative", "seal friction scatter", 0.0, 100.0),
    _PP("F_d", 8.0, "N", "dynamic friction", "O-ring seals", 0.30, "relative",
        "seal friction scatter", 0.0, 100.0),
    _PP("b_v", 300.0, "N s/mm", "damping of the plug's flow (mechanical lag ~2 s)", _CH, 0.20,
        "relative", "plug rubber", 10.0, 5000.0),
    _PP("k_ol", 60.0, "N/mm", "overload spring beyond the valve's end stop",
        "paper 002 V: overload-protected cartridge", 0.10, "relative", "spring tolerance", 1.0,
        1000.0),
    _PP("c_backlash", 0.10, "mm", "half-width of the play in the rod coupling",
        "paper 002 eq 20 (visible in Fig. 3)", 0.05, "uniform", "coupling tolerances", 0.0,
        1.0),
    _PP("x_max", 4.5, "mm", "valve stroke (end stop)", "paper 002 V: 4.5 mm stroke", 0.01,
        "relative", "seat and stop positions of valve and adaptor, ±0.05 mm", 1.0, 10.0),
)  # fmt: skip

#: The rig's table (see the module docstring): physics the identified model lacks.
AXT211_EXTRAS: tuple[ExtraPhysics, ...] = (
    ExtraPhysics("ptc_switching", "PTC resistance steep around its reference temperature",
                 "PTC heater datasheet R(T) curves; paper 002 VI-A (model: polynomial, eq 14)",
                 "R doubles at T_ref 97 °C, x1000 over ~30 K", "a fixed resistor R_min"),
    ExtraPhysics("ptc_node", "the PTC is a heat capacity of its own, hotter than the cartridge",
                 "contact conductance of a pressed ceramic pill (model: one node, eq 17)",
                 "C_h 3 J/K, G_hw 0.4 W/K: 15 K above the cartridge at 6 W",
                 "PTC and cartridge one lumped node"),
    ExtraPhysics("latent_heat", "heat of fusion of the paraffin charge",
                 "paraffin 150-250 J/g (handbook); paper 002 VI-B (model: constant C_P)",
                 "220 J (1.16 g): +18 J/K at the melt centre on a sensible 13 J/K", "L = 0"),
    ExtraPhysics("melt_hysteresis", "the charge solidifies below its melting range",
                 "DSC of paraffins: crystallisation 1-3 K below melting (model: eq 20 only)",
                 "1.5 K: ~0.7 mm more stroke on cooling at 66 °C", "one curve for both ways"),
    ExtraPhysics("melt_kinetics", "the melt front lags the cartridge temperature",
                 "conduction into the charge (model: tau_P, eq 19)", "tau_m 12 s",
                 "the melted fraction on its curve at once"),
    ExtraPhysics("natural_convection", "housing convection grows as dT^1.25",
                 "Holman: h = 1.42 (dT/L)^0.25, laminar vertical plate (model: lambda_GU)",
                 "h 6.0 W/(m2 K) at 20 K, 3.4 at 2 K", "linear at dT = 20 K"),
    ExtraPhysics("radiation", "the housing radiates as a grey body",
                 "Stefan-Boltzmann, emissivity 0.9 of polymers (model: in lambda_GU)",
                 "5.4 W/(m2 K) at 25 °C, +27 % at 50 °C", "linear, fixed at 35 °C"),
    ExtraPhysics("valve_neck", "the cartridge conducts into the valve's neck, a slow store",
                 "brass adaptor and bonnet, ~180 g (model: no such node)",
                 "C_v 70 J/K, G_wv 0.03, G_va 0.08 W/K: 1.0 of 4.7 W held fully open",
                 "G_wv = 0"),
    ExtraPhysics("spring_preload", "the stroke starts once the thrust exceeds the preload",
                 "return spring and rubber plug stiffness (model: T_P0, eq 19)",
                 "90 N / 150 N/mm: 0.6 mm of free stroke; the stem waits for the melt (59 °C, "
                 "30 °C without)", "F_0 = 0"),
    ExtraPhysics("friction", "static and dynamic friction of stem gland and piston seal",
                 "O-ring seal friction (model: none)", "12 N / 8 N: +-0.08 mm stuck band",
                 "no friction"),
    ExtraPhysics("source_resistance", "the supply sags under the heater current",
                 "24 V safety transformer regulation + cable (model: k_U at the PTC, eq 15)",
                 "1 Ohm: -2.0 % power cold", "0 Ohm"),
)  # fmt: skip

__doc__ = (__doc__ or "").replace("{extras}", extras_table(AXT211_EXTRAS))
_NAMES = tuple(p.name for p in AXT211_PARAMETERS)
_SWITCHES = tuple(e.name for e in AXT211_EXTRAS)
assert len(_NAMES) == _ph.N_PARAMS and len(_SWITCHES) == _ph.N_SWITCHES

_RECORDED_OUT = ("P_PTC", "R_PTC", "T_P", "T_G", "x_V")
_UNITS = {
    "u": "1",
    "k_U": "V",
    "T_U": "°C",
    "P_PTC": "W",
    "R_PTC": "Ohm",
    "T_P": "°C",
    "T_G": "°C",
    "x_V": "mm",
}
_ROLES = {
    "u": "input",
    "k_U": "disturbance",
    "T_U": "disturbance",
    **{k: "output" for k in _RECORDED_OUT},
}
_HIDDEN = ("T_ptc", "phi", "T_valve", "x_piston", "F_stuck", "E_el")


class AXT211Plant(TruePlant):
    """The AXT211's true plant: PTC, melting charge, housing, piston and stem (batched).

    Parameters
    ----------
    off : iterable of str
        Rows of :data:`AXT211_EXTRAS` to switch off.
    effects : sequence of str or EffectSpec
        Concealed plant effects (``backlash``, ``phase_change``,
        ``supply_variation``, ``nonlinear_heat_transfer``,
        ``unmeasured_disturbance``, ``time_varying_parameter``,
        ``transport_delay``), in the rig's physics.

    Examples
    --------
    >>> import numpy as np
    >>> plant = AXT211Plant()
    >>> u = np.column_stack([np.ones(601), np.full(601, 24.0), np.full(601, 25.0)])
    >>> run = plant.simulate(u, 1.0, plant.nominal())
    >>> bool(run.output("x_V")[0, -1] > 4.4)
    True
    """

    name = "axt211"
    input_names = ("u", "k_U", "T_U")
    output_names = _RECORDED_OUT
    hidden_names = _HIDDEN
    state_names = ("T_h", "T_w", "phi", "T_g", "T_v", "x_p", "m", "x_v", "E")
    units: ClassVar[dict[str, str]] = {
        **_UNITS, "T_ptc": "°C", "phi": "1", "T_valve": "°C", "x_piston": "mm",
        "F_stuck": "1", "E_el": "J",
    }  # fmt: skip
    max_step = 0.5
    parameters = AXT211_PARAMETERS
    extras = AXT211_EXTRAS
    supported_effects = (
        "backlash",
        "phase_change",
        "supply_variation",
        "nonlinear_heat_transfer",
        "unmeasured_disturbance",
        "time_varying_parameter",
        "transport_delay",
    )
    effect_defaults: ClassVar[dict[str, dict[str, Any]]] = {
        # a worn rod coupling
        "backlash": {"c_backlash": 0.25},
        # a paraffin grade with twice the latent heat melting over a narrower range
        "phase_change": {"latent_factor": 2.0, "width_factor": 0.5},
        # an undersized transformer shared by several actuators
        "supply_variation": {"R_src": 15.0},
        # a draught: turbulent convection (h ∝ ΔT^(1/3)), 2.5x the laminar coefficient
        "nonlinear_heat_transfer": {"factor": 2.5, "n_conv": 1.0 / 3.0},
        # an air cycle around the actuator that the chamber sensor does not see
        "unmeasured_disturbance": {"signal": "T_U", "amplitude": 3.0, "period": 3600.0},
        # the chamber's fan speeds up: convection grows
        "time_varying_parameter": {"name": "c_conv", "rate": 0.1},
        # a relay module delays the heater command
        "transport_delay": {"signal": "u", "delay": 20.0},
    }

    # ---- parameters as the kernel sees them (plant effects applied)
    def kernel_params(self, specimens: Specimens) -> NDArray[np.float64]:
        """(B, N_PARAMS) parameter array in kernel order, concealed effects applied.

        Cached for the last :class:`Specimens` object (treated as immutable).
        """
        cached = getattr(self, "_kp", None)
        if cached is not None and cached[0] is specimens:
            return cached[1]
        p = self._kernel_params(specimens)
        self._kp = (specimens, p)
        return p

    def _kernel_params(self, specimens: Specimens) -> NDArray[np.float64]:
        p = specimens.array(_NAMES)
        j = _NAMES.index
        s = self.effect("backlash")
        if s is not None:
            p[:, j("c_backlash")] = float(s.get("c_backlash", s.get("c", 0.25)))
        s = self.effect("phase_change")
        if s is not None:
            p[:, j("L_w")] *= float(s["latent_factor"])
            p[:, j("w_m")] *= float(s["width_factor"])
        s = self.effect("supply_variation")
        if s is not None:
            p[:, j("R_src")] = float(s["R_src"])
        s = self.effect("nonlinear_heat_transfer")
        if s is not None:
            p[:, j("c_conv")] *= float(s["factor"])
            p[:, j("n_conv")] = float(s["n_conv"])
        return np.ascontiguousarray(p)

    def _switches(self) -> NDArray[np.float64]:
        sw = getattr(self, "_sw", None)
        if sw is None:
            sw = self._sw = _ph.switch_vector(self.switches, _SWITCHES)
        return sw

    # ---- TruePlant
    def initial_state(self, specimens: Specimens, u0: NDArray[np.float64]) -> NDArray[np.float64]:
        """At rest in air at T_U: every node at T_U, charge solid, piston seated, valve shut."""
        B = specimens.n
        TU = np.broadcast_to(np.asarray(u0, dtype=float).reshape(-1, 3)[:, 2], (B,))
        p = self.kernel_params(specimens)
        return np.stack([self.rest_state(p[b], float(TU[b])) for b in range(B)])

    def rest_state(self, p: NDArray[np.float64], T: float) -> NDArray[np.float64]:
        """Rest state of one specimen (kernel parameters ``p``) long unpowered at ``T`` [°C].

        The charge is on its cooling curve (solid below its melting range); a
        charge warm enough to push holds the piston where the spring balances it.
        """
        sw = self._switches()
        x = np.zeros(_ph.N_STATES)
        x[_ph.X_TH] = x[_ph.X_TW] = x[_ph.X_TG] = x[_ph.X_TV] = T
        x[_ph.X_PHI] = _ph.melt_targets(T, p, sw)[1]
        for _ in range(200):  # settle the piston and stem (quasi-static, 1 s steps)
            _ph.mechanics(x, 1.0, p, sw)
        x[_ph.X_M] = 0.0
        return x

    def step(
        self,
        x: NDArray[np.float64],
        u: NDArray[np.float64],
        dt: float | NDArray[np.float64],
        specimens: Specimens,
        turns: Turns | None = None,
    ) -> NDArray[np.float64]:
        """Advance every specimen by ``dt`` (scalar or (B,)) with ``u`` (B, 3) held.

        ``turns``: note the turns of one state over the sub-steps there (:class:`Turns`).
        """
        B = specimens.n
        xn = np.array(x, dtype=float, copy=True)
        ub = np.ascontiguousarray(np.broadcast_to(np.asarray(u, dtype=float), (B, 3)))
        d = self.substeps(dt, self.max_step, B)
        p, sw = self.kernel_params(specimens), self._switches()
        if turns is None:
            _ph.step_batch(xn, ub, d, p, sw, self.max_step)
        else:
            _ph.step_batch_noting(
                xn, ub, d, p, sw, self.max_step, turns.column, turns.state, turns.values
            )
        return xn

    def outputs(
        self, x: NDArray[np.float64], u: NDArray[np.float64], specimens: Specimens
    ) -> NDArray[np.float64]:
        """P_PTC, R_PTC, T_P, T_G, x_V of every specimen, shape (B, 5)."""
        B = specimens.n
        ub = np.broadcast_to(np.asarray(u, dtype=float), (B, 3))
        p = self.kernel_params(specimens)
        sw = self._switches()
        y = np.empty((B, 5))
        for b in range(B):
            _ph.outputs(x[b], ub[b, 0], ub[b, 1], p[b], sw, y[b])
        return y

    def hidden(
        self, x: NDArray[np.float64], specimens: Specimens
    ) -> dict[str, NDArray[np.float64]]:
        """PTC temperature, melted fraction, valve neck, piston stroke, stuck flag, energy."""
        return {
            "T_ptc": x[:, _ph.X_TH].copy(),
            "phi": x[:, _ph.X_PHI].copy(),
            "T_valve": x[:, _ph.X_TV].copy(),
            "x_piston": x[:, _ph.X_XP].copy(),
            "F_stuck": (x[:, _ph.X_M] == 0.0).astype(float),
            "E_el": x[:, _ph.X_E].copy(),
        }

    def plant_inputs(self, u: NDArray[np.float64], dt: float, t0: float) -> NDArray[np.float64]:
        """Delay the heater command, add the unseen air cycle (concealed effects)."""
        out = u
        s = self.effect("transport_delay")
        if s is not None:
            out = out.copy()
            col = self.input_names.index(str(s["signal"]))
            shift = float(s["delay"]) / dt
            idx = np.arange(out.shape[1])
            for b in range(out.shape[0]):
                out[b, :, col] = np.interp(idx - shift, idx, u[b, :, col], left=u[b, 0, col])
        s = self.effect("unmeasured_disturbance")
        if s is not None:
            out = out.copy() if out is u else out
            col = self.input_names.index(str(s["signal"]))
            t = t0 + dt * np.arange(out.shape[1])
            phase = float(s.get("phase", 0.0))
            out[:, :, col] += float(s["amplitude"]) * np.sin(
                2 * np.pi * t / float(s["period"]) + phase
            )
        return out

    def _simulate(
        self,
        u: NDArray[np.float64],
        dt: float,
        specimens: Specimens,
        x: NDArray[np.float64],
        t0: float,
    ) -> PlantRun:
        B, T, _ = u.shape
        p = self.kernel_params(specimens).copy()
        sw = self._switches()
        y = np.empty((B, T, 5))
        xs = np.empty((B, T, _ph.N_STATES))
        s = self.effect("time_varying_parameter")
        if s is None:
            _ph.simulate_batch(np.ascontiguousarray(x), u, dt, p, sw, self.max_step, y, xs)
        else:
            # the parameter changes in 60-sample chunks (piecewise constant), state carried over
            j = _NAMES.index(str(s["name"]))
            rate = float(s["rate"])
            base = p[:, j].copy()
            xc = np.ascontiguousarray(x)
            for a in range(0, T, 60):
                b = min(a + 61, T)
                p[:, j] = base * (1.0 + rate * (t0 + dt * 0.5 * (a + b - 1)) / 3600.0)
                yc = np.empty((B, b - a, 5))
                xsc = np.empty((B, b - a, _ph.N_STATES))
                _ph.simulate_batch(xc, np.ascontiguousarray(u[:, a:b]), dt, p, sw,
                                   self.max_step, yc, xsc)  # fmt: skip
                n = min(60, T - a)
                y[:, a : a + n] = yc[:, :n]
                xs[:, a : a + n] = xsc[:, :n]
                if a + 60 < T:
                    xc = np.ascontiguousarray(xsc[:, 60])
        hid = {k: np.empty((B, T)) for k in _HIDDEN}
        for k in range(T):
            for name, v in self.hidden(xs[:, k], specimens).items():
                hid[name][:, k] = v
        return PlantRun(t0 + dt * np.arange(T, dtype=np.float64), u, y, xs, hid, self.output_names)

    # ---- derived physical quantities (for comparisons with identified models)
    def derived(self, specimens: Specimens) -> dict[str, NDArray[np.float64]]:
        """Physical quantities of each specimen that an outside observer could measure.

        ``C_sensible`` [J/K]: heat capacity of PTC and cartridge without the
        latent heat; ``G_to_housing`` [W/K]: conductance from PTC and cartridge
        to the housing; ``C_housing`` [J/K]: heat capacity of the housing;
        ``G_housing_air`` [W/K]: the housing's loss conductance to the air
        (convection and radiation) at 20 K excess over 25 °C;
        ``T_stroke_start`` [°C]: cartridge temperature at which, heated slowly,
        the piston reaches the middle of the coupling's play (the stem's
        contact point), friction aside; ``tau_melt`` [s]; ``play`` [mm]
        (half-width); ``stroke`` [mm].
        """
        p = self.kernel_params(specimens)
        sw = self._switches()
        B = specimens.n
        node = self.is_on("ptc_node")
        out = {
            "C_sensible": p[:, _ph.P_CH] + p[:, _ph.P_CW],
            "G_to_housing": p[:, _ph.P_GWG] + (p[:, _ph.P_GHG] if node else 0.0),
            "C_housing": p[:, _ph.P_CG].copy(),
            "G_housing_air": np.array(
                [_ph.housing_loss(45.0, 25.0, p[b], sw) / 20.0 for b in range(B)]
            ),
            "tau_melt": p[:, _ph.P_TAUM].copy(),
            "play": p[:, _ph.P_C].copy(),
            "stroke": p[:, _ph.P_XMAX].copy(),
        }
        start = np.empty(B)
        for b in range(B):
            q = p[b]
            F0 = q[_ph.P_F0] if self.is_on("spring_preload") else 0.0
            c = q[_ph.P_C]

            def excess(T: float, q: NDArray[np.float64] = q, F0: float = F0, c: float = c) -> float:
                phi = _ph.melt_targets(T, q, sw)[0]
                return q[_ph.P_KC] * (_ph.free_stroke(T, phi, q) - c) - F0 - q[_ph.P_KS] * c

            lo, hi = 0.0, 150.0
            for _ in range(60):  # bisection: the thrust grows with temperature
                mid = 0.5 * (lo + hi)
                lo, hi = (mid, hi) if excess(mid) < 0.0 else (lo, mid)
            start[b] = 0.5 * (lo + hi)
        out["T_stroke_start"] = start
        return out

    # ---- specimens of production dates
    def draw_specimens(
        self, rng: np.random.Generator, n: int, dates: int | None = None
    ) -> Specimens:
        """``n`` specimens; with ``dates``, specimen i from production date ``i % dates``.

        Specimens of one date share a shift of the melting temperature
        (uniform ±0.7 K) and of the charge (±2 %) on top of their own spread:
        the same wax batch and filling setting (paper 002 section VIII).
        """
        spec = super().draw_specimens(rng, n)
        if not dates:
            return spec
        shift_T = rng.uniform(-0.7, 0.7, int(dates))
        shift_S = 1.0 + rng.uniform(-0.02, 0.02, int(dates))
        d = np.arange(spec.n) % int(dates)
        return spec.replace(
            {"T_m": spec["T_m"] + shift_T[d], "S_melt": spec["S_melt"] * shift_S[d]}
        )


def specimen_spread(rng: np.random.Generator, n: int = 15, dates: int = 3) -> Specimens:
    """``n`` AXT211 specimens from ``dates`` production dates (paper 002 section VIII).

    Examples
    --------
    >>> s = specimen_spread(np.random.default_rng(0), n=4)
    >>> s.n, bool(np.ptp(s["T_m"]) > 0)
    (4, True)
    """
    return AXT211Plant().draw_specimens(rng, n, dates=dates)


def pwm_profile(t: np.ndarray, period: float, duty: float = 0.5) -> np.ndarray:
    """On/off signal with the given period [s] and duty cycle, starting on.

    Examples
    --------
    >>> pwm_profile(np.arange(6.0), period=4.0).tolist()
    [1.0, 1.0, 0.0, 0.0, 1.0, 1.0]
    """
    return ((np.mod(t, period) / period) < duty).astype(float)


def _draws(rng: np.random.Generator) -> np.ndarray:
    # random numbers of one sensor sample (SensorStream layout: 2 normal, 4 uniform)
    return np.concatenate([rng.standard_normal(2), rng.random(N_RANDOM - 2)])[None]


def _ou(rng: np.random.Generator, n: int, dt: float, sigma: float, tau: float) -> np.ndarray:
    # stationary Ornstein-Uhlenbeck series (slow fluctuations of the rig's supplies)
    a = np.exp(-dt / tau)
    z = rng.standard_normal(n)
    out = np.empty(n)
    out[0] = sigma * z[0]
    for k in range(1, n):
        out[k] = a * out[k - 1] + sigma * np.sqrt(1 - a * a) * z[k]
    return out


class AXT211Rig(Rig):
    """Virtual AXT211 test bench (paper 002, section IV)."""

    name = "axt211"
    plant_cls = AXT211Plant
    sensors: ClassVar[dict[str, Sensor]] = {
        "P_PTC": Sensor(0.01, 0.001, source="power meter, 10 mW"),
        "R_PTC": Sensor(0.5, 0.01, source="voltage / current, 0.5 Ω"),
        "T_P": Sensor(0.08, 0.01, colored=0.05, colored_tau=900.0, lag=3.0, spike_rate=0.2,
                      spike_size=3.0, dropout_rate=0.2, dropout_s=4.0, dropout="hold",
                      source="type K thermocouple on the cartridge, Fluke Hydra"),
        "T_G": Sensor(0.08, 0.01, colored=0.05, colored_tau=900.0, lag=5.0, spike_rate=0.2,
                      spike_size=3.0, dropout_rate=0.2, dropout_s=4.0, dropout="hold",
                      source="type K thermocouple on the housing, Fluke Hydra"),
        "x_V": Sensor(0.004, 0.001, colored=0.003, colored_tau=1800.0,
                      source="LVDT, Micro-Epsilon; carrier drift"),
        "k_U": Sensor(0.02, 0.01, source="DAQ, 20 mV"),
        "T_U": Sensor(0.08, 0.01, colored=0.03, colored_tau=900.0, lag=10.0,
                      source="chamber air thermocouple"),
    }  # fmt: skip
    supported_effects = (
        *AXT211Plant.supported_effects,
        "sensor_lag",
        "sensor_offset",
        "sensor_drift",
    )
    effect_defaults: ClassVar[dict[str, dict[str, Any]]] = {
        **AXT211Plant.effect_defaults,
        "sensor_lag": {"signal": "T_P", "tau": 45.0},
        "sensor_offset": {"signal": "T_P", "offset": 1.5},
        "sensor_drift": {"signal": "T_P", "rate": 0.5},
    }

    def __init__(self, effects: Sequence[Any] = (), *, off: Sequence[str] = ()) -> None:
        super().__init__(effects, off=off)
        self.check_sensor_effects(self.sensors)

    def conditions(
        self, rng: np.random.Generator, n: int, dt: float, supply_V: float, ambient_C: float
    ) -> tuple[np.ndarray, np.ndarray]:
        """True supply and chamber air over ``n`` samples: set-points plus slow fluctuations."""
        kU = supply_V + _ou(rng, n, dt, 0.1, 1800.0)
        TU = ambient_C + _ou(rng, n, dt, 0.15, 900.0)
        return kU, TU

    def record_runs(
        self,
        ids: Sequence[str],
        u: np.ndarray,
        dt: float,
        rng: np.random.Generator,
        metas: Sequence[dict[str, Any]],
        specimens: Specimens | None = None,
    ) -> list[RigRun]:
        """Simulate true inputs ``u`` (B, T, 3) on B specimens and record each through the sensors.

        The recorded ``u`` is the command; ``k_U`` and ``T_U`` are measured.
        """
        plant = self.plant()
        spec = specimens if specimens is not None else self._batch(u.shape[0])
        run = plant.simulate(u, dt, spec)
        t = dt * np.arange(u.shape[1], dtype=np.float64)
        out = []
        for b, (eid, meta) in enumerate(zip(ids, metas, strict=True)):
            truth = {n: run.outputs[b, :, i] for i, n in enumerate(plant.output_names)}
            truth.update({n: v[b] for n, v in run.hidden.items()})
            truth.update({"k_U": u[b, :, 1], "T_U": u[b, :, 2]})
            measured = self.measure({k: truth[k] for k in _RECORDED_OUT}, rng, t)
            # no current, no resistance: R_PTC exists only while the heater is on
            measured["R_PTC"] = np.where(u[b, :, 0] > 0, measured["R_PTC"], np.nan)
            exo = self.measure({"k_U": u[b, :, 1], "T_U": u[b, :, 2]}, rng, t)
            cols = {"u": u[b, :, 0].copy(), **exo, **measured}
            out.append(RigRun(eid, t, cols, dict(_UNITS), dict(_ROLES), dict(meta), truth=truth))
        return out

    def _batch(self, n: int) -> Specimens:
        s = self.specimen
        return s.take(np.zeros(n, dtype=np.int64))


def _steps(
    rig: AXT211Rig,
    rng: np.random.Generator,
    *,
    voltages=(19.0, 24.0, 29.0),
    ambients=(0.0, 25.0, 50.0),
    on_s: float = 1800.0,
    off_s: float = 3600.0,
    dt: float = 1.0,
) -> list[RigRun]:
    n_on, n = int(on_s / dt), int((on_s + off_s) / dt)
    cases = [(kU, TU) for kU in voltages for TU in ambients]
    u = np.zeros((len(cases), n, 3))
    for i, (kU, TU) in enumerate(cases):
        u[i, :n_on, 0] = 1.0
        u[i, :, 1], u[i, :, 2] = rig.conditions(rng, n, dt, kU, TU)
    ids = [f"axt211-step-{kU:g}V-{TU:g}C" for kU, TU in cases]
    metas = [{"supply_V": kU, "ambient_C": TU, "on_s": on_s} for kU, TU in cases]
    return rig.record_runs(ids, u, dt, rng, metas)


def _pwm_command(dt: float, periods: tuple[float, float, float]) -> np.ndarray:
    t = dt * np.arange(int(6 * 3600 / dt))
    h = t / 3600.0
    u = np.where(h <= 1, 1.0, 0.0)
    for (a, b), period in zip(((1, 3), (3, 4.5), (4.5, 6.0)), periods, strict=True):
        sel = (h > a) & (h <= b)
        u[sel] = pwm_profile(t[sel] - a * 3600.0, period)
    return u


def _pwm(
    rig: AXT211Rig,
    rng: np.random.Generator,
    *,
    periods=(10.0, 120.0, 1200.0),
    supply_V: float = 24.0,
    ambient_C: float = 25.0,
    dt: float = 1.0,
) -> list[RigRun]:
    cmd = _pwm_command(dt, tuple(periods))
    u = np.zeros((1, cmd.size, 3))
    u[0, :, 0] = cmd
    u[0, :, 1], u[0, :, 2] = rig.conditions(rng, cmd.size, dt, supply_V, ambient_C)
    meta = {"periods_s": list(periods), "duty": 0.5, "supply_V": supply_V, "ambient_C": ambient_C}
    return rig.record_runs(["axt211-pwm"], u, dt, rng, [meta])


def _spread(
    rig: AXT211Rig,
    rng: np.random.Generator,
    *,
    n: int = 15,
    periods=(10.0, 120.0, 1200.0),
    dt: float = 1.0,
) -> list[RigRun]:
    specimens = AXT211Plant(off=rig.off).draw_specimens(rng, n, dates=3)
    cmd = _pwm_command(dt, tuple(periods))
    u = np.zeros((n, cmd.size, 3))
    u[:, :, 0] = cmd
    # one chamber run: every actuator sees the same air and supply (section VIII)
    kU, TU = rig.conditions(rng, cmd.size, dt, 24.0, 25.0)
    u[:, :, 1], u[:, :, 2] = kU, TU
    ids = [f"axt211-spread-{i + 1:02d}" for i in range(n)]
    metas = [
        {"specimen": i + 1, "production_date": i % 3 + 1, "periods_s": list(periods)}
        for i in range(n)
    ]
    return rig.record_runs(ids, u, dt, rng, metas, specimens=specimens)


def _staircase(
    rig: AXT211Rig,
    rng: np.random.Generator,
    *,
    low: float = 52.0,
    high: float = 70.0,
    step: float = 2.0,
    hold_s: float = 1800.0,
    supply_V: float = 24.0,
    ambient_C: float = 25.0,
    dt: float = 1.0,
) -> list[RigRun]:
    up = np.arange(low, high + 1e-9, step)
    levels = np.concatenate([up, up[-2::-1]])
    n_hold = int(hold_s / dt)
    sp = np.repeat(levels, n_hold)
    n = sp.size
    plant = rig.plant()
    spec = rig.specimen
    kU, TU = rig.conditions(rng, n, dt, supply_V, ambient_C)
    uu = np.zeros((1, n, 3))
    uu[0, :, 1], uu[0, :, 2] = kU, TU
    seen = plant.plant_inputs(uu, dt, 0.0)  # supply and air as the plant sees them
    delay = plant.effect("transport_delay")
    lag_n = round(float(delay["delay"]) / dt) if delay is not None else 0
    x = plant.initial_state(spec, seen[:, 0])
    # the loop reads the cartridge thermocouple sample by sample (its lag and noise included)
    stream = SensorStream(rig.sensor("T_P"), 1)
    stream.start([0], x[:, 1], _draws(rng))
    T_meas = float(stream.first([0], _draws(rng))[0])
    ys = np.empty((n, 5))
    xs = np.empty((n, x.shape[1]))
    # PI on the measured wax temperature; the output is the heating-power fraction, turned
    # into u by u = sqrt(fraction) since P ∝ (k_U u)² (paper 002 eq 15)
    kp, ti, integ = 0.15, 300.0, 0.0
    for k in range(n):
        e = sp[k] - T_meas
        raw = kp * e + integ
        frac = min(max(raw, 0.0), 1.0)
        if raw == frac:  # anti-windup: integrate only while unsaturated
            integ += kp * dt / ti * e
        uu[0, k, 0] = np.sqrt(frac)
        seen[0, k, 0] = uu[0, k - lag_n, 0] if k >= lag_n else 0.0
        ys[k] = plant.outputs(x, seen[:, k], spec)[0]
        xs[k] = x[0]
        x = plant.step(x, seen[:, k], dt, spec)
        T_meas = float(stream.sample(np.array([True]), x[:, 1], dt, _draws(rng))[0])
    t = dt * np.arange(n, dtype=np.float64)
    truth = {name: ys[:, i] for i, name in enumerate(plant.output_names)}
    truth.update(plant.hidden(xs, spec.take(np.zeros(n, dtype=np.int64))))
    truth.update({"k_U": kU, "T_U": TU})
    measured = rig.measure({k: truth[k] for k in _RECORDED_OUT}, rng, t)
    measured["R_PTC"] = np.where(uu[0, :, 0] > 0, measured["R_PTC"], np.nan)
    exo = rig.measure({"k_U": kU, "T_U": TU}, rng, t)
    cols = {"u": uu[0, :, 0].copy(), **exo, **measured, "T_P_setpoint": sp.astype(float)}
    units = {**_UNITS, "T_P_setpoint": "°C"}
    roles = {**_ROLES, "T_P_setpoint": "disturbance"}
    meta = {
        "levels_C": levels.tolist(),
        "hold_s": hold_s,
        "supply_V": supply_V,
        "ambient_C": ambient_C,
    }
    return [RigRun("axt211-staircase", t, cols, units, roles, meta, truth=truth)]


AXT211Rig.protocols = {
    "steps": Protocol("steps", "power on/off steps at 19-29 V and 0-50 °C", _steps),
    "pwm": Protocol("pwm", "step then PWM at high, medium and low frequency (50 % duty)", _pwm),
    "spread": Protocol("spread", "the PWM input on 15 actuators of 3 production dates", _spread),
    "staircase": Protocol(
        "staircase", "closed-loop wax temperature staircase 52-70-52 °C", _staircase
    ),
}
