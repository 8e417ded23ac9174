"""Given input and output offsets (issue 16 item 1): used by the fit, stored, applied.

The plant is a first-order lag with delay about a known operating point
(P = 20 W, T = 22 °C), at rest there at ``t = 0``. Offsets given to the
identification replace what the ``operating_point_mode`` would give the
signals they name, are stored in the FitResult as given, and every command
that simulates the fit applies them unchanged.
"""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

from thermogym.cli import main as cli_main
from thermogym.errors import ConfigError
from thermogym.identification.foptd import fit_foptd
from thermogym.identification.linear_fit import predict
from thermogym.identification.metrics import nrmse
from thermogym.identification.n4sid import n4sid
from thermogym.identification.pem import pem, sopdt
from thermogym.identification.ssest import ssest
from thermogym.models.linear import FOPTDModel
from thermogym.recording import Recording, read_recording, write_recording

P_OP, T_OP, K, TAU_S = 20.0, 22.0, 0.5, 60.0
GIVEN = {"inputs": {"P": P_OP}, "outputs": {"T": T_OP}}


def plant_recording(seed: int = 0, n: int = 900, noise: float = 0.01) -> Recording:
    """The lag about (P_OP, T_OP): at rest there, then steps of +10 W from the first sample."""
    rng = np.random.default_rng(seed)
    u = P_OP + 10.0 * np.r_[1.0, np.repeat(rng.integers(0, 2, n // 30), 30)[1:]]
    m = FOPTDModel(["P"], ["T"], K=K, T=TAU_S, tau=5.0)
    y = T_OP + m.simulate((u - P_OP)[:, None], 1.0).outputs[0, :, 0]
    return Recording(
        np.arange(float(n)),
        {"P": u, "T": y + noise * rng.normal(size=n)},
        units={"P": "W", "T": "degC"},
        roles={"P": "input", "T": "output"},
        experiment_id=f"run{seed}",
    )


FITS = {
    "foptd_estimate": lambda r, **kw: fit_foptd(r, "P", "T", max_delay=10, **kw),
    "foptd_initial": lambda r, **kw: fit_foptd(
        r, "P", "T", max_delay=10, operating_point_mode="initial", **kw
    ),
    "n4sid_mean": lambda r, **kw: n4sid(
        r, ["P"], ["T"], 2, decimate=1, operating_point_mode="mean", **kw
    ),
    "arx_mean": lambda r, **kw: pem(r, ["P"], ["T"], "arx", na=1, nb=1, nk=5, **kw),
    "oe_none": lambda r, **kw: pem(
        r, ["P"], ["T"], "oe", nb=1, nf=1, nk=5, operating_point_mode="none", **kw
    ),
    "sopdt_rest": lambda r, **kw: sopdt(r, ["P"], ["T"], operating_point_mode="rest", **kw),
    "ssest_mean": lambda r, **kw: ssest(
        r, ["P"], ["T"], order=1, feedthrough=False, input_delay=5, decimate=1, **kw
    ),
}


@pytest.mark.parametrize("name", sorted(FITS))
def test_given_offsets_are_stored_unchanged_and_predict_the_data(name):
    rec = plant_recording()
    fit = FITS[name](rec, offsets=GIVEN).fit
    op = fit.settings["operating_point"]
    assert op["inputs"] == {"P": P_OP} and op["outputs"] == {"T": T_OP}  # exactly as given
    assert op["given"] == GIVEN
    if fit.model == "ss":  # the state space carries them in its own configuration
        assert fit.model_config["u_op"] == [P_OP] and fit.model_config["y_op"] == [T_OP]
    p = predict(fit, rec)
    assert p.u_op.tolist() == [P_OP] and p.y_op.tolist() == [T_OP]  # applied as given
    # the model about the true operating point describes the data
    assert nrmse(rec["T"], p.outputs[:, 0]) > 0.9, name


def test_offsets_are_used_for_the_fit():
    # "none" about zero: the plant is not at rest at P = 0, T = 0 and the lag is wrong; the
    # given operating point (the other signals none: zero) is the true one
    rec = plant_recording()
    plain = fit_foptd(rec, "P", "T", max_delay=10, operating_point_mode="none")
    given = fit_foptd(rec, "P", "T", max_delay=10, operating_point_mode="none", offsets=GIVEN)
    assert abs(plain.K[0, 0] - K) > 0.05
    assert given.K[0, 0] == pytest.approx(K, rel=0.01)
    assert given.T[0, 0] == pytest.approx(TAU_S, rel=0.02)
    # "estimate" fits the output offset unless it is given: a wrong one is kept, and costs fit
    wrong = fit_foptd(rec, "P", "T", max_delay=10, offsets={"outputs": {"T": T_OP + 3.0}})
    assert wrong.fit.settings["operating_point"]["outputs"] == {"T": T_OP + 3.0}
    free = fit_foptd(rec, "P", "T", max_delay=10)
    assert wrong.fit.metrics["train"]["mnrmse"] < free.fit.metrics["train"]["mnrmse"] - 0.05


def test_signals_not_named_keep_the_modes_values():
    recs = [plant_recording(1), plant_recording(2)]
    res = n4sid(recs, ["P"], ["T"], 1, decimate=1, operating_point_mode="mean",
                offsets={"inputs": {"P": 3.0}})  # fmt: skip
    op = res.fit.settings["operating_point"]
    assert op["inputs"] == {"P": 3.0}
    assert op["outputs"]["T"] == pytest.approx(np.mean([np.mean(r["T"]) for r in recs]))
    assert op["given"] == {"inputs": {"P": 3.0}, "outputs": {}}


def test_a_recordings_own_operating_point_keeps_the_given_offsets():
    # mode "initial": each recording is referred to its first samples, except the given input
    fit = fit_foptd(plant_recording(), "P", "T", max_delay=10, operating_point_mode="initial",
                    offsets={"inputs": {"P": P_OP}}).fit  # fmt: skip
    other = plant_recording(5)
    other = Recording(other.time, {"P": other["P"], "T": other["T"] + 4.0}, units=other.units)
    p = predict(fit, other, operating="recording")
    assert p.operating == "recording"
    assert p.u_op.tolist() == [P_OP]  # not the recording's first input (30 W)
    assert p.y_op.tolist() == [other["T"][0]]  # the output not named: the mode's value


@pytest.mark.parametrize(
    ("offsets", "match"),
    [
        ({"outputs": {"X": 1.0}}, "'X', which is not an output"),
        ({"inputs": {"T": 1.0}}, "'T', which is not an input"),
        ({"inputs": {"P": float("nan")}}, "expected a finite number"),
        ({"inputs": {"P": "warm"}}, "'warm'; expected a finite number"),
        ({"input": {"P": 1.0}}, "key(s) ['input']"),
    ],
)
def test_bad_offsets_are_refused_by_name(offsets, match):
    rec = plant_recording(n=120)
    for fit in (FITS["foptd_estimate"], FITS["n4sid_mean"], FITS["arx_mean"]):
        with pytest.raises(ConfigError, match=re.escape(match)):
            fit(rec, offsets=offsets)


@pytest.mark.parametrize(
    ("method", "extra"),
    [
        ("foptd", ["--max-delay-s", "10"]),
        ("n4sid", ["--order", "2", "--decimate", "1"]),
        ("arx", ["--na", "1", "--nb", "1", "--nk", "5"]),
    ],
)
def test_identify_with_offsets_then_simulate_gives_the_same_prediction(
    tmp_path, capsys, method, extra
):
    rec = plant_recording()
    write_recording(rec, tmp_path / "run.csv")
    out = tmp_path / "fit.json"
    argv = ["identify", method, str(tmp_path / "run.csv"), "--inputs", "P", "--outputs", "T",
            "--u-offset", "P=20", "--y-offset", "T=22", "--out", str(out), *extra]  # fmt: skip
    assert cli_main(argv) == 0
    assert "given offsets P=20, T=22" in capsys.readouterr().out
    fit = json.loads(out.read_text())
    assert fit["settings"]["operating_point"]["inputs"] == {"P": P_OP}
    assert fit["settings"]["operating_point"]["outputs"] == {"T": T_OP}
    reported = fit["metrics"]["train"]["experiments"]["run0"]["nrmse"]["T"]
    assert cli_main(["simulate", "--params", str(out), "--inputs", str(tmp_path / "run.csv"),
                     "--out", str(tmp_path / "sim.csv")]) == 0  # fmt: skip
    sim = read_recording(tmp_path / "sim.csv")
    assert float(nrmse(rec["T"], sim["T"])) == pytest.approx(reported, abs=1e-9)
    assert "operating point of the fit" in capsys.readouterr().out


def test_identify_rls_stores_the_given_offsets(tmp_path):
    write_recording(plant_recording(), tmp_path / "run.csv")
    out = tmp_path / "rls.json"
    argv = ["identify", "rls", str(tmp_path / "run.csv"), "--inputs", "P", "--outputs", "T",
            "--delays", "5", "--u-offset", "P=20", "--out", str(out)]  # fmt: skip
    assert cli_main(argv) == 0
    op = json.loads(out.read_text())["settings"]["operating_point"]
    assert op["inputs"] == {"P": P_OP} and op["given"] == {"inputs": {"P": P_OP}, "outputs": {}}
    assert op["outputs"]["T"] == pytest.approx(plant_recording()["T"][0])  # the first sample


@pytest.mark.parametrize("method", ["foptd", "n4sid", "rls", "arx", "ssest", "auto"])
@pytest.mark.parametrize(
    ("option", "value", "match"),
    [
        ("--y-offset", "X=1", "--y-offset names 'X', which is not an output"),
        ("--u-offset", "T=1", "--u-offset names 'T', which is not an input"),
        ("--u-offset", "P=nan", "nan is not finite"),
        ("--u-offset", "P=warm", "'warm' is not a number"),
        ("--y-offset", "T", "'T' is not of the form NAME=VALUE"),
        ("--y-offset", "T=1,T=2", "names 'T' more than once"),
    ],
)
def test_bad_offset_options_exit_2_before_any_work(tmp_path, capsys, method, option, value, match):
    # the recording does not exist: the offsets are refused before anything is read
    out = tmp_path / "fit.json"
    argv = ["identify", method, str(tmp_path / "missing.csv"), "--inputs", "P", "--outputs", "T",
            option, value, "--out", str(out)]  # fmt: skip
    assert cli_main(argv) == 2
    err = capsys.readouterr().err
    assert match in err and "Traceback" not in err
    assert not out.exists()
