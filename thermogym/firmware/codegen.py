"""The observer in the firmware's coordinates, its memory footprint and its C header.

Pure functions (no file I/O): :func:`firmware_model` turns an
:class:`~thermogym.estimation.ObserverMatrices` into the scaled,
offset form the C code runs, :func:`footprint` estimates flash and static RAM
on the target from the dimensions, :func:`render_header` writes ``vs_model.h``.

Coordinates. The C observer works in deviations from an operating point of
the model and in scaled units, which keeps float32 numbers of order one::

    u_s = (u − u_off) / u_scale,   z_s = (z − z_off) / z_scale,   y = y_off + y_scale · y_s
    x_s = x − x_off,   x_off = (I − A)⁻¹ B u_off   (the model's equilibrium at u_off)

with ``z_off = C_z x_off + D_z u_off`` and ``y_off = C_h x_off + D_h u_off``, so
the innovation at the operating point is zero and the observer equations keep
their form exactly. The state is expressed in the ordered real Schur basis
of ``A`` (:func:`ordered_schur`), an orthogonal change of coordinates.
Offsets default to 25 °C for temperatures and 0 otherwise; scales to 1000
for rpm, 10 for temperatures, 1 otherwise. The state matrix is
stored as ``M = A − I``, computed in double precision: storing ``A`` in
float32 and subtracting ``I`` on the target would lose the slow modes'
decay rates (``1 − λ ≈ 1e-4`` against a float32 resolution of 6e-8 of ``λ``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.linalg
import scipy.linalg.lapack
from numpy.typing import NDArray

from thermogym._checks import positive
from thermogym.errors import ConfigError, ParameterError
from thermogym.estimation import ObserverMatrices

__all__ = [
    "TARGETS",
    "ChannelSpec",
    "FirmwareModel",
    "Footprint",
    "Target",
    "budget_target",
    "c_literal",
    "check_budget",
    "firmware_model",
    "footprint",
    "ordered_schur",
    "render_header",
]

_TEMPERATURE_UNITS = ("°C", "degC", "C", "K")


@dataclass(frozen=True)
class Target:
    """Memory of a microcontroller target.

    Attributes
    ----------
    name : str
    flash_bytes : int
        Program memory [byte].
    ram_bytes : int
        SRAM [byte].
    bootloader_bytes : int
        Flash kept free for a bootloader [byte].
    stack_reserve_bytes : int
        SRAM kept free for the stack and the application's own buffers [byte].
    f_cpu_hz : float
        Clock [Hz].
    """

    name: str
    flash_bytes: int
    ram_bytes: int
    bootloader_bytes: int
    stack_reserve_bytes: int
    f_cpu_hz: float

    @property
    def flash_available(self) -> int:
        """Flash the observer may use [byte]."""
        return self.flash_bytes - self.bootloader_bytes

    @property
    def ram_available(self) -> int:
        """Static RAM the observer may use [byte]."""
        return self.ram_bytes - self.stack_reserve_bytes


#: Known targets. The ATmega328P of paper 001's module (Arduino Bluno Beetle):
#: 32 KB flash of which 512 B hold the Optiboot boot loader, 2 KB SRAM of which
#: 512 B are left to the stack, the UART/Bluetooth and ADC drivers.
TARGETS: dict[str, Target] = {
    "atmega328p": Target("atmega328p", 32768, 2048, 512, 512, 16e6),
}

#: Flash of the observer and RTD code with the avr-libc float routines they pull in and
#: the C runtime, without the model tables [byte]: avr-gcc 5.4 -Os, avr-size of the
#: probe program (thermogym/firmware/c/avr_probe.c) less its tables, rounded up
#: (5496 B measured without measured channels).
CODE_FLASH_BYTES = 5600
#: Extra code of the innovation path when channels are measured [byte] (1084 B measured).
CODE_FLASH_MEASURED_BYTES = 1100
#: Static RAM of the C runtime and the probe besides the observer instance [byte]
#: (avr-size: 160 B for an instance of 134 B).
BASE_RAM_BYTES = 26


@dataclass(frozen=True)
class ChannelSpec:
    """One channel of the firmware: name, unit, offset, scale and valid range."""

    name: str
    unit: str
    offset: float
    scale: float
    lower: float = -math.inf
    upper: float = math.inf


@dataclass(frozen=True)
class FirmwareModel:
    """The observer in the firmware's scaled deviation coordinates.

    Attributes
    ----------
    M, B, G, Cz, Dz, Ch, Dh, F : ndarray
        ``M = A − I`` and the other observer matrices, scaled.
    Nu, Nz : ndarray or None
        Rest-state map ``x_s = Nu u_s + Nz z_s`` (None without a rest state).
    u, z, y : tuple of ChannelSpec
        Exogenous, measured and hidden channels.
    dt : float
        Sample period [s].
    x_off : ndarray, shape (n,)
        Operating point of the state, in the firmware's state basis.
    basis : ndarray, shape (n, n)
        ``Z`` of the state basis: model state ``x = Z x_firmware``.
    """

    M: NDArray[np.float64]
    B: NDArray[np.float64]
    G: NDArray[np.float64]
    Cz: NDArray[np.float64]
    Dz: NDArray[np.float64]
    Ch: NDArray[np.float64]
    Dh: NDArray[np.float64]
    F: NDArray[np.float64]
    Nu: NDArray[np.float64] | None
    Nz: NDArray[np.float64] | None
    u: tuple[ChannelSpec, ...]
    z: tuple[ChannelSpec, ...]
    y: tuple[ChannelSpec, ...]
    dt: float
    x_off: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    basis: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 0)))

    @property
    def dims(self) -> tuple[int, int, int, int]:
        """``(n_states, n_exogenous, n_measured, n_hidden)``."""
        return (self.M.shape[0], self.B.shape[1], self.Cz.shape[0], self.Ch.shape[0])

    @property
    def has_dz(self) -> bool:
        """Whether the measured channels have a feedthrough."""
        return bool(np.any(self.Dz != 0))

    @property
    def has_dh(self) -> bool:
        """Whether the hidden channels have a feedthrough."""
        return bool(np.any(self.Dh != 0))

    @property
    def has_reset(self) -> bool:
        """Whether the model has a rest state (``vs_reset``)."""
        return self.Nu is not None

    def footprint(self, target: str | Target = "atmega328p") -> Footprint:
        """Estimated flash and static RAM of this observer on ``target``."""
        n, m, q, p = self.dims
        return footprint(
            n, m, q, p, has_reset=self.has_reset, has_dz=self.has_dz, has_dh=self.has_dh,
            target=target,
        )  # fmt: skip


def ordered_schur(A: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Real Schur form ``A = Z T Zᵀ`` with the slowest modes last (|λ| ascending).

    In this orthogonal basis the eigenvalues are the diagonal (blocks) of ``T``:
    rounding the off-diagonal entries to float32 does not move them, and
    ``M = T − I`` stores each ``λ − 1`` to float32's *relative* precision, so
    the slow modes that set the steady temperatures keep their time constants
    (in a general basis, rounding ``M`` moves ``1 − λ ≈ 1e-4`` by
    ``eps·‖M‖·κ``). With the slowest mode in the last row, that row's
    increment has no terms of faster modes, whose rounding errors the slow
    mode would otherwise integrate. Blocks are moved with LAPACK's ``dtrexc``.

    Examples
    --------
    >>> import numpy as np
    >>> T, Z = ordered_schur(np.array([[0.999, 0.2], [0.0, 0.5]]))
    >>> np.round(np.diag(T), 3).tolist(), bool(np.allclose(Z @ T @ Z.T, [[0.999, 0.2], [0, 0.5]]))
    ([0.5, 0.999], True)
    """
    T, Z = scipy.linalg.schur(np.asarray(A, dtype=float), output="real")
    n = T.shape[0]

    def blocks(T: NDArray[np.float64]) -> list[tuple[int, int, float]]:
        out, i = [], 0
        while i < n:
            size = 2 if i + 1 < n and T[i + 1, i] != 0.0 else 1
            lam = np.linalg.eigvals(T[i : i + size, i : i + size])
            out.append((i, size, float(np.abs(lam).max())))
            i += size
        return out

    end = n  # rows [end, n) hold the modes already placed, slowest at the bottom
    while end > 0:
        cand = [b for b in blocks(T) if b[0] + b[1] <= end]
        start, size, _ = max(cand, key=lambda b: b[2])
        target = end - size
        if start != target:
            T, Z, info = scipy.linalg.lapack.dtrexc(T, Z, start + 1, target + 1)
            if info != 0:  # a swap too ill-conditioned: keep the order reached
                break
            # dtrexc may re-split a block; recompute the block that now ends at `end`
            size = next((b[1] for b in blocks(T) if b[0] + b[1] == end), size)
        end -= size
    return T, Z


