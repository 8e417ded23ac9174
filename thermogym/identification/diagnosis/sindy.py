"""Sparse-regression fallback: discover the residual's dynamics as an equation.

When no catalogued effect explains a mismatch, the residual ``e = y − ŷ`` of
the output carrying most of the error is modelled as a dynamic system driven
by physically meaningful terms (SINDy, Brunton, Proctor & Kutz 2016, with
``pysindy``)::

    de/dt = Σ_m c_m φ_m(e, Δ, u, t)

with the library :data:`~.augmented.RESIDUAL_TERMS`: a constant (heat leak),
``e`` (relaxation), the temperature rise ``Δ = ŷ − r`` above the ambient (or
the start), ``Δ|Δ|`` (radiation-like growth), ``Δ|Δ|^(1/3)`` (natural
convection), the input ``u``, ``u²``, ``u·Δ`` (forced convection) and the
time ``t`` in hours. Sequentially thresholded least squares (STLSQ) on
smoothed data proposes sparse supports at a few thresholds; each support is
then fitted as a ``residual_ode`` augmentation of the model by simulation
(so noise in the derivative does not bias the coefficients) and judged on the
held-out recordings like every other hypothesis. The result is reported as an
equation, and mapped to a vocabulary effect when its dominant term has a clear
physical reading.
"""

from __future__ import annotations

import math
import warnings
from typing import Any

import numpy as np
from numpy.typing import NDArray

from thermogym.identification.diagnosis.effects import CATALOGUE, Candidate, Context
from thermogym.models.augmented import RESIDUAL_TERMS, _term_tag

__all__ = ["MAPS_TO", "propose_supports", "sparse_hypothesis"]

#: Vocabulary effect a dominant residual term points to.
MAPS_TO: dict[str, str] = {
    "dT|dT|": "nonlinear_heat_transfer",
    "dT^4/3": "nonlinear_heat_transfer",
    "u*dT": "input_dependent_heat_transfer",
    "u^2": "input_nonlinearity",
    "t": "time_varying_parameter",
    "1": "unmeasured_disturbance",
    "u": "missing_dynamics",
    "dT": "missing_dynamics",
    "e": "missing_dynamics",
}


