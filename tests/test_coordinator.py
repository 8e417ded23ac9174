"""The identification coordinator: FitResults, recovery with confidence intervals, ratios, CLI."""

from __future__ import annotations

import json

import numpy as np
import pytest
from _model_plants import model_axt211_step, model_strut_steps

from thermogym.cli import main as cli
from thermogym.fitresult import FitResult
from thermogym.identification.coordinator import identify, run_identification
from thermogym.identification.problem import FreeParameter, Problem, RatioParameter
from thermogym.identification.simmodel import SimBatch
from thermogym.identification.uncertainty import estimate_input_noise
from thermogym.models.axt211 import AXT211
from thermogym.models.strut import StrutModel
from thermogym.recording import Recording, write_recording

SPECIMEN = {"r_motor": 1.6, "r_bearing": 0.7, "r_nut": 1.4, "r_spindle_air": 1.1, "r_tube_air": 0.9}
RATIOS = tuple(SPECIMEN)


@pytest.fixture(scope="module")
def strut_recs():
    # known ratios need a truth in the model class: the strut model's own step tests (the
    # strut rig is a plant of its own and has no ratio parameters)
    return model_strut_steps(seed=4, specimen=SPECIMEN, feed_rates=(20.0, 30.0))


def strut_problem(recs, **kw):
    outs = [
        "T_drive",
        "T_belt_housing",
        "T_bearing",
        "T_nut",
        "T_spindle",
        "T_tube_front",
        "T_tube_rear",
    ]
    return Problem(StrutModel(), recs, pairs=outs, free=list(RATIOS), fixed={"T_ref": 20.0}, **kw)


def test_known_ratios_recovered_from_noisy_rig_data_within_their_intervals(strut_recs):
    pb = strut_problem(strut_recs, objective="mse")  # start: every ratio 1 (paper 000)
    # the simulation is driven by the measured, noisy air temperature: its share counts too
    noise = estimate_input_noise(strut_recs, ["T_air"])
    assert noise["T_air"] == pytest.approx(0.05, rel=0.3)  # the rig's sensor
    res = run_identification(pb, "greybox", level=0.99, progress=False, input_noise=noise)
    assert res.stop_reason.startswith("converged")
    truth = np.array([SPECIMEN[n] for n in RATIOS])
    u = res.uncertainty
    assert u.contains(truth).all(), (res.x, u.lower, u.upper)
    # the intervals are informative: the heat sources to better than 5 %
    assert (u.stderr[:3] / truth[:3] < 0.05).all()
    # every interval also holds in the FitResult, with the covariance
    assert set(res.fit.stderr) == set(RATIOS)
    assert res.fit.covariance_names == list(RATIOS)


def test_fit_result_is_complete_and_round_trips(strut_recs, tmp_path):
    pb = strut_problem(strut_recs[:1])
    res = run_identification(
        pb, "cmaes", max_iter=40, seed=2, progress=False, validation=strut_recs[1:]
    )
    fit = res.fit
    assert fit.model == "strut" and fit.method == "coordinator:cmaes"
    assert fit.parameters["T_ref"] == 20.0 and "T_ref" in fit.fixed
    assert [d["role"] for d in fit.data] == ["train", "validation"]
    assert fit.metrics["train"]["criterion"] == pytest.approx(res.criterion)
    assert "strut-step-30" in fit.metrics["validation"]
    assert fit.settings["stop"]["max_iter"] == 40 and fit.settings["seed"] == 2
    path = fit.save(tmp_path / "fit.json")
    back = FitResult.load(path)
    assert back.fingerprint() == fit.fingerprint()
    np.testing.assert_allclose(back.theta(StrutModel())[0, :5], res.x)
    assert "criterion (eq 4)" in res.summary()
    hist = json.loads(res.save_history(tmp_path / "h.json").read_text())
    assert len(hist["history"]) == res.iterations


def test_identify_returns_the_fit_result(strut_recs):
    fit = identify(strut_problem(strut_recs[:1]), "montecarlo", n_samples=300, progress=False)
    assert isinstance(fit, FitResult) and fit.method == "coordinator:montecarlo"


