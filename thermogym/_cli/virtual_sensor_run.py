"""The work of ``thermogym virtual-sensor``.

The command's description and its options: :mod:`thermogym._cli.virtual_sensor`.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np

# write_recording is looked up in its module when called, so that a replacement there is used
# (the interruption tests replace it)
from thermogym import recording
from thermogym._cli.common import plan_outputs
from thermogym._cli.data_run import check_units, load_recordings
from thermogym.errors import ConfigError
from thermogym.estimation import consistency, normalized_error_squared
from thermogym.firmware.export import sensor_from_fit
from thermogym.identification.metrics import fit_text, nrmse, rmse
from thermogym.recording import Recording


def _names(text: str | None) -> tuple[str, ...] | None:
    if text is None:
        return None
    return tuple(s.strip() for s in text.split(",") if s.strip())


def _pairs(items: list[str]) -> dict[str, float | str]:
    out: dict[str, float | str] = {}
    for item in items:
        k, sep, v = item.partition("=")
        k, v = k.strip(), v.strip()
        if not sep or not k:
            raise ConfigError(f"{item!r} is not of the form NAME=NUMBER or NAME=CHANNEL")
        try:
            out[k] = float(v)
        except ValueError:
            if not v.isidentifier():
                raise ConfigError(f"{item!r}: {v!r} is neither a number nor a channel") from None
            out[k] = v
            continue
        if not np.isfinite(out[k]):
            raise ConfigError(f"{item!r}: {v!r} is not a finite number")
    return out


def _at_rate(sensor, rec):  # type: ignore[no-untyped-def]
    if not rec.is_uniform():
        raise ConfigError(
            f"recording {rec.experiment_id or ''} is not uniformly sampled; prepare it first "
            "(thermogym.identification.prepare: outliers, resampling, gaps)"
        )
    dt = rec.dt
    try:
        return sensor.at_period(dt)
    except ValueError as e:
        raise ConfigError(
            f"the recording's sample period {dt:g} s is not a multiple of the model's "
            f"{sensor.dt:g} s; resample it ({e})"
        ) from e


def run(args: argparse.Namespace) -> int:
    """Estimate, write, report (the outputs are checked first and replaced last)."""
    plan = plan_outputs(
        args,
        files={"out": "recording", "plot": "figure"},
        inputs=("data", "fit", "tune"),
    )
    with plan:
        return _estimate(args, plan)


def _estimate(args: argparse.Namespace, plan: Any) -> int:
    rest = _pairs(args.rest)
    sensor, fit = sensor_from_fit(
        args.fit,
        measured=_names(args.measured) or (),
        hidden=_names(args.hidden),
        reference=args.reference,
        measurement_std=args.measurement_std,
        process_std=args.process_std,
        disturbance_inputs=_names(args.disturbance) or (),
    )
    (rec,) = load_recordings([args.data], "DATA", args)
    # exogenous, measured and hidden channels (a recorded hidden one is compared)
    check_units(rec, sensor.units, f"fit {Path(args.fit).name!r}")
    sensor = _at_rate(sensor, rec)
    if args.tune:
        (cal,) = load_recordings([args.tune], "--tune", args)
        check_units(cal, sensor.units, f"fit {Path(args.fit).name!r}")
        cal_sensor = _at_rate(sensor, cal)
        u_c, z_c = cal_sensor.arrays(cal)
        _, alpha = cal_sensor.tuned(u_c, z_c)
        sensor = sensor.with_noise(sensor.noise.scaled(process=alpha))
        print(f"process noise scaled by {alpha:.4g} on {args.tune} (mean NIS = measured channels)")
    x0 = args.x0
    if x0 == "auto":  # --rest says the record starts at rest: the steady state then
        x0 = "estimate" if sensor.measured_names and not rest else "steady"
    print(f"initial state: {x0}")
    est = sensor.estimate(rec, method=args.method, rest=rest or None, x0=x0)
    cols = {}
    units = {}
    for j, name in enumerate(est.names):
        cols[name] = est.values[:, j]
        cols[f"{name}_std"] = est.std[:, j]
        units[name] = units[f"{name}_std"] = sensor.units.get(name, "1")
    cols["vs_status"] = est.status.astype(float)
    out = Recording(
        rec.time,
        cols,
        units=units,
        experiment_id=f"{rec.experiment_id or Path(args.data).stem}-virtual-sensor",
        source=f"thermogym virtual-sensor ({args.method})",
        meta={
            "data": str(args.data),
            "fit_fingerprint": fit.fingerprint(),
            "measured": list(sensor.measured_names),
            "exogenous": list(sensor.exogenous_names),
            "reference": sensor.reference,
        },
    )
    recording.write_recording(out, plan.path("--out"))
    print(
        f"virtual sensor ({args.method}, order {sensor.n_states}, dt {sensor.dt:g} s): "
        f"{rec.n_samples} samples -> {args.out}; exogenous {list(sensor.exogenous_names)}, "
        f"measured {list(sensor.measured_names)}"
    )
    rejected = int((est.status != 0).sum())
    if rejected:
        print(
            f"  {rejected} sample(s) with an invalid or missing channel (estimate held/predicted)"
        )
    have = [n for n in est.names if n in rec]
    truth = {}
    if have:
        Y = np.column_stack([rec[n] for n in have])
        idx = [est.names.index(n) for n in have]
        Yh = est.values[:, idx]
        for j, n in enumerate(have):
            truth[n] = Y[:, j]
            print(
                f"  {n:<24} RMSE {float(rmse(Y[:, j], Yh[:, j])):.4f}   "
                f"fit {fit_text(float(nrmse(Y[:, j], Yh[:, j])))}"
            )
        ok = np.isfinite(Y).all(axis=1)
        if ok.sum() > 2:
            # the recorded hidden signals carry sensor noise: add it to the estimate's covariance
            cov = est.cov[:, idx][:, :, idx] + np.eye(len(idx)) * args.measurement_std**2
            rep = consistency(normalized_error_squared(Y - Yh, cov), len(have))
            print(
                f"  NEES mean {rep.mean:.3g} for {len(have)} dof (consistent interval "
                f"{rep.mean_bounds[0]:.3g}..{rep.mean_bounds[1]:.3g}, recorded values' noise "
                f"{args.measurement_std:g} included): "
                f"{'consistent' if rep.consistent else 'not consistent'}"
            )
    if sensor.measured_names:
        nis = est.nis()
        if np.isfinite(nis).sum() > 2:
            rep = consistency(nis, len(sensor.measured_names))
            print(
                f"  NIS mean {rep.mean:.3g} for {rep.dof} dof: "
                f"{'consistent' if rep.consistent else 'not consistent'}"
            )
    if args.plot:
        # figures only when asked: matplotlib costs ~0.5 s at start-up
        from thermogym.firmware.plots import plot_virtual_sensor

        plot_virtual_sensor(
            rec.time,
            {n: est[n] for n in est.names},
            plan.path("--plot"),
            measured={n: rec[n] for n in sensor.measured_names if n in rec},
            truth=truth or None,
            std={n: est.std[:, j] for j, n in enumerate(est.names)},
            unit=sensor.units.get(est.names[0], ""),
            title=f"virtual sensor: {Path(args.data).name}",
            truth_label="recorded",
        )
        print(f"  plot: {args.plot}")
    return 0
