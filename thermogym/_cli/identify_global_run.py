"""The work of ``thermogym identify global``.

The command's description and its options: :mod:`thermogym._cli.identify_global`.
"""

from __future__ import annotations

import argparse
import inspect
import sys
from pathlib import Path
from typing import Any

from thermogym._checks import finite
from thermogym._cli.common import (
    Interrupted,
    plan_outputs,
)
from thermogym._cli.data_run import (
    load_recordings,
    parse_prepare,
)
from thermogym.errors import ConfigError
from thermogym.identification.coordinator import run_identification
from thermogym.identification.external import load_external
from thermogym.identification.problem import FreeParameter, Problem, RatioParameter
from thermogym.identification.uncertainty import estimate_input_noise
from thermogym.models.registry import get_model

#: CLI option → (method option name, methods it applies to)
_METHOD_OPTIONS: dict[str, tuple[str, tuple[str, ...]]] = {
    "jac": ("jac", ("greybox",)),
    "diff": ("diff", ("greybox",)),
    "solver": ("solver", ("greybox",)),
    "samples": ("n_samples", ("montecarlo",)),
    "batch_size": ("batch_size", ("montecarlo",)),
    "sampler": ("sampler", ("montecarlo",)),
    "chains": ("n_chains", ("anneal",)),
    "popsize": ("popsize", ("evolution", "cmaes")),
    "sigma0": ("sigma0", ("cmaes",)),
}


def _number(text: str, what: str) -> float:
    return finite(what, text, error=ConfigError)


def _free_specs(items: list[str], log: list[str]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for item in items:
        name, _, rng = item.partition("=")
        name = name.strip()
        if name in out:
            raise ConfigError(f"--free {name} is given twice ({item!r}); give each once")
        kw: dict[str, Any] = {"scale": "log" if name in log else "linear"}
        if rng:
            parts = rng.split(":")
            if len(parts) not in (2, 3):
                raise ConfigError(f"--free {item!r}: expected NAME=LO:HI or NAME=LO:HI:START")
            kw["lower"] = _number(parts[0], f"lower bound of {name!r}")
            kw["upper"] = _number(parts[1], f"upper bound of {name!r}")
            if len(parts) == 3:
                kw["start"] = _number(parts[2], f"start of {name!r}")
            if not kw["lower"] < kw["upper"]:
                raise ConfigError(f"--free {item!r}: expected a lower bound below the upper one")
        out[name] = FreeParameter(name, **kw)
    unknown_log = [n for n in log if n not in out]
    if unknown_log and items:
        raise ConfigError(f"--log names {unknown_log}, which are not given with --free")
    return out


def _pairs(items: list[str]) -> list[tuple[str, str, float]] | None:
    if not items:
        return None
    out = []
    for item in items:
        body, _, w = item.partition("@")
        meas, _, sim = body.partition(":")
        weight = _number(w, f"weight of pair {item!r}") if w else 1.0
        out.append((meas.strip(), (sim or meas).strip(), weight))
    return out


def _ratios(items: list[str]) -> list[Any]:
    out = []
    for item in items:
        name, eq, rest = item.partition("=")
        if not eq or not rest:
            raise ConfigError(f"--ratio {item!r}: expected NAME=TARGET[,TARGET...][:LO:HI]")
        parts = rest.split(":")
        targets = tuple(t.strip() for t in parts[0].split(",") if t.strip())
        kw: dict[str, Any] = {}
        if len(parts) == 3:
            kw["lower"] = _number(parts[1], f"lower bound of ratio {name!r}")
            kw["upper"] = _number(parts[2], f"upper bound of ratio {name!r}")
        elif len(parts) != 1:
            raise ConfigError(f"--ratio {item!r}: give both bounds, NAME=TARGETS:LO:HI")
        out.append(RatioParameter(name.strip(), targets, **kw))
    return out


def _fixed(items: list[str]) -> dict[str, float]:
    out = {}
    for item in items:
        name, eq, value = item.partition("=")
        if not eq:
            raise ConfigError(f"--fix {item!r}: expected NAME=VALUE")
        out[name.strip()] = _number(value, f"value of {name.strip()!r}")
    return out


def _noise_specs(items: list[str]) -> dict[str, float | None]:
    """``--input-noise COLUMN[=SIGMA]``: sigma, or None to estimate it from the data."""
    out: dict[str, float | None] = {}
    for item in items:
        col, eq, sigma = item.partition("=")
        col = col.strip()
        if not col:
            raise ConfigError(f"--input-noise {item!r}: expected COLUMN or COLUMN=SIGMA")
        out[col] = _number(sigma, f"noise of {col!r}") if eq else None
        if eq and not out[col] > 0:  # type: ignore[operator]
            raise ConfigError(f"--input-noise {item!r}: expected a noise sigma > 0")
    return out


def _external(args: argparse.Namespace) -> Any:
    extra = {k: getattr(args, k) for k in ("backend", "workers") if getattr(args, k) is not None}
    if extra.get("backend") == "local":
        extra["backend"] = "process"
    if extra:
        params = inspect.signature(load_external).parameters
        open_kw = any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values())
        bad = [] if open_kw else [k for k in extra if k not in params]
        if bad:
            raise ConfigError(
                f"load_external does not take {bad}; set them in the configuration file"
            )
    return load_external(args.external, **extra)


