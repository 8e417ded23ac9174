"""External-model adapters: each identifies the same toy model to the same answer.

The toy model is a first-order thermal lag tau dy/dt = -y + K u. The data are
made here independently of every adapter: the ODE is integrated with
scipy's solve_ivp (tight tolerances) over each sample interval with the input
held, on a non-uniform time grid, plus seeded Gaussian noise. Each adapter
(callable, script, batch job, FMU, Octave) wraps its own implementation of
the model (fixtures in tests/data/external/), and scipy.optimize.least_squares
fits K and tau through the adapter's SimModel interface.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import least_squares

from thermogym.errors import ConfigError, ParameterError, RecordingError
from thermogym.identification.external import (
    BatchJobModel,
    CallableModel,
    CoSimModel,
    FMUModel,
    OctaveModel,
    ScriptModel,
    load_external,
    read_config,
    time_evaluations,
)
from thermogym.identification.external.octave import find_octave
from thermogym.identification.external.script import rewrite_script
from thermogym.identification.simmodel import SimModel
from thermogym.recording import Recording

DATA = Path(__file__).parent / "data" / "external"
K_TRUE, TAU_TRUE = 2.5, 180.0
NOISE = 0.2  # K
PARAMS = {
    "K": {"start": 1.0, "lower": 0.1, "upper": 10.0},
    "tau": {"start": 60.0, "lower": 5.0, "upper": 2000.0},
}
OCTAVE = find_octave()
needs_octave = pytest.mark.skipif(
    OCTAVE is None, reason="GNU Octave is not installed (no octave-cli/octave on PATH)"
)


def lag_truth(time: np.ndarray, u: np.ndarray, K: float, tau: float, y0: float = 0.0) -> np.ndarray:
    """Integrate tau dy/dt = -y + K u with u held over each interval (independent truth)."""
    y = np.empty_like(time)
    y[0] = y0
    for k in range(len(time) - 1):
        sol = solve_ivp(
            lambda t, x, uk=u[k]: (-x + K * uk) / tau,
            (time[k], time[k + 1]),
            [y[k]],
            rtol=1e-11,
            atol=1e-12,
        )
        y[k + 1] = sol.y[0, -1]
    return y


@pytest.fixture(scope="module")
def lag_data() -> Recording:
    rng = np.random.default_rng(42)
    n = 120
    time = np.concatenate([[0.0], np.cumsum(10.0 + rng.uniform(-2.0, 2.0, n - 1))])
    levels = rng.choice([0.0, 20.0, 40.0], size=n // 8 + 1)
    u = np.repeat(levels, 8)[:n]
    y = lag_truth(time, u, K_TRUE, TAU_TRUE)
    noisy = y + rng.normal(0.0, NOISE, n)
    return Recording(
        time,
        {"P_heater": u, "T_rise": noisy, "T_true": y},
        units={"P_heater": "W", "T_rise": "K", "T_true": "K"},
        experiment_id="lag_prbs",
    )


def fit(model: SimModel, rec: Recording, column: str = "T_rise") -> tuple[np.ndarray, np.ndarray]:
    """Least squares through the SimModel interface; the Jacobian's sets go in one batch."""
    y = rec[column]
    last: dict = {}

    def residual(theta: np.ndarray) -> np.ndarray:
        batch = model.simulate(theta[None], rec)
        assert batch.errors == [None], batch.errors
        last["theta"], last["out"] = theta.copy(), batch.outputs[0, :, 0]
        return batch.outputs[0, :, 0] - y

    def jac(theta: np.ndarray) -> np.ndarray:
        h = 1e-6 * np.maximum(np.abs(theta), 1.0)
        if not np.array_equal(last.get("theta"), theta):
            residual(theta)
        batch = model.simulate(theta + np.diag(h), rec)  # the perturbed sets in parallel
        assert all(e is None for e in batch.errors), batch.errors
        return ((batch.outputs[:, :, 0] - last["out"]) / h[:, None]).T

    res = least_squares(
        residual, model.nominal, jac=jac, bounds=(model.lower, model.upper), xtol=1e-12, ftol=1e-12
    )
    J = res.jac
    s2 = 2 * res.cost / (len(y) - len(res.x))
    se = np.sqrt(np.diag(np.linalg.inv(J.T @ J) * s2))
    return res.x, se


