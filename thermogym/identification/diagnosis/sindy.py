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

import warnings

import numpy as np
from numpy.typing import NDArray

from thermogym.identification.diagnosis.context import Context
from thermogym.identification.diagnosis.hypothesis import Candidate
from thermogym.models.augmented import RESIDUAL_TERMS

__all__ = ["MAPS_TO", "equation", "propose_supports", "sparse_candidates"]

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
) -> list[tuple[list[str], str]]:
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
    list of (list of str, str)
        Term names of :data:`~.augmented.RESIDUAL_TERMS` and the dominant one.
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
    supports: list[tuple[list[str], str]] = []
    target = de / (np.std(de) or 1.0)
    for thr in (0.5, 0.2, 0.1, 0.05, 0.02):
        opt = ps.STLSQ(threshold=thr, alpha=1e-6, max_iter=50)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            opt.fit(Fn, target[:, None])
        coef = np.asarray(opt.coef_).reshape(-1)
        nz = np.flatnonzero(coef)
        sup = [names[k] for k in nz]
        if 0 < len(sup) <= max_terms and sup not in [s for s, _ in supports]:
            # Fn has unit-spread columns: |coefficient| is the term's typical contribution
            dominant = names[int(nz[np.argmax(np.abs(coef[nz]))])]
            supports.append((sup, dominant))
    supports.sort(key=lambda s: len(s[0]))
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


def sparse_candidates(ctx: Context, *, max_terms: int = 3) -> list[Candidate]:
    """The sparse supports as ``residual_ode`` candidates, each named by its dominant term.

    The dominant term is the one with the largest typical contribution
    ``|c_m| · rms(φ_m)`` in the sparse regression; :data:`MAPS_TO` reads it as
    an effect of the vocabulary.

    Returns
    -------
    list of Candidate
        Effect: the vocabulary effect the dominant term points to; form: the
        sparse regression's support.
    """
    j = int(np.argmax([ctx.share.get(o, 0.0) for o in ctx.outputs]))
    o = ctx.outputs[j]
    supports = propose_supports(ctx, j, max_terms=max_terms)
    out = []
    for sup, dominant in supports:
        spec = {
            "effect": "residual_ode",
            "signal": o,
            "terms": sup,
            "input": ctx.main_input,
            **({"reference": ctx.ambient} if ctx.ambient else {}),
        }
        maps = MAPS_TO.get(dominant, "missing_dynamics")
        out.append(
            Candidate(
                maps,
                f"sparse regression: d e/dt from {sup} (dominant {dominant!r}: "
                f"{RESIDUAL_TERMS[dominant]})",
                o,
                (spec,),
                evidence=f"sparse regression of d e_{o}/dt selects {sup}",
            )
        )
    return out
