"""Operating point and initial state through every path that simulates a fit.

A state-space fit identified about an operating point (inputs around 5, an
output 18 K above zero) must give the same prediction wherever it is used:
the identification metrics, ``thermogym simulate``, ``thermogym compare``,
the virtual sensor and the firmware's equations. The firmware check re-states
the C observer's equations (``thermogym/firmware/codegen.py`` docstring)
independently of the Python observer.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from thermogym.cli import main as cli_main
from thermogym.errors import ConfigError
from thermogym.fitresult import FitResult
from thermogym.identification.compare import compare, resid
from thermogym.identification.linear_fit import evaluate_fit, predict
from thermogym.identification.metrics import nrmse
from thermogym.models.linear import StateSpaceModel
from thermogym.recording import Recording, read_recording, write_recording

A = np.array([[0.95, 0.03], [0.0, 0.8]])
B = np.array([[0.05], [0.2]])
C = np.array([[1.0, 0.0], [0.3, 1.0]])
U_OP, Y_OP = np.array([5.0]), np.array([18.0, 21.0])


def plant_recording(seed: int, x0=(0.0, 0.0), n: int = 600) -> Recording:
    """The plant about (U_OP, Y_OP), a piecewise-constant input, started at x0."""
    rng = np.random.default_rng(seed)
    u = U_OP + np.repeat(rng.uniform(-2, 2, n // 20), 20)[:, None]
    m = StateSpaceModel.from_matrices(A, B, C, dt=10.0, u_op=U_OP, y_op=Y_OP, inputs=["P"],
                                      outputs=["T_core", "T_surf"])  # fmt: skip
    y = m.simulate(u, 10.0, x0=list(x0)).outputs[0]
    return Recording(
        10.0 * np.arange(n),
        {"P": u[:, 0], "T_core": y[:, 0], "T_surf": y[:, 1]},
        units={"P": "W", "T_core": "°C", "T_surf": "°C"},
        roles={"P": "input", "T_core": "output", "T_surf": "output"},
        experiment_id=f"run{seed}",
    )


@pytest.fixture(scope="module")
def ss_fit() -> FitResult:
    """The plant itself as an ``ss`` FitResult with its operating point (no noise model)."""
    m = StateSpaceModel.from_matrices(A, B, C, dt=10.0, u_op=U_OP, y_op=Y_OP, inputs=["P"],
                                      outputs=["T_core", "T_surf"],
                                      units={"P": "W", "T_core": "°C", "T_surf": "°C"})  # fmt: skip
    return FitResult.from_model(m, method="test")


def test_identified_operating_point_is_stored_in_the_model(tmp_path):
    from thermogym.identification.n4sid import n4sid

    rec = plant_recording(1, n=1200)
    res = n4sid(rec, ["P"], ["T_core", "T_surf"], 2, decimate=1, operating_point_mode="mean")
    cfg = res.fit.model_config
    assert cfg["u_op"] == pytest.approx([float(np.mean(rec["P"]))])
    assert cfg["y_op"] == pytest.approx([float(np.mean(rec["T_core"])), np.mean(rec["T_surf"])])
    # the fit predicts its own data (noise-free, the right order) from the stored model alone
    p = predict(res.fit, rec)
    for j, c in enumerate(("T_core", "T_surf")):
        assert nrmse(rec[c], p.outputs[:, j]) > 0.95


def test_same_prediction_through_every_path(tmp_path, ss_fit, capsys):
    rec = plant_recording(2)
    path = ss_fit.save(tmp_path / "fit.json")
    write_recording(rec, tmp_path / "rec.csv")
    ref = predict(ss_fit, rec, x0="steady").outputs  # at rest at the first input
    # 1. identification metrics (x0 steady) are the fit of that prediction
    m = evaluate_fit(ss_fit, rec, x0="steady")["experiments"]["run2"]["nrmse"]
    assert m["T_core"] == pytest.approx(float(nrmse(rec["T_core"], ref[:, 0])), abs=1e-12)
    # 2. thermogym simulate
    assert cli_main(["simulate", "--params", str(path), "--inputs", str(tmp_path / "rec.csv"),
                     "--out", str(tmp_path / "sim.csv"), "--x0", "steady"]) == 0  # fmt: skip
    sim = read_recording(tmp_path / "sim.csv")
    np.testing.assert_allclose(sim["T_core"], ref[:, 0], atol=1e-9)
    assert "initial state: steady" in capsys.readouterr().out
    # 3. compare
    cmp = compare([path], rec, x0="steady")
    np.testing.assert_allclose(cmp.models[0].outputs["T_surf"], ref[:, 1], atol=1e-12)
    # 4. the virtual sensor with nothing measured is the model from its rest state
    from thermogym.firmware.codegen import firmware_model
    from thermogym.firmware.export import sensor_from_fit

    sensor, _ = sensor_from_fit(path)
    est = sensor.observe(np.asarray(rec["P"])[:, None])
    np.testing.assert_allclose(est["T_core"], ref[:, 0], atol=1e-9)
    np.testing.assert_allclose(est["T_surf"], ref[:, 1], atol=1e-9)
    # 5. the firmware's equations in its own coordinates (float64 here)
    fm = firmware_model(sensor.observer_matrices())
    u_off = np.array([c.offset for c in fm.u])
    u_sc = np.array([c.scale for c in fm.u])
    y_off = np.array([c.offset for c in fm.y])
    y_sc = np.array([c.scale for c in fm.y])
    us = (np.asarray(rec["P"])[:, None] - u_off) / u_sc
    xs = fm.Nu @ us[0]  # reset at rest: x_s = Nu u_s (no measured channel)
    out = np.empty((us.shape[0], len(fm.y)))
    for k in range(us.shape[0]):
        out[k] = y_off + y_sc * (fm.Ch @ xs + fm.Dh @ us[k])
        xs = xs + fm.M @ xs + fm.B @ us[k]  # x_s⁺ = x_s + (A − I) x_s + B u_s
    np.testing.assert_allclose(out, ref, atol=1e-8)


def test_an_old_fitresult_keeps_its_operating_point_in_the_settings(ss_fit):
    d = ss_fit.to_dict()
    cfg = dict(d["model_config"])
    u_op, y_op = cfg.pop("u_op"), cfg.pop("y_op")
    d["model_config"] = cfg
    d["settings"] = {
        "operating_point": {
            "mode": "mean",
            "inputs": {"P": u_op[0]},
            "outputs": {"T_core": y_op[0], "T_surf": y_op[1]},
        }
    }
    old = FitResult.from_dict(d)
    rec = plant_recording(3)
    np.testing.assert_allclose(
        predict(old, rec, x0="steady").outputs, predict(ss_fit, rec, x0="steady").outputs
    )


def test_x0_modes_on_a_recording_that_starts_away_from_rest(ss_fit):
    rec = plant_recording(4, x0=(30.0, -8.0))
    y = np.column_stack([rec["T_core"], rec["T_surf"]])
    est = predict(ss_fit, rec)  # auto: the outputs are there, estimate
    assert est.x0 == "estimate"
    np.testing.assert_allclose(est.state0, [30.0, -8.0], atol=1e-7)
    np.testing.assert_allclose(est.outputs, y, atol=1e-7)
    for mode in ("steady", "zero"):
        p = predict(ss_fit, rec, x0=mode)
        assert p.x0 == mode and np.abs(p.outputs[:5] - y[:5]).max() > 5.0
    # without the outputs there is nothing to estimate from: steady
    inputs_only = Recording(rec.time, {"P": rec["P"]})
    assert predict(ss_fit, inputs_only).x0 == "steady"


def test_firmware_refuses_an_operating_point_it_cannot_honour(tmp_path):
    from thermogym.firmware.export import sensor_from_fit

    integrating = StateSpaceModel.from_matrices(
        [[1.0, 0.0], [0.1, 0.9]], [[0.1], [0.0]], C, dt=10.0, u_op=[5.0], y_op=[18.0, 0.0]
    )
    path = FitResult.from_model(integrating).save(tmp_path / "int.json")
    with pytest.raises(ConfigError, match="operating point cannot be honoured"):
        sensor_from_fit(path)
    code = cli_main(["firmware", "export", str(path), "--out", str(tmp_path / "fw")])
    assert code == 2 and not (tmp_path / "fw").exists()


def test_compare_k_step_and_resid(tmp_path, ss_fit, capsys):
    rng = np.random.default_rng(5)
    rec = plant_recording(6)
    noisy = Recording(
        rec.time,
        {**{c: rec[c] for c in rec.columns}, "T_core": rec["T_core"] + 0.05 * rng.normal(size=600)},
        experiment_id="noisy",
    )
    c = compare([ss_fit], noisy, k_step=3)
    assert c.models[0].horizon is None or c.models[0].note  # no noise model: simulation
    assert "output-error" in c.models[0].note
    tests = resid(ss_fit, noisy, max_lag=20)
    # the model is the plant: residuals are the white noise, independent of the input
    assert tests["T_core"].p_white > 0.01 and tests["T_core"].p_independent["P"] > 0.01
    write_recording(noisy, tmp_path / "noisy.csv")
    fit_path = ss_fit.save(tmp_path / "fit.json")
    data = str(tmp_path / "noisy.csv")
    files = ["--plot", str(tmp_path / "r.png"), "--json", str(tmp_path / "r.json")]
    assert cli_main(["resid", str(fit_path), "--data", data, *files]) == 0
    assert (tmp_path / "r.png").stat().st_size > 1000
    doc = json.loads((tmp_path / "r.json").read_text())
    assert doc["T_core"]["whiteness"]["white"] is True
    assert cli_main(["compare", str(fit_path), str(fit_path), "--data",
                     str(tmp_path / "noisy.csv"), "--labels", "a,b",
                     "--plot", str(tmp_path / "c.png")]) == 0  # fmt: skip
    out = capsys.readouterr().out
    assert "a " in out and "b " in out and (tmp_path / "c.png").stat().st_size > 1000


@pytest.mark.parametrize(
    ("argv", "match"),
    [
        (["compare", "FIT", "--data", "DATA", "--k-step", "0"], "--k-step"),
        (["compare", "FIT", "--data", "DATA", "--labels", "a,b"], "--labels"),
        (["compare", "FIT", "--data", "DATA", "--json", "FIT"], "is also an input"),
        (["resid", "FIT", "--data", "DATA", "--alpha", "2"], "--alpha"),
        (["resid", "FIT", "--data", "DATA", "--max-lag", "0"], "--max-lag"),
        (["simulate", "axt211", "--inputs", "DATA", "--out", "OUT", "--x0", "zero"], "--x0"),
        (
            [
                "identify",
                "foptd",
                "DATA",
                "--inputs",
                "P",
                "--outputs",
                "T_core",
                "--out",
                "OUT",
                "--expect-sign",
                "P=up",
            ],
            "--expect-sign",
        ),
        (
            [
                "identify",
                "n4sid",
                "DATA",
                "--inputs",
                "P",
                "--outputs",
                "T_core",
                "--out",
                "OUT",
                "--cv-tolerance",
                "-1",
            ],
            "--cv-tolerance",
        ),
    ],
)
def test_bad_option_values_exit_2_with_a_clear_message(tmp_path, ss_fit, capsys, argv, match):
    write_recording(plant_recording(7, n=100), tmp_path / "data.csv")
    ss_fit.save(tmp_path / "fit.json")
    subs = {"FIT": str(tmp_path / "fit.json"), "DATA": str(tmp_path / "data.csv"),
            "OUT": str(tmp_path / "out.json")}  # fmt: skip
    if argv[0] == "simulate":
        from thermogym.models import AXT211

        write_recording(
            Recording(np.arange(5.0), {s.name: np.ones(5) for s in AXT211().exogenous}),
            tmp_path / "data.csv",
        )
        subs["OUT"] = str(tmp_path / "out.csv")
    assert cli_main([subs.get(a, a) for a in argv]) == 2
    assert match in capsys.readouterr().err


@pytest.mark.parametrize("argv", [["compare", "F", "--data", "D", "--x0", "fast"],
                                  ["resid", "F", "--data", "D", "--k-step", "x"]])  # fmt: skip
def test_bad_choices_are_refused_by_the_parser(argv, capsys):
    assert cli_main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and ("--x0" in err or "--k-step" in err)


def test_compare_takes_a_nonlinear_fit_too():
    from thermogym.models import AXT211

    model = AXT211()
    n = 300
    u = np.column_stack([np.r_[np.zeros(50), np.ones(n - 50)], np.full(n, 24.0), np.full(n, 25.0)])
    assert model.exogenous_names == ("u", "k_U", "T_U")
    sim = model.simulate(u, 1.0)
    cols = {c: u[:, i] for i, c in enumerate(model.exogenous_names)}
    cols |= {c: sim.outputs[0, :, j] for j, c in enumerate(model.output_names)}
    rec = Recording(np.arange(float(n)), cols, experiment_id="axt")
    fit = FitResult.from_model(model, method="nominal")
    c = compare([fit], rec, k_step=1)
    m = c.models[0]
    assert m.x0 == "model" and "no noise model" in m.note
    assert all(v == pytest.approx(1.0) for v in m.fits.values() if np.isfinite(v))
    with pytest.raises(ConfigError, match="applies to linear fits"):
        compare([fit], rec, x0="zero")


def test_controllers_linear_plant_takes_the_models_operating_point(ss_fit):
    from thermogym.controllers.linmodel import linear_plant
    from thermogym.models.linear import FOPTDModel

    lp = linear_plant(ss_fit)
    assert lp.u_op == pytest.approx(5.0) and lp.y_op.tolist() == pytest.approx([18.0, 21.0])
    fo = FOPTDModel(["P"], ["T"], K=2.0, T=100.0, tau=20.0, offsets=True, y0=20.0, u_op=[5.0])
    lp = linear_plant(FitResult.from_model(fo), dt=10.0)
    assert lp.u_op == pytest.approx(5.0) and lp.y_op.tolist() == pytest.approx([20.0])
    # the plant's steady state at u = 8 is the model's: y0 + K (8 − u_op)
    (G,) = lp.dc_gain()[:1]
    assert float(lp.y_op[0] + G[0, 0] * (8.0 - lp.u_op)) == pytest.approx(26.0)


@pytest.mark.parametrize("structure", ["arx", "armax", "bj"])
def test_k_step_prediction_of_a_polynomial_fit_uses_its_noise_model(structure):
    # ARX, ARMAX and BJ carry a noise model: their one-step prediction (MATLAB
    # compare(data, sys, 1)) leaves the innovations, not the simulation error
    from scipy.signal import lfilter

    from thermogym.models.polynomial import PolynomialModel

    rng = np.random.default_rng(7)
    n = 800
    u = np.repeat(rng.choice([-1.0, 1.0], n // 8), 8)
    e = 0.1 * rng.normal(size=n)
    if structure == "bj":
        m = PolynomialModel(["u"], ["y"], structure="bj", nb=1, nf=1, nc=1, nd=1, nk=1, dt=1.0)
        th = {"b0_y": 0.5, "f1_y": -0.8, "c1_y": 0.4, "d1_y": -0.9}
        y = lfilter([0, 0.5], [1, -0.8], u) + lfilter([1, 0.4], [1, -0.9], e)
    else:
        nc = 1 if structure == "armax" else 0
        m = PolynomialModel(["u"], ["y"], structure=structure, na=1, nb=1, nc=nc, nk=1, dt=1.0)
        th = {"a1_y": -0.8, "b0_y": 0.5} | ({"c1_y": 0.4} if nc else {})
        y = lfilter([0, 0.5], [1, -0.8], u) + lfilter([1, 0.4 if nc else 0.0], [1, -0.8], e)
    fit = FitResult.from_model(m, parameters=th, method="test")
    rec = Recording(np.arange(n, dtype=float), {"u": u, "y": y}, experiment_id="poly")
    one = compare([fit], rec, k_step=1, x0="zero").models[0]
    assert not one.note  # a noise model: no "output-error structure" note
    np.testing.assert_allclose(y - one.outputs["y"], e, atol=1e-9)  # the innovations
    sim = compare([fit], rec, x0="zero").models[0]
    assert one.fits["y"] > sim.fits["y"] + 0.02
    # the simulation is the deterministic part, whatever the horizon asked elsewhere
    np.testing.assert_allclose(sim.outputs["y"], lfilter([0, 0.5], [1, -0.8], u), atol=1e-9)
    # residual tests of the one-step errors: white, as the innovations are
    assert resid(fit, rec, k_step=1, x0="zero")["y"].p_white > 0.01
