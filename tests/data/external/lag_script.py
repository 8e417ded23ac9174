"""Toy model for the external-adapter tests: first-order thermal lag as a script.

tau dy/dt = -y + K u, inputs held constant between samples (zero-order hold),
so y[k+1] = a y[k] + (1 - a) K u[k] with a = exp(-(t[k+1] - t[k]) / tau).

Uncertain parameters K [K/W] and tau [s] are plain variables (the adapter
replaces these defaults); y0 [K] can be set manually.
"""

import numpy as np

K = 1.0  # gain [K/W]
tau = 100.0  # time constant [s]
y0 = 0.0  # initial temperature rise [K]

# stand-alone defaults (replaced by the recording's time and input column)
time = np.arange(0.0, 600.0, 10.0)
u = np.where(time >= 50.0, 20.0, 0.0)

a = np.exp(-np.diff(time) / tau)
y = np.empty_like(time)
y[0] = y0
for k in range(len(time) - 1):
    y[k + 1] = a[k] * y[k] + (1.0 - a[k]) * K * u[k]

if __name__ == "__main__":
    print(y[-1])
