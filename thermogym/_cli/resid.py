"""``thermogym resid FIT --data REC``: residual tests of a fitted model.

As MATLAB's ``resid``: the residuals ``y − ŷ`` of the fit on a recording are
tested for whiteness (Ljung-Box over lags 1..M) and for independence from
each input (cross-correlation over lags 0..M, bounds widened for coloured
signals); the figure shows both with their confidence bounds. Residuals that
are coloured but independent of the inputs call for more dynamics or a noise
model; residuals correlated with an input say its effect is mis-modelled.

Example::

    thermogym resid fits/foptd.json --data dataset:hair_dryer --plot resid.png
"""

from __future__ import annotations

import argparse
import json

from thermogym._cli.common import plan_outputs, probability, whole
from thermogym._cli.compare import X0_OPTION, load_one
from thermogym._cli.data import add_data_options

# resid is looked up in its module when called, so that a replacement there is used (the
# interruption tests replace it)
from thermogym.identification import compare
from thermogym.identification.linear_plots import plot_resid


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Declare the options."""
    p.add_argument("fit", metavar="FIT", help="FitResult JSON file")
    p.add_argument("--data", required=True, help="recording (file or dataset:NAME)")
    p.add_argument(
        "--x0",
        choices=X0_OPTION,
        default="auto",
        help="initial state of a linear fit (default auto: estimated from the outputs)",
    )
    p.add_argument(
        "--k-step",
        type=whole(1, 1_000_000, what="a prediction horizon in samples"),
        metavar="K",
        help="test the K-step prediction errors (1: one-step, as MATLAB for models with a "
        "noise model) instead of the simulation residuals",
    )
    p.add_argument(
        "--max-lag",
        type=whole(1, 100_000, what="a number of lags"),
        default=25,
        help="largest lag M [samples] (25)",
    )
    p.add_argument(
        "--alpha", type=probability(), default=0.01, help="level of the bounds and verdicts (0.01)"
    )
    p.add_argument("--plot", help="PNG to write")
    p.add_argument("--json", help="write the test results as JSON")
    add_data_options(p)


def run(args: argparse.Namespace) -> int:
    """Test and print the verdicts."""
    plan = plan_outputs(args, files={"plot": "figure", "json": "json"}, inputs=("fit", "data"))
    with plan:
        rec = load_one(args.data, args)
        tests = compare.resid(
            args.fit, rec, x0=args.x0, k_step=args.k_step, max_lag=args.max_lag, alpha=args.alpha
        )
        what = f"{args.k_step}-step prediction errors" if args.k_step else "simulation residuals"
        # the tests use at most a quarter of the valid samples as lags
        used = min((min(args.max_lag, t.n_samples // 4) for t in tests.values()), default=1)
        lags = f"lags up to {used}" + (
            f" (--max-lag {args.max_lag} reduced to a quarter of the samples)"
            if used < args.max_lag
            else ""
        )
        print(
            f"residual tests of {what} on {rec.experiment_id or args.data} "
            f"({lags}, level {args.alpha:g})"
        )
        for name, t in tests.items():
            verdict = "white" if t.white(args.alpha) else "NOT white (coloured residuals)"
            print(f"  {name}: whiteness p = {t.p_white:.3g}: {verdict}")
            for u, p in t.p_independent.items():
                ok = "independent" if p >= args.alpha else "CORRELATED with the input"
                print(f"    × {u}: p = {p:.3g}: {ok}")
        if args.plot:
            plot_resid(tests, plan.path("--plot"), dt=rec.dt)
            print(f"  figure: {args.plot}")
        if args.json:
            doc = {name: t.to_dict(args.alpha) for name, t in tests.items()}
            plan.path("--json").write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")
            print(f"  wrote {args.json}")
    return 0
