"""Diagnosing an identified state space: no numpy overflow warnings on the console.

The re-calibration of a sixth-order N4SID model of the hair dryer passes
through unstable trial parameter sets; their simulations overflow, which the
objective treats as a failed simulation (a large cost). That is expected and
must not reach the user as five ``RuntimeWarning`` lines.
"""

from __future__ import annotations

import json
import warnings

from thermogym import datasets
from thermogym.cli import main as cli_main
from thermogym.recording import write_recording


def test_diagnose_of_an_ss_fit_prints_no_overflow_warnings(tmp_path, capsys):
    fit = tmp_path / "dryer_ss.json"
    # the README's command: order 6 by 2-fold cross-validation
    argv = ["identify", "n4sid", "dataset:hair_dryer", "--folds", "2", "--out", str(fit)]
    assert cli_main(argv) == 0
    assert json.loads(fit.read_text())["model_config"]["n_states"] == 6
    rec = datasets.load("hair_dryer")
    t = rec.time
    write_recording(rec.slice(t[t.size // 2 + 1], None).replace(experiment_id="b"),
                    tmp_path / "b.csv")  # fmt: skip
    capsys.readouterr()
    out = tmp_path / "diag.json"
    held_out = str(tmp_path / "b.csv")
    argv = ["diagnose", "--model", "ss:6", "--params", str(fit), "--train",
            "dataset:hair_dryer", "--validate", held_out, "--out", str(out)]  # fmt: skip
    with warnings.catch_warnings():
        # as a user runs it: not the suite's filter that turns thermogym's RuntimeWarnings
        # into errors (which the failed-simulation path would swallow)
        warnings.simplefilter("always", RuntimeWarning)
        assert cli_main(argv) == 0
    err = capsys.readouterr().err
    assert "overflow" not in err and "invalid value" not in err and "warning" not in err, err
    rep = json.loads(out.read_text())
    # the nominal model is re-calibrated to a finite, useful held-out fit all the same
    assert rep["fit_before"]["validation"]["mean"] > 0.8
