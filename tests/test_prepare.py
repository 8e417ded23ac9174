"""Data preparation against hand-made data whose defects are known exactly."""

from __future__ import annotations

import numpy as np
import pytest

from thermogym.errors import ConfigError, IdentificationError, RecordingError
from thermogym.identification.prepare import (
    PrepareConfig,
    align,
    check_identification_data,
    detrend,
    fill_gaps,
    hampel_mask,
    nan_runs,
    prepare,
    remove_outliers,
    resample,
    subtract_ambient,
)
from thermogym.recording import Recording


@pytest.fixture
def rng():
    return np.random.default_rng(7)


def smooth_channel(rng, n=3000):
    t = np.sort(rng.uniform(0.0, 3000.0, n))
    y = 25.0 + 10.0 * (1 - np.exp(-t / 800.0)) + 0.02 * rng.standard_normal(n)
    return t, y


def test_hampel_finds_exactly_the_injected_spikes(rng):
    _, y = smooth_channel(rng)
    idx = np.array([100, 101, 1500, 2999])  # a pair, one inside, one at the end
    y[idx] += np.array([40.0, 25.0, -30.0, 50.0])
    assert np.flatnonzero(hampel_mask(y)).tolist() == idx.tolist()


def test_hampel_leaves_a_clean_noisy_channel_alone(rng):
    _, y = smooth_channel(rng, 20000)
    assert hampel_mask(y).sum() == 0


def test_hampel_keeps_steps_of_a_commanded_signal():
    u = np.r_[np.zeros(50), np.full(50, 6000.0), np.zeros(50)]
    assert not hampel_mask(u).any()


def test_remove_outliers_range_and_hampel_on_asynchronous_channels(rng):
    t, y = smooth_channel(rng)
    y[::3] = np.nan  # another channel sampled here
    y[[10, 20]] = [300.0, -50.0]  # open-circuit readings at the RTD range limits
    y[601] += 35.0  # a glitch
    other = np.where(np.isnan(y), 24.0, np.nan)
    rec = Recording(t, {"T": y, "T_amb": other}, roles={"T": "output", "T_amb": "disturbance"})
    out, rep = remove_outliers(rec, valid_range=(-50, 300))
    removed = rep["removed"]["T"]
    assert removed["count"] == 3 and removed["out_of_range"] == 2 and removed["hampel"] == 1
    assert sorted(removed["values"]) == sorted([300.0, -50.0, float(y[601])])
    # nothing else changed, the other channel's NaN pattern is untouched
    changed = np.isnan(out["T"]) != np.isnan(rec["T"])
    assert np.flatnonzero(changed).tolist() == [10, 20, 601]
    assert np.array_equal(np.isnan(out["T_amb"]), np.isnan(rec["T_amb"]))
    assert out.meta["preparation"]["steps"][-1]["step"] == "remove_outliers"


def test_remove_outliers_skips_commanded_inputs():
    t = np.arange(100.0)
    u = np.zeros(100)
    u[40] = 100.0  # a one-sample pulse of a PRBS: not a glitch
    rec = Recording(t, {"u": u, "y": np.ones(100)}, roles={"u": "input", "y": "output"})
    out, rep = remove_outliers(rec)
    assert out["u"][40] == 100.0 and "u" not in rep["removed"]


def test_resample_is_exact_for_a_linear_signal_and_marks_gaps(rng):
    t = np.arange(0.0, 400.0, 0.6) + rng.uniform(0.0, 0.3, 667)  # a jittery 1.67 Hz logger
    t = t[(t < 100) | (t > 150)]  # a 50 s drop-out
    rec = Recording(t, {"y": 2.0 + 0.5 * t})
    out, rep = resample(rec, 1.0)
    assert out.is_uniform() and out.dt == 1.0
    ok = np.isfinite(out["y"])
    assert np.allclose(out["y"][ok], 2.0 + 0.5 * out.time[ok], atol=1e-9)
    gap = (out.time > 100.5) & (out.time < 149.5)
    assert np.isnan(out["y"][gap]).all()
    assert rep["channels"]["y"]["gaps"] == 1


def test_resample_mean_averages_the_bin():
    t = np.array([0.0, 0.2, 0.4, 0.9, 1.1, 1.3, 2.0])
    y = np.array([1.0, 3.0, 5.0, 7.0, 9.0, 11.0, 4.0])
    out, _ = resample(Recording(t, {"y": y}), 1.0, method="mean")
    # bins [-0.5, 0.5), [0.5, 1.5), [1.5, 2.5)
    assert out["y"].tolist() == [3.0, 9.0, 4.0]


def test_fill_gaps_interpolates_short_and_names_long_gaps():
    t = np.arange(300.0)
    y = 1.0 + 0.1 * t
    y[50:70] = np.nan  # 21 s between the valid samples 49 and 70
    y[200:260] = np.nan  # 61 s between 199 and 260
    rec = Recording(t, {"T_bearing": y})
    with pytest.raises(RecordingError) as e:
        fill_gaps(rec, max_gap_s=60.0)
    msg = str(e.value)
    assert "'T_bearing'" in msg and "from 199 s to 260 s" in msg and "61 s" in msg
    out, rep = fill_gaps(rec, max_gap_s=61.0)
    assert np.allclose(out["T_bearing"], 1.0 + 0.1 * t)
    assert rep["filled"]["T_bearing"] == {
        "gaps": 2,
        "points": 80,
        "longest_s": 61.0,
        "leading_nan": 0,
        "trailing_nan": 0,
    }


