"""Issue 15 on small independent plants: parameter or physics, combinations, forms, identifiability.

The plant is a heated block simulated by its own RK4 code with hidden effects
and coloured sensor noise (``tests/_diag_plants.py``, independent of the
augmentations); the nominal model is a user's own :class:`Model` with design
values 20-25 % off the truth.
"""

from __future__ import annotations

import json
import math
import re

import pytest
from _diag_plants import NodeModel, node_recordings

from thermogym.identification.diagnosis import diagnose
from thermogym.identification.diagnosis.run import INADEQUATE_MARGIN
from thermogym.identification.metrics import fit_text
from thermogym.recording import Recording

_FAST = {"hours": 1.5, "dt": 10.0}


def _run(effects, seed, **kw):
    tr, va = node_recordings(seed, effects=effects, **_FAST)
    return diagnose(NodeModel(), tr, va, **kw)


def test_control_with_off_design_constants_and_coloured_noise_names_no_physics():
    rep = _run({}, seed=3)
    assert set(rep.named_effects) <= {"none", "parameter_error"}
    # the design values are 20-25 % off: re-calibration is needed, and says which moved
    assert rep.named_effects == ["parameter_error"]
    moved = rep.parameters["moved"]
    assert moved and set(moved) <= {"C", "G", "P"}
    for p in moved:
        row = rep.parameters["parameters"][p]
        assert row["low"] < row["calibrated"] < row["high"]
        assert not row["low"] <= row["given"] <= row["high"]
    doc = json.loads(rep.to_json())
    assert doc["named_effects"] == ["parameter_error"] and doc["augmented_fit"] is None


@pytest.mark.parametrize("seed", [2, 4, 7, 8])
def test_sensor_wander_as_large_as_the_white_noise_is_not_named_as_physics(seed):
    # controls whose Gauss-Markov sensor noise (0.08 K, 5 min) exceeds the white (0.05 K):
    # per-recording courses follow that wander on held-out data too; with the keep bar
    # below twice the white level these seeds named a disturbance or a supply wander
    rep = _run({}, seed=seed)
    assert set(rep.named_effects) <= {"none", "parameter_error"}, rep.verdict
    # nor is the model called inadequate unless a plain ARX predicts materially better
    b = rep.baseline
    assert rep.nominal_adequate == (
        b["validation"]["mean"] <= b["nominal_validation"]["mean"] + INADEQUATE_MARGIN
    )


def test_delay_and_lag_are_told_apart():
    # the candidates that compete for a time shift: dead times, lags, an input-side store
    which = ["transport_delay", "sensor_lag", "missing_dynamics"]
    delay = _run({"delay": 60.0}, seed=4, max_effects=1, candidates=which)
    lag = _run({"lag": 120.0}, seed=4, max_effects=1, candidates=which)
    assert delay.named_effects[0] == "transport_delay"
    assert lag.named_effects[0] == "sensor_lag"
    assert delay.best["params"]["delay_u"]["value"] == pytest.approx(60.0, rel=0.2)
    assert lag.best["params"]["tau_lag_T"]["value"] == pytest.approx(120.0, rel=0.25)
    # each fits its own data better than the other's form does
    d = {(h["effect"], h["target"]): h["delta_ic"] for h in delay.hypotheses}
    g = {(h["effect"], h["target"]): h["delta_ic"] for h in lag.hypotheses}
    assert d[("transport_delay", "u")] < d[("sensor_lag", "T")]
    assert g[("sensor_lag", "T")] < g[("transport_delay", "u")]


