"""``diagnose`` end to end on small concealed-effect cases, its report, CLI and bad input."""

from __future__ import annotations

import json

import numpy as np
import pytest
from _model_plants import model_spindle_day, model_strut_steps, write_model_strut

from thermogym.cli import main
from thermogym.errors import ConfigError, RecordingError, UnknownNameError
from thermogym.fitresult import FitResult
from thermogym.identification.diagnosis import CATALOGUE, diagnose
from thermogym.identification.diagnosis.effects import Context, signatures
from thermogym.identification.diagnosis.experiments import decimate
from thermogym.identification.diagnosis.locate import locate, regime_variables
from thermogym.recording import Recording
from thermogym.rigs import get_rig, to_recording
from thermogym.vocabulary import EFFECT_NAMES


def _strut(effects=(), seed=3):
    # the diagnosis machinery on data whose answer lies in the model's vocabulary: the strut
    # model's own step tests with one effect (the strut rig is a plant of its own, richer
    # than the model; benchmarks/concealed measures the diagnosis on it)
    recs = model_strut_steps(seed=seed, effects=effects)
    return recs[:1], recs[1:]  # paper 000: train at 20 m/min, validate at 25 and 30


@pytest.fixture(scope="module")
def paper_case():
    tr, va = _strut(["input_dependent_heat_transfer"])
    return diagnose("strut", tr, va)


def test_catalogue_covers_the_vocabulary():
    # parameter_error is named by the re-calibration test and proposes no augmentation
    assert set(EFFECT_NAMES) == set(CATALOGUE)
    for e in CATALOGUE.values():
        assert len(e.explanation) > 80 and e.signature and e.augmentation
        assert e.experiment("x")


def test_no_effect_no_mismatch():
    tr, va = _strut(seed=11)
    rep = diagnose("strut", tr, va)
    assert not rep.mismatch_detected and rep.best["effect"] == "none"
    assert rep.hypotheses == [] and rep.augmented_fit is None
    for role in ("train", "validation"):
        assert not any(d["significant"] for d in rep.detection[role].values())


def test_paper_000_forced_convection_is_named_modelled_and_closes_the_gap(paper_case):
    # paper 000 section 4.1: fitted at 20 m/min, much larger errors at 25 and 30 m/min
    rep = paper_case
    assert rep.mismatch_detected and rep.best["effect"] == "input_dependent_heat_transfer"
    before, after = rep.best["validation_before"]["mean"], rep.best["validation_after"]["mean"]
    assert after - before > 0.15 and rep.best["explained"] > 0.8
    beta = rep.best["params"]["beta_u"]["value"]
    assert 1.5 < beta < 2.5  # the rig's concealed value is 2.0
    # located on the moving parts the air flow cools (not on the drive)
    moving = ("T_nut", "T_spindle", "T_bearing", "T_tube_rear", "T_tube_front")
    assert rep.located["signals"][0]["signal"] in moving
    # the other hypotheses were fitted and explain less
    assert all(h["score"] < rep.hypotheses[0]["score"] for h in rep.hypotheses[1:])


def test_augmented_fitresult_rebuilds_the_winner_and_reproduces_the_report(paper_case):
    rep = paper_case
    fit = FitResult.from_dict(json.loads(json.dumps(rep.augmented_fit.to_dict())))
    # the strut with the named effect (its own equations, or an augmentation on top of them)
    assert (fit.model, fit.model_config.get("base")) in (("strut", None), ("augmented", "strut"))
    assert "input_dependent_heat_transfer" in json.dumps(fit.model_config)
    model = fit.build_model()
    s = rep.series[-1]
    u = np.column_stack([s["u"][:, 0], s["u"][:, 1]])
    y = model.simulate(u, float(np.diff(s["time"])[0]), fit.theta(model)).outputs[0]
    # the report's curve adds the estimated initial state; both rise the same way
    j = rep.outputs.index("T_nut")
    rise_model = y[-1, j] - y[0, j]
    rise_report = s["augmented"][-1, j] - s["augmented"][0, j]
    assert rise_model == pytest.approx(rise_report, rel=0.05)


