"""Spindle run-in rig with two multiplexed RTD modules (paper 001): its own true plant.

The rig stands in for the externally driven spindle of
``001_6d13a2cd04f5de5e.txt`` (Fig. 3b/c): a shaft in two angular-contact
bearing pairs (rear A, B; front C, D), an inner housing (the bearing sleeve)
pressed into a cast-iron outer housing, a belt pulley at the rear and the
nose at the front. Its plant, :class:`SpindlePlant`, is built from geometry,
materials, bearing friction and heat-transfer correlations; it imports
nothing from :mod:`thermogym.models` (the package's 14-node RC network,
:class:`thermogym.models.spindle.SpindleModel`, and the N4SID models of the
paper are approximations of it). Recordings carry the model's signal names.

Design (the rig's own estimates)
--------------------------------
Shaft Ø85/25 mm × 0.60 m (11 kJ/K), bearing sleeve Ø180/125 mm × 0.52 m
(25 kJ/K), cast-iron outer housing Ø260/180 mm × 0.62 m (57 kJ/K), an
aluminium pulley (1.8 kJ/K). Bearings: rear pair d_m 80 mm, front pair
d_m 90 mm, light preload 200 N, grease with ISO VG 22 base oil. Friction per
bearing (Palmgren; Harris, *Rolling Bearing Analysis*)::

    M = M_0 + M_1,  M_0 = 10⁻⁷ f_0 (ν n)^(2/3) d_m³,  M_1 = f_1 F d_m,  P = M ω

with ``f_1 = 0.001 (F_0/C_0)^(1/3)`` (SKF, angular-contact bearings; C_0 25 kN
front, 18 kN rear), the preload ``F = F_0 + k_th (T_inner ring − T_outer
ring)`` and f_0 = 0.26, the equivalent of a run-in grease fill (chosen so that
the four bearings make 116 W at 6000 rpm and 40 °C and a run-in day at
4000-8000 rpm rises by tens of kelvin as in the paper's run-in; catalogue
values for fresh grease give several times more). The viscous term, 92 % of the
heat at 6000 rpm, grows as n^(5/3), the load term as n: isothermally the heat
grows as n^1.61 from 4000 to 8000 rpm. Belt hysteresis: 1.5 W per 1000 rpm
into the pulley. The slowest time constant is about 3.5 h, so a run at
4000-8000 rpm settles (1 °C in 3 h) within the day and cools by the evening, as
in the paper's Table 4 protocol.

What the rig has that the identified model lacks
------------------------------------------------
Each entry: physical source; size; switch (``SpindlePlant(off=[name])`` or
``get_rig("spindle", off=[name])``; every item is on by default). The rows are
:data:`EXTRAS`.

``friction_power_law``
    Palmgren's viscous friction M_0 ∝ (ν n)^(2/3), so P ∝ n^(5/3), beside the
    load term ∝ n (the model: heat ∝ n). 92 % of the heat at 6000 rpm; the
    total grows as n^1.61 from 4000 to 8000 rpm at 40 °C, as n^1.32 between the
    steady states (the warmer oil is thinner: ``lubricant_viscosity``). Switch
    ``friction_power_law`` (off: the same heat at 6000 rpm, linear in n).
``thermal_preload``
    The inner ring runs warmer than the outer ring and the fixed-position
    preload grows, ``k_th`` = 40 N/K per bearing (radial expansion
    α d ΔT = 0.9 µm/K against ~45 N/µm contact stiffness): +20 % of the
    load friction (+0.75 % of the bearing heat) per kelvin of ring difference.
    Switch ``thermal_preload``.
``lubricant_viscosity``
    Base-oil viscosity falls with temperature, ν = 22 mm²/s ·
    exp(−0.027 (T − 40 °C)) (ISO VG 22: 22 mm²/s at 40 °C, 4.3 at 100 °C):
    −1.8 % of the viscous friction per kelvin. Switch ``lubricant_viscosity``.
``rotating_convection``
    Nose and pulley rotate in the air, ``Nu = 0.133 Re_ω^(2/3) Pr^(1/3)``
    (Kays & Bjorklund; Bossmanns & Tu, ref. [3] of paper 001): 160 W/(m² K)
    on the nose at 6000 rpm against 6 still. Switch ``rotating_convection``.
``distributed_nodes``
    The shaft (30 segments), the sleeve and the outer housing (10 each) are
    conducting bodies, each bearing has an inner and an outer ring joined by
    the rolling contact: 60 nodes (the model: 14). Switch ``distributed_nodes``
    (off: 3 shaft and 2 + 2 housing segments); ``n_shaft=``, ``n_housing=``.
``heat_partition``
    Friction heat shared by the inner and outer ring (50 %). Switch
    ``heat_partition`` (off: all into the outer ring).
``sensor_mounting``
    RTD probes lag their mounting points: spring-loaded against the outer
    rings τ = 40 s, inner housing 60 s, adhesive pads on the outer housing
    120 s (× the specimen's ``rtd_tau``). Switch ``sensor_mounting``.
specimen spread
    Bearing friction +200/−70 % (000 appendix, rolling contacts), preload
    ±20 %, belt loss +200/−70 %, air exchange +30/−20 %, rolling-contact
    conductance +100/−40 %, capacities ±10 %, probe lags ×0.5-2
    (:data:`SPREAD`, log-uniform). Switch ``SpindleRig.with_specimen("nominal")``.

Concealed effects (``effect_defaults``; written here, never borrowed from the
model's augmentations or the diagnosis, never named in recordings):

* ``input_nonlinearity`` — the balls' centrifugal force loads the outer
  raceway: ``F += k_c (n / 1000 rpm)²``, k_c = 5 N (12.7 mm balls at
  d_m 90 mm: ~50 N per ball at 8000 rpm), so the load friction grows as n³.
* ``input_dependent_heat_transfer`` — the drive motor's shaft fan blows along
  the outer housing at 1.5 m/s at 6000 rpm (∝ speed): laminar flat-plate
  convection (Incropera eq 7.30) mixed with free convection: the housing's air
  exchange (radiation included) 1.35× at 6000 rpm, 1.45× at 8000.
* ``nonlinear_heat_transfer`` — free convection and radiation at the actual
  temperatures instead of their 10 K linearisation.
* ``time_varying_parameter`` — grease churning: after a night at rest the
  grease has flowed back into the rolling path and the viscous friction is
  60 % higher; it channels out with a 1.5 h time constant while running and
  flows back with 8 h at rest.
* ``unmeasured_disturbance`` — a 2 K, 5 h machine-hall air-conditioning cycle
  around the spindle that the ambient RTD does not see.
* ``sensor_offset`` — 1 K on the front outer-housing RTD (3.9 Ω contact
  resistance in its connector; PT1000: 3.85 Ω/K).
* ``sensor_lag`` — that RTD in a magnetic holder: τ = 600 s.
* ``sensor_drift`` — the inner-housing RTD drifting 0.15 K/h (moisture in
  its cable gland).
* ``transport_delay`` — the speed log of the motor controller runs 10 min
  behind the sensor modules' clock.
* ``missing_dynamics`` — a 60 kJ/K headstock casting bolted to the front of
  the outer housing (4 W/K, 1 W/K to the air).

Protocols
---------
``run-in``
    Table 4: one run a day at 4000, 5000, 6000, 7000 and 8000 rpm, two folds
    each. The spindle runs at constant speed until its temperatures change by
    less than 1 °C over 3 consecutive hours (judged on the rise above ambient,
    so that the daily swing of the room does not mask the spindle's own
    settling), is then stopped, and cools until the day (24 h) is over.
``validation``
    Section 3.2: the same protocol at 4500, 5300 and 7800 rpm.

Sensors (section 2.1): two TSWTM modules, each an AD7794 converting one
channel at a time at 4.17 Hz through a multiplexer. Module 1 reads bearings A,
B, C, D and the inner housing; module 2 the rear and front outer housing and
the ambient. Channel samples are therefore asynchronous (NaN in the other
columns of a row) and uneven (clock drift and jitter); RTD noise 0.02 K
(accuracy ±0.05 K at 25 °C, Table 2), resolution 1 mK. A few outliers (device
glitches and open-circuit readings) and short Bluetooth drop-outs are included,
as the paper's data-preparation stage expects (section 2.3.1). The spindle
speed is logged by the motor controller at 1 Hz. The room temperature follows
a daily cycle (Fig. 5) with a slow random wander; each run starts at 08:00.

The rig's spindle is one specimen drawn from :data:`SPREAD` with seed
:data:`SPECIMEN_SEED`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import numba as nb
import numpy as np
from numpy.typing import NDArray

from thermogym._checks import integer
from thermogym._jitcache import cache_depends_on
from thermogym.errors import ConfigError, ShapeError, UnknownNameError
from thermogym.rigs import _convection
from thermogym.rigs._convection import (
    h_free_cylinder,
    h_mixed,
    h_moving_surface,
    h_radiation,
    h_rotating_shaft,
)
from thermogym.rigs._machine import Links, ratio_parameters, segment_weights
from thermogym.rigs.base import (
    EffectSpec,
    ExtraPhysics,
    PlantRun,
    Protocol,
    Rig,
    RigRun,
    Specimens,
    TruePlant,
)
from thermogym.rigs.sensors import Sensor

__all__ = [
    "CONVERSION_HZ",
    "MODULES",
    "PHYSICS",
    "SPECIMEN_SEED",
    "SPREAD",
    "TEMPERATURES",
    "SpindlePlant",
    "SpindleRig",
    "ambient_profile",
]

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
#: Channels of each TSWTM module, in multiplexer order.
MODULES: tuple[tuple[str, ...], ...] = (TEMPERATURES[:5], (*TEMPERATURES[5:], "T_amb"))
CONVERSION_HZ = 4.17
_UNITS = {"speed": "rpm", "T_amb": "°C", **{k: "°C" for k in TEMPERATURES}}
_ROLES = {"speed": "input", "T_amb": "disturbance", **{k: "output" for k in TEMPERATURES}}

#: The rig's table: what it has that the identified model lacks (switch: ``off=[name]``).
EXTRAS: tuple[ExtraPhysics, ...] = (
    ExtraPhysics(
        "friction_power_law",
        "viscous bearing friction grows with speed to the power 5/3 beside the load term",
        "Palmgren: M_0 = 1e-7 f_0 (ν n)^(2/3) d_m³, M_1 = f_1 F d_m (Harris, Rolling "
        "Bearing Analysis; SKF catalogue)",
        "92 % of the bearing heat at 6000 rpm; the heat grows as n^1.61 from 4000 to 8000 rpm "
        "at 40 °C (n^1.32 between the steady states: the warmer oil is thinner)",
        "the same heat at 6000 rpm, proportional to speed (as the model)",
    ),
    ExtraPhysics(
        "thermal_preload",
        "the preload grows as the inner ring runs warmer than the outer ring",
        "radial expansion α d ΔT = 0.9 µm/K against ~45 N/µm of contact stiffness",
        "k_th = 40 N/K on a 200 N preload: +20 % of the load friction (+0.75 % of the bearing "
        "heat) per kelvin of ring difference",
        "constant preload",
    ),
    ExtraPhysics(
        "lubricant_viscosity",
        "the base oil's viscosity falls with temperature",
        "ISO VG 22: 22 mm²/s at 40 °C, 4.3 mm²/s at 100 °C, ν = ν_40 exp(−0.027 (T − 40))",
        "−1.8 % of the viscous friction per kelvin",
        "viscosity at 40 °C",
    ),
    ExtraPhysics(
        "rotating_convection",
        "nose and pulley rotate in the air",
        "Nu = 0.133 Re_ω^(2/3) Pr^(1/3) (Kays & Bjorklund 1958; Bossmanns & Tu, ref. [3] of 001)",
        "160 W/(m² K) on the nose at 6000 rpm against 6 in still air",
        "free convection and radiation only",
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
#: Seed of the rig's own specimen (the spindle of the run-in system).
SPECIMEN_SEED = 0

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
_SPACER_GAP = 0.001  # m air gap between rotating and stationary spacer (Ta < 1700)
_BEARINGS = (  # name, x from, x to, d_m [mm], static load rating C_0 [N]
    ("A", 0.07, 0.09, 80.0, 18000.0),
    ("B", 0.10, 0.12, 80.0, 18000.0),
    ("C", 0.47, 0.49, 90.0, 25000.0),
    ("D", 0.50, 0.52, 90.0, 25000.0),
)
_FITS = ((0.04, 0.13, 15.0), (0.45, 0.56, 15.0))  # sleeve in the outer housing [W/K]
_GAP_IO = 0.002  # m air gap between sleeve and outer housing between the fits
_F0_VISC, _PRELOAD, _K_TH = 0.26, 200.0, 40.0
_NU40, _NU_B = 22.0, 0.027  # mm²/s, 1/K
_N_REF = 6000.0
_Q_BELT = 1.5  # W per 1000 rpm
_C_IR, _C_OR, _C_PULLEY = 140.0, 200.0, 1800.0
_G_IR, _G_OR, _G_BALLS, _G_SPACER_RING = 25.0, 15.0, 2.5, 3.0
_G_PULLEY = 5.0
_G_LABYRINTH = 0.5
_G_BENCH = 3.0  # W/K, feet on the bench (at room temperature)
_A_PULLEY, _D_PULLEY = 0.059, 0.15
_EPS_HOUSING, _EPS_SHAFT, _EPS_PULLEY = 0.9, 0.3, 0.2
_DT_DESIGN = 10.0
_RTD_TAU = (40.0, 40.0, 40.0, 40.0, 60.0, 120.0, 120.0)
_SIM_DT = 10.0  # s, grid of the protocols' simulations


def _spacer_conductance_per_m() -> float:
    """Air gap of the spacer sleeves: below Taylor's instability, conduction only [W/(m K)]."""
    r = 0.5 * _D_SHAFT + 0.01
    return _K_AIR * 2 * math.pi * r / _SPACER_GAP