def _default_offset(unit: str) -> float:
    return 25.0 if unit in _TEMPERATURE_UNITS else 0.0


def _default_scale(unit: str) -> float:
    if unit == "rpm":
        return 1000.0
    if unit in _TEMPERATURE_UNITS:
        return 10.0
    return 1.0


def firmware_model(
    obs: ObserverMatrices,
    *,
    offsets: Mapping[str, float] | None = None,
    scales: Mapping[str, float] | None = None,
    schur: bool = True,
) -> FirmwareModel:
    """Transform an observer into the firmware's scaled deviation coordinates.

    Parameters
    ----------
    obs : ObserverMatrices
        From :meth:`VirtualSensor.observer_matrices`.
    offsets : mapping, optional
        Operating point of exogenous channels ``{name: value}`` (physical
        units); the measured and hidden offsets follow from the model.
    scales : mapping, optional
        Scale of any channel ``{name: value}`` (physical unit per scaled unit).
    schur : bool
        Express the state in the ordered real Schur basis of ``A``
        (:func:`ordered_schur`; an orthogonal change of coordinates that
        keeps float32 from moving the slow modes). ``False`` keeps the
        model's own state coordinates.

    Returns
    -------
    FirmwareModel

    Raises
    ------
    ConfigError
        Unknown channel names, non-positive scales.

    Examples
    --------
    >>> import numpy as np
    >>> from thermogym.models.linear import StateSpaceModel
    >>> from thermogym.estimation import VirtualSensor
    >>> m = StateSpaceModel.from_matrices([[0.9]], [[0.1]], [[1.0]], dt=1.0,
    ...                                   inputs=["T_in"], outputs=["T_out"],
    ...                                   units={"T_in": "°C", "T_out": "°C"})
    >>> fm = firmware_model(VirtualSensor(m).observer_matrices())
    >>> fm.u[0].offset, round(fm.y[0].offset, 9), round(float(fm.M[0, 0]), 6)
    (25.0, 25.0, -0.1)
    """
    n, m, _, _ = obs.dims
    names = (*obs.exogenous, *obs.measured, *obs.hidden)
    offs = dict(offsets or {})
    scl = dict(scales or {})
    bad = [k for k in offs if k not in obs.exogenous]
    if bad:
        raise ConfigError(
            f"offsets given for {bad}; offsets are set on exogenous channels "
            f"{list(obs.exogenous)} (the others follow from the model)"
        )
    bad = [k for k in scl if k not in names]
    if bad:
        raise ConfigError(f"scales given for unknown channel(s) {bad}; channels are {list(names)}")
    for k, v in scl.items():
        positive(f"scale of {k!r}", v, error=ConfigError, text=False)
    unit = obs.units
    u_off = np.array([float(offs.get(s, _default_offset(unit.get(s, "1")))) for s in obs.exogenous])
    # operating point: the model's equilibrium at u_off (zero innovation there)
    try:
        x_off = np.linalg.solve(np.eye(n) - obs.A, obs.B @ u_off)
        if not np.isfinite(x_off).all():
            raise np.linalg.LinAlgError
    except np.linalg.LinAlgError:
        if np.any(u_off != 0):
            raise ParameterError(
                "the model has an integrating mode (I − A singular): it has no equilibrium at "
                "the offsets; pass offsets of 0 for every exogenous channel"
            ) from None
        x_off = np.zeros(n)
    # the model's constant output terms (its operating point) belong to the offsets
    z_off = obs.z_const + obs.Cz @ x_off + obs.Dz @ u_off
    y_off = obs.y_const + obs.Ch @ x_off + obs.Dh @ u_off

    def sc(s: str) -> float:
        return float(scl.get(s, _default_scale(unit.get(s, "1"))))

    su = np.array([sc(s) for s in obs.exogenous])
    sz = np.array([sc(s) for s in obs.measured])
    sy = np.array([sc(s) for s in obs.hidden])
    # state basis: ordered real Schur form of A, x = Z x_s (orthogonal, exact)
    if schur:
        T, Z = ordered_schur(obs.A)
    else:
        T, Z = obs.A.copy(), np.eye(n)
    # u = u_off + Su u_s, z = z_off + Sz z_s, y = y_off + Sy y_s
    Mx = T - np.eye(n)
    B = Z.T @ obs.B * su
    G = Z.T @ obs.G * sz
    Cz = obs.Cz @ Z / sz[:, None]
    Dz = obs.Dz * su / sz[:, None]
    Ch = obs.Ch @ Z / sy[:, None]
    Dh = obs.Dh * su / sy[:, None]
    F = obs.F * sz / sy[:, None]
    if obs.N is not None:
        # the rest state in deviations: x_s = N [u; z] − x_off, and N [u_off; z_off] = x_off
        Nu = Z.T @ obs.N[:, :m] * su
        Nz = Z.T @ obs.N[:, m:] * sz
    else:
        Nu = Nz = None
    lo, hi = obs.lower, obs.upper
    u_spec = tuple(
        ChannelSpec(s, unit.get(s, "1"), float(u_off[j]), float(su[j]), float(lo[j]), float(hi[j]))
        for j, s in enumerate(obs.exogenous)
    )
    z_spec = tuple(
        ChannelSpec(
            s, unit.get(s, "1"), float(z_off[j]), float(sz[j]), float(lo[m + j]), float(hi[m + j])
        )
        for j, s in enumerate(obs.measured)
    )
    y_spec = tuple(
        ChannelSpec(s, unit.get(s, "1"), float(y_off[j]), float(sy[j]))
        for j, s in enumerate(obs.hidden)
    )
    return FirmwareModel(
        Mx, B, G, Cz, Dz, Ch, Dh, F, Nu, Nz, u_spec, z_spec, y_spec, float(obs.dt), Z.T @ x_off, Z
    )


