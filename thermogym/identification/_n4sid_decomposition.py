"""The N4SID decomposition: one reduction of the data from which every order follows.

The block Hankel matrix of past and future inputs and outputs is reduced to
its triangular factor chunk by chunk (:class:`HankelAccumulator`); the oblique
projections, the weighting and the SVD act on the rows of that factor
(:func:`_decompose_factor`). :func:`n4sid_decompose` does this for deviation
data (scaling and decimation included), and
:meth:`N4SIDDecomposition.system` derives the model of any order (steps 3 and
4 of :mod:`thermogym.identification.n4sid`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, cast

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from numpy.typing import NDArray

from thermogym.errors import ConfigError, IdentificationError
from thermogym.identification._n4sid_decimation import (
    _block_mean_maps,
    auto_decimation,
    decimate_data,
)
from thermogym.identification._n4sid_system import (
    StateSpaceFit,
    _fine_output_map,
    _kalman_gain,
    _mirror_schur,
    _regress_bd,
)
from thermogym.models._blas import single_blas_thread
from thermogym.models.linear import c2d_zoh, d2c_zoh

__all__ = [
    "WEIGHTINGS",
    "HankelAccumulator",
    "N4SIDDecomposition",
    "decomposition_from_accumulator",
    "n4sid_decompose",
]

#: Weightings of the projected Hankel matrix before the SVD.
WEIGHTINGS: tuple[str, ...] = ("moesp", "cva", "n4sid")


_X0_MODES = ("estimate", "zero")


_BD_MODES = ("regression", "subspace")


class HankelAccumulator:
    """Triangular factor of a block Hankel data matrix, accumulated chunk by chunk.

    The data matrix has ``2·horizon`` block rows of inputs (``m`` rows each)
    followed by ``2·horizon`` block rows of outputs (``p`` each); column ``k``
    holds ``u[k], …, u[k+2i−1], y[k], …, y[k+2i−1]``. Columns never straddle
    two experiments. Only the triangular factor ``R`` (``H Hᵀ = Rᵀ R``) is
    kept, updated by a QR of ``[R; H_chunkᵀ]``; memory is
    ``O(chunk · 2i(m+p))`` whatever the number of samples.

    Parameters
    ----------
    n_inputs, n_outputs : int
    horizon : int
        Block rows ``i`` of the past (and of the future).
    chunk : int
        Hankel columns per QR update.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> u, y = rng.normal(size=(500, 1)), rng.normal(size=(500, 2))
    >>> acc = HankelAccumulator(1, 2, horizon=3, chunk=64)
    >>> for k in range(0, 500, 100):
    ...     acc.add(u[k:k + 100], y[k:k + 100])
    >>> acc.n_columns, acc.r_factor().shape
    (495, (18, 18))
    """

    def __init__(self, n_inputs: int, n_outputs: int, horizon: int, *, chunk: int = 4096):
        if horizon < 1 or int(horizon) != horizon:
            raise ConfigError(f"horizon is {horizon!r}; expected a whole number >= 1")
        self.m, self.p, self.horizon = int(n_inputs), int(n_outputs), int(horizon)
        self.rows = 2 * self.horizon * (self.m + self.p)
        self.chunk = max(int(chunk), self.rows)
        self._R = np.zeros((0, self.rows))
        self._tail_u = np.zeros((0, self.m))
        self._tail_y = np.zeros((0, self.p))
        self.n_columns = 0
        self.n_experiments = 0
        self._open = False

    def add(self, u: NDArray[np.float64], y: NDArray[np.float64]) -> None:
        """Append samples to the current experiment (opens one if none is open)."""
        u = np.asarray(u, dtype=float).reshape(-1, self.m)
        y = np.asarray(y, dtype=float).reshape(-1, self.p)
        if u.shape[0] != y.shape[0]:
            raise ConfigError(f"u has {u.shape[0]} samples, y {y.shape[0]}; expected equal")
        if not (np.isfinite(u).all() and np.isfinite(y).all()):
            raise IdentificationError("HankelAccumulator.add: u and y must be finite")
        if not self._open:
            self.n_experiments += 1
            self._open = True
        bu = np.concatenate([self._tail_u, u])
        by = np.concatenate([self._tail_y, y])
        w = 2 * self.horizon
        ncol = bu.shape[0] - w + 1
        if ncol > 0:
            for c0 in range(0, ncol, self.chunk):
                c1 = min(ncol, c0 + self.chunk)
                self._update(bu[c0 : c1 + w - 1], by[c0 : c1 + w - 1])
            # the last w − 1 samples start columns that need the next chunk's samples
            self._tail_u, self._tail_y = bu[ncol:], by[ncol:]
        else:
            self._tail_u, self._tail_y = bu, by

    def _update(self, u: NDArray[np.float64], y: NDArray[np.float64]) -> None:
        w = 2 * self.horizon
        # Hᵀ rows: [u[k], …, u[k+w−1], y[k], …, y[k+w−1]] for each column k
        Uw = sliding_window_view(u, w, axis=0)  # (ncol, m, w)
        Yw = sliding_window_view(y, w, axis=0)
        ncol = Uw.shape[0]
        Ht = np.empty((ncol, self.rows))
        Ht[:, : w * self.m] = Uw.transpose(0, 2, 1).reshape(ncol, w * self.m)
        Ht[:, w * self.m :] = Yw.transpose(0, 2, 1).reshape(ncol, w * self.p)
        # numpy's stubs type every mode as QRResult; mode="r" returns R alone
        self._R = cast(NDArray[np.float64], np.linalg.qr(np.vstack([self._R, Ht]), mode="r"))
        self.n_columns += ncol

    def end_experiment(self) -> None:
        """Close the current experiment: the next samples start a new one."""
        self._tail_u = np.zeros((0, self.m))
        self._tail_y = np.zeros((0, self.p))
        self._open = False

    def r_factor(self) -> NDArray[np.float64]:
        """Upper-triangular ``R`` with ``H Hᵀ = Rᵀ R``, shape (rows, rows)."""
        if self.n_columns < self.rows:
            raise IdentificationError(
                f"the data give {self.n_columns} Hankel columns, fewer than the {self.rows} rows "
                f"of a horizon of {self.horizon} block rows; use more samples, a shorter "
                "horizon or a lower order"
            )
        return self._R[: self.rows]


def _coords(L: NDArray[np.float64], i: int, m: int, p: int) -> dict[str, Any]:
    """Row blocks of the lower-triangular factor (coordinates of data matrices)."""

    def U(a: int, b: int) -> NDArray[np.float64]:
        return L[a * m : b * m]

    def Y(a: int, b: int) -> NDArray[np.float64]:
        o = 2 * i * m
        return L[o + a * p : o + b * p]

    return {"U": U, "Y": Y}


def _oblique(
    Yf: NDArray[np.float64], Wp: NDArray[np.float64], Uf: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Oblique projection ``Yf /_{Uf} Wp`` in coordinates: the ``Wp`` part of ``Yf / [Wp; Uf]``."""
    Z = np.vstack([Wp, Uf])
    Theta = np.linalg.lstsq(Z.T, Yf.T, rcond=None)[0].T
    return Theta[:, : Wp.shape[0]] @ Wp


