"""Recording contract: validation, derivations, model integration, CSV/Parquet files."""

from __future__ import annotations

import gzip
import json
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest

from thermogym import recording as recmod
from thermogym._fileio import atomic_write, atomic_write_many, to_jsonable
from thermogym.errors import RecordingError, ThermogymError, UnitError, UnknownNameError
from thermogym.models import AXT211
from thermogym.recording import Recording, read_recording, sidecar_path, write_recording
from thermogym.recording import _files as recfiles

# ----------------------------------------------------------------------------- helpers


def make_rec(n: int = 6, **kw) -> Recording:
    t = np.arange(n, dtype=float) * 0.5
    cols = {"u": np.linspace(0, 1, n), "T_P": 20.0 + t, "x_V": np.full(n, np.nan)}
    cols["T_P"][2] = np.nan
    kw.setdefault("units", {"u": "1", "T_P": "°C", "x_V": "mm"})
    kw.setdefault("roles", {"u": "input", "T_P": "output", "x_V": "output"})
    kw.setdefault("experiment_id", "exp1")
    kw.setdefault("source", "unit-test")
    kw.setdefault("meta", {"protocol": "ramp", "seed": 3, "report": {"dropped": [1, 2]}})
    return Recording(t, cols, **kw)


def nasty_floats(n: int, seed: int = 0) -> np.ndarray:
    """Random float64 bit patterns plus edge values, NaN and inf."""
    rng = np.random.default_rng(seed)
    x = rng.integers(0, 2**63, size=n, dtype=np.int64).view(np.float64)
    x = np.where(np.isfinite(x), x, 1.0) * rng.choice([-1.0, 1.0], size=n)
    x[:10] = [5e-324, -1.7976931348623157e308, 0.1 + 0.2, 1e23, np.nan, np.inf, -np.inf, 0.0,
              2.0**53 + 2, 1e-310]  # fmt: skip
    return x


