"""Numerics shared by the machine-tool rigs' true plants (strut, spindle); no plant equations.

Factors on physical estimates with a log-uniform spread, finite-volume weights
of an interval on a segmented body, and an accumulator of symmetric
conductances.

Examples
--------
>>> import numpy as np
>>> segment_weights(np.linspace(0.0, 1.0, 5), 0.2, 0.6).round(2).tolist()
[0.12, 0.62, 0.25, 0.0]
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from thermogym.errors import ParameterError
from thermogym.rigs.base import PhysicalParameter

__all__ = ["Links", "RatioParameter", "ratio_parameters", "segment_weights"]

#: A spread table: factor -> (low, high, what it multiplies and why).
Spread = Mapping[str, tuple[float, float, str]]


@dataclass(frozen=True)
class RatioParameter(PhysicalParameter):
    """A physical estimate whose true value lies between two ratios of it, log-uniformly.

    A spread such as "+200/−70 %" (paper 000's appendix) says the true value
    lies between 0.3 and 3 times the estimate with no preferred side: a
    log-uniform draw treats ×3 and ÷3.3 alike. ``nominal`` is the estimate;
    :meth:`draw` returns ``nominal · exp(U(ln low, ln high))``.

    Parameters
    ----------
    low, high : float
        Ratios bounding the true value (``0 < low <= 1 <= high``).

    Examples
    --------
    >>> p = RatioParameter("loss", 1.0, "1", "loss factor", "estimate", low=0.3, high=3.0)
    >>> v = p.draw(np.random.default_rng(0), 1000)
    >>> bool(v.min() >= 0.3 and v.max() <= 3.0)
    True
    >>> bool(abs(np.log(v).mean() - (np.log(0.3) + np.log(3.0)) / 2) < 0.05)  # uniform in log
    True
    """

    low: float = 1.0
    high: float = 1.0

    def __post_init__(self) -> None:
        if not (0 < self.low <= 1.0 <= self.high < math.inf):
            raise ParameterError(
                f"{self.name}: ratios [{self.low}, {self.high}], expected 0 < low <= 1 <= high"
            )

    def draw(self, rng: np.random.Generator, n: int) -> NDArray[np.float64]:
        """``n`` values (one uniform number each, always drawn)."""
        z = rng.uniform(math.log(self.low), math.log(self.high), n)
        return self.nominal * np.exp(z)


def ratio_parameters(spread: Spread, source: str) -> tuple[RatioParameter, ...]:
    """Factors on the physical estimates (nominal 1) from a spread table."""
    return tuple(
        RatioParameter(k, 1.0, "1", what, source, low=lo, high=hi, spread_source=what, lower=0.0)
        for k, (lo, hi, what) in spread.items()
    )


def segment_weights(edges: NDArray[np.float64], a: float, b: float) -> NDArray[np.float64]:
    """Share of the interval ``[a, b]`` lying in each segment ``[edges[i], edges[i+1]]``."""
    lo = np.clip(edges[:-1], a, b)
    hi = np.clip(edges[1:], a, b)
    return np.maximum(hi - lo, 0.0) / max(b - a, 1e-12)


class Links:
    """Symmetric conductances of a batch of B networks, accumulated link by link."""

    def __init__(self, B: int) -> None:
        self.B = B
        self._g: dict[tuple[int, int], NDArray[np.float64]] = {}

    def add(self, i: int, j: int, g: Any) -> None:
        """Add conductance ``g`` [W/K] (a number or shape (B,)) between nodes ``i`` and ``j``."""
        if i == j:
            return
        key = (min(i, j), max(i, j))
        self._g[key] = self._g.get(key, np.zeros(self.B)) + np.broadcast_to(g, (self.B,))

    def spread(self, i: int, first: int, weights: NDArray[np.float64], g: Any) -> None:
        """Add ``g`` between node ``i`` and segments ``first + k`` in proportion to ``weights``."""
        for k in np.flatnonzero(weights > 0):
            self.add(i, first + int(k), np.asarray(g) * weights[k])

    def arrays(self) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.float64]]:
        """``(i, j, G)`` with ``G`` of shape (B, n_links)."""
        keys = sorted(self._g)
        if not keys:
            return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((self.B, 0))
        ei = np.array([k[0] for k in keys], dtype=np.int64)
        ej = np.array([k[1] for k in keys], dtype=np.int64)
        return ei, ej, np.ascontiguousarray(np.column_stack([self._g[k] for k in keys]))

    def totals(self, n: int) -> NDArray[np.float64]:
        """Sum of the conductances at each of ``n`` nodes, shape (B, n)."""
        tot = np.zeros((self.B, n))
        for (i, j), g in self._g.items():
            tot[:, i] += g
            tot[:, j] += g
        return tot