@dataclass(frozen=True)
class _Arrays:
    C: NDArray[np.float64]  # (B, nn)
    ei: NDArray[np.int64]
    ej: NDArray[np.int64]
    eg: NDArray[np.float64]  # (B, E)
    A: NDArray[np.float64]  # (B, nn)
    gb: NDArray[np.float64]  # (B, nn) bench conductance to ambient
    D: NDArray[np.float64]
    eps: NDArray[np.float64]
    hnat: NDArray[np.float64]
    hrad: NDArray[np.float64]
    ftype: NDArray[np.int64]  # 0 none, 1 rotating, 2 housing in the fan stream
    bir: NDArray[np.int64]  # (4,) inner-ring node
    bor: NDArray[np.int64]  # (4,) outer-ring node
    bpar: NDArray[np.float64]  # (B, 4, 4): m0 at n_ref & 40 °C [N m], f1 d_m [m], F0 [N], k_th
    qbelt: NDArray[np.float64]  # (B,) W per rpm into the pulley
    ipul: int
    rtd: NDArray[np.int64]  # (7,) node each RTD sits on
    tau: NDArray[np.float64]  # (B, 7)
    rho: NDArray[np.float64]  # (B,)


class SpindlePlant(TruePlant):
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
        self.physics = dict(self.switches)
        self.concealed = {e.name: self.effect(e.name) or {} for e in self.effects}
        if self.physics["distributed_nodes"]:
            self.n_shaft = integer("n_shaft", n_shaft, lo=1)
            self.n_housing = integer("n_housing", n_housing, lo=1)
        else:
            self.n_shaft, self.n_housing = 3, 2
        # nodes: pulley, bracket, 4 inner rings, 4 outer rings, shaft, sleeve, outer housing
        self._first = {"shaft": 10, "sleeve": 10 + self.n_shaft}
        self._first["outer"] = self._first["sleeve"] + self.n_housing
        self.n_nodes = self._first["outer"] + self.n_housing
        self.state_names = (  # type: ignore[misc]
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
        self.n_states = len(self.state_names)
        self._cache: dict[int, tuple[Any, _Arrays]] = {}

    def arrays(self, specimens: Specimens) -> _Arrays:
        """Kernel arrays for a batch of specimens (cached per Specimens object)."""
        hit = self._cache.get(id(specimens))
        if hit is not None and hit[0] is specimens:
            return hit[1]
        missing = [k for k in SPREAD if k not in specimens]
        if missing:
            raise UnknownNameError(
                f"spindle specimens lack {missing}; they need {list(SPREAD)} (SpindlePlant.nominal)"
            )
        arr = self._build({k: specimens[k] for k in SPREAD})
        if len(self._cache) > 8:
            self._cache.clear()
        self._cache[id(specimens)] = (specimens, arr)
        return arr

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
        bpar = np.zeros((B, 4, 4))
        visc = _F0_VISC * (_NU40 * _N_REF) ** (2.0 / 3.0) * 1e-7 * 1e-3  # N m per mm³ of d_m³
        for k, (_, a, b, dm, c0) in enumerate(_BEARINGS):
            ir, orr = 2 + k, 6 + k
            L.spread(ir, S0, segment_weights(xs, a, b), _G_IR)
            L.spread(orr, I0, segment_weights(xi, a, b), _G_OR)
            L.add(ir, orr, _G_BALLS * sp["g_contact"])
            bpar[:, k, 0] = visc * dm**3 * sp["loss_bearing"]
            f1 = 0.001 * (_PRELOAD / c0) ** (1.0 / 3.0)
            bpar[:, k, 1] = f1 * dm * 1e-3 * sp["loss_bearing"]
            bpar[:, k, 2] = _PRELOAD * sp["preload"]
            bpar[:, k, 3] = _K_TH if ph["thermal_preload"] else 0.0
        for a, b in ((2, 3), (4, 5), (6, 7), (8, 9)):  # spacer rings within each pair
            L.add(a, b, _G_SPACER_RING)
        # shaft ↔ sleeve across the spacer gap, sleeve ↔ outer housing (fits, air gap)
        g_sp = _spacer_conductance_per_m() * (_SPACER[1] - _SPACER[0])
        w_s = segment_weights(xs, *_SPACER)
        w_i = segment_weights(xi, *_SPACER)
        for m in np.flatnonzero(w_s > 0).tolist():
            L.spread(S0 + m, I0, w_i, g_sp * w_s[m])
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
            ftype[0] = 1
            ftype[S0:I0] = np.where(w_nose > 0, 1, 0)
        if "input_dependent_heat_transfer" in cc:
            ftype[O0:] = 2
        hnat = np.array([h_free_cylinder(_DT_DESIGN, d) for d in D])
        hrad = np.array([h_radiation(25.0 + _DT_DESIGN / 2, 25.0 - _DT_DESIGN / 2, e) for e in eps])
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
        tot = L.totals(nn) + gb
        h_hi = 250.0 if ph["rotating_convection"] else 30.0
        rho = np.max((tot + A * h_hi) / C, axis=1)
        if ph["sensor_mounting"]:
            rho = np.maximum(rho, 1.0 / tau.min(axis=1))
        bir = np.arange(2, 6, dtype=np.int64)
        bor = np.arange(6, 10, dtype=np.int64)
        return _Arrays(
            C, ei, ej, eg, A, gb, D, eps, hnat, hrad, ftype, bir, bor, bpar, qbelt, 0,
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
                _NU40,
                _NU_B,
                float(nl.get("k_c", 5.0)) if "input_nonlinearity" in self.concealed else 0.0,
                float(fan.get("air_speed", 1.5)) / float(fan.get("at_rpm", 6000.0)),
                _OUTER[1] - _OUTER[0],
                float(tv.get("churn", 0.6)),
                3600.0 * float(tv.get("tau_h", 1.5)),
                3600.0 * float(tv.get("rest_h", 8.0)),
            ]
        )

    # ------------------------------------------------------------------ contract
    def initial_state(self, specimens: Specimens, u0: NDArray[np.float64]) -> NDArray[np.float64]:
        """At rest at the ambient ``u0[..., 1]`` after a night (grease back in the rolling path)."""
        B = specimens.n
        u0 = np.asarray(u0, dtype=float)
        Ta = np.broadcast_to(u0[..., 1] if u0.ndim else u0, (B,))
        x = np.repeat(Ta[:, None], self.n_states, axis=1)
        x[:, -1] = 1.0
        return x

    def step(
        self,
        x: NDArray[np.float64],
        u: NDArray[np.float64],
        dt: float | NDArray[np.float64],
        specimens: Specimens,
    ) -> NDArray[np.float64]:
        """The state (B, n_x) after ``dt`` seconds with ``u`` (B, 2) or (2,) held."""
        B = specimens.n
        d = self.substeps(dt, self.max_step, B)
        if np.any(d != d[0]):
            raise ShapeError("the spindle plant steps every specimen by the same dt")
        if d[0] == 0.0:
            return np.array(x, dtype=float, copy=True)
        U = np.repeat(np.broadcast_to(np.asarray(u, dtype=float), (B, 2))[:, None], 2, axis=1)
        xs = np.empty((B, 2, self.n_states))
        y = np.empty((B, 2, 7))
        self._kernel(np.asarray(x, dtype=float), U, float(d[0]), specimens, y, xs, True)
        return xs[:, 1].copy()

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

    def plant_inputs(self, u: NDArray[np.float64], dt: float, t0: float) -> NDArray[np.float64]:
        """The inputs the spindle sees: the logged speed shifted, the air disturbed."""
        s = self.effect("transport_delay")
        d = self.effect("unmeasured_disturbance")
        if s is None and d is None:
            return u
        ua = np.array(u, dtype=float, copy=True)
        T = ua.shape[1]
        if s is not None:  # the speed log runs late: the spindle turned earlier
            shift = float(s.get("delay", 600.0)) / dt
            k = np.arange(T)
            for b in range(ua.shape[0]):
                ua[b, :, 0] = np.interp(k + shift, k, ua[b, :, 0], right=ua[b, -1, 0])
        if d is not None:  # an air-conditioning cycle the ambient RTD does not see
            t = t0 + dt * np.arange(T)
            amp, per = float(d.get("amplitude", 2.0)), float(d.get("period", 18000.0))
            ua[:, :, 1] += amp * np.sin(2 * np.pi * t / per + float(d.get("phase", 0.0)))
        return ua

    def rate_bound(self, specimens: Specimens) -> float:
        """Bound of the fastest rate of the batch [1/s]."""
        return float(self.arrays(specimens).rho.max())

    def heat_flows(
        self, x: NDArray[np.float64], u: NDArray[np.float64], specimens: Specimens
    ) -> dict[str, NDArray[np.float64]]:
        """Heat balance at state ``x`` (B, n_x) with inputs ``u`` (B, 2) or (2,).

        Returns
        -------
        dict
            ``source`` (B, n_nodes) heat generated in each node [W]; ``g_air``
            (B, n_nodes) its conductance to the ambient (air and bench) [W/K];
            ``generated`` and ``to_air`` (B,) totals [W]; ``stored`` (B,)
            ``Σ C dT/dt`` [W].
        """
        arr = self.arrays(specimens)
        B, nn = specimens.n, self.n_nodes
        X = np.ascontiguousarray(np.broadcast_to(np.asarray(x, dtype=float), (B, self.n_states)))
        U = np.ascontiguousarray(np.broadcast_to(np.asarray(u, dtype=float), (B, 2)))
        rec = np.zeros((B, 2, nn))
        dxdt = np.zeros((B, self.n_states))
        _flows(
            X, U, arr.C, arr.ei, arr.ej, arr.eg, arr.A, arr.gb, arr.D, arr.eps, arr.hnat,
            arr.hrad, arr.ftype, arr.bir, arr.bor, arr.bpar, arr.qbelt, arr.ipul, arr.rtd,
            arr.tau, self._flags(), self._par(), rec, dxdt,
        )  # fmt: skip
        return {
            "source": rec[:, 0],
            "g_air": rec[:, 1],
            "generated": rec[:, 0].sum(axis=1),
            "to_air": np.sum(rec[:, 1] * (X[:, :nn] - U[:, 1:2]), axis=1),
            "stored": np.sum(arr.C * dxdt[:, :nn], axis=1),
        }

    def _simulate(
        self,
        u: NDArray[np.float64],
        dt: float,
        specimens: Specimens,
        x: NDArray[np.float64],
        t0: float,
    ) -> PlantRun:
        B, T, _ = u.shape
        y = np.empty((B, T, 7))
        xs = np.empty((B, T, self.n_states))
        self._kernel(x, u, dt, specimens, y, xs, True)
        t = t0 + dt * np.arange(T, dtype=np.float64)
        return PlantRun(t, u, y, xs, self.hidden(xs, specimens), TEMPERATURES)

    def _kernel(
        self,
        x: NDArray[np.float64],
        U: NDArray[np.float64],
        dt: float,
        specimens: Specimens,
        y: NDArray[np.float64],
        xs: NDArray[np.float64],
        keep: bool,
    ) -> None:
        arr = self.arrays(specimens)
        if x.shape != (specimens.n, self.n_states):
            raise ShapeError(f"x has shape {x.shape}, expected ({specimens.n}, {self.n_states})")
        nsub = max(1, math.ceil(dt * float(arr.rho.max())))
        _simulate(
            np.ascontiguousarray(x), np.ascontiguousarray(U), float(dt), nsub,
            arr.C, arr.ei, arr.ej, arr.eg, arr.A, arr.gb, arr.D, arr.eps, arr.hnat, arr.hrad,
            arr.ftype, arr.bir, arr.bor, arr.bpar, arr.qbelt, arr.ipul, arr.rtd, arr.tau,
            self._flags(), self._par(), y, xs, keep,
        )  # fmt: skip


