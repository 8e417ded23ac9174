"""Process models with dead time (SOPDT) and discrete realisations of the linear models.

Description
-----------
:class:`SOPDTModel` is a set of second-order-plus-dead-time transfer
functions, one per (output j, exogenous i) pair, added up over the inputs as
the FOPTD set of :mod:`thermogym.models.linear` (MATLAB's process model
``P2D``)::

    G_ji(s) = K_ji e^{−τ_ji s} / ((T1_ji s + 1)(T2_ji s + 1))

Two lags in series (``T1 ≥ T2`` by convention; the model is symmetric in
them). Heated bodies seen through a sensor (a heater and its sensor, a wall
and its surface) are often this: the FOPTD's dead time then stands in for the
second lag. The simulation is the exact zero-order-hold solution for any
delay: with ``τ = (d + f) Δt``, ``0 ≤ f < 1``, the input sample ``u[k−d−1]``
acts during the first ``fΔt`` of an interval and ``u[k−d]`` during the rest::

    z[k+1] = Φ z[k] + Γ((1−f)Δt) u[k−d] + e^{A(1−f)Δt} Γ(fΔt) u[k−d−1]
    Φ = e^{AΔt},  Γ(h) = ∫₀ʰ e^{As} ds b,  A = [[−1/T1, 0], [1/T2, −1/T2]],
    b = [K/T1, 0]ᵀ,  y = z₂

:func:`discrete_realization` turns any linear thermogym model (``ss``,
``foptd``, ``sopdt``, the polynomial models) into one discrete state space
``x⁺ = A x + B u``, ``y = C x + D u`` at a given period, the input delays as
shift-register states: what an environment steps.

Parameters
----------
============================  ===============  ===========================================
parameter                     unit             meaning
============================  ===============  ===========================================
``K_<out>[__<in>]``           output/input     static gain
``T1_<out>[__<in>]``          s                first time constant, > 0
``T2_<out>[__<in>]``          s                second time constant, > 0
``tau_<out>[__<in>]``         s                dead time, ≥ 0
============================  ===============  ===========================================

Bounds: ``K ± (10|K| + 1)``, ``T ∈ [T/1000, 1000 T]``, ``τ ∈ [0, 10 max(τ, T1)]``;
provenance "identified".

Starting State
--------------
Every lag at zero and no input before ``t = 0`` (deviation form), or with
``steady_start=True`` every lag at its steady state ``K u[0]`` with the
input constant at ``u[0]`` before ``t = 0``.

Version History
---------------
* v1: initial release.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from thermogym._checks import positive
from thermogym.errors import ConfigError, ParameterError, ShapeError
from thermogym.models._linear_base import _compact, _make_signals, _transposed, _wide
from thermogym.models._linear_kernels import _ss_simulate_kernel
from thermogym.models.base import Model, Parameter, ThetaLike
from thermogym.models.linear import FOPTDModel, StateSpaceMatrices, StateSpaceModel, foptd_zoh
from thermogym.models.polynomial import PolynomialModel, _whole_steps

__all__ = ["MODELS", "SOPDTModel", "discrete_realization", "sopdt_zoh"]

_PROV = "identified (second-order process model with dead time)"
_SNAP = 1e-9


def _split_delay(
    tau: NDArray[np.float64], dt: float
) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    r = tau / dt
    near = np.round(r)
    snap = np.abs(r - near) <= _SNAP * np.maximum(1.0, r)
    d = np.where(snap, near, np.floor(r))
    return d.astype(np.int64), np.where(snap, 0.0, r - d)


def sopdt_zoh(
    K: ArrayLike, T1: ArrayLike, T2: ArrayLike, tau: ArrayLike, dt: float
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.int64]]:
    """Exact ZOH matrices of SOPDT pairs with any (fractional) delay.

    Parameters
    ----------
    K, T1, T2, tau : array_like, same shape S
        Gain, time constants [s] (> 0) and delay [s] (≥ 0).
    dt : float
        Sample period [s].

    Returns
    -------
    Phi : ndarray, shape (*S, 2, 2)
    Ga, Gb : ndarray, shape (*S, 2)
        Input vectors of ``u[k−d]`` and ``u[k−d−1]``.
    d : ndarray of int, shape S

    Examples
    --------
    The steady state of ``z⁺ = Φ z + (Γa + Γb) u`` is ``K u`` in both lags:

    >>> import numpy as np
    >>> from thermogym.models.process import sopdt_zoh
    >>> Phi, Ga, Gb, d = sopdt_zoh(2.0, 30.0, 10.0, 4.5, dt=1.0)
    >>> z = np.linalg.solve(np.eye(2) - Phi, Ga + Gb)
    >>> z.round(9).tolist(), int(d)
    ([2.0, 2.0], 4)
    """
    Ka, T1a, T2a, ta = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (K, T1, T2, tau)))
    positive("dt", dt, unit="s", text=False)
    for name, v in (("K", Ka), ("T1", T1a), ("T2", T2a), ("tau", ta)):
        if not np.isfinite(v).all():
            raise ParameterError(f"{name} contains {v[~np.isfinite(v)].flat[0]!r}; expected finite")
    if (T1a <= 0).any() or (T2a <= 0).any():
        raise ParameterError("time constants T1, T2 must be positive")
    if (ta < 0).any():
        raise ParameterError(f"delay tau is {ta[ta < 0].flat[0]!r} s; it must be >= 0")
    S = Ka.shape
    d, f = _split_delay(ta, dt)
    # augmented matrix [[A, b], [0, 0]]: expm(M h) = [[e^{Ah}, Γ(h)], [0, 1]]
    M = np.zeros((*S, 3, 3))
    M[..., 0, 0] = -1.0 / T1a
    M[..., 0, 2] = Ka / T1a
    M[..., 1, 0] = 1.0 / T2a
    M[..., 1, 1] = -1.0 / T2a

    def ex(h: NDArray[np.float64]) -> NDArray[np.float64]:
        return scipy.linalg.expm(M * h[..., None, None]) if M.size else M.copy()

    full = ex(np.full(S, dt))
    late = ex((1.0 - f) * dt)  # the newer sample's share of the interval
    early = ex(f * dt)
    Phi = full[..., :2, :2]
    Ga = late[..., :2, 2]
    Gb = np.einsum("...ij,...j->...i", late[..., :2, :2], early[..., :2, 2])
    return Phi, Ga, Gb, d


def _pairs_realization(
    Phi: NDArray[np.float64],
    Ga: NDArray[np.float64],
    Gb: NDArray[np.float64],
    Cz: NDArray[np.float64],
    d: NDArray[np.int64],
    history: int | None = None,
) -> tuple[StateSpaceMatrices, int]:
    """Discrete state space of delayed pairs ``z⁺ = Φ z + Ga u[k−d] + Gb u[k−d−1]``.

    ``Phi`` (B, p, m, r, r), ``Ga``/``Gb`` (B, p, m, r), ``Cz`` (r,) maps a
    pair's state to its output share, ``d`` (B, p, m). States: the ``p·m·r``
    pair states, then per input a shift register ``u[k−1] … u[k−H]``.
    Returns the matrices and ``H``.
    """
    Bt, p, m, r = Ga.shape
    need = d + (np.abs(Gb).max(axis=-1) > 0)
    H = int(need.max(initial=0)) if history is None else int(history)
    if need.max(initial=0) > H:
        raise ShapeError(f"delays need {int(need.max())} past inputs, history is {H}")
    nq = p * m * r
    n = nq + m * H
    A = np.zeros((Bt, n, n))
    Bm = np.zeros((Bt, n, m))
    C = np.zeros((Bt, p, n))
    D = np.zeros((Bt, p, m))

    def reg(i: int, h: int) -> int:  # state holding u_i[k−h], h ≥ 1
        return nq + i * H + (h - 1)

    for i in range(m):
        if H:
            Bm[:, reg(i, 1), i] = 1.0  # s_1⁺ = u[k]
            for h in range(2, H + 1):
                A[:, reg(i, h), reg(i, h - 1)] = 1.0  # s_h⁺ = s_{h−1}
    b_idx = np.arange(Bt)
    for j in range(p):
        for i in range(m):
            s = (j * m + i) * r
            sl = slice(s, s + r)
            A[:, sl, sl] = Phi[:, j, i]
            C[:, j, sl] = Cz
            for which, G, lag in ((0, Ga[:, j, i], d[:, j, i]), (1, Gb[:, j, i], d[:, j, i] + 1)):
                if which == 1 and not np.any(G):
                    continue
                now = lag == 0
                if np.any(now):
                    Bm[b_idx[now], sl, i] += G[now]
                for b in np.flatnonzero(~now):
                    if G[b].any():  # (a whole-sample delay has no older share)
                        A[b, sl, reg(i, int(lag[b]))] += G[b]
    return StateSpaceMatrices(A, Bm, C, D, np.zeros((Bt, n, p))), H


class SOPDTModel(Model):
    """Set of second-order-plus-dead-time transfer functions (MATLAB ``P2D``).

    Output ``j`` is ``Σ_i y_ji`` with ``Y_ji = K e^{−τs} / ((T1 s + 1)(T2 s + 1)) U_i``,
    simulated exactly (zero-order hold, fractional delays included).

    Parameters
    ----------
    inputs, outputs : sequence of str
        Column names.
    disturbances : sequence of str
        Further exogenous columns.
    units : mapping, optional
    K, T1, T2, tau : float or array_like (n_out, n_exog)
        Nominal gains, time constants [s] and delays [s].
    steady_start : bool
        Start every lag at ``K u[0]`` with the input constant before ``t = 0``.

    Examples
    --------
    The step response reaches ``K (1 − (T1 e^{−t/T1} − T2 e^{−t/T2}) / (T1 − T2))``
    after the delay:

    >>> import numpy as np
    >>> from thermogym.models.process import SOPDTModel
    >>> m = SOPDTModel(["P"], ["T"], K=2.0, T1=60.0, T2=20.0, tau=10.0)
    >>> y = m.simulate(np.ones((301, 1)), 1.0).outputs[0, :, 0]
    >>> t = 100.0 - 10.0
    >>> exact = 2.0 * (1 - (60 * np.exp(-t / 60) - 20 * np.exp(-t / 20)) / 40)
    >>> float(y[10]), round(float(y[100]), 9) == round(float(exact), 9)
    (0.0, True)
    """

    name = "sopdt"
    version = "1"

    def __init__(
        self,
        inputs: Sequence[str] | str = ("u",),
        outputs: Sequence[str] | str = ("y",),
        *,
        disturbances: Sequence[str] | str = (),
        units: Mapping[str, str] | None = None,
        K: ArrayLike = 1.0,
        T1: ArrayLike = 60.0,
        T2: ArrayLike = 10.0,
        tau: ArrayLike = 0.0,
        steady_start: bool = False,
    ) -> None:
        ins, dis, outs, full_units, signals = _make_signals(
            inputs, disturbances, outputs, units, "SOPDT model"
        )
        exo = ins + dis
        p, m = len(outs), len(exo)

        def nominal(name: str, v: ArrayLike) -> NDArray[np.float64]:
            try:
                a = np.broadcast_to(np.asarray(v, dtype=float), (p, m))
            except ValueError:
                raise ShapeError(
                    f"{name} has shape {np.shape(v)}, expected a scalar or ({p}, {m}) "
                    f"(outputs {outs} x exogenous {exo})"
                ) from None
            if not np.isfinite(a).all():
                raise ParameterError(f"{name} contains a non-finite value; expected finite")
            return a

        Kn, T1n, T2n, tn = (
            nominal(k, v) for k, v in (("K", K), ("T1", T1), ("T2", T2), ("tau", tau))
        )
        for name, a in (("T1", T1n), ("T2", T2n)):
            if (a <= 0).any():
                raise ParameterError(f"{name} is {a[a <= 0][0]!r} s; a time constant must be > 0")
        if (tn < 0).any():
            raise ParameterError(f"tau is {tn[tn < 0][0]!r} s; a delay must be >= 0")
        self.n_inputs, self.n_outputs = m, p
        self.steady_start = bool(steady_start)
        self._cfg_names = (ins, dis, outs, full_units)

        def tag(j: int, i: int) -> str:
            return outs[j] if m == 1 else f"{outs[j]}__{exo[i]}"

        params: list[Parameter] = []
        self._idx = {k: np.empty((p, m), dtype=np.int64) for k in ("K", "T1", "T2", "tau")}
        for j in range(p):
            uy = full_units[outs[j]]
            for i in range(m):
                ui = full_units[exo[i]]
                k_, a_, b_, d_ = (float(v[j, i]) for v in (Kn, T1n, T2n, tn))
                specs = (
                    ("K", k_, *_wide(k_), f"{uy}/{ui}", "static gain"),
                    ("T1", a_, a_ / 1000.0, 1000.0 * a_, "s", "first time constant"),
                    ("T2", b_, b_ / 1000.0, 1000.0 * b_, "s", "second time constant"),
                    ("tau", d_, 0.0, 10.0 * max(d_, a_, b_), "s", "dead time"),
                )
                for key, v, lo, hi, unit, desc in specs:
                    self._idx[key][j, i] = len(params)
                    params.append(
                        Parameter(
                            f"{key}_{tag(j, i)}",
                            v,
                            lo,
                            hi,
                            unit,
                            f"{desc} of {outs[j]} after {exo[i]}",
                            _PROV,
                            outs[j],
                        )
                    )
        states = [f"z{r}_{tag(j, i)}" for j in range(p) for i in range(m) for r in (1, 2)]
        super().__init__(signals, params, states)

    def config(self) -> dict[str, Any]:
        """Constructor arguments that rebuild this model (JSON-able)."""
        ins, dis, outs, units = self._cfg_names
        K, T1, T2, tau = (v[0].tolist() for v in self.pair_parameters())
        return {
            "inputs": list(ins),
            "outputs": list(outs),
            "disturbances": list(dis),
            "units": dict(units),
            "K": K,
            "T1": T1,
            "T2": T2,
            "tau": tau,
            "steady_start": self.steady_start,
        }

    def pair_parameters(self, theta: ThetaLike = None) -> tuple[NDArray[np.float64], ...]:
        """``K``, ``T1``, ``T2``, ``tau``, each shape (B, n_out, n_exog)."""
        th = self.theta(theta)
        return tuple(th[:, self._idx[k]] for k in ("K", "T1", "T2", "tau"))

    def dcgain(self, theta: ThetaLike = None) -> NDArray[np.float64]:
        """Static gains ``K``, shape (B, n_out, n_exog)."""
        return self.pair_parameters(theta)[0]

    def _validate_theta(self, theta: NDArray[np.float64]) -> None:
        self._require_positive(
            theta, [self.param_names[i] for k in ("T1", "T2") for i in self._idx[k].ravel()]
        )
        for i in self._idx["tau"].ravel():
            if (theta[:, i] < 0).any():
                raise ParameterError(
                    f"parameter {self.param_names[i]!r} is {float(theta[:, i].min())!r} s; a "
                    "delay must be >= 0"
                )

    def realization(
        self, theta: ThetaLike, dt: float, history: int | None = None
    ) -> tuple[StateSpaceMatrices, int]:
        """Discrete state space at ``dt``: lag states then input shift registers.

        Returns the matrices (batched) and the number ``H`` of past input
        samples each register holds.
        """
        K, T1, T2, tau = self.pair_parameters(theta)
        Phi, Ga, Gb, d = sopdt_zoh(K, T1, T2, tau, dt)
        return _pairs_realization(Phi, Ga, Gb, np.array([0.0, 1.0]), d, history)

    def initial_state(
        self, theta: NDArray[np.float64], u0: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """Zero lags, or (``steady_start``) both lags of each pair at ``K u0``."""
        th = np.atleast_2d(theta)
        u0 = np.atleast_2d(u0)
        Bt = max(th.shape[0], u0.shape[0])
        p, m = self.n_outputs, self.n_inputs
        x = np.zeros((Bt, p * m * 2))
        if self.steady_start:
            z = np.broadcast_to(th[:, self._idx["K"]] * u0[:, None, :], (Bt, p, m))
            x[:, 0::2] = z.reshape(Bt, -1)
            x[:, 1::2] = z.reshape(Bt, -1)
        return x

    def _simulate(self, theta, u, dt, x0, return_states):
        r, H = self.realization(theta, dt)
        Bt, T = r.A.shape[0], u.shape[1]
        m = self.n_inputs
        nq = x0.shape[1]
        xa = np.zeros((Bt, nq + m * H))
        xa[:, :nq] = x0
        if H and self.steady_start:  # the input was u[0] before t = 0
            u0 = np.broadcast_to(u[:, 0, :], (Bt, m))
            xa[:, nq:] = np.repeat(u0, H, axis=1)
        y = np.empty((Bt, T, self.n_outputs))
        xs = np.empty((Bt, T, xa.shape[1])) if return_states else np.empty((1, 1, 1))
        _ss_simulate_kernel(
            *(_transposed(a) for a in (r.A, r.B, r.C, r.D)),
            _compact(u),
            xa,
            1,
            y,
            xs,
            return_states,
        )
        return y, (xs[:, :, :nq] if return_states else None)


def discrete_realization(
    model: Model, theta: ThetaLike, dt: float, *, history: int | None = None
) -> tuple[StateSpaceMatrices, int]:
    """Discrete state space of a linear model at period ``dt`` for a parameter batch.

    Parameters
    ----------
    model : StateSpaceModel, FOPTDModel, SOPDTModel or PolynomialModel
    theta : parameter batch
    dt : float
        Period [s]: any positive value for the continuous-time FOPTD/SOPDT
        sets, the model's own ``dt`` or a multiple of it for the discrete
        ``ss`` and polynomial models.
    history : int, optional
        Input shift-register length of the delay models (default: what the
        delays of this batch need); a longer one pads with unused states.

    Returns
    -------
    StateSpaceMatrices
        ``x⁺ = A x + B u``, ``y = C x + D u`` in deviations from the model's
        operating point (``u − u_op``, ``y − y_op``; an FOPTD's offsets ``y0``
        are its ``y_op``); ``K`` zero except for models with a noise model at
        their own period.
    history : int
        Shift-register length used (0 for models without delay states).

    Raises
    ------
    ConfigError
        Not a linear model; ``dt`` not a multiple of a discrete model's period.

    Examples
    --------
    >>> import numpy as np
    >>> from thermogym.models.linear import FOPTDModel
    >>> from thermogym.models.process import discrete_realization
    >>> r, H = discrete_realization(FOPTDModel(K=2.0, T=10.0, tau=2.5), None, 1.0)
    >>> H, round(float((r.C[0] @ np.linalg.solve(np.eye(4) - r.A[0], r.B[0]))[0, 0]), 9)
    (3, 2.0)
    """
    th = model.theta(theta)
    if isinstance(model, SOPDTModel):
        return model.realization(th, dt, history)
    if isinstance(model, FOPTDModel):
        K, T, tau = model.pair_parameters(th)
        a, b1, b2, d = foptd_zoh(K, T, tau, dt)
        r, H = _pairs_realization(
            a[..., None, None], b1[..., None], b2[..., None], np.ones(1), d, history
        )
        return r, H
    if isinstance(model, StateSpaceModel):
        r = model.matrices(th)
        same = model.dt is None or abs(dt - model.dt) <= 1e-12 * dt
        Ar, Br = model.at_period(dt, th)  # exact resampling (held inputs)
        return StateSpaceMatrices(Ar, Br, r.C, r.D, r.K if same else np.zeros_like(r.K)), 0
    if isinstance(model, PolynomialModel):
        nsub = _whole_steps(dt, model.dt, "discrete_realization")
        r = model.realization(th)
        A, Bm = r.A, r.B
        Ar, Br = A.copy(), Bm.copy()
        for _ in range(nsub - 1):  # inputs held over nsub model steps
            Br = A @ Br + Bm
            Ar = A @ Ar
        K = r.K if nsub == 1 else np.zeros_like(r.K)
        return StateSpaceMatrices(Ar, Br, r.C, r.D, K), 0
    raise ConfigError(
        f"model {model.name!r} is not linear; discrete_realization takes ss, foptd, sopdt, "
        "arx, armax, oe or bj models"
    )


MODELS: dict[str, type[Model]] = {"sopdt": SOPDTModel}
