"""The work of ``thermogym resid``.

The command's description and its options: :mod:`thermogym._cli.resid`.
"""

from __future__ import annotations

import argparse
import json

from thermogym._cli.common import plan_outputs
from thermogym._cli.compare_run import load_one

# resid is looked up in its module when called, so that a replacement there is used (the
# interruption tests replace it)
from thermogym.identification import compare


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
            # figures only when asked: matplotlib costs ~0.5 s at start-up
            from thermogym.identification.linear_plots import plot_resid

            plot_resid(tests, plan.path("--plot"), dt=rec.dt)
            print(f"  figure: {args.plot}")
        if args.json:
            doc = {name: t.to_dict(args.alpha) for name, t in tests.items()}
            plan.path("--json").write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")
            print(f"  wrote {args.json}")
    return 0
