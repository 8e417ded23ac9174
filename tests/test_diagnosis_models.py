"""Models diagnosis builds: the augmented model, the switched network, the rigs' hidden node."""

from __future__ import annotations

import math

import numpy as np
import pytest
from _model_plants import with_hidden_node

import thermogym.identification.diagnosis  # noqa: F401  (registers the "augmented" model)
from thermogym.errors import ConfigError, SimulationError
from thermogym.fitresult import FitResult
from thermogym.models.augmented import AugmentedModel
from thermogym.models.fastnet import SwitchedNetwork, fast_or_none
from thermogym.models.linear import FOPTDModel
from thermogym.models.registry import get_model
from thermogym.rigs import get_rig, run_experiment
from thermogym.rigs.base import first_order_lag

_BASE = {
    "inputs": ["u"],
    "outputs": ["y", "y2"],
    "disturbances": ["Ta"],
    "T": [[100.0, 300.0], [50.0, 80.0]],
    "K": [[2.0, 1.0], [1.0, 1.0]],
    "offsets": True,
}
_SPECS = [
    ("transport_delay", "u", {"history": 20}),
    ("unmeasured_disturbance", "Ta", {"period": 500.0}),
    ("input_nonlinearity", "u", {"u_ref": 1.0}),
    ("missing_dynamics", "y", {"sources": ["u", "Ta"]}),
    ("input_dependent_heat_transfer", "y", {"share": "all", "reference": "Ta"}),
    ("input_dependent_heat_transfer", "y2", {"share": "all"}),
    ("nonlinear_heat_transfer", "y", {"reference": "Ta"}),
    ("time_varying_parameter", "y", {}),
    ("backlash", "y", {}),
    ("residual_ode", "y2", {"terms": ["e", "dT|dT|", "u"]}),
    ("sensor_lag", "y", {}),
    ("sensor_offset", "y", {}),
    ("sensor_drift", "y", {}),
    ("unmeasured_disturbance", "y2", {"period": 300.0}),
    # forms (issue 15): input maps, courses per recording, the loop side, dead times
    ("input_nonlinearity", "u", {"form": "saturation", "u_ref": 1.0}),
    ("input_nonlinearity", "u", {"form": "dead_zone", "u_ref": 1.0}),
    ("input_nonlinearity", "u", {"form": "piecewise_linear", "knots": [0.0, 0.5, 1.0, 1.5]}),
    ("supply_variation", "u", {"form": "steps", "span": 400.0, "segments": 4}),
    ("unmeasured_disturbance", "Ta", {"form": "smooth", "span": 400.0, "segments": 4}),
    ("unmeasured_disturbance", "Ta", {"form": "periodic", "period": 150.0}),
    ("backlash", "u", {"form": "input"}),
    ("missing_dynamics", "u", {"form": "input_lag"}),
    ("transport_delay", "y2", {"form": "output", "history": 12}),
    ("nonlinear_heat_transfer", "y", {"form": "radiation", "port": "Ta", "reference": "Ta"}),
    ("nonlinear_heat_transfer", "y2", {"form": "convection", "port": "u", "scale": 0.5}),
    (
        "input_dependent_heat_transfer",
        "y",
        {"form": "power", "port": "Ta", "source": "u", "reference": "Ta"},
    ),
    ("time_varying_parameter", "y2", {"form": "ramp", "port": "Ta", "reference": "Ta"}),
    (
        "time_varying_parameter",
        "y",
        {"form": "random_walk", "port": "Ta", "span": 400.0, "segments": 3},
    ),
    ("missing_dynamics", "y2", {"form": "extra_node", "port": "Ta"}),
    ("phase_change", "y", {"form": "latent_heat", "port": "u", "T_melt": 21.0}),
    # a hard limit of the input; a course added to the reading (the diagnosis' course baseline)
    ("input_nonlinearity", "u", {"form": "limit", "u_max": 1.5}),
    ("sensor_drift", "y2", {"form": "wander", "span": 400.0, "segments": 3}),
    # a conductance an input sets, fouling at a steady pace (one rate for all recordings)
    ("supply_variation", "u", {"form": "ramp"}),
]
#: legacy static maps read the current input, which a sensor lag of the next sample cannot
#: know when stepping: they are left out of the combination (each is checked alone)
_STATIC = {1, 4, 5, 6}
_VALUES = {
    "delay_u": 7.3,
    "dist_sin_Ta": 1.0,
    "dist_cos_Ta": 0.5,
    "alpha_u": 1.3,
    "md_K_y__u": 0.5,
    "md_K_y__Ta": -0.2,
    "md_T_y": 40.0,
    "gamma_y": 0.3,
    "tv_rate_y": 0.2,
    "backlash_y": 0.2,
    "tau_lag_y": 15.0,
    "offset_y": 0.4,
    "drift_y": 1.0,
    "beta_all": 0.7,
    "dist_sin_y2": 0.3,
    "c_e_y2": -0.01,
    "c_dT2_y2": -0.001,
    "c_u_y2": 0.002,
    "y0_y": 20.0,
    "y0_y2": 21.0,
    "sat_u": 1.5,
    "dz_u": 0.3,
    "pwl1_u": 2.0,
    "pwl2_u": 0.5,
    "sv_k1_u": 0.2,
    "sv_k3_u": -0.1,
    "dist_k0_Ta": 0.5,
    "dist_k2_Ta": -1.0,
    "backlash_u": 0.2,
    "lag_in_u": 9.0,
    "delay_out_y2": 6.5,
    "kappa_rad_y": 0.8,
    "kappa_conv_y2": 0.3,
    "kappa_fc_y": 0.4,
    "m_fc_y": 1.2,
    "tv_ramp_y2": 0.3,
    "tv_k1_y": 0.5,
    "xn_kappa_y2": 0.6,
    "xn_tau_y2": 60.0,
    "pc_kappa_y": 30.0,
    "pc_w_y": 0.5,
    "lim_u": 1.1,
    "wander_k1_y2": 0.4,
    "wander_k3_y2": -0.2,
    "sv_ramp_u": -0.3,
}


