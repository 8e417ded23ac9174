"""Stage 5: controller benchmark on energy, lifetime and accuracy.

A small grid of :func:`thermogym.controllers.run_benchmark`: on/off, PWM
(open loop at the medium period), PID with a high-frequency PWM output stage,
linear MPC and the shipped pre-trained PPO policy, on the AXT211 valve's
set-point-steps scenario, on the identified model and on the virtual rig
(sim-to-real gap). The harness writes its own report (tables, figures,
trajectories) under ``control/``.
"""

from __future__ import annotations

from typing import Any

from thermogym.controllers import run_benchmark
from thermogym.controllers.tables import kpi_axes, pareto_front
from thermogym.demo.core import DemoContext, StageResult

__all__ = ["CONTROLLERS", "stage_control"]

#: Controllers of the full demo (``--quick`` runs the first two and PID only).
CONTROLLERS = ("onoff", "pwm-medium", "pid-high", "mpc", "ppo")
ENV_ID = "thermogym/AXT211Valve-v0"
SCENARIO = "setpoint-steps"


def stage_control(ctx: DemoContext, res: StageResult) -> None:
    """Run the grid, summarise its KPIs, keep the harness's figures."""
    ctrls = ("onoff", "pid-high", "ppo") if ctx.quick else CONTROLLERS
    seeds = [ctx.seed] if ctx.quick else [ctx.seed, ctx.seed + 1]
    folder = ctx.path("control", "valve")
    bench = run_benchmark(
        ENV_ID,
        SCENARIO,
        ",".join(ctrls),
        seeds=seeds,
        out=folder,
        plants=("model", "rig"),
        progress=ctx.bars,
        title="thermogym demo: AXT211 valve controllers",
    )
    t = bench.table
    axes = kpi_axes(list(t.columns))
    e, life, acc = axes["energy"], axes["lifetime"], axes["accuracy"]
    cols = [acc, e, life, "switch_cycles", "stroke_reversals"]
    cols = [c for c in dict.fromkeys(cols) if c in t.columns]
    mean = t.groupby(["plant", "controller"], sort=False)[cols].mean()
    rows: list[list[Any]] = []
    for (plant, ctrl), r in mean.iterrows():
        rows.append([ctrl, plant, *[float(r[c]) for c in cols]])
    res.table(
        ["controller", "plant", *cols],
        rows,
        f"{ENV_ID}, scenario {SCENARIO} (4 h of random stroke set-points), mean over "
        f"{len(seeds)} seed(s); lower is better everywhere",
    )
    model = mean.loc["model"]
    pts = model[[e, life, acc]].to_numpy()
    front = [c for c, keep in zip(model.index, pareto_front(pts), strict=True) if keep]
    best_acc = model[acc].idxmin()
    for p in sorted(str(p) for p in bench.files.values() if str(p).endswith(".png")):
        # model: every figure; rig: trajectories (its KPIs are in the sim-to-real figure)
        if "_rig_" in p and not p.endswith("trajectories.png"):
            continue
        res.figure(ctx.rel(p), _caption(p))
    res.shows = (
        "Control strategies compared on the three axes of DESIGN.md: energy "
        f"(`{e}`), actuator lifetime (`{life}`, rainflow-counted) and accuracy (`{acc}`), on "
        "the model and on the virtual rig (the sim-to-real gap)."
    )
    res.text = (
        f"Grid: {len(ctrls)} controllers × {len(seeds)} seed(s) × 2 plants = {len(t)} episodes "
        f"in {bench.seconds:.0f} s ({bench.workers} worker processes). PPO is the shipped "
        "pre-trained policy (`thermogym/controllers/policies/`). Pareto-optimal on the model "
        f"(energy, lifetime, accuracy): {', '.join(f'`{c}`' for c in front)}. The harness's "
        "own report is `control/valve/summary.md` with `results.csv` (one row per episode)."
    )
    res.highlights["controller benchmark"] = (
        f"most accurate on the model: `{best_acc}` ({model.loc[best_acc, acc]:.3f} mm); "
        f"Pareto front {', '.join(front)}"
    )
    ctx.products["benchmark"] = bench


def _caption(path: str) -> str:
    name = path.rsplit("/", 1)[-1].removesuffix(".png")
    plant = "virtual rig" if "_rig_" in name else "identified model"
    if name.endswith("sim_to_real"):
        return "Sim-to-real gap: KPIs on the rig against the model, per controller"
    if name.endswith("pareto"):
        return f"Energy, lifetime and accuracy per controller ({plant}); Pareto front marked"
    if name.endswith("kpis"):
        return f"KPIs per controller, mean ± std over seeds ({plant})"
    if name.endswith("trajectories"):
        return f"Stroke, set-point and heater power of the first seed ({plant})"
    return name
