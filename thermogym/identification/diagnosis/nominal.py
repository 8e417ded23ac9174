"""The nominal model: its resolution, its calibration and the plain ARX baseline beside it.

* :func:`resolve_model` turns a registered name, ``foptd``, ``ss:ORDER`` or a
  user's own :class:`~thermogym.models.base.Model` into a model and the
  :class:`~.hypothesis.NominalSpec` every hypothesis is built from. Generic
  linear models work about an operating point (the training data's mean
  inputs: their ``u_op``) with an output offset per output, so a log that
  starts mid-operation needs no rest assumption; their initial state is
  estimated like any model's.
* :func:`calibration_set` ranks the parameters by their identifiability on the
  training data (the sensitivity ranking and collinearity index of
  :func:`thermogym.identification.uncertainty.identifiability`, Brun et al.
  2001) and returns those the data can determine: only they are
  re-calibrated, the others keep their given values.
* :func:`calibrate` fits them from the given values and from points drawn
  inside their bounds (multi-start).
* :func:`arx_baseline` fits a plain second-order ARX (least squares, one
  intercept) on the same training data and simulates it on the held-out
  recordings: a nominal model worse than that is *inadequate*.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any, cast

import numpy as np
from numpy.typing import NDArray

from thermogym.errors import ConfigError
from thermogym.identification.diagnosis.experiments import Experiment
from thermogym.identification.diagnosis.fit import (
    FitOutcome,
    FitProblem,
    fit_model,
)
from thermogym.identification.diagnosis.hypothesis import NominalSpec
from thermogym.identification.n4sid import n4sid
from thermogym.identification.uncertainty import identifiability
from thermogym.models.augmented import AugmentedModel
from thermogym.models.base import Model
from thermogym.models.linear import FOPTDModel, StateSpaceModel
from thermogym.models.registry import get_model
from thermogym.recording import Recording

__all__ = [
    "arx_baseline",
    "calibrate",
    "calibration_set",
    "generic_bounds",
    "resolve_model",
]

#: Largest collinearity index of the re-calibrated subset (Brun et al. 2001: 10-15).
MAX_COLLINEARITY = 10.0
#: Least importance, relative to the most important parameter, of a re-calibrated one.
MIN_IMPORTANCE = 0.02


def resolve_model(
    model: str | Model,
    recording: Recording | None = None,
    *,
    model_config: Mapping[str, Any] | None = None,
    inputs: Sequence[str] | None = None,
    outputs: Sequence[str] | None = None,
    u_op: Sequence[float] | None = None,
) -> tuple[Model, NominalSpec]:
    """Build the nominal model from a name, a ``foptd`` / ``ss:ORDER`` spec or an instance.

    Parameters
    ----------
    model : str or Model
        A registered model (``axt211``, ``strut``, ...), ``foptd``,
        ``ss:ORDER``, or a model instance.
    recording : Recording, optional
        Gives units and roles of the columns of a generic model.
    model_config : mapping, optional
        Constructor arguments of a registered model.
    inputs, outputs : sequence of str
        Columns of a generic model: exogenous columns (those with role
        ``disturbance`` in the recording become disturbances) and outputs.
    u_op : sequence of float, optional
        Operating-point inputs of a generic model (exogenous order).

    Returns
    -------
    model : Model
    spec : NominalSpec

    Raises
    ------
    ConfigError
        A generic model without ``inputs`` / ``outputs``, a bad order.
    UnknownNameError
        An unknown model name.
    """
    if isinstance(model, Model):
        return model, NominalSpec(model, {}, [], model.name)
    if not isinstance(model, str):
        raise ConfigError(f"model is a {type(model).__name__}; expected a name or a Model")
    name, _, order = model.partition(":")
    if name in ("foptd", "ss"):
        if not inputs or not outputs:
            raise ConfigError(
                f"model {model!r} is generic: name the recording's input columns and output "
                "columns (inputs=..., outputs=...; --inputs COL,... --outputs COL,...)"
            )
        rec = recording
        roles = dict(rec.roles) if rec is not None else {}
        units = {c: rec.units.get(c, "1") for c in [*inputs, *outputs]} if rec is not None else {}
        dis = [c for c in inputs if roles.get(c) == "disturbance"]
        ins = [c for c in inputs if c not in dis] or list(inputs[:1])
        dis = [c for c in dis if c not in ins]
        cfg: dict[str, Any] = {
            "inputs": ins,
            "outputs": list(outputs),
            "disturbances": dis,
            "units": units,
        }
        if u_op is not None:
            cfg["u_op"] = [float(v) for v in u_op]
        if name == "foptd":
            cfg.update(offsets=True, steady_start=True)
            spec = NominalSpec("foptd", cfg, [], "foptd")
            return spec.build(), spec
        try:
            n = int(order or 1)
        except ValueError:
            raise ConfigError(
                f"model {model!r}: the order after 'ss:' must be an integer"
            ) from None
        if n < 1:
            raise ConfigError(f"model {model!r}: order {n} must be >= 1")
        cfg.update(n_states=n, steady_start=False)
        offsets = [
            {"effect": "sensor_offset", "signal": o, "bounds": {"offset": [-1e6, 1e6]}}
            for o in outputs
        ]
        spec = NominalSpec("ss", cfg, offsets, f"ss:{n}")
        return spec.build(), spec
    cfg = dict(model_config or {})
    m = get_model(name, **cfg)
    return m, NominalSpec(name, m.config(), [], name)


def generic_bounds(
    model: Model, free: Sequence[str], theta: NDArray[np.float64], train: Sequence[Experiment]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Finite, data-scaled bounds for the parameters of a generic linear model."""
    dur = max(e.n * e.dt for e in train)
    dt = min(e.dt for e in train)
    y = np.concatenate([e.y for e in train])
    spread = float(np.nanmax(np.nanstd(y, axis=0))) or 1.0
    lo = np.empty(len(free))
    hi = np.empty(len(free))
    for i, p in enumerate(free):
        v = float(theta[model.param_index(p)])
        spec = model.parameters[model.param_index(p)]
        lo[i], hi[i] = spec.lower, spec.upper
        if p.startswith("T_"):
            lo[i], hi[i] = max(dt / 10, 1e-3), 20 * dur
        elif p.startswith("tau_"):
            lo[i], hi[i] = 0.0, 0.5 * dur
        elif p.startswith(("y0_", "offset_")):
            w = 1e3 + 10 * abs(v) + 20 * spread
            lo[i], hi[i] = v - w, v + w
        elif p.startswith(("K_", "B_", "C_", "D_")):
            w = 100 * abs(v) + 10.0
            lo[i], hi[i] = v - w, v + w
        elif p.startswith("A_"):
            r, c = p.split("_")[1:3]
            lo[i], hi[i] = (-0.5, 0.99999) if r == c else (-1.0, 1.0)
        if not (np.isfinite(lo[i]) and np.isfinite(hi[i])):
            w = 10 * abs(v) + 1.0
            lo[i], hi[i] = v - w, v + w
    return lo, hi


