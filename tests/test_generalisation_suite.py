"""The public generalisation suite of the diagnosis (benchmarks/diagnosis/).

Independence from the diagnosis it scores (an AST check of every suite
module), and the suite's own physics against hand calculations: steady
states and energy balances of the new plants, each effect switched off
giving the nominal truth, each effect's sign and size, determinism.
"""

from __future__ import annotations

import ast
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

ROOT = Path(__file__).resolve().parents[1]
SUITE = ROOT / "benchmarks" / "diagnosis"
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from benchmarks.diagnosis import effects as fx  # noqa: E402
from benchmarks.diagnosis.cases import CASES, RIG_FAMILIES, _profiles, build  # noqa: E402
from benchmarks.diagnosis.effects import FORMS, Hidden  # noqa: E402
from benchmarks.diagnosis.generalisation import named_effects, ranking, score  # noqa: E402
from benchmarks.diagnosis.nominal import BuildingModel, PlateModel, TankModel  # noqa: E402
from benchmarks.diagnosis.plants import (  # noqa: E402
    FAMILIES,
    BuildingPlant,
    PlatePlant,
    Profiles,
    TankPlant,
)
from benchmarks.diagnosis.signals import gauss_markov, smooth_random  # noqa: E402
from thermogym.vocabulary import EFFECT_NAMES  # noqa: E402

FORBIDDEN = ("thermogym.models.augmented", "thermogym.identification.diagnosis")


# ------------------------------------------------------------------------ independence
def _imports(path: Path) -> list[tuple[str, tuple[str, ...]]]:
    """(module, imported names) of every import statement in a file."""
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out += [(a.name, ()) for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module:
            names = tuple(a.name for a in node.names)
            out.append((node.module, names))
            # `from thermogym.identification import diagnosis` imports the package too
            out += [(f"{node.module}.{n}", ()) for n in names]
    return out


def _forbidden(module: str) -> bool:
    return any(module == f or module.startswith(f + ".") for f in FORBIDDEN)


def test_suite_modules_do_not_import_the_diagnosis_or_the_augmentations():
    files = sorted(SUITE.glob("*.py"))
    assert {"plants.py", "effects.py", "cases.py", "rigcases.py"} <= {f.name for f in files}
    for f in files:
        imports = _imports(f)
        if f.name == "generalisation.py":
            # the runner alone calls the public entry point, nothing else of the diagnosis
            bad = [
                (m, n)
                for m, n in imports
                if _forbidden(m)
                and not (m == "thermogym.identification.diagnosis" and n == ("diagnose",))
                and m != "thermogym.identification.diagnosis.diagnose"
            ]
        else:
            bad = [(m, n) for m, n in imports if _forbidden(m)]
        assert not bad, f"{f.name} imports {bad}"
        text = f.read_text(encoding="utf-8")
        assert "import_module" not in text and "__import__" not in text, f.name


def test_importing_the_suite_loads_neither_module():
    # the runners too: they reach the diagnosis only when a case is scored (run_case)
    code = (
        "import sys; sys.path.insert(0, {!r})\n"
        "import benchmarks.diagnosis.cases, benchmarks.diagnosis.rigcases, "
        "benchmarks.diagnosis.nominal, benchmarks.diagnosis.generalisation, "
        "benchmarks.diagnosis.detection_limits\n"
        "print([m for m in sys.modules if m.startswith({!r}) or m.startswith({!r})])"
    ).format(str(ROOT), *FORBIDDEN)
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT
    )
    assert out.stdout.strip() == "[]"


# ------------------------------------------------------------------------- the case list
def test_case_list_covers_what_the_issue_asks():
    kinds = [c.kind for c in CASES]
    assert len(CASES) >= 80
    assert kinds.count("combo") >= 10 and kinds.count("control") >= 10
    assert len({c.family for c in CASES}) >= 4
    assert {"plate", "tank", "building"} <= {c.family for c in CASES}
    assert set(RIG_FAMILIES) <= {c.family for c in CASES}
    assert len({c.name for c in CASES}) == len(CASES)
    assert {"user", "foptd", "ss:2"} <= {c.model for c in CASES}
    for c in CASES:
        for h in c.hidden:
            assert h.effect in EFFECT_NAMES and h.form in FORMS[h.effect]
            assert h.size, c.name
    forms = {(h.effect, h.form) for c in CASES for h in c.hidden}
    for effect, wanted in {
        "input_nonlinearity": {"power_law", "saturation", "dead_zone", "piecewise_linear"},
        "nonlinear_heat_transfer": {"radiation", "natural_convection"},
        "time_varying_parameter": {"ramp", "step", "random_walk"},
        "unmeasured_disturbance": {"periodic", "steps", "smooth"},
    }.items():
        assert {(effect, f) for f in wanted} <= forms, effect
    quick = [c for c in CASES if c.quick]
    assert 15 <= len(quick) <= 25 and {c.kind for c in quick} == {"control", "single", "combo"}


