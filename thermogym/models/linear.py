"""Linear models fitted by identification: discrete state space and FOPTD sets.

Description
-----------
Two black-box model classes whose parameters identification fits directly.

:class:`StateSpaceModel` is the discrete-time MIMO state space in innovation
form that N4SID returns (section 2.3.3 of ``001_6d13a2cd04f5de5e.txt``, eq 3)::

    x[k+1] = A x[k] + B u[k] + K e[k]                                  (3)
    y[k]   = C x[k] + D u[k] + e[k]

Paper 001 writes (3) as a difference quotient ``(x(t+Δt) − x(t))/Δt = A x +
B u + K e``; that is the same model with ``A_d = I + Δt A``, ``B_d = Δt B``,
``K_d = Δt K``. The matrices here are always the discrete ones (``A_d`` ...),
so ``x[k+1] = A x[k] + ...``. :meth:`StateSpaceModel.simulate` is the
deterministic part (``e = 0``); :meth:`StateSpaceModel.predict` is the Kalman
predictor that uses ``K``.

:class:`FOPTDModel` is a set of first-order-plus-time-delay transfer functions,
one per (output j, input i) pair, added up over the inputs (superposition);
section 4.1 of ``000_24627a5308ee07db.txt``::

    G_ji(s) = K_ji e^{−τ_ji s} / (T_ji s + 1)                          (7)
    T_ji dy_ji/dt + y_ji(t) = K_ji u_i(t − τ_ji),   y_j = Σ_i y_ji      (8)
    y[k] = a y[k−1] + b u[k−1−d],  G(z) = b z^{−1−d} / (1 − a z^{−1})  (9)-(10)
    a = e^{−Δt/T},  b = K (1 − a),  d = τ / Δt
    T = −Δt / ln a,  K = b / (1 − a),  τ = d Δt                        (11)-(12)

The paper's (9)-(10) hold only for delays that are integer multiples of Δt.
The simulation here is the exact zero-order-hold discretisation for *any*
delay (modified z-transform): with ``τ = (d + f) Δt``, ``0 ≤ f < 1``, the held
input sample reaches the lag partly during one interval and partly during the
next::

    y[k] = a y[k−1] + b1 u[k−1−d] + b2 u[k−2−d]
    b1 = K (1 − e^{−(1−f)Δt/T}),   b2 = K (e^{−(1−f)Δt/T} − e^{−Δt/T})

so ``b1 + b2 = K (1 − a)`` and ``f = 0`` gives (9) back.

FOPTD outputs are deviations (the paper subtracts the initial temperatures,
because a linear model gives zero output for zero input); ``offsets=True``
adds one parameter ``y0_<out>`` per output that is added to it.

Parameters
----------
============================  ===============  ===========================================
parameter                     unit             meaning
============================  ===============  ===========================================
``A_r_c``                     1                state-transition entry, row r, column c
``B_r_c``                     state/input      input-matrix entry (state r, exogenous c)
``C_r_c``                     output/state     output-matrix entry (output r, state c)
``D_r_c`` (``has_D``)         output/input     feedthrough entry (output r, exogenous c)
``K_r_c`` (``has_K``)         state/output     innovation (Kalman) gain entry
``x0_r`` (``fit_x0``)         state            initial state entry
``K_<out>[__<in>]``           output/input     FOPTD gain (7)
``T_<out>[__<in>]``           s                FOPTD time constant (7), > 0
``tau_<out>[__<in>]``         s                FOPTD dead time (7), ≥ 0
``y0_<out>`` (``offsets``)    output           FOPTD output offset
============================  ===============  ===========================================

The FOPTD names carry ``__<in>`` only when the model has more than one
exogenous signal. State-space bounds are ``v ± (10|v| + 1)`` around the
nominal ``v``; FOPTD bounds are ``K ± (10|K| + 1)``, ``T ∈ [T/1000, 1000 T]``,
``τ ∈ [0, 10 max(τ, T)]``; provenance "identified".

Operating Point and Sample Period
---------------------------------
Both models are linear about an operating point ``(u_op, y_op)`` (constructor
arguments ``u_op`` and, for the state space, ``y_op``; FOPTD's output offset
is its parameter ``y0``): they map ``u − u_op`` to ``y − y_op``, in every
simulation path (:meth:`~StateSpaceModel.simulate`, ``step``/``output`` for
environments, :meth:`StateSpaceModel.predict`, the initial-state estimates).
A FitResult stores it in ``model_config``, so ``fit.build_model()`` applies it.

A state space built with ``dt=None`` (the default) steps once per sample of
whatever data it is simulated on, at any positive period (e.g. 1228.8 s); one
built with a period is resampled exactly to any other period
(:meth:`StateSpaceModel.at_period`). FOPTD parameters are continuous and are
discretised exactly at the period of the data.

Starting State
--------------
``simulate(..., x0=MODE)`` with ``MODE`` one of :data:`X0_MODES`:

* ``"zero"``: at rest at the operating point (state space ``x = 0``; FOPTD
  lags zero and the input at ``u_op`` before ``t = 0``);
* ``"steady"``: settled at the first input sample (``x = (I − A)^{-1} B
  (u[0] − u_op)``; FOPTD lags at ``K (u[0] − u_op)``, input ``u[0]`` before);
* ``"estimate"``: least squares on the measured outputs ``y`` given the
  inputs (:meth:`StateSpaceModel.estimate_x0`, :meth:`FOPTDModel.estimate_x0`
  — the lags and the input held during the delay before ``t = 0``). Measured
  data rarely start at rest; this is what MATLAB's ``compare`` does.

Without ``x0`` the model's default: state space ``x = 0``,
``steady_start=True`` the steady state, ``fit_x0=True`` the parameters
``x0_r`` (so optimisers fit it); FOPTD at rest at ``u_op``, or steady with
``steady_start=True``. An explicit state array is used as it is (FOPTD: the
input before ``t = 0`` is ``u[0]`` with ``steady_start``, else ``u_op``). For
step-wise use (environments) the FOPTD state holds the last ``history`` input
samples, enough for delays up to ``history·Δt`` (see :class:`FOPTDModel`).

Version History
---------------
* v1: initial release. The operating point, ``dt=None`` and the ``x0``
  modes were added later without a version change: models stored in
  FitResults (which always name their ``dt``) simulate as before.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence
from typing import Any, NamedTuple

import numba as nb
import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from thermogym.errors import ConfigError, ParameterError, ShapeError, SimulationError
from thermogym.models.base import Model, Parameter, Signal, Simulation, ThetaLike

__all__ = [
    "MODELS",
    "ContinuousStateSpace",
    "FOPTDModel",
    "StateSpaceMatrices",
    "StateSpaceModel",
    "c2d_zoh",
    "d2c_zoh",
    "discrete_to_foptd",
    "foptd_to_discrete",
    "foptd_zoh",
]

_PROV = "identified"
_PROV_FOPTD = "identified (000_24627a5308ee07db.txt section 4.1)"
_SNAP = 1e-9  # relative tolerance for a delay to count as an integer number of samples


# ============================================================== shared helpers
def _names(value: Sequence[str] | str, what: str) -> list[str]:
    if isinstance(value, str):
        return [value]
    try:
        out = [str(v) for v in value]
    except TypeError:
        raise ConfigError(f"{what} is {value!r}; expected a list of signal names") from None
    return out


def _make_signals(
    inputs: Sequence[str] | str,
    disturbances: Sequence[str] | str,
    outputs: Sequence[str] | str,
    units: Mapping[str, str] | None,
    model: str,
) -> tuple[list[str], list[str], list[str], dict[str, str], tuple[Signal, ...]]:
    ins = _names(inputs, "inputs")
    dis = _names(disturbances, "disturbances")
    outs = _names(outputs, "outputs")
    if not ins + dis:
        raise ConfigError(f"{model}: no inputs or disturbances; expected at least one")
    if not outs:
        raise ConfigError(f"{model}: no outputs; expected at least one")
    units = dict(units or {})
    unknown = sorted(set(units) - set(ins + dis + outs))
    if unknown:
        raise ConfigError(
            f"{model}: units given for unknown signal(s) {unknown}; signals are {ins + dis + outs}"
        )
    full = {s: str(units.get(s, "1")) for s in ins + dis + outs}
    sig = (
        *(Signal(s, "input", full[s], f"input {s} of the {model}") for s in ins),
        *(Signal(s, "disturbance", full[s], f"disturbance {s} of the {model}") for s in dis),
        *(Signal(s, "output", full[s], f"output {s} of the {model}") for s in outs),
    )
    return ins, dis, outs, full, sig


def _matrix(
    name: str, value: ArrayLike, shape: tuple[int, int], meaning: str
) -> NDArray[np.float64]:
    a = np.asarray(value, dtype=float)
    if a.shape != shape:
        raise ShapeError(f"{name} has shape {a.shape}, expected {shape} ({meaning})")
    if not np.isfinite(a).all():
        r, c = np.argwhere(~np.isfinite(a))[0]
        raise ParameterError(f"{name}[{r}, {c}] is {a[r, c]!r}; expected a finite number")
    return a


def _wide(v: float) -> tuple[float, float]:
    w = 10.0 * abs(v) + 1.0
    return v - w, v + w


def _period(dt: float, what: str) -> float:
    if not (np.isfinite(dt) and dt > 0):
        raise ShapeError(f"{what}: dt is {dt!r}, expected a positive sample period in seconds")
    return float(dt)


def _vector(
    name: str, value: ArrayLike | None, names: Sequence[str], what: str
) -> NDArray[np.float64]:
    """An operating-point vector: one finite value per named signal (zeros when None)."""
    n = len(names)
    if value is None:
        return np.zeros(n)
    if isinstance(value, Mapping):
        unknown = sorted(set(value) - set(names))
        if unknown:
            raise ConfigError(f"{name} names {unknown}, which are not {what} {list(names)}")
        value = [value.get(c, 0.0) for c in names]
    a = np.asarray(value, dtype=float)
    if a.ndim == 0:
        a = np.full(n, float(a))
    if a.shape != (n,):
        raise ShapeError(
            f"{name} has shape {a.shape}, expected ({n},): one value per {what} {list(names)}"
        )
    if not np.isfinite(a).all():
        j = int(np.argmax(~np.isfinite(a)))
        raise ParameterError(f"{name} of {names[j]!r} is {a[j]!r}; expected a finite number")
    return a


def _y_batch(y: ArrayLike, p: int, T: int, names: Sequence[str]) -> NDArray[np.float64]:
    ya = np.asarray(y, dtype=float)
    if ya.ndim == 1 and p == 1:
        ya = ya[:, None]
    if ya.ndim == 2:
        ya = ya[None]
    if ya.ndim != 3 or ya.shape[1:] != (T, p):
        raise ShapeError(
            f"y has shape {np.shape(y)}, expected ({T}, {p}) or (B, {T}, {p}) with columns "
            f"{list(names)} and as many samples as u"
        )
    return ya


def _u_batch(u: ArrayLike, names: Sequence[str]) -> NDArray[np.float64]:
    """Validate exogenous signals: shape (Bu, T, m), finite."""
    ua = np.asarray(u, dtype=float)
    m = len(names)
    if ua.ndim == 1 and m == 1:
        ua = ua[:, None]
    if ua.ndim == 2:
        ua = ua[None]
    if ua.ndim != 3 or ua.shape[2] != m:
        raise ShapeError(
            f"u has shape {np.shape(u)}, expected (T, {m}) or (B, T, {m}) with columns "
            f"{list(names)}"
        )
    if ua.shape[1] < 1:
        raise ShapeError("u has no samples")
    if not np.isfinite(ua).all():
        b, k, j = np.argwhere(~np.isfinite(ua))[0]
        raise ShapeError(
            f"exogenous signal {names[j]!r} is {float(ua[b, k, j])!r} at sample {int(k)}; "
            "expected finite inputs (prepare the recording first)"
        )
    return ua


def _compact(u: NDArray[np.float64]) -> NDArray[np.float64]:
    """Contiguous copy of ``u`` that keeps a broadcast batch axis at size 1."""
    if u.shape[0] > 1 and u.strides[0] == 0:
        u = u[:1]
    u = np.ascontiguousarray(u)
    # one kernel signature: numba types read-only arrays separately
    return u if u.flags.writeable else u.copy()


def _transposed(a: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.ascontiguousarray(np.swapaxes(a, 1, 2))


def _broadcast_batch(*arrays: NDArray[np.float64]) -> list[NDArray[np.float64]]:
    sizes = {a.shape[0] for a in arrays} - {1}
    if len(sizes) > 1:
        raise ShapeError(f"batch sizes {sorted(sizes)} differ; expected equal sizes or 1")
    B = sizes.pop() if sizes else 1
    return [np.ascontiguousarray(np.broadcast_to(a, (B, *a.shape[1:]))) for a in arrays]


#: Initial-state modes of the generic linear models (module docstring, "Starting State").
X0_MODES: tuple[str, ...] = ("zero", "steady", "estimate")


def check_x0_mode(mode: object) -> str:
    """Return ``mode`` when it is one of :data:`X0_MODES`, else raise :class:`ConfigError`.

    Examples
    --------
    >>> from thermogym.models.linear import check_x0_mode
    >>> check_x0_mode("estimate")
    'estimate'
    """
    if not isinstance(mode, str) or mode not in X0_MODES:
        raise ConfigError(f"x0 is {mode!r}; expected one of {list(X0_MODES)} or an array")
    return mode


class _LinearModel(Model):
    """Operating point and initial-state modes shared by the generic linear models.

    Subclasses implement ``_run(theta, u, dt, x0, return_states, pre)`` (``pre``:
    the exogenous signals held before ``t = 0``, shape (B, m), or None for the
    model's default), :meth:`operating_point`, ``_start(mode, ...)`` and
    :meth:`estimate_x0`.
    """

    def operating_point(
        self, theta: ThetaLike = None
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Operating point ``(u_op, y_op)``, shapes (B, m) and (B, p).

        The model maps ``u − u_op`` to ``y − y_op``: at rest with ``u = u_op``
        its output is ``y_op``.
        """
        raise NotImplementedError  # pragma: no cover - every subclass overrides it

    def _simulate(self, theta, u, dt, x0, return_states):
        return self._run(theta, u, dt, x0, return_states, None)

    def _run(self, theta, u, dt, x0, return_states, pre):  # pragma: no cover - abstract
        raise NotImplementedError

    def _start(self, mode, theta, u, dt, y):  # pragma: no cover - abstract
        raise NotImplementedError

    def start_state(
        self,
        mode: str,
        u: ArrayLike,
        dt: float,
        theta: ThetaLike = None,
        y: ArrayLike | None = None,
    ) -> NDArray[np.float64]:
        """Initial state of mode ``"zero"``, ``"steady"`` or ``"estimate"``, shape (B, n_x).

        Parameters
        ----------
        mode : {"zero", "steady", "estimate"}
            ``zero``: at rest at the operating point; ``steady``: in the steady
            state of the first input sample; ``estimate``: least squares on the
            measured outputs ``y`` given the inputs (see :meth:`estimate_x0`).
        u : array_like, shape (T, m) or (B, T, m)
            Exogenous signals.
        dt : float
            Sample period of ``u`` and ``y`` [s].
        theta : parameter batch, optional
        y : array_like, shape (T, p) or (B, T, p), optional
            Measured outputs; needed by ``"estimate"``.

        Returns
        -------
        ndarray, shape (B, n_x)
        """
        mode = check_x0_mode(mode)
        th, ua = self._simulation_batch(u, dt, theta)
        return self._start(mode, th, ua, float(dt), y)[0]

    def simulate(
        self,
        u: ArrayLike,
        dt: float,
        theta: ThetaLike = None,
        x0: ArrayLike | str | None = None,
        *,
        y: ArrayLike | None = None,
        t0: float = 0.0,
        return_states: bool = False,
        strict: bool = True,
    ) -> Simulation:
        """Simulate at any positive period, from a state or an initial-state mode.

        Parameters
        ----------
        u : array_like, shape (T, m) or (B, T, m)
            Exogenous signals in :attr:`exogenous_names` order, held over each
            sample interval (absolute values: the model subtracts ``u_op``).
        dt : float
            Sample period [s]; any positive value.
        theta : parameter batch, optional
        x0 : array_like (n_x,) or (B, n_x), {"zero", "steady", "estimate"}, optional
            Initial state, or how to choose it (module docstring, "Starting
            State"); :meth:`initial_state` when omitted. ``simulation.meta["x0"]``
            names the mode used.
        y : array_like, shape (T, p) or (B, T, p), optional
            Measured outputs, for ``x0="estimate"`` only.
        t0 : float
            Time of the first sample [s].
        return_states : bool
        strict : bool
            Raise on non-finite outputs (default) instead of returning NaN rows.

        Returns
        -------
        Simulation
        """
        th, ua = self._simulation_batch(u, dt, theta)
        meta: dict[str, Any] = {}
        pre = None
        if isinstance(x0, str):
            mode = check_x0_mode(x0)
            x, pre = self._start(mode, th, ua, float(dt), y)
            meta["x0"] = mode
        else:
            if y is not None:
                raise ConfigError("y (measured outputs) is used only with x0='estimate'")
            x = self._initial_array(x0, th, ua)
        yk, xs = self._run(th, ua, float(dt), np.ascontiguousarray(x), return_states, pre)
        return self._simulation_result(th, ua, dt, yk, xs, t0=t0, strict=strict, meta=meta)

    def _measured(self, y: ArrayLike | None, T: int) -> NDArray[np.float64]:
        if y is None:
            raise ConfigError(
                "x0='estimate' needs the measured outputs y (columns "
                f"{list(self.output_names)}); without them use 'steady' or 'zero'"
            )
        return _y_batch(y, self.n_outputs, T, self.output_names)


# ======================================================= state-space kernels
# The kernels take transposed matrices (At[b, j, i] = A[b, i, j]) so that the inner loops
# are contiguous axpy updates (x_new += A[:, j] x_j) that the compiler vectorises without
# reordering a floating-point sum.
@nb.njit(cache=True)
def _ss_simulate_kernel(At, Bt_, Ct, Dt, u, x0, nsub, y, xs, keep):  # pragma: no cover
    nb_, T, m = At.shape[0], u.shape[1], u.shape[2]
    n = At.shape[1]
    p = Ct.shape[2]
    x = np.empty(n)
    xn = np.empty(n)
    yk = np.empty(p)
    for b in range(nb_):
        ub = b if u.shape[0] > 1 else 0
        Ab, Bb, Cb, Db = At[b], Bt_[b], Ct[b], Dt[b]
        for i in range(n):
            x[i] = x0[b, i]
        for k in range(T):
            # y[k] = C x[k] + D u[k]                      (3) in 001_6d13a2cd04f5de5e.txt
            yk[:] = 0.0
            for j in range(n):
                xj = x[j]
                for i in range(p):
                    yk[i] += Cb[j, i] * xj
            for j in range(m):
                uj = u[ub, k, j]
                for i in range(p):
                    yk[i] += Db[j, i] * uj
            for i in range(p):
                y[b, k, i] = yk[i]
            if keep:
                for i in range(n):
                    xs[b, k, i] = x[i]
            if k + 1 == T:
                break
            for _ in range(nsub):
                # x[k+1] = A x[k] + B u[k]   (e = 0)      (3) in 001_6d13a2cd04f5de5e.txt
                xn[:] = 0.0
                for j in range(n):
                    xj = x[j]
                    for i in range(n):
                        xn[i] += Ab[j, i] * xj
                for j in range(m):
                    uj = u[ub, k, j]
                    for i in range(n):
                        xn[i] += Bb[j, i] * uj
                x[:] = xn


@nb.njit(cache=True)
def _ss_predict_kernel(At, Bt_, Ct, Dt, Kt, Aht, AhBt, u, y, x0, h, out):  # pragma: no cover
    nb_, T, m = At.shape[0], u.shape[1], u.shape[2]
    n = At.shape[1]
    p = Ct.shape[2]
    xp = np.empty((T, n))
    x = np.empty(n)
    xn = np.empty(n)
    e = np.empty(p)
    yk = np.empty(p)
    P = np.empty(n)
    S = np.empty(n)
    v = np.empty(n)
    for b in range(nb_):
        ub = b if u.shape[0] > 1 else 0
        yb = b if y.shape[0] > 1 else 0
        Ab, Bb, Cb, Db, Kb, Ahb, AhBb = At[b], Bt_[b], Ct[b], Dt[b], Kt[b], Aht[b], AhBt[b]
        # one-step Kalman predictor in innovation form; x̂[k|k−1] is stored in xp[k]:
        # x̂[k+1|k] = A x̂ + B u + K (y − C x̂ − D u) = (A − K C) x̂ + (B − K D) u + K y
        # a missing (NaN) y component gives a zero innovation component.
        for i in range(n):
            x[i] = x0[b, i]
        for k in range(T):
            xp[k, :] = x
            yk[:] = 0.0
            for j in range(n):
                for i in range(p):
                    yk[i] += Cb[j, i] * x[j]
            for j in range(m):
                for i in range(p):
                    yk[i] += Db[j, i] * u[ub, k, j]
            for i in range(p):
                yi = y[yb, k, i]
                e[i] = 0.0 if math.isnan(yi) else yi - yk[i]
            xn[:] = 0.0
            for j in range(n):
                for i in range(n):
                    xn[i] += Ab[j, i] * x[j]
            for j in range(m):
                for i in range(n):
                    xn[i] += Bb[j, i] * u[ub, k, j]
            for j in range(p):
                for i in range(n):
                    xn[i] += Kb[j, i] * e[j]
            x[:] = xn
        # h-step-ahead: x̄[k|k−h] = A^{h−1} x̂[k−h+1|k−h] + S[k],
        # S[k] = Σ_{j=0}^{h−2} A^j B u[k−1−j]; for k < h−1 the data start is x0:
        # x̄ = A^k x0 + S[k] with the window still growing.
        for i in range(n):
            P[i] = x0[b, i]
            S[i] = 0.0
        for k in range(T):
            if k < h - 1:
                for i in range(n):
                    v[i] = P[i] + S[i]
            else:
                v[:] = S
                for j in range(n):
                    for i in range(n):
                        v[i] += Ahb[j, i] * xp[k - h + 1, j]
            # ŷ[k|k−h] = C x̄ + D u[k]
            yk[:] = 0.0
            for j in range(n):
                for i in range(p):
                    yk[i] += Cb[j, i] * v[j]
            for j in range(m):
                for i in range(p):
                    yk[i] += Db[j, i] * u[ub, k, j]
            out[b, k, :] = yk
            # S[k+1] = A S[k] + B u[k] (− A^{h−1} B u[k−h+1] once the window is full)
            xn[:] = 0.0
            for j in range(n):
                for i in range(n):
                    xn[i] += Ab[j, i] * S[j]
            for j in range(m):
                for i in range(n):
                    xn[i] += Bb[j, i] * u[ub, k, j]
                    if k >= h - 1:
                        xn[i] -= AhBb[j, i] * u[ub, k - h + 1, j]
            S[:] = xn
            if k < h - 1:
                xn[:] = 0.0
                for j in range(n):
                    for i in range(n):
                        xn[i] += Ab[j, i] * P[j]
                P[:] = xn


@nb.njit(cache=True)
def _obs_rows(M, A, out):  # pragma: no cover - numba
    # rows of the free response: out[k] = C A^{k0+k}, with M = C A^{k0} updated in place
    L, p, n = out.shape
    tmp = np.empty((p, n))
    for k in range(L):
        for r in range(p):
            for c in range(n):
                out[k, r, c] = M[r, c]
        for r in range(p):
            for c in range(n):
                acc = 0.0
                for j in range(n):
                    acc += M[r, j] * A[j, c]
                tmp[r, c] = acc
        for r in range(p):
            for c in range(n):
                M[r, c] = tmp[r, c]


# ============================================================ ZOH conversions
class StateSpaceMatrices(NamedTuple):
    """Batched discrete matrices of a :class:`StateSpaceModel`.

    Attributes
    ----------
    A : ndarray, shape (B, n, n)
    B : ndarray, shape (B, n, m)
    C : ndarray, shape (B, p, n)
    D : ndarray, shape (B, p, m)
        Zero when the model has no feedthrough.
    K : ndarray, shape (B, n, p)
        Zero when the model has no innovation gain.
    """

    A: NDArray[np.float64]
    B: NDArray[np.float64]
    C: NDArray[np.float64]
    D: NDArray[np.float64]
    K: NDArray[np.float64]


class ContinuousStateSpace(NamedTuple):
    """Batched continuous-time matrices ``dx/dt = A x + B u``, ``y = C x + D u``.

    Attributes
    ----------
    A : ndarray, shape (B, n, n)
        [1/s].
    B : ndarray, shape (B, n, m)
        [state/(input·s)].
    C : ndarray, shape (B, p, n)
    D : ndarray, shape (B, p, m)
    """

    A: NDArray[np.float64]
    B: NDArray[np.float64]
    C: NDArray[np.float64]
    D: NDArray[np.float64]


def c2d_zoh(
    A: ArrayLike, B: ArrayLike, dt: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Exact zero-order-hold discretisation of ``dx/dt = A x + B u``.

    ``exp([[A, B], [0, 0]] Δt) = [[A_d, B_d], [0, I]]``.

    Parameters
    ----------
    A : array_like, shape (n, n)
        Continuous state matrix [1/s].
    B : array_like, shape (n, m)
        Continuous input matrix [state/(input·s)].
    dt : float
        Sample period [s].

    Returns
    -------
    Ad : ndarray, shape (n, n)
    Bd : ndarray, shape (n, m)

    Examples
    --------
    >>> from thermogym.models.linear import c2d_zoh
    >>> Ad, Bd = c2d_zoh([[-0.5]], [[0.5]], dt=2.0)
    >>> round(float(Ad[0, 0]), 6), round(float(Bd[0, 0]), 6)
    (0.367879, 0.632121)
    """
    Aa = np.asarray(A, dtype=float)
    n = Aa.shape[0] if Aa.ndim == 2 else -1
    Aa = _matrix("A", Aa, (n, n), "n_states, n_states")
    Ba = np.asarray(B, dtype=float)
    m = Ba.shape[1] if Ba.ndim == 2 else -1
    Ba = _matrix("B", Ba, (n, m), "n_states, n_inputs")
    if not (np.isfinite(dt) and dt > 0):
        raise ParameterError(f"dt is {dt!r}, expected a positive sample period in seconds")
    M = np.zeros((n + m, n + m))
    M[:n, :n] = Aa * dt
    M[:n, n:] = Ba * dt
    E = scipy.linalg.expm(M)
    return E[:n, :n], E[:n, n:]


def d2c_zoh(
    A: ArrayLike, B: ArrayLike, dt: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Continuous-time system whose ZOH discretisation is ``(A, B)``.

    Inverse of :func:`c2d_zoh` through the principal matrix logarithm
    ``log([[A, B], [0, I]]) / Δt = [[A_c, B_c], [0, 0]]``.

    Parameters
    ----------
    A : array_like, shape (n, n)
        Discrete state matrix.
    B : array_like, shape (n, m)
        Discrete input matrix.
    dt : float
        Sample period [s].

    Returns
    -------
    Ac : ndarray, shape (n, n)
    Bc : ndarray, shape (n, m)

    Raises
    ------
    ParameterError
        ``A`` has an eigenvalue on the non-positive real axis: no real
        continuous-time system has this ZOH equivalent.

    Examples
    --------
    >>> from thermogym.models.linear import d2c_zoh
    >>> Ac, Bc = d2c_zoh([[0.36787944117144233]], [[0.6321205588285577]], dt=2.0)
    >>> round(float(Ac[0, 0]), 6), round(float(Bc[0, 0]), 6)
    (-0.5, 0.5)
    """
    Aa = np.asarray(A, dtype=float)
    n = Aa.shape[0] if Aa.ndim == 2 else -1
    Aa = _matrix("A", Aa, (n, n), "n_states, n_states")
    Ba = np.asarray(B, dtype=float)
    m = Ba.shape[1] if Ba.ndim == 2 else -1
    Ba = _matrix("B", Ba, (n, m), "n_states, n_inputs")
    if not (np.isfinite(dt) and dt > 0):
        raise ParameterError(f"dt is {dt!r}, expected a positive sample period in seconds")
    lam = np.linalg.eigvals(Aa)
    bad = (np.abs(lam.imag) <= 1e-12 * np.maximum(1.0, np.abs(lam))) & (lam.real <= 0)
    if bad.any():
        raise ParameterError(
            f"A has eigenvalue {lam[bad][0].real:.6g} on the non-positive real axis; a "
            "ZOH-sampled continuous system has only eigenvalues exp(λΔt), so no real "
            "continuous-time equivalent exists"
        )
    M = np.zeros((n + m, n + m))
    M[:n, :n] = Aa
    M[:n, n:] = Ba
    M[n:, n:] = np.eye(m)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        L = scipy.linalg.logm(M)
    L = np.asarray(L)
    if np.iscomplexobj(L):
        if np.abs(L.imag).max() > 1e-8 * max(1.0, np.abs(L.real).max()):
            raise ParameterError(
                "the matrix logarithm of [[A, B], [0, I]] is complex; no real "
                "continuous-time equivalent of this A exists"
            )
        L = L.real
    return L[:n, :n] / dt, L[:n, n:] / dt


# ============================================================ StateSpaceModel
class StateSpaceModel(_LinearModel):
    """Discrete MIMO state space in innovation form (001 eq 3).

    ``x[k+1] = A x[k] + B u[k] + K e[k]``, ``y[k] = C x[k] + D u[k] + e[k]``
    with sample period ``dt``. The parameters are the entries of ``A``,
    ``B``, ``C`` and, when enabled, ``D``, ``K`` and ``x0`` (row-major, names
    ``A_r_c``); a batch ``theta`` of shape (B, P) is simulated at once by a
    compiled loop. With an operating point the model maps ``u − u_op`` to
    ``y − y_op``: ``x[k+1] = A x[k] + B (u[k] − u_op)``,
    ``y[k] = y_op + C x[k] + D (u[k] − u_op)``.

    Parameters
    ----------
    n_states : int, optional
        Model order ``n``; taken from ``A`` when omitted (1 without ``A``).
    inputs : sequence of str
        Column names of the manipulated inputs.
    outputs : sequence of str
        Column names of the outputs.
    dt : float, optional
        Sample period the matrices are discrete at [s]. ``None`` (default):
        one step of the matrices is one sample of whatever data the model is
        simulated on (a black-box model identified at the data's period).
        With a period, :meth:`simulate` and :meth:`step` accept any positive
        period: an integer multiple holds the input over the sub-steps,
        any other period uses the exact ZOH resampling of the continuous
        equivalent (:func:`d2c_zoh`, :func:`c2d_zoh`).
    disturbances : sequence of str
        Column names of exogenous, non-manipulated inputs; they follow the
        inputs as further columns of ``u`` (and of ``B``, ``D``).
    units : mapping, optional
        ``{signal name: unit}``; unlisted signals get ``"1"`` (dimensionless
        or unknown).
    A, B, C, D, K : array_like, optional
        Nominal matrices, shapes (n, n), (n, m), (p, n), (p, m), (n, p) with
        ``m`` exogenous signals and ``p`` outputs; zero when omitted.
    x0 : array_like, shape (n,), optional
        Nominal initial state; only with ``fit_x0=True``.
    has_D : bool, optional
        Make the feedthrough ``D`` a parameter; default: whether ``D`` is
        given. Without it ``D = 0`` (strictly proper, as in paper 001).
    has_K : bool, optional
        Make the innovation gain ``K`` a parameter; default: whether ``K`` is
        given. Without it ``K = 0`` and :meth:`predict` equals simulation.
    fit_x0 : bool
        Add parameters ``x0_r`` and start every simulation from them.
    steady_start : bool
        Start from ``(I − A)^{-1} B (u[0] − u_op)`` instead of ``x = 0``.
    u_op : array_like (m,) or mapping, optional
        Operating-point inputs (absolute units), zero when omitted.
    y_op : array_like (p,) or mapping, optional
        Operating-point outputs (absolute units), zero when omitted.

    Raises
    ------
    ShapeError
        A matrix has the wrong shape (the message names it and the expected shape).
    ConfigError
        Contradicting options (``D`` given with ``has_D=False``, ...).

    Examples
    --------
    >>> import numpy as np
    >>> from thermogym.models.linear import StateSpaceModel
    >>> m = StateSpaceModel.from_matrices([[0.9]], [[0.1]], [[1.0]], dt=1.0,
    ...                                   inputs=["P"], outputs=["T"])
    >>> m.param_names
    ('A_0_0', 'B_0_0', 'C_0_0')
    >>> sim = m.simulate(np.ones((200, 1)), dt=1.0)
    >>> round(float(sim.output("T")[0, -1]), 4), round(float(m.dcgain()[0, 0, 0]), 12)
    (1.0, 1.0)
    """

    name = "ss"
    version = "1"

    def __init__(
        self,
        n_states: int | None = None,
        inputs: Sequence[str] | str = ("u",),
        outputs: Sequence[str] | str = ("y",),
        *,
        dt: float | None = None,
        disturbances: Sequence[str] | str = (),
        units: Mapping[str, str] | None = None,
        A: ArrayLike | None = None,
        B: ArrayLike | None = None,
        C: ArrayLike | None = None,
        D: ArrayLike | None = None,
        K: ArrayLike | None = None,
        x0: ArrayLike | None = None,
        has_D: bool | None = None,
        has_K: bool | None = None,
        fit_x0: bool = False,
        steady_start: bool = False,
        u_op: ArrayLike | Mapping[str, float] | None = None,
        y_op: ArrayLike | Mapping[str, float] | None = None,
    ) -> None:
        ins, dis, outs, full_units, signals = _make_signals(
            inputs, disturbances, outputs, units, "state-space model"
        )
        if n_states is None:
            n_states = np.shape(A)[0] if A is not None and np.ndim(A) == 2 else 1
        if int(n_states) != n_states or n_states < 1:
            raise ConfigError(f"n_states is {n_states!r}; expected a positive integer")
        if dt is not None and not (
            isinstance(dt, int | float | np.integer | np.floating) and np.isfinite(dt) and dt > 0
        ):
            raise ConfigError(
                f"dt is {dt!r}; expected a positive sample period in seconds or None (the "
                "period of the data)"
            )
        if fit_x0 and steady_start:
            raise ConfigError("fit_x0 and steady_start both set; choose one starting state")
        n, m, p = int(n_states), len(ins) + len(dis), len(outs)
        exo = ins + dis
        self.dt = None if dt is None else float(dt)
        self.n_states, self.n_inputs, self.n_outputs = n, m, p
        self.u_op = _vector("u_op", u_op, exo, "exogenous signal")
        self.y_op = _vector("y_op", y_op, outs, "output")
        self._cfg_names = (ins, dis, outs, full_units)
        self.fit_x0, self.steady_start = bool(fit_x0), bool(steady_start)

        def opt(name, value, flag, shape, meaning):
            use = (value is not None) if flag is None else bool(flag)
            if value is None:
                return use, np.zeros(shape)
            a = _matrix(name, value, shape, meaning)
            if not use and np.any(a != 0):
                raise ConfigError(
                    f"{name} is given (non-zero) but has_{name}=False would ignore it; "
                    f"drop {name} or set has_{name}=True"
                )
            return use, a

        Am = np.zeros((n, n)) if A is None else _matrix("A", A, (n, n), "n_states, n_states")
        Bm = np.zeros((n, m)) if B is None else _matrix("B", B, (n, m), "n_states, n_exogenous")
        Cm = np.zeros((p, n)) if C is None else _matrix("C", C, (p, n), "n_outputs, n_states")
        self.has_D, Dm = opt("D", D, has_D, (p, m), "n_outputs, n_exogenous")
        self.has_K, Km = opt("K", K, has_K, (n, p), "n_states, n_outputs")
        if x0 is not None and not fit_x0:
            raise ConfigError("x0 is given but fit_x0=False; pass x0 to simulate() instead")
        x0m = np.zeros(n) if x0 is None else np.asarray(x0, dtype=float).reshape(-1)
        if x0m.shape != (n,):
            raise ShapeError(f"x0 has shape {np.shape(x0)}, expected ({n},) (n_states)")

        uo = {s: full_units[s] for s in exo + outs}
        params: list[Parameter] = []

        def add(group, mat, desc, unit, name=None):
            for r in range(mat.shape[0]):
                for c in range(mat.shape[1]):
                    v = float(mat[r, c])
                    lo, hi = _wide(v)
                    pname = name(r) if name else f"{group}_{r}_{c}"
                    params.append(Parameter(pname, v, lo, hi, unit(r, c), desc(r, c), _PROV, group))

        add("A", Am, lambda r, c: f"state transition x_{c} → x_{r}", lambda r, c: "1")
        add("B", Bm, lambda r, c: f"input {exo[c]} → x_{r}", lambda r, c: f"state/{uo[exo[c]]}")
        add("C", Cm, lambda r, c: f"x_{c} → output {outs[r]}", lambda r, c: f"{uo[outs[r]]}/state")
        if self.has_D:
            add(
                "D",
                Dm,
                lambda r, c: f"feedthrough {exo[c]} → {outs[r]}",
                lambda r, c: f"{uo[outs[r]]}/{uo[exo[c]]}",
            )
        if self.has_K:
            add(
                "K",
                Km,
                lambda r, c: f"innovation gain e_{outs[c]} → x_{r}",
                lambda r, c: f"state/{uo[outs[c]]}",
            )
        if self.fit_x0:
            add(
                "x0",
                x0m[:, None],
                lambda r, c: f"initial value of x_{r}",
                lambda r, c: "state",
                name=lambda r: f"x0_{r}",
            )
        # column slices of the parameter groups in theta
        i = 0
        self._sl: dict[str, slice] = {}
        for g, size, on in (
            ("A", n * n, True),
            ("B", n * m, True),
            ("C", p * n, True),
            ("D", p * m, self.has_D),
            ("K", n * p, self.has_K),
            ("x0", n, self.fit_x0),
        ):
            if on:
                self._sl[g] = slice(i, i + size)
                i += size
        super().__init__(signals, params, tuple(f"x_{r}" for r in range(n)))

    # -------------------------------------------------------------- construction
    @classmethod
    def from_matrices(
        cls,
        A: ArrayLike,
        B: ArrayLike,
        C: ArrayLike,
        D: ArrayLike | None = None,
        K: ArrayLike | None = None,
        *,
        dt: float | None = None,
        inputs: Sequence[str] | str | None = None,
        outputs: Sequence[str] | str | None = None,
        **kwargs: Any,
    ) -> StateSpaceModel:
        """Build a model whose nominal parameters are the given matrices.

        Parameters
        ----------
        A, B, C : array_like
            Discrete matrices, shapes (n, n), (n, m), (p, n).
        D : array_like, shape (p, m), optional
            Feedthrough; ``None`` means ``D = 0`` and no ``D`` parameters.
        K : array_like, shape (n, p), optional
            Innovation gain; ``None`` means no ``K`` parameters.
        dt : float, optional
            Sample period [s]; ``None``: the period of the data (see the class).
        inputs, outputs : sequence of str, optional
            Signal names; default ``u_0 … u_{m−1}`` and ``y_0 … y_{p−1}``
            (``disturbances`` in ``kwargs`` take the last columns of ``B``).
        **kwargs
            Further constructor arguments (``units``, ``disturbances``,
            ``fit_x0``, ``steady_start``, ...).

        Returns
        -------
        StateSpaceModel

        Examples
        --------
        >>> from thermogym.models.linear import StateSpaceModel
        >>> m = StateSpaceModel.from_matrices([[0.5]], [[1.0]], [[1.0]], [[0.0]], dt=60.0)
        >>> m.exogenous_names, m.output_names, m.has_D, m.has_K
        (('u_0',), ('y_0',), True, False)
        """
        Aa = np.asarray(A, dtype=float)
        if Aa.ndim != 2:
            raise ShapeError(f"A has shape {Aa.shape}, expected (n, n) (n_states, n_states)")
        Ba = np.asarray(B, dtype=float)
        Ca = np.asarray(C, dtype=float)
        if Ba.ndim != 2:
            raise ShapeError(f"B has shape {Ba.shape}, expected (n, m) (n_states, n_exogenous)")
        if Ca.ndim != 2:
            raise ShapeError(f"C has shape {Ca.shape}, expected (p, n) (n_outputs, n_states)")
        n_dis = len(_names(kwargs.get("disturbances", ()), "disturbances"))
        if inputs is None:
            inputs = [f"u_{i}" for i in range(Ba.shape[1] - n_dis)]
        if outputs is None:
            outputs = [f"y_{i}" for i in range(Ca.shape[0])]
        return cls(
            Aa.shape[0],
            inputs,
            outputs,
            dt=dt,
            A=Aa,
            B=Ba,
            C=Ca,
            D=D,
            K=K,
            has_D=D is not None,
            has_K=K is not None,
            **kwargs,
        )

    @classmethod
    def from_continuous(
        cls,
        Ac: ArrayLike,
        Bc: ArrayLike,
        C: ArrayLike,
        D: ArrayLike | None = None,
        *,
        dt: float,
        K: ArrayLike | None = None,
        inputs: Sequence[str] | str | None = None,
        outputs: Sequence[str] | str | None = None,
        **kwargs: Any,
    ) -> StateSpaceModel:
        """Build the exact ZOH discretisation of a continuous-time system.

        Parameters
        ----------
        Ac : array_like, shape (n, n)
            Continuous state matrix [1/s].
        Bc : array_like, shape (n, m)
            Continuous input matrix [state/(input·s)].
        C : array_like, shape (p, n)
        D : array_like, shape (p, m), optional
        dt : float
            Sample period [s].
        K : array_like, shape (n, p), optional
            *Discrete* innovation gain, taken as it is.
        inputs, outputs : sequence of str, optional
        **kwargs
            Further constructor arguments.

        Returns
        -------
        StateSpaceModel

        Examples
        --------
        >>> from thermogym.models.linear import StateSpaceModel
        >>> m = StateSpaceModel.from_continuous([[-0.01]], [[0.01]], [[1.0]], dt=10.0)
        >>> round(float(m.matrices().A[0, 0, 0]), 6)
        0.904837
        """
        Ad, Bd = c2d_zoh(Ac, Bc, dt)
        return cls.from_matrices(Ad, Bd, C, D, K, dt=dt, inputs=inputs, outputs=outputs, **kwargs)

    def config(self) -> dict[str, Any]:
        """Constructor arguments that rebuild this model (JSON-able)."""
        ins, dis, outs, units = self._cfg_names
        mats = self.matrices()
        cfg: dict[str, Any] = {
            "n_states": self.n_states,
            "inputs": list(ins),
            "outputs": list(outs),
            "dt": self.dt,
            "disturbances": list(dis),
            "units": dict(units),
            "A": mats.A[0].tolist(),
            "B": mats.B[0].tolist(),
            "C": mats.C[0].tolist(),
            "has_D": self.has_D,
            "has_K": self.has_K,
            "fit_x0": self.fit_x0,
            "steady_start": self.steady_start,
        }
        if self.has_D:
            cfg["D"] = mats.D[0].tolist()
        if self.has_K:
            cfg["K"] = mats.K[0].tolist()
        if self.fit_x0:
            cfg["x0"] = self.nominal[self._sl["x0"]].tolist()
        if np.any(self.u_op != 0):
            cfg["u_op"] = self.u_op.tolist()
        if np.any(self.y_op != 0):
            cfg["y_op"] = self.y_op.tolist()
        return cfg

    # ------------------------------------------------------------------ matrices
    def matrices(self, theta: ThetaLike = None) -> StateSpaceMatrices:
        """Batched matrices of a parameter batch.

        Parameters
        ----------
        theta : parameter batch, optional
            Anything :meth:`theta` accepts; nominal when omitted.

        Returns
        -------
        StateSpaceMatrices
            ``A`` (B, n, n), ``B`` (B, n, m), ``C`` (B, p, n), ``D`` (B, p, m),
            ``K`` (B, n, p).

        Examples
        --------
        >>> from thermogym.models.linear import StateSpaceModel
        >>> m = StateSpaceModel(2, ["u"], ["y"])
        >>> m.matrices(m.theta(A_0_1=[0.1, 0.2])).A.shape
        (2, 2, 2)
        """
        th = self.theta(theta)
        Bt = th.shape[0]
        n, m, p = self.n_states, self.n_inputs, self.n_outputs

        def grab(g, shape):
            if g in self._sl:
                return th[:, self._sl[g]].reshape(Bt, *shape)
            return np.zeros((Bt, *shape))

        return StateSpaceMatrices(
            grab("A", (n, n)),
            grab("B", (n, m)),
            grab("C", (p, n)),
            grab("D", (p, m)),
            grab("K", (n, p)),
        )

    def eigenvalues(self, theta: ThetaLike = None) -> NDArray[np.complex128]:
        """Eigenvalues of ``A`` (discrete poles), shape (B, n).

        Examples
        --------
        >>> from thermogym.models.linear import StateSpaceModel
        >>> m = StateSpaceModel.from_matrices([[0.5, 1.0], [0.0, 0.8]], [[0], [1]],
        ...                                   [[1, 0]], dt=1.0)
        >>> sorted(m.eigenvalues()[0].real.round(3).tolist())
        [0.5, 0.8]
        """
        return np.linalg.eigvals(self.matrices(theta).A)

    def is_stable(self, theta: ThetaLike = None) -> NDArray[np.bool_]:
        """Whether every eigenvalue of ``A`` lies inside the unit circle, shape (B,).

        Examples
        --------
        >>> from thermogym.models.linear import StateSpaceModel
        >>> m = StateSpaceModel.from_matrices([[1.01]], [[1.0]], [[1.0]], dt=1.0)
        >>> m.is_stable().tolist()
        [False]
        """
        return np.abs(self.eigenvalues(theta)).max(axis=1) < 1.0

    def dcgain(self, theta: ThetaLike = None) -> NDArray[np.float64]:
        """Steady-state gain ``C (I − A)^{-1} B + D``, shape (B, p, m).

        Raises
        ------
        SimulationError
            ``I − A`` is singular (an eigenvalue of ``A`` at 1, integrating mode).

        Examples
        --------
        >>> from thermogym.models.linear import StateSpaceModel
        >>> m = StateSpaceModel.from_matrices([[0.5]], [[1.0]], [[2.0]], dt=1.0)
        >>> m.dcgain().tolist()
        [[[4.0]]]
        """
        mats = self.matrices(theta)
        return np.einsum("bpn,bnm->bpm", mats.C, self._steady(mats.A, mats.B)) + mats.D

    def _steady(self, A: NDArray[np.float64], Bu: NDArray[np.float64]) -> NDArray[np.float64]:
        eye = np.eye(self.n_states)
        try:
            # x = A x + B u  ⇒  x = (I − A)^{-1} B u
            return np.linalg.solve(eye[None] - A, Bu)
        except np.linalg.LinAlgError as e:
            raise SimulationError(
                "I − A is singular (A has an eigenvalue at 1, an integrating mode); the "
                "steady state / DC gain does not exist"
            ) from e

    def to_continuous(self, theta: ThetaLike = None) -> ContinuousStateSpace:
        """Continuous-time system whose exact ZOH sampling at ``dt`` is this model.

        ``K`` has no continuous counterpart here and is left out.

        Parameters
        ----------
        theta : parameter batch, optional

        Returns
        -------
        ContinuousStateSpace
            ``A`` [1/s] and ``B`` [state/(input·s)] from :func:`d2c_zoh`;
            ``C``, ``D`` unchanged.

        Raises
        ------
        ParameterError
            ``A`` has an eigenvalue on the non-positive real axis.

        Examples
        --------
        >>> from thermogym.models.linear import StateSpaceModel
        >>> m = StateSpaceModel.from_continuous([[-0.01]], [[0.01]], [[1.0]], dt=10.0)
        >>> round(float(m.to_continuous().A[0, 0, 0]), 9)
        -0.01
        """
        if self.dt is None:
            raise ConfigError(
                "to_continuous: the model has no sample period (dt=None); build it with dt"
            )
        mats = self.matrices(theta)
        pairs = [d2c_zoh(a, b, self.dt) for a, b in zip(mats.A, mats.B, strict=True)]
        return ContinuousStateSpace(
            np.stack([q[0] for q in pairs]), np.stack([q[1] for q in pairs]), mats.C, mats.D
        )

    # ------------------------------------------------------------------ numerics
    def operating_point(
        self, theta: ThetaLike = None
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Operating point ``(u_op, y_op)``, shapes (B, m) and (B, p).

        Examples
        --------
        >>> from thermogym.models.linear import StateSpaceModel
        >>> m = StateSpaceModel.from_matrices([[0.5]], [[1.0]], [[1.0]], u_op=[2.0], y_op=[20.0])
        >>> [a.tolist() for a in m.operating_point()]
        [[[2.0]], [[20.0]]]
        """
        B = self.theta(theta).shape[0]
        return np.tile(self.u_op, (B, 1)), np.tile(self.y_op, (B, 1))

    def at_period(
        self, dt: float, theta: ThetaLike = None
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Discrete ``(A, B)`` at sample period ``dt``, shapes (B, n, n) and (B, n, m).

        The model's own matrices when ``dt`` is its period (or the model has
        none); ``[[A, B], [0, I]]^r`` for an integer ratio ``r = dt / self.dt``
        (input held over ``r`` steps); otherwise the exact ZOH resampling of the
        continuous-time equivalent, ``exp(r log [[A, B], [0, I]])``.

        Raises
        ------
        SimulationError
            A non-integer ratio and an ``A`` with no real continuous-time
            equivalent (an eigenvalue on the non-positive real axis).

        Examples
        --------
        >>> from thermogym.models.linear import StateSpaceModel
        >>> m = StateSpaceModel.from_continuous([[-0.01]], [[0.01]], [[1.0]], dt=10.0)
        >>> A, B = m.at_period(25.0)
        >>> round(float(A[0, 0, 0]), 6), round(float(np.exp(-0.25)), 6)
        (0.778801, 0.778801)
        """
        mats = self.matrices(theta)
        return self._resample(mats.A, mats.B, _period(dt, "at_period"))

    def _resample(
        self, A: NDArray[np.float64], Bm: NDArray[np.float64], dt: float
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        if self.dt is None:
            return A, Bm
        r = dt / self.dt
        n_int = round(r)
        n, m = self.n_states, self.n_inputs
        if n_int >= 1 and abs(r - n_int) <= 1e-9 * max(r, 1.0):
            if n_int == 1:
                return A, Bm
            # [[A, B], [0, I]]^r = [[A^r, Σ_{j<r} A^j B], [0, I]]: input held over r steps
            M = np.zeros((A.shape[0], n + m, n + m))
            M[:, :n, :n] = A
            M[:, :n, n:] = Bm
            M[:, n:, n:] = np.eye(m)
            P = np.linalg.matrix_power(M, n_int)
            return np.ascontiguousarray(P[:, :n, :n]), np.ascontiguousarray(P[:, :n, n:])
        Ar, Br = np.empty_like(A), np.empty_like(Bm)
        for b in range(A.shape[0]):
            try:
                Ac, Bc = d2c_zoh(A[b], Bm[b], self.dt)
            except ParameterError as e:
                raise SimulationError(
                    f"cannot simulate at dt = {dt!r} s: the model is discrete at dt = "
                    f"{self.dt!r} s and the period is not a whole multiple of it, and {e}; "
                    "simulate at a multiple of the model's period"
                ) from e
            Ar[b], Br[b] = c2d_zoh(Ac, Bc, dt)
        return Ar, Br

    def initial_state(
        self, theta: NDArray[np.float64], u0: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """Initial state, shape (B, n): zero, steady at ``u0`` or from ``x0_r``.

        ``steady_start=True``: ``x0 = (I − A)^{-1} B (u0 − u_op)``;
        ``fit_x0=True``: the parameters ``x0_r``; otherwise zero (at rest at the
        operating point).
        """
        th = np.atleast_2d(theta)
        Bt = max(th.shape[0], np.atleast_2d(u0).shape[0])
        if self.fit_x0:
            return np.ascontiguousarray(np.broadcast_to(th[:, self._sl["x0"]], (Bt, self.n_states)))
        if self.steady_start:
            return self._steady_state(th, np.atleast_2d(u0))
        return np.zeros((Bt, self.n_states))

    def _steady_state(
        self, th: NDArray[np.float64], u0: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        mats = self.matrices(th)
        A, Bm, u0b = _broadcast_batch(mats.A, mats.B, u0 - self.u_op)
        # x = A x + B (u0 − u_op)  ⇒  x = (I − A)^{-1} B (u0 − u_op), the same at every period
        Bu = np.einsum("bnm,bm->bn", Bm, u0b)[..., None]
        return np.ascontiguousarray(self._steady(A, Bu)[..., 0])

    def _start(self, mode, theta, u, dt, y):
        Bt = theta.shape[0]
        if mode == "zero":
            return np.zeros((Bt, self.n_states)), None
        if mode == "steady":
            return self._steady_state(theta, u[:, 0, :]), None
        ya = self._measured(y, u.shape[1])
        return self.estimate_x0(u, ya, theta, dt=dt), None

    def _deviation(self, u: NDArray[np.float64]) -> NDArray[np.float64]:
        """``u − u_op`` (the array itself when the operating point is zero)."""
        if not np.any(self.u_op != 0):
            return u
        return u - self.u_op

    def _run(self, theta, u, dt, x0, return_states, pre):
        mats = self.matrices(theta)
        A, Bm = self._resample(mats.A, mats.B, dt)
        Bt, T = mats.A.shape[0], u.shape[1]
        y = np.empty((Bt, T, self.n_outputs))
        xs = np.empty((Bt, T, self.n_states)) if return_states else np.empty((1, 1, 1))
        _ss_simulate_kernel(
            *(_transposed(a) for a in (A, Bm, mats.C, mats.D)),
            _compact(self._deviation(u)),
            np.ascontiguousarray(x0),
            1,
            y,
            xs,
            return_states,
        )
        if np.any(self.y_op != 0):
            y += self.y_op
        return y, (xs if return_states else None)

    def _step(self, x, u, theta, dt):
        mats = self.matrices(theta)
        A, Bm = self._resample(mats.A, mats.B, _period(dt, "step"))
        x, u, A, Bm = _broadcast_batch(x, u, A, Bm)
        self._check_step_shapes(x, u)
        # x[k+1] = A x[k] + B (u[k] − u_op)                (3) in 001_6d13a2cd04f5de5e.txt
        return np.einsum("bij,bj->bi", A, x) + np.einsum("bij,bj->bi", Bm, self._deviation(u))

    def _output(self, x, u, theta):
        mats = self.matrices(theta)
        x, u, C, D = _broadcast_batch(x, u, mats.C, mats.D)
        self._check_step_shapes(x, u)
        # y[k] = y_op + C x[k] + D (u[k] − u_op)           (3) in 001_6d13a2cd04f5de5e.txt
        return (
            self.y_op
            + np.einsum("bij,bj->bi", C, x)
            + np.einsum("bij,bj->bi", D, self._deviation(u))
        )

    def _check_step_shapes(self, x: NDArray[np.float64], u: NDArray[np.float64]) -> None:
        if x.shape[1] != self.n_states:
            raise ShapeError(f"x has shape {x.shape}, expected (B, {self.n_states})")
        if u.shape[1] != self.n_inputs:
            raise ShapeError(
                f"u has shape {u.shape}, expected (B, {self.n_inputs}) with columns "
                f"{list(self.exogenous_names)}"
            )

    def _prepare(
        self, u: ArrayLike, y: ArrayLike, theta: ThetaLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        th = self.theta(theta)
        ua = _u_batch(u, self.exogenous_names)
        ya = _y_batch(y, self.n_outputs, ua.shape[1], self.output_names)
        sizes = {th.shape[0], ua.shape[0], ya.shape[0]} - {1}
        if len(sizes) > 1:
            raise ShapeError(
                f"batch sizes differ: theta {th.shape[0]}, u {ua.shape[0]}, y {ya.shape[0]}; "
                "expected equal sizes or 1"
            )
        Bt = sizes.pop() if sizes else 1
        th = np.repeat(th, Bt // th.shape[0], axis=0)
        return th, _compact(ua), _compact(ya)

    def predict(
        self,
        y: ArrayLike,
        u: ArrayLike,
        theta: ThetaLike = None,
        x0: ArrayLike | str | None = None,
        horizon: int | None = 1,
    ) -> NDArray[np.float64]:
        """Kalman-predicted outputs ``ŷ[k | k − horizon]`` using ``K``.

        One step (innovation form, (3) of paper 001 with ``e = y − ŷ``)::

            x̂[k+1] = (A − K C) x̂[k] + (B − K D) u[k] + K y[k]
            ŷ[k]   = C x̂[k] + D u[k]

        ``horizon = h > 1`` propagates ``x̂[k−h+1]`` over ``h − 1`` steps with
        the known inputs (``e = 0``); while fewer than ``h`` samples have been
        seen, the prediction runs from ``x0``. ``horizon=None`` is pure
        simulation. NaN entries of ``y`` (missing samples) give a zero
        innovation for that component.

        Parameters
        ----------
        y : array_like, shape (T, p) or (B, T, p)
            Measured outputs.
        u : array_like, shape (T, m) or (B, T, m)
            Exogenous signals, sampled at the model's ``dt``.
        theta : parameter batch, optional
        x0 : array_like (n,) or (B, n), {"zero", "steady", "estimate"} or None
            Initial predictor state; ``None``: :meth:`initial_state`; a mode
            as in :meth:`simulate` (``"estimate"``: :meth:`estimate_x0` on
            these data).
        horizon : int or None
            Prediction horizon in samples (≥ 1), or ``None`` for infinity.

        Returns
        -------
        ndarray, shape (B, T, p)

        Examples
        --------
        >>> import numpy as np
        >>> from thermogym.models.linear import StateSpaceModel
        >>> m = StateSpaceModel.from_matrices([[0.9]], [[0.1]], [[1.0]], K=[[0.5]], dt=1.0)
        >>> yhat = m.predict(np.ones((3, 1)), np.zeros((3, 1)))
        >>> yhat[0, :, 0].round(3).tolist()
        [0.0, 0.5, 0.7]
        """
        th, ua, ya = self._prepare(u, y, theta)
        Bt, T = th.shape[0], ua.shape[1]
        if horizon is None:
            h = T + 1
        else:
            if int(horizon) != horizon or horizon < 1:
                raise ShapeError(f"horizon is {horizon!r}; expected an integer >= 1 or None")
            h = min(int(horizon), T + 1)
        if isinstance(x0, str):
            xi = self._start(check_x0_mode(x0), th, ua, self.dt or 1.0, ya)[0]
        elif x0 is None:
            xi = self.initial_state(th, ua[:, 0, :])
        else:
            xi = np.array(x0, dtype=float, ndmin=2)
            if xi.shape[1] != self.n_states or xi.shape[0] not in (1, Bt):
                raise ShapeError(
                    f"x0 has shape {np.shape(x0)}, expected ({self.n_states},) or "
                    f"({Bt}, {self.n_states})"
                )
        xi = np.ascontiguousarray(np.broadcast_to(xi, (Bt, self.n_states)))
        mats = self.matrices(th)
        if h <= T:
            Ah = np.linalg.matrix_power(mats.A, h - 1)
        else:
            Ah = np.zeros_like(mats.A)
        AhB = Ah @ mats.B
        out = np.empty((Bt, T, self.n_outputs))
        du = _compact(self._deviation(ua))
        dy = _compact(ya - self.y_op) if np.any(self.y_op != 0) else ya
        _ss_predict_kernel(*(_transposed(a) for a in (*mats, Ah, AhB)), du, dy, xi, h, out)
        if np.any(self.y_op != 0):
            out += self.y_op
        return out

    def estimate_x0(
        self,
        u: ArrayLike,
        y: ArrayLike,
        theta: ThetaLike = None,
        *,
        dt: float | None = None,
        max_samples: int | None = None,
    ) -> NDArray[np.float64]:
        """Least-squares initial state from measured data (free response).

        ``y[k] − y_forced[k] = C A^k x0`` where ``y_forced`` is the response to
        ``u`` from ``x = 0`` (operating point included); ``x0`` minimises the
        sum of squares over all samples (NaN samples of ``y`` are skipped). The
        tall system is reduced chunk by chunk with QR (never formed in full),
        and the loop stops once
        ``C A^k`` has decayed below round-off. Unobservable directions get the
        minimum-norm value (zero).

        Parameters
        ----------
        u : array_like, shape (T, m) or (B, T, m)
            Exogenous signals.
        y : array_like, shape (T, p) or (B, T, p)
            Measured outputs.
        theta : parameter batch, optional
        dt : float, optional
            Sample period of ``u`` and ``y`` [s]; default the model's own.
        max_samples : int, optional
            Use only the first ``max_samples`` samples.

        Returns
        -------
        ndarray, shape (B, n)

        Examples
        --------
        >>> import numpy as np
        >>> from thermogym.models.linear import StateSpaceModel
        >>> m = StateSpaceModel.from_matrices([[0.9, 0.1], [0.0, 0.7]], [[0.0], [1.0]],
        ...                                   [[1.0, 0.0]], dt=1.0)
        >>> u = np.ones((50, 1))
        >>> y = m.simulate(u, dt=1.0, x0=[2.0, -1.0]).outputs[0]
        >>> m.estimate_x0(u, y).round(6).tolist()
        [[2.0, -1.0]]
        """
        th, ua, ya = self._prepare(u, y, theta)
        if max_samples is not None:
            if int(max_samples) != max_samples or max_samples < 1:
                raise ShapeError(f"max_samples is {max_samples!r}; expected an integer >= 1")
            ua = np.ascontiguousarray(ua[:, : int(max_samples)])
            ya = ya[:, : int(max_samples)]
        Bt, T = th.shape[0], ua.shape[1]
        n = self.n_states
        period = _period(self.dt or 1.0 if dt is None else dt, "estimate_x0")
        zero = np.zeros((Bt, n))
        forced, _ = self._run(th, ua, period, zero, False, None)
        r = ya - forced
        mats = self.matrices(th)
        A_dt, _ = self._resample(mats.A, mats.B, period)
        chunk = max(64, 8192 // max(1, self.n_outputs))
        x0 = np.empty((Bt, n))
        for b in range(Bt):
            A = np.ascontiguousarray(A_dt[b])
            M = np.array(mats.C[b], dtype=float, copy=True)
            R = np.zeros((0, n + 1))
            scale = 0.0
            for k0 in range(0, T, chunk):
                L = min(chunk, T - k0)
                rows = np.empty((L, self.n_outputs, n))
                _obs_rows(M, A, rows)  # C A^k for k in [k0, k0 + L)
                O = rows.reshape(L * self.n_outputs, n)
                rb = r[b if r.shape[0] > 1 else 0, k0 : k0 + L].reshape(-1)
                ok = np.isfinite(rb)
                aug = np.vstack([R, np.column_stack([O[ok], rb[ok]])])
                R = np.linalg.qr(aug, mode="r")
                scale = max(scale, float(np.abs(R[:, :n]).max(initial=0.0)))
                if not np.isfinite(M).all():
                    raise SimulationError(
                        f"estimate_x0: C A^k of parameter set {b} overflowed at sample "
                        f"{k0 + L}; A is unstable, use fewer samples (max_samples)"
                    )
                if np.abs(M).max() <= 1e-17 * scale:
                    break
            x0[b] = np.linalg.lstsq(R[:, :n], R[:, n], rcond=None)[0]
        return x0


# ======================================================================= FOPTD
def _foptd_arrays(
    K: ArrayLike, T: ArrayLike, tau: ArrayLike, dt: float
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    Ka, Ta, ta = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (K, T, tau)))
    if not (np.isfinite(dt) and dt > 0):
        raise ParameterError(f"dt is {dt!r}, expected a positive sample period in seconds")
    for name, v in (("K", Ka), ("T", Ta), ("tau", ta)):
        if not np.isfinite(v).all():
            raise ParameterError(f"{name} contains {v[~np.isfinite(v)].flat[0]!r}; expected finite")
    if (Ta <= 0).any():
        raise ParameterError(f"time constant T is {Ta[Ta <= 0].flat[0]!r} s; it must be positive")
    if (ta < 0).any():
        raise ParameterError(f"delay tau is {ta[ta < 0].flat[0]!r} s; it must be >= 0")
    return Ka, Ta, ta


def _split_delay(
    tau: NDArray[np.float64], dt: float
) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    r = tau / dt
    near = np.round(r)
    snap = np.abs(r - near) <= _SNAP * np.maximum(1.0, r)
    d = np.where(snap, near, np.floor(r))
    f = np.where(snap, 0.0, r - d)
    return d.astype(np.int64), f


def foptd_zoh(
    K: ArrayLike, T: ArrayLike, tau: ArrayLike, dt: float
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.int64]]:
    """Exact ZOH coefficients of an FOPTD with any (fractional) delay.

    ``y[k] = a y[k−1] + b1 u[k−1−d] + b2 u[k−2−d]`` with ``τ = (d + f) Δt``,
    ``a = e^{−Δt/T}``, ``b1 = K (1 − e^{−(1−f)Δt/T})``,
    ``b2 = K (e^{−(1−f)Δt/T} − a)`` (modified z-transform of (7)).

    Parameters
    ----------
    K : array_like
        Gain [output unit / input unit].
    T : array_like
        Time constant [s], > 0.
    tau : array_like
        Delay [s], ≥ 0.
    dt : float
        Sample period [s].

    Returns
    -------
    a, b1, b2 : ndarray
        Broadcast shape of the inputs.
    d : ndarray of int
        Whole samples of delay.

    Examples
    --------
    >>> from thermogym.models.linear import foptd_zoh
    >>> a, b1, b2, d = foptd_zoh(2.0, 10.0, 2.5, dt=1.0)
    >>> int(d), round(float(b1 + b2), 12) == round(float(2.0 * (1 - a)), 12)
    (2, True)
    """
    Ka, Ta, ta = _foptd_arrays(K, T, tau, dt)
    d, f = _split_delay(ta, dt)
    a = np.exp(-dt / Ta)
    c = np.exp(-(1.0 - f) * dt / Ta)
    # the held sample u[k−1−d] acts over the last (1−f)Δt of the interval,
    # u[k−2−d] over its first fΔt; expm1 keeps precision for Δt ≪ T
    b1 = -Ka * np.expm1(-(1.0 - f) * dt / Ta)
    b2 = -Ka * c * np.expm1(-f * dt / Ta)
    return a, b1, b2, d


def foptd_to_discrete(
    K: ArrayLike, T: ArrayLike, tau: ArrayLike, dt: float, *, round_delay: bool = False
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64]]:
    """Difference-equation coefficients ``(a, b, d)`` of an FOPTD, eqs (9)-(10).

    ``y[k] = a y[k−1] + b u[k−1−d]`` with ``a = e^{−Δt/T}``,
    ``b = K (1 − a)``, ``d = τ/Δt`` (exact ZOH when ``τ`` is a multiple of Δt).

    Parameters
    ----------
    K : array_like
        Gain [output unit / input unit].
    T : array_like
        Time constant [s], > 0.
    tau : array_like
        Delay [s], ≥ 0.
    dt : float
        Sample period [s].
    round_delay : bool
        Round ``τ/Δt`` to the nearest integer instead of refusing fractional
        delays (use :func:`foptd_zoh` for their exact form).

    Returns
    -------
    a, b : ndarray
    d : ndarray of int

    Raises
    ------
    ParameterError
        ``T ≤ 0``, ``τ < 0``, or ``τ`` not a multiple of ``dt`` without ``round_delay``.

    Examples
    --------
    >>> from thermogym.models.linear import foptd_to_discrete, discrete_to_foptd
    >>> a, b, d = foptd_to_discrete(2.0, 100.0, 30.0, dt=10.0)
    >>> [round(float(v), 6) for v in discrete_to_foptd(a, b, d, dt=10.0)]
    [2.0, 100.0, 30.0]
    """
    Ka, Ta, ta = _foptd_arrays(K, T, tau, dt)
    r = ta / dt
    d = np.round(r)
    off = np.abs(r - d) > _SNAP * np.maximum(1.0, r)
    if off.any() and not round_delay:
        raise ParameterError(
            f"delay tau = {ta[off].flat[0]!r} s is not a multiple of dt = {dt!r} s; (9)-(10) "
            "need an integer delay: pass round_delay=True or use foptd_zoh for the exact form"
        )
    a = np.exp(-dt / Ta)  # (9)-(10) in 000_24627a5308ee07db.txt, inverse of (11)
    b = -Ka * np.expm1(-dt / Ta)  # b = K (1 − a), inverse of (12)
    return a, b, d.astype(np.int64)


def discrete_to_foptd(
    a: ArrayLike, b: ArrayLike, d: ArrayLike, dt: float
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Continuous FOPTD ``(K, T, τ)`` from ``(a, b, d)``, eqs (11)-(12).

    ``T = −Δt / ln a``, ``K = b / (1 − a)``, ``τ = d Δt``.

    Parameters
    ----------
    a : array_like
        Pole of the difference equation (9), ``0 < a < 1``.
    b : array_like
        Input coefficient of (9) [output unit / input unit].
    d : array_like
        Delay in whole samples, ≥ 0.
    dt : float
        Sample period [s].

    Returns
    -------
    K, T, tau : ndarray
        Gain, time constant [s], delay [s].

    Raises
    ------
    ParameterError
        ``a`` outside (0, 1) (no stable first-order lag), ``d`` negative or
        not whole.

    Examples
    --------
    >>> from thermogym.models.linear import discrete_to_foptd
    >>> [round(float(v), 4) for v in discrete_to_foptd(0.9, 0.2, 3, dt=1.0)]
    [2.0, 9.4912, 3.0]
    """
    aa, ba, da = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (a, b, d)))
    if not (np.isfinite(dt) and dt > 0):
        raise ParameterError(f"dt is {dt!r}, expected a positive sample period in seconds")
    bad = ~((aa > 0) & (aa < 1))
    if bad.any():
        raise ParameterError(
            f"a = {aa[bad].flat[0]!r}; expected 0 < a < 1 (a stable, non-oscillating "
            "first-order lag)"
        )
    if not np.isfinite(ba).all():
        raise ParameterError(f"b = {ba[~np.isfinite(ba)].flat[0]!r}; expected finite")
    badd = (da < 0) | (da != np.round(da))
    if badd.any():
        raise ParameterError(f"d = {da[badd].flat[0]!r}; expected a whole number >= 0")
    T = -dt / np.log(aa)  # (11) in 000_24627a5308ee07db.txt
    K = ba / (1.0 - aa)  # (12) in 000_24627a5308ee07db.txt
    return K, T, da * dt


@nb.njit(cache=True)
def _foptd_kernel(a, b1, b2, d, y0, u, hist, pre, z0, y, zs, keep):  # pragma: no cover
    Bt, T, m = a.shape[0], u.shape[1], u.shape[2]
    p = a.shape[1]
    H = hist.shape[1]
    for bb in range(Bt):
        ub = bb if u.shape[0] > 1 else 0
        for k in range(T):
            for j in range(p):
                y[bb, k, j] = y0[bb, j]
        for j in range(p):
            for i in range(m):
                q = j * m + i
                aa = a[bb, j, i]
                c1 = b1[bb, j, i]
                c2 = b2[bb, j, i]
                dd = d[bb, j, i]
                z = z0[bb, q]
                for k in range(T):
                    y[bb, k, j] += z  # y_j = y0_j + Σ_i y_ji   (8), superposition
                    if keep:
                        zs[bb, k, q] = z
                    # input samples k−d and k−d−1: from u, the stored history, or before it
                    i1 = k - dd
                    if i1 >= 0:
                        u1 = u[ub, i1, i]
                    elif -i1 <= H:
                        u1 = hist[bb, -i1 - 1, i]
                    else:
                        u1 = pre[bb, i]
                    i2 = i1 - 1
                    if i2 >= 0:
                        u2 = u[ub, i2, i]
                    elif -i2 <= H:
                        u2 = hist[bb, -i2 - 1, i]
                    else:
                        u2 = pre[bb, i]
                    # y[k+1] = a y[k] + b1 u[k−d] + b2 u[k−d−1]   exact ZOH of (8)
                    z = aa * z + c1 * u1 + c2 * u2


class FOPTDModel(_LinearModel):
    """Set of first-order-plus-time-delay transfer functions (000 eqs 7-8).

    Output ``j`` is ``y0_j + Σ_i y_ji`` with ``Y_ji(s) = K_ji e^{−τ_ji s} /
    (T_ji s + 1) U_i(s)``; the simulation is the exact zero-order-hold
    solution at the sample instants, also for delays that are not a multiple
    of ``dt``. Outputs are deviations from the initial value unless
    ``offsets=True``.

    Parameters
    ----------
    inputs : sequence of str
        Column names of the manipulated inputs.
    outputs : sequence of str
        Column names of the outputs (e.g. temperature measurement points).
    disturbances : sequence of str
        Further exogenous columns, each with its own FOPTD per output.
    units : mapping, optional
        ``{signal name: unit}``; unlisted signals get ``"1"``.
    K : float or array_like, shape (n_out, n_exog)
        Nominal gains [output unit / input unit].
    T : float or array_like, shape (n_out, n_exog)
        Nominal time constants [s], > 0.
    tau : float or array_like, shape (n_out, n_exog)
        Nominal delays [s], ≥ 0.
    offsets : bool
        Add parameters ``y0_<out>`` (output value at rest) [output unit].
    y0 : float or array_like, shape (n_out,)
        Nominal offsets (with ``offsets=True``).
    history : int
        Past input samples kept in the state for :meth:`step`; a pair whose
        delay spans more samples than this cannot be stepped. ``simulate``
        needs none (inputs before the stored history are zero, or ``u[0]``
        with ``steady_start``, or the oldest stored sample when
        ``history > 0``).
    steady_start : bool
        Start every lag at ``K (u[0] − u_op)`` with the input constant before
        ``t = 0``.
    u_op : array_like (m,) or mapping, optional
        Operating-point inputs (absolute units), zero when omitted: the lags
        are driven by ``u − u_op``, so ``y0`` is the output at rest at
        ``u = u_op``.

    Examples
    --------
    >>> import numpy as np
    >>> from thermogym.models.linear import FOPTDModel
    >>> m = FOPTDModel(["v_f"], ["T_1"], units={"v_f": "m/min", "T_1": "°C"},
    ...                K=0.5, T=600.0, tau=90.0)
    >>> m.param_names
    ('K_T_1', 'T_T_1', 'tau_T_1')
    >>> sim = m.simulate(np.full((3601, 1), 20.0), dt=1.0)
    >>> y = sim.output("T_1")[0]
    >>> float(y[90]), round(float(y[690]), 4), round(float(10 * (1 - np.exp(-1))), 4)
    (0.0, 6.3212, 6.3212)
    """

    name = "foptd"
    version = "1"

    def __init__(
        self,
        inputs: Sequence[str] | str = ("u",),
        outputs: Sequence[str] | str = ("y",),
        *,
        disturbances: Sequence[str] | str = (),
        units: Mapping[str, str] | None = None,
        K: ArrayLike = 1.0,
        T: ArrayLike = 60.0,
        tau: ArrayLike = 0.0,
        offsets: bool = False,
        y0: ArrayLike = 0.0,
        history: int = 0,
        steady_start: bool = False,
        u_op: ArrayLike | Mapping[str, float] | None = None,
    ) -> None:
        ins, dis, outs, full_units, signals = _make_signals(
            inputs, disturbances, outputs, units, "FOPTD model"
        )
        exo = ins + dis
        p, m = len(outs), len(exo)
        shape = (p, m)

        def nominal(name, v):
            a = np.asarray(v, dtype=float)
            try:
                a = np.broadcast_to(a, shape)
            except ValueError:
                raise ShapeError(
                    f"{name} has shape {a.shape}, expected a scalar or {shape} "
                    f"(outputs {outs} × exogenous {exo})"
                ) from None
            if not np.isfinite(a).all():
                raise ParameterError(f"{name} contains {a[~np.isfinite(a)][0]!r}; expected finite")
            return a

        Kn, Tn, tn = nominal("K", K), nominal("T", T), nominal("tau", tau)
        if (Tn <= 0).any():
            j, i = np.argwhere(Tn <= 0)[0]
            raise ParameterError(
                f"T of pair ({outs[j]}, {exo[i]}) is {Tn[j, i]!r} s; a time constant must be "
                "positive"
            )
        if (tn < 0).any():
            j, i = np.argwhere(tn < 0)[0]
            raise ParameterError(
                f"tau of pair ({outs[j]}, {exo[i]}) is {tn[j, i]!r} s; a delay must be >= 0"
            )
        y0n = np.asarray(y0, dtype=float)
        try:
            y0n = np.broadcast_to(y0n, (p,))
        except ValueError:
            raise ShapeError(f"y0 has shape {y0n.shape}, expected a scalar or ({p},)") from None
        if not offsets and np.any(y0n != 0):
            raise ConfigError("y0 is given but offsets=False; set offsets=True to use it")
        if int(history) != history or history < 0:
            raise ConfigError(f"history is {history!r}; expected a whole number of samples >= 0")

        self.n_inputs, self.n_outputs = m, p
        self.u_op = _vector("u_op", u_op, exo, "exogenous signal")
        self.offsets, self.history, self.steady_start = (
            bool(offsets),
            int(history),
            bool(steady_start),
        )
        self._cfg_names = (ins, dis, outs, full_units)

        def tag(j, i):
            return outs[j] if m == 1 else f"{outs[j]}__{exo[i]}"

        params: list[Parameter] = []
        self._iK = np.empty(shape, dtype=np.int64)
        self._iT = np.empty(shape, dtype=np.int64)
        self._itau = np.empty(shape, dtype=np.int64)
        self._iy0 = np.empty(p, dtype=np.int64)
        for j in range(p):
            uy = full_units[outs[j]]
            for i in range(m):
                ui = full_units[exo[i]]
                k_, t_, d_ = float(Kn[j, i]), float(Tn[j, i]), float(tn[j, i])
                self._iK[j, i] = len(params)
                params.append(
                    Parameter(
                        f"K_{tag(j, i)}",
                        k_,
                        *_wide(k_),
                        f"{uy}/{ui}",
                        f"gain of {outs[j]} per unit {exo[i]} (7)",
                        _PROV_FOPTD,
                        outs[j],
                    )
                )
                self._iT[j, i] = len(params)
                params.append(
                    Parameter(
                        f"T_{tag(j, i)}",
                        t_,
                        t_ / 1000.0,
                        1000.0 * t_,
                        "s",
                        f"time constant of {outs[j]} after {exo[i]} (7)",
                        _PROV_FOPTD,
                        outs[j],
                    )
                )
                self._itau[j, i] = len(params)
                params.append(
                    Parameter(
                        f"tau_{tag(j, i)}",
                        d_,
                        0.0,
                        10.0 * max(d_, t_),
                        "s",
                        f"dead time of {outs[j]} after {exo[i]} (7)",
                        _PROV_FOPTD,
                        outs[j],
                    )
                )
            if self.offsets:
                v = float(y0n[j])
                self._iy0[j] = len(params)
                params.append(
                    Parameter(
                        f"y0_{outs[j]}",
                        v,
                        *_wide(v),
                        uy,
                        f"value of {outs[j]} at rest",
                        _PROV_FOPTD,
                        outs[j],
                    )
                )
        states = [f"z_{tag(j, i)}" for j in range(p) for i in range(m)]
        states += [f"{exo[i]}__lag{h + 1}" for h in range(self.history) for i in range(m)]
        super().__init__(signals, params, states)

    def config(self) -> dict[str, Any]:
        """Constructor arguments that rebuild this model (JSON-able)."""
        ins, dis, outs, units = self._cfg_names
        K, T, tau = (v[0] for v in self.pair_parameters())
        cfg: dict[str, Any] = {
            "inputs": list(ins),
            "outputs": list(outs),
            "disturbances": list(dis),
            "units": dict(units),
            "K": K.tolist(),
            "T": T.tolist(),
            "tau": tau.tolist(),
            "offsets": self.offsets,
            "history": self.history,
            "steady_start": self.steady_start,
        }
        if self.offsets:
            cfg["y0"] = self.nominal[self._iy0].tolist()
        if np.any(self.u_op != 0):
            cfg["u_op"] = self.u_op.tolist()
        return cfg

    # ----------------------------------------------------------------- accessors
    def pair_parameters(
        self, theta: ThetaLike = None
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Gains, time constants [s] and delays [s], each shape (B, n_out, n_exog).

        Examples
        --------
        >>> from thermogym.models.linear import FOPTDModel
        >>> m = FOPTDModel(["a", "b"], ["y"], K=[[1.0, 2.0]])
        >>> m.param_names[:3], m.pair_parameters()[0].tolist()
        (('K_y__a', 'T_y__a', 'tau_y__a'), [[[1.0, 2.0]]])
        """
        th = self.theta(theta)
        return th[:, self._iK], th[:, self._iT], th[:, self._itau]

    def _offsets(self, th: NDArray[np.float64]) -> NDArray[np.float64]:
        if self.offsets:
            return th[:, self._iy0]
        return np.zeros((th.shape[0], self.n_outputs))

    def dcgain(self, theta: ThetaLike = None) -> NDArray[np.float64]:
        """Steady-state gains ``K_ji``, shape (B, n_out, n_exog)."""
        return self.pair_parameters(theta)[0]

    def to_discrete(
        self, dt: float, theta: ThetaLike = None, *, round_delay: bool = False
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64]]:
        """Coefficients ``(a, b, d)`` of (9)-(10) per pair, each (B, n_out, n_exog).

        Parameters
        ----------
        dt : float
            Sample period [s].
        theta : parameter batch, optional
        round_delay : bool
            Round fractional delays to whole samples instead of refusing them.

        Returns
        -------
        a, b : ndarray
        d : ndarray of int

        Examples
        --------
        >>> from thermogym.models.linear import FOPTDModel
        >>> a, b, d = FOPTDModel(K=2.0, T=10.0, tau=3.0).to_discrete(1.0)
        >>> round(float(a[0, 0, 0]), 4), round(float(b[0, 0, 0]), 4), int(d[0, 0, 0])
        (0.9048, 0.1903, 3)
        """
        return foptd_to_discrete(*self.pair_parameters(theta), dt, round_delay=round_delay)

    # ------------------------------------------------------------------ numerics
    def _validate_theta(self, theta: NDArray[np.float64]) -> None:
        self._require_positive(theta, [self.param_names[i] for i in self._iT.ravel()])
        for i in self._itau.ravel():
            col = theta[:, i]
            if (col < 0).any():
                b = int(np.argmax(col < 0))
                raise ParameterError(
                    f"parameter {self.param_names[i]!r} of set {b} is {col[b]!r} s; a delay "
                    "must be >= 0"
                )

    def operating_point(
        self, theta: ThetaLike = None
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Operating point ``(u_op, y_op)``, shapes (B, m) and (B, p); ``y_op = y0``.

        Examples
        --------
        >>> from thermogym.models.linear import FOPTDModel
        >>> m = FOPTDModel(K=2.0, offsets=True, y0=20.0, u_op=[5.0])
        >>> [a.tolist() for a in m.operating_point()]
        [[[5.0]], [[20.0]]]
        """
        th = self.theta(theta)
        return np.tile(self.u_op, (th.shape[0], 1)), self._offsets(th)

    def initial_state(
        self, theta: NDArray[np.float64], u0: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """Lags and input history at rest at ``u_op``, or (``steady_start``) at ``u0``.

        Rest: lags zero, history ``u_op``; steady: lags ``K (u0 − u_op)``,
        history ``u0``.
        """
        th = np.atleast_2d(theta)
        u0 = np.atleast_2d(u0)
        if self.steady_start:
            return self._lags_state(th, u0, self._steady_lags(th, u0))
        Bt = max(th.shape[0], u0.shape[0])
        return self._lags_state(th, np.tile(self.u_op, (Bt, 1)), None)

    def _steady_lags(self, th: NDArray[np.float64], u0: NDArray[np.float64]) -> NDArray[np.float64]:
        K = th[:, self._iK]
        p, m = self.n_outputs, self.n_inputs
        return (K * (u0 - self.u_op)[:, None, :]).reshape(-1, p * m)

    def _lags_state(
        self,
        th: NDArray[np.float64],
        held: NDArray[np.float64],
        lags: NDArray[np.float64] | None,
    ) -> NDArray[np.float64]:
        """State (B, n_x) with the given lags (zero when None) and the history at ``held``."""
        p, m, H = self.n_outputs, self.n_inputs, self.history
        Bt = max(th.shape[0], held.shape[0], 1 if lags is None else lags.shape[0])
        x = np.zeros((Bt, p * m + H * m))
        if lags is not None:
            x[:, : p * m] = lags
        if H:
            x[:, p * m :] = np.tile(held, (1, H))
        return x

    def _start(self, mode, theta, u, dt, y):
        u0 = np.ascontiguousarray(u[:, 0, :])
        if mode == "zero":
            held = np.tile(self.u_op, (theta.shape[0], 1))
            return self._lags_state(theta, held, None), held
        if mode == "steady":
            return self._lags_state(theta, u0, self._steady_lags(theta, u0)), u0
        ya = self._measured(y, u.shape[1])
        return self._estimate(theta, u, ya, dt)

    def estimate_x0(
        self,
        u: ArrayLike,
        y: ArrayLike,
        theta: ThetaLike = None,
        *,
        dt: float,
        max_samples: int | None = None,
    ) -> NDArray[np.float64]:
        """Least-squares initial lags and held input from measured data.

        The initial state of a delayed lag is its value and the input during
        the delay before ``t = 0``. The input is taken constant there (at
        ``u[0] + δ``); the output is then the forced response plus the free
        response of the lags, ``Σ_i a_ji^k z_ji(0)`` with ``a = e^{−Δt/T}``,
        plus the response to ``δ``; ``z(0)`` and ``δ`` minimise the squared
        error over the samples (NaN samples of ``y`` skipped). ``δ_i`` is
        estimated only for inputs whose delay spans two samples or more (else
        ``δ = 0``: the input before the start is ``u[0]``, the guess for a
        recording that starts mid-operation); lags of one output with the same
        time constant share their value (the minimum-norm solution).
        :meth:`simulate` with ``x0="estimate"`` uses the same estimate.

        Parameters
        ----------
        u : array_like, shape (T, m) or (B, T, m)
            Exogenous signals (absolute).
        y : array_like, shape (T, p) or (B, T, p)
            Measured outputs (absolute).
        theta : parameter batch, optional
        dt : float
            Sample period [s].
        max_samples : int, optional
            Use only the first ``max_samples`` samples.

        Returns
        -------
        ndarray, shape (B, n_x)
            Lags, then the input history (the held input before ``t = 0``).

        Examples
        --------
        >>> import numpy as np
        >>> from thermogym.models.linear import FOPTDModel
        >>> m = FOPTDModel(K=2.0, T=30.0, tau=4.0, offsets=True, y0=10.0, steady_start=True)
        >>> u = np.ones((200, 1))
        >>> y = m.simulate(u, 1.0, x0=[5.0]).outputs[0]  # 3 above the steady state at u = 1
        >>> m.estimate_x0(u, y, dt=1.0).round(6).tolist()
        [[5.0]]
        """
        th = self.theta(theta)
        ua = _u_batch(u, self.exogenous_names)
        ya = _y_batch(y, self.n_outputs, ua.shape[1], self.output_names)
        if max_samples is not None:
            if int(max_samples) != max_samples or max_samples < 1:
                raise ShapeError(f"max_samples is {max_samples!r}; expected an integer >= 1")
            ua, ya = ua[:, : int(max_samples)], ya[:, : int(max_samples)]
        sizes = {th.shape[0], ua.shape[0], ya.shape[0]} - {1}
        if len(sizes) > 1:
            raise ShapeError(
                f"batch sizes differ: theta {th.shape[0]}, u {ua.shape[0]}, y {ya.shape[0]}; "
                "expected equal sizes or 1"
            )
        Bt = sizes.pop() if sizes else 1
        th = np.ascontiguousarray(np.broadcast_to(th, (Bt, th.shape[1])))
        ua = np.ascontiguousarray(np.broadcast_to(ua, (Bt, *ua.shape[1:])))
        return self._estimate(th, ua, ya, _period(dt, "estimate_x0"))[0]

    def _estimate(
        self,
        th: NDArray[np.float64],
        ua: NDArray[np.float64],
        ya: NDArray[np.float64],
        dt: float,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Initial state (B, n_x) and held input before the start (B, m) by least squares."""
        Bt, T = th.shape[0], ua.shape[1]
        p, m = self.n_outputs, self.n_inputs
        nq = p * m
        ua = np.ascontiguousarray(np.broadcast_to(ua, (Bt, T, m)))
        u0 = np.ascontiguousarray(ua[:, 0, :])
        zero = self._lags_state(th, u0, None)
        forced, _ = self._run(th, ua, dt, zero, False, u0)
        r = ya - forced  # (B, T, p)
        ok = np.isfinite(r)
        r = np.where(ok, r, 0.0)
        a, _, b2, d = foptd_zoh(*self.pair_parameters(th), dt)  # (B, p, m)
        # inputs whose held value before the start reaches the output over >= 2 samples
        span = (d + (b2 != 0)).max(axis=(0, 1))
        free = [i for i in range(m) if span[i] >= 2]
        # response of every output to a unit step of input i held before t = 0 (from rest)
        rest = np.ascontiguousarray(np.broadcast_to(self.u_op, (Bt, T, m)))
        pulse = np.empty((Bt, T, p, len(free)))
        for c, i in enumerate(free):
            held = np.tile(self.u_op, (Bt, 1))
            held[:, i] += 1.0
            yi, _ = self._run(th, rest, dt, self._lags_state(th, held, None), False, held)
            pulse[:, :, :, c] = yi - self._offsets(th)[:, None, :]
        nf = len(free)
        n_unk = nq + nf
        G = np.zeros((Bt, n_unk, n_unk))
        rhs = np.zeros((Bt, n_unk))
        chunk = 8192
        for k0 in range(0, T, chunk):
            k = np.arange(k0, min(T, k0 + chunk), dtype=float)
            for j in range(p):
                w = ok[:, k0 : k0 + k.size, j]
                # columns of output j: free responses a_ji^k of its lags, then the held inputs
                Phi = (
                    np.concatenate(
                        [a[:, j, None, :] ** k[None, :, None], pulse[:, k0 : k0 + k.size, j, :]],
                        axis=2,
                    )
                    * w[:, :, None]
                )
                idx = np.r_[np.arange(j * m, (j + 1) * m), nq + np.arange(nf)].astype(np.int64)
                G[:, idx[:, None], idx[None, :]] += np.einsum("bki,bkl->bil", Phi, Phi)
                rhs[:, idx] += np.einsum("bki,bk->bi", Phi, r[:, k0 : k0 + k.size, j])
        sol = np.einsum("bil,bl->bi", np.linalg.pinv(G, rcond=1e-10, hermitian=True), rhs)
        held = u0.copy()
        held[:, free] += sol[:, nq:]
        x = self._lags_state(th, held, sol[:, :nq])
        return x, held

    def _run(self, theta, u, dt, x0, return_states, pre):
        Bt, T = theta.shape[0], u.shape[1]
        p, m, H = self.n_outputs, self.n_inputs, self.history
        nq = p * m
        a, b1, b2, d = foptd_zoh(*self.pair_parameters(theta), dt)
        hist = np.ascontiguousarray(x0[:, nq:].reshape(Bt, H, m))
        if pre is not None:
            pre = np.ascontiguousarray(np.broadcast_to(pre, (Bt, m)))
        elif H > 0:
            pre = hist[:, H - 1, :].copy()
        elif self.steady_start:
            pre = np.ascontiguousarray(np.broadcast_to(u[:, 0, :], (Bt, m)))
        else:
            pre = np.tile(self.u_op, (Bt, 1))
        y = np.empty((Bt, T, p))
        zs = np.empty((Bt, T, nq)) if return_states else np.empty((1, 1, 1))
        shift = np.any(self.u_op != 0)
        # the lags see u − u_op (the kernel's inputs, history and pre-start values)
        _foptd_kernel(
            a,
            b1,
            b2,
            np.ascontiguousarray(d),
            np.ascontiguousarray(self._offsets(theta)),
            _compact(u - self.u_op if shift else u),
            np.ascontiguousarray(hist - self.u_op) if shift else hist,
            pre - self.u_op if shift else pre,
            np.ascontiguousarray(x0[:, :nq]),
            y,
            zs,
            return_states,
        )
        if not return_states:
            return y, None
        xs = np.empty((Bt, T, nq + H * m))
        xs[:, :, :nq] = zs
        if H:
            # state lag h+1 at sample k is u[k−1−h]
            full = np.concatenate([hist[:, ::-1, :], u], axis=1)
            for h in range(H):
                xs[:, :, nq + h * m : nq + (h + 1) * m] = full[:, H - 1 - h : H - 1 - h + T]
        return y, xs

    def _step(self, x, u, theta, dt):
        p, m, H = self.n_outputs, self.n_inputs, self.history
        nq = p * m
        th, x, u = _broadcast_batch(theta, x, u)
        if x.shape[1] != nq + H * m or u.shape[1] != m:
            raise ShapeError(
                f"x has shape {x.shape} and u {u.shape}, expected (B, {nq + H * m}) and (B, {m})"
            )
        a, b1, b2, d = foptd_zoh(*self.pair_parameters(th), _period(dt, "step"))
        need = d + (b2 != 0)
        if (need > H).any():
            j, i = np.argwhere((need > H).any(axis=0))[0]
            raise SimulationError(
                f"pair ({self.output_names[j]}, {self.exogenous_names[i]}): its delay needs the "
                f"input from {int(need.max())} samples back at dt = {dt!r} s but the state "
                f"keeps history = {H} past inputs; build the model with history >= "
                f"{int(need.max())}"
            )
        # lagged inputs: lag 0 is the current u[k], lag h the stored u[k−h]
        Bt = x.shape[0]
        lagged = np.concatenate([u[:, None, :], x[:, nq:].reshape(Bt, H, m)], axis=1)
        dev = lagged - self.u_op
        bi = np.arange(Bt)[:, None, None]
        ii = np.arange(m)[None, None, :]
        u1 = dev[bi, np.minimum(d, H), ii]
        u2 = dev[bi, np.minimum(d + 1, H), ii]
        z = x[:, :nq].reshape(Bt, p, m)
        # y[k+1] = a y[k] + b1 (u[k−d] − u_op) + b2 (u[k−d−1] − u_op)   exact ZOH of (8)
        xn = np.empty_like(x)
        xn[:, :nq] = (a * z + b1 * u1 + np.where(b2 != 0, b2 * u2, 0.0)).reshape(Bt, nq)
        xn[:, nq:] = lagged[:, :H].reshape(Bt, H * m)
        return xn

    def _output(self, x, u, theta):
        p, m = self.n_outputs, self.n_inputs
        th, x = _broadcast_batch(theta, x)
        return self._offsets(th) + x[:, : p * m].reshape(-1, p, m).sum(axis=2)


MODELS: dict[str, type[Model]] = {"ss": StateSpaceModel, "foptd": FOPTDModel}
