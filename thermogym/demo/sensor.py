"""Stage 6: the spindle virtual sensor and its sensor-module firmware.

The Table 6 model 3I5O of paper 001 (speed and the two outer-housing
temperatures in, the bearings and the inner housing out; order 8) is
identified by N4SID on the prepared run-in day of stage 2, run as a Kalman
virtual sensor on the held-out validation day (internal temperatures hidden
from it, compared afterwards), then exported as C99 firmware: the host build
(gcc) always runs the C code on a day of data and compares it with the Python
observer; with avr-gcc and simavr the ATmega328P build is sized and run too.
"""

from __future__ import annotations

import math

import numpy as np

from thermogym.demo.core import DemoContext, StageResult
from thermogym.demo.identify import save_fit
from thermogym.firmware.export import sensor_from_fit
from thermogym.firmware.plots import plot_virtual_sensor
from thermogym.firmware.selftest import run_case
from thermogym.firmware.toolchain import (
    avr_tools_available,
    host_compiler,
    run_host_test,
    run_simavr,
)
from thermogym.identification.metrics import fit_text, nrmse, rmse
from thermogym.studies.spindle import INTERNAL, SURFACE, virtual_sensor_fit

__all__ = ["stage_sensor"]


def stage_sensor(ctx: DemoContext, res: StageResult) -> None:
    """Identify, run and export the virtual sensor; build and test its firmware."""
    ctx.need("spindle_data")
    data = ctx.products["spindle_data"]
    train_speed = 6000 if (6000, 1) in data.runs else sorted(data.runs)[0][0]
    fit = virtual_sensor_fit("3I5O", order=8, train_speed=train_speed, data=data)
    rel = save_fit(ctx, fit, "spindle_virtual_sensor")
    sensor, _ = sensor_from_fit(fit)
    speed = sorted(data.validation)[0]
    day = data.validation[speed]
    sensor = sensor.at_period(day.dt)
    est = sensor.estimate(day, method="kalman", rest={"speed": 0.0})
    rows: list[tuple[str, float, float, float]] = []
    for name in INTERNAL:
        y, yh = np.asarray(day[name]), est[name]
        rows.append(
            (
                name,
                float(rmse(y, yh)),
                float(nrmse(y, yh)),
                float(np.mean(est.std[:, est.names.index(name)])),
            )
        )
    res.table(
        ["hidden output", "RMSE [K]", "fit", "mean estimate σ [K]"],
        [[r[0], r[1], fit_text(r[2]), r[3]] for r in rows],
        f"Virtual sensor (3I5O, order 8, trained at {train_speed} rpm) on the held-out "
        f"{speed} rpm day: internal temperatures estimated from speed and surface "
        "temperatures (rises above ambient)",
    )
    p = plot_virtual_sensor(
        np.asarray(day.time),
        {n: est[n] for n in INTERNAL[:3]},
        ctx.path("figures", "sensor_spindle_estimates.png"),
        measured={n: np.asarray(day[n]) for n in SURFACE},
        truth={n: np.asarray(day[n]) for n in INTERNAL[:3]},
        std={n: est.std[:, est.names.index(n)] for n in INTERNAL[:3]},
        unit="K",
        title=f"Spindle virtual sensor on the held-out {speed} rpm day",
        truth_label="true (hidden RTD)",
    )
    res.figure(
        ctx.rel(p),
        "Measured surface temperatures, hidden true internal temperatures and their estimates "
        "(±2σ)",
    )
    # firmware: export with test vectors from a held-out rig day, then build and compare
    fw_rows: list[list[object]] = []
    folder = ctx.path("firmware", "spindle_3i5o")
    samples = 20_000 if ctx.quick else None
    rep = run_case(folder, "3I5O-rise", 8, fit=fit, samples=samples, check_avr=False)
    fp = rep.footprint
    fw_rows.append(
        [
            "export",
            f"order {rep.dims[0]}, {rep.dims[1]} inputs, {rep.dims[3]} outputs",
            f"estimated {fp.flash_bytes} B flash / {fp.ram_bytes} B RAM on the {fp.target.name}",
        ]
    )
    if host_compiler() is None:
        fw_rows.append(["host build (gcc)", "not run", "no C compiler found"])
        host_ok = False
    else:
        host = run_host_test(folder)
        host_ok = host.passed
        fw_rows.append(
            [
                "host build (gcc, float32)",
                "passed" if host.passed else "FAILED",
                f"{host.observer_samples} samples, max |C − Python| = "
                f"{host.observer_max_err:.2e} °C; RTD conversion max error "
                f"{(host.rtd_max_err if host.rtd_max_err is not None else math.nan):.2e} °C",
            ]
        )
    if avr_tools_available(simulator=True):
        sim = run_simavr(folder)
        fw_rows.append(
            [
                "ATmega328P (avr-gcc -Os, simavr 16 MHz)",
                "passed" if sim.observer.get("status_mismatch", 1) == 0 else "FAILED",
                f"{sim.observer['steps']} steps, max |AVR − Python| = {sim.max_err_degC:.2e} °C, "
                f"{sim.step_ms:.2f} ms per step (budget 240 ms at 4.17 Hz); harness "
                f"{sim.size.get('flash_bytes', 0)} B flash incl. test vectors",
            ]
        )
        avr = f"; ATmega328P step {sim.step_ms:.2f} ms under simavr"
    else:
        fw_rows.append(
            [
                "ATmega328P",
                "not run",
                "avr-gcc / simavr not installed (`make demo` installs gcc-avr, avr-libc and "
                "simavr with apt-get where it runs as root; `make -C firmware avr-tools`)",
            ]
        )
        avr = "; AVR build not run (avr-gcc / simavr not installed)"
    res.table(["firmware check", "result", "details"], fw_rows, "Sensor-module firmware (C99)")
    if not host_ok:
        raise RuntimeError(f"the firmware host test failed; see {ctx.rel(folder)}/")
    mean_fit = float(np.mean([r[2] for r in rows]))
    res.shows = (
        "The virtual sensor of paper 001 section 3.3: internal spindle temperatures estimated "
        "from measurable surface temperatures, first in Python, then as the C firmware of the "
        "sensor module, checked against the Python observer on the same data."
    )
    res.text = (
        f"FitResult `{rel}`; firmware sources, generated `vs_model.h` and test vectors in "
        f"`{ctx.rel(folder)}/` (`make -C {ctx.rel(folder)} test` repeats the host check)."
    )
    res.highlights["virtual sensor"] = (
        f"hidden temperatures on a held-out day: mean fit {fit_text(mean_fit)}; firmware host "
        f"test {'passed' if host_ok else 'FAILED'}{avr}"
    )
