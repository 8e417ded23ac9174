"""Rig sensors: white and coloured noise, lag, quantisation, spikes, dropouts, offset, drift."""

from __future__ import annotations

import numpy as np
import pytest

from thermogym.errors import ShapeError, ThermogymError
from thermogym.rigs.sensors import N_RANDOM, Sensor, SensorStream


def _rng(seed=0):
    return np.random.default_rng(seed)


def test_white_and_coloured_noise_have_their_variance_and_correlation():
    t = np.arange(200_000.0)
    e = Sensor(noise=0.1).measure(np.zeros(t.size), _rng(), t)
    assert e.std() == pytest.approx(0.1, rel=0.02)
    assert abs(np.corrcoef(e[1:], e[:-1])[0, 1]) < 0.01  # white
    c = Sensor(colored=0.2, colored_tau=50.0).measure(np.zeros(t.size), _rng(1), t)
    assert c.std() == pytest.approx(0.2, rel=0.1)
    # an Ornstein-Uhlenbeck process: correlation exp(−lag / τ)
    for lag in (10, 50):
        r = np.corrcoef(c[lag:], c[:-lag])[0, 1]
        assert r == pytest.approx(np.exp(-lag / 50.0), abs=0.03)
    # the same law on an uneven grid (exact sampling)
    tu = np.cumsum(_rng(2).uniform(0.5, 1.5, 100_000))
    cu = Sensor(colored=0.2, colored_tau=50.0).measure(np.zeros(tu.size), _rng(3), tu)
    assert cu.std() == pytest.approx(0.2, rel=0.1)


def test_lag_is_exact_for_a_ramp_and_starts_in_equilibrium():
    tau = 20.0
    t = np.arange(0.0, 400.0, 2.0)
    x = 20.0 + 0.1 * t  # a ramp: a first-order lag trails it by τ·slope after the transient
    y = Sensor(lag=tau).measure(x, _rng(), t)
    truth = 20.0 + 0.1 * (t - tau * (1.0 - np.exp(-t / tau)))
    np.testing.assert_allclose(y, truth, atol=1e-9)
    # the stream gives the same values sample by sample
    s = SensorStream(Sensor(lag=tau), 1)
    s.start([0], x[:1], np.zeros((1, N_RANDOM)))
    z = np.zeros((1, N_RANDOM))
    z[:, 2:] = 0.999  # no spikes, no dropouts
    ys = [s.first([0], z)[0]]
    for k in range(1, t.size):
        ys.append(s.sample(np.array([True]), x[k : k + 1], 2.0, z)[0])
    np.testing.assert_allclose(ys, truth, atol=1e-9)


def test_quantisation_offset_drift_and_span():
    t = np.arange(3601.0)
    y = Sensor(resolution=0.5, offset=1.0, drift=2.0, span=(0.0, 22.0)).measure(
        np.full(t.size, 20.1), _rng(), t
    )
    assert y[0] == 21.0  # 20.1 + 1.0 → 21.1 → 21.0
    assert y[-1] == 22.0  # +2 K after an hour, clipped at the top of the range
    assert np.allclose(y * 2, np.round(y * 2))


def test_spikes_and_dropouts_at_their_rates():
    t = np.arange(360_000.0)  # 100 h at 1 s
    s = Sensor(spike_rate=2.0, spike_size=3.0, dropout_rate=1.0, dropout_s=20.0)
    y = s.measure(np.zeros(t.size), _rng(), t)
    spikes = np.abs(np.nan_to_num(y)) > 1.0
    assert 150 < spikes.sum() < 250  # 2 per hour
    assert np.all(np.abs(y[spikes]) >= 1.5) and np.all(np.abs(y[spikes]) <= 4.5)
    assert abs(np.mean(np.sign(y[spikes]))) < 0.3  # both signs
    lost = np.isnan(y)
    starts = np.count_nonzero(lost[1:] & ~lost[:-1])
    assert 70 < starts < 130 and lost.sum() / starts == pytest.approx(20.0, rel=0.25)
    held = s.replace(dropout="hold").measure(np.arange(t.size) * 1e-3, _rng(), t)
    assert np.isfinite(held).all()
    run = np.flatnonzero(np.diff(held) == 0.0)
    assert run.size > 500  # held samples repeat the last value


