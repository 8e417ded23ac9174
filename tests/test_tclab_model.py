"""Tests of the TCLab two-heater model and of its shipped identification.

Truth: steady states solved independently with scipy from the single-heater
heat balance, the global energy balance (the coupling terms cancel), the
symmetry of the two heaters, the sensor lag against an exact first-order
filter, the linearised time constant, and the real recordings for the shipped
FitResult.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.signal import lsim

from thermogym.datasets import load
from thermogym.envs.tclab import FIT_PATH
from thermogym.errors import ParameterError, ShapeError
from thermogym.fitresult import FitResult, data_entry
from thermogym.models.registry import get_model
from thermogym.models.tclab import SIGMA, TCLabModel

K = 273.15


@pytest.fixture(scope="module")
def model() -> TCLabModel:
    return TCLabModel()


def pv(m: TCLabModel, th: np.ndarray, *names: str) -> list[float]:
    return [float(th[0, m.param_index(n)]) for n in names]


def exog(T: int, Q1=0.0, Q2=0.0, Ta=21.0) -> np.ndarray:
    return np.column_stack([np.broadcast_to(np.asarray(v, float), (T,)) for v in (Q1, Q2, Ta)])


def test_registered_and_described(model):
    m = get_model("tclab")
    assert isinstance(m, TCLabModel)
    d = m.describe()
    assert d["name"] == "tclab" and d["states"] == ["T_H1", "T_H2", "T_C1", "T_C2"]
    assert m.exogenous_names == ("Q1", "Q2", "T_amb")
    assert m.output_names[:2] == ("T1", "T2")


def test_uncoupled_steady_state_matches_the_heat_balance(model):
    th = model.theta({"A_s": 0.0, "U_s": 0.0})
    U, A, eps, a1 = pv(model, th, "U", "A", "eps", "alpha_1")
    Ta, Q = 21.0, 60.0

    def balance(T: float) -> float:
        # U A (Ta − T) + ε σ A (Ta⁴ − T⁴) + α Q = 0
        return U * A * (Ta - T) + eps * SIGMA * A * ((Ta + K) ** 4 - (T + K) ** 4) + a1 * Q

    T_ss = brentq(balance, Ta, Ta + 300.0)
    sim = model.simulate(exog(4 * 3600, Q1=Q, Ta=Ta), dt=1.0, theta=th)
    assert sim.output("TH1")[0, -1] == pytest.approx(T_ss, abs=1e-3)
    assert sim.output("T1")[0, -1] == pytest.approx(T_ss, abs=1e-3)
    assert sim.output("T2")[0, -1] == pytest.approx(Ta, abs=1e-9)  # no coupling, no heat


def test_coupled_steady_state_balances_total_power(model):
    th = model.theta()
    U, A, eps, a1, a2 = pv(model, th, "U", "A", "eps", "alpha_1", "alpha_2")
    Ta, Q1, Q2 = 23.0, 70.0, 40.0
    y = model.simulate(exog(4 * 3600, Q1, Q2, Ta), dt=1.0, theta=th).outputs[0, -1]
    T = np.array([y[2], y[3]])
    # the exchange between the heaters cancels: heat in = losses of both heaters to ambient
    loss = U * A * (T - Ta) + eps * SIGMA * A * ((T + K) ** 4 - (Ta + K) ** 4)
    assert loss.sum() == pytest.approx(a1 * Q1 + a2 * Q2, rel=1e-5)
    assert y[0] > y[1] > Ta
    ss = model.steady_state(th, Q1, Q2, Ta)
    np.testing.assert_allclose(ss[0], T, atol=1e-4)


def test_heaters_are_symmetric(model):
    th = model.theta()
    a1, a2 = pv(model, th, "alpha_1", "alpha_2")
    sw = model.theta(th[0], alpha_1=a2, alpha_2=a1)
    rng = np.random.default_rng(0)
    q1, q2 = rng.uniform(0, 100, 600), rng.uniform(0, 100, 600)
    y = model.simulate(exog(600, q1, q2, 20.0), 1.0, th).outputs[0]
    ys = model.simulate(exog(600, q2, q1, 20.0), 1.0, sw).outputs[0]
    np.testing.assert_allclose(ys[:, [1, 0, 3, 2]], y[:, :4], rtol=0, atol=1e-10)


def test_sensor_lags_its_heater_by_a_first_order_filter(model):
    th = model.theta()
    (tau,) = pv(model, th, "tau_s")
    dt = 0.05  # fine steps: the heater trajectory is known accurately
    T = int(900 / dt)
    sim = model.simulate(exog(T, 80.0, 0.0, 21.0), dt, th)
    t = dt * np.arange(T)
    TH, TC = sim.output("TH1")[0], sim.output("T1")[0]
    _, y, _ = lsim(([1.0], [tau, 1.0]), TH - 21.0, t, interp=True)
    np.testing.assert_allclose(TC - 21.0, y, atol=2e-3)


def test_small_step_time_constant_matches_linearisation(model):
    th = model.theta({"A_s": 0.0, "U_s": 0.0, "tau_s": 2.0})
    C, U, A, eps, a1 = pv(model, th, "C_H", "U", "A", "eps", "alpha_1")
    Ta = 21.0
    G = U * A + 4 * eps * SIGMA * A * (Ta + K) ** 3  # dQ/dT at ambient
    tau = C / G
    dt = 0.5
    sim = model.simulate(exog(int(6 * tau / dt), 1.0, 0.0, Ta), dt, th)
    rise = sim.output("TH1")[0] - Ta
    t63 = dt * np.argmax(rise >= 0.632 * rise[-1] / (1 - np.exp(-6)))
    assert t63 == pytest.approx(tau, rel=0.03)
    assert rise[-1] == pytest.approx(a1 / G * (1 - np.exp(-6)), rel=0.02)


def test_batch_and_step_agree_with_simulate(model):
    rng = np.random.default_rng(1)
    th = model.theta({"C_H": [1.5, 2.0, 3.0]})
    u = exog(200, rng.uniform(0, 100, 200), rng.uniform(0, 100, 200), 22.0)
    yb = model.simulate(u, 2.0, th).outputs
    for b in range(3):
        np.testing.assert_array_equal(yb[b], model.simulate(u, 2.0, th[b]).outputs[0])
    x = model.initial_state(th[:1], u[:1])
    for k in range(5):
        x = model.step(x, u[k : k + 1], th[0], 2.0)
    np.testing.assert_allclose(model.output(x, u[5:6], th[0])[0], yb[0, 5], rtol=0, atol=1e-12)


def test_bad_inputs_and_parameters_are_named(model):
    with pytest.raises(ShapeError, match="heater command"):
        model.simulate(exog(5, Q1=120.0), 1.0)
    with pytest.raises(ParameterError, match="U_s"):
        model.theta({"U_s": -1.0})
    with pytest.raises(ParameterError, match="tau_s"):
        model.theta({"tau_s": 0.0})


# ------------------------------------------------------------ shipped fit
@pytest.fixture(scope="module")
def fit() -> FitResult:
    return FitResult.load(FIT_PATH)


def test_shipped_fit_provenance(fit):
    assert fit.model == "tclab" and fit.method == "least_squares"
    roles = {d["experiment_id"]: d["role"] for d in fit.data}
    assert {"tclab_mimo_1s", "tclab_step", "tclab_sine"} <= {
        k for k, v in roles.items() if v == "train"
    }
    assert {k for k, v in roles.items() if v == "validation"} >= {
        "tclab_step_50_run2",
        "tclab_mimo_3s_a",
    }
    # fingerprints are those of the shipped recordings (the data the fit was made from)
    for d in fit.data:
        assert data_entry(load(d["experiment_id"]))["fingerprint"] == d["fingerprint"]
    assert np.asarray(fit.covariance).shape == (len(fit.covariance_names),) * 2
    assert fit.metrics["train"]["mnrmse_mean"] > 0.9


def test_shipped_fit_predicts_an_unseen_run(fit):
    # independent of the fit script: resimulate a validation run from its raw recording
    m = fit.build_model()
    th = fit.theta(m)
    rec = load("tclab_step_50_run2")
    t = np.arange(0.0, np.floor(rec.time[-1]))
    q1 = np.interp(t, rec.time, rec["Q1"])
    Ta = 0.5 * (rec["T1"][:5].mean() + rec["T2"][:5].mean())
    x0 = np.array([[rec["T1"][0], rec["T2"][0], rec["T1"][0], rec["T2"][0]]])
    # the Dowling board's heater 1 is stronger: its gain is stored with the fit
    th[0, m.param_index("alpha_1")] = fit.settings["alpha_1_dowling"]
    y = m.simulate(exog(t.size, q1, 0.0, Ta), 1.0, th, x0).outputs[0]
    for j, name in enumerate(("T1", "T2")):
        meas = np.interp(t, rec.time, rec[name])
        fit_ = 1 - np.linalg.norm(meas - y[:, j]) / np.linalg.norm(meas - meas.mean())
        assert fit_ > 0.9, name
