"""Spindle and strut RC networks: steady states, energy balance, exact vs RK4, effects."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import simpson

from thermogym.errors import ConfigError, ParameterError, UnknownNameError
from thermogym.models.spindle import SPINDLE_OUTPUTS, SpindleModel
from thermogym.models.strut import ALPHA_STEEL, ELONGATION_PATH, STRUT_OUTPUTS, StrutModel
from thermogym.models.thermal_network import network_matrices

MODELS = [SpindleModel, StrutModel]
U_TEST = {"spindle": 6000.0, "strut": 20.0}


def _const(T: int, u: float, Ta: float) -> np.ndarray:
    return np.column_stack([np.full(T, u), np.full(T, Ta)])


@pytest.mark.parametrize("cls", MODELS)
def test_steady_state_heat_balance_by_hand(cls):
    # At steady state every watt produced leaves through the air conductances:
    # Σ_i q_i u = Σ_i g_i (T_i − T_amb), and the node balances (13) vanish one by one.
    m = cls()
    u, Ta = U_TEST[m.name], 21.0
    net = m.arrays(None)
    T = m.steady_state(m.theta(), np.array([[u, Ta]]))[0]
    q, g, G, C = net.q[0, :, 0] * u, net.g_amb[0], net.G[0], net.C[0]
    assert q.sum() == pytest.approx(np.sum(g * (T - Ta)), rel=1e-10)
    node_flux = q + G @ T - G.sum(axis=1) * T + g * (Ta - T)
    np.testing.assert_allclose(node_flux / C, 0.0, atol=1e-12)


@pytest.mark.parametrize("cls", MODELS)
def test_long_run_reaches_steady_state_and_scales_linearly(cls):
    m = cls()
    u = U_TEST[m.name]
    ss1 = m.steady_state(m.theta(), np.array([[u, 20.0]]))[0]
    ss2 = m.steady_state(m.theta(), np.array([[2 * u, 20.0]]))[0]
    np.testing.assert_allclose(ss2 - 20.0, 2 * (ss1 - 20.0), rtol=1e-12)  # superposition
    sim = m.simulate(_const(40, u, 20.0), dt=6 * 3600.0, return_states=True)
    np.testing.assert_allclose(sim.states[0, -1], ss1, atol=1e-6)


@pytest.mark.parametrize("cls", MODELS)
def test_exact_and_rk4_agree(cls):
    m = cls()
    rng = np.random.default_rng(3)
    T, dt = 200, 60.0
    u = np.column_stack(
        [
            np.repeat(rng.uniform(0, 1.5 * U_TEST[m.name], 10), 20),
            20.0 + 3 * np.sin(np.arange(T) / 30.0),
        ]
    )
    th = m.theta(batch=2)
    x0 = np.full((2, len(m.nodes)), 20.0)
    y_exact, _ = m.simulate_network(th, u[None].repeat(2, 0), dt, x0)
    y_rk4, _ = m.simulate_network(th, u[None].repeat(2, 0), dt, x0, force_rk4=True)
    # the default sub-step rule (h ρ ≤ 1) is accurate to well under a millikelvin ...
    np.testing.assert_allclose(y_rk4, y_exact, atol=1e-3)
    n = m.rk4_substeps(m.network(m.full_theta(th)), dt, float(u[:, 0].max()))
    fine, _ = m.simulate_network(th, u[None].repeat(2, 0), dt, x0, force_rk4=True, substeps=8 * n)
    # ... and RK4 converges on the exact solution (T_air held over each sample like ZOH)
    np.testing.assert_allclose(fine, y_exact, atol=1e-6)


@pytest.mark.parametrize("cls", MODELS)
def test_energy_balance_over_a_transient(cls):
    # ∫ Σq u dt = Σ C_i ΔT_i + ∫ Σ g_i (T_i − T_amb) dt
    m = cls()
    dt, T = 30.0, 2000
    u = _const(T, U_TEST[m.name], 20.0)
    sim = m.simulate(u, dt=dt, return_states=True)
    net = m.arrays(None)
    X = sim.states[0]
    stored = np.sum(net.C[0] * (X[-1] - X[0]))
    lost = simpson((X - 20.0) @ net.g_amb[0], x=sim.time)
    produced = net.q[0, :, 0].sum() * U_TEST[m.name] * sim.time[-1]
    assert stored + lost == pytest.approx(produced, rel=1e-5)


@pytest.mark.parametrize("cls", MODELS)
def test_step_response_is_monotonic(cls):
    # A heat step into a network at rest never cools any node (positive system).
    m = cls()
    sim = m.simulate(_const(500, U_TEST[m.name], 20.0), dt=60.0)
    assert np.all(np.diff(sim.outputs[0], axis=0) >= -1e-12)


def test_spindle_time_constants_are_hours_and_day_reaches_steady_state():
    m = SpindleModel()
    A, _ = network_matrices(m.arrays(None))
    tau = -1.0 / np.linalg.eigvals(A[0]).real
    assert 1.5 * 3600 < tau.max() < 8 * 3600
    for rpm in (4000.0, 8000.0):
        ss = m.steady_state(m.theta(), np.array([[rpm, 20.0]]))[0]
        sim = m.simulate(_const(21, rpm, 20.0), dt=3600.0, return_states=True)
        rise = ss - 20.0
        np.testing.assert_array_less(np.abs(sim.states[0, -1] - ss), 0.05 * rise + 1e-9)
    assert list(m.output_names) == list(SPINDLE_OUTPUTS)
    # bearings are the heat sources: they are the hottest measured points
    ss = m.steady_state(m.theta(), np.array([[6000.0, 20.0]]))[0]
    y = m._H @ ss
    assert y[:4].min() > y[4:].max()


def test_strut_has_19_nodes_and_elongation_follows_eq5():
    m = StrutModel()
    assert len(m.nodes) == 18  # plus the air of infinite capacity = 19 nodes
    sim = m.simulate(_const(60, 20.0, 22.0), dt=140.9, return_states=True)
    X = sim.states[0]
    dl = sum(
        1e6 * ALPHA_STEEL * L * (X[:, m.nodes.index(n)] - 20.0) for n, L in ELONGATION_PATH.items()
    )
    np.testing.assert_allclose(sim.output("dL_um")[0], dl, rtol=1e-12, atol=1e-9)
    assert list(m.output_names) == [*STRUT_OUTPUTS, "dL_um"]
    # T_ref set to the initial temperature gives eq (5)'s change from the initial value
    sim2 = m.simulate(_const(60, 20.0, 22.0), dt=140.9, theta={"T_ref": 22.0})
    assert sim2.output("dL_um")[0, 0] == pytest.approx(0.0, abs=1e-9)


def test_strut_ratio_parameters_scale_the_physical_estimates():
    m = StrutModel()
    base = m.arrays(None)
    scaled = m.arrays(m.theta({"r_motor": 2.0, "r_tube_air": 1.2}))
    i = m.nodes.index("drive")
    assert scaled.q[0, i, 0] == pytest.approx(2 * base.q[0, i, 0])
    j = m.nodes.index("tube_mid")
    assert scaled.g_amb[0, j] == pytest.approx(1.2 * base.g_amb[0, j])
    # bounds from the appendix: +200/−70 % for losses, +30/−20 % for air conductances
    bounds = {p.name: (p.lower, p.upper) for p in m.parameters}
    assert bounds["r_nut"] == (0.3, 3.0) and bounds["r_tube_air"] == (0.8, 1.3)


def test_effects_change_the_physics_as_documented():
    u_ref = 20.0
    m = StrutModel(effects=("input_nonlinearity", "input_dependent_heat_transfer"))
    x0 = np.full((1, 18), 20.0)
    th = m.theta()

    def final(theta, u):
        U = _const(400, u, 20.0)[None]
        y, _ = m.simulate_network(theta, U, 300.0, x0)
        return y[0, -1, :7] - 20.0

    lin_20, lin_30 = final(th, u_ref), final(th, 1.5 * u_ref)
    nl = m.theta({"alpha_u": 0.5})
    # Q ∝ u_ref (u/u_ref)^α: unchanged at u_ref, grows by 1.5^0.5 instead of 1.5
    np.testing.assert_allclose(final(nl, u_ref), lin_20, rtol=1e-5)
    np.testing.assert_allclose(final(nl, 1.5 * u_ref), lin_20 * 1.5**0.5, rtol=1e-4)
    assert np.all(lin_30 > final(nl, 1.5 * u_ref))
    forced = m.theta({"beta_u": 1.0})
    assert np.all(final(forced, u_ref) <= lin_20 + 1e-9)


def test_unknown_effect_and_parameter_errors():
    with pytest.raises(UnknownNameError, match=r"cannot include effect.*'backlash'"):
        SpindleModel(effects=("backlash",))
    with pytest.raises(ParameterError, match=r"'C_shaft' of set 0 is -5.0"):
        SpindleModel().simulate(_const(5, 1000.0, 20.0), dt=1.0, theta={"C_shaft": -5.0})


def test_simulate_network_takes_an_explicit_substep_count():
    m = SpindleModel(effects=["nonlinear_heat_transfer"])
    th = m.theta({"gamma_nl": 1.0}, batch=1)
    T, dt = 120, 120.0
    u = np.column_stack([np.repeat([0.0, 6000.0, 3000.0], T // 3), np.full(T, 21.0)])[None]
    x0 = np.full((1, len(m.nodes)), 21.0)
    full = m.full_theta(th)
    n = m.rk4_substeps(m.network(full), dt, 6000.0, m.effect_values(full))
    y_default, _ = m.simulate_network(th, u, dt, x0)
    y_same, _ = m.simulate_network(th, u, dt, x0, substeps=n)
    np.testing.assert_array_equal(y_same, y_default)  # the default is that count
    y_fine, _ = m.simulate_network(th, u, dt, x0, substeps=4 * n)
    assert not np.array_equal(y_fine, y_default)  # the count is used ...
    np.testing.assert_allclose(y_fine, y_default, atol=1e-3)  # ... and RK4 has converged
    for bad in (0, 1.5):
        with pytest.raises(ConfigError, match=f"substeps is {bad!r}"):
            m.simulate_network(th, u, dt, x0, substeps=bad)