# ------------------------------------------------------------------ compiled kernel
@nb.njit(cache=True)
def _friction(x, n, bir, bor, bpar, flags, par, k):  # pragma: no cover - numba
    # friction power of bearing k [W] and its mean ring temperature
    tv, law, visc = flags[1], flags[2], flags[3]
    Ti = x[bir[k]]
    To = x[bor[k]]
    w = n * 2.0 * math.pi / 60.0
    m0 = bpar[k, 0]  # at n_ref and 40 °C
    if visc:  # M_0 ∝ ν^(2/3)
        m0 *= math.exp(-par[2] * (2.0 / 3.0) * (0.5 * (Ti + To) - 40.0))
    if tv:
        m0 *= 1.0 + par[6] * x[x.shape[0] - 1]
    if law:
        m0 *= (n / par[0]) ** (2.0 / 3.0)
    else:
        m0 *= n / par[0]  # linear law: the same heat at n_ref, proportional to speed
        w = par[0] * 2.0 * math.pi / 60.0
    F = bpar[k, 2] + bpar[k, 3] * (Ti - To) + par[3] * (n / 1000.0) ** 2
    if F < 0.0:
        F = 0.0
    return w * m0 + n * 2.0 * math.pi / 60.0 * bpar[k, 1] * F


@nb.njit(cache=True)
def _bearing_power(x, n, bir, bor, bpar, flags, par, out):  # pragma: no cover - numba
    for b in range(x.shape[0]):
        for k in range(4):
            out[b, k] = _friction(x[b], n, bir, bor, bpar[b], flags, par, k) if n > 0 else 0.0


