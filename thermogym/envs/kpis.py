"""Key performance indicators of DESIGN.md as pure functions of trajectories.

Every environment accumulates these KPIs while it runs and returns them at the
end of an episode in ``info["kpis"]``; the controller benchmark harness
computes the same numbers from recorded trajectories with the functions here.
The environments use the same streaming primitives (:func:`tp_update`) so that
both give the same values on the same trajectory. The AXT211 environments feed
the wax temperature after every integration sub-step, not only at the end of a
control period: their wax cycles equal :func:`wax_thermal_cycles` of that dense
trajectory (a PWM period long against the wax's time constant heats and cools
it within the period, which end-of-period samples do not see).

Units are in the names (DESIGN.md, "KPIs for controller comparison"):

============================  ==========================================================
KPI                           definition
============================  ==========================================================
``actuator_energy_Wh``        ∫ P_PTC dt / 3600 (heater electrical energy)
``heat_delivered_kWh``        ∫ Q_heat dt / 3.6e6 (radiator heat into the room)
``switch_cycles``             number of heater switch-on events (off → on edges)
``stroke_travel_mm``          Σ |Δx_V| (total valve-stem travel)
``stroke_reversals``          direction changes of x_V larger than a hysteresis
``wax_thermal_cycles``        rainflow-counted cycles of the wax temperature T_P
``wax_damage``                Palmgren-Miner sum over those cycles (see below)
``time_above_limit_h``        time a temperature spends above its limit
``stroke_rmse_mm``            root mean square of x_V − x_ref
``stroke_iae_mm_s``           ∫ |x_V − x_ref| dt
``discomfort_Kh``             ∫ distance of T_zone outside the comfort band dt, occupied
``bearing_over_limit_Kh``     ∫ max(max_i T_bearing,i − limit, 0) dt
``elongation_error_um``       RMS of the thermal elongation left after compensation,
                              ΔL − c with ΔL = Σ α ΔT L (eq 5 of 000_24627a5308ee07db.txt)
============================  ==========================================================

Turning points and rainflow
---------------------------
Reversals and thermal cycles are counted on the *turning points* of a signal
after a hysteresis filter (a "racetrack" filter): a peak or a valley is
confirmed only once the signal has moved away from it by at least the
hysteresis ``h``, so measurement noise and ripple smaller than ``h`` do not
count. The first sample is the first turning point and the last candidate
extreme the last one. Cycles are then counted by the four-point rainflow
method of ASTM E1049-85 (:mod:`rainflow` package) on that sequence.

Wax damage model (assumptions)
------------------------------
The wax cartridge of a thermal actuator ages with every expansion-contraction
cycle of its wax charge (fatigue of the elastomer diaphragm and seals that
the expanding wax pushes, and wear of the guide). We count that as thermal
fatigue driven by the temperature range of each rainflow cycle of T_P, with a
Basquin / Coffin-Manson type S-N curve in the temperature range and linear
Palmgren-Miner accumulation::

    N_f(ΔT) = N_ref (ΔT_ref / ΔT)^m          cycles to failure at range ΔT
    D = Σ_i n_i / N_f(ΔT_i)                   n_i = 1 (full) or 0.5 (half cycle)

Defaults (chosen here, not published for the AXT211): ``N_ref = 1e5`` full
cycles at ``ΔT_ref = 50 K`` (a full open-close stroke from a 25 °C room takes
the wax from about 25 to 75 °C), exponent ``m = 2``; cycles smaller than the
hysteresis (default 2 K) are ignored (endurance limit). Stated simplifications:
no mean-temperature or dwell-time effect, no sequence effect (Miner), failure
at ``D = 1``. ``D`` is therefore a relative lifetime consumption for comparing
control strategies, not a calibrated life prediction.

Since neither the exponent nor the endurance limit is known for a wax
cartridge, :func:`wax_cycle_kpis` also returns the cycle count and the Miner
sum under the other assumptions of :data:`SN_CUTOFFS_K` (cut-off ranges: a
cycle with a smaller range, i.e. an amplitude under half of it, does no
damage) and :data:`SN_EXPONENTS`, so that a report can show whether a ranking
of controllers survives them (:func:`thermogym.controllers.tables.lifetime_rankings`).
The heater's switching operations (``switch_cycles``) are a wear KPI of their
own: they wear a relay's contacts, whatever the wax does.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numba as nb
import numpy as np
import rainflow
from numpy.typing import ArrayLike, NDArray

from thermogym._checks import nonnegative, positive
from thermogym.errors import ShapeError

__all__ = [
    "DAMAGE_EXPONENT",
    "DAMAGE_N_REF",
    "DAMAGE_RANGE_REF_K",
    "SN_CUTOFFS_K",
    "SN_EXPONENTS",
    "actuator_energy_Wh",
    "bearing_over_limit_Kh",
    "discomfort_Kh",
    "elongation_error_um",
    "energy_Wh",
    "heat_delivered_kWh",
    "miner_damage",
    "pwm_switch_cycles",
    "rainflow_cycles",
    "sn_columns",
    "stroke_iae_mm_s",
    "stroke_reversals",
    "stroke_rmse_mm",
    "stroke_travel_mm",
    "switch_cycles",
    "time_above_limit_h",
    "tp_finish",
    "tp_select",
    "tp_update",
    "tp_update_at",
    "turning_points",
    "wax_cycle_kpis",
    "wax_damage",
    "wax_thermal_cycles",
]

#: Cycles to failure at the reference range (assumption, see the module docstring).
DAMAGE_N_REF = 1.0e5
#: Reference temperature range of the S-N curve [K].
DAMAGE_RANGE_REF_K = 50.0
#: Exponent m of the S-N curve.
DAMAGE_EXPONENT = 2.0
#: Cut-off ranges [K] of the S-N variants (the first is the turning-point hysteresis).
SN_CUTOFFS_K: tuple[float, ...] = (2.0, 5.0, 10.0, 20.0)
#: Exponents m of the S-N variants.
SN_EXPONENTS: tuple[float, ...] = (1.0, 2.0, 3.0, 4.0)


def _series(x: ArrayLike, name: str) -> NDArray[np.float64]:
    a = np.asarray(x, dtype=np.float64)
    if a.ndim != 1:
        raise ShapeError(f"{name} has shape {a.shape}, expected a 1-D series")
    if not np.isfinite(a).all():
        i = int(np.argmax(~np.isfinite(a)))
        raise ShapeError(f"{name}[{i}] is {float(a[i])!r}; KPIs need finite samples")
    return a


def _dt(dt: float) -> float:
    return positive("dt", dt, unit="s", error=ShapeError, text=False)


def _pair(x: ArrayLike, ref: ArrayLike, a: str, b: str) -> tuple[NDArray, NDArray]:
    xa = _series(x, a)
    ra = np.broadcast_to(np.asarray(ref, dtype=np.float64), xa.shape)
    if not np.isfinite(ra).all():
        raise ShapeError(f"{b} holds non-finite values")
    return xa, ra


# ------------------------------------------------------------------- energy
def energy_Wh(power_W: ArrayLike, dt: float, *, method: str = "rectangle") -> float:
    """Energy [Wh] of a power signal sampled every ``dt`` seconds.

    Parameters
    ----------
    power_W : array_like, shape (T,)
        Power [W].
    dt : float
        Sample period [s].
    method : {"rectangle", "trapezoid"}
        ``"rectangle"``: each sample is the mean power of the interval that
        follows it (zero-order hold, the convention of the models' inputs);
        ``"trapezoid"``: samples are instantaneous values at the interval ends.

    Returns
    -------
    float

    Examples
    --------
    >>> energy_Wh([3.0, 3.0, 0.0, 0.0], dt=1800.0)
    3.0
    """
    p = _series(power_W, "power_W")
    d = _dt(dt)
    if method == "rectangle":
        return float(p.sum() * d / 3600.0)
    if method == "trapezoid":
        return float(np.trapezoid(p, dx=d) / 3600.0)
    raise ShapeError(f"method is {method!r}; expected 'rectangle' or 'trapezoid'")


def actuator_energy_Wh(P_PTC_W: ArrayLike, dt: float, *, method: str = "rectangle") -> float:
    """Electrical energy of the actuator heater, ``∫ P_PTC dt`` [Wh] (see :func:`energy_Wh`)."""
    return energy_Wh(P_PTC_W, dt, method=method)


def heat_delivered_kWh(Q_heat_W: ArrayLike, dt: float, *, method: str = "rectangle") -> float:
    """Heat delivered into the room, ``∫ Q_heat dt`` [kWh] (see :func:`energy_Wh`)."""
    return energy_Wh(Q_heat_W, dt, method=method) / 1000.0


# ---------------------------------------------------------------- switching
def switch_cycles(on: ArrayLike, *, initially_on: bool = False) -> int:
    """Number of switch-on events (off → on edges) of a sampled on/off signal.

    Parameters
    ----------
    on : array_like of bool or {0, 1}, shape (T,)
        Heater state per sample (held over the interval).
    initially_on : bool
        State before the first sample.

    Examples
    --------
    >>> switch_cycles([1, 1, 0, 0, 1, 0, 1])
    3
    """
    s = _series(on, "on") > 0.5
    prev = np.concatenate([[bool(initially_on)], s[:-1]])
    return int(np.count_nonzero(s & ~prev))


def pwm_switch_cycles(duty: ArrayLike, *, initially_on: bool = False) -> int:
    """Switch-on events of a heater driven by PWM, one duty cycle per period.

    In each period the heater is on for ``duty · period`` at its start and off
    for the rest, so a period with ``0 < duty`` switches on unless the heater
    was still on at the end of the previous period (previous duty 1).

    Parameters
    ----------
    duty : array_like, shape (T,)
        Duty cycle per PWM period, in [0, 1].
    initially_on : bool
        Heater on at the start (as after a period of duty 1).

    Examples
    --------
    >>> pwm_switch_cycles([0.5, 0.5, 1.0, 1.0, 0.2, 0.0, 0.3])
    4
    """
    d = _series(duty, "duty")
    if (d < 0).any() or (d > 1).any():
        raise ShapeError("duty holds values outside [0, 1]")
    end_on = np.concatenate([[bool(initially_on)], d[:-1] >= 1.0])
    return int(np.count_nonzero((d > 0.0) & ~end_on))


# ------------------------------------------------------- turning points
@nb.njit(cache=True, inline="always")
def _tp_next(
    started: float, ext: float, d: float, conf: float, v: float, h: float
) -> tuple[float, float, float, float, float]:
    # one sample of the turning-point tracker on its state (started, extreme, direction,
    # confirmed): the new state and a confirmed turning point or NaN
    if started == 0.0:
        return 1.0, v, 0.0, conf, v
    if d == 0.0:
        if v - ext >= h:
            return started, v, 1.0, conf, math.nan
        if ext - v >= h:
            return started, v, -1.0, conf, math.nan
        return started, ext, d, conf, math.nan
    if d > 0.0:
        if v > ext:
            return started, v, d, conf, math.nan
        if ext - v >= h:
            return started, v, -1.0, conf + 1.0, ext
        return started, ext, d, conf, math.nan
    if v < ext:
        return started, v, d, conf, math.nan
    if v - ext >= h:
        return started, v, 1.0, conf + 1.0, ext
    return started, ext, d, conf, math.nan


@nb.njit(cache=True, inline="always")
def tp_select(
    started: float, ext: float, d: float, conf: float, v: float, h: float
) -> tuple[float, float, float, float, float, bool]:
    """:func:`tp_update`'s step on a tracker state, branch-free (selects only).

    The same new state ``(started, extreme, direction, confirmed)`` as the
    tracker, then the value of the turning point this sample confirms and whether
    it confirms one (the first sample confirms itself). For loops over many
    trackers that must vectorise (the lockstep kernels of the AXT211
    environments); the values are those of :func:`tp_update`, bit for bit.
    """
    first = started == 0.0
    pos = d > 0.0
    neg = d < 0.0
    up = v - ext >= h
    dn = ext - v >= h
    higher = v > ext
    lower = v < ext
    peak = pos & (not higher) & dn  # a peak confirmed: moved down by h from it
    valley = neg & (not lower) & up  # a valley confirmed
    flat = not (pos | neg)
    moved = (pos & higher) | (neg & lower) | peak | valley | (flat & (up | dn))
    d1 = d
    d1 = 1.0 if (flat & up) else d1
    d1 = -1.0 if (flat & (not up) & dn) else d1
    d1 = -1.0 if peak else d1
    d1 = 1.0 if valley else d1
    turn = peak | valley
    return (
        1.0,
        v if (first | moved) else ext,
        0.0 if first else d1,
        conf + 1.0 if ((not first) & turn) else conf,
        v if first else ext,
        first | turn,
    )


@nb.njit(cache=True)
def tp_update(st: NDArray[np.float64], v: float, h: float) -> float:
    """Feed one sample ``v`` to a hysteresis turning-point tracker.

    ``st`` holds ``[started, extreme, direction, confirmed]`` (a float array
    of length 4, zeros before the first sample). Returns the value of a
    turning point confirmed by this sample, or NaN. The first sample is
    returned as the first turning point.
    """
    st[0], st[1], st[2], st[3], tp = _tp_next(st[0], st[1], st[2], st[3], v, h)
    return tp


@nb.njit(cache=True, inline="always")
def tp_update_at(a: NDArray[np.float64], r: int, c: int, v: float, h: float) -> float:
    """:func:`tp_update` on the tracker held in ``a[r, c:c + 4]`` (no array view: cheaper)."""
    a[r, c], a[r, c + 1], a[r, c + 2], a[r, c + 3], tp = _tp_next(
        a[r, c], a[r, c + 1], a[r, c + 2], a[r, c + 3], v, h
    )
    return tp


@nb.njit(cache=True)
def tp_finish(st: NDArray[np.float64]) -> float:
    """Last turning point of a tracker (its pending extreme), NaN if none moved."""
    if st[0] == 0.0 or st[2] == 0.0:
        return math.nan
    return st[1]


@nb.njit(cache=True)
def _turning_points(x: NDArray[np.float64], h: float) -> tuple[NDArray[np.float64], int]:
    st = np.zeros(4)
    out = np.empty(x.size + 1)
    n = 0
    for v in x:
        tp = tp_update(st, v, h)
        if not math.isnan(tp):
            out[n] = tp
            n += 1
    last = tp_finish(st)
    if not math.isnan(last):
        out[n] = last
        n += 1
    return out[:n], int(st[3])


def _hyst(h: float) -> float:
    return nonnegative("hysteresis", h, error=ShapeError, text=False)


def turning_points(x: ArrayLike, hysteresis: float) -> NDArray[np.float64]:
    """Turning points of ``x`` after a hysteresis filter (see the module docstring).

    Parameters
    ----------
    x : array_like, shape (T,)
    hysteresis : float
        Smallest move that confirms a peak or valley, in the unit of ``x``.

    Returns
    -------
    ndarray
        First sample, confirmed peaks and valleys, last pending extreme.

    Examples
    --------
    >>> turning_points([0.0, 1.0, 0.95, 2.0, 0.0, 0.1, 1.0], 0.5).tolist()
    [0.0, 2.0, 0.0, 1.0]
    """
    tp, _ = _turning_points(_series(x, "x"), _hyst(hysteresis))
    return tp


def stroke_travel_mm(x_V_mm: ArrayLike) -> float:
    """Total valve-stem travel ``Σ |Δx_V|`` [mm].

    Examples
    --------
    >>> stroke_travel_mm([0.0, 2.0, 1.0, 3.0])
    5.0
    """
    x = _series(x_V_mm, "x_V_mm")
    return float(np.abs(np.diff(x)).sum())


def stroke_reversals(x_V_mm: ArrayLike, hysteresis_mm: float = 0.05) -> int:
    """Direction changes of the valve stroke by more than ``hysteresis_mm``.

    Examples
    --------
    >>> stroke_reversals([0.0, 1.0, 0.98, 2.0, 0.0, 0.1, 1.0], 0.05)
    2
    """
    _, n = _turning_points(_series(x_V_mm, "x_V_mm"), _hyst(hysteresis_mm))
    return int(n)


def rainflow_cycles(x: ArrayLike, hysteresis: float = 0.0) -> list[tuple[float, float]]:
    """Rainflow cycles of ``x`` (ASTM E1049-85) after a hysteresis filter.

    Parameters
    ----------
    x : array_like, shape (T,)
    hysteresis : float
        Ranges smaller than this are filtered out before counting.

    Returns
    -------
    list of (range, count)
        ``count`` is 1 for full cycles and 0.5 for half cycles (residue).

    Examples
    --------
    >>> rainflow_cycles([0.0, 10.0, 2.0, 5.0, 0.0])  # one inner cycle, two half cycles
    [(3.0, 1.0), (10.0, 0.5), (10.0, 0.5)]
    """
    tp = turning_points(x, hysteresis)
    return _rainflow_tp(tp, hysteresis)


def _rainflow_tp(tp: NDArray[np.float64], hysteresis: float) -> list[tuple[float, float]]:
    if tp.size < 2:
        return []
    # four-point rainflow counting (ASTM E1049-85) by the rainflow package
    return [
        (float(rng), float(count))
        for rng, _mean, count, _i0, _i1 in rainflow.extract_cycles(tp)
        if rng > 0 and rng >= hysteresis
    ]


def wax_thermal_cycles(T_P_C: ArrayLike, min_range_K: float = 2.0) -> float:
    """Rainflow-counted thermal cycles of the wax temperature (full = 1, half = 0.5).

    Parameters
    ----------
    T_P_C : array_like, shape (T,)
        Wax-cartridge temperature [°C].
    min_range_K : float
        Hysteresis: cycles smaller than this are not counted [K].

    Examples
    --------
    >>> wax_thermal_cycles([25.0, 75.0, 25.0, 75.0, 25.0, 75.0, 25.0])
    3.0
    """
    return float(sum(c for _, c in rainflow_cycles(T_P_C, min_range_K)))


def miner_damage(
    cycles: Sequence[tuple[float, float]],
    *,
    n_ref: float = DAMAGE_N_REF,
    range_ref: float = DAMAGE_RANGE_REF_K,
    exponent: float = DAMAGE_EXPONENT,
) -> float:
    """Palmgren-Miner sum ``Σ n_i (ΔT_i/ΔT_ref)^m / N_ref`` of rainflow cycles.

    Parameters
    ----------
    cycles : sequence of (range, count)
        From :func:`rainflow_cycles`.
    n_ref : float
        Cycles to failure at ``range_ref``.
    range_ref : float
        Reference range of the S-N curve (unit of the ranges).
    exponent : float
        S-N exponent m.

    Examples
    --------
    >>> miner_damage([(50.0, 1.0), (25.0, 1.0)], n_ref=100.0, range_ref=50.0, exponent=2.0)
    0.0125
    """
    for name, v in (("n_ref", n_ref), ("range_ref", range_ref), ("exponent", exponent)):
        positive(f"damage model {name}", v, error=ShapeError, text=False)
    return float(sum(c * (r / range_ref) ** exponent for r, c in cycles) / n_ref)


def wax_damage(
    T_P_C: ArrayLike,
    min_range_K: float = 2.0,
    *,
    n_ref: float = DAMAGE_N_REF,
    range_ref_K: float = DAMAGE_RANGE_REF_K,
    exponent: float = DAMAGE_EXPONENT,
) -> float:
    """Miner damage of the wax cartridge from its temperature (module docstring model).

    Examples
    --------
    >>> round(wax_damage([25.0, 75.0, 25.0]), 8)  # one full 50 K cycle
    1e-05
    """
    return miner_damage(
        rainflow_cycles(T_P_C, min_range_K), n_ref=n_ref, range_ref=range_ref_K, exponent=exponent
    )


def sn_columns() -> dict[str, tuple[str, float, float | None]]:
    """Names of the S-N variant KPIs: ``column → (kind, cut-off [K], exponent)``.

    ``kind`` is ``"cycles"`` (rainflow count of the cycles at least the cut-off;
    exponent None) or ``"damage"`` (Miner sum over them with that exponent).

    Examples
    --------
    >>> cols = sn_columns()
    >>> cols["wax_cycles_ge5K"], cols["wax_damage_m3_ge10K"]
    (('cycles', 5.0, None), ('damage', 10.0, 3.0))
    """
    out: dict[str, tuple[str, float, float | None]] = {}
    for c in SN_CUTOFFS_K:
        out[f"wax_cycles_ge{c:g}K"] = ("cycles", c, None)
        for m in SN_EXPONENTS:
            out[f"wax_damage_m{m:g}_ge{c:g}K"] = ("damage", c, m)
    return out


def wax_cycle_kpis(cycles: Sequence[tuple[float, float]]) -> dict[str, float]:
    """The wax KPIs of rainflow cycles: the defaults and every S-N variant.

    Parameters
    ----------
    cycles : sequence of (range, count)
        Rainflow cycles of the wax temperature (:func:`rainflow_cycles`).

    Returns
    -------
    dict
        ``wax_thermal_cycles`` and ``wax_damage`` (the module docstring's
        defaults), then one value per :func:`sn_columns` name: the cycles whose
        range is at least the cut-off, counted or summed by Miner with the
        variant's exponent (``N_ref`` and ``ΔT_ref`` as the defaults).

    Examples
    --------
    >>> k = wax_cycle_kpis([(50.0, 1.0), (4.0, 1.0), (4.0, 0.5)])
    >>> k["wax_thermal_cycles"], k["wax_cycles_ge5K"]
    (2.5, 1.0)
    >>> k["wax_damage_m2_ge5K"] < k["wax_damage"] == k["wax_damage_m2_ge2K"]
    True
    """
    out = {
        "wax_thermal_cycles": float(sum(c for _, c in cycles)),
        "wax_damage": miner_damage(cycles),
    }
    for name, (kind, cut, m) in sn_columns().items():
        kept = [(r, c) for r, c in cycles if r >= cut]
        if kind == "cycles":
            out[name] = float(sum(c for _, c in kept))
        else:
            out[name] = miner_damage(kept, exponent=float(m))  # type: ignore[arg-type]
    return out


# ----------------------------------------------------------------- accuracy
def time_above_limit_h(y: ArrayLike, limit: float, dt: float) -> float:
    """Time [h] the sampled signal ``y`` spends above ``limit`` (each sample counts ``dt``).

    Examples
    --------
    >>> time_above_limit_h([80.0, 90.0, 91.0, 70.0], 85.0, dt=1800.0)
    1.0
    """
    a = _series(y, "y")
    return float(np.count_nonzero(a > limit) * _dt(dt) / 3600.0)


def stroke_rmse_mm(x_V_mm: ArrayLike, x_ref_mm: ArrayLike) -> float:
    """Root mean square tracking error of the valve stroke [mm].

    Examples
    --------
    >>> stroke_rmse_mm([1.0, 2.0], [0.0, 3.0])
    1.0
    """
    x, r = _pair(x_V_mm, x_ref_mm, "x_V_mm", "x_ref_mm")
    return float(np.sqrt(np.mean((x - r) ** 2))) if x.size else 0.0


def stroke_iae_mm_s(x_V_mm: ArrayLike, x_ref_mm: ArrayLike, dt: float) -> float:
    """Integral of the absolute stroke error ``Σ |x_V − x_ref| dt`` [mm·s].

    Examples
    --------
    >>> stroke_iae_mm_s([1.0, 2.0], [0.0, 3.0], dt=10.0)
    20.0
    """
    x, r = _pair(x_V_mm, x_ref_mm, "x_V_mm", "x_ref_mm")
    return float(np.abs(x - r).sum() * _dt(dt))


def discomfort_Kh(
    T_zone_C: ArrayLike,
    low_C: ArrayLike,
    high_C: ArrayLike,
    dt: float,
    occupied: ArrayLike | None = None,
) -> float:
    """Degree-hours [K·h] outside the comfort band while the room is occupied.

    ``Σ_k occ_k · max(low_k − T_k, 0, T_k − high_k) · dt / 3600``.

    Examples
    --------
    >>> discomfort_Kh([19.0, 21.0, 25.0], 20.0, 24.0, dt=3600.0)
    2.0
    >>> discomfort_Kh([19.0, 21.0, 25.0], 20.0, 24.0, dt=3600.0, occupied=[0, 1, 1])
    1.0
    """
    T, lo = _pair(T_zone_C, low_C, "T_zone_C", "low_C")
    hi = np.broadcast_to(np.asarray(high_C, dtype=float), T.shape)
    dev = np.maximum(np.maximum(lo - T, T - hi), 0.0)
    if occupied is not None:
        dev = dev * (np.broadcast_to(np.asarray(occupied, dtype=float), T.shape) > 0.5)
    return float(dev.sum() * _dt(dt) / 3600.0)


def bearing_over_limit_Kh(T_bearings_C: ArrayLike, limit_C: float, dt: float) -> float:
    """Degree-hours [K·h] the hottest bearing spends above ``limit_C``.

    Parameters
    ----------
    T_bearings_C : array_like, shape (T,) or (T, n_bearings)
        Bearing temperatures [°C].
    limit_C : float
        Temperature limit [°C].
    dt : float
        Sample period [s].

    Examples
    --------
    >>> bearing_over_limit_Kh([[40.0, 46.0], [50.0, 44.0]], 45.0, dt=3600.0)
    6.0
    """
    a = np.asarray(T_bearings_C, dtype=float)
    if a.ndim == 2:
        a = a.max(axis=1)
    a = _series(a, "T_bearings_C")
    return float(np.maximum(a - limit_C, 0.0).sum() * _dt(dt) / 3600.0)


def elongation_error_um(dL_um: ArrayLike, compensation_um: ArrayLike = 0.0) -> float:
    """RMS thermal elongation left after compensation [µm], ``ΔL − c``.

    ``ΔL = Σ_i α_i ΔT_i L_i`` is eq (5) of ``000_24627a5308ee07db.txt``;
    ``c`` is the offset the controller applies.

    Examples
    --------
    >>> elongation_error_um([10.0, 20.0], [10.0, 10.0])
    7.0710678118654755
    """
    d, c = _pair(dL_um, compensation_um, "dL_um", "compensation_um")
    return float(np.sqrt(np.mean((d - c) ** 2))) if d.size else 0.0
