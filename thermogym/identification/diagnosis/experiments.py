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

What was done is kept in :attr:`Experiment.notes` for the report.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from thermogym.errors import RecordingError
from thermogym.identification.prepare import resample
from thermogym.models.base import Model
from thermogym.recording import Recording

__all__ = ["Experiment", "decimate", "prepare_experiments"]


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
