"""Units that say nothing are not a conflict; units that disagree are.

A FitResult identified from a CSV without units stores ``"1"`` for its
signals. Simulating it on a recording with units (the README's TCLab example
followed by the shipped data set) must work, with a note that the units were
not checked; a real conflict (``"°C"`` against ``"K"``) is still refused, by
``simulate`` and by ``virtual-sensor`` alike.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import lfilter

from thermogym.cli import main as cli_main
from thermogym.errors import UnitError
from thermogym.fitresult import FitResult
from thermogym.recording import Recording, read_recording, write_recording


def lag(units: dict[str, str] | None, n: int = 400, seed: int = 1) -> Recording:
    """Two first-order heater lags at 20 °C, heater steps (noise-free)."""
    rng = np.random.default_rng(seed)
    u = np.r_[0.0, np.repeat(rng.uniform(0.0, 10.0, n // 20), 20)][:n]
    y1 = 20.0 + lfilter([0.0, 0.5], [1.0, -0.9], u)
    y2 = 20.0 + lfilter([0.0, 0.3], [1.0, -0.8], u)
    cols = {"Q1": u, "T1": y1, "T2": y2}
    if units is not None and "T1" in units:
        units = {**units, "T2": units["T1"]}
    return Recording(np.arange(float(n)), cols, units=units, experiment_id="lag")


def test_check_units_accepts_unspecified_and_refuses_a_real_conflict():
    rec = lag({"Q1": "%", "T1": "°C"})
    assert rec.check_units({"Q1": "1", "T1": "1"}, "model 'ss'") == ("Q1", "T1")
    assert rec.check_units({"Q1": "%", "T1": "degC"}, "model 'ss'") == ()
    assert lag(None).check_units({"Q1": "W", "T1": "1"}, "model 'ss'") == ("Q1",)
    assert lag({"Q1": "-"}).check_units({"Q1": "1"}, "model 'ss'") == ()  # both unspecified
    with pytest.raises(UnitError, match=r"column 'T1' of recording 'lag' is in '°C', model "
                       r"'ss' expects 'K'"):  # fmt: skip
        rec.check_units({"Q1": "1", "T1": "K"}, "model 'ss'")
    with pytest.raises(UnitError, match=r"'Q1' .* is in '%', model 'ss' expects 'W'"):
        rec.check_units({"Q1": "W"}, "model 'ss'")


def _identify(tmp_path, rec: Recording, name: str) -> str:
    write_recording(rec, tmp_path / f"{name}.csv")
    out = tmp_path / f"{name}.json"
    argv = ["identify", "n4sid", str(tmp_path / f"{name}.csv"), "--inputs", "Q1",
            "--outputs", "T1,T2", "--orders", "2", "--operating-point", "rest",
            "--out", str(out)]  # fmt: skip
    assert cli_main(argv) == 0
    return str(out)


def test_simulate_a_fit_without_units_on_data_with_units(tmp_path, capsys):
    fit = _identify(tmp_path, lag(None), "raw")
    assert set(FitResult.load(fit).model_config["units"].values()) == {"1"}
    write_recording(lag({"Q1": "%", "T1": "°C"}, seed=2), tmp_path / "units.csv")
    argv = ["simulate", "--params", fit, "--inputs", str(tmp_path / "units.csv"),
            "--out", str(tmp_path / "sim.csv")]  # fmt: skip
    assert cli_main(argv) == 0
    out = capsys.readouterr().out
    assert "units not checked for 'Q1' (recording '%', model 'ss' unspecified)" in out
    assert "T1                       fit 100.00 %" in out
    assert read_recording(tmp_path / "sim.csv").n_samples == 400


def test_simulate_and_virtual_sensor_refuse_a_real_unit_conflict(tmp_path, capsys):
    fit = _identify(tmp_path, lag({"Q1": "W", "T1": "°C"}), "units")
    write_recording(lag({"Q1": "W", "T1": "K"}, seed=2), tmp_path / "kelvin.csv")
    data = str(tmp_path / "kelvin.csv")
    argv = ["simulate", "--params", fit, "--inputs", data, "--out", str(tmp_path / "s.csv")]
    assert cli_main(argv) == 2
    err = capsys.readouterr().err
    assert "column 'T1' of recording 'lag' is in 'K', model 'ss' expects '°C'" in err
    vs = ["virtual-sensor", data, "--fit", fit, "--measured", "T1",
          "--out", str(tmp_path / "vs.csv")]  # fmt: skip
    assert cli_main(vs) == 2
    err = capsys.readouterr().err
    assert "column 'T1' of recording 'lag' is in 'K', fit 'units.json' expects '°C'" in err
    assert not (tmp_path / "vs.csv").exists() and not (tmp_path / "s.csv").exists()
    # the same data without units: estimated, with a note that the units were not checked
    write_recording(lag(None, seed=2), tmp_path / "raw.csv")
    vs[1] = str(tmp_path / "raw.csv")
    assert cli_main(vs) == 0
    assert "units not checked for 'Q1' (recording unspecified, fit 'units.json' 'W')" in (
        capsys.readouterr().out
    )