@pytest.fixture(scope="module")
def fmu_path(tmp_path_factory: pytest.TempPathFactory) -> Path:
    pytest.importorskip("pythonfmu")
    pytest.importorskip("fmpy")
    out = tmp_path_factory.mktemp("fmu")
    subprocess.run(
        [
            sys.executable,
            "-m",
            "pythonfmu",
            "build",
            "-f",
            str(DATA / "lag_fmu.py"),
            "-d",
            str(out),
        ],
        check=True,
        capture_output=True,
    )
    return out / "LagFMU.fmu"


def _adapter(kind: str, fmu: Path | None = None, **kw):
    common = dict(parameters=PARAMS, inputs={"u": "P_heater"}, outputs={"y": "T_rise"}, **kw)
    if kind == "callable":
        return CallableModel(f"{DATA / 'lag_func.py'}:lag", **common)
    if kind == "script":
        return ScriptModel(DATA / "lag_script.py", **common)
    if kind == "batchjob":
        cmd = ["{python}", str(DATA / "lag_batch.py"), "{inputs}", "{params}", "{outputs}"]
        return BatchJobModel(cmd, **common)
    if kind == "fmu":
        return FMUModel(fmu, **common)
    if kind == "octave":
        return OctaveModel(DATA / "lag_octave.m", **common)
    raise AssertionError(kind)


KINDS = [
    "callable",
    "script",
    "batchjob",
    "fmu",
    pytest.param("octave", marks=needs_octave),
]


@pytest.fixture(scope="module")
def fits() -> dict:
    """Estimates of the adapters of this module, for the comparison test."""
    return {}


@pytest.mark.parametrize("kind", KINDS)
def test_each_adapter_identifies_the_toy_model(kind, lag_data, fits, request):
    fmu = request.getfixturevalue("fmu_path") if kind == "fmu" else None
    with _adapter(kind, fmu, timeout=60.0) as model:
        assert isinstance(model, SimModel)
        assert model.param_names == ("K", "tau")
        assert model.input_names == ("P_heater",) and model.output_names == ("T_rise",)
        # the noise-free prediction at the true parameters matches the integrated ODE
        truth = model.simulate(np.array([[K_TRUE, TAU_TRUE]]), lag_data)
        assert truth.errors == [None]
        np.testing.assert_allclose(truth.outputs[0, :, 0], lag_data["T_true"], atol=1e-6)
        theta, se = fit(model, lag_data)
        assert model.stats["failed"] == 0
    # known parameters recovered within their confidence intervals (4 standard errors)
    assert abs(theta[0] - K_TRUE) < 4 * se[0], (theta, se)
    assert abs(theta[1] - TAU_TRUE) < 4 * se[1], (theta, se)
    assert se[0] < 0.05 * K_TRUE and se[1] < 0.1 * TAU_TRUE
    fits[kind] = theta


def test_all_adapters_reach_the_same_answer(fits):
    if len(fits) < 4:
        pytest.skip("needs the per-adapter fits of this module")
    ref = fits["callable"]
    for kind, theta in fits.items():
        np.testing.assert_allclose(theta, ref, rtol=1e-6, err_msg=kind)


@pytest.mark.parametrize("kind", ["callable", "script", "batchjob", "fmu"])
def test_config_of_a_model_rebuilds_it(kind, lag_data, request):
    fmu = request.getfixturevalue("fmu_path") if kind == "fmu" else None
    th = np.array([[K_TRUE, TAU_TRUE], [1.0, 50.0]])
    with _adapter(kind, fmu, backend="serial") as model:
        cfg = model.config()
        json.dumps(cfg)  # plain JSON: it goes into FitResults
        with load_external(cfg) as again:
            assert type(again) is type(model) and again.version == model.version
            assert again.param_names == model.param_names and again.inputs == model.inputs
            np.testing.assert_array_equal(
                again.simulate(th, lag_data).outputs, model.simulate(th, lag_data).outputs
            )


# ------------------------------------------------------------------ configuration
def _write(path: Path, text: str) -> Path:
    path.write_text(text, encoding="utf-8")
    return path


def _heater() -> dict:
    """The lag plant as a co-simulation member (the Python callable of tests/data/external)."""
    return {
        "type": "callable",
        "path": str(DATA / "lag_func.py"),
        "function": "lag",
        "parameters": dict(PARAMS),
        "inputs": {"u": "P_heater"},
        "outputs": {"y": "T_h"},
    }


