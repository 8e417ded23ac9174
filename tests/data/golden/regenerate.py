"""Regenerate the golden closed-loop trajectories of every environment (STYLE item 10).

For each registered environment two simple controllers run one seeded
episode — an on/off rule and a PI(D) controller — and the observations,
actions, rewards, episode flags, noise-free plant signals and final KPIs are
written to ``<Env>_<controller>.npz`` next to this script.
``tests/test_envs_golden.py`` replays the same loops and compares with
tolerances; the test never rewrites these files. Regenerate them only after a
deliberate behaviour change (and bump the environment's version if the change
is visible to users)::

    python tests/data/golden/regenerate.py

The controllers are defined here and imported by the test, so both run the
same code.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import thermogym.envs

HERE = Path(__file__).resolve().parent
SEED = 0

#: Environment -> (ID, keyword arguments of the golden episode).
CASES: dict[str, tuple[str, dict[str, Any]]] = {
    "AXT211Valve": ("thermogym/AXT211Valve-v0", {"episode_s": 3600.0}),
    "AXT211Room": (
        "thermogym/AXT211Room-v0",
        {"control_period": 60.0, "episode_days": 0.25, "start_day": 15, "start_hour": 4.0},
    ),
    "SpindleThermal": ("thermogym/SpindleThermal-v0", {"episode_s": 4 * 3600.0}),
    "StrutThermal": ("thermogym/StrutThermal-v0", {"episode_s": 4 * 3600.0}),
    "TCLab": ("thermogym/TCLab-v0", {"episode_s": 600.0}),
}
CONTROLLERS = ("onoff", "pid")


class PI:
    """Discrete PI controller with output limits and conditional-integration anti-windup."""

    def __init__(self, kp: float, ti: float, dt: float, lo: float, hi: float, bias: float = 0.0):
        self.kp, self.ki, self.lo, self.hi, self.bias = kp, kp * dt / ti, lo, hi, bias
        self.i = 0.0

    def __call__(self, e: float) -> float:
        raw = self.bias + self.kp * e + self.i
        out = min(max(raw, self.lo), self.hi)
        if raw == out:
            self.i += self.ki * e
        return out


def controller(name: str, ctrl: str, env: gym.Env) -> tuple[dict[str, Any], Callable]:
    """Extra make() keyword arguments and a policy ``obs -> action`` (fresh state)."""
    ix = {n: i for i, n in enumerate(env.unwrapped.obs_names)}
    dt = env.unwrapped.dt
    if name in ("AXT211Valve", "AXT211Room"):
        if ctrl == "onoff":
            if name == "AXT211Valve":
                return {"action_mode": "onoff"}, lambda o: int(o[ix["x_V"]] < o[ix["x_ref"]])
            state = {"on": 0}

            def thermostat(o):
                T, Ts = o[ix["T_zone"]], o[ix["T_set"]]
                state["on"] = int(T < Ts - 0.25 or (T < Ts + 0.25 and state["on"]))
                return state["on"]

            return {"action_mode": "onoff"}, thermostat
        if name == "AXT211Valve":
            pi = PI(0.4, 300.0, dt, 0.0, 1.0, bias=0.3)
            return {}, lambda o: np.array([2 * pi(o[ix["x_ref"]] - o[ix["x_V"]]) - 1], np.float32)
        pi = PI(0.5, 1800.0, dt, 0.0, 1.0)
        return {}, lambda o: np.array([2 * pi(o[ix["T_set"]] - o[ix["T_zone"]]) - 1], np.float32)
    if name == "SpindleThermal":
        if ctrl == "onoff":
            return {}, lambda o: np.array([1.0 if o[1] < 36.0 else -1.0], np.float32)
        pi = PI(0.2, 1800.0, dt, 0.0, 1.0, bias=0.5)
        return {}, lambda o: np.array([2 * pi(36.0 - o[1]) - 1], np.float32)
    if name == "StrutThermal":
        ref: dict[str, float] = {}

        def comp(o) -> float:
            # ΔL ≈ α L (mean rise of spindle and tube), α L = 11.5 µm/(m K) × 2.1 m
            ref.setdefault("T0", float(o[ix["T_air"]]))
            rise = np.mean([o[ix[k]] for k in ("T_spindle", "T_tube_front", "T_tube_rear")])
            return float(np.clip(24.15 * (rise - ref["T0"]) / 600.0, -1.0, 1.0))

        if ctrl == "onoff":
            return {}, lambda o: np.array(
                [1.0 if o[ix["T_drive"]] < 35.0 else -1.0, comp(o)], np.float32
            )
        pi = PI(0.2, 1800.0, dt, 0.0, 1.0, bias=0.5)
        return {}, lambda o: np.array([2 * pi(35.0 - o[ix["T_drive"]]) - 1, comp(o)], np.float32)
    if name == "TCLab":
        if ctrl == "onoff":
            return {}, lambda o: np.where(o[0:2] < o[2:4], 1.0, -1.0).astype(np.float32)
        pis = [PI(0.1, 120.0, dt, 0.0, 1.0) for _ in range(2)]
        return {}, lambda o: np.array(
            [2 * pis[i](o[2 + i] - o[i]) - 1 for i in range(2)], np.float32
        )
    raise KeyError(name)


def run(name: str, ctrl: str) -> dict[str, np.ndarray]:
    """One golden episode: arrays to store or compare."""
    env_id, kw = CASES[name]
    probe = gym.make(env_id, **kw)
    extra, _ = controller(name, ctrl, probe)
    env = gym.make(env_id, record=True, **kw, **extra)
    _, policy = controller(name, ctrl, env)
    obs, _ = env.reset(seed=SEED)
    O, A, R, F = [obs], [], [], []
    while True:
        a = policy(obs)
        obs, r, te, tr, info = env.step(a)
        O.append(obs)
        A.append(np.atleast_1d(np.asarray(a, dtype=float)))
        R.append(r)
        F.append((te, tr))
        if te or tr:
            break
    h = env.unwrapped.history()
    k = info["kpis"]
    return {
        "obs": np.array(O),
        "actions": np.array(A),
        "rewards": np.array(R),
        "flags": np.array(F, dtype=bool),
        "signals": np.column_stack([h[n] for n in env.unwrapped._e.sig_names]),
        "signal_names": np.array(env.unwrapped._e.sig_names),
        "kpi_names": np.array(list(k)),
        "kpis": np.array(list(k.values())),
    }


def main() -> None:
    manifest: dict[str, Any] = {"seed": SEED, "files": {}}
    for name in CASES:
        for ctrl in CONTROLLERS:
            data = run(name, ctrl)
            path = HERE / f"{name}_{ctrl}.npz"
            np.savez_compressed(path, **data)
            manifest["files"][path.name] = {
                "steps": len(data["rewards"]),
                "return": float(data["rewards"].sum()),
                "kpis": dict(zip(data["kpi_names"].tolist(), data["kpis"].tolist(), strict=True)),
            }
            print(f"{path.name:28s} {len(data['rewards']):5d} steps, return "
                  f"{data['rewards'].sum():10.3f}")  # fmt: skip
    import numba

    manifest["versions"] = {
        "thermogym": thermogym.__version__,
        "numpy": np.__version__,
        "numba": numba.__version__,
        "gymnasium": gym.__version__,
    }
    (HERE / "manifest.json").write_text(json.dumps(manifest, indent=2) + "\n")


if __name__ == "__main__":
    main()
