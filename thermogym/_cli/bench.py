r"""``thermogym bench``: benchmark controllers on energy, lifetime and accuracy.

Example::

    thermogym bench --env AXT211Valve --scenario setpoint-steps \\
        --controllers onoff,pwm,pid,mpc --seeds 3 --plant model,rig --out out/bench-valve

Runs every controller × scenario × seed (× plant) with
:func:`thermogym.controllers.harness.run_benchmark` and writes the tidy table
(CSV, Parquet), ``summary.md`` and the figures into ``--out``.
"""

from __future__ import annotations

import argparse

from thermogym._cli.common import whole


def _seed_list(text: str) -> tuple[int, ...]:
    """``--seed-list 0,1,7``: whole numbers in [0, 2**32 - 1], at least one, none twice."""
    seed = whole(0, 2**32 - 1, what="a seed")
    items = [x.strip() for x in text.split(",")]
    if not text.strip() or any(not x for x in items):
        raise argparse.ArgumentTypeError(f"{text!r}: expected seeds like 0,1,2 (no empty item)")
    seeds = tuple(seed(x) for x in items)
    if len(set(seeds)) != len(seeds):
        raise argparse.ArgumentTypeError(f"{text!r} names a seed more than once")
    return seeds


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Arguments of ``thermogym bench``."""
    p.add_argument("--env", help="environment ID or name (thermogym/AXT211Room-v0, AXT211Room)")
    p.add_argument(
        "--scenario",
        action="append",
        help="scenario name or name@version (repeat or comma-separate; default: the "
        "environment's main one)",
    )
    p.add_argument(
        "--controllers",
        default="onoff,pwm,pid,mpc",
        help="comma list of presets and groups (default: onoff,pwm,pid,mpc; see --list)",
    )
    p.add_argument(
        "--seeds",
        type=whole(1, 10_000, what="a number of seeds"),
        default=3,
        help="number of seeds, 0..N-1 (default 3)",
    )
    p.add_argument(
        "--seed-list",
        type=_seed_list,
        help="explicit comma list of seeds (overrides --seeds)",
    )
    p.add_argument("--out", help="output folder of the report (created)")
    p.add_argument("--backend", choices=["local", "ray", "serial"], default="local")
    p.add_argument(
        "--workers",
        type=whole(1, 1024, what="a number of workers"),
        help="parallel episodes (default: CPU count)",
    )
    p.add_argument(
        "--plant",
        default="model",
        help="model, rig or model,rig (both: the sim-to-real gap; default model)",
    )
    p.add_argument(
        "--policy",
        action="append",
        default=[],
        metavar="ALGO=PATH",
        help="policy of an RL preset, e.g. ppo=out/rl/policy.zip (repeatable)",
    )
    p.add_argument(
        "--params",
        metavar="FIT.json",
        help="FitResult of the identified model for the episodes on the model (rig episodes "
        "are unaffected)",
    )
    p.add_argument("--record", choices=["first", "all", "none"], default="first")
    p.add_argument("--title", help="title of summary.md")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--list", action="store_true", help="list presets and scenarios, then exit")