def _u(T=400):
    k = np.arange(T)
    return np.column_stack([(k % 100 < 50) * 1.5, 20 + np.sin(k / 30)])


def _augs(specs):
    # one form per (effect, signal): pick the combination's specs that do not clash
    seen, out = set(), []
    for e, s, x in specs:
        key = (e, s, x.get("form", ""))
        clash = any(k[0] == e and k[1] == s for k in seen)
        if not clash:
            out.append({"effect": e, "signal": s, **x})
        seen.add(key)
    return out


@pytest.mark.parametrize("i", [*range(len(_SPECS)), None])
def test_stepping_reproduces_simulation(i):
    specs = [x for j, x in enumerate(_SPECS) if j not in _STATIC] if i is None else [_SPECS[i]]
    augs = _augs(specs)
    m = AugmentedModel("foptd", _BASE, augs)
    th = m.theta({k: v for k, v in _VALUES.items() if k in m.param_names})
    u = _u()
    x0 = m.initial_state(th, u[:1])
    sim = m.simulate(u, 1.0, th, x0, return_states=True)
    # the loop side is solved by waveform relaxation to 1e-9 of the output's scale (~50)
    tol = 1e-6 if any(a.get("port") for a in augs) else 1e-9
    x, ys = x0.copy(), []
    for k in range(u.shape[0]):
        assert np.allclose(x, sim.states[:, k], atol=tol)
        ys.append(m.output(x, u[k : k + 1], th))
        x = m.step(x, u[k : k + 1], th, 1.0)
    np.testing.assert_allclose(np.stack(ys, 1), sim.outputs, atol=tol)


def test_neutral_augmentations_leave_the_base_model_unchanged():
    augs = _augs(_SPECS)
    m = AugmentedModel("foptd", _BASE, augs)
    base = FOPTDModel(**_BASE)
    th = m.theta({"y0_y": 20.0, "y0_y2": 21.0})
    thb = base.theta({"y0_y": 20.0, "y0_y2": 21.0})
    np.testing.assert_allclose(
        m.simulate(_u(), 1.0, th).outputs, base.simulate(_u(), 1.0, thb).outputs, atol=1e-12
    )


def _lagged_plant(u, K, T, tau, dt):
    # exact samples of a sensor s' = (y − s)/τ reading a first-order plant T y' = K u − y
    # driven by a held input: the 2-state system's matrix exponential per sample
    from scipy.linalg import expm

    A = np.array([[-1 / T, 0.0, K / T], [1 / tau, -1 / tau, 0.0], [0.0, 0.0, 0.0]])
    E = expm(A * dt)
    x = np.zeros(3)
    out = []
    for uk in u:
        out.append(x[1])
        x[2] = uk
        x = E @ x
    return np.array(out)


