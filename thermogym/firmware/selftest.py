"""Firmware self-test: export an observer with test vectors from a day of rig data.

``python -m thermogym.firmware.selftest --out DIR --case 3I5O-rise:8`` (what
``make -C firmware test`` runs) exports an observer and the vectors its C twin
is checked against:

* the model: the order-``N`` model of the case — the identified one when a
  FitResult is given (``--fit``), otherwise the spindle reference of
  :mod:`thermogym.firmware.reference` (known matrices, balanced reduction);
* the data: one held-out day of the spindle rig (``validation`` protocol,
  clean 1 Hz channels, run starting from rest), a few samples made invalid on
  purpose (a NaN, an RTD reading of 350 °C) so that the hold-on-invalid path
  is tested as well;
* for ``-rise`` cases every temperature is taken relative to the measured
  ambient, so that the firmware gets exactly the Table 6 inputs (3I5O: speed
  and the two outer-housing temperatures).

Cases: ``3I5O-rise`` (Table 6 3I5O: 3 inputs, 5 outputs, input-driven),
``3I5O`` (the same with the ambient as a fourth input), ``1I7O`` (speed and
ambient in, the two surface temperatures measured, five estimated: the
Kalman-corrected virtual sensor), ``random`` (a random stable model with 3
inputs and 5 outputs, for sizing at any order).
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from thermogym.errors import ConfigError, ThermogymError
from thermogym.estimation import VirtualSensor
from thermogym.firmware.export import ExportReport, export, sensor_from_fit
from thermogym.firmware.reference import random_stable_model, spindle_reference_model
from thermogym.fitresult import FitResult
from thermogym.rigs import get_rig

__all__ = ["CASES", "case_sensor", "main", "rig_day", "run_case"]

_SURFACE = ("T_front_outer_housing", "T_rear_outer_housing")
#: case -> (reference variant, VirtualSensor keyword arguments, relative to ambient)
CASES: dict[str, tuple[str, dict[str, Any], bool]] = {
    "3I5O-rise": ("3I5O-rise", {}, True),
    "3I5O": ("3I5O", {}, False),
    "1I7O": ("1I7O", {"measured": _SURFACE}, False),
    "random": ("random", {}, False),
}


def rig_day(
    *, speed: float = 5300.0, seed: int = 1, relative: bool = False, invalid: bool = True
) -> dict[str, np.ndarray]:
    """One held-out day of the spindle rig as columns (1 s, clean channels).

    Parameters
    ----------
    speed : float
        Spindle speed of the run [rpm] (a validation speed of paper 001).
    seed : int
        Rig seed.
    relative : bool
        Express every temperature relative to the measured ambient ``T_amb``.
    invalid : bool
        Make a few samples invalid (NaN speed at 2 min, 350 °C front surface at
        3 min), as a disconnected sensor would.
    """
    run = get_rig("spindle").run("validation", seed=seed, raw=False, speeds=[speed])[0]
    cols = {k: np.array(v, dtype=float) for k, v in run.columns.items()}
    cols["time"] = np.array(run.time, dtype=float)
    if relative:
        amb = cols["T_amb"].copy()
        for k in list(cols):
            if k.startswith("T_") and k != "T_amb":
                cols[k] = cols[k] - amb
    if invalid:
        cols["speed"][120] = np.nan
        cols["T_front_outer_housing"][180] = 350.0
    return cols


def case_sensor(
    case: str, order: int, *, fit: Any = None, dt: float = 1.0
) -> tuple[VirtualSensor, Any, bool]:
    """The sensor of a self-test case (and the FitResult it came from, if any)."""
    try:
        variant, kwargs, relative = CASES[case]
    except KeyError:
        raise ConfigError(f"unknown case {case!r}; cases are {list(CASES)}") from None
    if fit is not None:
        sensor, fr = sensor_from_fit(fit, **kwargs)
        return sensor, fr, relative
    if variant == "random":
        model = random_stable_model(
            order, ["speed", *_SURFACE], list(spindle_reference_model("3I5O").output_names), dt=dt
        )
    else:
        model = spindle_reference_model(variant, order=order, dt=dt)
    sensor = VirtualSensor(model, **kwargs)
    fr = FitResult.from_model(model, method="reference (network, balanced residualisation)")
    return sensor, fr, relative


def run_case(
    out: str | Path,
    case: str = "3I5O-rise",
    order: int = 8,
    *,
    fit: Any = None,
    seed: int = 1,
    samples: int | None = None,
    avr_samples: int | None = None,
    check_avr: bool | None = False,
    overwrite: bool = True,
) -> ExportReport:
    """Export one self-test case with its vectors into ``out``.

    Parameters
    ----------
    out : path
        Folder to write.
    case : str
        One of :data:`CASES`.
    order : int
        Model order (reference and random cases).
    fit : FitResult, path or dict, optional
        An identified model to use instead of the reference.
    seed : int
        Rig seed of the day of data.
    samples : int, optional
        Use only the first samples of the day (default: all 86 400).
    avr_samples : int, optional
        Samples in the AVR run.
    check_avr : bool, optional
        Confirm the footprint with avr-size (None: when installed).
    overwrite : bool
        Replace an existing folder's files.
    """
    sensor, fr, relative = case_sensor(case, order, fit=fit)
    data = rig_day(seed=seed, relative=relative)
    if samples is not None:
        data = {k: v[: int(samples)] for k, v in data.items()}
    return export(
        fr,
        out,
        sensor=sensor,
        vectors=data,
        rest={"speed": 0.0},
        avr_samples=avr_samples,
        check_avr=check_avr,
        overwrite=overwrite,
    )


def main(argv: Sequence[str] | None = None) -> int:
    """Command line of the self-test (used by ``firmware/Makefile``)."""
    p = argparse.ArgumentParser(prog="python -m thermogym.firmware.selftest", description=__doc__)
    p.add_argument("--out", required=True, help="folder to write")
    p.add_argument("--case", default="3I5O-rise:8", help="CASE[:ORDER], e.g. 3I5O-rise:8")
    p.add_argument(
        "--fit", help="FitResult JSON of an identified ss model instead of the reference"
    )
    p.add_argument("--seed", type=int, default=1, help="rig seed of the day of data")
    p.add_argument("--samples", type=int, help="use the first SAMPLES seconds only")
    p.add_argument("--avr-samples", type=int, help="samples of the AVR run")
    args = p.parse_args(argv)
    case, _, order = args.case.partition(":")
    try:
        rep = run_case(
            args.out,
            case,
            int(order or 8),
            fit=args.fit,
            seed=args.seed,
            samples=args.samples,
            avr_samples=args.avr_samples,
            check_avr=False,
        )
    except (ThermogymError, ValueError) as e:
        print(f"selftest: error: {e}", file=sys.stderr)
        return 2
    print(f"selftest: {args.case} -> {rep.out_dir}: " + json.dumps(rep.vectors))
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
