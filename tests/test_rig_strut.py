"""The strut rig's true plant (paper 000): its extra physics, conservation, concealed effects.

Hand calculations use the handbook formulas written out here, with the air
properties of Incropera Table A.4 at 300 K, independently of the rig's code.
"""

from __future__ import annotations

import ast
import json
import math
from pathlib import Path

import numpy as np
import pytest

from thermogym.errors import UnknownNameError
from thermogym.rigs import _strut_plant as rsp
from thermogym.rigs import get_rig, run_experiment
from thermogym.rigs import strut as rs
from thermogym.rigs.strut import SPREAD, StrutPlant, StrutRig

NU, K_AIR, ALPHA_AIR, PR, SIGMA = 15.89e-6, 26.3e-3, 22.5e-6, 0.707, 5.670374e-8


def churchill_chu(dT, D):
    ra = 9.81 / 300.0 * dT * D**3 / (NU * ALPHA_AIR)
    return (
        (0.60 + 0.387 * ra ** (1 / 6) / (1 + (0.559 / PR) ** (9 / 16)) ** (8 / 27)) ** 2 * K_AIR / D
    )


def taylor_couette(n_rpm, ri, ro):
    # Becker & Kaye (1962): Nu = h 2δ/k = 0.409 Ta^0.241 for 1e4 < Ta, Ta = ω² r_m δ³ / ν²
    w, d = n_rpm * 2 * math.pi / 60, ro - ri
    ta = w * w * (ri + ro) / 2 * d**3 / NU**2
    assert ta > 1e4
    return 0.409 * ta**0.241 / 2  # over conduction (Nu = 2)


def annulus_free(dT, ri, ro):
    # Raithby & Hollands, Incropera eqs 9.58-9.60
    L = ro - ri
    ra_l = 9.81 / 300.0 * dT * L**3 / (NU * ALPHA_AIR)
    ra_c = math.log(ro / ri) ** 4 * ra_l / (L**3 * ((2 * ri) ** -0.6 + (2 * ro) ** -0.6) ** 5)
    return 0.386 * (PR / (0.861 + PR)) ** 0.25 * ra_c**0.25


def flat_plate(U, L):
    return 0.664 * math.sqrt(U * L / NU) * PR ** (1 / 3) * K_AIR / L


def radiation(T, Ta, eps):
    a, b = T + 273.15, Ta + 273.15
    return eps * SIGMA * (a * a + b * b) * (a + b)


def mixed(a, b):
    return (a**3 + b**3) ** (1 / 3)


def steady(plant, v, Ta=20.0, spec=None, hours=30):
    spec = plant.nominal(1) if spec is None else spec
    U = np.tile([v, Ta], (hours, 1))
    run = plant.simulate(U, 3600.0, spec)
    return run, spec, U


def test_rig_modules_import_nothing_of_the_models():
    root = Path(rs.__file__).parent
    for name in (
        "strut.py",
        "_strut_plant.py",
        "_strut_kernels.py",
        "spindle.py",
        "_spindle_plant.py",
        "_spindle_kernels.py",
        "_convection.py",
        "_machine.py",
        "_plant_base.py",
    ):
        tree = ast.parse((root / name).read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom):
                assert not (node.module or "").startswith("thermogym.models"), (name, node.module)
            if isinstance(node, ast.Import):
                assert not any(a.name.startswith("thermogym.models") for a in node.names), name


def test_linear_without_its_extras_and_sublinear_with_forced_convection():
    # with forced convection and the copper's resistance off the strut is a linear network:
    # the steady rises scale with the feed rate (superposition)
    lin = StrutPlant(off=["forced_convection", "copper_resistance"])
    ref = np.r_[[20.0] * 7, 0.0]  # rises above the 20 °C air; ΔL at the ISO 20 °C reference
    r20, r30 = (steady(lin, v)[0].outputs[0, -1] - ref for v in (20.0, 30.0))
    np.testing.assert_allclose(r30 / r20, 1.5, rtol=1e-6)
    # paper 000 section 4.1: the plant is not linear in the feed rate. The screw's annulus
    # convection grows as n^0.48 while its heat grows as n: the screw, the nut and the push
    # tube warm less than in proportion (steady 30/20 about 1.41-1.45, not 1.5)
    full = StrutPlant()
    f20, f30 = (steady(full, v)[0].outputs[0, -1] - ref for v in (20.0, 30.0))
    for name in ("T_nut", "T_spindle", "T_tube_rear", "T_tube_front"):
        i = rs.OUTPUTS.index(name)
        assert 1.35 < f30[i] / f20[i] < 1.47, name
    nut, screw = rs.OUTPUTS.index("T_nut"), rs.OUTPUTS.index("T_spindle")
    assert f20[nut] < r20[nut] - 3.0 and f20[screw] < r20[screw] - 3.0  # and run cooler


