"""Identifiability of the parameters a diagnosis reports: intervals, and what would pin them.

Every parameter a hypothesis adds (and every nominal parameter it
re-calibrates) gets a 95 % interval from the Jacobian of the weighted
residuals at the optimum, in the sandwich form with batch means over each
recording's output series
(:func:`thermogym.identification.uncertainty.covariance_from_jacobian`):
the residuals of thermal models are autocorrelated, and the white-noise
formula would be far too optimistic.

A parameter is *not identifiable from these data* when its direction in
parameter space is numerically absent (the Gauss-Newton matrix is singular
along it: its standard error is NaN) or when its interval is wider than its
whole admissible range. The report then names the experiment that would
identify it (:meth:`~.effects.Effect.experiment`): for a conductance that grows
with an input seen at one level only, "a second level of the input".
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from thermogym.identification.diagnosis.experiments import Experiment
from thermogym.identification.diagnosis.fit import FitProblem
from thermogym.identification.diagnosis.hypothesis import Hypothesis
from thermogym.identification.uncertainty import covariance_from_jacobian

__all__ = ["intervals"]

_Z95 = 1.959963984540054


def intervals(
    h: Hypothesis,
    names: Sequence[str],
    exps: Sequence[Experiment],
    weights: np.ndarray,
    x0: str,
    *,
    experiment: dict[str, str] | None = None,
) -> dict[str, dict[str, Any]]:
    """95 % intervals of ``names`` (shared free parameters of ``h``) on ``exps``.

    Parameters
    ----------
    h : Hypothesis
        Fitted.
    names : sequence of str
        Parameters to report (those not free in ``h`` are skipped).
    exps : sequence of Experiment
        The recordings the intervals are for (the training recordings).
    weights : ndarray
    x0 : str
    experiment : dict, optional
        Per parameter, the experiment that would identify it.

    Returns
    -------
    dict
        ``{name: {"low", "high", "stderr", "identifiable", "note"}}``.
    """
    assert h.model is not None and h.theta is not None
    free = [p for p in h.free if p in h.bounds]
    if not free or not exps:
        return {}
    lo = np.array([h.bounds[p][0] for p in free])
    hi = np.array([h.bounds[p][1] for p in free])
    local_vals = h.local_train if len(h.local_train) == len(exps) else None
    pb = FitProblem(
        h.model, tuple(free), h.theta, lo, hi, exps, weights, x0, local_values=local_vals
    )
    z = pb.start()
    if local_vals:
        names_l = [p for p in free if p in h.local]
        for i, vals in enumerate(local_vals):
            base = pb.n_global + i * pb.n_local
            for jl, p in enumerate(names_l):
                if p in vals:
                    z[base + jl] = vals[p]
    r = pb.residuals(z[None])[0]
    span = np.where(pb.z_upper > pb.z_lower, pb.z_upper - pb.z_lower, 1.0)
    step = np.where(z + 1e-6 * span <= pb.z_upper, 1e-6 * span, -1e-6 * span)
    J = pb.jacobian(z, r, step)
    # series of every residual (recording × output) for the batch-means meat
    series, tix = [], []
    sid = 0
    for e in exps:
        ny = len(e.outputs)
        k = np.repeat(np.arange(e.n), ny)
        j = np.tile(np.arange(ny), e.n)
        series.append(sid + j)
        tix.append(k)
        sid += ny
    valid = np.any(J != 0.0, axis=1) | (r != 0.0)
    try:
        _, se, *_ = covariance_from_jacobian(
            J,
            r,
            valid=valid,
            series=np.concatenate(series),
            time_index=np.concatenate(tix),
            block="auto",
        )
    except Exception:  # too few residuals, a degenerate Jacobian: nothing can be said
        se = np.full(J.shape[1], np.nan)
    names_g = [p for p in free if p not in h.local]
    out: dict[str, dict[str, Any]] = {}
    for p in names:
        if p not in names_g:
            continue
        i = names_g.index(p)
        v = float(h.theta[h.model.param_index(p)])
        s = float(se[i])
        a, b = h.bounds[p]
        width = 2 * _Z95 * s
        ident = math.isfinite(s) and width <= (b - a)
        row: dict[str, Any] = {
            "low": v - _Z95 * s if math.isfinite(s) else math.nan,
            "high": v + _Z95 * s if math.isfinite(s) else math.nan,
            "stderr": s,
            "identifiable": bool(ident),
        }
        if not ident:
            exp = (experiment or {}).get(p, "a richer excitation of the inputs")
            row["note"] = f"not identifiable from these data; would be identified by {exp}"
        out[p] = row
    return out