def test_ratio_parameter_scales_its_physical_estimates():
    m = AXT211()
    u = np.zeros((2400, 3))
    u[:1200, 0] = 1.0
    u[:, 1], u[:, 2] = 24.0, 25.0
    true = m.theta({"C_P": 18.0 * 1.25, "C_G": 40.0 * 1.25})
    sim = m.simulate(u, 1.0, true)
    rec = Recording.from_simulation(sim, model=m, experiment_id="sim")
    pb = Problem(
        m,
        rec,
        pairs=["T_P", "T_G"],
        free=[],
        ratios=[RatioParameter("r_capacity", ("C_P", "C_G"), 0.5, 2.0)],
    )
    res = run_identification(pb, "greybox", progress=False)
    assert res.values["r_capacity"] == pytest.approx(1.25, rel=1e-6)
    assert res.fit.parameters["C_P"] == pytest.approx(22.5, rel=1e-6)
    assert res.fit.parameters["C_G"] == pytest.approx(50.0, rel=1e-6)
    assert res.fit.settings["ratios"]["r_capacity"]["targets"] == {"C_P": 18.0, "C_G": 40.0}
    assert res.fit.bounds["C_P"] == [9.0, 36.0]


class Toy:
    """An external-looking SimModel (no thermogym model behind it)."""

    name = "toy"
    version = "3"
    batched = True
    param_names = ("a", "b")
    nominal = np.array([1.0, 1.0])
    lower = np.array([0.0, 0.0])
    upper = np.array([5.0, 5.0])
    input_names = ("x",)
    output_names = ("y",)

    def config(self):
        return {"source": "test"}

    def simulate(self, theta, experiment):
        x = np.asarray(experiment["x"])
        th = np.atleast_2d(theta)
        y = th[:, :1] * x[None] + th[:, 1:2] * x[None] ** 2
        return SimBatch(y[:, :, None], [None] * th.shape[0])

    def close(self):
        pass


def test_external_sim_model_gets_a_fit_result():
    x = np.linspace(0, 2, 50)
    rec = Recording(np.arange(50.0), {"x": x, "y": 2.0 * x + 0.5 * x**2})
    res = run_identification(Problem(Toy(), rec), "evolution", seed=0, progress=False)
    np.testing.assert_allclose(res.x, [2.0, 0.5], rtol=1e-3)
    fit = res.fit
    assert (fit.model, fit.model_version, fit.model_config) == ("toy", "3", {"source": "test"})
    assert set(fit.stderr) == {"a", "b"}


def test_fixed_log_scaled_and_bounded_parameters_are_honoured():
    # a known C_G needs a truth in the model class: the AXT211 model's own step (the rig is
    # a plant of its own)
    recs = [model_axt211_step(24.0, 25.0, on_s=900, off_s=900, seed=0)]
    pb = Problem(
        AXT211(),
        recs,
        pairs=["T_G"],
        free=[FreeParameter("C_G", start=80.0, lower=20.0, upper=200.0, scale="log")],
        fixed={"lambda_GU": 0.11},
    )
    res = run_identification(pb, "greybox", progress=False)
    assert res.values["C_G"] == pytest.approx(40.0, rel=0.02)
    assert res.fit.parameters["lambda_GU"] == 0.11 and "lambda_GU" in res.fit.fixed


# ------------------------------------------------------------------------- CLI
@pytest.fixture(scope="module")
def strut_files(tmp_path_factory, strut_recs):
    d = tmp_path_factory.mktemp("strut")
    for r in strut_recs:
        write_recording(r, d / f"{r.experiment_id}.csv")
    return d


def test_cli_montecarlo_writes_a_fit(strut_files, tmp_path, capsys):
    out = tmp_path / "fit.json"
    rc = cli(
        [
            "identify",
            "montecarlo",
            "--model",
            "strut",
            str(strut_files / "strut-step-20.csv"),
            "--out",
            str(out),
            "--free",
            "r_motor",
            "--free",
            "r_nut=0.3:3:1",
            "--fix",
            "T_ref=20",
            "--pair",
            "T_drive",
            "--pair",
            "T_nut@2",
            "--samples",
            "300",
            "--no-progress",
            "--history",
            str(tmp_path / "h.json"),
        ]
    )
    assert rc == 0
    fit = FitResult.load(out)
    assert fit.settings["problem"]["pairs"][1] == {
        "measured": "T_nut",
        "simulated": "T_nut",
        "weight": 2.0,
    }
    assert set(fit.stderr) == {"r_motor", "r_nut"}
    assert "wrote" in capsys.readouterr().out


def test_cli_search_says_which_model_outputs_it_left_out(strut_recs, tmp_path, capsys):
    # a recording without one of the model's outputs: the default pairs leave it out; the
    # fit and the console say so (before, nothing told the fit was on part of the outputs)
    rec = strut_recs[0].drop("T_drive")
    write_recording(rec, tmp_path / "r.csv")
    out = tmp_path / "fit.json"
    argv = ["identify", "montecarlo", "--model", "strut", str(tmp_path / "r.csv"), "--free",
            "r_nut", "--samples", "20", "--no-progress", "--out", str(out)]  # fmt: skip
    assert cli(argv) == 0
    said = [ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("note:")]
    assert len(said) == 1 and "['T_drive']" in said[0] and "left out" in said[0]
    warned = [w for w in FitResult.load(out).warnings if w["code"] == "outputs_left_out"]
    assert len(warned) == 1 and "'T_nut'" in warned[0]["message"]
    assert cli([*argv, "--pair", "T_nut"]) == 0  # pairs named: nothing left out unasked
    assert "left out" not in capsys.readouterr().out


