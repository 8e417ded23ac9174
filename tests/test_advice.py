"""Warnings about fits: each fires on a case made to trigger it and not on a clean one."""

from __future__ import annotations

import numpy as np
import pytest

from thermogym.cli import main as cli_main
from thermogym.errors import ConfigError
from thermogym.fitresult import FitResult
from thermogym.identification.advice import (
    FitWarning,
    check_order,
    expected_signs,
    parse_expect_sign,
    parsimonious_index,
)
from thermogym.identification.crossval import make_folds, split_excited, split_recording
from thermogym.identification.foptd import fit_foptd
from thermogym.models.linear import FOPTDModel
from thermogym.recording import Recording, write_recording


def heater_recording(K: float, seed: int = 0, n: int = 400, T: float = 40.0) -> Recording:
    """A heater (W) on a temperature (°C): a FOPTD with gain K, steps every 40 s."""
    rng = np.random.default_rng(seed)
    u = np.repeat(rng.uniform(0, 100, n // 40), 40)[:, None]
    m = FOPTDModel(["P"], ["T"], K=K, T=T, tau=3.0, offsets=True, y0=20.0, steady_start=True)
    y = m.simulate(u, 1.0).outputs[0, :, 0] + 0.01 * rng.normal(size=n)
    return Recording(
        np.arange(float(n)),
        {"P": u[:, 0], "T": y},
        units={"P": "W", "T": "°C"},
        roles={"P": "input", "T": "output"},
        experiment_id=f"heater{seed}",
    )


def codes(fit: FitResult) -> set[str]:
    return {w["code"] for w in fit.warnings}


def test_clean_fit_has_no_warning():
    res = fit_foptd(heater_recording(0.05), ["P"], ["T"], validate=heater_recording(0.05, 1))
    assert res.K[0, 0] == pytest.approx(0.05, rel=0.02)
    assert res.fit.warnings == []


def test_gain_sign_against_the_physics_of_a_heater():
    # a "heater" that cools: the data say K < 0, the units say a heater must heat
    res = fit_foptd(heater_recording(-0.05), ["P"], ["T"])
    assert res.K[0, 0] < 0
    assert codes(res.fit) == {"gain_sign"}
    assert "must be positive" in res.fit.warnings[0]["message"]


def test_fit_below_zero_on_held_out_data():
    # validated on a plant whose gain has the other sign: worse than the mean
    res = fit_foptd(heater_recording(0.05), ["P"], ["T"], validate=heater_recording(-0.05, 2))
    assert "fit_below_zero" in codes(res.fit)
    assert res.fit.metrics["validation"]["mnrmse"] < 0


def test_time_constant_and_delay_at_the_bounds():
    # an output that integrates the input: T runs to the bound of ten record lengths
    rec = heater_recording(0.05)
    ramp = Recording(rec.time, {"P": rec["P"], "T": 20 + 1e-3 * np.cumsum(rec["P"])})
    res = fit_foptd(ramp, ["P"], ["T"], max_delay=5)
    assert "time_constant_bound" in codes(res.fit)
    # a delay longer than the range searched
    slow = FOPTDModel(["P"], ["T"], K=0.05, T=40.0, tau=30.0, offsets=True, y0=20.0)
    y_late = slow.simulate(rec["P"][:, None], 1.0, x0="steady").outputs[0, :, 0]
    late = Recording(rec.time, {"P": rec["P"], "T": y_late})
    res = fit_foptd(late, ["P"], ["T"], max_delay=10)
    assert "order_at_edge" in codes(res.fit)
    assert "order_at_edge" not in codes(fit_foptd(late, ["P"], ["T"], max_delay=60).fit)


def test_order_rule_and_order_warnings():
    # the smallest order within the tolerance of the best, whatever argmax says
    assert parsimonious_index([0.5, 0.95, 0.9504, 0.9505], tolerance=0.001) == 1
    assert parsimonious_index([0.5, np.nan, 0.9], tolerance=0.0) == 2
    orders = list(range(1, 7))
    flat = [0.5, 0.90, 0.9005, 0.9003, 0.9006, 0.9004]
    assert [w.code for w in check_order(orders, flat, 2)] == ["flat_cv"]
    peaked = [0.5, 0.7, 0.9, 0.8, 0.7, 0.6]
    assert check_order(orders, peaked, 3) == []
    rising = [0.5, 0.6, 0.7, 0.8, 0.85, 0.9]
    assert [w.code for w in check_order(orders, rising, 6)] == ["order_at_edge"]
    with pytest.raises(ConfigError):
        FitWarning("no_such_code", "x")


def test_cli_warns_and_stores_the_warnings(tmp_path, capsys):
    write_recording(heater_recording(-0.05), tmp_path / "train.csv")
    out = tmp_path / "fit.json"
    args = ["identify", "foptd", str(tmp_path / "train.csv"), "--inputs", "P", "--outputs", "T"]
    assert cli_main([*args, "--out", str(out)]) == 0
    assert "warning: gain of output 'T'" in capsys.readouterr().err
    assert codes(FitResult.load(out)) == {"gain_sign"}
    # declared physics wins over the units: a cooler may lower the temperature
    assert cli_main([*args, "--out", str(out), "--expect-sign", "P=-"]) == 0
    assert "warning" not in capsys.readouterr().err and FitResult.load(out).warnings == []
    assert cli_main([*args, "--out", str(out), "--expect-sign", "none"]) == 0
    assert FitResult.load(out).warnings == []


def test_expected_signs_from_units_names_and_declarations():
    units = {"P_heater": "W", "T_out": "°C", "cool_valve": "%", "T_in": "°C", "q": "W/m2"}
    exp = expected_signs(["P_heater", "T_out", "cool_valve"], ["T_in", "q"], units)
    assert exp == {("T_in", "P_heater"): 1, ("T_in", "T_out"): 1, ("T_in", "cool_valve"): -1}
    assert expected_signs(["u"], ["y"], {"u": "V", "y": "V"}) == {}
    assert expected_signs(["u"], ["y"], {}, parse_expect_sign("u:y=-")) == {("y", "u"): -1}
    assert expected_signs(["P_heater"], ["T_in"], units, parse_expect_sign("none")) == {}
    for bad in ("P", "P=up", "P:T:x=+", "1P=+"):
        with pytest.raises(ConfigError, match="--expect-sign"):
            parse_expect_sign(bad)


def pulses() -> Recording:
    """A short record with a few input steps, all in the first half."""
    u = np.zeros(200)
    u[20:40] = 1.0
    u[60:70] = 2.0
    u[90:95] = 1.0
    return Recording(np.arange(200.0), {"u": u, "y": np.cumsum(u)}, experiment_id="pulses")


def test_folds_hold_excitation_or_say_what_was_done():
    rec = pulses()
    assert np.ptp(split_recording(rec, 2)[1]["u"]) == 0  # the equal cut leaves it constant
    parts = split_excited(rec, 2, ["u"])
    assert parts[0].n_samples < 100 and sum(p.n_samples for p in parts) == 200
    assert all(np.ptp(p["u"]) > 0 for p in parts)
    folds, notes = make_folds([rec], 2, ["u"])
    assert folds is not None and len(folds) == 2 and "where the inputs move" in notes[0]
    # three folds: the steps allow it; eight do not (six input changes), the fallback says so
    folds, notes = make_folds([rec], 3, ["u"])
    assert len(folds) == 3 and all(np.ptp(f[0]["u"]) > 0 for f in folds)
    folds, notes = make_folds([rec], 8, ["u"])
    assert folds is not None and len(folds) < 8 and "used" in notes[0]
    one = Recording(rec.time, {"u": np.r_[np.zeros(100), np.ones(100)], "y": rec["y"]})
    folds, notes = make_folds([one], 2, ["u"])
    assert folds is None and "no cross-validation" in notes[0]
    # a well excited record is cut into equal parts without a note
    prbs = Recording(rec.time, {"u": np.sign(np.sin(np.arange(200) / 3.0)), "y": rec["y"]})
    assert make_folds([prbs], 2, ["u"])[1] == []


def test_cli_cross_validation_on_a_short_record_with_few_steps(tmp_path, capsys):
    rng = np.random.default_rng(3)
    u = np.zeros(600)
    for a, b, v in ((40, 120, 1.0), (150, 190, 0.5), (230, 300, 1.5)):
        u[a:b] = v
    m = FOPTDModel(["u"], ["y"], K=2.0, T=20.0, tau=2.0)
    y = 10 + m.simulate(u[:, None], 1.0).outputs[0, :, 0] + 0.01 * rng.normal(size=600)
    write_recording(Recording(np.arange(600.0), {"u": u, "y": y}), tmp_path / "short.csv")
    argv = ["identify", "n4sid", str(tmp_path / "short.csv"), "--inputs", "u"]
    argv += ["--outputs", "y", "--orders", "1:4", "--folds", "2", "--decimate", "1"]
    argv += ["--out", str(tmp_path / "s.json")]
    assert cli_main(argv) == 0
    text = capsys.readouterr()
    assert "where the inputs move" in text.out
    fit = FitResult.load(tmp_path / "s.json")
    assert "cv_fallback" in codes(fit) and fit.settings["cross_validation"]["folds"]
