"""Shared integrator generators: classical Runge-Kutta 4 built around a model's right-hand side.

A plant's dynamics module writes its equations once, as a numba ``inline="always"``
function ``rhs(x, args) -> (dx, aux)`` on a tuple of states ``x`` (``dx`` a tuple of the
same length, ``aux`` any by-product the callers want at the stage's start, e.g. a
resistance). Every variant of the integration is then made here from that one function:

* :func:`rk4_step` — one fixed step of one system (the scalar kernels; the batched
  structure-of-arrays and lockstep-lane kernels call it inside their loops over systems,
  and since it is branch-free whenever ``rhs`` is, those loops vectorise);
* :func:`rk4_stage_input`, :func:`rk4_accumulate`, :func:`rk4_finish` — the same step cut
  into its four stages, for kernels that run each stage over a whole block of systems in a
  loop of its own (the AXT211Room environment's lockstep).

Both give the same floating-point operations in the same order: stage inputs
``x + (h/2) k₁``, ``x + (h/2) k₂``, ``x + h k₃``; sum ``((k₁ + 2k₂) + 2k₃) + k₄``; update
``x + (h/6) sum``. numba does not contract to fused multiply-adds, so a system gives the
same bits whichever variant steps it.

The element-wise tuple helpers (:func:`axpy`, :func:`loader`) are generated for each tuple
length from a one-line template: numba has no element-wise arithmetic on tuples, and
tuples (not arrays) keep a system's states in registers.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numba as nb
from numba import types
from numba.extending import overload

__all__ = ["axpy", "loader", "rk4_accumulate", "rk4_finish", "rk4_stage_input", "rk4_step"]

_GENERATED: dict[tuple[str, int], Callable[..., Any]] = {}


def _generate(name: str, n: int, args: str, item: str) -> Callable[..., Any]:
    # a function `def f(args): return (item(0), item(1), ..., item(n-1),)`, made once per n
    key = (name, n)
    if key not in _GENERATED:
        body = "".join(item.format(i=i) + ", " for i in range(n))
        ns: dict[str, Any] = {}
        exec(f"def {name}({args}):\n    return ({body})\n", ns)
        _GENERATED[key] = ns[name]
    return _GENERATED[key]


def axpy(x: tuple[float, ...], a: float, k: tuple[float, ...]) -> tuple[float, ...]:
    """Element-wise ``x + a·k`` of two tuples of equal length (compiled inline in numba).

    Examples
    --------
    >>> axpy((1.0, 2.0), 0.5, (2.0, 4.0))
    (2.0, 4.0)
    """
    return tuple(xi + a * ki for xi, ki in zip(x, k, strict=True))


@overload(axpy, inline="always")
def _axpy_numba(x, a, k):  # type: ignore[no-untyped-def]
    # (no annotations: numba compares the signature with the generated implementation's)
    if isinstance(x, types.BaseTuple) and isinstance(k, types.BaseTuple) and len(x) == len(k):
        return _generate("axpy", len(x), "x, a, k", "x[{i}] + a * k[{i}]")
    return None


def loader(n: int) -> Any:
    """Compiled inline ``load(wb, o, W, i)``: rows ``o .. o+n-1`` of lane ``i`` as a tuple.

    A block of ``W`` lanes lies in one flat array ``wb``, row ``r`` of lane ``i`` at
    ``wb[r * W + i]`` (the lockstep kernels' layout).
    """
    f = _generate(f"load{n}", n, "wb, o, W, i", "wb[(o + {i}) * W + i]")
    return nb.njit(inline="always")(f)


def rk4_step(rhs: Any) -> Any:
    """One classical RK4 step ``(x, h, args) -> (x_new, aux)`` of ``rhs(x, args) -> (dx, aux)``.

    ``aux`` is that of the first stage (at ``x``). The returned function is compiled inline
    into its callers (numba ``inline="always"``).
    """

    @nb.njit(inline="always")
    def step(x, h, args):  # type: ignore[no-untyped-def]  # pragma: no cover - numba
        hh = 0.5 * h
        k1, aux = rhs(x, args)
        k2, _ = rhs(axpy(x, hh, k1), args)
        k3, _ = rhs(axpy(x, hh, k2), args)
        k4, _ = rhs(axpy(x, h, k3), args)
        return rk4_finish(x, h, axpy(axpy(axpy(k1, 2.0, k2), 2.0, k3), 1.0, k4)), aux

    return step


@nb.njit(inline="always")
def rk4_stage_input(x, k, h, j):  # type: ignore[no-untyped-def]  # pragma: no cover - numba
    """Input of stage ``j`` (1-4) from the step's start ``x`` and the previous stage's ``k``.

    Stage 1 takes ``x`` itself (``k`` is ignored; pass ``x``).
    """
    if j == 1:
        return x
    return axpy(x, h if j == 4 else 0.5 * h, k)


@nb.njit(inline="always")
def rk4_accumulate(s, k, j):  # type: ignore[no-untyped-def]  # pragma: no cover - numba
    """The weighted stage sum after stage ``j``: ``k`` at stage 1, then ``s + w_j k``."""
    if j == 1:
        return k
    return axpy(s, 1.0 if j == 4 else 2.0, k)


@nb.njit(inline="always")
def rk4_finish(x, h, s):  # type: ignore[no-untyped-def]  # pragma: no cover - numba
    """The state after the step, ``x + (h/6)·s`` with ``s`` the weighted stage sum."""
    return axpy(x, h / 6.0, s)
