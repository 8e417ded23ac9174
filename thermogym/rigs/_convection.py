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
>>> round(k_ratio_rotating_annulus(1000.0, 0.020, 0.045), 1)  # ... turning inside a Ø90 tube
12.0
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
    "g_annulus_conduction",
    "g_annulus_radiation",
    "h_cross_flow",
    "h_free_cylinder",
    "h_mixed",
    "h_moving_surface",
    "h_radiation",
    "h_rotating_disk",
    "h_rotating_shaft",
    "k_ratio_free_annulus",
    "k_ratio_rotating_annulus",
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
def h_rotating_disk(n_rpm, R):  # pragma: no cover - numba
    """Face of a disk of radius ``R`` rotating in still air, mean [W/(m² K)].

    Cobb & Saunders (1956, *Proc. R. Soc. A* 236:343), laminar:
    ``Nu_R = h R / k = 0.36 Re^(1/2)``, ``Re = ω R² / ν`` (below 2.4·10⁵, where
    the flow turns turbulent at the rim; beyond, the laminar mean is kept: a
    turbulent rim raises it by some tens of per cent).
    """
    w = abs(n_rpm) * 2.0 * math.pi / 60.0
    return 0.36 * math.sqrt(w * R * R / AIR_NU) * AIR_K / R


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


@nb.njit(cache=True, inline="always")
def k_ratio_rotating_annulus(n_rpm, r_i, r_o):  # pragma: no cover - numba
    """Air in an annulus whose inner cylinder turns: effective over molecular conductivity.

    Becker & Kaye (1962, *J. Heat Transfer* 84:97-105), the air-gap correlation of
    rotating electrical machines (Staton, Boglietti & Cavagnino, *IEEE Trans. Energy
    Convers.* 20(3), 2005; reviewed by Fénot et al., *Int. J. Therm. Sci.* 50, 2011):
    ``Ta = ω² r_m δ³ / ν²`` with the mean radius ``r_m`` and the gap ``δ``;
    ``Nu = h 2δ / k`` is 2 (conduction, laminar Couette flow) below ``Ta = 1700``,
    ``0.128 Ta^0.367`` up to 10⁴ (Taylor vortices) and ``0.409 Ta^0.241`` above
    (measured to 10⁷; extrapolated beyond). Returns ``Nu / 2``, the factor on the
    gap's conduction. The correlation was measured on narrow gaps; for a wide gap
    (``δ / r_m`` near 1, a screw in a tube) it is an estimate, within the ±30 %
    the rigs' spreads give their air exchanges.
    """
    w = abs(n_rpm) * 2.0 * math.pi / 60.0
    d = r_o - r_i
    ta = w * w * 0.5 * (r_i + r_o) * d * d * d / (AIR_NU * AIR_NU)
    if ta < 1700.0:
        return 1.0
    if ta < 1e4:
        return 0.5 * 0.128 * ta**0.367
    return 0.5 * 0.409 * ta**0.241


@nb.njit(cache=True, inline="always")
def k_ratio_free_annulus(dT, r_i, r_o):  # pragma: no cover - numba
    """Free convection in a horizontal annulus: effective over molecular conductivity.

    Raithby & Hollands (1975), Incropera eqs 9.58-9.60:
    ``k_eff / k = 0.386 (Pr / (0.861 + Pr))^(1/4) Ra_c^(1/4)`` with
    ``Ra_c = [ln(r_o / r_i)]⁴ Ra_L / (L³ (D_i^(−3/5) + D_o^(−3/5))⁵)``, ``L = r_o − r_i``,
    ``Ra_L`` on ``L`` and ``|ΔT|`` between the cylinders; at least 1 (conduction).
    """
    L = r_o - r_i
    ra = _G / 300.0 * abs(dT) * L * L * L / (AIR_NU * AIR_ALPHA)
    s = (2.0 * r_i) ** -0.6 + (2.0 * r_o) ** -0.6
    rac = math.log(r_o / r_i) ** 4 * ra / (L * L * L * s**5)
    k = 0.386 * (AIR_PR / (0.861 + AIR_PR)) ** 0.25 * rac**0.25
    return k if k > 1.0 else 1.0


def g_annulus_conduction(r_i: float, r_o: float) -> float:
    """Conduction through the air of an annulus per metre [W/(m K)]: ``2π k / ln(r_o/r_i)``."""
    return 2.0 * math.pi * AIR_K / math.log(r_o / r_i)


def g_annulus_radiation(
    r_i: float, r_o: float, eps_i: float, eps_o: float, T: float = 25.0
) -> float:
    """Radiation between long concentric cylinders per metre [W/(m K)], linearised at ``T`` °C.

    ``q' = 2π r_i σ (T_i⁴ − T_o⁴) / (1/ε_i + (r_i/r_o)(1/ε_o − 1))`` (Incropera eq 13.25).
    """
    a = T + _T0
    resistance = 1.0 / eps_i + r_i / r_o * (1.0 / eps_o - 1.0)
    return 2.0 * math.pi * r_i * 4.0 * SIGMA * a**3 / resistance
