"""The benchmark harness: every controller × scenario × seed × plant, in parallel.

:func:`run_benchmark` expands the grid into independent episodes
(:class:`EpisodeSpec`), runs each with :func:`run_episode` — make the
environment with the scenario's keyword arguments, build the controller
preset (:func:`~thermogym.controllers.presets.build_controller`), reset both
with the seed, step to the end of the episode, read the KPIs of DESIGN.md
from ``info["kpis"]`` — and collects one row per episode into a tidy table.

Backends
--------
``"local"`` (default)
    A pool of local worker processes (``spawn``: no state inherited from the
    parent), with a progress bar.
``"ray"``
    The same function as Ray tasks, on the running Ray instance or cluster,
    or on a local one started with ``ray_options``.
``"serial"``
    In this process (debugging, tiny grids).

An episode depends only on its spec (environment, scenario, controller,
seed, plant): every random draw comes from the seed, controllers are built
fresh in the worker and torch policies run single-threaded. Results are
therefore identical whichever the backend and the number of workers (the
wall time column excepted).

Reproducibility
---------------
Each row records the package version, the environment ID and version, the
scenario key (``name@version``), the controller settings (JSON), the
fingerprints of the FitResults the controller was tuned or trained on and of
the environment's plant parameters, the plant (``model``/``rig``) and the
seed.

Sim-to-real
-----------
With ``plants=("model", "rig")`` every episode runs on the identified model
and on the virtual rig (the true plant, its sensors, an actuator specimen):
controllers tuned on identified models meet the plant they were not tuned
on, and the report shows the gap
(:func:`~thermogym.controllers.tables.sim_to_real_gap`).
"""

from __future__ import annotations

import json
import logging
import math
import multiprocessing as mp
import os
import sys
import time
from collections.abc import Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pandas as pd
from tqdm.auto import tqdm

import thermogym.envs  # noqa: F401 - registers the environments
from thermogym import __version__
from thermogym.controllers.presets import build_controller, expand_controllers
from thermogym.controllers.report import write_report
from thermogym.controllers.scenarios import Scenario, get_scenario
from thermogym.controllers.tables import KEY_COLUMNS
from thermogym.errors import ConfigError

__all__ = [
    "BACKENDS",
    "BenchmarkResult",
    "EpisodeSpec",
    "run_benchmark",
    "run_episode",
]

log = logging.getLogger("thermogym.controllers")

BACKENDS = ("local", "ray", "serial")


@dataclass(frozen=True)
class EpisodeSpec:
    """One episode of a benchmark grid.

    Attributes
    ----------
    env_id : str
        Registered environment ID.
    scenario : str
        Scenario key (``name@version``).
    controller : str
        Controller preset name.
    seed : int
        Episode seed (environment and controller).
    plant : str
        ``"model"`` or ``"rig"`` (the scenario may force the rig).
    options : dict
        Controller options (``{"policy": PATH}``).
    record : bool
        Keep the trajectory.
    index : int
        Position in the grid.
    points : int
        Largest number of trajectory samples kept (block means beyond).
    scenario_def : Scenario, optional
        The scenario itself when it is not a registered one (a user's own
        :class:`Scenario` travels with the episode to the worker processes).
    params : str, optional
        FitResult file of the identified model for the episodes on the model
        (``gymnasium.make(..., params=...)``); rig episodes ignore it.
    """

    env_id: str
    scenario: str
    controller: str
    seed: int
    plant: str = "model"
    options: dict[str, Any] = field(default_factory=dict)
    record: bool = False
    index: int = 0
    points: int = 12000
    scenario_def: Scenario | None = None
    params: str | None = None

    def scenario_obj(self) -> Scenario:
        """The episode's scenario (its own definition, else the registered one)."""
        return get_scenario(self.scenario_def or self.scenario)

    def env_kwargs(self, env_name: str) -> dict[str, Any]:
        """Keyword arguments of ``gymnasium.make`` for this episode."""
        scen = self.scenario_obj()
        kw = scen.kwargs(env_name, self.seed, self.plant)
        if self.params is not None and scen.plant_for(self.plant) == "model":
            kw["params"] = self.params
        return kw


def _env_name(env_id: str) -> str:
    return env_id.split("/")[-1].split("-v")[0]


def _fingerprints(obj: Any) -> list[str]:
    out: list[str] = []
    if isinstance(obj, Mapping):
        for k, v in obj.items():
            if k in ("fingerprint", "fit_fingerprint") and isinstance(v, str):
                out.append(v)
            else:
                out += _fingerprints(v)
    elif isinstance(obj, list | tuple):
        for v in obj:
            out += _fingerprints(v)
    return out


