"""Recordings prepared for a diagnosis fit: checked, on a uniform grid, arrays in model order.

Every fit of the diagnosis (:mod:`.fit`) and every score on held-out data
(:mod:`.select`) works on :class:`Experiment` objects: one recording checked
against the model (:meth:`~thermogym.recording.Recording.validate_for`), its
exogenous signals in ``model.exogenous_names`` order and its fitted outputs
in the order compared. :func:`prepare_experiments` builds them:

* a recording whose steps vary a little (a logger's jitter) is resampled
  onto a uniform grid of its median step (linear interpolation); one with
  gaps is refused (prepare it first, :mod:`thermogym.identification.prepare`);
* with ``dt``, it is averaged onto a coarser grid (:func:`decimate`: the
  exogenous signals averaged over each interval, as a zero-order hold sees
  them; the outputs point-sampled).

:func:`auto_period` picks that coarser grid for long recordings: a day at
1 Hz holds 86,400 samples per output, far more than a thermal model whose
fastest response takes minutes can use, and every simulation of the search
costs in proportion to them.

What was done is kept in :attr:`Experiment.notes` for the report.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from thermogym.errors import RecordingError
from thermogym.identification.prepare import resample
from thermogym.models.base import Model
from thermogym.recording import Recording

__all__ = [
    "AUTO_SAMPLES",
    "Experiment",
    "auto_period",
    "decimate",
    "half_response_time",
    "half_time",
    "prepare_experiments",
    "step_responses",
]

#: Recordings holding more samples than this in all (training and held-out) are averaged
#: onto a coarser grid when the caller gives no period (:func:`auto_period`).
AUTO_SAMPLES = 20_000
#: The grid :func:`auto_period` picks is at most this share of the model's fastest
#: half-response time (about a thirtieth of a first-order time constant: averaging then
#: changes a first-order response by well under a per cent of its step).
AUTO_SHARE = 1.0 / 20.0
#: ... and keeps at least this many samples in every recording.
AUTO_MIN_SAMPLES = 500


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


def step_responses(
    model: Model,
    theta: NDArray[np.float64],
    u: NDArray[np.float64],
    dt: float,
    steps: Sequence[tuple[int, float]],
) -> NDArray[np.float64] | None:
    """Output changes after steps of exogenous signals, shape (len(steps), T − T/4, n_out).

    Each ``(column, size)`` raises that column of ``u`` (T, n_u) by ``size`` a
    quarter into the record; one batched simulation at ``theta`` with the
    unchanged record as the reference. None when the model cannot be simulated
    so; rows of sets that fail hold NaN.
    """
    n0 = u.shape[0] // 4
    uu = np.repeat(u[None], len(steps) + 1, axis=0)
    for b, (j, size) in enumerate(steps, start=1):
        uu[b, n0:, j] += size
    th = np.repeat(np.asarray(theta, dtype=float)[None], len(steps) + 1, axis=0)
    try:
        x0 = model.initial_state(th, uu[:, 0])
        out = model.simulate(uu, dt, th, x0, strict=False).outputs
    except Exception:  # a model that cannot be simulated here has no step response
        return None
    return out[1:, n0:, :] - out[:1, n0:, :]


def half_time(x: NDArray[np.float64], dt: float) -> float:
    """Seconds a step response ``x`` takes to make half the change of its last sixth.

    Infinite when it never does, shows no change, or holds NaN.
    """
    if not np.isfinite(x).all():
        return math.inf
    final = float(np.mean(x[-max(x.size // 6, 1) :]))
    if final == 0.0:
        return math.inf
    hit = np.nonzero(np.abs(x) >= 0.5 * abs(final))[0]
    return float(hit[0]) * dt if hit.size else math.inf


def half_response_time(
    model: Model, theta: NDArray[np.float64], e: Experiment, outputs: Sequence[str]
) -> float:
    """Fastest half-response [s] of the model's ``outputs`` to a step of any exogenous signal.

    Each exogenous signal that varies in ``e`` is raised by 1 % of its span a
    quarter into the recording (:func:`step_responses`); the fastest
    :func:`half_time` over signals and outputs. Infinite when the model cannot
    be simulated so or no output responds.

    Examples
    --------
    >>> from thermogym.models.registry import get_model
    >>> m = get_model("foptd")
    >>> t = np.arange(2000.0)
    >>> rec = Recording(t, {"u": (t > 100).astype(float), "y": np.zeros(2000)})
    >>> e = prepare_experiments(m, [rec], ["y"])[0]
    >>> th = m.nominal.copy()
    >>> th[m.param_index("T_y")] = 300.0  # time constant [s], no dead time
    >>> t_half = half_response_time(m, th, e, ["y"])  # ln 2 of the time constant
    >>> bool(abs(t_half - 300.0 * np.log(2.0)) <= 10.0)
    True
    """
    span = np.ptp(e.u, axis=0)
    steps = [(j, 0.01 * float(span[j])) for j in range(e.u.shape[1]) if span[j] > 0]
    cols = [model.output_names.index(o) for o in outputs if o in model.output_names]
    d = step_responses(model, theta, e.u, e.dt, steps) if steps and cols else None
    if d is None:
        return math.inf
    return min(half_time(d[b, :, k], e.dt) for b in range(len(steps)) for k in cols)


def auto_period(
    model: Model,
    theta: NDArray[np.float64],
    experiments: Sequence[Experiment],
    outputs: Sequence[str],
) -> tuple[float, float] | None:
    """A coarser comparison period for long recordings, or None to keep theirs.

    When the experiments hold more than :data:`AUTO_SAMPLES` samples in all,
    the longest whole multiple of their period that is at most
    :data:`AUTO_SHARE` of the model's fastest half-response
    (:func:`half_response_time` on the first experiment, at ``theta``) and
    leaves every experiment :data:`AUTO_MIN_SAMPLES` samples. None when the
    recordings are short, their periods differ, or the multiple is below 2.

    Returns
    -------
    (dt, t_half) : tuple of float
        The period [s] and the half-response time [s] it was chosen from.
    """
    if not experiments or sum(e.n for e in experiments) <= AUTO_SAMPLES:
        return None
    dt0 = experiments[0].dt
    if any(abs(e.dt - dt0) > 1e-9 * dt0 for e in experiments):
        return None
    t_half = half_response_time(model, theta, experiments[0], outputs)
    if not math.isfinite(t_half):
        return None
    k = min(
        math.floor(AUTO_SHARE * t_half / dt0 + 1e-9),
        min(e.n for e in experiments) // AUTO_MIN_SAMPLES,
    )
    if k < 2:
        return None
    return k * dt0, t_half


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

    out, _ = resample(rec, step, t_start=float(rec.time[0]))
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
        if not np.isfinite(u).all():
            raise RecordingError(
                f"{what} recording {rec.experiment_id!r}: exogenous signals hold NaN after "
                "resampling; prepare the recording first"
            )
        y = np.column_stack([np.asarray(r[o], dtype=float) for o in outputs])
        out.append(Experiment(r, r.dt, u, y, tuple(outputs), notes))
    return out
