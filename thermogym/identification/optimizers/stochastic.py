"""Global, derivative-free optimisers with batched populations.

Paper 000 (section 3, step 6) offers Monte Carlo, simulated annealing and an
evolutionary algorithm; CMA-ES is added. All of them work in unit coordinates
(:meth:`~thermogym.identification.problem.Problem.to_unit`) and hand each
population to the :class:`~thermogym.identification.optimizers.base.Tracker`
as **one batch**, which the batched thermogym models simulate in one call per
experiment (external adapters parallelise it).

==============  ==================================================================
method          implementation
==============  ==================================================================
``montecarlo``  uniform random sampling of the box (paper 000), or scrambled
                Sobol / Latin hypercube (``scipy.stats.qmc``), in batches
``anneal``      simulated annealing with a population of independent Metropolis
                chains, geometric cooling and per-chain step adaptation — written
                here because scipy's ``dual_annealing`` evaluates one point at a
                time and cannot use a batched simulator
``evolution``   differential evolution, :func:`scipy.optimize.differential_evolution`
                with ``vectorized=True`` (whole generation per call)
``cmaes``       CMA-ES of the ``cma`` package, ask/tell with a batched ``tell``
==============  ==================================================================

Failed parameter sets (a SimBatch error) get a penalty worse than every
finite cost seen, so the search avoids them and goes on.
"""

from __future__ import annotations

import math
import warnings
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import differential_evolution
from scipy.stats import qmc

from thermogym._checks import in_range, integer, positive
from thermogym.errors import ConfigError
from thermogym.identification.optimizers.base import Tracker

__all__ = [
    "ANNEAL_OPTIONS",
    "CMAES_OPTIONS",
    "EVOLUTION_OPTIONS",
    "MONTECARLO_OPTIONS",
    "run_anneal",
    "run_cmaes",
    "run_evolution",
    "run_monte_carlo",
]


class _Penalty:
    """Replace the cost of failed sets by a value worse than any finite cost seen."""

    def __init__(self) -> None:
        self.worst = -math.inf

    def __call__(self, cost: NDArray[np.float64]) -> NDArray[np.float64]:
        fin = np.isfinite(cost)
        if fin.any():
            self.worst = max(self.worst, float(cost[fin].max()))
        base = self.worst if math.isfinite(self.worst) else 0.0
        return np.where(fin, cost, 2.0 * abs(base) + 1.0)


# --------------------------------------------------------------- Monte Carlo
#: Options of ``montecarlo`` and their defaults.
MONTECARLO_OPTIONS: dict[str, Any] = {
    "n_samples": 10_000,
    "batch_size": 1_000,
    "sampler": "uniform",
    "include_start": True,
}
_SAMPLERS = ("uniform", "sobol", "lhs")


def run_monte_carlo(
    problem: Any,
    tracker: Tracker,
    rng: np.random.Generator,
    *,
    n_samples: int = 10_000,
    batch_size: int = 1_000,
    sampler: str = "uniform",
    include_start: bool = True,
) -> dict[str, Any]:
    """Monte Carlo search: random parameter sets in the bounds, best kept (paper 000).

    Parameters
    ----------
    problem : Problem
    tracker : Tracker
    rng : numpy.random.Generator
    n_samples : int
        Parameter sets to draw (``max_evals`` of the stop criteria wins if smaller).
    batch_size : int
        Sets simulated per batch (one iteration).
    sampler : {"uniform", "sobol", "lhs"}
        Plain uniform draws (the paper's Monte Carlo), scrambled Sobol points
        or Latin hypercube per batch (better coverage of the box).
    include_start : bool
        Evaluate the start vector first (the result is never worse than it).

    Returns
    -------
    dict
        ``{"samples": n}``.
    """
    n = integer("n_samples", n_samples, lo=1, error=ConfigError)
    b = integer("batch_size", batch_size, lo=1, error=ConfigError)
    if sampler not in _SAMPLERS:
        raise ConfigError(f"sampler is {sampler!r}, expected one of {_SAMPLERS}")
    if tracker.stop.max_evals is not None:
        n = min(n, tracker.stop.max_evals)
    P = problem.n_params
    gen: Any = None
    if sampler == "sobol":
        gen = qmc.Sobol(d=P, scramble=True, rng=rng)
    elif sampler == "lhs":
        gen = qmc.LatinHypercube(d=P, rng=rng)
    done = 0
    first = True
    while done < n:
        m = min(b, n - done)
        if gen is None:
            U = rng.random((m, P))
        else:
            with warnings.catch_warnings():
                # Sobol points balance best in powers of two; any batch size is allowed
                warnings.simplefilter("ignore", UserWarning)
                U = gen.random(m)
        if first and include_start:
            U[0] = problem.to_unit(problem.start)
        first = False
        tracker.evaluate_unit(U)
        done += m
        tracker.end_iteration()
    return {"samples": done}


