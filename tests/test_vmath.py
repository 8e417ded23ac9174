"""The vectorisable power function of the room model (thermogym.models._vmath)."""

from __future__ import annotations

import math

import numba as nb
import numpy as np
import pytest

from thermogym.models._vmath import vexp, vlog, vpow


@nb.njit(error_model="numpy")
def _loop(x, y, out):  # a loop LLVM vectorises
    for i in range(x.shape[0]):
        out[i] = vpow(x[i], y[i])


@nb.njit
def _one(x, y):  # one value at a time (scalar code, Python error model)
    return vpow(x, y)


@nb.njit
def _log_exp(x, t):
    return vlog(x), vexp(t)


@pytest.mark.parametrize(
    ("xlo", "xhi", "ylo", "yhi", "tol"),
    [
        (0.0, 3.0, 1.0, 2.0, 4e-15),  # radiator law |Δ/ΔT_ref|^n_rad
        (1.01, 100.0, -1.0, 0.0, 4e-15),  # equal-percentage valve R_v^(h-1)
        (1e-8, 1e3, 1.0, 2.0, 4e-15),
        (0.5, 2.0, -3.0, 3.0, 1e-15),
    ],
)
def test_vpow_agrees_with_numpy_power(xlo, xhi, ylo, yhi, tol):
    rng = np.random.default_rng(1)
    x = rng.uniform(xlo, xhi, 200_000)
    y = rng.uniform(ylo, yhi, 200_000)
    got = np.empty_like(x)
    _loop(x, y, got)
    ref = np.power(x, y)
    rel = np.abs(got - ref) / np.maximum(np.abs(ref), 1e-300)
    assert rel.max() < tol


def test_vpow_vector_loop_equals_scalar_calls_bit_for_bit():
    # the room env's lockstep kernel (vectorised) and its scalar kernel must agree exactly
    rng = np.random.default_rng(2)
    x = np.concatenate([rng.uniform(0.0, 2.0, 997), [0.0, 1.0, 2.0**-30]])
    y = rng.uniform(1.0, 1.6, x.size)
    got = np.empty_like(x)
    _loop(x, y, got)
    one = np.array([_one(a, b) for a, b in zip(x, y, strict=True)])
    assert np.array_equal(got.view(np.int64), one.view(np.int64))


def test_vpow_special_values():
    assert _one(0.0, 1.3) == 0.0  # radiator at Δ = 0
    assert _one(1e-250, 1.3) == 0.0  # below 1e-200 counts as 0
    assert _one(0.0, 0.0) == 1.0
    assert _one(1.0, 7.5) == 1.0
    assert _one(4.0, 0.5) == 2.0
    for bad in (math.nan, math.inf):
        assert math.isnan(_one(bad, 1.3))  # never a silent finite value
    assert math.isnan(_one(2.0, math.nan))


def test_vlog_and_vexp_on_their_own():
    for x in (1e-300, 1e-5, 0.7071, 1.0, 1.5, 2.0, 1e10, 1e300):
        lg, _ = _log_exp(x, 0.0)
        assert lg == pytest.approx(math.log(x), rel=1e-15, abs=1e-16)
    for t in (-700.0, -50.0, -0.3, 0.0, 0.3, 1.0, 50.0, 700.0):
        _, ex = _log_exp(1.0, t)
        assert ex == pytest.approx(math.exp(t), rel=2e-15)
    assert _log_exp(1.0, -800.0)[1] == 0.0
    assert _log_exp(1.0, 800.0)[1] == math.inf
