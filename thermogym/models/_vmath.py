"""Math that compiles to vector code: ``x ** y`` for the room model's power laws, min and max.

:func:`vmin` and :func:`vmax` are numba's builtins written out, so that they always inline
into a loop over lanes (branch-free kernels of the AXT211 and the room).

numba calls libm's ``pow`` once per value; LLVM cannot vectorise such a call without
Intel's SVML, so in the AXT211Room environment's lockstep kernel the radiator law
``|Δ/ΔT_ref|^n_rad`` (one ``pow`` per plant and RK4 stage, about 15 ns each) took half of
the step time. :func:`vpow` computes ``exp(y · ln x)`` from additions, multiplications,
fused multiply-adds, one division, comparisons and integer operations on the bit patterns
(no calls), so a loop over plants vectorises, and the scalar and the vectorised kernels,
which both call it, give bit-identical results (IEEE arithmetic; a fused multiply-add is
rounded once whether scalar or vector; on a CPU without FMA instructions LLVM calls libm's
``fma``, slower, same result).

Written here because no library provides it for numba without SVML. The method is the
textbook one (e.g. J.-M. Muller, *Elementary Functions: Algorithms and
Implementation*):
``x = 2^e m`` with ``m`` in ``[√½, √2)``, ``ln m = 2 atanh(s)``, ``s = (m − 1)/(m + 1)``
by its odd series; ``exp(t) = 2^k e^r`` with ``k = round(t/ln 2)`` and ``|r| ≤ ln2/2``,
``e^r`` by its Taylor series, ``ln 2`` split in two parts (Cody-Waite). The relative error
is a few units in the last place where ``|y ln x|`` is of order one (tested against
``numpy.power``: below 4e-15 on the room model's ranges); glibc's ``pow`` is accurate to
within one unit, so results differ from it in the last bits only.

Domain: ``x`` finite and non-negative; ``0 ** y`` is 0 for ``y > 0`` (the radiator law at
``Δ = 0``), and any ``x`` below 1e-200 counts as 0. A NaN or infinite ``x`` or ``y`` gives
NaN (never a silent finite value).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import cast

import numba as nb
from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

__all__ = ["vexp", "vlog", "vmax", "vmin", "vpow"]


def _bits_typing(typingctx, x):  # type: ignore[no-untyped-def]
    # the IEEE bit pattern of a float64 as int64 (an LLVM bitcast: vectorises)
    if x != types.float64:
        return None

    def codegen(context, builder, signature, args):  # type: ignore[no-untyped-def]
        return builder.bitcast(args[0], ir.IntType(64))

    return types.int64(types.float64), codegen


# numba's stubs type an intrinsic's call with its typing function's signature; inside
# compiled code it is called with the values alone
_bits = cast(Callable[[float], int], intrinsic(_bits_typing))


def _float_typing(typingctx, i):  # type: ignore[no-untyped-def]
    # the float64 with bit pattern i (int64)
    if i != types.int64:
        return None

    def codegen(context, builder, signature, args):  # type: ignore[no-untyped-def]
        return builder.bitcast(args[0], ir.DoubleType())

    return types.float64(types.int64), codegen


_float = cast(Callable[[int], float], intrinsic(_float_typing))


def _fma_typing(typingctx, a, b, c):  # type: ignore[no-untyped-def]
    # a·b + c rounded once (IEEE fused multiply-add: the same result scalar and vectorised)
    if not (a == b == c == types.float64):
        return None

    def codegen(context, builder, signature, args):  # type: ignore[no-untyped-def]
        d = ir.DoubleType()
        fty = ir.FunctionType(d, [d, d, d])
        fn = cgutils.get_or_insert_function(builder.module, fty, "llvm.fma.f64")
        return builder.call(fn, args)

    return types.float64(types.float64, types.float64, types.float64), codegen


_fma = cast(Callable[[float, float, float], float], intrinsic(_fma_typing))


_LN2_HI = 6.93147180369123816490e-01  # ln 2 with 21 trailing zero bits: k ln2_hi is exact
_LN2_LO = 1.90821492927058770002e-10  # ln 2 − _LN2_HI
_INV_LN2 = 1.44269504088896338700e00
_SQRT2 = 1.4142135623730951
_MAGIC = 6755399441055744.0  # 1.5 · 2^52: adding it rounds to an integer in the low bits
_MAGIC_BITS = 0x4338000000000000  # its bit pattern
_EXP_BIAS = 0x4330000000000000  # bit pattern of 2^52: OR an integer in, subtract 2^52
_TWO52 = 4503599627370496.0
_MANT = 0x000FFFFFFFFFFFFF
_ONE_BITS = 0x3FF0000000000000
_TINY = 1e-200
_INF = float("inf")


@nb.njit(cache=True, inline="always")
def vmax(a: float, b: float) -> float:
    """``max(a, b)`` as numba's builtin (``b if b > a else a``; NaN in ``a`` propagates).

    Written out: numba's builtin is a separate overload that does not always inline into
    a loop, and a loop with a call in it does not vectorise.
    """
    return b if b > a else a


@nb.njit(cache=True, inline="always")
def vmin(a: float, b: float) -> float:
    """``min(a, b)`` as numba's builtin (``b if b < a else a``), written out (see :func:`vmax`)."""
    return b if b < a else a