def test_sensor_lag_is_the_exact_lag_of_a_continuous_signal_and_delay_the_foptd_dead_time():
    base = {"inputs": ["u"], "outputs": ["y"], "K": 2.0, "T": 60.0}
    u = 1.5 - _u()[:, :1]  # starts at rest (0): both conventions agree on the past input
    y = FOPTDModel(**base).simulate(u, 1.0).outputs[0, :, 0]
    lag = AugmentedModel("foptd", base, [{"effect": "sensor_lag", "signal": "y"}])
    got = lag.simulate(u, 1.0, {"tau_lag_y": 25.0}).outputs[0, :, 0]
    truth = _lagged_plant(u[:, 0], 2.0, 60.0, 25.0, 1.0)
    # the first-order hold takes the plant's output as linear between samples: exact to
    # the curvature of a 60 s lag over 1 s, far closer than the zero-order hold of the
    # rig's sampled lag (half a sample late)
    np.testing.assert_allclose(got, truth, atol=2e-3)
    assert np.max(np.abs(first_order_lag(y, 25.0, 1.0) - truth)) > 5 * np.max(np.abs(got - truth))
    delayed = AugmentedModel("foptd", base, [{"effect": "transport_delay", "signal": "u"}])
    got = delayed.simulate(u, 1.0, {"delay_u": 12.0}).outputs[0, :, 0]
    truth = FOPTDModel(**base, tau=12.0).simulate(u, 1.0).outputs[0, :, 0]
    np.testing.assert_allclose(got, truth, atol=1e-12)


def test_saturating_heat_transfer_is_the_steady_state_of_a_growing_conductance():
    # steady state of Q = g0 Δ (1 + γ Δ/ΔT_ref) with the linear rise Δ_lin = Q/g0
    base = {"inputs": ["u"], "outputs": ["y"], "K": 10.0, "T": 5.0, "offsets": True}
    m = AugmentedModel("foptd", base, [{"effect": "nonlinear_heat_transfer", "signal": "y"}])
    y = m.simulate(np.ones((400, 1)), 1.0, {"gamma_y": 0.5, "y0_y": 20.0}).outputs[0, -1, 0]
    d = y - 20.0
    assert d * (1 + 0.5 * d / 10.0) == pytest.approx(10.0, rel=1e-9)


def test_fitresult_rebuilds_the_augmented_model():
    augs = [
        {"effect": "sensor_offset", "signal": "T_nut"},
        {"effect": "sensor_lag", "signal": "T_nut"},
    ]
    m = get_model("augmented", base="strut", base_config={}, augmentations=augs)
    fit = FitResult.from_model(m, {"offset_T_nut": 0.7, "tau_lag_T_nut": 300.0})
    again = FitResult.from_dict(fit.to_dict()).build_model()
    u = np.column_stack([np.full(40, 20.0), np.full(40, 21.0)])
    np.testing.assert_array_equal(
        m.simulate(u, 140.9, fit.theta(m)).outputs,
        again.simulate(u, 140.9, fit.theta(again)).outputs,
    )


def test_bad_augmentations_are_refused_by_name():
    with pytest.raises(ConfigError, match="outputs of model 'foptd'"):
        AugmentedModel("foptd", _BASE, [{"effect": "sensor_lag", "signal": "nope"}])
    with pytest.raises(ConfigError, match="augmentations are"):
        AugmentedModel("foptd", _BASE, [{"effect": "warp_drive", "signal": "y"}])
    with pytest.raises(ConfigError, match=r"its forms are \['latent_heat'\]"):
        AugmentedModel("foptd", _BASE, [{"effect": "phase_change", "signal": "y", "form": "x"}])
    with pytest.raises(ConfigError, match="needs a 'port' input"):
        AugmentedModel("foptd", _BASE, [{"effect": "phase_change", "signal": "y"}])
    with pytest.raises(ConfigError, match="'port' 'T_nope' is not an exogenous signal"):
        AugmentedModel("foptd", _BASE, [{"effect": "nonlinear_heat_transfer", "signal": "y",
                                          "form": "radiation", "port": "T_nope"}])  # fmt: skip
    with pytest.raises(
        ConfigError, match="input_nonlinearity u_ref is 'fast'; expected a positive number"
    ):
        AugmentedModel("foptd", _BASE, [{"effect": "input_nonlinearity", "signal": "u",
                                          "u_ref": "fast"}])  # fmt: skip
    with pytest.raises(ConfigError, match=r"nonlinear_heat_transfer dT_ref is -1\.0"):
        AugmentedModel("foptd", _BASE, [{"effect": "nonlinear_heat_transfer", "signal": "y",
                                          "reference": "Ta", "dT_ref": -1.0}])  # fmt: skip
    with pytest.raises(ConfigError, match="appears twice"):
        AugmentedModel(
            "foptd",
            _BASE,
            [{"effect": "sensor_lag", "signal": "y"}, {"effect": "sensor_lag", "signal": "y"}],
        )
    m = AugmentedModel("foptd", _BASE, [{"effect": "transport_delay", "signal": "u", "history": 2}])
    th = m.theta({"delay_u": 5.0})
    x = m.initial_state(th, _u()[:1])
    with pytest.raises(SimulationError, match="history"):
        m.step(x, _u()[:1], th, 1.0)


