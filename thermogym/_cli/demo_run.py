"""The work of ``thermogym demo``.

The command's description and its options: :mod:`thermogym._cli.demo`.
"""

from __future__ import annotations

import argparse
import sys

# run_demo is looked up in its module when called, so that a replacement there is used (the
# tests that check bad input is refused before any work)
from thermogym import demo
from thermogym._cli.common import Interrupted, plan_outputs
from thermogym._cli.demo import check_only
from thermogym.errors import ConfigError


def run(args: argparse.Namespace) -> int:
    """Run the demo; exit status 1 when a stage failed, 2 when none could run."""
    check_only(args.only, demo.stage_keys())  # the stage table as it is now (tests replace it)
    plan_outputs(args, folders=("out",), unstaged=("out",))  # the demo stages its own files
    try:
        results = demo.run_demo(
            args.out,
            quick=args.quick,
            seed=args.seed,
            only=args.only,
            progress=not args.no_progress,
        )
    except demo.DemoInterrupted as e:
        if not e.reports:
            raise Interrupted(
                f"stage {e.stage!r} published nothing; every file in {args.out} is as it was"
            ) from None
        raise Interrupted(
            f"stage {e.stage!r} published nothing; stage(s) {e.finished} finished before it "
            f"and replaced their files, so {args.out}/report.html and report.md were rewritten "
            f"to match (the section of {e.stage!r} is the earlier run's, marked)"
        ) from None
    if args.no_progress:  # the progress lines said it otherwise
        status = ", ".join(f"{r.key} {r.status}" for r in results)
        print(f"report: {args.out}/report.html (and report.md); stages: {status}")
    if results and all(r.status == "skipped" for r in results):
        first = results[0]
        raise ConfigError(
            f"no stage ran: {first.key!r} was skipped, {first.error}; run the stages it needs "
            f"first (thermogym demo --out {args.out}, or add --only for them)"
        )
    failed = [r.key for r in results if r.status == "failed"]
    if failed:
        print(
            f"thermogym demo: stage(s) {failed} failed; see {args.out}/report.html and "
            f"{args.out}/logs/",
            file=sys.stderr,
        )
        return 1
    return 0