@nb.njit(cache=True)
def _rhs(
    x, n, Ta, C, ei, ej, eg, A, gb, D, eps, hnat, hrad, ftype, bir, bor, bpar, qbelt, ipul,
    rtd, tau, flags, par, out, rec, record,
):  # pragma: no cover - numba  # fmt: skip
    # dx/dt into out; with record, each node's heat source [W] and conductance to the
    # ambient [W/K] into rec[0], rec[1]
    nn = C.shape[0]
    nl, tv, part, lag = flags[0], flags[1], flags[4], flags[5]
    n = abs(n)
    for i in range(nn):
        g = gb[i]
        if A[i] > 0.0:
            d = Ta - x[i]
            if nl:
                hn = h_free_cylinder(d, D[i])
                hr = h_radiation(x[i], Ta, eps[i])
            else:
                hn = hnat[i]
                hr = hrad[i]
            if ftype[i] == 1:
                h = h_mixed(hn, h_rotating_shaft(n, D[i]))
            elif ftype[i] == 2:
                h = h_mixed(hn, h_moving_surface(par[4] * n, par[5]))
            else:
                h = hn
            g += A[i] * (h + hr)
        out[i] = g * (Ta - x[i])
        if record:
            rec[0, i] = 0.0
            rec[1, i] = g
    for e in range(ei.shape[0]):
        a = ei[e]
        b = ej[e]
        q = eg[e] * (x[b] - x[a])
        out[a] += q
        out[b] -= q
    if n > 0.0:
        share = 0.5 if part else 0.0
        for k in range(4):
            p = _friction(x, n, bir, bor, bpar, flags, par, k)
            out[bir[k]] += share * p
            out[bor[k]] += (1.0 - share) * p
            if record:
                rec[0, bir[k]] += share * p
                rec[0, bor[k]] += (1.0 - share) * p
        out[ipul] += qbelt * n
        if record:
            rec[0, ipul] += qbelt * n
    for i in range(nn):
        out[i] /= C[i]
    for c in range(7):
        out[nn + c] = (x[rtd[c]] - x[nn + c]) / tau[c] if lag else 0.0
    g = x[nn + 7]
    if tv:
        out[nn + 7] = -g / par[7] if n > 0.0 else (1.0 - g) / par[8]
    else:
        out[nn + 7] = 0.0


