"""Sensor-module firmware: RTD reference, code generation, export, host C tests, AVR.

The host tests build the exported C sources with the machine's C compiler and
compare them with the Python observer on a day of spindle-rig data and with
the Python RTD reference over −50..300 °C. The AVR tests (avr-gcc, avr-size,
simavr) skip with a reason when the tools are not installed; ``make -C
firmware test`` installs them when it can.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from thermogym.cli import main
from thermogym.errors import ConfigError
from thermogym.estimation import VirtualSensor
from thermogym.firmware import rtd
from thermogym.firmware.codegen import TARGETS, firmware_model, footprint
from thermogym.firmware.export import C_SOURCES, c_source_dir, export
from thermogym.firmware.reference import spindle_reference_model
from thermogym.firmware.selftest import run_case
from thermogym.firmware.toolchain import (
    avr_size_probe,
    avr_tools_available,
    host_compiler,
    run_host_test,
    run_simavr,
)
from thermogym.fitresult import FitResult

needs_cc = pytest.mark.skipif(host_compiler() is None, reason="no host C compiler (cc/gcc)")
needs_avr = pytest.mark.skipif(
    not avr_tools_available(simulator=True),
    reason="AVR tools missing (gcc-avr, avr-libc, simavr); `make -C firmware test` installs them",
)


# ======================================================================== RTD
def test_callendar_van_dusen_matches_the_standard_table():
    # DIN EN 60751 reference values of Pt1000 (table of the standard, rounded to 1 mΩ)
    t = np.array([-50.0, 0.0, 25.0, 100.0, 200.0, 300.0])
    r = np.array([803.063, 1000.0, 1097.347, 1385.055, 1758.560, 2120.515])
    assert np.allclose(rtd.temperature_to_resistance(t), r, atol=5e-4)
    back, st = rtd.resistance_to_temperature(r)
    assert np.allclose(back, t, atol=2e-6) and (st == rtd.RTD_OK).all()


def test_adc_code_round_trip_and_edge_statuses():
    cfg = rtd.AdcConfig()
    t = np.linspace(-50, 300, 701)
    codes = rtd.resistance_to_code(rtd.temperature_to_resistance(t), cfg)
    back, st = rtd.code_to_temperature(codes, cfg)
    lsb_K = cfg.r_ref / cfg.gain / 2**23 / (cfg.r0 * rtd.CVD_A)  # one code in kelvin
    assert np.abs(back - t).max() < lsb_K
    full = 2**24 - 1
    _, st = rtd.code_to_temperature([full, 2**23, 0], cfg)
    assert st.tolist() == [rtd.RTD_OPEN, rtd.RTD_SHORT, rtd.RTD_SHORT]
    _, st = rtd.code_to_temperature(
        rtd.resistance_to_code(rtd.temperature_to_resistance([-60, 310]))
    )
    assert st.tolist() == [3, 4]
    uni = rtd.AdcConfig(bipolar=False)
    c = rtd.resistance_to_code(1385.055, uni)
    assert abs(rtd.code_to_temperature(c, uni)[0][0] - 100.0) < 1e-3


# ==================================================================== codegen
def _scaled_run(fm, u, z, x0_phys):
    """Python float64 run of the C algorithm in the firmware's scaled coordinates."""
    us = (u - [c.offset for c in fm.u]) / [c.scale for c in fm.u]
    zs = (z - [c.offset for c in fm.z]) / [c.scale for c in fm.z] if fm.z else z
    x = fm.basis.T @ x0_phys - fm.x_off
    out = []
    for k in range(u.shape[0]):
        nu = zs[k] - fm.Cz @ x - fm.Dz @ us[k]
        ys = fm.Ch @ x + fm.Dh @ us[k] + fm.F @ nu
        out.append([c.offset for c in fm.y] + ys * [c.scale for c in fm.y])
        x = x + fm.M @ x + fm.B @ us[k] + fm.G @ nu
    return np.array(out)


