"""The work of ``thermogym experiment``.

The command's description and its options: :mod:`thermogym._cli.experiment`.
"""

from __future__ import annotations

import argparse
import ast
import inspect
import math
from typing import Any

# the rigs are used through their module (rigs.run_experiment looked up when called), so that
# a replacement there is used (the tests that check bad input is refused before any work)
from thermogym import rigs
from thermogym._cli.common import plan_outputs
from thermogym.errors import ConfigError

#: Option names whose values must be > 0 (durations, periods, speeds, rates, counts, steps).
_POSITIVE = (
    "dt",
    "duration_h",
    "on_s",
    "hold_s",
    "speeds",
    "feed_rates",
    "voltages",
    "supply_V",
    "periods",
    "n",
    "folds",
    "step",
)


#: Option names whose values must be >= 0.
_NONNEGATIVE = ("off_s",)


#: Temperatures [°C]: ambient and set points, inside what the rigs' physics covers.
_TEMPERATURES = ("T_air", "ambients", "ambient_C", "low", "high")


_T_RANGE = (-60.0, 200.0)


#: Largest number of samples one protocol run may ask for (about 1 GB of float64 per column
#: set); beyond it the options are refused before the rig runs.
_MAX_SAMPLES = 20_000_000


#: Largest number of experiments a list option may ask for.
_MAX_ITEMS = 100


def _literal(value: str) -> Any:
    try:
        return ast.literal_eval(value.strip())
    except (ValueError, SyntaxError, MemoryError, RecursionError, TypeError):
        return value.strip()


def _is_number(v: Any) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool)


def _check_value(key: str, raw: str, value: Any, default: Any) -> Any:
    """``value`` converted to the type of the protocol's ``default``, or a clear error."""
    where = f"--option {key}={raw}"
    if isinstance(default, bool):
        if isinstance(value, bool):
            return value
        if isinstance(value, str) and value.lower() in ("true", "false"):
            return value.lower() == "true"
        raise ConfigError(f"{where}: expected true or false")
    if isinstance(default, list | tuple):
        items = [value] if _is_number(value) else value
        like = f"{key}=[{','.join(f'{x:g}' for x in default)}]"
        if not isinstance(items, list | tuple) or not items:
            raise ConfigError(f"{where}: expected a list of numbers like {like}")
        bad = [x for x in items if not _is_number(x) or not math.isfinite(x)]
        if bad:
            raise ConfigError(
                f"{where}: {bad[0]!r} is not a number; expected a list of numbers like {like}"
            )
        if len(items) > _MAX_ITEMS:
            raise ConfigError(f"{where}: {len(items)} items; at most {_MAX_ITEMS} are run")
        whole_items = all(isinstance(x, int) for x in default)
        if whole_items and any(float(x) != int(x) for x in items):
            raise ConfigError(f"{where}: expected whole numbers")
        out = [int(x) if whole_items else float(x) for x in items]
        _check_sign(key, where, out)
        return out
    if _is_number(default):
        if not _is_number(value) or not math.isfinite(value):
            raise ConfigError(f"{where}: expected a number like {key}={default!r}")
        if isinstance(default, int) and float(value) != int(value):
            raise ConfigError(f"{where}: expected a whole number like {key}={default!r}")
        v = int(value) if isinstance(default, int) else float(value)
        _check_sign(key, where, [v])
        return v
    return value


def _check_sign(key: str, where: str, values: list[Any]) -> None:
    if key in _POSITIVE and any(x <= 0 for x in values):
        raise ConfigError(f"{where}: expected values > 0")
    if key in _NONNEGATIVE and any(x < 0 for x in values):
        raise ConfigError(f"{where}: expected values >= 0")
    lo, hi = _T_RANGE
    if key in _TEMPERATURES and any(not lo <= x <= hi for x in values):
        raise ConfigError(f"{where}: expected temperatures in [{lo:g}, {hi:g}] °C")


def _options(rig_name: str, protocol: str, items: list[str]) -> dict[str, Any]:
    """``--option`` items checked against the protocol's keyword defaults."""
    rig = rigs.get_rig(rig_name)
    try:
        proto = rig.protocols[protocol]
    except KeyError:
        raise ConfigError(
            f"rig {rig_name!r} has no protocol {protocol!r}; protocols are {list(rig.protocols)}"
        ) from None
    params = {
        n: prm.default
        for n, prm in inspect.signature(proto.run).parameters.items()
        if prm.kind == prm.KEYWORD_ONLY
    }
    out: dict[str, Any] = {}
    for item in items:
        key, sep, value = item.partition("=")
        key = key.strip()
        if not sep or not key.isidentifier():
            raise ConfigError(f"--option {item!r} is not of the form KEY=VALUE")
        if key not in params:
            raise ConfigError(
                f"--option {key}: protocol {protocol!r} of rig {rig_name!r} has no option "
                f"{key!r}; options are {sorted(params)}"
            )
        if key in out:
            raise ConfigError(f"--option {key} is given twice")
        default = params[key]
        out[key] = _check_value(key, value, _literal(value), default)
    _check_size(rig_name, protocol, {**params, **out}, out)
    return out


def _check_size(rig: str, protocol: str, opts: dict[str, Any], given: dict[str, Any]) -> None:
    """Refuse options that would ask for more samples than memory holds."""
    dt = opts.get("dt")
    if not isinstance(dt, int | float) or isinstance(dt, bool) or dt <= 0 or not given:
        return
    span = sum(
        float(opts[k]) * (3600.0 if k.endswith("_h") else 1.0)
        for k in ("on_s", "off_s", "hold_s", "duration_h")
        if _is_number(opts.get(k))
    )
    if span and span / float(dt) > _MAX_SAMPLES:
        raise ConfigError(
            f"the options of {rig} {protocol} ask for {span / float(dt):.3g} samples per "
            f"experiment (dt = {dt:g} s); at most {_MAX_SAMPLES:.0e} are run: raise dt or "
            "shorten the protocol"
        )


def run(args: argparse.Namespace) -> int:
    """Run the protocol and write its recordings."""
    rigs.get_rig(args.rig, args.effect)  # unknown rig or effect: refused before anything else
    options = _options(args.rig, args.protocol, args.option)
    plan = plan_outputs(args, folders=("out",))
    with plan:
        recs = rigs.run_experiment(
            args.rig,
            args.protocol,
            plan.path("--out"),
            seed=args.seed,
            effects=args.effect,
            fmt=args.fmt,
            **options,
        )
    for rec in recs:
        print(f"{rec.experiment_id}: {rec.n_samples} samples, {rec.duration / 3600:.2f} h")
    print(f"wrote {len(recs)} recording(s) and manifest.json to {args.out}")
    return 0