@nb.njit(cache=True)
def _simulate(
    x0, U, dt, nsub, C, ei, ej, eg, A, gb, D, eps, hnat, hrad, ftype, bir, bor, bpar, qbelt,
    ipul, rtd, tau, flags, par, y, xs, keep,
):  # pragma: no cover - numba  # fmt: skip
    B, T = U.shape[0], U.shape[1]
    n_x = x0.shape[1]
    nn = C.shape[1]
    h = dt / nsub
    x = np.empty(n_x)
    k1 = np.empty(n_x)
    k2 = np.empty(n_x)
    k3 = np.empty(n_x)
    k4 = np.empty(n_x)
    tmp = np.empty(n_x)
    rec = np.empty((2, 1))
    lag = flags[5]
    for b in range(B):
        x[:] = x0[b]
        for k in range(T):
            for c in range(7):
                y[b, k, c] = x[nn + c] if lag else x[rtd[c]]
            if keep:
                xs[b, k, :] = x
            if k + 1 == T:
                break
            n = U[b, k, 0]
            Ta = U[b, k, 1]
            for _ in range(nsub):
                _rhs(x, n, Ta, C[b], ei, ej, eg[b], A[b], gb[b], D, eps, hnat, hrad, ftype,
                     bir, bor, bpar[b], qbelt[b], ipul, rtd, tau[b], flags, par, k1, rec,
                     False)  # fmt: skip
                for i in range(n_x):
                    tmp[i] = x[i] + 0.5 * h * k1[i]
                _rhs(tmp, n, Ta, C[b], ei, ej, eg[b], A[b], gb[b], D, eps, hnat, hrad, ftype,
                     bir, bor, bpar[b], qbelt[b], ipul, rtd, tau[b], flags, par, k2, rec,
                     False)  # fmt: skip
                for i in range(n_x):
                    tmp[i] = x[i] + 0.5 * h * k2[i]
                _rhs(tmp, n, Ta, C[b], ei, ej, eg[b], A[b], gb[b], D, eps, hnat, hrad, ftype,
                     bir, bor, bpar[b], qbelt[b], ipul, rtd, tau[b], flags, par, k3, rec,
                     False)  # fmt: skip
                for i in range(n_x):
                    tmp[i] = x[i] + h * k3[i]
                _rhs(tmp, n, Ta, C[b], ei, ej, eg[b], A[b], gb[b], D, eps, hnat, hrad, ftype,
                     bir, bor, bpar[b], qbelt[b], ipul, rtd, tau[b], flags, par, k4, rec,
                     False)  # fmt: skip
                for i in range(n_x):
                    x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])


