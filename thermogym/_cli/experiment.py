"""``thermogym experiment RIG PROTOCOL --out DIR``: run a virtual test rig."""

from __future__ import annotations

import argparse
import ast
from typing import Any

from thermogym.errors import ConfigError


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Declare the options."""
    p.add_argument("rig", help="axt211, spindle or strut")
    p.add_argument("protocol", help="protocol of the rig (see --list)")
    p.add_argument("--out", required=True, help="folder for the recordings")
    p.add_argument("--seed", type=int, default=0, help="seed of every random draw (default 0)")
    p.add_argument(
        "--format",
        choices=("csv", "parquet"),
        default="csv",
        dest="fmt",
        help="file format (default csv, with a .meta.json sidecar)",
    )
    p.add_argument(
        "--effect",
        action="append",
        default=[],
        metavar="NAME[:k=v,...]",
        help="include physics the nominal model lacks (concealed: not recorded)",
    )
    p.add_argument(
        "--option",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="protocol option, e.g. speeds=[4000,6000]",
    )


def _options(items: list[str]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key.isidentifier():
            raise ConfigError(f"option {item!r} is not of the form KEY=VALUE")
        try:
            out[key] = ast.literal_eval(value)
        except (ValueError, SyntaxError):
            out[key] = value
    return out


def run(args: argparse.Namespace) -> int:
    """Run the protocol and write its recordings."""
    from thermogym.rigs import run_experiment

    recs = run_experiment(
        args.rig,
        args.protocol,
        args.out,
        seed=args.seed,
        effects=args.effect,
        fmt=args.fmt,
        **_options(args.option),
    )
    for rec in recs:
        print(f"{rec.experiment_id}: {rec.n_samples} samples, {rec.duration / 3600:.2f} h")
    print(f"wrote {len(recs)} recording(s) and manifest.json to {args.out}")
    return 0
