"""Sets of first-order-plus-time-delay transfer functions (000 eqs 7-12); see :mod:`.linear`."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numba as nb
import numpy as np
from numpy.typing import ArrayLike, NDArray

from thermogym._checks import positive
from thermogym.errors import ConfigError, ParameterError, ShapeError, SimulationError
from thermogym.models._linear_base import (
    _PROV_FOPTD,
    _SNAP,
    _broadcast_batch,
    _compact,
    _LinearModel,
    _make_signals,
    _period,
    _u_batch,
    _vector,
    _wide,
    _y_batch,
)
from thermogym.models.base import Parameter, ThetaLike

__all__ = ["FOPTDModel", "discrete_to_foptd", "foptd_to_discrete", "foptd_zoh"]


# ======================================================================= FOPTD
def _foptd_arrays(
    K: ArrayLike, T: ArrayLike, tau: ArrayLike, dt: float
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    Ka, Ta, ta = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (K, T, tau)))
    positive("dt", dt, unit="s", text=False)
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
    positive("dt", dt, unit="s", text=False)
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
