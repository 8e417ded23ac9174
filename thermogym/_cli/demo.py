"""``thermogym demo``: the whole loop on embedded defaults, with a report."""

from __future__ import annotations

import argparse


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Declare the options."""
    p.add_argument("--out", default="out", help="output folder (default: out)")
    p.add_argument("--seed", type=int, default=0, help="seed of every random draw")
    p.add_argument("--quick", action="store_true", help="smaller experiments (for tests)")
    p.add_argument("--only", action="append", metavar="STAGE", help="run only this stage")


def run(args: argparse.Namespace) -> int:
    """Run the demo; exit status 1 when a stage failed."""
    from thermogym.demo import run_demo

    results = run_demo(args.out, quick=args.quick, seed=args.seed, only=args.only)
    return 1 if any(r.status == "failed" for r in results) else 0