def test_hidden_rejects_unknown_effects_and_forms():
    with pytest.raises(ValueError, match="vocabulary"):
        Hidden("friction", "power_law")
    with pytest.raises(ValueError, match="form"):
        Hidden("sensor_lag", "second_order")


# ------------------------------------------------------------------------- plate physics
def _plate(hidden=(), n=600, lamp=50.0, T_amb=22.0, consts=None, active=None, dt=5.0, prof=None):
    """The plate plant on constant or given inputs; steady-state checks use dt = 20 s."""
    p = PlatePlant()
    consts = consts or p.design_values()
    active = active if active is not None else [[h.effect for h in hidden]]
    u = {
        "lamp": np.full((len(active), n), lamp) if np.ndim(lamp) == 0 else np.atleast_2d(lamp),
        "T_amb": np.full((len(active), n), T_amb),
    }
    n_sub = 2 if dt <= 5.0 else 1
    return p.simulate(
        u, dt, consts, p.settings(list(hidden), active), prof or Profiles(), n_sub=n_sub
    )


def test_plate_steady_state_and_energy_balance():
    c = PlatePlant().design_values()
    run = _plate(n=400, dt=20.0)
    T = run.outputs["T_plate"][0]
    # hand calculation: P u = G (T - T_amb)  ->  T = 22 + 45 * 0.5 / 0.5 = 67 °C
    assert T[-1] == pytest.approx(22.0 + c["P_max"] * 0.5 / c["G"], abs=1e-3)
    assert PlatePlant.steady_state(50.0, 22.0, c["C"], c["G"], c["P_max"]) == pytest.approx(67.0)
    # energy balance over the transient: C ΔT = ∫ (P u − G (T − T_amb)) dt
    dt = 20.0
    stored = c["C"] * (T[-1] - T[0])
    net = np.trapezoid(c["P_max"] * 0.5 - c["G"] * (T - 22.0), dx=dt)
    assert stored == pytest.approx(net, rel=1e-3)


def test_plate_radiation_matches_hand_balance_and_keeps_the_operating_point():
    c = PlatePlant().design_values()
    eps = 0.9
    h = Hidden("nonlinear_heat_transfer", "radiation", {"emissivity": eps})
    # at the reference point (50 °C in 22 °C air) the loss is still G ΔT: same steady state
    assert PlatePlant.T_REF - PlatePlant.DT_REF == 22.0
    u_ref = 100.0 * c["G"] * (PlatePlant.T_REF - 22.0) / c["P_max"]
    run = _plate([h], n=400, lamp=u_ref, dt=20.0)
    assert run.outputs["T_plate"][0, -1] == pytest.approx(PlatePlant.T_REF, abs=1e-3)
    # at full power: solve P = G_lin ΔT + ε σ A (T⁴ − Ta⁴) by hand
    A = PlatePlant.AREA
    G_lin = c["G"] - eps * fx.SIGMA_SB * A * (323.15**4 - 295.15**4) / 28.0

    def balance(T):
        return (
            c["P_max"]
            - G_lin * (T - 22.0)
            - eps * fx.SIGMA_SB * A * ((T + 273.15) ** 4 - 295.15**4)
        )

    T_hand = brentq(balance, 22.0, 300.0)
    hot = _plate([h], n=400, lamp=100.0, dt=20.0).outputs["T_plate"][0, -1]
    assert hot == pytest.approx(T_hand, abs=1e-3)
    # sign: above the reference radiation cools more than the linear loss, below it less
    linear = 22.0 + c["P_max"] / c["G"]
    assert hot < linear - 1.0
    warm = _plate([h], n=400, lamp=0.5 * u_ref, dt=20.0).outputs["T_plate"][0, -1]
    assert warm > 22.0 + c["P_max"] * 0.005 * u_ref / c["G"]


