"""Gymnasium environments wrapping the identified plant models.

``import thermogym`` (and so ``import thermogym.envs``) registers the
environments (versioned IDs; a behaviour change means a new version; the
table is :data:`thermogym.ENVIRONMENTS`):

==============================  ===========================================================
ID                              plant
==============================  ===========================================================
``thermogym/AXT211Valve-v0``    valve positioning with the AXT211 wax actuator (paper 002)
``thermogym/AXT211Room-v0``     room temperature through an AXT211-driven radiator valve
``thermogym/SpindleThermal-v0`` spindle speed under bearing-temperature limits (paper 001)
``thermogym/StrutThermal-v0``   feed rate and thermal-elongation compensation (paper 000)
``thermogym/TCLab-v0``          the two-heater Temperature Control Lab, identified from
                                real recordings
``thermogym/IdentifiedPlant-v0`` any identified linear model of a user's own plant
                                (``params=FIT`` of ss, foptd, sopdt, arx, armax, oe, bj)
==============================  ===========================================================

Without importing this module first, ``gymnasium.make("thermogym.envs:thermogym/TCLab-v0")``
imports it (Gymnasium's ``module:ID`` form). Each has a native vector version
(``gymnasium.make_vec(ID, num_envs=N, vectorization_mode="vector_entry_point")``)
that steps all ``N`` plants in one compiled call. Every environment accepts
``params=FitResult | path | dict`` (the identified model) or ``plant="rig"``
(the virtual rig's true plant), returns the KPIs of DESIGN.md in
``info["kpis"]`` at the end of an episode, and terminates only on a safety
trip (truncation at the horizon). Wrappers: :class:`ParameterRefresh`,
:class:`DomainRandomization` (:mod:`thermogym.envs.wrappers`); KPI
arithmetic: :mod:`thermogym.envs.kpis`.

Examples
--------
>>> import gymnasium as gym
>>> import thermogym.envs
>>> env = gym.make("thermogym/TCLab-v0")
>>> obs, info = env.reset(seed=1)
>>> env.unwrapped.obs_names
('T1', 'T2', 'T1_set', 'T2_set', 'Q1_prev', 'Q2_prev')
"""

from __future__ import annotations

from typing import Any

from thermogym import ENVIRONMENTS, register_environments

__all__ = ["ENV_IDS", "DomainRandomization", "ParameterRefresh"]

ENV_IDS: tuple[str, ...] = tuple(ENVIRONMENTS)

register_environments()  # already done by ``import thermogym``; kept for explicitness


def __getattr__(name: str) -> Any:
    # wrappers are imported on first use so that registration stays cheap
    if name in ("DomainRandomization", "ParameterRefresh"):
        from thermogym.envs import wrappers

        return getattr(wrappers, name)
    raise AttributeError(f"module 'thermogym.envs' has no attribute {name!r}")
