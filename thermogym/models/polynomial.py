"""Polynomial input-output models: ARX, ARMAX, output error (OE), Box-Jenkins (BJ).

Description
-----------
The model families of MATLAB's ``arx``, ``armax``, ``oe`` and ``bj`` (the
general form of Ljung, *System Identification*, 2nd ed., eq 4.33). Output
``j`` of a multi-input model is a multi-input single-output (MISO) model of
its own::

    A_j(q) y_j(t) = Σ_i B_ji(q)/F_ji(q) u_i(t − nk_ji) + C_j(q)/D_j(q) e_j(t)

    A(q) = 1 + a1 q⁻¹ + … + a_na q⁻ⁿᵃ       B(q) = b0 + b1 q⁻¹ + … + b_{nb−1} q^{−nb+1}
    C(q) = 1 + c1 q⁻¹ + …                    D(q), F(q) likewise, monic

==========  ==========================  =======================
structure   polynomials                 noise model H
==========  ==========================  =======================
``arx``     A, B                        1/A
``armax``   A, B, C                     C/A
``oe``      B, F                        1
``bj``      B, F, C, D                  C/D
==========  ==========================  =======================

Simulation is the deterministic part (``e = 0``); the noise model enters the
Kalman (one-step) predictor. Both run through an exact state-space
realisation in observer canonical form (:meth:`PolynomialModel.realization`):
for ``y + α₁y(t−1) + … = β₀u + β₁u(t−1) + … + e + γ₁e(t−1) + …``::

    x_k(t+1) = x_{k+1}(t) − α_k x_1(t) + (β_k − α_k β₀) u(t) + (γ_k − α_k) e(t)
    y(t)     = x_1(t) + β₀ u(t) + e(t)

ARX and ARMAX share one block per output (common denominator A); OE and BJ
have one block per input with denominator F_i plus a noise block C/D. So the
models simulate a batch of parameter sets with the compiled state-space
kernel of :mod:`thermogym.models.linear`, and every tool that handles a
state-space model (initial-state estimation, Kalman prediction,
environments) handles these too.

Parameters
----------
==============================  =============  ======================================
parameter                       unit           meaning
==============================  =============  ======================================
``a<k>_<out>``                  1              coefficient k of A (k = 1..na)
``b<k>_<out>[__<in>]``          output/input   coefficient k of B (k = 0..nb−1)
``f<k>_<out>[__<in>]``          1              coefficient k of F (k = 1..nf)
``c<k>_<out>``                  1              coefficient k of C (k = 1..nc)
``d<k>_<out>``                  1              coefficient k of D (k = 1..nd)
==============================  =============  ======================================

Names carry ``__<in>`` only with more than one exogenous signal. The delays
``nk`` (whole samples) and the orders are structure (constructor
arguments), not parameters. Bounds are ``v ± (10|v| + 1)`` around the
nominal ``v`` (zero by default); provenance "identified".

Starting State
--------------
Zero (at rest) by default, or with ``steady_start=True`` the steady state of
the first input sample. Measured data rarely start at rest: estimate the
initial state with :meth:`PolynomialModel.state_space` and
:meth:`~thermogym.models.linear.StateSpaceModel.estimate_x0`.

Version History
---------------
* v1: initial release.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from thermogym._checks import choice, positive
from thermogym.errors import ConfigError, ShapeError, SimulationError
from thermogym.models._linear_base import (
    _broadcast_batch,
    _compact,
    _make_signals,
    _transposed,
    _wide,
)
from thermogym.models._linear_kernels import _ss_simulate_kernel
from thermogym.models.base import Model, Parameter, ThetaLike
from thermogym.models.linear import StateSpaceMatrices, StateSpaceModel

__all__ = ["MODELS", "STRUCTURES", "PolynomialModel", "PolynomialOrders"]

#: Structures and which polynomials each has besides B.
STRUCTURES: dict[str, tuple[str, ...]] = {
    "arx": ("a",),
    "armax": ("a", "c"),
    "oe": ("f",),
    "bj": ("f", "c", "d"),
}
_PROV = "identified (prediction-error method)"


@dataclass(frozen=True)
class PolynomialOrders:
    """Orders and delays of a polynomial model (whole samples).

    Attributes
    ----------
    na, nc, nd : ndarray of int, shape (p,)
        Orders of A, C, D per output.
    nb, nf, nk : ndarray of int, shape (p, m)
        Orders of B (number of coefficients), F and the input delays per
        (output, exogenous signal) pair.
    """

    na: NDArray[np.int64]
    nb: NDArray[np.int64]
    nc: NDArray[np.int64]
    nd: NDArray[np.int64]
    nf: NDArray[np.int64]
    nk: NDArray[np.int64]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready orders."""
        return {k: getattr(self, k).tolist() for k in ("na", "nb", "nc", "nd", "nf", "nk")}


