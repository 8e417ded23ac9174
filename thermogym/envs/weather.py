"""Weather files for ``AXT211Room`` (file I/O kept out of the numerical modules).

A weather file is a recording (CSV with its ``.meta.json`` sidecar, or
Parquet; :func:`thermogym.recording.read_recording`) — or a
:class:`~thermogym.recording.Recording` — with

* ``time`` [s] since 1 January 00:00 (local time),
* ``T_out`` [°C] outdoor air temperature,
* optionally ``Q_sol`` [W]: solar gains into the room (zero when absent).

It is resampled to hourly values by linear interpolation and used
periodically (a year of 8760 h repeats; a shorter file repeats too, which is
meant for test-reference days). Typical sources: a TMY/EPW file converted
with its dry-bulb temperature column.
"""

from __future__ import annotations

import os

import numpy as np
from numpy.typing import NDArray

from thermogym.errors import ConfigError
from thermogym.recording import Recording, read_recording

__all__ = ["weather_table"]


def weather_table(src: Recording | str | os.PathLike[str]) -> NDArray[np.float64]:
    """Hourly ``[T_out, Q_sol]`` table of shape (2, n_hours) from a weather recording.

    Raises
    ------
    ConfigError
        No ``T_out`` column, fewer than 24 hours, or non-finite values.
    """
    rec = src if isinstance(src, Recording) else read_recording(src)
    if "T_out" not in rec:
        raise ConfigError(
            f"weather recording {rec.experiment_id or ''!r} has columns {list(rec.columns)}; "
            "expected 'T_out' [°C] (and optionally 'Q_sol' [W])"
        )
    t = rec.time
    span_h = int(np.floor((t[-1] - t[0]) / 3600.0)) + 1
    if span_h < 24:
        raise ConfigError(f"weather recording covers {span_h} h; expected at least 24 h")
    start = float(np.ceil(t[0] / 3600.0) * 3600.0)
    hours = start + 3600.0 * np.arange(span_h)
    hours = hours[hours <= t[-1]]
    cols = [rec["T_out"], rec["Q_sol"] if "Q_sol" in rec else np.zeros(rec.n_samples)]
    out = np.vstack([np.interp(hours, t, c) for c in cols])
    if not np.isfinite(out).all():
        raise ConfigError("weather recording holds non-finite T_out or Q_sol values")
    # rotate so that column i is absolute hour i (mod the table length)
    shift = round(hours[0] / 3600.0) % out.shape[1]
    return np.ascontiguousarray(np.roll(out, shift, axis=1))
