"""Fit metrics against hand-computed values."""

from __future__ import annotations

import numpy as np
import pytest

from thermogym.errors import ShapeError
from thermogym.identification.metrics import (
    accuracy_xi,
    confidence_interval,
    fit_report,
    mnrmse,
    nrmse,
    rmse,
    sse,
    train_validation_accuracy,
    weighted_criterion,
)

Y = np.array([1.0, 2.0, 4.0, 5.0])
YH = np.array([1.0, 3.0, 3.0, 5.0])


def test_sse_rmse_by_hand():
    assert sse(Y, YH) == 2.0  # (0 + 1 + 1 + 0)
    assert rmse(Y, YH) == pytest.approx(np.sqrt(2.0 / 4.0))


def test_nrmse_and_xi_by_hand():
    # ‖y − ŷ‖ = √2, mean 3, ‖y − 3‖ = √(4+1+1+4) = √10
    assert nrmse(Y, YH) == pytest.approx(1 - np.sqrt(2) / np.sqrt(10))
    # ‖y‖ = √(1+4+16+25) = √46
    assert accuracy_xi(Y, YH) == pytest.approx(1 - np.sqrt(2) / np.sqrt(46))


def test_batch_and_nan_handling():
    yh = np.stack([YH, Y, Y + 1])
    np.testing.assert_allclose(nrmse(Y, yh), [1 - np.sqrt(2 / 10), 1.0, 1 - np.sqrt(4 / 10)])
    y = Y.copy()
    y[1] = np.nan  # a missing measurement is ignored, not propagated
    assert sse(y, YH) == 1.0
    assert np.isnan(nrmse([2.0, 2.0, 2.0], [2.0, 2.0, 2.0]))  # nothing to explain
    assert np.isnan(rmse([np.nan, np.nan], [1.0, 2.0]))


def test_mnrmse_is_mean_over_outputs():
    y = np.stack([Y, 2 * Y])
    yh = np.stack([YH, 2 * Y])
    assert mnrmse(y, yh) == pytest.approx(0.5 * (1 - np.sqrt(0.2) + 1.0))


def test_weighted_criterion_eq4():
    y = {"a": Y, "b": Y}
    yh = {"a": YH, "b": Y + 2}
    expected = 1.0 * np.sqrt(0.5) + 0.25 * 2.0
    assert weighted_criterion(y, yh, {"a": 1.0, "b": 0.25}) == pytest.approx(expected)
    with pytest.raises(ShapeError, match="lack"):
        weighted_criterion(y, {"a": YH})


def test_train_validation_accuracy_eqs_7_to_9():
    ta, va = train_validation_accuracy([[0.99, 0.97], [0.95, 0.98]])
    assert ta == pytest.approx(0.985) and va == pytest.approx(0.96)
    with pytest.raises(ShapeError):
        train_validation_accuracy([[1.0, 2.0]])


def test_confidence_interval_eq23_with_the_papers_t():
    x = np.array([4.0, 4.2, 3.8, 4.1, 3.9] * 3)  # n = 15
    lo, hi = confidence_interval(x, t=2.98)
    half = 2.98 * x.std(ddof=1) / np.sqrt(15)
    assert lo == pytest.approx(x.mean() - half) and hi == pytest.approx(x.mean() + half)
    # the default Student factor for n = 15, γ = 99 % is the paper's 2.98
    lo2, _ = confidence_interval(x, gamma=0.99)
    assert lo2 == pytest.approx(lo, rel=1e-3)


def test_fit_report_collects_per_signal_values():
    rep = fit_report({"a": Y}, {"a": YH})
    assert rep["nrmse"]["a"] == pytest.approx(nrmse(Y, YH))
    assert rep["mnrmse"] == pytest.approx(nrmse(Y, YH))
