"""Virtual test rigs: plants of their own that run the papers' experiments as recordings.

Each rig has a true plant written apart from the identified models
(:class:`~thermogym.rigs.base.TruePlant`), richer than them, with a table of
what it has that the model lacks; sensors (:mod:`thermogym.rigs.sensors`);
protocols; and concealed effects in its own physics.

>>> from thermogym.rigs import get_rig, rig_names
>>> rig_names()
['axt211', 'room', 'spindle', 'strut']
>>> sorted(get_rig("strut").protocols)
['steps']
"""

from __future__ import annotations

import json
import os
import secrets
import shutil
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from thermogym._fileio import atomic_write_text
from thermogym.errors import ConfigError, SimulationError, UnknownNameError
from thermogym.recording import Recording, write_recording
from thermogym.rigs.axt211 import AXT211Rig
from thermogym.rigs.base import (
    EFFECT_NAMES,
    EffectSpec,
    ExtraPhysics,
    PhysicalParameter,
    Rig,
    RigRun,
    Specimens,
    TruePlant,
    parse_effect,
)
from thermogym.rigs.room import RoomRig
from thermogym.rigs.sensors import Sensor
from thermogym.rigs.spindle import SpindleRig
from thermogym.rigs.strut import StrutRig

__all__ = [
    "EFFECT_NAMES",
    "PHYSICAL_C",
    "EffectSpec",
    "ExtraPhysics",
    "PhysicalParameter",
    "Rig",
    "RigRun",
    "Sensor",
    "Specimens",
    "TruePlant",
    "check_physical",
    "get_rig",
    "parse_effect",
    "rig_names",
    "run_experiment",
    "to_recording",
]

_RIGS: dict[str, type[Rig]] = {
    "axt211": AXT211Rig,
    "room": RoomRig,
    "spindle": SpindleRig,
    "strut": StrutRig,
}


def rig_names() -> list[str]:
    """Names of the virtual rigs."""
    return list(_RIGS)


def get_rig(
    name: str, effects: Sequence[str | EffectSpec] = (), *, off: Sequence[str] = (), **options: Any
) -> Rig:
    """Build the rig called ``name``, optionally carrying concealed effects.

    Parameters
    ----------
    name : str
        One of :func:`rig_names`.
    effects : sequence of str or EffectSpec
        ``NAME[:k=v,...]`` effects from the vocabulary (see :data:`EFFECT_NAMES`).
    off : sequence of str
        Rows of the rig's table of extra physics to switch off (rigs with a
        true plant of their own).
    **options
        Constructor options of the rig (the room rig's ``valve``).
    """
    try:
        cls = _RIGS[name]
    except KeyError:
        raise UnknownNameError(f"unknown rig {name!r}; rigs are {rig_names()}") from None
    if off or options:
        return cls(effects, off=off, **options)  # type: ignore[call-arg]
    return cls(effects)


#: Temperatures [°C] a rig's recording can hold: above absolute zero, below where its
#: parts would have melted (steels about 1400-1500 °C; the rigs' waxes, oils and plastics far
#: lower). A value outside means the protocol's options drove the simulation out of its
#: physics (e.g. a feed rate of 1e300 m/min), not a measurement.
PHYSICAL_C = (-273.15, 2000.0)


def check_physical(rec: Recording, rig: str, protocol: str) -> None:
    """Refuse a rig recording with an infinite value or an impossible temperature.

    Missing samples (NaN: sensor dropouts) are allowed.

    Raises
    ------
    SimulationError
        Naming the recording, the column, the first bad value and its time.
    """
    lo, hi = PHYSICAL_C
    for name in rec.columns:
        v = rec[name]
        bad = np.isinf(v)
        if rec.units.get(name) == "°C":
            bad |= (v < lo) | (v > hi)
        if bad.any():
            k = int(np.argmax(bad))
            raise SimulationError(
                f"rig {rig!r} protocol {protocol!r}: recording {rec.experiment_id!r} has "
                f"{name} = {float(v[k]):.4g} {rec.units.get(name, '')} at time "
                f"{float(rec.time[k]):g} s, outside what the rig can hold ({lo:g} to {hi:g} °C, "
                "finite); its options drove the simulation out of its physics: choose values "
                "nearer the protocol's defaults"
            )


def to_recording(run: RigRun, rig: str) -> Recording:
    """Turn a rig run into a :class:`~thermogym.recording.Recording` (truth is not kept)."""
    return Recording(
        run.time,
        run.columns,
        units={k: v for k, v in run.units.items() if k in run.columns},
        roles={k: v for k, v in run.roles.items() if k in run.columns},
        experiment_id=run.experiment_id,
        source=f"thermogym virtual rig {rig!r}",
        meta=run.meta,
    )


def run_experiment(
    rig: str,
    protocol: str,
    out: str | Path | None = None,
    *,
    seed: int = 0,
    effects: Sequence[str | EffectSpec] = (),
    fmt: str = "csv",
    overwrite: bool = True,
    **options: Any,
) -> list[Recording]:
    """Run a rig protocol; write its recordings and a ``manifest.json`` when ``out`` is given.

    Parameters
    ----------
    rig, protocol : str
        Rig name and protocol name.
    out : path, optional
        Folder for the recordings (created if needed). The files are written
        into a staging folder inside it and moved into place, manifest last,
        only when all of them were written.
    seed : int
        Seed of every random draw.
    effects : sequence
        Concealed physics (never written to the metadata).
    fmt : {"csv", "parquet"}
        File format.
    overwrite : bool
        Replace existing files of the same name.
    **options
        Protocol options.

    Returns
    -------
    list of Recording
    """
    if fmt not in ("csv", "parquet"):
        raise ConfigError(f"format {fmt!r} is not supported; use 'csv' or 'parquet'")
    r = get_rig(rig, effects)
    recs = [to_recording(run, rig) for run in r.run(protocol, seed=seed, **options)]
    for rec in recs:
        check_physical(rec, rig, protocol)
    if out is not None:
        folder = Path(out)
        folder.mkdir(parents=True, exist_ok=True)
        # every file goes to a staging folder first and moves into place only when all of
        # them (manifest included) were written: an interrupted run leaves no partial set
        stage = folder / f".staging-{os.getpid()}-{secrets.token_hex(4)}"
        stage.mkdir()
        try:
            entries = []
            for rec in recs:
                name = f"{rec.experiment_id}.{fmt}"
                if not overwrite and (folder / name).exists():
                    raise ConfigError(f"{str(folder / name)!r} exists and overwrite=False")
                write_recording(rec, stage / name)
                entries.append(
                    {
                        "file": name,
                        "experiment_id": rec.experiment_id,
                        "n_samples": rec.n_samples,
                        "duration_s": rec.duration,
                        "meta": rec.meta,
                    }
                )
            manifest = {"rig": rig, "protocol": protocol, "seed": seed, "recordings": entries}
            atomic_write_text(stage / "manifest.json", json.dumps(manifest, indent=2) + "\n")
            for f in sorted(stage.iterdir(), key=lambda f: f.name == "manifest.json"):
                os.replace(f, folder / f.name)  # the manifest last
        finally:
            shutil.rmtree(stage, ignore_errors=True)
    return recs
