"""The spindle rig's true plant (paper 001): bearing friction, convection, conservation, effects.

Hand calculations write out Palmgren's friction (SKF catalogue form) and the
convection correlations with the air properties of Incropera Table A.4 (300 K).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from thermogym.rigs import get_rig, run_experiment
from thermogym.rigs import spindle as rsp
from thermogym.rigs.spindle import TEMPERATURES, SpindlePlant, SpindleRig

NU, K_AIR, ALPHA_AIR, PR, SIGMA = 15.89e-6, 26.3e-3, 22.5e-6, 0.707, 5.670374e-8
BEARINGS = ((80.0, 18000.0), (80.0, 18000.0), (90.0, 25000.0), (90.0, 25000.0))  # d_m, C_0


def palmgren(n, T=40.0, F=200.0, f0=0.26, visc=True):
    """Friction power of each bearing [W]: M0 = 1e-7 f0 (ν n)^(2/3) d_m³, M1 = f1 F d_m."""
    nu = 22.0 * math.exp(-0.027 * (T - 40.0)) if visc else 22.0
    w = n * 2 * math.pi / 60
    out = []
    for dm, c0 in BEARINGS:
        m0 = 1e-7 * f0 * (nu * n) ** (2 / 3) * dm**3
        m1 = 0.001 * (200.0 / c0) ** (1 / 3) * F * dm
        out.append((m0 + m1) * 1e-3 * w)
    return np.array(out)


def at_temperature(plant, T, ring_diff=0.0):
    x = plant.initial_state(plant.nominal(1), [0.0, T])
    x[0, 2:6] += ring_diff  # inner rings warmer than the outer rings
    return x


def test_bearing_friction_is_palmgrens_law_with_speed():
    p = SpindlePlant()
    spec = p.nominal(1)
    x = at_temperature(p, 40.0)
    for n in (4000.0, 6000.0, 8000.0):
        np.testing.assert_allclose(p.bearing_heat(x, n, spec)[0], palmgren(n), rtol=1e-9)
    # the viscous term grows as n^(5/3): the heat grows faster than the model's n^1
    ratio = palmgren(8000.0).sum() / palmgren(4000.0).sum()
    assert 2**1.5 < ratio < 2 ** (5 / 3)
    lin = SpindlePlant(off=["friction_power_law"])
    h = [lin.bearing_heat(x, n, spec).sum() for n in (4000.0, 6000.0, 8000.0)]
    assert h[2] / h[0] == pytest.approx(2.0, rel=1e-12)  # off: linear in speed
    assert h[1] == pytest.approx(palmgren(6000.0).sum(), rel=1e-12)  # same heat at 6000 rpm


def test_thermal_preload_and_oil_viscosity_change_the_friction():
    p = SpindlePlant()
    spec = p.nominal(1)
    n = 6000.0
    warm = p.bearing_heat(at_temperature(p, 40.0, ring_diff=4.0), n, spec)[0]
    # the ring mean rises by 2 K too: compare with Palmgren at that mean and 40 N/K × 4 K more
    np.testing.assert_allclose(warm, palmgren(n, T=42.0, F=200.0 + 40.0 * 4.0), rtol=1e-9)
    off = SpindlePlant(off=["thermal_preload"])
    np.testing.assert_allclose(
        off.bearing_heat(at_temperature(p, 40.0, ring_diff=4.0), n, spec)[0],
        palmgren(n, T=42.0),
        rtol=1e-9,
    )
    hot = p.bearing_heat(at_temperature(p, 60.0), n, spec)[0]
    np.testing.assert_allclose(hot, palmgren(n, T=60.0), rtol=1e-9)
    assert hot.sum() < 0.8 * palmgren(n).sum()  # thinner oil, less churning
    novisc = SpindlePlant(off=["lubricant_viscosity"])
    np.testing.assert_allclose(
        novisc.bearing_heat(at_temperature(p, 60.0), n, spec)[0], palmgren(n), rtol=1e-9
    )


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
    on = steady(SpindlePlant(), 6000.0)[0]
    off = steady(SpindlePlant(off=["heat_partition"]), 6000.0)[0]
    # half of the friction heat enters the inner ring: a warmer shaft side, a cooler outer ring
    assert on.hidden["T_inner_ring_C"][0, -1] > off.hidden["T_inner_ring_C"][0, -1] + 0.2
    c = TEMPERATURES.index("T_front_bearing_C")
    assert on.outputs[0, -1, c] < off.outputs[0, -1, c] - 0.1
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
    # centrifugal ball load: F = 200 N + 5 N (n/1000 rpm)²
    cf = SpindlePlant(effects=["input_nonlinearity"])
    np.testing.assert_allclose(
        cf.bearing_heat(x, 8000.0, spec)[0], palmgren(8000.0, F=200.0 + 5.0 * 64.0), rtol=1e-9
    )
    # grease churning after a night at rest: viscous friction × 1.6, fading with 1.5 h
    tv = SpindlePlant(effects=["time_varying_parameter"])
    churn = tv.bearing_heat(x, 6000.0, spec)[0] - palmgren(6000.0)
    visc = palmgren(6000.0, F=0.0)  # the viscous part alone
    np.testing.assert_allclose(churn, 0.6 * visc, rtol=1e-9)
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