def _orders(name: str, value: ArrayLike, shape: tuple[int, ...], lo: int) -> NDArray[np.int64]:
    a = np.asarray(value)
    try:
        a = np.broadcast_to(a, shape)
    except ValueError:
        raise ShapeError(
            f"{name} has shape {np.shape(value)}, expected a whole number or shape {shape}"
        ) from None
    af = a.astype(float)
    if not np.all(np.isfinite(af)) or np.any(af != np.round(af)) or np.any(af < lo):
        raise ConfigError(
            f"{name} is {np.asarray(value).tolist()!r}; expected whole numbers >= {lo}"
        )
    return np.array(af, dtype=np.int64)


class PolynomialModel(Model):
    """ARX, ARMAX, OE or BJ model, one MISO polynomial model per output.

    Parameters
    ----------
    inputs : sequence of str
        Column names of the manipulated inputs.
    outputs : sequence of str
        Column names of the outputs.
    structure : {"arx", "armax", "oe", "bj"}
    na, nc, nd : int or sequence of int
        Orders of A, C, D (per output); only where the structure has them.
    nb : int or array_like (p, m)
        Number of B coefficients per pair, >= 1.
    nf : int or array_like (p, m)
        Order of F per pair (``oe``, ``bj``).
    nk : int or array_like (p, m)
        Input delay per pair [samples], >= 0 (0: direct feedthrough).
    dt : float
        Sample period [s]; :meth:`simulate` accepts it or integer multiples.
    disturbances : sequence of str
        Further exogenous columns (after the inputs in ``u``).
    units : mapping, optional
        ``{signal: unit}``.
    steady_start : bool
        Start simulations at the steady state of the first input sample.

    Examples
    --------
    A first-order ARX ``y(t) − 0.9 y(t−1) = 0.2 u(t−1)``: DC gain 2.

    >>> import numpy as np
    >>> from thermogym.models.polynomial import PolynomialModel
    >>> m = PolynomialModel(["u"], ["y"], structure="arx", na=1, nb=1, nk=1, dt=1.0)
    >>> m.param_names
    ('a1_y', 'b0_y')
    >>> th = m.theta({"a1_y": -0.9, "b0_y": 0.2})
    >>> y = m.simulate(np.ones((200, 1)), 1.0, th).outputs[0, :, 0]
    >>> float(y[0]), round(float(y[1]), 3), round(float(y[-1]), 6)
    (0.0, 0.2, 2.0)
    """

    version = "1"

    def __init__(
        self,
        inputs: Sequence[str] | str = ("u",),
        outputs: Sequence[str] | str = ("y",),
        *,
        structure: str = "arx",
        na: ArrayLike = 0,
        nb: ArrayLike = 1,
        nc: ArrayLike = 0,
        nd: ArrayLike = 0,
        nf: ArrayLike = 0,
        nk: ArrayLike = 1,
        dt: float = 1.0,
        disturbances: Sequence[str] | str = (),
        units: Mapping[str, str] | None = None,
        steady_start: bool = False,
    ) -> None:
        structure = choice("structure", structure, STRUCTURES, error=ConfigError)
        ins, dis, outs, full_units, signals = _make_signals(
            inputs, disturbances, outputs, units, f"{structure.upper()} model"
        )
        positive("dt", dt, unit="s", error=ConfigError, text=False)
        exo = ins + dis
        p, m = len(outs), len(exo)
        o = PolynomialOrders(
            na=_orders("na", na, (p,), 0),
            nb=_orders("nb", nb, (p, m), 1),
            nc=_orders("nc", nc, (p,), 0),
            nd=_orders("nd", nd, (p,), 0),
            nf=_orders("nf", nf, (p, m), 0),
            nk=_orders("nk", nk, (p, m), 0),
        )
        has = STRUCTURES[structure]
        for poly in ("a", "c", "d", "f"):
            if poly not in has and np.any(getattr(o, f"n{poly}") != 0):
                raise ConfigError(
                    f"{structure.upper()} has no {poly.upper()} polynomial but n{poly} is "
                    f"{getattr(o, f'n{poly}').tolist()}; expected 0 (polynomials of "
                    f"{structure}: B, {', '.join(x.upper() for x in has)})"
                )
        self.name = structure
        self.structure = structure
        self.orders = o
        self.dt = float(dt)
        self.steady_start = bool(steady_start)
        self.n_inputs, self.n_outputs = m, p
        self._cfg_names = (ins, dis, outs, full_units)

        def tag(j: int, i: int | None = None) -> str:
            if i is None or m == 1:
                return outs[j]
            return f"{outs[j]}__{exo[i]}"

        params: list[Parameter] = []
        # column indices of each polynomial in theta: lists per output / pair
        self._ia: list[list[int]] = []
        self._ib: list[list[list[int]]] = []
        self._if: list[list[list[int]]] = []
        self._ic: list[list[int]] = []
        self._id: list[list[int]] = []

        def add(name: str, unit: str, desc: str, group: str) -> int:
            params.append(Parameter(name, 0.0, *_wide(0.0), unit, desc, _PROV, group))
            return len(params) - 1

        for j in range(p):
            uy = full_units[outs[j]]
            self._ia.append(
                [
                    add(f"a{k}_{tag(j)}", "1", f"A of {outs[j]}, q^-{k}", outs[j])
                    for k in range(1, o.na[j] + 1)
                ]
            )
            bj, fj = [], []
            for i in range(m):
                ui = full_units[exo[i]]
                bj.append(
                    [
                        add(
                            f"b{k}_{tag(j, i)}",
                            f"{uy}/{ui}",
                            f"B of {exo[i]} -> {outs[j]}, q^-{k + o.nk[j, i]}",
                            outs[j],
                        )
                        for k in range(o.nb[j, i])
                    ]
                )
                fj.append(
                    [
                        add(
                            f"f{k}_{tag(j, i)}", "1", f"F of {exo[i]} -> {outs[j]}, q^-{k}", outs[j]
                        )
                        for k in range(1, o.nf[j, i] + 1)
                    ]
                )
            self._ib.append(bj)
            self._if.append(fj)
            self._ic.append(
                [
                    add(f"c{k}_{tag(j)}", "1", f"C of {outs[j]}, q^-{k}", outs[j])
                    for k in range(1, o.nc[j] + 1)
                ]
            )
            self._id.append(
                [
                    add(f"d{k}_{tag(j)}", "1", f"D of {outs[j]}, q^-{k}", outs[j])
                    for k in range(1, o.nd[j] + 1)
                ]
            )
        self._layout = self._state_layout()
        n = self._layout[-1]
        super().__init__(signals, params, tuple(f"x_{r}" for r in range(n)))

    # ------------------------------------------------------------ structure
    def _state_layout(self) -> list[int]:
        """Block sizes of the realisation; last entry: total number of states.

        Per output: ``shared`` (ARX, ARMAX) one block of order
        ``max(na, nc, max_i(nk_i + nb_i − 1))``; otherwise one block per input
        of order ``max(nf_i, nk_i + nb_i − 1)`` and a noise block of order
        ``max(nc, nd)``.
        """
        o = self.orders
        self._blocks: list[tuple[int, int | None, int, int]] = []  # (output, input|None, start, n)
        start = 0
        for j in range(self.n_outputs):
            lb = o.nk[j] + o.nb[j] - 1  # degree of q^-nk B
            if self.structure in ("arx", "armax"):
                n = int(max(o.na[j], o.nc[j], lb.max()))
                self._blocks.append((j, None, start, n))
                start += n
            else:
                for i in range(self.n_inputs):
                    n = int(max(o.nf[j, i], lb[i]))
                    self._blocks.append((j, i, start, n))
                    start += n
                n = int(max(o.nc[j], o.nd[j]))
                self._blocks.append((j, -1, start, n))
                start += n
        return [start]

    @property
    def n_states(self) -> int:
        """Number of states of the realisation."""
        return len(self.state_names)

    def config(self) -> dict[str, Any]:
        """Constructor arguments that rebuild this model (JSON-able, without ``structure``)."""
        ins, dis, outs, units = self._cfg_names
        o = self.orders.to_dict()
        cfg: dict[str, Any] = {
            "inputs": list(ins),
            "outputs": list(outs),
            "disturbances": list(dis),
            "units": dict(units),
            "dt": self.dt,
            "steady_start": self.steady_start,
        }
        for k in ("nb", "nk"):
            cfg[k] = o[k]
        for poly in STRUCTURES[self.structure]:
            key = f"n{poly}"
            cfg[key] = o[key]
        return cfg

    def polynomials(self, theta: ThetaLike = None) -> dict[str, list[Any]]:
        """Coefficient arrays (monic polynomials with their leading 1).

        Returns
        -------
        dict
            ``"A"``, ``"C"``, ``"D"``: per output an array (B, 1 + n);
            ``"B"``, ``"F"``: per output a list over inputs of arrays
            (B, nk + nb) (leading zeros for the delay) and (B, 1 + nf).

        Examples
        --------
        >>> from thermogym.models.polynomial import PolynomialModel
        >>> m = PolynomialModel(structure="oe", nb=1, nf=1, nk=2)
        >>> P = m.polynomials({"b0_y": 0.5, "f1_y": -0.5})
        >>> P["B"][0][0].tolist(), P["F"][0][0].tolist()
        ([[0.0, 0.0, 0.5]], [[1.0, -0.5]])
        """
        th = self.theta(theta)
        Bt = th.shape[0]

        def monic(cols: list[int]) -> NDArray[np.float64]:
            return (
                np.column_stack([np.ones(Bt), *(th[:, c] for c in cols)])
                if cols
                else np.ones((Bt, 1))
            )

        out: dict[str, list[Any]] = {"A": [], "B": [], "C": [], "D": [], "F": []}
        for j in range(self.n_outputs):
            out["A"].append(monic(self._ia[j]))
            out["C"].append(monic(self._ic[j]))
            out["D"].append(monic(self._id[j]))
            bs, fs = [], []
            for i in range(self.n_inputs):
                nk = int(self.orders.nk[j, i])
                bs.append(np.column_stack([np.zeros((Bt, nk)), th[:, self._ib[j][i]]]))
                fs.append(monic(self._if[j][i]))
            out["B"].append(bs)
            out["F"].append(fs)
        return out

    # ---------------------------------------------------------- realisation
    def realization(self, theta: ThetaLike = None) -> StateSpaceMatrices:
        """Batched innovation-form state space of the model at ``dt``.

        ``x(t+1) = A x + B u + K e``, ``y = C x + D u + e`` with the same
        input-output behaviour and one-step predictor as the polynomials.

        Returns
        -------
        StateSpaceMatrices
            ``A`` (B, n, n), ``B`` (B, n, m), ``C`` (B, p, n), ``D`` (B, p, m),
            ``K`` (B, n, p).

        Examples
        --------
        >>> import numpy as np
        >>> from thermogym.models.polynomial import PolynomialModel
        >>> m = PolynomialModel(structure="armax", na=1, nb=1, nc=1, nk=1)
        >>> r = m.realization({"a1_y": -0.9, "b0_y": 0.2, "c1_y": 0.5})
        >>> r.A[0].tolist(), r.B[0].tolist(), r.K[0].tolist()
        ([[0.9]], [[0.2]], [[1.4]])
        """
        P = self.polynomials(theta)
        Bt = P["A"][0].shape[0]
        n, m, p = self.n_states, self.n_inputs, self.n_outputs
        A = np.zeros((Bt, n, n))
        Bm = np.zeros((Bt, n, m))
        C = np.zeros((Bt, p, n))
        D = np.zeros((Bt, p, m))
        K = np.zeros((Bt, n, p))

        def pad(c: NDArray[np.float64], length: int) -> NDArray[np.float64]:
            out = np.zeros((Bt, length))
            w = min(length, c.shape[1])
            out[:, :w] = c[:, :w]
            return out

        for j, i, s, nb_ in self._blocks:
            if nb_ == 0:  # a pure gain (nk = 0, nb = 1) or no noise dynamics (H = 1)
                for ii in range(m) if i is None else [i] if i >= 0 else []:
                    D[:, j, ii] += P["B"][j][ii][:, 0]
                continue
            sl = slice(s, s + nb_)
            if i is None:  # shared block: denominator A, numerators B_i, noise C
                alpha = pad(P["A"][j], nb_ + 1)
                gam = pad(P["C"][j], nb_ + 1)
                cols = list(range(m))
            elif i >= 0:  # input block: denominator F_i, numerator B_i, no noise
                alpha = pad(P["F"][j][i], nb_ + 1)
                gam = alpha
                cols = [i]
            else:  # noise block: denominator D, numerator C
                alpha = pad(P["D"][j], nb_ + 1)
                gam = pad(P["C"][j], nb_ + 1)
                cols = []
            # x_k(t+1) = x_{k+1}(t) − α_k x_1(t) + (β_k − α_k β₀) u(t) + (γ_k − α_k) e(t)
            A[:, sl, s] = -alpha[:, 1:]
            idx = np.arange(s, s + nb_ - 1)
            A[:, idx, idx + 1] = 1.0
            C[:, j, s] = 1.0
            for ii in cols:
                beta = pad(P["B"][j][ii], nb_ + 1)
                Bm[:, sl, ii] = beta[:, 1:] - alpha[:, 1:] * beta[:, :1]
                D[:, j, ii] += beta[:, 0]  # y(t) = x_1(t) + β₀ u(t) + e(t)
            if i is None or i < 0:
                K[:, sl, j] = gam[:, 1:] - alpha[:, 1:]
        return StateSpaceMatrices(A, Bm, C, D, K)

    def state_space(self, theta: ThetaLike = None) -> StateSpaceModel:
        """The realisation of one parameter set as a :class:`StateSpaceModel`.

        Examples
        --------
        >>> from thermogym.models.polynomial import PolynomialModel
        >>> m = PolynomialModel(structure="arx", na=2, nb=2, nk=1)
        >>> ss = m.state_space({"a1_y": -1.5, "a2_y": 0.56, "b0_y": 1.0, "b1_y": 0.5})
        >>> round(float(ss.dcgain()[0, 0, 0]), 6), round(1.5 / 0.06, 6)
        (25.0, 25.0)
        """
        r = self.realization(theta)
        if r.A.shape[0] != 1:
            raise ConfigError(f"state_space takes one parameter set, got {r.A.shape[0]}")
        ins, dis, outs, units = self._cfg_names
        has_d = bool(np.any(self.orders.nk == 0))
        has_k = self.structure != "oe"
        return StateSpaceModel(
            max(self.n_states, 1),
            ins,
            outs,
            dt=self.dt,
            disturbances=dis,
            units=units,
            A=_at_least_one(r.A[0], (1, 1)),
            B=_at_least_one(r.B[0], (1, self.n_inputs)),
            C=_at_least_one(r.C[0], (self.n_outputs, 1)),
            D=r.D[0] if has_d else None,
            K=_at_least_one(r.K[0], (1, self.n_outputs)) if has_k else None,
            has_D=has_d,
            has_K=has_k,
            steady_start=self.steady_start,
        )

    def dcgain(self, theta: ThetaLike = None) -> NDArray[np.float64]:
        """Steady-state gains ``B_i(1) / (A(1) F_i(1))``, shape (B, p, m).

        Examples
        --------
        >>> from thermogym.models.polynomial import PolynomialModel
        >>> m = PolynomialModel(structure="oe", nb=1, nf=1)
        >>> m.dcgain({"b0_y": 0.3, "f1_y": -0.7}).round(12).tolist()
        [[[1.0]]]
        """
        P = self.polynomials(theta)
        Bt = P["A"][0].shape[0]
        g = np.empty((Bt, self.n_outputs, self.n_inputs))
        for j in range(self.n_outputs):
            for i in range(self.n_inputs):
                den = P["A"][j].sum(axis=1) * P["F"][j][i].sum(axis=1)
                with np.errstate(divide="ignore", invalid="ignore"):
                    g[:, j, i] = P["B"][j][i].sum(axis=1) / den
        return g

    def poles(self, theta: ThetaLike = None) -> list[NDArray[np.complex128]]:
        """Eigenvalues of the realisation's ``A`` per parameter set (list of arrays)."""
        r = self.realization(theta)
        return [np.linalg.eigvals(a) if a.size else np.zeros(0, complex) for a in r.A]

    # ------------------------------------------------------------- numerics
    def initial_state(
        self, theta: NDArray[np.float64], u0: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """Zero, or (``steady_start``) the steady state at ``u0``, shape (B, n)."""
        th = np.atleast_2d(theta)
        u0 = np.atleast_2d(u0)
        Bt = max(th.shape[0], u0.shape[0])
        n = self.n_states
        if not self.steady_start or n == 0:
            return np.zeros((Bt, n))
        r = self.realization(th)
        A, Bm, u0b = _broadcast_batch(r.A, r.B, u0)
        try:
            # x = A x + B u  ⇒  x = (I − A)^{-1} B u
            return np.linalg.solve(np.eye(n)[None] - A, np.einsum("bnm,bm->bn", Bm, u0b))
        except np.linalg.LinAlgError as e:
            raise SimulationError(
                f"{self.structure.upper()} model has a pole at 1 (integrator); no steady state"
            ) from e

    def _simulate(self, theta, u, dt, x0, return_states):
        nsub = _whole_steps(dt, self.dt, "simulate")
        if nsub != 1:
            raise ShapeError(
                f"simulate: dt is {dt!r} s but the {self.structure.upper()} model is discrete "
                f"with dt = {self.dt!r} s; a polynomial model runs at its own period"
            )
        r = self.realization(theta)
        Bt, T = r.A.shape[0], u.shape[1]
        y = np.empty((Bt, T, self.n_outputs))
        xs = np.empty((Bt, T, self.n_states)) if return_states else np.empty((1, 1, 1))
        _ss_simulate_kernel(
            *(_transposed(a) for a in (r.A, r.B, r.C, r.D)),
            _compact(u),
            np.ascontiguousarray(x0),
            1,
            y,
            xs,
            return_states,
        )
        return y, (xs if return_states else None)

    def _step(self, x, u, theta, dt):
        if _whole_steps(dt, self.dt, "step") != 1:
            raise ShapeError(f"step: dt is {dt!r} s; the model steps at dt = {self.dt!r} s")
        r = self.realization(theta)
        x, u, A, Bm = _broadcast_batch(x, u, r.A, r.B)
        return np.einsum("bij,bj->bi", A, x) + np.einsum("bij,bj->bi", Bm, u)

    def _output(self, x, u, theta):
        r = self.realization(theta)
        x, u, C, D = _broadcast_batch(x, u, r.C, r.D)
        return np.einsum("bij,bj->bi", C, x) + np.einsum("bij,bj->bi", D, u)


def _whole_steps(dt: float, model_dt: float, what: str) -> int:
    """``dt / model_dt`` as a whole number of model steps, or :class:`ShapeError`."""
    positive(f"{what}: dt", dt, unit="s", error=ShapeError, text=False)
    r = dt / model_dt
    n = round(r)
    if n < 1 or abs(r - n) > 1e-9 * max(r, 1.0):
        raise ShapeError(
            f"{what}: dt is {dt!r} s but the model is discrete with dt = {model_dt!r} s; "
            "expected dt equal to the model's or an integer multiple of it"
        )
    return int(n)


def _at_least_one(a: NDArray[np.float64], shape: tuple[int, int]) -> NDArray[np.float64]:
    """A zero-state realisation as a one-state model with a zero state."""
    if a.size:
        return a
    return np.zeros(shape)


def _factory(structure: str) -> Any:
    def build(**config: Any) -> PolynomialModel:
        if "structure" in config:
            raise ConfigError(
                f"model {structure!r}: 'structure' is fixed by the model name; drop it"
            )
        return PolynomialModel(structure=structure, **config)

    build.__name__ = f"{structure}_model"
    return build


MODELS: dict[str, Any] = {s: _factory(s) for s in STRUCTURES}
