"""Fitting one polynomial family with fixed orders, and the FitResult of a PEM fit.

The training problem (deviation arrays, checked as for N4SID), the fit of
ARX, ARMAX, OE or BJ one output at a time (:func:`_fit_family`), the
FitResult with its covariance and bounds (:func:`_fitresult`) and the
warnings of :mod:`~thermogym.identification.advice` (:func:`_advise`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from thermogym._checks import integer
from thermogym.errors import ConfigError
from thermogym.fitresult import FitResult
from thermogym.identification._pem_arx import _start, arx_ls
from thermogym.identification._pem_solver import _Data, _offset, _solve
from thermogym.identification.advice import check_fit, structure_warnings
from thermogym.identification.linear_fit import data_entries, evaluate_fit, signal_ranges
from thermogym.identification.n4sid import N4SIDProblem, prepare_problem
from thermogym.models.base import Model
from thermogym.models.linear import StateSpaceModel
from thermogym.models.polynomial import STRUCTURES, PolynomialModel
from thermogym.recording import Recording

__all__ = ["PEMResult"]


@dataclass
class PEMResult:
    """Outcome of :func:`pem`, :func:`sopdt` or :func:`refine`.

    Attributes
    ----------
    fit : FitResult
    model : Model
    theta : ndarray, shape (1, P)
    seconds : float
    selection : dict, optional
        The cross-validation that chose orders and delays.
    """

    fit: FitResult
    model: Model
    theta: NDArray[np.float64]
    seconds: float
    selection: dict[str, Any] = field(default_factory=dict)


def _problem(
    recordings: Recording | Sequence[Recording],
    inputs: Sequence[str] | str,
    outputs: Sequence[str] | str,
    disturbances: Sequence[str] | None,
    operating_point_mode: str,
    offsets: Mapping[str, Any] | None = None,
    what: str = "N4SID",
) -> N4SIDProblem:
    return prepare_problem(
        recordings,
        inputs,
        outputs,
        disturbances=disturbances,
        operating_point_mode=operating_point_mode,
        min_samples=8,
        offsets=offsets,
        what=what,
    )


def _sub_problem(prob: N4SIDProblem, us: list, ys: list) -> N4SIDProblem:  # type: ignore[type-arg]
    return N4SIDProblem(
        prob.inputs,
        prob.disturbances,
        prob.outputs,
        us,
        ys,
        prob.ops[: len(us)],
        prob.dt,
        prob.units,
        prob.recordings,
        prob.mode,
        prob.offsets,
    )


def _orders_arg(name: str, value: Any, shape: tuple[int, ...], lo: int) -> NDArray[np.int64]:
    a = np.asarray(value)
    try:
        a = np.broadcast_to(a, shape)
    except ValueError:
        raise ConfigError(
            f"{name} has shape {np.shape(value)}; expected a whole number or {shape}"
        ) from None
    return np.array(
        [integer(name, v, lo=lo, error=ConfigError) for v in a.ravel()], dtype=np.int64
    ).reshape(shape)


def _fit_family(
    family: str,
    prob: N4SIDProblem,
    *,
    na: Any,
    nb: Any,
    nc: Any,
    nd: Any,
    nf: Any,
    nk: Any,
    focus: str,
    max_nfev: int,
) -> tuple[PolynomialModel, NDArray[np.float64], NDArray[np.float64], dict[str, Any]]:
    """Fit one polynomial family with fixed orders on deviation data: model, θ, cov, info."""
    p, m = len(prob.outputs), len(prob.inputs) + len(prob.disturbances)
    o = {
        "na": _orders_arg("na", na, (p,), 0),
        "nb": _orders_arg("nb", nb, (p, m), 1),
        "nc": _orders_arg("nc", nc, (p,), 0),
        "nd": _orders_arg("nd", nd, (p,), 0),
        "nf": _orders_arg("nf", nf, (p, m), 0),
        "nk": _orders_arg("nk", nk, (p, m), 0),
    }
    has = STRUCTURES[family]
    kw = {k: v for k, v in o.items() if k in ("nb", "nk") or k[1] in has}
    model = PolynomialModel(
        prob.inputs,
        prob.outputs,
        structure=family,
        disturbances=prob.disturbances,
        units=prob.units,
        dt=prob.dt,
        **{k: v.tolist() for k, v in kw.items()},
    )
    P = len(model.param_names)
    theta = np.zeros(P)
    cov = np.zeros((P, P))
    info: dict[str, Any] = {"outputs": {}}
    for j, out in enumerate(prob.outputs):
        ys = [y[:, j] for y in prob.ys]
        nbj, nkj = o["nb"][j].tolist(), o["nk"][j].tolist()
        if family == "arx":
            th, cj, s2 = arx_ls(prob.us, ys, int(o["na"][j]), nbj, nkj)
            info["outputs"][out] = {"sigma2": s2, "method": "least squares"}
        else:
            sub = PolynomialModel(
                prob.inputs,
                [out],
                structure=family,
                disturbances=prob.disturbances,
                dt=prob.dt,
                **{k: v[j : j + 1].tolist() for k, v in kw.items()},
            )
            th0 = _start(family, prob.us, ys, o, j)
            data = _Data(list(prob.us), [y[:, None] for y in ys], prob.dt, _offset(prob))
            sol = _solve(sub, th0, np.arange(th0.size), data, focus, max_nfev=max_nfev)
            th, cj = sol.theta, sol.cov
            info["outputs"][out] = {"sigma2": sol.sigma2, "nfev": sol.nfev, "status": sol.status}
        cols = _columns(model, j)
        theta[cols] = th
        cov[np.ix_(cols, cols)] = cj
    return model, theta[None], cov, info


def _columns(model: PolynomialModel, j: int) -> NDArray[np.int64]:
    """Theta columns of output ``j`` in the sub-model's order (a, b/f per input, c, d)."""
    cols = list(model._ia[j])
    for i in range(model.n_inputs):
        cols += model._ib[j][i] + model._if[j][i]
    cols += model._ic[j] + model._id[j]
    return np.array(cols, dtype=np.int64)