@pytest.mark.parametrize(
    ("effects", "names"),
    [
        ({"delay": 60.0, "offset": 1.5}, {"transport_delay", "sensor_offset"}),
        ({"power": 1.5, "lag": 60.0}, {"input_nonlinearity", "sensor_lag"}),
    ],
)
def test_a_two_effect_case_reports_both_largest_share_first(effects, names):
    which = ["transport_delay", "sensor_offset", "sensor_lag", "input_nonlinearity", "sensor_drift"]
    rep = _run(effects, seed=1, candidates=which)
    assert names <= set(rep.named_effects)
    shares = [c["share_of_explained_error"] for c in rep.combination]
    assert all(0 < x <= 1 for x in shares) and sum(shares) == pytest.approx(1.0)
    assert shares == sorted(shares, reverse=True)  # the effect that removes most comes first
    assert rep.named_effects[0] == rep.combination[0]["effect"] == rep.best["effect"]
    # an effect of the combination is no alternative to another of it
    assert not {a["effect"] for a in rep.alternatives} & set(rep.named_effects)
    assert rep.best["validation_after"]["mean"] > rep.best["validation_before"]["mean"]


@pytest.mark.xfail(
    strict=True,
    reason="known miss (issue 15 closing note): radiation + offset on the node plant; the first "
    "round keeps natural convection, which absorbs part of the offset, and the offset then "
    "fails the held-out block test",
)
def test_two_effects_at_once_are_both_reported_with_their_shares():
    # two effects that each mimic the other partly, among competitors that could absorb both
    which = ["nonlinear_heat_transfer", "sensor_offset", "missing_dynamics", "sensor_drift"]
    rep = _run({"radiation": 0.15, "offset": 0.8}, seed=5, candidates=which)
    assert {"nonlinear_heat_transfer", "sensor_offset"} <= set(rep.named_effects)
    shares = [c["share_of_explained_error"] for c in rep.combination]
    assert all(0 < s <= 1 for s in shares) and sum(shares) == pytest.approx(1.0)
    rad = next(c for c in rep.combination if c["effect"] == "nonlinear_heat_transfer")
    assert rad["form"].startswith("radiation")
    assert rep.best["validation_after"]["mean"] > rep.best["validation_before"]["mean"]


def test_generic_ss_model_at_a_period_that_is_not_whole_seconds():
    # a log at 1228.8 s (a building's 20.48 min): the ss model steps once per sample
    tr, va = node_recordings(6, hours=30.0, dt=1228.8, hold=(3 * 3600.0, 12 * 3600.0))
    rep = diagnose("ss:1", tr, va, inputs=["u", "T_a"], outputs=["T"])
    assert math.isfinite(rep.fit_before["validation"]["mean"])
    assert rep.fit_before["validation"]["mean"] > 0.8
    assert rep.named_effects == ["none"] or "parameter_error" not in rep.named_effects


def test_units_missing_heat_transfer_is_tried_as_celsius_and_said():
    tr, va = node_recordings(7, effects={"radiation": 0.2}, **_FAST)

    def strip(r: Recording) -> Recording:
        return Recording(
            r.time, {c: r[c] for c in r.columns}, experiment_id=r.experiment_id, roles=dict(r.roles)
        )

    rep = diagnose(
        "foptd", [strip(r) for r in tr], [strip(r) for r in va], inputs=["u", "T_a"], outputs=["T"]
    )
    assert any("°C" in n for n in rep.notes)
    assert any(h["effect"] == "nonlinear_heat_transfer" for h in rep.hypotheses)


def test_a_nominal_model_worse_than_a_plain_arx_is_said_first():
    # the block carries a second mass the one-node model cannot follow: a second-order ARX can
    tr, va = node_recordings(8, effects={"mass": (8000.0, 2.0)}, coloured=0.02, **_FAST)
    said: list[str] = []
    rep = diagnose(NodeModel(), tr, va, candidates=["sensor_offset"], progress=said.append)
    assert not rep.nominal_adequate
    assert rep.verdict.startswith("Nominal model inadequate")
    b = rep.baseline
    assert b["validation"]["mean"] > b["nominal_validation"]["mean"]
    assert "Nominal model inadequate" in rep.to_markdown()
    # the fit as every command shows it: "fit 84.31 %", not a fraction called NRMSE
    arx, nom = fit_text(b["validation"]["mean"]), fit_text(b["nominal_validation"]["mean"])
    assert f"(mean fit {arx} against {nom})" in rep.verdict
    assert f"better: mean fit {arx} against the nominal model's {nom}" in rep.to_markdown()
    assert f"held-out mean fit {nom} against a plain ARX's {arx}" in " ".join(said)
    assert any(re.search(r"held-out ΔIC -?[\d.]+, mean fit -?[\d.]+ % ", s) for s in said)
    assert not any("NRMSE" in s for s in [*said, rep.verdict])


