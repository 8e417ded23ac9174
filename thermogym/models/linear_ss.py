"""The discrete MIMO state space of N4SID (paper 001 eq 3); conventions in :mod:`.linear`."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, NamedTuple, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from thermogym.errors import ConfigError, ParameterError, ShapeError, SimulationError
from thermogym.models._linear_base import (
    _PROV,
    _broadcast_batch,
    _compact,
    _LinearModel,
    _make_signals,
    _matrix,
    _names,
    _period,
    _transposed,
    _u_batch,
    _vector,
    _wide,
    _y_batch,
    c2d_zoh,
    check_x0_mode,
    d2c_zoh,
)
from thermogym.models._linear_kernels import _obs_rows, _ss_predict_kernel, _ss_simulate_kernel
from thermogym.models.base import Parameter, ThetaLike

__all__ = ["ContinuousStateSpace", "StateSpaceMatrices", "StateSpaceModel"]


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
        if x0 is not None and x0m.shape != (n,):
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

    def eigenvalues(
        self, theta: ThetaLike = None
    ) -> NDArray[np.floating[Any]] | NDArray[np.complexfloating[Any, Any]]:
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
            # float64 in, float64 out (numpy's stubs say floating[Any])
            return cast(NDArray[np.float64], np.linalg.solve(eye[None] - A, Bu))
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
        a_t, b_t, c_t, d_t, k_t, ah_t, ahb_t = (_transposed(a) for a in (*mats, Ah, AhB))
        _ss_predict_kernel(a_t, b_t, c_t, d_t, k_t, ah_t, ahb_t, du, dy, xi, h, out)
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
                # numpy's stubs type every mode as QRResult; mode="r" returns R alone
                R = cast(NDArray[np.float64], np.linalg.qr(aug, mode="r"))
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
