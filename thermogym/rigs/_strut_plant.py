"""The strut's true plant: geometry, materials, the rig's table and :class:`StrutPlant`.

The plant of :mod:`thermogym.rigs.strut` (its docstring gives the design and
the sources): the rig's table of physics the model lacks (:data:`EXTRAS`),
the specimen spread (:data:`SPREAD`), the geometry, material and joint
constants, and the plant class that builds the node network of a batch of
specimens and steps it in the compiled kernels of
:mod:`thermogym.rigs._strut_kernels`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from thermogym.rigs._convection import (
    g_annulus_conduction,
    g_annulus_radiation,
    k_ratio_free_annulus,
)
from thermogym.rigs._machine import Links, ratio_parameters, segment_weights
from thermogym.rigs._plant_base import NetworkPlant, air_coefficients, link_flags, node_totals
from thermogym.rigs._strut_kernels import _flows, _g_annulus, _simulate
from thermogym.rigs.base import EffectSpec, ExtraPhysics, Specimens

__all__ = ["EXTRAS", "OUTPUTS", "PHYSICS", "SPREAD", "TEMPERATURES", "StrutPlant"]

#: The seven thermocouples of the test stand (recorded with the model's signal names).
TEMPERATURES: tuple[str, ...] = (
    "T_drive",
    "T_belt_housing",
    "T_bearing",
    "T_nut",
    "T_spindle",
    "T_tube_front",
    "T_tube_rear",
)
OUTPUTS: tuple[str, ...] = (*TEMPERATURES, "dL_um")
_UNITS = {"feed_rate": "m/min", "T_air": "°C", "dL_um": "µm", **{k: "°C" for k in TEMPERATURES}}

#: The rig's table: what it has that the identified model lacks (switch: ``off=[name]``).
EXTRAS: tuple[ExtraPhysics, ...] = (
    ExtraPhysics(
        "conduction_1d",
        "heat conduction along the screw and the push tube, 60 finite volumes each",
        "000 section 4, eq (6): the heat equation; the model lumps the screw in 5, the "
        "tube in 3 nodes",
        "60 + 60 segments of 25 and 20 mm",
        "5 screw and 3 tube segments (the model's resolution)",
    ),
    ExtraPhysics(
        "forced_convection",
        "convection of the screw turning in its enclosed annulus (push tube, bellows) and of "
        "the push tube moving through the air",
        "annulus with a rotating inner cylinder Nu = 0.409 Ta^0.241 (Becker & Kaye 1962; "
        "Staton et al. 2005), free convection in the annulus (Raithby & Hollands, Incropera "
        "eq 9.58); flat plate over the stroke Nu = 0.664 Re^(1/2) Pr^(1/3) (Incropera eq 7.30); "
        "mixed with free convection, n = 3 (Incropera eq 9.64)",
        "annulus 0.65 W/(m K) at rest, ×4.1 at 20 m/min, ×4.9 at 30; the screw's exchange "
        "with the air through the bellows ×2.7 at 20 m/min; the tube's outside +6 %, +10 %",
        "the annulus and the tube at rest (conduction, free convection, radiation)",
    ),
    ExtraPhysics(
        "copper_resistance",
        "the copper loss of the motor follows the winding resistance",
        "α_Cu = 3.93e-3 1/K, annealed copper at 20 °C (IEC 60028)",
        "+0.39 % of the 30 W copper loss (at 20 m/min) per kelvin of winding rise",
        "copper loss at its 20 °C value",
    ),
    ExtraPhysics(
        "winding_node",
        "the winding is a heat capacity of its own behind the stator",
        "servo motor datasheets: winding-housing R_th ≈ 0.12 K/W for ~3 kW",
        "1.2 kJ/K, 8 W/K to the housing",
        "the copper loss heats the housing node (one node of both capacities)",
    ),
    ExtraPhysics(
        "heat_partition",
        "friction heat is shared by the two contact partners",
        "Blok's heat partition, equal shares for equal materials (steel on steel)",
        "50 % of the bearing, nut and bushing heat enters the screw or the tube",
        "all of it into the nut, bearing and bushing nodes (as the model assumes)",
    ),
    ExtraPhysics(
        "stroke_contacts",
        "contacts of moving parts averaged over the stroke",
        "periodic motion over 0.6 m at constant speed: the stroke period (seconds) is far "
        "below every thermal time constant",
        "nut ↔ screw over 0.7 m, screw ↔ push tube across the annulus, tube ↔ bushing, the "
        "screw's length under the bellows",
        "every contact at the stroke's mean position",
    ),
    ExtraPhysics(
        "thermocouple_lag",
        "thermocouple junctions lag their mounting points",
        "sheathed thermocouples in blind holes with paste",
        "τ = 30 s (× the specimen's tc_tau, 0.5-2)",
        "the readings are the node temperatures",
    ),
)
#: Switch names of :data:`EXTRAS`.
PHYSICS: tuple[str, ...] = tuple(e.name for e in EXTRAS)

#: Specimen spread: factor -> (low, high, what it multiplies); drawn log-uniformly.
SPREAD: dict[str, tuple[float, float, str]] = {
    "loss_motor": (0.3, 3.0, "motor losses (000 appendix: +200/−70 % for electric units)"),
    "loss_bearing": (0.3, 3.0, "bearing pair and guide bushing friction (+200/−70 %)"),
    "loss_nut": (0.3, 3.0, "ball-screw nut friction (+200/−70 % for rolling contacts)"),
    "g_air_screw": (0.8, 1.3, "screw → air exchange (+30/−20 %, 000 appendix)"),
    "g_air_tube": (0.8, 1.3, "push tube → air exchange (+30/−20 %)"),
    "g_air_other": (0.8, 1.3, "housings, motor → air exchange (+30/−20 %)"),
    "g_contact": (0.6, 2.0, "rolling-contact conductances (+100/−40 %, 000 appendix)"),
    "capacity": (0.9, 1.1, "heat capacities (masses × specific heat, ±10 %)"),
    "tc_tau": (0.5, 2.0, "thermocouple time constants (mounting)"),
}

# ------------------------------------------------------------ geometry, materials
_RHO_C_STEEL = 7850.0 * 460.0  # J/(m³ K)
_K_STEEL = 45.0  # W/(m K)
_ALPHA_STEEL = 11.5e-6  # 1/K
_ALPHA_CU = 3.93e-3  # 1/K, annealed copper at 20 °C (IEC 60028)
_LEAD = 0.020  # m per screw revolution; n [rpm] = v [m/min] / lead
_D_SCREW, _L_SCREW = 0.040, 1.5
_D_TUBE, _D_TUBE_IN, _L_TUBE = 0.110, 0.090, 1.2
_STROKE = (0.45, 1.05)  # nut centre on the screw [m from the rear end]
_L_NUT = 0.10
_BEARING = (0.05, 0.11)  # bearing pair on the screw
_PULLEY = (0.0, 0.04)
_BUSHING_X = 1.55  # guide bushing, fixed, on the screw axis
_TUBE_REAR_OFFSET = -0.05  # push tube rear end relative to the nut centre
_DT_DESIGN = 10.0  # K: rise at which free convection and radiation are linearised
_T_REF = 20.0  # °C: reference temperature of the strut length (ISO 1)
_TC_TAU = 30.0  # s: thermocouple in a blind hole with paste
_N_REF = 1000.0  # rpm: reference speed of the viscous friction
_V_REF = 20.0  # m/min
_L_MOTOR = 0.3  # m, motor housing length along the fan's air stream

# lumped nodes
_LUMPED = (
    "winding",
    "drive",
    "motor_flange",
    "pulley_motor",
    "belt_housing",
    "pulley_spindle",
    "bearing_housing",
    "bearing",
    "nut",
    "carriage",
    "bushing",
    "bracket",
)
_IX = {k: i for i, k in enumerate(_LUMPED)}
_NL = len(_LUMPED)
#: capacity [J/K]
_CAP = {
    "winding": 1200.0,
    "drive": 7000.0,
    "motor_flange": 1500.0,
    "pulley_motor": 400.0,
    "belt_housing": 3000.0,
    "pulley_spindle": 500.0,
    "bearing_housing": 4000.0,
    "bearing": 320.0,
    "nut": 1000.0,
    "carriage": 3700.0,
    "bushing": 500.0,
}
#: air exchange of the lumped nodes: area [m²], characteristic diameter [m], emissivity
_AIR = {
    "drive": (0.25, 0.15, 0.9),
    "motor_flange": (0.04, 0.15, 0.9),
    "belt_housing": (0.15, 0.20, 0.2),
    "bearing_housing": (0.12, 0.15, 0.9),
    "nut": (0.02, 0.08, 0.3),
    "carriage": (0.05, 0.11, 0.3),
    "bushing": (0.04, 0.15, 0.9),
}
_EPS_TUBE = 0.8  # painted push tube
_EPS_SCREW, _EPS_TUBE_IN = 0.3, 0.5  # ground screw; the tube's drawn, oxidised bore
#: the bellows over the screw between the bearing housing and the carriage
_COVER_D, _EPS_COVER = 0.11, 0.9  # m (outer), coated fabric
_HOUSING_FACE = 0.12  # m: the screw leaves the bearing housing
_R_SCREW, _R_BORE = 0.5 * _D_SCREW, 0.5 * _D_TUBE_IN  # the annulus around the screw
#: joints between lumped nodes [W/K] and whether they are rolling contacts
_JOINTS = (
    ("winding", "drive", 8.0),
    ("drive", "motor_flange", 5.0),
    ("drive", "pulley_motor", 1.0),
    ("motor_flange", "belt_housing", 3.0),
    ("pulley_motor", "belt_housing", 0.4),
    ("pulley_spindle", "belt_housing", 0.4),
    ("belt_housing", "bearing_housing", 4.0),
    ("bearing", "bearing_housing", 8.0),
    ("nut", "carriage", 6.0),
)
#: heat sources at 20 m/min [W]
_Q_COPPER, _Q_IRON, _Q_BELT = 30.0, 10.0, 6.0
_M_BEARING, _M_NUT, _F_BUSHING = 0.13, 0.28, 20.0  # N m, N m, N
_G_PULLEY_SCREW = 3.0  # W/K, clamping hub
_G_BALLS_BEARING, _G_BALLS_NUT = 2.0, 3.0  # W/K, rolling contacts
_G_CARRIAGE_TUBE = 10.0  # W/K, bolted
_G_BUSHING_TUBE = 1.5  # W/K, sliding contact
#: the annulus around the screw (inside the push tube or the bellows) at rest [W/(m K)]:
#: conduction × free convection (Raithby & Hollands at the design rise) + radiation
_G_ANN_COND = g_annulus_conduction(_R_SCREW, _R_BORE)
_KR_FREE = float(k_ratio_free_annulus(_DT_DESIGN, _R_SCREW, _R_BORE))
_G_ANN_RAD = g_annulus_radiation(_R_SCREW, _R_BORE, _EPS_SCREW, _EPS_TUBE_IN)
_G_ANN_STILL = _KR_FREE * _G_ANN_COND + _G_ANN_RAD
_N_HI = 3000.0  # rpm (60 m/min): speed of the integrator's rate bound
_PALMGREN = (2 * 2.0, 55.0, 4.0, 40.0, 100.0)  # f0 bearings (×2), d_m, f0 nut, d_m, ν [mm²/s]


def _palmgren_watts(f0: float, dm_mm: float, n_rpm: float, nu: float) -> float:
    """Viscous friction power of Palmgren's M_0 at ``n_rpm`` [W] (M_0 in N mm)."""
    m0 = 1e-7 * f0 * (nu * n_rpm) ** (2.0 / 3.0) * dm_mm**3 if nu * n_rpm >= 2000 else 0.0
    return m0 * 1e-3 * n_rpm * 2 * math.pi / 60.0


