"""State estimation on identified models: virtual sensors, observers, consistency tests.

The Kalman virtual sensor and the steady-state observer of paper
``001_6d13a2cd04f5de5e.txt``, the AXT211 wax-temperature UKF of paper
``002_dae2310635fe074e.txt``, filter consistency tests (NEES, NIS) and balanced
truncation. This layer sits above :mod:`thermogym.models` (``estimation -> models``);
envs, firmware and the CLI use it.
"""

from thermogym.estimation.virtual_sensor import (
    AXT211WaxUKF,
    ConsistencyReport,
    Estimate,
    KalmanGains,
    NoiseModel,
    ObserverMatrices,
    ObserverStatus,
    SteadyStateObserver,
    VirtualSensor,
    balanced_truncation,
    consistency,
    innovation_covariance,
    normalized_error_squared,
    steady_state_gains,
)

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