def _decompose_factor(
    L: NDArray[np.float64], i: int, m: int, p: int, weighting: str
) -> dict[str, Any]:
    blk = _coords(L, i, m, p)
    U, Y = blk["U"], blk["Y"]
    Up, Uf, Yp, Yf = U(0, i), U(i, 2 * i), Y(0, i), Y(i, 2 * i)
    Wp = np.vstack([Up, Yp])
    Oi = _oblique(Yf, Wp, Uf)  # O_i = Y_f /_{U_f} W_p
    Oi1 = _oblique(Y(i + 1, 2 * i), np.vstack([U(0, i + 1), Y(0, i + 1)]), U(i + 1, 2 * i))
    W1inv = None

    def perp(M: NDArray[np.float64]) -> NDArray[np.float64]:
        # M Π_{U_f⊥}: remove the part in the row space of U_f
        return M - np.linalg.lstsq(Uf.T, M.T, rcond=None)[0].T @ Uf

    if weighting == "n4sid":
        Ow = Oi
    elif weighting == "moesp":
        Ow = perp(Oi)
    else:  # cva: W1 = (Y_f Π_{U_f⊥} Y_fᵀ)^{-1/2}
        Yfp = perp(Yf)
        w, V = np.linalg.eigh(Yfp @ Yfp.T)
        w = np.maximum(w, 1e-12 * max(float(w.max()), 1e-300))
        W1 = (V / np.sqrt(w)) @ V.T
        W1inv = (V * np.sqrt(w)) @ V.T
        Ow = W1 @ perp(Oi)
    Us, s, _ = np.linalg.svd(Ow, full_matrices=False)
    return {
        "U": Us,
        "s": s,
        "W1inv": W1inv,
        "Oi": Oi,
        "Oi1": Oi1,
        "Ui": U(i, i + 1),
        "Yi": Y(i, i + 1),
    }


