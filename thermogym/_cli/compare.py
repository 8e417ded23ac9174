r"""``thermogym compare FIT [FIT ...] --data REC``: several fitted models on one recording.

As MATLAB's ``compare``: each FitResult is simulated (or predicted ``--k-step``
samples ahead) on the recording's inputs; the fit of every output (NRMSE
fit, in percent) is printed and drawn in one figure.

Example::

    thermogym compare fits/foptd.json fits/ss.json --data dataset:hair_dryer \\
        --plot compare.png
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from thermogym.errors import ConfigError
from thermogym.recording import Recording


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Declare the options."""
    p.add_argument("fits", nargs="+", metavar="FIT", help="FitResult JSON files")
    p.add_argument(
        "--data", required=True, help="recording (CSV/Parquet file or dataset:NAME) to compare on"
    )
    p.add_argument(
        "--x0",
        choices=("auto", "estimate", "steady", "zero"),
        default="auto",
        help="initial state of linear fits (default auto: estimated from the outputs)",
    )
    p.add_argument(
        "--k-step",
        type=int,
        metavar="K",
        help="compare K-step-ahead predictions instead of simulations (K >= 1)",
    )
    p.add_argument("--labels", help="names of the fits in the table and figure, comma separated")
    p.add_argument("--plot", help="PNG to write (one panel per output)")
    p.add_argument("--json", help="write the fits per output as JSON")


def load_one(item: str) -> Recording:
    """One recording from a file or ``dataset:NAME``."""
    from thermogym._cli.diagnose import load_data

    recs = load_data([item], "comparison")
    if len(recs) != 1:
        raise ConfigError(f"--data {item!r} holds {len(recs)} recordings; give one")
    return recs[0]


def check_outputs(paths: list[str | None], inputs: list[str]) -> None:
    """Refuse an output file that is one of the input files."""
    given = {Path(p).resolve() for p in inputs if not p.startswith("dataset:")}
    for p in paths:
        if p and Path(p).resolve() in given:
            raise ConfigError(f"output file {p!r} is one of the inputs; choose another name")


def run(args: argparse.Namespace) -> int:
    """Compare and print the table."""
    from thermogym._fileio import atomic_write_text
    from thermogym.identification.compare import compare
    from thermogym.identification.metrics import fit_text

    if args.k_step is not None and args.k_step < 1:
        raise ConfigError(f"--k-step {args.k_step}: expected a whole number of samples >= 1")
    labels = None
    if args.labels is not None:
        labels = [s.strip() for s in args.labels.split(",")]
        if len(labels) != len(args.fits) or not all(labels):
            raise ConfigError(
                f"--labels {args.labels!r}: give {len(args.fits)} non-empty names, one per fit"
            )
    check_outputs([args.plot, args.json], [*args.fits, args.data])
    rec = load_one(args.data)
    result = compare(args.fits, rec, x0=args.x0, k_step=args.k_step, labels=labels)
    how = f"{args.k_step}-step prediction" if args.k_step else "simulation"
    print(
        f"compare on {rec.experiment_id or args.data} ({rec.n_samples} samples, dt = "
        f"{rec.dt:g} s), {how}; fit = NRMSE fit in %"
    )
    width = max(len(m.label) for m in result.models)
    header = "  ".join(f"{o:>14}" for o in result.outputs)
    print(f"  {'model':<{width}}  {header}  {'mean':>10}  x0")
    for m in result.models:
        cells = "  ".join(f"{fit_text(m.fits.get(o, float('nan'))):>14}" for o in result.outputs)
        print(f"  {m.label:<{width}}  {cells}  {fit_text(m.mean_fit):>10}  {m.x0}")
        if m.note:
            print(f"    note: {m.note}")
    if args.plot:
        from thermogym.identification.linear_plots import plot_compare

        print(f"  figure: {plot_compare(result, args.plot)}")
    if args.json:
        text = json.dumps(result.to_dict(), indent=2, allow_nan=True) + "\n"
        atomic_write_text(args.json, text)
        print(f"  wrote {args.json}")
    return 0
