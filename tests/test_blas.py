"""The one BLAS thread limiter: limits every loaded BLAS inside the block, restores after."""

from __future__ import annotations

from threadpoolctl import threadpool_info

from thermogym.models._blas import blas_threads, single_blas_thread


def _blas_threads() -> dict[str, int]:
    return {i["filepath"]: i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"}


def test_limit_applies_to_every_blas_and_is_restored():
    before = _blas_threads()
    assert len(before) >= 2  # numpy's and scipy's own OpenBLAS
    with blas_threads(1):
        assert set(_blas_threads().values()) == {1}
    assert _blas_threads() == before


def test_none_leaves_the_libraries_alone_and_the_decorator_limits():
    before = _blas_threads()
    with blas_threads(None):
        assert _blas_threads() == before

    @single_blas_thread
    def inside() -> set[int]:
        return set(_blas_threads().values())

    assert inside() == {1}
    assert _blas_threads() == before
