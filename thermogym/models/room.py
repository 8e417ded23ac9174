"""Office room heated by a water radiator through an AXT211-driven valve.

Description
-----------
Plant 4 of DESIGN.md: the control loop the AXT211 actuator is built for
(``002_dae2310635fe074e.txt``, section I: room temperature control, dominant
time constants of 15 h and more). A SAUTER AXT211 wax actuator, hanging in the
room, pushes the stem of a radiator valve; the valve sets the hot-water flow
through a panel radiator; the radiator heats a two-capacity zone (room air
with furniture, building structure) that loses heat to the outdoor air.

States ``x = [T_P, T_G, x_P, x_V, T_rad, T_zone, T_struct]``: the four states
of :class:`~thermogym.models.axt211.AXT211` (wax cartridge, housing, cartridge
stroke, valve stroke) followed by the radiator water temperature, the zone air
temperature and the structure temperature.

Equations
---------
Actuator, exactly :mod:`thermogym.models.axt211` (its numba functions are
reused; equation numbers of ``002_dae2310635fe074e.txt``) with the zone air as
its environment, ``T_U = T_zone``::

    R_PTC = Σ_i R_i τ^i,  τ = (T_P − 65 °C)/35 K                          (14)
    P_PTC = (k_U u)² / R_PTC                                              (15)
    C_P dT_P/dt = P_PTC − λ_PG (T_P − T_G)                                (17)
    C_G dT_G/dt = λ_PG (T_P − T_G) − λ_GU (T_G − T_zone)                  (18)
    τ_P dx_P/dt = k_P(x_P)(T_P − T_P0) − x_P,  k_P = a x_P² + b x_P + c   (19), (21)
    x_V = backlash_c(x_P) in [0, x_max]                                   (20)

Valve (chosen here; installed characteristic with valve authority 1, i.e. a
constant differential pressure across the valve), relative stroke
``h = x_V / x_max``::

    linear:            φ(h) = h
    equal_percentage:  φ(h) = R_v^(h − 1)                  for h ≥ h_0
                       φ(h) = (h / h_0) R_v^(h_0 − 1)      for h < h_0,  h_0 = 0.05

so that ``φ(0) = 0`` (the valve shuts tight) and ``φ(1) = 1``; ``R_v`` is the
rangeability (ratio of the largest to the smallest controllable flow).

Heating curve (chosen here; linear between its design point and its foot
point at 20 °C outdoor, clipped outside)::

    T_out* = min(max(T_out, T_out_d), 20 °C)
    T_supply = T_sup_20 + (T_sup_d − T_sup_20)(20 °C − T_out*)/(20 °C − T_out_d)

Radiator: one well-mixed water node (its outlet is at ``T_rad``) whose heat
emission follows the EN 442-2 characteristic ``Φ = K ΔT^n``, calibrated so
that it emits ``Q_rad_nom`` at the design state (supply ``T_sup_d``, return
``T_sup_d − ΔT_w,nom``, room 20 °C, full flow)::

    ṁ c_w = φ(h) · Q_rad_nom / ΔT_w,nom
    C_rad dT_rad/dt = ṁ c_w (T_supply − T_rad) − Q_heat
    Q_heat = Q_rad_nom · sgn(Δ) |Δ / ΔT_ref|^n_rad,   Δ = T_rad − T_zone,
    ΔT_ref = T_sup_d − ΔT_w,nom − 20 °C

``Q_heat`` is negative only when the radiator is colder than the zone (a
supply below the zone temperature; the heat then flows back into the water).

Zone, two capacities (in the spirit of the 5R1C model of ISO 13790:2008 with
its surface node folded into the air node; chosen here)::

    C_a dT_zone/dt = Q_heat + f_int Q_int + H_as (T_struct − T_zone) + H_ao (T_out − T_zone)
    C_s dT_struct/dt = H_as (T_zone − T_struct) + H_so (T_out − T_struct) + (1 − f_int) Q_int

The energy balance ``∫(Q_heat + Q_int) dt = ΔU_a + ΔU_s + ∫[H_ao (T_zone − T_out)
+ H_so (T_struct − T_out)] dt`` with ``U_a = C_a T_zone``, ``U_s = C_s T_struct``
holds for the exact solution, and for the integrated one with RK4's own
quadrature: the update of ``C_a T_zone + C_s T_struct`` is exactly the step
times the weighted stage average of the heat flows.

Why a radiator with its own capacity (rather than a static emission law):
the radiator lags the valve by 3-4 min when it opens at design flow (the water
content is exchanged in ~3 min) and by 10-16 min when it cools with the valve
shut (the emission's slope vanishes as ``Δ → 0`` since ``n_rad > 1``). That is
the same order as the actuator's own strokes (about 5 min to open and 6 min to
close at 25 °C, longer to close in a warm room) and as the PWM periods used
with thermal actuators, so it shapes on/off and PWM results. The flow balance
also gives the concave emission-versus-flow curve of real radiators (about 1/4
of the design output at 10 % flow), the reason equal-percentage valves are used
on them; with emission proportional to ``φ`` the valve keyword would have no
physical meaning.

Left out: the actuator's own dissipation into the zone (≤ 3 W, < 0.3 % of the
design load), valve authority below 1 (pressure redistribution in the pipe
network), pipe transport delays and heat losses, and solar gains as a separate
signal (they enter ``Q_int``).

Numerics: classical Runge-Kutta 4 over all seven states with a fixed step of
at most ``max_step`` = 1 s, one numba call for the whole batch (section III-A
of ``002`` explains why fixed steps). Inside each step the valve stroke seen by
the radiator at every stage is the backlash operator (20) applied to that
stage's ``x_P`` with the memory ``x_V`` of the step start (exact while ``x_P``
is monotonic within the step); after the step ``x_V`` is updated exactly as in
:mod:`~thermogym.models.axt211`, so with the zone temperature held the
actuator reproduces the stand-alone model. Against a 1/8 s reference over a
day of 15-min on/off operation, 1 s steps are within 1e-5 K (``T_zone``),
0.01 W (``Q_heat``) and 2e-3 mm (``x_V``; this largest error lasts the one
step in which the cartridge reaches its end stop, elsewhere it is below
1e-5 mm). 2 s steps would halve the cost at 2-4× those errors; 1 s, the
AXT211's own step, is kept so that the actuator in the room matches the
stand-alone model step for step, and a year already takes only seconds (about
0.2 µs per step and system: a year at 10 s samples in about 6 s for one
system). Batches of 32 or more systems run one system per thread.

Action Space
------------
``u`` in [0, 1]: normalised heater command of the actuator (PWM duty or on/off),
as :class:`~thermogym.models.axt211.AXT211`.

Observation Space
-----------------
Outputs, in this order: ``T_zone``, ``T_struct``, ``T_rad``, ``T_supply`` [°C],
``Q_heat`` [W], ``x_V``, ``x_P`` [mm], ``P_PTC`` [W], ``T_P``, ``T_G`` [°C].
Disturbances: ``k_U`` [V] (actuator supply), ``T_out`` [°C], ``Q_int`` [W]
(internal and solar gains; negative values are accepted as extra losses).

Rewards
-------
None at model level; environments compute them from the KPIs of DESIGN.md
(``discomfort_Kh``, ``heat_delivered_kWh``, ``actuator_energy_Wh``, ...).

Starting State
--------------
:meth:`RoomModel.initial_state`: the steady state of the unheated building for
the first disturbance sample (valve shut, radiator and actuator at the zone
temperature, cartridge retracted), so a simulation starts without a transient.

Episode End
-----------
None at model level.

Arguments
---------
``valve``: ``"linear"`` (default) or ``"equal_percentage"`` (adds the parameter
``R_v``); ``effects``: actuator effects of
:data:`~thermogym.models.axt211.AXT211_EFFECTS`, passed through.

Parameter values
----------------
The first parameters are those of :class:`~thermogym.models.axt211.AXT211`
(same names, same defaults, same order, then the selected actuator effects);
the room's own follow. Building: ~20 m² office (2.7 m high, 54 m³) with one
facade in a moderately insulated, medium-weight building.

==========  =========  ======  ============================================================
parameter   nominal    unit    provenance
==========  =========  ======  ============================================================
C_a         3.0e5      J/K     chosen: air 65 kJ/K (54 m³) plus furniture and light
                               internal mass; air-node time constant ≈ 10 min
C_s         3.3e6      J/K     ISO 13790:2008 Table 12, medium class: 165 kJ/(m²·K) × 20 m²
H_as        455        W/K     ISO 13790:2008 5R1C: h_ms A_m, h_ms = 9.1 W/(m²K), A_m = 2.5 A_f
                               (medium class, Table 12), A_f = 20 m²
H_ao        13         W/K     chosen: ventilation 0.5 1/h × 54 m³ × 0.34 Wh/(m³K) = 9.2 W/K
                               plus a 3 m² window at 1.3 W/(m²K)
H_so        21.3       W/K     chosen: remaining transmission, so that H_ao + H_as‖H_so
                               = 33.35 W/K, design load 1.0 kW at 20 °C / −10 °C
f_int       0.5        1       ISO 13790:2008 annex C: half of the internal gains to the air
Q_rad_nom   1200       W       chosen: radiator sized 1.2 × the design load
n_rad       1.3        1       EN 442-2 radiator exponent (panel radiators 1.25-1.35)
dT_w_nom    10         K       chosen: 55/45 °C design water temperatures
C_rad       3.8e4      J/K     chosen: double panel ~6 l water (25 kJ/K) + ~28 kg steel
T_out_d     −10        °C      chosen: design outdoor temperature (central Europe)
T_sup_d     55         °C      chosen: low-temperature radiator system design supply
T_sup_20    20         °C      chosen: heating-curve foot point (supply at 20 °C outdoor)
R_v         25         1       chosen: rangeability of a small equal-percentage valve
                               (``valve="equal_percentage"`` only)
==========  =========  ======  ============================================================

With these values the zone's time constants are ≈ 29 h (structure, dominant)
and ≈ 10 min (air); the radiator's is 3.5 min at design flow (valve open) and
10-16 min when it cools with the valve shut (excess temperature 25 to 5 K). At
10 % flow the radiator gives 26 % of its design output, at 50 % flow 75 %.

Version History
---------------
* v1: initial release.
"""

