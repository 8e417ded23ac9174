"""Second-order-plus-dead-time models by minimising the simulation error (``procest``).

Starting values from second-order ARX models with the delay scanned
(:func:`_sopdt_start`); each output is fitted alone from three starts, the
best end point kept (:func:`_sopdt_fit`).
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from thermogym.errors import IdentificationError
from thermogym.identification._pem_arx import arx_ls
from thermogym.identification._pem_fit import PEMResult, _advise, _fitresult, _problem
from thermogym.identification._pem_solver import _Data, _offset, _Solution, _solve
from thermogym.identification.n4sid import N4SIDProblem
from thermogym.models.process import SOPDTModel
from thermogym.recording import Recording

__all__ = ["sopdt"]


def sopdt(
    recordings: Recording | Sequence[Recording],
    inputs: Sequence[str] | str,
    outputs: Sequence[str] | str,
    *,
    max_delay_s: float | None = None,
    disturbances: Sequence[str] | None = None,
    operating_point_mode: str = "mean",
    offsets: Mapping[str, Any] | None = None,
    validate: Recording | Sequence[Recording] = (),
    max_nfev: int = 100,
    expect: Mapping[str, int] | None = None,
) -> PEMResult:
    """Second-order-plus-dead-time model by minimising the simulation error.

    Starting values from the FOPTD fit of
    :func:`~thermogym.identification.foptd.fit_foptd` (``T1 = 0.8 T``,
    ``T2 = 0.2 T``, same gain and delay) and from a long-lag start
    (``T1 = T2 = T/2``, delay halved); the better end point is kept. Delays
    are searched continuously in ``[0, max_delay_s]``.

    Parameters
    ----------
    recordings, inputs, outputs, disturbances, operating_point_mode, offsets, validate
        As :func:`pem`.
    max_delay_s : float, optional
        Largest delay [s] (default: a tenth of the longest experiment).
    max_nfev : int
    expect : mapping, optional
        Declared gain signs, as :func:`pem`.

    Returns
    -------
    PEMResult
        With the warnings of :mod:`~thermogym.identification.advice`.

    Examples
    --------
    >>> from thermogym.models.process import SOPDTModel
    >>> true = SOPDTModel(["P"], ["T"], K=0.5, T1=80.0, T2=15.0, tau=6.0)
    >>> u = np.repeat(np.random.default_rng(2).choice([0.0, 10.0], 12), 100)
    >>> y = 20.0 + true.simulate(u[:, None], 1.0).outputs[0, :, 0]
    >>> rec = Recording(np.arange(u.size, dtype=float), {"P": u, "T": y})
    >>> res = sopdt(rec, ["P"], ["T"], operating_point_mode="rest")
    >>> [round(res.fit.parameters[k], 1) for k in ("K_T", "T1_T", "T2_T", "tau_T")]
    [0.5, 80.0, 15.0, 6.0]
    """
    t0 = time.perf_counter()
    prob = _problem(
        recordings, inputs, outputs, disturbances, operating_point_mode, offsets, "SOPDT"
    )
    vals = [validate] if isinstance(validate, Recording) else list(validate)
    final, th, cov, info = _sopdt_fit(prob, max_delay_s, max_nfev)
    settings = {
        "dt": prob.dt,  # the training period: the default period of the realisation
        "operating_point_mode": operating_point_mode,
        "focus": "simulation",
        **info,
        "seconds": time.perf_counter() - t0,
    }
    fit = _fitresult(
        final,
        th[None],
        cov,
        prob,
        vals,
        method="sopdt",
        settings=settings,
        notes="second-order plus dead time by simulation-error minimisation",
    )
    _advise(fit, prob, expect)
    return PEMResult(fit, final, th[None], time.perf_counter() - t0)


def _sopdt_fit(
    prob: N4SIDProblem, max_delay_s: float | None, max_nfev: int
) -> tuple[SOPDTModel, NDArray[np.float64], NDArray[np.float64], dict[str, Any]]:
    """SOPDT of a problem's deviation data: model, θ, covariance, info."""
    dt = prob.dt
    span = max(u.shape[0] for u in prob.us) * dt
    if max_delay_s is None:
        max_delay_s = 0.1 * span
    K0, T10, T20, tau0 = _sopdt_start(prob, max_delay_s, span)
    model = SOPDTModel(
        prob.inputs,
        prob.outputs,
        disturbances=prob.disturbances,
        units=prob.units,
        K=K0,
        T1=T10,
        T2=T20,
        tau=tau0,
    )
    # one output at a time: the outputs share no parameter (MISO fits, as the polynomials)
    th = model.nominal.copy()
    cov = np.zeros((th.size, th.size))
    nfev, s2s = 0, []
    m = model.n_inputs
    for jo, out in enumerate(prob.outputs):
        sub = SOPDTModel(prob.inputs, [out], disturbances=prob.disturbances,
                         K=K0[jo : jo + 1], T1=T10[jo : jo + 1], T2=T20[jo : jo + 1],
                         tau=tau0[jo : jo + 1])  # fmt: skip
        names = sub.param_names
        lo = np.array(
            [-np.inf if n.startswith("K_") else (0.0 if n.startswith("tau_") else dt / 20)
             for n in names]
        )  # fmt: skip
        hi = np.array([max_delay_s if n.startswith("tau_") else np.inf for n in names])
        data = _Data(list(prob.us), [y[:, jo : jo + 1] for y in prob.ys], dt, _offset(prob))
        best: _Solution | None = None
        Tsum = T10[jo] + T20[jo]
        for t1, t2, tau in (
            (T10[jo], T20[jo], tau0[jo]),
            (0.8 * Tsum, 0.2 * Tsum, tau0[jo]),
            (0.5 * Tsum, 0.5 * Tsum, 0.5 * tau0[jo]),
        ):
            ths = sub.nominal.copy()
            ths[sub._idx["T1"].ravel()] = np.ravel(t1)
            ths[sub._idx["T2"].ravel()] = np.ravel(t2)
            ths[sub._idx["tau"].ravel()] = np.ravel(np.minimum(tau, max_delay_s))
            sol = _solve(sub, ths, np.arange(ths.size), data, "simulation", lower=lo, upper=hi,
                         max_nfev=max_nfev)  # fmt: skip
            nfev += sol.nfev
            if best is None or sol.cost < best.cost:
                best = sol
        assert best is not None
        cols = np.arange(jo * 4 * m, (jo + 1) * 4 * m)  # K, T1, T2, tau per input of output jo
        th[cols] = best.theta
        cov[np.ix_(cols, cols)] = best.cov
        s2s.append(best.sigma2)
    # convention T1 >= T2 (the model is symmetric in them)
    for j in range(len(prob.outputs)):
        for i in range(model.n_inputs):
            a, b = model._idx["T1"][j, i], model._idx["T2"][j, i]
            if th[b] > th[a]:
                th[a], th[b] = th[b], th[a]
                cov[[a, b]] = cov[[b, a]]
                cov[:, [a, b]] = cov[:, [b, a]]
    final = SOPDTModel(
        prob.inputs,
        prob.outputs,
        disturbances=prob.disturbances,
        units=prob.units,
        **{
            k: v[0]
            for k, v in zip(("K", "T1", "T2", "tau"), model.pair_parameters(th[None]), strict=True)
        },
    )
    return final, th, cov, {"max_delay_s": max_delay_s, "nfev": nfev, "sigma2": s2s}


