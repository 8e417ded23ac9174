"""``thermogym demo``: the whole loop on embedded defaults, with a report.

Writes ``OUT/report.html`` (self-contained, every figure embedded),
``OUT/report.md`` (its Markdown twin), ``OUT/fits/*.json`` and each stage's
files; exit status 1 when a stage failed (the report says which and why).
"""

from __future__ import annotations

import argparse


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Declare the options."""
    from thermogym.demo import stage_keys

    p.add_argument("--out", default="out", help="output folder (default: out)")
    p.add_argument("--seed", type=int, default=0, help="seed of every random draw (default 0)")
    p.add_argument(
        "--quick", action="store_true", help="smaller experiments and grids (about a minute)"
    )
    p.add_argument(
        "--only",
        action="append",
        metavar="STAGE",
        choices=stage_keys(),
        help=f"run only this stage (repeatable): {', '.join(stage_keys())}",
    )
    p.add_argument("--no-progress", action="store_true", help="no progress lines or bars")


def run(args: argparse.Namespace) -> int:
    """Run the demo; exit status 1 when a stage failed."""
    from thermogym.demo import run_demo

    results = run_demo(
        args.out,
        quick=args.quick,
        seed=args.seed,
        only=args.only,
        progress=not args.no_progress,
    )
    return 1 if any(r.status == "failed" for r in results) else 0
