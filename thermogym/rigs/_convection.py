"""Heat-transfer correlations of the machine-tool rigs (strut, spindle), compiled.

Generic physics shared by the rigs' true plants (never a plant model): air
properties, free convection from horizontal cylinders, forced convection of
rotating shafts, of surfaces moving through the air and of cylinders in cross
flow, their combination, and radiation. Every function is a scalar ``njit``
function that the rigs' kernels inline; each states its source.

Air properties are taken at 300 K (Incropera, DeWitt, Bergman, Lavine,
*Fundamentals of Heat and Mass Transfer*, 6th ed., Table A.4); their change
over the rigs' 20-60 °C is a few per cent, below the spread of the rigs'
physical estimates.

Examples
--------
>>> from thermogym.rigs._convection import h_free_cylinder, h_rotating_shaft
>>> round(h_free_cylinder(10.0, 0.04), 2)  # a 40 mm screw 10 K above the air [W/(m² K)]
4.45
>>> round(h_rotating_shaft(1000.0, 0.04), 1)  # the same screw at 1000 rpm
37.5
"""

from __future__ import annotations

import math

import numba as nb

__all__ = [
    "AIR_ALPHA",
    "AIR_K",
    "AIR_NU",
    "AIR_PR",
    "SIGMA",
    "h_cross_flow",
    "h_free_cylinder",
    "h_mixed",
    "h_moving_surface",
    "h_radiation",
    "h_rotating_shaft",
]

#: Kinematic viscosity of air at 300 K [m²/s] (Incropera Table A.4).
AIR_NU = 15.89e-6
#: Thermal conductivity of air at 300 K [W/(m K)].
AIR_K = 26.3e-3
#: Thermal diffusivity of air at 300 K [m²/s].
AIR_ALPHA = 22.5e-6
#: Prandtl number of air at 300 K.
AIR_PR = 0.707
#: Stefan-Boltzmann constant [W/(m² K⁴)].
SIGMA = 5.670374e-8
_G = 9.81
_T0 = 273.15


@nb.njit(cache=True, inline="always")
def h_free_cylinder(dT, D):  # pragma: no cover - numba (tested through its Python calls)
    """Free convection from a horizontal cylinder [W/(m² K)] (Churchill & Chu).

    ``Nu = {0.60 + 0.387 Ra^(1/6) / [1 + (0.559/Pr)^(9/16)]^(8/27)}²``
    (Incropera eq 9.34, Ra ≤ 10¹²), ``Ra = g β |ΔT| D³ / (ν α)`` with
    ``β = 1/T`` at 300 K.
    """
    ra = _G / 300.0 * abs(dT) * D * D * D / (AIR_NU * AIR_ALPHA)
    f = (1.0 + (0.559 / AIR_PR) ** (9.0 / 16.0)) ** (8.0 / 27.0)
    s = 0.60 + 0.387 * ra ** (1.0 / 6.0) / f
    return s * s * AIR_K / D


@nb.njit(cache=True, inline="always")
def h_rotating_shaft(n_rpm, D):  # pragma: no cover - numba
    """Forced convection of a shaft rotating in still air [W/(m² K)].

    ``Nu = 0.133 Re_ω^(2/3) Pr^(1/3)``, ``Re_ω = ω D² / ν`` (Kays & Bjorklund
    1958, Re_ω < 4.3·10⁵; the shaft correlation of the spindle models of
    Bossmanns & Tu, ref. [3] of ``001_6d13a2cd04f5de5e.txt``).
    """
    w = abs(n_rpm) * 2.0 * math.pi / 60.0
    re = w * D * D / AIR_NU
    return 0.133 * re ** (2.0 / 3.0) * AIR_PR ** (1.0 / 3.0) * AIR_K / D


@nb.njit(cache=True, inline="always")
def h_moving_surface(speed, L):  # pragma: no cover - numba
    """Forced convection of a surface of length ``L`` moving at ``speed`` [m/s] along itself.

    Laminar flat plate, average over ``L``: ``Nu_L = 0.664 Re_L^(1/2) Pr^(1/3)``
    (Incropera eq 7.30, Re_L < 5·10⁵); above it the mixed laminar-turbulent
    average ``Nu_L = (0.037 Re_L^(4/5) − 871) Pr^(1/3)`` (eq 7.38).
    """
    re = abs(speed) * L / AIR_NU
    if re < 5e5:
        nu = 0.664 * math.sqrt(re) * AIR_PR ** (1.0 / 3.0)
    else:
        nu = (0.037 * re**0.8 - 871.0) * AIR_PR ** (1.0 / 3.0)
    return nu * AIR_K / L


@nb.njit(cache=True, inline="always")
def h_cross_flow(speed, D):  # pragma: no cover - numba
    """Cylinder of diameter ``D`` in a cross flow of ``speed`` [m/s] (Churchill & Bernstein).

    ``Nu = 0.3 + 0.62 Re^(1/2) Pr^(1/3) / [1 + (0.4/Pr)^(2/3)]^(1/4)
    · [1 + (Re/282000)^(5/8)]^(4/5)`` (Incropera eq 7.54, Re Pr > 0.2).
    """
    re = abs(speed) * D / AIR_NU
    if re <= 0.0:
        return 0.0
    a = 0.62 * math.sqrt(re) * AIR_PR ** (1.0 / 3.0) / (1.0 + (0.4 / AIR_PR) ** (2.0 / 3.0)) ** 0.25
    nu = 0.3 + a * (1.0 + (re / 282000.0) ** 0.625) ** 0.8
    return nu * AIR_K / D


@nb.njit(cache=True, inline="always")
def h_mixed(h_free, h_forced):  # pragma: no cover - numba
    """Free and forced convection combined: ``h = (h_free³ + h_forced³)^(1/3)``.

    Churchill (1977); Incropera eq 9.64 with n = 3 (assisting and transverse flows).
    """
    return (h_free * h_free * h_free + h_forced * h_forced * h_forced) ** (1.0 / 3.0)


@nb.njit(cache=True, inline="always")
def h_radiation(T, T_air, eps):  # pragma: no cover - numba
    """Radiation to surroundings at the air temperature [W/(m² K)], per kelvin of difference.

    ``h_r = ε σ (T² + T_a²)(T + T_a)`` in kelvin (Incropera eq 1.9), exact for a
    small body in large surroundings.
    """
    a = T + _T0
    b = T_air + _T0
    return eps * SIGMA * (a * a + b * b) * (a + b)
