"""Where the catalogue enters heat flows, read from the nominal model's own structure.

A coil behind a valve: the valve sets a conductance across the coolant
temperature, the heater is a power input. The catalogue must tell them apart
from the model alone (no names), keep heat flows off the coolant side, take a
concave map of the valve as a heat-transfer coefficient growing with the flow,
and enter loop terms where a generic model responds as the node does.
"""

from __future__ import annotations

import numpy as np
import pytest

from thermogym.identification.diagnosis import proposers
from thermogym.identification.diagnosis.context import Context
from thermogym.models.base import Model, Parameter, Signal
from thermogym.models.registry import get_model


class CoilTank(Model):
    """``C dT/dt = P h − K v (T − T_c) − G (T − T_a)``: a heater, a valve on a coil (Euler)."""

    name = "user_coil_tank"
    version = "1"

    def __init__(self) -> None:
        params = [
            Parameter("C", 8.0e4, 1e3, 1e6, "J/K", "heat capacity", "design"),
            Parameter("P", 2000.0, 10.0, 1e4, "W", "heater power at full command", "design"),
            Parameter("K", 40.0, 1.0, 500.0, "W/K", "coil conductance at full flow", "design"),
            Parameter("G", 2.5, 0.1, 50.0, "W/K", "loss conductance", "design"),
        ]
        signals = [
            # the coolant first: the first exogenous temperature is not always the surroundings
            Signal("T_c", "disturbance", "°C", "coolant inlet temperature"),
            Signal("T_a", "disturbance", "°C", "room temperature"),
            Signal("h", "input", "1", "heater command"),
            Signal("v", "input", "1", "valve opening"),
            Signal("T", "output", "°C", "tank temperature"),
        ]
        super().__init__(signals, params, ["T"])

    def _validate_theta(self, theta):
        self._require_positive(theta, self.param_names)

    def _parts(self, theta, u):
        C, P, K, G = (theta[:, i : i + 1] for i in range(4))
        h, v, tc, ta = (u[..., i] for i in range(4))  # inputs first, then disturbances
        return C, P * h + K * v * tc + G * ta, K * v + G

    def initial_state(self, theta, u0):
        _, q, g = self._parts(theta, u0[:, None, :])
        return q / g

    def _simulate(self, theta, u, dt, x0, return_states):
        C, q, g = self._parts(theta, u)
        y = np.empty((theta.shape[0], u.shape[1], 1))
        x = x0[:, 0].copy()
        for k in range(u.shape[1]):
            y[:, k, 0] = x
            x = x + dt * (q[:, k] - g[:, k] * x) / C[:, 0]
        return y, (y.copy() if return_states else None)


def _context(model, theta, u, y, dt=30.0) -> Context:
    n = u.shape[0]
    return Context(
        model=model,
        spec=None,  # type: ignore[arg-type]  # not read by the structure tests
        theta=np.asarray(theta, float),
        free=(),
        outputs=tuple(model.output_names),
        time=[np.arange(n) * dt],
        dt=[dt],
        u=[u],
        y=[y],
        sim=[y],
        is_train=[True],
        sigma={o: 0.05 for o in model.output_names},
        scale={o: 1.0 for o in model.output_names},
        share={o: 1.0 for o in model.output_names},
    )