def test_plate_natural_convection_matches_hand_balance():
    c = PlatePlant().design_values()
    h = Hidden("nonlinear_heat_transfer", "natural_convection", {"exponent": 1.33, "share": 1.0})
    k = c["G"] * PlatePlant.DT_REF ** (1 - 1.33)
    dT = brentq(lambda d: c["P_max"] - k * d**1.33, 0.0, 500.0)
    T = _plate([h], n=400, lamp=100.0, dt=20.0).outputs["T_plate"][0, -1]
    assert T == pytest.approx(22.0 + dT, abs=1e-3)
    assert dT < c["P_max"] / c["G"]  # ΔT^1.33 grows faster than ΔT above ΔT_ref


def _all_family_effects(family: str) -> list[Hidden]:
    seen, out = set(), []
    for c in CASES:
        if c.family != family:
            continue
        for h in c.hidden:
            if (h.effect, h.form) not in seen:
                seen.add((h.effect, h.form))
                out.append(h)
    return out


@pytest.mark.parametrize("family", ["plate", "tank", "building"])
def test_each_effect_switched_off_gives_the_nominal_truth(family):
    fam = FAMILIES[family]
    rng = np.random.default_rng(3)
    n = 150
    dt = {"plate": 5.0, "tank": 30.0, "building": 600.0}[family]
    t = dt * np.arange(n)
    u = {
        "plate": {"lamp": 100 * rng.random(n), "T_amb": np.full(n, 21.0)},
        "tank": {
            "heater": rng.random(n),
            "valve": rng.random(n),
            "T_cw": np.full(n, 13.0),
            "T_amb": np.full(n, 21.0),
        },
        "building": {
            "hp_demand": 100 * rng.random(n),
            "T_out": np.full(n, 3.0),
            "I_sol": np.full(n, 100.0),
        },
    }[family]
    u = {k: v[None] for k, v in u.items()}
    consts = fam.design_values()
    x0 = None if family != "building" else np.array([[20.0, 18.0, 20.0, 20.0]])
    base = fam.simulate(u, dt, consts, fam.settings([], [[]]), Profiles(), x0)
    hidden = _all_family_effects(family)
    assert len(hidden) >= 7
    for h in hidden:
        prof = _profiles([h], np.random.default_rng(1), t, 10, dt)
        off = fam.simulate(u, dt, consts, fam.settings([h], [[]]), prof, x0)
        on = fam.simulate(u, dt, consts, fam.settings([h], [[h.effect]]), prof, x0)
        for k in base.outputs:
            np.testing.assert_array_equal(off.outputs[k], base.outputs[k], err_msg=h.effect)
        moved = max(np.abs(on.outputs[k] - base.outputs[k]).max() for k in base.outputs)
        assert moved > 1e-3, f"{family}: {h.effect} ({h.form}) changes nothing"


def test_sensor_offset_drift_lag_and_delay_on_the_plate():
    lamp = np.where(np.arange(400) < 100, 0.0, 80.0)[None]
    base = _plate(lamp=lamp, n=400).outputs["T_plate"][0]
    off = _plate([Hidden("sensor_offset", "constant", {"offset": 1.5})], lamp=lamp, n=400)
    np.testing.assert_allclose(off.outputs["T_plate"][0] - base, 1.5, atol=1e-12)
    prof = Profiles({"drift_t": 5.0 * np.arange(400) / 3600.0})
    dr = _plate([Hidden("sensor_drift", "linear", {"rate": 0.6})], lamp=lamp, n=400, prof=prof)
    np.testing.assert_allclose(dr.outputs["T_plate"][0] - base, 0.6 * prof.values["drift_t"])
    # a 30 s dead time shifts the response by exactly 6 samples (constant ambient)
    td = _plate([Hidden("transport_delay", "clock_skew", {"delay": 30.0})], lamp=lamp, n=400)
    np.testing.assert_allclose(td.outputs["T_plate"][0, 6:], base[:-6], atol=1e-9)
    # a lagging sensor reads below the rising plate, by about rate × τ on the ramp
    lag = _plate([Hidden("sensor_lag", "first_order", {"tau": 30.0})], lamp=lamp, n=400)
    y = lag.outputs["T_plate"][0]
    assert np.all(y[100:] <= base[100:] + 1e-9)
    k = 110
    rate = (base[k + 1] - base[k - 1]) / 10.0
    assert base[k] - y[k] == pytest.approx(rate * 30.0, rel=0.15)