@dataclass
class N4SIDDecomposition:
    """The data decomposition of one training set, from which every order is derived.

    Built by :func:`n4sid_decompose`; :meth:`system` gives the model of any
    order, :meth:`suggest_order` the order the singular values suggest.

    Attributes
    ----------
    singular_values : ndarray
        Of the weighted projected Hankel matrix (as MATLAB's n4sid plots them).
    horizon : int
    decimate : int
    dt : float
        Sample period of the data [s].
    n_inputs, n_outputs : int
    weighting : str
    seconds : float
        Wall time of the decomposition [s].
    """

    singular_values: NDArray[np.float64]
    horizon: int
    decimate: int
    dt: float
    n_inputs: int
    n_outputs: int
    weighting: str
    u_scale: NDArray[np.float64]
    y_scale: NDArray[np.float64]
    seconds: float
    _U: NDArray[np.float64]
    _W1inv: NDArray[np.float64] | None
    _Oi: NDArray[np.float64]
    _Oi1: NDArray[np.float64]
    _Ui: NDArray[np.float64]
    _Yi: NDArray[np.float64]
    _ncol: int
    _data: list[tuple[NDArray[np.float64], NDArray[np.float64]]] | None
    _noise_fine: NDArray[np.float64] | None
    _fine: list[tuple[NDArray[np.float64], NDArray[np.float64]]] | None = None
    info: dict[str, Any] = field(default_factory=dict)

    @property
    def max_order(self) -> int:
        """Largest order the horizon supports: ``(horizon − 1) · n_outputs``."""
        return min((self.horizon - 1) * self.n_outputs, int(np.sum(self.singular_values > 0)))

    def suggest_order(self, orders: Sequence[int] | None = None) -> int:
        """Order with the largest gap between consecutive log singular values.

        The rule of SLICOT's ``IB01OD`` without a tolerance; MATLAB's ``n4sid``
        shows the same singular values for a manual choice.

        Parameters
        ----------
        orders : sequence of int, optional
            Candidates (default ``1 .. max_order``).
        """
        s = self.singular_values
        cand = [n for n in (orders or range(1, self.max_order + 1)) if 1 <= n < s.size]
        cand = [n for n in cand if n <= self.max_order]
        if not cand:
            raise ConfigError(f"no candidate order in {orders!r} is below {self.max_order + 1}")
        with np.errstate(divide="ignore"):
            gaps = [np.log10(s[n - 1] / max(s[n], 1e-300)) for n in cand]
        return int(cand[int(np.argmax(gaps))])

    def _check_order(self, order: int) -> int:
        if int(order) != order or order < 1:
            raise ConfigError(f"order is {order!r}; expected a whole number >= 1")
        if order > self.max_order:
            raise IdentificationError(
                f"order {order} needs a longer horizon: horizon {self.horizon} with "
                f"{self.n_outputs} output(s) supports orders up to {self.max_order}; pass "
                f"horizon >= {math.ceil(order / self.n_outputs) + 1}"
            )
        return int(order)

    @single_blas_thread
    def system(
        self,
        order: int,
        *,
        x0: str = "estimate",
        bd: str = "regression",
        feedthrough: bool = False,
        stable: bool = True,
        max_radius: float = 1.0 - 1e-9,
        noise_model: bool = True,
    ) -> StateSpaceFit:
        """Model of one order: A, C from the decomposition; B, D, x0, K as asked.

        Parameters
        ----------
        order : int
        x0 : {"estimate", "zero"}
            Estimate each training experiment's initial state jointly with
            ``B``, ``D`` (regression only).
        bd : {"regression", "subspace"}
            ``B``, ``D`` by least squares of the simulation error on the
            training data, or from the state-sequence regression on the
            triangular factor (no data needed).
        feedthrough : bool
            Estimate ``D`` (paper 001's model has none).
        stable : bool
            Mirror unstable eigenvalues of ``A`` into the unit circle.
        max_radius : float
            Largest eigenvalue magnitude kept.
        noise_model : bool
            Compute the Kalman gain ``K``.

        Returns
        -------
        StateSpaceFit
        """
        n = self._check_order(order)
        if x0 not in _X0_MODES:
            raise ConfigError(f"x0 is {x0!r}; expected one of {_X0_MODES}")
        if bd not in _BD_MODES:
            raise ConfigError(f"bd is {bd!r}; expected one of {_BD_MODES}")
        if bd == "regression" and self._data is None:
            raise ConfigError(
                "bd='regression' needs the training data; this decomposition was built from "
                "an accumulator without them: use bd='subspace'"
            )
        p = self.n_outputs
        info: dict[str, Any] = {}
        # Γ_i = W1⁻¹ U1 S1^{1/2}                  (Van Overschee & De Moor, Theorem 2)
        G = self._U[:, :n] * np.sqrt(self.singular_values[:n])
        if self._W1inv is not None:
            G = self._W1inv @ G
        C = G[:p].copy()
        # shift invariance: Γ_{i−1}(first i−1 block rows) A = Γ(last i−1 block rows)
        # (float64 in, float64 out: numpy's stubs say floating[Any])
        A = cast(NDArray[np.float64], np.linalg.lstsq(G[:-p], G[p:], rcond=None)[0])
        lam0 = np.linalg.eigvals(A)
        if stable or self.decimate > 1:
            A = _mirror_schur(A, max_radius if stable else np.inf, self.decimate > 1)
            lam1 = np.linalg.eigvals(A)
            moved = int(np.sum(np.abs(np.sort_complex(lam0) - np.sort_complex(lam1)) > 1e-12))
            if moved:
                info["eigenvalues_moved"] = moved
        # state sequences X_i = Γ_i^† O_i, X_{i+1} = Γ_{i−1}^† O_{i+1}    (algorithm 2)
        Xi = np.linalg.lstsq(G, self._Oi, rcond=None)[0]
        Xi1 = np.linalg.lstsq(G[:-p], self._Oi1, rcond=None)[0]
        # [X_{i+1}; Y_i] − [A; C] X_i = [B; D] U_i + ρ   (least squares in R-space)
        lhs = np.vstack([Xi1 - A @ Xi, self._Yi - C @ Xi])
        r = self.decimate
        # block means have a feedthrough D̄ = D + C N B even when the plant has none
        coarse_d = feedthrough or r > 1
        BD = cast(NDArray[np.float64], np.linalg.lstsq(self._Ui.T, lhs.T, rcond=None)[0].T)
        if not coarse_d:
            BD[n:] = 0.0
        rho = lhs - BD @ self._Ui
        Sig = rho @ rho.T / max(self._ncol, 1)
        Sig = 0.5 * (Sig + Sig.T)
        if bd == "subspace":
            B, D = BD[:n].copy(), BD[n:].copy()
            x0s = [np.zeros(n) for _ in range(self.info.get("n_experiments", 1))]
        else:
            assert self._data is not None
            B, D, x0s = _regress_bd(A, C, self._data, coarse_d, x0 == "estimate")
        A_id, B_id, C_id, D_id = A, B, C, D
        if r > 1:
            # exact ZOH conversion of the dynamics to the data period ...
            Ac, Bc = d2c_zoh(A, B, self.dt * r)
            A, B = c2d_zoh(Ac, Bc, self.dt)
            # ... and C, D by least squares on the data at that period, the states
            # propagated inside each block from the block-start states (C̄ = C M cannot
            # be inverted safely: M is near singular for modes that oscillate or decay
            # within a block)
            if self._fine is not None:
                assert self._data is not None  # kept with the fine-rate data
                C, D = _fine_output_map(
                    A, B, A_id, B_id, self._data, self._fine, x0s, r, feedthrough
                )
            else:
                Mm, Nm = _block_mean_maps(A, r)
                C = cast(
                    NDArray[np.float64], np.linalg.lstsq(Mm.T, C_id.T, rcond=1e-6)[0].T
                )  # C̄ = C M
                D = D_id - C @ Nm @ B if feedthrough else np.zeros_like(D_id)
        # Kalman gain of the innovation form (3): DARE on the residual covariances
        K = np.zeros((n, p))
        if noise_model:
            Q = Sig[:n, :n]
            S = Sig[:n, n:]
            R = Sig[n:, n:]
            if r > 1 and self._noise_fine is not None:
                # per fine step: process noise ≈ Q_id / r, measurement noise measured at dt
                Q, S, R = Q / r, np.zeros_like(S), np.diag(self._noise_fine)
            K, status = _kalman_gain(A, C, Q, R, S)
            info["noise_model"] = status
        Cs = C * self.y_scale[:, None]
        return StateSpaceFit(
            A=A,
            B=B / self.u_scale[None, :],
            C=Cs,
            D=(D * self.y_scale[:, None]) / self.u_scale[None, :],
            K=K / self.y_scale[None, :],
            dt=self.dt,
            order=n,
            x0=x0s,
            decimate=self.decimate,
            A_id=A_id,
            B_id=B_id,
            C_id=C_id,
            D_id=D_id,
            u_scale=self.u_scale,
            y_scale=self.y_scale,
            info=info,
        )