def generic_start(model: Model, train: Sequence[Experiment]) -> NDArray[np.float64]:
    """Data-based start values of a generic linear model (step-response estimates, N4SID)."""
    th = model.nominal.copy()
    base = model.base if isinstance(model, AugmentedModel) else model
    outs = train[0].outputs
    y = np.concatenate([e.y for e in train])
    u = np.concatenate([e.u for e in train])
    dur = sum(e.n * e.dt for e in train) / len(train)
    for j, o in enumerate(outs):
        level = float(np.nanmean(y[:, j]))
        for p in (f"y0_{o}", f"offset_{o}"):
            if p in model.param_names:
                th[model.param_index(p)] = level
    if isinstance(base, FOPTDModel):
        # one-shot least squares of the steady relation y ≈ y0 + Σ K_i (u_i − u_op,i)
        uop = base.u_op
        X = np.column_stack([np.ones(u.shape[0]), u - uop[None, :]])
        for j, o in enumerate(outs):
            ok = np.isfinite(y[:, j])
            coef, *_ = np.linalg.lstsq(X[ok], y[ok, j], rcond=None)
            th[model.param_index(f"y0_{o}")] = coef[0]
            for i, c in enumerate(base.exogenous_names):
                tag = o if len(base.exogenous_names) == 1 else f"{o}__{c}"
                if f"K_{tag}" in model.param_names:
                    th[model.param_index(f"K_{tag}")] = coef[1 + i]
                    th[model.param_index(f"T_{tag}")] = max(dur / 10.0, train[0].dt)
        return th
    if isinstance(base, StateSpaceModel):
        mats = _n4sid_start(base, train)
        if mats is not None:
            for name, M in zip("ABC", mats, strict=True):
                for r in range(M.shape[0]):
                    for col in range(M.shape[1]):
                        th[model.param_index(f"{name}_{r}_{col}")] = M[r, col]
        else:
            n = base.n_states
            taus = np.geomspace(max(5 * train[0].dt, dur / 200), dur / 3, n)
            for i in range(n):
                th[model.param_index(f"A_{i}_{i}")] = math.exp(-train[0].dt / taus[i])
                th[model.param_index(f"B_{i}_0")] = 1.0 - math.exp(-train[0].dt / taus[i])
                for j in range(len(outs)):
                    th[model.param_index(f"C_{j}_{i}")] = 0.1
    return th


def _n4sid_start(base: Any, train: Sequence[Experiment]) -> tuple[Any, Any, Any] | None:
    """N4SID matrices (paper 001) at the data's period, about the training operating point."""
    try:
        usable = [e.recording for e in train if np.all(np.ptp(e.u, axis=0) > 0)]
        if not usable:
            return None
        res = n4sid(
            usable,
            list(base.exogenous_names),
            list(base.output_names),
            order=base.n_states,
            disturbances=[s.name for s in base.disturbances],
            noise_model=False,
            operating_point_mode="mean",
        )
        mats = res.system
        A, B, C = np.asarray(mats.A), np.asarray(mats.B), np.asarray(mats.C)
    except Exception:  # no N4SID for these data: a modal start
        return None
    if A.shape != (base.n_states, base.n_states) or not np.isfinite(A).all():
        return None
    if np.max(np.abs(np.linalg.eigvals(A))) >= 1.0:
        return None
    return A, B, C