def test_first_order_lag_is_exact_on_a_ramp_and_a_step():
    dt, tau = 10.0, 60.0
    t = dt * np.arange(200)
    y = fx.first_order_lag(0.5 * t, tau, dt)
    # analytic: y = 0.5 (t − τ (1 − e^(−t/τ)))
    np.testing.assert_allclose(y, 0.5 * (t - tau * (1 - np.exp(-t / tau))), atol=1e-9)
    step = fx.first_order_lag(np.r_[0.0, np.ones(199)], tau, dt)
    assert step[1 + 6] > 1 - math.exp(-1) - 0.09  # 60 s after the step (held from 0 to 10 s)


def test_plate_missing_dynamics_phase_change_supply_and_time_variation():
    c = PlatePlant().design_values()
    # a holder with no loss of its own leaves the steady state alone and slows the response
    md = Hidden("missing_dynamics", "extra_state", {"C_b": 200.0, "G_b": 1.5, "g_b": 0.0})
    both = _plate([md], n=600, active=[["missing_dynamics"], []], dt=20.0)
    y = both.outputs["T_plate"]
    assert y[0, -1] == pytest.approx(y[1, -1], abs=1e-3)
    assert y[0, 10] < y[1, 10] - 1.0
    # latent heat: the integral of the apparent capacity is L
    T = np.linspace(0, 100, 20001)
    cap = fx.latent_capacity(T, 2000.0, 50.0, 1.5)
    assert np.trapezoid(cap, T) == pytest.approx(2000.0, rel=1e-6)
    # heating through the melting range is delayed by about L / net power
    pc = Hidden("phase_change", "latent_heat", {"mass": 0.01, "T_melt": 50.0, "width": 1.5})
    runs = _plate([pc], n=300, lamp=100.0, active=[["phase_change"], []], dt=10.0)
    runs = runs.outputs["T_plate"]
    t_on = 10.0 * np.argmax(runs[0] > 70.0)
    t_off = 10.0 * np.argmax(runs[1] > 70.0)
    L = 0.01 * PlatePlant.L_PCM
    net = c["P_max"] - c["G"] * (50.0 - 22.0)
    sens = 0.01 * PlatePlant.CP_PCM * (70.0 - 22.0) / (c["P_max"] - c["G"] * (46.0 - 22.0))
    assert t_on - t_off == pytest.approx(L / net + sens, rel=0.2)
    # supply: lamp power ∝ V^1.6
    sv = Hidden("supply_variation", "steps", {"amplitude": 0.05})
    prof = Profiles({"supply": np.ones(400)})
    T = _plate([sv], n=400, prof=prof, dt=20.0).outputs["T_plate"][0, -1]
    assert T - 22.0 == pytest.approx(c["P_max"] * 0.5 * 1.05**1.6 / c["G"], rel=1e-4)
    # time-varying loss: +30 % conductance after the step
    tv = Hidden("time_varying_parameter", "step", {"change": 0.3})
    prof = Profiles({"tv": np.r_[np.zeros(200), np.ones(300)]})
    T = _plate([tv], n=500, prof=prof, dt=20.0).outputs["T_plate"][0]
    assert T[199] - 22.0 == pytest.approx(c["P_max"] * 0.5 / c["G"], rel=1e-3)
    assert T[-1] - 22.0 == pytest.approx(c["P_max"] * 0.5 / (1.3 * c["G"]), rel=1e-3)
    # unmeasured air temperature change: the plate follows it one to one at steady state
    ud = Hidden("unmeasured_disturbance", "steps", {"amplitude_K": 2.0})
    prof = Profiles({"dist": -np.ones(400)})
    T = _plate([ud], n=400, prof=prof, dt=20.0).outputs["T_plate"][0, -1]
    assert T == pytest.approx(22.0 - 2.0 + c["P_max"] * 0.5 / c["G"], abs=1e-3)


