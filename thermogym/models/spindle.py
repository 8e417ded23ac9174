"""Externally driven machine-tool spindle: a speed-driven thermal RC network.

Description
-----------
Physical counterpart of the spindle of ``001_6d13a2cd04f5de5e.txt``: a spindle
driven through a belt, with a rear bearing pair (A, B) and a front bearing pair
(C, D), an inner housing and an outer housing (Fig. 3c). The paper identifies it
as a black-box LTI state-space model; this module is the white-box network the
virtual rig simulates, built from the paper's statements: bearings are the main
heat sources (section 2.2.1, after Brecher et al.), the inner housing is
metallic and conducts fast, the outer housing surface is the only place a
sensor can go, time constants are hours and a run at 4000-8000 rpm reaches a
steady state within a day (section 2.3.1, Table 4).

Nodes: shaft (rear, mid, front), belt pulley, the four bearing outer-ring
groups, inner housing (rear, mid, front), outer housing (rear, front) and the
front nose; the air is the boundary. Heat: each bearing dissipates
``q · n / 1000`` [W] at speed ``n`` [rpm] (linear in speed, so the nominal
plant is LTI as the paper concludes in section 3.1); the belt pulley
``q_belt · n / 1000``. Every node balance is eq (13) of
``000_24627a5308ee07db.txt`` (see :mod:`thermogym.models.thermal_network`).

Signals: input ``speed`` [rpm]; disturbance ``T_amb`` [°C]; outputs the seven
temperatures of Table 6 of paper 001.

Parameter values were chosen here (the paper gives none): a ~200 kg spindle
unit (steel shaft ~25 kg, housings ~160 kg), ~170 W bearing and belt losses at
8000 rpm giving bearing rises of about 25 K, a dominant time constant of about
3.5 h.

Version History
---------------
* v1: initial release.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from thermogym.models.base import Parameter, Signal
from thermogym.models.thermal_network import NetworkArrays, ThermalNetworkModel

__all__ = ["SPINDLE_OUTPUTS", "SpindleModel"]

#: Heat of the inner bearing of a pair relative to the outer one (chosen here).
_PAIR_SHARE = 0.85
_P = "chosen here to match the behaviour described in 001_6d13a2cd04f5de5e.txt"

NODES: tuple[str, ...] = (
    "shaft_rear",
    "shaft_mid",
    "shaft_front",
    "pulley",
    "bearing_A",
    "bearing_B",
    "bearing_C",
    "bearing_D",
    "inner_rear",
    "inner_mid",
    "inner_front",
    "outer_rear",
    "outer_front",
    "nose",
)

#: Output name -> node (Table 6 of paper 001).
SPINDLE_OUTPUTS: dict[str, str] = {
    "T_rear_bearing_A": "bearing_A",
    "T_rear_bearing_B": "bearing_B",
    "T_front_bearing_C": "bearing_C",
    "T_front_bearing_D": "bearing_D",
    "T_inner_housing": "inner_mid",
    "T_rear_outer_housing": "outer_rear",
    "T_front_outer_housing": "outer_front",
}

SIGNALS: tuple[Signal, ...] = (
    Signal("speed", "input", "rpm", "spindle rotational speed"),
    Signal("T_amb", "disturbance", "°C", "ambient air temperature"),
    Signal("T_rear_bearing_A", "output", "°C", "outer ring of rear bearing A"),
    Signal("T_rear_bearing_B", "output", "°C", "outer ring of rear bearing B"),
    Signal("T_front_bearing_C", "output", "°C", "outer ring of front bearing C"),
    Signal("T_front_bearing_D", "output", "°C", "outer ring of front bearing D"),
    Signal("T_inner_housing", "output", "°C", "centre of the inner housing"),
    Signal("T_rear_outer_housing", "output", "°C", "rear end of the outer housing surface"),
    Signal("T_front_outer_housing", "output", "°C", "front end of the outer housing surface"),
)

PARAMETERS: tuple[Parameter, ...] = (
    Parameter(
        "q_rear",
        4.0,
        0.5,
        20.0,
        "W/krpm",
        "heat of rear bearing A per 1000 rpm (B: 0.85×)",
        _P,
        "heat",
    ),
    Parameter(
        "q_front",
        5.5,
        0.5,
        20.0,
        "W/krpm",
        "heat of front bearing C per 1000 rpm (D: 0.85×)",
        _P,
        "heat",
    ),
    Parameter("q_belt", 2.0, 0.0, 10.0, "W/krpm", "belt and pulley loss per 1000 rpm", _P, "heat"),
    Parameter(
        "C_shaft", 12000.0, 3000.0, 50000.0, "J/K", "shaft heat capacity (3 nodes)", _P, "capacity"
    ),
    Parameter(
        "C_bearing", 800.0, 100.0, 5000.0, "J/K", "capacity of each bearing node", _P, "capacity"
    ),
    Parameter(
        "C_inner",
        30000.0,
        5000.0,
        150000.0,
        "J/K",
        "inner housing capacity (3 nodes)",
        _P,
        "capacity",
    ),
    Parameter(
        "C_outer",
        45000.0,
        5000.0,
        200000.0,
        "J/K",
        "outer housing capacity (2 nodes)",
        _P,
        "capacity",
    ),
    Parameter(
        "C_end", 2500.0, 300.0, 20000.0, "J/K", "capacity of pulley and of nose", _P, "capacity"
    ),
    Parameter(
        "G_bs", 3.0, 0.3, 30.0, "W/K", "bearing → shaft (rolling elements)", _P, "conductance"
    ),
    Parameter(
        "G_bh", 8.0, 0.5, 60.0, "W/K", "bearing → inner housing (outer-ring fit)", _P, "conductance"
    ),
    Parameter(
        "G_shaft", 6.0, 0.5, 50.0, "W/K", "axial conductance between shaft nodes", _P, "conductance"
    ),
    Parameter(
        "G_inner",
        15.0,
        1.0,
        100.0,
        "W/K",
        "axial conductance of the inner housing",
        _P,
        "conductance",
    ),
    Parameter(
        "G_io", 10.0, 1.0, 100.0, "W/K", "inner → outer housing at each end", _P, "conductance"
    ),
    Parameter(
        "G_outer",
        5.0,
        0.5,
        50.0,
        "W/K",
        "axial conductance of the outer housing",
        _P,
        "conductance",
    ),
    Parameter(
        "g_outer", 3.0, 0.3, 20.0, "W/K", "outer housing node → air (each)", _P, "conductance"
    ),
    Parameter("g_end", 0.8, 0.05, 10.0, "W/K", "pulley, nose → air (each)", _P, "conductance"),
)


class SpindleModel(ThermalNetworkModel):
    """Thermal network of an externally driven spindle (paper 001 plant).

    Parameters
    ----------
    effects : sequence of str
        Effects of :data:`thermogym.models.thermal_network.NETWORK_EFFECTS`.

    Examples
    --------
    >>> import numpy as np
    >>> from thermogym.models.spindle import SpindleModel
    >>> m = SpindleModel()
    >>> u = np.column_stack([np.full(25, 6000.0), np.full(25, 22.0)])
    >>> sim = m.simulate(u, dt=3600.0)
    >>> bool(sim.output("T_front_bearing_C")[0, -1] > 40.0)
    True
    """

    name = "spindle"
    version = "1"
    nodes = NODES
    u_ref = 6000.0

    def __init__(self, effects: tuple[str, ...] | list[str] = ()) -> None:
        super().__init__(SIGNALS, PARAMETERS, effects)
        self._H = np.zeros((len(SPINDLE_OUTPUTS), len(NODES)))
        for i, node in enumerate(SPINDLE_OUTPUTS.values()):
            self._H[i, NODES.index(node)] = 1.0

    def forced_nodes(self) -> tuple[str, ...]:
        """Rotating parts: their air conductance grows with speed."""
        return ("shaft_rear", "shaft_mid", "shaft_front", "pulley", "nose")

    def _validate_theta(self, theta: NDArray[np.float64]) -> None:
        self._require_positive(theta, [p.name for p in PARAMETERS if p.group != "heat"])

    def network(self, theta_full: NDArray[np.float64]) -> NetworkArrays:
        """Physical arrays of the spindle network for full parameter vectors."""
        B, n = theta_full.shape[0], len(NODES)
        p = {name: theta_full[:, i] for i, name in enumerate(x.name for x in PARAMETERS)}
        ix = {name: i for i, name in enumerate(NODES)}
        C = np.empty((B, n))
        for k, f in (("shaft_rear", 0.3), ("shaft_mid", 0.4), ("shaft_front", 0.3)):
            C[:, ix[k]] = f * p["C_shaft"]
        for k in ("bearing_A", "bearing_B", "bearing_C", "bearing_D"):
            C[:, ix[k]] = p["C_bearing"]
        for k, f in (("inner_rear", 0.3), ("inner_mid", 0.4), ("inner_front", 0.3)):
            C[:, ix[k]] = f * p["C_inner"]
        C[:, ix["outer_rear"]] = 0.5 * p["C_outer"]
        C[:, ix["outer_front"]] = 0.5 * p["C_outer"]
        C[:, ix["pulley"]] = p["C_end"]
        C[:, ix["nose"]] = p["C_end"]

        G = np.zeros((B, n, n))

        def link(a: str, b: str, g: NDArray[np.float64]) -> None:
            G[:, ix[a], ix[b]] += g
            G[:, ix[b], ix[a]] += g

        link("pulley", "shaft_rear", p["G_shaft"])
        link("shaft_rear", "shaft_mid", p["G_shaft"])
        link("shaft_mid", "shaft_front", p["G_shaft"])
        link("shaft_front", "nose", p["G_shaft"])
        for bearing, shaft, inner in (
            ("bearing_A", "shaft_rear", "inner_rear"),
            ("bearing_B", "shaft_rear", "inner_rear"),
            ("bearing_C", "shaft_front", "inner_front"),
            ("bearing_D", "shaft_front", "inner_front"),
        ):
            link(bearing, shaft, p["G_bs"])
            link(bearing, inner, p["G_bh"])
        link("bearing_A", "bearing_B", 0.25 * p["G_bh"])  # spacer between the pair
        link("bearing_C", "bearing_D", 0.25 * p["G_bh"])
        link("inner_rear", "inner_mid", p["G_inner"])
        link("inner_mid", "inner_front", p["G_inner"])
        link("inner_rear", "outer_rear", p["G_io"])
        link("inner_front", "outer_front", p["G_io"])
        link("inner_mid", "outer_rear", 0.5 * p["G_io"])
        link("inner_mid", "outer_front", 0.5 * p["G_io"])
        link("outer_rear", "outer_front", p["G_outer"])
        link("nose", "outer_front", 0.25 * p["G_io"])  # front cap / labyrinth

        g = np.zeros((B, n))
        g[:, ix["outer_rear"]] = p["g_outer"]
        g[:, ix["outer_front"]] = p["g_outer"]
        g[:, ix["pulley"]] = p["g_end"]
        g[:, ix["nose"]] = p["g_end"]
        g[:, ix["shaft_mid"]] = 0.1 * p["g_end"]  # air in the bore

        q = np.zeros((B, n, 1))
        # The outer bearing of each pair carries more of the axial preload than the inner one.
        q[:, ix["bearing_A"], 0] = p["q_rear"] / 1000.0
        q[:, ix["bearing_B"], 0] = _PAIR_SHARE * p["q_rear"] / 1000.0
        q[:, ix["bearing_C"], 0] = p["q_front"] / 1000.0
        q[:, ix["bearing_D"], 0] = _PAIR_SHARE * p["q_front"] / 1000.0
        q[:, ix["pulley"], 0] = p["q_belt"] / 1000.0
        return NetworkArrays(C, G, g, q, self._H, np.zeros((B, self._H.shape[0])))


MODELS = {"spindle": SpindleModel}
