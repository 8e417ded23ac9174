"""The work of ``thermogym diagnose``.

The command's description and its options: :mod:`thermogym._cli.diagnose`.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from thermogym._cli.common import plan_outputs
from thermogym._cli.data_run import load_recordings
from thermogym.errors import ConfigError, UnknownNameError
from thermogym.identification.diagnosis import diagnose
from thermogym.models.registry import model_names


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
        x0=args.x0,
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
    x0 = rep.nominal_fit.settings.get("x0")
    how = {
        "estimate": "estimated from each recording's outputs",
        "rest": "the model's own start",
        "measured": "measured states from their first samples",
    }.get(str(x0), "")
    print(f"initial state: {x0} ({how}; --x0 {args.x0})")
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