def test_a_parameter_the_training_data_cannot_identify_is_reported_as_such():
    # a fan's conductance grows with the command, but the training runs use one level only:
    # how it grows (the exponent) is not identifiable from them; the held-out runs vary it
    tr, va = node_recordings(9, effects={"forced": 2.0}, train_levels=(0.0, 60.0), n_val=3, **_FAST)
    rep = diagnose(NodeModel(), tr, va, candidates=["input_dependent_heat_transfer"])
    assert rep.named_effects[0] == "input_dependent_heat_transfer"
    m = rep.best["params"]["m_fc_T"]
    assert not m["identifiable"]
    assert "not identifiable from these data" in m["note"] and "second level of u" in m["note"]


def test_a_search_the_time_limit_cut_short_says_so_and_what_it_left_out():
    which = ["transport_delay", "sensor_lag"]
    whole = _run({"delay": 60.0}, seed=4, max_effects=1, candidates=which)
    assert whole.complete and whole.incomplete == []
    assert not whole.verdict.startswith("Incomplete")
    # a limit that has passed before the first candidate: nothing screened, and said
    cut = _run({"delay": 60.0}, seed=4, max_effects=1, candidates=which, time_limit=1e-3)
    assert not cut.complete
    assert cut.incomplete[0].startswith("time limit of 0.001 s: ")
    assert re.search(r"none of \d+ candidates tried$", cut.incomplete[0]) and not cut.hypotheses
    assert cut.verdict.startswith("Incomplete search")
    doc = json.loads(cut.to_json())
    assert doc["complete"] is False and doc["incomplete"] == cut.incomplete
    assert "## Incomplete search" in cut.to_markdown()


@pytest.mark.parametrize(("reserve", "refit_s"), [(2.0, 0.0), (2.0, 3.0), (0.0, 0.0)])
def test_a_search_the_time_limit_cuts_short_still_refits_what_it_screened(
    monkeypatch, reserve, refit_s
):
    # a clock that moves only when a candidate is fitted (1 s a screening fit, refit_s a
    # joint refit): the limit of 4 s cuts the screening of 7 candidates on any machine
    import time

    from thermogym.identification.diagnosis import select

    clock = [1000.0]
    fit = select.fit_hypothesis

    def fit_and_tick(*a, **k):
        out = fit(*a, **k)
        clock[0] += 1.0 if k.get("screen") else refit_s
        return out

    monkeypatch.setattr(time, "perf_counter", lambda: clock[0])
    monkeypatch.setattr(select, "fit_hypothesis", fit_and_tick)
    # the time kept for refits, in screening fits (0: none, the old behaviour)
    monkeypatch.setattr(select, "REFIT_RESERVE", reserve)
    which = ["sensor_lag", "transport_delay", "sensor_offset", "nonlinear_heat_transfer"]
    rep = _run({"delay": 60.0}, seed=4, max_effects=1, candidates=which, time_limit=4.0)
    assert not rep.complete and "candidates not screened" in rep.incomplete[0]
    if not reserve:
        # a screening that runs to the limit leaves nothing refitted: nothing named
        assert rep.named_effects == ["parameter_error"]
        assert any("not refitted jointly" in s for s in rep.incomplete)
        return
    # a few of seven screened; the time left is kept for refitting them, and the dead time
    # is named on what was screened
    assert rep.named_effects[0] == "transport_delay", rep.verdict
    assert any(not h["screened"] for h in rep.to_dict()["hypotheses"])
    (delay,) = rep.best["params"].values()
    assert delay["value"] == pytest.approx(60.0, abs=10.0)
    if refit_s:
        # the refit ran past the limit: no intervals (their Jacobian would run further past
        # it), and the report says so instead of showing values as if they had them
        assert "low" not in delay
        assert "intervals of the reported parameters not computed" in rep.incomplete
        assert any("intervals not computed" in n for n in rep.best["notes"])
    else:
        assert delay["low"] < delay["value"] < delay["high"]