# --------------------------------------------------------------------------- input maps
def test_input_maps_have_the_shapes_physics_gives():
    u = np.linspace(0, 1, 11)
    np.testing.assert_allclose(fx.power_law(u, 2.0), u**2)
    assert fx.saturation(u, 0.6).max() == 0.6
    dz = fx.dead_zone(u, 0.2)
    assert np.all(dz[u <= 0.2] == 0) and dz[-1] == pytest.approx(1.0)
    ph = fx.phase_angle_power(u)
    assert ph[0] == pytest.approx(0.0) and ph[-1] == pytest.approx(1.0)
    assert ph[5] == pytest.approx(0.5)  # half the firing angle: half the power
    assert np.all(np.diff(ph) > 0) and ph[1] < 0.1 * 0.5  # S-curve: flat at the ends
    pl = fx.piecewise_linear(u, [0, 0.5, 1], [0, 0.2, 1])
    assert pl[5] == pytest.approx(0.2)
    with pytest.raises(ValueError, match="increasing"):
        fx.piecewise_linear(u, [0, 0.5, 0.4], [0, 0.2, 1])


def test_backlash_takes_up_its_play_on_reversal():
    up = np.linspace(0, 1, 101)
    u = np.r_[up, up[::-1]]
    y = fx.backlash(u, 0.1)
    assert np.all(np.abs(y - u) <= 0.05 + 1e-12)
    # after the reversal the output holds until the input has moved by the play
    top = int(np.argmax(u))
    assert np.all(y[top : top + 10] == y[top])
    assert y[top + 12] < y[top]


def test_clock_skew_shifts_a_held_signal():
    t = 10.0 * np.arange(50)
    x = (t >= 200).astype(float)
    np.testing.assert_array_equal(fx.clock_skew(t, x, 60.0), (t + 60 >= 200).astype(float))


# ---------------------------------------------------------------------------- tank physics
def test_tank_steady_state_and_flow_dependent_coil():
    d = TankPlant().design_values()
    tp = TankPlant()
    n, dt = 900, 120.0
    u = {
        "heater": np.full((1, n), 0.5),
        "valve": np.full((1, n), 0.4),
        "T_cw": np.full((1, n), 13.0),
        "T_amb": np.full((1, n), 21.0),
    }
    base = tp.simulate(u, dt, d, tp.settings([], [[]]), Profiles())
    hand = TankPlant.steady_state(0.5, 0.4, 13.0, 21.0, d["P_max"], d["K_coil"], d["G"])
    assert base.outputs["T_tank"][0, -1] == pytest.approx(hand, abs=1e-3)
    # a finite coil removes less heat: effectiveness 1 − exp(−NTU0 v^−0.2)
    h = Hidden("input_dependent_heat_transfer", "flow_dependent", {"ntu_full": 1.0})
    run = tp.simulate(u, dt, d, tp.settings([h], [[h.effect]]), Profiles())
    eff = 1 - math.exp(-(0.4**-0.2))
    K = d["K_coil"] * 0.4 * eff
    T = (d["P_max"] * 0.5 + K * 13.0 + d["G"] * 21.0) / (K + d["G"])
    assert run.outputs["T_tank"][0, -1] == pytest.approx(T, abs=1e-3)
    assert T > hand
    # the nominal model a user brings agrees with the nominal plant
    sim = TankModel().simulate(np.tile([0.5, 0.4, 13.0, 21.0], (n, 1)), dt, x0=[21.0])
    np.testing.assert_allclose(sim.outputs[0, :, 0], base.outputs["T_tank"][0], atol=1e-6)


def test_tank_stratification_keeps_the_energy_balance():
    d = TankPlant().design_values()
    tp = TankPlant()
    n = 400
    u = {
        "heater": np.full((2, n), 0.6),
        "valve": np.zeros((2, n)),
        "T_cw": np.full((2, n), 13.0),
        "T_amb": np.full((2, n), 21.0),
    }
    md = Hidden("missing_dynamics", "extra_state", {"G_mix": 50.0, "lower_share": 0.4})
    run = tp.simulate(u, 30.0, d, tp.settings([md], [[md.effect], []]), Profiles())
    x = run.states
    stored = d["C"] * 0.6 * (x[0, -1, 0] - 21.0) + d["C"] * 0.4 * (x[0, -1, 1] - 21.0)
    mean_loss = d["G"] * (0.6 * (x[0, :, 0] - 21) + 0.4 * (x[0, :, 1] - 21))
    net = np.trapezoid(d["P_max"] * 0.6 - mean_loss, dx=30.0)
    assert stored == pytest.approx(net, rel=2e-3)
    # the sensor sits in the upper layer: it warms later than the mixed tank
    assert run.outputs["T_tank"][0, 20] < run.outputs["T_tank"][1, 20]


