"""Linear models fitted by identification: discrete state space and FOPTD sets.

Description
-----------
Two black-box model classes whose parameters identification fits directly.

:class:`StateSpaceModel` is the discrete-time MIMO state space in innovation
form that N4SID returns (section 2.3.3 of ``001_6d13a2cd04f5de5e.txt``, eq 3)::

    x[k+1] = A x[k] + B u[k] + K e[k]                                  (3)
    y[k]   = C x[k] + D u[k] + e[k]

Paper 001 writes (3) as a difference quotient ``(x(t+Δt) − x(t))/Δt = A x +
B u + K e``; that is the same model with ``A_d = I + Δt A``, ``B_d = Δt B``,
``K_d = Δt K``. The matrices here are always the discrete ones (``A_d`` ...),
so ``x[k+1] = A x[k] + ...``. :meth:`StateSpaceModel.simulate` is the
deterministic part (``e = 0``); :meth:`StateSpaceModel.predict` is the Kalman
predictor that uses ``K``.

:class:`FOPTDModel` is a set of first-order-plus-time-delay transfer functions,
one per (output j, input i) pair, added up over the inputs (superposition);
section 4.1 of ``000_24627a5308ee07db.txt``::

    G_ji(s) = K_ji e^{−τ_ji s} / (T_ji s + 1)                          (7)
    T_ji dy_ji/dt + y_ji(t) = K_ji u_i(t − τ_ji),   y_j = Σ_i y_ji      (8)
    y[k] = a y[k−1] + b u[k−1−d],  G(z) = b z^{−1−d} / (1 − a z^{−1})  (9)-(10)
    a = e^{−Δt/T},  b = K (1 − a),  d = τ / Δt
    T = −Δt / ln a,  K = b / (1 − a),  τ = d Δt                        (11)-(12)

The paper's (9)-(10) hold only for delays that are integer multiples of Δt.
The simulation here is the exact zero-order-hold discretisation for *any*
delay (modified z-transform): with ``τ = (d + f) Δt``, ``0 ≤ f < 1``, the held
input sample reaches the lag partly during one interval and partly during the
next::

    y[k] = a y[k−1] + b1 u[k−1−d] + b2 u[k−2−d]
    b1 = K (1 − e^{−(1−f)Δt/T}),   b2 = K (e^{−(1−f)Δt/T} − e^{−Δt/T})

so ``b1 + b2 = K (1 − a)`` and ``f = 0`` gives (9) back.

FOPTD outputs are deviations (the paper subtracts the initial temperatures,
because a linear model gives zero output for zero input); ``offsets=True``
adds one parameter ``y0_<out>`` per output that is added to it.

Parameters
----------
============================  ===============  ===========================================
parameter                     unit             meaning
============================  ===============  ===========================================
``A_r_c``                     1                state-transition entry, row r, column c
``B_r_c``                     state/input      input-matrix entry (state r, exogenous c)
``C_r_c``                     output/state     output-matrix entry (output r, state c)
``D_r_c`` (``has_D``)         output/input     feedthrough entry (output r, exogenous c)
``K_r_c`` (``has_K``)         state/output     innovation (Kalman) gain entry
``x0_r`` (``fit_x0``)         state            initial state entry
``K_<out>[__<in>]``           output/input     FOPTD gain (7)
``T_<out>[__<in>]``           s                FOPTD time constant (7), > 0
``tau_<out>[__<in>]``         s                FOPTD dead time (7), ≥ 0
``y0_<out>`` (``offsets``)    output           FOPTD output offset
============================  ===============  ===========================================

The FOPTD names carry ``__<in>`` only when the model has more than one
exogenous signal. State-space bounds are ``v ± (10|v| + 1)`` around the
nominal ``v``; FOPTD bounds are ``K ± (10|K| + 1)``, ``T ∈ [T/1000, 1000 T]``,
``τ ∈ [0, 10 max(τ, T)]``; provenance "identified".

Operating Point and Sample Period
---------------------------------
Both models are linear about an operating point ``(u_op, y_op)`` (constructor
arguments ``u_op`` and, for the state space, ``y_op``; FOPTD's output offset
is its parameter ``y0``): they map ``u − u_op`` to ``y − y_op``, in every
simulation path (:meth:`~StateSpaceModel.simulate`, ``step``/``output`` for
environments, :meth:`StateSpaceModel.predict`, the initial-state estimates).
A FitResult stores it in ``model_config``, so ``fit.build_model()`` applies it.

A state space built with ``dt=None`` (the default) steps once per sample of
whatever data it is simulated on, at any positive period (e.g. 1228.8 s); one
built with a period is resampled exactly to any other period
(:meth:`StateSpaceModel.at_period`). FOPTD parameters are continuous and are
discretised exactly at the period of the data.

Starting State
--------------
``simulate(..., x0=MODE)`` with ``MODE`` one of :data:`X0_MODES`:

* ``"zero"``: at rest at the operating point (state space ``x = 0``; FOPTD
  lags zero and the input at ``u_op`` before ``t = 0``);
* ``"steady"``: settled at the first input sample (``x = (I − A)^{-1} B
  (u[0] − u_op)``; FOPTD lags at ``K (u[0] − u_op)``, input ``u[0]`` before);
* ``"estimate"``: least squares on the measured outputs ``y`` given the
  inputs (:meth:`StateSpaceModel.estimate_x0`, :meth:`FOPTDModel.estimate_x0`
  — the lags and the input held during the delay before ``t = 0``). Measured
  data rarely start at rest; this is what MATLAB's ``compare`` does.

Without ``x0`` the model's default: state space ``x = 0``,
``steady_start=True`` the steady state, ``fit_x0=True`` the parameters
``x0_r`` (so optimisers fit it); FOPTD at rest at ``u_op``, or steady with
``steady_start=True``. An explicit state array is used as it is (FOPTD: the
input before ``t = 0`` is ``u[0]`` with ``steady_start``, else ``u_op``). For
step-wise use (environments) the FOPTD state holds the last ``history`` input
samples, enough for delays up to ``history·Δt`` (see :class:`FOPTDModel`).

Version History
---------------
* v1: initial release. The operating point, ``dt=None`` and the ``x0``
  modes were added later without a version change: models stored in
  FitResults (which always name their ``dt``) simulate as before.
"""

from __future__ import annotations

from thermogym.models._linear_base import X0_MODES, c2d_zoh, check_x0_mode, d2c_zoh
from thermogym.models.base import Model
from thermogym.models.linear_foptd import (
    FOPTDModel,
    discrete_to_foptd,
    foptd_to_discrete,
    foptd_zoh,
)
from thermogym.models.linear_ss import (
    ContinuousStateSpace,
    StateSpaceMatrices,
    StateSpaceModel,
)

__all__ = [
    "MODELS",
    "X0_MODES",
    "ContinuousStateSpace",
    "FOPTDModel",
    "StateSpaceMatrices",
    "StateSpaceModel",
    "c2d_zoh",
    "check_x0_mode",
    "d2c_zoh",
    "discrete_to_foptd",
    "foptd_to_discrete",
    "foptd_zoh",
]

MODELS: dict[str, type[Model]] = {"ss": StateSpaceModel, "foptd": FOPTDModel}
