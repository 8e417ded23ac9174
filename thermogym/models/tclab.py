"""Temperature Control Lab (TCLab): two transistor heaters with their sensors.

Description
-----------
The TCLab (J. Hedengren, BYU; J. Kantor, Notre Dame) is an Arduino shield with
two TIP31C transistors used as heaters, each with a TMP36 temperature sensor
glued to its heat sink; the heat sinks are about 1 cm apart, so heater 1 also
warms sensor 2. It is the one plant in thermogym whose model is identified
from real recordings (:mod:`thermogym.datasets`, ``tclab_*``).

States ``x = [T_H1, T_H2, T_C1, T_C2]``: the two heater (heat-sink)
temperatures and the two sensor temperatures.

Equations (the physically based two-heater energy balance of the APMonitor /
BYU course material: apmonitor.com/pdc "TCLab Radiative Heat Transfer",
"TCLab MIMO Model" and "TCLab Higher Order Models"; temperatures in kelvin
inside the radiation terms)::

    Q_C12 = U_s A_s (T_H2 − T_H1)                     convection between the sinks
    Q_R12 = ε σ A_s (T_H2⁴ − T_H1⁴)                   radiation between the sinks
    C_H dT_H1/dt = U A (T_a − T_H1) + ε σ A (T_a⁴ − T_H1⁴) + Q_C12 + Q_R12 + α_1 Q_1
    C_H dT_H2/dt = U A (T_a − T_H2) + ε σ A (T_a⁴ − T_H2⁴) − Q_C12 − Q_R12 + α_2 Q_2
    τ_s dT_Ci/dt = T_Hi − T_Ci,   i = 1, 2              sensor lag (conduction to the TMP36)
    T_1 = T_C1,  T_2 = T_C2

``C_H = m c_p`` is the heat capacity of one heater with its sink (the course
material uses m = 4 g, c_p = 500 J/(kg K)); ``A`` the surface not facing the
other heater (10 cm²), ``A_s`` the surface between the heaters (2 cm²);
``Q_1, Q_2`` are the heater commands in percent and ``α_1, α_2`` the heater
power per percent (heater 1 dissipates up to about 1 W, heater 2 up to 0.75 W,
as limited by the firmware).

Numerics: classical Runge-Kutta 4 with a fixed step of at most ``max_step`` =
1 s (the sensor lag is the fastest dynamics, τ_s ≥ 2 s within the bounds), one
numba call for the whole batch.

Action Space
------------
``Q1``, ``Q2`` in [0, 100] %.

Observation Space
-----------------
Outputs ``T1``, ``T2`` (sensor temperatures), ``TH1``, ``TH2`` (heater
temperatures) [°C] and ``P1``, ``P2`` (heater power, ``α_i Q_i``) [W].

Starting State
--------------
:meth:`TCLabModel.initial_state`: every temperature at the ambient ``T_amb``
(the board at rest).

Parameter values
----------------
=========  =========  ======  ===========================================================
parameter  nominal    unit    provenance
=========  =========  ======  ===========================================================
C_H        2.0        J/K     APMonitor course: m = 4 g, c_p = 500 J/(kg K)
U          10         W/m²K   APMonitor course: natural convection
U_s        20         W/m²K   chosen: convection across the 1 cm gap (refit from data)
alpha_1    0.01       W/%     APMonitor course: heater 1 up to 1 W
alpha_2    0.0075     W/%     APMonitor course: heater 2 up to 0.75 W
tau_s      10         s       chosen: sensor lag of the order of the course's fitted values
A          1.0e-3     m²      APMonitor course: 10 cm² not between the heaters
A_s        2.0e-4     m²      APMonitor course: 2 cm² between the heaters
eps        0.9        1       APMonitor course: emissivity
=========  =========  ======  ===========================================================

The values identified from the shipped recordings are in
``thermogym/envs/data/tclab_fit.json`` (see ``scripts/fit_tclab.py``).

Version History
---------------
* v1: initial release.
"""

from __future__ import annotations

