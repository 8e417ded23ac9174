"""Sensor-module firmware: the order-8 virtual-sensor observer on the ATmega328P.

Exports the order-8, 3-input, 5-output observer (Table 6 3I5O of
``001_6d13a2cd04f5de5e.txt``: speed and the two outer-housing temperatures in,
bearings and inner housing out) identified by N4SID on the rig's run-in day
(:func:`thermogym.studies.spindle.virtual_sensor_fit`; the
network-derived reference model when that module is missing), with test vectors
from a held-out day of rig data, and measures

* host (gcc, float32): max |C − Python| over the whole day (86 400 steps), also
  with double precision, without the compensated sum, and for the named peer:
  the textbook float32 update ``x⁺ = A x + B u + G ν`` (ratio printed);
* ATmega328P (avr-gcc -Os, avr-size): flash and static RAM of the observer
  with the RTD conversion and the C runtime (size probe);
* simavr at 16 MHz: cycles of one observer step (Timer1), max |AVR − Python|;
* the same for the Kalman-corrected 1I7O observer (2 measured channels);
* the largest order that fits the flash (3 inputs, 5 outputs), confirmed by
  avr-size and timed in simavr, and the step time at several orders.

Without avr-gcc/simavr the AVR figures are *estimates* from the footprint
model and the cycle count per multiply-accumulate measured once here
(:data:`CYCLES_PER_MAC`), and the JSON says so.

Usage::

    python benchmarks/firmware.py [--json PATH] [--out DIR] [--quick]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

from thermogym.estimation import VirtualSensor
from thermogym.firmware.codegen import TARGETS, footprint
from thermogym.firmware.export import export
from thermogym.firmware.reference import random_stable_model
from thermogym.firmware.selftest import rig_day, run_case
from thermogym.firmware.toolchain import (
    avr_size_probe,
    avr_tools_available,
    run_host_test,
    run_simavr,
)

#: simavr cycles per multiply-accumulate of the step, measured for the order-8 3I5O
#: observer (56 644 cycles, 143 MACs): used only for estimates without the AVR tools.
CYCLES_PER_MAC = 400.0
F_CPU = 16e6
PERIOD_MS = 240.0  # the module's sampling period (4.17 Hz)
HIDDEN = ["y0", "y1", "y2", "y3", "y4"]


def macs(n: int, m: int, q: int, p: int) -> int:
    """Multiply-accumulates of one step (innovation, outputs, increment)."""
    return q * (n + m) + p * (n + m + q) + n * (n + m + q)


def identified_3i5o():
    try:
        from thermogym.studies.spindle import virtual_sensor_fit
    except ImportError:
        return None, "reference (spindle network, balanced residualisation)"
    fit = virtual_sensor_fit("3I5O", order=8)
    return (
        fit,
        "N4SID on the rig's run-in day D1_6000 (thermogym.studies.spindle.virtual_sensor_fit)",
    )


def measure_case(out: Path, case: str, order: int, fit=None, avr: bool = True) -> dict:
    t0 = time.perf_counter()
    rep = run_case(out, case, order, fit=fit)
    res: dict = {"export_s": time.perf_counter() - t0, "dims": rep.dims}
    host = run_host_test(out)
    host_d = run_host_test(out, cflags="-DVS_FLOAT=double")
    host_nc = run_host_test(out, cflags="-DVS_NO_COMPENSATION")
    host_nv = run_host_test(out, cflags="-DVS_NAIVE_UPDATE")
    res["host"] = {
        "samples": host.observer_samples,
        "max_abs_err_degC": host.observer_max_err,
        "max_abs_err_double_degC": host_d.observer_max_err,
        "max_abs_err_plain_increment_degC": host_nc.observer_max_err,
        "max_abs_err_textbook_update_degC": host_nv.observer_max_err,
        "rtd_max_abs_err_degC": host.rtd_max_err,
        "passed": host.passed,
    }
    n, m, q, p = rep.dims
    est = rep.footprint
    res["estimate"] = {
        "flash_bytes": est.flash_bytes,
        "ram_bytes": est.ram_bytes,
        "step_ms": 1e3 * CYCLES_PER_MAC * macs(n, m, q, p) / F_CPU,
    }
    if avr:
        probe = avr_size_probe(out)
        sim = run_simavr(out)
        res["avr"] = {
            "flash_bytes": probe["flash_bytes"],
            "ram_bytes": probe["ram_bytes"],
            "cycles_max": sim.observer["cycles_max"],
            "cycles_mean": sim.observer["cycles_mean"],
            "step_ms": sim.step_ms,
            "max_abs_err_degC": sim.max_err_degC,
            "steps": sim.observer["steps"],
            "status_mismatch": sim.observer["status_mismatch"],
            "rtd_cycles_max": sim.rtd["cycles_max"],
            "rtd_max_abs_err_degC": sim.rtd["max_err_udegC"] * 1e-6,
        }
    return res


def largest_order(out: Path, avr: bool, quick: bool) -> dict:
    tgt = TARGETS["atmega328p"]
    n = 8
    while footprint(n + 1, 3, 0, 5).fits:
        n += 1
    result: dict = {"estimated_max_order": n}
    day = rig_day(relative=True)
    k = slice(0, 2000)
    data = {c: v[k] for c, v in day.items()}
    names = ["speed", "T_front_outer_housing", "T_rear_outer_housing"]
    timings = {}
    orders = [16, 32, 48, n] if not quick else [32, n]
    for order in orders:
        model = random_stable_model(order, names, HIDDEN, seed=order)
        sensor = VirtualSensor(model)
        d = out / f"random-n{order}"
        fit_orders = order
        while True:
            try:
                rep = export(
                    None, d, sensor=sensor, vectors=data, rest={"speed": 0.0}, check_avr=avr,
                    overwrite=True,
                )  # fmt: skip
                break
            except Exception as e:  # avr-size refused: one state less
                if order != n or "too many" not in str(e):
                    raise
                fit_orders -= 1
                order = fit_orders
                model = random_stable_model(order, names, HIDDEN, seed=order)
                sensor = VirtualSensor(model)
                d = out / f"random-n{order}"
        entry = {"estimate_flash_bytes": rep.footprint.flash_bytes}
        if avr:
            probe = avr_size_probe(d)
            try:
                sim = run_simavr(d)
                entry["timed_with"] = "test vectors"
            except Exception:  # no flash left for the vector tables: time synthetic steps
                sim = run_simavr(d, timing_only=True)
                entry["timed_with"] = "synthetic inputs (no room for vectors)"
            entry.update(
                flash_bytes=probe["flash_bytes"],
                ram_bytes=probe["ram_bytes"],
                cycles_max=sim.observer["cycles_max"],
                step_ms=sim.step_ms,
                avr_max_abs_err_degC=sim.max_err_degC
                if entry["timed_with"] == "test vectors"
                else None,
                steps=sim.observer["steps"],
            )
        else:
            entry["step_ms_estimate"] = 1e3 * CYCLES_PER_MAC * macs(order, 3, 0, 5) / F_CPU
        host = run_host_test(d)
        entry["host_max_abs_err"] = host.observer_max_err
        timings[order] = entry
    result["orders"] = timings
    result["max_order"] = max(timings)
    # the largest order whose step stays under 20 ms, from a quadratic fit of the cycles
    if avr:
        o = np.array(sorted(timings), dtype=float)
        c = np.array([timings[int(k)]["cycles_max"] for k in o], dtype=float)
        coef = np.polyfit(o, c, 2)
        grid = np.arange(8, result["max_order"] + 1)
        ok = grid[np.polyval(coef, grid) <= 0.020 * F_CPU]
        result["max_order_under_20ms"] = int(ok.max()) if ok.size else None
    result["target"] = {"flash_available": tgt.flash_available, "ram_available": tgt.ram_available}
    return result


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", help="write the results as JSON")
    ap.add_argument("--out", help="keep the exported folders here (default: a temp dir)")
    ap.add_argument("--quick", action="store_true", help="fewer orders in the size sweep")
    args = ap.parse_args()
    load = os.getloadavg()
    print(f"machine load (1/5/15 min): {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}")
    print(f"CPUs: {os.cpu_count()}")
    avr = avr_tools_available(simulator=True)
    if not avr:
        print("AVR tools (gcc-avr, avr-libc, simavr) missing: AVR figures are ESTIMATES")
    root = Path(args.out) if args.out else Path(tempfile.mkdtemp(prefix="tg-fw-bench-"))
    root.mkdir(parents=True, exist_ok=True)
    fit, source = identified_3i5o()
    print(f"order-8 3I5O model: {source}")
    main_case = measure_case(root / "3I5O-n8", "3I5O-rise", 8, fit=fit, avr=avr)
    kalman = measure_case(root / "1I7O-n8", "1I7O", 8, avr=avr)
    ref = measure_case(root / "ref-3I5O-n8", "3I5O-rise", 8, avr=False)
    big = largest_order(root, avr, args.quick)
    a = main_case.get("avr")
    figures = {
        "step_ms": a["step_ms"] if a else main_case["estimate"]["step_ms"],
        "ram_bytes": a["ram_bytes"] if a else main_case["estimate"]["ram_bytes"],
        "flash_bytes": a["flash_bytes"] if a else main_case["estimate"]["flash_bytes"],
        "max_abs_err_degC": max(
            main_case["host"]["max_abs_err_degC"], a["max_abs_err_degC"] if a else 0.0
        ),
    }
    result = {
        "figures": figures,
        "figures_kind": "measured (avr-size, simavr at 16 MHz)" if avr else "estimated",
        "model_source": source,
        "order8_3i5o": main_case,
        "order8_1i7o_kalman": kalman,
        "order8_reference_3i5o": ref,
        "largest_order": big,
        "load": list(load),
    }
    h = main_case["host"]
    print("\norder 8, 3 inputs, 5 outputs (Table 6 3I5O):")
    print(
        f"  step           {figures['step_ms']:.2f} ms at 16 MHz "
        f"(budget 20 ms; period {PERIOD_MS:g} ms)"
    )
    print(f"  static RAM     {figures['ram_bytes']} B (budget 1024 B)")
    print(f"  flash          {figures['flash_bytes']} B (budget 16384 B)")
    print(
        f"  max |C − Py|   {figures['max_abs_err_degC']:.2e} °C (host day {h['samples']} steps"
        + (f", AVR {a['steps']} steps)" if a else ")")
    )
    for label, case in (("3I5O", main_case), ("1I7O Kalman", kalman), ("reference 3I5O", ref)):
        hh = case["host"]
        ratio = hh["max_abs_err_textbook_update_degC"] / max(hh["max_abs_err_degC"], 1e-15)
        print(
            f"  peer, {label}: textbook float32 x+ = A x + B u + G nu: "
            f"{hh['max_abs_err_textbook_update_degC']:.2e} °C = {ratio:.1f}x the increment form "
            f"with TwoSum ({hh['max_abs_err_degC']:.2e}; without TwoSum "
            f"{hh['max_abs_err_plain_increment_degC']:.2e}; "
            f"double {hh['max_abs_err_double_degC']:.1e})"
        )
    if kalman.get("avr"):
        k = kalman["avr"]
        kerr = max(k["max_abs_err_degC"], kalman["host"]["max_abs_err_degC"])
        print(
            f"1I7O Kalman (2 measured): step {k['step_ms']:.2f} ms, RAM {k['ram_bytes']} B, "
            f"flash {k['flash_bytes']} B, max err {kerr:.1e} °C"
        )
    mo = big["max_order"]
    e = big["orders"][mo]
    print(
        f"largest order that fits (3 in, 5 out): {mo}; "
        + (
            f"flash {e['flash_bytes']} B, RAM {e['ram_bytes']} B, step {e['step_ms']:.1f} ms, "
            f"host max err {e['host_max_abs_err']:.1e} °C; largest order under 20 ms: "
            f"{big.get('max_order_under_20ms')}"
            if avr
            else f"estimated step {e['step_ms_estimate']:.1f} ms"
        )
    )
    if args.json:
        Path(args.json).write_text(json.dumps(result, indent=2, default=float) + "\n")
        print(f"wrote {args.json}")
    if not args.out:
        shutil.rmtree(root, ignore_errors=True)


if __name__ == "__main__":
    main()
