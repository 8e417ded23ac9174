"""KPI arithmetic on hand-made trajectories with known answers.

The truth is counted by hand (square waves, triangles, constant powers) or
computed by an independent brute-force implementation, never frozen from the
code under test.
"""

from __future__ import annotations

import itertools

import numpy as np
import pandas as pd
import pytest

from thermogym.envs import kpis
from thermogym.errors import ShapeError


def square_wave(n_periods: int, samples_on: int, samples_off: int) -> np.ndarray:
    return np.tile(np.r_[np.ones(samples_on), np.zeros(samples_off)], n_periods)


# ------------------------------------------------------------------ energy
def test_energy_of_a_square_wave_is_power_times_on_time():
    # 12 periods of 5 min on / 10 min off at 7 W: 12 * 300 s * 7 W = 7 Wh
    on = square_wave(12, 5, 10)
    assert kpis.actuator_energy_Wh(7.0 * on, dt=60.0) == pytest.approx(7.0)
    assert kpis.heat_delivered_kWh(1000.0 * on, dt=60.0) == pytest.approx(1.0)


def test_trapezoid_integrates_a_ramp_exactly():
    t = np.linspace(0.0, 3600.0, 361)
    # ∫_0^1h (t/1h · 10 W) dt = 5 Wh
    assert kpis.energy_Wh(10.0 * t / 3600.0, 10.0, method="trapezoid") == pytest.approx(5.0)
    with pytest.raises(ShapeError, match="method"):
        kpis.energy_Wh([1.0], 1.0, method="simpson")


def test_switch_cycles_count_rising_edges():
    on = square_wave(17, 3, 4)
    assert kpis.switch_cycles(on) == 17
    assert kpis.switch_cycles(on, initially_on=True) == 16  # the first edge is missing
    assert kpis.switch_cycles(np.zeros(50)) == 0
    assert kpis.switch_cycles(np.ones(50)) == 1


def test_pwm_switch_cycles():
    # duty 0.5 every period switches on every period
    assert kpis.pwm_switch_cycles(np.full(20, 0.5)) == 20
    # full on: one switch-on for the whole block
    assert kpis.pwm_switch_cycles(np.r_[np.ones(5), np.zeros(3), np.ones(2)]) == 2
    with pytest.raises(ShapeError, match="duty"):
        kpis.pwm_switch_cycles([1.5])


# ------------------------------------------------------- stroke and cycles
def test_stroke_travel_and_reversals_of_a_triangle_wave():
    up = np.linspace(0.0, 4.0, 41)
    tri = np.concatenate([up, up[-2::-1], up[1:], up[-2::-1]])  # 0→4→0→4→0
    assert kpis.stroke_travel_mm(tri) == pytest.approx(16.0)
    assert kpis.stroke_reversals(tri, 0.05) == 3
    # a dithering plateau (sensor noise, ±0.02 mm) inserted at 2 mm on the way up
    rng = np.random.default_rng(0)
    plateau = 2.0 + rng.uniform(-0.02, 0.02, 100)
    noisy = np.concatenate([up[:21], plateau, up[21:], up[-2::-1], up[1:], up[-2::-1]])
    assert kpis.stroke_reversals(noisy, 0.05) == 3
    assert kpis.stroke_reversals(noisy, 0.0) > 50


def test_turning_points_streaming_equals_batch():
    rng = np.random.default_rng(3)
    x = np.cumsum(rng.standard_normal(2000))
    tp = kpis.turning_points(x, 2.0)
    st = np.zeros(4)
    got = [v for v in (kpis.tp_update(st, float(s), 2.0) for s in x) if not np.isnan(v)]
    got.append(kpis.tp_finish(st))
    np.testing.assert_array_equal(tp, got)
    # consecutive turning points alternate and differ by at least the hysteresis
    d = np.diff(tp[1:])
    assert np.all(np.abs(d) >= 2.0)
    assert np.all(np.sign(d[1:]) == -np.sign(d[:-1]))