from __future__ import annotations

from typing import Any

import numba as nb
import numpy as np
from numpy.typing import ArrayLike, NDArray

from thermogym._checks import in_range
from thermogym._jitcache import module_kernels_depend_on
from thermogym.errors import ConfigError, ParameterError, ShapeError
from thermogym.models import axt211_dynamics as ax
from thermogym.models import room_dynamics as dyn
from thermogym.models._effects import EffectLayout
from thermogym.models.axt211_dynamics import AXT211_EFFECTS, AXT211_PARAMETERS
from thermogym.models.base import Model
from thermogym.models.room_dynamics import ROOM_PARAMETERS, ROOM_SIGNALS, T_DESIGN

__all__ = ["MODELS", "ROOM_PARAMETERS", "ROOM_SIGNALS", "VALVES", "RoomModel", "valve_flow"]

#: Valve characteristics and their kernel codes.
VALVES: dict[str, int] = {"linear": 0, "equal_percentage": 1}

_NX, _NY = 7, 10


@nb.njit(cache=True, inline="always")
def _valve(h: float, Rv: float, kind: int) -> float:
    # relative flow φ(h) of dyn.flow for a rangeability R_v (valve_flow)
    pwv = dyn.power_law(Rv, h - 1.0) if kind != 0 else 0.0
    return dyn.flow(h, pwv, Rv ** (dyn.H0 - 1.0), kind)


