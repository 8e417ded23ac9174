"""Run the C toolchains on an exported folder: gcc host test, avr-gcc, avr-size, simavr.

Used by the tests, the benchmarks and :func:`thermogym.firmware.export`; the
same recipes are in the exported ``Makefile`` for people without Python.
Every function raises :class:`ToolchainError` with the tool's output when a
build or run fails, and :func:`avr_tools_available` tells whether the AVR part
can run here (Debian packages ``gcc-avr``, ``avr-libc``, ``simavr``; the
top-level ``firmware/Makefile`` installs them when it can).
"""

from __future__ import annotations

import re
import shutil
import subprocess
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from thermogym.errors import ExternalModelError

__all__ = [
    "HostResult",
    "SimResult",
    "ToolchainError",
    "avr_size_probe",
    "avr_tools_available",
    "host_compiler",
    "run_host_test",
    "run_simavr",
]

_ANSI = re.compile(r"\x1b\[[0-9;]*m")


class ToolchainError(ExternalModelError):
    """A compiler, avr-size or simavr failed; the message holds its output."""


def host_compiler() -> str | None:
    """Path of a host C compiler (``cc`` or ``gcc``), or None."""
    return shutil.which("cc") or shutil.which("gcc")


def avr_tools_available(*, simulator: bool = False) -> bool:
    """Whether avr-gcc and avr-size (and simavr with ``simulator=True``) are installed."""
    tools = ["avr-gcc", "avr-size"] + (["simavr"] if simulator else [])
    return all(shutil.which(t) for t in tools)


def _run(cmd: list[str], cwd: Path, timeout: float) -> str:
    try:
        proc = subprocess.run(
            cmd, cwd=cwd, capture_output=True, text=True, timeout=timeout, check=False
        )
    except FileNotFoundError as e:
        raise ToolchainError(f"{cmd[0]} is not installed: {e}") from e
    except subprocess.TimeoutExpired as e:
        raise ToolchainError(f"{' '.join(cmd)} did not finish within {timeout:g} s") from e
    out = _ANSI.sub("", (proc.stdout or "") + (proc.stderr or ""))
    if proc.returncode != 0:
        raise ToolchainError(f"{' '.join(cmd)} failed (exit {proc.returncode}):\n{out[-4000:]}")
    return out


@dataclass(frozen=True)
class HostResult:
    """Outcome of the host test.

    Attributes
    ----------
    observer_max_err : float
        Largest |C − Python| of the estimates [°C].
    observer_samples : int
    rtd_max_err : float or None
        Largest |C − Python| of the RTD temperatures [°C].
    passed : bool
    output : str
    """

    observer_max_err: float
    observer_samples: int
    rtd_max_err: float | None
    passed: bool
    output: str


def run_host_test(folder: Path, *, cflags: str = "", timeout: float = 300.0) -> HostResult:
    """Compile ``test_host`` with the host compiler and run it on the folder's vectors.

    Parameters
    ----------
    folder : Path
        An exported folder with vectors.
    cflags : str
        Extra compiler flags (e.g. ``-DVS_FLOAT=double``).
    timeout : float
        Seconds for compile and run together.
    """
    cc = host_compiler()
    if cc is None:
        raise ToolchainError("no host C compiler (cc/gcc) found")
    folder = Path(folder).resolve()  # the tools run inside it: relative paths would break
    exe = folder / "build" / "test_host"
    exe.parent.mkdir(exist_ok=True)
    flags = ["-std=c99", "-O2", "-Wall", "-Wextra", "-Wpedantic", "-Werror", *cflags.split()]
    _run(
        [cc, *flags, "test_host.c", "vs_observer.c", "rtd.c", "-lm", "-o", str(exe)],
        folder,
        timeout,
    )
    args = [str(exe), "vs_observer_vectors.bin"]
    if (folder / "rtd_vectors.bin").exists():
        args.append("rtd_vectors.bin")
    proc = subprocess.run(args, cwd=folder, capture_output=True, text=True, timeout=timeout)
    out = proc.stdout + proc.stderr
    m = re.search(r"observer: (\d+) samples.*?max \|y_C - y_Python\| = ([0-9.eE+-]+|nan|inf)", out)
    r = re.search(r"rtd: .*?max \|T_C - T_Python\| = ([0-9.eE+-]+|nan|inf)", out)
    if m is None:
        raise ToolchainError(f"test_host printed no observer result:\n{out[-4000:]}")
    return HostResult(
        float(m.group(2)),
        int(m.group(1)),
        float(r.group(1)) if r else None,
        proc.returncode == 0,
        out,
    )