@pytest.mark.parametrize("h", [0.0, 0.5, 2.0])
def test_branch_free_tracker_step_equals_the_tracker(h):
    # tp_select (the lockstep kernels' tracker) is tp_update bit for bit: state and points,
    # on a walk with ties and plateaus (quantised) and on the hysteresis 0 edge case
    rng = np.random.default_rng(11)
    x = np.round(np.cumsum(rng.standard_normal(3000)) * 2.0) / 2.0
    x[500:520] = x[499]  # a plateau
    st = np.zeros(4)
    lane = (0.0, 0.0, 0.0, 0.0)
    for v in x:
        ref = kpis.tp_update(st, float(v), h)
        *lane, tp, hit = kpis.tp_select(*lane, float(v), h)
        assert tuple(lane) == tuple(st)
        assert hit == (not np.isnan(ref))
        if hit:
            assert tp == ref


def brute_force_rainflow(series: np.ndarray) -> list[tuple[float, float]]:
    """ASTM E1049-85 four-point counting written out independently (test truth)."""
    pts = [series[0]]
    for v in series[1:]:
        if v == pts[-1]:
            continue
        if len(pts) >= 2 and (pts[-1] - pts[-2]) * (v - pts[-1]) > 0:
            pts[-1] = v
        else:
            pts.append(v)
    out: list[tuple[float, float]] = []
    stack: list[float] = []
    for p in pts:
        stack.append(p)
        while len(stack) >= 3:
            X = abs(stack[-1] - stack[-2])
            Y = abs(stack[-2] - stack[-3])
            if X < Y:
                break
            if len(stack) == 3:
                out.append((Y, 0.5))
                stack.pop(0)
            else:
                out.append((Y, 1.0))
                last = stack.pop()
                stack.pop()
                stack.pop()
                stack.append(last)
    out.extend((abs(b - a), 0.5) for a, b in itertools.pairwise(stack))
    return out


def test_rainflow_matches_an_independent_counter():
    rng = np.random.default_rng(7)
    x = np.cumsum(rng.standard_normal(500)) * 3.0
    got = sorted(kpis.rainflow_cycles(x))
    truth = sorted((r, c) for r, c in brute_force_rainflow(x) if r > 0)
    assert len(got) == len(truth)
    np.testing.assert_allclose([g[0] for g in got], [t[0] for t in truth])
    assert sum(c for _, c in got) == pytest.approx(sum(c for _, c in truth))


def test_wax_cycles_of_a_known_temperature_square_wave():
    # 10 heat-cool cycles 25 → 75 → 25 °C with ripple below the hysteresis
    T = np.tile(np.r_[np.full(30, 25.0), np.full(30, 75.0)], 10)
    T = np.r_[T, 25.0] + 0.5 * np.sin(np.arange(T.size + 1))
    assert kpis.wax_thermal_cycles(T, 2.0) == pytest.approx(10.0)
    # Miner sum: 10 cycles at the reference range 50 K -> 10 / N_ref
    assert kpis.wax_damage(T, 2.0) == pytest.approx(10.0 / kpis.DAMAGE_N_REF, rel=0.05)


def test_miner_damage_follows_the_s_n_curve():
    # halving the range divides the damage per cycle by 2^m
    d_full = kpis.miner_damage([(50.0, 1.0)], n_ref=1e4, range_ref=50.0, exponent=3.0)
    d_half = kpis.miner_damage([(25.0, 1.0)], n_ref=1e4, range_ref=50.0, exponent=3.0)
    assert d_full == pytest.approx(1e-4)
    assert d_full / d_half == pytest.approx(8.0)
    with pytest.raises(ShapeError):
        kpis.miner_damage([(1.0, 1.0)], n_ref=0.0)