def calibration_set(
    model: Model,
    theta: NDArray[np.float64],
    candidates: Sequence[str],
    lower: NDArray[np.float64],
    upper: NDArray[np.float64],
    train: Sequence[Experiment],
    weights: NDArray[np.float64],
    x0: str,
) -> tuple[list[str], dict[str, Any]]:
    """The parameters the training data identify, by sensitivity and collinearity.

    Returns
    -------
    selected : list of str
        In ranking order.
    table : dict
        :meth:`~thermogym.identification.uncertainty.Identifiability.to_dict`.
    """
    if not candidates:
        return [], {}
    pb = FitProblem(model, tuple(candidates), theta, lower, upper, train, weights, x0)
    z = pb.start()
    r0 = pb.residuals(z[None])[0]
    span = np.where(upper > lower, upper - lower, 1.0)
    h = np.where(z + 1e-4 * span <= upper, 1e-4 * span, -1e-4 * span)
    J = pb.jacobian(z, r0, h)
    # J is 2-D (N, n_free), so the reduction over axis 0 is an array, not a scalar
    keep = cast(NDArray[np.bool_], np.isfinite(J).all(axis=0))
    J = np.where(np.isfinite(J), J, 0.0)
    idf = identifiability(
        J,
        tuple(candidates),
        span,
        max_collinearity=MAX_COLLINEARITY,
        min_importance=MIN_IMPORTANCE,
    )
    sel = [p for p in idf.selected if keep[list(candidates).index(p)]]
    return sel, idf.to_dict()


def calibrate(
    model: Model,
    theta: NDArray[np.float64],
    free: Sequence[str],
    lower: NDArray[np.float64],
    upper: NDArray[np.float64],
    train: Sequence[Experiment],
    weights: NDArray[np.float64],
    x0: str,
    *,
    n_random: int = 6,
    max_nfev: int = 60,
    deadline: float | None = None,
) -> FitOutcome:
    """Least squares of ``free`` from the given values and from points drawn in the bounds."""
    pb = FitProblem(model, tuple(free), theta, lower, upper, train, weights, x0)
    return fit_model(
        pb, n_random=n_random, n_refine=2, max_nfev=max_nfev, deadline=deadline, seed=0
    )


def _arx_rows(y: NDArray, u: NDArray, na: int, nb: int) -> tuple[NDArray, NDArray]:
    L = max(na, nb)
    T = y.shape[0]
    cols = [y[L - k : T - k] for k in range(1, na + 1)]
    for i in range(u.shape[1]):
        cols += [u[L - k : T - k, i] for k in range(1, nb + 1)]
    cols.append(np.ones(T - L))
    return np.column_stack(cols), y[L:]


def arx_baseline(
    train: Sequence[Experiment], val: Sequence[Experiment], na: int = 2, nb: int = 2
) -> dict[str, Any]:
    """A plain ARX(na, nb) per output, fitted on ``train``, simulated on ``val``.

    ``y[k] = Σ_i a_i y[k−i] + Σ_m Σ_i b_mi u_m[k−i] + c`` by least squares;
    on a held-out recording it starts from the first ``max(na, nb)`` measured
    samples and then runs on its own outputs (simulation, not prediction).

    Returns
    -------
    dict
        ``sims`` (T, n_y) per held-out recording, ``n_params``, ``orders``.
    """
    n_y = train[0].y.shape[1]
    L = max(na, nb)
    sims = [np.full_like(e.y, np.nan) for e in val]
    n_params = 0
    for j in range(n_y):
        X, Y = [], []
        for e in train:
            x, yy = _arx_rows(e.y[:, j], e.u, na, nb)
            ok = np.isfinite(yy) & np.isfinite(x).all(axis=1)
            X.append(x[ok])
            Y.append(yy[ok])
        Xa, Ya = np.concatenate(X), np.concatenate(Y)
        if Ya.size <= Xa.shape[1]:
            continue
        coef, *_ = np.linalg.lstsq(Xa, Ya, rcond=None)
        n_params += coef.size
        a = coef[:na]
        b = coef[na : na + nb * train[0].u.shape[1]].reshape(-1, nb)
        c = coef[-1]
        for s, e in zip(sims, val, strict=True):
            yv = e.y[:, j]
            first = yv[:L]
            if not np.isfinite(first).all():
                first = np.full(L, np.nanmean(yv[: max(L, 10)]))
            ys = np.empty(e.n)
            ys[:L] = first
            for k in range(L, e.n):
                acc = c + sum(a[i] * ys[k - 1 - i] for i in range(na))
                for m in range(e.u.shape[1]):
                    acc += float(b[m] @ e.u[k - nb : k, m][::-1])
                ys[k] = acc
                if not math.isfinite(acc) or abs(acc) > 1e12:
                    ys[k:] = np.nan
                    break
            s[:, j] = ys
    return {"sims": sims, "n_params": n_params, "orders": {"na": na, "nb": nb, "nk": 1}}