@nb.njit(cache=True)
def _flows(
    X, U, C, ei, ej, eg, A, gb, D, eps, hnat, hrad, ftype, bir, bor, bpar, qbelt, ipul, rtd,
    tau, flags, par, rec, dxdt,
):  # pragma: no cover - numba  # fmt: skip
    for b in range(X.shape[0]):
        _rhs(X[b], U[b, 0], U[b, 1], C[b], ei, ej, eg[b], A[b], gb[b], D, eps, hnat, hrad,
             ftype, bir, bor, bpar[b], qbelt[b], ipul, rtd, tau[b], flags, par, dxdt[b], rec[b],
             True)  # fmt: skip


for _k in (_rhs, _simulate, _flows):
    cache_depends_on(_k, _convection)


# ----------------------------------------------------------------------- the rig
def ambient_profile(
    t: np.ndarray,
    rng: np.random.Generator,
    *,
    start_clock_h: float = 8.0,
    mean: float = 24.0,
    swing: float = 1.5,
) -> np.ndarray:
    """Room temperature over a day: a daily cycle peaking mid-afternoon plus a slow wander.

    Parameters
    ----------
    t : ndarray
        Time since the start of the run [s] (uniform grid).
    rng : Generator
    start_clock_h : float
        Clock time of ``t = 0`` [h].
    mean, swing : float
        Daily mean and amplitude [°C].
    """
    clock = start_clock_h + t / 3600.0
    daily = swing * np.sin(2 * np.pi * (clock - 9.0) / 24.0)
    # slow wander: random walk smoothed over ~1 h
    step = rng.standard_normal(t.size) * 0.004
    walk = np.cumsum(step)
    k = max(1, int(3600.0 / max(t[1] - t[0], 1e-9)) if t.size > 1 else 1)
    # moving average over k samples (edge-padded), by cumulative sums: O(N)
    c = np.concatenate([[0.0], np.cumsum(np.pad(walk, (k // 2, k - 1 - k // 2), mode="edge"))])
    walk = (c[k:] - c[:-k]) / k
    return mean + rng.uniform(-1.0, 1.0) + daily + walk - walk[0]


class SpindleRig(Rig):
    """Virtual spindle run-in system (paper 001, Fig. 3b) around :class:`SpindlePlant`.

    Parameters
    ----------
    effects : sequence of str or EffectSpec
        Concealed effects (``NAME[:k=v,...]``, see the module docstring).
    off : iterable of str
        Rows of the plant's table (:data:`EXTRAS`) to switch off.
    """

    name = "spindle"
    plant_cls = SpindlePlant
    sensors: ClassVar[dict[str, Sensor]] = {
        k: Sensor(
            noise=0.02,
            resolution=0.001,
            colored=0.01,
            colored_tau=3600.0,
            source="PT1000 class A, AD7794 (001 Table 2: ±0.05 K at 25 °C); reference drift",
        )
        for k in (*TEMPERATURES, "T_amb")
    }
    supported_effects = (
        *SpindlePlant.supported_effects,
        "sensor_offset",
        "sensor_lag",
        "sensor_drift",
    )
    effect_defaults: ClassVar[dict[str, dict[str, Any]]] = {
        **SpindlePlant.effect_defaults,
        "sensor_offset": {"signal": "T_front_outer_housing", "offset": 1.0},
        "sensor_lag": {"signal": "T_front_outer_housing", "tau": 600.0},
        "sensor_drift": {"signal": "T_inner_housing", "rate": 0.15},
    }

    def __init__(
        self, effects: Sequence[str | EffectSpec] = (), *, off: Iterable[str] = ()
    ) -> None:
        super().__init__(effects, off=off)
        self.check_sensor_effects((*TEMPERATURES, "T_amb"))

    def plant(self) -> SpindlePlant:
        """The true plant with this rig's plant effects and switches."""
        return super().plant()  # type: ignore[return-value]

    @property
    def specimen(self) -> Specimens:
        """The rig's spindle: drawn from :data:`SPREAD` with :data:`SPECIMEN_SEED` unless set."""
        if self._specimen is None:
            rng = np.random.default_rng(SPECIMEN_SEED)
            self._specimen = self.plant().draw_specimens(rng, 1)
        return self._specimen

    def with_specimen(self, values: Mapping[str, float] | Specimens | str) -> SpindleRig:
        """A copy with another spindle: ``"nominal"``, a :class:`Specimens` of one, or factors."""
        if isinstance(values, str):
            if values != "nominal":
                raise ConfigError(f"specimen {values!r}; expected 'nominal', a dict or Specimens")
            values = self.plant().nominal(1)
        elif not isinstance(values, Specimens):
            bad = [k for k in values if k not in SPREAD]
            if bad:
                raise UnknownNameError(
                    f"spindle specimen factor(s) {bad} unknown; factors are {list(SPREAD)} "
                    "(the rig is not the model: it has no model parameters)"
                )
        return super().with_specimen(values)  # type: ignore[return-value]

    def days(
        self,
        experiment_ids: Sequence[str],
        speeds: Sequence[float],
        rng: np.random.Generator,
        *,
        duration_h: float = 24.0,
        max_run_h: float = 20.0,
        window_h: float = 3.0,
        settle_K: float = 1.0,
        raw: bool = True,
        metas: Sequence[dict[str, Any]] | None = None,
    ) -> list[RigRun]:
        """Run-in days at constant speeds [rpm], simulated as one batch: heat, settle, cool."""
        dt = 1.0
        n = int(duration_h * 3600 / dt)
        t = dt * np.arange(n, dtype=np.float64)
        amb = np.array([ambient_profile(t, rng) for _ in speeds])
        # the plant runs on a 10 s grid (its fastest probe lags 20 s or more; the speed
        # steps fall on the grid) and is interpolated onto the 1 s grid of the recordings
        sub = int(_SIM_DT / dt)
        ts = t[::sub]
        U = np.zeros((len(speeds), ts.size, 2))
        U[:, :, 0] = np.asarray(speeds, dtype=float)[:, None]
        U[:, :, 1] = amb[:, ::sub]
        plant = self.plant()
        spec = self.specimen.take(np.zeros(len(speeds), dtype=np.int64))
        y = plant.simulate(U, _SIM_DT, spec).outputs
        rise = y - U[:, :, 1:2]
        w = int(window_h * 3600 / _SIM_DT)
        stops = []
        for b in range(len(speeds)):
            change = np.abs(rise[b, w:] - rise[b, :-w]).max(axis=1)
            settled = np.nonzero(change < settle_K)[0]
            k_stop = settled[0] + w if settled.size else ts.size
            stops.append(int(min(k_stop * sub, max_run_h * 3600 / dt, n)))
            U[b, stops[-1] // sub :, 0] = 0.0
        y = plant.simulate(U, _SIM_DT, spec).outputs
        out = {
            k: np.array([np.interp(t, ts, y[b, :, i]) for b in range(len(speeds))])
            for i, k in enumerate(TEMPERATURES)
        }
        speed_log = np.zeros((len(speeds), n))
        for b, s in enumerate(speeds):
            speed_log[b, : stops[b] - stops[b] % sub] = float(s)
        runs = []
        for b, (eid, speed) in enumerate(zip(experiment_ids, speeds, strict=True)):
            meta = {"speed_rpm": float(speed), "stop_s": float((stops[b] - stops[b] % sub) * dt)}
            meta |= dict(metas[b]) if metas else {}
            vals = {k: out[k][b] for k in TEMPERATURES}
            truth = vals | {"T_amb": amb[b], "speed": speed_log[b].copy()}
            if not raw:
                cols = {
                    "speed": speed_log[b].copy(),
                    **self.measure({"T_amb": amb[b]}, rng, t),
                    **self.measure(vals, rng, t),
                }
                runs.append(RigRun(eid, t, cols, dict(_UNITS), dict(_ROLES), meta, truth))
            else:
                runs.append(
                    self._raw(eid, t, speed_log[b], {**vals, "T_amb": amb[b]}, rng, meta, truth)
                )
        return runs

    def day(
        self,
        experiment_id: str,
        speed: float,
        rng: np.random.Generator,
        *,
        raw: bool = True,
        meta: dict[str, Any] | None = None,
        **options: Any,
    ) -> RigRun:
        """One run-in day at constant ``speed`` [rpm] (see :meth:`days`)."""
        return self.days([experiment_id], [speed], rng, raw=raw, metas=[meta or {}], **options)[0]

    def _raw(
        self,
        experiment_id: str,
        t: np.ndarray,
        speed: np.ndarray,
        values: dict[str, np.ndarray],
        rng: np.random.Generator,
        meta: dict[str, Any],
        truth: dict[str, np.ndarray],
    ) -> RigRun:
        """Asynchronous multiplexed sampling with outliers and drop-outs."""
        t_end = t[-1]
        times, chans, vals = [], [], []
        channels = [c for module in MODULES for c in module]
        for module in MODULES:
            period = (1.0 / CONVERSION_HZ) * (1.0 + rng.normal(0.0, 2e-4))  # clock tolerance
            k = np.arange(int(t_end / period))
            tk = rng.uniform(0.0, period) + k * period + rng.normal(0.0, 0.002, k.size)
            tk = np.clip(tk, 0.0, t_end)
            ch = k % len(module)
            keep = np.ones(k.size, dtype=bool)
            for _ in range(rng.integers(2, 5)):  # Bluetooth drop-outs of 5-40 s
                a = rng.uniform(0.05, 0.95) * t_end
                keep &= ~((tk >= a) & (tk < a + rng.uniform(5.0, 40.0)))
            tk, ch = tk[keep], ch[keep]
            for j, name in enumerate(module):
                sel = ch == j
                true = np.interp(tk[sel], t, values[name])
                meas = self.sensor(name).measure(true, rng, tk[sel])
                times.append(tk[sel])
                chans.append(np.full(sel.sum(), channels.index(name)))
                vals.append(meas)
        tt, cc, vv = np.concatenate(times), np.concatenate(chans), np.concatenate(vals)
        # outliers: glitches of +15..60 K and open-circuit readings at the range limits
        n_out = int(rng.integers(4, 10))
        idx = rng.choice(tt.size, n_out, replace=False)
        glitch = rng.uniform(15.0, 60.0, n_out)
        vv[idx] = np.where(
            rng.random(n_out) < 0.7, vv[idx] + glitch, rng.choice([-50.0, 300.0], n_out)
        )
        # the speed log of the motor controller, 1 Hz
        tt = np.concatenate([tt, t])
        cc = np.concatenate([cc, np.full(t.size, len(channels))])
        vv = np.concatenate([vv, speed])
        tt = np.round(tt, 3)
        order = np.lexsort((cc, tt))
        tt, cc, vv = tt[order], cc[order], vv[order]
        ut, row = np.unique(tt, return_inverse=True)
        names = [*channels, "speed"]
        cols = {name: np.full(ut.size, np.nan) for name in names}
        for j, name in enumerate(names):
            sel = cc == j
            cols[name][row[sel]] = vv[sel]
        meta = {**meta, "sampling": "asynchronous: 2 multiplexed 4.17 Hz RTD modules, speed 1 Hz"}
        return RigRun(experiment_id, ut, cols, dict(_UNITS), dict(_ROLES), meta, truth)


def _run_in(
    rig: SpindleRig,
    rng: np.random.Generator,
    *,
    speeds=(4000, 5000, 6000, 7000, 8000),
    folds=(1, 2),
    raw: bool = True,
    duration_h: float = 24.0,
) -> list[RigRun]:
    pairs = [(float(s), int(f)) for s in speeds for f in folds]
    return rig.days(
        [f"spindle-{int(s)}rpm-fold{f}" for s, f in pairs],
        [s for s, _ in pairs],
        rng,
        raw=raw,
        duration_h=duration_h,
        metas=[{"fold": f} for _, f in pairs],
    )


def _validation(
    rig: SpindleRig,
    rng: np.random.Generator,
    *,
    speeds=(4500, 5300, 7800),
    raw: bool = True,
    duration_h: float = 24.0,
) -> list[RigRun]:
    return rig.days(
        [f"spindle-{int(s)}rpm-validation" for s in speeds],
        [float(s) for s in speeds],
        rng,
        raw=raw,
        duration_h=duration_h,
    )


SpindleRig.protocols = {
    "run-in": Protocol("run-in", "Table 4: a day at 4000-8000 rpm, two folds each", _run_in),
    "validation": Protocol("validation", "section 3.2: days at 4500, 5300, 7800 rpm", _validation),
}