from typing import Any

import numba as nb
import numpy as np
from numpy.typing import NDArray

from thermogym._jitcache import module_kernels_depend_on
from thermogym.errors import ParameterError, ShapeError
from thermogym.models.base import Model, Parameter, Signal
from thermogym.models.integrators import rk4_step

__all__ = [
    "MODELS",
    "SIGMA",
    "TCLAB_PARAMETERS",
    "TCLAB_SIGNALS",
    "TCLabModel",
    "advance",
    "heater_power",
    "rhs",
]

#: Stefan-Boltzmann constant [W/(m² K⁴)].
SIGMA = 5.670374419e-8
_K = 273.15
_APM = "APMonitor/BYU TCLab course material (apmonitor.com/pdc, TCLab MIMO model)"

TCLAB_SIGNALS: tuple[Signal, ...] = (
    Signal("Q1", "input", "%", "heater 1 command, 0..100 %"),
    Signal("Q2", "input", "%", "heater 2 command, 0..100 %"),
    Signal("T_amb", "disturbance", "°C", "ambient air temperature"),
    Signal("T1", "output", "°C", "temperature sensor 1 (next to heater 1)"),
    Signal("T2", "output", "°C", "temperature sensor 2 (next to heater 2)"),
    Signal("TH1", "output", "°C", "heater 1 (heat sink) temperature"),
    Signal("TH2", "output", "°C", "heater 2 (heat sink) temperature"),
    Signal("P1", "output", "W", "heater 1 power alpha_1 Q1"),
    Signal("P2", "output", "W", "heater 2 power alpha_2 Q2"),
)

TCLAB_PARAMETERS: tuple[Parameter, ...] = (
    Parameter("C_H", 2.0, 0.5, 10.0, "J/K", "heat capacity of one heater with its sink", _APM),
    Parameter(
        "U",
        10.0,
        0.1,
        40.0,
        "W/(m²K)",
        "convection coefficient to the air",
        _APM + "; lower bound wide: the fits to real boards give small values",
    ),
    Parameter(
        "U_s",
        20.0,
        0.0,
        200.0,
        "W/(m²K)",
        "convection coefficient between the two heat sinks",
        "chosen here; identified from the recordings",
    ),
    Parameter("alpha_1", 0.01, 5e-4, 0.03, "W/%", "heater 1 power per percent", _APM),
    Parameter("alpha_2", 0.0075, 5e-4, 0.03, "W/%", "heater 2 power per percent", _APM),
    Parameter(
        "tau_s",
        10.0,
        2.0,
        120.0,
        "s",
        "time constant of the sensor lag behind its heater",
        "chosen here; identified from the recordings",
        "sensor",
    ),
    Parameter("A", 1.0e-3, 5.0e-4, 2.0e-3, "m²", "heater surface not between the heaters", _APM),
    Parameter("A_s", 2.0e-4, 5.0e-5, 5.0e-4, "m²", "heater surface between the heaters", _APM),
    Parameter("eps", 0.9, 0.5, 1.0, "1", "emissivity of the heat sinks", _APM),
)

_I_C, _I_U, _I_US, _I_A1, _I_A2, _I_TAU, _I_A, _I_AS, _I_EPS = range(9)


@nb.njit(cache=True, inline="always")
def rhs(x: tuple, args: tuple) -> tuple:  # type: ignore[type-arg]
    """Energy balances of the two heaters and the sensor lags (module docstring).

    ``x = (T_H1, T_H2, T_C1, T_C2)``, ``args = (Q1, Q2, T_a, p)`` with ``p`` the parameter
    vector. Returns the derivatives and ``None``.
    """
    TH1, TH2, TC1, TC2 = x
    q1, q2, Ta, p = args
    a1 = TH1 + _K
    a2 = TH2 + _K
    aa = Ta + _K
    es = p[_I_EPS] * SIGMA
    a1_4 = a1 * a1 * a1 * a1
    a2_4 = a2 * a2 * a2 * a2
    aa_4 = aa * aa * aa * aa
    q12 = p[_I_US] * p[_I_AS] * (TH2 - TH1) + es * p[_I_AS] * (a2_4 - a1_4)
    ua = p[_I_U] * p[_I_A]
    esa = es * p[_I_A]
    ic = 1.0 / p[_I_C]
    d1 = (ua * (Ta - TH1) + esa * (aa_4 - a1_4) + q12 + p[_I_A1] * q1) * ic
    d2 = (ua * (Ta - TH2) + esa * (aa_4 - a2_4) - q12 + p[_I_A2] * q2) * ic
    it = 1.0 / p[_I_TAU]
    return (d1, d2, (TH1 - TC1) * it, (TH2 - TC2) * it), None