def _avr_flags(f_cpu: int) -> list[str]:
    return [
        "-std=c99",
        "-Os",
        "-mmcu=atmega328p",
        f"-DF_CPU={f_cpu}UL",
        "-Wall",
        "-Wextra",
        "-Werror",
        "-ffunction-sections",
        "-fdata-sections",
    ]


def _avr_size(elf: Path, cwd: Path) -> dict[str, int]:
    out = _run(["avr-size", "--format=berkeley", str(elf)], cwd, 60)
    line = out.strip().splitlines()[-1].split()
    text, data, bss = int(line[0]), int(line[1]), int(line[2])
    return {
        "text": text,
        "data": data,
        "bss": bss,
        "flash_bytes": text + data,
        "ram_bytes": data + bss,
    }


def avr_size_probe(
    folder: Path, *, f_cpu: int = 16_000_000, timeout: float = 300.0
) -> dict[str, int]:
    """Build the size probe for the ATmega328P and measure it with avr-size.

    Returns
    -------
    dict
        ``text``, ``data``, ``bss``, ``flash_bytes`` (text + data) and
        ``ram_bytes`` (data + bss, static RAM).
    """
    folder = Path(folder).resolve()  # the tools run inside it: relative paths would break
    elf = folder / "build" / "avr_probe.elf"
    elf.parent.mkdir(exist_ok=True)
    _run(
        ["avr-gcc", *_avr_flags(f_cpu), "avr_probe.c", "vs_observer.c", "rtd.c",
         "-mmcu=atmega328p", "-Wl,--gc-sections", "-lm", "-o", str(elf)],
        folder,
        timeout,
    )  # fmt: skip
    return _avr_size(elf, folder)


@dataclass(frozen=True)
class SimResult:
    """What the ATmega328P printed under simavr.

    Attributes
    ----------
    observer : dict
        ``n, m, q, p, steps, max_err_udegC, status_mismatch, cycles_max,
        cycles_mean, f_cpu``.
    rtd : dict
        ``codes, max_err_udegC, status_mismatch, cycles_max``.
    size : dict
        avr-size of the harness program (vectors included).
    output : str
    """

    observer: dict[str, int]
    rtd: dict[str, int]
    size: dict[str, int]
    output: str

    @property
    def step_ms(self) -> float:
        """Longest observer step [ms] at the simulated clock."""
        return 1e3 * self.observer["cycles_max"] / self.observer["f_cpu"]

    @property
    def max_err_degC(self) -> float:
        """Largest |AVR − Python| of the estimates [°C]."""
        return self.observer["max_err_udegC"] * 1e-6

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {"observer": self.observer, "rtd": self.rtd, "size": self.size}


def _fields(line: str) -> dict[str, int]:
    return {k: int(v) for k, v in re.findall(r"(\w+)=(\d+)", line)}


def run_simavr(
    folder: Path, *, f_cpu: int = 16_000_000, timeout: float = 600.0, timing_only: bool = False
) -> SimResult:
    """Build the harness with the folder's vectors and run it on the simulated ATmega328P.

    Parameters
    ----------
    folder : Path
        An exported folder (with ``vs_vectors.h`` unless ``timing_only``).
    f_cpu : int
        Simulated clock [Hz].
    timeout : float
        Seconds for build and run.
    timing_only : bool
        Time 16 steps on synthetic inputs without vector tables (a model that
        leaves no flash for them); errors are then not measured.
    """
    folder = Path(folder).resolve()  # the tools run inside it: relative paths would break
    if not timing_only and not (folder / "vs_vectors.h").exists():
        raise ToolchainError(f"{folder}/vs_vectors.h is missing; export with vectors first")
    elf = folder / "build" / ("avr_timing.elf" if timing_only else "avr_harness.elf")
    elf.parent.mkdir(exist_ok=True)
    extra = ["-DVS_TIMING_ONLY"] if timing_only else []
    _run(
        ["avr-gcc", *_avr_flags(f_cpu), *extra, "avr_harness.c", "vs_observer.c", "rtd.c",
         "-mmcu=atmega328p", "-Wl,--gc-sections", "-lm", "-o", str(elf)],
        folder,
        timeout,
    )  # fmt: skip
    size = _avr_size(elf, folder)
    out = _run(["simavr", "-m", "atmega328p", "-f", str(f_cpu), str(elf)], folder, timeout)
    obs_line = next((ln for ln in out.splitlines() if "TGVS observer" in ln), None)
    rtd_line = next((ln for ln in out.splitlines() if "TGVS rtd" in ln), None)
    if obs_line is None or rtd_line is None or "TGVS done" not in out:
        raise ToolchainError(f"the simulated ATmega328P printed no complete result:\n{out[-4000:]}")
    return SimResult(_fields(obs_line), _fields(rtd_line), size, out)