def _default_horizon(max_order: int, p: int) -> int:
    return max(10, math.ceil(max_order / p) + 1)


@single_blas_thread
def n4sid_decompose(
    u: Sequence[NDArray[np.float64]],
    y: Sequence[NDArray[np.float64]],
    dt: float,
    *,
    horizon: int | None = None,
    max_order: int = 10,
    decimate: int | str = "auto",
    weighting: str = "moesp",
    scale: bool = True,
    chunk: int = 4096,
) -> N4SIDDecomposition:
    """Decompose deviation data once; every order is then derived from it.

    Parameters
    ----------
    u : sequence of ndarray (T_e, m)
        Inputs of each experiment, operating point already subtracted.
    y : sequence of ndarray (T_e, p)
        Outputs of each experiment.
    dt : float
        Sample period [s].
    horizon : int, optional
        Block rows ``i`` (past and future); default
        ``max(10, ceil(max_order / p) + 1)``.
    max_order : int
        Highest order that will be asked for (sets the default horizon).
    decimate : int or "auto"
        Identification at ``decimate · dt`` (see the module docstring).
    weighting : {"moesp", "cva", "n4sid"}
    scale : bool
        Divide every channel by its RMS over the training data.
    chunk : int
        Hankel columns per QR update.

    Returns
    -------
    N4SIDDecomposition

    Examples
    --------
    >>> from thermogym.identification.n4sid import simulate_ss
    >>> rng = np.random.default_rng(1)
    >>> A = np.array([[0.9, 0.2], [0.0, 0.7]]); B = np.array([[0.0], [1.0]])
    >>> C = np.array([[1.0, 0.0]]); u = rng.normal(size=(2000, 1))
    >>> y = simulate_ss(A, B, C, np.zeros((1, 1)), u)
    >>> dec = n4sid_decompose([u], [y], 1.0, decimate=1)
    >>> dec.suggest_order(range(1, 6))
    2
    >>> sys = dec.system(2)
    >>> sorted(np.linalg.eigvals(sys.A).real.round(6).tolist())
    [0.7, 0.9]
    """
    t0 = time.perf_counter()
    us = [np.asarray(v, dtype=float) for v in u]
    ys = [np.asarray(v, dtype=float) for v in y]
    if weighting not in WEIGHTINGS:
        raise ConfigError(f"weighting is {weighting!r}; expected one of {WEIGHTINGS}")
    m, p = us[0].shape[1], ys[0].shape[1]
    i = int(horizon) if horizon is not None else _default_horizon(max_order, p)
    if i < 2:
        raise ConfigError(f"horizon is {horizon!r}; expected at least 2 block rows")
    tau = math.nan
    if decimate == "auto":
        r, tau = auto_decimation(us, ys, dt, min_samples=max(400, 4 * 2 * i * (m + p) + 2 * i))
    elif (
        isinstance(decimate, int | np.integer) and not isinstance(decimate, bool) and decimate >= 1
    ):
        r = int(decimate)
    else:
        raise ConfigError(f"decimate is {decimate!r}; expected a whole number >= 1 or 'auto'")
    if scale:
        su = np.sqrt(np.mean(np.concatenate([v**2 for v in us]), axis=0))
        sy = np.sqrt(np.mean(np.concatenate([v**2 for v in ys]), axis=0))
        su = np.where(su > 0, su, 1.0)
        sy = np.where(sy > 0, sy, 1.0)
    else:
        su, sy = np.ones(m), np.ones(p)
    # measurement noise at the fine rate (scaled): var(Δy)/2 of white noise
    noise = None
    if r > 1:
        d = np.concatenate([np.diff(v / sy, axis=0) for v in ys])
        noise = np.maximum(0.5 * np.var(d, axis=0), 1e-16)
    data = []
    fine: list[tuple[NDArray[np.float64], NDArray[np.float64]]] | None = [] if r > 1 else None
    acc = HankelAccumulator(m, p, i, chunk=chunk)
    rows = acc.rows
    for ue, ye in zip(us, ys, strict=True):
        ur, yr = decimate_data(ue / su, ye / sy, r)
        assert yr is not None
        if ur.shape[0] < 2 * i + 1:
            raise IdentificationError(
                f"an experiment has {ue.shape[0]} samples ({ur.shape[0]} after decimation by "
                f"{r}); N4SID with a horizon of {i} block rows needs at least {2 * i + 1}"
            )
        data.append((ur, yr))
        if fine is not None:
            fine.append((ue / su, ye / sy))
        acc.add(ur, yr)
        acc.end_experiment()
    if acc.n_columns < rows:
        need = rows + 2 * i - 1
        raise IdentificationError(
            f"N4SID: {acc.n_columns} Hankel columns for {rows} rows (horizon {i}, {m} inputs, "
            f"{p} outputs{f', decimation {r}' if r > 1 else ''}); give at least {need * r} "
            "samples, a lower order or a shorter horizon"
        )
    L = acc.r_factor().T
    dec = _decompose_factor(L, i, m, p, weighting)
    return N4SIDDecomposition(
        singular_values=dec["s"],
        horizon=i,
        decimate=r,
        dt=float(dt),
        n_inputs=m,
        n_outputs=p,
        weighting=weighting,
        u_scale=su,
        y_scale=sy,
        seconds=time.perf_counter() - t0,
        _U=dec["U"],
        _W1inv=dec["W1inv"],
        _Oi=dec["Oi"],
        _Oi1=dec["Oi1"],
        _Ui=dec["Ui"],
        _Yi=dec["Yi"],
        _ncol=acc.n_columns,
        _data=data,
        _noise_fine=noise,
        _fine=fine,
        info={"n_experiments": len(us), "dominant_tau_s": tau, "hankel_columns": acc.n_columns},
    )


