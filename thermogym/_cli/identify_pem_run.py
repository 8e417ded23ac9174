"""The work of ``thermogym identify pem``.

The command's description and its options: :mod:`thermogym._cli.identify_pem`.
"""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np

from thermogym._cli.common import plan_outputs
from thermogym._cli.data_run import (
    load_recordings,
    parse_prepare,
)
from thermogym._cli.identify_linear_run import (
    _cols,
    _plot_fits,
    _print_offsets,
    _report,
    _warn,
    early_model,
    offsets_option,
)
from thermogym._cli.identify_linear_run import _signals as signals
from thermogym.errors import ConfigError, IdentificationError

# pem is looked up in its module when called, so that a replacement there is used (the
# interruption tests replace it)
from thermogym.identification import pem
from thermogym.identification.advice import (
    check_expect_names,
    parse_expect_sign,
    structure_warnings,
)
from thermogym.identification.ssest import identify_auto, ssest


def _ints(name: str, text: str | None) -> Any:
    """``3`` or ``1,2`` (per input) or ``1,2;3,4`` (per output; per input)."""
    if text is None:
        return None
    try:
        rows = [[int(v) for v in row.split(",")] for row in text.split(";")]
    except ValueError:
        raise ConfigError(
            f"--{name} {text!r}: expected whole numbers, e.g. 2, or 2,1 (one per input), or "
            "2,1;1,1 (rows per output)"
        ) from None
    if any(v < 0 for row in rows for v in row):
        raise ConfigError(f"--{name} {text!r}: expected whole numbers >= 0")
    if len(rows) == 1 and len(rows[0]) == 1:
        return rows[0][0]
    if len(rows) == 1:
        return [rows[0]]
    return rows


def _orders_range(text: str) -> range:
    """``--orders A:B`` of ssest, or a one-line error naming it."""
    a, _, b = text.partition(":")
    try:
        orders_r = range(int(a), int(b or a) + 1)
    except ValueError:
        raise ConfigError(f"--orders {text!r} is not of the form A:B") from None
    if orders_r.start < 1 or len(orders_r) == 0 or orders_r.stop - 1 > 500:
        raise ConfigError(f"--orders {text!r}: expected 1 <= A <= B <= 500")
    return orders_r


def _early(method: str, args: argparse.Namespace) -> None:
    """Parse the structured options into ``args`` before any work starts."""
    if method in ("arx", "armax", "oe", "bj"):
        args.pem_orders = {
            k: _ints(k, getattr(args, k, None)) for k in ("na", "nb", "nc", "nd", "nf", "nk")
        }
    if method == "ssest":
        args.orders_r = _orders_range(args.orders)
        delay = (
            None if args.input_delay in (None, "auto") else _ints("input-delay", args.input_delay)
        )
        if isinstance(delay, list):
            raise ConfigError("--input-delay: one delay for all inputs")
        args.delay = delay


def choose_operating_point(
    train: list[Any],
    inputs: list[str],
    outputs: list[str],
    dist: list[str] | None,
    folds: int,
    offsets: dict[str, dict[str, float]] | None = None,
) -> tuple[str, dict[str, float]]:
    """``"mean"`` or ``"none"``: whichever ARX cross-validates better on the training data.

    Given ``offsets`` hold in both (they replace the mode's values of their signals).
    """
    scores = {}
    for mode in ("mean", "none"):
        try:
            r = pem.pem(
                train,
                inputs,
                outputs,
                "arx",
                folds=folds,
                disturbances=dist,
                operating_point_mode=mode,
                offsets=offsets,
            )
            scores[mode] = float(r.selection["order_scores"][r.selection["chosen_order"] - 1])
        except (IdentificationError, ConfigError):
            scores[mode] = float("-inf")
    best = "none" if scores["none"] > scores["mean"] + 1e-3 else "mean"
    if not np.isfinite(scores[best]):
        best = "mean"
    return best, scores


def run(method: str, args: argparse.Namespace) -> int:
    """Run ``thermogym identify METHOD`` on its parsed options (``args``)."""
    args.command = "identify"
    args.expect = parse_expect_sign(args.expect_sign)  # refused early
    prep = parse_prepare(args.prepare)
    _cols(args.inputs), _cols(args.outputs), _cols(args.disturbances)  # refused early
    offsets_option(args, _cols(args.inputs), _cols(args.outputs))  # names given: refused early
    _early(method, args)
    early_model(args)
    plan = plan_outputs(
        args, files={"out": "json"}, folders=("plots",), inputs=("data", "validate")
    )
    with plan:
        return _identify(method, args, prep, plan)