@nb.njit(cache=True)
def _simulate_one(p, u, x0, h, n, kind, y, xs, keep):  # type: ignore[no-untyped-def]  # pragma: no cover
    # one system over the whole grid: y[k] = h(x[k]), x[k+1] = Φ(x[k], u[k])
    q, r, e = ax.coefficients(p), dyn.coefficients(p), ax.effect_coefficients(p)
    Rs = p[ax.I_RS]
    x = (x0[0], x0[1], x0[2], x0[3], x0[4], x0[5], x0[6])
    T = u.shape[0]
    for k in range(T):
        v = u[k, 1] * u[k, 0]
        Tsup = dyn.supply(u[k, 2], p)  # T_out is held over the sample
        yk = dyn.outputs(x, v * v, Tsup, q, r, Rs)
        for j in range(_NY):
            y[k, j] = yk[j]
        if keep:
            for j in range(_NX):
                xs[k, j] = x[j]
        if k + 1 < T:
            x = dyn.advance(x, v * v, Tsup, u[k, 2], u[k, 3], h, n, q, r, e, kind)


@nb.njit(cache=True)
def _simulate_serial(theta, u, x0, h, n, kind, y, xs, keep):  # type: ignore[no-untyped-def]  # pragma: no cover
    # u has B rows, or one row shared by the batch; xs has B rows when keep
    for b in range(y.shape[0]):
        ub = u[0] if u.shape[0] == 1 else u[b]
        _simulate_one(theta[b], ub, x0[b], h, n, kind, y[b], xs[b if keep else 0], keep)