def decomposition_from_accumulator(
    acc: HankelAccumulator, dt: float, *, weighting: str = "moesp"
) -> N4SIDDecomposition:
    """Decomposition from streamed data (no data kept: use ``bd="subspace"``).

    The accumulator must have been fed scaled deviation data at the
    identification period ``dt`` (no decimation is applied here).
    """
    if weighting not in WEIGHTINGS:
        raise ConfigError(f"weighting is {weighting!r}; expected one of {WEIGHTINGS}")
    t0 = time.perf_counter()
    L = acc.r_factor().T
    dec = _decompose_factor(L, acc.horizon, acc.m, acc.p, weighting)
    return N4SIDDecomposition(
        singular_values=dec["s"],
        horizon=acc.horizon,
        decimate=1,
        dt=float(dt),
        n_inputs=acc.m,
        n_outputs=acc.p,
        weighting=weighting,
        u_scale=np.ones(acc.m),
        y_scale=np.ones(acc.p),
        seconds=time.perf_counter() - t0,
        _U=dec["U"],
        _W1inv=dec["W1inv"],
        _Oi=dec["Oi"],
        _Oi1=dec["Oi1"],
        _Ui=dec["Ui"],
        _Yi=dec["Yi"],
        _ncol=acc.n_columns,
        _data=None,
        _noise_fine=None,
        info={"n_experiments": acc.n_experiments, "hankel_columns": acc.n_columns},
    )
