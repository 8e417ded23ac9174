"""The work of ``thermogym bench``.

The command's description and its options: :mod:`thermogym._cli.bench`.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from thermogym._cli.common import plan_outputs

# run_benchmark is looked up in its module when called, so that a replacement there is used
# (the tests that check bad input is refused before any work)
from thermogym.controllers import harness
from thermogym.controllers.presets import CONTROLLER_GROUPS, CONTROLLER_NAMES, expand_controllers
from thermogym.controllers.scenarios import SCENARIOS, get_scenario, scenarios_for
from thermogym.controllers.tables import kpi_axes
from thermogym.envs import ENV_IDS
from thermogym.errors import ConfigError

#: Scenario run when none is named.
DEFAULT_SCENARIO = {"AXT211Room": "winter-week", "AXT211Valve": "setpoint-steps"}


def _env_id(name: str) -> str:
    if name in ENV_IDS:
        return name
    for i in ENV_IDS:
        if i.split("/")[1].split("-v")[0].lower() == name.lower():
            return i
    raise ConfigError(f"unknown environment {name!r}; environments are {list(ENV_IDS)}")


def _list() -> int:
    print("controller presets:", ", ".join(CONTROLLER_NAMES))
    print("groups:", ", ".join(f"{k} = {'+'.join(v)}" for k, v in CONTROLLER_GROUPS.items()))
    print("scenarios:")
    for key, s in SCENARIOS.items():
        if "@" in key:
            print(f"  {key:22s} {s.description} ({', '.join(sorted(s.env_kwargs))})")
    for i in ENV_IDS:
        n = i.split("/")[1].split("-v")[0]
        print(f"{i}: scenarios {', '.join(scenarios_for(n))}")
    return 0


def run(args: argparse.Namespace) -> int:
    """Run the benchmark grid and write its report."""
    if args.list:
        return _list()
    if not args.env:
        raise ConfigError("--env is required (or --list)")
    if not args.out:
        raise ConfigError("--out is required: the folder of the report")
    policies = [item.partition("=")[2].strip() for item in args.policy]
    plan = plan_outputs(args, folders=("out",), inputs=("params",), extra_inputs=policies)
    for path in [args.params, *policies]:
        if path and not Path(path).is_file():
            raise ConfigError(f"{path!r} does not exist (--params/--policy name a file)")

    env_id = _env_id(args.env)
    name = env_id.split("/")[1].split("-v")[0]
    scenarios: list[str] = []
    for s in args.scenario or [DEFAULT_SCENARIO.get(name, "default")]:
        scenarios += [x.strip() for x in s.split(",") if x.strip()]
    # names the benchmark would refuse only after starting its workers: refused here
    expand_controllers(args.controllers)
    if not scenarios:
        raise ConfigError(f"--scenario {','.join(args.scenario or [])!r} names no scenario")
    for sc in scenarios:
        get_scenario(sc)
    seeds: Any = args.seeds
    if args.seed_list:
        seeds = list(args.seed_list)
    options: dict[str, dict[str, Any]] = {}
    for item in args.policy:
        algo, sep, path = item.partition("=")
        if not sep or not path:
            raise ConfigError(f"--policy {item!r}: expected ALGO=PATH (e.g. ppo=policy.zip)")
        options[algo.strip()] = {"policy": path.strip()}
    plants = [p.strip() for p in args.plant.split(",") if p.strip()]
    bad = [p for p in plants if p not in ("model", "rig")]
    if bad or not plants:
        raise ConfigError(f"--plant {args.plant!r}: expected model, rig or model,rig")
    with plan:
        res = harness.run_benchmark(
            env_id,
            scenarios,
            args.controllers,
            seeds,
            plan.path("--out"),
            args.backend,
            plants=plants,
            workers=args.workers,
            options=options,
            record=args.record,
            progress=False if args.no_progress else None,
            title=args.title,
            params=args.params,
        )
    axes = list(kpi_axes(list(res.table.columns)).values())
    mean = res.table.groupby(["scenario", "plant", "controller"], sort=False)[axes].mean()
    print(mean.to_string(float_format=lambda v: f"{v:.4g}"))
    print(
        f"{len(res.table)} episodes in {res.seconds:.1f} s ({res.backend}, {res.workers} workers); "
        f"report: {Path(args.out) / 'summary.md'}",
        file=sys.stderr,
    )
    return 0
