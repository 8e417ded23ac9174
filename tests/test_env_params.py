"""Parameters of every environment: plain overrides, complete FitResults, registration on import."""

from __future__ import annotations

import subprocess
import sys

import gymnasium as gym
import pytest

import thermogym
from thermogym.errors import ParameterError
from thermogym.fitresult import FitResult

IDS = tuple(thermogym.ENVIRONMENTS)


def _first_param(env_id: str) -> tuple[str, float]:
    env = gym.make(env_id)
    model = env.unwrapped._e.model
    name = model.param_names[0]
    value = float(env.unwrapped._e.plant.fit.parameters[name])
    env.close()
    return name, value


@pytest.mark.parametrize("env_id", IDS)
def test_plain_overrides_on_every_env(env_id):
    name, value = _first_param(env_id)
    new = value * 1.1 if value else 0.5
    env = gym.make(env_id, params={name: new})
    e = env.unwrapped._e
    assert e.plant.fit.parameters[name] == pytest.approx(new)
    assert float(e.base_theta[0, e.model.param_index(name)]) == pytest.approx(new)
    env.reset(seed=0)
    with pytest.raises(ParameterError, match="no_such_parameter"):
        gym.make(env_id, params={"no_such_parameter": 1.0})
    # the same on a running environment
    change = env.unwrapped.set_parameters({name: value})
    assert name in change["changed"]
    env.close()


@pytest.mark.parametrize("env_id", IDS)
def test_a_fitresult_missing_a_parameter_is_refused_with_its_name(env_id):
    env = gym.make(env_id)
    d = env.unwrapped._e.plant.fit.to_dict()
    env.close()
    name = next(iter(d["parameters"]))
    for key in ("parameters", "bounds", "stderr"):
        d[key] = {k: v for k, v in d[key].items() if k != name}
    d["covariance"], d["covariance_names"], d["fixed"] = None, [], []
    with pytest.raises(ParameterError, match=rf"lacks parameter\(s\) \['{name}'\]"):
        gym.make(env_id, params=FitResult.from_dict(d))


def test_import_thermogym_registers_the_environments():
    code = "import gymnasium as gym, thermogym; gym.make('thermogym/TCLab-v0').reset(seed=0)"
    subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, timeout=120)
