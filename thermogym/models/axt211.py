"""SAUTER AXT211 electrothermal valve actuator (PTC heater, wax cartridge, spring return).

Description
-----------
Grey-box model of ``002_dae2310635fe074e.txt`` (Muffato & Kunz), section VI:
a PTC thermistor heats a wax cartridge; the wax expands and pushes the valve
rod through a play (backlash); a spring closes the valve when the wax cools.

States ``x = [T_P, T_G, x_P, x_V]``: wax-cartridge temperature, housing
temperature, cartridge stroke (the paper's three states, eq 12) plus the
valve stroke ``x_V`` that the backlash operator (20) keeps as memory of the
previous sample.

Equations (numbers of ``002_dae2310635fe074e.txt``)::

    R_PTC = Σ_i R_i τ^i,  τ = (T_P − 65 °C) / 35 K                  (14)
    P_PTC = (k_U u)² / R_PTC                                         (15)
    C_P dT_P/dt = P_PTC − λ_PG (T_P − T_G)                           (17)
    C_G dT_G/dt = λ_PG (T_P − T_G) − λ_GU (T_G − T_U)                (18)
    τ_P dx_P/dt = k_P(x_P) (T_P − T_P0) − x_P                        (19)
    k_P(x_P) = a x_P² + b x_P + c,  a < 0                            (21)
    x_V = backlash_c(x_P)  (play of half-width c)                    (20)

Eq. (14) is written in a normalised temperature τ so that the polynomial
coefficients have comparable magnitudes (least-squares conditioning); it is the
same 5th-order polynomial in T_P. It is validated for T_P in [30, 101] °C
(paper); below 30 °C the resistance is held at R(30 °C) (a PTC is flat below its
switching range), above 101 °C it is extended linearly with the slope at
101 °C.

The stroke coordinate ``x_P`` is measured from the point where the cartridge
touches the closed valve rod, so it ranges over ``[−c, x_max + c]`` and the
valve stroke ``x_V`` over ``[0, x_max]`` (x_max = 4.5 mm).

Integration: explicit classical Runge-Kutta 4 with a fixed step of at most
``max_step`` = 1 s (section III-A: fixed steps keep finite-difference Jacobians
consistent); compiled with numba, one call for the whole batch. The equations are
written once in :mod:`thermogym.models.axt211_dynamics` (with the parameter table);
this module's kernels, the room model, the environments' lanes and the
identification's sensitivities are all built from them.

Parameter values
----------------
The paper does not publish its parameter values. The defaults below were chosen
here to reproduce what it states (section V and VI): at 24 V and 25 °C ambient,
u = 1, the valve starts moving when T_P is about 60 °C and reaches 4.5 mm after
about 5 minutes; the stroke gain peaks near T_P = 68 °C (Fig. 3); closing is
slower than opening (16); supply 19-29 V and ambient 0-50 °C stay in range;
and PWM at 50 % duty and high frequency holds the actuator mid-stroke, where the
spread between specimens is large (section VIII, Fig. 8). The PTC curve gives
about 7 W cold and 2.5-3 W when self-regulating.

Consequences of these choices, measured with the defaults: at 24 V, 25 °C the
valve is fully open 301 s after power-on and closed 353 s after power-off
(1,100 s in a 50 °C room); 50 % duty at a 10 s period holds 3.5 mm. The half-duty
requirement needs a PTC that is fairly flat between 70 and 90 °C, so at the
corner 19 V / 0 °C the heater cannot reach the full-stroke temperature: the
valve opens to about 0.9 mm only (every other corner opens fully).

====================  ========  =========  =================================================
parameter             nominal   unit       provenance
====================  ========  =========  =================================================
R_0 … R_5             see code  Ω          chosen: PTC 85 Ω cold, 135 Ω at 70 °C, 290 Ω at 101 °C
C_P                   18        J/K        chosen: 4.5 mm stroke after ~5 min at 24 V, 25 °C
lambda_PG             0.07      W/K        chosen: self-regulation near 89 °C at u = 1
C_G                   40        J/K        chosen: ~50 g plastic housing
lambda_GU             0.11      W/K        chosen: 50 % duty holds mid-stroke (Fig. 8)
T_P0                  60        °C         paper section V: movement begins at about 60 °C
kP_a, kP_b, kP_c      -0.018,   mm/K/mm²,  chosen: gain peaks at 68 °C (paper Fig. 3), full
                      0.14,     1/K,       stroke near 76 °C
                      0.02      mm/K
tau_P                 8         s          chosen: mechanical lag, much faster than thermal
x_max                 4.5       mm         paper section V: 4.5 mm stroke
c_backlash            0.1       mm         chosen: visible hysteresis as in paper Fig. 3
====================  ========  =========  =================================================

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
from thermogym.errors import ShapeError
from thermogym.models import axt211_dynamics as dyn
from thermogym.models._effects import EffectLayout
from thermogym.models.axt211_dynamics import AXT211_EFFECTS, AXT211_PARAMETERS, AXT211_SIGNALS
from thermogym.models.base import Model

__all__ = ["AXT211", "AXT211_EFFECTS", "AXT211_PARAMETERS", "AXT211_SIGNALS", "ptc_resistance"]

_PARALLEL_MIN_BATCH = 32  # one system per core pays off only for larger batches (~10 µs)
_BLOCK = 64  # time steps the SoA kernel keeps in a local buffer before copying them out


@nb.njit(cache=True)
def _simulate_one(p, ub, x0, h, n, y, xs, keep):  # type: ignore[no-untyped-def]  # pragma: no cover
    # one system over the grid: y[k] = h(x[k]), x[k+1] = Φ(x[k], u[k]), effects included
    q = dyn.coefficients(p)
    e = dyn.effect_coefficients(p)
    x = (x0[0], x0[1], x0[2], x0[3])
    T = y.shape[0]
    for k in range(T):
        v = ub[k, 1] * ub[k, 0]
        yk = dyn.outputs(x, v * v, q, p[dyn.I_RS])
        for j in range(6):
            y[k, j] = yk[j]
        if keep:
            for j in range(4):
                xs[k, j] = x[j]
        if k + 1 < T:
            x = dyn.advance(x, v * v, ub[k, 2], h, n, q, e)


def _make_simulate_kernel(parallel: bool):  # type: ignore[no-untyped-def]
    @nb.njit(cache=True, parallel=parallel)
    def kernel(theta, u, x0, h, n, y, xs, keep):  # type: ignore[no-untyped-def]  # pragma: no cover
        # reading `parallel` makes it a closure cell: numba keys its on-disk cache on the
        # cells, so the serial and the threaded kernel get separate cache entries
        _variant = parallel
        shared_u = u.shape[0] == 1
        for b in nb.prange(y.shape[0]):
            i = np.int64(b)  # the prange index is unsigned; keep index arithmetic signed
            ub = u[0] if shared_u else u[i]
            _simulate_one(theta[i], ub, x0[i], h, n, y[i], xs[i if keep else 0], keep)

    return kernel


_simulate_serial = _make_simulate_kernel(False)
_simulate_parallel = _make_simulate_kernel(True)


# error_model="numpy": a float division by zero gives inf/nan instead of a check and a
# raise per division. The checks are branches in the loop over systems, and a loop with
# branches does not vectorise (2.6x slower per system-step, measured). The threaded caller's
# parfor body already ran under the numpy model, but a function it calls is compiled with
# its own flags. The parameters' positivity is validated before the kernels run.
@nb.njit(cache=True, error_model="numpy")
def _soa_chunk(theta, u, x0, h, n, y, b0, b1):  # type: ignore[no-untyped-def]  # pragma: no cover
    # systems b0..b1-1, effect-free, one shared input trajectory, batch innermost (SIMD)
    T = y.shape[1]
    m = b1 - b0
    Q = np.empty(dyn.N_COEF * m)  # the chunk's coefficients, row j of system i at j·m + i
    for i in range(m):
        q = dyn.coefficients(theta[b0 + i])
        for j in range(dyn.N_COEF):
            Q[j * m + i] = q[j]
    TP = x0[b0:b1, 0].copy()
    TG = x0[b0:b1, 1].copy()
    XP = x0[b0:b1, 2].copy()
    XV = x0[b0:b1, 3].copy()
    buf = np.empty((_BLOCK, 6, m))
    for k0 in range(0, T, _BLOCK):
        kn = min(_BLOCK, T - k0)
        for kk in range(kn):
            k = k0 + kk
            v = u[k, 1] * u[k, 0]
            v2 = v * v
            TU = u[k, 2]
            for i in range(m):
                q = dyn.load_coefficients(Q, 0, m, i)
                yk = dyn.outputs((TP[i], TG[i], XP[i], XV[i]), v2, q, 0.0)
                for j in range(6):
                    buf[kk, j, i] = yk[j]
            if k + 1 == T:
                continue
            for _ in range(n):
                for i in range(m):
                    q = dyn.load_coefficients(Q, 0, m, i)
                    s, _R = dyn.step((TP[i], TG[i], XP[i], XV[i]), v2, TU, h, q)
                    TP[i], TG[i], XP[i], XV[i] = s
        for i in range(m):
            for kk in range(kn):
                for j in range(6):
                    y[b0 + i, k0 + kk, j] = buf[kk, j, i]


@nb.njit(cache=True, parallel=True)
def _simulate_soa(theta, u, x0, h, n, y, edges):  # type: ignore[no-untyped-def]  # pragma: no cover
    """Effect-free batch with one shared input trajectory, in chunks of systems on threads."""
    for c in nb.prange(edges.size - 1):
        _soa_chunk(theta, u, x0, h, n, y, edges[c], edges[c + 1])


@nb.njit(cache=True)
def _step_kernel(x, u, theta, h, n):  # type: ignore[no-untyped-def]  # pragma: no cover
    for b in range(x.shape[0]):
        p = theta[b]
        v = u[b, 1] * u[b, 0]
        s = (x[b, 0], x[b, 1], x[b, 2], x[b, 3])
        s = dyn.advance(s, v * v, u[b, 2], h, n, dyn.coefficients(p), dyn.effect_coefficients(p))
        for j in range(4):
            x[b, j] = s[j]


@nb.njit(cache=True)
def _output_kernel(x, u, theta, y):  # type: ignore[no-untyped-def]  # pragma: no cover
    for b in range(x.shape[0]):
        p = theta[b]
        v = u[b, 1] * u[b, 0]
        s = (x[b, 0], x[b, 1], x[b, 2], x[b, 3])
        yb = dyn.outputs(s, v * v, dyn.coefficients(p), p[dyn.I_RS])
        for j in range(6):
            y[b, j] = yb[j]


_NOMINAL = np.array([p.nominal for p in dyn.FULL_PARAMETERS])


def ptc_resistance(
    T_P: NDArray[np.float64] | float, coeffs: NDArray[np.float64]
) -> NDArray[np.float64]:
    """PTC resistance (14) for temperatures ``T_P`` [°C] and coefficients ``R_0..R_5`` [Ω].

    Parameters
    ----------
    T_P : float or ndarray
        Wax-cartridge temperature [°C].
    coeffs : ndarray, shape (6,)
        Polynomial coefficients of τ^0..τ^5, τ = (T_P − 65 °C)/35 K.

    Returns
    -------
    ndarray
        Resistance [Ω], clamped below 30 °C and linearly extended above 101 °C.

    Examples
    --------
    >>> from thermogym.models.axt211 import AXT211, ptc_resistance
    >>> m = AXT211()
    >>> round(float(ptc_resistance(30.0, m.nominal[:6])), 1)
    83.3
    """
    p = _NOMINAL.copy()
    p[dyn.I_R0 : dyn.I_R0 + 6] = np.asarray(coeffs, dtype=float)
    q = dyn.coefficients(p)
    T = np.atleast_1d(np.asarray(T_P, dtype=float))
    out = np.array([dyn.resistance(float(t), q) for t in T.ravel()]).reshape(T.shape)
    return out if np.ndim(T_P) else out[0]


class AXT211(Model):
    """SAUTER AXT211 wax-cartridge electrothermal valve actuator (paper 002, eqs 12-21).

    Parameters
    ----------
    effects : sequence of str
        Physical effects to include (``phase_change``, ``nonlinear_heat_transfer``,
        ``supply_variation``); their parameters are appended to the public
        parameters with neutral nominal values.

    Examples
    --------
    >>> import numpy as np
    >>> from thermogym.models import AXT211
    >>> m = AXT211()
    >>> u = np.column_stack([np.ones(601), np.full(601, 24.0), np.full(601, 25.0)])
    >>> sim = m.simulate(u, dt=1.0)
    >>> bool(sim.output("x_V")[0, -1] > 4.4)
    True
    """

    name = "axt211"
    version = "1"
    max_step = 1.0
    physical_effects = AXT211_EFFECTS

    def __init__(self, effects: tuple[str, ...] | list[str] = ()) -> None:
        self._layout = EffectLayout(AXT211_PARAMETERS, AXT211_EFFECTS, effects, self.name)
        super().__init__(AXT211_SIGNALS, self._layout.public, ("T_P", "T_G", "x_P", "x_V"))

    @property
    def effects(self) -> tuple[str, ...]:
        """Physical effects this instance includes."""
        return self._layout.selected

    def config(self) -> dict[str, Any]:
        """Constructor arguments (stored in FitResults)."""
        return {"effects": list(self._layout.selected)} if self._layout.selected else {}

    def _validate_theta(self, theta: NDArray[np.float64]) -> None:
        self._require_positive(theta, ("C_P", "lambda_PG", "C_G", "lambda_GU", "tau_P", "x_max"))

    @staticmethod
    def _check_u(u: NDArray[np.float64]) -> None:
        uu = u[..., 0]
        if (uu < 0).any() or (uu > 1).any():
            v = uu[(uu < 0) | (uu > 1)].flat[0]
            raise ShapeError(f"input 'u' is {float(v)!r}; expected a normalised input in [0, 1]")
        kU = u[..., 1]
        if (kU < 0).any():
            raise ShapeError(f"supply 'k_U' is {float(kU[kU < 0].flat[0])!r} V; expected >= 0")

    def initial_state(
        self, theta: NDArray[np.float64], u0: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """Rest state: both temperatures at the environment, cartridge retracted, valve shut."""
        B = theta.shape[0]
        x = np.empty((B, 4))
        x[:, 0] = u0[:, 2]
        x[:, 1] = u0[:, 2]
        x[:, 2] = -theta[:, self.param_index("c_backlash")]
        x[:, 3] = 0.0
        return x

    def _simulate(self, theta, u, dt, x0, return_states):
        self._check_u(u)
        full = self._layout.full_theta(theta)
        B, T = u.shape[0], u.shape[1]
        if B > 1 and u.strides[0] == 0:  # one input trajectory shared by the batch
            u = np.ascontiguousarray(u[:1])
        n = self.n_substeps(dt)
        y = np.empty((B, T, 6))
        xs = np.empty((B, T, 4)) if return_states else np.empty((1, 1, 4))
        plain = not self._layout.selected or not np.any(full[:, dyn.I_L :] != full[0, dyn.I_L :])
        plain = plain and bool(dyn.is_plain(full[0]))
        if plain and u.shape[0] == 1 and B >= _PARALLEL_MIN_BATCH and not return_states:
            chunks = max(1, min(2 * nb.get_num_threads(), B // 16))
            edges = np.linspace(0, B, chunks + 1).astype(np.int64)
            _simulate_soa(
                full, np.ascontiguousarray(u[0]), np.ascontiguousarray(x0), dt / n, n, y, edges
            )
        else:
            kernel = _simulate_parallel if B >= _PARALLEL_MIN_BATCH else _simulate_serial
            kernel(
                full,
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
        xn = np.array(x, dtype=float, copy=True)
        n = self.n_substeps(dt)
        _step_kernel(xn, np.ascontiguousarray(u), self._layout.full_theta(theta), dt / n, n)
        return xn

    def _output(self, x, u, theta):
        y = np.empty((x.shape[0], 6))
        _output_kernel(
            np.ascontiguousarray(x), np.ascontiguousarray(u), self._layout.full_theta(theta), y
        )
        return y

    def full_theta(self, theta: NDArray[np.float64]) -> NDArray[np.float64]:
        """Kernel parameter vector including neutral values of absent effects."""
        return self._layout.full_theta(theta)


# the kernels above inline compiled functions of other modules (derived cache dependencies)
module_kernels_depend_on(globals())
