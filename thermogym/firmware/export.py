"""``thermogym firmware export``: model header, C sources and test vectors in one folder.

:func:`export` turns a FitResult of a linear state-space model (``ss``) into a
folder a user can build with nothing but a C compiler:

* ``vs_model.h`` — generated: dimensions, scaled matrices, steady-state Kalman
  gains, channel offsets/scales/ranges and a provenance comment with the
  FitResult fingerprint (:mod:`thermogym.firmware.codegen`);
* the C sources shipped with thermogym (``vs_types.h``, ``vs_observer.[ch]``,
  ``rtd.[ch]``, the host test ``test_host.c``, the simavr harness
  ``avr_harness.c``, the size probe ``avr_probe.c`` and a ``Makefile``);
* with ``vectors=`` (a recording): test vectors of the Python observer on
  those data (``vs_observer_vectors.bin`` for the host test, a subset in
  ``vs_vectors.h`` for the AVR run) and of the Python RTD reference over
  −50..300 °C (``rtd_vectors.bin``).

It refuses a model whose estimated flash or static RAM exceeds the target's and
says by how much; where avr-gcc is installed it confirms the estimate with
avr-size before writing anything. The folder is written as a whole: a refused
or failed export leaves no partial folder and never replaces an existing one
unless ``overwrite=True``.
"""

from __future__ import annotations

import datetime as _dt
import importlib.resources
import json
import os
import shutil
import struct
import tempfile
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

import thermogym
from thermogym.errors import ConfigError
from thermogym.estimation import VirtualSensor
from thermogym.firmware import rtd as rtd_ref
from thermogym.firmware.codegen import (
    FirmwareModel,
    Footprint,
    budget_target,
    c_literal,
    check_budget,
    firmware_model,
    render_header,
)
from thermogym.firmware.toolchain import avr_size_probe, avr_tools_available
from thermogym.fitresult import FitResult, load_fit
from thermogym.models.linear import StateSpaceModel

__all__ = [
    "C_SOURCES",
    "ExportReport",
    "c_source_dir",
    "export",
    "rtd_test_codes",
    "sensor_from_fit",
    "write_observer_vectors",
    "write_rtd_vectors",
]

_DIMS = ("n_states", "n_exogenous", "n_measured", "n_hidden")

#: The C files shipped as package data (thermogym/firmware/c), copied by every export.
C_SOURCES: tuple[str, ...] = (
    "vs_types.h",
    "vs_observer.h",
    "vs_observer.c",
    "rtd.h",
    "rtd.c",
    "test_host.c",
    "avr_harness.c",
    "avr_probe.c",
    "Makefile",
)


def c_source_dir() -> Path:
    """Folder of the C sources inside the installed package."""
    return Path(str(importlib.resources.files("thermogym.firmware") / "c"))


@dataclass
class ExportReport:
    """What :func:`export` wrote and measured.

    Attributes
    ----------
    out_dir : Path
    files : list of str
        Names of the files written.
    dims : tuple of int
        ``(n_states, n_exogenous, n_measured, n_hidden)``.
    footprint : Footprint
        Estimate from the dimensions.
    avr_size : dict or None
        ``{"flash_bytes", "ram_bytes"}`` measured by avr-size on the size
        probe, None when avr-gcc is not installed or the check was skipped.
    fingerprint : str
        FitResult fingerprint written into the header.
    vectors : dict
        Number of observer samples, AVR samples and RTD codes written.
    """

    out_dir: Path
    files: list[str]
    dims: tuple[int, int, int, int]
    footprint: Footprint
    avr_size: dict[str, int] | None
    fingerprint: str
    vectors: dict[str, int] = field(default_factory=dict)

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {
            "out_dir": str(self.out_dir),
            "files": list(self.files),
            "dims": dict(zip(_DIMS, self.dims, strict=True)),
            "footprint": self.footprint.as_dict(),
            "avr_size": self.avr_size,
            "fingerprint": self.fingerprint,
            "vectors": dict(self.vectors),
        }


