"""The benchmark harness: a tiny grid, reports, backends, scenarios, presets, CLI."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from thermogym.cli import main as cli_main
from thermogym.controllers import (
    EpisodeSpec,
    build_controller,
    expand_controllers,
    get_scenario,
    run_benchmark,
    run_episode,
    sim_to_real_gap,
)
from thermogym.controllers.report import pareto_front
from thermogym.errors import ConfigError, UnknownNameError

VALVE = "thermogym/AXT211Valve-v0"
# run-dependent columns: everything else must be identical between runs and backends
VOLATILE = ["wall_s"]


def _stable(t: pd.DataFrame) -> pd.DataFrame:
    return t.drop(columns=VOLATILE).reset_index(drop=True)


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench")
    res = run_benchmark(
        VALVE,
        ["setpoint-steps"],
        "onoff,pwm-high,pid",
        seeds=[0, 1],
        out=out,
        backend="serial",
        plants=("model", "rig"),
    )
    return res, out


def test_tiny_grid_table_is_tidy_and_reproducible(tiny):
    res, _ = tiny
    t = res.table
    assert len(t) == 3 * 2 * 2
    assert set(t["controller"]) == {"onoff", "pwm-high", "pid"}
    assert set(t["plant"]) == {"model", "rig"}
    for col in (
        "package_version",
        "env_version",
        "scenario_version",
        "controller_settings",
        "controller_fits",
        "env_fit_fingerprint",
        "seed",
    ):
        assert col in t.columns and t[col].notna().all(), col
    assert (t["env_version"] == "v0").all() and (t["steps"] == 1440).all()
    # settings are JSON and name the tuning model of the PID
    pid = t[t["controller"] == "pid"].iloc[0]
    s = json.loads(pid["controller_settings"])
    assert s["type"] == "PWM" and s["inner"]["tuning"]["method"] == "SIMC"
    assert len(pid["controller_fits"]) == 64
    # the rig and the model are different plants (fingerprints), the KPIs come from info["kpis"]
    assert t.groupby("plant")["env_fit_fingerprint"].nunique().tolist() == [1, 1]
    assert (
        t[t.plant == "model"].env_fit_fingerprint.iloc[0]
        != t[t.plant == "rig"].env_fit_fingerprint.iloc[0]
    )
    for k in ("actuator_energy_Wh", "switch_cycles", "wax_thermal_cycles", "stroke_rmse_mm"):
        assert (t[k] > 0).all(), k
    # the same episode again gives the same row
    spec = res.specs[0]
    again = run_episode(spec)["row"]
    row = t.iloc[0].to_dict()
    for k, v in again.items():
        if k not in VOLATILE:
            assert row[k] == v or (isinstance(v, float) and np.isclose(row[k], v, rtol=0, atol=0))


def test_feedback_beats_open_loop_and_onoff_switches_least(tiny):
    t = tiny[0].table
    m = t[t.plant == "model"].groupby("controller")[["stroke_rmse_mm", "switch_cycles"]].mean()
    assert m.at["pid", "stroke_rmse_mm"] < m.at["pwm-high", "stroke_rmse_mm"]
    assert m.at["onoff", "switch_cycles"] < m.at["pid", "switch_cycles"]


def test_report_files_and_summary(tiny):
    res, out = tiny
    for name in (
        "results.csv",
        "results.parquet",
        "summary.md",
        "trajectories.parquet",
        "run.json",
    ):
        assert (out / name).exists(), name
    back = pd.read_parquet(out / "results.parquet")
    pd.testing.assert_frame_equal(back, res.table, check_dtype=False)
    md = (out / "summary.md").read_text()
    assert "setpoint-steps@1 on the model" in md and "Sim-to-real gap" in md
    assert " ± " in md and "Pareto-optimal" in md
    # the lifetime ranking under other S-N assumptions and the switching operations as wear
    assert "## Lifetime: how the ranking depends on the wear measure" in md
    assert "Kendall τ" in md and "switching ops" in md and "Miner m=4 ≥2 K" in md
    assert "switching operations as a wear axis of their own" in md
    assert (res.table["wax_damage"] == res.table["wax_damage_m2_ge2K"]).all()
    assert (res.table["wax_cycles_ge20K"] <= res.table["wax_cycles_ge2K"]).all()
    figs = sorted(p.name for p in (out / "figures").iterdir())
    assert any(f.endswith("_trajectories.png") for f in figs)
    assert any(f.endswith("_pareto.png") for f in figs)
    assert any(f.endswith("_sim_to_real.png") for f in figs)
    for f in figs:
        assert f"figures/{f}" in md
    traj = pd.read_parquet(out / "trajectories.parquet")
    assert set(traj["seed"]) == {0}  # the first seed is the representative episode
    gap = sim_to_real_gap(res.table, ["stroke_rmse_mm"])
    m = res.table.groupby(["controller", "plant"])["stroke_rmse_mm"].mean()
    assert gap.loc[("setpoint-steps", "pid"), "stroke_rmse_mm_gap"] == pytest.approx(
        m[("pid", "rig")] - m[("pid", "model")]
    )


GRID = {"seeds": [3, 4], "plants": ("model",), "record": "none", "report": False}


def test_local_processes_give_the_serial_results():
    ref = run_benchmark(VALVE, "setpoint-steps", "onoff,pid", backend="serial", **GRID)
    local = run_benchmark(VALVE, "setpoint-steps", "onoff,pid", backend="local", workers=2, **GRID)
    pd.testing.assert_frame_equal(_stable(local.table), _stable(ref.table))


def test_a_users_own_scenario_reaches_the_worker_processes():
    from thermogym.controllers.scenarios import Scenario

    mine = Scenario(
        "my-hold", 1, "hold 3 mm for 2 h",
        {"AXT211Valve": {"setpoint": 3.0, "episode_s": 7200.0}},
    )  # fmt: skip
    kw = {**GRID, "seeds": [0]}
    ref = run_benchmark(VALVE, mine, "pid", backend="serial", **kw)
    local = run_benchmark(VALVE, [mine], "pid", backend="local", workers=2, **kw)
    pd.testing.assert_frame_equal(_stable(local.table), _stable(ref.table))
    assert set(ref.table["scenario"]) == {"my-hold"}
    # the user's episode length, not a registered scenario's
    assert ref.table["steps"].iloc[0] == 7200 // 10


@pytest.mark.slow
def test_ray_gives_the_serial_results():
    ray = pytest.importorskip("ray")
    kw = GRID
    ref = run_benchmark(VALVE, "setpoint-steps", "onoff,pid", backend="serial", **kw)
    started = not ray.is_initialized()
    if started:
        ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    try:
        remote = run_benchmark(VALVE, "setpoint-steps", "onoff,pid", backend="ray", **kw)
    finally:
        if started:
            ray.shutdown()
    pd.testing.assert_frame_equal(_stable(remote.table), _stable(ref.table))


def test_scenarios_are_versioned_and_spread_draws_a_specimen_per_seed():
    s = get_scenario("actuator-spread")
    assert s.key == "actuator-spread@1" and get_scenario("actuator-spread@1") is s
    k0, k1 = s.kwargs("AXT211Valve", 0), s.kwargs("AXT211Valve", 1)
    assert k0["plant"] == "rig" and (k0["specimen_seed"], k1["specimen_seed"]) == (0, 1)
    assert get_scenario("winter-week").kwargs("AXT211Room", 5, "rig")["plant"] == "rig"
    with pytest.raises(ConfigError, match="not defined for AXT211Valve"):
        get_scenario("winter-week").kwargs("AXT211Valve", 0)
    with pytest.raises(UnknownNameError, match="scenarios are"):
        get_scenario("summer")
    # two specimens are two plants: the open-loop PWM lands on different strokes
    res = run_benchmark(VALVE, "actuator-spread", "pwm-high", seeds=[0, 1], backend="serial",
                        record="none", report=False)  # fmt: skip
    t = res.table
    assert (t["plant"] == "rig").all() and t["env_fit_fingerprint"].nunique() == 2
    assert t["stroke_rmse_mm"].iloc[0] != t["stroke_rmse_mm"].iloc[1]


def test_presets_and_errors():
    import gymnasium as gym

    import thermogym.envs  # noqa: F401

    assert expand_controllers("onoff,pwm") == ["onoff", "pwm-high", "pwm-medium", "pwm-low"]
    with pytest.raises(UnknownNameError, match="presets are"):
        expand_controllers("fuzzy")
    room = gym.make("thermogym/AXT211Room-v0")
    with pytest.raises(ConfigError, match="start_day"):
        build_controller("mpc", room, env_kwargs={})
    spindle = gym.make("thermogym/SpindleThermal-v0")
    with pytest.raises(ConfigError, match="no controller presets for SpindleThermal"):
        build_controller("pid", spindle)
    with pytest.raises(ConfigError, match="no SAC policy is shipped"):
        build_controller("sac", gym.make(VALVE))
    with pytest.raises(ConfigError, match="not defined for AXT211Valve"):
        run_benchmark(VALVE, "winter-week", "onoff", seeds=1, backend="serial")
    with pytest.raises(ConfigError, match="backend"):
        run_benchmark(VALVE, "setpoint-steps", "onoff", seeds=1, backend="mpi")
    tclab = gym.make("thermogym/TCLab-v0")
    c = build_controller("pid", tclab)
    obs, _ = tclab.reset(seed=0)
    assert tclab.action_space.contains(c.act(obs))


def test_pareto_front_and_episode_spec():
    pts = np.array([[1.0, 5.0, 1.0], [2.0, 2.0, 2.0], [3.0, 3.0, 3.0], [1.0, 5.0, 1.0]])
    assert pareto_front(pts).tolist() == [True, True, False, True]
    spec = EpisodeSpec(VALVE, "setpoint-steps@1", "random", seed=7)
    a, b = run_episode(spec)["row"], run_episode(spec)["row"]
    assert a["return"] == b["return"] and a["seed"] == 7


def test_cli_bench(tmp_path, capsys):
    out = tmp_path / "cli"
    rc = cli_main(
        ["bench", "--env", "AXT211Valve", "--controllers", "onoff,pid", "--seeds", "1",
         "--backend", "serial", "--out", str(out), "--record", "none", "--no-progress"]
    )  # fmt: skip
    assert rc == 0
    assert (out / "summary.md").exists() and (out / "results.csv").exists()
    assert "stroke_rmse_mm" in capsys.readouterr().out
    # --params: the model episodes run on the user's FitResult (a slower cartridge), the rig's not
    from thermogym.fitresult import FitResult
    from thermogym.models.axt211 import AXT211

    fit = FitResult.from_model(AXT211(), {"C_P": 36.0}, method="test")
    fit.save(tmp_path / "fit.json")
    out2 = tmp_path / "cli2"
    rc = cli_main(
        ["bench", "--env", "AXT211Valve", "--controllers", "onoff", "--seeds", "1", "--plant",
         "model,rig", "--backend", "serial", "--out", str(out2), "--record", "none",
         "--no-progress", "--params", str(tmp_path / "fit.json")]
    )  # fmt: skip
    assert rc == 0
    a = pd.read_csv(out / "results.csv").set_index(["controller", "plant"])
    b = pd.read_csv(out2 / "results.csv").set_index(["controller", "plant"])
    assert b.loc[("onoff", "model"), "env_fit_fingerprint"] == fit.fingerprint()
    assert b.loc[("onoff", "rig"), "env_fit_fingerprint"] != fit.fingerprint()
    # twice the heat capacity: the same on/off rule tracks differently
    key = ("onoff", "model")
    assert b.loc[key, "stroke_rmse_mm"] != a.loc[key, "stroke_rmse_mm"]
    rc = cli_main(["bench", "--env", "AXT211Valve", "--controllers", "fuzzy", "--out", str(out)])
    assert rc == 2 and "fuzzy" in capsys.readouterr().err
    rc = cli_main(["bench", "--env", "Nope", "--out", str(out)])
    assert rc == 2 and "unknown environment" in capsys.readouterr().err
