"""N4SID against known systems: eigenvalues, DC gain, impulse response, invariants."""

from __future__ import annotations

import numpy as np
import pytest

from thermogym.cli import main as cli_main
from thermogym.errors import ConfigError, IdentificationError, RecordingError
from thermogym.fitresult import FitResult
from thermogym.identification._n4sid_system import _mirror_schur
from thermogym.identification.linear_fit import predict_fit
from thermogym.identification.n4sid import (
    HankelAccumulator,
    decimate_data,
    decomposition_from_accumulator,
    n4sid,
    n4sid_decompose,
    simulate_ss,
)
from thermogym.models.linear import StateSpaceModel, c2d_zoh, d2c_zoh
from thermogym.recording import Recording, write_recording


def known_system(seed=5):
    """A 4-state, 2-input, 3-output stable system with well separated poles."""
    rng = np.random.default_rng(seed)
    V = np.linalg.qr(rng.normal(size=(4, 4)))[0] + 0.3 * rng.normal(size=(4, 4))
    lam = np.array([0.95, 0.85, 0.7, 0.5])
    A = V @ np.diag(lam) @ np.linalg.inv(V)
    B = rng.normal(size=(4, 2))
    C = rng.normal(size=(3, 4))
    return A, B, C, np.zeros((3, 2)), lam


def markov(A, B, C, k):
    out, M = [], C.copy()
    for _ in range(k):
        out.append(M @ B)
        M = M @ A
    return np.array(out)


def as_recording(u, y, dt=1.0, eid=None):
    cols = {f"u{i}": u[:, i] for i in range(u.shape[1])} | {
        f"y{j}": y[:, j] for j in range(y.shape[1])
    }
    return Recording(dt * np.arange(u.shape[0]), cols, experiment_id=eid)


def test_random_stable_mimo_system_recovered_from_noisy_data():
    A, B, C, D, lam = known_system()
    rng = np.random.default_rng(11)
    u = rng.normal(size=(6000, 2))
    y0 = simulate_ss(A, B, C, D, u)
    y = y0 + 0.01 * y0.std(axis=0) * rng.standard_normal(y0.shape)
    res = n4sid(as_recording(u, y), ["u0", "u1"], ["y0", "y1", "y2"], 4, decimate=1)
    sys_ = res.system
    # eigenvalues
    est = np.sort(np.linalg.eigvals(sys_.A).real)
    assert np.allclose(est, np.sort(lam), atol=0.01)
    assert np.abs(np.linalg.eigvals(sys_.A).imag).max() < 1e-6
    # DC gain C (I − A)^{-1} B
    dc_true = C @ np.linalg.solve(np.eye(4) - A, B)
    dc_est = sys_.C @ np.linalg.solve(np.eye(4) - sys_.A, sys_.B)
    assert np.linalg.norm(dc_est - dc_true) / np.linalg.norm(dc_true) < 0.02
    # impulse response (Markov parameters C A^k B), 40 samples
    h_true, h_est = markov(A, B, C, 40), markov(sys_.A, sys_.B, sys_.C, 40)
    assert np.linalg.norm(h_est - h_true) / np.linalg.norm(h_true) < 0.03
    # the singular values reveal the order
    s = res.decomposition.singular_values
    assert s[3] / s[4] > 20 and res.decomposition.suggest_order(range(1, 9)) == 4
    assert res.fit.metrics["train"]["mnrmse"] > 0.98


def test_slow_plant_at_1hz_is_recovered_exactly_through_decimation():
    # continuous 3-node thermal chain, time constants of about 10 min to 2 h, sampled at 1 s
    Ac = np.array(
        [[-1 / 600, 1 / 1200, 0.0], [1 / 2400, -1 / 1800, 1 / 3600], [0, 1 / 7200, -1 / 5000]]
    )
    Bc = np.array([[1 / 600, 0.0], [0.0, 0.0], [0.0, 1 / 5000]])
    C = np.eye(3)
    A, B = c2d_zoh(Ac, Bc, 1.0)
    rng = np.random.default_rng(3)
    u = np.repeat(rng.uniform(0, 1, size=(700, 2)), 120, axis=0)  # switching every 2 min
    y = simulate_ss(A, B, C, np.zeros((3, 2)), u)
    rec = as_recording(u, y)
    res = n4sid(rec, ["u0", "u1"], ["y0", "y1", "y2"], 3, decimate=40)  # 120 s is 3 blocks
    Ac_est = d2c_zoh(res.system.A, res.system.B, 1.0)[0]
    assert np.allclose(
        np.sort(np.linalg.eigvals(Ac_est).real), np.sort(np.linalg.eigvals(Ac).real), rtol=1e-6
    )
    assert res.fit.metrics["train"]["mnrmse"] == pytest.approx(1.0, abs=1e-8)
    assert res.fit.settings["decimate"] == 40 and res.system.dt == 1.0
    # automatic decimation: ~200 samples per dominant time constant; inputs no longer switch
    # exactly on the coarse grid, the model is still essentially exact
    auto = n4sid(rec, ["u0", "u1"], ["y0", "y1", "y2"], 3)
    assert auto.decomposition.decimate > 10
    assert auto.fit.metrics["train"]["mnrmse"] > 0.999