def _g_annulus_np(n_rpm: float, forced: bool) -> float:
    """The annulus around the screw per metre at ``n_rpm`` [W/(m K)] (see the kernel)."""
    return float(_g_annulus(n_rpm, forced, _R_SCREW, _R_BORE, _KR_FREE, _G_ANN_COND, _G_ANN_RAD))


def _stroke_positions(stroke_contacts: bool) -> NDArray[np.float64]:
    # the nut moves at constant speed over the stroke: positions uniform in time
    if not stroke_contacts:
        return np.array([0.5 * (_STROKE[0] + _STROKE[1])])
    return np.linspace(_STROKE[0], _STROKE[1], 61)


@dataclass(frozen=True)
class _Arrays:
    """Kernel arrays of a batch of specimens."""

    C: NDArray[np.float64]  # (B, nn)
    ei: NDArray[np.int64]
    ej: NDArray[np.int64]
    eg: NDArray[np.float64]  # (B, E)
    eann: NDArray[np.int64]  # (E,) 1: across the annulus around the screw (grows with speed)
    A: NDArray[np.float64]  # (B, nn) exposed area × factor; screw: length under the bellows
    A2: NDArray[np.float64]  # (B, nn) screw segments: bellows' outer area × factor
    D: NDArray[np.float64]  # (nn,)
    eps: NDArray[np.float64]
    hnat: NDArray[np.float64]  # (nn,) linearised free convection
    hrad: NDArray[np.float64]  # (nn,) linearised radiation
    ftype: NDArray[np.int64]  # (nn,) 0 none, 1 screw under the bellows, 2 push tube
    xf: NDArray[np.float64]  # (nn,) fan air speed per motor rpm [m/s per rpm]
    qlin: NDArray[np.float64]  # (B, nn) W per m/min
    qcu: NDArray[np.float64]
    qwear: NDArray[np.float64]
    qvisc: NDArray[np.float64]  # (B, nn) W at the reference speed
    tca: NDArray[np.int64]
    tcb: NDArray[np.int64]
    tcw: NDArray[np.float64]
    tctau: NDArray[np.float64]  # (B, 7)
    wL: NDArray[np.float64]  # (nn,) elongation path lengths [m]
    rho: NDArray[np.float64]  # (B,) bound of the fastest rate [1/s]