@nb.njit(cache=True, parallel=True)
def _simulate_parallel(theta, u, x0, h, n, kind, y, xs, keep):  # type: ignore[no-untyped-def]  # pragma: no cover
    # one system per thread; each writes only its own rows, so results equal the serial ones
    for b in nb.prange(y.shape[0]):
        i = np.int64(b)  # the prange index is unsigned; keep index arithmetic signed
        ub = u[0] if u.shape[0] == 1 else u[i]
        _simulate_one(theta[i], ub, x0[i], h, n, kind, y[i], xs[i if keep else 0], keep)


# Threads pay off only for larger batches (start-up ~10 µs), as in axt211. Steps of an
# environment stay serial: 1024 systems take ~1 ms, where thread hand-offs cost more than
# they save on a loaded machine (measured 8 ms with 2 threads on 2 busy cores).
_PARALLEL_MIN_BATCH = 32


@nb.njit(cache=True)
def _bad_input_row(u: NDArray[np.float64]) -> int:  # pragma: no cover - numba
    # first row with u outside [0, 1], k_U < 0 or a non-finite value; −1 when all are valid
    for b in range(u.shape[0]):
        ub = u[b]
        if not (0.0 <= ub[0] <= 1.0 and ub[1] >= 0.0):
            return b
        if not (np.isfinite(ub[1]) and np.isfinite(ub[2]) and np.isfinite(ub[3])):
            return b
    return -1


@nb.njit(cache=True, inline="always")
def _fill(p: NDArray[np.float64], theta_b: NDArray[np.float64], cols: NDArray[np.int64]) -> None:
    # public parameter set -> kernel vector (absent effects and R_v keep their neutral values)
    for j in range(cols.shape[0]):
        p[cols[j]] = theta_b[j]


@nb.njit(cache=True)
def _step_kernel(x, u, theta, cols, neutral, h, n, kind):  # type: ignore[no-untyped-def]  # pragma: no cover
    # advance every system in place; theta is the public batch (1 or B rows), expanded here
    bad = _bad_input_row(u)
    if bad >= 0:
        return bad
    p = neutral.copy()
    for b in range(x.shape[0]):
        if b == 0 or theta.shape[0] > 1:
            _fill(p, theta[b], cols)
        v = u[b, 1] * u[b, 0]
        s = (x[b, 0], x[b, 1], x[b, 2], x[b, 3], x[b, 4], x[b, 5], x[b, 6])
        s = dyn.advance(
            s, v * v, dyn.supply(u[b, 2], p), u[b, 2], u[b, 3], h, n, ax.coefficients(p),
            dyn.coefficients(p), ax.effect_coefficients(p), kind,
        )  # fmt: skip
        for j in range(_NX):
            x[b, j] = s[j]
    return -1


@nb.njit(cache=True)
def _output_kernel(x, u, theta, cols, neutral, y):  # type: ignore[no-untyped-def]  # pragma: no cover
    bad = _bad_input_row(u)
    if bad >= 0:
        return bad
    p = neutral.copy()
    for b in range(x.shape[0]):
        if b == 0 or theta.shape[0] > 1:
            _fill(p, theta[b], cols)
        v = u[b, 1] * u[b, 0]
        s = (x[b, 0], x[b, 1], x[b, 2], x[b, 3], x[b, 4], x[b, 5], x[b, 6])
        yb = dyn.outputs(
            s, v * v, dyn.supply(u[b, 2], p), ax.coefficients(p), dyn.coefficients(p),
            p[ax.I_RS],
        )  # fmt: skip
        for j in range(_NY):
            y[b, j] = yb[j]
    return -1


