"""``thermogym diagnose``: locate a model mismatch and name the missing physics.

::

    thermogym diagnose --model MODEL [--params fit.json] --train DATA... --validate DATA...
                       --out report.json [--html report.html] [--md report.md]
                       [--augmented-fit fit.json] [--inputs COL,...] [--outputs COL,...]

``MODEL`` is a thermogym plant (``axt211``, ``strut``, ``spindle``, ...), ``foptd``
or ``ss:ORDER`` (with ``--inputs`` and ``--outputs`` naming the recording's
columns). ``DATA`` is a recording file (CSV/Parquet), a folder of them, or
``dataset:NAME`` for a shipped data set (``thermogym.datasets``).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from thermogym.errors import ConfigError, RecordingError

_SUFFIXES = (".csv", ".csv.gz", ".parquet", ".pq")


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Declare the options."""
    p.add_argument(
        "--model",
        required=True,
        help="nominal model: a thermogym plant, 'foptd' or 'ss:ORDER'",
    )
    p.add_argument("--params", help="FitResult JSON of the nominal model (fitted when omitted)")
    p.add_argument(
        "--train",
        nargs="+",
        required=True,
        metavar="DATA",
        help="training recordings: files, folders or dataset:NAME",
    )
    p.add_argument(
        "--validate",
        nargs="+",
        required=True,
        metavar="DATA",
        help="held-out recordings: files, folders or dataset:NAME",
    )
    p.add_argument("--out", required=True, help="report JSON to write")
    p.add_argument("--html", help="also write a self-contained HTML report with figures")
    p.add_argument("--md", help="also write a Markdown report (figures next to it)")
    p.add_argument(
        "--augmented-fit", help="also write the winning augmented model's FitResult JSON"
    )
    p.add_argument("--inputs", help="generic models: exogenous columns, comma-separated")
    p.add_argument("--outputs", help="output columns to compare, comma-separated")
    p.add_argument("--candidates", help="effects to consider, comma-separated (default: all)")
    p.add_argument("--dt", type=float, help="average the recordings onto this period [s] first")
    p.add_argument("--alpha", type=float, default=0.01, help="test level (default 0.01)")
    p.add_argument(
        "--scheme",
        choices=("auto", "split", "crossfit"),
        default="auto",
        help="how hypotheses are scored on held-out data (default auto)",
    )
    p.add_argument("--time-limit", type=float, help="start no hypothesis after this many seconds")
    p.add_argument("--no-sparse", action="store_true", help="skip the sparse-regression fallback")
    p.add_argument("--quiet", action="store_true", help="print only the verdict")


def _split(text: str | None) -> list[str] | None:
    if text is None:
        return None
    items = [s.strip() for s in text.split(",") if s.strip()]
    if not items:
        raise ConfigError(f"{text!r} names no column; expected COL,COL,...")
    return items


def load_data(items: list[str], what: str) -> list:
    """Recordings from files, folders and ``dataset:NAME`` items."""
    from thermogym.recording import read_recording

    recs = []
    for item in items:
        if item.startswith("dataset:"):
            from thermogym.datasets import load

            recs.append(load(item.split(":", 1)[1]))
            continue
        path = Path(item)
        if path.is_dir():
            files = sorted(
                f for f in path.iterdir() if f.is_file() and f.name.lower().endswith(_SUFFIXES)
            )
            if not files:
                raise RecordingError(f"{what} folder {item!r} holds no CSV or Parquet recording")
            recs.extend(read_recording(f) for f in files)
        elif path.exists():
            recs.append(read_recording(path))
        else:
            raise RecordingError(f"{what} recording {item!r} does not exist")
    return recs


def run(args: argparse.Namespace) -> int:
    """Diagnose and write the reports."""
    from thermogym.identification.diagnosis import diagnose

    train = load_data(args.train, "training")
    val = load_data(args.validate, "validation")
    say = (lambda s: None) if args.quiet else (lambda s: print(f"  {s}", flush=True))
    rep = diagnose(
        args.model,
        train,
        val,
        params=args.params,
        inputs=_split(args.inputs),
        outputs=_split(args.outputs),
        candidates=_split(args.candidates),
        dt=args.dt,
        alpha=args.alpha,
        scheme=args.scheme,
        time_limit=args.time_limit,
        sparse=not args.no_sparse,
        progress=say,
    )
    rep.save(args.out)
    print(rep.verdict)
    print(f"report: {args.out}")
    if args.html:
        rep.save_html(args.html)
        print(f"html:   {args.html}")
    if args.md:
        stem = Path(args.md).stem
        rep.save_markdown(args.md, figures_dir=f"{stem}_figures")
        print(f"md:     {args.md}")
    if args.augmented_fit:
        if rep.augmented_fit is None:
            print("no augmented model: nothing written to --augmented-fit")
        else:
            rep.augmented_fit.save(args.augmented_fit)
            print(f"fit:    {args.augmented_fit}")
    return 0
