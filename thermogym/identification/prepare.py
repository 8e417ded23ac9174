"""Data preparation: raw recordings → uniform, gap-free data ready for identification.

Section 2.3.1 of ``001_6d13a2cd04f5de5e.txt`` prepares the spindle's raw
sensor data in explicit steps: remove outliers ("extremely erroneous data ...
due to device failure"), resample the asynchronous channels to 1 Hz, remove
missing data (NaN), start all series "simultaneously with the first time
sample that has all non-NaN temperatures", subtract the ambient temperature
and adjust the starting time. Here each of those is a function that returns
the new recording *and a report of what it changed* (counts, time spans), and
:func:`prepare` chains them. The reports travel with the prepared recording in
``meta["preparation"]``, so a FitResult's data fingerprint can always be traced
back to the raw file and every change made to it.

============================  ==================================================
step                          what it does
============================  ==================================================
:func:`remove_outliers`       physical range limits, then a Hampel filter per
                              channel (running median ± ``n_sigma`` · 1.4826 ·
                              MAD over ``2·window + 1`` of the channel's own
                              samples); flagged samples become NaN
:func:`resample`              every channel onto a common grid of period ``dt``
                              (linear interpolation or bin means); grid points
                              inside a gap of the raw channel stay NaN
:func:`align`                 keep the samples from the first time every channel
                              is valid to the last (paper's start alignment)
:func:`fill_gaps`             interior NaN runs up to ``max_gap_s`` are
                              interpolated linearly; a longer gap is refused
                              with an error naming channel and time span
:func:`subtract_ambient`      temperatures relative to the ambient channel
:func:`detrend`               remove a constant, linear trend or initial value
============================  ==================================================

Every function is vectorised (no Python loop over samples): a raw spindle day
of about 800 000 asynchronous rows is prepared in well under a second.

:func:`check_identification_data` is the gate the identification methods call:
it refuses NaN-only or non-finite channels, constant inputs and records too
short for the requested model, with messages that say what to do.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from numpy.typing import NDArray

from thermogym._checks import positive
from thermogym.errors import ConfigError, IdentificationError, RecordingError
from thermogym.recording import Recording

__all__ = [
    "PrepareConfig",
    "align",
    "check_identification_data",
    "detrend",
    "fill_gaps",
    "hampel_mask",
    "measured_columns",
    "nan_runs",
    "prepare",
    "remove_outliers",
    "resample",
    "subtract_ambient",
]

_MAD_TO_SIGMA = 1.4826  # σ = 1.4826 · MAD for Gaussian noise
_DETREND_KINDS = ("constant", "linear", "initial")
_RESAMPLE_METHODS = ("linear", "mean")


# ================================================================ small helpers
def _fmt_span(t0: float, t1: float) -> str:
    return f"{t0:.6g} s .. {t1:.6g} s ({t1 - t0:.6g} s)"


def _columns(rec: Recording, columns: Sequence[str] | str | None, default: list[str]) -> list[str]:
    if columns is None:
        return default
    names = [columns] if isinstance(columns, str) else list(columns)
    rec.select(names)  # raises UnknownNameError listing the columns
    return names


def measured_columns(rec: Recording) -> list[str]:
    """Columns that hold *measured* values: role output or disturbance.

    Inputs are commanded (a heater switching, a set speed) and are left alone by
    outlier removal: a short pulse of a PRBS input is not a glitch. Without any
    role information every column counts as measured.

    Examples
    --------
    >>> rec = Recording([0.0, 1.0], {"u": [0, 1], "y": [2.0, 3.0]},
    ...                 roles={"u": "input", "y": "output"})
    >>> measured_columns(rec)
    ['y']
    """
    if not rec.roles:
        return list(rec.columns)
    return [c for c in rec.columns if rec.roles.get(c) in ("output", "disturbance")]


def nan_runs(valid: NDArray[np.bool_]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Start and end (exclusive) indices of the runs of ``False`` in ``valid``.

    Examples
    --------
    >>> s, e = nan_runs(np.array([True, False, False, True, False]))
    >>> s.tolist(), e.tolist()
    ([1, 4], [3, 5])
    """
    bad = np.concatenate([[False], ~np.asarray(valid, dtype=bool), [False]]).astype(np.int8)
    d = np.diff(bad)
    return np.flatnonzero(d == 1), np.flatnonzero(d == -1)


def _append(rec: Recording, report: dict[str, Any]) -> Recording:
    """Append a step report to ``rec.meta["preparation"]["steps"]`` (``rec`` is new)."""
    prep = dict(rec.meta.get("preparation") or {})
    prep["steps"] = [*prep.get("steps", []), report]
    rec.meta["preparation"] = prep
    return rec