# =================================================================== footprint
@dataclass(frozen=True)
class Footprint:
    """Estimated memory of the observer on a target.

    Attributes
    ----------
    tables_bytes : int
        Model tables in flash [byte].
    code_bytes : int
        Observer and RTD code with the float routines [byte].
    flash_bytes : int
        ``tables_bytes + code_bytes``.
    ram_bytes : int
        Static RAM: one observer instance and the runtime [byte].
    target : Target
    """

    tables_bytes: int
    code_bytes: int
    flash_bytes: int
    ram_bytes: int
    target: Target

    @property
    def flash_excess(self) -> int:
        """Bytes of flash beyond what the target offers (≤ 0: fits)."""
        return self.flash_bytes - self.target.flash_available

    @property
    def ram_excess(self) -> int:
        """Bytes of static RAM beyond what the target offers (≤ 0: fits)."""
        return self.ram_bytes - self.target.ram_available

    @property
    def fits(self) -> bool:
        """Whether both fit."""
        return self.flash_excess <= 0 and self.ram_excess <= 0

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {
            "target": self.target.name,
            "tables_bytes": self.tables_bytes,
            "code_bytes": self.code_bytes,
            "flash_bytes": self.flash_bytes,
            "ram_bytes": self.ram_bytes,
            "flash_available": self.target.flash_available,
            "ram_available": self.target.ram_available,
            "fits": self.fits,
        }