def test_initial_state_is_estimated():
    A, B, C, D, _ = known_system(1)
    rng = np.random.default_rng(0)
    u = rng.normal(size=(3000, 2))
    y = simulate_ss(A, B, C, D, u, x0=np.array([5.0, -3.0, 2.0, 1.0]))
    rec = as_recording(u, y)
    res = n4sid(rec, ["u0", "u1"], ["y0", "y1", "y2"], 4, decimate=1, x0="estimate")
    assert res.fit.metrics["train"]["mnrmse"] == pytest.approx(1.0, abs=1e-6)
    assert len(res.fit.arrays["x0_train"]) == 1
    zero = n4sid(rec, ["u0", "u1"], ["y0", "y1", "y2"], 4, decimate=1, x0="zero")
    assert predict_fit(zero.fit, rec, x0="zero").shape == (3000, 3)
    assert np.allclose(predict_fit(res.fit, rec), y, atol=1e-5)


def test_innovation_form_kalman_gain_improves_one_step_prediction():
    A, B, C, _, _ = known_system(2)
    rng = np.random.default_rng(4)
    N = 6000
    u = rng.normal(size=(N, 2))
    K = 0.3 * rng.normal(size=(4, 3))
    e = 0.3 * rng.standard_normal((N, 3))
    x = np.zeros(4)
    y = np.empty((N, 3))
    for k in range(N):  # innovation form (3): x+ = A x + B u + K e, y = C x + e
        y[k] = C @ x + e[k]
        x = A @ x + B @ u[k] + K @ e[k]
    res = n4sid(as_recording(u, y), ["u0", "u1"], ["y0", "y1", "y2"], 4, decimate=1)
    model = res.fit.build_model()
    assert isinstance(model, StateSpaceModel) and model.has_K
    mats = model.matrices()
    assert np.abs(np.linalg.eigvals(mats.A[0] - mats.K[0] @ mats.C[0])).max() < 1.0
    one_step = model.predict(y, u)[0]
    simulated = model.simulate(u, 1.0).outputs[0]
    assert np.var(y - one_step) < 0.6 * np.var(y - simulated)
    assert np.var(y - one_step) < 1.3 * 0.3**2  # close to the innovation variance
    assert res.fit.settings["noise_model_status"] == "ok"


def test_chunked_accumulation_equals_one_pass_and_streaming_decomposition():
    rng = np.random.default_rng(8)
    u, y = rng.normal(size=(2000, 1)), rng.normal(size=(2000, 2))
    one = HankelAccumulator(1, 2, 4, chunk=100000)
    one.add(u, y)
    many = HankelAccumulator(1, 2, 4, chunk=37)
    for k in range(0, 2000, 113):  # uneven chunks of one experiment
        many.add(u[k : k + 113], y[k : k + 113])
    R1, R2 = one.r_factor(), many.r_factor()
    assert one.n_columns == many.n_columns == 2000 - 7
    assert np.allclose(R1.T @ R1, R2.T @ R2, rtol=1e-10, atol=1e-8)
    # experiments never share a Hankel column
    two = HankelAccumulator(1, 2, 4)
    two.add(u[:1000], y[:1000])
    two.end_experiment()
    two.add(u[1000:], y[1000:])
    assert two.n_columns == 2 * (1000 - 7) and two.n_experiments == 2
    # a streamed decomposition has the batch one's singular values
    A, B, C, D, _ = known_system(3)
    uu = rng.normal(size=(4000, 2))
    yy = simulate_ss(A, B, C, D, uu)
    acc = HankelAccumulator(2, 3, 6, chunk=500)
    for k in range(0, 4000, 1000):
        acc.add(uu[k : k + 1000], yy[k : k + 1000])
    streamed = decomposition_from_accumulator(acc, 1.0)
    batch = n4sid_decompose([uu], [yy], 1.0, horizon=6, decimate=1, scale=False)
    assert np.allclose(streamed.singular_values, batch.singular_values, rtol=1e-8)
    sys_ = streamed.system(4, bd="subspace")
    assert np.allclose(np.sort(np.linalg.eigvals(sys_.A).real), [0.5, 0.7, 0.85, 0.95], atol=1e-6)
    with pytest.raises(ConfigError, match="subspace"):
        streamed.system(4)  # regression needs the data


