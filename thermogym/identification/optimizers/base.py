"""Shared machinery of the optimisers: stop criteria, best-so-far tracking, history.

Every optimiser evaluates candidates through a :class:`Tracker`, which

* evaluates a whole population as one batch (:meth:`Problem.evaluate`);
* keeps the best parameter set found so far, so that a run that is stopped
  (stop criterion, ``KeyboardInterrupt``) still returns its best result;
* records failed parameter sets with the model's message and goes on; if no
  set has simulated after ``fail_after`` evaluations it stops with an
  :class:`~thermogym.errors.IdentificationError` naming the first messages;
* checks the stop criteria of paper 000 (workflow step 7) — iterations, time
  limit — and the quality limit the paper says "could be added easily";
* shows a progress bar (tqdm) with the best criterion so far and writes the
  history (one entry per iteration).
"""

from __future__ import annotations

import math
import sys
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from tqdm.auto import tqdm

from thermogym._checks import finite, positive
from thermogym.errors import ConfigError, IdentificationError

if TYPE_CHECKING:  # the problem imports the sensitivities of this package at run time
    from thermogym.identification.problem import Evaluation, Problem

__all__ = ["HistoryEntry", "StopCriteria", "StopSearch", "Tracker"]


@dataclass(frozen=True)
class StopCriteria:
    """When a search ends (paper 000, workflow step 7); any one criterion ends it.

    Parameters
    ----------
    max_iter : int, optional
        Iterations (generations, batches, Gauss-Newton steps).
    max_evals : int, optional
        Parameter sets evaluated (each simulated on every experiment).
    time_limit : float, optional
        Wall-clock limit [s], checked after every batch.
    target : float, optional
        Quality limit: stop once the problem's criterion (eq 4 of paper 000
        for ``objective="rmse"``) is at or below this value.
    """

    max_iter: int | None = None
    max_evals: int | None = None
    time_limit: float | None = None
    target: float | None = None

    def __post_init__(self) -> None:
        for name in ("max_iter", "max_evals"):
            v = getattr(self, name)
            if v is not None and (
                isinstance(v, bool) or not isinstance(v, int | np.integer) or v < 1
            ):
                raise ConfigError(f"{name} is {v!r}, expected a positive whole number")
        if self.time_limit is not None:
            positive("time_limit", self.time_limit, unit="s", error=ConfigError, text=False)
        if self.target is not None:
            finite("target", self.target, error=ConfigError, text=False)

    def as_dict(self) -> dict[str, Any]:
        """The criteria as JSON types."""
        return dict(vars(self))


class StopSearch(Exception):
    """Raised inside a search to end it; ``reason`` says which criterion fired."""

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


@dataclass(frozen=True)
class HistoryEntry:
    """State of a search after one iteration.

    Attributes
    ----------
    iteration : int
    evaluations : int
        Parameter sets evaluated so far.
    simulations : int
        Simulations so far (parameter sets × experiments).
    best : float
        Best cost so far (the optimiser's cost).
    current : float
        Best cost of this iteration (or the current point's cost).
    elapsed_s : float
        Seconds since the start.
    """

    iteration: int
    evaluations: int
    simulations: int
    best: float
    current: float
    elapsed_s: float


