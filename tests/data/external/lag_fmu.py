"""Toy model for the external-adapter tests: first-order thermal lag as an FMU source.

Built into an FMI 2 co-simulation FMU by the tests with
``python -m pythonfmu build -f lag_fmu.py``. Each step of length h holds the
input u constant (zero-order hold) and advances exactly:
y <- a y + (1 - a) K u with a = exp(-h / tau).
"""

import math

from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real


class LagFMU(Fmi2Slave):
    author = "thermogym tests"
    description = "first-order thermal lag tau dy/dt = -y + K u"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.K = 1.0
        self.tau = 100.0
        self.y0 = 0.0
        self.u = 0.0
        self.y = 0.0
        tunable = dict(causality=Fmi2Causality.parameter, variability=Fmi2Variability.tunable)
        self.register_variable(Real("K", **tunable))
        self.register_variable(Real("tau", **tunable))
        self.register_variable(Real("y0", **tunable))
        self.register_variable(Real("u", causality=Fmi2Causality.input))
        self.register_variable(Real("y", causality=Fmi2Causality.output))

    def exit_initialization_mode(self):
        self.y = self.y0

    def do_step(self, current_time, step_size):
        a = math.exp(-step_size / self.tau)
        self.y = a * self.y + (1.0 - a) * self.K * self.u
        return True