@pytest.mark.parametrize("seed", [5, 6, 7])
def test_a_constant_offset_is_not_taken_for_a_disturbance_course_it_looks_like(seed):
    # once the initial state is estimated, a constant sensor offset and a constant unmeasured
    # change of the air look alike; the disturbance's course, re-estimated on every held-out
    # recording, also follows their noise. The offset predicts the held-out data outright
    tr, va = node_recordings(seed, effects={"offset": 1.0}, hours=1.5, dt=10.0, coloured=0.0)
    rep = diagnose(
        NodeModel(), tr, va, candidates=["sensor_offset", "unmeasured_disturbance"], max_effects=1
    )
    assert rep.named_effects[0] == "sensor_offset"
    assert rep.best["params"]["offset_T"]["value"] == pytest.approx(1.0, abs=0.2)
    # the look-alike is listed as an alternative the data do not tell apart, with the
    # experiment that would
    best = rep.best["delta_ic"]
    for a in rep.alternatives:
        assert a["effect"] != "sensor_offset" and a["delta_ic"] <= best + 6.0
        assert a["instead_of"] == "sensor_offset"
        assert "calibration point" in a["tell_apart"]
    assert ("## Alternatives the data do not tell apart" in rep.to_markdown()) == bool(
        rep.alternatives
    )
    if seed == 5:
        assert [a["effect"] for a in rep.alternatives] == ["unmeasured_disturbance"]
        assert "about as well as 'sensor_offset'" in rep.verdict


def test_an_effect_that_barely_changes_the_prediction_is_not_material():
    import numpy as np

    from thermogym.identification.diagnosis.hypothesis import Hypothesis
    from thermogym.identification.diagnosis.select import Data, change_snr

    rng = np.random.default_rng(0)
    base = [rng.normal(size=(200, 2)), rng.normal(size=(100, 2))]
    parent = Hypothesis(candidates=())
    parent.sims_val = base
    small = Hypothesis(candidates=())
    small.sims_val = [b + np.array([0.01, 0.02]) for b in base]
    data = Data([], [], np.ones(2), "estimate", noise=np.array([0.1, 0.1]), min_snr=0.5)
    assert change_snr(small, parent, data) == pytest.approx(0.2)  # the larger output's
    big = Hypothesis(candidates=())
    big.sims_val = [b + np.array([0.0, 0.3]) for b in base]
    assert change_snr(big, parent, data) == pytest.approx(3.0)
    data.noise = None  # unknown noise: materiality is not asked
    assert change_snr(small, parent, data) == math.inf


def test_a_step_test_logged_from_the_step_identifies_the_gain_on_real_data():
    # TCLab heater 1 step test: Q1 = 50 % from the first sample to the last. With the initial
    # state free, the gain cannot be told from the state the log starts in (a fit with K = 0
    # and the rise as a free response fits it as well); the step from zero is the evidence
    from thermogym.datasets import load

    step, sine = load("tclab_step"), load("tclab_sine")
    rep = diagnose("foptd", [step], [sine], inputs=["Q1"], outputs=["T1"])
    assert any("constant within every training recording" in n for n in rep.notes)
    k = rep.nominal_fit.to_dict()["parameters"]["K_T1"]
    k = k["value"] if isinstance(k, dict) else k
    assert 0.5 < k < 1.0  # K per %: 50 % gives a rise of about 39 K over the room
    held_out = rep.fit_before["validation"]["mean"]
    assert held_out > 0.8 and held_out > rep.baseline["validation"]["mean"]
    assert rep.nominal_adequate