def test_s_n_variants_cut_off_and_weigh_the_cycles():
    # two 50 K cycles, one 8 K cycle, a 3 K half cycle: by hand
    cycles = [(50.0, 1.0), (50.0, 1.0), (8.0, 1.0), (3.0, 0.5)]
    k = kpis.wax_cycle_kpis(cycles)
    assert k["wax_thermal_cycles"] == 3.5 and k["wax_cycles_ge5K"] == 3.0
    assert k["wax_cycles_ge10K"] == k["wax_cycles_ge20K"] == 2.0
    n = kpis.DAMAGE_N_REF
    assert k["wax_damage_m3_ge2K"] == pytest.approx((2 + 0.16**3 + 0.5 * 0.06**3) / n)
    assert k["wax_damage_m1_ge5K"] == pytest.approx((2 + 0.16) / n)
    assert k["wax_damage_m4_ge10K"] == pytest.approx(2 / n)
    assert k["wax_damage"] == k["wax_damage_m2_ge2K"]  # the default is one of the variants
    assert set(k) == {"wax_thermal_cycles", "wax_damage", *kpis.sn_columns()}


def test_cycle_count_and_miner_damage_can_rank_two_controllers_oppositely():
    # many small cycles (a fast PWM) against a few full strokes (a thermostat)
    from thermogym.controllers.tables import lifetime_rankings

    fast = kpis.wax_cycle_kpis([(6.0, 1.0)] * 200)
    slow = kpis.wax_cycle_kpis([(50.0, 1.0)] * 20)
    t = pd.DataFrame([fast, slow]).assign(
        scenario="s", plant="model", controller=["fast", "slow"], switch_cycles=[900.0, 20.0]
    )
    r = lifetime_rankings(t)[("s", "model")]
    rank, tau = r["rank"], r["tau"]
    assert rank.at["slow", "wax_damage"] == 2  # 20 full cycles: 200 · 0.12² < 20
    assert rank.at["slow", "wax_cycles_ge2K"] == 1 and rank.at["fast", "switch_cycles"] == 2
    assert rank.at["fast", "wax_cycles_ge10K"] == 1  # the small cycles are under the cut-off
    assert rank.at["fast", "wax_damage_m1_ge2K"] == 2  # m = 1: 200 · 0.12 = 24 > 20 · 1
    assert tau["wax_cycles_ge2K"] == tau["wax_damage_m1_ge2K"] == -1.0
    assert tau["wax_damage_m3_ge2K"] == 1.0


# ------------------------------------------------------------------ accuracy
def test_time_above_limit_and_errors():
    y = np.r_[np.full(6, 80.0), np.full(4, 90.0)]
    assert kpis.time_above_limit_h(y, 85.0, dt=900.0) == pytest.approx(1.0)
    x, ref = np.array([1.0, 2.0, 3.0]), np.array([1.0, 1.0, 1.0])
    assert kpis.stroke_rmse_mm(x, ref) == pytest.approx(np.sqrt(5.0 / 3.0))
    assert kpis.stroke_iae_mm_s(x, ref, dt=10.0) == pytest.approx(30.0)


def test_discomfort_counts_only_occupied_hours_outside_the_band():
    T = np.r_[np.full(4, 18.0), np.full(4, 22.0), np.full(4, 26.0)]  # hourly samples
    occ = np.r_[np.ones(2), np.zeros(2), np.ones(8)]
    # occupied: 2 h at 2 K below, 4 h inside, 4 h at 2 K above -> 12 K·h
    assert kpis.discomfort_Kh(T, 20.0, 24.0, 3600.0, occ) == pytest.approx(12.0)
    assert kpis.discomfort_Kh(T, 20.0, 24.0, 3600.0) == pytest.approx(16.0)


def test_bearing_and_elongation_errors():
    Tb = np.array([[40.0, 44.0], [46.0, 47.0], [50.0, 41.0]])
    assert kpis.bearing_over_limit_Kh(Tb, 45.0, dt=3600.0) == pytest.approx(2.0 + 5.0)
    assert kpis.elongation_error_um([10.0, -10.0], 0.0) == pytest.approx(10.0)
    assert kpis.elongation_error_um([5.0, 6.0], [5.0, 6.0]) == 0.0


def test_bad_input_is_named():
    with pytest.raises(ShapeError, match=r"power_W\[1\]"):
        kpis.energy_Wh([1.0, np.nan], 1.0)
    with pytest.raises(ShapeError, match="dt"):
        kpis.time_above_limit_h([1.0], 0.0, dt=-1.0)
    with pytest.raises(ShapeError, match="1-D"):
        kpis.stroke_travel_mm(np.zeros((2, 2)))
