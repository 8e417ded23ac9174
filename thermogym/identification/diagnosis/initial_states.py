"""Initial states of a diagnosis fit: the policies, and the deviations an estimate works on.

Recordings rarely start at rest (paper 000: the drive "had not fully cooled
down"; a building log starts mid-operation). :func:`initial_states` gives a
parameter batch's initial states under a policy:

* ``"rest"``: the model's own initial state (usually rest, or steady at the
  first input);
* ``"measured"``: the measured temperature states start at their first
  samples; in a thermal network the unmeasured nodes then take the steady
  field the measured ones impose (a harmonic interpolation over the
  conductances, eq 13 of paper 000 with zero sources).

The policy ``"estimate"`` of :class:`~.fit.FitProblem` starts from
``"rest"`` and estimates a deviation by linear least squares from the free
responses of the model to unit deviations of its states. Those deviations
are :func:`state_directions` (one per state whose start is unknown) or, for
a thermal network, :func:`network_directions` (one per measured node, spread
to the unmeasured nodes as the steady field it imposes).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from thermogym.models.augmented import AugmentedModel
from thermogym.models.base import Model
from thermogym.models.fastnet import ExtraNodeNetwork, SwitchedNetwork
from thermogym.models.thermal_network import ThermalNetworkModel, network_matrices

__all__ = ["initial_states", "network_directions", "state_directions"]

#: Units of the states and outputs that count as temperatures.
_TEMPERATURE_UNITS = ("°C", "K", "degC")


def _network_x0(
    model: Any, theta: NDArray[np.float64], u0: NDArray[np.float64], first: Mapping[str, float]
) -> NDArray[np.float64] | None:
    if isinstance(model, SwitchedNetwork):
        model = model.plant
    if not isinstance(model, ThermalNetworkModel):
        return None
    net = model.arrays(theta)
    H = net.H
    measured: dict[int, float] = {}
    for j, name in enumerate(model.output_names):
        if name not in first or not math.isfinite(first[name]):
            continue
        row = H[j]
        nz = np.flatnonzero(row)
        if nz.size == 1 and row[nz[0]] == 1.0 and net.h0[0, j] == 0.0:
            measured[int(nz[0])] = float(first[name])
    x = model.initial_state(theta, u0)
    if not measured:
        return x
    A, Bm = network_matrices(net)
    n = A.shape[1]
    Mi = np.array(sorted(measured))
    Ui = np.array([i for i in range(n) if i not in measured])
    xm = np.array([measured[i] for i in Mi])
    for b in range(x.shape[0]):
        x[b, Mi] = xm
        if Ui.size:
            # steady state of the unmeasured nodes with the measured ones held and no heat input
            rhs = -(A[b][np.ix_(Ui, Mi)] @ xm + Bm[b, Ui, -1] * u0[b, -1])
            x[b, Ui] = np.linalg.solve(A[b][np.ix_(Ui, Ui)], rhs)
    return x


def initial_states(
    model: Model,
    theta: NDArray[np.float64],
    u0: NDArray[np.float64],
    first: Mapping[str, float] | None,
    policy: str = "rest",
) -> NDArray[np.float64]:
    """Initial states of a parameter batch under an initial-state policy.

    Parameters
    ----------
    model : Model
    theta : ndarray, shape (B, P)
    u0 : ndarray, shape (B, n_u)
        Exogenous signals at the first sample.
    first : mapping, optional
        First measured value of each output.
    policy : {"rest", "measured"}
        ``rest``: the model's own initial state; ``measured``: measured
        temperature states start at their measured values.

    Returns
    -------
    ndarray, shape (B, n_x)
    """
    if isinstance(model, AugmentedModel):
        nb = len(model.base.parameters)
        xb = initial_states(model.base, theta[:, :nb], u0, first, policy)
        return model.augment_state(xb, theta, u0)
    if policy == "rest" or not first:
        return model.initial_state(theta, u0)
    x = _network_x0(model, theta, u0, first)
    if x is not None:
        return x
    x = model.initial_state(theta, u0)
    units = {s.name: s.unit for s in model.signals}
    for name, v in first.items():
        if name in model.state_names and units.get(name) in _TEMPERATURE_UNITS and math.isfinite(v):
            x[:, model.state_names.index(name)] = v
    return x


def network_directions(
    model: Any, theta: NDArray[np.float64], u0: NDArray[np.float64], outputs: Sequence[str]
) -> NDArray[np.float64] | None:
    """Harmonic initial-state directions of a thermal network's measured nodes, or None."""
    if isinstance(model, AugmentedModel):
        nb = len(model.base.parameters)
        d = network_directions(model.base, theta[:, :nb], u0, outputs)
        if d is None:
            return None
        full = np.zeros((d.shape[0], len(model.state_names)))
        full[:, : d.shape[1]] = d
        return full
    if isinstance(model, SwitchedNetwork):
        model = model.plant
    if isinstance(model, ExtraNodeNetwork):
        nb = len(model.plant.parameters)
        d = network_directions(model.plant, theta[:, :nb], u0, outputs)
        return None if d is None else np.column_stack([d, np.zeros(d.shape[0])])
    if not isinstance(model, ThermalNetworkModel):
        return None
    units = {s.name: s.unit for s in model.signals}
    temp = [o for o in outputs if units.get(o) in _TEMPERATURE_UNITS]
    x_rest = model.initial_state(theta, u0)
    ref = {o: float(x_rest[0, 0]) for o in temp}
    base = _network_x0(model, theta, u0, ref)
    dirs = []
    for o in temp:
        bumped = dict(ref)
        bumped[o] = ref[o] + 1.0
        x = _network_x0(model, theta, u0, bumped)
        if base is not None and x is not None and np.any(x[0] != base[0]):
            dirs.append(x[0] - base[0])
    return np.array(dirs) if dirs else np.zeros((0, len(model.state_names)))


def state_directions(model: Model, x_rest: NDArray[np.float64]) -> NDArray[np.float64]:
    """Unit deviations of the states whose initial values are unknown.

    The unit is 1, or 1e-3 of a large state value.
    """
    scale = np.maximum(1.0, 1e-3 * np.abs(x_rest[0]))
    dirs = np.diag(scale)
    if isinstance(model, AugmentedModel):
        # the augmentations' physical states (a sensor's lag, a mass) are unknown at the start
        # like the base model's; clocks, dead-time histories and references are not
        dirs = dirs[model.x0_free]
    return dirs