class Tracker:
    """Evaluates batches for an optimiser, keeps the best and the history.

    Parameters
    ----------
    problem : Problem
    stop : StopCriteria
    cost : {"rmse", "mse"}
        The cost the optimiser minimises.
    method : str
        Name shown on the progress bar.
    progress : bool, optional
        Show a tqdm progress bar (default: only when stderr is a terminal).
    callback : callable, optional
        ``callback(entry: HistoryEntry) -> bool | None`` after every
        iteration; returning True stops the search.
    keep_samples : bool
        Keep every evaluated set with its cost and pair RMSEs (Monte Carlo
        archives, dotty plots).
    fail_after : int
        Stop with an error when no set has simulated after this many evaluations.
    total : int, optional
        Expected number of iterations for the progress bar.
    """

    def __init__(
        self,
        problem: Problem,
        stop: StopCriteria,
        *,
        cost: str = "rmse",
        method: str = "",
        progress: bool | None = None,
        callback: Callable[[HistoryEntry], bool | None] | None = None,
        keep_samples: bool = False,
        fail_after: int = 20,
        total: int | None = None,
        max_failures_kept: int = 20,
    ) -> None:
        self.problem = problem
        self.stop = stop
        self.cost = cost
        self.method = method
        self.callback = callback
        self.keep_samples = keep_samples
        self.fail_after = int(fail_after)
        self.t0 = time.perf_counter()
        self.iteration = 0
        self.n_evaluated = 0
        self.n_ok = 0
        self.n_failed = 0
        self.best_z: NDArray[np.float64] | None = None
        self.best_cost = math.inf
        self.best_objective = math.inf
        self.history: list[HistoryEntry] = []
        self.failures: list[dict[str, Any]] = []
        self.failure_messages: Counter[str] = Counter()
        self._max_failures_kept = max_failures_kept
        self._iter_best = math.inf
        self._samples_z: list[NDArray[np.float64]] = []
        self._samples_cost: list[NDArray[np.float64]] = []
        self._samples_pair: list[NDArray[np.float64]] = []
        self._sims0 = problem.counters.simulations
        if progress is None:
            progress = bool(getattr(sys.stderr, "isatty", lambda: False)())
        self._bar = tqdm(
            total=total or stop.max_iter,
            desc=method or "identify",
            unit="it",
            disable=not progress,
            leave=False,
            file=sys.stderr,
            dynamic_ncols=True,
        )

    # ------------------------------------------------------------------ state
    @property
    def elapsed(self) -> float:
        """Seconds since the tracker was made."""
        return time.perf_counter() - self.t0

    @property
    def simulations(self) -> int:
        """Simulations run through this tracker (sets × experiments)."""
        return self.problem.counters.simulations - self._sims0

    def remaining_evals(self) -> int | None:
        """Evaluations left before ``max_evals`` (None: unlimited)."""
        if self.stop.max_evals is None:
            return None
        return max(0, self.stop.max_evals - self.n_evaluated)

    def check(self) -> None:
        """Raise :class:`StopSearch` if the time, evaluation or quality limit is reached."""
        s = self.stop
        if s.target is not None and self.best_objective <= s.target:
            raise StopSearch("target")
        if s.time_limit is not None and self.elapsed >= s.time_limit:
            raise StopSearch("time_limit")
        if s.max_evals is not None and self.n_evaluated >= s.max_evals:
            raise StopSearch("max_evals")

    # ------------------------------------------------------------- evaluate
    def evaluate(self, z: ArrayLike, *, residuals: bool = False) -> Evaluation:
        """Evaluate a batch of optimiser vectors (physical units), track the best.

        Raises
        ------
        StopSearch
            A limit was reached (after this batch was recorded).
        IdentificationError
            Nothing has simulated after ``fail_after`` evaluations.
        """
        if self.n_ok:  # the first batch always runs: a stopped search still has a result
            self.check()
        Z = np.atleast_2d(np.asarray(z, dtype=float))
        ev = self.problem.evaluate(Z, residuals=residuals)
        self.record(Z, ev)
        self.check()
        return ev

    def evaluate_unit(self, u: ArrayLike, *, residuals: bool = False) -> Evaluation:
        """:meth:`evaluate` for vectors in unit coordinates."""
        return self.evaluate(self.problem.from_unit(np.atleast_2d(u)), residuals=residuals)

    def record(self, Z: NDArray[np.float64], ev: Evaluation) -> None:
        """Account for an evaluated batch (best, failures, samples)."""
        B = Z.shape[0]
        self.n_evaluated += B
        ok = ev.ok
        self.n_ok += int(ok.sum())
        self.n_failed += int((~ok).sum())
        for i in np.flatnonzero(~ok):
            msg = str(ev.errors[i])
            self.failure_messages[msg] += 1
            if len(self.failures) < self._max_failures_kept:
                self.failures.append({"parameters": self.problem.as_dict(Z[i]), "message": msg})
        cost = ev.cost(self.cost)
        obj = ev.cost(self.problem.objective)
        if self.keep_samples:
            self._samples_z.append(Z.copy())
            self._samples_cost.append(np.where(ok, cost, np.inf))
            self._samples_pair.append(ev.pair_rmse.copy())
        if ok.any():
            best = int(np.argmin(np.where(ok, cost, np.inf)))
            self._iter_best = min(self._iter_best, float(cost[best]))
            if cost[best] < self.best_cost:
                self.best_cost = float(cost[best])
                self.best_objective = float(obj[best])
                self.best_z = Z[best].copy()
        if self.n_ok == 0 and self.n_evaluated >= self.fail_after:
            top = "; ".join(f"{m} ({n}x)" for m, n in self.failure_messages.most_common(3))
            raise IdentificationError(
                f"model {self.problem.model.name!r}: none of the {self.n_evaluated} parameter sets "
                f"evaluated simulated; most frequent errors: {top}"
            )

    def end_iteration(self, current: float | None = None) -> HistoryEntry:
        """Close an iteration: history, progress bar, callback, ``max_iter``.

        Parameters
        ----------
        current : float, optional
            Cost of the iteration's point (default: best cost evaluated in it).
        """
        self.iteration += 1
        cur = self._iter_best if current is None else float(current)
        entry = HistoryEntry(
            self.iteration,
            self.n_evaluated,
            self.simulations,
            self.best_cost,
            cur,
            self.elapsed,
        )
        self.history.append(entry)
        self._iter_best = math.inf
        self._bar.set_postfix(best=f"{self.best_cost:.5g}", evals=self.n_evaluated, refresh=False)
        self._bar.update(1)  # redraws (rate-limited by tqdm) with the new postfix
        if self.callback is not None and self.callback(entry):
            raise StopSearch("callback")
        if self.stop.max_iter is not None and self.iteration >= self.stop.max_iter:
            raise StopSearch("max_iter")
        self.check()
        return entry

    def close(self) -> None:
        """Close the progress bar."""
        self._bar.close()

    # -------------------------------------------------------------- samples
    def samples(self) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Every evaluated set: ``(z (n, P), cost (n,), pair_rmse (n, n_pairs))``."""
        if not self._samples_z:
            P, J = self.problem.n_params, len(self.problem.pairs)
            return np.empty((0, P)), np.empty(0), np.empty((0, J))
        return (
            np.concatenate(self._samples_z),
            np.concatenate(self._samples_cost),
            np.concatenate(self._samples_pair),
        )
