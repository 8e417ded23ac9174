"""Identify the linear models the controller presets are tuned on; write them as package data.

This script produced the JSON files in ``thermogym/controllers/data/``, which
:mod:`thermogym.controllers.presets` reads: the models a control engineer
would identify from plant tests before tuning PID, feedforward and MPC. It is
a script, not part of the controllers' import graph: it may call
:mod:`thermogym.identification` (the controllers only read FitResults).

Every experiment runs on the *identified model* environment
(``plant="model"``, the package's nominal parameters, sensor noise on) — what
a user would have; the benchmark then evaluates the tunings on that model and
on the virtual rig (``plant="rig"``: its own parameters, its sensors and an
actuator specimen), which is the sim-to-real gap it reports.

``axt211valve_foptd.json`` — FOPTD ``x_V`` from the PWM duty (10 s PWM):
    two step tests at 24 V, 25 °C, each starting in steady state after 1.5 h
    (0.43 → 0.47 and 0.47 → 0.43; the stroke gain and the backlash make the
    actuator asymmetric, so the fit averages an opening and a closing step),
    :func:`~thermogym.identification.foptd.fit_foptd` (paper 000 section 4.1).
``axt211valve_static.json`` — steady-state stroke against the duty at each
    PWM frequency of :data:`~thermogym.controllers.pwm.PWM_PERIODS` (no
    sensor noise; 2.5 h to settle, then the mean over 40 min): the static
    inverse the open-loop PWM presets use.
``axt211room_ss_{high,medium,low}.json`` — N4SID state space (paper 001
    section 2.3.3) of ``T_zone`` from the duty, with the outdoor temperature
    and the occupancy flag as measured disturbances, sampled every 1200 s
    with the heater driven by PWM at that frequency: four fortnights of random
    duty levels (held 1-3 h) in January, February, mid-winter and November,
    plus a held-out fortnight for validation; operating point "mean"; order 2.
    The duty → heat map depends on the PWM frequency (at 10 s the valve sits
    part-open at a duty-dependent stroke; at 20 min it opens and shuts fully),
    hence one model per frequency.
``tclab_foptd.json`` — FOPTD of each TCLab sensor from each heater (one
    test: heater 1 0 → 50 % at 1 min, heater 2 at 30 min, ambient 21 °C).

Usage::

    python scripts/make_models.py [--out FOLDER] [--only NAME ...]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import gymnasium as gym
import numpy as np

import thermogym.envs  # noqa: F401 - registers the environments
from thermogym import __version__
from thermogym._fileio import atomic_write_text
from thermogym.controllers.feedforward import steady_state_map
from thermogym.controllers.pwm import PWM, PWM_PERIODS
from thermogym.identification.foptd import fit_foptd
from thermogym.identification.n4sid import n4sid
from thermogym.recording import Recording

#: Where the controller presets read the models (package data of the checkout).
DATA = Path(__file__).resolve().parents[1] / "thermogym" / "controllers" / "data"
ROOM_DT = 1200.0


def _valve_step(u0: float, u1: float, seed: int) -> Recording:
    env = gym.make("thermogym/AXT211Valve-v0", setpoint=2.0, episode_s=4 * 3600.0)
    obs, _ = env.reset(seed=seed)
    n = env.unwrapped.horizon
    duty = np.r_[np.full(n // 2, u0), np.full(n - n // 2, u1)]
    xs, us = [float(obs[0])], []
    for k in range(n):
        obs, *_ = env.step(np.array([2 * duty[k] - 1], dtype=np.float32))
        xs.append(float(obs[0]))
        us.append(float(duty[k]))
    us.append(float(duty[-1]))
    rec = Recording(
        10.0 * np.arange(n + 1),
        {"duty": np.array(us), "x_V": np.array(xs)},
        units={"duty": "1", "x_V": "mm"},
        roles={"duty": "input", "x_V": "output"},
        experiment_id=f"valve-step-{u0}-{u1}",
        source="thermogym/AXT211Valve-v0 plant=model (nominal), 10 s PWM",
    )
    return rec.slice(5400.0, None)  # from 1.5 h on: the step starts in steady state


def valve_foptd(out: Path) -> dict:
    """FOPTD of the stroke from the duty (two steps)."""
    recs = [_valve_step(0.43, 0.47, 1), _valve_step(0.47, 0.43, 2)]
    res = fit_foptd(recs, ["duty"], ["x_V"], operating_point_mode="initial", max_delay_s=200.0)
    res.fit.notes = (res.fit.notes or "") + "; made by scripts/make_models.py"
    res.fit.save(out / "axt211valve_foptd.json")
    return {"K": float(res.K[0, 0]), "T": float(res.T[0, 0]), "tau": float(res.tau[0, 0])}


def valve_static(out: Path) -> dict:
    """Steady-state stroke against the duty per PWM frequency."""
    duties = np.round(np.arange(0.0, 1.0001, 0.02), 4)
    table: dict = {
        "what": "steady-state valve stroke x_V [mm] against the PWM duty, per PWM frequency",
        "env": "thermogym/AXT211Valve-v0",
        "env_kwargs": {"sensor_noise": False, "supply_V": 24.0, "ambient_C": 25.0},
        "settle_s": 9000.0,
        "average_s": 2400.0,
        "package_version": __version__,
        "maps": {},
    }

    def make() -> gym.Env:
        return gym.make(
            "thermogym/AXT211Valve-v0", setpoint=2.0, episode_s=12000.0, sensor_noise=False
        )

    for name, period in PWM_PERIODS.items():
        d, x = steady_state_map(
            make,
            duties,
            measurement="x_V",
            controller=lambda v, p=period: PWM(p, duty=v),
            settle_s=9000.0,
            average_s=2400.0,
        )
        table["maps"][name] = {"period_s": period, "duty": d.tolist(), "x_V": x.round(5).tolist()}
    atomic_write_text(out / "axt211valve_static.json", json.dumps(table, indent=1) + "\n")
    return {k: [min(v["x_V"]), max(v["x_V"])] for k, v in table["maps"].items()}


def _room_run(period: float, seed: int, start_day: int, days: float = 14.0) -> Recording:
    env = gym.make("thermogym/AXT211Room-v0", start_day=start_day, episode_days=days)
    obs, _ = env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    names = env.unwrapped.obs_names
    blk = round(ROOM_DT / env.unwrapped.dt)
    n_blk = env.unwrapped.horizon // blk
    levels: list[float] = []
    while len(levels) < n_blk:
        levels += [float(rng.uniform(0.0, 1.0))] * int(rng.integers(3, 10))
    cols: dict[str, list[float]] = {"duty": [], "T_out": [], "occupied": [], "T_zone": []}
    for b in range(n_blk):
        ctrl = PWM(period, duty=levels[b]).bind(env)
        cols["duty"].append(levels[b])
        for c in ("T_out", "occupied", "T_zone"):
            cols[c].append(float(obs[names.index(c)]))
        for _ in range(blk):
            obs, *_ = env.step(ctrl.act(obs))
    return Recording(
        ROOM_DT * np.arange(n_blk),
        {k: np.array(v) for k, v in cols.items()},
        units={"duty": "1", "T_out": "°C", "occupied": "1", "T_zone": "°C"},
        roles={
            "duty": "input",
            "T_out": "disturbance",
            "occupied": "disturbance",
            "T_zone": "output",
        },
        experiment_id=f"room-pwm{period:g}s-seed{seed}-day{start_day}",
        source="thermogym/AXT211Room-v0 plant=model (nominal), duty levels through PWM",
    )


def room_ss(out: Path) -> dict:
    """N4SID models of the room per PWM frequency."""
    info = {}
    for name, period in PWM_PERIODS.items():
        train = [_room_run(period, s, d) for s, d in ((1, 0), (2, 28), (3, 300), (4, 320))]
        val = [_room_run(period, 9, 42)]
        res = n4sid(
            train,
            ["duty", "T_out", "occupied"],
            ["T_zone"],
            order=2,
            disturbances=["T_out", "occupied"],
            operating_point_mode="mean",
            validate=val,
        )
        fit = res.fit
        fit.notes = (fit.notes or "") + (
            f"; room heater through PWM at {period:g} s; made by scripts/make_models.py"
        )
        fit.save(out / f"axt211room_ss_{name}.json")
        m = fit.build_model()
        info[name] = {
            "dcgain": m.dcgain(fit.theta(m))[0].tolist(),
            "nrmse_train": fit.metrics["train"]["mnrmse"],
            "nrmse_validation": fit.metrics["validation"]["mnrmse"],
        }
    return info


def _tclab_steps(seed: int) -> Recording:
    env = gym.make("thermogym/TCLab-v0", episode_s=3600.0, ambient_C=21.0, setpoint=(40.0, 40.0))
    obs, _ = env.reset(seed=seed)
    n = env.unwrapped.horizon
    q = np.zeros((n, 2))
    q[60:, 0] = 50.0
    q[1800:, 1] = 50.0
    cols: dict[str, list[float]] = {"Q1": [], "Q2": [], "T1": [], "T2": []}
    for k in range(n):
        cols["Q1"].append(q[k, 0])
        cols["Q2"].append(q[k, 1])
        cols["T1"].append(float(obs[0]))
        cols["T2"].append(float(obs[1]))
        obs, *_ = env.step((q[k] / 50.0 - 1.0).astype(np.float32))
    return Recording(
        np.arange(n, dtype=float),
        {k: np.array(v) for k, v in cols.items()},
        units={"Q1": "%", "Q2": "%", "T1": "°C", "T2": "°C"},
        roles={"Q1": "input", "Q2": "input", "T1": "output", "T2": "output"},
        experiment_id=f"tclab-steps-{seed}",
        source="thermogym/TCLab-v0 (shipped fit to real recordings)",
    )


def tclab_foptd(out: Path) -> dict:
    """FOPTD of T1, T2 from Q1, Q2 (one step per heater)."""
    recs = [_tclab_steps(1)]
    res = fit_foptd(recs, ["Q1", "Q2"], ["T1", "T2"], operating_point_mode="initial", max_delay=60)
    res.fit.notes = (res.fit.notes or "") + "; made by scripts/make_models.py"
    res.fit.save(out / "tclab_foptd.json")
    return {"K": res.K.tolist(), "T": res.T.tolist(), "tau": res.tau.tolist()}


JOBS = {
    "valve_foptd": valve_foptd,
    "valve_static": valve_static,
    "room_ss": room_ss,
    "tclab_foptd": tclab_foptd,
}


def main() -> None:
    """Run the identification jobs and write their JSON files."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=DATA)
    ap.add_argument("--only", nargs="*", choices=list(JOBS))
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    for name in args.only or list(JOBS):
        t0 = time.perf_counter()
        summary = JOBS[name](args.out)
        print(f"{name}: {time.perf_counter() - t0:.1f} s  {json.dumps(summary)[:400]}")


if __name__ == "__main__":
    main()