def run(method: str, args: argparse.Namespace) -> int:
    """Run ``thermogym identify METHOD`` on its parsed options (``args``)."""
    args.command = "identify"
    prep = parse_prepare(args.prepare)
    if args.external is not None and not Path(args.external).is_file():
        what = "is a folder" if Path(args.external).is_dir() else "does not exist"
        raise ConfigError(f"--external {str(args.external)!r} {what}; expected a TOML/YAML file")
    plan = plan_outputs(
        args,
        files={"out": "json", "history": "json", "plot": "figure"},
        inputs=("data", "validate", "external"),
    )
    if args.no_overwrite:
        plan.must_not_exist("--out")
    with plan:
        return _identify(method, args, prep, plan)


def _identify(method: str, args: argparse.Namespace, prep: Any, plan: Any) -> int:
    options: dict[str, Any] = {}
    for cli, (opt, methods) in _METHOD_OPTIONS.items():
        v = getattr(args, cli)
        if v is None:
            continue
        if method not in methods:
            flag = "--" + cli.replace("_", "-")
            raise ConfigError(f"option {flag} does not apply to method {method!r}")
        options[opt] = v
    if args.polish and method == "greybox":
        raise ConfigError("--polish refines a global method; greybox is already local")
    if args.external is not None and args.effects:
        raise ConfigError("--effects applies to --model, not to --external")
    if args.external is None and (args.backend or args.workers):
        raise ConfigError("--backend/--workers apply to --external models")
    free = _free_specs(args.free, args.log) or None
    if free is None and args.log:
        raise ConfigError("--log needs the parameters given with --free")
    pairs, ratios, fixed = _pairs(args.pair), _ratios(args.ratio), _fixed(args.fix)
    given_noise = _noise_specs(args.input_noise)
    if args.external is None:  # an unknown model or effect: refused before reading data
        model = get_model(args.model, **({"effects": list(args.effects)} if args.effects else {}))
    recs = load_recordings(args.data, "training", args, prepare=prep)
    validation = (
        load_recordings(args.validate, "validation", args, prepare=prep) if args.validate else None
    )
    if args.external is not None:
        model = _external(args)
    else:
        for rec in [*recs, *(validation or [])]:  # the model's units, before any work
            rec.validate_for(model, outputs=[n for n in model.output_names if n in rec])
    try:
        problem = Problem(
            model,
            recs,
            pairs=pairs,
            free=free,
            ratios=ratios,
            fixed=fixed,
            objective=args.objective,
        )
        noise: dict[str, float] = {}
        for col, sigma in given_noise.items():
            if sigma is not None:
                noise[col] = sigma
            else:
                noise.update(estimate_input_noise(recs, [col]))
        result = run_identification(
            problem,
            method,
            seed=args.seed,
            max_iter=args.max_iter,
            max_evals=args.max_evals,
            time_limit=args.time_limit,
            target=args.target,
            progress=False if args.no_progress else None,
            level=args.level,
            polish=args.polish,
            validation=validation,
            input_noise=noise or None,
            **options,
        )
    finally:
        close = getattr(model, "close", None)
        if args.external is not None and callable(close):
            close()
    if result.stop_reason.startswith("interrupted"):
        # Ctrl-C ended the search: --out (and every other output) stays as it was; the
        # best parameters found so far go to a new name
        saved = plan.write_partial("--out", lambda p: result.fit.save(p, overwrite=False))
        raise Interrupted(
            f"the search was stopped after {result.evaluations} evaluations; the best result "
            f"so far is in {saved} (criterion {result.criterion:.6g}); --out {args.out} was "
            "left unchanged"
        )
    left = [o for o in model.output_names if o not in {p.simulated for p in problem.pairs}]
    if left and not pairs:  # the default pairs: the outputs every recording measures
        text = (
            f"output(s) {left} of model {model.name!r} are not columns of every training "
            f"recording and were left out of the fit; it compares "
            f"{[p.label for p in problem.pairs]} (name them with --pair)"
        )
        result.fit.add_warnings([{"code": "outputs_left_out", "message": text}])
        print(f"note: {text}")
    result.fit.save(plan.path("--out"))
    if args.history is not None:
        result.save_history(plan.path("--history"))
    if args.plot is not None:
        # figures only when asked: matplotlib costs ~0.5 s at start-up
        from thermogym.identification.coordinator_plots import plot_fit

        plot_fit(result, plan.path("--plot"))
    print(result.summary())
    if result.failed:
        top = sorted(result.failure_messages.items(), key=lambda kv: -kv[1])[:3]
        print(
            f"{result.failed} parameter set(s) failed; e.g. "
            + "; ".join(f"{m} ({n}x)" for m, n in top),
            file=sys.stderr,
        )
    print(f"wrote {args.out}")
    return 0