LAG_TOML = f"""
type = "script"
name = "lag"
path = "{DATA / "lag_script.py"}"
timeout = 30
[parameters.K]
start = 1.0
lower = 0.1
upper = 10.0
unit = "K/W"
[parameters.tau]
lower = 5.0
upper = 2000.0
[fixed]
y0 = 0.0
[inputs]
u = "P_heater"
[outputs]
y = "T_rise"
[evaluation]
backend = "serial"
"""


def test_toml_and_yaml_configs_build_the_same_model(tmp_path, lag_data):
    toml_path = _write(tmp_path / "lag.toml", LAG_TOML)
    yaml_path = _write(
        tmp_path / "lag.yaml",
        f"""
type: script
name: lag
path: {DATA / "lag_script.py"}
timeout: 30
parameters:
  K: {{start: 1.0, lower: 0.1, upper: 10.0, unit: K/W}}
  tau: {{lower: 5.0, upper: 2000.0}}
fixed: {{y0: 0.0}}
inputs: {{u: P_heater}}
outputs: {{y: T_rise}}
evaluation: {{backend: serial}}
""",
    )
    a, b = load_external(toml_path), load_external(yaml_path)
    try:
        for m in (a, b):
            assert m.param_names == ("K", "tau")
            np.testing.assert_array_equal(m.nominal, [1.0, 0.5 * (5.0 + 2000.0)])
            assert m.fixed == {"y0": 0.0} and m.timeout == 30.0
            assert m.evaluation.backend == "serial"
        th = np.array([[K_TRUE, TAU_TRUE]])
        np.testing.assert_array_equal(
            a.simulate(th, lag_data).outputs, b.simulate(th, lag_data).outputs
        )
    finally:
        a.close()
        b.close()


def test_config_paths_are_relative_to_the_file_and_overrides_apply(tmp_path):
    shutil.copy(DATA / "lag_script.py", tmp_path / "model.py")
    cfg = _write(
        tmp_path / "c.toml",
        'type = "script"\npath = "model.py"\nparameters = {K = [1.0, 0.1, 10.0]}\n'
        'inputs = ["u"]\noutputs = ["y"]\n',
    )
    c = read_config(cfg, backend="ray", workers=3, timeout=float("inf"))
    assert c.options["path"] == tmp_path / "model.py"
    assert c.name == "c" and c.workdir == tmp_path
    assert c.evaluation.backend == "ray" and c.evaluation.workers == 3
    assert c.timeout is None


@pytest.mark.parametrize(
    ("patch", "key"),
    [
        ({"type": "matlab"}, "'type'"),
        ({"colour": "red"}, "'colour'"),
        ({"parameters": {"K": {"start": 1, "lower": 2, "upper": 3}}}, "'parameters.K.start'"),
        ({"parameters": {"K": {"lower": 5, "upper": 3}}}, "'parameters.K'"),
        ({"parameters": {"K": {"lower": "a", "upper": 3}}}, "'parameters.K.lower'"),
        ({"parameters": {"K": {"lower": 0, "upper": 3, "step": 1}}}, "'parameters.K.step'"),
        ({"parameters": {"K": {"lower": 0.0}}}, "'parameters.K.start'"),
        ({"parameters": {"1K": [1, 0, 2]}}, "'parameters.1K'"),
        ({"fixed": {"y0": "zero"}}, "'fixed.y0'"),
        ({"fixed": {"K": 1.0}}, "'fixed.K'"),
        ({"inputs": {"u": "P heater"}}, "'inputs.u'"),
        ({"outputs": []}, "'outputs'"),
        ({"timeout": -1}, "'timeout'"),
        ({"evaluation": {"backend": "mpi"}}, "evaluation.backend"),
        ({"evaluation": {"workers": 0}}, "evaluation.workers"),
        ({"evaluation": {"threads": 2}}, "'evaluation.threads'"),
        ({"path": "nope.py"}, "'path'"),
        ({"path": str(DATA / "lag_octave.m")}, "'path'"),
    ],
)
def test_config_errors_name_the_offending_key(patch, key):
    cfg = {
        "type": "script",
        "path": str(DATA / "lag_script.py"),
        "parameters": {"K": [1.0, 0.1, 10.0], "tau": [100.0, 5.0, 2000.0]},
        "inputs": {"u": "P_heater"},
        "outputs": {"y": "T_rise"},
    }
    cfg.update(patch)
    with pytest.raises(ConfigError) as err:
        load_external(cfg)
    assert key in str(err.value)