def budget_target(
    target: str | Target, *, flash_budget: int | None = None, ram_budget: int | None = None
) -> Target:
    """``target`` with less flash / static RAM available to the observer.

    Parameters
    ----------
    target : str or Target
    flash_budget, ram_budget : int, optional
        Bytes the observer may use; at most what the target offers.

    Examples
    --------
    >>> budget_target("atmega328p", flash_budget=16384).flash_available
    16384
    """
    t = _target(target)
    fl, ra = t.flash_available, t.ram_available
    for name, v, cap in (("flash_budget", flash_budget, fl), ("ram_budget", ram_budget, ra)):
        if v is not None and not (int(v) == v and 0 < v <= cap):
            raise ConfigError(f"{name} is {v!r}; expected a whole number of bytes in 1..{cap}")
    return Target(
        t.name,
        t.flash_bytes,
        t.ram_bytes,
        t.flash_bytes - int(flash_budget if flash_budget is not None else fl),
        t.ram_bytes - int(ram_budget if ram_budget is not None else ra),
        t.f_cpu_hz,
    )


def _target(target: str | Target) -> Target:
    if isinstance(target, Target):
        return target
    try:
        return TARGETS[target]
    except KeyError:
        raise ConfigError(f"unknown target {target!r}; targets are {list(TARGETS)}") from None


