"""k-fold cross-validation of the N4SID order (paper 001, eqs 7-10)."""

from __future__ import annotations

import numpy as np
import pytest

from thermogym.errors import ConfigError, IdentificationError
from thermogym.identification.crossval import cross_validate_order, split_recording
from thermogym.identification.metrics import train_validation_accuracy
from thermogym.identification.n4sid import simulate_ss
from thermogym.recording import Recording

# a third-order system with well separated poles: orders 1 and 2 cannot explain it
A = np.diag([0.97, 0.8, 0.5])
B = np.array([[0.3], [1.0], [-1.5]])
C = np.array([[1.0, 1.0, 1.0], [0.5, -1.0, 0.2]])


def experiment(seed: int, n: int = 1500, noise: float = 0.02) -> Recording:
    rng = np.random.default_rng(seed)
    u = np.repeat(rng.normal(size=n // 5), 5)[:, None]
    y = simulate_ss(A, B, C, np.zeros((2, 1)), u)
    y = y + noise * y.std(axis=0) * rng.standard_normal(y.shape)
    return Recording(
        np.arange(n, dtype=float),
        {"u": u[:, 0], "y1": y[:, 0], "y2": y[:, 1]},
        experiment_id=f"run{seed}",
    )


def test_cross_validation_picks_the_true_order():
    cv = cross_validate_order(
        [experiment(1), experiment(2)], ["u"], ["y1", "y2"], range(1, 9), decimate=1
    )
    assert cv.parsimonious_order == 3
    va = dict(zip(cv.orders.tolist(), cv.va, strict=True))
    assert va[3] > va[2] + 0.02 > va[1] + 0.02  # lower orders are clearly worse
    # eq (10): argmax VA is the true order or one that fits the noise, no better than it
    assert cv.best_order >= 3 and va[cv.best_order] - va[3] < cv.tolerance
    assert cv.folds == [["run1"], ["run2"]] and cv.scheme == "paper"


def test_ta_va_are_eqs_8_9_of_the_fits_matrix():
    cv = cross_validate_order(
        [experiment(3), experiment(4)], ["u"], ["y1", "y2"], [2, 3, 4], decimate=1
    )
    for o in range(3):
        ta, va = train_validation_accuracy(cv.fits[o])
        assert cv.ta[o] == ta and cv.va[o] == va
        # MNRMSE (eq 6) is the mean of the per-output fits
        assert np.allclose(cv.fits[o], cv.output_fits[o].mean(axis=-1))
    assert set(cv.seconds) == {"decomposition", "models", "evaluation", "total"}
    d = cv.to_dict()
    assert d["best_order"] == cv.best_order and len(d["fits"]) == 3


def test_kfold_scheme_with_three_folds_and_one_split_recording():
    parts = split_recording(experiment(5, n=3000), 3)
    assert [p.n_samples for p in parts] == [1000, 1000, 1000]
    assert parts[1].time[0] == 1000.0 and parts[2].experiment_id == "run5-part3"
    cv = cross_validate_order(parts, ["u"], ["y1", "y2"], [1, 3], scheme="kfold", decimate=1)
    assert cv.fits.shape == (2, 3, 3) and cv.va[1] > cv.va[0]
    assert cv.va[1] == pytest.approx(np.mean([cv.fits[1][i, i] for i in range(3)]))


def test_errors():
    with pytest.raises(ConfigError, match="at least 2 folds"):
        cross_validate_order([experiment(1)], ["u"], ["y1"], [1])
    with pytest.raises(ConfigError, match="scheme"):
        cross_validate_order([experiment(1), experiment(2)], ["u"], ["y1"], [1], scheme="loo")
    with pytest.raises(IdentificationError, match="horizon"):
        cross_validate_order(
            [experiment(1), experiment(2)], ["u"], ["y1"], [30], horizon=4, decimate=1
        )
    with pytest.raises(ConfigError):
        split_recording(experiment(1), 1)
