"""AXT211 actuator model: paper facts, invariants and an independent integrator."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import simpson, solve_ivp
from scipy.optimize import brentq

from thermogym.errors import ParameterError, ShapeError
from thermogym.models import AXT211
from thermogym.models.axt211 import ptc_resistance


def _inputs(T: int, on: int, kU: float = 24.0, TU: float = 25.0) -> np.ndarray:
    u = np.zeros((T, 3))
    u[:on, 0] = 1.0
    u[:, 1] = kU
    u[:, 2] = TU
    return u


@pytest.fixture(scope="module")
def model() -> AXT211:
    return AXT211()


def test_opens_in_about_five_minutes_at_24V_25C(model):
    # 002 section V: movement begins at about 60 °C, 4.5 mm after ca. 5 minutes.
    sim = model.simulate(_inputs(900, 900), dt=1.0)
    xv, tp = sim.output("x_V")[0], sim.output("T_P")[0]
    t_full = int(np.argmax(xv >= 4.45))
    assert 240 <= t_full <= 360
    k_move = int(np.argmax(xv > 0.02))
    assert 58.0 <= tp[k_move] <= 67.0
    assert xv.max() == pytest.approx(4.5, abs=1e-9)


def test_steady_stroke_gain_peaks_near_68C(model):
    # Steady state of (19) with (21): x = k_P(x) (T_P − T_P0); gain dx/dT_P peaks near 68 °C.
    p = dict(zip(model.param_names, model.nominal, strict=True))

    def x_ss(T: float) -> float:
        s = T - p["T_P0"]
        if s <= 0:
            return 0.0
        f = lambda x: (p["kP_a"] * x * x + p["kP_b"] * x + p["kP_c"]) * s - x  # noqa: E731
        return brentq(f, 0.0, 2 * p["x_max"]) if f(p["x_max"]) < 0 else p["x_max"]

    T = np.arange(56.0, 82.0, 0.25)
    x = np.array([x_ss(t) for t in T])
    gain = np.gradient(x, T)
    assert 66.0 <= T[np.argmax(gain)] <= 70.0
    assert gain[np.searchsorted(T, 60.5)] < 0.2 * gain.max()  # "very small gain" at 60 °C


@pytest.mark.parametrize(("TU", "ratio"), [(25.0, 1.1), (50.0, 3.0)])
def test_closing_is_slower_than_opening(model, TU, ratio):
    # (16): heating by the PTC is faster than cooling by natural convection.
    on = 3600
    sim = model.simulate(_inputs(on + 5400, on, TU=TU), dt=1.0)
    xv = sim.output("x_V")[0]
    t_open = int(np.argmax(xv >= 4.45))  # from power-on
    assert xv[on:].min() < 0.05
    t_close = int(np.argmax(xv[on:] < 0.05))  # from power-off
    assert t_close > ratio * t_open


@pytest.mark.parametrize(("kU", "TU"), [(19.0, 50.0), (29.0, 0.0), (29.0, 50.0), (19.0, 0.0)])
def test_valid_operating_range(model, kU, TU):
    # 002 section I: supply 19..29 V and environment 0..50 °C are valid conditions.
    on = 3600
    sim = model.simulate(_inputs(on + 5400, on, kU, TU), dt=2.0)
    xv, tp = sim.output("x_V")[0], sim.output("T_P")[0]
    if (kU, TU) == (19.0, 0.0):
        # documented limitation of the defaults: the weakest supply in the coldest room
        # opens the valve part way only
        assert 0.3 < xv.max() < 4.45
    else:
        assert xv[: on // 2].max() >= 4.45  # opens fully
    assert xv[-1] < 0.05  # and closes again
    assert tp.max() < 120.0


def test_half_duty_pwm_holds_mid_stroke(model):
    # 002 section VIII: at 50 % duty and high PWM frequency the actuators sit in the
    # sensitive mid-range where specimens differ most (Fig. 8).
    u = _inputs(7200, 7200)
    u[:, 0] = (np.arange(7200) % 10 < 5).astype(float)
    xv = model.simulate(u, dt=1.0).output("x_V")[0, -1800:]
    assert 1.5 < xv.mean() < 4.0


def test_stroke_limits_under_random_switching(model):
    rng = np.random.default_rng(1)
    T = 6000
    u = _inputs(T, T)
    u[:, 0] = np.repeat(rng.integers(0, 2, T // 60), 60)
    sim = model.simulate(u, dt=1.0, theta=model.theta({"c_backlash": [0.0, 0.1, 0.3]}))
    xv = sim.output("x_V")
    assert xv.min() >= 0.0 and xv.max() <= 4.5


def _paper_rhs(p: dict[str, float]):
    """Eqs (14)-(21) written independently of the package, in plain numpy."""
    R = [p[f"R_{i}"] for i in range(6)]

    def rhs(t, x, u, kU, TU):
        TP, TG, xP = x
        Tc = min(max(TP, 30.0), 101.0)
        tau = (Tc - 65.0) / 35.0
        Rptc = sum(R[i] * tau**i for i in range(6))
        if TP > 101.0:
            dR = sum(i * R[i] * tau ** (i - 1) for i in range(1, 6)) / 35.0
            Rptc += dR * (TP - 101.0)
        P = (kU * u) ** 2 / Rptc
        dTP = (P - p["lambda_PG"] * (TP - TG)) / p["C_P"]
        dTG = (p["lambda_PG"] * (TP - TG) - p["lambda_GU"] * (TG - TU)) / p["C_G"]
        xp = max(xP, 0.0)
        k = p["kP_a"] * xp * xp + p["kP_b"] * xp + p["kP_c"]
        dx = (k * (TP - p["T_P0"]) - xP) / p["tau_P"]
        if xP <= 0.0 and dx < 0.0:  # the cartridge rests on its stop (stroke limit)
            dx = 0.0
        return [dTP, dTG, dx]

    return rhs


def test_rk4_matches_independent_solve_ivp(model):
    # Backlash off (c=0) so x_P stays in [0, x_max] where the plain ODE holds.
    p = dict(zip(model.param_names, model.nominal, strict=True))
    p["c_backlash"] = 0.0
    T_on = 180  # heat for 3 min: T_P passes 60 °C but the stroke stays below its limit
    rhs = _paper_rhs(p)
    sol = solve_ivp(
        lambda t, x: rhs(t, x, 1.0, 24.0, 25.0),
        (0, T_on),
        [25.0, 25.0, 0.0],
        rtol=1e-10,
        atol=1e-10,
        t_eval=np.arange(0, T_on + 1.0),
    )
    sim = model.simulate(
        _inputs(T_on + 1, T_on + 1), dt=1.0, theta=p, x0=[25, 25, 0, 0], return_states=True
    )
    np.testing.assert_allclose(sim.output("T_P")[0], sol.y[0], atol=2e-4)
    np.testing.assert_allclose(sim.output("T_G")[0], sol.y[1], atol=2e-4)
    np.testing.assert_allclose(sim.output("x_P")[0], sol.y[2], atol=2e-3)


def test_energy_balance(model):
    # (17)+(18): ∫P dt = C_P ΔT_P + C_G ΔT_G + ∫ λ_GU (T_G − T_U) dt   (δW = 0)
    dt = 0.5
    u = _inputs(int(3600 / dt), int(1200 / dt))
    sim = model.simulate(u, dt=dt)
    p = dict(zip(model.param_names, model.nominal, strict=True))
    P, TP, TG = (sim.output(n)[0] for n in ("P_PTC", "T_P", "T_G"))
    t = sim.time
    # u switches off at sample k: P(t) is smooth on [0, t_k] and zero after. The sample at
    # t_k already uses u = 0, so the end of the heating interval is evaluated with u = 1.
    k = int(1200 / dt)
    P_on = P[: k + 1].copy()
    P_on[k] = 24.0**2 / ptc_resistance(TP[k], model.nominal[:6])
    e_in = simpson(P_on, x=t[: k + 1])
    stored = p["C_P"] * (TP[-1] - TP[0]) + p["C_G"] * (TG[-1] - TG[0])
    lost = simpson(p["lambda_GU"] * (TG - 25.0), x=t)
    assert stored + lost == pytest.approx(e_in, rel=2e-3)


def test_steady_state_matches_hand_derivation(model):
    p = dict(zip(model.param_names, model.nominal, strict=True))
    kU, TU = 24.0, 25.0
    lam = 1.0 / (1.0 / p["lambda_PG"] + 1.0 / p["lambda_GU"])
    coeffs = model.nominal[:6]
    TP_ss = brentq(lambda T: kU**2 / ptc_resistance(T, coeffs) - lam * (T - TU), 30.0, 150.0)
    TG_ss = (p["lambda_PG"] * TP_ss + p["lambda_GU"] * TU) / (p["lambda_PG"] + p["lambda_GU"])
    sim = model.simulate(_inputs(5 * 3600 // 10, 5 * 3600 // 10), dt=10.0)
    assert sim.output("T_P")[0, -1] == pytest.approx(TP_ss, abs=0.02)
    assert sim.output("T_G")[0, -1] == pytest.approx(TG_ss, abs=0.02)


def test_backlash_operator_on_a_triangle(model):
    from thermogym.models.axt211_dynamics import backlash as _backlash

    c = 0.2
    up = np.linspace(0.0, 3.0, 301)
    down = up[::-1]
    xv = 0.0
    out_up = []
    for x in up:
        xv = _backlash(x, xv, c, 4.5)
        out_up.append(xv)
    out_down = []
    for x in down:
        xv = _backlash(x, xv, c, 4.5)
        out_down.append(xv)
    np.testing.assert_allclose(np.array(out_up)[up > c + 0.01], up[up > c + 0.01] - c, atol=1e-12)
    # after the reversal the rod stays until the play 2c is crossed, then follows at x_P + c
    sel = down < 3.0 - 2 * c - 0.01
    np.testing.assert_allclose(np.array(out_down)[sel], down[sel] + c, atol=1e-12)
    assert np.all(np.array(out_down)[down > 3.0 - 2 * c + 0.01] == pytest.approx(3.0 - c))


def test_batch_equals_one_by_one_and_is_deterministic(model):
    u = _inputs(1200, 600)
    th = model.theta({"C_P": [20.0, 24.0, 30.0], "tau_P": [5.0, 8.0, 12.0]})
    batch = model.simulate(u, dt=2.0, theta=th)
    for b in range(3):
        one = model.simulate(u, dt=2.0, theta=th[b])
        np.testing.assert_array_equal(batch.outputs[b], one.outputs[0])
    again = model.simulate(u, dt=2.0, theta=th)
    np.testing.assert_array_equal(batch.outputs, again.outputs)


def test_large_batch_with_a_shared_input_equals_one_by_one(model):
    # 40 sets with one input trajectory take the batch-innermost (SIMD) kernel; each set
    # alone takes the per-system kernel: both are built from the same step, same bits
    u = _inputs(300, 200)
    rng = np.random.default_rng(4)
    th = model.theta(batch=40)
    for name in ("C_P", "lambda_GU", "tau_P", "kP_b"):
        th[:, model.param_index(name)] *= rng.uniform(0.8, 1.2, 40)
    batch = model.simulate(u, dt=5.0, theta=th)
    for b in (0, 17, 39):
        one = model.simulate(u, dt=5.0, theta=th[b])
        np.testing.assert_array_equal(batch.outputs[b], one.outputs[0])


def test_step_api_matches_simulate(model):
    u = _inputs(301, 301)
    sim = model.simulate(u, dt=1.0, return_states=True)
    x = sim.states[:, 0, :]
    th = model.theta()
    for k in range(300):
        x = model.step(x, u[k][None], th, 1.0)
    np.testing.assert_allclose(x, sim.states[:, -1, :], atol=1e-12)
    y = model.output(x, u[-1][None], th)
    np.testing.assert_allclose(y, sim.outputs[:, -1, :], atol=1e-12)


def test_phase_change_delays_the_stroke():
    m = AXT211(effects=("phase_change",))
    assert "L_melt" in m.param_names
    u = _inputs(900, 900)
    base = m.simulate(u, dt=1.0)
    latent = m.simulate(u, dt=1.0, theta={"L_melt": 400.0, "T_melt": 58.0})
    t0 = np.argmax(base.output("x_V")[0] >= 4.45)
    t1 = np.argmax(latent.output("x_V")[0] >= 4.45)
    assert t1 > t0 + 10
    # the neutral value reproduces the plain model exactly
    np.testing.assert_array_equal(base.outputs, AXT211().simulate(u, dt=1.0).outputs)


def test_supply_sag_reduces_power():
    m = AXT211(effects=("supply_variation",))
    u = _inputs(10, 10)
    p0 = m.simulate(u, dt=1.0).output("P_PTC")[0, 0]
    p1 = m.simulate(u, dt=1.0, theta={"R_source": 20.0}).output("P_PTC")[0, 0]
    R = ptc_resistance(25.0, m.nominal[:6])
    assert p1 == pytest.approx(24.0**2 * R / (R + 20.0) ** 2, rel=1e-12)
    assert p1 < p0


def test_bad_inputs_are_rejected_with_names(model):
    u = _inputs(10, 10)
    u[3, 0] = 1.5
    with pytest.raises(ShapeError, match=r"'u' is 1.5"):
        model.simulate(u, dt=1.0)
    with pytest.raises(ShapeError, match=r"\(T, 3\).*'u', 'k_U', 'T_U'"):
        model.simulate(np.zeros((10, 2)), dt=1.0)
    u = _inputs(10, 10)
    u[4, 2] = np.nan
    with pytest.raises(ShapeError, match=r"'T_U' is nan at sample 4"):
        model.simulate(u, dt=1.0)
    with pytest.raises(ParameterError, match=r"unknown parameter\(s\) \['C_X'\].*C_P"):
        model.simulate(_inputs(10, 10), dt=1.0, theta={"C_X": 1.0})
    with pytest.raises(ParameterError, match=r"'C_P' of set 0 is -1.0"):
        model.simulate(_inputs(10, 10), dt=1.0, theta={"C_P": -1.0})
    with pytest.raises(ShapeError, match="dt is 0"):
        model.simulate(_inputs(10, 10), dt=0)


def test_vectorised_batch_kernel_equals_scalar_kernel(model):
    # Large effect-free batches with one shared input go through the batch-innermost
    # kernel; it must reproduce the scalar kernel used for single systems.
    rng = np.random.default_rng(4)
    th = model.theta(batch=40)
    th[:, model.param_index("C_P")] *= rng.uniform(0.8, 1.2, 40)
    th[:, model.param_index("T_P0")] += rng.uniform(-2, 2, 40)
    u = _inputs(900, 450)
    u[:, 0] = np.where(np.arange(900) < 450, (np.arange(900) % 20 < 10), 0.0)
    batch = model.simulate(u, dt=1.0, theta=th)
    for b in (0, 17, 39):
        one = model.simulate(u, dt=1.0, theta=th[b])
        np.testing.assert_allclose(batch.outputs[b], one.outputs[0], rtol=1e-10, atol=1e-10)


@pytest.mark.slow
def test_batched_kernel_loop_over_systems_vectorises():
    # The effect-free batched kernel exists for speed: its loop over systems must compile to
    # SIMD code. A branch in the loop body (e.g. numba's division-by-zero checks under the
    # default error model) silently turns it back into scalar code, 2.6x slower. The kernel
    # is recompiled here with its own options (its cached copy cannot be inspected), and the
    # RK4 stages' divisions v2 / R_PTC must appear as vector divisions in the LLVM IR.
    import re

    import numba as nb

    from thermogym.models import axt211 as mod

    opts = {k: v for k, v in mod._soa_chunk.targetoptions.items() if k not in ("cache", "nopython")}
    fresh = nb.njit(**opts)(mod._soa_chunk.py_func)
    m = AXT211()
    B, T = 32, 3
    full = m.full_theta(np.tile(m.nominal, (B, 1)))
    u = np.tile([1.0, 24.0, 25.0], (T, 1))
    x0 = m.initial_state(full[:, : m.nominal.size], np.tile(u[0], (B, 1)))
    y = np.empty((B, T, 6))
    fresh(full, u, x0, 1.0, 1, y, 0, B)
    ref = np.empty_like(y)
    mod._soa_chunk(full, u, x0, 1.0, 1, ref, 0, B)
    assert np.array_equal(y, ref)
    llvm = next(iter(fresh.inspect_llvm().values()))
    assert re.search(r"fdiv[a-z ]*<\d+ x double>", llvm), "the loop over systems is scalar"