def _block_mean(a: np.ndarray, k: int) -> np.ndarray:
    n = (a.size // k) * k
    if n == 0:
        return a
    head = a[:n].reshape(-1, k).mean(axis=1)
    return head if n == a.size else np.append(head, a[n:].mean())


def run_episode(spec: EpisodeSpec) -> dict[str, Any]:
    """Run one episode; return ``{"row": {...}, "trajectory": {...} | None}``.

    Parameters
    ----------
    spec : EpisodeSpec

    Returns
    -------
    dict
        ``row``: the table row (keys of the grid, reproducibility columns,
        return, steps, the KPIs and the controller's stats prefixed
        ``ctrl_``); ``trajectory``: signal name → array (recorded episodes
        only; block means when longer than ``spec.points``).

    Examples
    --------
    >>> spec = EpisodeSpec("thermogym/AXT211Valve-v0", "setpoint-steps@1", "onoff", seed=0)
    >>> out = run_episode(spec)
    >>> out["row"]["controller"], out["row"]["steps"], out["row"]["switch_cycles"] > 10
    ('onoff', 1440, True)
    """
    try:  # deterministic, and no oversubscription of the cores by torch / BLAS
        import torch

        torch.set_num_threads(1)
    except ImportError:
        pass
    scen = spec.scenario_obj()
    kw = spec.env_kwargs(_env_name(spec.env_id))
    t0 = time.perf_counter()
    env = gym.make(spec.env_id, record=spec.record, **kw)
    ctrl = build_controller(spec.controller, env, env_kwargs=kw, options=spec.options)
    obs, _ = env.reset(seed=spec.seed)
    ctrl.reset(seed=spec.seed)
    total, steps = 0.0, 0
    terminated = truncated = False
    info: dict[str, Any] = {}
    while not (terminated or truncated):
        obs, r, terminated, truncated, info = env.step(ctrl.act(obs))
        total += float(r)
        steps += 1
    u = env.unwrapped
    settings = ctrl.settings()
    row: dict[str, Any] = {
        "env_id": spec.env_id,
        "env_version": spec.env_id.rsplit("-", 1)[-1],
        "scenario": scen.name,
        "scenario_version": scen.version,
        "controller": spec.controller,
        "plant": scen.plant_for(spec.plant),
        "seed": int(spec.seed),
        "package_version": __version__,
        "controller_settings": json.dumps(settings, sort_keys=True, default=str),
        "controller_fits": ",".join(sorted(set(_fingerprints(settings)))),
        "env_fit_fingerprint": fit.fingerprint() if (fit := getattr(u, "fit", None)) else "",
        "steps": steps,
        "terminated": bool(terminated),
        "trip": str(info.get("trip", "")),
        "return": total,
    }
    row.update({k: float(v) for k, v in info.get("kpis", {}).items()})
    row.update({f"ctrl_{k}": float(v) for k, v in ctrl.stats().items()})
    row["wall_s"] = time.perf_counter() - t0
    traj = None
    if spec.record:
        hist = u.history()  # type: ignore[attr-defined]
        n = len(hist["time"])
        k = max(1, math.ceil(n / max(int(spec.points), 2)))
        traj = {key: _block_mean(np.asarray(v, dtype=float), k) for key, v in hist.items()}
        traj["time"] = np.asarray(hist["time"][::k], dtype=float)[: len(traj[next(iter(hist))])]
    env.close()
    return {"row": row, "trajectory": traj}


@dataclass
class BenchmarkResult:
    """Outcome of :func:`run_benchmark`.

    Attributes
    ----------
    table : pandas.DataFrame
        One row per episode, in grid order (see :func:`run_episode`).
    trajectories : dict
        ``(scenario, controller, plant, seed) → {signal: array}`` of the
        recorded episodes.
    specs : list of EpisodeSpec
    backend : str
    workers : int
    seconds : float
        Wall time of the grid.
    files : dict
        What :func:`~thermogym.controllers.report.write_report` wrote
        (``name → path``), when ``out`` was given.
    """

    table: Any
    trajectories: dict[tuple[str, str, str, int], dict[str, np.ndarray]]
    specs: list[EpisodeSpec]
    backend: str
    workers: int
    seconds: float
    files: dict[str, Path] = field(default_factory=dict)

    def kpi_columns(self) -> list[str]:
        """The KPI columns of the table."""
        skip = {
            *KEY_COLUMNS,
            "env_version",
            "scenario_version",
            "package_version",
            "controller_settings",
            "controller_fits",
            "env_fit_fingerprint",
            "steps",
            "terminated",
            "trip",
            "return",
            "wall_s",
        }
        return [c for c in self.table.columns if c not in skip and not c.startswith("ctrl_")]

    def summary(self, kpis: Sequence[str] | None = None) -> Any:
        """Mean, standard deviation and count per scenario, plant and controller."""
        cols = list(kpis) if kpis is not None else [*self.kpi_columns(), "return"]
        g = self.table.groupby(["scenario", "plant", "controller"], sort=False)[cols]
        return g.agg(["mean", "std", "count"])


def _specs(
    env_id: str,
    scenarios: Sequence[str | Scenario],
    controllers: Sequence[str],
    seeds: Sequence[int],
    plants: Sequence[str],
    options: Mapping[str, Mapping[str, Any]],
    record: str,
    points: int,
    params: str | None = None,
) -> list[EpisodeSpec]:
    name = _env_name(env_id)
    out: list[EpisodeSpec] = []
    done: set[tuple[str, str, int, str]] = set()
    for s in scenarios:
        scen = get_scenario(s)
        if not scen.applies_to(name):
            raise ConfigError(
                f"scenario {scen.key!r} is not defined for {name}; it is for "
                f"{sorted(scen.env_kwargs)}"
            )
        for plant in plants:
            p = scen.plant_for(plant)
            for c in controllers:
                for i, seed in enumerate(seeds):
                    key = (scen.key, c, int(seed), p)
                    if key in done:  # a scenario that forces the rig runs once
                        continue
                    done.add(key)
                    rec = record == "all" or (record == "first" and i == 0)
                    out.append(
                        EpisodeSpec(
                            env_id,
                            scen.key,
                            c,
                            int(seed),
                            p,
                            dict(options.get(c, {})),
                            rec,
                            len(out),
                            int(points),
                            scen if isinstance(s, Scenario) else None,
                            params,
                        )
                    )
    return out


def _progress(total: int, show: bool | None) -> Any:
    disable = (not sys.stderr.isatty()) if show is None else not show
    return tqdm(total=total, desc="episodes", unit="ep", disable=disable, leave=False)


def _run_local(specs: list[EpisodeSpec], workers: int, bar: Any) -> list[dict[str, Any]]:
    results: list[dict[str, Any] | None] = [None] * len(specs)
    ctx = mp.get_context("spawn")
    with ProcessPoolExecutor(max_workers=workers, mp_context=ctx) as pool:
        futs = {pool.submit(run_episode, s): s.index for s in specs}
        for fut in as_completed(futs):
            results[futs[fut]] = fut.result()
            bar.update(1)
    return results  # type: ignore[return-value]


def _run_ray(
    specs: list[EpisodeSpec], workers: int | None, bar: Any, ray_options: Mapping[str, Any]
) -> list[dict[str, Any]]:
    try:
        import ray
    except ImportError as e:
        raise ConfigError("backend 'ray' needs Ray (pip install 'thermogym[ray]')") from e
    if not ray.is_initialized():
        opts: dict[str, Any] = {"include_dashboard": False, "log_to_driver": False}
        if workers is not None:
            opts["num_cpus"] = workers
        opts.update(ray_options)
        ray.init(**opts)
    task = ray.remote(num_cpus=1)(run_episode)
    refs = {task.remote(s): s.index for s in specs}
    results: list[dict[str, Any] | None] = [None] * len(specs)
    pending = list(refs)
    while pending:
        done, pending = ray.wait(pending, num_returns=1)
        for r in done:
            results[refs[r]] = ray.get(r)
            bar.update(1)
    return results  # type: ignore[return-value]


def run_benchmark(
    env_id: str,
    scenarios: str | Scenario | Sequence[str | Scenario],
    controllers: str | Sequence[str],
    seeds: int | Sequence[int] = 3,
    out: str | os.PathLike[str] | None = None,
    backend: str = "local",
    *,
    plants: str | Sequence[str] = ("model",),
    workers: int | None = None,
    options: Mapping[str, Mapping[str, Any]] | None = None,
    record: str = "first",
    trajectory_points: int = 12000,
    progress: bool | None = None,
    ray_options: Mapping[str, Any] | None = None,
    report: bool = True,
    title: str | None = None,
    params: str | os.PathLike[str] | None = None,
) -> BenchmarkResult:
    """Run a controller benchmark grid and (optionally) write its report.

    Parameters
    ----------
    env_id : str
        Registered environment ID (``"thermogym/AXT211Room-v0"``).
    scenarios : str, Scenario or sequence
        Scenario names or keys (:mod:`thermogym.controllers.scenarios`).
    controllers : str or sequence of str
        Controller presets or groups (``"onoff,pwm,pid,mpc,ppo"``).
    seeds : int or sequence of int
        ``N`` (seeds 0..N−1) or the seeds.
    out : path, optional
        Folder for the report (:func:`~thermogym.controllers.report.write_report`).
    backend : {"local", "ray", "serial"}
    plants : str or sequence
        ``"model"``, ``"rig"`` or both (sim-to-real gap).
    workers : int, optional
        Parallel episodes (default: the CPU count, at most the grid size).
    options : mapping, optional
        ``{controller: {option: value}}`` (``{"ppo": {"policy": PATH}}``).
    record : {"first", "all", "none"}
        Which episodes keep their trajectory (``"first"``: the first seed of
        each scenario × controller × plant, for the trajectory figures).
    trajectory_points : int
        Samples kept per recorded trajectory (block means of longer episodes).
    progress : bool, optional
        Show a progress bar (default: when stderr is a terminal).
    ray_options : mapping, optional
        ``ray.init`` keyword arguments when no Ray instance runs.
    report : bool
        Write the report when ``out`` is given.
    title : str, optional
        Title of the Markdown report.
    params : path, optional
        FitResult of the identified model: episodes on the model run with
        ``params=`` (the environment is built from it; its fingerprint is in
        the table's ``env_fit_fingerprint``); rig episodes are unaffected.

    Returns
    -------
    BenchmarkResult

    Raises
    ------
    ConfigError
        Unknown backend, scenario not defined for the environment, bad
        seeds, or a controller that cannot be built (checked before the grid
        starts, on the first scenario).

    Examples
    --------
    >>> res = run_benchmark("thermogym/AXT211Valve-v0", "setpoint-steps", "onoff,pid",
    ...                     seeds=[0], backend="serial")
    >>> res.table[["controller", "seed"]].values.tolist()
    [['onoff', 0], ['pid', 0]]
    >>> bool((res.table["stroke_rmse_mm"] > 0).all())
    True
    """
    if backend not in BACKENDS:
        raise ConfigError(f"backend is {backend!r}; expected one of {BACKENDS}")
    if record not in ("first", "all", "none"):
        raise ConfigError(f"record is {record!r}; expected 'first', 'all' or 'none'")
    scen_list = [scenarios] if isinstance(scenarios, str | Scenario) else list(scenarios)
    if not scen_list:
        raise ConfigError("no scenario given")
    ctrl_list = expand_controllers(controllers)
    if isinstance(seeds, int | np.integer):
        if seeds < 1:
            raise ConfigError(f"seeds is {seeds!r}; expected N >= 1 or a list of seeds")
        seed_list = list(range(int(seeds)))
    else:
        seed_list = [int(s) for s in seeds]
        if not seed_list or len(set(seed_list)) != len(seed_list):
            raise ConfigError(f"seeds {list(seeds)!r}; expected distinct integers")
    plant_list = [plants] if isinstance(plants, str) else list(plants)
    bad = [p for p in plant_list if p not in ("model", "rig")]
    if bad or not plant_list:
        raise ConfigError(f"plants {plant_list!r}; expected 'model' and/or 'rig'")
    specs = _specs(
        env_id,
        scen_list,
        ctrl_list,
        seed_list,
        plant_list,
        options or {},
        record,
        trajectory_points,
        None if params is None else os.fspath(params),
    )
    _check_buildable(env_id, specs)
    n_cpu = os.cpu_count() or 1
    n_workers = max(1, min(len(specs), workers or n_cpu))
    t0 = time.perf_counter()
    with _progress(len(specs), progress) as bar:
        if backend == "serial" or (backend == "local" and n_workers == 1):
            results = []
            for s in specs:
                results.append(run_episode(s))
                bar.update(1)
        elif backend == "local":
            results = _run_local(specs, n_workers, bar)
        else:
            results = _run_ray(specs, workers, bar, ray_options or {})
    seconds = time.perf_counter() - t0
    table = pd.DataFrame([r["row"] for r in results])
    trajs = {
        (s.scenario, s.controller, s.plant, s.seed): r["trajectory"]
        for s, r in zip(specs, results, strict=True)
        if r["trajectory"] is not None
    }
    res = BenchmarkResult(table, trajs, specs, backend, n_workers, seconds)
    log.info("benchmark of %d episodes in %.1f s (%s)", len(specs), seconds, backend)
    if out is not None and report:
        res.files = write_report(res, Path(out), title=title)
    return res


def _check_buildable(env_id: str, specs: list[EpisodeSpec]) -> None:
    """Build every (scenario, controller, plant) once before the grid: fail early."""
    seen: set[tuple[str, str, str]] = set()
    for s in specs:
        key = (s.scenario, s.controller, s.plant)
        if key in seen:
            continue
        seen.add(key)
        kw = s.env_kwargs(_env_name(env_id))
        env = gym.make(env_id, **kw)
        build_controller(s.controller, env, env_kwargs=kw, options=s.options)
        env.close()


def episode_specs_dict(res: BenchmarkResult) -> list[dict[str, Any]]:
    """The grid as JSON-able dicts."""
    return [asdict(s) for s in res.specs]
