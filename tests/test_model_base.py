"""The batched Model interface: parameter batches, registry, keyword rejection."""

from __future__ import annotations

import numpy as np
import pytest

from thermogym.errors import ConfigError, ParameterError, ShapeError, UnknownNameError
from thermogym.models import AXT211, Parameter, Signal
from thermogym.models.registry import get_model, model_names


def test_theta_forms_agree():
    m = AXT211()
    P = len(m.param_names)
    assert m.theta().shape == (1, P)
    np.testing.assert_array_equal(m.theta()[0], m.nominal)
    th = m.theta({"C_P": [10.0, 20.0]})
    assert th.shape == (2, P) and list(th[:, m.param_index("C_P")]) == [10.0, 20.0]
    np.testing.assert_array_equal(m.theta([{"C_P": 10.0}, {"C_P": 20.0}]), th)
    np.testing.assert_array_equal(m.theta(th), th)
    np.testing.assert_array_equal(m.theta(None, batch=3), np.repeat(m.nominal[None], 3, 0))
    assert m.theta(C_P=11.0)[0, m.param_index("C_P")] == 11.0


def test_theta_errors_name_the_problem():
    m = AXT211()
    with pytest.raises(ParameterError, match=r"theta has shape \(3,\)"):
        m.theta(np.zeros(3))
    with pytest.raises(ParameterError, match="different lengths"):
        m.theta({"C_P": [1.0, 2.0], "C_G": [1.0, 2.0, 3.0]})
    with pytest.raises(ParameterError, match="'tau_P' of set 0 is nan"):
        m.theta({"tau_P": np.nan})


def test_signals_and_parameters_validate_their_own_fields():
    with pytest.raises(ParameterError, match="role 'sensor'"):
        Signal("T", "sensor", "°C", "x")  # type: ignore[arg-type]
    with pytest.raises(ParameterError, match="not an identifier"):
        Signal("T out", "output", "°C", "x")
    with pytest.raises(ParameterError, match="outside its bounds"):
        Parameter("a", 5.0, 0.0, 1.0, "1", "x", "y")


def test_registry_builds_every_model_and_rejects_unknown_kwargs():
    names = model_names()
    for n in ("axt211", "spindle", "strut"):
        assert n in names
        m = get_model(n)
        assert m.name == n
        assert get_model(n, **m.config()).param_names == m.param_names
    with pytest.raises(UnknownNameError, match="unknown model 'pump'"):
        get_model("pump")
    with pytest.raises(ConfigError, match="'axt211' cannot be built"):
        get_model("axt211", colour="red")
    with pytest.raises(TypeError):
        AXT211(colour="red")  # type: ignore[call-arg]


def test_simulate_broadcasts_u_and_theta_batches():
    m = AXT211()
    u = np.zeros((2, 50, 3))
    u[:, :, 1] = 24.0
    u[:, :, 2] = [[10.0], [30.0]]
    sim = m.simulate(u, dt=1.0, theta=m.theta())
    assert sim.outputs.shape == (2, 50, 6)
    assert sim.output("T_G")[0, 0] == 10.0 and sim.output("T_G")[1, 0] == 30.0
    with pytest.raises(ShapeError, match="x0 has shape"):
        m.simulate(u, dt=1.0, x0=np.zeros(3))
    with pytest.raises(UnknownNameError, match="outputs are"):
        sim.output("T_Q")


def test_describe_lists_signals_and_parameters_with_provenance():
    d = AXT211().describe()
    assert d["name"] == "axt211"
    roles = {s["name"]: s["role"] for s in d["signals"]}
    assert roles["u"] == "input" and roles["k_U"] == "disturbance" and roles["x_V"] == "output"
    assert all(p["provenance"] and p["unit"] for p in d["parameters"])
