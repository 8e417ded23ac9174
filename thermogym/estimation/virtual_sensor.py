"""Virtual sensors: Kalman filters and steady-state observers on identified models.

Description
-----------
Paper ``001_6d13a2cd04f5de5e.txt`` (abstract, section 3.3) writes an identified
linear model into the firmware of its sensor module so that the module computes
the spindle's *internal* temperatures (bearings, inner housing), which no
sensor can reach, from its *surface* temperatures. The package
:mod:`thermogym.estimation` holds the numerics of such virtual sensors:

* :class:`VirtualSensor` — a linear state-space model (``ss``,
  :class:`~thermogym.models.linear.StateSpaceModel`) split into **exogenous**
  signals (known exactly: speed, ambient temperature), **measured** outputs
  (the surface RTDs the module reads) and **hidden** outputs (the internal
  temperatures it estimates). It gives a time-varying Kalman filter built
  with filterpy (:meth:`VirtualSensor.filter`) and the steady-state observer
  the firmware runs (:meth:`VirtualSensor.observe`,
  :class:`~thermogym.estimation.observer.SteadyStateObserver`),
  whose gain comes from the discrete algebraic Riccati equation (scipy).
* :class:`~thermogym.estimation.ukf.AXT211WaxUKF` — an unscented Kalman filter
  (filterpy) over the AXT211 model's step function that estimates the wax temperature ``T_P`` of
  paper ``002_dae2310635fe074e.txt`` from the valve stroke and the supply.
* Filter consistency: normalised estimation error squared (NEES), normalised
  innovation squared (NIS) and chi-square tests (:mod:`thermogym.estimation.consistency`).
* :func:`~thermogym.estimation.reduction.balanced_truncation` — model reduction
  for reference models and for fitting a model into a small target.

What the observer corrects with (a design decision)
---------------------------------------------------
In Table 6 of paper 001 the surface temperatures are *inputs* of the identified
models (3I5O: speed and two outer-housing temperatures in, five internal
temperatures out; 2I5O, 1I5O likewise) and the internal temperatures are the
*outputs*. Such a model is an input-driven estimator: the measurements already
reach the state through ``B``, and no measured output remains to form an
innovation, so its Kalman gain is zero. :class:`VirtualSensor` covers it with
``measured=()`` (the filter then only propagates the estimate's covariance).

The formulation this module recommends keeps the surface temperatures as
*measured outputs*: a model with the known signals as exogenous inputs
(speed and ambient temperature, the 1I7O model of Table 6 plus the ambient the
module's second channel group records) and all seven temperatures as outputs,
two of them measured. The Kalman filter then corrects the state with the
surface innovations — this removes a wrong initial state (a machine switched
on warm), absorbs unmeasured heat and ambient disturbances and, with
``disturbance_inputs=("speed",)`` (a random-walk input disturbance), a biased
speed-to-heat gain. The reasons: (1) an innovation is the only way an observer
can notice that its model is wrong; (2) a surface-as-input model has no place
for sensor noise on those inputs (it passes straight into the estimate);
(3) the measured-output model keeps the ambient temperature, without which an
LTI model in absolute temperatures cannot reproduce the daily swing of the room
(with ambient-subtracted data the neglected term ``C dT_amb/dt`` costs about
0.15 K on the rig). Both formulations run in the same firmware.

Equations
---------
Model (innovation form of paper 001 eq 3, discrete matrices, measured part
``z`` and hidden part ``y_h`` of the outputs)::

    x[k+1] = A x[k] + B u[k] + w[k]                  cov w = Q
    z[k]   = C_z x[k] + D_z u[k] + v[k]              cov v = R,  cov(w, v) = S
    y_h[k] = C_h x[k] + D_h u[k]

Steady-state Kalman filter (P from the DARE)::

    P = A P Aᵀ + Q − (A P C_zᵀ + S) Σ⁻¹ (A P C_zᵀ + S)ᵀ,  Σ = C_z P C_zᵀ + R
    L = P C_zᵀ Σ⁻¹                  (filter gain, x̂[k|k] = x̂[k|k−1] + L ν)
    K = (A P C_zᵀ + S) Σ⁻¹          (predictor gain)

One observer step, as the firmware runs it (``ν`` the innovation)::

    ν[k]       = z[k] − C_z x̂[k] − D_z u[k]
    ŷ_h[k|k]   = C_h x̂[k] + D_h u[k] + F ν[k],   F = C_h L
    x̂[k+1]     = A x̂[k] + B u[k] + K ν[k]

With the innovation-form noise of an identified model (``w = K_id e``,
``v = e_z``) and every output measured, this gain is the identified ``K_id``
itself (P = 0): the predictor of :meth:`StateSpaceModel.predict`.

Version History
---------------
* v1: initial release.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import scipy.linalg
import scipy.optimize
from filterpy.kalman import KalmanFilter
from numpy.typing import ArrayLike, NDArray

from thermogym._checks import nonnegative
from thermogym.errors import ConfigError, ParameterError, ShapeError, UnknownNameError
from thermogym.estimation._linalg import _names
from thermogym.estimation.gains import NoiseModel, steady_state_gains
from thermogym.estimation.observer import (
    Estimate,
    ObserverMatrices,
    ObserverStatus,
    SteadyStateObserver,
    _observer_kernel,
)
from thermogym.models.base import ThetaLike
from thermogym.models.linear import StateSpaceModel

__all__ = ["VirtualSensor"]

_TEMPERATURE_UNITS = ("°C", "degC", "C", "K")


# ============================================================== the sensor
def _input_referred_q(
    A: NDArray[np.float64],
    B: NDArray[np.float64],
    C: NDArray[np.float64],
    D: NDArray[np.float64],
    process_std: float,
) -> NDArray[np.float64]:
    """Process noise that enters like the exogenous signals, scaled at the outputs.

    ``Q = α B W Bᵀ`` with ``W = diag(1/g_j²)``, ``g_j`` the largest DC gain of
    input ``j`` (so every input disturbs the outputs alike, whatever its unit),
    and ``α`` such that one sample of noise moves the outputs by
    ``process_std`` on average. Independent of the state coordinates and
    confined to the controllable subspace — an unmeasured heat flow or ambient
    error acts exactly there.
    """
    nonnegative("process_std", process_std, text=False)
    n, m = B.shape
    try:
        G = C @ np.linalg.solve(np.eye(n) - A, B) + D
        g = np.abs(G).max(axis=0)
    except np.linalg.LinAlgError:
        g = np.full(m, np.nan)
    alt = np.linalg.norm(C @ B, axis=0)
    g = np.where(np.isfinite(g) & (g > 0), g, alt)
    w = np.where(g > 0, 1.0 / np.where(g > 0, g, 1.0) ** 2, 0.0)
    Q0 = (B * w) @ B.T
    scale = float(np.mean(np.diag(C @ Q0 @ C.T)))
    if not scale > 0:
        return np.zeros((n, n))
    Q = process_std**2 * Q0 / scale
    return 0.5 * (Q + Q.T)


def _lyapunov_sum(A: NDArray[np.float64], Q: NDArray[np.float64], k: int) -> NDArray[np.float64]:
    """``Σ_{i<k} A^i Q A^iᵀ`` in O(log k) products (k may be 10^10: a period 10^9 times dt).

    Blocks of ``2^j`` terms double: ``S_{2t} = S_t + A^t S_t A^tᵀ``; the blocks of
    the set bits of ``k`` are laid end to end, each shifted by the powers before it.

    Examples
    --------
    >>> A, Q = np.array([[0.9, 0.1], [0.0, 0.5]]), np.eye(2)
    >>> direct = sum(np.linalg.matrix_power(A, i) @ Q @ np.linalg.matrix_power(A, i).T
    ...              for i in range(13))
    >>> bool(np.allclose(_lyapunov_sum(A, Q, 13), direct))
    True
    """
    total = np.zeros_like(Q)
    shift = np.eye(A.shape[0])  # A^m, m: terms summed so far
    block, power = Q.copy(), A.copy()  # 2^j terms, A^(2^j)
    while k:
        if k & 1:
            total = total + shift @ block @ shift.T
            shift = shift @ power
        k >>= 1
        if k:
            block = block + power @ block @ power.T
            power = power @ power
    return total


class VirtualSensor:
    """Kalman virtual sensor on an identified linear state-space model.

    Parameters
    ----------
    model : StateSpaceModel
        The identified model (``ss``), e.g. built from a FitResult.
    theta : parameter batch, optional
        One parameter set (the FitResult's); nominal when omitted.
    measured : sequence of str
        Model outputs the sensor measures at run time (e.g. the surface
        temperatures). Empty for the Table 6 models, whose measurements are
        inputs.
    hidden : sequence of str, optional
        Outputs to estimate; every output that is not measured by default.
    reference : str, optional
        A signal the model's temperatures are relative to (``"T_amb"`` for a
        model identified on ambient-subtracted data). The sensor then takes
        the absolute temperatures and the reference as an extra exogenous
        channel and returns absolute estimates; the transformation is exact.
    referenced : sequence of str, optional
        Signals expressed relative to ``reference``; by default every model
        signal whose unit is a temperature.
    noise : NoiseModel, optional
        Noise of the model's states and measured channels. By default: from
        the model's innovation gain ``K`` with ``Re = diag(measurement_std²)``
        when the model has one, otherwise process noise entering like the
        exogenous signals (``Q ∝ B W Bᵀ``, each input weighted by its DC gain),
        scaled to move the outputs by ``process_std`` per sample, and
        ``R = diag(measurement_std²)``.
        :meth:`tuned` scales it to be consistent with data.
    measurement_std : float or mapping
        Measurement noise standard deviation [output unit] (one value, or per
        output name). Default 0.05, the RTD accuracy of 001 Table 2.
    process_std : float
        See ``noise`` [output unit per sample].
    disturbance_inputs : sequence of str
        Exogenous signals that get a random-walk input disturbance state
        (offset-free estimation of a biased input gain, e.g. ``"speed"``).
    disturbance_std : float or mapping
        Random-walk step of each disturbance [input unit per sample].
    ranges : mapping, optional
        ``{channel: (lower, upper)}``: valid ranges of exogenous and measured
        channels; samples outside are rejected by the observer. Temperatures
        default to the RTD range −50..300 °C (001 Table 2), others to ±inf.

    Raises
    ------
    UnknownNameError
        A measured, hidden, reference or disturbance name is not a model signal.
    ConfigError
        Contradicting names (an output both measured and hidden, ...).
    ParameterError
        The model with these measurements is not detectable.

    Examples
    --------
    >>> import numpy as np
    >>> from thermogym.models.linear import StateSpaceModel
    >>> m = StateSpaceModel.from_matrices(
    ...     [[0.99, 0.0], [0.005, 0.995]], [[0.01], [0.0]], [[1.0, 0.0], [0.0, 1.0]],
    ...     dt=1.0, inputs=["P"], outputs=["T_core", "T_surface"])
    >>> vs = VirtualSensor(m, measured=["T_surface"], measurement_std=0.05)
    >>> vs.hidden_names, vs.measured_names, vs.exogenous_names
    (('T_core',), ('T_surface',), ('P',))
    >>> u = np.ones((3000, 1))
    >>> truth = m.simulate(u, 1.0).outputs[0]
    >>> est = vs.observe(u, truth[:, 1:] + 0.05 * np.random.default_rng(1).normal(size=(3000, 1)))
    >>> bool(abs(est["T_core"][-1] - truth[-1, 0]) < 0.1)
    True
    """

    def __init__(
        self,
        model: StateSpaceModel,
        theta: ThetaLike = None,
        *,
        measured: Sequence[str] | str = (),
        hidden: Sequence[str] | str | None = None,
        reference: str | None = None,
        referenced: Sequence[str] | None = None,
        noise: NoiseModel | None = None,
        measurement_std: float | Mapping[str, float] = 0.05,
        process_std: float = 1e-3,
        disturbance_inputs: Sequence[str] | str = (),
        disturbance_std: float | Mapping[str, float] = 1.0,
        ranges: Mapping[str, tuple[float, float]] | None = None,
    ) -> None:
        if not isinstance(model, StateSpaceModel):
            raise ConfigError(
                f"a virtual sensor needs a linear state-space model ('ss'), got "
                f"{type(model).__name__} {getattr(model, 'name', '')!r}"
            )
        th = model.theta(theta)
        if th.shape[0] != 1:
            raise ParameterError(f"theta holds {th.shape[0]} parameter sets; expected one")
        mats = model.matrices(th)
        A, B, C, D = mats.A[0], mats.B[0], mats.C[0], mats.D[0]
        outs = list(model.output_names)
        exo = list(model.exogenous_names)
        units = {s.name: s.unit for s in model.signals}
        if model.dt is None:
            raise ConfigError(
                "the state-space model has no sample period (dt=None); a virtual sensor runs at "
                "a fixed period: build the model with dt"
            )
        self.model = model
        self.theta = th
        self.dt = float(model.dt)
        # operating point: y = y_op + C x + D (u − u_op). In the state x' = x + s with
        # s = (I − A)⁻¹ B u_op the model is x'⁺ = A x' + B u, y = c0 + C x' + D u with the
        # constant c0 = y_op − C s − D u_op, which the observer carries as z0 / y0.
        u_op, y_op = (a[0] for a in model.operating_point(th))
        c0 = np.zeros(len(outs))
        if np.any(u_op != 0) or np.any(y_op != 0):
            try:
                shift = np.linalg.solve(np.eye(A.shape[0]) - A, B @ u_op)
                if not np.isfinite(shift).all():
                    raise np.linalg.LinAlgError
            except np.linalg.LinAlgError:
                raise ConfigError(
                    "the fit's operating point cannot be honoured: the model has an "
                    "integrating mode (I − A singular), so its offsets do not map onto a "
                    "steady state; identify it about a zero operating point"
                ) from None
            c0 = y_op - C @ shift - D @ u_op
        else:
            shift = np.zeros(A.shape[0])
        self._shift = shift
        self.output_constant = dict(zip(outs, c0.tolist(), strict=True))

        meas = _names(measured, "measured")
        for nme in meas:
            if nme not in outs:
                raise UnknownNameError(
                    f"measured channel {nme!r} is not an output of the model; outputs are {outs}"
                )
        if len(set(meas)) != len(meas):
            raise ConfigError(f"measured channels {list(meas)} repeat a name")
        hid = tuple(o for o in outs if o not in meas) if hidden is None else _names(hidden, "")
        for nme in hid:
            if nme not in outs:
                raise UnknownNameError(
                    f"hidden channel {nme!r} is not an output of the model; outputs are {outs}"
                )
            if nme in meas:
                raise ConfigError(f"output {nme!r} is both measured and hidden")
        if not hid:
            raise ConfigError("nothing to estimate: every output is measured; leave one hidden")
        iz = [outs.index(o) for o in meas]
        ih = [outs.index(o) for o in hid]

        # ------------------------------------------------ reference transform
        if reference is not None:
            if reference in exo or reference in outs:
                raise ConfigError(
                    f"reference {reference!r} is already a signal of the model; a reference is "
                    "the signal the model's data were made relative to"
                )
            if referenced is None:
                rel = [s for s in exo + outs if units.get(s) in _TEMPERATURE_UNITS]
                if not rel:
                    raise ConfigError(
                        f"reference {reference!r} given but no model signal has a temperature "
                        "unit; name the relative signals with referenced=[...]"
                    )
            else:
                rel = list(referenced)
                bad = [s for s in rel if s not in exo + outs]
                if bad:
                    raise UnknownNameError(
                        f"referenced signal(s) {bad} are not model signals {exo + outs}"
                    )
            # θ = T − T_ref: B θ_u = B T_u − (Σ_referenced B_j) T_ref; y = θ_y + T_ref
            ju = [exo.index(s) for s in rel if s in exo]
            b_ref = -B[:, ju].sum(axis=1, keepdims=True)
            d_ref = -D[:, ju].sum(axis=1, keepdims=True)
            for s in rel:
                if s in outs:
                    d_ref[outs.index(s), 0] += 1.0
            B = np.hstack([B, b_ref])
            D = np.hstack([D, d_ref])
            exo = [*exo, reference]
            units[reference] = next((units[s] for s in rel if s in units), "°C")
        self.reference = reference

        # ------------------------------------------------ noise model
        n0 = A.shape[0]
        stds = np.array(
            [
                float(measurement_std.get(o, 0.05))  # type: ignore[union-attr]
                if isinstance(measurement_std, Mapping)
                else float(measurement_std)
                for o in outs
            ]
        )
        if (stds <= 0).any() or not np.isfinite(stds).all():
            raise ParameterError(f"measurement_std is {measurement_std!r}; expected > 0")
        if noise is None:
            if model.has_K:
                noise = NoiseModel.from_innovation(mats.K[0], np.diag(stds**2), iz)
            else:
                noise = NoiseModel(
                    _input_referred_q(A, B, C, D, process_std), np.diag(stds[iz] ** 2)
                )
        if noise.n_states != n0 or noise.n_measured != len(iz):
            raise ShapeError(
                f"noise model is for {noise.n_states} states and {noise.n_measured} measured "
                f"channels; the model has {n0} states and {len(iz)} measured"
            )
        Q, R, S = noise.Q, noise.R, noise.S

        # ------------------------------------------------ disturbance states
        dist = _names(disturbance_inputs, "disturbance_inputs")
        for d in dist:
            if d not in exo:
                raise UnknownNameError(
                    f"disturbance input {d!r} is not an exogenous signal; they are {exo}"
                )
        if dist:
            jd = [exo.index(d) for d in dist]
            r = len(jd)
            # x_d[k+1] = x_d[k] + ε (random walk), acting like the input: x⁺ = A x + B_d x_d
            A = np.block([[A, B[:, jd]], [np.zeros((r, n0)), np.eye(r)]])
            B = np.vstack([B, np.zeros((r, B.shape[1]))])
            C = np.hstack([C, D[:, jd]])
            dstd = np.array(
                [
                    float(disturbance_std.get(d, 1.0))  # type: ignore[union-attr]
                    if isinstance(disturbance_std, Mapping)
                    else float(disturbance_std)
                    for d in dist
                ]
            )
            Q = scipy.linalg.block_diag(Q, np.diag(dstd**2))
            S = np.vstack([S, np.zeros((r, S.shape[1]))])
            noise = NoiseModel(Q, R, S)
        self.disturbance_inputs = dist

        self._A, self._B = A, B
        self._Cz, self._Dz = C[iz], D[iz]
        self._Ch, self._Dh = C[ih], D[ih]
        self._z0, self._y0 = c0[iz], c0[ih]
        self.noise = noise
        self.gains = steady_state_gains(A, self._Cz, noise)
        self.exogenous_names = tuple(exo)
        self.measured_names = tuple(meas)
        self.hidden_names = tuple(hid)
        self.units = {k: units.get(k, "1") for k in (*exo, *meas, *hid)}

        chans = (*exo, *meas)
        rng_map = dict(ranges or {})
        unknown = [k for k in rng_map if k not in chans]
        if unknown:
            raise UnknownNameError(
                f"ranges given for {unknown}, which are not exogenous or measured channels "
                f"{list(chans)}"
            )
        lo, hi = np.full(len(chans), -np.inf), np.full(len(chans), np.inf)
        for j, ch in enumerate(chans):
            if ch in rng_map:
                a, b = (float(v) for v in rng_map[ch])
                if not a < b:
                    raise ParameterError(
                        f"range of {ch!r} is ({a!r}, {b!r}); expected lower < upper"
                    )
                lo[j], hi[j] = a, b
            elif self.units[ch] in _TEMPERATURE_UNITS:
                lo[j], hi[j] = -50.0, 300.0  # RTD measurement range, 001 Table 2
        self._lower, self._upper = lo, hi

    # ---------------------------------------------------------------- matrices
    @property
    def n_states(self) -> int:
        """Observer order (model order plus disturbance states)."""
        return int(self._A.shape[0])

    def observer_matrices(self) -> ObserverMatrices:
        """The steady-state observer (what the firmware exports)."""
        g = self.gains
        A, B, Cz, Dz, Ch, Dh = self._A, self._B, self._Cz, self._Dz, self._Ch, self._Dh
        G, F = g.K, Ch @ g.L
        n = A.shape[0]
        # equilibrium of x⁺ = (A − G Cz) x + (B − G Dz) u + G z
        Ao = A - G @ Cz
        N: NDArray[np.float64] | None
        try:
            N = np.linalg.solve(np.eye(n) - Ao, np.hstack([B - G @ Dz, G]))
            if not np.isfinite(N).all() or np.linalg.cond(np.eye(n) - Ao) > 1e12:
                N = None
        except np.linalg.LinAlgError:
            N = None
        if N is None:
            # the model's own equilibrium for u, disturbance states at zero, z unused
            r = len(self.disturbance_inputs)
            nb_ = n - r
            try:
                Xb = np.linalg.solve(np.eye(nb_) - A[:nb_, :nb_], B[:nb_])
                if np.isfinite(Xb).all() and np.linalg.cond(np.eye(nb_) - A[:nb_, :nb_]) < 1e12:
                    N = np.zeros((n, B.shape[1] + Cz.shape[0]))
                    N[:nb_, : B.shape[1]] = Xb
            except np.linalg.LinAlgError:
                N = None
        return ObserverMatrices(
            A.copy(),
            B.copy(),
            G.copy(),
            Cz.copy(),
            Dz.copy(),
            Ch.copy(),
            Dh.copy(),
            F,
            N,
            self.exogenous_names,
            self.measured_names,
            self.hidden_names,
            self._lower.copy(),
            self._upper.copy(),
            self.dt,
            dict(self.units),
            self._z0.copy(),
            self._y0.copy(),
        )

    def step_observer(self) -> SteadyStateObserver:
        """A fresh step-wise steady-state observer (firmware twin, env use)."""
        return SteadyStateObserver(self.observer_matrices())

    def rest_state(self, u: ArrayLike, z: ArrayLike | None = None) -> NDArray[np.float64]:
        """Observer equilibrium for constant readings ``(u, z)``, shape (n,)."""
        return self.observer_matrices().rest_state(u, z)

    # ------------------------------------------------------------------- data
    def arrays(self, data: Any) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Exogenous and measured arrays from a mapping of columns (e.g. a Recording).

        Returns
        -------
        u : ndarray, shape (T, m)
        z : ndarray, shape (T, q)
        """
        need = (*self.exogenous_names, *self.measured_names)
        missing = [c for c in need if c not in data]
        if missing:
            raise UnknownNameError(
                f"data lack column(s) {missing}; the virtual sensor needs exogenous "
                f"{list(self.exogenous_names)} and measured {list(self.measured_names)}"
            )
        cols = [np.asarray(data[c], dtype=float) for c in need]
        T = cols[0].shape[0] if cols else 0
        if any(c.shape != (T,) for c in cols):
            raise ShapeError("columns have different lengths or are not 1-D")
        m = len(self.exogenous_names)
        u = np.column_stack(cols[:m]) if m else np.zeros((T, 0))
        z = np.column_stack(cols[m:]) if len(cols) > m else np.zeros((T, 0))
        return u, z

    def _uz(
        self, u: ArrayLike, z: ArrayLike | None
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        m, q = len(self.exogenous_names), len(self.measured_names)
        ua = np.asarray(u, dtype=float)
        if ua.ndim == 1 and m == 1:
            ua = ua[:, None]
        if ua.ndim != 2 or ua.shape[1] != m:
            raise ShapeError(
                f"u has shape {ua.shape}, expected (T, {m}) with columns "
                f"{list(self.exogenous_names)}"
            )
        T = ua.shape[0]
        if z is None:
            za = np.zeros((T, 0))
        else:
            za = np.asarray(z, dtype=float)
            if za.ndim == 1 and q == 1:
                za = za[:, None]
        if za.shape != (T, q):
            raise ShapeError(
                f"z has shape {za.shape}, expected ({T}, {q}) with columns "
                f"{list(self.measured_names)}"
            )
        if T < 1:
            raise ShapeError("no samples")
        return np.ascontiguousarray(ua), np.ascontiguousarray(za)

    def rest_inputs(
        self, u0: ArrayLike, rest: Mapping[str, float | str] | None = None
    ) -> NDArray[np.float64]:
        """Exogenous sample ``u0`` with the channels named in ``rest`` replaced.

        A record that starts when the machine is switched on has the new speed
        in its first sample but temperatures of a machine at rest; the rest
        state must then be taken with ``rest={"speed": 0.0}``. A value may
        name another exogenous channel: ``{"T_front_outer_housing": "T_amb"}``
        takes the ambient's first sample (a machine at rest is at ambient
        temperature — and a model whose steady state is sensitive to the
        difference of two surface readings does not amplify their noise).
        """
        ua = np.array(u0, dtype=float).reshape(-1)
        first = ua.copy()
        for name, value in (rest or {}).items():
            if name not in self.exogenous_names:
                raise UnknownNameError(
                    f"rest value given for {name!r}, which is not an exogenous channel "
                    f"{list(self.exogenous_names)}"
                )
            if isinstance(value, str):
                if value not in self.exogenous_names:
                    raise UnknownNameError(
                        f"rest value of {name!r} names {value!r}, which is not an exogenous "
                        f"channel {list(self.exogenous_names)}"
                    )
                ua[self.exogenous_names.index(name)] = first[self.exogenous_names.index(value)]
            else:
                ua[self.exogenous_names.index(name)] = float(value)
        return ua

    def _x0(
        self,
        x0: ArrayLike | str | None,
        u: NDArray,
        z: NDArray,
        rest: Mapping[str, float | str] | None = None,
    ) -> NDArray[np.float64]:
        n = self.n_states
        if isinstance(x0, str) and x0 == "zero":
            # at rest at the model's operating point: x = 0, i.e. x' = s (disturbances 0)
            x = np.zeros(n)
            x[: self._shift.size] = self._shift
            return x
        if isinstance(x0, str) and x0 == "estimate":
            return self.estimate_x0(u, z)
        if x0 is None or (isinstance(x0, str) and x0 in ("rest", "steady")):
            u0 = self.rest_inputs(u[0], rest)
            v = np.concatenate([u0, z[0]])
            if not np.isfinite(v).all():
                raise ShapeError(
                    "the first sample has a non-finite channel; the rest state needs a valid "
                    "first sample (trim the data or give x0)"
                )
            return self.rest_state(u0, z[0])
        if isinstance(x0, str):
            raise ConfigError(
                f"x0 is {x0!r}; expected 'steady' (or 'rest'), 'zero', 'estimate' or an array "
                f"of {n} states"
            )
        xa = np.asarray(x0, dtype=float).reshape(-1)
        if xa.shape != (n,):
            raise ShapeError(f"x0 has shape {xa.shape}, expected ({n},)")
        return xa

    def estimate_x0(self, u: ArrayLike, z: ArrayLike | None = None) -> NDArray[np.float64]:
        """Initial state by least squares on the measured channels given the inputs.

        The free response ``z − z0 − z_forced = C_z A^k x0`` over the series
        (NaN samples skipped; :meth:`StateSpaceModel.estimate_x0`);
        unobservable directions get zero. Without measured channels this is
        the rest state.

        Parameters
        ----------
        u : array_like, shape (T, m)
        z : array_like, shape (T, q)

        Returns
        -------
        ndarray, shape (n,)
        """
        ua, za = self._uz(u, z)
        if za.shape[1] == 0:
            return self.rest_state(ua[0], za[0])
        sub = StateSpaceModel.from_matrices(
            self._A,
            self._B,
            self._Cz,
            self._Dz,
            y_op=self._z0,
            inputs=[f"u{j}" for j in range(ua.shape[1])],
            outputs=[f"z{j}" for j in range(za.shape[1])],
        )
        return sub.estimate_x0(ua, za)[0]

    # ---------------------------------------------------------------- running
    def observe(
        self,
        u: ArrayLike,
        z: ArrayLike | None = None,
        *,
        x0: ArrayLike | str | None = "rest",
        rest: Mapping[str, float | str] | None = None,
    ) -> Estimate:
        """Run the steady-state observer over a series (compiled; firmware semantics).

        Parameters
        ----------
        u : array_like, shape (T, m)
            Exogenous channels in :attr:`exogenous_names` order.
        z : array_like, shape (T, q)
            Measured channels in :attr:`measured_names` order.
        x0 : {"steady", "zero", "estimate"} or array_like, shape (n,)
            Initial state: ``"steady"`` (also ``"rest"``, the default) the
            equilibrium at the first sample; ``"zero"`` at rest at the
            model's operating point; ``"estimate"`` least squares on the
            measured channels (:meth:`estimate_x0`).
        rest : mapping, optional
            Exogenous values to take for the rest state instead of the first
            sample's (:meth:`rest_inputs`), e.g. ``{"speed": 0.0}``; a value
            may name another exogenous channel.

        Returns
        -------
        Estimate
            Hidden estimates with the constant steady-state covariance
            ``C_h P[k|k] C_hᵀ``; invalid samples hold the last estimate.
        """
        ua, za = self._uz(u, z)
        M = self.observer_matrices()
        x = self._x0(x0, ua, za, rest)
        T = ua.shape[0]
        n, _, q, p = M.dims
        y = np.empty((T, p))
        xs = np.empty((T, n))
        nus = np.empty((T, q))
        status = np.empty(T, dtype=np.int8)
        y0 = M.Ch @ x + M.Dh @ np.nan_to_num(ua[0])
        # the kernel runs without the constant output terms: z − z0 in, + y0 out (the
        # channel ranges apply to the readings themselves)
        lo, hi = M.lower.copy(), M.upper.copy()
        m = ua.shape[1]
        lo[m:] -= self._z0
        hi[m:] -= self._z0
        _observer_kernel(
            M.A, M.B, M.G, M.Cz, M.Dz, M.Ch, M.Dh, M.F,
            lo, hi, ua, np.ascontiguousarray(za - self._z0), x, y0, y, xs, nus, status,
        )  # fmt: skip
        y += self._y0
        covh = self._Ch @ self.gains.P_post @ self._Ch.T
        return Estimate(
            self.hidden_names,
            y,
            np.broadcast_to(covh, (T, p, p)),
            xs,
            nus,
            np.broadcast_to(self.gains.innovation_cov, (T, q, q)),
            status,
            self.measured_names,
        )

    def kalman_filter(self, x0: ArrayLike, P0: ArrayLike | None = None) -> Any:
        """A filterpy :class:`~filterpy.kalman.KalmanFilter` for this model.

        The cross-covariance ``S`` of the innovation form is removed by the
        usual decorrelation, ``x⁺ = (A − S R⁻¹ C_z) x + (B − S R⁻¹ D_z) u +
        S R⁻¹ z + w̃`` with ``cov w̃ = Q − S R⁻¹ Sᵀ``, so the filter's control
        input is ``[u; z_prev]`` (see :meth:`filter`). ``H = C_z``; the
        measurement passed to ``update`` must have ``D_z u`` subtracted.

        Parameters
        ----------
        x0 : array_like, shape (n,)
        P0 : array_like, shape (n, n), optional
            Default: the steady-state prior covariance.
        """
        n, m, q = self.n_states, len(self.exogenous_names), len(self.measured_names)
        kf = KalmanFilter(dim_x=n, dim_z=max(q, 1), dim_u=m + q)
        R, S = self.noise.R, self.noise.S
        SRi = np.linalg.solve(R, S.T).T if q else np.zeros((n, 0))
        kf.F = self._A - SRi @ self._Cz
        kf.B = np.hstack([self._B - SRi @ self._Dz, SRi])
        Qt = self.noise.Q - SRi @ S.T
        kf.Q = 0.5 * (Qt + Qt.T)
        if q:
            kf.H = self._Cz.copy()
            kf.R = R.copy()
        kf.x = np.asarray(x0, dtype=float).reshape(n, 1).copy()
        kf.P = np.array(self.gains.P if P0 is None else P0, dtype=float).reshape(n, n)
        return kf

    def filter(
        self,
        u: ArrayLike,
        z: ArrayLike | None = None,
        *,
        x0: ArrayLike | str | None = "rest",
        P0: ArrayLike | None = None,
        rest: Mapping[str, float | str] | None = None,
    ) -> Estimate:
        """Run the time-varying Kalman filter (filterpy) over a series.

        Missing measured samples (NaN) are skipped channel by channel (the
        update uses the available rows of ``C_z``, ``R`` and ``S``); the
        exogenous channels must be finite. The covariance update is
        filterpy's Joseph form.

        Parameters
        ----------
        u : array_like, shape (T, m)
        z : array_like, shape (T, q)
        x0 : {"steady", "zero", "estimate"} or array_like, shape (n,)
            As :meth:`observe`.
        P0 : array_like, shape (n, n), optional
            Initial prior covariance; the steady-state one by default (the
            filter then equals :meth:`observe` when no sample is missing).
        rest : mapping, optional
            As :meth:`observe`.

        Returns
        -------
        Estimate
        """
        ua, za = self._uz(u, z)
        if not np.isfinite(ua).all():
            k = int(np.argwhere(~np.isfinite(ua))[0][0])
            raise ShapeError(
                f"exogenous channel is not finite at sample {k}; the Kalman filter needs every "
                "exogenous sample (prepare the data), missing measurements are fine"
            )
        keep_nan = isinstance(x0, str) and x0 == "estimate"
        x = self._x0(x0, ua, za if keep_nan else np.nan_to_num(za), rest)
        kf = self.kalman_filter(x, P0)
        T = ua.shape[0]
        n, m, q, p = self.n_states, ua.shape[1], za.shape[1], len(self.hidden_names)
        R, S, Q = self.noise.R, self.noise.S, self.noise.Q
        cache: dict[bytes, tuple[Any, ...]] = {}

        def pattern(ok: NDArray[np.bool_]) -> tuple[Any, ...]:
            key = ok.tobytes()
            hit = cache.get(key)
            if hit is None:
                idx = np.flatnonzero(ok)
                Ra = R[np.ix_(idx, idx)]
                Sa = S[:, idx]
                SRi = np.linalg.solve(Ra, Sa.T).T if idx.size else np.zeros((n, 0))
                F = self._A - SRi @ self._Cz[idx]
                Bf = np.zeros((n, m + q))
                Bf[:, :m] = self._B - SRi @ self._Dz[idx]
                Bf[:, m + idx] = SRi
                Qt = Q - SRi @ Sa.T
                hit = (idx, Ra, self._Cz[idx], F, Bf, 0.5 * (Qt + Qt.T))
                cache[key] = hit
            return hit

        xs = np.empty((T, n))
        y = np.empty((T, p))
        cov = np.empty((T, p, p))
        nus = np.full((T, q), np.nan)
        sig = np.full((T, q, q), np.nan)
        status = np.zeros(T, dtype=np.int8)
        for k in range(T):
            ok = np.isfinite(za[k])
            idx, Ra, Ha, F, Bf, Qt = pattern(ok)
            if idx.size:
                zk = (za[k, idx] - self._z0[idx] - self._Dz[idx] @ ua[k]).reshape(-1, 1)
                kf.update(zk, R=Ra, H=Ha)
                nus[k, idx] = kf.y.reshape(-1)
                sig[k][np.ix_(idx, idx)] = kf.S
            else:
                if q:
                    status[k] = ObserverStatus.NOT_FINITE
                kf.update(None)
            xk = kf.x.reshape(-1)
            xs[k] = xk
            y[k] = self._y0 + self._Ch @ xk + self._Dh @ ua[k]  # ŷ[k|k] = y0 + C_h x̂ + D_h u
            cov[k] = self._Ch @ kf.P @ self._Ch.T
            uz = np.concatenate([ua[k], np.where(ok, za[k] - self._z0, 0.0)]).reshape(-1, 1)
            # x⁺ = F̃ x + B̃ [u; z],  P⁺ = F̃ P F̃ᵀ + Q̃
            kf.predict(u=uz, B=Bf, F=F, Q=Qt)
        return Estimate(self.hidden_names, y, cov, xs, nus, sig, status, self.measured_names)

    def estimate(self, data: Any, *, method: str = "kalman", **kwargs: Any) -> Estimate:
        """Estimate from a mapping of columns (a Recording): ``filter`` or ``observe``."""
        u, z = self.arrays(data)
        if method == "kalman":
            return self.filter(u, z, **kwargs)
        if method == "observer":
            return self.observe(u, z, **kwargs)
        raise ConfigError(f"method is {method!r}; expected 'kalman' or 'observer'")

    def at_period(self, period: float) -> VirtualSensor:
        """The same sensor sampled every ``period`` = k · dt (inputs held over it).

        For an environment whose control period is a multiple of the model's
        sample period: ``A_k = A^k``, ``B_k = Σ_{i<k} A^i B`` (exact for a held
        input), ``Q_k = Σ_{i<k} A^i Q A^iᵀ``, ``S_k = A^{k−1} S``; the gains
        are recomputed for the slower measurements.

        Parameters
        ----------
        period : float
            New sample period [s], an integer multiple of :attr:`dt`.

        Returns
        -------
        VirtualSensor
        """
        r = period / self.dt
        k = round(r)
        if not (np.isfinite(r) and k >= 1 and abs(r - k) <= 1e-9 * max(r, 1.0)):
            raise ParameterError(
                f"period {period!r} s is not an integer multiple of the model's dt = {self.dt!r} s"
            )
        if k == 1:
            return self
        n, m = self._B.shape
        E = np.zeros((n + m, n + m))
        E[:n, :n], E[:n, n:], E[n:, n:] = self._A, self._B, np.eye(m)
        Ek = np.linalg.matrix_power(E, k)
        Qk = _lyapunov_sum(self._A, self.noise.Q, k)
        Sk = np.linalg.matrix_power(self._A, k - 1) @ self.noise.S
        new = object.__new__(VirtualSensor)
        new.__dict__.update(self.__dict__)
        new._A, new._B = Ek[:n, :n], Ek[:n, n:]
        new.dt = float(period)
        noise = NoiseModel(0.5 * (Qk + Qk.T), self.noise.R, Sk)
        new.noise = noise
        new.gains = steady_state_gains(new._A, new._Cz, noise)
        return new

    # ----------------------------------------------------------------- tuning
    def with_noise(self, noise: NoiseModel) -> VirtualSensor:
        """A copy of this sensor with another noise model (same model and channels)."""
        new = object.__new__(VirtualSensor)
        new.__dict__.update(self.__dict__)
        if noise.n_states != self.n_states or noise.n_measured != len(self.measured_names):
            raise ShapeError(
                f"noise model is for {noise.n_states} states / {noise.n_measured} measured; "
                f"the sensor has {self.n_states} / {len(self.measured_names)}"
            )
        new.noise = noise
        new.gains = steady_state_gains(self._A, self._Cz, noise)
        return new

    def tuned(
        self,
        u: ArrayLike,
        z: ArrayLike | None = None,
        *,
        hidden_truth: ArrayLike | None = None,
        truth_std: float | Sequence[float] = 0.0,
        rest: Mapping[str, float | str] | None = None,
        bounds: tuple[float, float] = (1e-6, 1e8),
        discard: int = 0,
    ) -> tuple[VirtualSensor, float]:
        """Scale the process noise until the filter is consistent on calibration data.

        A consistent filter's NIS averages the number of measured channels and
        its NEES the number of estimated ones (Bar-Shalom et al., *Estimation
        with Applications to Tracking and Navigation*, 5.4). A single factor
        ``α`` on ``Q`` (and ``S``) is searched on a log scale so that the mean
        NEES of the hidden estimates equals their number when ``hidden_truth``
        is given (identification data record the internal temperatures), else
        the mean NIS equals the number of measured channels. Use training
        data, never the held-out runs.

        Parameters
        ----------
        u, z : array_like
            Calibration series (exogenous, measured).
        hidden_truth : array_like, shape (T, p), optional
            The hidden signals recorded on the calibration data.
        truth_std : float or sequence of float
            Noise std of the recorded hidden signals [their unit]; added to the
            estimate's covariance in the NEES (the recording is not the truth).
        rest : mapping, optional
            Rest-state inputs at the start (:meth:`observe`).
        bounds : (float, float)
            Search range of ``α``.
        discard : int
            Leading samples left out of the mean (start-up transient).

        Returns
        -------
        sensor : VirtualSensor
            The tuned copy.
        alpha : float
            The factor found.
        """
        q = len(self.measured_names)
        ua, za = self._uz(u, z)
        truth = None
        if hidden_truth is not None:
            truth = np.asarray(hidden_truth, dtype=float)
            if truth.ndim == 1:
                truth = truth[:, None]
            if truth.shape != (ua.shape[0], len(self.hidden_names)):
                raise ShapeError(
                    f"hidden_truth has shape {truth.shape}, expected "
                    f"({ua.shape[0]}, {len(self.hidden_names)}) for {list(self.hidden_names)}"
                )
        elif q == 0:
            raise ConfigError(
                "nothing is measured, so the NIS is undefined: give hidden_truth (the recorded "
                "hidden signals of the calibration data) to tune on the NEES"
            )
        dof = len(self.hidden_names) if truth is not None else q
        tstd = np.broadcast_to(np.asarray(truth_std, dtype=float), (len(self.hidden_names),))
        extra = np.diag(tstd**2)

        def mean_stat(log_a: float) -> float:
            try:
                s = self.with_noise(self.noise.scaled(process=math.exp(log_a)))
            except ParameterError:
                return math.inf
            est = s.observe(ua, za, rest=rest)
            v = est.nees(truth, extra) if truth is not None else est.nis()
            return float(np.nanmean(v[int(discard) :]))

        def objective(log_a: float) -> float:
            m = mean_stat(log_a)
            return math.log(m / dof) ** 2 if np.isfinite(m) and m > 0 else 1e6

        lo, hi = (math.log(b) for b in bounds)
        res = scipy.optimize.minimize_scalar(objective, bounds=(lo, hi), method="bounded")
        alpha = math.exp(float(res.x))
        return self.with_noise(self.noise.scaled(process=alpha)), alpha

    def __repr__(self) -> str:
        return (
            f"<VirtualSensor n={self.n_states}: exogenous {list(self.exogenous_names)}, measured "
            f"{list(self.measured_names)}, hidden {list(self.hidden_names)}, dt={self.dt:g} s>"
        )