@pytest.mark.parametrize(
    ("plant", "effect", "values", "u_on", "dt"),
    [
        ("spindle", "input_dependent_heat_transfer", {"beta_u": 1.5}, 8000.0, 120.0),
        ("spindle", "input_nonlinearity", {"alpha_u": 1.6}, 8000.0, 120.0),
        ("strut", "input_dependent_heat_transfer", {"beta_u": 2.0}, 30.0, 158.3),
    ],
)
def test_switched_network_matches_the_plants_own_rk4(plant, effect, values, u_on, dt):
    m = get_model(plant, effects=[effect])
    T = 200
    u = np.column_stack(
        [
            np.r_[0.0, np.full(T // 2, u_on), np.zeros(T - T // 2 - 1)],
            24 + np.sin(np.arange(T) / 50),
        ]
    )
    th = m.theta(values)
    y_rk4 = m.simulate(u, dt, th).outputs[0]
    y_fast = fast_or_none(m).simulate(u, dt, th).outputs[0]
    assert np.abs(y_rk4 - y_fast).max() < 1e-3 * np.abs(y_rk4 - y_rk4[0]).max()


def test_hidden_node_keeps_the_steady_state_and_slows_the_response():
    # a mass attached without a path to the air stores heat but changes no steady state
    plant = get_model("strut")
    hidden = with_hidden_node(plant, "tube_rear", capacity=20000.0, conductance=2.0, g_air=0.0)
    assert hidden.state_names[-1] == "hidden_mass" and len(hidden.state_names) == 19
    u = np.column_stack([np.full(2000, 20.0), np.full(2000, 21.0)])
    th = plant.theta()
    ss = plant.steady_state(th, u[:1])[0]
    y_h = hidden.simulate(u, 600.0, th).outputs[0]
    y_p = plant.simulate(u, 600.0, th).outputs[0]
    j = plant.output_names.index("T_tube_rear")
    assert y_h[-1, j] == pytest.approx(ss[plant.state_names.index("tube_rear")], abs=1e-6)
    assert y_h[12, j] < y_p[12, j] - 0.1  # two hours in, the mass still absorbs heat
    with pytest.raises(ConfigError, match="nodes are"):
        with_hidden_node(plant, "nowhere", capacity=1.0, conductance=1.0)


def test_missing_dynamics_rig_leaves_no_trace_in_the_metadata(tmp_path):
    recs = run_experiment("strut", "steps", tmp_path, seed=1, effects=["missing_dynamics"])
    clean = get_rig("strut").run("steps", seed=1)
    assert not np.allclose(recs[0]["T_bearing"], clean[0].columns["T_bearing"], atol=0.2)
    text = " ".join(p.read_text() for p in tmp_path.iterdir() if p.suffix == ".json")
    assert "hidden" not in text and "missing" not in text and "effect" not in text


def test_sensor_lag_of_the_rig_starts_in_equilibrium():
    y = first_order_lag(np.full(50, 25.0), 900.0, 140.9)
    np.testing.assert_allclose(y, 25.0)


def test_network_substeps_follow_the_effects_switched_on():
    # the sub-step rule bounds the stiffness the effects can add: forced convection by
    # 1 + β u_max/u_ref, the loss nonlinearity by its slope (≤ 4/3 (ΔT_span/ΔT_ref)^(1/3))
    m = get_model("spindle", effects=["nonlinear_heat_transfer"])
    full = m.full_theta(m.theta({}))
    net, eff = m.network(full), m.effect_values(full)
    base = m.rk4_substeps(net, 120.0, 8000.0, eff)
    assert base < m.rk4_substeps(net, 120.0, 8000.0)  # β = 0: no forced-convection margin
    big = eff.copy()
    big[:, 2] = 5.0
    n5 = m.rk4_substeps(net, 120.0, 8000.0, big)
    assert base < n5 <= math.ceil(base * 4.0 / 3.0 * 6.0 ** (1.0 / 3.0)) + 1
    # the count it picks is accurate: four times finer steps change the output < 1 mK
    th = m.theta({"gamma_nl": 5.0}, batch=1)
    T = 240
    u = np.column_stack([np.repeat([0.0, 8000.0, 3000.0], T // 3), np.full(T, 21.0)])[None]
    x0 = np.full((1, len(m.nodes)), 21.0)
    full = m.full_theta(th)
    n = m.rk4_substeps(m.network(full), 120.0, 8000.0, m.effect_values(full))
    y, _ = m.simulate_network(th, u, 120.0, x0)
    y_fine, _ = m.simulate_network(th, u, 120.0, x0, substeps=4 * n)
    assert float(np.ptp(y)) > 5.0  # the run heats the spindle
    np.testing.assert_allclose(y, y_fine, atol=1e-3)
    # the loss nonlinearity is not linear in the state: no switched-LTI fast path
    assert fast_or_none(m) is None
    with pytest.raises(ConfigError, match="nonlinear_heat_transfer"):
        SwitchedNetwork(m)
