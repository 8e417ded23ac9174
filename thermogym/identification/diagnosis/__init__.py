"""Mismatch diagnosis: locate it, name the missing physics, model it, show the fit improve.

When a simulation and recordings differ, :func:`diagnose`

1. fits the nominal model on the training recordings (or takes a FitResult),
2. **detects** whether the mismatch is significant beyond noise (Ljung's residual
   whiteness and input-independence tests, by FFT: :mod:`.residuals`),
3. **locates** it: outputs, time windows, operating regimes (:mod:`.locate`),
4. **explains** it: shortlists effects of the vocabulary by their residual
   signature, fits each augmented model and ranks them on held-out data with a
   BIC penalty (:mod:`.effects`, :mod:`.fit`); a sparse regression of the
   residual dynamics (:mod:`.sindy`) when none fits,
5. **models** it: the winner as a FitResult environments accept (the plant with
   the effect switched on, or the registered ``augmented`` model of
   :mod:`thermogym.models.augmented`),
6. **shows** it: fits before/after on training and held-out data, residual
   tests after, figures (:mod:`.report`, :mod:`.plots`).

>>> from thermogym.identification.diagnosis import CATALOGUE
>>> sorted(CATALOGUE)[:3]
['backlash', 'input_dependent_heat_transfer', 'input_nonlinearity']
"""

from thermogym.identification.diagnosis.effects import CATALOGUE, Effect, EffectEntry
from thermogym.identification.diagnosis.hypothesis import Candidate, Hypothesis
from thermogym.identification.diagnosis.report import DiagnosisReport
from thermogym.identification.diagnosis.run import diagnose, resolve_model
from thermogym.identification.residuals import (
    ResidualTest,
    autocorrelation,
    cross_correlation,
    noise_sigma,
    residual_tests,
)
from thermogym.models.augmented import AugmentedModel, register

register()

__all__ = [
    "CATALOGUE",
    "AugmentedModel",
    "Candidate",
    "DiagnosisReport",
    "Effect",
    "EffectEntry",
    "Hypothesis",
    "ResidualTest",
    "autocorrelation",
    "cross_correlation",
    "diagnose",
    "noise_sigma",
    "residual_tests",
    "resolve_model",
]
