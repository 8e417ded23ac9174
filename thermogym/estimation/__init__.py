"""State estimation on identified models: virtual sensors, observers, consistency tests.

The Kalman virtual sensor and the steady-state observer of paper
``001_6d13a2cd04f5de5e.txt``, the AXT211 wax-temperature UKF of paper
``002_dae2310635fe074e.txt``, filter consistency tests (NEES, NIS) and balanced
truncation. This layer sits above :mod:`thermogym.models` (``estimation -> models``);
envs, firmware and the CLI use it.

Modules
-------
* :mod:`~thermogym.estimation.virtual_sensor`: :class:`VirtualSensor` (Kalman filter
  and steady-state observer of a linear model split into exogenous, measured and
  hidden signals); the design notes and equations.
* :mod:`~thermogym.estimation.gains`: :class:`NoiseModel`, :class:`KalmanGains`,
  :func:`steady_state_gains` (DARE), :func:`innovation_covariance`.
* :mod:`~thermogym.estimation.observer`: :class:`SteadyStateObserver` (the firmware's
  twin), :class:`ObserverMatrices`, :class:`ObserverStatus`, :class:`Estimate`.
* :mod:`~thermogym.estimation.ukf`: :class:`AXT211WaxUKF`.
* :mod:`~thermogym.estimation.consistency`: :func:`consistency`,
  :func:`normalized_error_squared`, :class:`ConsistencyReport`.
* :mod:`~thermogym.estimation.reduction`: :func:`balanced_truncation`.
"""

from thermogym.estimation.consistency import (
    ConsistencyReport,
    consistency,
    normalized_error_squared,
)
from thermogym.estimation.gains import (
    KalmanGains,
    NoiseModel,
    innovation_covariance,
    steady_state_gains,
)
from thermogym.estimation.observer import (
    Estimate,
    ObserverMatrices,
    ObserverStatus,
    SteadyStateObserver,
)
from thermogym.estimation.reduction import balanced_truncation
from thermogym.estimation.ukf import AXT211WaxUKF
from thermogym.estimation.virtual_sensor import VirtualSensor

__all__ = [
    "AXT211WaxUKF",
    "ConsistencyReport",
    "Estimate",
    "KalmanGains",
    "NoiseModel",
    "ObserverMatrices",
    "ObserverStatus",
    "SteadyStateObserver",
    "VirtualSensor",
    "balanced_truncation",
    "consistency",
    "innovation_covariance",
    "normalized_error_squared",
    "steady_state_gains",
]