def _fitresult(
    model: Model,
    theta: NDArray[np.float64],
    cov: NDArray[np.float64] | None,
    prob: N4SIDProblem,
    validate: Sequence[Recording],
    *,
    method: str,
    settings: dict[str, Any],
    notes: str,
) -> FitResult:
    exo = prob.inputs + prob.disturbances
    st = dict(settings)
    st["operating_point"] = {
        **prob.stored_operating_point(),
        "mode": st.get("operating_point_mode", "mean"),
    }
    st.setdefault("x0", "estimate")
    if isinstance(model, StateSpaceModel):  # the state space carries its operating point
        model = StateSpaceModel(
            **{
                **model.config(),
                "u_op": [st["operating_point"]["inputs"][c] for c in exo],
                "y_op": [st["operating_point"]["outputs"][c] for c in prob.outputs],
            }
        )
    st["signal_ranges"] = signal_ranges(prob.recordings, exo + prob.outputs)
    kwargs: dict[str, Any] = {}
    if cov is not None:
        se = np.sqrt(np.clip(np.diag(cov), 0.0, None))
        kwargs["stderr"] = dict(zip(model.param_names, se.tolist(), strict=True))
        kwargs["covariance"] = (0.5 * (cov + cov.T)).tolist()
        kwargs["covariance_names"] = list(model.param_names)
    th = theta[0]
    bounds = {
        n: [float(v - 10 * abs(v) - 1), float(v + 10 * abs(v) + 1)]
        for n, v in zip(model.param_names, th, strict=True)
    }
    for prm in model.parameters:  # keep the model's physical bounds (time constants > 0, ...)
        if prm.lower >= 0 and bounds[prm.name][0] < 0:
            bounds[prm.name][0] = (
                0.0
                if prm.unit == "s" and prm.name.startswith("tau")
                else (float(th[model.param_index(prm.name)]) / 1000.0)
            )
    fit = FitResult.from_model(
        model,
        th,
        method=method,
        settings=st,
        bounds=bounds,
        data=data_entries(prob.recordings, list(validate)),
        notes=notes,
        **kwargs,
    )
    fit.metrics["train"] = evaluate_fit(fit, prob.recordings)
    if validate:
        fit.metrics["validation"] = evaluate_fit(fit, list(validate))
    return fit


def _advise(
    fit: FitResult, prob: N4SIDProblem, expect: Mapping[str, int] | None, **kw: Any
) -> None:
    """Store the warnings of :mod:`.advice` in ``fit`` (the command line prints them)."""
    record_s = max(u.shape[0] for u in prob.us) * prob.dt
    fit.add_warnings(
        check_fit(fit, units=prob.units, expect=expect)
        + structure_warnings(fit, record_s=record_s, **kw)
    )