def valve_flow(
    h: ArrayLike, valve: str = "linear", rangeability: float = 25.0
) -> NDArray[np.float64]:
    """Relative flow φ of the radiator valve at relative stroke ``h``.

    Parameters
    ----------
    h : array_like
        Relative valve stroke ``x_V / x_max`` [1]; clipped to [0, 1].
    valve : {"linear", "equal_percentage"}
        Valve characteristic.
    rangeability : float
        Rangeability ``R_v`` [1] of the equal-percentage characteristic (> 1).

    Returns
    -------
    ndarray
        Relative flow [1], 0 when shut and 1 when fully open.

    Raises
    ------
    ConfigError
        Unknown ``valve``.
    ParameterError
        ``rangeability`` not above 1.

    Examples
    --------
    >>> from thermogym.models.room import valve_flow
    >>> valve_flow([0.0, 0.5, 1.0], "equal_percentage", 25.0).round(3).tolist()
    [0.0, 0.2, 1.0]
    """
    kind = _valve_kind(valve)
    in_range("rangeability", rangeability, 1.0, lo_open=True, text=False)
    ha = np.asarray(h, dtype=float)
    out = np.array([_valve(float(v), float(rangeability), kind) for v in ha.ravel()])
    return out.reshape(ha.shape)


def _valve_kind(valve: str) -> int:
    try:
        return VALVES[valve]
    except (KeyError, TypeError):
        raise ConfigError(f"valve is {valve!r}; expected one of {sorted(VALVES)}") from None