@pytest.fixture(scope="module")
def tank_ctx() -> Context:
    rng = np.random.default_rng(0)
    n = 960
    h = np.repeat(rng.uniform(0.1, 0.8, n // 40), 40)
    v = np.repeat(rng.uniform(0.05, 0.9, n // 40), 40)
    u = np.column_stack([h, v, np.full(n, 12.0), np.full(n, 21.0)])
    m = CoilTank()
    th = m.nominal[None]
    y = m.simulate(u[None], 30.0, th, m.initial_state(th, u[None, 0]), strict=False).outputs[0]
    return _context(m, m.nominal, u, y)


def test_a_valve_on_a_coil_sets_a_conductance_across_the_coolant(tank_ctx):
    assert tank_ctx.sets_conductance("v", "T") == "T_c"
    assert tank_ctx.sets_conductance("h", "T") is None
    # the surroundings are the room, although the coolant is the first temperature listed
    assert tank_ctx.ambient == "T_a"


def test_loop_terms_enter_where_a_heat_flow_does_not_scale_with_the_valve(tank_ctx):
    port, _ = proposers._port(tank_ctx, "T")
    # the room path is weak beside the coil (G ≪ K v): the heater, never the valve or coolant
    assert port == "h"
    dist = proposers._unmeasured_disturbance(tank_ctx)
    assert dist and {c.target for c in dist} == {"h"}


def test_a_concave_map_of_the_valve_is_a_heat_transfer_coefficient_growing_with_flow(tank_ctx):
    cands = proposers._input_nonlinearity(tank_ctx)
    by = {(c.effect, c.target, c.form.split(" (")[0]) for c in cands}
    hd = [c for c in cands if c.effect == "input_dependent_heat_transfer"]
    assert [c.target for c in hd] == ["v"]
    assert hd[0].augmentations[0]["bounds"]["alpha"] == [0.2, 1.0]
    convex = [c for c in cands if c.target == "v" and c.form == "power law (convex)"]
    assert convex and convex[0].augmentations[0]["bounds"]["alpha"] == [1.0, 3.0]
    # the heater keeps every form of an input nonlinearity, the power law over its whole range
    assert ("input_nonlinearity", "h", "power law") in by
    heater_power = [c for c in cands if c.target == "h" and c.form == "power law"]
    assert "bounds" not in heater_power[0].augmentations[0]


def test_a_generic_model_whose_ambient_channel_lags_takes_loop_terms_at_the_input():
    # an FOPTD set whose ambient channel has a 1.5 h dead time: a heat flow at the node
    # responds as the input channel does, so loop terms enter there
    m = get_model(
        "foptd",
        inputs=["lamp"],
        outputs=["T"],
        disturbances=["T_amb"],
        units={"lamp": "%", "T_amb": "°C", "T": "°C"},
    )
    th = m.nominal.copy()
    for name, value in (
        ("K_T__lamp", 0.7),
        ("T_T__lamp", 180.0),
        ("K_T__T_amb", 1.0),
        ("T_T__T_amb", 400.0),
        ("tau_T__T_amb", 5400.0),
    ):
        th[m.param_index(name)] = value
    n, dt = 2160, 5.0
    rng = np.random.default_rng(1)
    u = np.column_stack([np.repeat(rng.uniform(0, 100, n // 120), 120), np.full(n, 22.0)])
    y = m.simulate(u[None], dt, th[None], m.initial_state(th[None], u[None, 0]), strict=False)
    ctx = _context(m, th, u, y.outputs[0], dt)
    assert ctx.response_time("T_amb", "T") > 2 * ctx.response_time("lamp", "T")
    assert proposers._port(ctx, "T")[0] == "lamp"
    # without the dead time the ambient is the port, as in a physical network
    th[m.param_index("tau_T__T_amb")] = 0.0
    th[m.param_index("T_T__T_amb")] = 180.0
    ctx2 = _context(m, th, u, y.outputs[0], dt)
    assert proposers._port(ctx2, "T")[0] == "T_amb"


class TwoZones(Model):
    """A heater in zone 1 of two coupled zones, the outdoor air at both (Euler)."""

    name = "user_two_zones"
    version = "1"

    def __init__(self) -> None:
        params = [
            Parameter("C1", 1.4e7, 1e6, 1e8, "J/K", "zone 1 heat capacity", "design"),
            Parameter("C2", 9.0e6, 1e6, 1e8, "J/K", "zone 2 heat capacity", "design"),
            Parameter("UA1", 95.0, 10.0, 500.0, "W/K", "zone 1 envelope", "design"),
            Parameter("UA2", 60.0, 10.0, 500.0, "W/K", "zone 2 envelope", "design"),
            Parameter("K", 250.0, 10.0, 1000.0, "W/K", "between the zones", "design"),
            Parameter("P", 5000.0, 100.0, 2e4, "W", "heater at full command", "design"),
        ]
        signals = [
            Signal("h", "input", "1", "heater command"),
            Signal("T_out", "disturbance", "°C", "outdoor air"),
            Signal("T1", "output", "°C", "zone 1"),
            Signal("T2", "output", "°C", "zone 2"),
        ]
        super().__init__(signals, params, ["T1", "T2"])

    def _validate_theta(self, theta):
        self._require_positive(theta, self.param_names)

    def initial_state(self, theta, u0):
        _, _, U1, U2, K, P = theta.T
        q, To = P * u0[:, 0], u0[:, 1]
        det = (U1 + K) * (U2 + K) - K * K
        T1 = To + q * (U2 + K) / det
        T2 = To + q * K / det
        return np.column_stack([T1, T2])

    def _simulate(self, theta, u, dt, x0, return_states):
        C1, C2, U1, U2, K, P = (theta[:, i] for i in range(6))
        y = np.empty((theta.shape[0], u.shape[1], 2))
        x = x0.copy()
        sub = 10
        for k in range(u.shape[1]):
            y[:, k] = x
            q, To = P * u[:, k, 0], u[:, k, 1]
            for _ in range(sub):
                f = K * (x[:, 0] - x[:, 1])
                d1 = (q - U1 * (x[:, 0] - To) - f) / C1
                d2 = (f - U2 * (x[:, 1] - To)) / C2
                x = x + dt / sub * np.column_stack([d1, d2])
        return y, (y.copy() if return_states else None)


def test_heat_flows_at_a_zone_enter_where_they_reach_that_zone_first():
    rng = np.random.default_rng(2)
    n, dt = 1008, 600.0
    h = np.repeat(rng.uniform(0.1, 0.9, n // 24), 24)
    t_out = 3.0 + 4.0 * np.sin(2 * np.pi * np.arange(n) * dt / 86400.0)
    u = np.column_stack([h, t_out])
    m = TwoZones()
    th = m.nominal[None]
    y = m.simulate(u[None], dt, th, m.initial_state(th, u[None, 0]), strict=False).outputs[0]
    ctx = _context(m, m.nominal, u, y, dt)
    # the heater warms zone 1 before zone 2; the outdoor air reaches both at once
    assert ctx.locality("h", "T1") > 10.0
    assert ctx.locality("T_out", "T1") < 2.0
    assert proposers._port(ctx, "T1")[0] == "h"
    # zone 2 has no heater of its own: its heat flows enter through the outdoor air
    assert proposers._port(ctx, "T2")[0] == "T_out"
    # a disturbance on zone 1 is tried at both
    assert {c.target for c in proposers._unmeasured_disturbance(ctx)} >= {"h", "T_out"}


def test_phase_change_admits_a_latent_heat_as_large_as_the_sensible_heat_of_the_range(tank_ctx):
    # a tank of PCM balls stores about as much latent heat as its water does over the range
    # it is run through: the candidate's bound must admit that, its starts span decades
    (cand,) = proposers._phase_change(tank_ctx)
    spec = cand.augmentations[0]
    k_max = spec["bounds"]["kappa"][1]
    m = tank_ctx.model
    C, K, G = (float(m.nominal[m.param_index(p)]) for p in ("C", "K", "G"))
    lo, hi = tank_ctx.output_range("T")
    g_node = K * float(np.mean(tank_ctx.u[0][:, 1])) + G  # the node's linear conductance
    # κ is in seconds of the node's linear loss per kelvin: a latent heat of κ · g_node joules
    assert k_max * g_node >= C * (hi - lo)
    kappas = sorted(st[f"pc_kappa_{spec['signal']}"] for st in cand.starts)
    assert kappas[-1] / kappas[0] > 100.0
    assert all(0.0 < k <= k_max for k in kappas)