def _identify(method: str, args: argparse.Namespace, prep: Any, plan: Any) -> int:
    train = load_recordings(args.data, "training", args, prepare=prep)
    vals = load_recordings(args.validate, "validation", args, prepare=prep)
    inputs, outputs = signals(args, train[0])
    dist = _cols(args.disturbances)
    check_expect_names(args.expect, [*inputs, *(dist or [])], outputs)
    offsets = offsets_option(args, inputs, outputs)
    _print_offsets(offsets)
    max_delay = getattr(args, "max_delay_s", None)
    if max_delay is not None:  # as foptd: a delay longer than the data cannot be told
        span = min(r.duration for r in train)
        if max_delay > span:
            raise ConfigError(
                f"--max-delay-s {max_delay:g} s is longer than the recording ({span:g} s); "
                "expected a delay within it"
            )
    op = args.operating_point
    if op == "auto":
        op, scores = choose_operating_point(train, inputs, outputs, dist, args.folds, offsets)
        print(
            f"operating point: {op} (ARX cross-validation: mean {100 * scores['mean']:.1f} %, "
            f"none {100 * scores['none']:.1f} %)"
        )
    common: dict[str, Any] = {
        "disturbances": dist,
        "operating_point_mode": op,
        "offsets": offsets,
        "validate": vals,
    }
    if method in ("arx", "armax", "oe", "bj"):
        orders = args.pem_orders
        res = pem.pem(
            train,
            inputs,
            outputs,
            method,
            max_order=args.max_order,
            max_delay=args.max_delay,
            folds=args.folds,
            focus=args.focus,
            **{k: v for k, v in orders.items() if v is not None},
            **common,
        )
        o = res.fit.settings["orders"]
        print(
            f"{method.upper()} ({res.fit.settings['order_source']}) in {res.seconds:.2f} s: "
            + ", ".join(f"{k} = {v}" for k, v in o.items())
        )
    elif method == "sopdt":
        res = pem.sopdt(train, inputs, outputs, max_delay_s=args.max_delay_s, **common)
        print(f"SOPDT in {res.seconds:.2f} s:")
        for name, v in res.fit.parameters.items():
            print(f"  {name:<28} {v:12.5g} ± {res.fit.stderr.get(name, float('nan')):.3g}")
    elif method == "ssest":
        orders_r, delay = args.orders_r, args.delay
        res = ssest(
            train,
            inputs,
            outputs,
            order=args.order,
            orders=orders_r,
            feedthrough={"auto": None, "yes": True, "no": False}[args.feedthrough],
            input_delay=delay,
            max_delay=args.max_delay,
            folds=args.folds,
            refine_fit=not args.no_refine,
            focus=args.focus,
            **common,
        )
        st = res.fit.settings
        refined = st.get("status", "none")
        if st.get("evaluation_limit_reached"):
            refined = f"stopped after {st.get('nfev')} evaluations (see the warning)"
        print(
            f"ssest in {res.seconds:.2f} s: order {st['order']}, feedthrough "
            f"{st['feedthrough']}, input delay {st['input_delay']} samples "
            f"({st['structure_source']}); refinement: {refined}"
        )
    else:
        fams = list(args.families)
        res = identify_auto(
            train,
            inputs,
            outputs,
            families=fams,
            folds=args.folds,
            max_order=args.max_order,
            max_delay=args.max_delay,
            expect=args.expect,
            **common,
        )
        auto = res.fit.settings["auto"]
        print(
            f"auto in {res.seconds:.1f} s: chose {auto['chosen']}, the best cross-validated "
            f"fit on the training data ({args.folds} parts and {auto['kfold_blocks'] or 'no'} "
            "k-fold blocks) among the stable families whose gains agree with the physics"
        )
        for fam, s in auto["families"].items():
            if "cv_mnrmse" in s:
                why = [] if s["stable"] else [f"unstable: pole {s['max_abs_eigenvalue']:.4g}"]
                why += ["gain sign"] if s["gain_sign"] else []
                print(
                    f"  {fam:<6} CV MNRMSE {100 * s['cv_mnrmse']:7.2f} %   {s['structure']}"
                    + (f"   not admissible ({'; '.join(why)})" if why else "")
                )
            else:
                print(f"  {fam:<6} failed: {s['error']}")
        if auto.get("note"):
            print(f"  note: {auto['note']}")
    fit = res.fit
    if op != args.operating_point:
        fit.settings["operating_point_choice"] = {"mode": op, "rule": "ARX cross-validation"}
    _report(fit, args.x0)
    _structure_warn(fit, method, args, train, vals)
    fit.save(plan.path("--out"))
    plots = plan.get("--plots")
    if plots:
        figures = _plot_fits(fit, train, plots, "train", args.x0)
        figures += _plot_fits(fit, vals, plots, "validation", args.x0)
        for f in figures:
            print(f"  figure: {plan.final(f)}")
    print(f"wrote {args.out}")
    return 0


def _structure_warn(
    fit: Any, method: str, args: argparse.Namespace, train: list[Any], vals: list[Any]
) -> None:
    """Print and store the warnings: fits below zero, gain signs, structure at an edge."""
    orders = None
    if method == "ssest" and args.order is None:
        a, _, b = args.orders.partition(":")
        orders = range(int(a), int(b or a) + 1)
    record_s = max(r.n_samples * r.dt for r in train)
    extra = structure_warnings(
        fit, orders=orders, max_delay=getattr(args, "max_delay", None), record_s=record_s
    )
    _warn(fit, train + vals, args, extra)
