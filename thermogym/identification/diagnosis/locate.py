"""Locate a mismatch: which outputs, which time windows, which operating regimes.

Given the nominal model's simulation error ``e_j = y_j − ŷ_j`` on every
recording, :func:`locate` answers three questions a control engineer asks
before suspecting any physics:

* **signals** — the share of the (weighted) squared error each output
  carries, its RMS against the noise level, its NRMSE;
* **windows** — stretches of time where the smoothed residual stays outside
  what noise allows (``|ē| > 3 σ̂/√w`` for a moving mean over ``w`` samples),
  ranked by their squared error;
* **regimes** — how the residual depends on the operating regime: heating
  vs cooling and opening vs closing (sign of the simulated output's slope,
  noise-free), actuator on vs off, levels of each input (speed, feed rate,
  supply), temperature bands, early vs late in a run (drifts), and the
  recordings themselves (training vs validation, operating points). Each
  regime variable is scored by ``η² = SS_between / SS_total`` of the residual
  (the share of its variance explained by the regime's bin means) and
  weighted by the output's share of the error.

Regimes are derived from the model's signals and units alone (°C outputs get
bands and heating/cooling, mm outputs opening/closing, inputs with zeros get
on/off), so the same code locates errors of the AXT211, the RC networks and a
user's FOPTD model.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from thermogym._checks import with_unit

__all__ = ["Regime", "locate", "regime_variables"]

_TEMP = ("°C", "K", "degC")


@dataclass
class Regime:
    """A regime variable: a label for every sample of every recording.

    Attributes
    ----------
    name : str
        e.g. ``"heating/cooling of T_P"``, ``"level of speed"``.
    kind : str
        ``experiment``, ``input_level``, ``on_off``, ``heating_cooling``,
        ``opening_closing``, ``temperature_band``, ``time_in_run``.
    signal : str
        The signal that defines it (``""`` for experiment and time).
    labels : list of ndarray of int
        Bin of each sample, per recording (-1: excluded).
    bins : list of str
        Bin names.
    values : list of ndarray
        The regime variable's value per sample, per recording (for plots).
    """

    name: str
    kind: str
    signal: str
    labels: list[NDArray[np.int64]]
    bins: list[str]
    values: list[NDArray[np.float64]] = field(default_factory=list)


def _slope(y: NDArray[np.float64], dt: float) -> NDArray[np.float64]:
    return np.gradient(y, dt) if y.size > 1 else np.zeros_like(y)


def regime_variables(
    names: Sequence[str],
    roles: Sequence[str],
    units: dict[str, str],
    exo: Sequence[tuple[str, Sequence[NDArray[np.float64]]]],
    sims: Sequence[tuple[str, Sequence[NDArray[np.float64]]]],
    dts: Sequence[float],
    times: Sequence[NDArray[np.float64]],
) -> list[Regime]:
    """Build the regime variables of a set of recordings.

    Parameters
    ----------
    names : sequence of str
        Recording labels (experiment ids).
    roles : sequence of str
        ``"train"`` or ``"validation"`` per recording.
    units : dict
        Unit of every signal.
    exo : sequence of (name, per-recording arrays)
        Exogenous signals.
    sims : sequence of (name, per-recording arrays)
        Simulated outputs of the nominal model (noise-free slopes and levels).
    dts : sequence of float
        Sample periods [s].
    times : sequence of ndarray
        Sample times [s].

    Returns
    -------
    list of Regime
    """
    out: list[Regime] = []
    n_rec = len(names)
    out.append(
        Regime(
            "recording",
            "experiment",
            "",
            [np.full(t.size, i) for i, t in enumerate(times)],
            [f"{n} ({r})" for n, r in zip(names, roles, strict=True)],
            [np.full(t.size, float(i)) for i, t in enumerate(times)],
        )
    )
    thirds = []
    for t in times:
        rel = (t - t[0]) / max(float(t[-1] - t[0]), 1e-9)
        thirds.append(np.minimum((rel * 3).astype(int), 2))
    out.append(
        Regime(
            "time in run",
            "time_in_run",
            "",
            thirds,
            ["first third", "second third", "last third"],
            [(t - t[0]) / 3600.0 for t in times],
        )
    )
    for name, arrays in exo:
        allv = np.concatenate(arrays)
        finite = allv[np.isfinite(allv)]
        if finite.size == 0 or np.ptp(finite) == 0:
            continue
        levels = np.unique(np.round(finite, 6))
        if (finite == 0).any() and (finite != 0).any():
            out.append(
                Regime(
                    f"{name} on/off",
                    "on_off",
                    name,
                    [(a != 0).astype(np.int64) for a in arrays],
                    ["off (0)", "on (> 0)"],
                    [np.asarray(a, dtype=float) for a in arrays],
                )
            )
        if levels.size <= 8:
            if levels.size > 2 or not ((finite == 0).any()):
                lab = [np.searchsorted(levels, np.round(a, 6)) for a in arrays]
                out.append(
                    Regime(
                        f"level of {name}",
                        "input_level",
                        name,
                        lab,
                        [with_unit(f"{v:g}", units.get(name)) for v in levels],
                        [np.asarray(a, dtype=float) for a in arrays],
                    )
                )
        else:
            edges = np.unique(np.quantile(finite, [0.2, 0.4, 0.6, 0.8]))
            lab = [np.searchsorted(edges, a) for a in arrays]
            bounds = [float(finite.min()), *edges.tolist(), float(finite.max())]
            out.append(
                Regime(
                    f"level of {name}",
                    "input_level",
                    name,
                    lab,
                    [f"{a:.3g}-{b:.3g}" for a, b in itertools.pairwise(bounds)],
                    [np.asarray(a, dtype=float) for a in arrays],
                )
            )
    for name, arrays in sims:
        unit = units.get(name, "")
        allv = np.concatenate(arrays)
        if not np.isfinite(allv).any() or np.nanmax(allv) == np.nanmin(allv):
            continue
        if unit in _TEMP or unit == "mm":
            slopes = [_slope(a, dt) for a, dt in zip(arrays, dts, strict=True)]
            scale = float(np.nanmax(np.abs(np.concatenate(slopes)))) or 1.0
            dead = 0.02 * scale
            lab = [np.where(s > dead, 0, np.where(s < -dead, 1, 2)) for s in slopes]
            kind, bins = (
                ("heating_cooling", ["heating", "cooling", "steady"])
                if unit in _TEMP
                else ("opening_closing", ["opening", "closing", "at rest"])
            )
            out.append(
                Regime(
                    f"{bins[0]}/{bins[1]} ({name})",
                    kind,
                    name,
                    lab,
                    bins,
                    [s * 60.0 for s in slopes],
                )
            )
        if unit in _TEMP:
            lo, hi = float(np.nanmin(allv)), float(np.nanmax(allv))
            nb = int(min(8, max(3, math.ceil((hi - lo) / 5.0))))
            edges = np.linspace(lo, hi, nb + 1)[1:-1]
            lab = [np.searchsorted(edges, a) for a in arrays]
            full = [lo, *edges.tolist(), hi]
            out.append(
                Regime(
                    f"temperature band of {name}",
                    "temperature_band",
                    name,
                    lab,
                    [f"{a:.1f}-{b:.1f} {unit}" for a, b in itertools.pairwise(full)],
                    [np.asarray(a, dtype=float) for a in arrays],
                )
            )
    del n_rec
    return out


def eta_squared(
    e: Sequence[NDArray[np.float64]], labels: Sequence[NDArray[np.int64]], n_bins: int
) -> tuple[float, list[dict[str, float]]]:
    """Share of the residual variance explained by the bin means, and per-bin stats."""
    ev = np.concatenate([np.asarray(x, dtype=float) for x in e])
    lv = np.concatenate([np.asarray(x) for x in labels])
    ok = np.isfinite(ev) & (lv >= 0)
    ev, lv = ev[ok], lv[ok]
    stats: list[dict[str, float]] = []
    if ev.size < 3:
        return 0.0, stats
    mean = float(ev.mean())
    ss_tot = float(np.sum((ev - mean) ** 2))
    counts = np.bincount(lv, minlength=n_bins).astype(float)
    sums = np.bincount(lv, weights=ev, minlength=n_bins)
    sq = np.bincount(lv, weights=ev * ev, minlength=n_bins)
    with np.errstate(invalid="ignore", divide="ignore"):
        means = np.where(counts > 0, sums / np.maximum(counts, 1), np.nan)
        rms = np.where(counts > 0, np.sqrt(sq / np.maximum(counts, 1)), np.nan)
    ss_b = float(np.nansum(counts * (means - mean) ** 2))
    for b in range(n_bins):
        stats.append({"n": int(counts[b]), "mean": float(means[b]), "rms": float(rms[b])})
    return (ss_b / ss_tot if ss_tot > 0 else 0.0), stats


def _windows(
    e: NDArray[np.float64], t: NDArray[np.float64], sigma: float, w: int
) -> list[tuple[int, int]]:
    ok = np.isfinite(e)
    x = np.where(ok, e, 0.0)
    if x.size < w or not math.isfinite(sigma) or sigma <= 0:
        return []
    k = np.ones(w) / w
    sm = np.convolve(x, k, mode="same")
    bad = np.abs(sm) > 3.0 * sigma / math.sqrt(w)
    if not bad.any():
        return []
    d = np.diff(np.concatenate([[0], bad.astype(np.int8), [0]]))
    starts, ends = np.flatnonzero(d == 1), np.flatnonzero(d == -1)
    # the centred moving mean spreads a window by w/2 on each side: take that back
    h = w // 2
    out = []
    for a, b in zip(starts.tolist(), ends.tolist(), strict=True):
        a2 = a + h if a > 0 else a
        b2 = b - h if b < x.size else b
        out.append((a2, b2) if b2 > a2 else (a, b))
    return out


def locate(
    outputs: Sequence[str],
    recordings: Sequence[dict[str, Any]],
    regimes: Sequence[Regime],
    sigma: dict[str, float],
    scale: dict[str, float],
    *,
    max_windows: int = 8,
    max_regimes: int = 6,
) -> dict[str, Any]:
    """Which signals, windows and regimes carry the error.

    Parameters
    ----------
    outputs : sequence of str
        Compared outputs.
    recordings : sequence of dict
        Per recording: ``name``, ``role``, ``time`` (T,), ``dt``, ``residual``
        (T, n_y) and ``measured`` (T, n_y).
    regimes : sequence of Regime
        From :func:`regime_variables`, on the same recordings.
    sigma, scale : dict
        Noise level and spread of each output.
    max_windows, max_regimes : int
        How many of each to report.

    Returns
    -------
    dict
        ``signals`` (sorted by share), ``windows``, ``regimes`` (sorted by score).
    """
    n_y = len(outputs)
    sse = np.zeros(n_y)
    sq = np.zeros(n_y)
    cnt = np.zeros(n_y)
    for r in recordings:
        e = np.asarray(r["residual"], dtype=float)
        ok = np.isfinite(e)
        sq += np.where(ok, e * e, 0.0).sum(axis=0)
        cnt += ok.sum(axis=0)
        inv_scale = np.array([1.0 / (scale[o] or 1.0) for o in outputs])
        sse += np.where(ok, (e * inv_scale) ** 2, 0.0).sum(axis=0)
    share = sse / sse.sum() if sse.sum() > 0 else np.zeros(n_y)
    signals: list[dict[str, Any]] = []
    for j, o in enumerate(outputs):
        rms = math.sqrt(sq[j] / max(cnt[j], 1))
        sig = sigma.get(o, math.nan)
        sys_rms = math.sqrt(max(0.0, rms * rms - sig * sig)) if math.isfinite(sig) else rms
        signals.append(
            {
                "signal": o,
                "share_of_error": float(share[j]),
                "rms": rms,
                "noise_sigma": sig,
                "systematic_rms": sys_rms,
                "rms_over_noise": rms / sig if math.isfinite(sig) and sig > 0 else math.nan,
            }
        )
    signals.sort(key=lambda d: -d["share_of_error"])

    windows = []
    for r in recordings:
        t = np.asarray(r["time"], dtype=float)
        dt = float(r["dt"])
        e = np.asarray(r["residual"], dtype=float)
        for j, o in enumerate(outputs):
            sig = sigma.get(o, math.nan)
            w = int(max(3, min(e.shape[0] // 10, round(600.0 / dt) if dt < 600 else 3)))
            for a, b in _windows(e[:, j], t, sig, w):
                seg = e[a:b, j]
                seg = seg[np.isfinite(seg)]
                if seg.size == 0:
                    continue
                windows.append(
                    {
                        "recording": r["name"],
                        "role": r["role"],
                        "signal": o,
                        "t_start_s": float(t[a]),
                        "t_end_s": float(t[min(b, t.size - 1)]),
                        "mean_residual": float(seg.mean()),
                        "rms_residual": float(np.sqrt(np.mean(seg**2))),
                        "weighted_sse": float(np.sum((seg / (scale[o] or 1.0)) ** 2)),
                    }
                )
    windows.sort(key=lambda d: -d["weighted_sse"])

    reg_out: list[dict[str, Any]] = []
    for reg in regimes:
        for j, o in enumerate(outputs):
            if reg.signal and reg.kind in (
                "heating_cooling",
                "opening_closing",
                "temperature_band",
            ):
                if reg.signal != o:
                    continue
            es = [np.asarray(r["residual"], dtype=float)[:, j] for r in recordings]
            eta, stats = eta_squared(es, reg.labels, len(reg.bins))
            bins: list[dict[str, Any]] = [
                {"bin": name, **st} for name, st in zip(reg.bins, stats, strict=True) if st["n"] > 0
            ]
            if len(bins) < 2:
                continue
            worst = max(bins, key=lambda d: abs(d["mean"]) if math.isfinite(d["mean"]) else 0.0)
            reg_out.append(
                {
                    "variable": reg.name,
                    "kind": reg.kind,
                    "regime_signal": reg.signal,
                    "signal": o,
                    "eta2": float(eta),
                    "score": float(eta * share[j]),
                    "worst_bin": worst["bin"],
                    "bins": bins,
                }
            )
    reg_out.sort(key=lambda d: -d["score"])
    return {
        "signals": signals,
        "windows": windows[:max_windows],
        "regimes": reg_out[:max_regimes],
        "all_regimes": reg_out,
    }