_rk4 = rk4_step(rhs)


@nb.njit(cache=True)
def advance(
    x: NDArray[np.float64], q1: float, q2: float, Ta: float, p: Any, h: float, n: int
) -> None:
    """Advance one system by ``n`` RK4 steps of ``h`` seconds with inputs held (in place).

    ``x = [T_H1, T_H2, T_C1, T_C2]``, heater commands ``q1``, ``q2`` [%], ambient ``Ta``,
    parameter vector ``p``.
    """
    s = (x[0], x[1], x[2], x[3])
    for _ in range(n):
        s, _ = _rk4(s, h, (q1, q2, Ta, p))
    x[0], x[1], x[2], x[3] = s


@nb.njit(cache=True, inline="always")
def heater_power(p: Any, q1: float, q2: float) -> float:
    """Electrical power of both heaters [W] at commands ``q1``, ``q2`` [%]."""
    return p[_I_A1] * q1 + p[_I_A2] * q2


@nb.njit(cache=True, inline="always")
def _outputs(x: Any, q1: float, q2: float, p: Any, y: Any) -> None:
    y[0] = x[2]
    y[1] = x[3]
    y[2] = x[0]
    y[3] = x[1]
    y[4] = p[_I_A1] * q1
    y[5] = p[_I_A2] * q2


@nb.njit(cache=True)
def _simulate_kernel(theta, u, x0, h, n, y, xs, keep):  # pragma: no cover - numba
    B, T = y.shape[0], y.shape[1]
    shared = u.shape[0] == 1
    x = np.empty(4)
    for b in range(B):
        p = theta[b]
        ub = u[0] if shared else u[b]
        x[:] = x0[b]
        for k in range(T):
            _outputs(x, ub[k, 0], ub[k, 1], p, y[b, k])
            if keep:
                xs[b, k, :] = x
            if k + 1 < T:
                advance(x, ub[k, 0], ub[k, 1], ub[k, 2], p, h, n)


@nb.njit(cache=True)
def _step_kernel(x, u, theta, h, n):  # pragma: no cover - numba
    for b in range(x.shape[0]):
        advance(x[b], u[b, 0], u[b, 1], u[b, 2], theta[b if theta.shape[0] > 1 else 0], h, n)


@nb.njit(cache=True)
def _output_kernel(x, u, theta, y):  # pragma: no cover - numba
    for b in range(x.shape[0]):
        _outputs(x[b], u[b, 0], u[b, 1], theta[b if theta.shape[0] > 1 else 0], y[b])


