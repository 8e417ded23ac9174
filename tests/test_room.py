"""Tests of the radiator-heated room driven by an AXT211 valve actuator.

Truth is derived independently of the model code: steady states from the
linear two-node balance and from the algebraic heat balance solved with
scipy, the energy balance of the zone, the stand-alone AXT211 model, and
invariants (monotonicity, batch = one by one, determinism, step-size
convergence).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import brentq

from thermogym.errors import ConfigError, ParameterError, ShapeError, UnknownNameError
from thermogym.models import AXT211
from thermogym.models.axt211 import AXT211_PARAMETERS
from thermogym.models.registry import get_model
from thermogym.models.room import MODELS, ROOM_PARAMETERS, RoomModel, valve_flow

DAY = 86400.0


@pytest.fixture(scope="module")
def room() -> RoomModel:
    return RoomModel()


@pytest.fixture(scope="module")
def room_eq() -> RoomModel:
    return RoomModel(valve="equal_percentage")


def exog(T: int, u=0.0, k_U=24.0, T_out=0.0, Q_int=0.0) -> np.ndarray:
    """Exogenous array (T, 4) from scalars or arrays."""
    cols = [np.broadcast_to(np.asarray(v, dtype=float), (T,)) for v in (u, k_U, T_out, Q_int)]
    return np.column_stack(cols)


def pv(m: RoomModel, th: np.ndarray, *names: str) -> list[float]:
    return [float(th[0, m.param_index(n)]) for n in names]


def heating_curve(m: RoomModel, th: np.ndarray, T_out: float) -> float:
    Td, Tsd, T20 = pv(m, th, "T_out_d", "T_sup_d", "T_sup_20")
    To = min(max(T_out, Td), 20.0)
    return T20 + (Tsd - T20) * (20.0 - To) / (20.0 - Td)


def pinned(m: RoomModel, **kw) -> np.ndarray:
    """Parameter set whose valve stays where x0 puts it (backlash play wider than any stroke)."""
    return m.theta(None, c_backlash=1e3, **kw)


def pinned_x0(m: RoomModel, th: np.ndarray, u0: np.ndarray, x_V: float) -> np.ndarray:
    x0 = m.initial_state(th, u0[None, :])
    x0[:, 2] = x_V  # cartridge inside the play: the valve never moves
    x0[:, 3] = x_V
    return x0


# ---------------------------------------------------------------------------- metadata
def test_registry_layout_and_config():
    assert MODELS == {"room": RoomModel}
    m = get_model("room", valve="equal_percentage", effects=["phase_change"])
    assert isinstance(m, RoomModel)
    assert get_model("room", **m.config()).param_names == m.param_names
    axt = [p.name for p in AXT211_PARAMETERS]
    names = list(m.param_names)
    assert names[: len(axt)] == axt
    assert names[len(axt) : len(axt) + 3] == ["L_melt", "T_melt", "w_melt"]
    assert names[len(axt) + 3 :] == [p.name for p in ROOM_PARAMETERS]
    assert "R_v" not in RoomModel().param_names
    assert m.state_names[:4] == AXT211().state_names
    for s in ("T_zone", "T_struct", "x_V", "Q_heat", "P_PTC", "T_P", "T_G", "T_supply"):
        assert s in m.output_names
    assert m.exogenous_names == ("u", "k_U", "T_out", "Q_int")
    d = m.describe()
    assert d["name"] == "room" and d["config"] == {
        "valve": "equal_percentage",
        "effects": ["phase_change"],
    }


def test_defaults_meet_the_design_brief(room):
    th = room.theta()
    Ca, Cs, Has, Hao, Hso, Qn = pv(room, th, "C_a", "C_s", "H_as", "H_ao", "H_so", "Q_rad_nom")
    H = Hao + Has * Hso / (Has + Hso)
    assert H * 30.0 == pytest.approx(1000.0, rel=0.02)  # design load at 20 / -10 °C
    assert Qn == pytest.approx(1.2 * H * 30.0, rel=0.02)
    A = np.array([[-(Has + Hao) / Ca, Has / Ca], [Has / Cs, -(Has + Hso) / Cs]])
    tau_h = -1.0 / np.linalg.eigvals(A) / 3600.0
    assert tau_h.max() >= 15.0  # paper 002, section I


def test_radiator_delivers_its_rating_at_the_design_point(room):
    # zone held at 20 °C (huge capacities), -10 °C outside, valve pinned fully open
    th = pinned(room, C_a=1e15, C_s=1e15)
    u = exog(361, T_out=-10.0)
    x0 = pinned_x0(room, th, u[0], 4.5)
    x0[:, 4:] = 20.0
    sim = room.simulate(u, 10.0, th, x0)
    assert sim.output("T_supply")[0, -1] == pytest.approx(55.0)
    assert sim.output("Q_heat")[0, -1] == pytest.approx(1200.0, rel=1e-4)
    assert sim.output("T_rad")[0, -1] == pytest.approx(45.0, abs=1e-3)  # 55/45 °C design


# ----------------------------------------------------------------------- steady states
@pytest.mark.parametrize(("T_out", "Q_int"), [(0.0, 0.0), (-12.0, 250.0), (8.0, 600.0)])
def test_closed_valve_steady_state_is_the_linear_two_node_balance(room, T_out, Q_int):
    th = room.theta()
    Has, Hao, Hso, f = pv(room, th, "H_as", "H_ao", "H_so", "f_int")
    M = np.array([[Has + Hao, -Has], [-Has, Has + Hso]])
    Ta, Ts = np.linalg.solve(M, [Hao * T_out + f * Q_int, Hso * T_out + (1 - f) * Q_int])
    u = exog(145, T_out=T_out, Q_int=Q_int)
    sim = room.simulate(u, 600.0, return_states=True)  # one day from initial_state
    x = sim.states[0]
    assert x[0, 5] == pytest.approx(Ta, abs=1e-9)
    assert x[0, 6] == pytest.approx(Ts, abs=1e-9)
    # no transient: every state stays where it started
    assert np.abs(x - x[0]).max() < 1e-9
    # and the steady state attracts: 15 days (> 12 dominant time constants) from 20 °C
    x0 = x[0].copy()
    x0[[0, 1, 4, 5, 6]] = 20.0
    sim2 = room.simulate(exog(15 * 144 + 1, T_out=T_out, Q_int=Q_int), 600.0, x0=x0)
    assert sim2.output("T_zone")[0, -1] == pytest.approx(Ta, abs=1e-3)
    assert sim2.output("T_struct")[0, -1] == pytest.approx(Ts, abs=1e-3)


def open_valve_balance(m, th, phi, T_out, Q_int):
    """Steady (T_rad, T_zone, T_struct) for relative flow phi, by nested root finding."""
    Has, Hao, Hso, f, Qn, n, dTw, Tsd = pv(
        m, th, "H_as", "H_ao", "H_so", "f_int", "Q_rad_nom", "n_rad", "dT_w_nom", "T_sup_d"
    )
    Tsup = heating_curve(m, th, T_out)
    mc = phi * Qn / dTw

    def Q(Tr, Ta):
        d = Tr - Ta
        return np.sign(d) * Qn * (abs(d) / (Tsd - dTw - 20.0)) ** n

    def radiator(Ta):  # water heat in = emission
        if mc == 0.0 or Ta == Tsup:
            return Ta
        lo, hi = min(Ta, Tsup), max(Ta, Tsup)
        return brentq(lambda Tr: mc * (Tsup - Tr) - Q(Tr, Ta), lo, hi, xtol=1e-13)

    def struct(Ta):  # structure node balance, linear in T_s
        return (Has * Ta + Hso * T_out + (1 - f) * Q_int) / (Has + Hso)

    def air(Ta):  # air node balance
        return Q(radiator(Ta), Ta) + f * Q_int + Has * (struct(Ta) - Ta) + Hao * (T_out - Ta)

    Ta = brentq(air, -50.0, 100.0, xtol=1e-13)
    return radiator(Ta), Ta, struct(Ta)


@pytest.mark.parametrize(("T_out", "Q_int"), [(-15.0, 0.0), (5.0, 300.0)])
def test_open_valve_steady_state_matches_scipy_balance(room, T_out, Q_int):
    # the actuator itself opens the valve (heater on) and the room settles for 15 days
    u = exog(15 * 144 + 1, u=1.0, T_out=T_out, Q_int=Q_int)
    sim = room.simulate(u, 600.0)
    th = room.theta()
    assert sim.output("x_V")[0, -1] == pytest.approx(4.5)
    Tr, Ta, Ts = open_valve_balance(room, th, 1.0, T_out, Q_int)
    assert sim.output("T_rad")[0, -1] == pytest.approx(Tr, abs=2e-3)
    assert sim.output("T_zone")[0, -1] == pytest.approx(Ta, abs=2e-3)
    assert sim.output("T_struct")[0, -1] == pytest.approx(Ts, abs=2e-3)


@pytest.mark.parametrize("valve", ["linear", "equal_percentage"])
def test_partial_opening_steady_state_and_monotonic_response(valve):
    m = RoomModel(valve=valve)
    strokes = [0.0, 0.5, 1.0, 2.0, 3.0, 4.5]
    th = pinned(m, batch=len(strokes))
    u = exog(15 * 144 + 1, T_out=0.0, Q_int=100.0)
    x0 = np.vstack([pinned_x0(m, th[:1], u[0], s) for s in strokes])
    sim = m.simulate(u, 600.0, th, x0)
    np.testing.assert_allclose(sim.output("x_V")[:, -1], strokes)
    Tz = sim.output("T_zone")[:, -1]
    Qh = sim.output("Q_heat")[:, -1]
    assert np.all(np.diff(Tz) > 0.05)  # more opening, warmer room
    assert np.all(np.diff(Qh) > 1.0)
    R = 25.0
    for b, s in enumerate(strokes):
        h = s / 4.5
        if valve == "linear":
            phi = h
        else:  # independent formula: R^(h-1), linear below 5 % stroke
            phi = R ** (h - 1) if h >= 0.05 else h / 0.05 * R ** (0.05 - 1)
        if s == 0.0:
            phi = 0.0
        Tr, Ta, _ = open_valve_balance(m, th[:1], phi, 0.0, 100.0)
        assert Tz[b] == pytest.approx(Ta, abs=2e-3)
        assert sim.output("T_rad")[b, -1] == pytest.approx(Tr, abs=2e-3)


def test_equal_percentage_room_is_cooler_in_mid_range(room, room_eq):
    th = pinned(room)
    th_eq = pinned(room_eq)
    u = exog(4 * 144 + 1, T_out=0.0)
    for s in (1.0, 2.25, 3.5):
        lin = room.simulate(u, 600.0, th, pinned_x0(room, th, u[0], s)).output("T_zone")[0, -1]
        eq = room_eq.simulate(u, 600.0, th_eq, pinned_x0(room_eq, th_eq, u[0], s))
        assert eq.output("T_zone")[0, -1] < lin - 0.1


# ------------------------------------------------------------------------ energy balance
def test_energy_balance_over_a_day_of_on_off_operation(room):
    dt = 2.0
    t = np.arange(0.0, DAY + dt, dt)
    on = ((t % 3600.0) < 1500.0).astype(float)  # 25 min on, 35 min off
    T_out = -2.0 + 6.0 * np.sin(2 * np.pi * t / DAY)
    Q_int = np.where((t > 8 * 3600) & (t < 18 * 3600), 400.0, 50.0)
    u = exog(t.size, u=on, T_out=T_out, Q_int=Q_int)
    x0 = room.initial_state(room.theta(), u[:1])
    x0[0, 4:] = [21.0, 21.0, 19.0]  # start warm
    sim = room.simulate(u, dt, x0=x0)
    th = room.theta()
    Ca, Cs, Hao, Hso = pv(room, th, "C_a", "C_s", "H_ao", "H_so")
    Ta, Ts, Qh = (sim.output(n)[0] for n in ("T_zone", "T_struct", "Q_heat"))
    # inputs are held over each interval: rectangles; states are smooth: trapezoids
    heat = np.trapezoid(Qh, dx=dt)
    gains = Q_int[:-1].sum() * dt
    losses = Hao * (np.trapezoid(Ta, dx=dt) - T_out[:-1].sum() * dt) + Hso * (
        np.trapezoid(Ts, dx=dt) - T_out[:-1].sum() * dt
    )
    dU = Ca * (Ta[-1] - Ta[0]) + Cs * (Ts[-1] - Ts[0])
    assert heat > 5e6  # the radiator did work (J)
    assert abs(heat + gains - dU - losses) < 1e-7 * (heat + gains)
    # and the radiator's own balance: water heat = ΔU_rad + emission
    Qn, dTw, Cr = pv(room, th, "Q_rad_nom", "dT_w_nom", "C_rad")
    phi = sim.output("x_V")[0] / 4.5
    water = np.trapezoid(
        phi * Qn / dTw * (sim.output("T_supply")[0] - sim.output("T_rad")[0]), dx=dt
    )
    Tr = sim.output("T_rad")[0]
    assert abs(water - Cr * (Tr[-1] - Tr[0]) - heat) < 1e-5 * heat


# ------------------------------------------------------------------ actuator equivalence
@pytest.mark.parametrize(
    ("effects", "values"),
    [((), {}), (("phase_change", "supply_variation"), {"L_melt": 200.0, "R_source": 15.0})],
)
def test_actuator_in_held_room_matches_standalone_axt211(effects, values):
    m = RoomModel(effects=effects)
    a = AXT211(effects=effects)
    T_zone = 23.0
    t = np.arange(0.0, 1500.0 + 1.0, 1.0)
    on = (((t < 900.0) | (t > 1200.0)) & (t > 20.0)).astype(float)
    u = exog(t.size, u=on, T_out=T_zone)
    th = m.theta(values, C_a=1e15, C_s=1e15)
    sim = m.simulate(u, 1.0, th)
    ref = a.simulate(
        np.column_stack([on, np.full(t.size, 24.0), np.full(t.size, T_zone)]), 1.0, values
    )
    xV = ref.output("x_V")[0]
    assert xV.max() > 4.4 and xV[1200] < 0.5 and xV[-1] > 4.0  # opens, closes, reopens
    for name in ("x_V", "x_P", "T_P", "T_G", "P_PTC"):
        np.testing.assert_allclose(sim.output(name)[0], ref.output(name)[0], rtol=0, atol=1e-9)


# ------------------------------------------------------------ batch, determinism, step
def pwm_exog(T: int, dt: float, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    t = np.arange(T) * dt
    duty = np.repeat(rng.uniform(0.0, 1.0, T // 90 + 1), 90)[:T]
    on = ((t % 900.0) < 900.0 * duty).astype(float)
    return exog(T, u=on, T_out=3.0 + 2.0 * np.sin(t / 5000.0), Q_int=150.0)


def test_batch_equals_one_by_one_and_is_deterministic(room_eq):
    sets = [
        {},
        {"C_a": 2e5, "Q_rad_nom": 900.0, "c_backlash": 0.2},
        {"T_sup_d": 65.0, "R_v": 50.0, "C_P": 30.0, "H_ao": 20.0},
    ]
    u = pwm_exog(721, 10.0)
    batch = room_eq.simulate(u, 10.0, sets, return_states=True)
    for b, s in enumerate(sets):
        one = room_eq.simulate(u, 10.0, s, return_states=True)
        np.testing.assert_array_equal(batch.outputs[b], one.outputs[0])
        np.testing.assert_array_equal(batch.states[b], one.states[0])
    again = RoomModel(valve="equal_percentage").simulate(u, 10.0, sets, return_states=True)
    np.testing.assert_array_equal(again.outputs, batch.outputs)
    assert np.ptp(batch.output("T_zone")[:, -1]) > 0.01  # the sets differ


@pytest.mark.slow
def test_threaded_batch_equals_one_by_one():
    # B >= 32 runs one system per thread; results must not depend on it
    m = RoomModel()
    rng = np.random.default_rng(3)
    sets = [
        {"C_a": c, "c_backlash": cb}
        for c, cb in zip(rng.uniform(1e5, 6e5, 40), rng.uniform(0, 0.3, 40), strict=True)
    ]
    u = pwm_exog(361, 10.0, seed=4)
    batch = m.simulate(u, 10.0, sets, return_states=True)
    for b in (0, 17, 39):
        one = m.simulate(u, 10.0, sets[b], return_states=True)
        np.testing.assert_array_equal(batch.outputs[b], one.outputs[0])
        np.testing.assert_array_equal(batch.states[b], one.states[0])
    own = np.repeat(u[None], 40, axis=0).copy()  # one input trajectory per system
    np.testing.assert_array_equal(m.simulate(own, 10.0, sets).outputs, batch.outputs)


def test_step_and_output_reproduce_simulate(room_eq):
    sets = [{}, {"C_a": 2e5, "R_v": 40.0}]
    th = room_eq.theta(sets)
    u = pwm_exog(361, 10.0, seed=1)
    sim = room_eq.simulate(u, 10.0, th, return_states=True)
    x = room_eq.initial_state(th, np.repeat(u[:1], 2, axis=0))
    for k in range(u.shape[0]):
        uk = np.repeat(u[k : k + 1], 2, axis=0)
        np.testing.assert_array_equal(x, sim.states[:, k])
        np.testing.assert_array_equal(room_eq.output(x, uk, th), sim.outputs[:, k])
        x = room_eq.step(x, uk, th, 10.0)
    # nominal theta (one row) broadcasts over a batch of states
    x2 = room_eq.step(
        np.repeat(sim.states[:1, 5], 3, axis=0), np.repeat(u[5:6], 3, axis=0), None, 10.0
    )
    np.testing.assert_array_equal(x2[0], x2[2])


@pytest.mark.parametrize("valve", ["linear", "equal_percentage"])
def test_rk4_halving_max_step_changes_little(valve):
    class Fine(RoomModel):
        max_step = 0.5

    class Coarse(RoomModel):
        max_step = 2.0

    u = pwm_exog(3 * 360 + 1, 10.0, seed=2)
    sims = [M(valve=valve).simulate(u, 10.0) for M in (Coarse, RoomModel, Fine)]
    for name, tol in (("T_zone", 1e-5), ("T_rad", 5e-4), ("Q_heat", 0.02), ("x_V", 5e-3)):
        d_coarse = np.abs(sims[0].output(name) - sims[1].output(name)).max()
        d_fine = np.abs(sims[1].output(name) - sims[2].output(name)).max()
        assert d_fine < tol, (name, d_fine)
        assert d_fine <= d_coarse, (name, d_fine, d_coarse)


# ------------------------------------------------------------------------ valve
def test_valve_characteristic_limits():
    h = np.linspace(0.0, 1.0, 201)
    lin = valve_flow(h, "linear")
    for R in (25.0, 50.0):
        eq = valve_flow(h, "equal_percentage", R)
        assert eq[0] == 0.0 and eq[-1] == pytest.approx(1.0)
        assert np.all(np.diff(eq) > 0)
        mid = (h > 0.05) & (h < 0.95)
        assert np.all(eq[mid] < lin[mid])
        assert valve_flow(0.5, "equal_percentage", R) == pytest.approx(R**-0.5)
        # continuous at the end of the linear leak-off
        assert valve_flow(0.05 - 1e-12, "equal_percentage", R) == pytest.approx(R**-0.95)
    assert lin[0] == 0.0 and lin[-1] == 1.0
    np.testing.assert_allclose(lin, h)
    assert valve_flow(1.7, "linear") == 1.0 and valve_flow(-0.2, "linear") == 0.0


# ------------------------------------------------------------------------ bad input
def test_bad_inputs_raise_clear_errors(room, room_eq):
    u = exog(10, u=0.5)
    with pytest.raises(ShapeError, match=r"'u' is 1\.5"):
        room.simulate(exog(10, u=1.5), 10.0)
    with pytest.raises(ShapeError, match=r"'u' is -0\.1"):
        room.simulate(exog(10, u=-0.1), 10.0)
    with pytest.raises(ShapeError, match="'k_U'"):
        room.simulate(exog(10, k_U=-24.0), 10.0)
    with pytest.raises(ShapeError, match=r"expected \(T, 4\)"):
        room.simulate(u[:, :3], 10.0)
    with pytest.raises(ShapeError, match="T_out"):
        room.simulate(exog(10, T_out=np.nan), 10.0)
    with pytest.raises(ShapeError, match="x0 has shape"):
        room.simulate(u, 10.0, x0=np.zeros(4))
    th = room.theta()
    x = room.initial_state(th, u[:1])
    with pytest.raises(ShapeError, match="x has shape"):
        room.step(x[:, :4], u[:1], th, 10.0)
    with pytest.raises(ShapeError, match=r"u has shape \(1, 3\)"):
        room.step(x, u[:1, :3], th, 10.0)
    with pytest.raises(ShapeError, match=r"'u' is 2\.0"):
        room.step(x, exog(1, u=2.0), th, 10.0)
    with pytest.raises(ShapeError, match="'Q_int' of system 0"):
        room.step(x, exog(1, Q_int=np.inf), th, 10.0)
    with pytest.raises(ShapeError, match="dt is"):
        room.step(x, u[:1], th, 0.0)
    with pytest.raises(ShapeError, match="theta has shape"):
        room._step(x, u[:1], th[:, :5], 10.0)
    before = x.copy()
    with pytest.raises(ShapeError):
        room.step(x, exog(1, u=2.0), th, 10.0)
    np.testing.assert_array_equal(x, before)  # the caller's state is untouched
    with pytest.raises(ConfigError, match="'butterfly'"):
        RoomModel(valve="butterfly")
    with pytest.raises(TypeError):
        RoomModel(valves="linear")  # type: ignore[call-arg]
    with pytest.raises(UnknownNameError, match="backlashes"):
        RoomModel(effects=("backlashes",))
    with pytest.raises(ParameterError, match="'R_v'"):
        room.theta(R_v=30.0)  # linear valve has no rangeability
    for bad, what in (
        ({"f_int": 1.5}, "'f_int'"),
        ({"n_rad": 0.9}, "'n_rad'"),
        ({"C_s": 0.0}, "'C_s'"),
        ({"T_sup_d": 28.0}, "'T_sup_d'"),
        ({"T_sup_20": 60.0}, "'T_sup_d'"),
        ({"T_out_d": 20.0}, "'T_out_d'"),
    ):
        with pytest.raises(ParameterError, match=what):
            room.theta(bad)
    with pytest.raises(ParameterError, match="'R_v'"):
        room_eq.theta(R_v=1.0)
    with pytest.raises(ConfigError):
        valve_flow(0.5, "quick_opening")
    with pytest.raises(ParameterError, match="rangeability"):
        valve_flow(0.5, "equal_percentage", 1.0)