def test_config_file_errors(tmp_path):
    with pytest.raises(ConfigError, match=r"cannot be parsed"):
        load_external(_write(tmp_path / "bad.toml", "type = \n"))
    with pytest.raises(ConfigError, match=r"suffix"):
        load_external(_write(tmp_path / "bad.ini", "type=script"))
    with pytest.raises(ConfigError, match=r"'type'.*missing"):
        load_external(_write(tmp_path / "t.json", json.dumps({"path": "x.py"})))
    with pytest.raises(ConfigError, match=r"'command'"):
        load_external({"type": "batchjob", "parameters": {"K": [1, 0, 2]}, "outputs": ["y"]})
    with pytest.raises(ConfigError, match=r"not found on PATH"):
        load_external(
            {"type": "batchjob", "command": "no_such_program_xyz {inputs}", "outputs": ["y"]}
        )
    with pytest.raises(ConfigError, match=r"'connections\[0\].to'.*'c'"):
        load_external(
            {
                "type": "cosim",
                "models": {"a": {"type": "callable", "callable": "math:exp", "outputs": ["y"]}},
                "connections": [{"from": "a.y", "to": "c.u"}],
            }
        )


# ------------------------------------------------------------------ script contract
def test_script_names_must_be_variables_of_the_script():
    common = dict(inputs={"u": "P"}, outputs={"y": "T"})
    with pytest.raises(ConfigError, match=r"'parameters.Kp'.*not a variable"):
        ScriptModel(DATA / "lag_script.py", parameters={"Kp": (1, 0, 2)}, **common)
    with pytest.raises(ConfigError, match=r"'inputs.v'"):
        ScriptModel(
            DATA / "lag_script.py", parameters={"K": (1, 0, 2)}, inputs={"v": "P"}, outputs=["y"]
        )
    with pytest.raises(ConfigError, match=r"'outputs.z'.*never assigns"):
        ScriptModel(
            DATA / "lag_script.py", parameters={"K": (1, 0, 2)}, inputs={"u": "P"}, outputs=["z"]
        )


def test_script_defaults_are_replaced_and_later_assignments_run():
    src = (
        "import math\nK = 2.0\ntau: float = 5.0\nK = K * 10\n"
        "if 'c' not in globals():\n    c = 1\ny = K + tau + c\n"
    )
    tree, defaults = rewrite_script(src, "s.py", {"K", "tau", "c"})
    assert defaults == {"K": 2, "tau": 3}
    ns = {"K": 3.0, "tau": 1.0, "c": 7}
    exec(compile(tree, "s.py", "exec"), ns)
    assert ns["y"] == 3.0 * 10 + 1.0 + 7
    # a default the adapter could not replace is refused, with its line
    with pytest.raises(ConfigError, match=r"line 2.*'K'.*assignment"):
        rewrite_script("x = 1\nK, tau = 2.0, 3.0\n", "s.py", {"K"})
    with pytest.raises(ConfigError, match=r"line 1.*'K'.*import"):
        rewrite_script("from config import K\n", "s.py", {"K"})
    with pytest.raises(ConfigError, match=r"line 2: invalid syntax|line 2"):
        rewrite_script("x = 1\nK = = 2\n", "s.py", {"K"})


def test_script_error_names_the_line_and_values_can_be_set_manually(tmp_path, lag_data):
    script = _write(
        tmp_path / "m.py",
        "import numpy as np\nK = 1.0\noffset = 0.0\ny = K * u + offset\nif K > 5:\n    y = 1 / 0\n",
    )
    with ScriptModel(
        script,
        parameters={"K": (1, 0, 10)},
        inputs={"u": "P_heater"},
        outputs=["y"],
        backend="serial",
    ) as m:
        out = m.simulate(np.array([[2.0], [6.0]]), lag_data)
        np.testing.assert_array_equal(out.outputs[0, :, 0], 2.0 * lag_data["P_heater"])
        assert out.errors[0] is None
        assert out.errors[1] == "ZeroDivisionError: division by zero (script m.py line 6)"
        assert np.isnan(out.outputs[1]).all()
        m.set_values(offset=3.0)  # paper 000 workflow step 2: set manually
        out = m.simulate(np.array([[2.0]]), lag_data)
        np.testing.assert_array_equal(out.outputs[0, :, 0], 2.0 * lag_data["P_heater"] + 3.0)
        with pytest.raises(ParameterError, match=r"'K' is an uncertain parameter"):
            m.set_values(K=1.0)
        with pytest.raises(ConfigError, match=r"'gain' is not a variable of script"):
            m.set_values(gain=1.0)
        pred = m.predict(lag_data, K=0.5)
        assert pred.columns == ("y",) and pred.roles["y"] == "output"
        np.testing.assert_array_equal(pred["y"], 0.5 * lag_data["P_heater"] + 3.0)


