# ruff: noqa: E501  (the case table keeps one case per line)
"""The cases of the generalisation suite: plants, hidden effects, recordings, ground truth.

A :class:`Case` names a plant family, the hidden effects (none for a
control), the nominal model a user brings (their own ``Model`` subclass,
``foptd``, ``ss:2``, or a registered plant model for the papers' rigs) and a
seed. :func:`build` makes its training and held-out recordings as a user
would have them and states the ground truth with each effect's share of the
output variance.

The case list was written before any diagnosis result was looked at; see
``benchmarks/results/diagnosis/README.md`` for how the magnitudes were chosen.

Recordings of the suite's own families
--------------------------------------
* the true constants are 10-30 % off the design values the nominal model
  starts from, in every case (controls included), drawn per case;
* sensor noise is white plus Gauss-Markov (coloured), then quantised;
* the held-out recordings use another excitation and operating point than the
  training ones; held-out recordings always, and training recordings of odd
  seeds, start mid-operation (after an unrecorded period of use);
* the time stamps start at the time of day (or of year) the log started.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from thermogym.recording import Recording

from .effects import Hidden, phase_angle_power
from .plants import FAMILIES, Family, Profiles, TankPlant
from .signals import (
    effect_share,
    periodic,
    ramp_profile,
    random_levels,
    random_telegraph,
    smooth_random,
    step_profile,
)

__all__ = ["CASES", "Built", "Case", "build", "select"]

Array = NDArray[np.float64]
H = Hidden
RIG_FAMILIES = ("strut", "axt211", "spindle")


@dataclass(frozen=True)
class Case:
    """One case: a plant with hidden effects and the nominal model a user brings.

    Parameters
    ----------
    family : str
        ``plate``, ``tank``, ``building`` (this suite's plants) or ``strut``,
        ``axt211``, ``spindle`` (the papers' rigs).
    hidden : tuple of Hidden
        The ground truth; empty for a control.
    model : str
        ``user`` (the family's own :mod:`nominal` model), ``foptd``, ``ss:2``
        (generic models) or ``rig`` (the registered model of the rig).
    seed : int
    quick : bool
        Member of the ``--quick`` subset.
    """

    family: str
    hidden: tuple[Hidden, ...]
    model: str
    seed: int
    quick: bool = False

    @property
    def kind(self) -> str:
        """``control``, ``single`` or ``combo``."""
        return {0: "control", 1: "single"}.get(len(self.hidden), "combo")

    @property
    def truth(self) -> list[str]:
        """The effect names the diagnosis should report (``["none"]`` for a control)."""
        return [h.effect for h in self.hidden] or ["none"]

    @property
    def name(self) -> str:
        """``family/effect[+effect]/form[+form]/model/sSEED``: unique."""
        eff = "+".join(h.effect for h in self.hidden) or "control"
        form = "+".join(h.form for h in self.hidden) or "none"
        return f"{self.family}/{eff}/{form}/{self.model.replace(':', '')}/s{self.seed}"


@dataclass
class Built:
    """A case made concrete: recordings, the model to diagnose with, options, facts."""

    case: Case
    train: list[Recording]
    validate: list[Recording]
    model: Any
    options: dict[str, Any]
    share: dict[str, float]
    constants: dict[str, float] = field(default_factory=dict)
    note: str = ""
    rms: dict[str, float] = field(default_factory=dict)


# ============================================================================ profiles
def _profiles(
    hidden: Sequence[Hidden], rng: np.random.Generator, t: Array, n_pre: int, dt: float
) -> Profiles:
    """Unit-size time profiles of one recording (pre-roll included, ``t`` from its start).

    Time-varying parameters and sensor drift start with the recording (the
    logger is started with the session); disturbances and the supply wander
    go on through the pre-roll. The recording starts at ``t[n_pre]``.
    """
    n = t.size
    rec = t - t[n_pre]
    dur = rec[-1]
    p: dict[str, Array] = {"drift_t": np.clip(rec, 0.0, None) / 3600.0}
    for h in hidden:
        if h.effect == "time_varying_parameter":
            if h.form == "ramp":
                p["tv"] = ramp_profile(rec, 0.2 * dur, 0.8 * dur)
            elif h.form == "step":
                p["tv"] = step_profile(rec, rng.uniform(0.3, 0.7) * dur)
            else:  # smooth random walk of unit RMS starting at 0 with the recording
                w = np.zeros(n)
                w[n_pre:] = smooth_random(rng, rec[n_pre:], float(h.get("tau", dur / 6)), walk=True)
                p["tv"] = w
        elif h.effect == "unmeasured_disturbance":
            if h.form == "periodic":
                p["dist"] = periodic(
                    t,
                    float(h.params["period"]),
                    rng.uniform(0, 2 * math.pi),
                    sharpness=float(h.get("sharpness", 0.0)),
                )
            elif h.form == "steps":
                lo, hi = h.get("dwell", (900.0, 2700.0))
                if h.get("draws"):  # draw-offs: short on-periods, 0/1
                    p["draw"] = _events(rng, n, dt, float(h.get("on_s", 240.0)), (lo, hi))
                else:
                    p["dist"] = random_levels(
                        rng, n, dt, (float(h.get("low", -1.0)), 1.0), (lo, hi)
                    )
            else:
                p["dist"] = smooth_random(rng, t, float(h.get("tau", 1200.0)))
        elif h.effect == "supply_variation":
            if h.form == "steps":
                p["supply"] = random_levels(rng, n, dt, (-1.0, 1.0), (600.0, 1800.0))
            else:
                p["supply"] = smooth_random(rng, t, float(h.get("tau", 900.0)))
    return Profiles(p)


def _events(
    rng: np.random.Generator, n: int, dt: float, on_s: float, gap: tuple[float, float]
) -> Array:
    """0/1 events of ``on_s`` seconds separated by uniform random gaps [s]."""
    x = np.zeros(n)
    k = int(rng.uniform(*gap) / dt)
    while k < n:
        m = max(1, round(on_s * rng.uniform(0.5, 1.5) / dt))
        x[k : k + m] = 1.0
        k += m + int(rng.uniform(*gap) / dt)
    return x


# ============================================================================ scenarios
@dataclass
class Scenario:
    """Exogenous signals of one recording, pre-roll included."""

    u: dict[str, Array]
    dt: float
    n_pre: int
    t0: float  # time stamp of the first recorded sample [s]
    setpoint: Array | None = None


def _plate_scenario(rng: np.random.Generator, role: str, mid: bool) -> Scenario:
    dt = 5.0
    if role == "train":  # 3 h of random lamp levels, a fifth of them off
        n_pre, n = (int(2400 / dt) if mid else 0), int(3 * 3600 / dt)
        lamp = random_levels(rng, n_pre + n, dt, (0.0, 80.0), (300.0, 1200.0), p_zero=0.2)
        t0 = 9 * 3600.0
    else:  # 2 h: slow sine sweeps and a telegraph between 25 and 85 %, after 40 min of use
        n_pre, n = int(2400 / dt), int(2 * 3600 / dt)
        N = n_pre + n
        tt = dt * np.arange(N)
        ramp = 55.0 + 30.0 * np.sin(2 * np.pi * tt / 2400.0)
        tele = 25.0 + 60.0 * random_telegraph(rng, N, dt, (120.0, 600.0))
        lamp = np.where(tt < 0.5 * tt[-1], ramp, tele)
        lamp = np.round(lamp, 1)
        t0 = 86400.0 + 14 * 3600.0  # the next day, 14:00 (seconds since midnight of day 0)
    N = n_pre + n
    T_amb = 22.5 + 0.6 * smooth_random(rng, dt * np.arange(N), 3600.0)
    return Scenario({"lamp": lamp, "T_amb": T_amb}, dt, n_pre, t0)


def _tank_levels(
    rng: np.random.Generator,
    N: int,
    dt: float,
    dwell: tuple[float, float],
    Tcw: float,
    T_max: float,
    heater_share: tuple[float, float],
    valves: Sequence[float] | None = None,
) -> tuple[Array, Array]:
    """Heater and valve levels an operator would set: the tank never heads above ``T_max``.

    Each segment keeps or changes the valve, then picks the heater within the
    power whose design steady temperature stays below ``T_max`` at that valve
    opening (the nominal balance ``P h = (K v + G)(T − T_cw)``).
    """
    d = TankPlant.design
    P, K, G = d["P_max"].value, d["K_coil"].value, d["G"].value
    heater, valve = np.empty(N), np.empty(N)
    k, v = 0, 0.5
    while k < N:
        m = max(1, round(rng.uniform(*dwell) / dt))
        if valves is not None:
            if rng.random() < 0.5:
                v = float(rng.choice(valves))
        elif rng.random() < 0.6:
            v = 0.0 if rng.random() < 0.1 else rng.uniform(0.05, 1.0)
        h_max = min(1.0, (K * v + G) * (T_max - Tcw) / P)
        heater[k : k + m] = h_max * rng.uniform(*heater_share)
        valve[k : k + m] = v
        k += m
    return heater, valve


def _tank_scenario(rng: np.random.Generator, role: str, mid: bool) -> Scenario:
    dt = 30.0
    if role == "train":  # 8 h: random heater and valve levels, winter mains water
        n_pre, n = (int(2 * 3600 / dt) if mid else 0), int(8 * 3600 / dt)
        N = n_pre + n
        heater, valve = _tank_levels(rng, N, dt, (1200.0, 3600.0), 12.5, 65.0, (0.0, 1.0))
        Tcw = 12.5 + 0.4 * smooth_random(rng, dt * np.arange(N), 7200.0)
        t0 = 7 * 3600.0
    else:  # 6 h: shorter heater changes at three valve openings, summer mains water
        n_pre, n = int(2 * 3600 / dt), int(6 * 3600 / dt)
        N = n_pre + n
        heater, valve = _tank_levels(
            rng, N, dt, (600.0, 1800.0), 16.0, 62.0, (0.3, 1.0), valves=(0.15, 0.5, 0.85)
        )
        Tcw = 16.0 + 0.4 * smooth_random(rng, dt * np.arange(N), 7200.0)
        t0 = 86400.0 + 9 * 3600.0
    T_amb = 21.0 + 0.7 * smooth_random(rng, dt * np.arange(N), 3 * 3600.0)
    return Scenario(
        {"heater": np.round(heater, 3), "valve": np.round(valve, 3), "T_cw": Tcw, "T_amb": T_amb},
        dt,
        n_pre,
        t0,
    )


def _weather(rng: np.random.Generator, t: Array, mean: float) -> tuple[Array, Array]:
    """Winter weather: outdoor temperature [°C] and south-facade irradiance [W/m²]."""
    hour = (t / 3600.0) % 24.0
    T_out = (
        mean
        + 3.5 * np.sin(2 * np.pi * (hour - 9.0) / 24.0)
        + 3.0 * smooth_random(rng, t, 1.5 * 86400.0)
    )
    day = np.clip(np.sin(np.pi * (hour - 8.0) / 8.5), 0.0, None) ** 1.5  # 08:00-16:30
    cloud = np.clip(0.55 + 0.35 * smooth_random(rng, t, 0.5 * 86400.0), 0.08, 1.0)
    return T_out, 480.0 * day * cloud


def _building_scenario(rng: np.random.Generator, role: str, mid: bool) -> Scenario:
    dt = 600.0
    n_pre = int(4 * 86400 / dt)
    if role == "train":  # 10 days of January; 21 °C day, 17 °C night (22:00-06:00)
        n, t_start, mean, day_sp, night_sp, on, off = (
            int(10 * 86400 / dt),
            10 * 86400.0,
            2.0,
            21.0,
            17.0,
            6.0,
            22.0,
        )
    else:  # 7 days of February, colder, 20.5 °C day from 06:30 to 22:30, 18 °C night
        n, t_start, mean, day_sp, night_sp, on, off = (
            int(7 * 86400 / dt),
            38 * 86400.0,
            -1.5,
            20.5,
            18.0,
            6.5,
            22.5,
        )
    N = n_pre + n
    t = t_start - n_pre * dt + dt * np.arange(N)
    T_out, I = _weather(rng, t, mean)
    hour = (t / 3600.0) % 24.0
    sp = np.where((hour >= on) & (hour < off), day_sp, night_sp)
    return Scenario({"T_out": T_out, "I_sol": I}, dt, n_pre, t_start, sp)


SCENARIOS = {"plate": _plate_scenario, "tank": _tank_scenario, "building": _building_scenario}


# ============================================================================ recordings
def _n_sub(family: Family, hidden: Sequence[Hidden], dt: float) -> int:
    """RK4 steps per sample: a step at most half the fastest time constant."""
    fastest = {"plate": 60.0, "tank": 600.0, "building": 3600.0}[family.name]
    for h in hidden:
        if h.effect == "sensor_lag":
            fastest = min(fastest, float(h.params["tau"]))
        if h.effect == "missing_dynamics" and family.name == "plate":
            fastest = min(
                fastest,
                float(h.params["C_b"]) / (float(h.params["G_b"]) + float(h.get("g_b", 0.0))),
            )
    return max(1, math.ceil(dt / (0.5 * fastest)))


def _subsets(hidden: Sequence[Hidden]) -> list[list[Hidden]]:
    """Batch elements: all effects, none, and each alone (for combinations)."""
    out: list[list[Hidden]] = [list(hidden), []]
    if len(hidden) > 1:
        out += [[h] for h in hidden]
    return out


def simulate_recording(
    family: Family,
    consts: Mapping[str, float],
    hidden: Sequence[Hidden],
    scen: Scenario,
    rng: np.random.Generator,
) -> tuple[dict[str, Array], list[dict[str, Array]]]:
    """Simulate one recording with and without its effects (noise-free, recorded window).

    Returns the exogenous signals as logged (recorded window) and the outputs
    of the batch elements of :func:`_subsets` (first: all effects, then none).
    The effects' random profiles are drawn from ``rng``.
    """
    N = next(iter(scen.u.values())).size
    t = scen.dt * np.arange(N)
    prof = _profiles(hidden, rng, t, scen.n_pre, scen.dt)
    subsets = _subsets(hidden)
    s = family.settings(hidden, [[h.effect for h in sub] for sub in subsets])
    B = len(subsets)
    u = {k: np.broadcast_to(v, (B, N)) for k, v in scen.u.items()}
    nsub = _n_sub(family, hidden, scen.dt)
    if family.name == "building":
        x0 = np.tile([19.5, 18.8, 20.5, 19.5], (B, 1))
        # closed loop with every effect: the logged demand, then replayed open loop to all
        s1 = family.settings(hidden, [[h.effect for h in hidden]])
        first = family.simulate(  # type: ignore[call-arg]
            {k: v[:1] for k, v in u.items()},
            scen.dt,
            consts,
            s1,
            prof,
            x0[:1],
            nsub,
            setpoint=scen.setpoint,
            rng=rng,
        )
        u = dict(u) | {"hp_demand": np.broadcast_to(first.inputs["hp_demand"], (B, N))}
        run = family.simulate(u, scen.dt, consts, s, prof, x0, nsub)  # type: ignore[call-arg]
    else:
        run = family.simulate(u, scen.dt, consts, s, prof, None, nsub)  # type: ignore[call-arg]
    cut = slice(scen.n_pre, None)
    logged = {k: np.asarray(v[0, cut], dtype=float) for k, v in run.inputs.items()}
    outs = [{k: v[b, cut] for k, v in run.outputs.items()} for b in range(B)]
    return logged, outs


def _share_of(outs: Sequence[Mapping[str, Array]], i: int) -> tuple[float, float]:
    """The largest share over outputs of batch element ``i`` against element 1 (none)."""
    return max(effect_share(outs[i][k], outs[1][k]) for k in outs[0])


def _family_build(case: Case) -> Built:
    family = FAMILIES[case.family]
    rng = np.random.default_rng(case.seed)
    consts = family.draw_constants(rng)
    mid_train = case.seed % 2 == 1
    recs: dict[str, list[Recording]] = {"train": [], "validate": []}
    share_acc: dict[str, float] = {}
    rms: dict[str, float] = {}
    for role in ("train", "validate"):
        scen = SCENARIOS[case.family](rng, role, mid_train if role == "train" else True)
        logged, outs = simulate_recording(family, consts, case.hidden, scen, rng)
        if role == "train" and case.hidden:
            share_acc["all"], rms["all"] = _share_of(outs, 0)
            if len(case.hidden) == 1:
                share_acc[case.hidden[0].effect] = share_acc["all"]
                rms[case.hidden[0].effect] = rms["all"]
            else:
                for j, h in enumerate(case.hidden):
                    share_acc[h.effect], rms[h.effect] = _share_of(outs, 2 + j)
        recs[role].append(_to_recording(family, case, logged, outs[0], scen, rng, role))
    model, options = _model_for(case)
    return Built(
        case,
        recs["train"],
        recs["validate"],
        model,
        options,
        share_acc,
        consts,
        rms=rms,
    )


def _to_recording(
    family: Family,
    case: Case,
    logged: Mapping[str, Array],
    outputs: Mapping[str, Array],
    scen: Scenario,
    rng: np.random.Generator,
    role: str,
) -> Recording:
    """Noisy, quantised columns as the user's logger wrote them."""
    n = next(iter(outputs.values())).size
    t = scen.t0 + scen.dt * np.arange(n)
    cols: dict[str, Array] = {}
    units: dict[str, str] = {}
    roles: dict[str, str] = {}
    generic_building = case.family == "building" and case.model != "user"
    for k, (role_k, unit, _) in family.exogenous.items():
        if generic_building and k == "hp_demand":
            continue
        x = logged[k]
        if k in family.sensors:  # measured, not commanded
            x = family.sensors[k].apply(x, scen.dt, rng)
        cols[k], units[k], roles[k] = x, unit, role_k
    if generic_building:  # the heat meter's reading replaces the demand
        cols["q_hp"] = family.sensors["q_hp"].apply(logged["q_hp"], scen.dt, rng)
        units["q_hp"], roles["q_hp"] = "W", "input"
    for k, (unit, _) in family.outputs.items():
        cols[k] = family.sensors[k].apply(outputs[k], scen.dt, rng)
        units[k], roles[k] = unit, "output"
    return Recording(
        t,
        cols,
        units=units,
        roles=roles,
        experiment_id=f"{case.family}-{role}-s{case.seed}",
        source="generalisation suite",
        meta={"family": case.family, "role": role},
    )


def _model_for(case: Case) -> tuple[Any, dict[str, Any]]:
    """The nominal model a user would pass, and the diagnose options it needs."""
    from .nominal import nominal_model

    family = FAMILIES[case.family]
    if case.model == "user":
        return nominal_model(case.family), {}
    if case.family == "plate":
        return case.model, {"inputs": ["lamp", "T_amb"], "outputs": ["T_plate"]}
    if case.family == "building":
        return case.model, {"inputs": ["q_hp", "T_out", "I_sol"], "outputs": list(family.outputs)}
    raise ValueError(f"family {case.family!r} has no generic-model variant")


def build(case: Case) -> Built:
    """Make a case's recordings, nominal model, diagnose options and ground truth."""
    if case.family in RIG_FAMILIES:
        from .rigcases import rig_recordings

        train, val, options, facts = rig_recordings(
            case.family, case.hidden, case.seed, control=case.kind == "control"
        )
        return Built(
            case,
            train,
            val,
            case.family,
            options,
            facts["share"],
            note=facts["note"],
            rms=facts["rms"],
        )
    return _family_build(case)


# ============================================================================ the cases
def h(effect: str, form: str, where: str, size: str, **params: Any) -> Hidden:
    """A hidden effect (shorthand of :class:`Hidden` for the table below)."""
    return Hidden(effect, form, params, where, size)


def case(family: str, model: str, seed: int, *hidden: Hidden, quick: bool = False) -> Case:
    """A case with one or more hidden effects."""
    return Case(family, tuple(hidden), model, seed, quick)


def control(family: str, model: str, seed: int, *, quick: bool = False) -> Case:
    """A control: no hidden physics; constants 10-30 % off nominal, coloured noise."""
    return Case(family, (), model, seed, quick)


# a phase-angle dimmer's power share, sampled at six knots (a monotone piecewise-linear map)
_PHASE_MAP: dict[str, Any] = {
    "knots_u": [0.0, 0.2, 0.4, 0.6, 0.8, 1.0],
    "knots_y": [float(v) for v in phase_angle_power(np.array([0.0, 0.2, 0.4, 0.6, 0.8, 1.0]))],
}

# fmt: off
_PLATE: list[Case] = [
    # controls: no hidden physics; constants 10-30 % off, coloured noise
    control("plate", "user", 1, quick=True),
    control("plate", "foptd", 2, quick=True),
    control("plate", "ss:2", 3),
    control("plate", "user", 4),
    # nonlinear heat transfer: radiation of a grey plate, emissivity from polished to black
    case("plate", "user", 11, h("nonlinear_heat_transfer", "radiation", "plate surface", "ε = 0.15 (oxidised aluminium)", emissivity=0.15)),
    case("plate", "foptd", 12, h("nonlinear_heat_transfer", "radiation", "plate surface", "ε = 0.35", emissivity=0.35)),
    case("plate", "user", 13, h("nonlinear_heat_transfer", "radiation", "plate surface", "ε = 0.6", emissivity=0.6), quick=True),
    case("plate", "ss:2", 14, h("nonlinear_heat_transfer", "radiation", "plate surface", "ε = 0.9 (black anodised)", emissivity=0.9)),
    # natural convection: all or part of the loss ∝ ΔT^n (same conductance at 25 K)
    case("plate", "user", 15, h("nonlinear_heat_transfer", "natural_convection", "plate surface", "60 % of the loss laminar free convection, ΔT^1.25", exponent=1.25, share=0.6)),
    case("plate", "foptd", 16, h("nonlinear_heat_transfer", "natural_convection", "plate surface", "all of the loss turbulent free convection, ΔT^1.33", exponent=1.33, share=1.0), quick=True),
    # input nonlinearity of the lamp dimmer
    case("plate", "user", 21, h("input_nonlinearity", "power_law", "lamp", "radiant power ∝ command^1.3", exponent=1.3)),
    case("plate", "ss:2", 22, h("input_nonlinearity", "power_law", "lamp", "radiant power ∝ command^2", exponent=2.0)),
    case("plate", "user", 23, h("input_nonlinearity", "saturation", "lamp", "driver limits at 60 % of full power", level=0.6)),
    case("plate", "foptd", 24, h("input_nonlinearity", "dead_zone", "lamp", "no light below 15 % command", width=0.15)),
    case("plate", "user", 25, h("input_nonlinearity", "piecewise_linear", "lamp", "phase-angle dimmer curve (S-shaped), 6 knots", **_PHASE_MAP)),
    # time-varying loss conductance (room ventilation, a fume-hood fan, draughts)
    case("plate", "user", 31, h("time_varying_parameter", "ramp", "G", "loss conductance +40 % over the middle 60 % of each recording", change=0.4), quick=True),
    case("plate", "foptd", 32, h("time_varying_parameter", "step", "G", "loss conductance +30 % when a fume-hood fan starts", change=0.3)),
    case("plate", "user", 33, h("time_varying_parameter", "random_walk", "G", "loss conductance wandering with 15 % RMS", change=0.15, tau=900.0)),
    # unmeasured disturbance
    case("plate", "user", 41, h("unmeasured_disturbance", "periodic", "air at the plate", "air-conditioning cycle ±1 K, 30 min, not at the ambient sensor", amplitude_K=1.0, period=1800.0, sharpness=2.0)),
    case("plate", "foptd", 42, h("unmeasured_disturbance", "steps", "air at the plate", "air at the plate steps within ±2 K (door, oven nearby)", amplitude_K=2.0, dwell=(900.0, 2700.0))),
    case("plate", "ss:2", 43, h("unmeasured_disturbance", "smooth", "plate", "sun patch: 2 W RMS smooth heat flow", amplitude_W=2.0, tau=1200.0)),
    # transport delay: the lamp log's clock runs behind the thermocouple logger's
    case("plate", "user", 51, h("transport_delay", "clock_skew", "lamp", "15 s between the lamp log and the temperature log", delay=15.0)),
    case("plate", "ss:2", 52, h("transport_delay", "clock_skew", "lamp", "60 s between the lamp log and the temperature log", delay=60.0), quick=True),
    # sensor lag: thermocouple under tape or in a holder
    case("plate", "user", 61, h("sensor_lag", "first_order", "T_plate", "thermocouple lag 20 s", tau=20.0)),
    case("plate", "user", 62, h("sensor_lag", "first_order", "T_plate", "thermocouple lag 60 s", tau=60.0)),
    # sensor offset and drift
    case("plate", "user", 71, h("sensor_offset", "constant", "T_plate", "+0.5 K", offset=0.5)),
    case("plate", "user", 72, h("sensor_offset", "constant", "T_plate", "+2 K (type K class 2 allows 2.5 K)", offset=2.0), quick=True),
    case("plate", "user", 73, h("sensor_drift", "linear", "T_plate", "0.3 K/h cold-junction drift from logger start", rate=0.3)),
    case("plate", "foptd", 74, h("sensor_drift", "linear", "T_plate", "1 K/h cold-junction drift from logger start", rate=1.0)),
    # missing dynamics: a holder block the plate is screwed to
    case("plate", "user", 81, h("missing_dynamics", "extra_state", "plate", "60 J/K holder through 0.6 W/K", C_b=60.0, G_b=0.6, g_b=0.05)),
    case("plate", "user", 82, h("missing_dynamics", "extra_state", "plate", "200 J/K holder through 1.5 W/K", C_b=200.0, G_b=1.5, g_b=0.2), quick=True),
    # phase change: a paraffin pad (200 J/g) melting at 50 °C
    case("plate", "user", 91, h("phase_change", "latent_heat", "plate", "3 g paraffin, 600 J at 50 °C", mass=0.003, T_melt=50.0, width=1.5)),
    case("plate", "foptd", 92, h("phase_change", "latent_heat", "plate", "10 g paraffin, 2 kJ at 50 °C", mass=0.01, T_melt=50.0, width=1.5)),
    # supply variation: mains voltage, lamp power ∝ V^1.6
    case("plate", "user", 95, h("supply_variation", "steps", "lamp", "mains steps within ±5 % (±8 % lamp power)", amplitude=0.05)),
    case("plate", "foptd", 96, h("supply_variation", "smooth", "lamp", "mains wander 8 % RMS", amplitude=0.08, tau=900.0)),
    # two effects at once
    case("plate", "user", 101, h("nonlinear_heat_transfer", "radiation", "plate surface", "ε = 0.9", emissivity=0.9), h("sensor_lag", "first_order", "T_plate", "lag 45 s", tau=45.0), quick=True),
    case("plate", "user", 102, h("input_nonlinearity", "power_law", "lamp", "∝ command^1.6", exponent=1.6), h("missing_dynamics", "extra_state", "plate", "200 J/K holder", C_b=200.0, G_b=1.5, g_b=0.2)),
    case("plate", "foptd", 103, h("sensor_drift", "linear", "T_plate", "0.6 K/h", rate=0.6), h("unmeasured_disturbance", "periodic", "air at the plate", "±1 K, 30 min", amplitude_K=1.0, period=1800.0, sharpness=2.0)),
    case("plate", "user", 104, h("phase_change", "latent_heat", "plate", "6 g paraffin", mass=0.006, T_melt=50.0, width=1.5), h("sensor_offset", "constant", "T_plate", "+1 K", offset=1.0)),
    case("plate", "user", 105, h("time_varying_parameter", "step", "G", "G +30 % step", change=0.3), h("transport_delay", "clock_skew", "lamp", "40 s skew", delay=40.0)),
]

_TANK: list[Case] = [
    control("tank", "user", 201, quick=True),
    control("tank", "user", 202),
    control("tank", "user", 203),
    # flow-dependent coil: effectiveness 1 − exp(−NTU), NTU ∝ flow^-0.2 (Dittus-Boelter)
    case("tank", "user", 211, h("input_dependent_heat_transfer", "flow_dependent", "coil", "coil effectiveness 0.92 at full flow", ntu_full=2.5)),
    case("tank", "user", 212, h("input_dependent_heat_transfer", "flow_dependent", "coil", "coil effectiveness 0.70 at full flow", ntu_full=1.2), quick=True),
    case("tank", "user", 213, h("input_dependent_heat_transfer", "flow_dependent", "coil", "coil effectiveness 0.59 at full flow", ntu_full=0.9)),
    # backlash of the coolant valve's linkage
    case("tank", "user", 221, h("backlash", "play", "valve", "play of 4 % of the valve stroke", width=0.04)),
    case("tank", "user", 222, h("backlash", "play", "valve", "play of 12 % of the valve stroke", width=0.12), quick=True),
    # input nonlinearity of the thyristor
    case("tank", "user", 231, h("input_nonlinearity", "dead_zone", "heater", "thyristor does not fire below 12 %", width=0.12)),
    case("tank", "user", 232, h("input_nonlinearity", "piecewise_linear", "heater", "phase-angle firing: S-shaped power curve", **_PHASE_MAP)),
    case("tank", "user", 233, h("input_nonlinearity", "saturation", "heater", "thyristor current limit: at most 35 % power", level=0.35)),
    # phase change: encapsulated paraffin balls melting at 35 °C
    case("tank", "user", 241, h("phase_change", "latent_heat", "tank", "0.5 kg PCM balls, 90 kJ at 35 °C", mass=0.5, T_melt=35.0, width=1.5)),
    case("tank", "user", 242, h("phase_change", "latent_heat", "tank", "2 kg PCM balls, 360 kJ at 35 °C", mass=2.0, T_melt=35.0, width=1.5)),
    # missing dynamics: stratification, lower 40 % of the water exchanging through G_mix
    case("tank", "user", 251, h("missing_dynamics", "extra_state", "tank", "stratified, layers exchange 200 W/K", G_mix=200.0, lower_share=0.4)),
    case("tank", "user", 252, h("missing_dynamics", "extra_state", "tank", "stratified, layers exchange 50 W/K", G_mix=50.0, lower_share=0.4)),
    # sensors
    case("tank", "user", 261, h("sensor_lag", "first_order", "T_tank", "thermowell lag 60 s", tau=60.0)),
    case("tank", "user", 262, h("sensor_lag", "first_order", "T_tank", "thermowell lag 300 s", tau=300.0)),
    case("tank", "user", 263, h("sensor_offset", "constant", "T_tank", "+0.4 K (PT100 class B at 40 °C: ±0.5 K)", offset=0.4)),
    case("tank", "user", 264, h("sensor_drift", "linear", "T_tank", "0.25 K/h transmitter drift", rate=0.25)),
    # transport delay: PT100 in a sampling loop downstream of the tank
    case("tank", "user", 271, h("transport_delay", "output_dead_time", "T_tank", "sampling line, 90 s", delay=90.0)),
    case("tank", "user", 272, h("transport_delay", "output_dead_time", "T_tank", "sampling line, 240 s", delay=240.0)),
    # time-varying coil: fouling (ramp) or an air lock (step)
    case("tank", "user", 281, h("time_varying_parameter", "ramp", "coil", "coil heat removal −30 % (fouling)", change=-0.3)),
    case("tank", "user", 282, h("time_varying_parameter", "step", "coil", "coil heat removal −40 % (air lock)", change=-0.4)),
    # unmeasured disturbances
    case("tank", "user", 291, h("unmeasured_disturbance", "steps", "tank", "unlogged draw-offs of 1.8 l/min for ~4 min", draw_kg_s=0.03, draws=True, on_s=240.0, dwell=(1800.0, 5400.0)), quick=True),
    case("tank", "user", 292, h("unmeasured_disturbance", "periodic", "tank", "floor-heating pump on a timer: ±300 W, 1 h", amplitude_W=300.0, period=3600.0, sharpness=3.0)),
    case("tank", "user", 293, h("unmeasured_disturbance", "smooth", "tank", "smooth 150 W RMS heat flow", amplitude_W=150.0, tau=1800.0)),
    # supply variation: P ∝ V²
    case("tank", "user", 295, h("supply_variation", "smooth", "heater", "mains wander 5 % RMS (10 % power)", amplitude=0.05, tau=1800.0)),
    # two effects at once
    case("tank", "user", 301, h("backlash", "play", "valve", "10 % play", width=0.1), h("sensor_lag", "first_order", "T_tank", "lag 120 s", tau=120.0), quick=True),
    case("tank", "user", 302, h("input_dependent_heat_transfer", "flow_dependent", "coil", "effectiveness 0.63 at full flow", ntu_full=1.0), h("time_varying_parameter", "ramp", "coil", "−25 % fouling", change=-0.25)),
    case("tank", "user", 303, h("phase_change", "latent_heat", "tank", "1 kg PCM", mass=1.0, T_melt=35.0, width=1.5), h("unmeasured_disturbance", "steps", "tank", "draw-offs", draw_kg_s=0.03, draws=True, on_s=240.0, dwell=(1800.0, 5400.0))),
    case("tank", "user", 304, h("input_nonlinearity", "dead_zone", "heater", "10 % dead zone", width=0.1), h("sensor_drift", "linear", "T_tank", "0.2 K/h", rate=0.2)),
]

_BUILDING: list[Case] = [
    control("building", "user", 401, quick=True),
    control("building", "user", 402),
    control("building", "ss:2", 403),
    # missing dynamics: a heavy floor slab the heat pump heats
    case("building", "user", 411, h("missing_dynamics", "extra_state", "zone 1", "15 MJ/K slab through 800 W/K", C_m=15e6, K_m=800.0)),
    case("building", "user", 412, h("missing_dynamics", "extra_state", "zone 1", "50 MJ/K screed slab through 400 W/K", C_m=50e6, K_m=400.0), quick=True),
    case("building", "ss:2", 413, h("missing_dynamics", "extra_state", "zone 1", "40 MJ/K slab through 500 W/K", C_m=40e6, K_m=500.0)),
    # unmeasured gains in zone 1
    case("building", "user", 421, h("unmeasured_disturbance", "steps", "zone 1", "occupancy and appliances 0-400 W", amplitude_W=400.0, low=0.0, dwell=(3600.0, 21600.0))),
    case("building", "ss:2", 422, h("unmeasured_disturbance", "periodic", "zone 1", "daily gains ±500 W", amplitude_W=500.0, period=86400.0, sharpness=2.0)),
    case("building", "user", 423, h("unmeasured_disturbance", "smooth", "zone 1", "neighbour's party wall, 250 W RMS", amplitude_W=250.0, tau=43200.0)),
    # time-varying envelope conductance of zone 1
    case("building", "user", 431, h("time_varying_parameter", "step", "UA1", "UA1 +50 %: a window left tilted", change=0.5)),
    case("building", "ss:2", 432, h("time_varying_parameter", "random_walk", "UA1", "wind-driven infiltration, UA1 wandering 20 % RMS", change=0.2, tau=43200.0)),
    case("building", "user", 433, h("time_varying_parameter", "ramp", "UA1", "UA1 +40 % over the recording (ventilation schedule changed)", change=0.4)),
    # hydronic dead time, sensors
    case("building", "user", 441, h("transport_delay", "input_dead_time", "hp_demand", "20 min hydronic dead time", delay=1200.0)),
    case("building", "user", 442, h("transport_delay", "input_dead_time", "hp_demand", "40 min through a buffer tank", delay=2400.0)),
    case("building", "user", 451, h("sensor_lag", "first_order", "T_z1", "thermostat sensor lag 30 min", tau=1800.0)),
    case("building", "user", 452, h("sensor_offset", "constant", "T_z2", "first-floor sensor +0.8 K", offset=0.8)),
    case("building", "ss:2", 453, h("sensor_drift", "linear", "T_z2", "first-floor sensor drifting 0.5 K/day", rate=0.02)),
    # heat-pump input nonlinearity (the demand is the controller's, not a power reading)
    case("building", "user", 461, h("input_nonlinearity", "dead_zone", "hp_demand", "no heat below 25 % demand (minimum modulation)", width=0.25), quick=True),
    case("building", "user", 462, h("input_nonlinearity", "saturation", "hp_demand", "compressor capacity capped at 60 %", level=0.6)),
    case("building", "user", 463, h("input_nonlinearity", "power_law", "hp_demand", "part-load: heat ∝ demand^0.7", exponent=0.7)),
    # two effects at once
    case("building", "user", 471, h("missing_dynamics", "extra_state", "zone 1", "40 MJ/K slab", C_m=40e6, K_m=500.0), h("unmeasured_disturbance", "steps", "zone 1", "0-400 W gains", amplitude_W=400.0, low=0.0, dwell=(3600.0, 21600.0))),
    case("building", "user", 472, h("sensor_offset", "constant", "T_z2", "+0.8 K", offset=0.8), h("time_varying_parameter", "step", "UA1", "UA1 +50 % step", change=0.5)),
    case("building", "user", 473, h("transport_delay", "input_dead_time", "hp_demand", "30 min dead time", delay=1800.0), h("input_nonlinearity", "dead_zone", "hp_demand", "25 % minimum modulation", width=0.25)),
]

_RIG: list[Case] = [
    # strut (paper 000): train 20 m/min, validate 25 and 30 m/min
    control("strut", "rig", 501, quick=True),
    case("strut", "rig", 502, h("input_dependent_heat_transfer", "speed_dependent", "moving parts", "rig default: forced convection grows with feed rate")),
    case("strut", "rig", 503, h("nonlinear_heat_transfer", "natural_convection", "losses to the air", "rig default: h ∝ ΔT^(1/3)")),
    case("strut", "rig", 504, h("missing_dynamics", "extra_state", "bearing housing", "rig default: machine-frame bracket")),
    case("strut", "rig", 505, h("time_varying_parameter", "ramp", "heat sources", "rig default: losses growing per hour")),
    case("strut", "rig", 506, h("sensor_lag", "first_order", "T_nut", "nut thermocouple lag 600 s", tau=600.0), quick=True),
    case("strut", "rig", 507, h("sensor_offset", "constant", "T_nut", "nut thermocouple +1 K", offset=1.0)),
    case("strut", "rig", 508, h("transport_delay", "clock_skew", "feed_rate", "feed-rate log 10 min behind", delay=600.0)),
    case("strut", "rig", 509, h("unmeasured_disturbance", "periodic", "T_air", "air-conditioning cycle ±1.5 K, 2 h, unseen by the air sensor", amplitude_K=1.5, period=7200.0)),
    case("strut", "rig", 510, h("input_dependent_heat_transfer", "speed_dependent", "moving parts", "rig default"), h("sensor_offset", "constant", "T_nut", "+1 K", offset=1.0)),
    # AXT211 (paper 002): steps for training, the PWM test held out
    control("axt211", "rig", 601),
    case("axt211", "rig", 602, h("backlash", "rig", "rod coupling", "rig default: 0.25 mm play")),
    case("axt211", "rig", 603, h("phase_change", "rig", "wax", "rig default: latent heat around 57 °C"), quick=True),
    case("axt211", "rig", 604, h("supply_variation", "rig", "supply", "rig default: source resistance")),
    case("axt211", "rig", 605, h("nonlinear_heat_transfer", "natural_convection", "housing", "rig default: h ∝ ΔT^0.25")),
    case("axt211", "rig", 606, h("sensor_lag", "first_order", "T_P", "cartridge thermocouple lag 60 s", tau=60.0)),
    case("axt211", "rig", 607, h("unmeasured_disturbance", "periodic", "T_U", "chamber control cycle ±3 K, 40 min, unseen by its sensor", amplitude_K=3.0, period=2400.0)),
    case("axt211", "rig", 608, h("phase_change", "rig", "wax", "rig default"), h("sensor_offset", "constant", "T_P", "+1.5 K", offset=1.5)),
    # spindle (paper 001): run-in days for training, the validation days held out
    control("spindle", "rig", 701),
    case("spindle", "rig", 702, h("input_nonlinearity", "power_law", "heat sources", "rig default: friction ∝ speed^1.6"), quick=True),
    case("spindle", "rig", 703, h("input_dependent_heat_transfer", "speed_dependent", "rotating parts", "rig default: forced convection with speed")),
    case("spindle", "rig", 704, h("missing_dynamics", "extra_state", "front outer housing", "rig default: headstock casting")),
    case("spindle", "rig", 705, h("sensor_offset", "constant", "T_front_outer_housing", "+1 K", offset=1.0)),
    case("spindle", "rig", 706, h("transport_delay", "clock_skew", "speed", "speed log 10 min behind", delay=600.0)),
    case("spindle", "rig", 707, h("unmeasured_disturbance", "periodic", "T_amb", "hall air-conditioning ±2 K, 5 h, unseen by the ambient RTD", amplitude_K=2.0, period=18000.0)),
    case("spindle", "rig", 708, h("missing_dynamics", "extra_state", "front outer housing", "rig default"), h("sensor_lag", "first_order", "T_front_outer_housing", "lag 600 s", tau=600.0)),
]
# fmt: on

#: Every case of the suite.
CASES: list[Case] = [*_PLATE, *_TANK, *_BUILDING, *_RIG]


def select(pattern: str | None = None, *, quick: bool = False) -> list[Case]:
    """Cases whose name matches ``pattern`` (fnmatch, or a substring), optionally the quick subset."""
    import fnmatch

    out = [c for c in CASES if not quick or c.quick]
    if pattern:
        out = [c for c in out if fnmatch.fnmatch(c.name, pattern) or pattern in c.name]
    return out
