"""Physical effects built into a model's equations, off by default.

Some effects of the vocabulary in DESIGN.md change a plant's equations from
the inside (latent heat of the wax, convection growing with temperature
difference, a supply with internal resistance, ...). A model that can carry
such an effect declares it as a :class:`PhysicalEffect`: a few extra
parameters whose *nominal* value is the neutral one (the effect is absent).

The numerical kernel always receives the *full* parameter vector (base
parameters followed by every effect parameter); a model instance built with
``effects=("phase_change",)`` exposes the base parameters plus that effect's
parameters, and fills the others with their neutral values.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from thermogym.errors import UnknownNameError
from thermogym.models.base import Parameter

__all__ = ["EffectLayout", "PhysicalEffect"]


@dataclass(frozen=True)
class PhysicalEffect:
    """An effect a model's equations can include.

    Parameters
    ----------
    name : str
        Name from the effect vocabulary (DESIGN.md).
    explanation : str
        Plain-language physical explanation shown in diagnosis reports.
    parameters : tuple of Parameter
        Extra parameters; each nominal value switches the effect off.
    """

    name: str
    explanation: str
    parameters: tuple[Parameter, ...]


class EffectLayout:
    """Map between a model's public ``theta`` and its kernel's full vector.

    Parameters
    ----------
    base : sequence of Parameter
        Parameters every instance has.
    available : mapping of str to PhysicalEffect
        Effects the kernel implements, in kernel order.
    selected : sequence of str
        Effects this instance exposes.
    owner : str
        Model name for error messages.
    """

    def __init__(
        self,
        base: Sequence[Parameter],
        available: Mapping[str, PhysicalEffect],
        selected: Sequence[str],
        owner: str,
    ) -> None:
        unknown = [e for e in selected if e not in available]
        if unknown:
            raise UnknownNameError(
                f"model {owner!r} cannot include effect(s) {unknown}; it implements "
                f"{list(available)}"
            )
        self.selected = tuple(dict.fromkeys(selected))
        full = list(base)
        for eff in available.values():
            full.extend(eff.parameters)
        self.full: tuple[Parameter, ...] = tuple(full)
        public = list(base)
        for name in self.selected:
            public.extend(available[name].parameters)
        self.public: tuple[Parameter, ...] = tuple(public)
        full_index = {p.name: i for i, p in enumerate(self.full)}
        self._cols = np.array([full_index[p.name] for p in self.public], dtype=np.int64)
        self._neutral = np.array([p.nominal for p in self.full], dtype=float)

    def full_theta(self, theta: NDArray[np.float64]) -> NDArray[np.float64]:
        """Expand a public batch (B, P) to the kernel's full batch (B, P_full)."""
        out = np.repeat(self._neutral[None, :], theta.shape[0], axis=0)
        out[:, self._cols] = theta
        return out
