"""Virtual sensors: Kalman filters, steady-state observers, consistency, AXT211 UKF.

References are independent: the Riccati equation itself, filterpy's
time-varying filter run to convergence, Monte Carlo simulations with the
filter's own noise model (chi-square consistency), exact algebraic
transformations, the spindle network's truth and the AXT211 rig's truth.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal

from thermogym.errors import ConfigError, ParameterError, ShapeError, UnknownNameError
from thermogym.estimation import (
    AXT211WaxUKF,
    NoiseModel,
    ObserverStatus,
    VirtualSensor,
    balanced_truncation,
    consistency,
    innovation_covariance,
    normalized_error_squared,
    steady_state_gains,
)
from thermogym.firmware.reference import spindle_reference_model
from thermogym.identification.metrics import nrmse
from thermogym.models.linear import StateSpaceModel

HIDDEN = (
    "T_rear_bearing_A",
    "T_rear_bearing_B",
    "T_front_bearing_C",
    "T_front_bearing_D",
    "T_inner_housing",
)
SURFACE = ("T_front_outer_housing", "T_rear_outer_housing")


def random_system(rng, n=4, m=2, p=3, radius=0.95):
    A = rng.normal(size=(n, n))
    A *= radius / np.abs(np.linalg.eigvals(A)).max()
    return A, rng.normal(size=(n, m)), rng.normal(size=(p, n))


@pytest.fixture
def rng():
    return np.random.default_rng(7)


@pytest.fixture(scope="module")
def spindle_day():
    # the estimators are checked against a truth their model can hold: a day of the spindle
    # model itself (the spindle rig is a plant of its own; the virtual sensor's accuracy on
    # it is a benchmark figure)
    from _model_plants import model_spindle_day

    cols, truth = model_spindle_day(5300.0, seed=3)
    k = slice(0, 12 * 3600)  # the heating half of the day and the start of cooling
    return {c: v[k] for c, v in cols.items()}, {c: v[k] for c, v in truth.items()}


# ================================================================ Riccati gains
def test_gains_solve_the_riccati_equation(rng):
    A, _, C = random_system(rng)
    L = rng.normal(size=(4, 4))
    noise = NoiseModel(0.1 * L @ L.T, np.diag([0.2, 0.3, 0.5]), 0.01 * rng.normal(size=(4, 3)))
    g = steady_state_gains(A, C, noise)
    P, Q, R, S = g.P, noise.Q, noise.R, noise.S
    Sig = C @ P @ C.T + R
    rhs = A @ P @ A.T + Q - (A @ P @ C.T + S) @ np.linalg.solve(Sig, (A @ P @ C.T + S).T)
    assert np.allclose(P, rhs, atol=1e-10 * np.abs(P).max())
    assert np.abs(np.linalg.eigvals(A - g.K @ C)).max() < 1.0
    assert np.allclose(g.P_post, P - g.L @ Sig @ g.L.T)


def test_innovation_form_with_every_output_measured_gives_the_identified_gain(rng):
    A, _, C = random_system(rng, n=4, p=3, radius=0.6)
    K = 0.03 * rng.normal(size=(4, 3))
    assert np.abs(np.linalg.eigvals(A - K @ C)).max() < 1
    Re = np.diag([0.1, 0.2, 0.05])
    g = steady_state_gains(A, C, NoiseModel.from_innovation(K, Re, [0, 1, 2]))
    # the innovation form is its own steady-state predictor: P = 0, gain = K
    assert np.allclose(g.K, K, atol=1e-6)
    assert np.abs(g.P).max() < 1e-6


def test_steady_gain_is_the_limit_of_filterpys_time_varying_filter(rng):
    from filterpy.kalman import KalmanFilter

    A, _, C = random_system(rng, n=3, p=2)
    noise = NoiseModel(0.05 * np.eye(3), 0.1 * np.eye(2))
    g = steady_state_gains(A, C, noise)
    kf = KalmanFilter(dim_x=3, dim_z=2)
    kf.F, kf.H, kf.Q, kf.R, kf.P = A, C, noise.Q, noise.R, 10 * np.eye(3)
    for _ in range(400):
        kf.predict()
        kf.update(np.zeros((2, 1)))
    assert np.allclose(kf.K, g.L, atol=1e-8)
    assert np.allclose(kf.P_prior, g.P, atol=1e-8)


def test_no_measurement_covariance_is_the_lyapunov_solution(rng):
    A, _, _ = random_system(rng, n=3)
    Q = np.diag([0.1, 0.2, 0.3])
    g = steady_state_gains(A, np.zeros((0, 3)), NoiseModel(Q, np.zeros((0, 0))))
    assert np.allclose(g.P, A @ g.P @ A.T + Q)
    with pytest.raises(ParameterError, match="spectral radius"):
        steady_state_gains(1.01 * np.eye(3), np.zeros((0, 3)), NoiseModel(Q, np.zeros((0, 0))))


def test_undetectable_model_is_refused():
    A = np.diag([1.02, 0.5])  # unstable first state, only the second measured
    with pytest.raises(ParameterError, match="detectable"):
        steady_state_gains(A, [[0.0, 1.0]], NoiseModel(np.eye(2), [[1.0]]))


def test_noise_model_checks_its_covariances():
    with pytest.raises(ParameterError, match="positive definite"):
        NoiseModel(np.eye(2), [[0.0]])
    with pytest.raises(ParameterError, match="symmetric"):
        NoiseModel([[1.0, 0.5], [0.0, 1.0]], [[1.0]])
    with pytest.raises(ShapeError, match="S has shape"):
        NoiseModel(np.eye(2), [[1.0]], np.zeros((3, 1)))
    with pytest.raises(ParameterError, match="joint"):
        NoiseModel([[1.0]], [[1.0]], [[2.0]])  # |correlation| > 1


# ============================================================ filter vs observer
def _model(rng, n=4, m=2, p=3, K=False):
    A, B, C = random_system(rng, n, m, p)
    Kg = 0.05 * rng.normal(size=(n, p)) if K else None
    return StateSpaceModel.from_matrices(
        A, B, C, None, Kg, dt=1.0, inputs=["u0", "u1"][:m], outputs=["a", "b", "c"][:p]
    )


def test_time_varying_filter_equals_steady_observer_from_the_steady_covariance(rng):
    m = _model(rng, K=True)
    vs = VirtualSensor(m, measured=["a", "b"], measurement_std=0.1)
    u = rng.normal(size=(500, 2))
    y = m.simulate(u, 1.0).outputs[0] + 0.1 * rng.normal(size=(500, 3))
    e1 = vs.filter(u, y[:, :2])
    e2 = vs.observe(u, y[:, :2])
    assert np.allclose(e1.values, e2.values, atol=1e-9)
    assert np.allclose(e1.cov, e2.cov, atol=1e-9)
    assert np.allclose(e1.innovations, e2.innovations, atol=1e-9)


def test_step_observer_equals_the_compiled_run_including_holds(rng):
    m = _model(rng)
    vs = VirtualSensor(m, measured=["a"], ranges={"u0": (-3.0, 3.0)})
    u = rng.normal(size=(300, 2))
    z = m.simulate(u, 1.0).outputs[0][:, :1]
    u[50, 1] = np.nan
    u[60, 0] = 10.0  # out of range
    z[70, 0] = np.inf
    est = vs.observe(u, z)
    assert est.status[50] == ObserverStatus.NOT_FINITE
    assert est.status[60] == ObserverStatus.OUT_OF_RANGE
    assert est.status[70] == ObserverStatus.NOT_FINITE
    assert np.array_equal(est.values[50], est.values[49])  # held
    obs = vs.step_observer()
    obs.reset(u[0], z[0])
    ys = []
    for k in range(300):
        y, st = obs.step(u[k], z[k])
        ys.append(y)
        assert st == est.status[k]
    assert np.allclose(np.array(ys), est.values, atol=1e-12)


def test_missing_measurements_are_skipped_by_the_kalman_filter(rng):
    m = _model(rng)
    vs = VirtualSensor(m, measured=["a", "b"])
    u = rng.normal(size=(200, 2))
    z = m.simulate(u, 1.0).outputs[0][:, :2]
    z[100:110, 0] = np.nan
    z[120, :] = np.nan
    est = vs.filter(u, z)
    assert np.isfinite(est.values).all()
    assert np.isnan(est.innovations[105, 0]) and np.isfinite(est.innovations[105, 1])
    # the covariance grows while a channel is missing and shrinks afterwards
    tr = np.trace(est.cov, axis1=1, axis2=2)
    assert tr[109] > tr[99] and tr[130] < tr[109]


# ================================================================= consistency
def test_filter_is_consistent_on_data_drawn_from_its_noise_model(rng):
    # Monte Carlo truth: a linear plant with exactly the filter's Q, R; the NEES of the
    # state-derived hidden output and the NIS must pass the chi-square tests
    A, B, C = random_system(rng, n=3, m=1, p=3, radius=0.9)
    Q, R = 0.02 * np.eye(3), np.diag([0.05, 0.08])
    m = StateSpaceModel.from_matrices(A, B, C, dt=1.0, inputs=["u"], outputs=["h", "z1", "z2"])
    vs = VirtualSensor(m, measured=["z1", "z2"], noise=NoiseModel(Q, R))
    T = 8000
    u = rng.normal(size=(T, 1))
    x = np.zeros(3)
    X = np.empty((T, 3))
    for k in range(T):
        X[k] = x
        x = A @ x + B @ u[k] + rng.multivariate_normal(np.zeros(3), Q)
    Y = X @ C.T
    z = Y[:, 1:] + rng.multivariate_normal(np.zeros(2), R, size=T)
    est = vs.filter(u, z, x0=np.zeros(3), P0=np.zeros((3, 3)))
    nees = consistency(est.nees(Y[:, :1]), dof=1)
    nis = consistency(est.nis(), dof=2)
    assert nees.consistent and nis.consistent
    assert abs(nees.fraction_inside - 0.95) < 0.02
    # a filter that claims three times less process noise is caught
    bad = vs.with_noise(NoiseModel(Q / 3, R)).filter(u, z, x0=np.zeros(3), P0=np.zeros((3, 3)))
    assert not consistency(bad.nees(Y[:, :1]), dof=1).consistent


def test_normalized_error_squared_and_chi_square_bounds(rng):
    e = rng.normal(size=(4000, 3)) * [1.0, 2.0, 0.5]
    P = np.diag([1.0, 4.0, 0.25])
    v = normalized_error_squared(e, P)
    assert abs(v.mean() - 3) < 0.2
    assert consistency(v, 3).consistent
    assert not consistency(3 * v, 3).consistent
    assert np.isnan(normalized_error_squared([[np.nan, 1.0, 1.0]], P)[0])
    with pytest.raises(ParameterError):
        consistency(v, 0)


# ========================================================= spindle virtual sensor
def test_spindle_internal_temperatures_from_surface_temperatures(spindle_day):
    cols, truth = spindle_day
    model = spindle_reference_model("1I7O", order=8)
    vs = VirtualSensor(model, measured=SURFACE, measurement_std=0.02)
    est = vs.estimate(cols, method="observer", rest={"speed": 0.0})
    Y = np.column_stack([truth[h] for h in HIDDEN])
    fits = nrmse(Y.T, est.values.T)
    assert (fits > 0.99).all(), fits  # paper 001: above 99 %
    assert np.sqrt(np.mean((Y - est.values) ** 2)) < 0.05


def test_kalman_correction_recovers_from_a_wrong_initial_state(spindle_day):
    cols, truth = spindle_day
    k0 = 4 * 3600  # the estimator starts mid-run believing the spindle is at rest
    every = slice(k0, None, 10)  # 10 s samples (speed and ambient are held or smooth)
    cols = {c: v[every] for c, v in cols.items()}
    Y = np.column_stack([truth[h][every] for h in HIDDEN])
    model = spindle_reference_model("1I7O", order=8, dt=10.0)
    kf = VirtualSensor(model, measured=SURFACE, measurement_std=0.02)
    open_loop = VirtualSensor(model, hidden=HIDDEN)
    P0 = np.eye(kf.n_states) * 1e3 * np.trace(kf.gains.P)
    e_kf = kf.estimate(cols, method="kalman", rest={"speed": 0.0}, P0=P0)
    e_ol = open_loop.estimate(cols, method="observer", rest={"speed": 0.0})
    late = slice(720, None)  # after two hours
    err_kf = np.abs(Y - e_kf.values)[late].max()
    err_ol = np.abs(Y - e_ol.values)[late].max()
    assert err_kf < 0.25 * err_ol


def test_reference_transform_is_exact(rng):
    # a model on temperatures relative to T_ref, fed with absolute data, equals the
    # relative model run on relative data plus T_ref
    A, B, C = random_system(rng, n=3, m=2, p=2, radius=0.9)
    units = {"P": "W", "T_s": "°C", "T_h": "°C", "T_z": "°C"}
    m = StateSpaceModel.from_matrices(
        A, B, C, [[0.0, 0.3], [0.0, 0.1]], dt=1.0, inputs=["P", "T_s"], outputs=["T_h", "T_z"],
        units=units,
    )  # fmt: skip
    vs = VirtualSensor(m, reference="T_amb", hidden=["T_h", "T_z"])
    assert vs.exogenous_names == ("P", "T_s", "T_amb")
    T = 400
    P = rng.normal(size=T)
    rel_s = rng.normal(size=T)
    T_ref = 20 + np.cumsum(0.01 * rng.normal(size=T))
    est = vs.observe(np.column_stack([P, rel_s + T_ref, T_ref]), x0=np.zeros(3))
    sim = m.simulate(np.column_stack([P, rel_s]), 1.0, x0=np.zeros(3)).outputs[0]
    assert np.allclose(est.values, sim + T_ref[:, None], atol=1e-10)


def test_disturbance_state_removes_the_bias_of_a_wrong_input_gain(rng):
    # plant: heat 30 % above what the model believes; the augmented filter estimates it
    Ac = np.array([[-1 / 600, 1 / 600], [1 / 900, -2 / 900]])
    Bc = np.array([[1 / 600], [0.0]])
    C = np.eye(2)
    model = StateSpaceModel.from_continuous(
        Ac, Bc, C, dt=10.0, inputs=["P"], outputs=["core", "skin"]
    )
    plant = StateSpaceModel.from_continuous(
        Ac, 1.3 * Bc, C, dt=10.0, inputs=["P"], outputs=["core", "skin"]
    )
    u = np.full((3000, 1), 10.0)
    y = plant.simulate(u, 10.0).outputs[0]
    z = y[:, 1:] + 0.01 * rng.normal(size=(3000, 1))
    plain = VirtualSensor(model, measured=["skin"], measurement_std=0.01)
    aug = VirtualSensor(
        model, measured=["skin"], measurement_std=0.01, disturbance_inputs=["P"],
        disturbance_std=0.05,
    )  # fmt: skip
    e_plain = abs(plain.observe(u, z, x0=np.zeros(2)).values[-1, 0] - y[-1, 0])
    e_aug = abs(aug.observe(u, z, x0=np.zeros(3)).values[-1, 0] - y[-1, 0])
    assert e_aug < 0.05 * e_plain
    assert e_aug < 0.05


def test_at_period_is_the_exact_held_input_sampling(rng):
    m = _model(rng)
    vs = VirtualSensor(m, measured=["a"])
    slow = vs.at_period(5.0)
    assert slow.dt == 5.0
    A = m.matrices().A[0]
    assert np.allclose(slow.observer_matrices().A, np.linalg.matrix_power(A, 5))
    u = np.repeat(rng.normal(size=(40, 2)), 5, axis=0)  # held over 5 steps
    x = m.simulate(u, 1.0, return_states=True, x0=np.ones(4)).states[0]
    sim_slow = StateSpaceModel.from_matrices(
        slow.observer_matrices().A, slow.observer_matrices().B, np.eye(4), dt=5.0
    ).simulate(u[::5], 5.0, x0=np.ones(4))
    assert np.allclose(sim_slow.outputs[0], x[::5], atol=1e-10)
    with pytest.raises(ParameterError, match="multiple"):
        vs.at_period(2.5)


def test_tuning_reaches_the_target_statistic(rng):
    m = _model(rng)
    vs = VirtualSensor(m, measured=["a", "b"], measurement_std=0.1)
    u = rng.normal(size=(3000, 2))
    y = m.simulate(u, 1.0).outputs[0] + 0.1 * rng.normal(size=(3000, 3))
    tuned, alpha = vs.tuned(u, y[:, :2])
    assert abs(np.nanmean(tuned.observe(u, y[:, :2]).nis()) - 2.0) < 0.05 or alpha in (1e-6, 1e8)
    with pytest.raises(ConfigError, match="hidden_truth"):
        VirtualSensor(m, hidden=["c"]).tuned(u)


def test_innovation_covariance_of_white_noise(rng):
    m = StateSpaceModel.from_matrices([[0.8]], [[1.0]], [[1.0]], K=[[0.0]], dt=1.0)
    u = rng.normal(size=(5000, 1))
    y = m.simulate(u, 1.0).outputs[0] + 0.3 * rng.normal(size=(5000, 1))
    assert abs(innovation_covariance(m, u, y, discard=10)[0, 0] - 0.09) < 0.01


def test_virtual_sensor_refuses_bad_configurations(rng):
    m = _model(rng)
    with pytest.raises(UnknownNameError, match="not an output"):
        VirtualSensor(m, measured=["nope"])
    with pytest.raises(ConfigError, match="every output is measured"):
        VirtualSensor(m, measured=["a", "b", "c"])
    with pytest.raises(ConfigError, match="both measured and hidden"):
        VirtualSensor(m, measured=["a"], hidden=["a"])
    with pytest.raises(ConfigError, match="state-space"):
        VirtualSensor(spindle_reference_model.__globals__["SpindleModel"]())
    with pytest.raises(UnknownNameError, match="ranges"):
        VirtualSensor(m, ranges={"zz": (0, 1)})
    with pytest.raises(ShapeError, match="u has shape"):
        VirtualSensor(m).observe(np.zeros((10, 3)))
    with pytest.raises(UnknownNameError, match="lack"):
        VirtualSensor(m).estimate({"u0": np.zeros(3)})


# ===================================================================== reduction
def test_balanced_reduction_keeps_the_full_system_and_bounds_the_error(rng):
    A, B, C = random_system(rng, n=6, m=1, p=1, radius=0.9)
    Ar, Br, Cr, Dr, hsv = balanced_truncation(A, B, C, order=6)
    w = np.linspace(0, np.pi, 200)

    def freq(Aa, Ba, Ca, Da):
        num, den = scipy.signal.ss2tf(Aa, Ba, Ca, Da)
        return scipy.signal.freqz(num[0], den, worN=w)[1]

    full = freq(A, B, C, np.zeros((1, 1)))
    assert np.allclose(freq(Ar, Br, Cr, Dr), full, atol=1e-8 * np.abs(full).max())
    for method in ("truncate", "residualize"):
        Ar, Br, Cr, Dr, _ = balanced_truncation(A, B, C, order=3, method=method)
        err = np.abs(freq(Ar, Br, Cr, Dr) - full).max()
        assert err <= 2 * hsv[3:].sum() * (1 + 1e-6)
    Ar, Br, Cr, Dr, _ = balanced_truncation(A, B, C, order=2, method="residualize")
    dc_full = C @ np.linalg.solve(np.eye(6) - A, B)
    dc_red = Cr @ np.linalg.solve(np.eye(2) - Ar, Br) + Dr
    assert np.allclose(dc_red, dc_full)
    with pytest.raises(ParameterError, match="stable"):
        balanced_truncation(1.1 * np.eye(2), np.ones((2, 1)), np.ones((1, 2)), order=1)


# ====================================================================== AXT211
def _axt211_model_run(overrides=None, seed=2, n=5400):
    """A 24 V / 25 °C power step of the AXT211 *model* with the rig's sensor noise.

    The filter's own model generates the data (an independent truth for the filter's
    algebra); its accuracy on the rig's richer true plant is a benchmark figure
    (benchmarks/virtual_sensor.py), not these tests.
    """
    from types import SimpleNamespace

    from thermogym.models import AXT211

    m = AXT211()
    u = np.zeros((n, 3))
    u[:1800, 0] = 1.0
    u[:, 1], u[:, 2] = 24.0, 25.0
    sim = m.simulate(u, 1.0, m.theta(overrides or {}))
    rng = np.random.default_rng(seed)
    truth = {k: sim.output(k)[0] for k in ("T_P", "x_V", "P_PTC")}
    cols = {"u": u[:, 0], "k_U": u[:, 1] + 0.02 * rng.standard_normal(n),
            "T_U": u[:, 2] + 0.1 * rng.standard_normal(n),
            "x_V": truth["x_V"] + 0.005 * rng.standard_normal(n),
            "P_PTC": truth["P_PTC"] + 0.01 * rng.standard_normal(n)}  # fmt: skip
    return SimpleNamespace(columns=cols, truth=truth)


@pytest.fixture(scope="module")
def axt_run():
    return _axt211_model_run()


def test_axt211_ukf_tracks_the_wax_temperature_from_stroke_and_power(axt_run):
    run = axt_run
    T = 2400  # 30 min heating and 10 min cooling
    u = np.column_stack([run.columns[c][:T] for c in ("u", "k_U", "T_U")])
    z = np.column_stack([run.columns[c][:T] for c in ("x_V", "P_PTC")])
    truth = run.truth["T_P"][:T]
    ukf = AXT211WaxUKF()
    x0 = ukf.rest_state(u[0])
    x0[0] += 15.0  # a warm actuator mistaken for a cold one
    est = ukf.run(u, z, x0=x0)
    err = np.abs(est["T_P"] - truth)
    assert err[600:].max() < 1.5
    assert np.sqrt(np.mean(err[600:] ** 2)) < 0.5
    # the open-loop model from the same wrong start is worse
    from thermogym.models import AXT211

    sim = AXT211().simulate(u, 1.0, x0=x0).output("T_P")[0]
    assert np.sqrt(np.mean((sim[600:] - truth[600:]) ** 2)) > 2 * np.sqrt(np.mean(err[600:] ** 2))
    # the filter's own T_P variance is the right order of magnitude for its errors
    nees = normalized_error_squared((truth - est["T_P"])[:, None], est.cov[:, :1, :1])
    rep = consistency(nees[600:], dof=1)
    assert 0.1 < rep.mean < 10.0


def test_axt211_ukf_handles_missing_samples_and_bad_names(axt_run):
    run = axt_run
    u = np.column_stack([run.columns[c][:200] for c in ("u", "k_U", "T_U")])
    z = np.column_stack([run.columns[c][:200] for c in ("x_V", "P_PTC")])
    z[50:60, 0] = np.nan
    z[70, :] = np.nan
    est = AXT211WaxUKF().run(u, z)
    assert np.isfinite(est.values).all()
    assert est.status[70] == ObserverStatus.NOT_FINITE
    with pytest.raises(UnknownNameError):
        AXT211WaxUKF(measured=["stroke"])
    with pytest.raises(ShapeError):
        AXT211WaxUKF().run(u[:, :2], z)


# ========================================================================= CLI
def test_cli_virtual_sensor_writes_estimates_metrics_and_plot(tmp_path, capsys, spindle_day):
    from thermogym.cli import main
    from thermogym.fitresult import FitResult
    from thermogym.recording import Recording, read_recording, write_recording

    cols, truth = spindle_day
    k = slice(0, 4 * 3600, 5)  # 4 h at 5 s: the CLI resamples the 1 s model
    data = {c: v[k] for c, v in cols.items()}
    rec = Recording(5.0 * np.arange(len(data["speed"])), data, experiment_id="day")
    write_recording(rec, tmp_path / "day.csv")
    FitResult.from_model(spindle_reference_model("1I7O", order=8)).save(tmp_path / "fit.json")
    args = [
        "virtual-sensor", str(tmp_path / "day.csv"), "--fit", str(tmp_path / "fit.json"),
        "--out", str(tmp_path / "est.csv"), "--measured",
        "T_front_outer_housing,T_rear_outer_housing", "--rest", "speed=0",
        "--measurement-std", "0.02", "--plot", str(tmp_path / "vs.png"),
    ]  # fmt: skip
    assert main(args) == 0
    out = capsys.readouterr().out
    assert " fit " in out and "NEES mean" in out and "NIS mean" in out
    est = read_recording(tmp_path / "est.csv")
    for h in HIDDEN:
        assert f"{h}_std" in est
        # against the noise-free truth: the recorded internal temperatures are noisy
        assert np.sqrt(np.mean((est[h] - truth[h][k]) ** 2)) < 0.05
    assert (tmp_path / "vs.png").stat().st_size > 10_000
    # the firmware's observer gives the same estimates as the Kalman filter here
    assert (
        main([*args[:4], "--out", str(tmp_path / "obs.csv"), *args[6:], "--method", "observer"])
        == 0
    )
    obs = read_recording(tmp_path / "obs.csv")
    assert np.abs(obs[HIDDEN[0]] - est[HIDDEN[0]]).max() < 1e-6
    bad = [*args]
    bad[bad.index("--measured") + 1] = "T_nowhere"
    assert main(bad) == 2
    assert "T_nowhere" in capsys.readouterr().err


def test_axt211_ukf_learns_the_specimen_parameters():
    run = _axt211_model_run({"T_P0": 61.5, "kP_b": 0.155}, seed=5)  # a specimen off nominal
    k = slice(0, 3000)
    u = np.column_stack([run.columns[c][k] for c in ("u", "k_U", "T_U")])
    z = np.column_stack([run.columns[c][k] for c in ("x_V", "P_PTC")])
    truth = run.truth["T_P"][k]
    errs = {}
    for name, kw in (("plain", {}), ("joint", {"parameters": {"T_P0": 1.5, "kP_b": 0.015}})):
        est = AXT211WaxUKF(**kw).run(u, z)
        errs[name] = np.sqrt(np.mean((est["T_P"] - truth)[600:] ** 2))
        if name == "joint":
            assert est.names[-2:] == ("T_P0", "kP_b")
    assert errs["joint"] < errs["plain"]