def sensor_from_fit(fit: Any, **sensor_kwargs: Any) -> tuple[VirtualSensor, Any]:
    """Build a :class:`VirtualSensor` from a FitResult (object, path or dict).

    Returns
    -------
    sensor : VirtualSensor
    fit : FitResult
    """
    fr = load_fit(fit)
    model = fr.build_model()
    if not isinstance(model, StateSpaceModel):
        raise ConfigError(
            f"the FitResult is for model {fr.model!r}; a virtual sensor and its firmware need a "
            "linear state-space model ('ss', e.g. from N4SID)"
        )
    return VirtualSensor(model, fr.theta(model), **sensor_kwargs), fr


# ==================================================================== vectors
def _le_doubles(values: NDArray[np.float64]) -> bytes:
    return np.ascontiguousarray(values, dtype="<f8").tobytes()


def write_observer_vectors(
    path: Path,
    sensor: VirtualSensor,
    u: NDArray[np.float64],
    z: NDArray[np.float64],
    *,
    rest: Mapping[str, float | str] | None = None,
    tolerance: float = 1e-3,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int8]]:
    """Run the Python observer on ``(u, z)`` and write the host-test vector file.

    Layout (little-endian): ``b"TGVSOBS1"``, int32 ``T, n, m, q, p``, float64
    tolerance, the rest-state readings ``u_rest[m], z0[q]``, then per sample
    ``u[m], z[q], y[p], status`` as float64.

    Returns
    -------
    u_rest : ndarray, shape (m,)
    y : ndarray, shape (T, p)
        The Python estimates.
    status : ndarray of int8, shape (T,)
    """
    est = sensor.observe(u, z, x0="rest", rest=rest)
    u_rest = sensor.rest_inputs(u[0], rest)
    T = u.shape[0]
    n = sensor.n_states
    m, q, p = u.shape[1], z.shape[1], len(sensor.hidden_names)
    rec = np.hstack([u, z, est.values, est.status[:, None].astype(float)])
    head = b"TGVSOBS1" + struct.pack("<5i", T, n, m, q, p) + struct.pack("<d", tolerance)
    body = _le_doubles(np.concatenate([u_rest, z[0]])) + _le_doubles(rec)
    path.write_bytes(head + body)
    return u_rest, est.values, est.status


def rtd_test_codes(cfg: rtd_ref.AdcConfig | None = None, step_k: float = 0.01) -> NDArray[np.int64]:
    """ADC codes for −50..300 °C every ``step_k`` plus edge cases (short, open, out of range)."""
    c = cfg or rtd_ref.AdcConfig()
    t = np.arange(-50.0, 300.0 + step_k / 2, step_k)
    codes = rtd_ref.resistance_to_code(rtd_ref.temperature_to_resistance(t, c.r0), c)
    full = (1 << c.bits) - 1
    mid = 1 << (c.bits - 1) if c.bipolar else 0
    edges = [
        0,
        mid,
        mid + 1,
        full - 1,
        full,
        int(rtd_ref.resistance_to_code(rtd_ref.temperature_to_resistance(-60.0, c.r0), c)),
        int(rtd_ref.resistance_to_code(rtd_ref.temperature_to_resistance(310.0, c.r0), c)),
    ]
    return np.concatenate([codes, np.array(edges, dtype=np.int64)])


def write_rtd_vectors(
    path: Path,
    cfg: rtd_ref.AdcConfig | None = None,
    *,
    step_k: float = 0.01,
    tolerance: float = 1e-3,
) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.int64]]:
    """Write the RTD vector file: codes over −50..300 °C with the Python reference.

    Layout (little-endian): ``b"TGVSRTD1"``, int32 ``count, bits, bipolar``,
    float64 ``gain, r_ref, r0, tolerance``, then per code float64
    ``code, status, temperature`` (NaN when undefined).

    Returns
    -------
    codes, temperatures, statuses : ndarray
    """
    c = cfg or rtd_ref.AdcConfig()
    codes = rtd_test_codes(c, step_k)
    t, st = rtd_ref.code_to_temperature(codes, c)
    head = b"TGVSRTD1" + struct.pack("<3i", codes.size, c.bits, int(c.bipolar))
    head += struct.pack("<4d", c.gain, c.r_ref, c.r0, tolerance)
    rec = np.column_stack([codes.astype(float), st.astype(float), t])
    path.write_bytes(head + _le_doubles(rec))
    return codes, t, st