def footprint(
    n: int,
    m: int,
    q: int,
    p: int,
    *,
    has_reset: bool = True,
    has_dz: bool = False,
    has_dh: bool = False,
    target: str | Target = "atmega328p",
    real_bytes: int = 4,
) -> Footprint:
    """Estimate flash and static RAM of an observer from its dimensions.

    Flash: the model tables (``M``, ``B``, ``G``, ``C_z``, ``C_h``, ``F`` and,
    when present, ``D_z``, ``D_h``, the rest-state map and the channel
    offsets, scales and ranges) at ``real_bytes`` each, plus
    :data:`CODE_FLASH_BYTES` (and :data:`CODE_FLASH_MEASURED_BYTES` when
    ``q > 0``). Static RAM: one ``vs_observer`` (state in two
    parts, estimate, scratch) plus :data:`BASE_RAM_BYTES`.

    Parameters
    ----------
    n, m, q, p : int
        States, exogenous, measured and hidden channels.
    has_reset, has_dz, has_dh : bool
        Optional tables.
    target : str or Target
    real_bytes : int
        Size of ``vs_real`` [byte].

    Returns
    -------
    Footprint

    Examples
    --------
    >>> f = footprint(8, 3, 0, 5)
    >>> f.tables_bytes, f.fits
    (696, True)
    """
    for name, v in (("n", n), ("m", m), ("q", q), ("p", p)):
        if int(v) != v or v < 0:
            raise ParameterError(f"{name} is {v!r}; expected a whole number >= 0")
    if n < 1 or p < 1:
        raise ParameterError(f"n = {n} and p = {p}; the observer needs states and outputs")
    t = _target(target)
    floats = n * n + n * m + n * q + q * n + p * n + p * q
    floats += q * m * bool(has_dz) + p * m * bool(has_dh) + (n * m + n * q) * bool(has_reset)
    floats += 4 * m + 4 * q + 2 * p  # offsets, inverse scales, ranges; output offsets, scales
    tables = real_bytes * floats
    code = CODE_FLASH_BYTES + (CODE_FLASH_MEASURED_BYTES if q else 0)
    ram = real_bytes * (2 * n + p + m + q + n) + 6 + BASE_RAM_BYTES
    return Footprint(tables, code, tables + code, ram, t)