# ------------------------------------------------------------------------ building physics
def test_building_steady_state_and_cop():
    bp = BuildingPlant()
    c = bp.design_values()
    assert float(bp.cop(np.array(5.0), 0.45)) == pytest.approx(0.45 * 308.15 / 30.0)
    n = int(80 * 86400 / 3600)
    u = {
        "hp_demand": np.full((1, n), 40.0),
        "T_out": np.full((1, n), 5.0),
        "I_sol": np.full((1, n), 50.0),
    }
    x0 = np.array([[20.0, 18.0, 20.0, 20.0]])
    run = bp.simulate(u, 3600.0, c, bp.settings([], [[]]), Profiles(), x0)
    Q = float(bp.cop(np.array(5.0), c["eta"])) * c["P_el"] * 0.4
    A = np.array([[c["UA1"] + c["K12"], -c["K12"]], [-c["K12"], c["UA2"] + c["K12"]]])
    b = np.array([Q + c["gA1"] * 50 + c["UA1"] * 5, c["gA2"] * 50 + c["UA2"] * 5])
    T1, T2 = np.linalg.solve(A, b)
    assert run.outputs["T_z1"][0, -1] == pytest.approx(T1, abs=1e-3)
    assert run.outputs["T_z2"][0, -1] == pytest.approx(T2, abs=1e-3)
    # the user's two-node model: same steady state, same trajectory
    m = BuildingModel()
    sim = m.simulate(np.tile([40.0, 5.0, 50.0], (n, 1)), 3600.0, x0=[20.0, 18.0])
    np.testing.assert_allclose(sim.outputs[0, :, 0], run.outputs["T_z1"][0], atol=1e-4)
    st = m.initial_state(m.theta(), np.array([[40.0, 5.0, 50.0]]))
    np.testing.assert_allclose(st[0], [T1, T2], atol=1e-9)


def test_building_slab_delays_but_keeps_the_steady_state():
    bp = BuildingPlant()
    c = bp.design_values()
    n = int(120 * 86400 / 3600)
    u = {
        "hp_demand": np.full((2, n), 40.0),
        "T_out": np.full((2, n), 5.0),
        "I_sol": np.zeros((2, n)),
    }
    md = Hidden("missing_dynamics", "extra_state", {"C_m": 40e6, "K_m": 500.0})
    x0 = np.tile([15.0, 14.0, 15.0, 15.0], (2, 1))
    run = bp.simulate(u, 3600.0, c, bp.settings([md], [[md.effect], []]), Profiles(), x0)
    y = run.outputs["T_z1"]
    assert y[0, -1] == pytest.approx(y[1, -1], abs=1e-3)
    assert y[0, 24] < y[1, 24] - 0.5