def test_script_outputs_on_their_own_grid_are_interpolated(tmp_path, lag_data):
    script = _write(
        tmp_path / "grid.py",
        "import numpy as np\nslope = 1.0\n"
        "t_out = np.linspace(time[0], time[-1], 7)\ny = slope * t_out\n",
    )
    with ScriptModel(
        script,
        parameters={"slope": (1, 0, 2)},
        outputs=["y"],
        output_time="t_out",
        backend="serial",
    ) as m:
        out = m.simulate(np.array([[0.5]]), lag_data)
    np.testing.assert_allclose(out.outputs[0, :, 0], 0.5 * lag_data.time, rtol=1e-12)


def test_missing_input_column_and_bad_theta_raise(lag_data):
    with _adapter("callable", backend="serial") as m:
        with pytest.raises(RecordingError, match=r"lacks column.*'P_heater'"):
            m.simulate(np.array([[1.0, 100.0]]), lag_data.drop("P_heater"))
        with pytest.raises(ParameterError, match=r"shape \(1, 3\).*\(B, 2\)"):
            m.simulate(np.ones((1, 3)), lag_data)
        with pytest.raises(ParameterError, match=r"'tau' of set 0 is nan"):
            m.simulate(np.array([[1.0, np.nan]]), lag_data)
        nan_input = lag_data.with_columns(P_heater=np.where(lag_data.time > 100, np.nan, 1.0))
        with pytest.raises(RecordingError, match=r"'P_heater'.*nan.*finite inputs"):
            m.simulate(np.array([[1.0, 100.0]]), nan_input)


def test_vectorized_callable_is_batched_and_matches_the_loop(lag_data):
    th = np.array([[2.0, 50.0], [K_TRUE, TAU_TRUE], [0.5, 900.0]])
    kw = dict(
        parameters=PARAMS, inputs={"u": "P_heater"}, outputs={"y": "T_rise"}, backend="serial"
    )
    with CallableModel(f"{DATA / 'lag_func.py'}:lag_vectorized", vectorized=True, **kw) as vec:
        assert vec.batched
        a = vec.simulate(th, lag_data)
    with CallableModel(f"{DATA / 'lag_func.py'}:lag", **kw) as loop:
        b = loop.simulate(th, lag_data)
    np.testing.assert_allclose(a.outputs, b.outputs, rtol=1e-13)
    assert a.errors == b.errors == [None] * 3


# ------------------------------------------------------------------ batch job
def test_batch_job_failures_are_reported(tmp_path, lag_data):
    common = dict(parameters={"K": (1, 0, 2)}, outputs=["y"], backend="serial", timeout=2.0)
    th = np.array([[1.0]])
    cases = [
        (["sh", "-c", "echo 'model diverged' >&2; exit 3"], "exit status 3: model diverged"),
        (["sh", "-c", "true"], "wrote no output file 'outputs.csv'"),
        (["sh", "-c", "printf 'y\\n1\\n2\\n' > {outputs}"], "the outputs have 2 samples"),
        (
            [
                "{python}",
                "-c",
                "import numpy as np; "
                "np.savetxt('{outputs}', np.full(120, np.nan), header='y', comments='')",
            ],
            "non-finite output: 'y' is nan",
        ),
        (["sh", "-c", "sleep 30"], "timed out after 2 s (process group killed)"),
    ]
    for cmd, msg in cases:
        with BatchJobModel(cmd, **common) as m:
            out = m.simulate(th, lag_data)
        assert out.errors[0] is not None and msg in out.errors[0], (cmd, out.errors)
        assert np.isnan(out.outputs).all()


def test_batch_job_files_and_placeholders(tmp_path, lag_data):
    job = _write(
        tmp_path / "job.py",
        "import csv, os, sys, numpy as np\n"
        "p = {r['name']: float(r['value']) for r in csv.DictReader(open(sys.argv[1]))}\n"
        "d = np.genfromtxt(os.environ['THERMOGYM_INPUTS'], delimiter=',', names=True)\n"
        "np.savetxt(sys.argv[2], np.column_stack([d['time'], p['K'] * d['u']]), delimiter=',',\n"
        "           header='time,y', comments='', fmt='%.17g')\n",
    )
    with BatchJobModel(
        ["{python}", str(job), "{params}", "{outputs}"],
        parameters={"K": (1, 0, 2)},
        inputs={"u": "P_heater"},
        outputs=["y"],
        params_format="csv",
        backend="serial",
    ) as m:
        out = m.simulate(np.array([[0.3]]), lag_data)
    assert out.errors == [None]
    np.testing.assert_array_equal(out.outputs[0, :, 0], 0.3 * lag_data["P_heater"])