def check_budget(fp: Footprint, *, what: str = "the observer") -> None:
    """Raise :class:`ConfigError` when ``fp`` does not fit its target, saying by how much."""
    t = fp.target
    problems = []
    if fp.flash_excess > 0:
        problems.append(
            f"{fp.flash_bytes} bytes of flash ({fp.tables_bytes} of model tables), the "
            f"{t.name} offers {t.flash_available} ({t.flash_bytes} less {t.bootloader_bytes} "
            f"kept for the boot loader and the application): {fp.flash_excess} bytes too many"
        )
    if fp.ram_excess > 0:
        problems.append(
            f"{fp.ram_bytes} bytes of static RAM, the {t.name} offers {t.ram_available} "
            f"({t.ram_bytes} less {t.stack_reserve_bytes} kept for stack and application): "
            f"{fp.ram_excess} bytes too many"
        )
    if problems:
        raise ConfigError(
            f"{what} does not fit the {t.name}: it needs " + "; and ".join(problems) + ". Reduce "
            "the model order (balanced reduction) or the number of channels."
        )


# ===================================================================== header
def c_literal(v: float) -> str:
    """C literal of a ``vs_real`` constant (``VS_C(...)``; NaN and ±inf by name)."""
    if np.isnan(v):
        return "VS_C(NAN)"
    if np.isinf(v):
        return "VS_C(INFINITY)" if v > 0 else "VS_C(-INFINITY)"
    return f"VS_C({float(v)!r})"


def _c_array(name: str, a: NDArray[np.float64], size: str, per_line: int = 4) -> str:
    flat = np.asarray(a, dtype=float).reshape(-1)
    items = [c_literal(v) for v in flat]
    lines = [
        "    " + ", ".join(items[i : i + per_line]) + ("," if i + per_line < len(items) else "")
        for i in range(0, len(items), per_line)
    ]
    return f"static const vs_real VS_ROM {name}[{size}] = {{\n" + "\n".join(lines) + "\n};\n"


def _comment_safe(text: str) -> str:
    return str(text).replace("*/", "* /").replace("\n", " ")