def annulus_per_m(n_rpm):
    # the air around the Ø40 screw in the Ø90 bore (push tube or bellows) [W/(m K)]:
    # conduction × (free convection ⊕ Taylor vortices, their excess mixed with n = 3) and
    # radiation between the cylinders (ε 0.3 screw, 0.5 bore), linearised at 25 °C
    ri, ro = 0.020, 0.045
    cond = 2 * math.pi * K_AIR / math.log(ro / ri)
    kr = annulus_free(10.0, ri, ro)
    if n_rpm > 0:
        kr = 1 + ((kr - 1) ** 3 + (taylor_couette(n_rpm, ri, ro) - 1) ** 3) ** (1 / 3)
    rad = 2 * math.pi * ri * 4 * SIGMA * 298.15**3 / (1 / 0.3 + ri / ro * (1 / 0.5 - 1))
    return kr * cond + rad


def test_forced_convection_of_the_screw_matches_the_correlations():
    on, off = StrutPlant(), StrutPlant(off=["forced_convection"])
    spec = on.nominal(1)
    dx = 1.5 / 60
    # behind the nut (0.21 m): the annulus to the bellows in series with the bellows'
    # free convection and radiation (Ø110 mm, ε 0.9, linearised at a 10 K rise)
    i = rsp._NL + 8
    cover = math.pi * 0.11 * dx * (churchill_chu(10.0, 0.11) + radiation(30.0, 20.0, 0.9))
    # inside the push tube (1.4 m, beyond the nut's reach): the annulus to the tube; with
    # every other node at the air temperature the segment loses to its two neighbours
    # (k A / dx) and across the annulus
    k = rsp._NL + 56
    axial = 2 * 45.0 * math.pi / 4 * 0.04**2 / dx
    C = on.arrays(spec).C[0, k]
    for v in (0.0, 20.0, 30.0):
        n = v / 0.020  # screw speed [rpm] for a 20 mm lead
        for p, nn in ((on, n), (off, 0.0)):
            x = p.initial_state(spec, [v, 20.0])
            g = p.heat_flows(x, [v, 20.0], spec)["g_air"][0, i]
            ann = annulus_per_m(nn) * dx
            assert g == pytest.approx(ann * cover / (ann + cover), rel=1e-6)
            x[0, k] += 1.0
            lost = -C * p.heat_flows(x, [v, 20.0], spec)["dTdt"][0, k]
            assert lost == pytest.approx(axial + ann, rel=1e-6)
    # documented sizes: the annulus ×4.1 at 20 m/min, ×4.9 at 30 over its 0.65 W/(m K) at rest
    assert annulus_per_m(0.0) == pytest.approx(0.65, abs=0.005)
    assert annulus_per_m(1000.0) / annulus_per_m(0.0) == pytest.approx(4.1, abs=0.05)
    assert annulus_per_m(1500.0) / annulus_per_m(0.0) == pytest.approx(4.9, abs=0.05)


