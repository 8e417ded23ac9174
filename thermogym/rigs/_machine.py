"""Numerics shared by the machine-tool rigs' true plants (strut, spindle); no plant equations.

Specimen factors drawn from a spread table, finite-volume weights of an
interval on a segmented body, and an accumulator of symmetric conductances.

Examples
--------
>>> import numpy as np
>>> segment_weights(np.linspace(0.0, 1.0, 5), 0.2, 0.6).round(2).tolist()
[0.12, 0.62, 0.25, 0.0]
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from thermogym._checks import integer
from thermogym.errors import ShapeError, UnknownNameError

__all__ = ["Links", "check_factors", "draw_factors", "nominal_factors", "segment_weights"]

#: A spread table: factor -> (low, high, what it multiplies and why).
Spread = Mapping[str, tuple[float, float, str]]


def nominal_factors(spread: Spread, n: int = 1) -> dict[str, NDArray[np.float64]]:
    """``n`` specimens at the physical estimates (every factor 1)."""
    n = integer("n", n, lo=1)
    return {k: np.ones(n) for k in spread}


def draw_factors(spread: Spread, rng: np.random.Generator, n: int = 1) -> dict[str, Any]:
    """``n`` specimens, each factor drawn log-uniformly in its ``[low, high]``.

    A ratio's uncertainty such as "+200/−70 %" says the true value lies between
    0.3 and 3 times the estimate, with no preferred side: log-uniform draws
    treat ×3 and ÷3.3 alike.
    """
    n = integer("n", n, lo=1)
    return {
        k: np.exp(rng.uniform(math.log(lo), math.log(hi), n)) for k, (lo, hi, _) in spread.items()
    }


def check_factors(rig: str, spread: Spread, specimen: Mapping[str, Any]) -> dict[str, Any]:
    """Specimen factors as arrays of one common length B (missing ones are 1).

    Raises
    ------
    UnknownNameError
        A factor that is not in the spread table.
    ShapeError
        Lengths that differ, or values that are not finite and positive.
    """
    bad = [k for k in specimen if k not in spread]
    if bad:
        raise UnknownNameError(
            f"{rig} specimen factor(s) {bad} unknown; factors are {list(spread)}"
        )
    arrs = {k: np.atleast_1d(np.asarray(specimen.get(k, 1.0), dtype=float)) for k in spread}
    B = max(a.size for a in arrs.values())
    out = {}
    for k, a in arrs.items():
        if a.ndim != 1 or a.size not in (1, B) or not np.all(np.isfinite(a)) or np.any(a <= 0):
            raise ShapeError(
                f"{rig} specimen factor {k!r} is {a.tolist()}; expected positive numbers, "
                f"one or {B} of them"
            )
        out[k] = np.broadcast_to(a, (B,)).copy()
    return out


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
