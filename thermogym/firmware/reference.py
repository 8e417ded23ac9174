"""Reference virtual-sensor models built from the spindle's physical network.

The firmware and the virtual sensors need an identified state-space model
(paper 001: N4SID, order 8). These functions build *known* models of the same
shape from the white-box network the spindle rig simulates
(:mod:`thermogym.models.spindle`): the exact continuous matrices
(:func:`~thermogym.models.thermal_network.network_matrices`), discretised by
exact zero-order hold and, when an ``order`` is asked for, reduced by
balanced residualisation (exact DC gain). They serve as the ground truth of
tests and benchmarks, and as the firmware self-test's default model; they are
not fitted to data.

Variants (Table 6 of ``001_6d13a2cd04f5de5e.txt``; ``T_amb`` is the ambient
temperature the module's second channel group records):

==============  ===================================================  ==============================
variant         exogenous                                            outputs
==============  ===================================================  ==============================
``1I7O``        speed, T_amb (disturbance)                           the seven temperatures
``3I5O``        speed, T_front_outer_housing, T_rear_outer_housing,  bearings A-D, inner housing
                T_amb (disturbance)
``3I5O-rise``   speed and the two surface temperatures, all          bearings A-D, inner housing
                temperatures relative to T_amb (Table 6 exactly)     (relative to T_amb)
``2I5O-rise``   the two surface temperatures (relative)              as above
``1I5O-rise``   T_front_outer_housing (relative)                     as above
==============  ===================================================  ==============================

In the surface-as-input variants the outer-housing nodes are *pinned* to the
measured temperatures (they become boundary conditions of the remaining 12
nodes), which is the exact physical meaning of those models. The ``-rise``
variants drop the term ``C dT_amb/dt`` that a temperature relative to a
changing ambient carries; on the rig's daily room cycle that costs about
0.15 K (see :mod:`thermogym.estimation`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from thermogym._checks import integer
from thermogym.errors import ConfigError, ParameterError
from thermogym.estimation import balanced_truncation
from thermogym.models.base import ThetaLike
from thermogym.models.linear import StateSpaceModel, c2d_zoh
from thermogym.models.spindle import NODES, SPINDLE_OUTPUTS, SpindleModel
from thermogym.models.thermal_network import network_matrices

__all__ = ["VARIANTS", "random_stable_model", "spindle_reference_model"]

_HIDDEN = (
    "T_rear_bearing_A",
    "T_rear_bearing_B",
    "T_front_bearing_C",
    "T_front_bearing_D",
    "T_inner_housing",
)
_FRONT, _REAR = "T_front_outer_housing", "T_rear_outer_housing"
#: Output order of the 1I7O model in Table 6 of paper 001.
_ALL7 = (*_HIDDEN, _FRONT, _REAR)

#: variant -> (pinned surface signals, model inputs, disturbances, outputs, relative)
VARIANTS: dict[
    str, tuple[tuple[str, ...], tuple[str, ...], tuple[str, ...], tuple[str, ...], bool]
] = {
    "1I7O": ((), ("speed",), ("T_amb",), _ALL7, False),
    "3I5O": ((_FRONT, _REAR), ("speed", _FRONT, _REAR), ("T_amb",), _HIDDEN, False),
    "3I5O-rise": ((_FRONT, _REAR), ("speed", _FRONT, _REAR), (), _HIDDEN, True),
    "2I5O-rise": ((_FRONT, _REAR), (_FRONT, _REAR), (), _HIDDEN, True),
    "1I5O-rise": ((_FRONT,), (_FRONT,), (), _HIDDEN, True),
}


def spindle_reference_model(
    variant: str = "1I7O",
    *,
    order: int | None = None,
    dt: float = 1.0,
    theta: ThetaLike = None,
) -> StateSpaceModel:
    """Known state-space model of the spindle for a Table 6 variant.

    Parameters
    ----------
    variant : str
        One of :data:`VARIANTS`.
    order : int, optional
        Reduce to this order by balanced residualisation (speed scaled to
        krpm for the balancing); the full network order (14, or 12 with
        pinned surfaces; 13 for ``1I5O-rise``) when omitted.
    dt : float
        Sample period [s].
    theta : parameter batch, optional
        Spindle network parameters (one set); nominal when omitted.

    Returns
    -------
    StateSpaceModel
        Model ``ss`` with named signals in °C and rpm (feedthrough ``D``
        after residualisation).

    Examples
    --------
    >>> m = spindle_reference_model("3I5O-rise", order=8)
    >>> m.n_states, m.exogenous_names[0], len(m.output_names)
    (8, 'speed', 5)
    """
    try:
        pinned, inputs, dist, outputs, _relative = VARIANTS[variant]
    except KeyError:
        raise ConfigError(f"unknown variant {variant!r}; variants are {list(VARIANTS)}") from None
    sm = SpindleModel()
    th = sm.theta(theta)
    if th.shape[0] != 1:
        raise ParameterError(f"theta holds {th.shape[0]} parameter sets; expected one")
    net = sm.network(th)
    A, Bm = network_matrices(net)
    A, Bm = A[0], Bm[0]  # columns of Bm: speed, T_amb
    H = net.H  # rows: SPINDLE_OUTPUTS order
    out_index = {name: i for i, name in enumerate(SPINDLE_OUTPUTS)}
    node_of = dict(SPINDLE_OUTPUTS)
    ip = [NODES.index(node_of[s]) for s in pinned]
    keep = [i for i in range(len(NODES)) if i not in ip]
    Ak = A[np.ix_(keep, keep)]
    cols: dict[str, NDArray[np.float64]] = {
        "speed": Bm[keep, 0],
        "T_amb": Bm[keep, 1],
    }
    for s, i in zip(pinned, ip, strict=True):
        cols[s] = A[keep, i]  # the pinned node acts on its neighbours like an input
    Hk = np.array([H[out_index[o], keep] for o in outputs])
    exo = [*inputs, *dist]
    Bk = np.column_stack([cols[e] for e in exo])
    # relative variants: every temperature measured from T_amb; T_amb's own column is dropped
    Ad, Bd = c2d_zoh(Ak, Bk, dt)
    Cd = Hk
    Dd = np.zeros((len(outputs), len(exo)))
    if order is not None and order < Ad.shape[0]:
        scale = np.array([1000.0 if e == "speed" else 1.0 for e in exo])
        Ad, Bs, Cd, Ds, _ = balanced_truncation(
            Ad, Bd * scale, Cd, Dd, order=order, method="residualize"
        )
        Bd, Dd = Bs / scale, Ds / scale
    units = {s: ("rpm" if s == "speed" else "°C") for s in (*exo, *outputs)}
    has_D = bool(np.any(Dd != 0))
    return StateSpaceModel(
        Ad.shape[0],
        list(inputs),
        list(outputs),
        dt=dt,
        disturbances=list(dist),
        units=units,
        A=Ad,
        B=Bd,
        C=Cd,
        D=Dd if has_D else None,
        has_D=has_D,
    )


def random_stable_model(
    n: int,
    inputs: Sequence[str],
    outputs: Sequence[str],
    *,
    dt: float = 1.0,
    seed: int = 0,
    slowest_s: float = 3.0 * 3600.0,
    fastest_s: float = 60.0,
) -> StateSpaceModel:
    """A random stable model of any order with thermal time constants (sizing tests).

    Real modes with time constants spread log-uniformly between ``fastest_s``
    and ``slowest_s``, mixed by a random orthogonal basis change; inputs
    scaled so that a unit step (1000 rpm of an input named ``speed``) moves
    the outputs by a few kelvin.

    Parameters
    ----------
    n : int
        Order.
    inputs, outputs : sequence of str
        Signal names (units: rpm for ``speed``, °C otherwise).
    dt : float
        Sample period [s].
    seed : int
        Seed of the random draw.
    slowest_s, fastest_s : float
        Range of the time constants [s].

    Returns
    -------
    StateSpaceModel

    Examples
    --------
    >>> m = random_stable_model(20, ["u0", "u1", "u2"], ["y0", "y1"])
    >>> m.n_states, bool(m.is_stable()[0])
    (20, True)
    """
    n = integer("n", n, lo=1)
    rng = np.random.default_rng(seed)
    tau = np.exp(rng.uniform(np.log(fastest_s), np.log(slowest_s), n))
    lam = np.exp(-dt / tau)
    Qm, _ = np.linalg.qr(rng.normal(size=(n, n)))
    A = Qm @ np.diag(lam) @ Qm.T
    B = Qm @ (rng.normal(size=(n, len(inputs))) * (1.0 - lam)[:, None])
    # a few kelvin per 1000 rpm, like the spindle
    B[:, [i for i, s in enumerate(inputs) if s == "speed"]] *= 1e-3
    C = rng.normal(size=(len(outputs), n)) @ Qm.T
    units = {s: ("rpm" if s == "speed" else "°C") for s in (*inputs, *outputs)}
    return StateSpaceModel.from_matrices(
        A, B, C, dt=dt, inputs=list(inputs), outputs=list(outputs), units=units
    )
