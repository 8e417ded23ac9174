"""``diagnose --x0`` / ``diagnose(..., x0=)``: the initial-state policy, chosen and printed.

A first-order plant (K = 0.5 K/W, T = 300 s) whose recordings start 8 K
above the rest the inputs imply (the rig had not cooled down, paper 000):
estimating each recording's initial state fits them, starting at rest does
not, and the policy used is what the report and the command say.
"""

from __future__ import annotations

import numpy as np
import pytest

from thermogym._cli.diagnose import X0_POLICIES as CLI_X0
from thermogym.cli import main
from thermogym.errors import ConfigError
from thermogym.identification.diagnosis.run import X0_POLICIES, diagnose
from thermogym.models.linear import FOPTDModel
from thermogym.recording import Recording, write_recording

T = np.arange(0.0, 1500.0, 10.0)


def warm_start(period: float, seed: int, constant: bool = False) -> Recording:
    """Square-wave heater (or a constant one), output starting 8 K warm of its rest."""
    u = np.full(T.size, 20.0) if constant else ((T % period) < period / 2) * 40.0
    m = FOPTDModel(K=0.5, T=300.0)
    y = 20.0 + m.simulate(u[:, None], 10.0).outputs[0, :, 0] + 8.0 * np.exp(-T / 300.0)
    noise = np.random.default_rng(seed).normal(0, 0.05, T.size)
    return Recording(
        T,
        {"u": u, "y": y + noise},
        units={"u": "W", "y": "°C"},
        roles={"u": "input", "y": "output"},
        experiment_id=f"run{seed}",
    )


def _run(x0: str, constant: bool = False):
    return diagnose(
        "foptd",
        [warm_start(600.0, 1, constant)],
        [warm_start(400.0, 2, constant)],
        inputs=["u"],
        outputs=["y"],
        candidates=["sensor_offset"],
        max_effects=1,
        x0=x0,
    )


def test_the_options_list_the_diagnosis_policies():
    assert CLI_X0 == X0_POLICIES == ("auto", "estimate", "rest", "measured")


def test_the_initial_state_policy_is_used_and_recorded():
    est, rest = _run("auto"), _run("rest")
    assert est.nominal_fit.settings["x0"] == "estimate"
    assert rest.nominal_fit.settings["x0"] == "rest"
    # the recordings start 8 K warm: estimated starts fit them on held-out data, rest does not
    va_est = est.fit_before["validation"]["mean"]
    va_rest = rest.fit_before["validation"]["mean"]
    assert va_est > 0.9 and va_est > va_rest + 0.1


def test_auto_starts_at_rest_only_when_the_inputs_never_move_and_x0_is_not_given():
    assert _run("auto", constant=True).nominal_fit.settings["x0"] == "rest"
    assert _run("estimate", constant=True).nominal_fit.settings["x0"] == "estimate"


def test_bad_x0_is_refused():
    with pytest.raises(ConfigError, match="x0 is 'zero'; expected one of"):
        _run("zero")


def test_cli_takes_x0_and_prints_the_policy_used(tmp_path, capsys):
    write_recording(warm_start(600.0, 1), tmp_path / "tr.csv")
    write_recording(warm_start(400.0, 2), tmp_path / "va.csv")
    base = ["diagnose", "--model", "foptd", "--inputs", "u", "--outputs", "y", "--train",
            str(tmp_path / "tr.csv"), "--validate", str(tmp_path / "va.csv"), "--candidates",
            "sensor_offset", "--max-effects", "1", "--quiet"]  # fmt: skip
    assert main([*base, "--out", str(tmp_path / "a.json")]) == 0
    assert "initial state: estimate (estimated from each recording's outputs; --x0 auto)" in (
        capsys.readouterr().out
    )
    assert main([*base, "--out", str(tmp_path / "b.json"), "--x0", "rest"]) == 0
    assert "initial state: rest (the model's own start; --x0 rest)" in capsys.readouterr().out
    assert main([*base, "--out", str(tmp_path / "c.json"), "--x0", "zero"]) == 2
    err = capsys.readouterr().err
    assert "--x0" in err and "'zero'" in err and "Traceback" not in err
    assert not (tmp_path / "c.json").exists()