# ------------------------------------------------------------------ FMU
def test_fmu_step_and_simulate_modes_agree_on_a_uniform_grid(fmu_path):
    t = np.arange(0.0, 600.0, 10.0)
    u = np.where((t >= 50) & (t < 300), 20.0, 5.0)
    rec = Recording(t, {"P_heater": u})
    th = np.array([[K_TRUE, TAU_TRUE], [1.0, 40.0]])
    kw = dict(
        parameters=PARAMS, inputs={"u": "P_heater"}, outputs={"y": "T_rise"}, backend="serial"
    )
    with FMUModel(fmu_path, mode="step", **kw) as a, FMUModel(fmu_path, mode="simulate", **kw) as b:
        assert a.mode == "step" and b.mode == "simulate"
        ya, yb = a.simulate(th, rec).outputs, b.simulate(th, rec).outputs
    for i, (K, tau) in enumerate(th):
        np.testing.assert_allclose(ya[i, :, 0], lag_truth(t, u, K, tau), atol=1e-8)
    np.testing.assert_allclose(ya, yb, atol=1e-10)


def test_fmu_start_values_and_variable_checks(fmu_path):
    t = np.arange(0.0, 100.0, 10.0)
    rec = Recording(t, {"P_heater": np.zeros_like(t)})
    with FMUModel(
        fmu_path,
        parameters={"tau": (50.0, 1.0, 100.0)},
        fixed={"y0": 4.0, "K": 1.0},
        inputs={"u": "P_heater"},
        outputs=["y"],
        backend="serial",
    ) as m:
        y = m.simulate(np.array([[50.0]]), rec).outputs[0, :, 0]
    # free decay from the start value y0 = 4 (set before initialisation)
    np.testing.assert_allclose(y, 4.0 * np.exp(-t / 50.0), rtol=1e-12)
    with pytest.raises(ConfigError, match=r"'parameters.gain'.*no variable 'gain'"):
        FMUModel(fmu_path, parameters={"gain": (1, 0, 2)}, outputs=["y"])
    with pytest.raises(ConfigError, match=r"'inputs.K'.*causality 'parameter'"):
        FMUModel(fmu_path, parameters={"tau": (1, 0, 2)}, inputs=["K"], outputs=["y"])


# ------------------------------------------------------------------ Octave
@needs_octave
def test_octave_errors_and_timeouts_are_reported(tmp_path, lag_data):
    script = _write(
        tmp_path / "bad.m",
        "if K > 5, error('gain %g is too high', K); end\nif K < 0, pause(60); end\ny = K * u;\n",
    )
    with OctaveModel(
        script,
        parameters={"K": (1, -10, 10)},
        inputs={"u": "P_heater"},
        outputs=["y"],
        backend="serial",
        timeout=3.0,
    ) as m:
        out = m.simulate(np.array([[2.0], [7.0], [-1.0], [3.0]]), lag_data)
    assert out.errors[0] is None and out.errors[3] is None
    np.testing.assert_allclose(out.outputs[3, :, 0], 3.0 * lag_data["P_heater"])
    assert "gain 7 is too high" in out.errors[1]
    assert "timed out after 3 s" in out.errors[2]
    assert not (tmp_path / "octave-workspace").exists()  # no core dump of the killed session


@needs_octave
def test_octave_script_that_clears_the_workspace_is_refused(tmp_path):
    script = _write(tmp_path / "c.m", "% model\nclear all; close all;\ny = K * u;\n")
    with pytest.raises(ConfigError, match=r"line 2 clears the workspace"):
        OctaveModel(script, parameters={"K": (1, 0, 2)}, inputs=["u"], outputs=["y"])


