"""Toy model for the external-adapter tests: first-order thermal lag as a function."""

import numpy as np


def lag(time, inputs, params):
    """y[k+1] = a y[k] + (1 - a) K u[k], a = exp(-dt_k / tau) (exact zero-order hold)."""
    u = inputs["u"]
    a = np.exp(-np.diff(time) / params["tau"])
    y = np.empty_like(time)
    y[0] = params.get("y0", 0.0)
    for k in range(len(time) - 1):
        y[k + 1] = a[k] * y[k] + (1.0 - a[k]) * params["K"] * u[k]
    return {"y": y}


def lag_vectorized(time, inputs, params):
    """The same for a batch: params are arrays (B,), returns y (B, T)."""
    K = np.asarray(params["K"])[:, None]
    a = np.exp(-np.diff(time)[None, :] / np.asarray(params["tau"])[:, None])
    u = inputs["u"]
    y = np.empty((K.shape[0], len(time)))
    y[:, 0] = params.get("y0", 0.0)
    for k in range(len(time) - 1):
        y[:, k + 1] = a[:, k] * y[:, k] + (1.0 - a[:, k]) * K[:, 0] * u[k]
    return {"y": y}