def test_report_json_markdown_and_html(paper_case, tmp_path):
    rep = paper_case
    doc = json.loads(rep.to_json())
    for key in ("mismatch_detected", "located", "hypotheses", "best", "augmented_fit"):
        assert key in doc
    for key in ("signals", "windows", "regimes"):
        assert key in doc["located"]
    h = doc["hypotheses"][0]
    for key in (
        "effect",
        "explanation",
        "params",
        "fit_before",
        "fit_after",
        "validation_before",
        "validation_after",
        "score",
    ):
        assert key in h
    html = rep.to_html()
    assert html.count("data:image/png;base64,") >= 3 and "<table>" in html
    md = rep.to_markdown()
    assert "input_dependent_heat_transfer" in md and "| output |" in md
    # atomic, no overwrite when refused
    p = tmp_path / "r.json"
    p.write_text("keep")
    with pytest.raises(ConfigError):
        rep.save(p, overwrite=False)
    assert p.read_text() == "keep"


def test_sensor_offset_is_named_on_the_right_output():
    tr, va = _strut(["sensor_offset:signal=T_nut,offset=1.0"], seed=5)
    rep = diagnose("strut", tr, va)
    assert rep.best["effect"] == "sensor_offset" and rep.best["target"] == "T_nut"
    assert rep.best["params"]["offset_T_nut"]["value"] == pytest.approx(1.0, abs=0.15)
    assert rep.augmented_fit.model == "augmented"
    model = rep.augmented_fit.build_model()
    assert "offset_T_nut" in model.param_names
    # the winner whitens the residual of T_nut on held-out data
    assert (
        rep.detection_after["validation"]["T_nut"]["rms"]
        < 0.3 * rep.detection["validation"]["T_nut"]["rms"]
    )


def test_generic_foptd_model_on_a_users_recording():
    # a first-order plant whose sensor lags: --model foptd --inputs u --outputs y
    rng = np.random.default_rng(0)
    t = np.arange(0.0, 3000.0, 5.0)

    def rec(period, seed):
        u = ((t % period) < period / 2) * 40.0
        from thermogym.models.linear import FOPTDModel

        y = 20 + FOPTDModel(K=0.5, T=300.0).simulate(u[:, None], 5.0).outputs[0, :, 0]
        a = np.exp(-5.0 / 120.0)
        s = y.copy()
        for k in range(1, y.size):
            s[k] = a * s[k - 1] + (1 - a) * y[k - 1]
        noise = np.random.default_rng(seed).normal(0, 0.05, t.size)
        return Recording(
            t,
            {"u": u, "y": s + noise},
            units={"u": "W", "y": "°C"},
            roles={"u": "input", "y": "output"},
            experiment_id=f"run{seed}",
        )

    del rng
    rep = diagnose("foptd", [rec(1500.0, 1)], [rec(700.0, 2)], inputs=["u"], outputs=["y"])
    assert rep.mismatch_detected
    # the FOPTD's own dead time absorbs much of a lag; what is left is named as a lag
    assert rep.best["effect"] in ("sensor_lag", "missing_dynamics")
    assert rep.best["validation_after"]["mean"] > rep.best["validation_before"]["mean"]