@nb.njit(cache=True, inline="always")
def vlog(x: float) -> float:
    """Natural logarithm of a positive normal ``x`` (no check; see the module docstring)."""
    b = _bits(x)
    m = _float((b & _MANT) | _ONE_BITS)  # mantissa in [1, 2)
    e = _float(_EXP_BIAS | ((b >> 52) & 0x7FF)) - (_TWO52 + 1023.0)  # unbiased exponent
    hi = m > _SQRT2
    m = 0.5 * m if hi else m  # [√½, √2)
    e = e + 1.0 if hi else e
    s = (m - 1.0) / (m + 1.0)
    z = s * s
    # 2 atanh(s) = 2 (s + s³/3 + s⁵/5 + ...), |s| ≤ 0.1716: terms to s^23 (< 1e-18
    # relative); p(z) = Σ 2/(2j + 3) z^j, j = 0..10, by Estrin's scheme (a short
    # dependency chain: what a single plant's scalar kernel waits for)
    z2 = z * z
    z4 = z2 * z2
    z8 = z4 * z4
    a0 = _fma(2.0 / 5.0, z, 2.0 / 3.0)
    a1 = _fma(2.0 / 9.0, z, 2.0 / 7.0)
    a2 = _fma(2.0 / 13.0, z, 2.0 / 11.0)
    a3 = _fma(2.0 / 17.0, z, 2.0 / 15.0)
    a4 = _fma(2.0 / 21.0, z, 2.0 / 19.0)
    b0 = _fma(a1, z2, a0)
    b1 = _fma(a3, z2, a2)
    b2 = _fma(2.0 / 23.0, z2, a4)
    p = _fma(b2, z8, _fma(b1, z4, b0))
    lnm = 2.0 * s + s * (z * p)
    return e * _LN2_HI + (e * _LN2_LO + lnm)


@nb.njit(cache=True, inline="always")
def vexp(t: float) -> float:
    """``exp(t)``: 0 below −700, ``inf`` above 700, NaN for NaN (see the module docstring)."""
    tc = min(max(t, -700.0), 700.0)
    kk = tc * _INV_LN2 + _MAGIC  # round(t / ln 2) in the low bits
    k = kk - _MAGIC
    r = (tc - k * _LN2_HI) - k * _LN2_LO  # |r| ≤ ln2/2 (+ rounding)
    # e^r by Taylor to r^14 / 14! (< 4e-18 at |r| = ln2/2): q(r) = Σ r^j / (j + 2)!,
    # j = 0..12, by Estrin's scheme
    r2 = r * r
    r4 = r2 * r2
    r8 = r4 * r4
    a0 = _fma(1.0 / 6.0, r, 0.5)
    a1 = _fma(1.0 / 120.0, r, 1.0 / 24.0)
    a2 = _fma(1.0 / 5040.0, r, 1.0 / 720.0)
    a3 = _fma(1.0 / 362880.0, r, 1.0 / 40320.0)
    a4 = _fma(1.0 / 39916800.0, r, 1.0 / 3628800.0)
    a5 = _fma(1.0 / 6227020800.0, r, 1.0 / 479001600.0)
    b0 = _fma(a1, r2, a0)
    b1 = _fma(a3, r2, a2)
    b2 = _fma(a5, r2, a4)
    c0 = _fma(b1, r4, b0)
    c1 = _fma(1.0 / 87178291200.0, r4, b2)
    q = _fma(c1, r8, c0)
    er = 1.0 + (r + r * (r * q))
    scale = _float(((_bits(kk) - _MAGIC_BITS) + 1023) << 52)  # 2^k, |k| ≤ 1010
    y = er * scale
    y = 0.0 if t < -700.0 else y
    y = _INF if t > 700.0 else y
    return y + (t - t)  # NaN stays NaN (t − t is 0 for finite t)


@nb.njit(cache=True, inline="always")
def vpow(x: float, y: float) -> float:
    """``x ** y`` for finite ``x ≥ 0`` and ``y``, branch-free (see the module docstring).

    Examples
    --------
    >>> from thermogym.models._vmath import vpow
    >>> round(vpow(0.5, 1.3), 15) == round(0.5 ** 1.3, 15)
    True
    """
    xs = x if x >= _TINY else 1.0  # keep the logarithm finite; the select below gives 0
    r = vexp(y * vlog(xs))
    r = r if x >= _TINY else (0.0 if y > 0.0 else (1.0 if y == 0.0 else _INF))
    return r + (x - x)  # NaN or infinite x: NaN