def test_scaled_firmware_coordinates_are_an_exact_transformation():
    model = spindle_reference_model("1I7O", order=6)
    vs = VirtualSensor(model, measured=["T_front_outer_housing", "T_rear_outer_housing"])
    fm = firmware_model(vs.observer_matrices(), offsets={"T_amb": 21.0}, scales={"speed": 500.0})
    rng = np.random.default_rng(0)
    T = 300
    u = np.column_stack([rng.uniform(0, 8000, T), 20 + rng.normal(size=T)])
    z = 25 + rng.normal(size=(T, 2))
    x0 = vs.rest_state(u[0], z[0])
    ref = vs.observe(u, z, x0=x0).values
    assert np.allclose(_scaled_run(fm, u, z, x0), ref, atol=1e-9)
    # the rest state in scaled coordinates is the physical one minus the operating point
    us0 = (u[0] - [c.offset for c in fm.u]) / [c.scale for c in fm.u]
    zs0 = (z[0] - [c.offset for c in fm.z]) / [c.scale for c in fm.z]
    assert np.allclose(fm.Nu @ us0 + fm.Nz @ zs0, fm.basis.T @ x0 - fm.x_off, atol=1e-9)
    # the state basis is orthogonal and the slowest mode comes last
    assert np.allclose(fm.basis.T @ fm.basis, np.eye(fm.dims[0]), atol=1e-12)
    lam = np.abs(np.linalg.eigvals(fm.M + np.eye(fm.dims[0])))
    assert abs(fm.M[-1, -1] + 1 - lam.max()) < 1e-12


def test_footprint_grows_with_the_order_and_the_budget_says_by_how_much(tmp_path):
    sizes = [footprint(n, 3, 0, 5).flash_bytes for n in (4, 8, 16, 32)]
    assert sizes == sorted(sizes) and len(set(sizes)) == 4
    assert footprint(8, 3, 0, 5).fits
    assert not footprint(100, 3, 0, 5).fits
    assert footprint(100, 3, 0, 5).flash_excess > 0
    model = spindle_reference_model("3I5O-rise", order=8)
    fit = FitResult.from_model(model)
    need = footprint(8, 3, 0, 5, has_dh=True).flash_bytes
    out = tmp_path / "fw"
    with pytest.raises(ConfigError, match=r"bytes too many") as e:
        export(fit, out, check_avr=False, flash_budget=need - 100)
    assert "100 bytes too many" in str(e.value)
    assert not out.exists()  # nothing is left behind
    export(fit, out, check_avr=False, flash_budget=need)


def test_export_writes_header_sources_and_refuses_to_overwrite(tmp_path):
    model = spindle_reference_model("3I5O-rise", order=8)
    fit = FitResult.from_model(model, method="test")
    out = tmp_path / "fw"
    rep = export(fit, out, check_avr=False)
    assert rep.dims == (8, 3, 0, 5)
    for name in (*C_SOURCES, "vs_model.h", "budget.mk", "export.json"):
        assert (out / name).exists(), name
    header = (out / "vs_model.h").read_text()
    assert fit.fingerprint() in header
    assert "#define VS_N_X 8" in header and "#define VS_N_U 3" in header
    assert "#ifndef VS_MODEL_H" in header
    manifest = json.loads((out / "export.json").read_text())
    assert manifest["dims"]["n_states"] == 8
    (out / "vs_model.h").write_text("user edit")
    with pytest.raises(ConfigError, match="not empty"):
        export(fit, out, check_avr=False)
    assert (out / "vs_model.h").read_text() == "user edit"
    export(fit, out, check_avr=False, overwrite=True)
    assert "VS_N_X" in (out / "vs_model.h").read_text()


def test_c_sources_ship_inside_the_package():
    src = c_source_dir()
    for name in C_SOURCES:
        assert (src / name).is_file(), name
    for name in ("vs_observer.h", "rtd.h", "vs_types.h"):
        text = (src / name).read_text()
        guard = name.upper().replace(".", "_")
        assert f"#ifndef {guard}" in text and "@param" in text


# ================================================================= host C test
@pytest.fixture(scope="module")
def host_3i5o(tmp_path_factory):
    out = tmp_path_factory.mktemp("fw") / "3I5O-rise"
    run_case(out, "3I5O-rise", 8)
    return out


@needs_cc
def test_c_observer_equals_python_on_a_day_of_rig_data(host_3i5o):
    res = run_host_test(host_3i5o)
    assert res.passed, res.output
    assert res.observer_samples == 86400
    assert res.observer_max_err < 1e-3  # °C, the requirement
    assert res.rtd_max_err is not None and res.rtd_max_err < 1e-3
    assert "status mismatches 0" in res.output  # the invalid samples are held alike


