"""The thermogym command line: models, experiment, simulate, demo."""

from __future__ import annotations

import json

import numpy as np

from thermogym.cli import main
from thermogym.models.registry import get_model
from thermogym.recording import read_recording


def test_models_json_lists_signals_and_parameters(capsys):
    assert main(["models", "--json"]) == 0
    data = {d["name"]: d for d in json.loads(capsys.readouterr().out)}
    for name in ("axt211", "spindle", "strut"):
        assert data[name]["signals"] and data[name]["parameters"]
    assert main(["models", "strut"]) == 0
    assert "r_motor" in capsys.readouterr().out


def test_experiment_then_simulate_round_trip(tmp_path, capsys):
    rec_dir = tmp_path / "rec"
    assert (
        main(
            [
                "experiment",
                "axt211",
                "steps",
                "--out",
                str(rec_dir),
                "--seed",
                "1",
                "--option",
                "voltages=[24.0]",
                "--option",
                "ambients=[25.0]",
            ]
        )
        == 0
    )
    src = rec_dir / "axt211-step-24V-25C.csv"
    assert src.exists() and (rec_dir / "manifest.json").exists()
    out = tmp_path / "sim.csv"
    assert (
        main(
            [
                "simulate",
                "axt211",
                "--inputs",
                str(src),
                "--out",
                str(out),
                "--set",
                "C_P=20",
                "--plot",
                str(tmp_path / "sim.png"),
            ]
        )
        == 0
    )
    printed = capsys.readouterr().out
    assert " fit " in printed and (tmp_path / "sim.png").exists()
    rec, sim = read_recording(src), read_recording(out)
    model = get_model("axt211")
    ref = model.simulate(rec.exogenous_array(model), rec.dt, {"C_P": 20.0})
    np.testing.assert_allclose(sim["x_V"], ref.output("x_V")[0], atol=1e-12)


def test_errors_exit_2_with_a_message_and_write_nothing(tmp_path, capsys):
    out = tmp_path / "sim.csv"
    rec = tmp_path / "r.csv"
    rec.write_text("time,u,k_U\n0,1,24\n1,1,24\n")
    assert main(["simulate", "axt211", "--inputs", str(rec), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "T_U" in err and "error" in err
    assert not out.exists()
    assert (
        main(["simulate", "axt211", "--inputs", str(rec), "--out", str(out), "--set", "C_P=abc"])
        == 2
    )
    assert "NAME=NUMBER" in capsys.readouterr().err
    assert (
        main(["experiment", "strut", "steps", "--out", str(tmp_path), "--effect", "gremlins"]) == 2
    )
    assert "vocabulary" in capsys.readouterr().err
    assert main(["experiment", "strut"]) == 2  # missing arguments: one line, no SystemExit
    assert "required: protocol, --out" in capsys.readouterr().err


def test_demo_quick_runs_and_writes_a_report(tmp_path):
    assert main(["demo", "--quick", "--out", str(tmp_path), "--only", "rigs"]) == 0
    report = (tmp_path / "report.md").read_text()
    assert "Virtual test rigs" in report and "FAILED" not in report
    for line in report.splitlines():
        if line.startswith("!["):
            assert (tmp_path / line.split("](")[1].rstrip(")")).exists()


def test_option_modules_write_out_the_library_values_they_show():
    # the options modules load without the library; the values they show must be its values
    from thermogym import demo
    from thermogym._cli import demo as demo_options
    from thermogym._cli import identify_linear
    from thermogym.identification.advice import DEFAULT_TOLERANCE
    from thermogym.identification.linear_fit import X0_CHOICES

    assert list(demo_options.STAGE_KEYS) == demo.stage_keys()
    assert identify_linear.X0_CHOICES == X0_CHOICES
    assert identify_linear.DEFAULT_TOLERANCE == DEFAULT_TOLERANCE