# ------------------------------------------------------------------ co-simulation
def test_cosimulation_identifies_two_models_at_once(lag_data):
    """Paper 000 section 1: a function model and a script model fitted together.

    The heater (callable) turns P into its temperature rise T_h; the wall
    (script) is driven by T_h through a connection. Both outputs are measured;
    all four parameters come from one least-squares criterion.
    """
    t, u = lag_data.time, lag_data["P_heater"]
    rng = np.random.default_rng(7)
    y_h = lag_truth(t, u, 0.8, 60.0)
    y_w = lag_truth(t, y_h, 0.5, 400.0)
    rec = Recording(
        t,
        {
            "P_heater": u,
            "T_h": y_h + rng.normal(0, 0.05, t.size),
            "T_w": y_w + rng.normal(0, 0.05, t.size),
        },
    )
    heater = CallableModel(
        f"{DATA / 'lag_func.py'}:lag",
        parameters=PARAMS,
        inputs={"u": "P_heater"},
        outputs={"y": "T_h"},
    )
    wall = ScriptModel(
        DATA / "lag_script.py", parameters=PARAMS, inputs={"u": "T_h_in"}, outputs={"y": "T_w"}
    )
    with CoSimModel({"heater": heater, "wall": wall}, [("heater.T_h", "wall.T_h_in")]) as m:
        assert isinstance(m, SimModel)
        assert m.param_names == ("heater.K", "heater.tau", "wall.K", "wall.tau")
        assert m.input_names == ("P_heater",) and m.output_names == ("T_h", "T_w")
        y = np.column_stack([rec["T_h"], rec["T_w"]])

        def residual(theta):
            b = m.simulate(theta[None], rec)
            assert b.errors == [None], b.errors
            return (b.outputs[0] - y).ravel()

        res = least_squares(residual, m.nominal, bounds=(m.lower, m.upper), diff_step=1e-7)
        np.testing.assert_allclose(res.x, [0.8, 60.0, 0.5, 400.0], rtol=0.05)
        # the connection is what it says: the wall alone on a recording carrying the heater's output
        out = m.simulate(res.x[None], rec).outputs[0]
        alone = wall.simulate(res.x[None, 2:], rec.with_columns(T_h_in=out[:, 0])).outputs[0, :, 0]
        np.testing.assert_array_equal(out[:, 1], alone)
        # a set failing upstream is reported with the model's name and not passed on
        bad = m.simulate(np.array([[1.0, -1e-3, 1.0, 100.0]]), rec)
        assert bad.errors[0].startswith("heater: non-finite output") and np.isnan(bad.outputs).all()


def test_cosim_from_config_with_a_model_file(tmp_path, lag_data):
    _write(
        tmp_path / "wall.toml",
        LAG_TOML.replace('u = "P_heater"', 'u = "T_h_in"').replace('y = "T_rise"', 'y = "T_w"'),
    )
    cfg = {
        "type": "cosim",
        "name": "heater_wall",
        "models": {
            "heater": _heater(),
            "wall": "wall.toml",
        },
        "connections": [{"from": "heater.T_h", "to": "wall.T_h_in"}],
        "evaluation": {"backend": "serial"},
    }
    with load_external(cfg, base_dir=tmp_path) as m:
        assert m.param_names == ("heater.K", "heater.tau", "wall.K", "wall.tau")
        assert all(sub.evaluation.backend == "serial" for sub in m.models.values())
        out = m.simulate(np.array([[0.8, 60.0, 0.5, 400.0]]), lag_data)
    t, u = lag_data.time, lag_data["P_heater"]
    np.testing.assert_allclose(
        out.outputs[0, :, 1], lag_truth(t, lag_truth(t, u, 0.8, 60.0), 0.5, 400.0), atol=1e-6
    )


def test_cosim_rejects_loops_and_clashing_outputs():
    def mk(inp, out):
        return CallableModel(
            "math:exp", parameters={"K": (1, 0, 2)}, inputs=[inp], outputs=[out], backend="serial"
        )

    with pytest.raises(ConfigError, match=r"loop"):
        CoSimModel({"a": mk("x", "y"), "b": mk("y2", "x2")}, [("a.y", "b.y2"), ("b.x2", "a.x")])
    with pytest.raises(ConfigError, match=r"'y' of model 'b' is also an output"):
        CoSimModel({"a": mk("x", "y"), "b": mk("z", "y")})
    with pytest.raises(ConfigError, match=r"'q' is not an output of model 'a'"):
        CoSimModel({"a": mk("x", "y"), "b": mk("z", "w")}, [("a.q", "b.z")])