def test_cli_greybox_on_a_folder_and_refusals(strut_files, tmp_path, capsys):
    out = tmp_path / "fit.json"
    args = [
        "identify",
        "greybox",
        "--model",
        "strut",
        str(strut_files),
        "--out",
        str(out),
        "--free",
        "r_nut",
        "--free",
        "r_motor",
        "--fix",
        "T_ref=20",
        "--max-iter",
        "3",
        "--no-progress",
    ]
    assert cli(args) == 0
    before = out.read_text()
    assert cli([*args, "--no-overwrite"]) == 2  # the file exists: refused, untouched
    assert out.read_text() == before
    assert cli([*args[:-1], "--samples", "5"]) == 2
    err = capsys.readouterr().err
    assert "--samples does not apply to method 'greybox'" in err
    assert (
        cli(
            ["identify", "cmaes", "--model", "strut", str(tmp_path / "nope.csv"), "--out", str(out)]
        )
        == 2
    )
    assert "does not exist" in capsys.readouterr().err


def test_cli_external_model(tmp_path):
    pytest.importorskip("thermogym.identification.external")
    from thermogym.identification.external.examples import first_order_lag

    t = np.arange(0.0, 600.0, 5.0)
    u = np.where((t > 50) & (t < 300), 10.0, 0.0)
    y = first_order_lag(t, {"u": u}, {"K": 2.0, "tau": 60.0})["y"]
    write_recording(Recording(t, {"P_heater": u, "T_rise": y}), tmp_path / "d.csv")
    cfg = {
        "type": "callable",
        "callable": "thermogym.identification.external.examples:first_order_lag",
        "parameters": {
            "K": {"start": 1.0, "lower": 0.1, "upper": 10.0},
            "tau": {"start": 100.0, "lower": 5.0, "upper": 600.0},
        },
        "inputs": {"u": "P_heater"},
        "outputs": {"y": "T_rise"},
        "evaluation": {"backend": "serial"},
    }
    (tmp_path / "lag.json").write_text(json.dumps(cfg))
    out = tmp_path / "fit.json"
    rc = cli(
        [
            "identify",
            "greybox",
            "--external",
            str(tmp_path / "lag.json"),
            str(tmp_path / "d.csv"),
            "--out",
            str(out),
            "--no-progress",
        ]
    )
    assert rc == 0
    p = FitResult.load(out).parameters
    assert p["K"] == pytest.approx(2.0, rel=1e-5) and p["tau"] == pytest.approx(60.0, rel=1e-5)


def test_plots_are_written(strut_recs, tmp_path):
    from thermogym.identification.coordinator_plots import (
        plot_fit,
        plot_history,
        plot_identifiability,
        plot_samples,
    )

    pb = strut_problem(strut_recs[:1])
    mc = run_identification(pb, "montecarlo", n_samples=200, batch_size=50, progress=False)
    gb = run_identification(pb, "greybox", max_iter=5, progress=False)
    paths = [
        plot_history([mc, gb], tmp_path / "h.png"),
        plot_fit(gb, tmp_path / "f.png", experiments=strut_recs),
        plot_samples(mc, tmp_path / "s.png"),
        plot_identifiability(gb.identifiability, tmp_path / "i.png"),
    ]
    for p in paths:
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(ValueError, match="kept no samples"):
        plot_samples(gb, tmp_path / "x.png")


def test_cli_input_noise_widens_the_intervals(strut_files, tmp_path):
    base = [
        "identify",
        "greybox",
        "--model",
        "strut",
        str(strut_files),
        "--free",
        "r_nut",
        "--free",
        "r_motor",
        "--fix",
        "T_ref=20",
        "--no-progress",
        "--objective",
        "mse",
    ]
    assert cli([*base, "--out", str(tmp_path / "a.json")]) == 0
    assert cli([*base, "--out", str(tmp_path / "b.json"), "--input-noise", "T_air"]) == 0
    a, b = FitResult.load(tmp_path / "a.json"), FitResult.load(tmp_path / "b.json")
    assert b.stderr["r_nut"] > a.stderr["r_nut"]
    assert b.settings["input_noise"]["T_air"] == pytest.approx(0.05, rel=0.3)