def render_header(fm: FirmwareModel, provenance: Mapping[str, Any]) -> str:
    """Text of ``vs_model.h`` for a firmware model.

    Parameters
    ----------
    fm : FirmwareModel
    provenance : mapping
        Shown in the header comment (FitResult fingerprint, model, method,
        creation time, thermogym version, noise model, ...).

    Returns
    -------
    str
    """
    n, m, q, p = fm.dims
    if max(n, m, q, p) > 255:
        raise ConfigError(f"dimensions {fm.dims} exceed 255 (the firmware's loop counters)")
    prov = "\n".join(f" *   {k}: {_comment_safe(v)}" for k, v in provenance.items())

    def chans(specs: tuple[ChannelSpec, ...], kind: str) -> str:
        rows = []
        for j, c in enumerate(specs):
            rng = ""
            if np.isfinite(c.lower) or np.isfinite(c.upper):
                rng = f", valid {c.lower:g} .. {c.upper:g}"
            rows.append(
                f" *   {kind}[{j}] {c.name} [{c.unit}]: offset {c.offset:.9g}, "
                f"scale {c.scale:g}{rng}"
            )
        return "\n".join(rows) if rows else f" *   (no {kind} channels)"

    fp = fm.footprint()
    parts = [
        "/**",
        " * @file vs_model.h",
        " * @brief Virtual-sensor model and steady-state Kalman gains — GENERATED, do not edit.",
        " *",
        " * Written by `thermogym firmware export`. Include it only through vs_observer.h;",
        " * vs_observer.c defines VS_MODEL_IMPLEMENTATION to get the tables.",
        " *",
        " * Provenance:",
        prov,
        " *",
        f" * Dimensions: {n} states, {m} exogenous (u), {q} measured (z), {p} hidden (y);",
        f" * sample period {fm.dt:g} s. Channels (physical = offset + scale * scaled):",
        chans(fm.u, "u"),
        chans(fm.z, "z"),
        chans(fm.y, "y"),
        " *",
        f" * Estimated footprint on the {fp.target.name}: {fp.flash_bytes} B flash "
        f"({fp.tables_bytes} B tables), {fp.ram_bytes} B static RAM.",
        " */",
        "#ifndef VS_MODEL_H",
        "#define VS_MODEL_H",
        "",
        '#include "vs_types.h"',
        "",
        "/** Literal of the firmware's number type (double literal rounded once). */",
        "#define VS_C(x) ((vs_real)(x))",
        "",
        f"#define VS_N_X {n} /**< observer states */",
        f"#define VS_N_U {m} /**< exogenous channels */",
        f"#define VS_N_Z {q} /**< measured channels (innovation) */",
        f"#define VS_N_Y {p} /**< hidden channels (estimates) */",
        f"#define VS_HAS_DZ {int(fm.has_dz)} /**< measured channels have a feedthrough */",
        f"#define VS_HAS_DH {int(fm.has_dh)} /**< hidden channels have a feedthrough */",
        f"#define VS_HAS_RESET {int(fm.has_reset)} /**< vs_reset() available */",
        f"#define VS_DT_S {fm.dt!r} /**< sample period [s] */",
        f'#define VS_MODEL_FINGERPRINT "{_comment_safe(provenance.get("fingerprint", ""))}"',
        "",
        "#ifdef VS_MODEL_IMPLEMENTATION",
        "/* channel offsets, inverse scales and valid ranges (physical units) */",
        _c_array("vs_u_off", np.array([c.offset for c in fm.u]), "VS_N_U"),
        _c_array("vs_u_iscale", np.array([1.0 / c.scale for c in fm.u]), "VS_N_U"),
        _c_array("vs_u_lo", np.array([c.lower for c in fm.u]), "VS_N_U"),
        _c_array("vs_u_hi", np.array([c.upper for c in fm.u]), "VS_N_U"),
    ]
    if q:
        parts += [
            _c_array("vs_z_off", np.array([c.offset for c in fm.z]), "VS_N_Z"),
            _c_array("vs_z_iscale", np.array([1.0 / c.scale for c in fm.z]), "VS_N_Z"),
            _c_array("vs_z_lo", np.array([c.lower for c in fm.z]), "VS_N_Z"),
            _c_array("vs_z_hi", np.array([c.upper for c in fm.z]), "VS_N_Z"),
        ]
    parts += [
        _c_array("vs_y_off", np.array([c.offset for c in fm.y]), "VS_N_Y"),
        _c_array("vs_y_scale", np.array([c.scale for c in fm.y]), "VS_N_Y"),
        "/* M = A − I, row-major (increment form of the state update) */",
        _c_array("vs_M", fm.M, "VS_N_X * VS_N_X"),
        _c_array("vs_B", fm.B, "VS_N_X * VS_N_U"),
        "/* hidden outputs */",
        _c_array("vs_Ch", fm.Ch, "VS_N_Y * VS_N_X"),
    ]
    if fm.has_dh:
        parts.append(_c_array("vs_Dh", fm.Dh, "VS_N_Y * VS_N_U"))
    if q:
        parts += [
            "/* measured outputs and steady-state Kalman gains (predictor G, output F = Ch L) */",
            _c_array("vs_Cz", fm.Cz, "VS_N_Z * VS_N_X"),
            _c_array("vs_G", fm.G, "VS_N_X * VS_N_Z"),
            _c_array("vs_F", fm.F, "VS_N_Y * VS_N_Z"),
        ]
        if fm.has_dz:
            parts.append(_c_array("vs_Dz", fm.Dz, "VS_N_Z * VS_N_U"))
    if fm.has_reset:
        parts += ["/* rest state x = Nu u + Nz z */", _c_array("vs_Nu", fm.Nu, "VS_N_X * VS_N_U")]  # type: ignore[arg-type]
        if q:
            parts.append(_c_array("vs_Nz", fm.Nz, "VS_N_X * VS_N_Z"))  # type: ignore[arg-type]
    parts += ["#endif /* VS_MODEL_IMPLEMENTATION */", "", "#endif /* VS_MODEL_H */", ""]
    return "\n".join(parts)