def listing(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


@pytest.fixture(scope="module")
def axt() -> AXT211:
    return AXT211()


@pytest.fixture(scope="module")
def sim(axt: AXT211):
    T = 121
    u = np.column_stack([np.r_[np.ones(60), np.zeros(61)], np.full(T, 24.0), np.full(T, 25.0)])
    return axt.simulate(u, dt=2.0, theta=axt.theta({"C_P": [20.0, 30.0]}))


# ------------------------------------------------------------------------ construction


def test_basic_properties():
    rec = make_rec()
    assert rec.columns == ("u", "T_P", "x_V")
    assert rec.n_samples == len(rec) == 6
    assert rec.duration == 2.5
    assert rec.dt == 0.5
    assert rec.is_uniform()
    assert "u" in rec and "time" in rec and "nope" not in rec
    assert list(rec) == ["u", "T_P", "x_V"]
    assert rec.units["T_P"] == "°C" and rec.roles["u"] == "input"
    np.testing.assert_array_equal(rec["time"], np.arange(6) * 0.5)
    assert np.isnan(rec["T_P"][2]) and rec["T_P"][3] == 21.5


def test_arrays_are_copied_and_read_only():
    t = np.arange(3.0)
    u = np.array([1.0, 2.0, 3.0])
    rec = Recording(t, {"u": u})
    u[0] = 99.0
    t[0] = -5.0
    assert rec["u"][0] == 1.0 and rec.time[0] == 0.0
    with pytest.raises(ValueError, match="read-only"):
        rec["u"][0] = 5.0
    with pytest.raises(TypeError):
        rec.units["u"] = "V"  # type: ignore[index]


def test_integer_columns_scalars_and_none_become_float():
    rec = Recording([0, 1, 2], {"a": [1, 2, 3], "b": 24, "c": np.array([1.0, None, 3], object)})
    assert rec["a"].dtype == np.float64 and rec.time.dtype == np.float64
    np.testing.assert_array_equal(rec["b"], [24.0, 24.0, 24.0])
    assert np.isnan(rec["c"][1])


def test_mismatched_length_names_column_and_both_lengths():
    with pytest.raises(RecordingError, match=r"column 'T_P' has 4 samples but time has 5"):
        Recording(np.arange(5.0), {"u": np.zeros(5), "T_P": np.zeros(4)})
    with pytest.raises(RecordingError, match=r"column 'u' has shape \(5, 2\)"):
        Recording(np.arange(5.0), {"u": np.zeros((5, 2))})


@pytest.mark.parametrize(
    ("values", "row", "shown"),
    [
        (np.array([1.0, 2.0, "abc", 4.0], dtype=object), 2, "'abc'"),
        (["1.5", "2", "3", "4"], 0, "'1.5'"),
        (np.array([1.0, 2.0, 3.0, True], dtype=object), 3, "True"),
        (np.array([True, False, True, True]), 0, "True"),
        (np.array([1, 2, 3, 4]) + 1j, 0, "1j"),
    ],
)
def test_non_numeric_value_names_column_row_and_value(values, row, shown):
    with pytest.raises(RecordingError) as e:
        Recording(np.arange(4.0), {"k_U": values})
    msg = str(e.value)
    assert "'k_U'" in msg and f"row {row}" in msg and shown in msg


def test_time_not_increasing_names_index_and_times():
    with pytest.raises(RecordingError, match=r"index 3: time\[2\] = 2\.0 s, time\[3\] = 1\.5 s"):
        Recording([0.0, 1.0, 2.0, 1.5], {"u": np.zeros(4)})
    with pytest.raises(RecordingError, match=r"index 2: time\[1\] = 1\.0 s, time\[2\] = 1\.0 s"):
        Recording([0.0, 1.0, 1.0], {})


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_non_finite_time(bad):
    with pytest.raises(RecordingError, match=rf"time is {bad!r} at index 1"):
        Recording([0.0, bad, 2.0], {"u": np.zeros(3)})


def test_empty_recording():
    with pytest.raises(RecordingError, match="empty"):
        Recording([], {})
    with pytest.raises(RecordingError, match="empty"):
        Recording(np.array([]), {"u": np.array([])})


def test_duplicate_and_time_column_names():
    with pytest.raises(RecordingError, match="'u' is given twice"):
        Recording([0.0, 1.0], [("u", [1, 2]), ("u", [3, 4])])
    with pytest.raises(RecordingError, match="column called 'time'"):
        Recording([0.0, 1.0], {"time": [1, 2]})


@pytest.mark.parametrize("name", ["T P", "1a", "", "T-P", "Tü", 3])
def test_column_name_must_be_identifier(name):
    with pytest.raises(RecordingError, match="not an identifier"):
        Recording([0.0, 1.0], {name: [1, 2]})


def test_bad_metadata():
    with pytest.raises(RecordingError, match=r"units name column 'T_G'.*\['u'\]"):
        Recording([0.0], {"u": [1]}, units={"T_G": "°C"})
    with pytest.raises(UnitError, match="time is always in seconds"):
        Recording([0.0], {"u": [1]}, units={"time": "min"})
    assert Recording([0.0], {"u": [1]}, units={"time": "s"}).units == {}
    with pytest.raises(RecordingError, match="role 'sensor'"):
        Recording([0.0], {"u": [1]}, roles={"u": "sensor"})
    with pytest.raises(RecordingError, match="experiment_id is a int"):
        Recording([0.0], {"u": [1]}, experiment_id=3)  # type: ignore[arg-type]


def test_dt_non_uniform_and_single_sample():
    rec = Recording([0.0, 1.0, 2.0, 3.5, 4.5], {"u": np.zeros(5)})
    assert not rec.is_uniform()
    with pytest.raises(RecordingError, match=r"step of 1\.5 s from time 2 s to 3\.5 s"):
        _ = rec.dt
    assert rec.is_uniform(rtol=0.5)
    one = Recording([3.0], {"u": [1.0]})
    assert one.duration == 0.0 and not one.is_uniform()
    with pytest.raises(RecordingError, match="single sample"):
        _ = one.dt
    # float time axes such as k * 0.1 are uniform within the default tolerance
    assert Recording(np.arange(1000) * 0.1, {}).dt == pytest.approx(0.1)


def test_getitem_unknown_lists_columns():
    rec = make_rec()
    with pytest.raises(
        UnknownNameError, match=r"no column 'T_G'; columns are \['u', 'T_P', 'x_V'\]"
    ):
        rec["T_G"]
    with pytest.raises(LookupError):
        rec["T_G"]


# -------------------------------------------------------------------------- derivations


def test_select_drop_with_columns_replace_copy():
    rec = make_rec()
    sel = rec.select(["T_P", "u"])
    assert sel.columns == ("T_P", "u") and sel.units == {"u": "1", "T_P": "°C"}
    assert sel.meta == rec.meta and sel.meta is not rec.meta
    with pytest.raises(UnknownNameError, match="'nope'"):
        rec.select(["u", "nope"])
    assert rec.drop("x_V").columns == ("u", "T_P")
    with pytest.raises(UnknownNameError):
        rec.drop("nope")

    w = rec.with_columns(
        {"k_U": 24.0}, T_U=np.arange(6.0), units={"k_U": "V"}, roles={"T_U": "disturbance"}
    )
    assert w.columns == ("u", "T_P", "x_V", "k_U", "T_U")
    assert w.units["k_U"] == "V" and w.roles["T_U"] == "disturbance"
    assert rec.columns == ("u", "T_P", "x_V")  # unchanged
    replaced = rec.with_columns(u=np.ones(6))
    assert replaced.units["u"] == "1" and replaced["u"].sum() == 6
    with pytest.raises(RecordingError, match="'u' has 3 samples"):
        rec.with_columns(u=np.ones(3))

    r2 = rec.replace(experiment_id="exp2", units={})
    assert r2.experiment_id == "exp2" and r2.units == {} and r2.source == "unit-test"
    assert rec.experiment_id == "exp1"

    c = rec.copy()
    assert c == rec and c["u"] is not rec["u"]
    c.meta["report"]["dropped"].append(9)
    assert rec.meta["report"]["dropped"] == [1, 2]


def test_slice_is_closed_and_validates():
    rec = make_rec()  # time 0, .5, ..., 2.5
    s = rec.slice(0.5, 1.5)
    np.testing.assert_array_equal(s.time, [0.5, 1.0, 1.5])
    np.testing.assert_array_equal(s["u"], rec["u"][1:4])
    assert rec.slice(t1=0.0).n_samples == 1 and rec.slice(2.0).n_samples == 2
    with pytest.raises(
        RecordingError, match=r"no sample .* in \[5\.0, 6\.0\] s; it spans \[0\.0, 2\.5\] s"
    ):
        rec.slice(5.0, 6.0)
    with pytest.raises(RecordingError, match="after its end"):
        rec.slice(2.0, 1.0)


def test_all_nan_columns_and_check_values():
    rec = make_rec()
    assert rec.all_nan_columns() == ["x_V"]
    with pytest.raises(
        RecordingError, match=r"\['x_V'\] of recording 'exp1' hold no finite sample"
    ):
        rec.check_values()
    rec.check_values(["u", "T_P"], allow_nan=True)
    with pytest.raises(
        RecordingError,
        match=r"'T_P' .* 1 non-finite sample\(s\), the first nan at row 2 \(time 1\.0 s\)",
    ):
        rec.check_values(["T_P"])
    rec.check_values(["u"])


def test_fingerprint_identifies_data_and_units_only():
    a, b = make_rec(), make_rec(meta={"other": 1}, experiment_id="x", roles={})
    assert a.fingerprint() == b.fingerprint()
    assert len(a.fingerprint()) == 64 and int(a.fingerprint(), 16) >= 0
    assert a.select(["x_V", "T_P", "u"]).fingerprint() == a.fingerprint()  # column order
    assert a.replace(units={"u": "1"}).fingerprint() != a.fingerprint()
    assert a.with_columns(u=a["u"] + 1e-15).fingerprint() != a.fingerprint()
    assert a.drop("x_V").fingerprint() != a.fingerprint()
    z = Recording([0.0, 1.0], {"u": [0.0, 1.0]})
    assert Recording([0.0, 1.0], {"u": [-0.0, 1.0]}).fingerprint() == z.fingerprint()
    assert Recording([0.0, 1.0], {"v": [0.0, 1.0]}).fingerprint() != z.fingerprint()


def test_repr_and_equality():
    rec = make_rec()
    r = repr(rec)
    assert "'exp1'" in r and "6 samples" in r and "dt=0.5 s" in r and "T_P [°C]" in r
    assert rec == make_rec() and rec != make_rec(experiment_id="other")
    assert rec.equals(make_rec(experiment_id="other"), metadata=False)
    assert rec != rec.with_columns(u=rec["u"] * 2)


# --------------------------------------------------------------------------- pandas


def test_frame_round_trip_and_from_frame_options():
    rec = make_rec()
    df = rec.to_frame()
    assert list(df.columns) == ["time", "u", "T_P", "x_V"]
    assert Recording.from_frame(df) == rec
    df2 = pd.DataFrame({"t": [0.0, 1.0], "label": ["a", "b"], "u": [1, 2]})
    r = Recording.from_frame(df2, time="t", columns=["u"], units={"u": "1"})
    assert r.columns == ("u",) and r.units == {"u": "1"}
    r = Recording.from_frame(
        pd.DataFrame({"u": [1.0, 2.0]}, index=pd.Index([0.0, 1.0], name="time"))
    )
    assert r.columns == ("u",)
    with pytest.raises(
        RecordingError, match=r"no time column 'time'; columns are \['t', 'label', 'u'\]"
    ):
        Recording.from_frame(df2)
    with pytest.raises(
        RecordingError, match=r"column 'label' holds a non-numeric value at row 0: 'a'"
    ):
        Recording.from_frame(df2, time="t")
    nullable = pd.DataFrame({"time": [0.0, 1.0], "u": pd.array([1, None], dtype="Int64")})
    assert np.isnan(Recording.from_frame(nullable)["u"][1])
    dup = pd.DataFrame([[0.0, 1.0, 2.0]], columns=["time", "u", "u"])
    with pytest.raises(RecordingError, match=r"\['u'\] appear more than once"):
        Recording.from_frame(dup)
    clash = pd.DataFrame({"t": [0.0, 1.0], "time": [5.0, 6.0]})
    with pytest.raises(RecordingError, match="column called 'time'"):
        Recording.from_frame(clash, time="t")
    with pytest.raises(UnitError, match="'T_P' the unit '°C', the argument 'K'"):
        Recording.from_frame(df, units={"T_P": "K"})


# ---------------------------------------------------------------- model integration


def test_from_simulation_and_validate_for(axt, sim):
    rec = Recording.from_simulation(sim, 1, experiment_id="step")
    assert rec.columns == (*axt.exogenous_names, *axt.output_names)
    assert rec.roles["u"] == "input" and rec.roles["k_U"] == "disturbance"
    assert rec.roles["T_P"] == "output" and rec.units["T_P"] == "°C" and rec.units["k_U"] == "V"
    assert rec.meta["simulation"]["index"] == 1 and rec.meta["simulation"]["model"] == "axt211"
    assert rec.source == "simulation"
    np.testing.assert_array_equal(rec["x_V"], sim.output("x_V")[1])
    rec.validate_for(axt)
    rec.validate_for(axt, finite=True)
    rec2 = Recording.from_simulation(sim, 0, model=axt, meta={"seed": 1})
    assert rec2.roles == rec.roles and rec2.meta["seed"] == 1
    with pytest.raises(RecordingError, match=r"index 2 .* batch of size 2"):
        Recording.from_simulation(sim, 2)


def test_exogenous_array_feeds_the_model_again(axt, sim):
    rec = Recording.from_simulation(sim, 1)
    shuffled = rec.select(["T_U", "x_V", "u", "k_U", "T_P"])  # any column order
    u = shuffled.exogenous_array(axt)
    assert u.shape == (rec.n_samples, 3) and u.flags.writeable
    np.testing.assert_array_equal(u, sim.inputs[1])
    again = axt.simulate(u, dt=rec.dt, theta={"C_P": 30.0})
    np.testing.assert_array_equal(again.outputs[0], rec.output_array(axt))
    y = shuffled.output_array(axt, ["x_V", "T_P"])
    np.testing.assert_array_equal(
        y, sim.outputs[1][:, [axt.output_names.index("x_V"), axt.output_names.index("T_P")]]
    )
    with pytest.raises(UnknownNameError, match=r"'k_U'.* not outputs"):
        rec.output_array(axt, ["k_U"])


def test_validate_for_missing_columns_lists_expected(axt, sim):
    rec = Recording.from_simulation(sim).drop("T_U", "x_V")
    with pytest.raises(RecordingError) as e:
        rec.validate_for(axt)
    msg = str(e.value)
    assert "lacks column(s) ['T_U', 'x_V']" in msg and "'axt211'" in msg
    assert "exogenous ['u', 'k_U', 'T_U']" in msg and "'P_PTC'" in msg
    with pytest.raises(RecordingError, match=r"\['T_U'\]"):
        rec.validate_for(axt, outputs=False)
    rec.with_columns(T_U=25.0).validate_for(axt, outputs=["T_P"])


def test_validate_for_units(axt, sim):
    rec = Recording.from_simulation(sim)
    kelvin = rec.replace(units={**rec.units, "T_U": "K"})
    with pytest.raises(UnitError, match=r"column 'T_U' .* is in 'K', model 'axt211' expects '°C'"):
        kelvin.validate_for(axt)
    with pytest.raises(UnitError):
        kelvin.exogenous_array(axt)
    rec.replace(units={}).validate_for(axt)  # no units: accepted
    rec.replace(units={"T_U": "degC", "R_PTC": "Ω"}).validate_for(axt)  # spellings
    gap = rec.with_columns(k_U=np.where(np.arange(rec.n_samples) == 5, np.nan, 24.0))
    gap.validate_for(axt)
    with pytest.raises(RecordingError, match=r"'k_U'.*row 5"):
        gap.validate_for(axt, finite=True)


def test_temperatures_below_absolute_zero_are_named(axt, sim, tmp_path, capsys):
    # a logger's error code (-9999) or a column in another unit: refused where a unit says
    # the column is a temperature (its own, or the model's for a column without one)
    rec = Recording.from_simulation(sim)
    t_u = np.where(np.arange(rec.n_samples) == 7, -9999.0, rec["T_U"])
    bad = rec.with_columns(T_U=t_u)
    with pytest.raises(UnitError, match=r"'T_U' .* holds -9999 at row 7 .*absolute zero"):
        bad.validate_for(axt)
    with pytest.raises(UnitError, match=r"-273\.15 °C, the unit model 'axt211' expects"):
        bad.replace(units={}).validate_for(axt)
    with pytest.raises(UnitError, match=r"'T_U' .*0 K, its unit"):
        bad.replace(units={**rec.units, "T_U": "K"}).check_temperatures()
    bad.replace(units={}).check_temperatures()  # no unit anywhere: not known to be one
    bad.with_columns(T_U=np.where(t_u < -300, np.nan, t_u)).validate_for(axt)  # NaN: missing
    # the command line refuses it as it reads the file (its sidecar says °C), model or not
    from thermogym.cli import main

    path = tmp_path / "r.csv"
    write_recording(bad, path)
    assert read_recording(path).equals(bad)  # the reader itself reads what was written
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    argv = ["identify", "foptd", str(path), "--inputs", "u", "--outputs", "T_P"]
    assert main([*argv, "--out", str(tmp_path / "f.json")]) == 2
    err = capsys.readouterr().err.strip()
    assert "r.csv" in err and "'T_U'" in err and "-9999 at row 7" in err and "\n" not in err
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before


# ------------------------------------------------------------------------------ files


@pytest.mark.parametrize("name", ["r.csv", "r.parquet", "r.csv.gz"])
def test_file_round_trip_is_exact(tmp_path, name):
    n = 2000
    rec = Recording(
        np.cumsum(np.random.default_rng(1).uniform(0.01, 1.0, n)),
        {"a": nasty_floats(n, 2), "b": nasty_floats(n, 3), "empty": np.full(n, np.nan)},
        units={"a": "°C", "b": "W"},
        roles={"a": "output"},
        experiment_id="rt",
        source="rig:axt211",
        meta={"seed": np.int64(4), "gain": np.float32(0.5), "bad": np.nan, "list": (1, 2)},
    )
    path = write_recording(rec, tmp_path / name)
    back = read_recording(path)
    assert back.equals(rec, metadata=False)
    for c in rec.columns:  # bit-exact, NaN included
        np.testing.assert_array_equal(back[c], rec[c])
    assert back.fingerprint() == rec.fingerprint()
    assert back.units == rec.units and back.roles == rec.roles
    assert (back.experiment_id, back.source) == ("rt", "rig:axt211")
    assert back.meta["seed"] == 4 and back.meta["list"] == [1, 2] and back.meta["bad"] is None
    expected = [name, f"{name}.meta.json"] if ".csv" in name else [name]
    assert listing(tmp_path) == sorted(expected)


def test_csv_layout_nan_is_empty_field(tmp_path):
    rec = Recording([0.0, 0.5, 1.0], {"u": [1.0, np.nan, 0.25], "T": [np.nan, 2.0, 3.0]})
    write_recording(rec, tmp_path / "a.csv")
    assert (tmp_path / "a.csv").read_text() == "time,u,T\n0,1,\n0.5,,2\n1,0.25,3\n"
    side = json.loads(sidecar_path(tmp_path / "a.csv").read_text())
    assert side["format"] == "thermogym.recording" and side["columns"] == ["time", "u", "T"]


def test_parquet_metadata_key(tmp_path):
    write_recording(make_rec(), tmp_path / "a.parquet")
    md = pq.read_schema(tmp_path / "a.parquet").metadata
    doc = json.loads(md[b"thermogym"])
    assert doc["units"]["T_P"] == "°C" and doc["meta"]["protocol"] == "ramp"
    assert read_recording(tmp_path / "a.parquet") == make_rec()


def test_csv_float_format_is_compact(tmp_path):
    rec = Recording(np.arange(200.0), {"a": np.random.default_rng(0).normal(size=200)})
    write_recording(rec, tmp_path / "full.csv")
    write_recording(rec, tmp_path / "short.csv", float_format="%.6g")
    back = read_recording(tmp_path / "short.csv")
    np.testing.assert_allclose(back["a"], rec["a"], rtol=1e-5)
    assert (tmp_path / "short.csv").stat().st_size < 0.7 * (tmp_path / "full.csv").stat().st_size
    with pytest.raises(RecordingError, match="float_format"):
        write_recording(rec, tmp_path / "x.csv", float_format="%d %d")
    assert "x.csv" not in listing(tmp_path)
    write_recording(rec, tmp_path / "g.csv.gz", float_format="%.6g")
    with gzip.open(tmp_path / "g.csv.gz", "rt") as f:
        assert f.readline() == "time,a\n"


def test_foreign_csv_without_sidecar(tmp_path):
    p = tmp_path / "logger.csv"
    p.write_text("t;label;T_U;k_U\n0;a;25.5;24\n1;b;;24\n2;c;26;23.9\n")
    rec = read_recording(p, time="t", columns=["T_U", "k_U"], units={"T_U": "°C"}, delimiter=";",
                         experiment_id="log")  # fmt: skip
    assert rec.columns == ("T_U", "k_U") and rec.units == {"T_U": "°C"}
    assert np.isnan(rec["T_U"][1]) and rec.experiment_id == "log"
    with pytest.raises(RecordingError, match=r"non-numeric value 'a' at row 0 \(line 2\)"):
        read_recording(p, time="t", delimiter=";")
    # a logger's clock (times of day) and a true/false column: named as written, with the
    # fix; not "datetime.time(8, 0)" nor the units-row hint of a text cell
    p.write_text("time,u,y\n08:00:00,1,2\n08:00:01,1,3\n")
    with pytest.raises(RecordingError, match=r"value '08:00:00' at row 0 .*times of day") as e:
        read_recording(p)
    assert "units row" not in str(e.value)
    p.write_text("time,u,y\n0,true,2\n1,false,3\n")
    with pytest.raises(RecordingError, match=r"'u' holds .* True at row 0 .*true/false: give 1/0"):
        read_recording(p)


def test_explicit_units_must_agree_with_sidecar(tmp_path):
    write_recording(make_rec(), tmp_path / "a.csv")
    r = read_recording(tmp_path / "a.csv", units={"T_P": "degC"}, roles={"T_P": "output"})
    assert r.units["T_P"] == "°C"
    with pytest.raises(UnitError, match="'T_P' the unit '°C', the argument 'K'"):
        read_recording(tmp_path / "a.csv", units={"T_P": "K"})
    with pytest.raises(RecordingError, match="role 'output', the argument 'input'"):
        read_recording(tmp_path / "a.csv", roles={"T_P": "input"})
    r = read_recording(tmp_path / "a.csv", experiment_id="new", meta={"extra": 1})
    assert r.experiment_id == "new" and r.meta["extra"] == 1 and r.meta["protocol"] == "ramp"


@pytest.mark.parametrize(
    ("content", "pattern"),
    [
        ("", r"is empty \(0 bytes\)"),
        ("time,u\n", "header but no samples"),
        ("x,u,T_P\n0,1,2\n", r"no time column 'time'; its columns are \['x', 'u', 'T_P'\]"),
        (
            "time,u,T_P\n0,1,2\n1,1,2\n2,x1,3\n",
            r"column 'u' holds a non-numeric value 'x1' at row 2 \(line 4\)",
        ),
        (
            "time,u\n0,1\n1,2\n0.5,3\n",
            r"not strictly increasing at index 2: time\[1\] = 1\.0 s, time\[2\] = 0\.5 s",
        ),
        ("time,u\n0,1\n,2\n", r"time is nan at index 1"),
        ("time,u,u\n0,1,2\n", r"\['u'\] appear more than once"),
        ("time,u\n0,1\n1,2,3\n", "cannot read CSV"),
        ("time,u\n0,true\n1,false\n", r"column 'u' holds a non-numeric value .*True.* at row 0"),
    ],
)
def test_bad_csv_files(tmp_path, content, pattern):
    p = tmp_path / "bad.csv"
    p.write_text(content)
    with pytest.raises(RecordingError, match=pattern) as e:
        read_recording(p)
    assert "bad.csv" in str(e.value)


def test_missing_file_unknown_extension_and_corrupt_files(tmp_path):
    with pytest.raises(RecordingError, match="does not exist"):
        read_recording(tmp_path / "nope.csv")
    (tmp_path / "a.txt").write_text("time\n0\n")
    with pytest.raises(RecordingError, match=r"'\.csv', '\.csv\.gz', '\.parquet'"):
        read_recording(tmp_path / "a.txt")
    with pytest.raises(RecordingError, match="extension"):
        write_recording(make_rec(), tmp_path / "a.xlsx")
    assert listing(tmp_path) == ["a.txt"]
    (tmp_path / "junk.parquet").write_bytes(b"PAR1 this is not parquet")
    with pytest.raises(RecordingError, match="cannot read PARQUET file"):
        read_recording(tmp_path / "junk.parquet")
    with pytest.raises(RecordingError, match="not a file"):
        read_recording(tmp_path)  # a folder


def test_corrupt_or_mismatched_sidecar(tmp_path):
    p = write_recording(make_rec(), tmp_path / "a.csv")
    side = sidecar_path(p)
    good = side.read_text()
    side.write_text('{\n  "units": {"u": "1",\n}')
    with pytest.raises(RecordingError, match=r"not valid JSON \(line 3, column 1\)"):
        read_recording(p)
    side.write_text(json.dumps({"units": {}, "colour": "red"}))
    with pytest.raises(RecordingError, match=r"unknown key\(s\) \['colour'\]"):
        read_recording(p)
    side.write_text(json.dumps({"units": ["°C"]}))
    with pytest.raises(RecordingError, match="'units' is a list"):
        read_recording(p)
    side.write_text(good.replace('"x_V"', '"x_P"', 1))
    with pytest.raises(RecordingError, match=r"describe columns .* but the file has"):
        read_recording(p)
    side.write_text(json.dumps({"units": {"nope": "V"}}))
    with pytest.raises(RecordingError, match="'nope'"):
        read_recording(p)
    side.write_text(json.dumps({"units": {"time": "ms"}}))  # was the one message without the file
    with pytest.raises(UnitError, match=r"a\.csv': time is always in seconds.*'ms'"):
        read_recording(p)


def test_overwrite_false_refuses_and_keeps_bytes(tmp_path):
    p = write_recording(make_rec(), tmp_path / "a.csv")
    before = {f: (tmp_path / f).read_bytes() for f in listing(tmp_path)}
    with pytest.raises(RecordingError, match="exists and overwrite=False"):
        write_recording(make_rec(6).with_columns(u=0.0), p, overwrite=False)
    assert {f: (tmp_path / f).read_bytes() for f in listing(tmp_path)} == before
    # an orphan sidecar also blocks writing
    p.unlink()
    with pytest.raises(RecordingError, match=r"a\.csv\.meta\.json"):
        write_recording(make_rec(), p, overwrite=False)
    assert listing(tmp_path) == ["a.csv.meta.json"]
    write_recording(make_rec(), tmp_path / "b.parquet", overwrite=False)
    with pytest.raises(RecordingError, match="exists"):
        write_recording(make_rec(), tmp_path / "b.parquet", overwrite=False)
    write_recording(make_rec(4), tmp_path / "b.parquet", overwrite=True)
    assert read_recording(tmp_path / "b.parquet").n_samples == 4


def test_unserialisable_meta_writes_nothing(tmp_path):
    p = write_recording(make_rec(), tmp_path / "a.csv")
    before = {f: (tmp_path / f).read_bytes() for f in listing(tmp_path)}
    bad = make_rec(4, meta={"prep": {"fn": object()}})
    for target in (p, tmp_path / "new.csv", tmp_path / "new.parquet"):
        with pytest.raises(RecordingError, match=r"recording\['meta'\]\['prep'\]\['fn'\]"):
            write_recording(bad, target)
    assert {f: (tmp_path / f).read_bytes() for f in listing(tmp_path)} == before


@pytest.mark.parametrize("name", ["a.csv", "a.parquet"])
def test_failure_midway_leaves_files_untouched(tmp_path, monkeypatch, name):
    p = write_recording(make_rec(), tmp_path / name)
    before = {f: (tmp_path / f).read_bytes() for f in listing(tmp_path)}

    def half_written(table, where, *args, **kwargs):
        Path(where).write_text("time,u\n0,")
        raise OSError("disk full")

    monkeypatch.setattr(recfiles.pa_csv, "write_csv", half_written)
    monkeypatch.setattr(recfiles.pq, "write_table", half_written)
    for target in (p, tmp_path / f"new_{name}"):
        with pytest.raises(RecordingError, match="disk full"):
            write_recording(make_rec(3), target)
    assert {f: (tmp_path / f).read_bytes() for f in listing(tmp_path)} == before


def test_sidecar_failure_leaves_csv_untouched(tmp_path, monkeypatch):
    p = write_recording(make_rec(), tmp_path / "a.csv")
    before = {f: (tmp_path / f).read_bytes() for f in listing(tmp_path)}
    real = Path.write_text

    def failing(self, text, *a, **k):
        if self.name.startswith(".a.csv.meta.json"):
            real(self, text[:5])
            raise OSError("quota exceeded")
        return real(self, text, *a, **k)

    monkeypatch.setattr(Path, "write_text", failing)
    with pytest.raises(RecordingError, match="quota exceeded"):
        write_recording(make_rec(3), p)
    assert {f: (tmp_path / f).read_bytes() for f in listing(tmp_path)} == before


def test_write_into_missing_folder(tmp_path):
    with pytest.raises(RecordingError, match="does not exist"):
        write_recording(make_rec(), tmp_path / "no" / "a.csv")


# ------------------------------------------------------------------- atomic writing


def test_atomic_write_keeps_old_file_on_error(tmp_path):
    p = tmp_path / "f.txt"
    atomic_write(p, lambda tmp: tmp.write_text("old"))

    def boom(tmp: Path) -> None:
        tmp.write_text("half")
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        atomic_write(p, boom)
    assert p.read_text() == "old" and listing(tmp_path) == ["f.txt"]
    with pytest.raises(FileExistsError):
        atomic_write(p, lambda tmp: tmp.write_text("new"), overwrite=False)
    assert p.read_text() == "old" and listing(tmp_path) == ["f.txt"]


def test_atomic_write_many_is_all_or_nothing(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"

    def fail(tmp: Path) -> None:
        raise ValueError("second file cannot be written")

    with pytest.raises(ValueError, match="second"):
        atomic_write_many({a: lambda t: t.write_text("A"), b: fail})
    assert listing(tmp_path) == []
    atomic_write_many([(a, lambda t: t.write_text("A")), (b, lambda t: t.write_text("B"))])
    assert a.read_text() + b.read_text() == "AB"
    a.chmod(0o600)
    atomic_write(a, lambda t: t.write_text("A2"))
    assert a.read_text() == "A2" and (a.stat().st_mode & 0o777) == 0o600
    with pytest.raises(ValueError, match="named twice"):
        atomic_write_many([(a, fail), (tmp_path / "x" / ".." / "a", fail)])


def test_to_jsonable_names_offender():
    assert to_jsonable({"a": np.arange(2.0), "b": np.float32(np.inf)}) == {
        "a": [0.0, 1.0],
        "b": None,
    }
    with pytest.raises(TypeError, match=r"meta\['x'\]\[1\] is of type set"):
        to_jsonable({"x": [1, {2}]}, "meta")
    with pytest.raises(TypeError, match="key 3"):
        to_jsonable({3: 1})


def test_errors_share_the_root_and_roles_match_models():
    from thermogym.models.base import ROLES

    assert issubclass(RecordingError, ThermogymError) and issubclass(UnitError, RecordingError)
    assert recmod.ROLES == ROLES