def test_unstable_eigenvalues_are_mirrored_into_the_unit_circle():
    rng = np.random.default_rng(0)
    Q = np.linalg.qr(rng.normal(size=(4, 4)))[0]
    T = np.array([[1.2, 0.3, 0.1, 0.0], [0.0, 0.5, 0.2, 0.1], [0, 0, 0.0, -1.1], [0, 0, 1.1, 0.0]])
    A = Q @ T @ Q.T  # eigenvalues 1.2, 0.5, ±1.1j
    B = _mirror_schur(A, 1.0 - 1e-9, positive=False)
    lam = np.sort(np.abs(np.linalg.eigvals(B)))
    assert np.allclose(lam, np.sort([1 / 1.2, 0.5, 1 / 1.1, 1 / 1.1]))
    stable = Q @ np.diag([0.9, 0.5, -0.3, 0.2]) @ Q.T
    assert _mirror_schur(stable, 1.0 - 1e-9, positive=False) is stable
    assert np.all(np.linalg.eigvals(_mirror_schur(stable, 1.0, positive=True)).real > 0)


def test_decimate_data_block_means():
    u = np.arange(7.0)[:, None]
    ur, yr = decimate_data(u, 2 * u, 3)
    assert ur[:, 0].tolist() == [1.0, 4.0] and yr[:, 0].tolist() == [2.0, 8.0]


def test_clear_errors_for_bad_recordings():
    rng = np.random.default_rng(1)
    u, y = rng.normal(size=(30, 1)), rng.normal(size=(30, 2))
    short = as_recording(u, y)
    with pytest.raises(IdentificationError, match=r"Hankel columns|needs at least"):
        n4sid(short, ["u0"], ["y0", "y1"], 2, decimate=1)
    u, y = rng.normal(size=(500, 1)), rng.normal(size=(500, 2))
    rec = as_recording(u, y)
    with pytest.raises(IdentificationError, match="horizon"):
        n4sid(rec, ["u0"], ["y0", "y1"], 40, horizon=5, decimate=1)
    const = as_recording(np.ones((500, 1)), y)
    with pytest.raises(IdentificationError, match="constant"):
        n4sid(const, ["u0"], ["y0", "y1"], 2)
    y_nan = y.copy()
    y_nan[:, 1] = np.nan
    with pytest.raises(RecordingError, match="y1"):
        n4sid(as_recording(u, y_nan), ["u0"], ["y0", "y1"], 2)
    with pytest.raises(ConfigError, match="weighting"):
        n4sid(rec, ["u0"], ["y0", "y1"], 2, weighting="pca")


@pytest.mark.parametrize("weighting", ["moesp", "cva", "n4sid"])
def test_weightings_agree_on_noise_free_data(weighting):
    A, B, C, D, lam = known_system(6)
    u = np.random.default_rng(2).normal(size=(2000, 2))
    y = simulate_ss(A, B, C, D, u)
    dec = n4sid_decompose([u], [y], 1.0, decimate=1, weighting=weighting)
    assert np.allclose(np.sort(np.linalg.eigvals(dec.system(4).A).real), np.sort(lam), atol=1e-8)


def test_cli_identify_n4sid_with_cross_validated_order(tmp_path, capsys):
    A, B, C, D, _ = known_system(7)
    rng = np.random.default_rng(9)
    paths = []
    for k in range(2):
        u = rng.normal(size=(1500, 2))
        y = simulate_ss(A, B, C, D, u) + 0.01 * rng.standard_normal((1500, 3))
        paths.append(tmp_path / f"run{k}.csv")
        write_recording(as_recording(u, y, eid=f"run{k}"), paths[-1])
    out = tmp_path / "ss.json"
    rc = cli_main(
        [
            "identify",
            "n4sid",
            *map(str, paths),
            "--inputs",
            "u0,u1",
            "--outputs",
            "y0,y1,y2",
            "--orders",
            "1:6",
            "--folds",
            "2",
            "--decimate",
            "1",
            "--out",
            str(out),
            "--plots",
            str(tmp_path / "figs"),
        ]
    )
    assert rc == 0
    fit = FitResult.load(out)
    cv = fit.settings["cross_validation"]
    # one rule everywhere: the smallest order within the tolerance of the best VA
    va = np.array(cv["VA"])
    within = [n for n, v in zip(cv["orders"], va, strict=True) if v >= va.max() - 1e-3]
    assert fit.model == "ss" and fit.settings["order"] == min(within) >= 3
    assert cv["parsimonious_order"] == fit.settings["order"] and len(cv["VA"]) == 6
    if len(within) >= 3:  # and the flat curve is said
        assert "flat_cv" in {w["code"] for w in fit.warnings}
    assert (tmp_path / "figs" / "order_cv.png").exists()
    assert (tmp_path / "figs" / "singular_values.png").exists()
    assert "2-fold cross-validation" in capsys.readouterr().out
