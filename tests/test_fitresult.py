"""FitResult contract: JSON round trip, strict schema, model building, sampling."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

import thermogym
from thermogym.errors import ConfigError, ParameterError, ThermogymError, UnknownNameError
from thermogym.fitresult import FitResult, data_entry, load_fit
from thermogym.models import AXT211
from thermogym.recording import Recording


@pytest.fixture(scope="module")
def axt() -> AXT211:
    return AXT211()


def make_fit(axt: AXT211, **kw) -> FitResult:
    rec = Recording(np.arange(5.0), {"T_P": np.linspace(25, 30, 5)}, experiment_id="e1")
    fields = dict(
        stderr={"C_P": np.float64(1.5), "lambda_PG": np.nan, "T_P0": 0.4},
        covariance=np.array([[2.25, 0.3], [0.3, 0.16]]),
        covariance_names=["C_P", "T_P0"],
        bounds={"C_P": (3.0, 60.0), "T_P0": [45.0, 75.0], "tau_P": [1.0, math.inf]},
        fixed=["x_max"],
        method="least_squares",
        settings={"max_nfev": np.int64(200), "x_scale": (1.0, 2.0)},
        metrics={
            "train": {"nrmse_fit": {"T_P": np.float32(0.95), "x_V": np.nan}},
            "validation": {},
        },
        data=[data_entry(rec, role="train"), rec],
        notes="unit test",
    )
    fields.update(kw)
    return FitResult.from_model(axt, {"C_P": np.float64(26.0), "T_P0": 61.0}, **fields)


# ------------------------------------------------------------------------- round trips


def test_from_model_orders_parameters_and_converts_numpy(axt):
    fit = make_fit(axt)
    assert list(fit.parameters) == list(axt.param_names)
    assert fit.parameters["C_P"] == 26.0 and type(fit.parameters["C_P"]) is float
    assert fit.model == "axt211" and fit.model_version == axt.version
    assert fit.package_version == thermogym.__version__
    assert fit.bounds["C_P"] == [3.0, 60.0] and fit.bounds["tau_P"] == [1.0, math.inf]
    assert fit.data[0]["fingerprint"] == fit.data[1]["fingerprint"]
    assert fit.data[0]["role"] == "train" and fit.data[1]["n_samples"] == 5
    assert math.isnan(fit.metrics["train"]["nrmse_fit"]["x_V"])


def test_json_round_trip(tmp_path, axt):
    fit = make_fit(axt)
    p = fit.save(tmp_path / "fit.json")
    text = p.read_text()

    def no_constants(name):
        raise AssertionError(f"invalid JSON constant {name}")

    raw = json.loads(text, parse_constant=no_constants)  # NaN/Infinity would fail here
    assert raw["format"] == "thermogym.fitresult" and raw["schema_version"] == 1
    assert raw["metrics"]["train"]["nrmse_fit"]["x_V"] is None
    assert raw["stderr"]["lambda_PG"] is None and raw["bounds"]["tau_P"] == [1.0, None]
    assert raw["settings"] == {"max_nfev": 200, "x_scale": [1.0, 2.0]}
    back = FitResult.load(p)
    assert back.to_dict() == fit.to_dict()
    assert math.isnan(back.stderr["lambda_PG"]) and back.bounds["tau_P"][1] == math.inf
    assert back.fingerprint() == fit.fingerprint()
    assert FitResult.from_dict(fit.to_dict()).to_dict() == fit.to_dict()
    np.testing.assert_array_equal(back.theta(), fit.theta())
    assert listing(tmp_path) == ["fit.json"]


def test_arrays_round_trip(tmp_path):
    A = np.array([[0.9, 0.1], [0.0, 0.8]])
    fit = FitResult(
        model="ss", model_version="1", parameters={}, arrays={"A": A, "x0": [np.nan, 1.0]}
    )
    assert fit.arrays["A"] == A.tolist()
    back = FitResult.load(fit.save(tmp_path / "ss.json"))
    np.testing.assert_array_equal(back.array("A"), A)
    assert math.isnan(back.array("x0")[0])
    with pytest.raises(ConfigError, match=r"no array 'B'; arrays are \['A', 'x0'\]"):
        back.array("B")
    with pytest.raises(ConfigError, match="arrays\\['bad'\\] is not a rectangular array"):
        FitResult(model="ss", model_version="1", parameters={}, arrays={"bad": [[1, 2], [3]]})


def test_fingerprint_covers_model_and_values_only(axt):
    a = make_fit(axt)
    b = make_fit(axt, metrics={}, notes="other", created="2020-01-01T00:00:00+00:00", data=[])
    assert a.fingerprint() == b.fingerprint() and len(a.fingerprint()) == 64
    c = FitResult.from_model(axt, {"C_P": 26.0 + 1e-12, "T_P0": 61.0})
    assert c.fingerprint() != a.fingerprint()
    d = FitResult.from_model(AXT211(effects=["phase_change"]), {"C_P": 26.0, "T_P0": 61.0})
    assert d.fingerprint() != a.fingerprint()


# ------------------------------------------------------------------------ strict schema


def test_unknown_and_missing_keys(axt):
    d = make_fit(axt).to_dict()
    with pytest.raises(ConfigError, match=r"unknown FitResult key\(s\) \['colour', 'params'\]"):
        FitResult.from_dict({**d, "params": {}, "colour": 1})
    for key in ("model", "parameters"):
        bad = {k: v for k, v in d.items() if k != key}
        with pytest.raises(ConfigError, match=rf"lacks required key\(s\) \['{key}'\]"):
            FitResult.from_dict(bad)
    with pytest.raises(ConfigError, match="format is 'other'"):
        FitResult.from_dict({**d, "format": "other"})
    with pytest.raises(ConfigError, match="newer than this thermogym reads"):
        FitResult.from_dict({**d, "schema_version": 99})
    with pytest.raises(ConfigError, match="got list"):
        FitResult.from_dict([1, 2])  # type: ignore[arg-type]
    minimal = FitResult.from_dict({"model": "axt211", "model_version": "1", "parameters": {}})
    assert minimal.bounds == {} and minimal.covariance is None


@pytest.mark.parametrize(
    ("change", "error", "pattern"),
    [
        ({"parameters": {"C_P": math.nan}}, ParameterError, r"parameters\['C_P'\] is nan"),
        ({"parameters": {"C_P": "26"}}, ConfigError, r"parameters\['C_P'\] is '26' \(str\)"),
        ({"parameters": [1.0]}, ConfigError, "parameters is a list"),
        ({"stderr": {"nope": 1.0}}, ConfigError, r"stderr names \['nope'\]"),
        ({"bounds": {"C_P": [5.0, 1.0]}}, ParameterError, r"bounds\['C_P'\] is \[5\.0, 1\.0\]"),
        ({"bounds": {"C_P": [1.0]}}, ConfigError, r"bounds\['C_P'\] is \[1\.0\]"),
        ({"fixed": ["nope"]}, ConfigError, r"fixed names \['nope'\]"),
        ({"covariance": [[1.0]], "covariance_names": ["C_P", "T_P0"]}, ParameterError,
         r"shape \(1, 1\), expected \(2, 2\)"),
        ({"covariance": [[1.0, 0.5], [0.2, 1.0]], "covariance_names": ["C_P", "T_P0"]},
         ParameterError, "not symmetric: \\['C_P', 'T_P0'\\] = 0.5"),
        ({"covariance": None, "covariance_names": ["C_P"]}, ConfigError, "without a covariance"),
        ({"settings": {"callback": print}}, ConfigError, r"settings\['callback'\] is of type"),
        ({"data": [{"experiment_id": "x"}]}, ConfigError, r"data\[0\] .* 'fingerprint'"),
        ({"model_version": 1.5}, ConfigError, "model_version is 1.5"),
        ({"created": "yesterday"}, ConfigError, "created is 'yesterday'"),
    ],
)  # fmt: skip
def test_invalid_fields_are_named(axt, change, error, pattern):
    d = {"model": "axt211", "model_version": "1", "parameters": {"C_P": 26.0, "T_P0": 60.0}}
    d.update(change)
    with pytest.raises(error, match=pattern):
        FitResult.from_dict(d)


def test_integer_model_version_is_a_string():
    assert FitResult(model="axt211", model_version=1, parameters={}).model_version == "1"  # type: ignore[arg-type]


# ------------------------------------------------------------------------------- files


def listing(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


def test_load_errors(tmp_path, axt):
    with pytest.raises(ConfigError, match="does not exist"):
        FitResult.load(tmp_path / "nope.json")
    p = tmp_path / "bad.json"
    p.write_text('{\n  "model": "axt211",\n  "parameters": {1: 2}\n}\n')
    with pytest.raises(ConfigError, match=r"bad\.json' is not valid JSON: .* at line 3, column 18"):
        FitResult.load(p)
    p.write_text(json.dumps({"model": "axt211", "model_version": "1", "parameters": {}, "x": 1}))
    with pytest.raises(ConfigError, match=r"bad\.json': unknown FitResult key\(s\) \['x'\]"):
        FitResult.load(p)
    p.write_text(json.dumps({"model": "axt211", "model_version": "1", "parameters": {"C_P": None}}))
    with pytest.raises(ConfigError, match=r"bad\.json'.*parameters\['C_P'\] is None"):
        FitResult.load(p)


def test_save_is_atomic_and_respects_overwrite(tmp_path, axt, monkeypatch):
    fit = make_fit(axt)
    p = fit.save(tmp_path / "fit.json")
    before = p.read_bytes()
    with pytest.raises(ConfigError, match="exists and overwrite=False"):
        make_fit(axt, notes="new").save(p, overwrite=False)
    assert p.read_bytes() == before

    def broken(self, data):
        with open(self, "wb") as f:
            f.write(data[:10])
        raise OSError("no space left on device")

    monkeypatch.setattr(Path, "write_bytes", broken)
    with pytest.raises(ConfigError, match="no space left"):
        make_fit(axt, notes="new").save(p)
    assert p.read_bytes() == before and listing(tmp_path) == ["fit.json"]
    with pytest.raises(ConfigError, match="does not exist"):
        fit.save(tmp_path / "missing" / "fit.json")


def test_load_fit_variants(tmp_path, axt):
    fit = make_fit(axt)
    p = fit.save(tmp_path / "f.json")
    assert load_fit(fit) is fit
    for obj in (p, str(p), fit.to_dict()):
        assert load_fit(obj).to_dict() == fit.to_dict()
    with pytest.raises(ConfigError, match="got int"):
        load_fit(3)  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match=r"lacks required key\(s\) \['model', 'model_version'\]"):
        load_fit({"parameters": {"C_P": 1.0}})


# ------------------------------------------------------------------------------ model


def test_build_model_and_theta(axt):
    fit = make_fit(axt)
    m = fit.build_model()
    assert isinstance(m, AXT211) and m.effects == ()
    th = fit.theta()
    assert th.shape == (1, len(axt.param_names))
    assert th[0, axt.param_index("C_P")] == 26.0 and th[0, axt.param_index("T_P0")] == 61.0
    np.testing.assert_array_equal(fit.theta(axt), th)
    with_effect = FitResult.from_model(AXT211(effects=["phase_change"]), {"L_melt": 500.0})
    m2 = with_effect.build_model()
    assert m2.effects == ("phase_change",) and with_effect.model_config == {
        "effects": ["phase_change"]
    }
    assert with_effect.theta()[0, m2.param_index("L_melt")] == 500.0


def test_model_version_mismatch_is_refused(axt):
    old = FitResult(model="axt211", model_version="0", parameters={"C_P": 26.0})
    with pytest.raises(ConfigError) as e:
        old.build_model()
    msg = str(e.value)
    assert "version '0'" in msg and "version '1'" in msg and "axt211" in msg
    with pytest.raises(ConfigError, match="version '0'"):
        old.theta(axt)
    assert isinstance(old.build_model(check_version=False), AXT211)

    class AXT211v2(AXT211):
        version = "2"

    with pytest.raises(ConfigError, match="installed model is version '2'"):
        make_fit(axt).theta(AXT211v2())


def test_unknown_model_or_parameter(axt):
    with pytest.raises(UnknownNameError, match="unknown model 'nope'"):
        FitResult(model="nope", model_version="1", parameters={}).build_model()
    with pytest.raises(ParameterError, match=r"parameter\(s\) \['L_melt'\]"):
        FitResult(model="axt211", model_version="1", parameters={"L_melt": 1.0}).build_model()
    with pytest.raises(ConfigError, match="cannot be built"):
        FitResult(
            model="axt211", model_version="1", parameters={}, model_config={"x": 1}
        ).build_model()
    with pytest.raises(ConfigError, match="model given is"):
        FitResult(model="other", model_version="1", parameters={}).theta(axt)


# ----------------------------------------------------------------------------- sampling


def test_sample_respects_bounds_and_is_deterministic(axt):
    fit = make_fit(axt, bounds={"C_P": [25.0, 27.0], "T_P0": [45.0, 75.0]})
    s1 = fit.sample(500, np.random.default_rng(7))
    s2 = fit.sample(500, 7)
    s3 = fit.sample(500, 8)
    assert set(s1) == set(fit.parameters) and all(v.shape == (500,) for v in s1.values())
    for k in s1:
        np.testing.assert_array_equal(s1[k], s2[k])
    assert not np.array_equal(s1["C_P"], s3["C_P"])
    assert s1["C_P"].min() >= 25.0 and s1["C_P"].max() <= 27.0
    assert (s1["C_P"] == 25.0).any() and (s1["C_P"] == 27.0).any()  # clipped, std 1.5
    assert np.all(s1["x_max"] == fit.parameters["x_max"])  # fixed
    assert np.all(s1["R_0"] == fit.parameters["R_0"])  # no uncertainty
    assert s1["T_P0"].std() > 0.2


def test_sample_follows_the_covariance(axt):
    fit = make_fit(axt, bounds={}, stderr={}, fixed=[])
    s = fit.sample(40000, np.random.default_rng(0))
    x = np.column_stack([s["C_P"], s["T_P0"]])
    np.testing.assert_allclose(x.mean(axis=0), [26.0, 61.0], atol=0.03)
    np.testing.assert_allclose(np.cov(x.T), fit.covariance, rtol=0.05, atol=0.01)
    wide = fit.sample(40000, np.random.default_rng(0), scale=2.0)
    assert wide["C_P"].std() == pytest.approx(2 * s["C_P"].std(), rel=1e-12)


def test_sample_stderr_and_uniform_fallbacks(axt):
    fit = make_fit(axt, covariance=None, covariance_names=[], fixed=[])
    s = fit.sample(20000, 1)
    assert s["C_P"].std() == pytest.approx(1.5, rel=0.05) and s["T_P0"].std() == pytest.approx(
        0.4, rel=0.05
    )
    assert np.all(s["lambda_PG"] == fit.parameters["lambda_PG"])  # NaN stderr: not randomised

    plain = FitResult.from_model(axt)  # bounds from the model, no uncertainty
    u = plain.sample(5000, 3)
    for p in axt.parameters:
        assert u[p.name].min() >= p.lower and u[p.name].max() <= p.upper
        assert u[p.name].max() - u[p.name].min() > 0.9 * (p.upper - p.lower)
    th = plain.sample_theta(4, 3)
    assert th.shape == (4, len(axt.param_names))
    np.testing.assert_array_equal(th[:, axt.param_index("C_P")], plain.sample(4, 3)["C_P"])
    with pytest.raises(ParameterError, match="method 'normal' needs a covariance"):
        plain.sample(3, 0, method="normal")
    bare = FitResult(model="axt211", model_version="1", parameters={"C_P": 1.0})
    with pytest.raises(ParameterError, match="'uniform' needs finite bounds"):
        bare.sample(3, 0)
    with pytest.raises(ParameterError, match="n is 0"):
        plain.sample(0, 0)
    with pytest.raises(ConfigError, match="rng is a NoneType"):
        plain.sample(3, None)  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="method is 'gauss'"):
        plain.sample(3, 0, method="gauss")


def test_errors_share_the_root():
    assert issubclass(ConfigError, ThermogymError) and issubclass(ConfigError, ValueError)