def test_locate_finds_the_regime_and_the_window():
    t = np.arange(2000.0)
    u = ((t // 250) % 2).astype(float)
    y_sim = np.zeros_like(t)
    e = np.where(u > 0, 0.5, 0.0) + 0.01 * np.random.default_rng(1).standard_normal(t.size)
    regs = regime_variables(
        ["r"], ["train"], {"u": "1", "y": "°C"}, [("u", [u])], [("y", [y_sim])], [1.0], [t]
    )
    out = locate(
        ["y"],
        [
            {
                "name": "r",
                "role": "train",
                "time": t,
                "dt": 1.0,
                "residual": e[:, None],
                "measured": e[:, None],
            }
        ],
        regs,
        {"y": 0.01},
        {"y": 1.0},
    )
    top = out["regimes"][0]
    assert top["kind"] == "on_off" and top["worst_bin"] == "on (> 0)" and top["eta2"] > 0.9
    w = out["windows"][0]
    assert u[int(w["t_start_s"]) + 5] == 1.0


def test_signature_estimates_a_sensor_lag():
    from thermogym.identification.diagnosis.hypothesis import NominalSpec
    from thermogym.models.registry import get_model

    m = get_model("strut")
    rng = np.random.default_rng(2)
    t = 140.9 * np.arange(73)
    u = np.column_stack([np.r_[0, np.full(72, 20.0)], np.full(73, 21.0)])
    sim = m.simulate(u, 140.9).outputs[0]
    y = sim.copy()
    j = m.output_names.index("T_nut")
    y[:, j] = sim[:, j] - 600.0 * np.gradient(sim[:, j], 140.9)  # e ≈ −τ dŷ/dt, τ = 600 s
    y += 0.01 * rng.standard_normal(y.shape)
    ctx = Context(
        model=m,
        spec=NominalSpec("strut", {}, [], "strut"),
        theta=m.nominal,
        free=(),
        outputs=m.output_names,
        time=[t],
        dt=[140.9],
        u=[u],
        y=[y],
        sim=[sim],
        is_train=[True],
        sigma={o: 0.01 for o in m.output_names},
        scale={o: 1.0 for o in m.output_names},
        share={o: (1.0 if o == "T_nut" else 0.0) for o in m.output_names},
    )
    f = signatures(ctx)["outputs"]["T_nut"]
    assert f["lag"] > 0.9 and f["lag_tau"] == pytest.approx(600.0, rel=0.1)


def test_decimation_keeps_input_averages_and_output_samples():
    rec = Recording(np.arange(12.0), {"u": np.arange(12.0) % 2, "y": np.arange(12.0)})
    d = decimate(rec, 4.0, ["u"])
    assert d.dt == 4.0 and d["u"].tolist() == [0.5, 0.5, 0.5] and d["y"].tolist() == [0.0, 4.0, 8.0]
    with pytest.raises(RecordingError, match="whole multiple"):
        decimate(rec, 2.5, ["u"])


def test_bad_input_gives_clear_errors():
    tr, va = _strut(seed=1)
    with pytest.raises(ConfigError, match="no validation recordings"):
        diagnose("strut", tr, [])
    with pytest.raises(ConfigError, match="no training recordings"):
        diagnose("strut", [], va)
    with pytest.raises(RecordingError, match="needed by model 'axt211'"):
        diagnose("axt211", tr, va)
    short = tr[0].slice(0.0, 600.0)
    with pytest.raises(RecordingError, match="too short"):
        diagnose("strut", [short], va)
    with pytest.raises(RecordingError, match="too short"):  # too short to validate
        diagnose("strut", tr, [va[0].slice(0.0, 600.0)])
    with pytest.raises(RecordingError, match="expected a Recording"):
        diagnose("strut", tr, ["strut-step-25.csv"])
    with pytest.raises(UnknownNameError, match="vocabulary"):
        diagnose("strut", tr, va, candidates=["gremlins"])
    with pytest.raises(ConfigError, match="inputs"):
        diagnose("foptd", tr, va)
    with pytest.raises(ConfigError, match="scheme"):
        diagnose("strut", tr, va, scheme="magic")


def test_cli_writes_reports_and_refuses_bad_input(tmp_path, capsys):
    data = tmp_path / "data"
    write_model_strut(data, seed=4, effects=["sensor_lag:signal=T_nut,tau=600"])
    out = tmp_path / "rep.json"
    rc = main(
        [
            "diagnose",
            "--model",
            "strut",
            "--train",
            str(data / "strut-step-20.csv"),
            "--validate",
            str(data / "strut-step-25.csv"),
            str(data / "strut-step-30.csv"),
            "--out",
            str(out),
            "--html",
            str(tmp_path / "rep.html"),
            "--augmented-fit",
            str(tmp_path / "fit.json"),
            "--quiet",
        ]
    )
    assert rc == 0
    doc = json.loads(out.read_text())
    assert doc["best"]["effect"] == "sensor_lag" and doc["best"]["target"] == "T_nut"
    assert FitResult.load(tmp_path / "fit.json").build_model().name == "augmented"
    assert "sensor_lag" in capsys.readouterr().out
    # a recording of another plant: exit status 2, the existing report untouched
    before = out.read_text()
    rc = main(
        [
            "diagnose",
            "--model",
            "axt211",
            "--train",
            str(data / "strut-step-20.csv"),
            "--validate",
            str(data / "strut-step-25.csv"),
            "--out",
            str(out),
        ]
    )
    assert rc == 2 and out.read_text() == before
    assert "needed by model 'axt211'" in capsys.readouterr().err
    rc = main(
        [
            "diagnose",
            "--model",
            "strut",
            "--train",
            str(tmp_path / "nope.csv"),
            "--validate",
            str(data),
            "--out",
            str(out),
        ]
    )
    assert rc == 2


@pytest.mark.slow
@pytest.mark.xfail(
    reason="known miss (issue 15, stop 22 note): the play is a parameter of the nominal model "
    "(paper 002 eq 20, c_backlash = 0.1 mm), so the rig's 0.25 mm is a parameter error; the "
    "re-calibration of 15 parameters leaves c_backlash unmoved and names the PTC and thermal "
    "constants instead",
    strict=False,
)
def test_axt211_backlash_is_found_blind():
    rig = get_rig("axt211", ["backlash"]).with_specimen({"c_backlash": 0.0})
    tr = [to_recording(r, "axt211") for r in rig.run("steps", seed=0)]
    va = [to_recording(r, "axt211") for r in rig.run("pwm", seed=1)]
    rep = diagnose("axt211", tr, va, dt=5.0)
    # the model carries backlash (eq 20): the rig's play is found as that parameter moved
    # (issue 15 item 2: re-calibrating the model's own parameters comes before any physics)
    assert "parameter_error" in rep.named_effects
    assert "c_backlash" in rep.parameters["moved"]
    # the rig's coupling has 0.25 mm of play; the model's backlash also carries what the rig
    # has and the model lacks between heating and cooling: the charge's melt hysteresis
    # (1.5 K, up to ~0.35 mm of half-width at the gain peak) and the friction band
    # (±0.08 mm), so the fitted half-width is the play and at most those
    c = rep.parameters["parameters"]["c_backlash"]["calibrated"]
    assert 0.21 < c < 0.25 + 0.35 + 0.08


@pytest.mark.slow
def test_spindle_sensor_offset_on_a_day_of_data():
    def rec(speed, seed):
        cols, _ = model_spindle_day(speed, seed, offset={"T_front_outer_housing": 1.0})
        return Recording(np.arange(cols["speed"].size, dtype=float), cols, experiment_id=f"{speed}")

    tr = [rec(s, i) for i, s in enumerate((4000, 6000, 8000))]
    va = [rec(5300, 10)]
    rep = diagnose("spindle", tr, va, dt=120.0)
    assert rep.best["effect"] == "sensor_offset" and rep.best["target"] == "T_front_outer_housing"


def test_given_nominal_parameters_are_used_as_they_are(tmp_path):
    tr, va = _strut(["sensor_offset:signal=T_nut,offset=1.0"], seed=5)
    first = diagnose("strut", tr, va, candidates=["sensor_offset"])
    path = first.nominal_fit.save(tmp_path / "nominal.json")
    again = diagnose("strut", tr, va, params=path, candidates=["sensor_offset"])
    assert again.nominal_fit.method.startswith("diagnosis nominal (given")
    assert again.nominal_fit.parameters == pytest.approx(first.nominal_fit.parameters)
    assert again.best["effect"] == "sensor_offset"
    from thermogym.models.axt211 import AXT211

    with pytest.raises(ConfigError, match="is for model 'axt211'"):
        diagnose("strut", tr, va, params=FitResult.from_model(AXT211()))


def test_an_output_left_empty_throughout_is_named():
    # was "residual of 'T_drive' has fewer than 8 valid samples in every recording" (and a
    # 'Mean of empty slice' warning) after the nominal fit
    tr, va = _strut(seed=4)
    off = [r.with_columns(T_drive=np.full(r.n_samples, np.nan)) for r in tr]
    with pytest.raises(RecordingError, match=r"\['T_drive'\] .* any training recording"):
        diagnose("strut", off, va, max_effects=1, time_limit=2.0)
    off = [r.with_columns(T_drive=np.full(r.n_samples, np.nan)) for r in va]
    with pytest.raises(RecordingError, match=r"\['T_drive'\] .* any validation recording"):
        diagnose("strut", tr, off, max_effects=1, time_limit=2.0)
    # a column missing (not empty): left out, and the report says so
    rep = diagnose("strut", [r.drop("T_drive") for r in tr], va, max_effects=1, time_limit=2.0)
    said = [n for n in rep.notes if "left out" in n]
    assert len(said) == 1 and "['T_drive']" in said[0] and "T_drive" not in rep.outputs


def test_validation_data_that_is_training_data_is_said():
    tr, va = _strut(seed=4)
    again = tr[0].replace(experiment_id="copy", units={})  # the same file copied, no sidecar
    rep = diagnose("strut", tr, [again, va[0]], candidates=["sensor_offset"], time_limit=2.0)
    said = [n for n in rep.notes if "same data" in n]
    assert len(said) == 1 and "'copy'" in said[0] and f"{tr[0].experiment_id!r}" in said[0]
    assert not any("same data" in n for n in diagnose("strut", tr, va[:1], time_limit=2.0).notes)


def test_a_given_generic_fit_takes_its_own_input_columns_in_its_own_order(tmp_path):
    # a FitResult of foptd with two exogenous columns; recordings without roles (a plain CSV)
    from thermogym.identification.foptd import fit_foptd

    tr, va = _strut(seed=4)
    tr, va = [r.replace(roles={}) for r in tr], [r.replace(roles={}) for r in va[:1]]
    path = tmp_path / "foptd.json"
    fit_foptd(tr, ["feed_rate", "T_air"], ["T_drive", "T_nut"], disturbances=[]).fit.save(path)
    kw = dict(params=path, candidates=["sensor_offset"], max_effects=1)
    # columns other than the FitResult's: named, not an IndexError deep in the run
    with pytest.raises(ConfigError, match=r"\['feed_rate'\] \(--inputs\).*'T_air'"):
        diagnose("foptd", tr, va, inputs=["feed_rate"], **kw)
    with pytest.raises(ConfigError, match=r"\['T_bearing'\] \(--outputs\).*'T_nut'"):
        diagnose("foptd", tr, va, outputs=["T_bearing"], **kw)
    # the same columns in another order: the fitted gains stay with their inputs (were swapped)
    own = diagnose("foptd", tr, va, **kw).nominal_fit.parameters
    swapped = diagnose("foptd", tr, va, inputs=["T_air", "feed_rate"], **kw)
    assert swapped.nominal_fit.parameters == pytest.approx(own)


@pytest.mark.xfail(
    strict=True,
    reason="known miss after the issue 15 rewrite: the sparse-regression fallback proposes no "
    "support on this TCLab case (the report says 'none' with a non-white residual)",
)
def test_sparse_regression_names_the_residual_dynamics_as_an_equation():
    # real TCLab data, the catalogue restricted to an effect that cannot explain the error:
    # the fallback regresses the residual's dynamics on physical terms and must return an
    # equation whose dominant term reads as a vocabulary effect, judged on held-out runs
    from thermogym.datasets import load

    tr = [load("tclab_step"), load("tclab_sine")]
    va = [load("tclab_sin_5_50_run2"), load("tclab_step_50_run2")]
    rep = diagnose("foptd", tr, va, inputs=["Q1"], outputs=["T1"], candidates=["sensor_drift"])
    sparse = [h for h in rep.hypotheses if h["form"].startswith("sparse regression")]
    assert sparse
    h = sparse[0]
    assert h["effect"] in CATALOGUE and "d e/dt from" in h["form"]
    assert h["params"] and all(k.startswith("c_") for k in h["params"])
    assert h["validation_after"]["mean"] > h["validation_before"]["mean"]
