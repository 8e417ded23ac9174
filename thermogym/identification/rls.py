"""Recursive least squares with forgetting: refresh FOPTD/ARX models from a stream.

A running environment or controller sees one sample at a time. To follow a
plant that drifts or ages it refreshes the parameters of its model recursively
instead of refitting the whole history. For a linear-in-parameters model
``y[k] = φ[k]ᵀ θ + e[k]`` with exponential forgetting ``λ`` (weights ``λ^{N−k}``,
memory ≈ ``1/(1 − λ)`` samples), the textbook RLS update is::

    g = P φ / (λ + φᵀ P φ)                      gain
    θ ← θ + g (y − φᵀ θ)                         parameter update
    P ← (P − g φᵀ P) / λ                         covariance update

(Ljung, *System Identification*, 2nd ed., section 11.2). The covariance update
is computed in the Joseph form ``[(I − g φᵀ) P (I − g φᵀ)ᵀ + λ g gᵀ] / λ``,
algebraically the same but symmetric positive definite in floating point
(the plain form loses definiteness once ``P`` is ill conditioned, and the
estimate then diverges), and ``trace(P)`` is bounded (``max_trace``) so it
cannot blow up while the data carry no new information ("covariance wind-up"
when the input is constant).

:class:`RLS` runs a batch of independent regressions at once (one per output).
:class:`RecursiveFOPTD` uses it for the first-order ARX form (9) of paper 000
``y[k] = a y[k−1] + Σ_i b_i u_i[k−1−d_i]`` with fixed delays and turns the
current estimate into the same ``foptd`` FitResult as
:func:`thermogym.identification.foptd.fit_foptd` (eqs 11-12), so an
environment can swap it in (``params=fit``) at any time.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numba as nb
import numpy as np
from numpy.typing import ArrayLike, NDArray

from thermogym._checks import in_range, integer, positive
from thermogym.errors import ConfigError, IdentificationError, ShapeError
from thermogym.fitresult import FitResult, load_fit
from thermogym.models.linear import FOPTDModel, discrete_to_foptd

__all__ = ["RLS", "RecursiveFOPTD"]


@nb.njit(cache=True)
def _rls_kernel(theta, P, Phi, Y, lam, max_trace, err):  # pragma: no cover - numba
    # theta (J, q), P (J, q, q), Phi (T, J, q), Y (T, J); err (T, J) a-priori errors
    T, J, q = Phi.shape
    Pphi = np.empty(q)
    g = np.empty(q)
    M = np.empty((q, q))
    for k in range(T):
        for j in range(J):
            y = Y[k, j]
            if np.isnan(y):
                err[k, j] = np.nan
                continue
            pred = 0.0
            for a in range(q):
                pred += Phi[k, j, a] * theta[j, a]
            e = y - pred
            err[k, j] = e
            # g = P φ / (λ + φᵀ P φ)
            den = lam
            for a in range(q):
                acc = 0.0
                for b in range(q):
                    acc += P[j, a, b] * Phi[k, j, b]
                Pphi[a] = acc
                den += Phi[k, j, a] * acc
            for a in range(q):
                g[a] = Pphi[a] / den
                theta[j, a] += g[a] * e  # θ ← θ + g e
            # P ← [(I − g φᵀ) P (I − g φᵀ)ᵀ + λ g gᵀ] / λ  (Joseph form: equal to
            # (P − g φᵀ P)/λ in exact arithmetic, but stays symmetric positive definite)
            for a in range(q):
                for b in range(q):
                    acc = 0.0
                    for c in range(q):
                        acc += ((1.0 if a == c else 0.0) - g[a] * Phi[k, j, c]) * P[j, c, b]
                    M[a, b] = acc
            tr = 0.0
            for a in range(q):
                for b in range(a, q):
                    acc = 0.0
                    for c in range(q):
                        acc += M[a, c] * ((1.0 if b == c else 0.0) - g[b] * Phi[k, j, c])
                    v = (acc + lam * g[a] * g[b]) / lam
                    P[j, a, b] = v
                    P[j, b, a] = v
                tr += P[j, a, a]
            if tr > max_trace:
                s = max_trace / tr
                for a in range(q):
                    for b in range(q):
                        P[j, a, b] *= s


class RLS:
    """Recursive least squares with exponential forgetting for ``J`` regressions.

    Parameters
    ----------
    n_params : int
        Parameters per regression ``q``.
    n_problems : int
        Independent regressions ``J`` updated together (e.g. one per output).
    forgetting : float
        ``λ`` in (0, 1]; 1 is ordinary (growing-memory) least squares.
    p0 : float
        Initial covariance ``P = p0 · I`` (large: little trust in ``theta0``).
    theta0 : array_like, shape (J, q) or (q,), optional
        Initial parameters (zero by default).
    max_trace : float, optional
        Bound on ``trace(P)`` (default ``q · p0``).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> phi = rng.normal(size=(500, 1, 2)); y = phi @ np.array([2.0, -1.0])
    >>> est = RLS(2, forgetting=1.0)
    >>> _ = est.update_many(phi, y)
    >>> est.theta.round(6).tolist()
    [[2.0, -1.0]]
    """

    def __init__(
        self,
        n_params: int,
        *,
        n_problems: int = 1,
        forgetting: float = 0.999,
        p0: float = 1e4,
        theta0: ArrayLike | None = None,
        max_trace: float | None = None,
    ) -> None:
        integer("n_params", n_params, lo=1, error=ConfigError)
        integer("n_problems", n_problems, lo=1, error=ConfigError)
        # λ in (0, 1]: the estimate remembers about 1/(1 − λ) samples
        in_range(
            "forgetting factor", forgetting, 0.0, 1.0, lo_open=True, error=ConfigError, text=False
        )
        positive("p0", p0, error=ConfigError, text=False)
        self.q, self.J = int(n_params), int(n_problems)
        self.forgetting = float(forgetting)
        self.max_trace = float(max_trace) if max_trace is not None else self.q * float(p0)
        self.theta = np.zeros((self.J, self.q))
        if theta0 is not None:
            th = np.asarray(theta0, dtype=float)
            try:
                self.theta[:] = np.broadcast_to(th, (self.J, self.q))
            except ValueError:
                raise ShapeError(
                    f"theta0 has shape {th.shape}, expected ({self.q},) or ({self.J}, {self.q})"
                ) from None
        self.P = np.repeat(np.eye(self.q)[None] * float(p0), self.J, axis=0)
        self.n_updates = 0

    def update_many(self, phi: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        """Process samples in time order.

        Parameters
        ----------
        phi : array_like, shape (T, J, q) (or (T, q) when J = 1)
            Regressors.
        y : array_like, shape (T, J) (or (T,) when J = 1)
            Measurements; NaN skips that regression's update (missing sample).

        Returns
        -------
        ndarray, shape (T, J)
            A-priori prediction errors ``y − φᵀ θ`` (before each update).
        """
        Phi = np.asarray(phi, dtype=float)
        Y = np.asarray(y, dtype=float)
        if Phi.ndim == 2 and self.J == 1:
            Phi = Phi[:, None, :]
        if Y.ndim == 1 and self.J == 1:
            Y = Y[:, None]
        if Phi.ndim != 3 or Phi.shape[1:] != (self.J, self.q):
            raise ShapeError(f"phi has shape {np.shape(phi)}, expected (T, {self.J}, {self.q})")
        if Y.shape != Phi.shape[:2]:
            raise ShapeError(f"y has shape {np.shape(y)}, expected ({Phi.shape[0]}, {self.J})")
        if not np.isfinite(Phi).all():
            raise ShapeError("phi holds non-finite values; regressors must be finite")
        err = np.empty(Y.shape)
        _rls_kernel(
            self.theta,
            self.P,
            np.ascontiguousarray(Phi),
            np.ascontiguousarray(Y),
            self.forgetting,
            self.max_trace,
            err,
        )
        self.n_updates += int(Y.shape[0])
        return err

    def update(self, phi: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        """One sample: ``phi`` (J, q) or (q,), ``y`` (J,) or scalar; returns errors (J,)."""
        Phi = np.asarray(phi, dtype=float).reshape(1, self.J, self.q)
        return self.update_many(Phi, np.asarray(y, dtype=float).reshape(1, self.J))[0]


class RecursiveFOPTD:
    """FOPTD parameters refreshed sample by sample (first-order ARX with fixed delays).

    For output ``j``: ``Δy_j[k] = a_j Δy_j[k−1] + Σ_i b_ji Δu_i[k−1−d_ji]``
    (eq 9 of paper 000, deviations from the operating point), estimated by
    :class:`RLS`; :meth:`parameters` converts with eqs (11)-(12).

    Parameters
    ----------
    inputs : sequence of str
        Exogenous signal names (manipulated inputs first, then disturbances).
    outputs : sequence of str
    dt : float
        Sample period [s].
    delays : int or array_like (n_out, n_exog)
        Delays ``d_ji`` [samples] (from a batch fit, see :meth:`from_fit`).
    disturbances : sequence of str
        Which of ``inputs`` are disturbances (for the FitResult's model).
    forgetting : float
        ``λ``; memory ≈ ``dt / (1 − λ)`` seconds.
    p0 : float
        Initial covariance scale.
    u_op, y_op : array_like, optional
        Operating point; default: the first sample seen (the paper's initial
        values). A NaN entry takes its signal's first sample; the finite
        entries are stored in the FitResult as given offsets.
    theta0 : array_like (n_out, 1 + n_exog [+ 1]), optional
        Initial ``[a, b_1, …]`` (and ``c`` with ``bias``) per output.
    bias : bool
        Add a constant ``c`` to (9): absorbs an operating point that is not
        a steady state (a slowly moving ambient, a wrong first sample); the
        FitResult's offset then includes ``c / (1 − a)``.
    units : mapping, optional
        Units of the signals (for the FitResult).

    Examples
    --------
    >>> from thermogym.models.linear import FOPTDModel
    >>> u = np.r_[np.zeros(50), np.repeat(np.random.default_rng(1).integers(0, 2, 40), 50)]
    >>> y = FOPTDModel(K=2.0, T=30.0, tau=4.0).simulate(u[:, None], 1.0).outputs[0, :, 0]
    >>> est = RecursiveFOPTD(["u"], ["y"], dt=1.0, delays=4, forgetting=1.0)
    >>> est.update_many(u[:, None], y[:, None]).shape
    (2049, 1)
    >>> K, T, tau = est.parameters()
    >>> round(float(K[0, 0]), 4), round(float(T[0, 0]), 3), float(tau[0, 0])
    (2.0, 30.0, 4.0)
    """

    def __init__(
        self,
        inputs: Sequence[str],
        outputs: Sequence[str],
        *,
        dt: float,
        delays: int | ArrayLike = 0,
        disturbances: Sequence[str] = (),
        forgetting: float = 0.999,
        p0: float = 1e4,
        u_op: ArrayLike | None = None,
        y_op: ArrayLike | None = None,
        theta0: ArrayLike | None = None,
        units: Mapping[str, str] | None = None,
        bias: bool = False,
    ) -> None:
        self.inputs = [inputs] if isinstance(inputs, str) else list(inputs)
        self.outputs = [outputs] if isinstance(outputs, str) else list(outputs)
        self.disturbances = list(disturbances)
        bad = [d for d in self.disturbances if d not in self.inputs]
        if bad:
            raise ConfigError(f"disturbances {bad} are not among the inputs {self.inputs}")
        self.dt = positive("dt", dt, unit="s", error=ConfigError, text=False)
        m, p = len(self.inputs), len(self.outputs)
        d = np.asarray(delays)
        try:
            d = np.broadcast_to(d, (p, m))
        except ValueError:
            raise ShapeError(
                f"delays have shape {d.shape}, expected a scalar or ({p}, {m})"
            ) from None
        if (d < 0).any() or (d != np.round(d)).any():
            raise ConfigError(f"delays {d.tolist()} must be whole numbers of samples >= 0")
        self.delays = d.astype(np.int64).copy()
        self.units = dict(units or {})
        self.bias = bool(bias)
        self.rls = RLS(
            1 + m + int(self.bias), n_problems=p, forgetting=forgetting, p0=p0, theta0=theta0
        )
        self._hist = np.zeros((int(self.delays.max()) + 2, m))  # Δu[k−1−h], h = 0..
        self._y_prev = np.zeros(p)
        self._u_op = None if u_op is None else np.asarray(u_op, dtype=float).reshape(m)
        self._y_op = None if y_op is None else np.asarray(y_op, dtype=float).reshape(p)
        for name, a in (("u_op", self._u_op), ("y_op", self._y_op)):
            if a is not None and np.isinf(a).any():
                raise ConfigError(f"{name} {a.tolist()} is not finite; expected numbers (or NaN)")
        #: the offsets given (finite entries of u_op, y_op), stored as given
        self._given: dict[str, dict[str, float]] = {
            part: {c: float(v) for c, v in zip(names, a, strict=True) if np.isfinite(v)}
            if a is not None
            else {}
            for part, names, a in (
                ("inputs", self.inputs, self._u_op),
                ("outputs", self.outputs, self._y_op),
            )
        }
        self._started = False

    @classmethod
    def from_fit(
        cls, fit: FitResult | Mapping[str, Any], *, forgetting: float = 0.999, p0: float = 1.0
    ) -> RecursiveFOPTD:
        """Warm start from a ``foptd`` FitResult (its delays, gains, time constants).

        ``p0`` is small here: the batch fit is trusted, the recursion only
        follows changes.
        """
        f = load_fit(fit)
        if f.model != "foptd":
            raise ConfigError(f"from_fit needs a 'foptd' FitResult, got {f.model!r}")
        model = f.build_model()
        assert isinstance(model, FOPTDModel)
        K, T, tau = (v[0] for v in model.pair_parameters(f.theta(model)))
        dt = float(f.settings.get("dt", 0.0))
        if not dt > 0:
            raise ConfigError("the FitResult has no settings['dt']; pass a FOPTD fit of thermogym")
        if not np.allclose(T, T[:, :1]):
            raise ConfigError(
                "RecursiveFOPTD needs one time constant per output (a common pole); this fit "
                "has different T per input"
            )
        a = np.exp(-dt / T[:, 0])
        b = K * (1.0 - a)[:, None]
        op = f.settings.get("operating_point", {})
        exo = list(model.exogenous_names)
        outs = list(model.output_names)
        return cls(
            exo,
            outs,
            dt=dt,
            delays=np.round(tau / dt).astype(int),
            disturbances=[s.name for s in model.disturbances],
            forgetting=forgetting,
            p0=p0,
            u_op=[op.get("inputs", {}).get(c, 0.0) for c in exo] if op else None,
            y_op=[op.get("outputs", {}).get(c, 0.0) for c in outs] if op else None,
            theta0=np.column_stack([a, b]),
            units={s.name: s.unit for s in model.signals},
        )

    def update_many(self, u: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        """Feed samples ``u`` (T, n_exog), ``y`` (T, n_out); returns a-priori errors (T, n_out)."""
        U = np.asarray(u, dtype=float)
        Y = np.asarray(y, dtype=float)
        m, p = len(self.inputs), len(self.outputs)
        if U.ndim == 1:
            U = U[:, None] if m == 1 else U[None]
        if Y.ndim == 1:
            Y = Y[:, None] if p == 1 else Y[None]
        if U.ndim != 2 or U.shape[1] != m or Y.shape != (U.shape[0], p):
            raise ShapeError(
                f"u has shape {np.shape(u)} and y {np.shape(y)}; expected (T, {m}) and (T, {p})"
            )
        if not np.isfinite(U).all():
            raise ShapeError("inputs must be finite (NaN outputs are skipped)")
        if not self._started:
            if self._u_op is None or np.isnan(self._u_op).any():  # the first sample
                self._u_op = (
                    U[0].copy()
                    if self._u_op is None
                    else np.where(np.isnan(self._u_op), U[0], self._u_op)
                )
            if self._y_op is None or np.isnan(self._y_op).any():
                if not np.isfinite(Y[0]).all():
                    raise IdentificationError("the first output sample must be finite")
                self._y_op = (
                    Y[0].copy()
                    if self._y_op is None
                    else np.where(np.isnan(self._y_op), Y[0], self._y_op)
                )
            self._hist[:] = U[0] - self._u_op  # at rest before the first sample
            self._y_prev = Y[0] - self._y_op
            self._started = True
            U, Y = U[1:], Y[1:]
        T = U.shape[0]
        if T == 0:
            return np.zeros((0, p))
        assert self._u_op is not None and self._y_op is not None
        dU = U - self._u_op
        dY = Y - self._y_op
        H = self._hist.shape[0]
        # full input history: oldest first, ending at Δu[k−1] for the first new sample
        past = np.concatenate([self._hist[::-1], dU])  # past[H + t] = Δu of new sample t
        Phi = np.empty((T, p, 1 + m + int(self.bias)))
        if self.bias:
            Phi[:, :, -1] = 1.0
        yprev = np.concatenate([self._y_prev[None], dY[:-1]])
        # a NaN output: carry the last valid value as the regressor
        for j in range(p):
            col = yprev[:, j]
            if np.isnan(col).any():
                idx = np.where(np.isfinite(col), np.arange(T), 0)
                np.maximum.accumulate(idx, out=idx)
                col = col[idx]
                yprev[:, j] = np.where(np.isfinite(col), col, 0.0)
        Phi[:, :, 0] = yprev
        t = np.arange(T)
        for j in range(p):
            for i in range(m):
                # Δu[k−1−d] of new sample t is past[H + t − 1 − d]
                Phi[:, j, 1 + i] = past[H + t - 1 - int(self.delays[j, i]), i]
        err = self.rls.update_many(Phi, dY)
        # keep the last H inputs (newest first) and the last output
        self._hist = past[-H:][::-1].copy()
        last = dY[-1]
        self._y_prev = np.where(np.isfinite(last), last, yprev[-1])
        return err

    def update(self, u: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        """One sample ``u`` (n_exog,), ``y`` (n_out,); returns the a-priori errors."""
        return self.update_many(np.atleast_2d(np.asarray(u, dtype=float)), np.atleast_2d(y))[0]

    def parameters(self) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Current ``K``, ``T`` [s], ``τ`` [s], each (n_out, n_exog), eqs (11)-(12).

        Raises
        ------
        IdentificationError
            An output's pole is not in (0, 1) (yet): no stable first-order lag.
        """
        th = self.rls.theta
        a = th[:, 0]
        bad = ~((a > 0) & (a < 1))
        if bad.any():
            j = int(np.argmax(bad))
            raise IdentificationError(
                f"the current estimate of output {self.outputs[j]!r} has pole a = {a[j]:.6g}, "
                "not a stable first-order lag (0 < a < 1); feed more informative data "
                "(a changing input) before converting"
            )
        m = len(self.inputs)
        return discrete_to_foptd(
            np.repeat(a[:, None], m, axis=1), th[:, 1 : 1 + m], self.delays, self.dt
        )  # (11)-(12)

    def to_fitresult(self) -> FitResult:
        """The current estimate as the same ``foptd`` FitResult as the batch fit."""
        K, T, tau = self.parameters()
        assert self._u_op is not None and self._y_op is not None
        ins = [c for c in self.inputs if c not in self.disturbances]
        order = [self.inputs.index(c) for c in ins + self.disturbances]
        Ko, To, tauo = K[:, order], T[:, order], tau[:, order]
        u_op = self._u_op[order]
        y0 = self._y_op - Ko @ u_op
        if self.bias:  # the constant c of (9) shifts the rest level by c / (1 − a)
            th = self.rls.theta
            y0 = y0 + th[:, -1] / (1.0 - th[:, 0])
        model = FOPTDModel(
            ins,
            self.outputs,
            disturbances=self.disturbances,
            units={k: v for k, v in self.units.items() if k in self.inputs + self.outputs},
            K=Ko,
            T=To,
            tau=tauo,
            offsets=True,
            y0=y0,
            steady_start=True,
        )
        exo = ins + self.disturbances
        return FitResult.from_model(
            model,
            method="rls",
            settings={
                "forgetting": self.rls.forgetting,
                "bias": self.bias,
                "samples": self.rls.n_updates,
                "dt": self.dt,
                "common_pole": True,
                "delays_samples": self.delays[:, order].tolist(),
                "operating_point": {
                    "mode": "initial",
                    "inputs": {c: float(v) for c, v in zip(exo, u_op, strict=True)},
                    "outputs": {c: float(v) for c, v in zip(self.outputs, self._y_op, strict=True)},
                    **(
                        {"given": {k: dict(v) for k, v in self._given.items()}}
                        if self._given["inputs"] or self._given["outputs"]
                        else {}
                    ),
                },
            },
            notes="recursive least squares with forgetting of eq (9) of paper 000; eqs (11)-(12)",
        )