def test_switching_one_stage_off_keeps_the_others_draws():
    t = np.arange(1000.0)
    full = Sensor(noise=0.1, colored=0.1).measure(np.zeros(1000), _rng(5), t)
    white = Sensor(noise=0.1).measure(np.zeros(1000), _rng(5), t)
    col = Sensor(colored=0.1).measure(np.zeros(1000), _rng(5), t)
    np.testing.assert_allclose(full, white + col, atol=1e-12)


def test_batches_and_bad_settings():
    y = Sensor(noise=0.1).measure(np.zeros((3, 4, 50)), _rng(), np.arange(50.0))
    assert y.shape == (3, 4, 50) and np.unique(y).size == y.size
    with pytest.raises(ThermogymError):
        Sensor(noise=-1.0)
    with pytest.raises(ThermogymError):
        Sensor(dropout="zero")
    with pytest.raises(ShapeError, match="time"):
        Sensor().measure(np.zeros(5), _rng(), np.arange(4.0))
    with pytest.raises(ShapeError, match="increase"):
        Sensor().measure(np.zeros(3), _rng(), np.array([0.0, 2.0, 1.0]))


#: Where each rig's lags and its spikes/dropouts live when not in its Sensor settings: a row
#: of the plant's table (probe lags are plant states there) or the raw protocol (the
#: spindle's multiplexer writes its outliers and Bluetooth drop-outs itself).
_PLANT_LAG_ROWS = {"strut": "thermocouple_lag", "spindle": "sensor_mounting"}
_RAW_FAULTS = {"spindle"}


@pytest.mark.parametrize("name", ["axt211", "room", "spindle", "strut"])
def test_every_rig_has_coloured_noise_quantisation_lags_and_faults(name):
    # issue 14: "sensors on every rig: coloured (not only white) noise, quantisation, lags,
    # and the occasional spike or dropout"
    from thermogym.rigs import get_rig

    rig = get_rig(name)
    sensors = list(rig.sensors.values())
    assert any(s.colored > 0 and s.colored_tau > 0 for s in sensors), "coloured noise"
    assert all(s.resolution > 0 for s in sensors), "quantisation"
    rows = {e.name for e in rig.plant().extras}
    assert any(s.lag > 0 for s in sensors) or _PLANT_LAG_ROWS.get(name) in rows, "lags"
    faults = any(s.spike_rate > 0 or s.dropout_rate > 0 for s in sensors)
    assert faults or name in _RAW_FAULTS, "spikes or dropouts"


def test_room_bus_polls_hold_the_last_value_and_contact_sensors_spike():
    from thermogym.rigs import get_rig

    s = get_rig("room").sensors
    t = np.arange(0.0, 400 * 3600.0, 60.0)  # 400 h at 1 min
    truth = 21.0 + np.sin(t / 5000.0)  # always moving: a repeated reading is a held poll
    zone = s["T_zone"].replace(noise=0.0, colored=0.0, resolution=0.0).measure(truth, _rng(3), t)
    held = np.count_nonzero(np.diff(zone) == 0.0)
    # 0.1 polls lost per hour, 3 min each (on a 1 min grid: about 3 held samples each)
    assert 40 < held < 250 and np.isfinite(zone).all()
    sup = s["T_supply"].replace(noise=0.0, lag=0.0, resolution=0.0).measure(truth, _rng(4), t)
    spikes = np.abs(sup - truth) > 0.9
    assert 8 <= spikes.sum() <= 35  # 0.05 per hour over 400 h: 20 expected