def _replaced(
    rec: Recording,
    data: Mapping[str, NDArray[np.float64]],
    report: dict[str, Any],
    units: Mapping[str, str] | None = None,
) -> Recording:
    """``rec`` with columns replaced (a new recording) and the report appended."""
    out = rec.with_columns(dict(data), units=units) if data or units else rec.copy()
    return _append(out, report)


def _rebuilt(
    rec: Recording,
    time: NDArray[np.float64],
    data: Mapping[str, NDArray[np.float64]],
    report: dict[str, Any],
) -> Recording:
    """A recording on a new time axis with ``rec``'s metadata and the report appended."""
    out = Recording(
        time,
        data,
        units={k: v for k, v in rec.units.items() if k in data},
        roles={k: v for k, v in rec.roles.items() if k in data},
        experiment_id=rec.experiment_id,
        source=rec.source,
        meta=rec.meta,
    )
    return _append(out, report)


# ===================================================================== outliers
def hampel_mask(
    x: NDArray[np.float64], window: int = 7, n_sigma: float = 6.0, min_threshold: float = 0.0
) -> NDArray[np.bool_]:
    """Samples a Hampel filter flags as outliers.

    ``|x_k − med_k| > max(n_sigma · 1.4826 · max(MAD_k, median_j MAD_j),
    min_threshold)`` where ``med_k`` and ``MAD_k`` are the median and the
    median absolute deviation of the ``2·window + 1`` samples centred on ``k``
    (reflected at the ends). The channel-wide median of the local MADs is a
    floor: a window whose few samples agree by chance would otherwise flag
    ordinary noise. Runs of up to ``window`` consecutive outliers are found.

    Parameters
    ----------
    x : ndarray, shape (T,)
        Finite samples of one channel (drop NaN first).
    window : int
        Half-width of the window [samples], >= 1.
    n_sigma : float
        Threshold in robust standard deviations, > 0.
    min_threshold : float
        Smallest deviation ever flagged [signal unit]; guards quantised or
        noise-free channels whose MAD is zero.

    Returns
    -------
    ndarray of bool, shape (T,)

    Examples
    --------
    >>> x = np.sin(np.linspace(0, 3, 50)); x[20] += 40.0
    >>> np.flatnonzero(hampel_mask(x)).tolist()
    [20]
    """
    x = np.asarray(x, dtype=float)
    if int(window) != window or window < 1:
        raise ConfigError(f"Hampel window is {window!r}; expected a whole number of samples >= 1")
    positive("n_sigma", n_sigma, error=ConfigError, text=False)
    n = x.size
    w = int(window)
    if n < 3:
        return np.zeros(n, dtype=bool)
    w = min(w, (n - 1) // 2)
    # reflect-pad so every sample has a full window; the padded values are genuine samples
    xp = np.concatenate([x[w:0:-1], x, x[-2 : -w - 2 : -1]])
    win = sliding_window_view(xp, 2 * w + 1)
    med = np.median(win, axis=1)
    mad = np.median(np.abs(win - med[:, None]), axis=1)
    # floor: the channel's typical local scale, so that a window whose 15 samples happen to
    # agree closely (small MAD by chance, or quantisation) does not flag ordinary noise
    floor = n_sigma * _MAD_TO_SIGMA * float(np.median(mad))
    thr = np.maximum(np.maximum(n_sigma * _MAD_TO_SIGMA * mad, floor), float(min_threshold))
    return np.abs(x - med) > thr


def remove_outliers(
    rec: Recording,
    columns: Sequence[str] | str | None = None,
    *,
    window: int = 7,
    n_sigma: float = 6.0,
    min_threshold: float = 0.0,
    valid_range: tuple[float, float] | Mapping[str, tuple[float, float]] | None = None,
) -> tuple[Recording, dict[str, Any]]:
    """Replace outliers by NaN: range limits, then a Hampel filter per channel.

    Each channel is filtered on its own valid samples, so asynchronous
    channels (NaN where another channel sampled) are handled correctly.

    Parameters
    ----------
    rec : Recording
        Raw data; NaN marks missing samples.
    columns : sequence of str, optional
        Channels to clean; default :func:`measured_columns`.
    window : int
        Hampel half-width [samples of the channel].
    n_sigma : float
        Hampel threshold in robust standard deviations. 6 rather than the
        textbook 3: with 10⁵ samples per channel, 3σ would flag hundreds of
        good samples of Gaussian noise.
    min_threshold : float
        Smallest deviation flagged [signal unit] (see :func:`hampel_mask`).
    valid_range : (lo, hi) or mapping column -> (lo, hi), optional
        Physical limits of the sensors; samples outside (or at) them are
        outliers, e.g. ``(-50, 300)`` for the spindle's RTD modules, whose
        open-circuit readings sit at the range limits.

    Returns
    -------
    Recording
        Same time axis, outliers set to NaN.
    dict
        Report: per channel the number removed and the first times.

    Examples
    --------
    >>> t = np.arange(100.0)
    >>> y = 20 + 0.01 * t; y[[10, 60]] = [300.0, 75.0]
    >>> clean, rep = remove_outliers(Recording(t, {"T": y}), valid_range=(-50, 300))
    >>> rep["removed"]["T"]["count"], int(np.isnan(clean["T"]).sum())
    (2, 2)
    """
    cols = _columns(rec, columns, measured_columns(rec))
    ranges: dict[str, tuple[float, float]] = {}
    if isinstance(valid_range, Mapping):
        unknown = [k for k in valid_range if k not in rec]
        if unknown:
            raise ConfigError(f"valid_range names unknown column(s) {unknown}")
        ranges = {k: (float(v[0]), float(v[1])) for k, v in valid_range.items()}
    elif valid_range is not None:
        lo, hi = (float(v) for v in valid_range)
        ranges = {c: (lo, hi) for c in cols}
    for c, (lo, hi) in ranges.items():
        if not lo < hi:
            raise ConfigError(f"valid_range of {c!r} is ({lo!r}, {hi!r}); expected lo < hi")
    new: dict[str, NDArray[np.float64]] = {}
    removed: dict[str, Any] = {}
    total = 0
    for c in cols:
        x = rec[c]
        valid = np.isfinite(x)
        idx = np.flatnonzero(valid)
        bad_range = np.zeros(idx.size, dtype=bool)
        if c in ranges:
            lo, hi = ranges[c]
            v = x[idx]
            bad_range = (v <= lo) | (v >= hi)
        keep = idx[~bad_range]
        bad_h = hampel_mask(x[keep], window, n_sigma, min_threshold) if keep.size else keep
        out_idx = np.sort(np.concatenate([idx[bad_range], keep[bad_h]]))
        if out_idx.size:
            y = np.array(x, copy=True)
            y[out_idx] = np.nan
            new[c] = y
        total += int(out_idx.size)
        removed[c] = {
            "count": int(out_idx.size),
            "out_of_range": int(bad_range.sum()),
            "hampel": int(bad_h.sum()),
            "times_s": [float(v) for v in rec.time[out_idx[:10]]],
            "values": [float(v) for v in x[out_idx[:10]]],
        }
    report = {
        "step": "remove_outliers",
        "method": "hampel",
        "window": int(window),
        "n_sigma": float(n_sigma),
        "min_threshold": float(min_threshold),
        "valid_range": {k: list(v) for k, v in ranges.items()},
        "total_removed": total,
        "removed": removed,
    }
    return _replaced(rec, new, report), report


# =================================================================== resampling
def resample(
    rec: Recording,
    dt: float = 1.0,
    columns: Sequence[str] | str | None = None,
    *,
    method: str = "linear",
    max_spacing: float | Mapping[str, float] | None = None,
    t_start: float | None = None,
    t_end: float | None = None,
) -> tuple[Recording, dict[str, Any]]:
    """Resample every channel onto one uniform grid (paper 001: 1 Hz).

    The grid runs from ``t_start`` (default: the first time stamp rounded up
    to a multiple of ``dt``) to ``t_end`` (default: the last time stamp) in
    steps of ``dt``. Each channel is resampled from its own valid samples.
    Grid points that fall inside a *gap* of a channel — two consecutive valid
    samples further apart than ``max_spacing`` — and points before its first
    or after its last sample are NaN, for :func:`fill_gaps` and :func:`align`
    to handle.

    Parameters
    ----------
    rec : Recording
    dt : float
        Grid period [s], > 0.
    columns : sequence of str, optional
        Channels to keep; all by default.
    method : {"linear", "mean"}
        ``"linear"``: linear interpolation between the channel's samples;
        ``"mean"``: mean of the samples in ``[t − dt/2, t + dt/2)`` (an
        anti-alias average; an empty bin is NaN, i.e. a gap).
    max_spacing : float or mapping, optional
        Largest spacing of valid samples still interpolated [s]; default per
        channel ``max(3 × its median spacing, 2 dt)``.
    t_start, t_end : float, optional
        Grid limits [s].

    Returns
    -------
    Recording
        Uniform, period ``dt``.
    dict
        Report: grid, per channel the raw sample count, median spacing, the
        number of grid points left NaN and the gaps found.

    Examples
    --------
    >>> rec = Recording([0.0, 0.4, 1.3, 2.2, 3.1], {"y": [0.0, 0.4, np.nan, 2.2, 3.1]})
    >>> out, rep = resample(rec, 1.0)
    >>> out.time.tolist(), out["y"].round(6).tolist()
    ([0.0, 1.0, 2.0, 3.0], [0.0, 1.0, 2.0, 3.0])
    """
    positive("dt", dt, unit="s", error=ConfigError, text=False)
    if method not in _RESAMPLE_METHODS:
        raise ConfigError(f"resampling method {method!r}; expected one of {_RESAMPLE_METHODS}")
    cols = _columns(rec, columns, list(rec.columns))
    t = rec.time
    a = math.ceil(float(t[0]) / dt - 1e-9) * dt if t_start is None else float(t_start)
    b = float(t[-1]) if t_end is None else float(t_end)
    if b < a:
        raise RecordingError(
            f"resampling grid is empty: it would start at {a!r} s but the data end at {b!r} s"
        )
    n = math.floor((b - a) / dt + 1e-9) + 1
    grid = a + dt * np.arange(n, dtype=np.float64)
    data: dict[str, NDArray[np.float64]] = {}
    info: dict[str, Any] = {}
    for c in cols:
        x = rec[c]
        ok = np.isfinite(x)
        tv, xv = t[ok], x[ok]
        if tv.size == 0:
            raise RecordingError(
                f"channel {c!r} of recording {rec.experiment_id!r} holds no valid sample "
                "(NaN only); drop it (columns=...) or fix the logger"
            )
        spacing = np.diff(tv)
        med = float(np.median(spacing)) if spacing.size else dt
        if isinstance(max_spacing, Mapping):
            lim = float(max_spacing.get(c, max(3 * med, 2 * dt)))
        elif max_spacing is not None:
            lim = float(max_spacing)
        else:
            lim = max(3.0 * med, 2.0 * dt)
        # grid point g lies between the valid samples tv[j-1] <= g < tv[j]
        j = np.searchsorted(tv, grid, side="right")
        before = j == 0
        after = grid > tv[-1] + 1e-9 * dt
        if tv.size > 1:
            jc = np.clip(j, 1, tv.size - 1)
            inside = (j > 0) & (j < tv.size)
            span = np.where(inside, tv[jc] - tv[jc - 1], 0.0)
            on_sample = grid - tv[jc - 1] <= 1e-9 * max(dt, 1.0)
            in_gap = inside & (span > lim) & ~on_sample
        else:
            in_gap = np.zeros(grid.size, dtype=bool)
        if method == "linear":
            y = np.interp(grid, tv, xv)
        else:
            # bin k collects the samples in [grid_k − dt/2, grid_k + dt/2)
            kbin = np.floor((tv - a) / dt + 0.5).astype(np.int64)
            sel = (kbin >= 0) & (kbin < n)
            s = np.bincount(kbin[sel], weights=xv[sel], minlength=n)
            cnt = np.bincount(kbin[sel], minlength=n)
            with np.errstate(invalid="ignore", divide="ignore"):
                y = s / cnt
            in_gap = in_gap | ((cnt == 0) & ~before & ~after)
        y[before | after | in_gap] = np.nan
        data[c] = y
        gs, ge = nan_runs(~in_gap)
        info[c] = {
            "raw_samples": int(tv.size),
            "median_spacing_s": med,
            "max_spacing_s": lim,
            "nan_points": int(np.isnan(y).sum()),
            "gaps": int(gs.size),
            "gap_spans_s": [
                [float(grid[s0]), float(grid[e0 - 1])]
                for s0, e0 in zip(gs[:10], ge[:10], strict=True)
            ],
        }
    report = {
        "step": "resample",
        "method": method,
        "dt_s": float(dt),
        "t_start_s": float(grid[0]),
        "t_end_s": float(grid[-1]),
        "raw_rows": rec.n_samples,
        "samples": int(n),
        "channels": info,
    }
    return _rebuilt(rec, grid, data, report), report


# ================================================================ alignment
def align(
    rec: Recording,
    columns: Sequence[str] | str | None = None,
    *,
    end: bool = True,
    zero_time: bool = True,
) -> tuple[Recording, dict[str, Any]]:
    """Start (and end) every channel together where all are valid.

    Paper 001: "all time series should start simultaneously with the first
    time sample that has all non-NaN temperatures". ``zero_time`` then adjusts
    the starting time to 0 (the offset is reported, so absolute times can be
    recovered).

    Parameters
    ----------
    rec : Recording
    columns : sequence of str, optional
        Channels that must be valid (default all).
    end : bool
        Also cut after the last sample where all are valid.
    zero_time : bool
        Shift time so that the kept part starts at 0 s.

    Returns
    -------
    Recording, dict

    Raises
    ------
    RecordingError
        No sample has all channels valid.

    Examples
    --------
    >>> rec = Recording([0.0, 1.0, 2.0, 3.0], {"a": [np.nan, 1, 2, 3], "b": [0, 1, 2, np.nan]})
    >>> out, rep = align(rec)
    >>> out.time.tolist(), rep["t_offset_s"], rep["dropped_start"], rep["dropped_end"]
    ([0.0, 1.0], 1.0, 1, 1)
    """
    cols = _columns(rec, columns, list(rec.columns))
    ok = np.ones(rec.n_samples, dtype=bool)
    for c in cols:
        ok &= np.isfinite(rec[c])
    if not ok.any():
        worst = min(cols, key=lambda c: int(np.isfinite(rec[c]).sum()))
        raise RecordingError(
            f"no sample of recording {rec.experiment_id!r} has all of {cols} valid at once "
            f"(channel {worst!r} has {int(np.isfinite(rec[worst]).sum())} valid samples); "
            "resample the channels onto a common grid first"
        )
    i0 = int(np.argmax(ok))
    i1 = rec.n_samples - int(np.argmax(ok[::-1])) if end else rec.n_samples
    t0 = float(rec.time[i0])
    time = rec.time[i0:i1] - (t0 if zero_time else 0.0)
    data = {c: rec[c][i0:i1] for c in rec.columns}
    report = {
        "step": "align",
        "columns": cols,
        "dropped_start": i0,
        "dropped_end": rec.n_samples - i1,
        "t_first_valid_s": t0,
        "t_last_valid_s": float(rec.time[i1 - 1]),
        "t_offset_s": t0 if zero_time else 0.0,
    }
    return _rebuilt(rec, time, data, report), report


# =================================================================== NaN / gaps
def fill_gaps(
    rec: Recording,
    max_gap_s: float = 60.0,
    columns: Sequence[str] | str | None = None,
) -> tuple[Recording, dict[str, Any]]:
    """Interpolate interior NaN runs up to ``max_gap_s``; refuse longer ones.

    A run of NaN between two valid samples ``t_a`` and ``t_b`` with
    ``t_b − t_a <= max_gap_s`` is filled by linear interpolation. Leading and
    trailing NaN are left for :func:`align` (they are reported).

    Parameters
    ----------
    rec : Recording
        Usually uniform (after :func:`resample`).
    max_gap_s : float
        Longest gap interpolated [s] (between the valid samples around it).
    columns : sequence of str, optional
        Channels to fill; all by default.

    Returns
    -------
    Recording, dict

    Raises
    ------
    RecordingError
        A gap is longer than ``max_gap_s``; the message names the channel and
        the time span of the first such gap and counts the others.

    Examples
    --------
    >>> rec = Recording(np.arange(6.0), {"y": [0, 1, np.nan, np.nan, 4, 5]})
    >>> out, rep = fill_gaps(rec, max_gap_s=5)
    >>> out["y"].tolist(), rep["filled"]["y"]["points"]
    ([0.0, 1.0, 2.0, 3.0, 4.0, 5.0], 2)
    """
    if not (max_gap_s >= 0):  # inf allowed: fill every gap
        raise ConfigError(f"max_gap_s is {max_gap_s!r}; expected a duration >= 0 s")
    cols = _columns(rec, columns, list(rec.columns))
    t = rec.time
    new: dict[str, NDArray[np.float64]] = {}
    filled: dict[str, Any] = {}
    for c in cols:
        x = rec[c]
        ok = np.isfinite(x)
        if not ok.any():
            raise RecordingError(
                f"channel {c!r} of recording {rec.experiment_id!r} holds no valid sample "
                "(NaN only); drop it or fix the logger"
            )
        s, e = nan_runs(ok)
        interior = (s > 0) & (e < x.size)
        s_in, e_in = s[interior], e[interior]
        spans = t[e_in] - t[s_in - 1]
        long_ = spans > max_gap_s * (1 + 1e-12)
        if long_.any():
            k = int(np.argmax(long_))
            raise RecordingError(
                f"channel {c!r} of recording {rec.experiment_id!r} has a gap of "
                f"{float(spans[k]):.6g} s from {float(t[s_in[k] - 1]):.6g} s to "
                f"{float(t[e_in[k]]):.6g} s (no valid sample in between), longer than "
                f"max_gap_s = {max_gap_s:g} s"
                + (f"; {int(long_.sum()) - 1} more such gap(s)" if long_.sum() > 1 else "")
                + "; raise max_gap_s to interpolate it, or cut the recording "
                "(Recording.slice) into parts without it"
            )
        lead = int(e[0]) if s.size and s[0] == 0 else 0
        trail = int(x.size - s[-1]) if s.size and e[-1] == x.size else 0
        n_fill = int((e_in - s_in).sum())
        if n_fill:
            y = np.array(x, copy=True)
            holes = ~ok
            holes[:lead] = False
            if trail:
                holes[x.size - trail :] = False
            y[holes] = np.interp(t[holes], t[ok], x[ok])
            new[c] = y
        filled[c] = {
            "gaps": int(s_in.size),
            "points": n_fill,
            "longest_s": float(spans.max()) if spans.size else 0.0,
            "leading_nan": lead,
            "trailing_nan": trail,
        }
    report = {
        "step": "fill_gaps",
        "max_gap_s": float(max_gap_s),
        "method": "linear",
        "filled": filled,
        "total_filled": int(sum(v["points"] for v in filled.values())),
    }
    return _replaced(rec, new, report), report


# ======================================================== ambient / detrending
def subtract_ambient(
    rec: Recording,
    ambient: str = "T_amb",
    columns: Sequence[str] | str | None = None,
    *,
    drop: bool = False,
) -> tuple[Recording, dict[str, Any]]:
    """Express temperatures as rises above the ambient channel (paper 001, 2.3.1).

    Parameters
    ----------
    rec : Recording
    ambient : str
        Name of the ambient-temperature column.
    columns : sequence of str, optional
        Columns to subtract it from; default every column with the ambient's
        unit (or, without units, every output), except the ambient itself.
    drop : bool
        Remove the ambient column afterwards (it is kept by default: data is
        never lost, and it can serve as a disturbance input).

    Returns
    -------
    Recording
        The subtracted columns carry the unit ``"K"`` (a temperature
        difference).
    dict

    Examples
    --------
    >>> rec = Recording([0.0, 1.0], {"T": [25.0, 27.0], "T_amb": [24.0, 24.5]},
    ...                 units={"T": "°C", "T_amb": "°C"})
    >>> out, rep = subtract_ambient(rec)
    >>> out["T"].tolist(), out.units["T"], rep["columns"]
    ([1.0, 2.5], 'K', ['T'])
    """
    if ambient not in rec.columns:
        raise ConfigError(
            f"ambient column {ambient!r} is not in recording {rec.experiment_id!r}; columns "
            f"are {list(rec.columns)} (pass ambient=NAME)"
        )
    unit = rec.units.get(ambient)
    if columns is None:
        if unit is not None:
            cols = [c for c in rec.columns if c != ambient and rec.units.get(c) == unit]
        else:
            cols = [c for c in rec.columns if c != ambient and rec.roles.get(c) == "output"]
    else:
        cols = _columns(rec, columns, [])
        if ambient in cols:
            raise ConfigError(f"cannot subtract the ambient {ambient!r} from itself")
    amb = rec[ambient]
    data = {c: rec[c] - amb for c in cols}
    report = {
        "step": "subtract_ambient",
        "ambient": ambient,
        "columns": cols,
        "ambient_mean": float(np.nanmean(amb)) if np.isfinite(amb).any() else math.nan,
        "dropped_ambient": bool(drop),
    }
    out = _replaced(rec, data, report, units={c: "K" for c in cols})
    if drop:
        out = out.drop(ambient)
    return out, report


def detrend(
    rec: Recording,
    kind: str = "constant",
    columns: Sequence[str] | str | None = None,
) -> tuple[Recording, dict[str, Any]]:
    """Remove a constant, a linear trend or the initial value from columns.

    Parameters
    ----------
    rec : Recording
    kind : {"constant", "linear", "initial"}
        Subtract the mean, the least-squares line, or the first value.
    columns : sequence of str, optional
        Default: every column.

    Returns
    -------
    Recording
    dict
        Report with the removed offsets (and slopes, per second) so they can
        be added back.

    Examples
    --------
    >>> rec = Recording([0.0, 1.0, 2.0], {"y": [1.0, 3.0, 5.0]})
    >>> out, rep = detrend(rec, "linear")
    >>> bool(np.allclose(out["y"], 0.0)), round(rep["slope_per_s"]["y"], 9)
    (True, 2.0)
    """
    if kind not in _DETREND_KINDS:
        raise ConfigError(f"detrend kind {kind!r}; expected one of {_DETREND_KINDS}")
    cols = _columns(rec, columns, list(rec.columns))
    t = rec.time - rec.time[0]
    data, off, slope = {}, {}, {}
    for c in cols:
        x = rec[c]
        ok = np.isfinite(x)
        if not ok.any():
            raise RecordingError(f"channel {c!r} holds no valid sample; cannot detrend it")
        if kind == "constant":
            o, s = float(np.mean(x[ok])), 0.0
        elif kind == "initial":
            o, s = float(x[ok][0]), 0.0
        else:
            s, o = (float(v) for v in np.polyfit(t[ok], x[ok], 1))
        data[c] = x - o - s * t
        off[c], slope[c] = o, s
    report = {"step": "detrend", "kind": kind, "offset": off, "slope_per_s": slope}
    return _replaced(rec, data, report), report


# ===================================================================== pipeline
@dataclass(frozen=True)
class PrepareConfig:
    """Options of :func:`prepare` (each step can be switched off).

    Attributes
    ----------
    columns : tuple of str, optional
        Columns to keep (others are dropped first); all by default.
    outliers : bool
        Run :func:`remove_outliers`.
    outlier_columns : tuple of str, optional
        Channels to clean; default the measured ones (:func:`measured_columns`).
    hampel_window : int
        Hampel half-width [samples].
    hampel_sigma : float
        Hampel threshold [robust σ].
    valid_range : (float, float), optional
        Physical sensor limits; readings at or beyond them are outliers.
    dt : float, optional
        Resampling period [s] (paper 001: 1 Hz); ``None`` keeps a uniform
        time axis as it is (and refuses a non-uniform one).
    resample_method : {"linear", "mean"}
    max_gap_s : float
        Longest gap interpolated [s]; a longer one is an error.
    align : bool
        Start (and end) all channels together and reset time to 0.
    ambient : str, optional
        Ambient column to subtract from the temperatures.
    ambient_columns : tuple of str, optional
        Columns the ambient is subtracted from (default: same unit).
    drop_ambient : bool
        Remove the ambient column after subtracting it.
    detrend : {"constant", "linear", "initial"}, optional
        Detrending applied last.
    detrend_columns : tuple of str, optional
    """

    columns: tuple[str, ...] | None = None
    outliers: bool = True
    outlier_columns: tuple[str, ...] | None = None
    hampel_window: int = 7
    hampel_sigma: float = 6.0
    valid_range: tuple[float, float] | None = None
    dt: float | None = 1.0
    resample_method: str = "linear"
    max_gap_s: float = 60.0
    align: bool = True
    ambient: str | None = None
    ambient_columns: tuple[str, ...] | None = None
    drop_ambient: bool = False
    detrend: str | None = None
    detrend_columns: tuple[str, ...] | None = None

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready settings."""
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(self).items()}


def prepare(rec: Recording, config: PrepareConfig | None = None, **options: Any) -> Recording:
    """Run the preparation pipeline; the report lands in ``meta["preparation"]``.

    Order: select columns → outliers → resample → align → fill gaps →
    subtract ambient → detrend. ``meta["preparation"]`` holds the settings,
    the raw recording's fingerprint and one report per step.

    Parameters
    ----------
    rec : Recording
        Raw (possibly asynchronous) data.
    config : PrepareConfig, optional
    **options
        Fields of :class:`PrepareConfig` overriding ``config`` (unknown names
        are refused).

    Returns
    -------
    Recording
        Uniform, finite everywhere.

    Raises
    ------
    ConfigError
        Unknown option.
    RecordingError
        NaN-only channel, gap longer than ``max_gap_s`` (named), no common
        valid sample, non-uniform data with ``dt=None``.

    Examples
    --------
    >>> t = np.sort(np.random.default_rng(0).uniform(0, 100, 400))
    >>> y = 20 + 0.05 * t; y[::37] = np.nan; y[50] = 300.0
    >>> rec = Recording(t, {"T": y, "T_amb": np.full(t.size, 20.0)},
    ...                 units={"T": "°C", "T_amb": "°C"})
    >>> out = prepare(rec, ambient="T_amb", valid_range=(-50, 300))
    >>> out.is_uniform(), bool(np.isfinite(out["T"]).all()), out.units["T"]
    (True, True, 'K')
    >>> [s["step"] for s in out.meta["preparation"]["steps"]]
    ['remove_outliers', 'resample', 'align', 'fill_gaps', 'subtract_ambient']
    """
    cfg = config or PrepareConfig()
    if options:
        known = set(PrepareConfig.__dataclass_fields__)
        unknown = sorted(set(options) - known)
        if unknown:
            raise ConfigError(
                f"unknown preparation option(s) {unknown}; options are {sorted(known)}"
            )
        norm = {k: (tuple(v) if isinstance(v, list) else v) for k, v in options.items()}
        cfg = PrepareConfig(**{**asdict(cfg), **norm})
    raw_fp = rec.fingerprint()
    out = rec.copy()
    out.meta["preparation"] = {"raw_fingerprint": raw_fp, "config": cfg.to_dict(), "steps": []}
    if cfg.columns is not None:
        out = out.select(list(cfg.columns))
    empty = out.all_nan_columns()
    if empty:
        raise RecordingError(
            f"channel(s) {empty} of recording {rec.experiment_id!r} hold no valid sample (NaN "
            "only); leave them out with columns=[...] or fix the logger"
        )
    if cfg.outliers:
        out, _ = remove_outliers(
            out,
            cfg.outlier_columns,
            window=cfg.hampel_window,
            n_sigma=cfg.hampel_sigma,
            valid_range=cfg.valid_range,
        )
    if cfg.dt is not None:
        out, _ = resample(out, cfg.dt, method=cfg.resample_method)
    elif not out.is_uniform():
        out.dt  # noqa: B018  # raises the RecordingError that names the uneven step
    if cfg.align:
        out, _ = align(out)
    out, _ = fill_gaps(out, cfg.max_gap_s)
    left = [c for c in out.columns if not np.isfinite(out[c]).all()]
    if left:
        raise RecordingError(
            f"channel(s) {left} of recording {rec.experiment_id!r} still hold NaN at the "
            "start or end; enable align=True"
        )
    if cfg.ambient is not None:
        out, _ = subtract_ambient(out, cfg.ambient, cfg.ambient_columns, drop=cfg.drop_ambient)
    if cfg.detrend is not None:
        out, _ = detrend(out, cfg.detrend, cfg.detrend_columns)
    out.meta["preparation"]["raw_fingerprint"] = raw_fp
    return out


# ====================================================== identification gate
def check_identification_data(
    rec: Recording,
    inputs: Sequence[str],
    outputs: Sequence[str],
    *,
    min_samples: int = 2,
    what: str = "identification",
    step_inputs: bool = False,
) -> float:
    """Refuse data an identification method cannot use, with a clear reason.

    Parameters
    ----------
    rec : Recording
    inputs, outputs : sequence of str
        Columns the method reads.
    min_samples : int
        Fewest samples the method needs (e.g. ``2·horizon + order`` for N4SID).
    what : str
        Name of the method, for the messages.
    step_inputs : bool
        Accept an input that is constant but not zero: a step from zero at
        ``t = 0`` (the experiment starts at rest, the first sample is already
        the step).

    Returns
    -------
    float
        The sample period [s].

    Raises
    ------
    UnknownNameError
        A column is missing.
    RecordingError
        Non-uniform time axis, NaN-only or non-finite channel.
    IdentificationError
        Too few samples, or an input that never changes (it carries no
        information about the dynamics).

    Examples
    --------
    >>> rec = Recording(np.arange(5.0), {"u": np.ones(5), "y": np.arange(5.0)})
    >>> check_identification_data(rec, ["u"], ["y"])  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    thermogym.errors.IdentificationError: input 'u' of recording None is constant ...
    """
    if not isinstance(rec, Recording):
        raise RecordingError(
            f"{what}: a recording is a {type(rec).__name__} ({repr(rec)[:60]}); expected a "
            "thermogym Recording (read files with thermogym.recording.read_recording)"
        )
    names = [*inputs, *outputs]
    rec.select(names)  # raises UnknownNameError naming the missing column
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ConfigError(f"column(s) {dup} are named both as input and output (or twice)")
    if rec.n_samples < min_samples:
        raise IdentificationError(
            f"{what} needs at least {min_samples} samples, recording {rec.experiment_id!r} has "
            f"{rec.n_samples}; use a longer recording, a lower order or a shorter horizon"
        )
    dt = rec.dt  # RecordingError names the uneven step
    rec.check_values(names)  # NaN-only / non-finite, named
    for c in inputs:
        x = rec[c]
        if np.ptp(x) <= 1e-12 * max(1.0, float(np.abs(x).max())):
            if step_inputs and float(np.abs(x[0])) > 0:
                continue
            raise IdentificationError(
                f"input {c!r} of recording {rec.experiment_id!r} is constant ({float(x[0]):g} "
                f"everywhere); a constant input carries no information about the dynamics: "
                "give a recording where it changes, or treat it as a known offset"
            )
    return dt