# -------------------------------------------------------- simulated annealing
#: Options of ``anneal`` and their defaults.
ANNEAL_OPTIONS: dict[str, Any] = {
    "n_chains": 32,
    "t0": None,
    "cooling": None,
    "step0": 0.1,
    "target_accept": 0.3,
}


def run_anneal(
    problem: Any,
    tracker: Tracker,
    rng: np.random.Generator,
    *,
    n_chains: int = 32,
    t0: float | None = None,
    cooling: float | None = None,
    step0: float = 0.1,
    target_accept: float = 0.3,
) -> dict[str, Any]:
    """Simulated annealing with a population of Metropolis chains, one batch per step.

    Chain 0 starts at the start vector, the others at random points. Each
    iteration every chain proposes a Gaussian step (reflected at the bounds)
    and accepts it with probability ``min(1, exp(−ΔJ / T))``; the temperature
    falls geometrically, ``T_k = T_0 c^k``, and each chain's step grows when
    it accepts and shrinks when it rejects (towards ``target_accept``).

    Parameters
    ----------
    problem : Problem
    tracker : Tracker
    rng : numpy.random.Generator
    n_chains : int
        Chains (the batch size).
    t0 : float, optional
        Start temperature in cost units (default: the spread of the initial costs).
    cooling : float, optional
        Factor ``c`` per iteration (default: the temperature falls by 10⁻³ over
        ``max_iter``, or 0.97 without an iteration limit).
    step0 : float
        Initial step standard deviation in unit coordinates.
    target_accept : float
        Acceptance rate the step adaptation aims at.
    """
    K = integer("n_chains", n_chains, lo=1, error=ConfigError)
    s0 = in_range("step0", step0, 0.0, 1.0, lo_open=True, error=ConfigError, text=False)
    acc_t = in_range(
        "target_accept", target_accept, 0.0, 1.0, lo_open=True, error=ConfigError, text=False
    )
    P = problem.n_params
    pen = _Penalty()
    U = rng.random((K, P))
    U[0] = problem.to_unit(problem.start)
    cost = pen(tracker.evaluate_unit(U).cost(tracker.cost))
    fin = cost[np.isfinite(cost)]
    if t0 is None:
        spread = float(np.std(fin)) if fin.size > 1 else 0.0
        T = spread if spread > 0 else max(abs(float(fin.min())) * 0.1, 1e-12)
    else:
        T = positive("t0", t0, error=ConfigError, text=False)
    if cooling is None:
        n_it = tracker.stop.max_iter
        c = 1e-3 ** (1.0 / n_it) if n_it else 0.97
    else:
        c = in_range("cooling", cooling, 0.0, 1.0, lo_open=True, error=ConfigError, text=False)
    sigma = np.full(K, s0)
    tracker.end_iteration()
    accepted_total = 0
    while True:
        prop = U + sigma[:, None] * rng.standard_normal((K, P))
        prop = np.abs(prop)
        prop = np.where(prop > 1.0, 2.0 - prop, prop)  # reflect at the bounds
        prop = np.clip(prop, 0.0, 1.0)
        new = pen(tracker.evaluate_unit(prop).cost(tracker.cost))
        with np.errstate(over="ignore"):
            p_acc = np.exp(-np.maximum(new - cost, 0.0) / T)
        acc = rng.random(K) < p_acc
        U[acc] = prop[acc]
        cost[acc] = new[acc]
        accepted_total += int(acc.sum())
        sigma *= np.exp(0.5 * (acc.astype(float) - acc_t))
        sigma = np.clip(sigma, 1e-6, 0.5)
        T *= c
        tracker.end_iteration(current=float(cost.min()))


