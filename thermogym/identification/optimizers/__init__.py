"""Optimisers of the identification coordinator.

* :mod:`.base` — stop criteria, best-so-far tracking, history, progress bar;
* :mod:`.local` — bounded Gauss-Newton / Levenberg-Marquardt / trust region
  with batched finite-difference or exact Jacobians (paper 002, section III);
* :mod:`.stochastic` — Monte Carlo, simulated annealing, differential
  evolution, CMA-ES, populations evaluated as one batch (paper 000);
* :mod:`.sensitivities` — exact forward sensitivities of thermogym's models.

The coordinator (:mod:`thermogym.identification.coordinator`) selects them by name.
"""

from thermogym.identification.optimizers.base import HistoryEntry, StopCriteria, StopSearch, Tracker

__all__ = ["HistoryEntry", "StopCriteria", "StopSearch", "Tracker"]