def test_align_starts_where_all_channels_are_valid():
    t = np.arange(10.0) + 100.0
    a = np.r_[np.nan, np.nan, np.arange(8.0)]
    b = np.r_[np.arange(9.0), np.nan]
    out, rep = align(Recording(t, {"a": a, "b": b}))
    assert out.time[0] == 0.0 and out.n_samples == 7
    assert rep["t_offset_s"] == 102.0 and rep["dropped_start"] == 2 and rep["dropped_end"] == 1
    assert out["a"][0] == 0.0 and out["b"][0] == 2.0


def test_subtract_ambient_and_detrend():
    t = np.arange(5.0)
    rec = Recording(
        t,
        {"T1": 30 + t, "T2": 40 - t, "T_amb": 20 + 0.5 * t, "n": np.full(5, 6000.0)},
        units={"T1": "°C", "T2": "°C", "T_amb": "°C", "n": "rpm"},
    )
    out, rep = subtract_ambient(rec, "T_amb")
    assert rep["columns"] == ["T1", "T2"]
    assert np.allclose(out["T1"], 10 + 0.5 * t) and out.units["T1"] == "K"
    assert out["n"][0] == 6000.0 and "T_amb" in out
    assert "T_amb" not in subtract_ambient(rec, "T_amb", drop=True)[0]
    lin, rep = detrend(out, "linear", ["T1"])
    assert np.allclose(lin["T1"], 0.0, atol=1e-12) and rep["slope_per_s"]["T1"] == pytest.approx(
        0.5
    )
    ini, _ = detrend(out, "initial", ["T2"])
    assert ini["T2"][0] == 0.0
    with pytest.raises(ConfigError):
        subtract_ambient(rec, "T_room")


def test_prepare_a_raw_spindle_day_removes_the_injected_outliers():
    from thermogym.rigs import get_rig, to_recording

    run = get_rig("spindle").run("run-in", seed=11, speeds=[5000], folds=[1])[0]
    rec = to_recording(run, "spindle")
    out = prepare(rec, valid_range=(-50.0, 300.0), ambient="T_amb", max_gap_s=120.0)
    steps = {s["step"]: s for s in out.meta["preparation"]["steps"]}
    assert list(steps) == ["remove_outliers", "resample", "align", "fill_gaps", "subtract_ambient"]
    assert out.meta["preparation"]["raw_fingerprint"] == rec.fingerprint()
    truth_t = np.arange(run.truth["T_amb"].size, dtype=float)
    for c in [c for c in rec.columns if c != "speed"]:
        raw = rec[c]
        ok = np.isfinite(raw)
        dev = np.abs(raw[ok] - np.interp(rec.time[ok], truth_t, run.truth[c]))
        injected = set(np.round(rec.time[ok][dev > 1.0], 3))
        removed = set(np.round(steps["remove_outliers"]["removed"][c]["times_s"], 3))
        assert injected <= removed, c  # every glitch and open-circuit reading is gone
        assert len(removed - injected) <= 2, c  # and hardly anything else
    assert out.is_uniform() and out.dt == 1.0
    t0 = int(steps["align"]["t_offset_s"])
    for c in ("T_front_bearing_C", "T_rear_outer_housing"):
        truth = run.truth[c][t0 : t0 + out.n_samples] - run.truth["T_amb"][t0 : t0 + out.n_samples]
        rms = np.sqrt(np.mean((out[c] - truth) ** 2))
        assert rms < 0.05  # RTD noise 0.02 K on the channel and on the ambient


def test_prepare_refuses_nan_only_channel_and_unknown_option():
    t = np.arange(10.0)
    rec = Recording(t, {"u": t, "T_dead": np.full(10, np.nan)})
    with pytest.raises(RecordingError, match="T_dead"):
        prepare(rec)
    assert prepare(rec, columns=("u",)).columns == ("u",)
    with pytest.raises(ConfigError, match="hampel_windo"):
        prepare(rec, hampel_windo=3)
    assert PrepareConfig().to_dict()["dt"] == 1.0


def test_check_identification_data_gives_clear_errors():
    t = np.arange(20.0)
    rec = Recording(t, {"u": np.ones(20), "v": t, "y": t**2, "z": np.r_[np.nan, t[1:]]})
    with pytest.raises(IdentificationError, match=r"input 'u'.*constant"):
        check_identification_data(rec, ["u"], ["y"])
    check_identification_data(rec, ["u"], ["y"], step_inputs=True)  # a step at t = 0
    with pytest.raises(IdentificationError, match="at least 50 samples"):
        check_identification_data(rec, ["v"], ["y"], min_samples=50)
    with pytest.raises(RecordingError, match="'z'"):
        check_identification_data(rec, ["v"], ["z"])
    with pytest.raises(RecordingError, match="not uniformly sampled"):
        check_identification_data(Recording(t**1.1, {"v": t, "y": t}), ["v"], ["y"])


def test_nan_runs():
    s, e = nan_runs(np.array([False, True, False, False, True]))
    assert s.tolist() == [0, 2] and e.tolist() == [1, 4]
