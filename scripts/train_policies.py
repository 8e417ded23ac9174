"""Train the PPO policies shipped in ``thermogym/controllers/policies/`` (``ppo`` preset).

Each policy is trained on the *identified model* environment (``plant="model"``,
the package's nominal FitResult; its fingerprint is in the ``.json``) and
evaluated by the benchmark on the model and on the virtual rig. Training runs
on the CPU with one torch thread and four environments in this process; the
``.json`` next to each ``.zip`` records the configuration, the wall time and
the final evaluation against a random policy (:func:`thermogym.controllers.rl.train`).

``axt211valve_ppo``
    ``AXT211Valve`` with 30 s control (and PWM) periods, 4 h episodes of
    random stroke set-points (0.5-4 mm held 20 min: the ``setpoint-steps``
    conditions), default reward (tracking, energy, switch-ons).
``axt211room_ppo``
    ``AXT211Room`` with 20 min control periods (the PWM period of on-off
    operation, as the ``mpc`` and ``pid-low`` presets), one-week episodes
    starting on a random day of the heating season, default reward (comfort,
    heat, actuator energy, switch-ons).

Usage::

    python scripts/train_policies.py [--only valve|room] [--steps N]
        [--ship best|final] [--no-train] [--out FOLDER]

``--ship best`` (default) ships the policy of the best periodic evaluation
(``EvalCallback``; evaluation seeds 10000+ are disjoint from the benchmark's
seeds 0-4) and re-evaluates it; the ``.json`` says which one was shipped.
"""

from __future__ import annotations

import argparse
import json
import shutil
from pathlib import Path

import numpy as np

from thermogym._fileio import atomic_write_text
from thermogym.controllers.rl import RLConfig, evaluate, train

#: Where the ``ppo`` preset reads the shipped policies (package data of the checkout).
POLICIES = Path(__file__).resolve().parents[1] / "thermogym" / "controllers" / "policies"

CONFIGS = {
    "valve": RLConfig(
        algo="ppo",
        env_id="thermogym/AXT211Valve-v0",
        env_kwargs={
            "control_period": 30.0,
            "episode_s": 4 * 3600.0,
            "setpoint": "random",
            "setpoint_range": [0.5, 4.0],
            "setpoint_hold_s": 1200.0,
        },
        total_timesteps=300_000,
        seed=0,
        n_envs=4,
        algo_kwargs={"n_steps": 480, "batch_size": 240, "learning_rate": 3e-4, "gamma": 0.98},
        policy_kwargs={"net_arch": [64, 64]},
        eval_freq=40_000,
        n_eval_episodes=4,
        checkpoint_freq=100_000,
    ),
    "room": RLConfig(
        algo="ppo",
        env_id="thermogym/AXT211Room-v0",
        env_kwargs={"control_period": 1200.0, "episode_days": 7.0},
        total_timesteps=400_000,
        seed=0,
        n_envs=4,
        algo_kwargs={"n_steps": 504, "batch_size": 252, "learning_rate": 3e-4, "gamma": 0.99},
        policy_kwargs={"net_arch": [64, 64]},
        eval_freq=40_000,
        n_eval_episodes=4,
        checkpoint_freq=100_000,
    ),
}


def ship(name: str, work: Path, which: str, dest: Path = POLICIES) -> dict:
    """Copy the final or the best policy of a finished run to ``dest``, with its provenance."""
    cfg = CONFIGS[name]
    run = work / name
    meta = json.loads((run / "policy.json").read_text(encoding="utf-8"))
    src = run / "policy.zip"
    meta["shipped"] = {"which": "final", "timesteps": meta["timesteps"]}
    best = run / "best" / "best_model.zip"
    if which == "best" and best.exists():
        ev = np.load(run / "evaluations.npz")
        means = ev["results"].mean(axis=1)
        i = int(np.argmax(means))
        final_eval = meta["evaluation"]["policy"]["return_mean"]
        if means[i] > final_eval:
            import stable_baselines3 as sb3

            model = getattr(sb3, cfg.algo.upper()).load(str(best), device="cpu")
            meta["evaluation"]["final_policy"] = meta["evaluation"]["policy"]
            meta["evaluation"]["policy"] = evaluate(
                model, cfg.env_id, cfg.env_kwargs, meta["evaluation"]["seeds"]
            )
            meta["shipped"] = {
                "which": "best periodic evaluation",
                "timesteps": int(ev["timesteps"][i]),
                "periodic_return_mean": float(means[i]),
                "evaluation_curve": {
                    "timesteps": ev["timesteps"].tolist(),
                    "return_mean": means.tolist(),
                },
            }
            src = best
    stem = f"{cfg.env_id.split('/')[1].split('-v')[0].lower()}_{cfg.algo}"
    dest.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(src, dest / f"{stem}.zip")
    atomic_write_text(dest / f"{stem}.json", json.dumps(meta, indent=1, default=str) + "\n")
    return meta


def main() -> None:
    """Train the policies and copy the shipped ``.zip`` / ``.json`` to ``--out``."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", choices=list(CONFIGS))
    ap.add_argument("--steps", type=int, help="override total_timesteps")
    ap.add_argument("--work", type=Path, default=Path("out/rl-training"))
    ap.add_argument("--ship", choices=["best", "final"], default="best")
    ap.add_argument("--no-train", action="store_true", help="only ship finished runs")
    ap.add_argument(
        "--out", type=Path, default=POLICIES, help="where to ship (default: the package data)"
    )
    args = ap.parse_args()
    for name in [args.only] if args.only else list(CONFIGS):
        cfg = CONFIGS[name]
        cfg.out = str(args.work / name)
        if args.steps:
            cfg.total_timesteps = args.steps
        if not args.no_train:
            train(cfg)
        meta = ship(name, args.work, args.ship, args.out)
        ev = meta["evaluation"]
        print(
            f"{name}: trained {meta['seconds']:.0f} s, shipped {meta['shipped']['which']} "
            f"({meta['shipped']['timesteps']} steps): return {ev['policy']['return_mean']:.2f} "
            f"(random {ev['random']['return_mean']:.2f})"
        )


if __name__ == "__main__":
    main()
