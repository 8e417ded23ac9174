"""Machine-tool actuator strut (ball-screw axis): 19-node thermal RC network.

Description
-----------
The electric equivalent circuit of ``000_24627a5308ee07db.txt`` section 4.2 and
appendix: 18 capacitive nodes plus the surrounding air (infinite capacity, the
19th node). Every node obeys eq (13); the heat losses are proportional to the
feed rate ``v`` [m/min] (section 4.2.1: ``Q_i = k_i v``). The strut is moved
periodically at a constant feed rate, so the nut's heat is spread over the
spindle segments of its stroke.

Only five **ratio parameters** are identified (appendix, Table 5): factors on
the physically estimated values, 1 at the start, with the uncertainty ranges of
the appendix:

========================  ==========================================  ===========
ratio                     multiplies                                  bounds
========================  ==========================================  ===========
r_motor                   motor heat loss                             [0.3, 3.0]
r_bearing                 bearing heat losses (fixed and front)       [0.3, 3.0]
r_nut                     ball-screw nut heat loss                    [0.3, 3.0]
r_spindle_air             spindle (and nut) → air conductances        [0.8, 1.3]
r_tube_air                tube → air conductances                     [0.8, 1.3]
========================  ==========================================  ===========

(+200/−70 % for power losses of rolling contacts and electric units, +30/−20 %
for free convection and radiation; appendix.)

The paper's Tables 3 and 4 (the physical estimates of 14 capacities, 6 losses
and 28 conductances) were lost in the text conversion; the estimates below were
made here for a strut with a 40 mm ball screw of 1.5 m, a 1.2 m steel tube and
a ~3 kW servo motor, giving temperature rises of a few kelvin to ~20 K over
80-170 min at 20-30 m/min as in the paper's Figure 5 description.

Thermal elongation (eq 5): ``ΔL = Σ_i α_i ΔT_i L_i`` over the load path from
the fixed bearing to the front of the tube (the spindle segments between the
bearing and the nut's mean position, and the tube), with ``ΔT_i = T_i − T_ref``.
``T_ref`` defaults to 20 °C (ISO 1 reference temperature); set it to the
initial temperature to obtain the paper's "change compared to its initial
value".

Signals: input ``feed_rate`` [m/min]; disturbance ``T_air`` [°C]; outputs the
seven measured temperatures and ``dL_um`` [µm].

Version History
---------------
* v1: initial release.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from thermogym.models.base import Parameter, Signal
from thermogym.models.thermal_network import NetworkArrays, ThermalNetworkModel

__all__ = ["STRUT_CAPACITY", "STRUT_CONDUCTANCE", "STRUT_LOSS", "STRUT_OUTPUTS", "StrutModel"]

NODES: tuple[str, ...] = (
    "drive",
    "motor_flange",
    "pulley_motor",
    "belt_housing",
    "pulley_spindle",
    "bearing_housing",
    "bearing",
    "spindle_1",
    "spindle_2",
    "spindle_3",
    "spindle_4",
    "spindle_5",
    "nut",
    "carriage",
    "tube_rear",
    "tube_mid",
    "tube_front",
    "front_bearing",
)

#: Heat capacities [J/K] (physical estimates, chosen here; paper Table 3 lost).
STRUT_CAPACITY: dict[str, float] = {
    "drive": 9000.0,
    "motor_flange": 1500.0,
    "pulley_motor": 400.0,
    "belt_housing": 3000.0,
    "pulley_spindle": 500.0,
    "bearing_housing": 4000.0,
    "bearing": 600.0,
    "spindle_1": 1400.0,
    "spindle_2": 1400.0,
    "spindle_3": 1400.0,
    "spindle_4": 1400.0,
    "spindle_5": 1400.0,
    "nut": 1200.0,
    "carriage": 5000.0,
    "tube_rear": 6000.0,
    "tube_mid": 6000.0,
    "tube_front": 6000.0,
    "front_bearing": 500.0,
}

#: Heat loss per feed rate [W/(m/min)] and the ratio parameter scaling it (None: fixed).
STRUT_LOSS: dict[str, tuple[float, str | None]] = {
    "drive": (2.0, "r_motor"),
    "pulley_motor": (0.15, None),
    "pulley_spindle": (0.15, None),
    "bearing": (0.8, "r_bearing"),
    "front_bearing": (0.3, "r_bearing"),
    "nut": (1.5, "r_nut"),
}

#: Node-to-node conductances [W/K] (physical estimates, chosen here; paper Table 4 lost).
STRUT_CONDUCTANCE: tuple[tuple[str, str, float], ...] = (
    ("drive", "motor_flange", 4.0),
    ("drive", "pulley_motor", 1.0),
    ("motor_flange", "belt_housing", 3.0),
    ("pulley_motor", "pulley_spindle", 0.3),
    ("pulley_motor", "belt_housing", 0.5),
    ("pulley_spindle", "belt_housing", 0.5),
    ("pulley_spindle", "spindle_1", 2.0),
    ("belt_housing", "bearing_housing", 4.0),
    ("bearing_housing", "bearing", 3.0),
    ("bearing", "spindle_1", 1.5),
    ("spindle_1", "spindle_2", 0.2),
    ("spindle_2", "spindle_3", 0.2),
    ("spindle_3", "spindle_4", 0.2),
    ("spindle_4", "spindle_5", 0.2),
    ("nut", "spindle_2", 1.0),
    ("nut", "spindle_3", 1.0),
    ("nut", "spindle_4", 1.0),
    ("nut", "carriage", 5.0),
    ("carriage", "tube_rear", 4.0),
    ("tube_rear", "tube_mid", 2.0),
    ("tube_mid", "tube_front", 2.0),
    ("tube_front", "front_bearing", 0.5),
    ("front_bearing", "spindle_5", 1.0),
    ("bearing_housing", "tube_rear", 0.5),
)

#: Conductances to the air [W/K] and the ratio parameter scaling them (None: fixed).
STRUT_AIR: dict[str, tuple[float, str | None]] = {
    "drive": (1.5, None),
    "motor_flange": (0.3, None),
    "belt_housing": (1.2, None),
    "bearing_housing": (1.0, None),
    "carriage": (0.8, None),
    "front_bearing": (0.2, None),
    "spindle_1": (0.08, "r_spindle_air"),
    "spindle_2": (0.08, "r_spindle_air"),
    "spindle_3": (0.08, "r_spindle_air"),
    "spindle_4": (0.08, "r_spindle_air"),
    "spindle_5": (0.08, "r_spindle_air"),
    "nut": (0.1, "r_spindle_air"),
    "tube_rear": (0.6, "r_tube_air"),
    "tube_mid": (0.6, "r_tube_air"),
    "tube_front": (0.6, "r_tube_air"),
}

#: Output name -> node.
STRUT_OUTPUTS: dict[str, str] = {
    "T_drive": "drive",
    "T_belt_housing": "belt_housing",
    "T_bearing": "bearing",
    "T_nut": "nut",
    "T_spindle": "spindle_3",
    "T_tube_front": "tube_front",
    "T_tube_rear": "tube_rear",
}

ALPHA_STEEL = 11.5e-6  # 1/K, linear expansion coefficient of steel
#: Elongation load path: node -> length [m] (eq 5).
ELONGATION_PATH: dict[str, float] = {
    "spindle_1": 0.3,
    "spindle_2": 0.3,
    "spindle_3": 0.3,
    "tube_rear": 0.4,
    "tube_mid": 0.4,
    "tube_front": 0.4,
}

SIGNALS: tuple[Signal, ...] = (
    Signal("feed_rate", "input", "m/min", "feed rate of the periodic axis movement"),
    Signal("T_air", "disturbance", "°C", "air temperature around the strut"),
    Signal("T_drive", "output", "°C", "drive (motor) temperature"),
    Signal("T_belt_housing", "output", "°C", "belt housing temperature"),
    Signal("T_bearing", "output", "°C", "fixed-bearing temperature"),
    Signal("T_nut", "output", "°C", "ball-screw nut temperature"),
    Signal("T_spindle", "output", "°C", "ball-screw spindle temperature (middle)"),
    Signal("T_tube_front", "output", "°C", "tube temperature, front"),
    Signal("T_tube_rear", "output", "°C", "tube temperature, rear"),
    Signal("dL_um", "output", "µm", "thermal elongation of the strut, eq (5)"),
)

_R = "000_24627a5308ee07db.txt appendix, Table 5: ratio on the physical estimate, 1 at start"
PARAMETERS: tuple[Parameter, ...] = (
    Parameter("r_motor", 1.0, 0.3, 3.0, "1", "ratio on the motor heat loss", _R, "ratio"),
    Parameter("r_bearing", 1.0, 0.3, 3.0, "1", "ratio on the bearing heat losses", _R, "ratio"),
    Parameter("r_nut", 1.0, 0.3, 3.0, "1", "ratio on the ball-screw nut heat loss", _R, "ratio"),
    Parameter(
        "r_spindle_air", 1.0, 0.8, 1.3, "1", "ratio on spindle → air conductance", _R, "ratio"
    ),
    Parameter("r_tube_air", 1.0, 0.8, 1.3, "1", "ratio on tube → air conductance", _R, "ratio"),
    Parameter(
        "T_ref",
        20.0,
        -20.0,
        60.0,
        "°C",
        "reference temperature of the nominal length",
        "ISO 1 reference temperature (20 °C)",
        "elongation",
    ),
)


class StrutModel(ThermalNetworkModel):
    """19-node thermal network of a ball-screw actuator strut (paper 000 plant).

    Parameters
    ----------
    effects : sequence of str
        Effects of :data:`thermogym.models.thermal_network.NETWORK_EFFECTS`.

    Examples
    --------
    >>> import numpy as np
    >>> from thermogym.models.strut import StrutModel
    >>> m = StrutModel()
    >>> u = np.column_stack([np.full(60, 20.0), np.full(60, 20.0)])
    >>> sim = m.simulate(u, dt=140.9)
    >>> bool(sim.output("T_drive")[0, -1] > 25.0)
    True
    """

    name = "strut"
    version = "1"
    nodes = NODES
    u_ref = 20.0

    def __init__(self, effects: tuple[str, ...] | list[str] = ()) -> None:
        super().__init__(SIGNALS, PARAMETERS, effects)
        n = len(NODES)
        H = np.zeros((len(STRUT_OUTPUTS) + 1, n))
        for i, node in enumerate(STRUT_OUTPUTS.values()):
            H[i, NODES.index(node)] = 1.0
        for node, length in ELONGATION_PATH.items():
            H[-1, NODES.index(node)] = 1e6 * ALPHA_STEEL * length
        self._H = H
        self._L_total_um = 1e6 * ALPHA_STEEL * sum(ELONGATION_PATH.values())

    def forced_nodes(self) -> tuple[str, ...]:
        """Moving parts (spindle stirred by the nut, nut, tube): air conductance grows with feed."""
        return (
            "spindle_1",
            "spindle_2",
            "spindle_3",
            "spindle_4",
            "spindle_5",
            "nut",
            "tube_rear",
            "tube_mid",
            "tube_front",
        )

    def _validate_theta(self, theta: NDArray[np.float64]) -> None:
        self._require_positive(theta, [p.name for p in PARAMETERS if p.group == "ratio"])

    def network(self, theta_full: NDArray[np.float64]) -> NetworkArrays:
        """Physical arrays of the strut network for full parameter vectors."""
        B, n = theta_full.shape[0], len(NODES)
        p = {name: theta_full[:, i] for i, name in enumerate(x.name for x in PARAMETERS)}
        ix = {name: i for i, name in enumerate(NODES)}
        one = np.ones(B)
        C = np.repeat(np.array([STRUT_CAPACITY[k] for k in NODES])[None], B, axis=0)
        G = np.zeros((B, n, n))
        for a, b, g in STRUT_CONDUCTANCE:
            G[:, ix[a], ix[b]] += g
            G[:, ix[b], ix[a]] += g
        g_air = np.zeros((B, n))
        for node, (g, ratio) in STRUT_AIR.items():
            g_air[:, ix[node]] = g * (p[ratio] if ratio else one)
        q = np.zeros((B, n, 1))
        for node, (k, ratio) in STRUT_LOSS.items():
            q[:, ix[node], 0] = k * (p[ratio] if ratio else one)
        h0 = np.zeros((B, self._H.shape[0]))
        h0[:, -1] = -self._L_total_um * p["T_ref"]
        return NetworkArrays(C, G, g_air, q, self._H, h0)


MODELS = {"strut": StrutModel}
