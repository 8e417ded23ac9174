"""Identified linear models as prediction models for controllers.

:func:`linear_plant` turns an identified linear model — a
:class:`~thermogym.models.linear.FOPTDModel` or
:class:`~thermogym.models.linear.StateSpaceModel`, or their FitResult — into a
:class:`LinearPlant`: discrete matrices at the controller's sample time in
absolute signal units, with the exogenous signals split into the manipulated
input, measured disturbances and the rest (held at their operating point)::

    x[k+1] = A x[k] + B (u[k] − u_op) + E (d[k] − d_op)
    y[k]   = C x[k] + D_u (u[k] − u_op) + D_d (d[k] − d_op) + y_op

FOPTD sets (``000_24627a5308ee07db.txt`` eqs 7-12) become one lag state per
(output, input) pair plus a delay line per input, with the exact zero-order
hold coefficients of :func:`~thermogym.models.linear.foptd_zoh` (fractional
delays included). The operating point is the model's own
(``operating_point()``; a FitResult stores it in ``model_config``, FOPTD as
``u_op`` and the offsets ``y0``, the output at rest at ``u_op``).
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from thermogym.controllers.base import whole_periods
from thermogym.errors import ConfigError, ParameterError
from thermogym.fitresult import FitResult, load_fit
from thermogym.models.base import Model
from thermogym.models.linear import FOPTDModel, StateSpaceModel, foptd_zoh

__all__ = ["LinearPlant", "linear_plant"]


@dataclass(frozen=True)
class LinearPlant:
    """A discrete linear model split into manipulated input and measured disturbances.

    Attributes
    ----------
    A, B, E, C, D_u, D_d : ndarray
        Shapes (n, n), (n, 1), (n, q), (p, n), (p, 1), (p, q).
    dt : float
        Sample period [s].
    input : str
        Manipulated input name.
    disturbances : tuple of str
        Measured disturbances (q of them).
    outputs : tuple of str
        Outputs (p of them).
    u_op : float
    d_op : ndarray, shape (q,)
    y_op : ndarray, shape (p,)
        Operating point (absolute units).
    fingerprint : str or None
        Fingerprint of the FitResult it was built from.
    source : str
        Model kind it was built from.
    """

    A: NDArray[np.float64]
    B: NDArray[np.float64]
    E: NDArray[np.float64]
    C: NDArray[np.float64]
    D_u: NDArray[np.float64]
    D_d: NDArray[np.float64]
    dt: float
    input: str
    disturbances: tuple[str, ...]
    outputs: tuple[str, ...]
    u_op: float
    d_op: NDArray[np.float64]
    y_op: NDArray[np.float64]
    fingerprint: str | None = None
    source: str = ""

    @property
    def n_states(self) -> int:
        """State dimension."""
        return int(self.A.shape[0])

    def resample(self, dt: float) -> LinearPlant:
        """The same plant sampled every ``dt`` (a whole multiple of :attr:`dt`), inputs held.

        ``A_k = A^k``, ``B_k = Σ_{i<k} A^i B`` (exact for held inputs).
        """
        k = whole_periods("LinearPlant", "dt", dt, self.dt)
        if k == 1:
            return self
        Ak = np.eye(self.n_states)
        S = np.zeros_like(self.A)
        for _ in range(k):
            S = S + Ak
            Ak = self.A @ Ak
        return replace(self, A=Ak, B=S @ self.B, E=S @ self.E, dt=self.dt * k)

    def dc_gain(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Steady-state gains (p, 1) of the input and (p, q) of the disturbances."""
        n = self.n_states
        try:
            X = np.linalg.solve(np.eye(n) - self.A, np.hstack([self.B, self.E]))
        except np.linalg.LinAlgError as e:
            raise ParameterError("the linear plant has a pole at 1 (an integrator)") from e
        G = self.C @ X + np.hstack([self.D_u, self.D_d])
        return G[:, :1], G[:, 1:]

    def steady_state(self, u: float, d: ArrayLike) -> NDArray[np.float64]:
        """State at rest for constant input ``u`` and disturbances ``d`` (absolute units)."""
        dd = np.asarray(d, dtype=float).reshape(-1) - self.d_op
        rhs = self.B[:, 0] * (u - self.u_op) + self.E @ dd
        return np.asarray(np.linalg.solve(np.eye(self.n_states) - self.A, rhs), dtype=np.float64)

    def output(self, x: ArrayLike, u: float, d: ArrayLike) -> NDArray[np.float64]:
        """Outputs for state ``x``, input ``u``, disturbances ``d`` (absolute units)."""
        dd = np.asarray(d, dtype=float).reshape(-1) - self.d_op
        return self.C @ np.asarray(x) + self.D_u[:, 0] * (u - self.u_op) + self.D_d @ dd + self.y_op

    def inverse(self, y: float, d: ArrayLike, output: int = 0) -> float:
        """Input that holds output ``output`` at ``y`` in steady state (static inverse)."""
        Gu, Gd = self.dc_gain()
        dd = np.asarray(d, dtype=float).reshape(-1) - self.d_op
        g = float(Gu[output, 0])
        if g == 0:
            raise ParameterError(f"the input {self.input!r} has no steady-state effect")
        return self.u_op + float((y - self.y_op[output] - Gd[output] @ dd) / g)


