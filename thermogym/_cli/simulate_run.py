"""The work of ``thermogym simulate``.

The command's description and its options: :mod:`thermogym._cli.simulate`.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np

# write_recording and plot_recordings are looked up in their modules when called, so that a
# replacement there is used (the interruption tests replace them)
from thermogym import recording
from thermogym._cli.common import plan_outputs
from thermogym._cli.data_run import check_units, load_recordings
from thermogym.errors import ConfigError
from thermogym.fitresult import load_fit
from thermogym.identification.linear_fit import LINEAR_MODELS, predict, simulate_recording
from thermogym.identification.metrics import fit_text, nrmse
from thermogym.models.registry import get_model
from thermogym.recording import Recording


def parse_sets(items: list[str]) -> dict[str, float]:
    """Parse ``NAME=VALUE`` overrides."""
    out = {}
    for item in items:
        name, sep, value = item.partition("=")
        name = name.strip()
        if sep and name in out:
            raise ConfigError(f"--set {name} is given twice ({item!r}); give each parameter once")
        try:
            out[name] = float(value)
        except ValueError:
            sep = ""
        if not sep or not name.isidentifier():
            raise ConfigError(f"--set {item!r} is not of the form NAME=NUMBER")
        if not np.isfinite(out[name]):
            raise ConfigError(f"--set {item!r}: the value is not a finite number")
    return out


def run(args: argparse.Namespace) -> int:
    """Simulate and write the result."""
    plan = plan_outputs(
        args, files={"out": "recording", "plot": "figure"}, inputs=("inputs", "params")
    )
    sets = parse_sets(args.set)
    linear = None
    if args.params:
        fit = load_fit(args.params)
        if args.model and args.model != fit.model:
            raise ConfigError(
                f"model {args.model!r} given but {args.params} holds a {fit.model!r} fit"
            )
        model = fit.build_model()
        theta = fit.theta(model)
        if fit.model in LINEAR_MODELS:
            # ss, foptd and the polynomial and SOPDT families: the operating point the
            # fit was identified about and an initial state chosen by --x0
            linear = fit
    elif args.model:
        model = get_model(args.model)
        theta = model.theta()
    else:
        raise ConfigError("name a MODEL or give --params fit.json")
    if sets:
        overrides: dict[str, Any] = dict(sets)  # parameter name -> value
        theta = model.theta(theta, **overrides)
    (rec,) = load_recordings([args.inputs], "--inputs", args)
    rec.validate_for(model, outputs=False)  # the columns; units as check_units
    check_units(rec, {s.name: s.unit for s in model.signals}, f"model {model.name!r}")
    rec.check_values([s.name for s in model.exogenous])
    if linear is not None:
        linear.parameters.update(sets)
        pred = predict(linear, rec, x0=args.x0)
        out = simulate_recording(linear, rec, x0=pred.x0)
        start = {
            "estimate": "estimated from the recording's outputs",
            "steady": "settled at the first input",
            "zero": "at rest at the operating point",
        }[pred.x0]
        print(f"initial state: {pred.x0} ({start}); operating point of the {pred.operating}")
    else:
        if args.x0 != "auto":
            raise ConfigError(
                f"--x0 {args.x0} applies to linear fits (--params of ss, foptd, arx, armax, oe, "
                f"bj, sopdt); model {model.name!r} "
                "starts in its own initial state"
            )
        u = rec.exogenous_array(model)
        sim = model.simulate(u, rec.dt, theta, t0=float(rec.time[0]))
        out = Recording.from_simulation(
            sim,
            model=model,
            experiment_id=f"{rec.experiment_id or Path(args.inputs).stem}-sim",
            source=f"thermogym simulate {model.name}",
            meta={"inputs": str(args.inputs)},
        )
    with plan:
        recording.write_recording(out, plan.path("--out"))
        if args.plot:
            # figures only when asked: matplotlib costs ~0.5 s at start-up
            from thermogym import plotting

            names = [n for n in model.output_names if n in rec]
            plotting.plot_recordings(
                [rec],
                plan.path("--plot"),
                signals=names or list(model.output_names),
                overlay={"simulation": {n: out[n] for n in model.output_names}},
            )
    print(f"simulated {model.name} on {rec.n_samples} samples (dt = {rec.dt:g} s) -> {args.out}")
    for name in model.output_names:
        if name in rec and np.isfinite(rec[name]).all():
            print(f"  {name:<24} fit {fit_text(float(nrmse(rec[name], out[name])))}")
    if args.plot:
        print(f"  plot: {args.plot}")
    return 0