def test_copper_loss_follows_the_winding_temperature():
    # the network is linear at a fixed feed rate except for the copper loss; the winding's
    # only link is 8 W/K to the housing, so its heat raises it by R_dd + 1/8 K/W, where R_dd
    # is the housing's steady rise per watt, measured on the plant without the effect
    off = StrutPlant(off=["copper_resistance"])
    base = off.nominal(1)
    two = base.replace({"loss_motor": 2.0})
    tw = [steady(off, 20.0, spec=s)[0].hidden["T_winding"][0, -1] for s in (base, two)]
    q_cu, q_fe = 30.0, 10.0
    R_dd = (tw[1] - tw[0] - q_cu / 8.0) / (q_cu + q_fe)
    on = StrutPlant()
    tw_on = steady(on, 20.0)[0].hidden["T_winding"][0, -1]
    extra = 3.93e-3 * q_cu * (tw_on - 20.0)  # W more copper loss than at 20 °C
    assert tw_on - tw[0] == pytest.approx(extra * (R_dd + 1 / 8), rel=1e-4)
    assert tw_on > tw[0] + 0.5  # a hotter winding loses more: a real, visible effect


def test_winding_is_its_own_node_behind_the_housing():
    run, spec, U = steady(StrutPlant(), 20.0)
    q = StrutPlant().heat_flows(run.states[:, -1], U[-1], spec)["source"][0, rsp._IX["winding"]]
    T_drive = run.output("T_drive")[0, -1]  # the thermocouple has settled on the housing
    assert run.hidden["T_winding"][0, -1] - T_drive == pytest.approx(q / 8.0, rel=1e-6)
    merged = StrutPlant(off=["winding_node"])
    src = merged.heat_flows(run.states[:, -1], U[-1], spec)["source"][0]
    assert src[rsp._IX["winding"]] == 0.0 and src[rsp._IX["drive"]] > q


def test_heat_partition_and_stroke_averaging_move_heat_where_physics_says():
    ref = StrutPlant(off=["copper_resistance"])
    nut, screw = rs.OUTPUTS.index("T_nut"), rs.OUTPUTS.index("T_spindle")
    y_ref = steady(ref, 20.0)[0].outputs[0, -1]
    part_off = StrutPlant(off=["copper_resistance", "heat_partition"])
    y_po = steady(part_off, 20.0)[0].outputs[0, -1]
    # half of the nut's friction heat enters the screw: a warmer screw, a cooler nut
    assert y_ref[screw] > y_po[screw] + 0.1 and y_ref[nut] < y_po[nut] - 0.1
    gen = [p.heat_flows(p.initial_state(p.nominal(1), [20.0, 20.0]), [20.0, 20.0],
                        p.nominal(1))["generated"][0] for p in (ref, part_off)]  # fmt: skip
    assert gen[0] == pytest.approx(gen[1], rel=1e-12)  # the same heat, elsewhere
    # without the stroke, the nut sits at the mean position, over the screw's thermocouple
    still = StrutPlant(off=["copper_resistance", "stroke_contacts"])
    assert steady(still, 20.0)[0].outputs[0, -1][screw] > y_ref[screw] + 0.2


def test_thermocouple_lag_is_tau_times_the_slope():
    U = np.tile([30.0, 20.0], (90, 1))
    lag, nolag = StrutPlant(), StrutPlant(off=["thermocouple_lag"])
    spec = lag.nominal(1)
    y = lag.simulate(U, 20.0, spec).output("T_drive")[0]
    x = nolag.simulate(U, 20.0, spec).output("T_drive")[0]
    slope = np.gradient(x, 20.0)
    k = 60  # 20 min in: a smooth rise
    assert x[k] - y[k] == pytest.approx(30.0 * slope[k], rel=0.05)
    assert np.all(x[1:] > y[1:])


def test_screw_profile_is_the_analytic_fin_solution():
    # between the bearing pair (0.11 m) and the nut's stroke (0.40 m) the exposed screw has
    # no source and no contact: a fin, θ'' = m² θ with m² = h P / (k A)
    plant = StrutPlant()
    run, spec, U = steady(plant, 20.0)
    x = run.states[0, -1]
    seg = np.arange(5, 15)  # segments covering 0.125-0.375 m
    theta = x[rsp._NL + seg] - 20.0
    g = plant.heat_flows(run.states[:, -1], U[-1], spec)["g_air"][0, rsp._NL + seg]
    dx, A = 1.5 / 60, math.pi / 4 * 0.04**2
    m = math.sqrt(g.mean() / dx / (45.0 * A))
    s = (seg - seg[0]) * dx
    L = s[-1]
    exact = (theta[0] * np.sinh(m * (L - s)) + theta[-1] * np.sinh(m * s)) / np.sinh(m * L)
    assert np.abs(theta - exact).max() < 0.005 * np.abs(theta).max()
    assert np.ptp(theta) > 1.0  # a real profile, not a flat one


