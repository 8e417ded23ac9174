"""Warnings a careful engineer would give about a fit, and the one rule for orders.

Identification on real recordings can run to the end, write a FitResult and
still be wrong. The checks here look at what came out and say so in plain
words; every identify command prints them and stores them in the FitResult
(:attr:`thermogym.fitresult.FitResult.warnings`), so a later reader sees them
too. Each :class:`FitWarning` has a stable ``code``:

=======================  ===================================================================
code                     fires when
=======================  ===================================================================
``fit_below_zero``       an output's fit on training or held-out data is below 0 % (worse
                         than its own mean)
``gain_sign``            a steady-state gain has the sign opposite to the declared physics
                         (a heater on a temperature must raise it; see :func:`expected_signs`)
``order_at_edge``        the chosen order (or delay), or the best-scoring one, is the largest
                         of the searched range: the best may lie beyond it
``flat_cv``              the cross-validation curve is flat: several orders fit the held-out
                         data within the tolerance, so the data do not determine the order
                         and the smallest of them is taken
``time_constant_bound``  a time constant at the search bound: the record does not settle
                         enough to separate gain and time constant
``cv_fallback``          cross-validation could not use the folds asked for, and did
                         something else (what, is in the message)
``not_converged``        the prediction-error refinement stopped at its limit of function
                         evaluations, not at a minimum of the error
=======================  ===================================================================

The order rule (:func:`parsimonious_index`) is the same for the command line,
the API and the demo: **the smallest order whose validation fit is within the
tolerance of the best**. Orders above the true one fit the noise and differ
from it only in the last digits, so ``argmax`` (paper 001's eq 10) picks
among them by chance.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from thermogym._checks import nonnegative
from thermogym.errors import ConfigError

__all__ = [
    "CODES",
    "DEFAULT_TOLERANCE",
    "FitWarning",
    "check_cv_score",
    "check_expect_names",
    "check_fit",
    "check_gain_signs",
    "check_metrics",
    "check_order",
    "expected_signs",
    "parse_expect_sign",
    "parsimonious_index",
    "structure_warnings",
]

#: Stable codes of :class:`FitWarning` (the module docstring says when each fires).
CODES: tuple[str, ...] = (
    "fit_below_zero",
    "gain_sign",
    "order_at_edge",
    "flat_cv",
    "time_constant_bound",
    "cv_fallback",
    "not_converged",
)
#: Validation-fit tolerance of the order rule (fraction: 0.001 = 0.1 percentage point).
DEFAULT_TOLERANCE = 1e-3
#: Orders within the tolerance of the best from which the curve counts as flat.
_FLAT_COUNT = 3

_TEMPERATURE_UNITS = {"°c", "degc", "c", "k", "°f", "degf"}
_POWER_UNITS = {"w", "kw", "mw", "gw"}


@dataclass(frozen=True)
class FitWarning:
    """One warning about a fit.

    Attributes
    ----------
    code : str
        One of :data:`CODES`.
    message : str
        A sentence that names the signal or order and the number behind it.
    """

    code: str
    message: str

    def __post_init__(self) -> None:
        if self.code not in CODES:
            raise ConfigError(f"warning code {self.code!r} is unknown; codes are {list(CODES)}")

    def to_dict(self) -> dict[str, str]:
        """``{"code": ..., "message": ...}`` (as stored in FitResults)."""
        return {"code": self.code, "message": self.message}

    def __str__(self) -> str:
        return self.message


# ------------------------------------------------------------------------ orders
def parsimonious_index(scores: ArrayLike, tolerance: float = DEFAULT_TOLERANCE) -> int:
    """Index of the first score within ``tolerance`` of the best (higher is better).

    Parameters
    ----------
    scores : array_like
        Validation fits in the order of increasing model size; NaN counts as
        the worst.
    tolerance : float
        Allowed shortfall from the best (same scale as ``scores``), >= 0.

    Returns
    -------
    int

    Examples
    --------
    >>> parsimonious_index([0.50, 0.9010, 0.9005, 0.9012, 0.9011], tolerance=0.001)
    1
    """
    s = np.asarray(scores, dtype=float)
    if s.ndim != 1 or s.size == 0:
        raise ConfigError(f"scores has shape {s.shape}, expected a non-empty 1-D array")
    nonnegative("tolerance", tolerance, error=ConfigError, text=False)
    safe = np.where(np.isfinite(s), s, -np.inf)
    if not np.isfinite(safe).any():
        return 0
    return int(np.argmax(safe >= safe.max() - tolerance))


def check_order(
    orders: Sequence[int],
    scores: ArrayLike,
    chosen: int,
    *,
    tolerance: float = DEFAULT_TOLERANCE,
    what: str = "order",
) -> list[FitWarning]:
    """Warnings about an order chosen from a validation curve.

    ``order_at_edge`` when ``chosen`` is the largest order searched, or when
    the best-scoring order is (the parsimonious rule took a smaller one, but
    the curve still rises at the end of the range), and more than one order
    was searched; ``flat_cv`` when at least three orders are within
    ``tolerance`` of the best.

    Examples
    --------
    >>> [w.code for w in check_order([1, 2, 3], [0.5, 0.7, 0.9], 3)]
    ['order_at_edge']
    >>> [w.code for w in check_order(range(1, 6), [0.5, 0.9, 0.9, 0.9, 0.9], 2)]
    ['flat_cv']
    >>> [w.code for w in check_order(range(1, 6), [0.5, 0.9, 0.9, 0.9, 0.9005], 2)]
    ['order_at_edge', 'flat_cv']
    """
    o = [int(v) for v in orders]
    s = np.asarray(scores, dtype=float)
    out: list[FitWarning] = []
    safe = np.where(np.isfinite(s), s, -np.inf)
    if len(o) > 1 and int(chosen) == max(o):
        out.append(
            FitWarning(
                "order_at_edge",
                f"the chosen {what} {int(chosen)} is the largest searched ({min(o)}..{max(o)}): "
                f"the best may lie beyond; widen the range",
            )
        )
    elif (
        len(o) > 1
        and np.isfinite(safe).any()
        and o[int(np.argmax(safe))] == max(o)
        and int(chosen) in o
        # more than round-off above the chosen order (noise-free data give equal scores)
        and safe.max() - safe[o.index(int(chosen))] > 0.01 * tolerance
    ):
        out.append(
            FitWarning(
                "order_at_edge",
                f"the best cross-validated {what} is {max(o)}, the largest searched "
                f"({min(o)}..{max(o)}; {100 * safe.max():.2f} %), though {int(chosen)} is "
                f"taken as the smallest within {100 * tolerance:.2g} % of it: the range may be "
                "too small and the best may lie beyond; widen the range",
            )
        )
    if np.isfinite(safe).any():
        near = [n for n, v in zip(o, safe, strict=True) if v >= safe.max() - tolerance]
        if len(near) >= _FLAT_COUNT:
            out.append(
                FitWarning(
                    "flat_cv",
                    f"the cross-validation curve is flat: {what}s {', '.join(map(str, near))} "
                    f"fit the held-out data within {100 * tolerance:.2g} % of the best "
                    f"({100 * safe.max():.2f} %); the data do not determine the {what}, the "
                    f"smallest of them is taken ({min(near)})",
                )
            )
    return out


# ------------------------------------------------------------------------- fits
def check_metrics(metrics: Mapping[str, Any]) -> list[FitWarning]:
    """``fit_below_zero`` for each output whose fit is below zero (train, validation).

    Parameters
    ----------
    metrics : mapping
        ``FitResult.metrics``: ``{"train": {"experiments": {id: {"nrmse":
        {output: fit}}}}, "validation": ...}`` (fractions).

    Examples
    --------
    >>> m = {"validation": {"experiments": {"day2": {"nrmse": {"T": -0.4}}}}}
    >>> print(check_metrics(m)[0])
    validation fit of output 'T' on 'day2' is -40.0 %: the model predicts it worse than its mean
    """
    out: list[FitWarning] = []
    for part in ("train", "validation"):
        block = metrics.get(part)
        if not isinstance(block, Mapping):
            continue
        for eid, rep in (block.get("experiments") or {}).items():
            for name, v in (rep.get("nrmse") or {}).items():
                if isinstance(v, int | float) and math.isfinite(v) and v < 0:
                    out.append(
                        FitWarning(
                            "fit_below_zero",
                            f"{part} fit of output {name!r} on {eid!r} is {100 * v:.1f} %: the "
                            "model predicts it worse than its mean",
                        )
                    )
    return out


def _unit(units: Mapping[str, str], name: str) -> str:
    return str(units.get(name, "")).strip().lower().replace(" ", "")


def expected_signs(
    inputs: Sequence[str],
    outputs: Sequence[str],
    units: Mapping[str, str] | None = None,
    declared: Mapping[str, int] | None = None,
) -> dict[tuple[str, str], int]:
    """Signs the steady-state gains must have, from declared physics and units.

    Declared signs (``{"IN": +1}`` for every output, ``{"IN:OUT": -1}`` for
    one pair) win. Otherwise, for an output measured as a temperature: an
    input measured as a power (W, kW), or named like a heater (``heat`` in the
    name), raises it (+1); an input measured as a temperature raises it too
    (+1: a passive thermal network's gain from a boundary temperature lies in
    [0, 1]); an input named like a cooler (``cool``) lowers it (−1). Pairs
    with nothing declared or inferred are left out (not checked).

    Parameters
    ----------
    inputs, outputs : sequence of str
    units : mapping, optional
        Signal units (a recording's).
    declared : mapping, optional
        From :func:`parse_expect_sign`; the key ``"*"`` with value 0 turns the
        inference off.

    Returns
    -------
    dict
        ``{(output, input): +1 or -1}``.

    Examples
    --------
    >>> expected_signs(["P_heater", "T_out", "G"], ["T_in"],
    ...                {"P_heater": "W", "T_out": "°C", "T_in": "°C"})
    {('T_in', 'P_heater'): 1, ('T_in', 'T_out'): 1}
    """
    units = dict(units or {})
    declared = dict(declared or {})
    infer = declared.pop("*", 1) != 0
    out: dict[tuple[str, str], int] = {}
    for o in outputs:
        temp_out = _unit(units, o) in _TEMPERATURE_UNITS
        for i in inputs:
            sign = declared.get(f"{i}:{o}", declared.get(i))
            if sign is None and infer and temp_out:
                ui, low = _unit(units, i), i.lower()
                if "cool" in low:
                    sign = -1
                elif ui in _POWER_UNITS or "heat" in low or ui in _TEMPERATURE_UNITS:
                    sign = 1
            if sign:
                out[(o, i)] = int(sign)
    return out


def parse_expect_sign(text: str | Iterable[str] | None) -> dict[str, int]:
    """Parse ``--expect-sign``: ``IN=+``, ``IN:OUT=-``, comma separated, or ``none``.

    ``none`` turns the inference from units off (nothing is checked unless
    declared).

    Raises
    ------
    ConfigError
        An item not of the form ``NAME=+`` / ``NAME=-`` / ``NAME:OUT=+``.

    Examples
    --------
    >>> parse_expect_sign("P=+,valve:T=-")
    {'P': 1, 'valve:T': -1}
    """
    if text is None:
        return {}
    items = [text] if isinstance(text, str) else list(text)
    out: dict[str, int] = {}
    for chunk in items:
        for item in (p.strip() for p in chunk.split(",")):
            if not item:
                continue
            if item.lower() == "none":
                out["*"] = 0
                continue
            name, sep, sign = item.rpartition("=")
            parts = name.split(":")
            if (
                not sep
                or sign.strip() not in ("+", "-")
                or not (1 <= len(parts) <= 2)
                or not all(p.isidentifier() for p in parts)
            ):
                raise ConfigError(
                    f"--expect-sign {item!r} is not of the form INPUT=+, INPUT=- or "
                    "INPUT:OUTPUT=+ (or 'none')"
                )
            out[name] = 1 if sign.strip() == "+" else -1
    return out


def check_expect_names(
    expect: Mapping[str, int], inputs: Sequence[str], outputs: Sequence[str]
) -> None:
    """Refuse declared signs (:func:`parse_expect_sign`) that name no input or output.

    A misspelt name would otherwise check nothing, silently.

    Raises
    ------
    ConfigError
        An ``IN`` that is not an input, or an ``IN:OUT`` whose ``OUT`` is not an
        output.

    Examples
    --------
    >>> check_expect_names({"P": 1, "P:T": -1, "*": 0}, ["P"], ["T"])
    >>> check_expect_names({"Q": 1}, ["P"], ["T"])
    Traceback (most recent call last):
    ...
    thermogym.errors.ConfigError: --expect-sign Q: not an input (INPUT) or input and output ...
    """
    bad: list[str] = []
    for key in expect:
        if key == "*":
            continue
        i, _, o = key.partition(":")
        if i not in inputs or (o and o not in outputs):
            bad.append(key)
    if bad:
        raise ConfigError(
            f"--expect-sign {', '.join(bad)}: not an input (INPUT) or input and output "
            f"(INPUT:OUTPUT) of this fit, so nothing would be checked; inputs are "
            f"{list(inputs)}, outputs {list(outputs)}"
        )


def check_gain_signs(
    gains: Mapping[tuple[str, str], float],
    expected: Mapping[tuple[str, str], int],
    stderr: Mapping[tuple[str, str], float] | None = None,
) -> list[FitWarning]:
    """``gain_sign`` for each gain whose sign contradicts ``expected``.

    A gain within two standard errors of zero (when ``stderr`` gives one) is
    not determined and not reported.

    Examples
    --------
    >>> print(check_gain_signs({("T", "P"): -0.2}, {("T", "P"): 1})[0])
    gain of output 'T' per unit of input 'P' is -0.2; the declared physics says it must be positive
    """
    out: list[FitWarning] = []
    se = dict(stderr or {})
    for key, sign in expected.items():
        if key not in gains:
            continue
        g = float(gains[key])
        s = float(se.get(key, 0.0))
        if not math.isfinite(g) or g == 0 or np.sign(g) == sign:
            continue
        if math.isfinite(s) and abs(g) <= 2 * s:
            continue
        o, i = key
        out.append(
            FitWarning(
                "gain_sign",
                f"gain of output {o!r} per unit of input {i!r} is {g:.4g}; the declared physics "
                f"says it must be {'positive' if sign > 0 else 'negative'}",
            )
        )
    return out


#: FitResults whose steady-state gains :func:`check_fit` checks (the linear families).
_GAIN_MODELS = ("ss", "foptd", "sopdt", "arx", "armax", "oe", "bj")


def _linear_gains(fit: Any) -> tuple[dict[tuple[str, str], float], dict[tuple[str, str], float]]:
    """Steady-state gains (and FOPTD/SOPDT standard errors) of a linear FitResult."""
    model = fit.build_model()
    theta = fit.theta(model)
    exo, outs = list(model.exogenous_names), list(model.output_names)
    try:
        G = model.dcgain(theta)[0]
    except Exception:  # an integrating mode: no steady-state gain to check
        return {}, {}
    gains = {(o, i): float(G[j, k]) for j, o in enumerate(outs) for k, i in enumerate(exo)}
    se: dict[tuple[str, str], float] = {}
    if fit.model == "foptd":
        for o in outs:
            for i in exo:
                tag = o if len(exo) == 1 else f"{o}__{i}"
                se[(o, i)] = float(fit.stderr.get(f"K_{tag}", float("nan")))
    elif fit.model == "sopdt":
        for o in outs:
            for i in exo:
                se[(o, i)] = float(
                    fit.stderr.get(f"K_{o}__{i}", fit.stderr.get(f"K_{o}", math.nan))
                )
    return gains, se


def check_fit(
    fit: Any,
    *,
    units: Mapping[str, str] | None = None,
    expect: Mapping[str, int] | None = None,
) -> list[FitWarning]:
    """The generic checks of a FitResult: fits below zero, gain signs (linear families).

    Parameters
    ----------
    fit : FitResult
    units : mapping, optional
        Units of the recording's signals (the model's own are used too).
    expect : mapping, optional
        Declared signs (:func:`parse_expect_sign`).

    Returns
    -------
    list of FitWarning
    """
    out = check_metrics(fit.metrics)
    if fit.model in _GAIN_MODELS:
        model = fit.build_model()
        all_units = {s.name: s.unit for s in model.signals}
        all_units.update(dict(units or {}))
        exp = expected_signs(
            list(model.exogenous_names), list(model.output_names), all_units, expect
        )
        if exp:
            gains, se = _linear_gains(fit)
            out += check_gain_signs(gains, exp, se)
    return out


def check_cv_score(score: Any, what: str) -> list[FitWarning]:
    """``fit_below_zero`` when the cross-validated fit of the chosen ``what`` is below zero.

    Examples
    --------
    >>> [w.code for w in check_cv_score(-0.12, "order")], check_cv_score(0.8, "order")
    (['fit_below_zero'], [])
    """
    score = float(score) if isinstance(score, int | float | np.floating) else score
    if isinstance(score, float) and math.isfinite(score) and score < 0:
        return [
            FitWarning(
                "fit_below_zero",
                f"the cross-validated fit of the chosen {what} is {100 * score:.1f} %: on the "
                "part of the training data it was not fitted to it predicts worse than the "
                "mean; the data may be too short or the operating point wrong",
            )
        ]
    return []


def structure_warnings(
    fit: Any,
    *,
    orders: Sequence[int] | None = None,
    max_delay: int | None = None,
    record_s: float | None = None,
) -> list[FitWarning]:
    """Warnings about the structure a prediction-error fit chose by cross-validation.

    Reads what :func:`~thermogym.identification.pem.pem`,
    :func:`~thermogym.identification.pem.sopdt`,
    :func:`~thermogym.identification.ssest.ssest` and
    :func:`~thermogym.identification.ssest.identify_auto` store in
    ``fit.settings``: ``order_at_edge`` for an order or delay chosen at the
    end of its searched range, ``flat_cv`` for a flat order curve (the rule of
    :func:`check_order`), ``time_constant_bound`` for a SOPDT time constant
    longer than ten records, and ``fit_below_zero`` when the chosen
    structure's cross-validated fit is below zero. Orders and delays that
    were given rather than searched are not judged.

    Parameters
    ----------
    fit : FitResult
    orders : sequence of int, optional
        Orders the state-space search tried (``ssest``); default: the
        curve's length from 1.
    max_delay : int, optional
        Largest input delay searched [samples] (polynomial families); not
        judged without it.
    record_s : float, optional
        Duration of the longest training record [s], for the SOPDT time
        constants; not judged without it.

    Returns
    -------
    list of FitWarning
    """
    st = fit.settings
    out: list[FitWarning] = []
    auto = st.get("auto")
    if isinstance(auto, Mapping):
        chosen = auto.get("chosen")
        fam = (auto.get("families") or {}).get(chosen, {})
        out += check_cv_score(fam.get("cv_mnrmse"), f"model family ({chosen})")
    cv = st.get("cross_validation")
    if isinstance(cv, Mapping) and cv.get("order_scores"):
        scores = np.asarray(cv["order_scores"], dtype=float)
        chosen_n = int(cv.get("chosen_order", parsimonious_index(scores)))
        if not isinstance(auto, Mapping):
            out += check_cv_score(float(scores[chosen_n - 1]), "orders")
        out += check_order(
            range(1, scores.size + 1),
            scores,
            chosen_n,
            tolerance=float(cv.get("tolerance", DEFAULT_TOLERANCE)),
        )
        nk = np.asarray((st.get("orders") or {}).get("nk", []), dtype=float)
        if max_delay and "nk" in (st.get("chosen_by_cv") or []) and nk.size:
            if int(nk.max()) >= int(max_delay):
                out.append(
                    FitWarning(
                        "order_at_edge",
                        f"the chosen input delay {int(nk.max())} samples is the largest "
                        f"searched (0..{int(max_delay)}): the best may lie beyond; raise "
                        "--max-delay",
                    )
                )
    table = st.get("structure_cv")
    if isinstance(table, list) and st.get("structure_source") == "cross-validation":
        d, ft = st.get("input_delay"), st.get("feedthrough")
        row = next(
            (
                r
                for r in table
                if r.get("delay") == d and r.get("feedthrough") == ft and "VA_curve" in r
            ),
            None,
        )
        if row is not None:
            curve = np.asarray(row["VA_curve"], dtype=float)
            o = list(orders) if orders is not None else list(range(1, curve.size + 1))
            if len(o) == curve.size:
                if not isinstance(auto, Mapping):
                    out += check_cv_score(float(np.nanmax(curve)), "state-space structure")
                out += check_order(o, curve, int(st.get("order", o[0])))
        delays = sorted({int(r["delay"]) for r in table if "delay" in r})
        if len(delays) > 1 and d is not None and int(d) == delays[-1]:
            out.append(
                FitWarning(
                    "order_at_edge",
                    f"the chosen input delay {int(d)} samples is the largest searched "
                    f"(0..{delays[-1]}): the best may lie beyond; raise --max-delay",
                )
            )
    if st.get("evaluation_limit_reached"):
        out.append(
            FitWarning(
                "not_converged",
                "the prediction-error refinement stopped at its limit of "
                f"{st.get('nfev', '?')} function evaluations before converging: the model is "
                "the best point reached, not a minimum of the error (compare its fit with the "
                "N4SID start of `identify ssest --no-refine`)",
            )
        )
    if fit.model == "sopdt":
        bound = st.get("max_delay_s")
        for name, v in fit.parameters.items():
            if name.startswith("tau_") and bound and v >= 0.999 * float(bound):
                out.append(
                    FitWarning(
                        "order_at_edge",
                        f"the delay {name} = {v:.4g} s is at the largest searched "
                        f"({float(bound):.4g} s): the best may lie beyond; raise --max-delay-s",
                    )
                )
            if name.startswith(("T1_", "T2_")) and record_s and v >= 10.0 * record_s:
                out.append(
                    FitWarning(
                        "time_constant_bound",
                        f"the time constant {name} = {v:.4g} s is over ten record lengths "
                        f"({record_s:.4g} s): the record does not settle enough to tell the "
                        "gain from the time constant",
                    )
                )
    return out