def _sopdt_start(
    prob: N4SIDProblem, max_delay_s: float, span: float
) -> tuple[NDArray[np.float64], ...]:
    """Starting K, T1, T2, tau (p, m) from second-order ARX models, delay scanned."""
    dt = prob.dt
    p, m = len(prob.outputs), len(prob.inputs) + len(prob.disturbances)
    K, T1, T2, tau = (np.zeros((p, m)) for _ in range(4))
    dmax = int(min(max_delay_s / dt, max(u.shape[0] for u in prob.us) // 4))
    for j in range(p):
        ys = [y[:, j] for y in prob.ys]
        best = None
        for d in range(0, dmax + 1):
            try:
                th, _, s2 = arx_ls(prob.us, ys, 2, [2] * m, [d + 1] * m)
            except IdentificationError:
                break
            if best is None or s2 < best[0]:
                best = (s2, th, d)
        if best is None:
            raise IdentificationError(f"SOPDT of {prob.outputs[j]!r}: too few samples for a start")
        _, th, d = best
        A = np.r_[1.0, th[:2]]
        lam = np.roots(A)
        Ts = sorted(
            (-dt / np.log(abs(l.real)) for l in lam if abs(l.imag) < 1e-9 and 0 < l.real < 1),
            reverse=True,
        )
        t1 = Ts[0] if Ts else span / 10
        t2 = Ts[1] if len(Ts) > 1 else t1 / 5
        for i in range(m):
            b = th[2 + 2 * i : 4 + 2 * i]
            K[j, i] = b.sum() / A.sum() if abs(A.sum()) > 1e-12 else 0.0
        T1[j] = np.clip(t1, dt, 10 * span)
        T2[j] = np.clip(t2, dt / 10, 10 * span)
        tau[j] = d * dt
    return K, T1, T2, tau