# ------------------------------------------------------ differential evolution
#: Options of ``evolution`` and their defaults.
EVOLUTION_OPTIONS: dict[str, Any] = {
    "popsize": 15,
    "strategy": "best1bin",
    "mutation": (0.5, 1.0),
    "recombination": 0.7,
    "init": "latinhypercube",
    "tol": 0.01,
}


def run_evolution(
    problem: Any,
    tracker: Tracker,
    rng: np.random.Generator,
    *,
    popsize: int = 15,
    strategy: str = "best1bin",
    mutation: float | tuple[float, float] = (0.5, 1.0),
    recombination: float = 0.7,
    init: str = "latinhypercube",
    tol: float = 0.01,
) -> dict[str, Any]:
    """Differential evolution (scipy) with the whole generation as one batch.

    Parameters
    ----------
    problem : Problem
    tracker : Tracker
    rng : numpy.random.Generator
    popsize : int
        Population = ``popsize × P`` (scipy's convention).
    strategy, mutation, recombination, init, tol
        As :func:`scipy.optimize.differential_evolution`; the population
        converges when the spread of its costs falls below ``tol`` × their mean.
    """
    pop = integer("popsize", popsize, lo=1, error=ConfigError)
    P = problem.n_params
    pen = _Penalty()

    def func(U: NDArray[np.float64]) -> NDArray[np.float64]:
        # vectorized=True: U has shape (P, S), one column per member
        return pen(tracker.evaluate_unit(U.T).cost(tracker.cost))

    def callback(intermediate_result: Any) -> None:
        tracker.end_iteration(current=float(intermediate_result.fun))

    res = differential_evolution(
        func,
        bounds=[(0.0, 1.0)] * P,
        strategy=strategy,
        maxiter=10**9,
        popsize=pop,
        tol=tol,
        mutation=mutation,
        recombination=recombination,
        rng=rng,
        callback=callback,
        polish=False,
        init=init,
        updating="deferred",
        vectorized=True,
        x0=problem.to_unit(problem.start),
    )
    return {"message": str(res.message), "nit": int(res.nit), "nfev": int(res.nfev)}


# ------------------------------------------------------------------- CMA-ES
#: Options of ``cmaes`` and their defaults.
CMAES_OPTIONS: dict[str, Any] = {"sigma0": 0.25, "popsize": None, "tolfun": 1e-11}


def run_cmaes(
    problem: Any,
    tracker: Tracker,
    rng: np.random.Generator,
    *,
    sigma0: float = 0.25,
    popsize: int | None = None,
    tolfun: float = 1e-11,
) -> dict[str, Any]:
    """CMA-ES (``cma`` package) from the start vector, each generation one batch.

    Parameters
    ----------
    problem : Problem
    tracker : Tracker
    rng : numpy.random.Generator
        Seeds the strategy.
    sigma0 : float
        Initial step in unit coordinates.
    popsize : int, optional
        Offspring per generation (default ``4 + ⌊3 ln P⌋``).
    tolfun : float
        Stop when the costs of recent generations differ by less.
    """
    import cma  # cma (~0.6 s) only when CMA-ES runs

    s0 = in_range("sigma0", sigma0, 0.0, 1.0, lo_open=True, error=ConfigError, text=False)
    opts: dict[str, Any] = {
        "bounds": [0.0, 1.0],
        "seed": int(rng.integers(1, 2**31 - 1)),
        "verbose": -9,
        "tolfun": float(tolfun),
        "maxiter": 10**9,
        "maxfevals": 10**12,
    }
    if popsize is not None:
        opts["popsize"] = integer("popsize", popsize, lo=2, error=ConfigError)
    pen = _Penalty()
    es = cma.CMAEvolutionStrategy(problem.to_unit(problem.start).tolist(), s0, opts)
    while not es.stop():
        X = np.asarray(es.ask(), dtype=float)
        f = pen(tracker.evaluate_unit(X).cost(tracker.cost))
        es.tell(list(X), f.tolist())
        tracker.end_iteration(current=float(f.min()))
    return {
        "stop": {
            k: (v if isinstance(v, int | float | str) else str(v)) for k, v in es.stop().items()
        }
    }
