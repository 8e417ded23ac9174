"""Environment throughput: thermogym envs beside Pendulum-v1 and gym-electric-motor.

Steps per second of every registered thermogym environment

* alone, created by ``gymnasium.make`` (with Gymnasium's default wrappers,
  like the peers), and
* natively vectorised (``gymnasium.make_vec(..., vectorization_mode=
  "vector_entry_point")``) with ``--num-envs`` (1024) plants,

measured in the same run as Gymnasium's ``Pendulum-v1`` and
gym-electric-motor's ``Cont-SC-PermExDc-v0`` (the peers). Every loop applies a
constant mid-range action and resets when an episode ends, like a fixed
policy. The machine is shared with other work, so each single environment is
timed in rounds interleaved with Pendulum-v1 (one Pendulum run, one
environment run, ``--repeats`` times) and each figure is the best round; the
ratio to Pendulum uses process CPU time (what a step costs, unaffected by
being descheduled), wall-clock rates are printed beside it.

One environment step is one control period, which differs between
environments (AXT211Valve 10 s = 10 RK4 steps of the actuator, AXT211Room
10 s = 10 RK4 steps of the 7-state room with the actuator, spindle/strut one
exact ZOH step, TCLab 1 s). The AXT211 environments are therefore also
measured with a 1 s control period (one model step per environment step, as
the peers do), and the simulated plant time per wall-clock second is printed.

The vector envs are measured twice: on one core (``parallel=False``, the
default; CPU time, i.e. per core) and with ``parallel=True`` (blocks of plants
on numba's threads, one per core; wall clock, what a user waits for, on all
of this machine's cores). ``vector_steps_per_s`` in the JSON is the slower
AXT211 env with threads (wall clock); ``vector_steps_per_s_per_core`` the one
core figure.

Usage::

    python benchmarks/env_throughput.py [--num-envs 1024] [--json PATH]
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path
from typing import Any

import gymnasium as gym
import numba
import numpy as np

import thermogym.envs

PEERS = {"Pendulum-v1": "gymnasium", "Cont-SC-PermExDc-v0": "gym-electric-motor"}
AXT211 = ("thermogym/AXT211Valve-v0", "thermogym/AXT211Room-v0")


def _mid_action(space: gym.Space[Any]) -> Any:
    if isinstance(space, gym.spaces.Discrete):
        return 1
    return np.zeros(space.shape, dtype=space.dtype)


class Runner:
    """One environment stepped with a constant action; times rounds of ``steps``."""

    def __init__(self, make: Any, steps: int) -> None:
        self.env = make()
        self.env.reset(seed=0)
        self.a = _mid_action(self.env.action_space)
        self.steps = steps
        self.wall = 0.0  # best steps/s, wall clock
        self.cpu = 0.0  # best steps/s, process CPU time
        self.round()  # warm-up: compilation, caches
        self.wall = self.cpu = 0.0

    def round(self) -> None:
        env, a = self.env, self.a
        env.reset(seed=0)
        w0, c0 = time.perf_counter(), time.process_time()
        for _ in range(self.steps):
            out = env.step(a)
            if out[2] or out[3]:
                env.reset()
        w, c = time.perf_counter() - w0, time.process_time() - c0
        self.wall = max(self.wall, self.steps / w)
        self.cpu = max(self.cpu, self.steps / max(c, 1e-9))


def interleaved(runners: list[Runner], repeats: int) -> None:
    """Time the runners in alternating rounds (shared-machine noise hits all alike)."""
    for _ in range(repeats):
        for r in runners:
            r.round()


def vector_rate(
    env_id: str, n: int, steps: int, repeats: int, parallel: bool = False, **kw: Any
) -> tuple[float, float]:
    """Best env-steps/s (CPU time, wall clock) of the native vector env with ``n`` plants."""
    venv = gym.make_vec(
        env_id, num_envs=n, vectorization_mode="vector_entry_point", parallel=parallel, **kw
    )
    venv.reset(seed=0)
    a = np.stack([_mid_action(venv.single_action_space)] * n)
    venv.step(a)
    cpu = wall = 0.0
    for _ in range(repeats):
        w0, c0 = time.perf_counter(), time.process_time()
        for _ in range(steps):
            venv.step(a)
        wall = max(wall, n * steps / (time.perf_counter() - w0))
        cpu = max(cpu, n * steps / max(time.process_time() - c0, 1e-9))
    venv.close()
    return cpu, wall


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--num-envs", type=int, default=1024)
    ap.add_argument("--steps", type=int, default=20000, help="steps per single-env run")
    ap.add_argument("--vector-steps", type=int, default=50, help="batch steps per vector run")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    load0 = os.getloadavg()

    pend = Runner(lambda: gym.make("Pendulum-v1"), args.steps)
    peers_cpu: dict[str, float] = {}
    peers_wall: dict[str, float] = {}
    try:
        import gym_electric_motor as gem

        g = Runner(lambda: gem.make("Cont-SC-PermExDc-v0"), max(args.steps // 20, 500))
        interleaved([pend, g], args.repeats)
        peers_cpu["Cont-SC-PermExDc-v0"], peers_wall["Cont-SC-PermExDc-v0"] = g.cpu, g.wall
    except ImportError:  # optional peer (extra "bench")
        peers_cpu["Cont-SC-PermExDc-v0"] = peers_wall["Cont-SC-PermExDc-v0"] = float("nan")

    cases = [(i, i, {}) for i in thermogym.envs.ENV_IDS]
    cases += [(i + " @1s", i, {"control_period": 1.0}) for i in AXT211]
    single: dict[str, float] = {}
    single_wall: dict[str, float] = {}
    vector: dict[str, float] = {}
    vector_wall: dict[str, float] = {}
    threads_wall: dict[str, float] = {}
    dts: dict[str, float] = {}
    for label, env_id, kw in cases:
        r = Runner(lambda i=env_id, k=kw: gym.make(i, **k), args.steps)
        interleaved([pend, r], args.repeats)
        single[label], single_wall[label] = r.cpu, r.wall
        vector[label], vector_wall[label] = vector_rate(
            env_id, args.num_envs, args.vector_steps, args.repeats, **kw
        )
        threads_wall[label] = vector_rate(
            env_id, args.num_envs, args.vector_steps, args.repeats, parallel=True, **kw
        )[1]
        dts[label] = r.env.unwrapped.dt
    peers_cpu["Pendulum-v1"], peers_wall["Pendulum-v1"] = pend.cpu, pend.wall
    load1 = os.getloadavg()
    vector_1s = {k: v for k, v in vector.items() if k.endswith("@1s")}
    main_ids = list(thermogym.envs.ENV_IDS)

    pc = peers_cpu["Pendulum-v1"]
    print(
        f"machine load (1/5/15 min) before {load0[0]:.2f}/{load0[1]:.2f}/{load0[2]:.2f}, "
        f"after {load1[0]:.2f}/{load1[1]:.2f}/{load1[2]:.2f}; {os.cpu_count()} cores"
    )
    print(
        f"peers (steps/s, CPU time / wall clock): Pendulum-v1 {pc:.0f} / "
        f"{peers_wall['Pendulum-v1']:.0f}, Cont-SC-PermExDc-v0 "
        f"{peers_cpu['Cont-SC-PermExDc-v0']:.0f} / {peers_wall['Cont-SC-PermExDc-v0']:.0f}"
    )
    ncpu = os.cpu_count() or 1
    print(
        f"{'environment':32s} {'dt [s]':>6s} {'single CPU':>11s} {'(wall)':>9s} "
        f"{'x Pendulum':>10s} {'vector CPU':>11s} {'(wall)':>10s} {'threads':>10s} "
        f"{'plant s/s':>10s}"
    )
    for label in single:
        print(
            f"{label:32s} {dts[label]:6g} {single[label]:11.0f} {single_wall[label]:9.0f} "
            f"{single[label] / pc:10.2f} {vector[label]:11.0f} {vector_wall[label]:10.0f} "
            f"{threads_wall[label]:10.0f} {threads_wall[label] * dts[label]:10.3g}"
        )
    worst = min(single[i] for i in main_ids) / pc
    vec_axt_core = min(vector[i] for i in AXT211)
    vec_axt = min(threads_wall[i] for i in AXT211)
    vec_axt_1s = min(vector_1s.values())
    print(
        f"single env vs Pendulum-v1 (worst env): {worst:.2f}x (target >= 1); vectorised AXT211 "
        f"envs at their default control periods: {vec_axt:.3g} env-steps/s with parallel=True "
        f"on {ncpu} cores (wall clock), {vec_axt_core:.3g} on one core (CPU time); at a 1 s "
        f"period on one core: {vec_axt_1s:.3g} (target >= 2e6)"
    )
    if args.json:
        doc = {
            "figures": {
                "single_vs_pendulum": worst,
                "vector_steps_per_s": vec_axt,
                "vector_steps_per_s_per_core": vec_axt_core,
                "vector_steps_per_s_1s_control": vec_axt_1s,
                "vector_steps_per_s_threads_wall_per_env": threads_wall,
                "single_steps_per_s_cpu": single,
                "single_steps_per_s_wall": single_wall,
                "single_vs_pendulum_per_env": {k: v / pc for k, v in single.items()},
                "vector_steps_per_s_per_env": vector,
                "vector_steps_per_s_wall_per_env": vector_wall,
                "control_period_s": dts,
                "peers_steps_per_s_cpu": peers_cpu,
                "peers_steps_per_s_wall": peers_wall,
                "num_envs": args.num_envs,
            },
            "peer": "gymnasium Pendulum-v1 (single), gym-electric-motor Cont-SC-PermExDc-v0",
            "ratio": worst,
            "target": {"single_vs_pendulum": 1.0, "vector_steps_per_s": 2.0e6},
            "machine": {
                "load_before": load0,
                "load_after": load1,
                "cpus": os.cpu_count(),
                "numba_threads": numba.get_num_threads(),
            },
        }
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(doc, indent=2) + "\n")


if __name__ == "__main__":
    main()
