"""Orders and delays of a polynomial family by k-fold cross-validation.

Delays per input first (by ARX, as MATLAB's ``delayest``), then the order of
the family with its polynomials tied, each candidate scored by its simulation
fit on the other folds (:func:`select_orders`).
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from thermogym._checks import integer
from thermogym.errors import ConfigError, IdentificationError
from thermogym.identification._pem_fit import _fit_family, _orders_arg, _sub_problem
from thermogym.identification._pem_solver import simulation_fit
from thermogym.identification.n4sid import N4SIDProblem

__all__ = ["select_orders"]


def _fold_problems(prob: N4SIDProblem, k: int) -> list[tuple[list, list]]:  # type: ignore[type-arg]
    """``k`` folds of deviation data: experiments round robin, or one cut in parts."""
    k = integer("folds", k, lo=2, error=ConfigError)
    if len(prob.us) >= k:
        return [(prob.us[f::k], prob.ys[f::k]) for f in range(k)]
    if len(prob.us) == 1:
        T = prob.us[0].shape[0]
        edges = np.linspace(0, T, k + 1).round().astype(int)
        return [([prob.us[0][a:b]], [prob.ys[0][a:b]]) for a, b in itertools.pairwise(edges)]
    raise ConfigError(
        f"{k} folds from {len(prob.us)} recordings: give 1 or at least {k} recordings"
    )


def _cv_score(fold_data, fit_fn, dt) -> tuple[float, NDArray[np.float64]]:  # type: ignore[no-untyped-def]
    """Mean over ordered fold pairs (i ≠ j) of the simulation fit of model i on fold j."""
    k = len(fold_data)
    scores, per = [], []
    for i in range(k):
        try:
            model, theta = fit_fn(*fold_data[i])
        except (IdentificationError, np.linalg.LinAlgError, ValueError):
            return -np.inf, np.array([-np.inf])
        for j in range(k):
            if j == i:
                continue
            s, pj = simulation_fit(model, theta, fold_data[j][0], fold_data[j][1], dt)
            scores.append(s)
            per.append(pj)
    return float(np.mean(scores)), np.mean(np.stack(per), axis=0)


def select_orders(
    prob: N4SIDProblem,
    family: str,
    given: dict[str, Any] | None = None,
    *,
    max_order: int = 6,
    max_delay: int = 10,
    folds: int = 2,
    tolerance: float = 1e-3,
    focus: str = "simulation",
    max_nfev: int = 60,
) -> dict[str, Any]:
    """Orders and delays of a polynomial family by k-fold cross-validation.

    1. Delays ``nk`` per input (when not given): ARX models of order
       ``min(2, max_order)`` on each fold, every input's delay scanned over
       ``0..max_delay`` in turn (two passes), scored by the simulation fit on
       the other folds. For ARX itself (cheap) the delays are searched so at
       every order ``n`` and the order chosen over each order's best delays.
    2. Order ``n = 1..max_order`` of the family with the polynomials tied
       (ARX ``na = nb = n``; ARMAX also ``nc = n``; OE ``nb = nf = n``; BJ
       ``nb = nf = n``, ``nc = nd = min(n, 2)``), scored the same way; the
       smallest ``n`` within ``tolerance`` of the best is kept (the rule of
       :class:`~thermogym.identification.crossval.OrderCV`).

    Returns
    -------
    dict
        ``orders`` (na, nb, nc, nd, nf, nk as lists), ``delay_scores``,
        ``order_scores`` (VA per order), ``best_order``, ``chosen_order``.
    """
    given = dict(given or {})
    fd = _fold_problems(prob, folds)
    p, m = len(prob.outputs), len(prob.inputs) + len(prob.disturbances)
    out: dict[str, Any] = {"folds": len(fd), "tolerance": tolerance}

    def arx_fit(n: int, nk: NDArray[np.int64]) -> Callable[..., Any]:
        def fit(us, ys):  # type: ignore[no-untyped-def]
            sub = _sub_problem(prob, us, ys)
            mdl, th, _, _ = _fit_family(
                "arx",
                sub,
                na=n,
                nb=n,
                nc=0,
                nd=0,
                nf=0,
                nk=nk,
                focus="prediction",
                max_nfev=max_nfev,
            )
            return mdl, th

        return fit

    def delay_search(n0: int) -> tuple[NDArray[np.int64], float, dict[str, list[float]]]:
        # each input's delay over 0..max_delay in turn, the others fixed (two passes)
        nk = np.ones((p, m), dtype=np.int64)
        scores: dict[str, list[float]] = {}
        best = _cv_score(fd, arx_fit(n0, nk), prob.dt)[0]
        for _ in range(2):
            changed = False
            for i in range(m):
                row = []
                for d in range(0, max_delay + 1):
                    trial = nk.copy()
                    trial[:, i] = d
                    row.append(_cv_score(fd, arx_fit(n0, trial), prob.dt)[0])
                scores[f"input {i}"] = row
                d_best = int(np.argmax(row))
                if row[d_best] > best + 1e-9 and d_best != nk[0, i]:
                    nk[:, i] = d_best
                    best = row[d_best]
                    changed = True
            if not changed:
                break
        return nk, best, scores

    if given.get("nk") is not None:
        nk = _orders_arg("nk", given["nk"], (p, m), 0)
    elif family == "arx" and given.get("na") is None and given.get("nb") is None:
        # ARX is cheap: the delays searched anew at every order, the order by the
        # parsimonious rule over each order's best delays
        per = [delay_search(n) for n in range(1, max_order + 1)]
        va_a = np.array([q[1] for q in per])
        safe = np.where(np.isfinite(va_a), va_a, -np.inf)
        if not np.isfinite(safe).any():
            raise IdentificationError(
                f"cross-validation of ARX orders 1..{max_order}: no candidate could be fitted "
                "and simulated on the other fold"
            )
        chosen = int(np.argmax(safe >= safe.max() - tolerance)) + 1
        nk = per[chosen - 1][0]
        out.update(
            {
                "orders": {
                    "nk": nk.tolist(),
                    "na": chosen,
                    "nb": chosen,
                    "nc": 0,
                    "nd": 0,
                    "nf": 0,
                },
                "order_scores": va_a.tolist(),
                "best_order": int(np.argmax(safe)) + 1,
                "chosen_order": chosen,
                "delays_per_order": [q[0].tolist() for q in per],
            }
        )
        return out
    else:
        nk, _, scores = delay_search(min(2, max_order))
        out["delay_scores"] = scores
    out_orders: dict[str, Any] = {"nk": nk.tolist()}

    def tied(n: int) -> dict[str, Any]:
        o = {"na": 0, "nb": n, "nc": 0, "nd": 0, "nf": 0}
        if family in ("arx", "armax"):
            o["na"] = n
        if family == "armax":
            o["nc"] = n
        if family in ("oe", "bj"):
            o["nf"] = n
        if family == "bj":
            o["nc"] = o["nd"] = min(n, 2)
        return {k: (given[k] if given.get(k) is not None else v) for k, v in o.items()}

    va = []
    for n in range(1, max_order + 1):
        o = tied(n)

        def fit(us, ys, o=o):  # type: ignore[no-untyped-def]
            sub = _sub_problem(prob, us, ys)
            mdl, th, _, _ = _fit_family(family, sub, **o, nk=nk, focus=focus, max_nfev=max_nfev)
            return mdl, th

        va.append(_cv_score(fd, fit, prob.dt)[0])
    va_a = np.array(va)
    safe = np.where(np.isfinite(va_a), va_a, -np.inf)
    if not np.isfinite(safe).any():
        raise IdentificationError(
            f"cross-validation of {family.upper()} orders 1..{max_order}: no candidate could be "
            "fitted and simulated on the other fold"
        )
    best_n = int(np.argmax(safe)) + 1
    chosen = int(np.argmax(safe >= safe.max() - tolerance)) + 1
    out_orders.update(tied(chosen))
    out.update(
        {
            "orders": out_orders,
            "order_scores": va_a.tolist(),
            "best_order": best_n,
            "chosen_order": chosen,
        }
    )
    return out