def _c_float_list(values: NDArray[np.float64]) -> str:
    items = [c_literal(v) for v in np.asarray(values, dtype=float).reshape(-1)]
    lines = [", ".join(items[i : i + 4]) for i in range(0, len(items), 4)]
    return ",\n    ".join(lines) if lines else "VS_C(0.0)"


def render_avr_vectors(
    u_rest: NDArray[np.float64],
    z0: NDArray[np.float64],
    u: NDArray[np.float64],
    z: NDArray[np.float64],
    y: NDArray[np.float64],
    status: NDArray[np.int8],
    codes: NDArray[np.int64],
    t_ref: NDArray[np.float64],
    st_ref: NDArray[np.int64],
) -> str:
    """Text of ``vs_vectors.h``: the AVR run's test vectors as flash tables."""
    T = u.shape[0]
    parts = [
        "/* Test vectors for avr_harness.c — GENERATED by `thermogym firmware export`. */",
        "#ifndef VS_VECTORS_H",
        "#define VS_VECTORS_H",
        '#include "vs_model.h"',
        "",
        f"#define VSV_T {T}",
        f"#define RTV_N {codes.size}",
        "",
        "static const vs_real VS_ROM vsv_reset_u[VS_N_U] = {\n    "
        + _c_float_list(u_rest)
        + "\n};",
    ]
    if z.shape[1]:
        parts.append(
            "static const vs_real VS_ROM vsv_reset_z[VS_N_Z] = {\n    " + _c_float_list(z0) + "\n};"
        )
    st = status.astype(int)
    parts += [
        "static const vs_real VS_ROM vsv_u[VSV_T * VS_N_U] = {\n    " + _c_float_list(u) + "\n};",
    ]
    if z.shape[1]:
        parts.append(
            "static const vs_real VS_ROM vsv_z[VSV_T * VS_N_Z] = {\n    "
            + _c_float_list(z)
            + "\n};"
        )
    parts += [
        "static const vs_real VS_ROM vsv_y[VSV_T * VS_N_Y] = {\n    " + _c_float_list(y) + "\n};",
        "static const uint8_t VS_ROM vsv_status[VSV_T] = {"
        + ", ".join(str(int(s)) for s in st)
        + "};",
        "static const uint32_t VS_ROM rtv_code[RTV_N] = {"
        + ", ".join(f"{int(c)}UL" for c in codes)
        + "};",
        "static const vs_real VS_ROM rtv_t[RTV_N] = {\n    "
        + _c_float_list(np.nan_to_num(t_ref))
        + "\n};",
        "static const uint8_t VS_ROM rtv_status[RTV_N] = {"
        + ", ".join(str(int(s)) for s in st_ref)
        + "};",
        "",
        "#endif /* VS_VECTORS_H */",
        "",
    ]
    return "\n".join(parts)


# ===================================================================== export
def _publish_dir(stage: Path, out: Path, overwrite: bool) -> None:
    if out.exists():
        if not out.is_dir():
            raise ConfigError(f"{str(out)!r} exists and is not a folder")
        if any(out.iterdir()) and not overwrite:
            raise ConfigError(
                f"output folder {str(out)!r} exists and is not empty; pass overwrite=True "
                "(--overwrite) to replace its files"
            )
        for f in stage.iterdir():
            os.replace(f, out / f.name)  # file by file, each atomic
        shutil.rmtree(stage, ignore_errors=True)
    else:
        os.replace(stage, out)