def test_plate_nominal_model_matches_the_nominal_plant():
    rng = np.random.default_rng(0)
    n = 600
    lamp = np.repeat(100 * rng.random(n // 60), 60)
    truth = _plate(lamp=lamp[None], n=n, T_amb=22.0).outputs["T_plate"][0]
    sim = PlateModel().simulate(np.column_stack([lamp, np.full(n, 22.0)]), 5.0, x0=[22.0])
    np.testing.assert_allclose(sim.outputs[0, :, 0], truth, atol=1e-6)


# ------------------------------------------------------------------- noise, determinism
def test_gauss_markov_noise_has_its_variance_and_correlation_time():
    x = gauss_markov(np.random.default_rng(1), 200_000, 10.0, 0.3, 100.0)
    assert x.std() == pytest.approx(0.3, rel=0.05)
    r1 = np.corrcoef(x[:-1], x[1:])[0, 1]
    assert r1 == pytest.approx(math.exp(-0.1), abs=0.01)
    w = smooth_random(np.random.default_rng(2), 60.0 * np.arange(5000), 3600.0, walk=True)
    assert w[0] == 0.0 and np.sqrt(np.mean(w**2)) == pytest.approx(1.0)


def test_cases_are_deterministic_given_their_seed_and_noise_is_coloured():
    case = next(c for c in CASES if c.family == "tank" and c.kind == "control")
    a, b = build(case), build(case)
    for ra, rb in zip(a.train + a.validate, b.train + b.validate, strict=True):
        for k in ra.columns:
            np.testing.assert_array_equal(ra[k], rb[k])
    # the controls' constants are 10-30 % off the nominal model's
    nominal = TankPlant().design_values()
    for k, v in a.constants.items():
        assert 0.1 - 1e-9 <= abs(v / nominal[k] - 1) <= 0.3 + 1e-9
    # the residual noise is coloured: its lag-1 correlation is well above white noise's
    other = build(type(case)(case.family, case.hidden, case.model, case.seed + 1))
    assert not np.array_equal(other.train[0]["T_tank"], a.train[0]["T_tank"])
    fam = TankPlant()
    y = a.train[0]["T_tank"]
    assert np.all(np.round(y / 0.01) * 0.01 == pytest.approx(y))  # quantised to 0.01 K
    e = fam.sensors["T_tank"].apply(np.zeros(20000), 30.0, np.random.default_rng(0))
    assert np.corrcoef(e[:-1], e[1:])[0, 1] > 0.3
    assert a.validate[0].time[0] > 0  # the log does not start at t = 0


# ------------------------------------------------------------------------------- scoring
def test_named_effects_adapter_and_scores():
    assert named_effects({"named_effects": ["a", "b"]}) == (["a", "b"], "report")
    assert named_effects({"mismatch_detected": False, "best": {}}) == (["none"], "adapter")
    rep = {"mismatch_detected": True, "best": {"effect": "sensor_lag"}}
    assert named_effects(rep) == (["sensor_lag"], "adapter")
    rep = {"mismatch_detected": True, "best": {"effect": "unexplained"}}
    assert named_effects(rep) == (["unexplained"], "adapter")
    hyps = [
        {"rank": 2, "effect": "sensor_lag"},
        {"rank": 1, "effect": "missing_dynamics"},
        {"rank": 3, "effect": "sensor_lag"},
        {"rank": 4, "effect": "sindy"},
        {"rank": 5, "effect": "transport_delay"},
    ]
    assert ranking({"hypotheses": hyps}) == ["missing_dynamics", "sensor_lag", "transport_delay"]
    s = score(["sensor_lag"], "single", ["missing_dynamics"], ["missing_dynamics", "sensor_lag"])
    assert s["top1"] is False and s["top3"] is True and s["correct"] is False
    s = score(["a", "b"], "combo", ["b", "a", "c"], [])
    assert s["both"] is True and s["correct"] is True
    assert score(["none"], "control", ["parameter_error"], [])["control_ok"] is True
    assert score(["none"], "control", ["unexplained"], [])["control_ok"] is False


def test_figures_count_each_kind_once():
    from benchmarks.diagnosis.generalisation import figures

    rows = [
        {
            "kind": "single",
            "top1": True,
            "top3": True,
            "correct": True,
            "heldout_improves": True,
            "cpu_seconds": 1.0,
            "seconds": 2.0,
            "named_effects": ["sensor_lag"],
        },
        {
            "kind": "single",
            "top1": False,
            "top3": True,
            "correct": False,
            "cpu_seconds": 3.0,
            "seconds": 3.0,
            "named_effects": ["none"],
        },
        {
            "kind": "combo",
            "both": False,
            "correct": False,
            "cpu_seconds": 5.0,
            "seconds": 9.0,
            "named_effects": ["backlash"],
        },
        {
            "kind": "control",
            "control_ok": False,
            "cpu_seconds": 70.0,
            "seconds": 80.0,
            "named_effects": ["unexplained"],
        },
    ]
    f = figures(rows)
    assert (f["single_top1"], f["single_top3"], f["combo_both"]) == (0.5, 1.0, 0.0)
    assert f["controls_no_physics"] == 0.0 and f["controls_no_named_physics"] == 1.0
    assert f["heldout_improves"] == 1.0 and f["median_s"] == 4.0 and f["max_s"] == 70.0
    assert f["cases_over_60s"] == 1 and f["n_cases"] == 4
