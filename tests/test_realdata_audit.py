"""Issue 16 audit: every linear family through every path, and the warnings of the PEM commands.

A plant known exactly (a first-order discrete lag sitting at 20 °C, started at
rest) is identified by the polynomial and SOPDT families; simulate, compare
and the Python prediction must then agree with each other and with the
plant, about the fit's operating point. The prediction-error commands must
warn, as the FOPTD and N4SID ones do, on cases made to trigger each warning.
"""

from __future__ import annotations

import re

import numpy as np
import pytest
from scipy.signal import lfilter

from thermogym.cli import main as cli_main
from thermogym.fitresult import FitResult
from thermogym.identification.advice import structure_warnings
from thermogym.identification.compare import compare
from thermogym.identification.linear_fit import predict
from thermogym.identification.metrics import nrmse
from thermogym.models.process import SOPDTModel
from thermogym.recording import Recording, read_recording, write_recording

Y_REST = 20.0  # °C: the plant's output at rest


def lag_recording(
    seed: int, n: int = 300, delay: int = 1, y_start: float = 0.0, gain_sign: float = 1.0
) -> Recording:
    """``y = 20 + 0.5 q^-delay / (1 − 0.9 q^-1) u``, heater steps from 0 W, noise-free.

    ``y_start`` adds an initial deviation decaying with the plant's pole (a
    record that does not start at rest).
    """
    rng = np.random.default_rng(seed)
    u = np.r_[0.0, np.repeat(rng.uniform(0.0, 10.0, n // 20), 20)][:n]
    b = np.r_[np.zeros(delay), 0.5 * gain_sign]
    y = Y_REST + lfilter(b, [1.0, -0.9], u) + y_start * 0.9 ** np.arange(n)
    return Recording(
        np.arange(float(n)),
        {"P": u, "T": y},
        units={"P": "W", "T": "°C"},
        roles={"P": "input", "T": "output"},
        experiment_id=f"lag{seed}",
    )


def identify(tmp_path, method: str, rec: Recording, *extra: str) -> FitResult:
    write_recording(rec, tmp_path / "train.csv")
    out = tmp_path / f"{method}.json"
    argv = ["identify", method, str(tmp_path / "train.csv"), "--inputs", "P", "--outputs", "T"]
    assert cli_main([*argv, "--out", str(out), *extra]) == 0
    return FitResult.load(out)


@pytest.mark.parametrize(
    ("method", "orders"),
    [
        ("arx", ["--na", "1", "--nb", "1", "--nk", "1"]),
        ("oe", ["--nb", "1", "--nf", "1", "--nk", "1"]),
        ("sopdt", []),
    ],
)
def test_every_linear_family_is_simulated_about_its_operating_point(tmp_path, capsys, method,
                                                                    orders):  # fmt: skip
    fit = identify(tmp_path, method, lag_recording(1), "--operating-point", "rest", *orders)
    assert fit.settings["operating_point"]["outputs"]["T"] == pytest.approx(Y_REST)
    rec = lag_recording(2)  # a new run of the plant, from rest
    write_recording(rec, tmp_path / "new.csv")
    tol = 0.02 if method != "sopdt" else 0.5  # the polynomials are the plant exactly
    for x0 in ("estimate", "steady", "zero"):
        ref = predict(fit, rec, x0=x0).outputs[:, 0]
        sim_path = tmp_path / f"sim_{x0}.csv"
        argv = ["simulate", "--params", str(tmp_path / f"{method}.json"), "--inputs",
                str(tmp_path / "new.csv"), "--out", str(sim_path), "--x0", x0]  # fmt: skip
        assert cli_main(argv) == 0
        assert f"initial state: {x0}" in capsys.readouterr().out
        np.testing.assert_allclose(read_recording(sim_path)["T"], ref, atol=1e-9)
        cmp = compare([fit], rec, x0=x0)
        np.testing.assert_allclose(cmp.models[0].outputs["T"], ref, atol=1e-9)
        # about 20 °C, not about zero: the plant itself
        assert np.abs(ref - rec["T"]).max() < tol
    # a run that starts 4 K above rest, about the fit's operating point: the estimated
    # initial state follows the start, zero starts at rest
    away = lag_recording(3, y_start=4.0)
    est = predict(fit, away, x0="estimate", operating="fit").outputs[:, 0]
    zero = predict(fit, away, x0="zero", operating="fit").outputs[:, 0]
    assert zero[0] == pytest.approx(Y_REST, abs=1e-9) and abs(est[0] - away["T"][0]) < 0.5
    if method != "sopdt":
        assert nrmse(away["T"], est) > 0.999 > nrmse(away["T"], zero)


def codes(fit: FitResult) -> set[str]:
    return {w["code"] for w in fit.warnings}


def test_pem_commands_warn_about_a_delay_at_the_edge_and_a_flat_curve(tmp_path, capsys):
    # true delay 4 samples, only 0..2 searched: the delay is at the edge
    fit = identify(tmp_path, "arx", lag_recording(3, delay=4), "--operating-point", "rest",
                   "--max-delay", "2", "--max-order", "1")  # fmt: skip
    assert codes(fit) == {"order_at_edge"}
    assert "delay 2 samples is the largest searched (0..2)" in capsys.readouterr().err
    # searched wide enough: the true delay, no warning
    fit = identify(tmp_path, "arx", lag_recording(3, delay=4), "--operating-point", "rest",
                   "--max-delay", "6", "--max-order", "1")  # fmt: skip
    assert fit.settings["orders"]["nk"] == [[4]] and codes(fit) == set()
    # every ARX order from 1 fits the noise-free first-order plant: a flat curve, order 1
    fit = identify(tmp_path, "arx", lag_recording(3), "--operating-point", "rest",
                   "--max-delay", "3", "--max-order", "4")  # fmt: skip
    assert codes(fit) == {"flat_cv"} and fit.settings["orders"]["na"] == [1]
    assert "the cross-validation curve is flat" in capsys.readouterr().err


def test_pem_commands_warn_about_a_gain_against_the_physics(tmp_path, capsys):
    # a "heater" whose data say it cools: the units (W on °C) say it must heat
    fit = identify(tmp_path, "oe", lag_recording(4, gain_sign=-1.0), "--operating-point",
                   "rest", "--nb", "1", "--nf", "1", "--nk", "1")  # fmt: skip
    assert codes(fit) == {"gain_sign"}
    assert "must be positive" in capsys.readouterr().err
    # declared the other way round: no warning
    oe = ["--nb", "1", "--nf", "1", "--nk", "1", "--operating-point", "rest"]
    fit = identify(tmp_path, "oe", lag_recording(4, gain_sign=-1.0), *oe, "--expect-sign", "P=-")
    assert "gain_sign" not in codes(fit)


def test_pem_commands_warn_when_the_cross_validated_fit_is_below_zero(tmp_path, capsys):
    # the heater's gain changes sign halfway: a model of either half predicts the other
    # worse than its mean
    up, down = lag_recording(5, n=200), lag_recording(6, n=200, gain_sign=-1.0)
    rec = Recording(np.arange(400.0), {c: np.r_[up[c], down[c]] for c in ("P", "T")},
                    units=dict(up.units), roles=dict(up.roles), experiment_id="flip")  # fmt: skip
    fit = identify(tmp_path, "arx", rec, "--operating-point", "rest", "--max-order", "2",
                   "--max-delay", "2", "--expect-sign", "none")  # fmt: skip
    assert "fit_below_zero" in codes(fit)  # (the search's edges are warned about too)
    assert "cross-validated fit of the chosen orders is -" in capsys.readouterr().err


def test_sopdt_structure_warnings_on_made_fits():
    model = SOPDTModel(["P"], ["T"], K=0.5, T1=5.0e4, T2=10.0, tau=30.0)
    fit = FitResult.from_model(model, method="sopdt", settings={"max_delay_s": 30.0})
    w = structure_warnings(fit, record_s=1000.0)
    assert {x.code for x in w} == {"order_at_edge", "time_constant_bound"}
    assert any("T1_T" in x.message for x in w) and any("tau_T" in x.message for x in w)
    # a settled record and a delay inside its range: nothing
    model = SOPDTModel(["P"], ["T"], K=0.5, T1=50.0, T2=10.0, tau=3.0)
    fit = FitResult.from_model(model, method="sopdt", settings={"max_delay_s": 30.0})
    assert structure_warnings(fit, record_s=1000.0) == []


def test_n4sid_about_the_rest_judges_each_fold_about_its_recordings_rest(tmp_path, capsys):
    # the second half of a run that starts at rest does not itself start at rest: judged
    # about its own first sample the exact first-order model would look poor
    rec = lag_recording(7, n=400)
    fit = identify(tmp_path, "n4sid", rec, "--operating-point", "rest", "--folds", "2",
                   "--orders", "1:3", "--decimate", "1")  # fmt: skip
    assert fit.settings["operating_point"]["mode"] == "rest"
    assert fit.settings["operating_point"]["outputs"]["T"] == pytest.approx(Y_REST)
    cv = fit.settings["cross_validation"]
    assert cv["parsimonious_order"] == 1 and min(cv["VA"]) > 0.99
    assert fit.metrics["train"]["mnrmse"] > 0.999


def test_n4sid_warns_when_the_cross_validated_fit_is_below_zero(tmp_path, capsys):
    up, down = lag_recording(5, n=200), lag_recording(6, n=200, gain_sign=-1.0)
    rec = Recording(np.arange(400.0), {c: np.r_[up[c], down[c]] for c in ("P", "T")},
                    units=dict(up.units), roles=dict(up.roles), experiment_id="flip")  # fmt: skip
    fit = identify(tmp_path, "n4sid", rec, "--operating-point", "rest", "--folds", "2",
                   "--orders", "1:2", "--decimate", "1", "--expect-sign", "none")  # fmt: skip
    assert "fit_below_zero" in codes(fit)
    assert "cross-validated fit of the chosen order is -" in capsys.readouterr().err


def readme_dataset_commands() -> list[str]:
    """The example commands of the README's table of shipped real data sets."""
    from pathlib import Path

    text = (Path(__file__).resolve().parents[1] / "README.md").read_text()
    block = text.split("### Shipped real data sets", 1)[1].split("###", 1)[0]
    return re.findall(r"`thermogym (identify [^`]+)`", block)


@pytest.mark.slow
@pytest.mark.parametrize("command", readme_dataset_commands())
def test_readme_dataset_commands_run_and_validate(tmp_path, capsys, command):
    import shlex

    argv = [a.replace("fits/", f"{tmp_path}/") for a in shlex.split(command)]
    assert cli_main(argv) == 0
    fit = FitResult.load(argv[argv.index("--out") + 1])
    assert fit.metrics["train"]["mnrmse"] > 0 and "fit_below_zero" not in codes(fit)
    if "--validate" in argv:  # the TCLab rows: from rest, as the README says, not the mean
        assert fit.settings["operating_point"]["mode"] == "rest"
        i = argv.index("--operating-point") + 1
        assert cli_main([*argv[:i], "mean", *argv[i + 1 :]]) == 0
        mean = FitResult.load(argv[argv.index("--out") + 1])
        gain = fit.metrics["validation"]["mnrmse"] - mean.metrics["validation"]["mnrmse"]
        assert gain > 0.05


def test_identified_plant_env_from_an_n4sid_fit_reproduces_the_plants_step_response(tmp_path):
    import gymnasium as gym

    from thermogym.models.linear import StateSpaceModel

    A = np.array([[0.95, 0.03], [0.0, 0.8]])
    B = np.array([[0.05], [0.2]])
    C = np.array([[1.0, 0.0], [0.3, 1.0]])
    true = StateSpaceModel.from_matrices(A, B, C, dt=10.0, y_op=[Y_REST, 25.0])
    rng = np.random.default_rng(8)
    u = np.r_[0.0, np.repeat(rng.uniform(0.0, 10.0, 40), 20)][:800]
    y = true.simulate(u[:, None], 10.0).outputs[0]
    rec = Recording(10.0 * np.arange(800), {"P": u, "T1": y[:, 0], "T2": y[:, 1]},
                    units={"P": "W", "T1": "°C", "T2": "°C"})  # fmt: skip
    write_recording(rec, tmp_path / "run.csv")
    out = tmp_path / "ss.json"
    argv = ["identify", "n4sid", str(tmp_path / "run.csv"), "--inputs", "P", "--outputs",
            "T1,T2", "--order", "2", "--decimate", "1", "--operating-point", "rest",
            "--out", str(out)]  # fmt: skip
    assert cli_main(argv) == 0
    fit = FitResult.load(out)
    lo, hi = fit.settings["signal_ranges"]["P"]  # recorded: the env scales by them
    assert lo == 0.0 and hi == pytest.approx(u.max())
    env = gym.make("thermogym/IdentifiedPlant-v0", params=str(out), episode_steps=200)
    env.reset(seed=0)
    got = []
    for _ in range(150):
        env.step(np.ones(1, dtype=np.float32))  # the top of the recorded range
        got.append([env.unwrapped.true_outputs()[c] for c in ("T1", "T2")])
    step = true.simulate(np.full((151, 1), hi), 10.0).outputs[0][1:]  # from rest
    np.testing.assert_allclose(got, step, atol=1e-3)


@pytest.mark.parametrize("method", ["foptd", "sopdt", "n4sid"])
def test_every_identify_method_gives_a_fit_the_env_takes_as_it_is(tmp_path, method):
    import gymnasium as gym
    from gymnasium.utils.env_checker import check_env

    extra = ["--order", "1", "--decimate", "1"] if method == "n4sid" else []
    fit = identify(tmp_path, method, lag_recording(9), "--operating-point", "rest", *extra)
    lo, hi = fit.settings["signal_ranges"]["P"]
    assert lo == 0.0 and hi > 5.0
    env = gym.make("thermogym/IdentifiedPlant-v0", params=fit)  # no range, no period given
    check_env(env.unwrapped)
    assert env.unwrapped.dt == pytest.approx(1.0)  # the recording's period


@pytest.mark.parametrize(
    ("method", "extra", "match"),
    [
        ("auto", ["--families", "arx,foo"], "--families: unknown family(s) ['foo']"),
        ("auto", ["--families", ","], "--families"),
        ("arx", ["--expect-sign", "P=up"], "--expect-sign 'P=up'"),
        ("sopdt", ["--expect-sign", "P:T:x=+"], "--expect-sign"),
        ("ssest", ["--orders", "0:3"], "--orders '0:3'"),
        ("ssest", ["--input-delay", "1,2"], "--input-delay"),
        ("n4sid", ["--operating-point", "bogus"], "--operating-point"),
        ("oe", ["--max-delay", "-1"], "--max-delay"),
        # a declared sign for a name the fit does not have would check nothing, silently
        ("foptd", ["--expect-sign", "Q=+"], "--expect-sign Q: not an input"),
        ("n4sid", ["--expect-sign", "P=+,P:T_x=-"], "--expect-sign P:T_x: not an input"),
        ("arx", ["--na", "1", "--nb", "1", "--nk", "1", "--expect-sign", "heater=+"], "['P']"),
    ],
)
def test_bad_values_of_the_new_options_are_named(tmp_path, capsys, method, extra, match):
    write_recording(lag_recording(10, n=100), tmp_path / "run.csv")
    argv = ["identify", method, str(tmp_path / "run.csv"), "--inputs", "P", "--outputs", "T",
            "--out", str(tmp_path / "fit.json"), *extra]  # fmt: skip
    assert cli_main(argv) == 2
    err = capsys.readouterr().err
    assert match in err and err.count("\n") == 1
    assert not (tmp_path / "fit.json").exists()


def test_n4sid_about_the_rest_takes_a_step_test_logged_from_the_step_on(tmp_path, capsys):
    # a step test logged from the step on (the heater on throughout, TCLab's step run): about
    # the rest the input is a step from zero, as foptd, sopdt and arx take it; with --folds the
    # halves hold no input move, so the order comes from the singular values and it says so
    rec = lag_recording(8, n=300)
    held = Recording(rec.time, {"P": np.full(300, 6.0), "T": Y_REST + lfilter([0, 3.0], [1, -0.9],
                     np.ones(300))}, units=dict(rec.units), roles=dict(rec.roles),
                     experiment_id="step")  # fmt: skip
    fit = identify(tmp_path, "n4sid", held, "--operating-point", "rest", "--folds", "2",
                   "--orders", "1:3", "--decimate", "1")  # fmt: skip
    assert fit.settings["operating_point"]["mode"] == "rest"
    assert "cv_fallback" in codes(fit)
    assert "do not move in two separate parts" in capsys.readouterr().err
    assert fit.metrics["train"]["mnrmse"] > 0.99


def test_hair_dryer_arx_warns_that_the_best_order_is_at_the_edge(tmp_path, capsys):
    # the cross-validation curve rises to the last order searched (10) while the rule takes
    # 9, within 0.1 % of it: the range may be too small, even though 9 is not at the edge
    out = tmp_path / "arx.json"
    assert cli_main(["identify", "arx", "dataset:hair_dryer", "--out", str(out)]) == 0
    fit = FitResult.load(out)
    cv = fit.settings["cross_validation"]
    assert cv["chosen_order"] < len(cv["order_scores"]) == int(np.argmax(cv["order_scores"])) + 1
    assert "order_at_edge" in codes(fit)
    err = capsys.readouterr().err
    assert "the best cross-validated order is 10, the largest searched (1..10" in err
    assert "the range may be too small" in err


def test_ssest_stopped_at_its_evaluation_limit_is_a_warning_not_plain_text(tmp_path, capsys):
    out = tmp_path / "ssest.json"
    assert cli_main(["identify", "ssest", "dataset:hair_dryer", "--out", str(out)]) == 0
    std = capsys.readouterr()
    fit = FitResult.load(out)
    assert fit.settings["evaluation_limit_reached"] is True
    assert "not_converged" in codes(fit)
    assert "warning: the prediction-error refinement stopped at its limit of 40" in std.err
    assert "maximum number of function evaluations" not in std.out + std.err
    assert "refinement: stopped after 40 evaluations (see the warning)" in std.out
