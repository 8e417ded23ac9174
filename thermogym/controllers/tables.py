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

__all__ = [
    "AXES",
    "KEY_COLUMNS",
    "MAIN_KPIS",
    "format_mean_std",
    "kpi_axes",
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