class TCLabModel(Model):
    """Two-heater TCLab energy balance with convection, radiation and sensor lag.

    See the module docstring for the equations and the parameter table.

    Examples
    --------
    >>> import numpy as np
    >>> from thermogym.models.tclab import TCLabModel
    >>> m = TCLabModel()
    >>> T = 1200  # 20 min at 1 s: heater 1 at 50 %, ambient 21 °C
    >>> u = np.column_stack([np.full(T, 50.0), np.zeros(T), np.full(T, 21.0)])
    >>> sim = m.simulate(u, dt=1.0)
    >>> T1, T2 = sim.output("T1")[0, -1], sim.output("T2")[0, -1]
    >>> bool(T1 > T2 > 21.0)
    True
    """

    name = "tclab"
    version = "1"
    max_step = 1.0

    def __init__(self) -> None:
        super().__init__(TCLAB_SIGNALS, TCLAB_PARAMETERS, ("T_H1", "T_H2", "T_C1", "T_C2"))

    def config(self) -> dict[str, Any]:
        """Constructor arguments (none)."""
        return {}

    def _validate_theta(self, theta: NDArray[np.float64]) -> None:
        self._require_positive(theta, ("C_H", "U", "alpha_1", "alpha_2", "tau_s", "A", "eps"))
        bad = theta[:, _I_US] < 0
        if bad.any():
            b = int(np.argmax(bad))
            raise ParameterError(
                f"parameter 'U_s' of set {b} is {float(theta[b, _I_US])!r}; expected >= 0"
            )

    @staticmethod
    def _check_u(u: NDArray[np.float64]) -> None:
        q = u[..., :2]
        bad = (q < 0) | (q > 100)
        if bad.any():
            raise ShapeError(
                f"heater command is {float(q[bad].flat[0])!r} %; expected a value in [0, 100]"
            )

    def initial_state(
        self, theta: NDArray[np.float64], u0: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """Board at rest: heaters and sensors at the ambient temperature."""
        B = max(theta.shape[0], u0.shape[0])
        return np.repeat(np.broadcast_to(u0[:, 2:3], (B, 1)), 4, axis=1).astype(float)

    def steady_state(
        self, theta: NDArray[np.float64], Q1: float, Q2: float, T_amb: float
    ) -> NDArray[np.float64]:
        """Steady heater temperatures for constant inputs, shape (B, 2) [°C].

        Solves the two algebraic heat balances (``dT_H/dt = 0``) with
        :func:`scipy.optimize.fsolve`; the sensors equal their heaters then.

        Parameters
        ----------
        theta : ndarray, shape (B, P)
        Q1, Q2 : float
            Heater commands [%].
        T_amb : float
            Ambient temperature [°C].
        """
        from scipy.optimize import fsolve  # scipy.optimize (~0.6 s) only for a steady state

        th = self.theta(theta)
        out = np.empty((th.shape[0], 2))
        for b in range(th.shape[0]):
            p = th[b]

            def f(T: NDArray[np.float64], p: NDArray[np.float64] = p) -> list[float]:
                (d1, d2, _, _), _ = rhs((T[0], T[1], T[0], T[1]), (Q1, Q2, T_amb, p))
                return [d1, d2]

            out[b] = fsolve(f, [T_amb + 30.0, T_amb + 20.0], xtol=1e-12)
        return out

    def _simulate(self, theta, u, dt, x0, return_states):
        self._check_u(u)
        B, T = u.shape[0], u.shape[1]
        if B > 1 and u.strides[0] == 0:  # one input trajectory shared by the batch
            u = u[:1]
        n = self.n_substeps(dt)
        y = np.empty((B, T, 6))
        xs = np.empty((B, T, 4)) if return_states else np.empty((1, 1, 4))
        _simulate_kernel(
            np.ascontiguousarray(theta),
            np.ascontiguousarray(u),
            np.ascontiguousarray(x0),
            dt / n,
            n,
            y,
            xs,
            return_states,
        )
        return y, (xs if return_states else None)

    def _step(self, x, u, theta, dt):
        xn = np.array(x, dtype=float, order="C")
        ua = np.ascontiguousarray(u, dtype=float)
        self._check_u(ua)
        n = self.n_substeps(dt)
        _step_kernel(xn, ua, np.ascontiguousarray(theta, dtype=float), dt / n, n)
        return xn

    def _output(self, x, u, theta):
        y = np.empty((x.shape[0], 6))
        _output_kernel(
            np.ascontiguousarray(x, dtype=float),
            np.ascontiguousarray(u, dtype=float),
            np.ascontiguousarray(theta, dtype=float),
            y,
        )
        return y


MODELS = {"tclab": TCLabModel}


# the kernels above inline compiled functions of other modules (derived cache dependencies)
module_kernels_depend_on(globals())