@needs_cc
def test_c_kalman_observer_with_measured_channels(tmp_path):
    out = tmp_path / "1I7O"
    run_case(out, "1I7O", 8, samples=6 * 3600)
    res = run_host_test(out)
    assert res.passed, res.output
    assert res.observer_max_err < 1e-3
    # the same sources in double precision agree far more closely: float32 is the limit
    dbl = run_host_test(out, cflags="-DVS_FLOAT=double")
    assert dbl.passed and dbl.observer_max_err < 1e-3 * res.observer_max_err + 1e-9


@needs_cc
def test_cli_export_then_host_test(tmp_path, capsys, monkeypatch):
    from thermogym.firmware.selftest import rig_day
    from thermogym.recording import Recording, write_recording

    model = spindle_reference_model("1I7O", order=8)
    fit_path = tmp_path / "fit.json"
    FitResult.from_model(model, method="test").save(fit_path)
    day = rig_day(invalid=False)
    k = slice(0, 3 * 3600)
    data = Recording(day["time"][k], {c: v[k] for c, v in day.items() if c != "time"})
    write_recording(data, tmp_path / "day.csv")
    code = main(
        [
            "firmware", "export", str(fit_path), "--out", str(tmp_path / "fw"),
            "--measured", "T_front_outer_housing,T_rear_outer_housing",
            "--vectors", str(tmp_path / "day.csv"), "--rest", "speed=0", "--no-avr-check",
        ]
    )  # fmt: skip
    assert code == 0, capsys.readouterr()
    assert "exported the order-8 observer" in capsys.readouterr().out
    assert run_host_test(tmp_path / "fw").passed
    # a relative folder works as well (the compiler runs inside the folder)
    monkeypatch.chdir(tmp_path)
    assert run_host_test(Path("fw")).passed
    assert main(["firmware", "budget", str(fit_path)]) == 0
    assert json.loads(capsys.readouterr().out)["fits"] is True


def test_cli_refuses_a_model_too_big_for_the_target(tmp_path, capsys):
    fit_path = tmp_path / "fit.json"
    FitResult.from_model(spindle_reference_model("3I5O-rise", order=8)).save(fit_path)
    args = ["firmware", "export", str(fit_path), "--out", str(tmp_path / "fw"), "--no-avr-check"]
    assert main([*args, "--flash-budget", "4000"]) == 2
    err = capsys.readouterr().err
    assert "does not fit the atmega328p" in err and "bytes too many" in err
    assert not (tmp_path / "fw").exists()
    assert main(["firmware", "budget", str(fit_path), "--ram-budget", "100"]) == 1
    assert json.loads(capsys.readouterr().out)["fits"] is False


# ======================================================================== AVR
@needs_avr
def test_order_8_observer_on_the_atmega328p(host_3i5o):
    probe = avr_size_probe(host_3i5o)
    assert probe["ram_bytes"] < 1024 and probe["flash_bytes"] < 16384
    sim = run_simavr(host_3i5o)
    assert sim.observer["status_mismatch"] == 0 and sim.rtd["status_mismatch"] == 0
    assert sim.max_err_degC < 1e-3
    assert sim.step_ms < 20.0  # at 16 MHz, the sampling period being 240 ms
    assert sim.rtd["max_err_udegC"] < 1000


@needs_avr
def test_avr_size_confirms_the_estimate(tmp_path):
    model = spindle_reference_model("1I7O", order=8)
    rep = export(
        FitResult.from_model(model),
        tmp_path / "fw",
        sensor_kwargs={"measured": ["T_front_outer_housing", "T_rear_outer_housing"]},
        check_avr=True,
    )
    assert rep.avr_size is not None
    est = rep.footprint
    # the estimate is an upper bound within a few hundred bytes
    assert 0 <= est.flash_bytes - rep.avr_size["flash_bytes"] < 600
    assert abs(est.ram_bytes - rep.avr_size["ram_bytes"]) < 64


def test_make_is_available_for_the_firmware_makefile():
    if shutil.which("make") is None:
        pytest.skip("make is not installed")
    assert TARGETS["atmega328p"].flash_bytes == 32768