def test_energy_is_conserved_through_a_transient():
    plant = StrutPlant()
    spec = plant.nominal(1)
    dt = 15.0
    U = np.tile([30.0, 20.0], (481, 1))  # two hours
    run = plant.simulate(U, dt, spec)
    T = run.states.shape[1]
    f = plant.heat_flows(run.states[0], np.tile(U[0], (T, 1)), spec.take(np.zeros(T, int)))
    net = f["generated"] - f["to_air"]
    inflow = dt * (net[1:] + net[:-1]).sum() / 2.0
    C = plant.arrays(spec).C[0]
    n = plant.n_nodes
    stored = float(C @ (run.states[0, -1, :n] - run.states[0, 0, :n]))
    assert stored == pytest.approx(inflow, rel=2e-3)
    end = f["generated"][-1], f["to_air"][-1]
    assert end[0] > end[1]  # still warming after two hours


def test_specimens_span_the_papers_uncertainty():
    plant = StrutPlant()
    d = plant.draw_specimens(np.random.default_rng(1), 4000)
    for k, (lo, hi, _) in SPREAD.items():
        assert d[k].min() >= lo and d[k].max() <= hi
        assert np.log(d[k]).mean() == pytest.approx((math.log(lo) + math.log(hi)) / 2, abs=0.05)
    rig = get_rig("strut")
    first = plant.draw_specimens(np.random.default_rng(rs.SPECIMEN_SEED), 1)
    assert rig.specimen.to_dicts() == first.to_dicts()
    assert all(v == 1.0 for v in rig.with_specimen("nominal").specimen.to_dicts()[0].values())
    assert rig.with_specimen({"loss_nut": 2.0}).specimen["loss_nut"][0] == 2.0
    with pytest.raises(UnknownNameError, match="no ratio parameters"):
        rig.with_specimen({"r_nut": 1.2})
    with pytest.raises(UnknownNameError, match="conduction_1d"):
        StrutPlant(off=["conduction"])
    assert StrutPlant(off=["conduction_1d"]).n_screw == 5


@pytest.fixture(scope="module")
def base30():
    return get_rig("strut").run("steps", seed=2, feed_rates=[30.0])[0]


@pytest.mark.parametrize(
    ("effect", "signal", "sign", "where"),
    [
        ("input_dependent_heat_transfer", "T_drive", -1, "truth"),  # the motor's fan cools it
        ("input_nonlinearity", "T_bearing", +1, "truth"),  # viscous friction adds heat
        ("nonlinear_heat_transfer", "T_drive", -1, "truth"),  # hot bodies lose relatively more
        ("time_varying_parameter", "T_nut", +1, "truth"),  # the nut's grease wears thin
        ("missing_dynamics", "T_bearing", -1, "truth"),  # the bracket soaks up heat
        ("sensor_offset", "T_nut", +1, "columns"),  # the sensors', not the plant's
        ("sensor_drift", "T_spindle", +1, "columns"),
    ],
)
def test_concealed_effects_act_in_the_rigs_physics(base30, effect, signal, sign, where):
    run = get_rig("strut", [effect]).run("steps", seed=2, feed_rates=[30.0])[0]
    d = getattr(run, where)[signal][-1] - getattr(base30, where)[signal][-1]
    assert sign * d > 0.1, d
    if where == "columns":  # the same noise: the difference is the sensor fault alone
        np.testing.assert_array_equal(run.truth[signal], base30.truth[signal])


