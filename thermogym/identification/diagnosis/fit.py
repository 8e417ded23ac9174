"""Fitting for diagnosis: experiments, initial states, the nominal model, least squares.

Every model the diagnosis fits — the nominal model and each augmented
candidate — goes through :func:`fit_model`: bounded nonlinear least squares
(a projected Levenberg-Marquardt, see :func:`_projected_lm`) on the
simulation error of every fitted output in every training recording, with

* outputs weighted by the inverse of their spread in the training data (each
  output counts like its NRMSE, eq 5 of ``001_6d13a2cd04f5de5e.txt``), so a
  stroke in mm and a power in W are comparable;
* parameters scaled to their bounds (``s = (θ − lower)/(upper − lower)``);
* Jacobians by forward differences, all columns simulated in **one batched
  call** of the model (the batch dimension of :class:`thermogym.models.base.Model`);
* standard errors from the Jacobian (sandwich form of
  :func:`thermogym.identification.uncertainty.covariance_from_jacobian`).

This is the one place a fit happens, so the identification coordinator of
``thermogym.identification`` (``identify(problem, method=...)``) can replace
it later without touching the rest of the diagnosis.

The *nominal model* of a thermogym plant for diagnosis (:data:`NOMINAL_SPECS`)
is the structure an engineer would fit before suspecting missing physics:

* ``axt211`` — the paper-002 grey-box model with every parameter free except
  the stroke (4.5 mm, a specification) and the backlash, which is held at
  zero as when the paper fits the thermal and mechanical sub-models; a play in
  the linkage is then a hypothesis to test, not a nominal parameter;
* ``strut`` — the 19-node network with the five ratio parameters of paper
  000's appendix in their uncertainty ranges (losses 0.3-3, convection
  0.8-1.3): the physical estimates bound what the ratios may absorb;
* ``spindle`` — the white-box network with the parameters a drawing does not
  fix free within their bounds: the bearing and belt losses, the housing
  capacities, the bearing-seat and inner-outer housing conductances and the
  housing's conductance to the air (shaft, bearing and end capacities and the
  axial conductances follow from geometry and stay at their estimates).

Initial states: recordings rarely start exactly at rest (paper 000: the drive
"had not fully cooled down"). With ``x0="estimate"`` (the default) each
measured temperature state may start off its rest value: the deviations are a
nuisance, estimated by weighted least squares on the free responses over the
first 5 % of each recording (so a warm start is absorbed but a persistent
error is not); in a thermal network a deviation of a measured node spreads to
the unmeasured ones as the steady temperatures it imposes without heat input
(a harmonic interpolation over the conductances, eq 13 of paper 000 with zero
sources). ``x0="measured"`` starts exactly at the first measured values,
``x0="rest"`` at the model's rest state, and ``x0="initial"`` (generic
FOPTD / state-space models, paper 000 section 4.1) shifts each output to start
at its first measured value: the model predicts deviations from the operating
point the recording starts at.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from thermogym.errors import IdentificationError, RecordingError, ShapeError
from thermogym.models.base import Model
from thermogym.recording import Recording

__all__ = [
    "NOMINAL_SPECS",
    "Experiment",
    "FitOutcome",
    "FitProblem",
    "decimate",
    "fit_model",
    "initial_states",
    "prepare_experiments",
]

#: Diagnosis nominal model of each thermogym plant: fixed values and free parameters.
NOMINAL_SPECS: dict[str, dict[str, Any]] = {
    "axt211": {"fixed": {"c_backlash": 0.0, "x_max": 4.5}, "x0": "estimate"},
    "strut": {
        "free": ["r_motor", "r_bearing", "r_nut", "r_spindle_air", "r_tube_air"],
        "x0": "estimate",
    },
    "spindle": {
        "free": ["q_rear", "q_front", "q_belt", "C_inner", "C_outer", "G_bh", "G_io", "g_outer"],
        "x0": "estimate",
    },
    "room": {"x0": "estimate"},
    "tclab": {"x0": "estimate"},
}

_TEMPERATURE_UNITS = ("°C", "K", "degC")
#: Share of a recording's first samples that decides its initial state (policy "estimate").
_X0_WINDOW = 0.05


# ------------------------------------------------------------------ experiments
@dataclass
class Experiment:
    """One recording prepared for a model: uniform grid, arrays in model order.

    Attributes
    ----------
    recording : Recording
        The (possibly resampled) recording.
    dt : float
        Sample period [s].
    u : ndarray, shape (T, n_u)
        Exogenous signals in ``model.exogenous_names`` order.
    y : ndarray, shape (T, n_y)
        Measured outputs in the order of the fitted outputs (NaN where missing).
    outputs : tuple of str
    notes : list of str
        What was done to the recording (resampling, decimation).
    """

    recording: Recording
    dt: float
    u: NDArray[np.float64]
    y: NDArray[np.float64]
    outputs: tuple[str, ...]
    notes: list[str] = field(default_factory=list)

    @property
    def name(self) -> str:
        """Experiment id, or ``"recording"``."""
        return self.recording.experiment_id or "recording"

    @property
    def time(self) -> NDArray[np.float64]:
        """Sample times [s]."""
        return self.recording.time

    @property
    def n(self) -> int:
        """Number of samples."""
        return int(self.u.shape[0])


def decimate(rec: Recording, dt: float, exogenous: Sequence[str]) -> Recording:
    """Average a uniform recording onto a coarser grid of period ``dt``.

    Exogenous columns are averaged over ``[t_k, t_k + Δ)`` (what a model holds
    constant over the interval, zero-order hold); outputs are taken at ``t_k``
    (point samples: an average would smear outputs that jump with the input,
    such as a heater's power, and would hide the sensor's own noise level).
    The period must be a whole multiple of the recording's.

    Parameters
    ----------
    rec : Recording
        Uniformly sampled.
    dt : float
        New period [s].
    exogenous : sequence of str
        Columns averaged forwards.

    Returns
    -------
    Recording

    Raises
    ------
    RecordingError
        ``dt`` is not a whole multiple of the recording's period.

    Examples
    --------
    >>> import numpy as np
    >>> rec = Recording(np.arange(10.0), {"u": np.arange(10.0), "y": np.arange(10.0)})
    >>> d = decimate(rec, 2.0, ["u"])
    >>> d.time.tolist(), d["u"].tolist(), d["y"].tolist()
    ([0.0, 2.0, 4.0, 6.0, 8.0], [0.5, 2.5, 4.5, 6.5, 8.5], [0.0, 2.0, 4.0, 6.0, 8.0])
    """
    src = rec.dt
    f = dt / src
    m = round(f)
    if m < 1 or abs(f - m) > 1e-6 * f:
        raise RecordingError(
            f"cannot decimate recording {rec.experiment_id!r} from {src!r} s to {dt!r} s: the new "
            "period must be a whole multiple of the old"
        )
    if m == 1:
        return rec
    n = rec.n_samples // m
    if n < 2:
        raise RecordingError(
            f"recording {rec.experiment_id!r} ({rec.n_samples} samples) is too short for a "
            f"period of {dt!r} s"
        )
    cols: dict[str, NDArray[np.float64]] = {}
    for name in rec.columns:
        x = np.asarray(rec[name], dtype=float)
        if name in exogenous:
            cols[name] = np.nanmean(x[: n * m].reshape(n, m), axis=1)
        else:
            cols[name] = x[: n * m : m].copy()
    t = rec.time[: n * m : m]
    meta = {**rec.meta, "decimated_from_s": src}
    return Recording(
        t,
        cols,
        units=dict(rec.units),
        roles=dict(rec.roles),
        experiment_id=rec.experiment_id,
        source=rec.source,
        meta=meta,
    )


def _uniform(rec: Recording, notes: list[str]) -> Recording:
    if rec.n_samples < 2:
        raise RecordingError(f"recording {rec.experiment_id!r} has a single sample")
    if rec.is_uniform():
        return rec
    d = np.diff(rec.time)
    step = float(np.median(d))
    if float(d.max()) > 3 * step:
        raise RecordingError(
            f"recording {rec.experiment_id!r} has gaps (largest step {float(d.max())!r} s, median "
            f"{step!r} s); prepare it first (thermogym.identification.prepare)"
        )
    try:
        from thermogym.identification.prepare import resample

        out, _ = resample(rec, step, t_start=float(rec.time[0]))
    except ImportError:  # pragma: no cover - the preparation module is part of the package
        t = rec.time[0] + step * np.arange(math.floor(rec.duration / step) + 1)
        out = Recording(
            t,
            {c: np.interp(t, rec.time, rec[c]) for c in rec.columns},
            units=dict(rec.units),
            roles=dict(rec.roles),
            experiment_id=rec.experiment_id,
            source=rec.source,
            meta=rec.meta,
        )
    notes.append(
        f"{rec.experiment_id}: steps {float(d.min()):.4g}-{float(d.max()):.4g} s resampled onto "
        f"a uniform {step:.4g} s grid (linear interpolation)"
    )
    return out


def prepare_experiments(
    model: Model,
    recordings: Sequence[Recording],
    outputs: Sequence[str],
    *,
    dt: float | None = None,
    what: str = "training",
    deviation: Sequence[str] = (),
) -> list[Experiment]:
    """Check recordings against a model and bring them onto uniform grids.

    Parameters
    ----------
    model : Model
    recordings : sequence of Recording
    outputs : sequence of str
        Outputs to compare; each must be a model output and a column.
    dt : float, optional
        Decimate to this period [s] (a whole multiple of the recording's).
    what : str
        ``"training"`` or ``"validation"`` (for messages).
    deviation : sequence of str
        Exogenous columns given to the model as deviations from their first
        value (disturbances of a generic linear model: its operating point).

    Returns
    -------
    list of Experiment

    Raises
    ------
    RecordingError
        Missing columns (named, with what the model expects), non-finite
        exogenous samples, gaps, a recording too short.
    """
    out: list[Experiment] = []
    for i, rec in enumerate(recordings):
        if not isinstance(rec, Recording):
            raise RecordingError(
                f"{what} item {i} is a {type(rec).__name__}; expected a Recording "
                "(read files with thermogym.recording.read_recording)"
            )
        rec.validate_for(model, outputs=list(outputs))
        rec.check_values(list(model.exogenous_names))
        notes: list[str] = []
        r = _uniform(rec, notes)
        if dt is not None and abs(dt - r.dt) > 1e-9 * dt:
            r = decimate(r, float(dt), model.exogenous_names)
            notes.append(f"{rec.experiment_id}: averaged onto a {dt:g} s grid")
        u = r.exogenous_array(model)
        for c in deviation:
            j = list(model.exogenous_names).index(c)
            u[:, j] -= u[0, j]
        if not np.isfinite(u).all():
            raise RecordingError(
                f"{what} recording {rec.experiment_id!r}: exogenous signals hold NaN after "
                "resampling; prepare the recording first"
            )
        y = np.column_stack([np.asarray(r[o], dtype=float) for o in outputs])
        out.append(Experiment(r, r.dt, u, y, tuple(outputs), notes))
    return out


# ------------------------------------------------------------------ initial states
def _network_x0(
    model: Any, theta: NDArray[np.float64], u0: NDArray[np.float64], first: Mapping[str, float]
) -> NDArray[np.float64] | None:
    from thermogym.models.fastnet import SwitchedNetwork
    from thermogym.models.thermal_network import ThermalNetworkModel, network_matrices

    if isinstance(model, SwitchedNetwork):
        model = model.plant
    if not isinstance(model, ThermalNetworkModel):
        return None
    net = model.arrays(theta)
    H = net.H
    measured: dict[int, float] = {}
    names = list(model.output_names)
    for j, name in enumerate(names):
        if name not in first or not math.isfinite(first[name]):
            continue
        row = H[j]
        nz = np.flatnonzero(row)
        if nz.size == 1 and row[nz[0]] == 1.0 and net.h0[0, j] == 0.0:
            measured[int(nz[0])] = float(first[name])
    x = model.initial_state(theta, u0)
    if not measured:
        return x
    A, Bm = network_matrices(net)
    n = A.shape[1]
    Mi = np.array(sorted(measured))
    Ui = np.array([i for i in range(n) if i not in measured])
    xm = np.array([measured[i] for i in Mi])
    for b in range(x.shape[0]):
        x[b, Mi] = xm
        if Ui.size:
            # steady state of the unmeasured nodes with the measured ones held and no heat input
            rhs = -(A[b][np.ix_(Ui, Mi)] @ xm + Bm[b, Ui, -1] * u0[b, -1])
            x[b, Ui] = np.linalg.solve(A[b][np.ix_(Ui, Ui)], rhs)
    return x


def initial_states(
    model: Model,
    theta: NDArray[np.float64],
    u0: NDArray[np.float64],
    first: Mapping[str, float] | None,
    policy: str = "rest",
) -> NDArray[np.float64]:
    """Initial states of a parameter batch under an initial-state policy.

    Parameters
    ----------
    model : Model
    theta : ndarray, shape (B, P)
    u0 : ndarray, shape (B, n_u)
        Exogenous signals at the first sample.
    first : mapping, optional
        First measured value of each output.
    policy : {"rest", "measured"}
        ``rest``: the model's own initial state; ``measured``: measured
        temperature states start at their measured values (see the module
        docstring).

    Returns
    -------
    ndarray, shape (B, n_x)
    """
    from thermogym.models.augmented import AugmentedModel

    if isinstance(model, AugmentedModel):
        nb = len(model.base.parameters)
        xb = initial_states(model.base, theta[:, :nb], u0, first, policy)
        return model.augment_state(xb, theta, u0)
    if policy == "rest" or not first:
        return model.initial_state(theta, u0)
    x = _network_x0(model, theta, u0, first)
    if x is not None:
        return x
    x = model.initial_state(theta, u0)
    units = {s.name: s.unit for s in model.signals}
    for name, v in first.items():
        if name in model.state_names and units.get(name) in _TEMPERATURE_UNITS and math.isfinite(v):
            x[:, model.state_names.index(name)] = v
    return x


def initial_directions(
    model: Model, theta: NDArray[np.float64], u0: NDArray[np.float64], outputs: Sequence[str]
) -> NDArray[np.float64] | None:
    """Unit initial-state deviations (n_dir, n_x) of the measured temperature states.

    In a thermal network a deviation of one measured node spreads to the
    unmeasured ones as the steady field it imposes (harmonic interpolation);
    elsewhere it is a unit vector of a temperature state that is an output
    (or, for a FOPTD set, of the first lag of each output).
    """
    from thermogym.models.augmented import AugmentedModel
    from thermogym.models.fastnet import ExtraNodeNetwork, SwitchedNetwork
    from thermogym.models.linear import FOPTDModel
    from thermogym.models.thermal_network import ThermalNetworkModel

    if isinstance(model, SwitchedNetwork):
        model = model.plant
    if isinstance(model, ExtraNodeNetwork):
        nb = len(model.plant.parameters)
        d = initial_directions(model.plant, theta[:, :nb], u0, outputs)
        return None if d is None else np.column_stack([d, np.zeros(d.shape[0])])
    if isinstance(model, AugmentedModel):
        nb = len(model.base.parameters)
        d = initial_directions(model.base, theta[:, :nb], u0, outputs)
        if d is None:
            return None
        full = np.zeros((d.shape[0], len(model.state_names)))
        full[:, : d.shape[1]] = d
        return full
    units = {s.name: s.unit for s in model.signals}
    temp = [o for o in outputs if units.get(o) in _TEMPERATURE_UNITS]
    if isinstance(model, ThermalNetworkModel):
        x_rest = model.initial_state(theta, u0)
        dirs = []
        ref = {o: float(x_rest[0, 0]) for o in temp}
        base = _network_x0(model, theta, u0, ref)
        for o in temp:
            bumped = dict(ref)
            bumped[o] = ref[o] + 1.0
            x = _network_x0(model, theta, u0, bumped)
            if base is not None and x is not None and np.any(x[0] != base[0]):
                dirs.append(x[0] - base[0])
        return np.array(dirs) if dirs else None
    if isinstance(model, FOPTDModel):
        dirs = []
        m = len(model.exogenous_names)
        for o in outputs:
            j = list(model.output_names).index(o)
            d = np.zeros(len(model.state_names))
            d[j * m] = 1.0
            dirs.append(d)
        return np.array(dirs)
    dirs = []
    for o in temp:
        if o in model.state_names:
            d = np.zeros(len(model.state_names))
            d[model.state_names.index(o)] = 1.0
            dirs.append(d)
    return np.array(dirs) if dirs else None


# ------------------------------------------------------------------ least squares
@dataclass
class FitProblem:
    """What :func:`fit_model` fits: a model, its free parameters, data and weights.

    Parameters
    ----------
    model : Model
    free : sequence of str
        Parameters varied.
    base : ndarray, shape (P,)
        Values of every parameter (the free ones are the start).
    lower, upper : ndarray, shape (k,)
        Bounds of the free parameters (finite).
    experiments : sequence of Experiment
    weights : ndarray, shape (n_y,)
        Weight of each fitted output (1 / its spread).
    x0 : str
        Initial-state policy (see :func:`initial_states`).
    """

    model: Model
    free: tuple[str, ...]
    base: NDArray[np.float64]
    lower: NDArray[np.float64]
    upper: NDArray[np.float64]
    experiments: Sequence[Experiment]
    weights: NDArray[np.float64]
    x0: str = "rest"
    n_sims: int = 0

    def __post_init__(self) -> None:
        self.free = tuple(self.free)
        self._cols = np.array([self.model.param_index(p) for p in self.free], dtype=np.int64)
        self.lower = np.asarray(self.lower, dtype=float)
        self.upper = np.asarray(self.upper, dtype=float)
        if not (np.isfinite(self.lower).all() and np.isfinite(self.upper).all()):
            raise IdentificationError(
                f"parameters {list(self.free)} need finite bounds to be fitted"
            )
        self._out_idx = [
            np.array([self.model.output_names.index(o) for o in e.outputs])
            for e in self.experiments
        ]
        if self.x0 not in ("rest", "measured", "estimate", "initial"):
            raise IdentificationError(
                f"initial-state policy {self.x0!r}; expected 'rest', 'measured', 'estimate' or "
                "'initial'"
            )
        # experiments of equal length and period are simulated in one batch
        keys: dict[tuple[int, float], list[int]] = {}
        for i, e in enumerate(self.experiments):
            keys.setdefault((e.n, round(e.dt, 9)), []).append(i)
        self._groups = list(keys.values())
        self._phi: list[NDArray[np.float64] | None] = [None] * len(self.experiments)
        if self.x0 == "estimate":
            for i in range(len(self.experiments)):
                self._phi[i] = self._free_responses(i)

    def _free_responses(self, i: int) -> NDArray[np.float64] | None:
        """Output response (T, n_y, n_dir) to unit initial deviations of the measured states."""
        e = self.experiments[i]
        first = self._off_rest(i)
        dirs = initial_directions(self.model, self.base[None], e.u[:1], first)
        if dirs is None or dirs.shape[0] == 0:
            return None
        n = dirs.shape[0]
        th = np.repeat(self.base[None], n + 1, axis=0)
        u0 = np.repeat(e.u[:1], n + 1, axis=0)
        x_rest = initial_states(self.model, th[:1], u0[:1], None, "rest")
        x0 = np.repeat(x_rest, n + 1, axis=0)
        x0[1:] += dirs
        try:
            sim = self.model.simulate(e.u, e.dt, th, x0, t0=float(e.time[0]), strict=True)
        except Exception:
            return None
        y = sim.outputs[:, :, self._out_idx[i]]
        return np.moveaxis(y[1:] - y[:1], 0, -1)  # (T, n_y, n_dir), per unit deviation

    def _off_rest(self, i: int) -> list[str]:
        """Outputs whose first sample is off the rest state by more than the noise allows."""
        from thermogym.identification.diagnosis.residuals import noise_sigma
        from thermogym.models.linear import FOPTDModel

        e = self.experiments[i]
        base = getattr(self.model, "base", self.model)
        if isinstance(base, FOPTDModel):
            return list(e.outputs)  # a FOPTD set has no rest level before its offsets are fitted
        th = self.base[None]
        x = initial_states(self.model, th, e.u[:1], None, "rest")
        y0 = self.model.output(x, e.u[:1], th)[0, self._out_idx[i]]
        out = []
        for j, o in enumerate(e.outputs):
            sig = noise_sigma(e.y[:, j])
            k = min(3, e.n)
            first = float(np.nanmean(e.y[:k, j]))
            if math.isfinite(sig) and abs(first - y0[j]) > 4.0 * max(sig, 1e-12):
                out.append(o)
        return out

    def correct(self, yh: NDArray[np.float64], i: int) -> NDArray[np.float64]:
        """Apply the initial-state policy to simulated outputs.

        ``estimate``: add the least-squares initial-state response; ``initial``:
        shift each output so that it starts at the recording's first value (the
        operating point of paper 000, section 4.1: outputs are deviations from
        the initial temperatures).
        """
        if self.x0 == "initial":
            y0 = self.experiments[i].y[0]
            shift = np.where(np.isfinite(y0)[None], y0[None] - yh[:, 0], 0.0)
            return yh + shift[:, None, :]
        phi = self._phi[i]
        if phi is None:
            return yh
        e = self.experiments[i]
        w = self.weights[None, :]
        # only the first samples decide the initial state: over the whole record the slow free
        # responses would act as extra basis functions and absorb model error
        W = max(3, math.ceil(_X0_WINDOW * e.n))
        ok = np.isfinite(e.y[:W])
        A = (phi[:W] * w[:, :, None])[ok]  # (n_valid, n_dir)
        out = np.array(yh, copy=True)
        R = ((e.y[None, :W] - yh[:, :W]) * w[None])[:, ok]  # (B, n_valid)
        good = np.isfinite(R).all(axis=1)
        if not good.any():
            return out
        # δ = argmin ‖W (y − ŷ − Φ δ)‖² over the first samples (initial state as a nuisance)
        D, *_ = np.linalg.lstsq(A, R[good].T, rcond=None)  # (n_dir, B_good)
        out[good] += np.einsum("tyd,db->bty", phi, D)
        return out

    def theta(self, z: NDArray[np.float64]) -> NDArray[np.float64]:
        """Full parameter batch (B, P) from free values (B, k)."""
        z = np.atleast_2d(z)
        th = np.repeat(self.base[None], z.shape[0], axis=0)
        th[:, self._cols] = z
        return th

    def simulate(self, theta: NDArray[np.float64], i: int) -> NDArray[np.float64]:
        """Outputs (B, T, n_fit) of experiment ``i``; NaN rows for failed sets."""
        e = self.experiments[i]
        first = {o: float(e.y[0, j]) for j, o in enumerate(e.outputs)}
        B = theta.shape[0]
        u0 = np.repeat(e.u[:1], B, axis=0)
        self.n_sims += B
        try:
            policy = "rest" if self.x0 in ("estimate", "initial") else self.x0
            x0 = initial_states(self.model, theta, u0, first, policy)
            sim = self.model.simulate(e.u, e.dt, theta, x0, t0=float(e.time[0]), strict=False)
            return self.correct(sim.outputs[:, :, self._out_idx[i]], i)
        except Exception:
            if B == 1:
                return np.full((1, e.n, len(e.outputs)), np.nan)
            # one bad set must not spoil the others: simulate them one by one
            return np.concatenate([self.simulate(theta[b : b + 1], i) for b in range(B)])

    def simulate_group(self, theta: NDArray[np.float64], group: Sequence[int]) -> list:
        """Outputs of several experiments of equal length and period in one batched call.

        The parameter sets are repeated per experiment (batch index ``b G + g``),
        so the model's kernel sees one large batch (and runs it in parallel
        where it can) instead of ``G`` small ones.
        """
        if len(group) == 1:
            return [self.simulate(theta, group[0])]
        B, G = theta.shape[0], len(group)
        exps = [self.experiments[i] for i in group]
        try:
            th = np.repeat(theta, G, axis=0)
            u = np.stack([e.u for e in exps])  # (G, T, m)
            ub = np.tile(u, (B, 1, 1))
            policy = "rest" if self.x0 in ("estimate", "initial") else self.x0
            x0 = np.empty((B * G, len(self.model.state_names)))
            for g, e in enumerate(exps):
                first = {o: float(e.y[0, j]) for j, o in enumerate(e.outputs)}
                x0[g::G] = initial_states(
                    self.model, theta, np.repeat(e.u[:1], B, axis=0), first, policy
                )
            sim = self.model.simulate(
                ub, exps[0].dt, th, x0, t0=float(exps[0].time[0]), strict=False
            )
            self.n_sims += B * G
        except Exception:  # one experiment at a time (it handles failures per set)
            return [self.simulate(theta, i) for i in group]
        return [
            self.correct(sim.outputs[g::G][:, :, self._out_idx[i]], i) for g, i in enumerate(group)
        ]

    def residuals(self, theta: NDArray[np.float64]) -> NDArray[np.float64]:
        """Weighted residual vectors (B, N) over every experiment (NaN-free)."""
        parts: list[NDArray[np.float64] | None] = [None] * len(self.experiments)
        for group in self._groups:
            for i, yh in zip(group, self.simulate_group(theta, group), strict=True):
                parts[i] = self._weighted(yh, i)
        return np.concatenate(parts, axis=1)  # type: ignore[arg-type]

    def _weighted(self, yh: NDArray[np.float64], i: int) -> NDArray[np.float64]:
        e = self.experiments[i]
        r = (yh - e.y[None]) * self.weights[None, None, :]
        r = np.where(np.isfinite(e.y)[None], r, 0.0)
        bad = ~np.isfinite(r).all(axis=(1, 2))
        r[bad] = 1e3  # a failed simulation: a large, flat penalty
        return r.reshape(r.shape[0], -1)


@dataclass
class FitOutcome:
    """Result of :func:`fit_model`.

    Attributes
    ----------
    theta : ndarray, shape (P,)
        Every parameter at the optimum.
    free : tuple of str
    values : dict
        Free parameter → value.
    stderr : dict
        Free parameter → standard error (NaN where not identifiable).
    covariance : ndarray or None
    cost : float
        ``½ Σ r²`` of the weighted residuals.
    n_residuals : int
    nfev, njev : int
    seconds : float
    success : bool
    message : str
    at_bounds : list of str
        Free parameters that ended at a bound.
    """

    theta: NDArray[np.float64]
    free: tuple[str, ...]
    values: dict[str, float]
    stderr: dict[str, float]
    covariance: NDArray[np.float64] | None
    cost: float
    n_residuals: int
    nfev: int
    njev: int
    seconds: float
    success: bool
    message: str
    at_bounds: list[str] = field(default_factory=list)


def _covariance(J: NDArray[np.float64], r: NDArray[np.float64]) -> tuple[Any, NDArray[np.float64]]:
    try:
        from thermogym.identification.uncertainty import covariance_from_jacobian

        cov, se, *_ = covariance_from_jacobian(J, r)
        return cov, se
    except ImportError:  # pragma: no cover - fallback while the module is absent
        pass
    N, P = J.shape
    s2 = float(r @ r) / max(N - P, 1)
    try:
        cov = s2 * np.linalg.inv(J.T @ J)
    except np.linalg.LinAlgError:
        return None, np.full(P, np.nan)
    return cov, np.sqrt(np.clip(np.diag(cov), 0.0, None))


def _projected_lm(
    fun: Callable[[NDArray[np.float64]], NDArray[np.float64]],
    jac: Callable[[NDArray[np.float64]], NDArray[np.float64]],
    s0: NDArray[np.float64],
    *,
    max_nfev: int,
    xtol: float,
    ftol: float,
) -> tuple[NDArray[np.float64], int, int, bool, str]:
    """Levenberg-Marquardt on the normal equations, projected onto the unit box.

    Written here rather than calling ``scipy.optimize.least_squares``: its
    trust-region solvers factor (SVD) or iterate (LSMR) on the full m × k
    Jacobian at every step, which dominates the run time when m is a few
    hundred thousand residuals and k ~ 20 parameters; the k × k normal
    equations ``(JᵀJ + λ diag(JᵀJ)) δ = −Jᵀr`` cost one product ``JᵀJ`` per
    Jacobian. Steps are clipped to the box ``[0, 1]^k``; parameters at a bound
    whose gradient points outwards are held for that step.
    """
    s = np.clip(np.asarray(s0, dtype=float), 0.0, 1.0)
    r = fun(s)
    cost = 0.5 * float(r @ r)
    nfev, njev = 1, 0
    lam = 1e-3
    k = s.size
    while nfev < max_nfev:
        J = jac(s)
        njev += 1
        g = J.T @ r
        H = J.T @ J
        d = np.diag(H).copy()
        free = ~(((s <= 0.0) & (g > 0)) | ((s >= 1.0) & (g < 0)))
        if not free.any():
            return s, nfev, njev, True, "every parameter at a bound"
        improved = False
        while nfev < max_nfev:
            A = H[np.ix_(free, free)] + lam * np.diag(d[free] + 1e-12 * (d.max() + 1e-300))
            try:
                step_f = -np.linalg.solve(A, g[free])
            except np.linalg.LinAlgError:
                lam *= 10.0
                continue
            step = np.zeros(k)
            step[free] = step_f
            s_new = np.clip(s + step, 0.0, 1.0)
            r_new = fun(s_new)
            nfev += 1
            c_new = 0.5 * float(r_new @ r_new)
            if math.isfinite(c_new) and c_new < cost:
                dx = float(np.max(np.abs(s_new - s)))
                rel = (cost - c_new) / max(cost, 1e-300)
                s, r, cost = s_new, r_new, c_new
                # a tiny step only means convergence when it is a (nearly) Gauss-Newton step
                gn = lam < 1e-2
                lam = max(lam / 3.0, 1e-9)
                improved = True
                if gn and (rel < ftol or dx < xtol):
                    return s, nfev, njev, True, "converged"
                break
            lam *= 4.0
            if lam > 1e10:
                return s, nfev, njev, True, "no further decrease"
        if not improved:
            break
    return s, nfev, njev, False, "largest number of evaluations reached"


def fit_model(
    problem: FitProblem,
    *,
    start: NDArray[np.float64] | None = None,
    starts: Sequence[NDArray[np.float64]] = (),
    max_nfev: int = 60,
    xtol: float = 1e-8,
    ftol: float = 1e-8,
    deadline: float | None = None,
) -> FitOutcome:
    """Bounded least squares of the weighted simulation error (see the module docstring).

    Parameters
    ----------
    problem : FitProblem
    start : ndarray, shape (k,), optional
        Start of the free parameters (default: their values in ``problem.base``).
    starts : sequence of ndarray
        Further starts tried first for one cost evaluation each (multimodal
        parameters such as delays); the best start is refined.
    max_nfev : int
        Largest number of cost evaluations of the refinement.
    xtol, ftol : float
        Stop when a step moves no scaled parameter by more than ``xtol`` or
        lowers the cost by less than the relative ``ftol``.
    deadline : float, optional
        ``time.perf_counter()`` value after which the refinement stops.

    Returns
    -------
    FitOutcome
    """
    t0 = time.perf_counter()
    lo, hi = problem.lower, problem.upper
    span = np.where(hi > lo, hi - lo, 1.0)
    k = len(problem.free)
    x_start = problem.base[problem._cols] if start is None else np.asarray(start, dtype=float)
    cands = [x_start, *[np.asarray(s, dtype=float) for s in starts]]
    cands = [np.clip(c, lo, hi) for c in cands]
    if len(cands) > 1:
        costs = [
            0.5 * float(np.sum(problem.residuals(problem.theta(c[None]))[0] ** 2)) for c in cands
        ]
        x_start = cands[int(np.argmin(costs))]
    else:
        x_start = cands[0]
    if k == 0:
        r = problem.residuals(problem.theta(x_start[None]))[0]
        return FitOutcome(
            problem.theta(x_start[None])[0],
            (),
            {},
            {},
            None,
            0.5 * float(r @ r),
            r.size,
            1,
            0,
            time.perf_counter() - t0,
            True,
            "nothing to fit",
        )
    s0 = (x_start - lo) / span
    cache: dict[bytes, NDArray[np.float64]] = {}
    h = 1e-6

    class _Stop(Exception):
        pass

    def to_x(s: NDArray[np.float64]) -> NDArray[np.float64]:
        return lo + np.clip(s, 0.0, 1.0) * span

    def fun(s: NDArray[np.float64]) -> NDArray[np.float64]:
        key = s.tobytes()
        if key not in cache:
            if deadline is not None and time.perf_counter() > deadline and cache:
                raise _Stop
            cache.clear() if len(cache) > 4 else None
            cache[key] = problem.residuals(problem.theta(to_x(s)[None]))[0]
        return cache[key]

    def jac(s: NDArray[np.float64]) -> NDArray[np.float64]:
        f0 = fun(s)
        steps = np.where(s + h <= 1.0, h, -h)
        S = np.repeat(s[None], k, axis=0) + np.diag(steps)
        R = problem.residuals(problem.theta(to_x(S)))
        return ((R - f0[None]) / steps[:, None]).T

    best = {"s": s0.copy(), "cost": math.inf}

    def tracked(s: NDArray[np.float64]) -> NDArray[np.float64]:
        r = fun(s)
        c = 0.5 * float(r @ r)
        if c < best["cost"]:
            best["s"], best["cost"] = s.copy(), c
        return r

    message, success, nfev, njev = "", False, 0, 0
    try:
        s_opt, nfev, njev, success, message = _projected_lm(
            tracked, jac, s0, max_nfev=max_nfev, xtol=xtol, ftol=ftol
        )
        if best["cost"] < 0.5 * float(fun(s_opt) @ fun(s_opt)):
            s_opt = best["s"]
    except _Stop:
        s_opt, message = best["s"], "stopped at the time limit"
    x_opt = to_x(s_opt)
    r = fun(s_opt)
    J = jac(s_opt) / span[None, :]
    valid = np.any(J != 0.0, axis=1) | (r != 0.0)
    try:
        cov, se = _covariance(J[valid], r[valid])
    except ShapeError:
        cov, se = None, np.full(k, np.nan)
    at = [
        p
        for p, x, a, b in zip(problem.free, x_opt, lo, hi, strict=True)
        if x <= a + 1e-6 * (b - a) or x >= b - 1e-6 * (b - a)
    ]
    return FitOutcome(
        theta=problem.theta(x_opt[None])[0],
        free=problem.free,
        values={p: float(v) for p, v in zip(problem.free, x_opt, strict=True)},
        stderr={p: float(v) for p, v in zip(problem.free, se, strict=True)},
        covariance=cov,
        cost=0.5 * float(r @ r),
        n_residuals=int(valid.sum()),
        nfev=nfev,
        njev=njev,
        seconds=time.perf_counter() - t0,
        success=success,
        message=message,
        at_bounds=at,
    )


def output_weights(experiments: Sequence[Experiment]) -> NDArray[np.float64]:
    """Inverse spread of each fitted output over the experiments (NRMSE weighting)."""
    y = np.concatenate([e.y for e in experiments], axis=0)
    sd = np.nanstd(y, axis=0)
    scale = np.where(np.isfinite(sd) & (sd > 0), sd, 1.0)
    return 1.0 / scale


def simulate_all(
    model: Model,
    theta: NDArray[np.float64],
    experiments: Sequence[Experiment],
    x0: str = "rest",
) -> list[NDArray[np.float64]]:
    """Simulated fitted outputs (T, n_fit) of one parameter set on every experiment."""
    pb = FitProblem(
        model,
        (),
        np.asarray(theta, dtype=float).reshape(-1),
        np.zeros(0),
        np.zeros(0),
        experiments,
        np.ones(len(experiments[0].outputs)) if experiments else np.ones(0),
        x0,
    )
    th = np.asarray(theta, dtype=float).reshape(1, -1)
    return [pb.simulate(th, i)[0] for i in range(len(experiments))]
