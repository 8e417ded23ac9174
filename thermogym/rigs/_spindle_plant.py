"""The spindle's true plant: geometry, materials, the rig's table and :class:`SpindlePlant`.

The plant of :mod:`thermogym.rigs.spindle` (its docstring gives the design and
the sources): the rig's table of physics the model lacks (:data:`EXTRAS`),
the specimen spread (:data:`SPREAD`), the geometry and material constants,
and the plant class that builds the node network of a batch of specimens and
steps it in the compiled kernels of :mod:`thermogym.rigs._spindle_kernels`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from thermogym.rigs._convection import k_ratio_rotating_annulus
from thermogym.rigs._machine import Links, ratio_parameters, segment_weights
from thermogym.rigs._plant_base import NetworkPlant, air_coefficients, link_flags, node_totals
from thermogym.rigs._spindle_kernels import _bearing_power, _flows, _simulate
from thermogym.rigs.base import EffectSpec, ExtraPhysics, Specimens

__all__ = ["EXTRAS", "PHYSICS", "SPREAD", "TEMPERATURES", "SpindlePlant"]

#: The seven RTDs of Fig. 3c (recorded with the model's signal names).
TEMPERATURES: tuple[str, ...] = (
    "T_rear_bearing_A",
    "T_rear_bearing_B",
    "T_front_bearing_C",
    "T_front_bearing_D",
    "T_inner_housing",
    "T_rear_outer_housing",
    "T_front_outer_housing",
)
_UNITS = {"speed": "rpm", "T_amb": "°C", **{k: "°C" for k in TEMPERATURES}}

#: The rig's table: what it has that the identified model lacks (switch: ``off=[name]``).
EXTRAS: tuple[ExtraPhysics, ...] = (
    ExtraPhysics(
        "friction_power_law",
        "bearing friction at the actual speed: rolling (reduced by inlet shear heating and "
        "starvation) and sliding",
        "SKF model of the frictional moment (SKF Rolling bearings PUB BU/P1 17000, 2018; "
        "General Catalogue 6000, 2005): M = φ_ish φ_rs R1 d_m^1.97 (R2 F_a)^0.54 (ν n)^0.6 "
        "+ G_sl μ_sl, grease K_rs = 6e-8",
        "89 W at 4000 rpm, 140 at 6000, 181 at 8000 (40 °C): about n^1.0 (n^1.15 at "
        "4000-5000, n^0.86 at 7000-8000)",
        "the moment at 6000 rpm at every speed: heat proportional to speed (as the model)",
    ),
    ExtraPhysics(
        "thermal_preload",
        "the preload grows as the inner ring runs warmer than the outer ring",
        "radial expansion α d ΔT = 0.9 µm/K against ~45 N/µm of contact stiffness; "
        "G_rr ∝ F_a^0.54 (SKF)",
        "k_th = 40 N/K on a 200 N preload: +11 % of the bearing heat per kelvin of ring "
        "difference (1-1.5 K at 6000 rpm)",
        "constant preload",
    ),
    ExtraPhysics(
        "lubricant_viscosity",
        "the base oil's viscosity falls with temperature",
        "ISO VG 22: 22 mm²/s at 40 °C, 4.3 mm²/s at 100 °C, ASTM D341 (Walther) between",
        "heat −1.1 %/K at 4000 rpm, −0.5 %/K at 6000, +0.1 %/K at 8000 (40 °C); "
        "+0.1 to +3 %/K at 22 °C (thinner oil relieves the starvation)",
        "viscosity at 40 °C",
    ),
    ExtraPhysics(
        "rotating_convection",
        "nose, pulley and the spacer gap's air turn with the shaft",
        "Nu = 0.133 Re_ω^(2/3) Pr^(1/3) (Kays & Bjorklund 1958; Bossmanns & Tu, ref. [3] of "
        "001) on the nose and the pulley's free rim; Nu_R = 0.36 Re^(1/2) on its faces "
        "(Cobb & Saunders 1956); Taylor vortices in the 1 mm spacer gap (Becker & Kaye 1962)",
        "nose 2.6 W/K and pulley 3.7 W/K at 6000 rpm (0.1 and 0.2 still); spacer gap "
        "conduction ×2.6-3.6 at 4000-8000 rpm",
        "free convection and radiation only; the spacer gap conducts",
    ),
    ExtraPhysics(
        "distributed_nodes",
        "shaft, bearing sleeve and outer housing conduct; each bearing has two rings",
        "001 section 2.2.1 (Brecher et al.: bearings are the heat sources); the heat "
        "equation along each body",
        "60 nodes (30 shaft, 10 sleeve, 10 housing segments, 8 rings, pulley, bracket); the "
        "model: 14",
        "3 shaft and 2 + 2 housing segments",
    ),
    ExtraPhysics(
        "heat_partition",
        "friction heat shared by the inner and the outer ring",
        "Blok's heat partition, equal shares for equal materials",
        "50 % into the inner ring",
        "all into the outer ring",
    ),
    ExtraPhysics(
        "sensor_mounting",
        "RTD probes lag their mounting points",
        "spring-loaded probes on the outer rings, a probe in the sleeve, adhesive pads on "
        "the outer housing (001 Fig. 3c)",
        "τ = 40 s (rings), 60 s (sleeve), 120 s (outer housing) × the specimen's rtd_tau",
        "the readings are the node temperatures",
    ),
)
#: Switch names of :data:`EXTRAS`.
PHYSICS: tuple[str, ...] = tuple(e.name for e in EXTRAS)

#: Specimen spread: factor -> (low, high, what it multiplies); drawn log-uniformly.
SPREAD: dict[str, tuple[float, float, str]] = {
    "loss_bearing": (0.3, 3.0, "bearing friction (+200/−70 %, rolling contacts, 000 appendix)"),
    "preload": (0.8, 1.25, "bearing preload (±20 % mounting tolerance)"),
    "loss_belt": (0.3, 3.0, "belt hysteresis loss (+200/−70 %)"),
    "g_air": (0.8, 1.3, "air exchange and bench mount (+30/−20 %)"),
    "g_contact": (0.6, 2.0, "rolling-contact conductances (+100/−40 %)"),
    "capacity": (0.9, 1.1, "heat capacities (±10 %)"),
    "rtd_tau": (0.5, 2.0, "RTD probe time constants (mounting)"),
}

# ------------------------------------------------------------ geometry, materials
_RC_STEEL, _K_STEEL = 7850.0 * 460.0, 45.0
_RC_IRON, _K_IRON = 7200.0 * 460.0, 50.0
_K_AIR = 26.3e-3
_L_SHAFT, _D_SHAFT, _D_BORE = 0.60, 0.085, 0.025
_SLEEVE = (0.04, 0.56, 0.180, 0.125)  # x from, x to, outer, inner diameter
_OUTER = (0.0, 0.62, 0.260, 0.180)
_PULLEY = (0.0, 0.05)
_NOSE = (0.54, 0.60)
_SPACER = (0.13, 0.46)  # shaft inside the sleeve between the pairs: spacer sleeves
_SPACER_GAP = 0.001  # m air gap between rotating and stationary spacer
_R_SPACER = 0.5 * _D_SHAFT + 0.01  # m, the rotating spacer's outer radius
_SPACER_RADII = (_R_SPACER, _R_SPACER + _SPACER_GAP)
_BEARINGS = (  # name, x from, x to, d_m [mm], D − d [mm] (70-series proportions, 0.44 d_m)
    ("A", 0.07, 0.09, 80.0, 35.2),
    ("B", 0.10, 0.12, 80.0, 35.2),
    ("C", 0.47, 0.49, 90.0, 39.6),
    ("D", 0.50, 0.52, 90.0, 39.6),
)
_FITS = ((0.04, 0.13, 15.0), (0.45, 0.56, 15.0))  # sleeve in the outer housing [W/K]
_GAP_IO = 0.002  # m air gap between sleeve and outer housing between the fits
_PRELOAD, _K_TH = 200.0, 40.0
_NU40, _NU100 = 22.0, 4.3  # mm²/s: ISO VG 22 base oil of the spindle grease
#: SKF friction model, single-row angular contact ball bearings (module docstring)
_SKF_R = (5.03e-7, 1.97, 1.90e-12)  # R1, R2, R3 (rolling)
_SKF_S = (1.30e-2, 0.68, 1.91e-12)  # S1, S2, S3 (sliding)
_SKF_KZ, _SKF_KRS = 4.4, 6e-8  # geometry constant; replenishment constant, grease
_MU_BL, _MU_EHL = 0.15, 0.05  # sliding friction: boundary, full film (mineral base oil)
_N_REF = 6000.0
_Q_BELT = 1.5  # W per 1000 rpm
_C_IR, _C_OR, _C_PULLEY = 140.0, 200.0, 1800.0
_G_IR, _G_OR, _G_BALLS, _G_SPACER_RING = 25.0, 15.0, 2.5, 3.0
_G_PULLEY = 5.0
_G_LABYRINTH = 0.5
_G_BENCH = 3.0  # W/K, feet on the bench (at room temperature)
#: pulley Ø150 × 50 mm on the Ø85 shaft: the rim not under the belt (180° wrap) and two faces
_D_PULLEY, _W_PULLEY = 0.15, 0.05
_A_RIM = 0.5 * math.pi * _D_PULLEY * _W_PULLEY
_A_FACES = 2.0 * math.pi / 4.0 * (_D_PULLEY**2 - _D_SHAFT**2)
_A_PULLEY = _A_RIM + _A_FACES
_EPS_HOUSING, _EPS_SHAFT, _EPS_PULLEY = 0.9, 0.3, 0.2
_DT_DESIGN = 10.0
_RTD_TAU = (40.0, 40.0, 40.0, 40.0, 60.0, 120.0, 120.0)


def _spacer_conductance_per_m() -> float:
    """Air gap of the spacer sleeves at rest, conduction [W/(m K)] (Taylor vortices: kernel)."""
    return _K_AIR * 2 * math.pi * _R_SPACER / _SPACER_GAP


def _walther() -> tuple[float, float]:
    """ASTM D341 (Walther): ``log log (ν + 0.7) = A − B log T`` through ν at 40 and 100 °C."""
    z40 = math.log10(math.log10(_NU40 + 0.7))
    z100 = math.log10(math.log10(_NU100 + 0.7))
    t40, t100 = math.log10(313.15), math.log10(373.15)
    b = (z40 - z100) / (t100 - t40)
    return z40 + b * t40, b


_WALTHER_A, _WALTHER_B = _walther()


@dataclass(frozen=True)
class _Arrays:
    C: NDArray[np.float64]  # (B, nn)
    ei: NDArray[np.int64]
    ej: NDArray[np.int64]
    eg: NDArray[np.float64]  # (B, E)
    eann: NDArray[np.int64]  # (E,) 1: across the spacer gap (Taylor vortices while turning)
    A: NDArray[np.float64]  # (B, nn)
    gb: NDArray[np.float64]  # (B, nn) bench conductance to ambient
    D: NDArray[np.float64]
    eps: NDArray[np.float64]
    hnat: NDArray[np.float64]
    hrad: NDArray[np.float64]
    ftype: NDArray[np.int64]  # 0 none, 1 rotating shaft, 2 housing in the fan stream, 3 pulley
    bir: NDArray[np.int64]  # (4,) inner-ring node
    bor: NDArray[np.int64]  # (4,) outer-ring node
    bpar: NDArray[np.float64]  # (B, 4, 5): scale, d_m [mm], F0 [N], k_th [N/K], D − d [mm]
    qbelt: NDArray[np.float64]  # (B,) W per rpm into the pulley
    ipul: int
    rtd: NDArray[np.int64]  # (7,) node each RTD sits on
    tau: NDArray[np.float64]  # (B, 7)
    rho: NDArray[np.float64]  # (B,)


class SpindlePlant(NetworkPlant[_Arrays]):
    """The spindle's true plant: a batch of specimens, stepped in compiled code.

    Parameters
    ----------
    off : iterable of str
        Rows of :attr:`extras` to switch off.
    effects : sequence of str or EffectSpec
        Concealed effects of the plant (:attr:`supported_effects`).
    n_shaft, n_housing : int
        Segments of the shaft and of each housing (``distributed_nodes`` off:
        3 and 2, about the model's resolution).

    Notes
    -----
    State (:attr:`state_names`): node temperatures [°C], the seven RTD probes
    [°C], then the grease share in the rolling path (1 after a night at rest;
    used by the concealed ``time_varying_parameter``). Inputs
    ``u = [speed (rpm), T_amb (°C)]`` held over each sample; RK4 with fixed
    sub-steps, ``h ρ ≤ 1``.

    Examples
    --------
    >>> import numpy as np
    >>> p = SpindlePlant()
    >>> u = np.column_stack([np.full(25, 6000.0), np.full(25, 22.0)])
    >>> run = p.simulate(u, 3600.0, p.nominal())
    >>> bool(run.output("T_front_bearing_C")[0, -1] > 35.0)  # after a day at 6000 rpm
    True
    """

    name = "spindle"
    input_names = ("speed", "T_amb")
    output_names = TEMPERATURES
    hidden_names = (
        *(f"T_inner_ring_{b[0]}" for b in _BEARINGS),
        "T_shaft_max",
        "T_pulley",
        "grease_share",
    )
    units: ClassVar[dict[str, str]] = {
        **_UNITS,
        **{f"T_inner_ring_{b[0]}": "°C" for b in _BEARINGS},
        "T_shaft_max": "°C",
        "T_pulley": "°C",
        "grease_share": "1",
    }
    max_step = 5.0
    spread = SPREAD
    kernels = (_simulate, _flows)
    parameters = ratio_parameters(SPREAD, "the rig's physical estimate (module docstring)")
    extras = EXTRAS
    supported_effects = (
        "input_nonlinearity",
        "input_dependent_heat_transfer",
        "nonlinear_heat_transfer",
        "time_varying_parameter",
        "unmeasured_disturbance",
        "transport_delay",
        "missing_dynamics",
    )
    effect_defaults: ClassVar[dict[str, dict[str, Any]]] = {
        "input_nonlinearity": {"k_c": 5.0},
        "input_dependent_heat_transfer": {"air_speed": 1.5, "at_rpm": 6000.0},
        "nonlinear_heat_transfer": {},
        "time_varying_parameter": {"churn": 0.6, "tau_h": 1.5, "rest_h": 8.0},
        "unmeasured_disturbance": {"signal": "T_amb", "amplitude": 2.0, "period": 5 * 3600.0},
        "transport_delay": {"signal": "speed", "delay": 600.0},
        "missing_dynamics": {"C": 60000.0, "G": 4.0, "g_air": 1.0},
    }

    def __init__(
        self,
        *,
        off: Iterable[str] = (),
        effects: Sequence[str | EffectSpec] = (),
        n_shaft: int = 30,
        n_housing: int = 10,
    ) -> None:
        super().__init__(off=off, effects=effects)
        self.n_shaft, self.n_housing = self._segments(
            "distributed_nodes", {"n_shaft": (n_shaft, 3), "n_housing": (n_housing, 2)}
        )
        # nodes: pulley, bracket, 4 inner rings, 4 outer rings, shaft, sleeve, outer housing
        self._first = {"shaft": 10, "sleeve": 10 + self.n_shaft}
        self._first["outer"] = self._first["sleeve"] + self.n_housing
        self.n_nodes = self._first["outer"] + self.n_housing
        self._set_states(
            (
                "T_pulley",
                "T_bracket",
                *(f"T_inner_ring_{b[0]}" for b in _BEARINGS),
                *(f"T_outer_ring_{b[0]}" for b in _BEARINGS),
                *(f"T_shaft_{i}" for i in range(self.n_shaft)),
                *(f"T_sleeve_{i}" for i in range(self.n_housing)),
                *(f"T_outer_{i}" for i in range(self.n_housing)),
                *(f"RTD_{k}" for k in TEMPERATURES),
                "grease_share",
            )
        )

    def _build(self, sp: dict[str, NDArray[np.float64]]) -> _Arrays:
        ph, cc = self.physics, self.concealed
        B = sp["loss_bearing"].size
        Ns, Nh, nn = self.n_shaft, self.n_housing, self.n_nodes
        S0, I0, O0 = self._first["shaft"], self._first["sleeve"], self._first["outer"]
        xs = np.linspace(0.0, _L_SHAFT, Ns + 1)
        xi = np.linspace(_SLEEVE[0], _SLEEVE[1], Nh + 1)
        xo = np.linspace(_OUTER[0], _OUTER[1], Nh + 1)
        a_sh = math.pi / 4 * (_D_SHAFT**2 - _D_BORE**2)
        a_sl = math.pi / 4 * (_SLEEVE[2] ** 2 - _SLEEVE[3] ** 2)
        a_ou = math.pi / 4 * (_OUTER[2] ** 2 - _OUTER[3] ** 2)
        dxs, dxi, dxo = np.diff(xs)[0], np.diff(xi)[0], np.diff(xo)[0]
        C = np.ones((B, nn))
        C[:, 0] = _C_PULLEY
        md = cc.get("missing_dynamics")
        if md is not None:
            C[:, 1] = float(md.get("C", 60000.0))
        C[:, 2:6] = _C_IR
        C[:, 6:10] = _C_OR
        C[:, S0:I0] = _RC_STEEL * a_sh * dxs
        C[:, I0:O0] = _RC_STEEL * a_sl * dxi
        C[:, O0:] = _RC_IRON * a_ou * dxo
        C *= sp["capacity"][:, None]
        L = Links(B)
        for first, n, g in ((S0, Ns, _K_STEEL * a_sh / dxs), (I0, Nh, _K_STEEL * a_sl / dxi)):
            for i in range(n - 1):
                L.add(first + i, first + i + 1, g)
        for i in range(Nh - 1):
            L.add(O0 + i, O0 + i + 1, _K_IRON * a_ou / dxo)
        L.spread(0, S0, segment_weights(xs, *_PULLEY), _G_PULLEY)
        bpar = np.zeros((B, 4, 5))
        for k, (_, a, b, dm, wall) in enumerate(_BEARINGS):
            ir, orr = 2 + k, 6 + k
            L.spread(ir, S0, segment_weights(xs, a, b), _G_IR)
            L.spread(orr, I0, segment_weights(xi, a, b), _G_OR)
            L.add(ir, orr, _G_BALLS * sp["g_contact"])
            bpar[:, k, 0] = sp["loss_bearing"]  # on the SKF frictional moment
            bpar[:, k, 1] = dm
            bpar[:, k, 2] = _PRELOAD * sp["preload"]
            bpar[:, k, 3] = _K_TH if ph["thermal_preload"] else 0.0
            bpar[:, k, 4] = wall  # D − d [mm]
        for a, b in ((2, 3), (4, 5), (6, 7), (8, 9)):  # spacer rings within each pair
            L.add(a, b, _G_SPACER_RING)
        # shaft ↔ sleeve across the spacer gap, sleeve ↔ outer housing (fits, air gap)
        g_sp = _spacer_conductance_per_m() * (_SPACER[1] - _SPACER[0])
        w_s = segment_weights(xs, *_SPACER)
        w_i = segment_weights(xi, *_SPACER)
        spacer = set()
        for m in np.flatnonzero(w_s > 0).tolist():
            L.spread(S0 + m, I0, w_i, g_sp * w_s[m])
            spacer |= {(S0 + m, I0 + int(j)) for j in np.flatnonzero(w_i > 0)}
        for a, b, g in _FITS:
            w_a, w_b = segment_weights(xi, a, b), segment_weights(xo, a, b)
            for m in np.flatnonzero(w_a > 0).tolist():
                L.spread(I0 + m, O0, w_b, g * w_a[m])
        mid = (_FITS[0][1], _FITS[1][0])
        g_gap = _K_AIR * math.pi * _SLEEVE[2] * (mid[1] - mid[0]) / _GAP_IO
        w_a, w_b = segment_weights(xi, *mid), segment_weights(xo, *mid)
        for m in np.flatnonzero(w_a > 0).tolist():
            L.spread(I0 + m, O0, w_b, g_gap * w_a[m])
        L.spread(O0 + Nh - 1, S0, segment_weights(xs, *_NOSE), _G_LABYRINTH)  # labyrinth seal
        if md is not None:
            w = segment_weights(xo, _OUTER[1] - 0.12, _OUTER[1])
            L.spread(1, O0, w, float(md.get("G", 4.0)))
        ei, ej, eg = L.arrays()
        # the spacer gap's links carry Taylor vortices while the shaft turns
        eann = link_flags(ei, ej, spacer)
        # air
        A = np.zeros((B, nn))
        gb = np.zeros((B, nn))
        D = np.ones(nn)
        eps = np.zeros(nn)
        ftype = np.zeros(nn, dtype=np.int64)
        A[:, 0] = _A_PULLEY
        D[0], eps[0] = _D_PULLEY, _EPS_PULLEY
        w_nose = segment_weights(xs, *_NOSE)
        A[:, S0:I0] = math.pi * _D_SHAFT * (_NOSE[1] - _NOSE[0]) * w_nose[None]
        D[S0:I0], eps[S0:I0] = _D_SHAFT, _EPS_SHAFT
        A[:, O0:] = math.pi * _OUTER[2] * dxo
        ends = math.pi / 4 * (_OUTER[2] ** 2 - _OUTER[3] ** 2)
        A[:, O0] += ends
        A[:, O0 + Nh - 1] += ends
        D[O0:], eps[O0:] = _OUTER[2], _EPS_HOUSING
        gb[:, O0:] = _G_BENCH * segment_weights(xo, 0.20, 0.45)[None]
        if md is not None:
            A[:, 1] = float(md.get("g_air", 1.0)) / 10.0
            D[1], eps[1] = 0.3, 0.9
        A *= sp["g_air"][:, None]
        gb *= sp["g_air"][:, None]
        if ph["rotating_convection"]:
            ftype[0] = 3  # the pulley: its free rim and two faces
            ftype[S0:I0] = np.where(w_nose > 0, 1, 0)
        if "input_dependent_heat_transfer" in cc:
            ftype[O0:] = 2
        hnat, hrad = air_coefficients(D, eps, _DT_DESIGN)
        qbelt = _Q_BELT / 1000.0 * sp["loss_belt"]
        # RTDs: outer rings, sleeve centre, outer housing rear and front ends
        rtd = np.array(
            [
                6,
                7,
                8,
                9,
                I0 + int(np.clip(np.searchsorted(xi, 0.30) - 1, 0, Nh - 1)),
                O0,
                O0 + Nh - 1,
            ],
            dtype=np.int64,
        )
        tau = np.array(_RTD_TAU)[None] * sp["rtd_tau"][:, None]
        f_hi = k_ratio_rotating_annulus(12000.0, *_SPACER_RADII) if ph["rotating_convection"] else 1
        tot = node_totals(ei, ej, eg, eann, f_hi, gb)
        h_hi = 250.0 if ph["rotating_convection"] else 30.0
        rho = np.max((tot + A * h_hi) / C, axis=1)
        if ph["sensor_mounting"]:
            rho = np.maximum(rho, 1.0 / tau.min(axis=1))
        bir = np.arange(2, 6, dtype=np.int64)
        bor = np.arange(6, 10, dtype=np.int64)
        return _Arrays(
            C, ei, ej, eg, eann, A, gb, D, eps, hnat, hrad, ftype, bir, bor, bpar, qbelt, 0,
            rtd, tau, rho,
        )  # fmt: skip

    def _flags(self) -> NDArray[np.int64]:
        cc, ph = self.concealed, self.physics
        return np.array(
            [
                int("nonlinear_heat_transfer" in cc),
                int("time_varying_parameter" in cc),
                int(ph["friction_power_law"]),
                int(ph["lubricant_viscosity"]),
                int(ph["heat_partition"]),
                int(ph["sensor_mounting"]),
                int(ph["rotating_convection"]),
            ],
            dtype=np.int64,
        )

    def _par(self) -> NDArray[np.float64]:
        nl = self.concealed.get("input_nonlinearity", {})
        fan = self.concealed.get("input_dependent_heat_transfer", {})
        tv = self.concealed.get("time_varying_parameter", {})
        return np.array(
            [
                _N_REF,
                _WALTHER_A,
                _WALTHER_B,
                float(nl.get("k_c", 5.0)) if "input_nonlinearity" in self.concealed else 0.0,
                float(fan.get("air_speed", 1.5)) / float(fan.get("at_rpm", 6000.0)),
                _OUTER[1] - _OUTER[0],
                float(tv.get("churn", 0.6)),
                3600.0 * float(tv.get("tau_h", 1.5)),
                3600.0 * float(tv.get("rest_h", 8.0)),
                _NU40,
                *_SPACER_RADII,
                _A_RIM / _A_PULLEY,
                0.5 * _D_PULLEY,
            ]
        )

    # ------------------------------------------------------------------ contract
    def initial_state(self, specimens: Specimens, u0: NDArray[np.float64]) -> NDArray[np.float64]:
        """At rest at the ambient ``u0[..., 1]`` after a night (grease back in the rolling path)."""
        x = self._rest(specimens, u0)
        x[:, -1] = 1.0
        return x

    def outputs(
        self, x: NDArray[np.float64], u: NDArray[np.float64] | None, specimens: Specimens
    ) -> NDArray[np.float64]:
        """The seven RTD readings [°C], shape (B, 7)."""
        x = np.atleast_2d(x)
        if self.physics["sensor_mounting"]:
            return x[:, self.n_nodes : self.n_nodes + 7].copy()
        return x[:, self.arrays(specimens).rtd]

    def hidden(
        self, x: NDArray[np.float64], specimens: Specimens
    ) -> dict[str, NDArray[np.float64]]:
        """Truths no sensor records (:attr:`hidden_names`), each of shape (B,) (or (B, T))."""
        x = np.asarray(x, dtype=float)
        S0, I0 = self._first["shaft"], self._first["sleeve"]
        out = {f"T_inner_ring_{b[0]}": x[..., 2 + k].copy() for k, b in enumerate(_BEARINGS)}
        out["T_shaft_max"] = x[..., S0:I0].max(axis=-1)
        out["T_pulley"] = x[..., 0].copy()
        out["grease_share"] = x[..., -1].copy()
        return out

    def bearing_heat(
        self, x: NDArray[np.float64], speed: float, specimens: Specimens
    ) -> NDArray[np.float64]:
        """Friction power of the four bearings [W], shape (B, 4), at state ``x`` and ``speed``."""
        arr = self.arrays(specimens)
        x = np.ascontiguousarray(np.atleast_2d(x), dtype=float)
        out = np.zeros((x.shape[0], 4))
        _bearing_power(x, float(speed), arr.bir, arr.bor, arr.bpar, self._flags(), self._par(), out)
        return out

    def _kernel_arrays(self, arr: _Arrays, simulate: bool) -> tuple[Any, ...]:
        return (
            arr.C, arr.ei, arr.ej, arr.eg, arr.eann, arr.A, arr.gb, arr.D, arr.eps, arr.hnat,
            arr.hrad, arr.ftype, arr.bir, arr.bor, arr.bpar, arr.qbelt, arr.ipul, arr.rtd,
            arr.tau,
        )  # fmt: skip
