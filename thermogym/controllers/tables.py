"""Benchmark tables: KPI axes, Pareto front, sim-to-real gap, mean ± std.

Pure functions of a benchmark's tidy table (one row per episode, see
:func:`~thermogym.controllers.harness.run_episode`); no files, no figures. The
harness, the report (:mod:`~thermogym.controllers.report`) and the figures
(:mod:`~thermogym.controllers.plots`) all read them from here.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd
from scipy import stats

from thermogym.envs.kpis import SN_CUTOFFS_K, SN_EXPONENTS, sn_columns

__all__ = [
    "AXES",
    "KEY_COLUMNS",
    "MAIN_KPIS",
    "format_mean_std",
    "kpi_axes",
    "lifetime_rankings",
    "lifetime_variants",
    "pareto_front",
    "sim_to_real_gap",
]

#: Columns that identify an episode (the rest are results).
KEY_COLUMNS = ("env_id", "scenario", "controller", "plant", "seed")

#: KPIs of the energy / lifetime / accuracy axes, in order of preference.
AXES: dict[str, tuple[str, ...]] = {
    "energy": ("heat_delivered_kWh", "actuator_energy_Wh"),
    "lifetime": ("wax_thermal_cycles", "switch_cycles", "stroke_travel_mm"),
    "accuracy": (
        "discomfort_Kh",
        "stroke_rmse_mm",
        "temperature_rmse_K",
        "bearing_over_limit_Kh",
        "elongation_error_um",
    ),
}
#: KPIs shown in the summary tables and bars (those present), in this order.
MAIN_KPIS = (
    "discomfort_Kh",
    "stroke_rmse_mm",
    "stroke_iae_mm_s",
    "temperature_rmse_K",
    "heat_delivered_kWh",
    "actuator_energy_Wh",
    "switch_cycles",
    "wax_thermal_cycles",
    "wax_damage",
    "stroke_travel_mm",
    "stroke_reversals",
    "time_above_limit_h",
)


def kpi_axes(columns: Sequence[str]) -> dict[str, str]:
    """The KPI used for each of energy, lifetime and accuracy among ``columns``.

    Examples
    --------
    >>> kpi_axes(["actuator_energy_Wh", "switch_cycles", "wax_thermal_cycles", "stroke_rmse_mm"])
    {'energy': 'actuator_energy_Wh', 'lifetime': 'wax_thermal_cycles', 'accuracy': 'stroke_rmse_mm'}
    """
    out = {}
    for axis, names in AXES.items():
        for n in names:
            if n in columns:
                out[axis] = n
                break
    return out


def pareto_front(points: np.ndarray) -> np.ndarray:
    """Mask of the non-dominated rows of ``points`` (every column minimised).

    Examples
    --------
    >>> pareto_front(np.array([[1.0, 2.0], [2.0, 1.0], [2.0, 2.0]])).tolist()
    [True, True, False]
    """
    p = np.asarray(points, dtype=float)
    keep = np.ones(len(p), dtype=bool)
    for i in range(len(p)):
        others = np.delete(p, i, axis=0)
        dominated = np.any(np.all(others <= p[i], axis=1) & np.any(others < p[i], axis=1))
        keep[i] = not dominated
    return keep


def format_mean_std(mean: float, std: float, n: int) -> str:
    """``mean ± std`` with 3-4 significant digits (``std`` omitted for one seed).

    Examples
    --------
    >>> format_mean_std(12.345, 0.678, 3)
    '12.35 ± 0.678'
    >>> format_mean_std(5.0, float("nan"), 1)
    '5'
    """

    def f(v: float) -> str:
        if not math.isfinite(v):
            return "–"
        return f"{v:.4g}"

    if n <= 1 or not math.isfinite(std):
        return f(mean)
    return f"{f(mean)} ± {std:.3g}"


def sim_to_real_gap(table: Any, kpis: Sequence[str] | None = None) -> Any:
    """Mean KPI on the rig minus the mean on the identified model, per scenario and controller.

    Parameters
    ----------
    table : pandas.DataFrame
        A benchmark table with both plants.
    kpis : sequence of str, optional
        Columns (default: every numeric KPI column).

    Returns
    -------
    pandas.DataFrame
        Index (scenario, controller); columns ``<kpi>_model``, ``<kpi>_rig``,
        ``<kpi>_gap``. Empty when the table lacks either plant.
    """
    if not {"model", "rig"} <= set(table["plant"]):
        return pd.DataFrame()
    num = [c for c in (kpis or table.select_dtypes("number").columns) if c not in KEY_COLUMNS]
    num = [c for c in num if c not in ("scenario_version", "steps", "wall_s")]
    m = table.groupby(["scenario", "controller", "plant"], sort=False)[num].mean()
    rows = []
    for (scen, ctrl), grp in m.groupby(level=[0, 1], sort=False):
        plants = grp.index.get_level_values(2)
        if "model" not in plants or "rig" not in plants:
            continue
        a = grp.xs("model", level=2).iloc[0]
        b = grp.xs("rig", level=2).iloc[0]
        row: dict[str, Any] = {"scenario": scen, "controller": ctrl}
        for c in num:
            row[f"{c}_model"] = a[c]
            row[f"{c}_rig"] = b[c]
            row[f"{c}_gap"] = b[c] - a[c]
        rows.append(row)
    return pd.DataFrame(rows).set_index(["scenario", "controller"]) if rows else pd.DataFrame()


#: The reference lifetime measure of :func:`lifetime_rankings` (the default S-N curve).
LIFETIME_REFERENCE = "wax_damage"


def lifetime_variants(columns: Sequence[str]) -> dict[str, str]:
    """Wear measures of a table a controller ranking is compared under: column → label.

    The heater's switching operations (relay wear), the stem's travel, the
    rainflow cycle count of the wax temperature at every cut-off, the Miner sum
    at every exponent (smallest cut-off) and at every cut-off (default
    exponent), in that order; only the columns present
    (:func:`thermogym.envs.kpis.wax_cycle_kpis` writes the S-N variants).

    Examples
    --------
    >>> v = lifetime_variants(["switch_cycles", "wax_damage", "wax_cycles_ge5K"])
    >>> list(v.values())
    ['switching ops', 'cycles ≥5 K', 'Miner m=2 ≥2 K']
    """
    cols = set(columns)
    out = {"switch_cycles": "switching ops", "stroke_travel_mm": "stem travel"}
    variants = sn_columns()
    c0 = SN_CUTOFFS_K[0]
    for name, (kind, cut, _) in variants.items():
        if kind == "cycles":
            out[name] = f"cycles ≥{cut:g} K"
    for m in SN_EXPONENTS:
        out[f"wax_damage_m{m:g}_ge{c0:g}K"] = f"Miner m={m:g} ≥{c0:g} K"
    for cut in SN_CUTOFFS_K[1:]:
        out[f"wax_damage_m2_ge{cut:g}K"] = f"Miner m=2 ≥{cut:g} K"
    # the default S-N curve is m = 2 from the smallest cut-off (envs/kpis.py): its own column
    # (the same values as its variant column, which is shown under the default's name)
    ref = f"wax_damage_m2_ge{c0:g}K"
    if LIFETIME_REFERENCE in cols:
        out = {(LIFETIME_REFERENCE if k == ref else k): v for k, v in out.items()}
    return {k: v for k, v in out.items() if k in cols}


def lifetime_rankings(table: Any) -> dict[tuple[str, str], dict[str, Any]]:
    """How the lifetime ranking of the controllers changes with the wear measure.

    For every (scenario, plant) of a benchmark table: the controllers' mean of
    each measure of :func:`lifetime_variants`, their rank under it (1 = least
    wear; ties share the best rank) and Kendall's τ between that ranking and
    the one by the default Miner sum (``wax_damage``: exponent 2, cut-off
    2 K).

    Parameters
    ----------
    table : pandas.DataFrame
        A benchmark table (one row per episode).

    Returns
    -------
    dict
        ``(scenario, plant) → {"mean": DataFrame, "rank": DataFrame, "tau":
        Series, "labels": dict}`` (controllers as rows, measures as columns);
        empty when the table has no default Miner sum.

    Examples
    --------
    >>> t = pd.DataFrame({"scenario": "s", "plant": "model", "controller": ["a", "b"],
    ...                   "wax_damage": [2.0, 1.0], "switch_cycles": [1.0, 9.0]})
    >>> r = lifetime_rankings(t)[("s", "model")]
    >>> r["rank"].to_dict("list"), float(r["tau"]["switch_cycles"])
    ({'switch_cycles': [1, 2], 'wax_damage': [2, 1]}, -1.0)
    """
    labels = lifetime_variants(list(table.columns))
    if LIFETIME_REFERENCE not in labels:
        return {}
    cols = list(labels)
    out: dict[tuple[str, str], dict[str, Any]] = {}
    for (scen, plant), grp in table.groupby(["scenario", "plant"], sort=False):
        mean = grp.groupby("controller", sort=False)[cols].mean()
        rank = mean.rank(method="min").astype(int)
        ref = rank[LIFETIME_REFERENCE]
        tau = {}
        for c in cols:
            if len(rank) < 2 or rank[c].nunique() < 2 or ref.nunique() < 2:
                tau[c] = math.nan
            else:
                tau[c] = float(stats.kendalltau(ref, rank[c]).statistic)
        out[(str(scen), str(plant))] = {
            "mean": mean,
            "rank": rank,
            "tau": pd.Series(tau),
            "labels": labels,
        }
    return out
