"""Speed of two checkouts of thermogym side by side: a change against the commit before it.

The figures of ``env_throughput.py``, ``simulate.py`` and ``n4sid.py`` (thermogym's own
parts, without the peers) measured for two source trees in one run: each measurement is a
fresh process with ``PYTHONPATH`` set to one tree, the trees alternate (A, B, B, A, A, B, ...)
for ``--rounds`` rounds, and each figure is the best round of its tree (process CPU time:
what the work costs, unaffected by being descheduled on a shared machine; wall clock for
the threaded batch simulation beside it). The machine load is printed before and after.

A second worktree of the earlier commit serves as the base::

    git worktree add /tmp/base <commit>
    python benchmarks/compare_commits.py --base /tmp/base --new . --json out.json

Each tree compiles its numba kernels into its own ``__pycache__`` on the first round (a
warm-up call precedes every timing, so compilation is never timed).

Figures, per tree:

* ``env_single/<id>``: steps per CPU second of one environment from ``gymnasium.make``
  (``--steps`` steps, constant mid-range action), as ``env_throughput.py``'s single figure;
* ``env_vector/<id>``: env-steps per CPU second of the native vector env with ``--num-envs``
  plants on one core (``parallel=False``), as ``env_throughput.py``'s vector figure;
  AXT211 envs also at a 1 s control period (``@1s``);
* ``simulate_cpu``/``simulate_wall``: 1024 AXT211 parameter sets (±10 %), 3600 steps of
  1 s, one ``simulate`` call, as ``simulate.py``'s batched figure (reported as runs/s);
* ``n4sid_sweep``: ``cross_validate_order`` over orders 1..30 on the two spindle days of
  ``n4sid.py`` (the data made once by the base tree and shared through a file), as sweeps
  per CPU second.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

# -------------------------------------------------------------------------------- probe
# Runs inside the tree under test (only public API that both trees share).


def _best(fn: Any, repeats: int) -> tuple[float, float]:
    cpu = wall = float("inf")
    for _ in range(repeats):
        c0, w0 = time.process_time(), time.perf_counter()
        fn()
        cpu = min(cpu, time.process_time() - c0)
        wall = min(wall, time.perf_counter() - w0)
    return cpu, wall


def _probe_envs(args: argparse.Namespace) -> dict[str, float]:
    import gymnasium as gym
    import numpy as np

    import thermogym.envs

    out: dict[str, float] = {}
    cases = [(i, i, {}) for i in thermogym.envs.ENV_IDS]
    cases += [(i + " @1s", i, {"control_period": 1.0}) for i in thermogym.envs.ENV_IDS[:2]]
    for label, env_id, kw in cases:
        env = gym.make(env_id, **kw)
        env.reset(seed=0)
        a = np.zeros(env.action_space.shape, dtype=env.action_space.dtype)

        def run(env: Any = env, a: Any = a) -> None:
            env.reset(seed=0)
            for _ in range(args.steps):
                o = env.step(a)
                if o[2] or o[3]:
                    env.reset()

        run()
        cpu, _ = _best(run, 2)
        out[f"env_single/{label}"] = args.steps / cpu
        venv = gym.make_vec(
            env_id, num_envs=args.num_envs, vectorization_mode="vector_entry_point", **kw
        )
        venv.reset(seed=0)
        va = np.zeros((args.num_envs, *env.action_space.shape), dtype=env.action_space.dtype)
        venv.step(va)

        def vrun(venv: Any = venv, va: Any = va) -> None:
            for _ in range(args.vector_steps):
                venv.step(va)

        cpu, _ = _best(vrun, 2)
        out[f"env_vector/{label}"] = args.num_envs * args.vector_steps / cpu
        venv.close()
        env.close()
    return out


def _probe_simulate(args: argparse.Namespace) -> dict[str, float]:
    import numpy as np

    from thermogym.models import AXT211

    model = AXT211()
    rng = np.random.default_rng(0)
    theta = model.theta(batch=1024)
    scale = rng.uniform(0.9, 1.1, theta.shape)
    for name in ("C_P", "lambda_PG", "C_G", "lambda_GU", "tau_P", "kP_b", "kP_c"):
        j = model.param_index(name)
        theta[:, j] *= scale[:, j]
    theta[:, model.param_index("c_backlash")] = 0.0
    u = np.zeros((3600, 3))
    u[:1800, 0] = 1.0
    u[:, 1], u[:, 2] = 24.0, 25.0
    x0 = np.array([25.0, 25.0, 0.0, 0.0])
    model.simulate(u[:10], 1.0, theta[:64], x0)
    cpu, wall = _best(lambda: model.simulate(u, 1.0, theta, x0), 3)
    return {"simulate_cpu": 1.0 / cpu, "simulate_wall": 1.0 / wall}


def _probe_n4sid(args: argparse.Namespace) -> dict[str, float]:
    import numpy as np

    from thermogym.identification.crossval import cross_validate_order
    from thermogym.recording import Recording

    with np.load(args.data) as z:
        names = [str(n) for n in z["names"]]
        folds = [
            Recording(z[f"t{k}"], {n: z[f"d{k}_{n}"] for n in names}, units=None) for k in (1, 2)
        ]
    outputs = [n for n in names if n != "speed"]
    cross_validate_order(folds, ["speed"], outputs, [1, 2])
    cpu, wall = _best(lambda: cross_validate_order(folds, ["speed"], outputs, range(1, 31)), 1)
    return {"n4sid_sweep": 1.0 / cpu, "n4sid_sweep_wall": 1.0 / wall}


def _make_data(path: str) -> None:
    import numpy as np

    from thermogym.studies.spindle import OUTPUTS, spindle_data

    data = spindle_data(seed=0, speeds=(6000,), validation_speeds=())
    arrays: dict[str, Any] = {"names": np.array(["speed", *OUTPUTS])}
    for k in (1, 2):
        r = data.fold(6000, k)
        arrays[f"t{k}"] = r.time
        for n in ("speed", *OUTPUTS):
            arrays[f"d{k}_{n}"] = r[n]
    np.savez(path, **arrays)


PROBES = {"envs": _probe_envs, "simulate": _probe_simulate, "n4sid": _probe_n4sid}

# ------------------------------------------------------------------------------- driver


def _run(tree: Path, argv: list[str]) -> dict[str, float]:
    env = dict(os.environ, PYTHONPATH=str(tree))
    r = subprocess.run(
        [sys.executable, str(Path(__file__).resolve()), *argv],
        cwd=tree,
        env=env,
        capture_output=True,
        text=True,
        check=False,
    )
    if r.returncode != 0:
        raise SystemExit(f"probe in {tree} failed:\n{r.stderr[-4000:]}")
    return json.loads(r.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--base", type=Path, help="source tree of the earlier commit")
    ap.add_argument("--new", type=Path, default=Path("."), help="source tree of the change")
    ap.add_argument("--rounds", type=int, default=4)
    ap.add_argument("--probes", default="envs,simulate,n4sid")
    ap.add_argument("--steps", type=int, default=4000, help="steps per single-env timing")
    ap.add_argument("--num-envs", type=int, default=1024)
    ap.add_argument("--vector-steps", type=int, default=20)
    ap.add_argument("--json", type=Path)
    ap.add_argument("--probe", help=argparse.SUPPRESS)
    ap.add_argument("--data", help=argparse.SUPPRESS)
    ap.add_argument("--make-data", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.make_data:
        _make_data(args.make_data)
        print("{}")
        return
    if args.probe:
        print(json.dumps(PROBES[args.probe](args)))
        return
    if args.base is None:
        ap.error("--base is required")

    trees = {"base": args.base.resolve(), "new": args.new.resolve()}
    probes = [p for p in args.probes.split(",") if p]
    common = [
        f"--steps={args.steps}",
        f"--num-envs={args.num_envs}",
        f"--vector-steps={args.vector_steps}",
    ]
    load0 = os.getloadavg()
    best: dict[str, dict[str, float]] = {"base": {}, "new": {}}
    with tempfile.TemporaryDirectory() as tmp:
        data = str(Path(tmp) / "spindle.npz")
        if "n4sid" in probes:
            _run(trees["base"], [f"--make-data={data}"])
        for k in range(args.rounds):
            order = ("base", "new") if k % 2 == 0 else ("new", "base")
            for name in order:
                for p in probes:
                    fig = _run(trees[name], [f"--probe={p}", f"--data={data}", *common])
                    for key, v in fig.items():
                        best[name][key] = max(best[name].get(key, 0.0), v)
            la = os.getloadavg()
            print(f"round {k + 1}/{args.rounds} done, load {la[0]:.2f}", flush=True)
    load1 = os.getloadavg()
    print(
        f"load (1/5/15 min) before {load0[0]:.2f}/{load0[1]:.2f}/{load0[2]:.2f}, "
        f"after {load1[0]:.2f}/{load1[1]:.2f}/{load1[2]:.2f}; {os.cpu_count()} cores"
    )
    print(
        f"{'figure (per second, best of rounds)':44s} {'base':>12s} {'new':>12s} {'new/base':>9s}"
    )
    ratios = {}
    for key in best["base"]:
        b, n = best["base"][key], best["new"].get(key, float("nan"))
        ratios[key] = n / b
        print(f"{key:44s} {b:12.4g} {n:12.4g} {n / b:9.3f}")
    worst = min(ratios, key=ratios.__getitem__)
    print(f"worst ratio: {ratios[worst]:.3f} ({worst}); target >= 0.9")
    if args.json:
        doc = {
            "figures": {"base": best["base"], "new": best["new"], "ratio": ratios},
            "worst": {"figure": worst, "ratio": ratios[worst]},
            "target": 0.9,
            "trees": {k: str(v) for k, v in trees.items()},
            "rounds": args.rounds,
            "machine": {"load_before": load0, "load_after": load1, "cpus": os.cpu_count()},
        }
        args.json.parent.mkdir(parents=True, exist_ok=True)
        tmpf = args.json.with_suffix(args.json.suffix + ".tmp")
        tmpf.write_text(json.dumps(doc, indent=2) + "\n")
        tmpf.replace(args.json)


if __name__ == "__main__":
    main()
