"""The work of ``thermogym compare``.

The command's description and its options: :mod:`thermogym._cli.compare`.
"""

from __future__ import annotations

import argparse
import json

from thermogym._cli.common import plan_outputs
from thermogym._cli.data_run import load_recordings
from thermogym.errors import ConfigError
from thermogym.identification.compare import compare
from thermogym.identification.metrics import fit_text
from thermogym.recording import Recording


def load_one(item: str, args: argparse.Namespace) -> Recording:
    """One recording from a file or ``dataset:NAME`` (notes on what reading did)."""
    recs = load_recordings([item], "--data", args)
    if len(recs) != 1:
        raise ConfigError(f"--data {item!r} holds {len(recs)} recordings; give one")
    return recs[0]


def run(args: argparse.Namespace) -> int:
    """Compare and print the table."""
    if args.labels is not None and len(args.labels) != len(args.fits):
        raise ConfigError(
            f"--labels {','.join(args.labels)!r}: give {len(args.fits)} names, one per fit"
        )
    plan = plan_outputs(args, files={"plot": "figure", "json": "json"}, inputs=("fits", "data"))
    with plan:
        rec = load_one(args.data, args)
        result = compare(args.fits, rec, x0=args.x0, k_step=args.k_step, labels=args.labels)
        how = f"{args.k_step}-step prediction" if args.k_step else "simulation"
        print(
            f"compare on {rec.experiment_id or args.data} ({rec.n_samples} samples, dt = "
            f"{rec.dt:g} s), {how}; fit = NRMSE fit in %"
        )
        width = max(len(m.label) for m in result.models)
        header = "  ".join(f"{o:>14}" for o in result.outputs)
        print(f"  {'model':<{width}}  {header}  {'mean':>10}  x0")
        for m in result.models:
            cells = "  ".join(
                f"{fit_text(m.fits.get(o, float('nan'))):>14}" for o in result.outputs
            )
            print(f"  {m.label:<{width}}  {cells}  {fit_text(m.mean_fit):>10}  {m.x0}")
            if m.note:
                print(f"    note: {m.note}")
        if args.plot:
            # figures only when asked: matplotlib costs ~0.5 s at start-up
            from thermogym.identification.linear_plots import plot_compare

            plot_compare(result, plan.path("--plot"))
            print(f"  figure: {args.plot}")
        if args.json:
            text = json.dumps(result.to_dict(), indent=2, allow_nan=True) + "\n"
            plan.path("--json").write_text(text, encoding="utf-8")
            print(f"  wrote {args.json}")
    return 0