class StrutPlant(NetworkPlant[_Arrays]):
    """The strut's true plant: a batch of specimens, stepped in compiled code.

    Parameters
    ----------
    off : iterable of str
        Rows of :attr:`extras` to switch off.
    effects : sequence of str or EffectSpec
        Concealed effects of the plant (:attr:`supported_effects`, settings over
        :attr:`effect_defaults`).
    n_screw, n_tube : int
        Finite-volume segments of the screw and of the push tube (``conduction_1d``
        off: 5 and 3, the model's resolution).

    Notes
    -----
    State (:attr:`state_names`): the temperatures of the lumped nodes, the screw
    and tube segments [°C], the seven thermocouple junctions [°C] and the
    travelled distance [km]. Inputs ``u = [feed_rate (m/min), T_air (°C)]``
    are held over each sample. Integration: classical RK4 with fixed
    sub-steps from a bound of the fastest rate of the batch (Gershgorin), so
    that ``h ρ ≤ 1``.

    Examples
    --------
    >>> import numpy as np
    >>> p = StrutPlant()
    >>> u = np.column_stack([np.full(40, 20.0), np.full(40, 21.0)])
    >>> run = p.simulate(u, 140.9, p.nominal(2))
    >>> run.outputs.shape
    (2, 40, 8)
    >>> bool(run.output("T_nut")[0, -1] > run.output("T_nut")[0, 0] + 2.0)  # the nut warms
    True
    """

    name = "strut"
    input_names = ("feed_rate", "T_air")
    output_names = OUTPUTS
    hidden_names = ("T_winding", "T_screw_mean", "T_screw_max", "T_tube_mean", "travel_km")
    units: ClassVar[dict[str, str]] = {
        **_UNITS,
        "T_winding": "°C",
        "T_screw_mean": "°C",
        "T_screw_max": "°C",
        "T_tube_mean": "°C",
        "travel_km": "km",
    }
    max_step = 20.0
    spread = SPREAD
    kernels = (_simulate, _flows)
    parameters = ratio_parameters(SPREAD, "the rig's physical estimate (module docstring)")
    extras = EXTRAS
    supported_effects = (
        "input_dependent_heat_transfer",
        "input_nonlinearity",
        "nonlinear_heat_transfer",
        "time_varying_parameter",
        "transport_delay",
        "unmeasured_disturbance",
        "missing_dynamics",
    )
    effect_defaults: ClassVar[dict[str, dict[str, Any]]] = {
        "input_dependent_heat_transfer": {"air_speed": 3.0, "at_rpm": 1000.0},
        "input_nonlinearity": {"f0_scale": 1.0},
        "nonlinear_heat_transfer": {},
        "time_varying_parameter": {"per_km": 0.04},
        "transport_delay": {"signal": "feed_rate", "delay": 600.0},
        "unmeasured_disturbance": {"signal": "T_air", "amplitude": 1.5, "period": 7200.0},
        "missing_dynamics": {"C": 20000.0, "G": 2.0, "g_air": 0.5},
    }

    def __init__(
        self,
        *,
        off: Iterable[str] = (),
        effects: Sequence[str | EffectSpec] = (),
        n_screw: int = 60,
        n_tube: int = 60,
    ) -> None:
        super().__init__(off=off, effects=effects)
        self.n_screw, self.n_tube = self._segments(
            "conduction_1d", {"n_screw": (n_screw, 5), "n_tube": (n_tube, 3)}
        )
        self.n_nodes = _NL + self.n_screw + self.n_tube
        self._set_states(
            (
                *(f"T_{k}" for k in _LUMPED),
                *(f"T_screw_{i}" for i in range(self.n_screw)),
                *(f"T_tube_{i}" for i in range(self.n_tube)),
                *(f"TC_{k}" for k in TEMPERATURES),
                "travel_km",
            )
        )

    # --------------------------------------------------------------- the network
    def _build(self, sp: dict[str, NDArray[np.float64]]) -> _Arrays:
        ph, cc = self.physics, self.concealed
        Ns, Nt, NL = self.n_screw, self.n_tube, _NL
        nn = self.n_nodes
        B = sp["loss_motor"].size
        S0, T0 = NL, NL + Ns  # first screw and tube node
        xs_e = np.linspace(0.0, _L_SCREW, Ns + 1)
        ts_e = np.linspace(0.0, _L_TUBE, Nt + 1)
        dxs, dxt = _L_SCREW / Ns, _L_TUBE / Nt
        xs_c = 0.5 * (xs_e[:-1] + xs_e[1:])
        a_screw = math.pi / 4 * _D_SCREW**2
        a_tube = math.pi / 4 * (_D_TUBE**2 - _D_TUBE_IN**2)
        # capacities
        C = np.ones((B, nn))
        for k, c in _CAP.items():
            C[:, _IX[k]] = c
        C[:, S0:T0] = _RHO_C_STEEL * a_screw * dxs
        C[:, T0:] = _RHO_C_STEEL * a_tube * dxt
        md = cc.get("missing_dynamics")
        if md is not None:
            C[:, _IX["bracket"]] = float(md.get("C", 20000.0))
        if not ph["winding_node"]:
            # the winding shares the housing's temperature: one node of both capacities
            C[:, _IX["drive"]] += C[:, _IX["winding"]]
        C *= sp["capacity"][:, None]
        # conductances
        L = Links(B)
        for a, b, g in _JOINTS:
            if a == "winding" and not ph["winding_node"]:
                continue
            L.add(_IX[a], _IX[b], g)
        for i in range(Ns - 1):
            L.add(S0 + i, S0 + i + 1, _K_STEEL * a_screw / dxs)
        for i in range(Nt - 1):
            L.add(T0 + i, T0 + i + 1, _K_STEEL * a_tube / dxt)
        L.spread(_IX["pulley_spindle"], S0, segment_weights(xs_e, *_PULLEY), _G_PULLEY_SCREW)
        w_bear = segment_weights(xs_e, *_BEARING)
        L.spread(_IX["bearing"], S0, w_bear, _G_BALLS_BEARING * sp["g_contact"])
        if md is not None:
            L.add(_IX["bracket"], _IX["bearing_housing"], float(md.get("G", 2.0)))
        # stroke-averaged contacts: nut on the screw, screw inside the push tube, tube in
        # the bushing; the carriage rides with the tube's rear end
        pos = _stroke_positions(ph["stroke_contacts"])
        w_nut = np.zeros(Ns)
        covered = np.zeros(Ns)  # length of each screw segment under the bellows [m]
        g_st = np.zeros((Ns, Nt))
        w_bush = np.zeros(Nt)
        for xn in pos:
            w_nut += segment_weights(xs_e, xn - _L_NUT / 2, xn + _L_NUT / 2)
            rear = xn + _TUBE_REAR_OFFSET
            ins = np.clip((xs_e[1:] - np.maximum(xs_e[:-1], xn + _L_NUT / 2)) / dxs, 0.0, 1.0)
            lo, hi = np.maximum(xs_e[:-1], _HOUSING_FACE), np.minimum(xs_e[1:], xn - _L_NUT / 2)
            covered += np.maximum(hi - lo, 0.0)
            j = np.clip(((xs_c - rear) / dxt).astype(int), 0, Nt - 1)
            for m in np.flatnonzero(ins > 0).tolist():
                g_st[m, j[m]] += _G_ANN_STILL * dxs * ins[m]
            w_bush += segment_weights(ts_e, _BUSHING_X - rear - 0.02, _BUSHING_X - rear + 0.02)
        w_nut /= len(pos)
        covered /= len(pos)
        g_st /= len(pos)
        w_bush /= len(pos)
        L.spread(_IX["nut"], S0, w_nut, _G_BALLS_NUT * sp["g_contact"])
        annulus = set()
        for i, j in zip(*np.nonzero(g_st), strict=True):
            L.add(S0 + int(i), T0 + int(j), g_st[i, j] * sp["g_air_screw"])
            annulus.add((S0 + int(i), T0 + int(j)))
        L.spread(_IX["carriage"], T0, segment_weights(ts_e, 0.0, 0.06), _G_CARRIAGE_TUBE)
        L.spread(_IX["bushing"], T0, w_bush, _G_BUSHING_TUBE)
        ei, ej, eg = L.arrays()
        eann = link_flags(ei, ej, annulus)
        # air exchange
        A = np.zeros((B, nn))
        A2 = np.zeros((B, nn))
        D = np.ones(nn)
        eps = np.zeros(nn)
        ftype = np.zeros(nn, dtype=np.int64)
        xf = np.zeros(nn)
        for k, (area, d, e) in _AIR.items():
            A[:, _IX[k]] = area * sp["g_air_other"]
            D[_IX[k]], eps[_IX[k]] = d, e
        if md is not None:
            A[:, _IX["bracket"]] = float(md.get("g_air", 0.5)) / 10.0  # ~10 W/(m² K)
            D[_IX["bracket"]], eps[_IX["bracket"]] = 0.2, 0.9
        # the screw behind the nut: the annulus to the bellows in series with the bellows'
        # free convection and radiation (D, eps of these nodes are the bellows')
        A[:, S0:T0] = covered[None] * sp["g_air_screw"][:, None]
        A2[:, S0:T0] = (math.pi * _COVER_D * covered)[None] * sp["g_air_other"][:, None]
        D[S0:T0], eps[S0:T0] = _COVER_D, _EPS_COVER
        ftype[S0:T0] = 1
        A[:, T0:] = math.pi * _D_TUBE * dxt * sp["g_air_tube"][:, None]
        D[T0:], eps[T0:] = _D_TUBE, _EPS_TUBE
        if ph["forced_convection"]:
            ftype[T0:] = 2
        # the drive motor's shaft fan (concealed input-dependent heat transfer)
        fan = cc.get("input_dependent_heat_transfer")
        if fan is not None:
            per_rpm = float(fan.get("air_speed", 3.0)) / float(fan.get("at_rpm", 1000.0))
            xf[_IX["drive"]] = xf[_IX["motor_flange"]] = per_rpm
        hnat, hrad = air_coefficients(D, eps, _DT_DESIGN)
        # heat sources
        part = 0.5 if ph["heat_partition"] else 0.0
        w_rpm = 2 * math.pi / 60.0 / _LEAD  # rad/s per m/min
        qlin = np.zeros((B, nn))
        qcu = np.zeros((B, nn))
        qwear = np.zeros((B, nn))
        qvisc = np.zeros((B, nn))
        lm, lb, ln = sp["loss_motor"], sp["loss_bearing"], sp["loss_nut"]
        cu_node = _IX["winding"] if ph["winding_node"] else _IX["drive"]
        qcu[:, cu_node] = _Q_COPPER / _V_REF * lm
        qlin[:, _IX["drive"]] += _Q_IRON / _V_REF * lm
        qlin[:, _IX["pulley_motor"]] += 0.5 * _Q_BELT / _V_REF
        qlin[:, _IX["pulley_spindle"]] += 0.5 * _Q_BELT / _V_REF
        kb = _M_BEARING * w_rpm * lb  # qwear: rolling contacts whose grease wears
        qwear[:, _IX["bearing"]] += (1 - part) * kb
        qwear[:, S0:T0] += part * kb[:, None] * w_bear[None]
        kn = _M_NUT * w_rpm * ln
        qwear[:, _IX["nut"]] += (1 - part) * kn
        qwear[:, S0:T0] += part * kn[:, None] * w_nut[None]
        kf = _F_BUSHING / 60.0 * lb
        qlin[:, _IX["bushing"]] += (1 - part) * kf
        qlin[:, T0:] += part * kf[:, None] * w_bush[None]
        vc = cc.get("input_nonlinearity")
        if vc is not None:
            f0b, dmb, f0n, dmn, nu = _PALMGREN
            s = float(vc.get("f0_scale", 1.0))
            pb = s * _palmgren_watts(f0b, dmb, _N_REF, nu) * lb
            pn = s * _palmgren_watts(f0n, dmn, _N_REF, nu) * ln
            qvisc[:, _IX["bearing"]] += (1 - part) * pb
            qvisc[:, S0:T0] += part * pb[:, None] * w_bear[None]
            qvisc[:, _IX["nut"]] += (1 - part) * pn
            qvisc[:, S0:T0] += part * pn[:, None] * w_nut[None]
        # thermocouples: (node a, node b, weight of b)
        tca = np.zeros(7, dtype=np.int64)
        tcb = np.zeros(7, dtype=np.int64)
        tcw = np.zeros(7)
        for c, node in enumerate(("drive", "belt_housing", "bearing", "nut")):
            tca[c] = tcb[c] = _IX[node]

        def at(x: float, first: int, n: int, length: float, c: int) -> None:
            f = np.clip(x / length * n - 0.5, 0.0, n - 1.0)
            i = min(int(f), n - 2) if n > 1 else 0
            tca[c], tcb[c], tcw[c] = first + i, first + min(i + 1, n - 1), f - i

        at(0.75, S0, Ns, _L_SCREW, 4)  # middle of the screw
        at(1.10, T0, Nt, _L_TUBE, 5)  # front of the push tube
        at(0.15, T0, Nt, _L_TUBE, 6)  # rear of the push tube
        tau = np.full((B, 7), _TC_TAU) * sp["tc_tau"][:, None]
        # elongation path: screw from the bearing pair to the nut's mean position, the tube
        wL = np.zeros(nn)
        wL[S0:T0] = segment_weights(xs_e, 0.5 * sum(_BEARING), 0.5 * sum(_STROKE)) * (
            0.5 * sum(_STROKE) - 0.5 * sum(_BEARING)
        )
        wL[T0:] = dxt
        # fastest rate (Gershgorin): conductances + air at the largest forced convection
        # (the annulus at _N_HI, the air at 30 W/(m² K), more than any surface here sees)
        f_hi = _g_annulus_np(_N_HI, ph["forced_convection"]) / _G_ANN_STILL
        tot = node_totals(ei, ej, eg, eann, f_hi, np.zeros((B, nn)))
        g_air_hi = A * 30.0
        g_air_hi[:, S0:T0] = A[:, S0:T0] * _G_ANN_STILL * f_hi
        rho = np.max((tot + g_air_hi) / C, axis=1)
        if ph["thermocouple_lag"]:
            rho = np.maximum(rho, 1.0 / tau.min(axis=1))
        return _Arrays(
            C, ei, ej, eg, eann, A, A2, D, eps, hnat, hrad, ftype, xf, qlin, qcu, qwear, qvisc,
            tca, tcb, tcw, tau, wL, rho,
        )  # fmt: skip

    def _flags(self) -> NDArray[np.int64]:
        cc = self.concealed
        return np.array(
            [
                int("nonlinear_heat_transfer" in cc),
                int("input_dependent_heat_transfer" in cc),
                int("input_nonlinearity" in cc),
                int("time_varying_parameter" in cc),
                int(self.physics["copper_resistance"]),
                int(self.physics["thermocouple_lag"]),
                int(self.physics["forced_convection"]),
            ],
            dtype=np.int64,
        )

    def _par(self) -> NDArray[np.float64]:
        tv = self.concealed.get("time_varying_parameter", {})
        return np.array(
            [
                _D_SCREW,
                _STROKE[1] - _STROKE[0],  # the push tube's boundary layer restarts each stroke
                _LEAD,
                _ALPHA_CU,
                float(tv.get("per_km", 0.04)),
                _N_REF,
                _L_MOTOR,
                _R_SCREW,
                _R_BORE,
                _KR_FREE,
                _G_ANN_COND,
                _G_ANN_RAD,
            ]
        )

    # ------------------------------------------------------------------ contract
    def initial_state(
        self,
        specimens: Specimens,
        u0: NDArray[np.float64],
        *,
        drive_warm_K: float = 0.0,
    ) -> NDArray[np.float64]:
        """At rest at the air temperature ``u0[..., 1]``, shape (B, n_x).

        ``drive_warm_K``: the motor has not fully cooled down since the last run
        (winding and housing that much above the air, the flange 60 % of it).
        """
        x = self._rest(specimens, u0)
        x[:, -1] = 0.0
        if drive_warm_K:
            for node, f in (("winding", 1.0), ("drive", 1.0), ("motor_flange", 0.6)):
                x[:, _IX[node]] += f * drive_warm_K
            x[:, self.n_nodes + 0] += drive_warm_K  # the drive thermocouple
        return x

    def outputs(
        self, x: NDArray[np.float64], u: NDArray[np.float64] | None, specimens: Specimens
    ) -> NDArray[np.float64]:
        """The seven thermocouple readings [°C] and the elongation [µm], shape (B, 8)."""
        arr = self.arrays(specimens)
        x = np.atleast_2d(x)
        nn = self.n_nodes
        if self.physics["thermocouple_lag"]:
            T = x[:, nn : nn + 7]
        else:
            T = (1 - arr.tcw) * x[:, arr.tca] + arr.tcw * x[:, arr.tcb]
        dL = 1e6 * _ALPHA_STEEL * ((x[:, :nn] - _T_REF) @ arr.wL)
        return np.column_stack([T, dL])

    def hidden(
        self, x: NDArray[np.float64], specimens: Specimens
    ) -> dict[str, NDArray[np.float64]]:
        """Truths no sensor records (:attr:`hidden_names`), each of shape (B,)."""
        x = np.asarray(x, dtype=float)
        S0, T0 = _NL, _NL + self.n_screw
        return {
            "T_winding": x[..., _IX["winding"]].copy(),
            "T_screw_mean": x[..., S0:T0].mean(axis=-1),
            "T_screw_max": x[..., S0:T0].max(axis=-1),
            "T_tube_mean": x[..., T0 : self.n_nodes].mean(axis=-1),
            "travel_km": x[..., -1].copy(),
        }

    def profiles(
        self, x: NDArray[np.float64], specimens: Specimens
    ) -> dict[str, NDArray[np.float64]]:
        """Temperature profiles along the screw and the push tube and their positions [m]."""
        x = np.atleast_2d(x)
        S0, T0 = _NL, _NL + self.n_screw
        return {
            "x_screw": (np.arange(self.n_screw) + 0.5) * _L_SCREW / self.n_screw,
            "T_screw": x[:, S0:T0].copy(),
            "x_tube": (np.arange(self.n_tube) + 0.5) * _L_TUBE / self.n_tube,
            "T_tube": x[:, T0 : self.n_nodes].copy(),
        }

    def _kernel_arrays(self, arr: _Arrays, simulate: bool) -> tuple[Any, ...]:
        iw = _IX["winding"] if self.physics["winding_node"] else _IX["drive"]
        head = (
            arr.C, arr.ei, arr.ej, arr.eg, arr.eann, arr.A, arr.A2, arr.D, arr.eps, arr.hnat,
            arr.hrad, arr.ftype, arr.xf, arr.qlin, arr.qcu, arr.qwear, arr.qvisc, arr.tca,
            arr.tcb, arr.tcw, arr.tctau,
        )  # fmt: skip
        # the simulation also sums the elongation (path lengths wL)
        return (*head, arr.wL, iw) if simulate else (*head, iw)
