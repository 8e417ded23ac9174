"""The work of ``thermogym identify linear``.

The command's description and its options: :mod:`thermogym._cli.identify_linear`.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import numpy as np

from thermogym._cli.common import plan_outputs
from thermogym._cli.data_run import (
    load_recordings,
    parse_prepare,
)
from thermogym.errors import ConfigError
from thermogym.fitresult import data_entry

# n4sid is looked up in its module when called, so that a replacement there is used (the
# interruption tests replace it)
from thermogym.identification import n4sid
from thermogym.identification.advice import (
    FitWarning,
    check_cv_score,
    check_expect_names,
    check_fit,
    parse_expect_sign,
)
from thermogym.identification.crossval import (
    cross_validate_order,
    deviation_recordings,
    make_folds,
)
from thermogym.identification.foptd import fit_foptd
from thermogym.identification.linear_fit import (
    evaluate_fit,
    exogenous_roles,
    predict_fit,
    signal_arrays,
)
from thermogym.identification.metrics import fit_text, nrmse
from thermogym.identification.rls import RecursiveFOPTD
from thermogym.models.registry import get_model


def _cols(text: str | None) -> list[str] | None:
    if text is None:
        return None
    out = [c.strip() for c in text.split(",") if c.strip()]
    if not out:
        raise ConfigError(f"empty column list {text!r}")
    return out


def _signals(args: argparse.Namespace, rec: Any) -> tuple[list[str], list[str]]:
    inputs, outputs = _cols(args.inputs), _cols(args.outputs)
    if args.model:
        model = get_model(args.model)
        inputs = inputs or list(model.exogenous_names)
        outputs = outputs or list(model.output_names)
    if inputs is None:
        inputs = [c for c in rec.columns if rec.roles.get(c) in ("input", "disturbance")]
    if outputs is None:
        outputs = [c for c in rec.columns if rec.roles.get(c) == "output"]
    if not inputs or not outputs:
        raise ConfigError(
            f"name the columns: --inputs/--outputs (or --model PLANT); the recording has "
            f"{list(rec.columns)} and no roles to tell inputs from outputs"
        )
    return inputs, outputs


def offsets_option(
    args: argparse.Namespace, inputs: list[str] | None, outputs: list[str] | None
) -> dict[str, dict[str, float]] | None:
    """``--u-offset``/``--y-offset`` as the ``offsets=`` of the fits, names checked.

    ``inputs``/``outputs`` ``None``: not known yet (their names are checked
    once the recording's roles are read). Returns ``None`` without offsets.
    """
    given = {"inputs": args.u_offset or {}, "outputs": args.y_offset or {}}
    for option, part, names, what in (
        ("--u-offset", "inputs", inputs, "input"),
        ("--y-offset", "outputs", outputs, "output"),
    ):
        bad = [c for c in given[part] if names is not None and c not in names]
        if bad:
            raise ConfigError(
                f"{option} names {bad[0]!r}, which is not an {what} of the fit; expected "
                f"one of {list(names or [])} (--{what}s)"
            )
    if not given["inputs"] and not given["outputs"]:
        return None
    return given


def _print_offsets(offsets: dict[str, dict[str, float]] | None) -> None:
    if offsets:
        text = ", ".join(f"{c}={v:g}" for part in offsets.values() for c, v in part.items())
        print(f"operating point: given offsets {text} (the other signals: the mode's)")


def _report(fit: Any, x0: str) -> None:
    how = {
        "auto": "estimated from each recording's outputs",
        "estimate": "estimated from each recording's outputs",
        "steady": "settled at the first input",
        "zero": "at rest at the operating point",
    }[x0]
    print(f"  fit (NRMSE fit, %; initial state {how}, --x0 {x0}):")
    for part in ("train", "validation"):
        m = fit.metrics.get(part)
        if not m:
            continue
        print(f"  {part}: mean fit {fit_text(m['mnrmse'])}")
        for eid, rep in m["experiments"].items():
            per = "  ".join(f"{c} {fit_text(v)}" for c, v in rep["nrmse"].items())
            print(f"    {eid:<32} {per}")


def _warn(fit: Any, recs: list[Any], args: argparse.Namespace, extra: list[Any]) -> None:
    """Add the generic checks and ``extra`` to the FitResult and print every warning."""
    units: dict[str, str] = {}
    for r in recs:
        units.update({c: u for c, u in r.units.items() if u})
    fit.warnings = [w for w in fit.warnings if w["code"] not in ("fit_below_zero", "gain_sign")]
    fit.add_warnings([*extra, *check_fit(fit, units=units, expect=args.expect)])
    for w in fit.warnings:
        print(f"warning: {w['message']}", file=sys.stderr)


def _plot_fits(fit: Any, recs: list[Any], folder: Path, tag: str, x0: str) -> list[Path]:
    # figures only when asked: matplotlib costs ~0.5 s at start-up
    from thermogym.identification.linear_plots import plot_fit

    model = fit.build_model()
    outs = list(model.output_names)
    paths = []
    for rec in recs:
        yh = predict_fit(fit, rec, x0=x0)
        fits = {c: float(nrmse(rec[c], yh[:, j])) for j, c in enumerate(outs)}
        name = f"{tag}_{rec.experiment_id or 'recording'}.png"
        paths.append(
            plot_fit(
                rec, yh, outs, folder / name, title=f"{fit.method}: {rec.experiment_id}", fits=fits
            )
        )
    return paths


def run(method: str, args: argparse.Namespace) -> int:
    """Run ``thermogym identify METHOD`` on its parsed options (``args``)."""
    args.command = "identify"
    args.expect = parse_expect_sign(args.expect_sign)  # refused early
    prep = parse_prepare(args.prepare)
    _cols(args.inputs), _cols(args.outputs), _cols(args.disturbances)  # refused early
    offsets_option(args, _cols(args.inputs), _cols(args.outputs))  # names given: refused early
    if getattr(args, "from_fit", None) and (args.u_offset or args.y_offset):
        raise ConfigError(
            "--u-offset/--y-offset with --from-fit: the warm start keeps the operating point "
            "of the fit it starts from; expected one or the other"
        )
    decimate_option(args)
    early_model(args)
    if getattr(args, "delays", None):
        _delays(args.delays)
    plan = plan_outputs(
        args,
        files={"out": "json"},
        folders=("plots",),
        inputs=("data", "validate", "from_fit"),
    )
    with plan:
        return _identify(method, args, prep, plan)


def _delays(text: str) -> list[int]:
    """``--delays 2`` or ``--delays 2,3`` (one per output): whole numbers of samples >= 0."""
    try:
        delays = [int(v) for v in text.split(",")]
    except ValueError:
        raise ConfigError(
            f"--delays {text!r}: expected whole numbers of samples, comma-separated"
        ) from None
    if any(v < 0 for v in delays):
        raise ConfigError(f"--delays {text!r}: expected delays >= 0 samples")
    return delays


def early_model(args: argparse.Namespace) -> None:
    """Refuse an unknown ``--model`` (whose signal names are used) before reading data."""
    if getattr(args, "model", None):
        get_model(args.model)


def decimate_option(args: argparse.Namespace) -> None:
    """Check ``--decimate`` (a whole number >= 1 or ``auto``) before any work starts."""
    text = getattr(args, "decimate", "auto")
    if text == "auto":
        return
    try:
        args.decimate = int(text)
    except ValueError:
        raise ConfigError(f"--decimate {text!r}: expected a whole number or 'auto'") from None
    if args.decimate < 1:
        raise ConfigError(f"--decimate {text!r}: expected a whole number >= 1 or 'auto'")


def _identify(method: str, args: argparse.Namespace, prep: Any, plan: Any) -> int:
    train = load_recordings(args.data, "training", args, prepare=prep)
    vals = load_recordings(args.validate, "validation", args, prepare=prep)
    inputs, outputs = _signals(args, train[0])
    dist = _cols(args.disturbances)
    check_expect_names(args.expect, [*inputs, *(dist or [])], outputs)
    args.offsets = offsets_option(args, inputs, outputs)
    _print_offsets(args.offsets)
    max_delay = getattr(args, "max_delay_s", None)
    if max_delay is not None:
        span = min(r.duration for r in train)
        if max_delay > span:
            raise ConfigError(
                f"--max-delay-s {max_delay:g} s is longer than the recording ({span:g} s); "
                "expected a delay within it"
            )
    plots = plan.get("--plots")
    figures: list[Path] = []
    extra: list[Any] = []
    if method == "foptd":
        res = fit_foptd(
            train,
            inputs,
            outputs,
            disturbances=dist,
            max_delay_s=args.max_delay_s,
            criterion=args.criterion,
            operating_point_mode=args.operating_point or "estimate",
            offsets=args.offsets,
            validate=vals,
        )
        fit = res.fit
        print(f"FOPTD ({args.criterion} criterion) in {res.seconds:.3f} s:")
        for j, c in enumerate(outputs):
            for i, u in enumerate(res.model.exogenous_names):
                print(
                    f"  {c:<24} <- {u:<12} K = {res.K[j, i]:10.4g}  T = {res.T[j, i]:9.4g} s  "
                    f"tau = {res.tau[j, i]:7.4g} s"
                )
        if plots:
            # figures only when asked: matplotlib costs ~0.5 s at start-up
            from thermogym.identification.linear_plots import plot_delay_loss

            figures.append(plot_delay_loss(res, plots / "foptd_delay_search.png"))
    elif method == "rls":
        fit = _run_rls(args, train, vals, inputs, outputs, dist)
    else:
        fit, extra = _run_n4sid(args, train, vals, inputs, outputs, dist, plots, figures)
    if args.x0 != "auto":
        fit.metrics["train"] = evaluate_fit(fit, train, x0=args.x0)
        if vals:
            fit.metrics["validation"] = evaluate_fit(fit, vals, x0=args.x0)
    fit.settings["x0_evaluation"] = args.x0
    _report(fit, args.x0)
    _warn(fit, train + vals, args, extra)
    fit.save(plan.path("--out"))
    if plots:
        figures += _plot_fits(fit, train, plots, "train", args.x0)
        figures += _plot_fits(fit, vals, plots, "validation", args.x0)
        for f in figures:
            print(f"  figure: {plan.final(f)}")
    print(f"wrote {args.out}")
    return 0


def _from_fit_columns(
    args: argparse.Namespace, est: RecursiveFOPTD, exo: list[str], outputs: list[str]
) -> tuple[list[str], list[str]]:
    """The columns a warm start from ``--from-fit`` reads: the fit's own, in its order.

    ``--inputs``/``--outputs`` given must name the same columns (in any order): the
    recursion continues the fit's gains, which belong to its columns.

    Raises
    ------
    ConfigError
        Naming the columns given and the fit's.
    """
    if args.inputs is not None and sorted(exo) != sorted(est.inputs):
        raise ConfigError(
            f"--inputs {exo} are not the exogenous columns of --from-fit "
            f"{str(args.from_fit)!r}, {est.inputs}; give those"
        )
    if args.outputs is not None and sorted(outputs) != sorted(est.outputs):
        raise ConfigError(
            f"--outputs {outputs} are not the outputs of --from-fit {str(args.from_fit)!r}, "
            f"{est.outputs}; give those"
        )
    return list(est.inputs), list(est.outputs)


def _rls_arrays(
    train: list[Any], exo: list[str], outputs: list[str], dt: float
) -> list[tuple[np.ndarray, np.ndarray]]:
    """``(u, y)`` of every training recording, checked for the recursion of period ``dt``.

    Raises
    ------
    RecordingError, UnknownNameError
        A missing column, an uneven time axis or a non-finite sample, named.
    ConfigError
        A recording sampled at another period than ``dt`` (the recursion's
        coefficients hold for one period only).
    """
    out = []
    for rec in train:
        rec.select([*exo, *outputs])  # names a missing column
        if abs(rec.dt - dt) > 1e-9 * dt:  # rec.dt names an uneven step
            raise ConfigError(
                f"recording {rec.experiment_id!r} is sampled every {rec.dt:g} s; the RLS "
                f"recursion runs at {dt:g} s (its delays and poles are per sample): resample it "
                "(--prepare dt=SECONDS) or give recordings of one period"
            )
        rec.check_values([*exo, *outputs])  # non-finite samples, named
        u = np.column_stack([rec[c] for c in exo])
        y = np.column_stack([rec[c] for c in outputs])
        out.append((u, y))
    return out


def _run_rls(args, train, vals, inputs, outputs, dist):  # type: ignore[no-untyped-def]
    ins, dis = exogenous_roles(train[0], inputs, dist)
    exo = ins + dis
    if args.from_fit:
        est = RecursiveFOPTD.from_fit(args.from_fit, forgetting=args.forgetting)
        exo, outputs = _from_fit_columns(args, est, exo, outputs)
    else:
        if args.delays:
            delays = _delays(args.delays)
            n = min(r.n_samples for r in train)
            if max(delays) >= n // 2:
                raise ConfigError(
                    f"--delays {args.delays!r}: a delay of {max(delays)} samples leaves too little "
                    f"of a {n}-sample recording to fit; expected delays < {n // 2} samples"
                )
            d = np.array(delays)[:, None] if len(delays) > 1 else delays[0]
        else:
            d = np.round(
                fit_foptd(
                    train[0], inputs, outputs, disturbances=dist, max_delay_s=args.max_delay_s
                ).tau
                / train[0].dt
            ).astype(int)
            print(f"  delays from a batch FOPTD fit of {train[0].experiment_id}: {d.tolist()}")
        given = args.offsets or {"inputs": {}, "outputs": {}}
        est = RecursiveFOPTD(
            exo,
            outputs,
            # a given offset, else the first sample (NaN)
            u_op=[given["inputs"].get(c, np.nan) for c in exo] if args.offsets else None,
            y_op=[given["outputs"].get(c, np.nan) for c in outputs] if args.offsets else None,
            dt=train[0].dt,
            delays=d,
            disturbances=dis,
            forgetting=args.forgetting,
            units={k: v for k, v in train[0].units.items()},
        )
    for u, y in _rls_arrays(train, exo, outputs, est.dt):
        est.update_many(u, y)
    fit = est.to_fitresult()
    fit.data = [data_entry(r, "train") for r in train] + [data_entry(r, "validation") for r in vals]
    fit.metrics["train"] = evaluate_fit(fit, train)
    if vals:
        fit.metrics["validation"] = evaluate_fit(fit, vals)
    K, T, tau = est.parameters()
    print(f"RLS (λ = {args.forgetting}) over {est.rls.n_updates} samples:")
    for j, c in enumerate(outputs):
        for i, u_ in enumerate(exo):
            print(
                f"  {c:<24} <- {u_:<12} K = {K[j, i]:10.4g}  T = {T[j, i]:9.4g} s  "
                f"tau = {tau[j, i]:7.4g} s"
            )
    return fit


def _run_n4sid(args, train, vals, inputs, outputs, dist, plots, figures):  # type: ignore[no-untyped-def]
    decimate: int | str = args.decimate
    opm = args.operating_point or "auto"
    tol = float(args.cv_tolerance)
    common = {
        "disturbances": dist,
        "horizon": args.horizon,
        "decimate": decimate,
        "weighting": args.weighting,
        "feedthrough": args.feedthrough,
        "x0": "zero" if args.x0 == "zero" else "estimate",
    }
    offsets = args.offsets
    cv = None
    order = args.order
    orders = args.orders if args.order is None else range(args.order, args.order + 1)
    notes: list[Any] = []
    folds = None
    if args.folds is not None or opm == "auto":
        # checked first; about the rest, an input held at a non-zero value is a step from zero
        signal_arrays(
            train, inputs, outputs, min_samples=8, what="N4SID", step_inputs=opm == "rest"
        )

        ins, dis = exogenous_roles(train[0], inputs, dist)
        folds, texts = make_folds(train, args.folds or 2, ins + dis)
        notes += [FitWarning("cv_fallback", t) for t in texts]
        for t in texts:
            print(f"  note: {t}")
    cvs = {}
    if folds is not None and (args.folds is not None or opm == "auto"):
        for mode in ("none", "mean") if opm == "auto" else (opm,):
            # every fold about its whole recording's operating point (a part cut out of a
            # run that starts at rest does not itself start at rest): the same cuts, made
            # in the deviations
            dev = deviation_recordings(train, inputs, outputs, mode, offsets=offsets)
            dev_folds = make_folds(dev, args.folds or 2, ins + dis)[0]
            assert dev_folds is not None
            cvs[mode] = cross_validate_order(
                dev_folds,
                inputs,
                outputs,
                orders,
                scheme=args.scheme,
                tolerance=tol / 100,
                operating_point_mode=mode,
                deviations=True,
                **common,
            )
    if opm == "auto":
        # the operating point by cross-validation: "none" keeps the absolute levels (a plant
        # at rest at zero input: rises above ambient, an ambient input), "mean" removes them
        # (an output with an offset of its own, MATLAB's detrend); the better held-out fit wins
        if cvs:
            score = {m: float(c.va[list(c.orders).index(c.chosen_order)]) for m, c in cvs.items()}
            opm = max(score, key=lambda m: (score[m], m == "mean"))
            print(
                f"operating point: {opm} (cross-validated: none VA {fit_text(score['none'])}, "
                f"mean VA {fit_text(score['mean'])}; --operating-point sets it)"
            )
        else:
            opm = "mean"
            print(
                "operating point: mean (no folds to cross-validate it; --operating-point sets it)"
            )
    common["operating_point_mode"] = opm
    if args.folds is not None and opm in cvs:
        cv = cvs[opm]
        order = cv.chosen_order
        k = len(cv.folds)
        i_c = list(cv.orders).index(order)
        notes += check_cv_score(cv.va[i_c], "order") + cv.warnings()
        print(
            f"{k}-fold cross-validation ({args.scheme}) over orders {orders.start}.."
            f"{orders.stop - 1} in {cv.seconds['total']:.2f} s: n* = {order}, the smallest "
            f"order within {tol:g} % of the best validation fit (TA {fit_text(cv.ta[i_c])}, "
            f"VA {fit_text(cv.va[i_c])}; argmax VA: {cv.best_order})"
        )
        for row in cv.table():
            print(f"    n = {row['order']:3d}  TA {fit_text(row['TA'])}  VA {fit_text(row['VA'])}")
    res = n4sid.n4sid(
        train,
        inputs,
        outputs,
        order,
        orders=orders,
        noise_model=not args.no_noise_model,
        offsets=offsets,
        validate=vals,
        **common,
    )
    fit = res.fit
    if cv is not None:
        fit.settings["cross_validation"] = cv.to_dict()
        fit.settings["order_source"] = (
            f"{len(cv.folds)}-fold cross-validation (smallest order within {tol:g} % of the best)"
        )
    print(
        f"N4SID order {res.order} ({fit.settings['order_source']}), horizon "
        f"{res.decomposition.horizon}, decimation {res.decomposition.decimate}, "
        f"{res.seconds:.2f} s"
    )
    if plots:
        # figures only when asked: matplotlib costs ~0.5 s at start-up
        from thermogym.identification.linear_plots import plot_order_cv, plot_singular_values

        figures.append(
            plot_singular_values(
                res.decomposition.singular_values, plots / "singular_values.png", chosen=res.order
            )
        )
        if cv is not None:
            figures.append(plot_order_cv(cv, plots / "order_cv.png"))
    return fit, notes
