"""The AXT211 rig's true plant: paper 002's stated facts, its table of extra physics, effects.

Each row of the rig's table is switched on and off: on, it changes the output the way
its physics says (sign and size from a hand calculation); off, it is gone (the plant
equals the one whose parameter for that physics is neutral).
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from thermogym.errors import ShapeError, UnknownNameError
from thermogym.rigs import _axt211_physics as ph
from thermogym.rigs import get_rig, run_experiment
from thermogym.rigs.axt211 import AXT211_EXTRAS, AXT211Plant, AXT211Rig, specimen_spread
from thermogym.rigs.base import Specimens


def _step(plant: AXT211Plant, kU=24.0, TU=25.0, on=1800, off=3600, spec=None):
    u = np.zeros((on + off, 3))
    u[:on, 0] = 1.0
    u[:, 1], u[:, 2] = kU, TU
    return plant.simulate(u, 1.0, spec if spec is not None else plant.nominal())


def _first(mask: np.ndarray) -> int:
    return int(np.argmax(mask)) if mask.any() else -1


# ------------------------------------------------------------------ stated facts
@pytest.fixture(scope="module")
def corners():
    plant = AXT211Plant()
    out = {}
    for kU, TU in ((24.0, 25.0), (24.0, 0.0), (24.0, 50.0)):
        out[(kU, TU)] = _step(plant, kU, TU)
    return out


def test_valve_starts_near_60C_and_opens_in_about_five_minutes(corners):
    # paper 002 section V: at 25 °C the rod moves from about 60 °C on; 4.5 mm after ca. 5 min
    run = corners[(24.0, 25.0)]
    xv, TP = run.output("x_V")[0], run.output("T_P")[0]
    k0 = _first(xv > 0.02)
    assert 58.0 < TP[k0] < 65.0
    t_open = _first(xv > 4.45)
    assert 240 <= t_open <= 390
    assert xv.max() <= 4.5 + 1e-9 and xv.min() >= 0.0  # the valve's seat and end stop


def test_opening_and_closing_are_asymmetric_with_the_ambient(corners):
    # heating is forced, cooling passive (paper 002 eq 16): in a cold room the actuator
    # opens slowly and closes fast, in a warm room the other way round
    times = {}
    for (_, TU), run in corners.items():
        xv = run.output("x_V")[0]
        times[TU] = (_first(xv > 4.45), _first(xv[1800:] < 0.05))
    assert all(o > 0 and c > 0 for o, c in times.values())
    assert times[0.0][0] > 3 * times[0.0][1]
    assert times[50.0][1] > 3 * times[50.0][0]
    assert times[50.0][1] > times[25.0][1] > times[0.0][1]


def test_staircase_gain_peaks_near_68C_with_hysteresis():
    # paper 002 Fig. 3: very small gain at 60 °C, largest at 68 °C; different stationary
    # strokes on the way up and down
    run = get_rig("axt211").run("staircase", seed=0)[0]
    sp, xv, tp = run.columns["T_P_setpoint"], run.truth["x_V"], run.truth["T_P"]
    n = int(run.meta["hold_s"])
    ends = np.arange(n - 1, sp.size, n)
    level, stroke = sp[ends], xv[ends]
    assert np.all(np.abs(tp[ends] - level) < 0.5)  # the loop settles on every step
    peak = int(np.argmax(level))
    up_T, up_x = level[: peak + 1], stroke[: peak + 1]
    gain = np.diff(up_x) / np.diff(up_T)
    mid = 0.5 * (up_T[1:] + up_T[:-1])
    assert 65.0 <= mid[np.argmax(gain)] <= 70.0
    assert gain[mid == 59.0][0] < 0.25 * gain.max()
    for T in (64.0, 66.0, 68.0):
        up = stroke[:peak][level[:peak] == T][0]
        down = stroke[peak:][level[peak:] == T][0]
        assert down - up > 0.1


def test_spread_is_large_at_high_pwm_frequency_small_on_off():
    # paper 002 section VIII / Fig. 8
    runs = get_rig("axt211").run("spread", seed=0)
    assert len(runs) == 15 and runs[0].meta["production_date"] == 1
    X = np.array([r.truth["x_V"] for r in runs])
    h = np.arange(X.shape[1]) / 3600.0
    high = X[:, (h > 1.5) & (h <= 3)].std(axis=0).mean()
    low = X[:, (h > 5) & (h <= 6)].std(axis=0).mean()
    assert high > 2.0 * low


def test_steps_cover_the_ranges_with_the_rigs_sensors():
    runs = get_rig("axt211").run("steps", seed=3)
    assert [r.experiment_id for r in runs][4] == "axt211-step-24V-25C" and len(runs) == 9
    for run in runs:
        quiet = slice(4200, 5400)  # the last 20 min of the off phase: slow signals
        r = (run.columns["T_P"] - run.truth["T_P"])[quiet]
        mad = 1.4826 * np.median(np.abs(r - np.median(r)))
        assert 0.06 < mad < 0.13  # 0.08 K white + 0.05 K coloured thermocouple noise
        on = run.columns["u"] > 0
        assert np.isnan(run.columns["R_PTC"][~on]).all()  # no current, no resistance
        assert np.isfinite(run.columns["R_PTC"][on]).all()
        assert np.all(run.columns["x_V"] > -0.03) and np.all(run.columns["x_V"] < 4.53)
        # the chamber follows its set-point within its fluctuation
        assert abs(np.mean(run.truth["T_U"]) - run.meta["ambient_C"]) < 0.5


def test_specimens_differ_in_every_parameter_with_a_spread():
    # issue 14: "the manufacturing spread of every parameter"; the one exception is the
    # exponent of the free-convection law, a law of physics rather than a specimen property
    s = specimen_spread(np.random.default_rng(1), n=30)
    plant = AXT211Plant()
    fixed = {p.name for p in plant.parameters if p.spread == 0}
    assert fixed == {"n_conv"}
    for p in plant.parameters:
        v = s[p.name]
        if p.spread > 0:
            assert v.std() > 0, p.name
            assert np.all((v >= p.lower) & (v <= p.upper)), p.name
            assert p.spread_source, p.name
        else:
            assert np.all(v == p.nominal), p.name
    # production dates share a shift of the melting temperature
    d = np.arange(30) % 3
    means = [s["T_m"][d == i].mean() for i in range(3)]
    assert np.ptp(means) > 0.1
    with pytest.raises(UnknownNameError, match="no specimen parameter"):
        s["C_P"]


# ------------------------------------------------------------- the rig's table
def _no(name: str) -> AXT211Plant:
    return AXT211Plant(off=[name])


def _spec(**values: float) -> Specimens:
    return AXT211Plant().nominal().replace(values)


@pytest.mark.parametrize(
    ("switch", "neutral"),
    [
        ("latent_heat", {"L_w": 0.0}),
        ("melt_hysteresis", {"dT_hys": 0.0}),
        ("valve_neck", {"G_wv": 0.0}),
        ("spring_preload", {"F_0": 0.0}),
        ("friction", {"F_st": 0.0, "F_d": 0.0}),
        ("source_resistance", {"R_src": 0.0}),
    ],
)
def test_a_switched_off_row_is_gone(switch, neutral):
    a = _step(_no(switch), on=900, off=900)
    b = _step(AXT211Plant(), on=900, off=900, spec=_spec(**neutral))
    np.testing.assert_allclose(a.outputs, b.outputs, rtol=0, atol=1e-9)
    c = _step(AXT211Plant(), on=900, off=900)
    assert np.abs(c.outputs - a.outputs).max() > 1e-3  # and on, it changes something


def test_table_rows_have_sources_and_switches():
    names = [e.name for e in AXT211_EXTRAS]
    assert names == list(AXT211Plant().switches)
    doc = __import__("thermogym.rigs.axt211", fromlist=["x"]).__doc__
    for e in AXT211_EXTRAS:
        assert e.source and e.size and e.off
        assert e.name in doc
    with pytest.raises(UnknownNameError, match="no extra physics"):
        AXT211Plant(off=["gremlins"])


def test_ptc_switching_self_regulates_against_supply_and_cools_without_it():
    # a steep PTC holds its own temperature near T_ref whatever the supply; a fixed
    # resistor lets the power (∝ V²) set the temperature: 29² / 24² = 1.46 times the power
    tail = slice(1500, 1800)
    on = {v: _step(AXT211Plant(), v, 25.0, 1800, 1) for v in (24.0, 29.0)}
    off = {v: _step(_no("ptc_switching"), v, 25.0, 1800, 1) for v in (24.0, 29.0)}
    d_on = on[29.0].output("T_P")[0, tail].mean() - on[24.0].output("T_P")[0, tail].mean()
    d_off = off[29.0].output("T_P")[0, tail].mean() - off[24.0].output("T_P")[0, tail].mean()
    assert d_on < 5.0 and d_off > 20.0
    T_ptc = on[29.0].hidden["T_ptc"][0, tail].mean()
    assert abs(T_ptc - 97.0) < 6.0  # near its reference temperature
    assert off[29.0].output("T_P")[0, tail].mean() > on[29.0].output("T_P")[0, tail].mean() + 10


def test_ptc_node_is_hotter_than_the_cartridge_by_power_over_contact():
    run = _step(AXT211Plant(), on=300, off=1)
    k = 120  # heating, before self-regulation
    P = run.output("P_PTC")[0, k]
    gap = run.hidden["T_ptc"][0, k] - run.output("T_P")[0, k]
    assert gap == pytest.approx(P / 0.40, rel=0.25)  # P / G_hw, the PTC's own capacity aside
    lumped = _step(_no("ptc_node"), on=300, off=1)
    np.testing.assert_array_equal(lumped.hidden["T_ptc"], lumped.output("T_P"))


def test_latent_heat_costs_its_energy_on_the_way_up():
    # the extra electrical energy to full stroke is the latent heat melted on the way
    # (L Δφ) plus what the longer heating loses and stores in the housing, which is at
    # most the heater's power over the extra time
    on = _step(AXT211Plant(), on=900, off=1)
    off = _step(_no("latent_heat"), on=900, off=1)
    k_on, k_off = _first(on.output("x_V")[0] > 4.45), _first(off.output("x_V")[0] > 4.45)
    dE = on.hidden["E_el"][0, k_on] - off.hidden["E_el"][0, k_off]
    L_melted = 220.0 * on.hidden["phi"][0, k_on]
    P_max = on.output("P_PTC")[0, :k_on].max()
    assert L_melted < dE < L_melted + P_max * (k_on - k_off)
    assert k_on - k_off > L_melted / P_max


def test_melt_hysteresis_keeps_the_stroke_up_on_cooling():
    # down minus up at one temperature ≈ gain × ΔT_hys (0.5 mm/K × 1.5 K) with it, ~friction
    # and play without
    def updown(rig):
        run = rig.run("staircase", seed=0, low=62.0, high=70.0)[0]
        sp, xv = run.columns["T_P_setpoint"], run.truth["x_V"]
        n = int(run.meta["hold_s"])
        ends = np.arange(n - 1, sp.size, n)
        lv, st = sp[ends], xv[ends]
        p = int(np.argmax(lv))
        return st[p:][lv[p:] == 66.0][0] - st[:p][lv[:p] == 66.0][0]

    d_on = updown(get_rig("axt211"))
    d_off = updown(get_rig("axt211", off=["melt_hysteresis"]))
    assert 0.4 < d_on - d_off < 1.2
    assert d_off < 0.35


def test_melt_kinetics_delays_the_stroke_by_about_its_time_constant():
    on = _step(AXT211Plant(), on=900, off=1)
    off = _step(_no("melt_kinetics"), on=900, off=1)
    delay = _first(on.output("x_V")[0] > 2.0) - _first(off.output("x_V")[0] > 2.0)
    assert 4 <= delay <= 30  # τ_m = 12 s


def test_convection_and_radiation_are_nonlinear_and_linear_when_off():
    p = AXT211Plant().kernel_params(AXT211Plant().nominal())[0]

    def conductance(plant, dT, TU=25.0):
        return ph.housing_loss(TU + dT, TU, p, plant._switches()) / dT

    conv = AXT211Plant(off=["radiation"])
    # laminar natural convection: G ∝ ΔT^(1/4): 40 K against 5 K → 8^0.25 = 1.68
    g40, g5 = conductance(conv, 40.0), conductance(conv, 5.0)
    rad_lin = 4 * 0.9 * 5.670374419e-8 * 0.0095 * (308.15) ** 3
    assert (g40 - rad_lin) / (g5 - rad_lin) == pytest.approx(8**0.25, rel=1e-6)
    lin = AXT211Plant(off=["radiation", "natural_convection"])
    assert conductance(lin, 40.0) == pytest.approx(conductance(lin, 5.0), rel=1e-12)
    # radiation grows with the absolute temperature: a 50 °C room loses more per kelvin
    rad = AXT211Plant(off=["natural_convection"])
    assert conductance(rad, 20.0, 50.0) > 1.2 * conductance(rad, 20.0, 0.0)
    assert conductance(lin, 20.0, 50.0) == pytest.approx(conductance(lin, 20.0, 0.0))
    # at 20 K both laws meet their linear stand-ins (the reference point of "off")
    assert conductance(conv, 20.0) == pytest.approx(conductance(lin, 20.0), rel=0.02)


def test_valve_neck_is_a_slow_heat_sink():
    on = _step(AXT211Plant(), on=1800, off=1)
    off = _step(_no("valve_neck"), on=1800, off=1)
    dT_neck = on.hidden["T_valve"][0, -1] - 25.0
    assert 5.0 < dT_neck < 30.0
    np.testing.assert_array_equal(off.hidden["T_valve"][0], 25.0)
    # the extra loss path costs electrical energy
    assert on.hidden["E_el"][0, -1] > off.hidden["E_el"][0, -1]


def test_spring_preload_delays_the_stroke_by_F0_over_stiffness():
    plant, free = AXT211Plant(off=["friction"]), AXT211Plant(off=["friction", "spring_preload"])
    p = plant.kernel_params(plant.nominal())[0]
    for T in (66.0, 68.0):
        x_on = plant.rest_state(p, T)[ph.X_XP]
        x_off = free.rest_state(p, T)[ph.X_XP]
        # F_0 / (k_c + k_s): 90 N / 158 N/mm
        assert x_off - x_on == pytest.approx(90.0 / 158.0, rel=0.02)


def test_friction_sticks_within_its_band_and_slips_beyond():
    plant, free = AXT211Plant(), AXT211Plant(off=["friction"])
    p = plant.kernel_params(plant.nominal())[0]

    def nudge(pl, dT):
        x = pl.rest_state(p, 67.0)
        x0 = x[ph.X_XP]
        x[ph.X_TW] += dT  # a small change of the charge's temperature, melt fraction kept
        for _ in range(60):
            ph.mechanics(x, 1.0, p, pl._switches())
        return x[ph.X_XP] - x0

    # a 0.01 K step: the thrust changes by k_c β ΔT ≈ 0.015 N « F_st = 12 N
    assert nudge(plant, 0.01) == 0.0 and nudge(free, 0.01) > 0.0
    # a rest state with friction sits where the dynamic friction stopped it
    xs = plant.rest_state(p, 67.0)[ph.X_XP]
    xf = free.rest_state(p, 67.0)[ph.X_XP]
    assert xf - xs == pytest.approx(8.0 / 158.0, rel=0.05)  # F_d / (k_c + k_s)


def test_source_resistance_lowers_the_cold_power():
    on = _step(AXT211Plant(), on=5, off=1).output("P_PTC")[0, 0]
    off = _step(_no("source_resistance"), on=5, off=1).output("P_PTC")[0, 0]
    R = 24.0**2 / off
    assert on / off == pytest.approx((R / (R + 1.0)) ** 2, rel=1e-9)


# ------------------------------------------------------------- concealed effects
_EFFECTS = list(AXT211Rig.supported_effects)


@pytest.mark.parametrize("effect", _EFFECTS)
def test_concealed_effect_changes_the_data_and_leaves_no_trace(effect, tmp_path):
    kw = {"voltages": [24.0], "ambients": [25.0], "on_s": 900.0, "off_s": 900.0}
    clean = run_experiment("axt211", "steps", seed=4, **kw)[0]
    got = run_experiment("axt211", "steps", tmp_path, seed=4, effects=[effect], **kw)[0]
    diff = max(np.nanmax(np.abs(got[c] - clean[c])) for c in ("P_PTC", "T_P", "T_G", "x_V"))
    assert diff > 0.05, effect
    text = " ".join(p.read_text() for p in tmp_path.iterdir() if p.suffix == ".json")
    text += json.dumps(got.meta)
    assert "effect" not in text
    for word in (effect, *AXT211Rig.effect_defaults[effect]):
        assert word not in text, (effect, word)


def test_effects_are_the_rigs_own_physics():
    base = AXT211Plant().nominal()
    p0 = AXT211Plant().kernel_params(base)[0]
    names = AXT211Plant.parameter_names()
    for eff, name, want in (
        ("backlash", "c_backlash", 0.25),
        ("supply_variation", "R_src", 15.0),
        ("phase_change", "L_w", 2 * p0[names.index("L_w")]),
        ("nonlinear_heat_transfer", "n_conv", 1 / 3),
    ):
        p = AXT211Plant(effects=[eff]).kernel_params(base)[0]
        assert p[names.index(name)] == pytest.approx(want), eff
    with pytest.raises(UnknownNameError, match="cannot carry"):
        AXT211Plant(effects=["missing_dynamics"])


def test_step_takes_one_period_per_specimen():
    plant = AXT211Plant()
    spec = plant.nominal(3)
    x = plant.initial_state(spec, np.array([0.0, 24.0, 25.0]))
    u = np.tile([1.0, 24.0, 25.0], (3, 1))
    y = plant.step(x, u, np.array([0.0, 30.0, 60.0]), spec)
    np.testing.assert_array_equal(y[0], x[0])
    assert y[2, ph.X_TW] > y[1, ph.X_TW] > x[1, ph.X_TW]
    # two half steps are one step (fixed sub-steps of 0.5 s)
    y2 = plant.step(plant.step(x, u, 30.0, spec), u, 30.0, spec)
    np.testing.assert_allclose(y2[2], y[2], atol=1e-12)
    with pytest.raises(ShapeError, match="dt"):
        plant.step(x, u, -1.0, spec)
    with pytest.raises(ShapeError, match="u has shape"):
        plant.simulate(np.zeros((5, 2)), 1.0, spec)


@pytest.mark.parametrize("h", [0.0, 0.5, 2.0])
def test_noted_turns_give_the_turning_points_of_every_sample(h):
    # what the rig notes over its sub-steps (Turns, note_turn) plus the first and last value:
    # a hysteresis filter finds the same turning points as from every sample, hysteresis 0
    # (where a repeated value counts) included; strictly monotone runs are dropped
    from thermogym.envs.kpis import turning_points

    rng = np.random.default_rng(5)
    for _ in range(30):
        x = np.round(np.cumsum(rng.standard_normal(400)) * 2.0) / 2.0  # ties
        x[100:110] = x[99]  # a plateau
        x[200:260] = np.linspace(x[199], x[199] + 30.0, 60)  # a long rise
        st = np.array([x[0], 2.0, 0.0])
        out = np.zeros(x.size)
        for v in x[1:]:
            ph.note_turn(float(v), st, out)
        n = int(st[2])
        kept = np.r_[x[0], out[:n], x[-1]]
        np.testing.assert_array_equal(turning_points(kept, h), turning_points(x, h))
        assert n < x.size - 60


def test_turns_are_noted_over_the_steps_of_a_pwm_period():
    from thermogym.rigs.base import Turns

    plant = AXT211Plant()
    spec = plant.nominal(2)
    x = plant.initial_state(spec, np.array([0.0, 24.0, 25.0]))
    x = plant.step(x, [1.0, 24.0, 25.0], 300.0, spec)  # warm
    col = plant.state_names.index("T_w")
    turns = Turns(col, 2, capacity=241)
    turns.start(x)
    dt_on = np.array([60.0, 0.0])  # specimen 1 off the whole period
    a = plant.step(x, [1.0, 24.0, 25.0], dt_on, spec, turns=turns)
    b = plant.step(a, [0.0, 24.0, 25.0], 120.0 - dt_on, spec, turns=turns)
    # the same end state as without noting
    ref = plant.step(plant.step(x, [1.0, 24.0, 25.0], dt_on, spec), [0.0, 24.0, 25.0],
                     120.0 - dt_on, spec)  # fmt: skip
    np.testing.assert_array_equal(b, ref)
    # heated then cooled: one peak, above both ends; off only (after the warm-up) as well:
    # the wax still takes heat from the hotter PTC at first, then cools
    for i in (0, 1):
        assert turns.count(i) == 1 and turns.noted(i)[0] > max(x[i, col], b[i, col])
    small = Turns(col, 2, capacity=0)
    small.start(x)
    plant.step(x, [1.0, 24.0, 25.0], 1.0, spec, turns=small)
    small.state[0, 2] = 5.0
    with pytest.raises(ShapeError, match="capacity"):
        small.count(0)