class RoomModel(Model):
    """Office room heated by a radiator through an AXT211-driven valve.

    The AXT211 actuator (paper 002, eqs 14-21) sits in the zone and moves the
    valve of a one-node radiator that heats a two-capacity zone; see the module
    docstring for the equations and the parameter table.

    Parameters
    ----------
    valve : {"linear", "equal_percentage"}
        Valve characteristic; ``"equal_percentage"`` adds the parameter
        ``R_v`` (rangeability).
    effects : sequence of str
        Physical effects of the actuator to include (``phase_change``,
        ``nonlinear_heat_transfer``, ``supply_variation``); their parameters
        follow the AXT211 base parameters, before the room's own.

    Raises
    ------
    ConfigError
        Unknown ``valve``.
    UnknownNameError
        Unknown effect.

    Examples
    --------
    >>> import numpy as np
    >>> from thermogym.models.room import RoomModel
    >>> m = RoomModel()
    >>> T = 3 * 360  # three hours at 10 s: heater on, 24 V, 0 °C outside, 200 W gains
    >>> u = np.column_stack([np.ones(T), np.full(T, 24.0), np.zeros(T), np.full(T, 200.0)])
    >>> sim = m.simulate(u, dt=10.0)
    >>> round(float(sim.output("x_V")[0, -1]), 2)  # valve fully open
    4.5
    >>> bool(sim.output("T_zone")[0, -1] > sim.output("T_zone")[0, 0] + 2.0)
    True
    """

    name = "room"
    version = "1"
    max_step = 1.0
    physical_effects = AXT211_EFFECTS

    def __init__(self, valve: str = "linear", effects: tuple[str, ...] | list[str] = ()) -> None:
        self._valve_name = valve
        self._kind = _valve_kind(valve)
        self._layout = EffectLayout(AXT211_PARAMETERS, AXT211_EFFECTS, effects, self.name)
        room = ROOM_PARAMETERS if self._kind == 1 else ROOM_PARAMETERS[:-1]
        public = (*self._layout.public, *room)
        full = (*self._layout.full, *ROOM_PARAMETERS)
        super().__init__(
            ROOM_SIGNALS, public, ("T_P", "T_G", "x_P", "x_V", "T_rad", "T_zone", "T_struct")
        )
        index = {p.name: i for i, p in enumerate(full)}
        self._cols = np.array([index[p.name] for p in public], dtype=np.int64)
        self._neutral = np.array([p.nominal for p in full], dtype=float)

    @property
    def valve(self) -> str:
        """Valve characteristic of this instance."""
        return self._valve_name

    @property
    def effects(self) -> tuple[str, ...]:
        """Physical effects of the actuator this instance includes."""
        return self._layout.selected

    def config(self) -> dict[str, Any]:
        """Constructor arguments (stored in FitResults)."""
        cfg: dict[str, Any] = {"valve": self._valve_name}
        if self._layout.selected:
            cfg["effects"] = list(self._layout.selected)
        return cfg

    def full_theta(self, theta: NDArray[np.float64]) -> NDArray[np.float64]:
        """Kernel parameter vector: AXT211 full vector (absent effects neutral), then the room's."""
        out = np.repeat(self._neutral[None, :], theta.shape[0], axis=0)
        out[:, self._cols] = theta
        return out

    def _validate_theta(self, theta: NDArray[np.float64]) -> None:
        self._require_positive(
            theta,
            (
                "C_P", "lambda_PG", "C_G", "lambda_GU", "tau_P", "x_max",
                "C_a", "C_s", "H_as", "H_ao", "H_so", "Q_rad_nom", "dT_w_nom", "C_rad",
            ),
        )  # fmt: skip
        col = {n: theta[:, self.param_index(n)] for n in ("f_int", "n_rad", "T_out_d")}
        checks = [
            ("f_int", (col["f_int"] < 0) | (col["f_int"] > 1), "must lie in [0, 1]"),
            ("n_rad", col["n_rad"] < 1, "must be at least 1 (EN 442 exponents are 1.2-1.4)"),
            ("T_out_d", col["T_out_d"] >= T_DESIGN, "must be below 20 °C"),
        ]
        tsd = theta[:, self.param_index("T_sup_d")]
        t20 = theta[:, self.param_index("T_sup_20")]
        dtw = theta[:, self.param_index("dT_w_nom")]
        checks.append(("T_sup_d", tsd < t20, "must not be below T_sup_20"))
        checks.append(
            ("T_sup_d", tsd - dtw <= T_DESIGN, "minus dT_w_nom (design return) must exceed 20 °C")
        )
        if self._kind == 1:
            checks.append(("R_v", theta[:, self.param_index("R_v")] <= 1, "must exceed 1"))
        for name, bad, what in checks:
            if bad.any():
                b = int(np.argmax(bad))
                v = float(theta[b, self.param_index(name)])
                raise ParameterError(f"parameter {name!r} of set {b} is {v!r}; it {what}")

    @staticmethod
    def _check_u(u: NDArray[np.float64]) -> None:
        uu = u[..., 0]
        bad = (uu < 0) | (uu > 1)
        if bad.any():
            raise ShapeError(
                f"input 'u' is {float(uu[bad].flat[0])!r}; expected a normalised input in [0, 1]"
            )
        kU = u[..., 1]
        if (kU < 0).any():
            raise ShapeError(f"supply 'k_U' is {float(kU[kU < 0].flat[0])!r} V; expected >= 0")

    def closed_steady_state(
        self, theta: NDArray[np.float64], T_out: ArrayLike, Q_int: ArrayLike
    ) -> NDArray[np.float64]:
        """Zone and structure temperatures of the unheated building, shape (B, 2).

        Solves the two-node balance with ``Q_heat = 0``::

            0 = f_int Q_int + H_as (T_s − T_a) + H_ao (T_out − T_a)
            0 = H_as (T_a − T_s) + H_so (T_out − T_s) + (1 − f_int) Q_int

        Parameters
        ----------
        theta : ndarray, shape (B, P)
            Validated parameter batch.
        T_out : array_like, shape (B,) or scalar
            Outdoor temperature [°C].
        Q_int : array_like, shape (B,) or scalar
            Internal gains [W].

        Returns
        -------
        ndarray, shape (B, 2)
            ``[T_zone, T_struct]`` [°C].
        """
        To = np.broadcast_to(np.asarray(T_out, dtype=float), theta.shape[:1])
        Q = np.broadcast_to(np.asarray(Q_int, dtype=float), theta.shape[:1])
        G, a, s, f = (theta[:, self.param_index(n)] for n in ("H_as", "H_ao", "H_so", "f_int"))
        # [[G + a, −G], [−G, G + s]] [T_a, T_s] = [a T_out + f Q, s T_out + (1 − f) Q]
        r1 = a * To + f * Q
        r2 = s * To + (1.0 - f) * Q
        det = (G + a) * (G + s) - G * G
        Ta = ((G + s) * r1 + G * r2) / det
        Ts = (G * r1 + (G + a) * r2) / det
        return np.column_stack([Ta, Ts])

    def initial_state(
        self, theta: NDArray[np.float64], u0: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """Steady state of the unheated building at the first disturbances.

        Valve shut, zone and structure at :meth:`closed_steady_state` for
        ``T_out`` and ``Q_int`` of ``u0``, radiator and actuator (wax and
        housing) at the zone temperature, cartridge retracted to ``−c``.
        """
        B = theta.shape[0]
        TaTs = self.closed_steady_state(theta, u0[:, 2], u0[:, 3])
        x = np.empty((B, _NX))
        x[:, 0] = TaTs[:, 0]
        x[:, 1] = TaTs[:, 0]
        x[:, 2] = -theta[:, self.param_index("c_backlash")]
        x[:, 3] = 0.0
        x[:, 4] = TaTs[:, 0]
        x[:, 5] = TaTs[:, 0]
        x[:, 6] = TaTs[:, 1]
        return x

    def _simulate(self, theta, u, dt, x0, return_states):
        self._check_u(u)
        full = self.full_theta(theta)
        B, T = u.shape[0], u.shape[1]
        n = self.n_substeps(dt)
        y = np.empty((B, T, _NY))
        xs = np.empty((B, T, _NX)) if return_states else np.empty((1, 1, _NX))
        if B > 1 and u.strides[0] == 0:  # one input trajectory shared by the batch
            u = u[:1]
        if not (u.flags.c_contiguous and u.flags.writeable):
            u = np.array(u, order="C")  # broadcast views: one kernel signature for all callers
        kernel = _simulate_parallel if B >= _PARALLEL_MIN_BATCH else _simulate_serial
        kernel(
            full,
            u,
            np.ascontiguousarray(x0),
            dt / n,
            n,
            self._kind,
            y,
            xs,
            return_states,
        )
        return y, (xs if return_states else None)

    def _check_step_args(
        self, x: NDArray[np.float64], u: NDArray[np.float64], theta: NDArray[np.float64]
    ) -> None:
        if x.ndim != 2 or x.shape[1] != _NX:
            raise ShapeError(
                f"x has shape {x.shape}, expected (B, {_NX}) for states {list(self.state_names)}"
            )
        B = x.shape[0]
        if u.shape != (B, 4):
            raise ShapeError(
                f"u has shape {u.shape}, expected ({B}, 4) with columns "
                f"{list(self.exogenous_names)}"
            )
        if theta.ndim != 2 or theta.shape[0] not in (1, B) or theta.shape[1] != self._cols.size:
            raise ShapeError(
                f"theta has shape {theta.shape}, expected (1, {self._cols.size}) or "
                f"({B}, {self._cols.size})"
            )

    def _raise_bad_row(self, u: NDArray[np.float64], b: int) -> None:
        self._check_u(u[b : b + 1])
        j = int(np.argmax(~np.isfinite(u[b])))
        raise ShapeError(
            f"exogenous signal {self.exogenous_names[j]!r} of system {b} is {float(u[b, j])!r}; "
            "expected a finite value"
        )

    def _step(self, x, u, theta, dt):
        # hot path of environments: shape checks here, value checks inside the kernel
        self._check_step_args(x, u, theta)
        if not dt > 0.0:
            raise ShapeError(f"dt is {dt!r}, expected a positive step in seconds")
        n = self.n_substeps(dt)
        xn = np.array(x, dtype=np.float64, order="C")
        ua = np.ascontiguousarray(u, dtype=np.float64)
        th = np.ascontiguousarray(theta, dtype=np.float64)
        bad = _step_kernel(xn, ua, th, self._cols, self._neutral, dt / n, n, self._kind)
        if bad >= 0:
            self._raise_bad_row(ua, bad)
        return xn

    def _output(self, x, u, theta):
        self._check_step_args(x, u, theta)
        y = np.empty((x.shape[0], _NY))
        ua = np.ascontiguousarray(u, dtype=np.float64)
        bad = _output_kernel(
            np.ascontiguousarray(x, dtype=np.float64),
            ua,
            np.ascontiguousarray(theta, dtype=np.float64),
            self._cols,
            self._neutral,
            y,
        )
        if bad >= 0:
            self._raise_bad_row(ua, bad)
        return y


MODELS = {"room": RoomModel}


# the kernels above inline compiled functions of other modules (derived cache dependencies)
module_kernels_depend_on(globals())