def test_concealed_effect_sizes_from_hand_calculations():
    x0 = StrutPlant().initial_state(StrutPlant().nominal(1), [20.0, 20.0])
    u = [20.0, 20.0]

    def flows(effects):
        p = StrutPlant(effects=effects)
        return p.heat_flows(x0, u, p.nominal(1))

    base = flows([])
    # the self-ventilated motor: 3 m/s along its 0.3 m housing at 1000 rpm
    fan = flows(["input_dependent_heat_transfer"])["g_air"][0, rsp._IX["drive"]]
    h_nat, h_rad = churchill_chu(10.0, 0.15), radiation(30.0, 20.0, 0.9)
    ratio = (mixed(h_nat, flat_plate(3.0, 0.3)) + h_rad) / (h_nat + h_rad)
    assert fan / base["g_air"][0, rsp._IX["drive"]] == pytest.approx(ratio, rel=1e-9)
    # Palmgren's viscous friction at 1000 rpm: M0 = 1e-7 f0 (ν n)^(2/3) d_m³ [N mm]
    w = 1000 * 2 * math.pi / 60
    m0 = [1e-7 * f0 * (100 * 1000) ** (2 / 3) * dm**3 for f0, dm in ((4.0, 55.0), (4.0, 40.0))]
    extra = flows(["input_nonlinearity"])["generated"][0] - base["generated"][0]
    assert extra == pytest.approx(sum(m0) * 1e-3 * w, rel=1e-9)
    # grease wear: +4 %/km of the nut's and bearings' friction, after 2 km of travel
    x = x0.copy()
    x[0, -1] = 2.0
    p = StrutPlant(effects=["time_varying_parameter"])
    wear = p.heat_flows(x, u, p.nominal(1))["generated"][0] - base["generated"][0]
    friction = 20.0 * 2 * math.pi / 60 / 0.020 * (0.28 + 0.13)  # nut + bearing torque × ω
    assert wear == pytest.approx(0.04 * 2.0 * friction, rel=1e-9)


def test_transport_delay_and_unseen_air_cycle_act_on_what_the_plant_sees():
    p = StrutPlant(effects=["transport_delay", "unmeasured_disturbance"])
    u = np.zeros((1, 20, 2))
    u[0, 10:, 0] = 20.0
    u[0, :, 1] = 21.0
    seen = p.plant_inputs(u, 60.0, 0.0)
    # the strut moved 600 s (10 samples) before the log says
    np.testing.assert_array_equal(seen[0, :, 0], 20.0)
    t = 60.0 * np.arange(20)
    np.testing.assert_allclose(seen[0, :, 1] - 21.0, 1.5 * np.sin(2 * np.pi * t / 7200.0))


@pytest.mark.parametrize("effect", StrutRig.supported_effects)
def test_concealed_effects_leave_no_trace_in_the_metadata(tmp_path, effect):
    run_experiment("strut", "steps", tmp_path, seed=1, effects=[effect], feed_rates=[20.0])
    text = " ".join(p.read_text() for p in tmp_path.iterdir() if p.suffix == ".json")
    settings = StrutRig.effect_defaults.get(effect, {})
    assert effect not in text and "effect" not in text
    for key in settings:
        if key != "signal":
            assert f'"{key}"' not in text, key
    json.loads((tmp_path / "manifest.json").read_text())


def test_conduction_1d_is_converged_and_the_lumped_screw_is_not():
    # the 60 + 60 finite volumes against 120 + 120 (the same plant, a finer grid): within a few
    # hundredths of a kelvin after 4 h at 20 m/min; switched off (5 screw and 3 tube lumps, the
    # model's resolution) the nut is kelvins off, the screw and the tube tenths to kelvins
    U = np.tile([20.0, 20.0], (24, 1))
    ref = StrutPlant(n_screw=120, n_tube=120)
    y = {
        k: p.simulate(U, 600.0, ref.nominal(1)).outputs[0]
        for k, p in (("ref", ref), ("on", StrutPlant()), ("off", StrutPlant(off=["conduction_1d"])))
    }
    temps = [rs.OUTPUTS.index(k) for k in rs.OUTPUTS if k.startswith("T_")]
    err_on = np.abs(y["on"] - y["ref"])[:, temps].max()
    err_off = np.abs(y["off"] - y["ref"])[:, temps].max(axis=0)
    assert err_on < 0.05
    assert err_off[temps.index(rs.OUTPUTS.index("T_nut"))] > 1.0
    assert err_off.max() > 20 * err_on
