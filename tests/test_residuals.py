"""Residual analysis of diagnosis: FFT correlations, Ljung-Box and independence tests."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import lfilter

from thermogym.errors import ShapeError
from thermogym.identification.residuals import (
    autocorrelation,
    cross_correlation,
    noise_sigma,
    residual_tests,
)


def _direct_xcorr(a, b, M):
    a = a - a.mean()
    b = b - b.mean()
    den = np.sqrt(a @ a * (b @ b))
    out = []
    for tau in range(-M, M + 1):
        if tau >= 0:
            out.append(a[tau:] @ b[: a.size - tau])
        else:
            out.append(a[: a.size + tau] @ b[-tau:])
    return np.array(out) / den


def test_fft_cross_correlation_equals_the_direct_sum():
    rng = np.random.default_rng(0)
    a, b = rng.standard_normal(500), rng.standard_normal(500)
    np.testing.assert_allclose(cross_correlation(a, b, 30), _direct_xcorr(a, b, 30), atol=1e-12)
    r = autocorrelation(a, 10)
    assert r[0] == 1.0
    np.testing.assert_allclose(r, _direct_xcorr(a, a, 10)[10:], atol=1e-12)


def test_positive_lag_means_the_input_acts_earlier():
    rng = np.random.default_rng(1)
    u = rng.standard_normal(4000)
    e = np.r_[np.zeros(7), u[:-7]]  # e[k] = u[k - 7]
    r = cross_correlation(e, u, 20)
    assert int(np.argmax(r)) - 20 == 7


def test_whiteness_test_has_its_nominal_false_alarm_rate():
    # calibration: white residuals are rejected at about the test level
    rng = np.random.default_rng(2)
    rejected = 0
    for _ in range(200):
        t = residual_tests([rng.standard_normal(3000)], [{"u": rng.standard_normal(3000)}])
        rejected += t.p_white < 0.05
    assert rejected / 200 < 0.1


def test_colored_but_independent_residual_is_not_blamed_on_the_input():
    # an AR(1) residual and a slow random-telegraph input are independent: the bound widened
    # by P = Σ r_e r_u must keep the false alarm rate low even though both are autocorrelated
    rng = np.random.default_rng(3)
    alarms = 0
    for _ in range(100):
        e = lfilter([1.0], [1.0, -0.9], rng.standard_normal(5000))
        u = np.repeat(rng.integers(0, 2, 50), 100).astype(float)
        t = residual_tests([e], [{"u": u}], max_lag=25)
        alarms += t.p_independent["u"] < 0.01
        assert t.p_white < 1e-6  # the AR(1) residual is not white
    assert alarms / 100 < 0.1


def test_residual_driven_by_the_input_is_detected_by_both_tests():
    rng = np.random.default_rng(4)
    u = np.repeat(rng.integers(0, 2, 100), 60).astype(float)
    e = 0.3 * lfilter([0.05], [1.0, -0.95], u) + 0.05 * rng.standard_normal(u.size)
    t = residual_tests([e], [{"u": u}])
    assert t.p_white < 1e-10 and t.p_independent["u"] < 1e-10
    assert t.systematic_rms > 2 * t.sigma and t.material(0.5, 0.002)


def test_pooled_over_recordings_and_a_day_at_one_hertz_is_fine():
    rng = np.random.default_rng(5)
    n = 86_400
    recs = [rng.standard_normal(n) * 0.02 for _ in range(2)]
    u = [np.repeat(rng.integers(0, 2, n // 3600), 3600).astype(float) for _ in range(2)]
    t = residual_tests(recs, [{"speed": x} for x in u], signal="T")
    assert t.n_samples == 2 * n and t.q_dof == 50
    assert abs(t.sigma - 0.02) < 0.001 and not t.material(0.5, 0.0)


def test_noise_sigma_ignores_a_slow_systematic_error():
    rng = np.random.default_rng(6)
    t = np.arange(20_000.0)
    e = 2.0 * np.sin(t / 3000.0) + 0.05 * rng.standard_normal(t.size)
    assert noise_sigma(e) == pytest.approx(0.05, rel=0.05)


def test_bad_input_is_refused():
    with pytest.raises(ShapeError, match="at least one"):
        residual_tests([], [])
    with pytest.raises(ShapeError, match="equal lengths"):
        cross_correlation(np.ones(10), np.ones(12), 2)
    with pytest.raises(ShapeError, match="fewer than 8"):
        residual_tests([np.ones(4)], [{"u": np.ones(4)}])