def _select(
    exo: Sequence[str], input: str | None, disturbances: Sequence[str] | None, what: str
) -> tuple[int, list[int], list[int]]:
    exo = list(exo)
    if input is None:
        if not exo:
            raise ConfigError(f"{what} has no exogenous signal")
        input = exo[0]
    if input not in exo:
        raise ConfigError(f"{what} has no exogenous signal {input!r}; it has {exo}")
    dist = [] if disturbances is None else list(disturbances)
    bad = [d for d in dist if d not in exo or d == input]
    if bad:
        raise ConfigError(
            f"{what}: disturbance(s) {bad} are not exogenous signals of the model (other than "
            f"the input {input!r}); it has {exo}"
        )
    iu = exo.index(input)
    idd = [exo.index(d) for d in dist]
    rest = [i for i in range(len(exo)) if i != iu and i not in idd]
    return iu, idd, rest


def _foptd_matrices(
    model: FOPTDModel, theta: Any, dt: float
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """A, B (all exogenous columns), C of an FOPTD set at sample period dt."""
    K, T, tau = (v[0] for v in model.pair_parameters(theta))
    a, b1, b2, d = foptd_zoh(K, T, tau, dt)
    p, m = K.shape
    # delay line length per input: the oldest sample any pair needs
    need = np.where(np.abs(b2) > 0, d + 1, d)
    L = need.max(axis=0) if p else np.zeros(m, dtype=int)
    n_lag = p * m
    off = n_lag + np.concatenate([[0], np.cumsum(L)[:-1]]).astype(int)
    n = n_lag + int(L.sum())
    A = np.zeros((n, n))
    B = np.zeros((n, m))
    C = np.zeros((p, n))

    def feed(row: int, i: int, lag: int, coef: float) -> None:
        # coefficient on u_i[k − lag]: lag 0 is the input itself, lag l the l-th delay state
        if coef == 0:
            return
        if lag == 0:
            B[row, i] += coef
        else:
            A[row, off[i] + lag - 1] += coef

    for j in range(p):
        for i in range(m):
            s = j * m + i
            A[s, s] = a[j, i]  # z[k+1] = a z[k] + b1 u[k−d] + b2 u[k−d−1]   (9) with ZOH delay
            feed(s, i, int(d[j, i]), float(b1[j, i]))
            feed(s, i, int(d[j, i]) + 1, float(b2[j, i]))
            C[j, s] = 1.0  # y_j = y0_j + Σ_i z_ji   (8)
    for i in range(m):
        for lag in range(int(L[i])):
            r = off[i] + lag
            if lag == 0:
                B[r, i] = 1.0
            else:
                A[r, r - 1] = 1.0
    return A, B, C


def linear_plant(
    source: Any,
    *,
    input: str | None = None,
    disturbances: Sequence[str] | None = None,
    outputs: Sequence[str] | None = None,
    dt: float | None = None,
    theta: Any = None,
) -> LinearPlant:
    """Build a :class:`LinearPlant` from an identified linear model.

    Parameters
    ----------
    source : LinearPlant, FOPTDModel, StateSpaceModel, FitResult, path or dict
    input : str, optional
        Manipulated input (default: the model's first exogenous signal).
    disturbances : sequence of str, optional
        Measured disturbances; other exogenous signals are held at their
        operating point.
    outputs : sequence of str, optional
        Outputs to keep (default: all).
    dt : float, optional
        Sample period [s]: FOPTD sets are discretised exactly at it; state
        spaces are resampled (a whole multiple of their own period).
    theta : parameter set, optional
        Parameters of a model object (default nominal).

    Returns
    -------
    LinearPlant

    Examples
    --------
    >>> from thermogym.models.linear import FOPTDModel
    >>> m = FOPTDModel(["u"], ["y"], K=2.0, T=100.0, tau=25.0, offsets=True, y0=20.0)
    >>> lp = linear_plant(m, dt=10.0)
    >>> lp.n_states, round(float(lp.dc_gain()[0][0, 0]), 9), float(lp.y_op[0])
    (4, 2.0, 20.0)
    """
    if isinstance(source, LinearPlant):
        return source if dt is None else source.resample(dt)
    fp = None
    op: Mapping[str, Any] = {}
    if isinstance(source, FitResult | str | os.PathLike | Mapping):
        fit = load_fit(source)
        fp = fit.fingerprint()
        model: Model = fit.build_model()
        theta = fit.theta(model)
        op = dict(fit.settings.get("operating_point") or {})
    elif isinstance(source, Model):
        model = source
    else:
        raise ConfigError(
            f"cannot build a linear plant from {type(source).__name__}; give an FOPTDModel, a "
            "StateSpaceModel or their FitResult"
        )
    what = f"model {model.name!r}"
    exo = list(model.exogenous_names)
    outs_all = list(model.output_names)
    keep = outs_all if outputs is None else list(outputs)
    bad = [o for o in keep if o not in outs_all]
    if bad:
        raise ConfigError(f"{what} has no output(s) {bad}; its outputs are {outs_all}")
    jo = [outs_all.index(o) for o in keep]
    iu, idd, rest = _select(exo, input, disturbances, what)
    th = model.theta(theta)
    if isinstance(model, FOPTDModel):
        step = model_dt = float(dt) if dt is not None else None
        if step is None:
            raise ConfigError("linear_plant: give dt (the sample period) for an FOPTD model")
        A, Bx, C = _foptd_matrices(model, th, step)
        Dx = np.zeros((len(outs_all), len(exo)))
        # the model's own operating point (u_op, and y0 the output at rest there); a fit
        # without offsets keeps its operating point in the settings only
        u_all, y_op = (v[0] for v in model.operating_point(th))
        if not model.offsets:
            y_op, u_all = _op(op, "outputs", outs_all), _op(op, "inputs", exo)
        kind = "foptd"
    elif isinstance(model, StateSpaceModel):
        mats = model.matrices(th)
        A, Bx, C, Dx = mats.A[0], mats.B[0], mats.C[0], mats.D[0]
        model_dt = model.dt
        if model_dt is None:
            if dt is None:
                raise ConfigError(
                    "linear_plant: the state-space model has no sample period (dt=None); give "
                    "dt, the period its matrices are discrete at"
                )
            model_dt = float(dt)
        u_all, y_op = (v[0] for v in model.operating_point(th))  # FitResult.build_model sets it
        kind = "ss"
    else:
        raise ConfigError(
            f"{what} is not linear; MPC and tuning rules need an FOPTD or a state-space model "
            "(identify one from recordings: thermogym identify foptd / n4sid)"
        )
    # exogenous signals neither manipulated nor measured stay at their operating point: no term
    plant = LinearPlant(
        A=np.asarray(A, dtype=float),
        B=Bx[:, [iu]].astype(float),
        E=Bx[:, idd].astype(float),
        C=C[jo].astype(float),
        D_u=Dx[jo][:, [iu]].astype(float),
        D_d=Dx[jo][:, idd].astype(float),
        dt=float(model_dt),  # type: ignore[arg-type]
        input=exo[iu],
        disturbances=tuple(exo[i] for i in idd),
        outputs=tuple(keep),
        u_op=float(u_all[iu]),
        d_op=np.asarray([u_all[i] for i in idd], dtype=float),
        y_op=np.asarray(y_op, dtype=float)[jo],
        fingerprint=fp,
        source=kind,
    )
    del rest
    if dt is not None and kind == "ss":
        plant = plant.resample(dt)
    return plant


def _op(op: Mapping[str, Any], key: str, names: Sequence[str]) -> NDArray[np.float64]:
    vals = dict(op.get(key) or {})
    return np.array([float(vals.get(n, 0.0)) for n in names])
