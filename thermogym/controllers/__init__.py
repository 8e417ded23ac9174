"""Controllers for the thermogym environments and the benchmark harness.

One interface for every controller (:class:`Controller`): ``bind(env)``
resolves the observation layout by name, ``reset()`` starts an episode,
``act(obs)`` returns the action.

================================  ==========================================================
controller                        module
================================  ==========================================================
:class:`OnOff`                    thermostat with hysteresis, minimum on/off times
                                  (:mod:`~thermogym.controllers.onoff`)
:class:`PWM`                      PWM at a period: open loop or as output stage
                                  (:mod:`~thermogym.controllers.pwm`; paper 002 sec. VIII)
:class:`PID`                      anti-windup, derivative filter, limits, bumpless changes;
                                  :func:`simc`, :func:`lambda_tuning` from identified models
:class:`MPC`                      linear MPC (OSQP) with limits, switching cost, soft band
:class:`StaticMap`,               open-loop duty from a model's static inverse
:class:`LinearFeedforward`
:class:`RLController`             stable-baselines3 policies (:mod:`~thermogym.controllers.rl`:
                                  :class:`RLConfig`, :func:`train`)
:class:`Decentralized`            one single-loop controller per action channel
:class:`OptimumStart`             applies a schedule's occupied set-point early by the
                                  room's recovery time (:mod:`~thermogym.controllers.schedule`)
================================  ==========================================================

Benchmarks: :func:`run_benchmark` runs controller presets
(:mod:`~thermogym.controllers.presets`) × scenarios
(:mod:`~thermogym.controllers.scenarios`) × seeds × plants locally or on Ray
and writes tables, a Markdown summary and figures
(:mod:`~thermogym.controllers.report`, :mod:`~thermogym.controllers.plots`).

Examples
--------
>>> import gymnasium as gym
>>> import thermogym.envs
>>> from thermogym.controllers import PID, PWM
>>> env = gym.make("thermogym/AXT211Room-v0", action_mode="onoff", start_day=10)
>>> ctrl = PWM("low", inner=PID(kp=0.5, ti=7200.0)).bind(env)
>>> obs, info = env.reset(seed=0)
>>> ctrl.reset()
>>> env.step(ctrl.act(obs))[0].shape
(9,)
"""

from thermogym.controllers.base import (
    ENV_HOLD,
    ENV_LOOPS,
    Controller,
    Decentralized,
    EnvInfo,
    Loop,
    env_info,
)
from thermogym.controllers.feedforward import LinearFeedforward, StaticMap, steady_state_map
from thermogym.controllers.harness import (
    BenchmarkResult,
    EpisodeSpec,
    run_benchmark,
    run_episode,
)
from thermogym.controllers.linmodel import LinearPlant, linear_plant
from thermogym.controllers.mpc import MPC, PreviewData, SchedulePreview
from thermogym.controllers.onoff import OnOff
from thermogym.controllers.pid import FOPTD, PID, PIDGains, foptd_of, lambda_tuning, simc
from thermogym.controllers.presets import (
    CONTROLLER_GROUPS,
    CONTROLLER_NAMES,
    build_controller,
    expand_controllers,
)
from thermogym.controllers.pwm import PWM, PWM_PERIODS
from thermogym.controllers.rl import RLConfig, RLController, ScaledObservation, train
from thermogym.controllers.scenarios import SCENARIOS, Scenario, get_scenario
from thermogym.controllers.schedule import OptimumStart
from thermogym.controllers.tables import sim_to_real_gap

__all__ = [
    "CONTROLLER_GROUPS",
    "CONTROLLER_NAMES",
    "ENV_HOLD",
    "ENV_LOOPS",
    "FOPTD",
    "MPC",
    "PID",
    "PWM",
    "PWM_PERIODS",
    "SCENARIOS",
    "BenchmarkResult",
    "Controller",
    "Decentralized",
    "EnvInfo",
    "EpisodeSpec",
    "LinearFeedforward",
    "LinearPlant",
    "Loop",
    "OnOff",
    "OptimumStart",
    "PIDGains",
    "PreviewData",
    "RLConfig",
    "RLController",
    "ScaledObservation",
    "Scenario",
    "SchedulePreview",
    "StaticMap",
    "build_controller",
    "env_info",
    "expand_controllers",
    "foptd_of",
    "get_scenario",
    "lambda_tuning",
    "linear_plant",
    "run_benchmark",
    "run_episode",
    "sim_to_real_gap",
    "simc",
    "steady_state_map",
    "train",
]