def export(
    fit: Any,
    out_dir: str | os.PathLike[str],
    *,
    sensor: VirtualSensor | None = None,
    sensor_kwargs: Mapping[str, Any] | None = None,
    target: str = "atmega328p",
    flash_budget: int | None = None,
    ram_budget: int | None = None,
    offsets: Mapping[str, float] | None = None,
    scales: Mapping[str, float] | None = None,
    vectors: Any = None,
    rest: Mapping[str, float | str] | None = None,
    avr_samples: int | None = None,
    rtd_step_k: float = 0.01,
    tolerance: float = 1e-3,
    check_avr: bool | None = None,
    overwrite: bool = False,
) -> ExportReport:
    """Generate the model header and copy the C sources into ``out_dir``.

    Parameters
    ----------
    fit : FitResult, path or dict
        An identified ``ss`` model. Ignored for the model when ``sensor`` is
        given (its fingerprint is still used when ``fit`` is not None).
    out_dir : path
        Folder to create (must not exist or be empty, unless ``overwrite``).
    sensor : VirtualSensor, optional
        A ready sensor (measured/hidden split, noise) instead of building one.
    sensor_kwargs : mapping, optional
        Arguments of :class:`VirtualSensor` (``measured``, ``reference``,
        ``measurement_std``, ``ranges``, ...).
    target : str
        Microcontroller (:data:`~thermogym.firmware.codegen.TARGETS`).
    flash_budget, ram_budget : int, optional
        Bytes of flash / static RAM the observer may use, when less than the
        target offers (room for the application) [byte].
    offsets, scales : mapping, optional
        Operating point and scales of the channels
        (:func:`~thermogym.firmware.codegen.firmware_model`).
    vectors : Recording or mapping, optional
        Data for the test vectors (uniform, at the model's sample period).
    rest : mapping, optional
        Exogenous values for the rest state at the start of ``vectors``
        (e.g. ``{"speed": 0.0}``).
    avr_samples : int, optional
        Samples of ``vectors`` in the AVR run (default: as many as fit in the
        flash left, at most 256).
    rtd_step_k : float
        Temperature step of the RTD vectors [K].
    tolerance : float
        Largest accepted difference C − Python [°C], written into the vectors.
    check_avr : bool, optional
        Confirm the footprint with avr-gcc/avr-size; default: when installed.
    overwrite : bool
        Replace files in an existing folder.

    Returns
    -------
    ExportReport

    Raises
    ------
    ConfigError
        The model does not fit the target (the message says by how much), the
        folder exists, the data lack a channel, the FitResult is not ``ss``.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from thermogym.firmware.reference import spindle_reference_model
    >>> from thermogym.fitresult import FitResult
    >>> fit = FitResult.from_model(spindle_reference_model("3I5O", order=8))
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "fw"
    >>> rep = export(fit, out, check_avr=False)
    >>> rep.dims, (out / "vs_model.h").exists()
    ((8, 4, 0, 5), True)
    """
    out = Path(out_dir)
    if sensor is None:
        if fit is None:
            raise ConfigError("give a FitResult (fit=...) or a VirtualSensor (sensor=...)")
        sensor, fr = sensor_from_fit(fit, **dict(sensor_kwargs or {}))
    else:
        if sensor_kwargs:
            raise ConfigError("sensor_kwargs given together with a ready sensor; give one")
        fr = (
            load_fit(fit)
            if fit is not None
            else FitResult.from_model(sensor.model, sensor.theta[0], method="unknown")
        )
    if out.exists() and out.is_dir() and any(out.iterdir()) and not overwrite:
        raise ConfigError(
            f"output folder {str(out)!r} exists and is not empty; pass overwrite=True "
            "(--overwrite) to replace its files"
        )
    obs = sensor.observer_matrices()
    fm: FirmwareModel = firmware_model(obs, offsets=offsets, scales=scales)
    tgt = budget_target(target, flash_budget=flash_budget, ram_budget=ram_budget)
    fp = fm.footprint(tgt)
    check_budget(fp, what=f"the order-{fm.dims[0]} observer")
    provenance = {
        "fingerprint": fr.fingerprint(),
        "model": f"{fr.model} v{fr.model_version}",
        "method": fr.method or "unknown",
        "fitted": fr.created,
        "fitted with": f"thermogym {fr.package_version}",
        "exported": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        "exported with": f"thermogym {thermogym.__version__}",
        "observer": "steady-state Kalman filter (DARE); measured channels "
        + (", ".join(sensor.measured_names) or "none (input-driven model)"),
        "reference": sensor.reference or "none",
        "disturbance states": ", ".join(sensor.disturbance_inputs) or "none",
        "noise": f"trace Q = {np.trace(sensor.noise.Q):.4g}, R diag = "
        + ", ".join(f"{v:.4g}" for v in np.diag(sensor.noise.R)),
    }
    header = render_header(fm, provenance)
    src = c_source_dir()
    parent = out.resolve().parent
    parent.mkdir(parents=True, exist_ok=True)
    stage = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=parent))
    try:
        files = []
        for name in C_SOURCES:
            shutil.copyfile(src / name, stage / name)
            files.append(name)
        (stage / "vs_model.h").write_text(header, encoding="utf-8")
        files.append("vs_model.h")
        t = fp.target
        (stage / "budget.mk").write_text(
            f"# written by thermogym firmware export: the {t.name} less boot loader / stack\n"
            f"FLASH_BUDGET := {t.flash_available}\nRAM_BUDGET := {t.ram_available}\n",
            encoding="utf-8",
        )
        files.append("budget.mk")
        counts: dict[str, int] = {}
        if vectors is not None:
            u, z = sensor.arrays(vectors)
            u_rest, y, status = write_observer_vectors(
                stage / "vs_observer_vectors.bin", sensor, u, z, rest=rest, tolerance=tolerance
            )
            codes, t_ref, st_ref = write_rtd_vectors(
                stage / "rtd_vectors.bin", step_k=rtd_step_k, tolerance=tolerance
            )
            # the AVR run: as many samples as fit next to the model, RTD codes spread out
            _, m, q, p = fm.dims
            per = 4 * (m + q + p) + 1
            room = t.flash_available - fp.flash_bytes - 3000  # harness code and UART
            k_avr = int(min(256, max(8, room // per), u.shape[0]))
            if avr_samples is not None:
                k_avr = int(min(avr_samples, u.shape[0]))
            pick = np.unique(np.linspace(0, codes.size - 1, 64).round().astype(int))
            (stage / "vs_vectors.h").write_text(
                render_avr_vectors(
                    u_rest, z[0], u[:k_avr], z[:k_avr], y[:k_avr], status[:k_avr],
                    codes[pick], t_ref[pick], st_ref[pick],
                ),
                encoding="utf-8",
            )  # fmt: skip
            files += ["vs_observer_vectors.bin", "rtd_vectors.bin", "vs_vectors.h"]
            counts = {"observer_samples": int(u.shape[0]), "avr_samples": k_avr}
            counts["rtd_codes"] = int(codes.size)
        manifest = {
            "provenance": provenance,
            "dims": dict(zip(_DIMS, fm.dims, strict=True)),
            "channels": {
                "u": [c.__dict__ for c in fm.u],
                "z": [c.__dict__ for c in fm.z],
                "y": [c.__dict__ for c in fm.y],
            },
            "dt_s": fm.dt,
            "footprint_estimate": fp.as_dict(),
            "vectors": counts,
        }
        avr = None
        if check_avr is None:
            check_avr = avr_tools_available()
        if check_avr:
            avr = avr_size_probe(stage)
            excess_f = avr["flash_bytes"] - t.flash_available
            excess_r = avr["ram_bytes"] - t.ram_available
            if excess_f > 0 or excess_r > 0:
                raise ConfigError(
                    f"avr-size: the observer needs {avr['flash_bytes']} bytes of flash and "
                    f"{avr['ram_bytes']} bytes of static RAM; the {t.name} offers "
                    f"{t.flash_available} and {t.ram_available}: "
                    f"{max(excess_f, 0)} bytes of flash and {max(excess_r, 0)} of RAM too many"
                )
            manifest["avr_size"] = avr
        (stage / "export.json").write_text(
            json.dumps(manifest, indent=2, default=float, allow_nan=True) + "\n", encoding="utf-8"
        )
        files.append("export.json")
        _publish_dir(stage, out, overwrite)
    except BaseException:
        shutil.rmtree(stage, ignore_errors=True)
        raise
    return ExportReport(out, files, fm.dims, fp, avr, provenance["fingerprint"], counts)
