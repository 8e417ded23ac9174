"""Room rig: an office heated by a radiator whose valve the AXT211 rig's actuator moves.

The true plant
--------------
:class:`RoomPlant` is written apart from :mod:`thermogym.models.room` (which
it shares signal names with, no equations): a hot-water heating branch, a
panel radiator, a four-node office zone, and as actuator the AXT211 rig's own
true plant (:class:`thermogym.rigs.axt211.AXT211Plant`, every parameter and
switch of its table included), which here sits on a valve body full of supply
water in the radiator's warm plume.

States: the AXT211 plant's nine, then 8 supply-pipe segments and 6 radiator
segments [°C], the zone's air, internal mass (floor, furniture, partitions),
wall inner layer and wall outer layer [°C], and the heat emitted [J]. Inputs:
``u``, ``k_U`` (actuator), ``T_out`` [°C], ``Q_sol`` (solar gains through the
windows) and ``Q_occ`` (people, equipment) [W]. Sub-steps of at most 0.5 s:
room by the midpoint rule, actuator by its own sub-step
(:mod:`thermogym.rigs._room_physics`)::

    T_sup   = 20 + (T_sup,d − 20) ((20 − T_out)/(20 − T_out,d))^(1/n_c) + ΔT_b sin(2π t/P_b)
    Φ(h)    = 1 / sqrt(a / f(h)² + 1 − a),   h = x_V / x_max          (installed characteristic)
    ṁ c_w   = Φ Q_nom / ΔT_w,nom
    C_p/8 Ṫ_p,i = ṁ c_w (T_p,i−1 − T_p,i) − G_p/8 (T_p,i − T_a)        (plug flow, 8 segments)
    C_r/6 Ṫ_r,i = ṁ c_w (T_r,i−1 − T_r,i) − K/6 (T_r,i − T_a)^n,  K = Φ_50 / 50^n   (EN 442-2)
    C_a Ṫ_a = (1 − f_r) Q + H_int (T_i − T_a) + H_aw (T_wi − T_a) + Q_pipe + P_PTC
              + f_sa Q_sol + f_oa Q_occ − H_ve (T_a − T_out),
    H_ve    = H_win + H_inf + H_occ min(Q_occ / Q_occ,ref, 1)
    C_i Ṫ_i = H_int (T_a − T_i) + f_si Q_sol + 0.6 (1 − f_oa) Q_occ + f_r Q / 2
    C_wi Ṫ_wi = H_aw (T_a − T_wi) − H_wc (T_wi − T_wo) + (1 − f_sa − f_si) Q_sol
              + 0.4 (1 − f_oa) Q_occ + f_r Q / 2
    C_wo Ṫ_wo = H_wc (T_wi − T_wo) − H_we (T_wo − T_out)
    actuator: AXT211Plant with T_U = T_a + f_pl (T̄_r − T_a), its valve neck on water at T_p,8

What the rig has that the room model lacks
------------------------------------------
The AXT211 rig's table (:data:`thermogym.rigs.axt211.AXT211_EXTRAS`) and
:data:`ROOM_EXTRAS` (switched off by ``RoomPlant(off=[name])``):

{extras}

Protocol
--------
``thermostat``
    ``days`` winter days (synthetic weather of the rig: daily swing, slow
    anomaly, a clear-sky solar bell) with an on/off room thermostat (0.5 K
    hysteresis around 21 °C occupied, 17 °C otherwise, Monday-Friday 7-18 h)
    switching the actuator; records the room, the radiator, the supply and
    the actuator.

Sensors: room thermostat (NTC in a wall housing: 0.05 K white + 0.05 K
coloured, 4 min lag, 0.1 K steps), outdoor sensor (0.2 K, 10 min lag in its
shield), both polled over the building bus, where a missed poll (about one
every 10 h, 3 min on average) repeats the last value; supply and radiator
contact sensors (0.3 and 0.2 K, 1 min and 30 s lag) with a 2 K spike about
every 20 h (the boiler's igniter and the pump switching next to their cables);
heat meter (2 % coloured) read over M-Bus, a failed read-out (one in 20 h,
15 min) keeping the last value; the actuator's stroke (not measured in a real
room; recorded for the rig). These rates are this rig's assumptions, not
measured figures.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from thermogym._checks import choice
from thermogym.rigs import _axt211_physics as _ax
from thermogym.rigs import _room_physics as _rp
from thermogym.rigs.axt211 import AXT211_EXTRAS, AXT211_PARAMETERS, AXT211Plant
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

__all__ = ["ROOM_EXTRAS", "ROOM_PARAMETERS", "RoomPlant", "RoomRig"]

_PP = PhysicalParameter
_CH = "chosen here: a 20 m² office, one facade, medium-weight 1970s building"

#: The room's own physical parameters (after the actuator's), with their spread.
ROOM_PARAMETERS: tuple[PhysicalParameter, ...] = (
    _PP("C_air", 1.0e5, "J/K", "air (65 kJ/K for 54 m³) and light contents", _CH, 0.10),
    _PP("C_int", 2.0e6, "J/K", "internal mass: screed surface, furniture, partitions", _CH, 0.15),
    _PP("H_int", 150.0, "W/K", "air ↔ internal-mass surfaces (~50 m², 3 W/(m²K))",
        "EN ISO 6946 convective coefficients", 0.15),
    _PP("C_wi", 1.2e6, "J/K", "external wall, inner layer (plaster, masonry)", _CH, 0.10),
    _PP("H_aw", 69.0, "W/K", "air ↔ wall inner surface (9 m², R_si 0.13 m²K/W)",
        "EN ISO 6946: R_si = 0.13 m²K/W", 0.10),
    _PP("H_wc", 10.8, "W/K", "wall core, U = 1.0 W/(m²K) overall (1970s masonry)", _CH, 0.15),
    _PP("C_wo", 3.0e5, "J/K", "external wall, outer layer (render)", _CH, 0.15),
    _PP("H_we", 225.0, "W/K", "wall outer surface ↔ outdoors (R_se 0.04 m²K/W)",
        "EN ISO 6946: R_se = 0.04 m²K/W", 0.10),
    _PP("H_win", 8.4, "W/K", "window 3 m², U_w = 2.8 W/(m²K) (old double glazing)",
        "EN ISO 10077-1", 0.10),
    _PP("H_inf", 11.0, "W/K", "infiltration 0.6 1/h × 54 m³ × 0.34 Wh/(m³K)", _CH, 0.25),
    _PP("H_occ", 9.2, "W/K", "extra ventilation while occupied, 0.5 1/h",
        "EN 16798-1 occupancy-based ventilation", 0.25),
    _PP("Q_occ_ref", 250.0, "W", "occupancy gains of full occupancy", _CH, 0.0),
    _PP("f_sol_air", 0.10, "1", "share of solar gains into the air",
        "ISO 52016-1: solar to the air node 0-0.1", 0.2),
    _PP("f_sol_int", 0.60, "1", "share of solar gains onto the internal mass (floor)",
        "ISO 52016-1: floor and furniture take most of it", 0.1),
    _PP("f_occ_air", 0.50, "1", "convective share of occupancy gains",
        "ISO 13790 annex: people about half convective", 0.1),
    _PP("Phi_50", 2300.0, "W", "radiator output at 50 K excess (type 22, 600 × 1000 mm)",
        "EN 442-2 catalogue value", 0.05),
    _PP("n_rad", 1.3, "1", "radiator exponent", "EN 442-2: panel radiators 1.25-1.35", 0.02),
    _PP("C_rad", 3.8e4, "J/K", "radiator water 6 l and steel 28 kg", _CH, 0.05),
    _PP("f_rad_rad", 0.30, "1", "radiant share of the radiator's emission",
        "panel radiators: 30-50 % radiant", 0.15),
    _PP("Q_nom", 1200.0, "W", "design output setting the design flow (lockshield)", _CH, 0.05),
    _PP("dT_w_nom", 10.0, "K", "design water temperature drop 55/45 °C", _CH, 0.0),
    _PP("C_pipe", 3.4e3, "J/K", "supply pipe 4 m DN15: 0.8 l water and copper",
        "DN15: 0.2 l/m", 0.10),
    _PP("G_pipe", 1.0, "W/K", "supply pipe heat loss, 4 m insulated",
        "EN 12828: ~0.25 W/(m K) insulated", 0.2),
    _PP("authority", 0.5, "1", "valve authority (valve Δp / branch Δp at full flow)",
        "VDI 2073: design values 0.3-0.7", 0.2),
    _PP("R_v", 30.0, "1", "rangeability of an equal-percentage valve", "valve datasheets", 0.1),
    _PP("leak", 5e-4, "1", "seat leakage as a fraction of k_vs", "EN 60534-4 class IV", 0.2),
    _PP("T_sup_d", 55.0, "°C", "supply at the design outdoor temperature", _CH, 0.0),
    _PP("T_out_d", -10.0, "°C", "design outdoor temperature", _CH, 0.0),
    _PP("n_curve", 1.3, "1", "heating-curve curvature (radiator exponent)",
        "heating-controller practice", 0.0),
    _PP("ripple_K", 2.0, "K", "supply swing of an on/off boiler at part load",
        "boiler cycling", 0.25),
    _PP("ripple_s", 1200.0, "s", "boiler cycle period", "boiler cycling", 0.2),
    _PP("f_plume", 0.15, "1", "share of the radiator excess the actuator's air has",
        "radiator plume near the valve", 0.3),
)  # fmt: skip

#: The room's own rows of the rig's table (the actuator's come from the AXT211 rig).
ROOM_EXTRAS: tuple[ExtraPhysics, ...] = (
    ExtraPhysics("solar_gains", "solar gains land on floor, furniture and walls",
                 "ISO 52016-1 distribution (model: Q_int split by f_int)",
                 "10 % air, 60 % internal mass, 30 % wall", "half air, half internal mass"),
    ExtraPhysics("occupancy_ventilation", "ventilation grows while the room is occupied",
                 "EN 16798-1 occupancy-based rates (model: constant H_ao)",
                 "+0.5 1/h (9.2 W/K) at full occupancy", "half the extra, always"),
    ExtraPhysics("pipe_transport", "plug flow in the supply pipe: transport time, cooling",
                 "4 m DN15 supply pipe (model: none)", "28 s at design flow, 5 min at 10 %",
                 "radiator inlet at the supply temperature"),
    ExtraPhysics("valve_authority", "installed valve characteristic with authority 0.5",
                 "VDI 2073 valve sizing (model: authority 1)",
                 "50 % flow at 30 % of a linear valve's stroke", "authority 1"),
    ExtraPhysics("radiator_segments", "emission distributed along the water path",
                 "EN 442-2, log-mean excess (model: one mixed node)", "6 segments",
                 "one mixed node"),
    ExtraPhysics("radiant_emission", "30 % of the emission is radiant",
                 "panel radiators 30-50 % radiant (model: all to the air)",
                 "half onto internal mass, half onto the wall", "all to the air"),
    ExtraPhysics("hot_valve_body", "the actuator's neck sits on a valve full of supply water",
                 "valve body at the pipe water temperature (model: none)",
                 "G_va 0.08 W/K to ~55 °C water", "neck at the actuator's air"),
    ExtraPhysics("actuator_plume", "the actuator sits in the radiator's warm plume",
                 "convection plume (model: T_U = T_zone)", "15 % of the radiator excess",
                 "the room air"),
    ExtraPhysics("curved_heating_curve", "supply curved by the radiator exponent",
                 "heating-controller practice (model: linear curve)",
                 "+2.4 K at 5 °C outdoor", "linear"),
    ExtraPhysics("boiler_cycling", "an on/off boiler at part load swings the supply",
                 "boiler cycling (model: none)", "+-2 K, 20 min", "no swing"),
    ExtraPhysics("zone_nodes", "air, internal mass, wall inner and outer layer",
                 "ISO 52016-1 multi-node zone (model: air + structure)", "4 stores",
                 "air + one lumped store"),
)  # fmt: skip

__doc__ = (__doc__ or "").replace("{extras}", extras_table(ROOM_EXTRAS))
_ACT = tuple(p.name for p in AXT211_PARAMETERS)
_ROOM = tuple(p.name for p in ROOM_PARAMETERS)
_SW_ACT = tuple(e.name for e in AXT211_EXTRAS)
_SW_ROOM = tuple(e.name for e in ROOM_EXTRAS)
assert len(_ROOM) == _rp.N_ROOM_PARAMS and len(_SW_ROOM) == _rp.N_ROOM_SWITCHES

_OUT = ("T_zone", "T_rad", "T_supply", "Q_heat", "x_V", "P_PTC", "T_P", "T_U")
_UNITS = {
    "u": "1", "k_U": "V", "T_out": "°C", "Q_sol": "W", "Q_occ": "W", "T_zone": "°C",
    "T_rad": "°C", "T_supply": "°C", "Q_heat": "W", "x_V": "mm", "P_PTC": "W", "T_P": "°C",
    "T_U": "°C",
}  # fmt: skip
_HIDDEN = ("T_internal", "T_wall", "T_valve_water", "Q_heat_J", "E_el")
#: Concealed effects of the room rig: the actuator's, in the AXT211 rig's physics.
_ROOM_EFFECTS = ("backlash", "phase_change", "supply_variation", "nonlinear_heat_transfer")


class RoomPlant(TruePlant):
    """The room rig's true plant: heating branch, radiator, zone and the AXT211 rig (batched).

    Parameters
    ----------
    valve : {"linear", "equal_percentage"}
        Inherent characteristic of the radiator valve.
    off : iterable of str
        Rows of the table to switch off (the room's and the actuator's).
    effects : sequence
        Concealed effects of the actuator (those of :class:`AXT211Plant`).

    Examples
    --------
    >>> import numpy as np
    >>> plant = RoomPlant()
    >>> u = np.tile([1.0, 24.0, -5.0, 0.0, 0.0], (1800, 1))   # valve driven open, cold day
    >>> run = plant.simulate(u, 1.0, plant.nominal())
    >>> bool(run.output("Q_heat")[0, -1] > 800.0)
    True
    """

    name = "room"
    input_names = ("u", "k_U", "T_out", "Q_sol", "Q_occ")
    output_names = _OUT
    hidden_names = _HIDDEN
    state_names = (
        *AXT211Plant.state_names,
        *(f"T_pipe_{i}" for i in range(_rp.N_PIPE)),
        *(f"T_rad_{i}" for i in range(_rp.N_RAD)),
        "T_air", "T_int", "T_wi", "T_wo", "Q_J",
    )  # fmt: skip
    units: ClassVar[dict[str, str]] = {
        **_UNITS, "T_internal": "°C", "T_wall": "°C", "T_valve_water": "°C", "Q_heat_J": "J",
        "E_el": "J",
    }  # fmt: skip
    max_step = 0.5
    parameters = (*AXT211_PARAMETERS, *ROOM_PARAMETERS)
    extras = (*AXT211_EXTRAS, *ROOM_EXTRAS)
    supported_effects = _ROOM_EFFECTS
    effect_defaults: ClassVar[dict[str, dict[str, Any]]] = {
        k: AXT211Plant.effect_defaults[k] for k in _ROOM_EFFECTS
    }

    def __init__(
        self,
        valve: str = "linear",
        *,
        off: Sequence[str] = (),
        effects: Sequence[Any] = (),
    ) -> None:
        super().__init__(off=off, effects=effects)
        self.valve = choice("valve", valve, ("linear", "equal_percentage"))
        self._kind = 0 if valve == "linear" else 1
        act_off = [n for n in off if n in _SW_ACT]
        self.actuator = AXT211Plant(off=act_off, effects=effects)
        self._swa = _ax.switch_vector(self.actuator.switches, _SW_ACT)
        self._swr = _ax.switch_vector(self.switches, _SW_ROOM)

    def _params(self, specimens: Specimens) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        cached = getattr(self, "_kp", None)
        if cached is not None and cached[0] is specimens:
            return cached[1], cached[2]
        pa = self.actuator.kernel_params(specimens)
        q = specimens.array(_ROOM)
        self._kp = (specimens, pa, q)
        return pa, q

    def initial_state(self, specimens: Specimens, u0: NDArray[np.float64]) -> NDArray[np.float64]:
        """Unheated steady state for the first inputs: zone, walls and water at one temperature.

        The zone temperature is that of a room without heating for these
        outdoor conditions and gains (the caller may set its own, see
        :meth:`warm_state`).
        """
        B = specimens.n
        u0 = np.broadcast_to(np.asarray(u0, dtype=float).reshape(-1, 5), (B, 5))
        pa, q = self._params(specimens)
        x = np.zeros((B, _rp.N_STATES))
        for b in range(B):
            Tout, Qs, Qo = u0[b, 2], u0[b, 3], u0[b, 4]
            H = (
                q[b, _rp.R_HWIN]
                + q[b, _rp.R_HINF]
                + q[b, _rp.R_HOCC] * min(max(Qo / q[b, _rp.R_QOCC], 0.0), 1.0)
            )
            Uw = 1.0 / (1.0 / q[b, _rp.R_HWIO] + 1.0 / q[b, _rp.R_HWOE])
            Tz = Tout + (Qs + Qo) / (H + Uw)
            x[b] = self._state_at(b, Tz, Tout, pa, q)
        return x

    def warm_state(
        self, specimens: Specimens, T_zone: ArrayLike, T_out: ArrayLike
    ) -> NDArray[np.float64]:
        """A heated room: air, internal mass and water at ``T_zone``, walls at their gradient."""
        B = specimens.n
        pa, q = self._params(specimens)
        Tz = np.broadcast_to(np.asarray(T_zone, dtype=float), (B,))
        To = np.broadcast_to(np.asarray(T_out, dtype=float), (B,))
        return np.stack([self._state_at(b, Tz[b], To[b], pa, q) for b in range(B)])

    def _state_at(self, b: int, Tz: float, Tout: float, pa: Any, q: Any) -> NDArray[np.float64]:
        x = np.zeros(_rp.N_STATES)
        # the wall carries the steady heat flow through it
        hwc, hwe = q[b, _rp.R_HWIO], q[b, _rp.R_HWOE]
        haw = q[b, _rp.R_HAWI]
        U = 1.0 / (1.0 / haw + 1.0 / hwc + 1.0 / hwe)
        flow = U * (Tz - Tout)
        x[_rp.I_AIR] = Tz
        x[_rp.I_INT] = Tz
        x[_rp.I_WI] = Tz - flow / haw
        x[_rp.I_WO] = Tout + flow / hwe
        x[_rp.I_PIPE : _rp.I_PIPE + _rp.N_PIPE] = Tz
        x[_rp.I_RAD : _rp.I_RAD + _rp.N_RAD] = Tz
        x[: _rp.NA] = self.actuator.rest_state(pa[b], Tz)
        return x

    def step(
        self,
        x: NDArray[np.float64],
        u: NDArray[np.float64],
        dt: float | NDArray[np.float64],
        specimens: Specimens,
        t: float | NDArray[np.float64] = 0.0,
        turns: Turns | None = None,
    ) -> NDArray[np.float64]:
        """Advance every room by ``dt`` with ``u`` (B, 5) held; ``t``: time (boiler cycle) [s].

        ``turns``: note the turns of one state over the sub-steps there (:class:`Turns`).
        """
        B = specimens.n
        xn = np.array(x, dtype=float, copy=True)
        ub = np.ascontiguousarray(np.broadcast_to(np.asarray(u, dtype=float), (B, 5)))
        d = self.substeps(dt, self.max_step, B)
        tb = np.ascontiguousarray(np.broadcast_to(np.asarray(t, dtype=float), (B,)))
        pa, q = self._params(specimens)
        if turns is None:
            _rp.step_batch(xn, ub, tb, d, pa, q, self._swa, self._swr, self.max_step, self._kind)
        else:
            _rp.step_batch_noting(
                xn, ub, tb, d, pa, q, self._swa, self._swr, self.max_step, self._kind,
                turns.column, turns.state, turns.values,
            )  # fmt: skip
        return xn

    def outputs(
        self,
        x: NDArray[np.float64],
        u: NDArray[np.float64],
        specimens: Specimens,
        t: float | NDArray[np.float64] = 0.0,
    ) -> NDArray[np.float64]:
        """T_zone, T_rad (mean), T_supply, Q_heat, x_V, P_PTC, T_P, T_U of the actuator."""
        B = specimens.n
        ub = np.ascontiguousarray(np.broadcast_to(np.asarray(u, dtype=float), (B, 5)))
        tb = np.broadcast_to(np.asarray(t, dtype=float), (B,))
        pa, q = self._params(specimens)
        y = np.empty((B, len(_OUT)))
        for b in range(B):
            _rp.observe(x[b], ub[b], tb[b], pa[b], q[b], self._swa, self._swr, self._kind, y[b])
        return y

    def hidden(
        self, x: NDArray[np.float64], specimens: Specimens
    ) -> dict[str, NDArray[np.float64]]:
        """Internal mass, wall inner layer, water at the valve, emitted heat, actuator energy."""
        return {
            "T_internal": x[:, _rp.I_INT].copy(),
            "T_wall": x[:, _rp.I_WI].copy(),
            "T_valve_water": x[:, _rp.I_PIPE + _rp.N_PIPE - 1].copy(),
            "Q_heat_J": x[:, _rp.I_Q].copy(),
            "E_el": x[:, _ax.X_E].copy(),
        }

    def _simulate(self, u, dt, specimens, x, t0):  # type: ignore[no-untyped-def]
        B, T, _ = u.shape
        pa, q = self._params(specimens)
        y = np.empty((B, T, len(_OUT)))
        xs = np.empty((B, T, _rp.N_STATES))
        _rp.simulate_batch(np.ascontiguousarray(x), u, t0, dt, pa, q, self._swa, self._swr,
                           self.max_step, self._kind, y, xs)  # fmt: skip
        hid = {n: np.empty((B, T)) for n in _HIDDEN}
        for k in range(T):
            for n, v in self.hidden(xs[:, k], specimens).items():
                hid[n][:, k] = v
        return PlantRun(t0 + dt * np.arange(T), u, y, xs, hid, self.output_names)


def _weather(rng: np.random.Generator, n: int, dt: float) -> tuple[np.ndarray, np.ndarray]:
    # a winter day after day: daily swing, slow anomaly, clear-sky solar bell (peak 400 W)
    t = dt * np.arange(n)
    hour = (t / 3600.0) % 24.0
    a = np.exp(-dt / (36 * 3600.0))
    z = rng.standard_normal(n)
    anom = np.empty(n)
    anom[0] = 2.0 * z[0]
    for k in range(1, n):
        anom[k] = a * anom[k - 1] + 2.0 * np.sqrt(1 - a * a) * z[k]
    T_out = 1.0 + 3.0 * np.sin(2 * np.pi * (hour - 9.0) / 24.0) + anom
    sol = 400.0 * np.clip(np.sin(np.pi * (hour - 8.0) / 8.0), 0.0, None) * (hour > 8) * (hour < 16)
    return T_out, sol


class RoomRig(Rig):
    """Virtual office with a radiator, its valve and the AXT211 rig as actuator."""

    name = "room"
    plant_cls = RoomPlant
    sensors: ClassVar[dict[str, Sensor]] = {
        "T_zone": Sensor(0.05, 0.1, colored=0.05, colored_tau=3600.0, lag=240.0,
                         dropout_rate=0.1, dropout_s=180.0, dropout="hold",
                         source="room thermostat: NTC in a wall housing, polled over the "
                         "building bus (a missed poll repeats the last value)"),
        "T_out": Sensor(0.2, 0.1, colored=0.1, colored_tau=3600.0, lag=600.0,
                        dropout_rate=0.1, dropout_s=180.0, dropout="hold",
                        source="outdoor sensor in a radiation shield, on the same bus"),
        "T_supply": Sensor(0.3, 0.1, lag=60.0, spike_rate=0.05, spike_size=2.0,
                           source="contact sensor on the supply pipe; spikes when the "
                           "boiler's igniter or the pump switches next to its cable"),
        "Q_heat": Sensor(5.0, 1.0, colored=10.0, colored_tau=7200.0,
                         dropout_rate=0.05, dropout_s=900.0, dropout="hold",
                         source="heat meter read over M-Bus (a failed read-out keeps the "
                         "last value)"),
        "x_V": Sensor(0.004, 0.001, source="LVDT (rig only)"),
        "T_rad": Sensor(0.2, 0.1, lag=30.0, spike_rate=0.05, spike_size=2.0,
                        source="contact sensor on the radiator; spikes as T_supply"),
    }  # fmt: skip
    supported_effects = RoomPlant.supported_effects
    effect_defaults = RoomPlant.effect_defaults

    def __init__(
        self,
        effects: Sequence[Any] = (),
        *,
        off: Sequence[str] = (),
        valve: str = "linear",
    ) -> None:
        self.valve = valve
        super().__init__(effects, off=off)

    def plant(self) -> RoomPlant:
        """The room's true plant with this rig's valve, effects and switches."""
        return RoomPlant(self.valve, off=self.off, effects=self.effects)

    def with_specimen(self, values: Any) -> RoomRig:
        """A copy of this rig whose plant is one particular specimen (see :class:`Rig`)."""
        other = super().with_specimen(values)
        other.valve = self.valve  # type: ignore[attr-defined]
        return other  # type: ignore[return-value]


def _thermostat(
    rig: RoomRig,
    rng: np.random.Generator,
    *,
    days: float = 1.0,
    supply_V: float = 24.0,
    dt: float = 10.0,
) -> list[RigRun]:
    n = round(days * 86400.0 / dt)
    plant = rig.plant()
    spec = rig.specimen
    T_out, sol = _weather(rng, n, dt)
    t = dt * np.arange(n, dtype=np.float64)
    hour = (t / 3600.0) % 24.0
    occ = ((t // 86400.0) % 7 < 5) & (hour >= 7.0) & (hour < 18.0)
    Q_occ = np.where(occ, 250.0, 40.0)
    u = np.column_stack([np.zeros(n), np.full(n, supply_V), T_out, sol, Q_occ])
    x = plant.warm_state(spec, 20.0, T_out[0])
    ys = np.empty((n, len(_OUT)))
    xs = np.empty((n, _rp.N_STATES))
    on = False
    sens = rig.sensor("T_zone")
    st = SensorStream(sens, 1)
    st.start([0], x[:, _rp.I_AIR], np.zeros((1, N_RANDOM)))
    meas = float(x[0, _rp.I_AIR])
    for k in range(n):
        sp = 21.0 if occ[k] else 17.0
        on = meas < sp - 0.25 or (on and meas < sp + 0.25)  # on/off, 0.5 K hysteresis
        u[k, 0] = 1.0 if on else 0.0
        ys[k] = plant.outputs(x, u[k], spec, t[k])[0]
        xs[k] = x[0]
        x = plant.step(x, u[k], dt, spec, t[k])
        z = np.concatenate([rng.standard_normal(2), rng.random(N_RANDOM - 2)])[None]
        meas = float(st.sample(np.array([True]), x[:, _rp.I_AIR], dt, z)[0])
    truth = {name: ys[:, i] for i, name in enumerate(_OUT)}
    truth.update(plant.hidden(xs, spec.take(np.zeros(n, dtype=np.int64))))
    rec = ("T_zone", "T_out", "T_supply", "Q_heat", "x_V", "T_rad")
    measured = rig.measure({k: (T_out if k == "T_out" else truth[k]) for k in rec}, rng, t)
    cols = {"u": u[:, 0].copy(), "k_U": u[:, 1].copy(), "Q_sol": sol, "Q_occ": Q_occ, **measured}
    roles = {"u": "input", "k_U": "disturbance", "T_out": "disturbance", "Q_sol": "disturbance",
             "Q_occ": "disturbance", **{k: "output" for k in rec if k != "T_out"}}  # fmt: skip
    meta = {"days": days, "supply_V": supply_V, "valve": rig.valve}
    return [
        RigRun("room-thermostat", t, cols, {k: _UNITS[k] for k in cols}, roles, meta, truth=truth)
    ]


RoomRig.protocols = {
    "thermostat": Protocol("thermostat", "winter days with an on/off room thermostat", _thermostat),
}