def _smooth(x: NDArray[np.float64], w: int) -> NDArray[np.float64]:
    if w <= 1:
        return x
    k = np.ones(w) / w
    pad = np.pad(x, (w // 2, w - 1 - w // 2), mode="edge")
    return np.convolve(pad, k, mode="valid")


def _features(
    terms: list[str],
    e: NDArray[np.float64],
    y: NDArray[np.float64],
    u: NDArray[np.float64],
    ref: NDArray[np.float64],
    t_h: NDArray[np.float64],
) -> NDArray[np.float64]:
    d = y - ref
    cols = {
        "1": np.ones_like(y),
        "e": e,
        "dT": d,
        "dT|dT|": d * np.abs(d) / 10.0,
        "dT^4/3": d * np.abs(d) ** (1.0 / 3.0),
        "u": u,
        "u^2": u * u,
        "u*dT": u * d,
        "t": t_h,
    }
    return np.column_stack([cols[t] for t in terms])


def propose_supports(
    ctx: Context, j: int, *, max_terms: int = 3, n_support: int = 3
) -> list[list[str]]:
    """Sparse supports of ``de/dt`` for output ``j`` from STLSQ at several thresholds.

    Parameters
    ----------
    ctx : Context
    j : int
        Output index.
    max_terms : int
        Largest support kept.
    n_support : int
        Most supports returned (the sparsest first).

    Returns
    -------
    list of list of str
        Term names of :data:`~.augmented.RESIDUAL_TERMS`.
    """
    import pysindy as ps

    terms = list(RESIDUAL_TERMS)
    main = ctx.main_input
    iu = list(ctx.exogenous).index(main)
    amb = ctx.ambient
    ia = list(ctx.exogenous).index(amb) if amb else None
    X, dX = [], []
    for i, (t, dt, u, y, s) in enumerate(zip(ctx.time, ctx.dt, ctx.u, ctx.y, ctx.sim, strict=True)):
        if not ctx.is_train[i] or t.size < 8:
            continue
        w = max(1, min(t.size // 8, 5))
        e = _smooth(np.nan_to_num(y[:, j] - s[:, j]), w)
        ref = u[:, ia] if ia is not None else np.full(t.size, s[0, j])
        F = _features(terms, e, s[:, j], u[:, iu], ref, (t - t[0]) / 3600.0)
        de = np.gradient(e, dt)
        X.append(F)
        dX.append(de)
    if not X:
        return []
    F = np.concatenate(X)
    de = np.concatenate(dX)
    scale = np.std(F, axis=0)
    scale[scale == 0] = 1.0
    keep = np.std(F, axis=0) > 0
    keep[terms.index("1")] = True
    Fn = F[:, keep] / scale[keep]
    names = [t for t, k in zip(terms, keep, strict=True) if k]
    supports: list[list[str]] = []
    target = de / (np.std(de) or 1.0)
    for thr in (0.5, 0.2, 0.1, 0.05, 0.02):
        opt = ps.STLSQ(threshold=thr, alpha=1e-6, max_iter=50)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            opt.fit(Fn, target[:, None])
        coef = np.asarray(opt.coef_).reshape(-1)
        sup = [names[k] for k in np.flatnonzero(coef)]
        if 0 < len(sup) <= max_terms and sup not in supports:
            supports.append(sup)
    supports.sort(key=len)
    return supports[:n_support]


def equation(terms: list[str], coef: dict[str, float], signal: str) -> str:
    """``de/dt = c₁·φ₁ + ...`` as text."""
    names = {
        "1": "1",
        "e": "e",
        "dT": "Δ",
        "dT|dT|": "Δ|Δ|/10",
        "dT^4/3": "Δ|Δ|^(1/3)",
        "u": "u",
        "u^2": "u²",
        "u*dT": "u·Δ",
        "t": "t[h]",
    }
    parts = [f"{coef[t]:+.4g}·{names[t]}" for t in terms]
    return f"d e_{signal}/dt = " + " ".join(parts) + "  [per s]"


def sparse_hypothesis(
    ctx: Context,
    tr: list[Any],
    va: list[Any],
    weights: NDArray[np.float64],
    x0: str,
    bounds_nom: dict[str, tuple[float, float]],
    scheme: str,
    max_nfev: int,
    say: Any,
) -> dict[str, Any] | None:
    """Fit the sparse supports as ``residual_ode`` hypotheses; return the best one.

    Returns
    -------
    dict or None
        A hypothesis (as the catalogue's) with ``effect = "sparse_regression"``,
        the ``equation`` and ``maps_to``; None when no support was found.
    """
    from thermogym.identification.diagnosis.run import _explain, _wsse

    j = int(np.argmax([ctx.share.get(o, 0.0) for o in ctx.outputs]))
    o = ctx.outputs[j]
    try:
        supports = propose_supports(ctx, j)
    except Exception as e:  # pragma: no cover - pysindy failure is reported, not fatal
        say(f"sparse regression failed: {type(e).__name__}: {e}")
        return None
    if not supports:
        return None
    from thermogym.identification.diagnosis.effects import _wrap

    cands = []
    for sup in supports:
        spec = {
            "effect": "residual_ode",
            "signal": o,
            "terms": sup,
            "input": ctx.main_input,
            **({"reference": ctx.ambient} if ctx.ambient else {}),
        }
        name, cfg = _wrap(ctx, [spec])
        extra = {f"c_{_term_tag(t)}_{o}": (0.0, -1e3, 1e3) for t in sup}
        cands.append(
            Candidate(
                "missing_dynamics",  # placeholder effect for the catalogue lookups in _explain
                o,
                name,
                cfg,
                extra,
                [],
                f"sparse regression of d e_{o}/dt selects {sup}",
                0.0,
            )
        )
    hyps = _explain(
        ctx, cands, tr, va, weights, x0, bounds_nom, scheme, max_nfev, None, ctx.sigma, say
    )
    hyps = [h for h in hyps if "error" not in h]
    if not hyps:
        return None
    best = min(hyps, key=lambda h: _wsse([e.y for e in va], h["_sims_va"], weights)[0])
    sup = best["_candidate"].model_config["augmentations"][-1]["terms"]
    coef = {t: best["params"][f"c_{_term_tag(t)}_{o}"]["value"] for t in sup}
    # the dominant term: the largest typical contribution on the training data
    contrib = {}
    for t in sup:
        vals = []
        for i in range(len(ctx.time)):
            if not ctx.is_train[i]:
                continue
            s, u = ctx.sim[i][:, j], ctx.u[i][:, list(ctx.exogenous).index(ctx.main_input)]
            ref = (
                ctx.u[i][:, list(ctx.exogenous).index(ctx.ambient)]
                if ctx.ambient
                else np.full(s.size, s[0])
            )
            e = ctx.y[i][:, j] - s
            vals.append(
                _features([t], np.nan_to_num(e), s, u, ref, (ctx.time[i] - ctx.time[i][0]) / 3600)[
                    :, 0
                ]
            )
        contrib[t] = abs(coef[t]) * float(np.sqrt(np.mean(np.concatenate(vals) ** 2)))
    dominant = max(contrib, key=contrib.get)
    maps = MAPS_TO.get(dominant, "missing_dynamics")
    best["effect"] = "sparse_regression"
    best["equation"] = equation(sup, coef, o)
    best["maps_to"] = maps
    best["explanation"] = (
        f"No catalogued effect explains the residual; sparse regression finds "
        f"{best['equation']} (dominant term '{dominant}': {RESIDUAL_TERMS[dominant]}), which "
        f"reads as {maps}: {CATALOGUE[maps].explanation}"
    )
    best["augmentation"] = "residual ODE added to the output (sparse regression)"
    if not math.isfinite(best["_wsse_val"]):
        return None
    return best