def test_held_out_inputs_beyond_the_training_range_are_said():
    # training at commands up to 30 %, held out up to 100 %: what is named there is
    # extrapolation, and the report says so
    tr, va = node_recordings(5, hours=1.0, dt=10.0, train_levels=(10.0, 30.0, 20.0))
    rep = diagnose(NodeModel(), tr, va, candidates=["sensor_offset"], max_effects=1)
    notes = [n for n in rep.notes if "beyond its training range" in n]
    assert len(notes) == 1 and notes[0].startswith("the held-out recordings take u to ")
    # the same levels held out: nothing said
    tr2, va2 = node_recordings(5, hours=1.0, dt=10.0)
    rep2 = diagnose(NodeModel(), tr2, va2, candidates=["sensor_offset"], max_effects=1)
    assert not any("beyond its training range" in n for n in rep2.notes)


@pytest.mark.parametrize("seed", [4, 8])
def test_a_named_course_beat_a_course_added_to_the_reading(seed):
    # controls whose coloured sensor noise per-recording courses can follow: whatever course
    # effect is still named must have fitted the held-out data better than a course of as
    # many knots added to the reading unshaped (the baseline of item 6 for courses)
    rep = _run({}, seed=seed, candidates=["unmeasured_disturbance", "time_varying_parameter"])
    courses = {
        (h["effect"], h["form"], h["target"])
        for h in rep.hypotheses
        if h.get("n_local_per_recording", 0) >= 2
    }
    for c in rep.combination:
        if (c["effect"], c["form"], c["target"]) in courses:
            base = c["baseline"]["course"]
            assert base["physics_favoured"] and c["delta_ic"] < base["delta_ic"]
    assert courses  # the candidates were fitted; what was kept or refused is checked here
    first = [(c["effect"], c["form"], c["target"]) for c in rep.combination[:1]]
    for h in rep.hypotheses:  # the first round's
        if any("coloured noise of the sensor" in n for n in h.get("notes", [])):
            # refused there: its baseline fitted as well, and it is not the first kept effect
            assert not h["baseline"]["course"]["physics_favoured"]
            assert (h["effect"], h["form"], h["target"]) not in first


def test_parameter_error_verdict_does_not_claim_the_whole_answer_when_a_residual_remains():
    # the detection runs on the re-calibrated model: when its residual is still significant
    # and no hypothesis explains it, "no physics is missing" would be a claim the data refute
    from thermogym.identification.diagnosis.report import DiagnosisReport

    rep = DiagnosisReport("tank", {}, ["T"], ["P"], {"T": "°C"}, True, 0.01, {}, {}, None, {})  # type: ignore[arg-type]
    rep.named_effects = ["parameter_error"]
    rep.parameters = {"moved": ["K_coil"]}
    rep.located = {"signals": [{"signal": "T"}]}
    rep.detection = {"residual_structure": False}
    assert "explains the mismatch; no physics is missing" in rep.verdict
    rep.detection = {"residual_structure": True}
    assert "no physics is missing" not in rep.verdict
    assert "explains part of the mismatch" in rep.verdict and "mostly T" in rep.verdict


def test_verdict_and_markdown_show_the_fit_in_percent():
    from thermogym.identification.diagnosis.report import DiagnosisReport

    rep = DiagnosisReport("tank", {}, ["T"], ["P"], {"T": "°C"}, True, 0.01, {}, {}, None, {})  # type: ignore[arg-type]
    rep.named_effects = ["sensor_offset"]
    rep.located = {"signals": [{"signal": "T"}]}
    rep.combination = [{"effect": "sensor_offset", "form": "constant", "target": "T"}]
    rep.best = {
        "effect": "sensor_offset",
        "validation_before": {"T": 0.81234, "mean": 0.81234},
        "validation_after": {"T": 0.93456, "mean": 0.93456},
        "fit_after": {"T": 0.95, "mean": 0.95},
    }
    rep.fit_before = {"train": {"T": 0.7, "mean": 0.7}, "validation": {"T": 0.6, "mean": 0.6}}
    assert "held-out mean fit 81.23 % → 93.46 %" in rep.verdict
    rows = rep._fit_rows()
    assert rows[0] == ["T", "70.00 %", "95.00 %", "81.23 %", "93.46 %"]
