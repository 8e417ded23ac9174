"""The work of ``thermogym firmware``.

The command's description and its options: :mod:`thermogym._cli.firmware`.
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from thermogym._cli.common import plan_outputs
from thermogym._cli.data_run import load_recordings
from thermogym._cli.virtual_sensor_run import _pairs as rest_pairs
from thermogym.errors import ConfigError
from thermogym.firmware.codegen import budget_target, firmware_model
from thermogym.firmware.export import export, sensor_from_fit


def _pairs(items: list[str]) -> dict[str, float]:
    out = {}
    for item in items:
        k, sep, v = item.partition("=")
        try:
            out[k.strip()] = float(v)
        except ValueError:
            sep = ""
        if not sep or not k.strip() or not np.isfinite(out[k.strip()]):
            raise ConfigError(f"{item!r} is not of the form NAME=NUMBER (a finite number)")
    return out


def _rest_pairs(items: list[str]) -> dict[str, float | str]:
    return rest_pairs(items)


def _ranges(items: list[str]) -> dict[str, tuple[float, float]]:
    out = {}
    for item in items:
        k, sep, v = item.partition("=")
        lo, sep2, hi = v.partition(":")
        try:
            out[k.strip()] = (float(lo), float(hi))
        except ValueError:
            sep2 = ""
        if not sep or not sep2 or not k.strip():
            raise ConfigError(f"--range {item!r} is not of the form NAME=LO:HI")
        a, b = out[k.strip()]
        if not (np.isfinite(a) and np.isfinite(b) and a < b):
            raise ConfigError(f"--range {item!r}: expected finite LO < HI")
    return out


def _names(text: str | None) -> tuple[str, ...] | None:
    if text is None:
        return None
    return tuple(s.strip() for s in text.split(",") if s.strip())


def run(args: argparse.Namespace) -> int:
    """Export or size the firmware."""
    kwargs = {
        "measured": _names(args.measured) or (),
        "hidden": _names(args.hidden),
        "reference": args.reference,
        "measurement_std": args.measurement_std,
        "process_std": args.process_std,
        "disturbance_inputs": _names(args.disturbance) or (),
        "ranges": _ranges(args.range) or None,
    }
    if args.fw_command == "budget":
        sensor, _ = sensor_from_fit(args.fit, **kwargs)
        tgt = budget_target(args.target, flash_budget=args.flash_budget, ram_budget=args.ram_budget)
        fp = firmware_model(sensor.observer_matrices()).footprint(tgt)
        print(json.dumps(fp.as_dict(), indent=2))
        return 0 if fp.fits else 1
    plan = plan_outputs(
        args, folders=("out",), inputs=("fit", "vectors"), unstaged=("out",)
    )  # export() stages its folder itself
    out_dir = plan.path("--out")
    if out_dir.is_dir() and any(out_dir.iterdir()) and not args.overwrite:
        raise ConfigError(
            f"--out {args.out!r} exists and is not empty; pass --overwrite to replace its files"
        )
    offsets, scales, rest = _pairs(args.offset), _pairs(args.scale), _rest_pairs(args.rest)
    vectors = None
    if args.vectors:
        (vectors,) = load_recordings([args.vectors], "--vectors", args)
    rep = export(
        args.fit,
        args.out,
        sensor_kwargs=kwargs,
        target=args.target,
        flash_budget=args.flash_budget,
        ram_budget=args.ram_budget,
        offsets=offsets or None,
        scales=scales or None,
        vectors=vectors,
        rest=rest or None,
        check_avr=False if args.no_avr_check else None,
        overwrite=args.overwrite,
    )
    n, m, q, p = rep.dims
    fp = rep.footprint
    print(
        f"exported the order-{n} observer ({m} exogenous, {q} measured, {p} estimated) to "
        f"{rep.out_dir}: {len(rep.files)} files"
    )
    print(
        f"  estimated footprint on the {fp.target.name}: {fp.flash_bytes} B flash of "
        f"{fp.target.flash_available}, {fp.ram_bytes} B static RAM of {fp.target.ram_available}"
    )
    if rep.avr_size:
        print(
            f"  avr-size: {rep.avr_size['flash_bytes']} B flash, "
            f"{rep.avr_size['ram_bytes']} B static RAM"
        )
    if rep.vectors:
        print(f"  test vectors: {rep.vectors}; run `make -C {rep.out_dir} test`")
    print(f"  FitResult fingerprint {rep.fingerprint[:16]}…")
    return 0
