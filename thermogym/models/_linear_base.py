"""Shared parts of the generic linear models (see :mod:`thermogym.models.linear`).

Signal and matrix checks, the operating-point vectors, the initial-state modes
(:data:`X0_MODES`), :class:`_LinearModel` (the base of
:class:`~thermogym.models.linear_ss.StateSpaceModel` and
:class:`~thermogym.models.linear_foptd.FOPTDModel`) and the exact
zero-order-hold conversions :func:`c2d_zoh`, :func:`d2c_zoh`.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from thermogym._checks import positive
from thermogym.errors import ConfigError, ParameterError, ShapeError
from thermogym.models.base import Model, Signal, Simulation, ThetaLike

__all__ = ["X0_MODES", "c2d_zoh", "check_x0_mode", "d2c_zoh"]

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
    return positive(f"{what}: dt", dt, unit="s", error=ShapeError, text=False)


def _vector(
    name: str, value: ArrayLike | Mapping[str, float] | None, names: Sequence[str], what: str
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

    n_inputs: int
    n_outputs: int

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


# ============================================================ ZOH conversions
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
    positive("dt", dt, unit="s", text=False)
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
    positive("dt", dt, unit="s", text=False)
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
