"""Plant models: pure numerics, batched over parameter sets.

Every model declares its signals and parameters (:mod:`thermogym.models.base`)
and simulates a batch of parameter sets at once. :func:`get_model` builds a
model from its command-line name.
"""

from thermogym.models.axt211 import AXT211
from thermogym.models.base import Model, Parameter, Signal, Simulation

__all__ = ["AXT211", "Model", "Parameter", "Signal", "Simulation"]
