"""ARX by least squares, and the starting values it gives the iterative fits.

ARX is linear in its parameters (:func:`arx_ls`); ARMAX starts from
Hannan-Rissanen (long-ARX innovations as regressors), OE from Steiglitz-McBride
iterations, BJ from the OE start plus an ARMA model of its residuals
(:func:`_start`). Unstable starting polynomials are reflected into the unit
circle (:func:`_reflect`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import cast

import numpy as np
from numpy.typing import NDArray
from scipy.signal import lfilter

from thermogym.errors import IdentificationError

__all__ = ["arx_ls"]


def _regressors(
    u: NDArray[np.float64], y: NDArray[np.float64], na: int, nb: Sequence[int], nk: Sequence[int]
) -> tuple[NDArray[np.float64], NDArray[np.float64], int]:
    """ARX regression of one output: rows t ≥ L, columns −y lags then u lags."""
    L = max([na] + [k + b - 1 for k, b in zip(nk, nb, strict=True)] + [1])
    T = y.shape[0]
    cols = [-y[L - k : T - k] for k in range(1, na + 1)]
    for i, (b, k) in enumerate(zip(nb, nk, strict=True)):
        cols += [u[L - k - l : T - k - l, i] for l in range(b)]
    return np.column_stack(cols) if cols else np.zeros((T - L, 0)), y[L:], L


def arx_ls(
    us: Sequence[NDArray[np.float64]],
    ys: Sequence[NDArray[np.float64]],
    na: int,
    nb: Sequence[int],
    nk: Sequence[int],
) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
    """Least-squares ARX of one output over several experiments.

    Parameters
    ----------
    us : sequence of ndarray (T, m)
    ys : sequence of ndarray (T,)
    na : int
    nb, nk : sequence of int, one per input

    Returns
    -------
    theta : ndarray
        ``a1..a_na`` then per input ``b0..b_{nb−1}`` (the order of
        :class:`~thermogym.models.polynomial.PolynomialModel`).
    cov : ndarray
        ``σ² (ΦᵀΦ)⁻¹``.
    sigma2 : float
        Residual variance.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> u = rng.normal(size=(500, 1))
    >>> y = lfilter([0, 0.5], [1, -0.8], u[:, 0])
    >>> th, cov, s2 = arx_ls([u], [y], 1, [1], [1])
    >>> th.round(6).tolist()
    [-0.8, 0.5]
    """
    rows, rhs = [], []
    for u, y in zip(us, ys, strict=True):
        Phi, t, _ = _regressors(u, y, na, nb, nk)
        rows.append(Phi)
        rhs.append(t)
    Phi = np.vstack(rows)
    t = np.concatenate(rhs)
    if Phi.shape[0] <= Phi.shape[1]:
        raise IdentificationError(
            f"ARX with {Phi.shape[1]} parameters needs more than {Phi.shape[0]} usable samples"
        )
    th = cast(NDArray[np.float64], np.linalg.lstsq(Phi, t, rcond=None)[0])  # (numpy's stubs:
    res = t - Phi @ th  # floating[Any] for float64 in and out)
    s2 = float(res @ res / max(Phi.shape[0] - Phi.shape[1], 1))
    cov = cast(NDArray[np.float64], s2 * np.linalg.pinv(Phi.T @ Phi))
    return th, cov, s2


def _reflect(poly: NDArray[np.float64], radius: float = 0.99) -> NDArray[np.float64]:
    """Monic polynomial in q⁻¹ with its roots outside the unit circle reflected inside."""
    if poly.size <= 1:
        return poly
    r = np.roots(poly)
    big = np.abs(r) >= radius
    if not big.any():
        return poly
    r = np.where(big, radius / np.conj(r) * np.abs(r) / np.maximum(np.abs(r), 1e-12), r)
    r = np.where(np.abs(r) >= radius, r / np.abs(r) * radius, r)
    return np.real(np.poly(r))


def _hannan_rissanen(
    u: Sequence[NDArray[np.float64]],
    y: Sequence[NDArray[np.float64]],
    na: int,
    nb: Sequence[int],
    nk: Sequence[int],
    nc: int,
) -> NDArray[np.float64]:
    """ARMAX start: long-ARX innovations as extra regressors (Hannan-Rissanen)."""
    nlong = max(na, nc, *nb) * 3 + 2
    th, _, _ = arx_ls(u, y, nlong, [nlong] * len(nb), nk)
    es = []
    for ue, ye in zip(u, y, strict=True):
        Phi, t, L = _regressors(ue, ye, nlong, [nlong] * len(nb), nk)
        es.append(np.r_[np.zeros(L), t - Phi @ th])
    # regress y on −y lags, u lags and ê lags: an ARX with ê as an extra input
    ue2 = [np.column_stack([ue, ee]) for ue, ee in zip(u, es, strict=True)]
    th2, _, _ = arx_ls(ue2, y, na, [*nb, nc], [*nk, 1])
    a = th2[:na]
    c = th2[-nc:] if nc else np.zeros(0)
    c = _reflect(np.r_[1.0, c])[1:]
    return np.r_[a, th2[na : len(th2) - nc], c]


def _steiglitz_mcbride(
    u: Sequence[NDArray[np.float64]],
    y: Sequence[NDArray[np.float64]],
    nf: int,
    nb: Sequence[int],
    nk: Sequence[int],
    iterations: int = 5,
) -> tuple[NDArray[np.float64], list[NDArray[np.float64]]]:
    """OE start with one common denominator: ARX, then LS on data prefiltered by 1/F."""
    th, _, _ = arx_ls(u, y, nf, nb, nk)
    F = _reflect(np.r_[1.0, th[:nf]])
    bs = th[nf:]
    for _ in range(iterations):
        uf = [lfilter([1.0], F, ue, axis=0) for ue in u]
        yf = [lfilter([1.0], F, ye) for ye in y]
        th, _, _ = arx_ls(uf, yf, nf, nb, nk)
        Fn = _reflect(np.r_[1.0, th[:nf]])
        if not np.all(np.isfinite(Fn)):
            break
        F, bs = Fn, th[nf:]
    splits = np.cumsum(nb)[:-1]
    return F, np.split(bs, splits)


def _start(family: str, us, ys, o, j) -> NDArray[np.float64]:  # type: ignore[no-untyped-def]
    nb, nk = o["nb"][j].tolist(), o["nk"][j].tolist()
    if family == "armax":
        return _hannan_rissanen(us, ys, int(o["na"][j]), nb, nk, int(o["nc"][j]))
    nfs = o["nf"][j].tolist()
    nfc = max(nfs)
    F, bs = _steiglitz_mcbride(us, ys, nfc, nb, nk)
    parts = []
    for i, b in enumerate(bs):
        parts += [b, F[1 : nfs[i] + 1] if nfs[i] <= nfc else np.zeros(nfs[i])]
    th = np.concatenate(parts)
    if family == "oe":
        return th
    # BJ: an ARMA(nd, nc) of the OE residuals by Hannan-Rissanen
    nc, nd = int(o["nc"][j]), int(o["nd"][j])
    res = []
    for u, y in zip(us, ys, strict=True):
        yh = sum(
            lfilter(np.r_[np.zeros(k), b], F, u[:, i])
            for i, (b, k) in enumerate(zip(bs, nk, strict=True))
        )
        res.append(y - yh)
    dummy = [np.zeros((r.size, 0)) for r in res]
    if nd == 0 and nc == 0:
        return th
    arma = _hannan_rissanen(dummy, res, nd, [], [], nc) if nd else np.zeros(0)
    if nd == 0:
        c = np.zeros(nc)
        d = np.zeros(0)
    else:
        d = _reflect(np.r_[1.0, arma[:nd]])[1:]
        c = arma[nd:]
    return np.r_[th, c, d]