# ------------------------------------------------------------------ strut script, timing, CLI
def test_strut_example_script_reproduces_the_batched_simulator():
    from thermogym.identification.external.examples import STRUT_OUTPUTS, strut_config
    from thermogym.models.strut import StrutModel

    t = np.arange(0.0, 90 * 60.0, 140.9)
    rec = Recording(
        t, {"feed_rate": np.where(t < 3000, 20.0, 30.0), "T_air": np.full(t.size, 21.0)}
    )
    theta = np.random.default_rng(3).uniform([0.3, 0.3, 0.3, 0.8, 0.8], [3, 3, 3, 1.3, 1.3], (3, 5))
    with load_external(strut_config(evaluation={"backend": "serial"})) as script:
        out = script.simulate(theta, rec)
        timing = time_evaluations(script, rec, batch_size=4, repeats=1)
    strut = StrutModel()
    full = strut.theta({n: theta[:, j] for j, n in enumerate(script.param_names)})
    ref = strut.simulate(np.column_stack([rec["feed_rate"], rec["T_air"]]), 140.9, full)
    assert script.output_names == STRUT_OUTPUTS
    np.testing.assert_allclose(out.outputs, ref.outputs, rtol=1e-12, atol=1e-12)
    assert timing.batch_size == 4 and timing.failed == 0 and timing.single_s > 0
    assert timing.backend == "serial" and "ms per set" in timing.summary()
    # the TOML example next to the fixtures names the same script and ratios
    with load_external(DATA / "strut_script.toml", backend="serial") as from_file:
        assert from_file.param_names == script.param_names
        assert from_file.evaluator.path == script.evaluator.path
        sub = from_file.simulate(theta, rec)
    cols = [STRUT_OUTPUTS.index(c) for c in from_file.output_names]
    np.testing.assert_array_equal(sub.outputs, out.outputs[:, :, cols])


def test_check_command_reports_the_fit(tmp_path, lag_data, capsys):
    from thermogym.identification.external.__main__ import main
    from thermogym.recording import write_recording

    cfg = _write(tmp_path / "lag.toml", LAG_TOML)
    data = tmp_path / "lag.csv"
    write_recording(lag_data, data)
    out = tmp_path / "pred.csv"
    code = main(
        [
            str(cfg),
            str(data),
            "--set",
            f"K={K_TRUE}",
            "--set",
            f"tau={TAU_TRUE}",
            "--json",
            "--out",
            str(out),
        ]
    )
    assert code == 0
    report = json.loads(capsys.readouterr().out)
    assert report["parameters"]["K"] == K_TRUE
    # noise-free model against noisy data: RMSE close to the noise level
    assert abs(report["fit"]["rmse"]["T_rise"] - NOISE) < 0.05
    assert out.exists()
    assert main([str(cfg), str(data), "--set", "K"]) == 2


def test_check_command_refuses_a_cosimulation_by_name(tmp_path, lag_data, capsys):
    # a co-simulation has no predict(): said with exit status 2, not an AttributeError
    from thermogym.identification.external.__main__ import main
    from thermogym.recording import write_recording

    cfg = {
        "type": "cosim",
        "models": {
            "heater": _heater(),
        },
        "evaluation": {"backend": "serial"},
    }
    path = tmp_path / "cosim.json"
    path.write_text(json.dumps(cfg), encoding="utf-8")
    data = tmp_path / "lag.csv"
    write_recording(lag_data, data)
    assert main([str(path), str(data)]) == 2
    assert "co-simulation is checked model by model" in capsys.readouterr().err


# ------------------------------------------------------------------ through the coordinator
def test_the_coordinator_identifies_an_external_model(lag_data, fits):
    coordinator = pytest.importorskip("thermogym.identification.coordinator")
    problem = pytest.importorskip("thermogym.identification.problem")
    with _adapter("script", workers=2) as model:
        pb = problem.Problem(model, lag_data, pairs=["T_rise"])
        res = coordinator.run_identification(pb, "greybox", progress=False)
        theta = np.array([[res.values["K"], res.values["tau"]]])
        ref = model.simulate(theta, lag_data).outputs
    fit = res.fit
    assert fit.model == "lag_script" and fit.model_version.startswith("script:")
    if "script" in fits:  # the same answer as the plain least-squares fit of this module
        np.testing.assert_allclose(theta[0], fits["script"], rtol=1e-5)
    assert abs(res.values["K"] - K_TRUE) < 4 * fit.stderr["K"]
    assert abs(res.values["tau"] - TAU_TRUE) < 4 * fit.stderr["tau"]
    # the FitResult's model_config rebuilds the very model that was fitted
    with load_external(fit.model_config, backend="serial") as again:
        assert again.version == fit.model_version
        np.testing.assert_array_equal(again.simulate(theta, lag_data).outputs, ref)
