"""Real measured thermal data sets, shipped with the package, as recordings.

These are recordings of real plants made by others, used to check the
identification and diagnosis methods on data nobody here generated. Each
folder under ``thermogym/datasets/data/`` keeps the original ``README.txt``
with origin, columns, units, licence and citation terms; :func:`info` prints
it. Only the files meant for development are shipped.

>>> from thermogym.datasets import dataset_names, load
>>> "tclab_step" in dataset_names()
True
>>> rec = load("hair_dryer")
>>> rec.columns, rec.n_samples, rec.dt
(('u', 'y'), 1000, 0.08)
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np

from thermogym.errors import UnknownNameError
from thermogym.recording import Recording

__all__ = ["DATASETS", "Dataset", "dataset_names", "info", "load", "path"]


def path(folder: str) -> Path:
    """Folder of a shipped data set (inside the installed package)."""
    return Path(str(resources.files("thermogym.datasets").joinpath("data", folder)))


@dataclass(frozen=True)
class Dataset:
    """A shipped data set: folder, description, loader."""

    name: str
    folder: str
    description: str
    loader: Callable[[], Recording]


def _daisy(folder: str, file: str) -> np.ndarray:
    return np.loadtxt(path(folder) / file)


def _hair_dryer() -> Recording:
    d = _daisy("daisy_hair_dryer", "dryer.dat")
    return Recording(
        0.08 * np.arange(d.shape[0]),
        {"u": d[:, 0], "y": d[:, 1]},
        units={"u": "V", "y": "V"},
        roles={"u": "input", "y": "output"},
        experiment_id="daisy-hair-dryer",
        source="DaISy 96-006 (Favoreel, KU Leuven)",
        meta={
            "note": "y is the outlet air temperature as a thermocouple voltage; "
            "sampling time 0.08 s from MATLAB's dryer2 description",
            "citation": "De Moor (ed.), DaISy: Database for the Identification of Systems",
        },
    )


def _thermic_wall() -> Recording:
    d = _daisy("daisy_thermic_wall", "thermic_res_wall.dat")
    return Recording(
        np.arange(d.shape[0], dtype=float),
        {"T_in": d[:, 0], "T_out": d[:, 1], "q": d[:, 2]},
        units={"T_in": "°C", "T_out": "°C"},
        roles={"T_in": "input", "T_out": "input", "q": "output"},
        experiment_id="daisy-thermic-wall",
        source="DaISy (Favoreel, KU Leuven; JRC Ispra 1994)",
        meta={
            "note": "sampling time not stated: time is the sample index; q is the heat flow "
            "density (units not stated)"
        },
    )


def _heat_exchanger() -> Recording:
    d = _daisy("daisy_heat_exchanger", "exchanger.dat")
    return Recording(
        d[:, 0] - d[0, 0],
        {"q": d[:, 1], "th": d[:, 2]},
        units={"th": "°C"},
        roles={"q": "input", "th": "output"},
        experiment_id="daisy-heat-exchanger",
        source="DaISy 97-002 (Bittanti, Politecnico di Milano)",
        meta={
            "note": "liquid-saturated steam heat exchanger; q is the liquid flow rate (units "
            "not stated); non-minimum-phase"
        },
    )


def _glass_furnace() -> Recording:
    d = _daisy("daisy_glass_furnace", "glassfurnace.dat")
    cols = {f"u{i + 1}": d[:, 1 + i] for i in range(3)} | {
        f"y{i + 1}": d[:, 4 + i] for i in range(6)
    }
    return Recording(
        d[:, 0] - d[0, 0],
        cols,
        roles={k: ("input" if k.startswith("u") else "output") for k in cols},
        experiment_id="daisy-glass-furnace",
        source="DaISy (Van Overschee, KU Leuven; Philips)",
        meta={
            "note": "normalised data; sampling time not stated (time = sample index); "
            "u1, u3 heating, u2 cooling; y1..y6 temperatures"
        },
    )


def _building() -> Recording:
    f = path("building_dtu_prbs_1983") / "data_building.csv"
    d = np.loadtxt(f, delimiter=",", skiprows=1, usecols=(1, 2, 3, 4))
    return Recording(
        600.0 * np.arange(d.shape[0]),
        {"P_heater": 1000.0 * d[:, 2], "T_out": d[:, 1], "G_solar": d[:, 3], "T_in": d[:, 0]},
        units={"P_heater": "W", "T_out": "°C", "G_solar": "kW/m2", "T_in": "°C"},
        roles={
            "P_heater": "input",
            "T_out": "disturbance",
            "G_solar": "disturbance",
            "T_in": "output",
        },
        experiment_id="dtu-building-1983",
        source="DTU test building, October 1983 "
        "(probably Madsen & Holst 1995; via edxu96/BuildingHeatDynamics, MIT)",
        meta={"note": "PRBS on/off heater 0 / 1.5 kW; 10-min samples"},
    )


_TCLAB_DOWLING = {
    "tclab_step": "tclab_step_test.csv",
    "tclab_sine": "tclab_sine_test_5min_period.csv",
    "tclab_sin_2_50_run1": "validation_experiment_env_2_sin_2_50_run_1.csv",
    "tclab_sin_2_50_run2": "validation_experiment_env_2_sin_2_50_run_2.csv",
    "tclab_sin_2_50_run3": "validation_experiment_env_2_sin_2_50_run_3.csv",
    "tclab_sin_5_50_run2": "validation_experiment_env_2_sin_5_50_run_2.csv",
    "tclab_step_50_run2": "validation_experiment_env_2_step_50_run_2.csv",
}
_TCLAB_APM = {
    "tclab_mimo_1s": "mimo_steps_1s_energy_balance.txt",
    "tclab_mimo_3s_a": "mimo_steps_3s_2nd_order.txt",
    "tclab_mimo_3s_b": "mimo_steps_3s_hybrid.txt",
}
_TCLAB_META = {
    "units": {"Q1": "%", "Q2": "%", "T1": "°C", "T2": "°C"},
    "roles": {"Q1": "input", "Q2": "input", "T1": "output", "T2": "output"},
}


def _tclab_dowling(key: str) -> Callable[[], Recording]:
    def load_() -> Recording:
        d = np.loadtxt(path("tclab_dowlinglab") / _TCLAB_DOWLING[key], delimiter=",", skiprows=1)
        return Recording(
            d[:, 0] - d[0, 0],
            {"Q1": d[:, 3], "Q2": d[:, 4], "T1": d[:, 1], "T2": d[:, 2]},
            experiment_id=key,
            source="TCLab, Dowling Lab (Notre Dame), dowlinglab/pyomo-doe, BSD-3-Clause",
            meta={
                "file": _TCLAB_DOWLING[key],
                "note": "time steps 0.98-1.02 s (not exactly uniform)",
            },
            **_TCLAB_META,  # type: ignore[arg-type]
        )

    return load_


def _tclab_apm(key: str) -> Callable[[], Recording]:
    def load_() -> Recording:
        d = np.loadtxt(path("tclab_apmonitor_mimo") / _TCLAB_APM[key], delimiter=",", skiprows=1)
        return Recording(
            d[:, 0] - d[0, 0],
            {"Q1": d[:, 1], "Q2": d[:, 2], "T1": d[:, 3], "T2": d[:, 4]},
            experiment_id=key,
            source="TCLab, APMonitor/arduino (BYU), Apache-2.0",
            meta={"file": _TCLAB_APM[key], "note": "not exactly uniform sampling"},
            **_TCLAB_META,  # type: ignore[arg-type]
        )

    return load_


DATASETS: dict[str, Dataset] = {
    d.name: d
    for d in [
        Dataset(
            "hair_dryer",
            "daisy_hair_dryer",
            "hair dryer: heater voltage -> outlet air temperature (1000 samples, 0.08 s)",
            _hair_dryer,
        ),
        Dataset(
            "thermic_wall",
            "daisy_thermic_wall",
            "two-layer wall: inner and outer temperatures -> heat-flow density",
            _thermic_wall,
        ),
        Dataset(
            "heat_exchanger",
            "daisy_heat_exchanger",
            "steam heat exchanger: liquid flow -> outlet temperature (4000 samples, 1 s)",
            _heat_exchanger,
        ),
        Dataset(
            "glass_furnace",
            "daisy_glass_furnace",
            "glass furnace: 3 inputs -> 6 temperatures (normalised)",
            _glass_furnace,
        ),
        Dataset(
            "building",
            "building_dtu_prbs_1983",
            "test building: PRBS heater, outdoor temperature, solar -> indoor temperature (10 min)",
            _building,
        ),
        *(
            Dataset(k, "tclab_dowlinglab", f"TCLab heater 1 test ({v})", _tclab_dowling(k))
            for k, v in _TCLAB_DOWLING.items()
        ),
        *(
            Dataset(k, "tclab_apmonitor_mimo", f"TCLab MIMO steps ({v})", _tclab_apm(k))
            for k, v in _TCLAB_APM.items()
        ),
    ]
}


def dataset_names() -> list[str]:
    """Names accepted by :func:`load`."""
    return list(DATASETS)


def load(name: str) -> Recording:
    """Load a shipped data set as a :class:`~thermogym.recording.Recording`.

    Raises
    ------
    UnknownNameError
        ``name`` is not a shipped data set (the message lists them).
    """
    try:
        return DATASETS[name].loader()
    except KeyError:
        raise UnknownNameError(
            f"unknown data set {name!r}; data sets are {dataset_names()}"
        ) from None


def info(name: str) -> str:
    """The provenance README of a data set (origin, columns, licence, citation)."""
    if name not in DATASETS:
        load(name)  # raises the clear error
    return (path(DATASETS[name].folder) / "README.txt").read_text()
