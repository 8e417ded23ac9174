"""Check an external-model configuration on a recording.

``python -m thermogym.identification.external CONFIG RECORDING [options]``
loads the configuration, simulates the start values (and values given with
``--set``) on the recording, prints the fit per output (NRMSE, RMSE, ξ of
:mod:`thermogym.identification.metrics`) and, with ``--timing``, what one
evaluation and a batch cost. ``--out FILE`` writes the simulated outputs as a
recording (CSV or Parquet, atomically). Exit status 0 when the model ran,
1 when it failed (its message is printed), 2 for a bad configuration.
"""

from __future__ import annotations

import argparse
import json
import sys

from thermogym.errors import ConfigError, ThermogymError


def main(argv: list[str] | None = None) -> int:
    """Command-line entry point; returns the exit status."""
    ap = argparse.ArgumentParser(
        prog="python -m thermogym.identification.external", description=__doc__.split("\n\n")[0]
    )
    ap.add_argument("config", help="external-model configuration (.toml, .yaml, .json)")
    ap.add_argument("recording", help="recording with the model's input and output columns")
    ap.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="value of an uncertain parameter",
    )
    ap.add_argument(
        "--backend",
        choices=["process", "ray", "serial"],
        help="override the configuration's backend",
    )
    ap.add_argument("--workers", type=int, help="override the number of workers")
    ap.add_argument("--timing", action="store_true", help="time one evaluation and a batch of 16")
    ap.add_argument("--out", help="write the simulated outputs to this recording file")
    ap.add_argument("--json", action="store_true", help="print the report as JSON")
    args = ap.parse_args(argv)

    # after argument parsing: --help answers without pandas
    from thermogym.identification.external import load_external, time_evaluations
    from thermogym.identification.external.base import ExternalModel
    from thermogym.identification.metrics import fit_report
    from thermogym.recording import read_recording, write_recording

    overrides = {
        k: v for k, v in (("backend", args.backend), ("workers", args.workers)) if v is not None
    }
    try:
        values = {}
        for item in args.set:
            name, sep, val = item.partition("=")
            if not sep:
                raise ThermogymError(f"--set {item!r}: expected NAME=VALUE")
            values[name.strip()] = float(val)
        loaded = load_external(args.config, **overrides)
        if not isinstance(loaded, ExternalModel):  # a co-simulation has no predict()
            loaded.close()
            raise ConfigError(
                f"{args.config}: a co-simulation is checked model by model; give the "
                "configuration of one of its models"
            )
        model = loaded
        rec = read_recording(args.recording)
    except (ThermogymError, ValueError, OSError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    try:
        try:
            pred = model.predict(rec, **values)
        except ThermogymError as e:
            print(f"error: {e}", file=sys.stderr)
            return 1
        measured = {c: rec[c] for c in model.output_names if c in rec.columns}
        report: dict = {
            "model": model.name,
            "parameters": pred.meta.get("parameters", {}),
            "fit": fit_report(measured, {c: pred[c] for c in measured}) if measured else {},
            "stats": model.stats,
        }
        if args.timing:
            report["timing"] = time_evaluations(model, rec).as_dict()
        if args.out:
            write_recording(pred, args.out)
        if args.json:
            print(json.dumps(report, indent=1, default=float))
        else:
            print(f"{model!r}")
            print("values: " + ", ".join(f"{k}={v:g}" for k, v in report["parameters"].items()))
            for c in measured:
                fit = report["fit"]
                print(
                    f"  {c}: NRMSE fit {fit['nrmse'][c]:.4f}, RMSE {fit['rmse'][c]:.4g}, "
                    f"xi {fit['xi'][c]:.4f}"
                )
            missing = [c for c in model.output_names if c not in rec.columns]
            if missing:
                print(f"  (no measured column for {missing})")
            if args.timing:
                t = report["timing"]
                print(
                    f"timing: start-up {t['startup_s']:.3f} s, "
                    f"single {1e3 * t['single_s']:.2f} ms, "
                    f"batch of {t['batch_size']} {t['batch_s']:.3f} s; load {t['load'][0]:.2f}"
                )
    finally:
        model.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
