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

from thermogym._cli.common import choice_list, names, plan_outputs, positive, probability
from thermogym._cli.data import add_data_options, load_recordings
from thermogym.errors import ConfigError, UnknownNameError
from thermogym.identification.diagnosis import diagnose
from thermogym.models.registry import model_names
from thermogym.vocabulary import EFFECT_NAMES


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Declare the options."""
    p.add_argument(
        "--model",
        required=True,
        help="nominal model: a thermogym plant, 'foptd' or 'ss:ORDER'",
    )
    p.add_argument(
        "--params",
        help="FitResult JSON of the nominal model: its parameters are the given ones (the "
        "identifiable ones are re-calibrated); for ss:N or foptd a FitResult of that model "
        "(its operating point and columns are used)",
    )
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
    p.add_argument(
        "--inputs", type=names(), help="generic models: exogenous columns, comma-separated"
    )
    p.add_argument("--outputs", type=names(), help="output columns to compare, comma-separated")
    p.add_argument(
        "--candidates",
        type=choice_list([e for e in EFFECT_NAMES if e != "none"], "effect"),
        help="effects to consider, comma-separated (default: all)",
    )
    p.add_argument(
        "--dt",
        type=positive("s", "a sample period"),
        help="average the recordings onto this period [s] first",
    )
    p.add_argument(
        "--alpha",
        type=probability(),
        default=0.01,
        help="test level in (0, 1) (default 0.01)",
    )
    p.add_argument(
        "--scheme",
        choices=("auto", "split", "crossfit"),
        default="auto",
        help="how hypotheses are scored on held-out data (default auto)",
    )
    p.add_argument(
        "--time-limit",
        type=positive("s", "a time limit"),
        help="start no hypothesis after this many seconds",
    )
    p.add_argument(
        "--max-effects",
        type=int,
        default=3,
        help="most effects a combination holds (default 3)",
    )
    p.add_argument("--no-sparse", action="store_true", help="skip the sparse-regression fallback")
    p.add_argument("--quiet", action="store_true", help="print only the verdict")
    add_data_options(p)


def _split(items: tuple[str, ...] | None) -> list[str] | None:
    return None if items is None else list(items)


def _check_model(spec: str) -> None:
    """Refuse an unknown ``--model`` before any recording is read."""
    name, sep, order = spec.partition(":")
    if name == "ss":
        if sep and (not order.strip().isdigit() or int(order) < 1):
            raise ConfigError(f"--model {spec!r}: expected ss:ORDER with a whole ORDER >= 1")
        return
    if sep or name not in model_names() or name == "augmented":
        plants = [m for m in model_names() if m not in ("augmented", "ss")]
        raise UnknownNameError(
            f"--model {spec!r} is not a model; expected a thermogym plant or foptd "
            f"({', '.join(plants)}) or ss:ORDER"
        )


def load_data(items: list[str], what: str, args: argparse.Namespace | None = None) -> list:
    """Recordings from files, folders and ``dataset:NAME`` items (:mod:`thermogym._cli.data`)."""
    return load_recordings(items, what, args)


def run(args: argparse.Namespace) -> int:
    """Diagnose and write the reports."""
    _check_model(args.model)
    plan = plan_outputs(
        args,
        files={"out": "json", "html": "html", "md": "md", "augmented_fit": "json"},
        inputs=("train", "validate", "params"),
    )
    train = load_data(args.train, "training", args)
    val = load_data(args.validate, "validation", args)
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
        max_effects=args.max_effects,
        sparse=not args.no_sparse,
        progress=say,
    )
    with plan:
        rep.save(plan.path("--out"))
        if args.html:
            rep.save_html(plan.path("--html"))
        if args.md:
            stem = Path(args.md).stem
            rep.save_markdown(plan.path("--md"), figures_dir=f"{stem}_figures")
        if args.augmented_fit and rep.augmented_fit is not None:
            rep.augmented_fit.save(plan.path("--augmented-fit"))
    print(rep.verdict)
    for n in rep.notes:  # assumptions taken and warnings (extrapolation, units, resampling)
        print(f"note:   {n}")
    print(f"named:  {', '.join(rep.named_effects)}")
    print(f"report: {args.out}")
    if args.html:
        print(f"html:   {args.html}")
    if args.md:
        print(f"md:     {args.md}")
    if args.augmented_fit:
        if rep.augmented_fit is None:
            print("no augmented model: nothing written to --augmented-fit")
        else:
            print(f"fit:    {args.augmented_fit}")
    return 0
