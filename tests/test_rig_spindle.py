"""The spindle rig's true plant (paper 001): bearing friction, convection, conservation, effects.

Hand calculations write out the SKF frictional moment (SKF Rolling bearings
catalogue, "The SKF model for calculating the frictional moment"), the ASTM D341
viscosity-temperature relation and the convection correlations with the air
properties of Incropera Table A.4 (300 K).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from thermogym.rigs import get_rig, run_experiment
from thermogym.rigs import spindle as rsp
from thermogym.rigs.spindle import TEMPERATURES, SpindlePlant, SpindleRig

NU, K_AIR, ALPHA_AIR, PR, SIGMA = 15.89e-6, 26.3e-3, 22.5e-6, 0.707, 5.670374e-8
BEARINGS = ((80.0, 35.2), (80.0, 35.2), (90.0, 39.6), (90.0, 39.6))  # d_m, D − d [mm]


def viscosity(T):
    """ISO VG 22 base oil [mm²/s], ASTM D341: log log(ν + 0.7) = A − B log T through 40/100 °C."""
    z40, z100 = (math.log10(math.log10(v + 0.7)) for v in (22.0, 4.3))
    b = (z40 - z100) / (math.log10(373.15) - math.log10(313.15))
    return 10 ** (10 ** (z40 - b * (math.log10(T + 273.15) - math.log10(313.15)))) - 0.7


def skf(n, T=40.0, Fa=200.0, Fg=0.0, visc=True, parts=False):
    """Friction power of each bearing [W]: SKF rolling (with φ_ish, φ_rs) + sliding moment."""
    nu = viscosity(T) if visc else 22.0
    w = n * 2 * math.pi / 60
    roll, slide = [], []
    for dm, wall in BEARINGS:
        g_rr = 5.03e-7 * dm**1.97 * (Fg + 1.97 * Fa) ** 0.54
        ish = 1 / (1 + 1.84e-9 * (n * dm) ** 1.28 * nu**0.64)
        rs = math.exp(-6e-8 * nu * n * (2 * dm) * math.sqrt(4.4 / (2 * wall)))
        roll.append(ish * rs * g_rr * (nu * n) ** 0.6 * 1e-3 * w)
        bl = math.exp(-2.6e-8 * (n * nu) ** 1.4 * dm)
        g_sl = 1.30e-2 * dm**0.26 * (Fg ** (4 / 3) + 0.68 * Fa ** (4 / 3))
        slide.append(g_sl * (0.15 * bl + 0.05 * (1 - bl)) * 1e-3 * w)
    roll, slide = np.array(roll), np.array(slide)
    return (roll, slide) if parts else roll + slide


def at_temperature(plant, T, ring_diff=0.0):
    x = plant.initial_state(plant.nominal(1), [0.0, T])
    x[0, 2:6] += ring_diff  # inner rings warmer than the outer rings
    return x


def test_bearing_friction_is_the_skf_model_with_speed():
    p = SpindlePlant()
    spec = p.nominal(1)
    x = at_temperature(p, 40.0)
    for n in (4000.0, 6000.0, 8000.0):
        np.testing.assert_allclose(p.bearing_heat(x, n, spec)[0], skf(n), rtol=1e-9)
    # 140 W at 6000 rpm with the catalogue's constants; a starved grease bearing's heat
    # grows about as n (n^1.02 from 4000 to 8000 rpm), steeper at the low end
    assert skf(6000.0).sum() == pytest.approx(140.0, abs=1.0)
    assert 2**0.95 < skf(8000.0).sum() / skf(4000.0).sum() < 2**1.1
    assert skf(5000.0).sum() / skf(4000.0).sum() > (skf(8000.0).sum() / skf(7000.0).sum())
    lin = SpindlePlant(off=["friction_power_law"])
    h = [lin.bearing_heat(x, n, spec).sum() for n in (4000.0, 6000.0, 8000.0)]
    assert h[2] / h[0] == pytest.approx(2.0, rel=1e-12)  # off: linear in speed
    assert h[1] == pytest.approx(skf(6000.0).sum(), rel=1e-12)  # same heat at 6000 rpm


def test_oil_viscosity_is_astm_d341_through_the_grade():
    assert viscosity(40.0) == pytest.approx(22.0, rel=1e-9)
    assert viscosity(100.0) == pytest.approx(4.3, rel=1e-9)
    assert 45.0 < viscosity(22.0) < 55.0  # a VG 22 mineral oil near room temperature


def test_thermal_preload_and_oil_viscosity_change_the_friction():
    p = SpindlePlant()
    spec = p.nominal(1)
    n = 6000.0
    warm = p.bearing_heat(at_temperature(p, 40.0, ring_diff=4.0), n, spec)[0]
    # the ring mean rises by 2 K too: the SKF moment at that mean and 40 N/K × 4 K more
    np.testing.assert_allclose(warm, skf(n, T=42.0, Fa=200.0 + 40.0 * 4.0), rtol=1e-9)
    off = SpindlePlant(off=["thermal_preload"])
    np.testing.assert_allclose(
        off.bearing_heat(at_temperature(p, 40.0, ring_diff=4.0), n, spec)[0],
        skf(n, T=42.0),
        rtol=1e-9,
    )
    # G_rr ∝ F_a^0.54: 1 K of ring difference (+40 N) raises the heat about 11 %
    assert skf(n, Fa=240.0).sum() / skf(n).sum() == pytest.approx(1.10, abs=0.01)
    for T in (22.0, 60.0):
        np.testing.assert_allclose(
            p.bearing_heat(at_temperature(p, T), n, spec)[0], skf(n, T=T), rtol=1e-9
        )
    # thinner oil: less rolling friction where the bearing is fed (4000 rpm, 40 → 60 °C);
    # more where it was starved (8000 rpm, 22 → 40 °C): the SKF replenishment factor
    assert skf(4000.0, T=60.0).sum() < 0.85 * skf(4000.0).sum()
    assert skf(8000.0, T=40.0).sum() > 1.2 * skf(8000.0, T=22.0).sum()
    novisc = SpindlePlant(off=["lubricant_viscosity"])
    np.testing.assert_allclose(
        novisc.bearing_heat(at_temperature(p, 60.0), n, spec)[0], skf(n), rtol=1e-9
    )


def test_rotating_pulley_and_spacer_gap_match_their_correlations():
    on, off = SpindlePlant(), SpindlePlant(off=["rotating_convection"])
    spec = on.nominal(1)
    D, R, W = 0.15, 0.075, 0.05
    rim, faces = 0.5 * math.pi * D * W, 2 * math.pi / 4 * (D**2 - 0.085**2)
    ra = 9.81 / 300.0 * 10.0 * D**3 / (NU * ALPHA_AIR)
    h_nat = (0.60 + 0.387 * ra ** (1 / 6) / (1 + (0.559 / PR) ** (9 / 16)) ** (8 / 27)) ** 2
    h_nat *= K_AIR / D
    h_rad = 0.2 * SIGMA * (303.15**2 + 293.15**2) * (303.15 + 293.15)
    # the spacer gap: conduction k 2π r / δ over 0.33 m, Taylor vortices (Becker & Kaye)
    r, gap = 0.0525, 0.001
    i = 10 + 15  # shaft segment 15 (0.30-0.32 m), inside the spacer sleeves
    axial = 2 * 45.0 * math.pi / 4 * (0.085**2 - 0.025**2) / 0.02
    for n in (0.0, 4000.0, 8000.0):
        w = n * 2 * math.pi / 60
        h_cyl = 0.133 * (w * D**2 / NU) ** (2 / 3) * PR ** (1 / 3) * K_AIR / D
        h_disk = 0.36 * math.sqrt(w * R**2 / NU) * K_AIR / R  # Cobb & Saunders
        hf = (rim * h_cyl + faces * h_disk) / (rim + faces)
        h = (h_nat**3 + hf**3) ** (1 / 3)
        x = on.initial_state(spec, [n, 20.0])
        g = on.heat_flows(x, [n, 20.0], spec)["g_air"][0, 0]
        assert g == pytest.approx((rim + faces) * (h + h_rad), rel=1e-9)
        ta = w * w * (r + gap / 2) * gap**3 / NU**2
        f = 1.0 if ta < 1700 else 0.409 * ta**0.241 / 2  # Ta > 10⁴ at these speeds
        assert n == 0.0 or ta > 1e4
        x[0, i] += 1.0
        for p, ff in ((on, f), (off, 1.0)):
            C = p.arrays(spec).C[0, i]
            lost = -C * p.heat_flows(x, [n, 20.0], spec)["dTdt"][0, i]
            assert lost == pytest.approx(axial + K_AIR * 2 * math.pi * r / gap * 0.02 * ff)
    # documented sizes: pulley 3.7 W/K at 6000 rpm, the gap ×2.6-3.6 at 4000-8000 rpm
    x = on.initial_state(spec, [6000.0, 20.0])
    assert on.heat_flows(x, [6000.0, 20.0], spec)["g_air"][0, 0] == pytest.approx(3.7, abs=0.05)


def test_rotating_nose_convection_matches_the_correlation():
    D, dx = 0.085, 0.60 / 30
    ra = 9.81 / 300.0 * 10.0 * D**3 / (NU * ALPHA_AIR)
    h_nat = (0.60 + 0.387 * ra ** (1 / 6) / (1 + (0.559 / PR) ** (9 / 16)) ** (8 / 27)) ** 2
    h_nat *= K_AIR / D
    a, b = 303.15, 293.15
    h_rad = 0.3 * SIGMA * (a * a + b * b) * (a + b)
    i = 10 + 28  # shaft segment 28 (0.56-0.58 m): the exposed nose
    for n in (0.0, 6000.0):
        re = n * 2 * math.pi / 60 * D**2 / NU
        h_rot = 0.133 * re ** (2 / 3) * PR ** (1 / 3) * K_AIR / D
        for plant, h in ((SpindlePlant(), (h_nat**3 + h_rot**3) ** (1 / 3)),
                         (SpindlePlant(off=["rotating_convection"]), h_nat)):  # fmt: skip
            spec = plant.nominal(1)
            g = plant.heat_flows(plant.initial_state(spec, [n, 20.0]), [n, 20.0], spec)["g_air"]
            assert g[0, i] == pytest.approx(math.pi * D * dx * (h + h_rad), rel=1e-9)


def steady(plant, n, hours=36, Ta=22.0):
    spec = plant.nominal(1)
    U = np.tile([n, Ta], (hours, 1))
    return plant.simulate(U, 3600.0, spec), spec, U


def test_conservation_steady_state_and_transient():
    p = SpindlePlant()
    run, spec, U = steady(p, 6000.0)
    f = p.heat_flows(run.states[:, -1], U[-1], spec)
    assert f["generated"][0] == pytest.approx(f["to_air"][0], rel=1e-4)
    dt = 20.0
    U = np.tile([8000.0, 22.0], (541, 1))  # three hours from rest
    run = p.simulate(U, dt, spec)
    T = run.states.shape[1]
    f = p.heat_flows(run.states[0], np.tile(U[0], (T, 1)), spec.take(np.zeros(T, int)))
    net = f["generated"] - f["to_air"]
    inflow = dt * (net[1:] + net[:-1]).sum() / 2.0
    n = p.n_nodes
    stored = float(p.arrays(spec).C[0] @ (run.states[0, -1, :n] - run.states[0, 0, :n]))
    assert stored == pytest.approx(inflow, rel=2e-3)


def test_partition_and_probe_lags_act_as_their_physics_says():
    # at a fixed preload (the same heat, nearly): half of the friction heat enters the inner
    # ring, a warmer shaft side, a cooler outer ring
    on = steady(SpindlePlant(off=["thermal_preload"]), 6000.0)[0]
    off = steady(SpindlePlant(off=["heat_partition", "thermal_preload"]), 6000.0)[0]
    assert on.hidden["T_inner_ring_C"][0, -1] > off.hidden["T_inner_ring_C"][0, -1] + 0.2
    c = TEMPERATURES.index("T_front_bearing_C")
    assert on.outputs[0, -1, c] < off.outputs[0, -1, c] - 0.1
    # with the preload free to grow, the warmer inner ring raises it: more heat throughout
    full, part_off = (
        steady(SpindlePlant(), 6000.0),
        steady(SpindlePlant(off=["heat_partition"]), 6000.0),
    )
    q = [p.heat_flows(r.states[:, -1], u[-1], sp)["generated"][0]
         for p, (r, sp, u) in ((SpindlePlant(), full), (SpindlePlant(), part_off))]  # fmt: skip
    assert q[0] > q[1] * 1.05
    # an RTD pressed on the outer ring lags it by τ = 40 s: reading − ring ≈ −τ dT/dt
    U = np.tile([8000.0, 22.0], (361, 1))
    spec = SpindlePlant().nominal(1)
    y = SpindlePlant().simulate(U, 10.0, spec).output("T_front_bearing_C")[0]
    x = SpindlePlant(off=["sensor_mounting"]).simulate(U, 10.0, spec).output("T_front_bearing_C")
    slope = np.gradient(x[0], 10.0)
    assert x[0, 180] - y[180] == pytest.approx(40.0 * slope[180], rel=0.05)


def test_time_constants_are_hours():
    # paper 001 section 2.3.1: a run settles within the day, the spindle cools overnight
    p = SpindlePlant()
    U = np.tile([6000.0, 22.0], (24 * 6, 1))
    U[72:, 0] = 0.0
    y = p.simulate(U, 600.0, p.nominal(1)).output("T_front_bearing_C")[0] - 22.0
    cool = y[72:]
    t = 600.0 * np.arange(cool.size)
    k = (cool > 0.05 * cool[0]) & (cool < 0.6 * cool[0])
    tau_h = -1.0 / np.polyfit(t[k], np.log(cool[k]), 1)[0] / 3600.0
    assert 1.5 < tau_h < 6.0
    assert 10.0 < y[71] < 40.0  # ten to a few tens of kelvin at 6000 rpm


def test_specimen_and_switch_names():
    rig = get_rig("spindle")
    assert rig.specimen.to_dicts() == (
        SpindlePlant().draw_specimens(np.random.default_rng(rsp.SPECIMEN_SEED), 1).to_dicts()
    )
    assert SpindlePlant(off=["distributed_nodes"]).n_nodes == 10 + 3 + 2 + 2
    assert SpindlePlant().n_nodes > 4 * 14  # many more nodes than the model's 14


@pytest.fixture(scope="module")
def plain():
    return SpindlePlant().simulate(
        np.tile([8000.0, 22.0], (37, 1)), 600.0, SpindlePlant().nominal(1)
    )


@pytest.mark.parametrize(
    ("effect", "signal", "sign"),
    [
        ("input_nonlinearity", "T_front_bearing_C", +1),  # centrifugal ball load
        ("input_dependent_heat_transfer", "T_front_outer_housing", -1),  # the motor's fan
        ("nonlinear_heat_transfer", "T_front_outer_housing", -1),  # rise > 10 K: more loss
        ("missing_dynamics", "T_front_outer_housing", -1),  # the casting soaks up heat
    ],
)
def test_concealed_plant_effects(plain, effect, signal, sign):
    p = SpindlePlant(effects=[effect])
    run = p.simulate(np.tile([8000.0, 22.0], (37, 1)), 600.0, p.nominal(1))
    d = run.output(signal)[0, -1] - plain.output(signal)[0, -1]
    assert sign * d > 0.1, d


def test_concealed_effect_sizes_from_hand_calculations():
    base = SpindlePlant()
    x = at_temperature(base, 40.0)
    spec = base.nominal(1)
    # centrifugal ball load: the SKF model's F_g = 5 N (n/1000 rpm)²
    cf = SpindlePlant(effects=["input_nonlinearity"])
    np.testing.assert_allclose(
        cf.bearing_heat(x, 8000.0, spec)[0], skf(8000.0, Fg=5.0 * 64.0), rtol=1e-9
    )
    # grease churning after a night at rest: rolling friction × 1.6, fading with 1.5 h
    tv = SpindlePlant(effects=["time_varying_parameter"])
    churn = tv.bearing_heat(x, 6000.0, spec)[0] - skf(6000.0)
    rolling, _ = skf(6000.0, parts=True)
    np.testing.assert_allclose(churn, 0.6 * rolling, rtol=1e-9)
    run = tv.simulate(np.tile([6000.0, 22.0], (4, 1)), 3600.0, spec)
    assert run.hidden["grease_share"][0, 3] == pytest.approx(math.exp(-3.0 / 1.5), rel=1e-3)


def test_input_effects_and_sensor_faults_of_the_rig():
    p = SpindlePlant(effects=["transport_delay", "unmeasured_disturbance"])
    u = np.zeros((1, 40, 2))
    u[0, 20:, 0] = 6000.0
    u[0, :, 1] = 22.0
    seen = p.plant_inputs(u, 60.0, 0.0)
    assert seen[0, 10, 0] == 6000.0 and seen[0, 9, 0] == 0.0  # 10 min earlier than logged
    t = 60.0 * np.arange(40)
    np.testing.assert_allclose(seen[0, :, 1] - 22.0, 2.0 * np.sin(2 * np.pi * t / 18000.0))
    kw = {"speeds": [8000], "folds": [1], "raw": False, "duration_h": 4.0}
    clean = get_rig("spindle").run("run-in", seed=4, **kw)[0]
    for effect, signal, check in (
        ("sensor_offset", "T_front_outer_housing", lambda d: np.allclose(d, 1.0, atol=2e-3)),
        ("sensor_drift", "T_inner_housing", lambda d: abs(d[-1] - 0.15 * 4.0) < 0.01),
    ):
        run = get_rig("spindle", [effect]).run("run-in", seed=4, **kw)[0]
        assert check(run.columns[signal] - clean.columns[signal]), effect


@pytest.mark.parametrize("effect", SpindleRig.supported_effects)
def test_concealed_effects_leave_no_trace_in_the_metadata(tmp_path, effect):
    run_experiment(
        "spindle", "validation", tmp_path, seed=1, effects=[effect], speeds=[5300],
        raw=False, duration_h=1.0,
    )  # fmt: skip
    text = " ".join(p.read_text() for p in tmp_path.iterdir() if p.suffix == ".json")
    assert effect not in text and "effect" not in text
    for key in SpindleRig.effect_defaults.get(effect, {}):
        if key != "signal":
            assert f'"{key}"' not in text, key


def test_distributed_nodes_are_converged_and_the_lumped_spindle_is_not():
    # 60 nodes against a finer grid (60 shaft, 20 + 20 housing segments) over 6 h at 6000 rpm:
    # within 0.2 K; switched off (17 nodes, the model's size) the bearings run kelvins cooler
    # (the lumped shaft and housings spread the bearing heat over their whole capacity)
    U = np.tile([6000.0, 22.0], (36, 1))
    ref = SpindlePlant(n_shaft=60, n_housing=20)
    spec = ref.nominal(1)
    y = {
        k: p.simulate(U, 600.0, spec).outputs[0]
        for k, p in (
            ("ref", ref),
            ("on", SpindlePlant()),
            ("off", SpindlePlant(off=["distributed_nodes"])),
        )
    }
    assert np.abs(y["on"] - y["ref"]).max() < 0.2
    bearings = [i for i, k in enumerate(TEMPERATURES) if "bearing" in k]
    assert np.all(y["off"][-1, bearings] < y["ref"][-1, bearings] - 2.0)
