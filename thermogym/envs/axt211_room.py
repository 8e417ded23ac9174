"""AXT211Room: room temperature control through an AXT211-driven radiator valve.

Description
-----------
Plant 4 of DESIGN.md, the application the AXT211 is built for
(``002_dae2310635fe074e.txt``, section I): an office heated by a water
radiator whose valve an AXT211 wax actuator moves
(:class:`thermogym.models.room.RoomModel`: actuator eqs 14-21 of paper 002,
radiator after EN 442-2, two-capacity zone after ISO 13790). The controller
switches the actuator's heater — like a room thermostat does — to keep the
zone inside the comfort band while the room is occupied, with little heat and
actuator wear. The outdoor temperature, solar and internal gains and the
occupancy schedule disturb it; episodes last a day (default) up to a year.

Action Space
------------
As ``AXT211Valve``: ``action_mode="duty"`` (default), ``Box(-1, 1, (1,))``
mapped to a PWM duty ``(a + 1)/2`` with the control period as PWM period, or
``action_mode="onoff"``, ``Discrete(2)``.

Observation Space
-----------------
``Box(float32)``, entries (:attr:`AXT211RoomEnv.obs_names`)::

    0  T_zone     measured room temperature [°C] (thermostat sensor, 0..40)
    1  T_set      set-point of the schedule for the next period [°C]
    2  T_out      measured outdoor temperature [°C] (-40..45)
    3  occupied   1 while the room is occupied in the next period, else 0
    4  band_low   lower comfort limit now [°C]
    5  band_high  upper comfort limit now [°C]
    6  hour_sin   sin(2π · hour / 24) of the next period's start
    7  hour_cos   cos(2π · hour / 24)
    8  u_prev     duty applied in the last period (previous_action=True)

Rewards
-------
Per control period (weights ``reward_weights``, defaults :data:`DEFAULT_WEIGHTS`)::

    r_k = −( w_comfort   D_k       discomfort in the period [K·h] (occupied only)
           + w_heat      H_k       heat delivered by the radiator [kWh]
           + w_actuator  E_k       actuator electrical energy [Wh]
           + w_switching s_k )     heater switch-on in the period (0/1)

Starting State
--------------
A room that has been heated: zone air at ``initial_zone_C`` (drawn per
episode), the structure at its steady state for that zone temperature and the
first outdoor temperature, radiator at the zone temperature with the valve
shut, actuator at rest at the zone temperature.

Episode End
-----------
Termination: a safety trip — frost (zone below ``frost_C``, default 5 °C) or
an overheated actuator (wax above ``trip_C``). Truncation: after
``episode_days`` (default 1).

Disturbances
------------
Weather: ``weather="synthetic"`` (:func:`thermogym.envs.profiles.synthetic_weather`,
drawn per episode) or a weather file / Recording
(:func:`thermogym.envs.weather.weather_table`, hourly, periodic). Occupancy:
Monday to Friday (``occupied_days``) from ``occupied_hours[0]`` to
``occupied_hours[1]``; internal gains ``gains_W`` (occupied, unoccupied) plus
the solar gains. Day 0 of the year is a Monday. The start day is drawn in the
heating season (1 October to 30 April) unless ``start_day`` is given.

Arguments
---------
See :class:`RoomConfig`, plus ``render_mode``, ``render_path`` and ``record``.

KPIs
----
``discomfort_Kh``, ``heat_delivered_kWh``, ``actuator_energy_Wh``,
``switch_cycles``, ``stroke_travel_mm``, ``stroke_reversals``,
``wax_thermal_cycles``, ``wax_damage``, ``time_above_limit_h`` (wax above
``wax_limit_C``), ``episode_h``. The wax temperature's turning points are
taken after every RK4 sub-step (with ``plant="rig"``: every sub-step of the
rig), so that the heating and cooling within one PWM period count; zone
temperature, occupancy and the stroke are sampled at the end of every period;
energies are integrated by the trapezoidal rule on intervals of at most 10 s.

Fast path
---------
:meth:`AXT211RoomEnv.run_compiled` runs a numba-compiled controller in a
compiled loop over the same step kernel (same dynamics, noise and KPIs as
``step()``, without the Python overhead per step): a year at 10 s steps takes
seconds (``benchmarks/year.py``). The native vector environment
(``gymnasium.make_vec(ID, num_envs=N, vectorization_mode="vector_entry_point")``)
advances blocks of 32 plants in lockstep, one vectorised RK4 stage of every plant
per pass, bit for bit as single environments; ``parallel=True`` spreads the blocks
over numba's threads (``benchmarks/env_throughput.py``: about 2M env-steps/s per
core with 1024 plants at the 10 s period). The compiled kernels live in
:mod:`thermogym.envs._room_kernels`; this module holds the configuration, the
engine that drives them and the environment classes.

Version History
---------------
* v0: initial release. Revised in place (observations, rewards and every other KPI
  bit-identical): the wax-cycle and Miner-damage KPIs count the turning points of every
  integration sub-step, not only of period ends.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numba as nb
import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from thermogym.envs._base import (
    C_CUR,
    C_K,
    C_NTP,
    NOISE_BLOCK,
    Engine,
    ThermoEnv,
    ThermoVectorEnv,
    check_number,
    check_range,
    draw,
    parse_noise,
    parse_weights,
    steps_of,
)
from thermogym.envs._kernels import (
    lane_blocks,
    meas_array,
    put_lane,
    tp_buffer_full,
    tp_push_all,
    tp_room,
)
from thermogym.envs._plant import ParamsLike, resolve_plant, rig_only
from thermogym.envs._room_kernels import (
    _A_ABOVE,
    _A_DISC,
    _A_E,
    _A_Q,
    _A_QINT,
    _A_SW,
    _A_TOUT,
    _A_TPT,
    _A_TPX,
    _A_TRAV,
    _BW,
    _FROST,
    _GO,
    _GU,
    _HT,
    _KIND,
    _NACC,
    _NQ,
    _NROWB,
    _OCC0,
    _OCC1,
    _OCCD,
    _R_PLAIN,
    _ROOM,
    _T,
    _TRIP,
    _clock,
    _room_action,
    _room_post,
    _step_kernels,
    _StepKernels,
    _table,
)
from thermogym.envs.kpis import _rainflow_tp, tp_finish, wax_cycle_kpis
from thermogym.envs.profiles import synthetic_weather
from thermogym.envs.weather import weather_table
from thermogym.errors import ConfigError
from thermogym.models import room_dynamics as rd
from thermogym.models.room import RoomModel
from thermogym.recording import Recording

__all__ = ["DEFAULT_WEIGHTS", "AXT211RoomEnv", "AXT211RoomVectorEnv", "RoomConfig"]

ENV = "AXT211Room"
#: Default reward weights (see the module docstring).
DEFAULT_WEIGHTS = {"comfort": 10.0, "heat": 1.0, "actuator": 0.1, "switching": 0.01}
#: Sensor (σ, quantisation) of the observed channels.
SENSORS = {"T_zone": (0.1, 0.1), "T_out": (0.2, 0.1)}
_CH = ("T_zone", "T_out")
_HEATING_SEASON = np.concatenate([np.arange(273, 365), np.arange(0, 120)])
_STEPWISE_RIG_EFFECTS = ("backlash", "phase_change", "supply_variation", "nonlinear_heat_transfer")
_OBS = (
    "T_zone", "T_set", "T_out", "occupied", "band_low", "band_high", "hour_sin", "hour_cos",
    "u_prev",
)  # fmt: skip
_SIG = (
    "T_zone", "T_set", "band_low", "band_high", "T_out", "T_rad", "Q_heat", "x_V", "T_P",
    "P_PTC", "duty", "occupied", "Q_int", "reward",
)  # fmt: skip


@dataclass
class RoomConfig:
    """Keyword arguments of ``thermogym/AXT211Room-v0``."""

    params: ParamsLike = None
    """FitResult of model ``room``; default nominal values."""
    plant: str = "model"
    """``"model"`` or ``"rig"``: the room rig's true plant (:mod:`thermogym.rigs.room`:
    heating branch, radiator, four-node zone, the AXT211 rig as actuator), observed
    through its sensors."""
    rig_effects: Sequence[str] = ()
    """Concealed actuator effects of the room rig (``plant="rig"``)."""
    specimen_seed: int | None = 0
    """Rig only: seed of the actuator specimen from the AXT211 spread (None: nominal)."""
    valve: str = "linear"
    """Valve characteristic of the room model (``"linear"``, ``"equal_percentage"``)."""
    action_mode: str = "duty"
    """``"duty"`` or ``"onoff"``."""
    control_period: float = 10.0
    """Control (and PWM) period [s]: the sampling of a room thermostat; for room-level RL
    studies 300-900 s are typical (one step then integrates that many 1 s model steps)."""
    episode_days: float = 1.0
    """Episode length [days] (up to 366), a whole number of control periods."""
    start_day: int | None = None
    """Day of the year of the start (0 = 1 January, a Monday); None: drawn in the heating season."""
    start_hour: float = 0.0
    """Clock time of the start [h]."""
    weather: str | os.PathLike[str] | Recording = "synthetic"
    """``"synthetic"`` or a weather file / Recording (:mod:`thermogym.envs.weather`)."""
    supply_V: float | tuple[float, float] = 24.0
    """Actuator supply voltage [V] or a range drawn per episode."""
    occupied_hours: tuple[float, float] = (7.0, 18.0)
    """Occupancy from/to [h] on occupied days."""
    occupied_days: int = 5
    """Occupied days per week from Monday (5: Monday-Friday, 7: every day)."""
    setpoints_C: tuple[float, float] = (21.0, 17.0)
    """Thermostat set-point occupied / unoccupied [°C]."""
    comfort_band_C: tuple[float, float] = (20.0, 24.0)
    """Comfort band while occupied [°C] (discomfort is counted outside it)."""
    setback_band_C: tuple[float, float] = (16.0, 28.0)
    """Band shown in the observation while unoccupied [°C] (no discomfort counted)."""
    gains_W: tuple[float, float] = (250.0, 40.0)
    """Internal gains occupied / unoccupied [W] (people, equipment, lighting)."""
    initial_zone_C: float | tuple[float, float] = (19.0, 22.0)
    """Zone temperature at the start [°C], or a range drawn per episode."""
    sensor_noise: bool | Mapping[str, float] = True
    """Sensor noise; False: exact; a dict overrides σ of ``T_zone`` / ``T_out``."""
    previous_action: bool = True
    """Append the last applied duty to the observation."""
    reward_weights: Mapping[str, float] | None = None
    """Overrides of :data:`DEFAULT_WEIGHTS`."""
    wax_limit_C: float = 85.0
    """Wax temperature above which time counts in ``time_above_limit_h`` [°C].

    The default lies below the wax temperature of a fully powered AXT211 at 24 V
    (about 87 °C), so the KPI counts the time the valve is held fully open
    (thermal ageing of the wax), not overheating; the safety trip is separate."""
    trip_C: float = 110.0
    """Wax temperature of the safety trip [°C]."""
    frost_C: float = 5.0
    """Zone temperature of the frost trip [°C]."""
    cycle_hysteresis_K: float = 2.0
    """Smallest wax-temperature cycle counted [K]."""
    reversal_hysteresis_mm: float = 0.05
    """Smallest stroke movement counted as a reversal [mm]."""
    randomize: str | None = None
    """Domain randomisation per episode: ``"covariance"``, ``"bounds"``, ``"relative"``."""
    randomize_kwargs: Mapping[str, Any] | None = None
    """``scale``, ``names``, ``bounds`` of the randomisation."""


class _RoomEngine(Engine):
    name = ENV
    sig_names = _SIG
    sig_units = ("°C", "°C", "°C", "°C", "°C", "°C", "W", "mm", "°C", "W", "1", "1", "W", "1")
    noise_channels = _CH
    panels = (
        ("zone [°C]", ("T_zone", "T_set", "band_low", "band_high")),
        ("outdoor [°C]", ("T_out",)),
        ("radiator", ("T_rad", "x_V")),
        ("heat [W]", ("Q_heat",)),
        ("actuator", ("duty", "P_PTC", "T_P")),
    )

    def __init__(self, B: int, cfg: RoomConfig) -> None:
        self.cfg = cfg
        env = ENV
        if cfg.action_mode not in ("duty", "onoff"):
            raise ConfigError(f"{env}: action_mode is {cfg.action_mode!r}; 'duty' or 'onoff'")
        self.obs_names = _OBS if cfg.previous_action else _OBS[:8]
        units = ("°C", "°C", "°C", "1", "°C", "°C", "1", "1", "1")
        self.obs_units = units[: len(self.obs_names)]
        T = check_number(env, "control_period", cfg.control_period, lo=0.0, lo_open=True)
        self._dt = T
        days = check_number(env, "episode_days", cfg.episode_days, lo=0.0, hi=366.0, lo_open=True)
        self._horizon = steps_of(env, "episode_days", days * 86400.0, T)
        self.supply = check_range(env, "supply_V", cfg.supply_V, lo=0.0, hi=40.0)
        self.zone0 = check_range(env, "initial_zone_C", cfg.initial_zone_C, lo=0.0, hi=40.0)
        if cfg.start_day is not None:
            check_number(env, "start_day", cfg.start_day, lo=0, hi=365)
        self.start_hour = check_number(env, "start_hour", cfg.start_hour, lo=0.0, hi=24.0)
        occ0, occ1 = check_range(env, "occupied_hours", cfg.occupied_hours, lo=0.0, hi=24.0)
        occd = check_number(env, "occupied_days", cfg.occupied_days, lo=0, hi=7)
        spo, spu = (check_number(env, "setpoints_C", v, lo=0.0, hi=40.0) for v in cfg.setpoints_C)
        blo, bhi = check_range(env, "comfort_band_C", cfg.comfort_band_C, lo=0.0, hi=40.0)
        slo, shi = check_range(env, "setback_band_C", cfg.setback_band_C, lo=0.0, hi=40.0)
        go, gu = (check_number(env, "gains_W", v, lo=-5000.0, hi=5000.0) for v in cfg.gains_W)
        w = parse_weights(env, cfg.reward_weights, DEFAULT_WEIGHTS)
        specimen = None
        if cfg.plant == "rig" and cfg.specimen_seed is not None:
            # the actuator drawn from the AXT211 spread (as AXT211Valve's), the room nominal;
            # the rigs (~0.4 s) load only for plant='rig'
            from thermogym.rigs.axt211 import specimen_spread
            from thermogym.rigs.room import RoomPlant

            act = specimen_spread(np.random.default_rng(cfg.specimen_seed), n=1)
            specimen = RoomPlant(cfg.valve).nominal().replace({n: act[n] for n in act.names})
        plant = resolve_plant(
            env,
            params=cfg.params,
            plant=cfg.plant,
            models=("room",),
            default=lambda: RoomModel(valve=cfg.valve),
            rig="room",
            rig_effects=cfg.rig_effects,
            stepwise_effects=_STEPWISE_RIG_EFFECTS,
            specimen=specimen,
            rig_options={"valve": cfg.valve},
        )
        super().__init__(B, plant, _NACC, tp_capacity=256)
        model: RoomModel = plant.model  # type: ignore[assignment]
        self.kind = 1.0 if model.valve == "equal_percentage" else 0.0
        if isinstance(cfg.weather, str) and cfg.weather == "synthetic":
            self.shared_tab: NDArray[np.float64] | None = None
            n_h = math.ceil(self._horizon * T / 3600.0) + 26
            self.tab = np.zeros((B, 2, n_h))
        else:
            self.shared_tab = weather_table(cfg.weather)[None]
            self.tab = self.shared_tab
        sens = parse_noise(env, cfg.sensor_noise, _CH, SENSORS, plant.sensors)
        lo, hi = self.obs_bounds()
        self.meas = meas_array(sens, lo[[0, 2]], hi[[0, 2]])  # channels: T_zone, T_out
        self.cfgv = np.array(
            [
                T, RoomModel.max_step, float(self._horizon),
                1.0 if cfg.action_mode == "onoff" else 0.0, self.kind,
                w["comfort"], w["heat"], w["actuator"], w["switching"],
                check_number(env, "wax_limit_C", cfg.wax_limit_C),
                check_number(env, "trip_C", cfg.trip_C),
                check_number(env, "frost_C", cfg.frost_C),
                check_number(env, "cycle_hysteresis_K", cfg.cycle_hysteresis_K, lo=0.0),
                check_number(env, "reversal_hysteresis_mm", cfg.reversal_hysteresis_mm, lo=0.0),
                1.0 if cfg.previous_action else 0.0,
                occ0, occ1, float(occd), spo, spu, blo, bhi, slo, shi, go, gu,
                float(tp_room(T, RoomModel.max_step)),
            ]
        )  # fmt: skip
        self.x = np.zeros((B, 7))
        self.p = np.zeros((B, model.full_theta(plant.theta).shape[1]))
        self.lanes = lane_blocks(B, _BW, _NROWB)  # the kernel's block arrays, rows from p
        self.dist = np.zeros((B, 3))
        self._kernels: _StepKernels | None = None
        self._args: list[tuple[Any, ...] | None] = [None, None]  # kernel arguments per mode

    def action_space(self) -> spaces.Space[Any]:
        if self.cfg.action_mode == "onoff":
            return spaces.Discrete(2)
        return spaces.Box(-1.0, 1.0, (1,), dtype=np.float32)

    def obs_bounds(self) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
        lo = np.array([0.0, 0.0, -40.0, 0.0, 0.0, 0.0, -1.0, -1.0, 0.0], dtype=np.float32)
        hi = np.array([40.0, 40.0, 45.0, 1.0, 40.0, 40.0, 1.0, 1.0, 1.0], dtype=np.float32)
        n = len(self.obs_names)
        return lo[:n], hi[:n]

    def _set_theta_row(self, b: int, theta: NDArray[np.float64]) -> None:
        self.p[b] = self.model.full_theta(theta)[0]  # type: ignore[attr-defined]
        col = np.zeros((len(rd.LANE_ROWS), 1))
        rd.lane_column(self.p[b], col, 0)
        put_lane(self.lanes, b, _BW, col[:_NQ, 0], col[rd.LANE_PLAIN, 0], _R_PLAIN)

    def _reset_row(self, b: int, rng: np.random.Generator) -> None:
        cfg = self.cfg
        if cfg.start_day is None:
            day = int(_HEATING_SEASON[rng.integers(_HEATING_SEASON.size)])
        else:
            day = int(cfg.start_day)
        t0 = day * 86400.0 + self.start_hour * 3600.0
        kU = draw(rng, self.supply)
        Tz = draw(rng, self.zone0)
        if self.shared_tab is None:
            h0 = math.floor(t0 / 3600.0)
            self.tab[b] = synthetic_weather(rng, h0, self.tab.shape[2])
            base = float(h0)
        else:
            base = 0.0
        self.dist[b] = (kU, t0, base)
        # a heated room: structure at steady state for the zone temperature (zone node balance
        # not imposed: the heating held it there), radiator and actuator at the zone temperature
        H = self.tab.shape[2]
        bb = b if self.tab.shape[0] > 1 else 0
        j = int(math.floor(t0 / 3600.0) - base) % H
        Tout = float(self.tab[bb, 0, j])
        m = self.model
        th = self.theta[b]
        Has, Hso, f = (th[m.param_index(n)] for n in ("H_as", "H_so", "f_int"))
        day_i = math.floor(t0 / 86400.0)
        hour = (t0 - 86400.0 * day_i) / 3600.0
        occ = (day_i % 7) < self.cfgv[_OCCD] and self.cfgv[_OCC0] <= hour < self.cfgv[_OCC1]
        Q = (self.cfgv[_GO] if occ else self.cfgv[_GU]) + float(self.tab[bb, 1, j])
        Ts = (Has * Tz + Hso * Tout + (1.0 - f) * Q) / (Has + Hso)
        c = th[m.param_index("c_backlash")]
        self.x[b] = (Tz, Tz, -c, 0.0, Tz, Tz, Ts)

    def _kernel(self, mode: int) -> int:
        args = self._args[mode]
        if args is None or args[9] is not self.tpbuf:  # the arrays are fixed but tpbuf grows
            args = self._args[mode] = (
                mode, self.act, self.active, self.x, self.p, self.lanes, self.dist, self.tab,
                self.acc, self.tpbuf, self.ctr, self.noise, self.meas, self.cfgv, self.obs,
                self.out, self.sig,
            )  # fmt: skip
        k = self._kernels
        if k is None:  # looked up once (the valve characteristic and B are fixed)
            k = self._kernels = _step_kernels(int(self.cfgv[_KIND]), self.B >= _BW)
        if self.parallel and self.B > _BW:
            return int(k.step_parallel(*args, nb.get_num_threads()))
        return int(k.step(*args))

    def kpis(self, b: int) -> dict[str, float]:
        a = self.acc[b]
        tps = self.tpbuf[b, : self.ctr[b, C_NTP]]
        last = tp_finish(a[_A_TPT : _A_TPT + 4].copy())
        if not math.isnan(last):
            tps = np.append(tps, last)
        cycles = _rainflow_tp(tps, self.cfgv[_HT])
        return {
            "discomfort_Kh": float(a[_A_DISC]),
            "heat_delivered_kWh": float(a[_A_Q] / 3.6e6),
            "actuator_energy_Wh": float(a[_A_E] / 3600.0),
            "switch_cycles": float(a[_A_SW]),
            "stroke_travel_mm": float(a[_A_TRAV]),
            "stroke_reversals": float(a[_A_TPX + 3]),
            **wax_cycle_kpis(cycles),
            "time_above_limit_h": float(a[_A_ABOVE] / 3600.0),
            "episode_h": float(self.ctr[b, C_K] * self._dt / 3600.0),
        }

    def trip_reason(self, b: int) -> str:
        if self.x[b, 5] < self.cfgv[_FROST]:
            return f"frost: zone at {self.x[b, 5]:.1f} °C below frost_C = {self.cfgv[_FROST]} °C"
        return f"wax temperature {self.x[b, 0]:.1f} °C above trip_C = {self.cfgv[_TRIP]} °C"

    def rollout(
        self,
        controller: Callable[..., float],
        state: NDArray[np.float64],
        rng: np.random.Generator,
        max_steps: int,
    ) -> tuple[int, float]:
        """Run ``controller`` compiled for up to ``max_steps``; steps done and reward sum."""
        done_steps, total = 0, 0.0
        self.active[:] = True
        while done_steps < max_steps:
            if self.ctr[0, C_CUR] >= NOISE_BLOCK:
                self.refill(0, rng)
            n = min(NOISE_BLOCK - int(self.ctr[0, C_CUR]), max_steps - done_steps)
            # room for the turning points n periods can confirm (each up to cfg[_ROOM])
            while self.ctr[0, C_NTP] + n * int(self.cfgv[_ROOM]) > self.tpbuf.shape[1]:
                self.tpbuf = np.concatenate([self.tpbuf, np.zeros_like(self.tpbuf)], axis=1)
            status, i, r = _step_kernels(int(self.cfgv[_KIND]), False).rollout(
                controller, state, n, self.act, self.active, self.x, self.p, self.lanes, self.dist,
                self.tab, self.acc, self.tpbuf, self.ctr, self.noise, self.meas, self.cfgv,
                self.obs, self.out, self.sig,
            )  # fmt: skip
            done_steps += int(i)
            total += float(r)
            if status != 0:
                self._run(0)  # raises the error the kernel reported
            if self.out[0, 1] > 0.5 or self.out[0, 2] > 0.5:
                self.done[0] = True
                break
        return done_steps, total


class _RoomRigEngine(_RoomEngine):
    """The room on the room rig's true plant (``plant="rig"``, :mod:`thermogym.envs._rig`).

    Every control period the rig (radiator branch, four-node zone, the AXT211 rig as
    actuator) advances all plants at once, heater on for ``d·T`` then off; the outdoor
    temperature and the gains of the period are those the model path uses, split into
    solar and occupancy gains; KPIs and reward come from the rig's physical state through
    :func:`_room_post`, the observation from the rig's sensors. The wax-temperature
    tracker gets the turns of the cartridge temperature over the rig's sub-steps
    (:class:`thermogym.rigs.base.Turns`) and its value at the period's end: the turning
    points of every sub-step.
    """

    def __init__(self, B: int, cfg: RoomConfig) -> None:
        from thermogym.envs._rig import RigSensors  # the rigs load only for plant='rig'
        from thermogym.rigs.base import Turns

        super().__init__(B, cfg)
        pl = self.plant
        self.tp = pl.true_plant
        self.spec = pl.specimens.take(np.zeros(B, dtype=np.int64))
        self.xr = np.zeros((B, len(self.tp.state_names)))
        names = self.tp.state_names
        self._iw, self._ig, self._ip, self._iv, self._ie = (
            names.index(n) for n in ("T_w", "T_g", "x_p", "x_v", "E")
        )
        self._ia, self._ii, self._iq = (names.index(n) for n in ("T_air", "T_int", "Q_J"))
        self._irad = [i for i, n in enumerate(names) if n.startswith("T_rad_")]
        # the rig's sub-steps per period (on and off parts) bound the turns noted and the
        # turning points a period can confirm
        room = tp_room(self._dt, self.tp.max_step) + 1
        self.cfgv[_ROOM] = room
        self.turns = Turns(self._iw, B, capacity=room)
        lo, hi = self.obs_bounds()
        spans = [(float(lo[0]), float(hi[0])), (float(lo[2]), float(hi[2]))]
        self.rsens = RigSensors(ENV, pl.rig, _CH, spans, cfg.sensor_noise, _CH, B)
        self._rngs: Sequence[np.random.Generator] = ()

    def apply_fit(self, fit: ParamsLike, rows: Sequence[int] | None = None) -> dict[str, Any]:
        raise rig_only(ENV, "set_parameters / a FitResult")

    def randomize(self, method: str | None, **kwargs: Any) -> None:
        if method is not None:
            raise rig_only(ENV, "randomize")
        super().randomize(None)

    def rollout(self, controller, state, rng, max_steps):  # type: ignore[no-untyped-def]
        raise rig_only(ENV, "run_compiled")

    def reset_rows(self, rows: Sequence[int], rngs: Sequence[np.random.Generator]) -> None:
        self._rngs = rngs
        super().reset_rows(rows, rngs)

    def step(self, rngs: Sequence[np.random.Generator], active: NDArray[np.bool_] | None) -> None:
        self._rngs = rngs
        super().step(rngs, active)

    def _reset_row(self, b: int, rng: np.random.Generator) -> None:
        super()._reset_row(b, rng)
        _, t0, base = self.dist[b]
        Tout = _table(self.tab, b, 0, base, t0)
        self.xr[b] = self.tp.warm_state(self.spec.take([b]), self.x[b, 5], Tout)[0]

    def _view(self) -> NDArray[np.float64]:
        # the rig's state in the columns _room_post reads: wax, housing, piston, stem, mean
        # radiator, zone air, internal mass
        xr = self.xr
        return np.column_stack(
            [xr[:, self._iw], xr[:, self._ig], xr[:, self._ip], xr[:, self._iv],
             xr[:, self._irad].mean(axis=1), xr[:, self._ia], xr[:, self._ii]]
        )  # fmt: skip

    def _truth(self) -> NDArray[np.float64]:
        # observed channels: zone air, the outdoor temperature of the coming period
        return np.column_stack([self.xr[:, self._ia], self.acc[:, _A_TOUT]])

    def _post(self, rows: Any, mode: int, d: Any, E: Any, Q: Any, xv0: Any) -> None:
        xs = self._view()
        for b in rows:
            _room_post(b, mode, d[b], E[b], Q[b], xv0[b], xs, self.p, self.dist, self.tab,
                       self.acc, self.tpbuf, self.ctr, self.noise, self.meas, self.cfgv,
                       self.obs, self.out, self.sig)  # fmt: skip

    def _kernel(self, mode: int) -> int:
        if tp_buffer_full(self.active, self.ctr, self.tpbuf, int(self.cfgv[_ROOM])):
            return 2  # ST_GROW: the engine grows the turning-point buffer and calls again
        rows = np.flatnonzero(self.active)
        zero = np.zeros(self.B)
        if mode == 1:
            self._post(rows, 1, zero, zero, zero, self.xr[:, self._iv])
            first = self.rsens.start(rows, self._truth()[rows], self._rngs)
            self.obs[rows, 0] = first[:, 0]
            self.obs[rows, 2] = first[:, 1]
            return 0
        status = 0
        ok = np.zeros(self.B, dtype=np.bool_)
        d = np.zeros(self.B)
        for b in rows:
            v = _room_action(b, self.act, self.cfgv, self.ctr)
            if v < 0.0:
                status = 1
            else:
                ok[b], d[b] = True, v
        T = self.cfgv[_T]
        t = self.dist[:, 1] + self.ctr[:, C_K] * T
        # the period's outdoor temperature and gains (set by _room_post), occupancy split off
        Tout = self.acc[:, _A_TOUT].copy()
        Qint = self.acc[:, _A_QINT].copy()
        Qocc = np.array([self.cfgv[_GO] if _clock(tb, self.cfgv)[0] else self.cfgv[_GU]
                         for tb in t])  # fmt: skip
        Qsol = Qint - Qocc
        xv0 = self.xr[:, self._iv].copy()
        E0 = self.xr[:, self._ie].copy()
        Q0 = self.xr[:, self._iq].copy()
        kU = self.dist[:, 0]
        u_on = np.column_stack([np.ones(self.B), kU, Tout, Qsol, Qocc])
        u_off = u_on.copy()
        u_off[:, 0] = 0.0
        ton = np.where(ok, d * T, 0.0)
        turns = self.turns
        turns.start(self.xr)
        xr = self.tp.step(self.xr, u_on, ton, self.spec, t, turns=turns)
        xr = self.tp.step(xr, u_off, np.where(ok, T - ton, 0.0), self.spec, t + ton, turns=turns)
        self.xr = xr
        E = xr[:, self._ie] - E0
        Q = xr[:, self._iq] - Q0
        iw, hT = self._iw, self.cfgv[_HT]
        for b in np.flatnonzero(ok):
            # the wax temperature's turns within the period, then its value at the end
            ntp = tp_push_all(self.acc, b, _A_TPT, turns.values[b], turns.count(int(b)), hT,
                              self.tpbuf, self.ctr[b, C_NTP])  # fmt: skip
            self.ctr[b, C_NTP] = tp_push_all(self.acc, b, _A_TPT, xr[b, iw : iw + 1], 1, hT,
                                             self.tpbuf, ntp)  # fmt: skip
        self._post(np.flatnonzero(ok), 0, d, E, Q, xv0)
        readings = self.rsens.read(ok, self._truth(), T, self._rngs)
        self.obs[ok, 0] = readings[ok, 0]
        self.obs[ok, 2] = readings[ok, 1]
        return status

    def trip_reason(self, b: int) -> str:
        Tz, Tw = self.xr[b, self._ia], self.xr[b, self._iw]
        if Tz < self.cfgv[_FROST]:
            return f"frost: zone at {Tz:.1f} °C below frost_C = {self.cfgv[_FROST]} °C"
        return f"wax temperature {Tw:.1f} °C above trip_C = {self.cfgv[_TRIP]} °C"


def _room_engine(B: int, cfg: RoomConfig) -> _RoomEngine:
    # the rig's true plant or the identified model's kernels
    return _RoomRigEngine(B, cfg) if cfg.plant == "rig" else _RoomEngine(B, cfg)


class AXT211RoomEnv(ThermoEnv):
    """Room temperature control through the AXT211 valve (``thermogym/AXT211Room-v0``).

    See the module docstring and :class:`RoomConfig`.

    Examples
    --------
    >>> import gymnasium as gym
    >>> import thermogym.envs
    >>> env = gym.make("thermogym/AXT211Room-v0", action_mode="onoff", start_day=10)
    >>> obs, info = env.reset(seed=0)
    >>> names = env.unwrapped.obs_names
    >>> terminated = truncated = False
    >>> while not (terminated or truncated):  # a thermostat with 0.5 K hysteresis
    ...     T, T_set = obs[names.index("T_zone")], obs[names.index("T_set")]
    ...     on = int(T < T_set - 0.25 or (T < T_set + 0.25 and obs[names.index("u_prev")] > 0))
    ...     obs, r, terminated, truncated, info = env.step(on)
    >>> sorted(info["kpis"])[:3]
    ['actuator_energy_Wh', 'discomfort_Kh', 'episode_h']
    >>> bool(info["kpis"]["heat_delivered_kWh"] > 1.0)
    True
    """

    env_name = ENV
    config_cls = RoomConfig
    engine_cls = staticmethod(_room_engine)

    def run_compiled(
        self,
        controller: Callable[..., float],
        state: NDArray[np.float64] | None = None,
        max_steps: int | None = None,
    ) -> dict[str, Any]:
        """Run a numba-compiled controller until the episode ends (no Python per step).

        The loop calls the same step kernel as :meth:`step` (same dynamics,
        noise stream and KPIs; the history is not recorded).

        Parameters
        ----------
        controller : numba.njit function
            ``controller(obs: float32[:], state: float64[:]) -> float``: the
            action (0/1 for ``"onoff"``, [-1, 1] for ``"duty"``) from the
            observation; it may keep memory in ``state``.
        state : ndarray, optional
            Controller memory (default ``np.zeros(4)``).
        max_steps : int, optional
            Stop after this many steps (default: until the episode ends).

        Returns
        -------
        dict
            ``steps``, ``reward`` (sum), ``terminated``, ``truncated`` and
            ``kpis`` (the same as ``info["kpis"]``).
        """
        e: _RoomEngine = self._e  # type: ignore[assignment]
        if e.done[0]:
            raise ConfigError(f"{ENV}: the episode is over; call reset() before run_compiled()")
        st = np.zeros(4) if state is None else np.ascontiguousarray(state, dtype=np.float64)
        limit = e.horizon if max_steps is None else int(max_steps)
        steps, total = e.rollout(controller, st, self._rngs[0], limit)
        return {
            "steps": steps,
            "reward": total,
            "terminated": bool(e.out[0, 1] > 0.5),
            "truncated": bool(e.out[0, 2] > 0.5),
            "kpis": e.kpis(0),
        }


class AXT211RoomVectorEnv(ThermoVectorEnv):
    """``num_envs`` rooms stepped by one compiled call (native vector env).

    Keyword arguments as :class:`RoomConfig`, plus ``num_envs`` and ``autoreset_mode``.
    """

    single_env_cls = AXT211RoomEnv
