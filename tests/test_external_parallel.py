"""Parallel evaluation of external models: same results on every backend, failures contained.

A failing evaluation (exception, NaN output, a hang that ignores the soft
timeout, a worker that dies) is reported with its message in SimBatch.errors,
the other parameter sets of the batch are evaluated as usual, and nothing
hangs: every test here runs with short time limits.
"""

from __future__ import annotations

import inspect
import os
import signal
import time
from pathlib import Path

import numpy as np
import pytest

from thermogym.identification.external import CallableModel, ScriptModel
from thermogym.recording import Recording

DATA = Path(__file__).parent / "data" / "external"
PARAMS = {"K": (1.0, -100.0, 100.0), "tau": (100.0, 5.0, 2000.0)}


def flaky(time_, inputs, params):
    """The toy lag, failing in a different way for special gains."""
    K = params["K"]
    if K == -1.0:
        raise ValueError(f"negative gain K={K}")
    if K == -2.0:
        return {"y": np.full(time_.shape, np.nan)}
    if K == -3.0:
        time.sleep(60.0)  # interrupted by the soft timeout
    if K == -4.0:
        signal.signal(signal.SIGALRM, signal.SIG_IGN)  # deaf to the soft timeout
        while True:
            pass
    if K == -5.0:
        os._exit(3)  # the worker process dies
    if K == -6.0:
        return {"y": np.ones(3)}  # wrong length
    a = np.exp(-np.diff(time_) / params["tau"])
    y = np.zeros_like(time_)
    for k in range(len(time_) - 1):
        y[k + 1] = a[k] * y[k] + (1.0 - a[k]) * K * inputs["u"][k]
    return {"y": y}


@pytest.fixture(scope="module")
def rec() -> Recording:
    t = np.arange(0.0, 600.0, 10.0)
    return Recording(t, {"P": np.where(t >= 50.0, 20.0, 0.0)})


@pytest.fixture(scope="module")
def theta() -> np.ndarray:
    rng = np.random.default_rng(1)
    return np.column_stack([rng.uniform(0.1, 10.0, 24), rng.uniform(5.0, 2000.0, 24)])


def _script(**kw) -> ScriptModel:
    return ScriptModel(
        DATA / "lag_script.py", parameters=PARAMS, inputs={"u": "P"}, outputs={"y": "T"}, **kw
    )


def test_process_pool_matches_serial_and_is_reused(rec, theta):
    with _script(backend="serial") as serial:
        ref = serial.simulate(theta, rec)
    with _script(backend="process", workers=2, chunksize=5) as pooled:
        a = pooled.simulate(theta, rec)
        started = pooled.stats["workers_started"]
        b = pooled.simulate(theta[::-1], rec)
        assert pooled.stats["workers_started"] == started == 2  # the pool is reused
        assert pooled.stats["evaluations"] == 2 * len(theta)
        pids = {p.process.pid for p in pooled.executor._procs}
        assert len(pids) == 2
    assert pooled._executor is None  # closed by the context manager
    for pid in pids:  # and its workers are gone
        with pytest.raises(ProcessLookupError):
            os.kill(pid, 0)
    np.testing.assert_array_equal(a.outputs, ref.outputs)
    np.testing.assert_array_equal(b.outputs, ref.outputs[::-1])
    assert a.errors == ref.errors == [None] * len(theta)


def test_failures_are_reported_and_the_batch_goes_on(rec):
    ks = [2.0, -1.0, -2.0, 3.0, -3.0, -4.0, 4.0, -5.0, -6.0, 5.0]
    th = np.column_stack([ks, np.full(len(ks), 100.0)])
    with CallableModel(
        flaky,
        parameters=PARAMS,
        inputs={"u": "P"},
        outputs=["y"],
        timeout=1.0,
        kill_grace=1.0,
        workers=2,
        chunksize=3,
    ) as m:
        t0 = time.monotonic()
        out = m.simulate(th, rec)
        elapsed = time.monotonic() - t0
        stats = m.stats
        # the pool recovered: a later call runs normally
        again = m.simulate(th[[0, 3]], rec)
    assert elapsed < 20.0
    errors = dict(zip(ks, out.errors, strict=True))
    lines, first = inspect.getsourcelines(flaky)
    line = first + next(i for i, ln in enumerate(lines) if "raise ValueError" in ln)
    assert (
        errors[-1.0] == f"ValueError: negative gain K=-1.0 (test_external_parallel.py line {line})"
    )
    assert errors[-2.0].startswith("non-finite output: 'y' is nan at t = 0 s (sample 0; 60 of 60")
    assert errors[-3.0] == "evaluation timed out after 1 s"
    assert errors[-4.0].startswith("evaluation timed out after 1 s (the worker did not respond")
    assert "died" in errors[-5.0] or "exited" in errors[-5.0]
    assert (
        errors[-6.0]
        == "the outputs have 3 samples, the experiment 60 (give the model's own output times "
        "to have them resampled)"
    )
    for k in (2.0, 3.0, 4.0, 5.0):
        assert errors[k] is None
        i = ks.index(k)
        ref = flaky(rec.time, {"u": rec["P"]}, {"K": k, "tau": 100.0})["y"]
        np.testing.assert_array_equal(out.outputs[i, :, 0], ref)
    for k in (-1.0, -2.0, -3.0, -4.0, -5.0, -6.0):
        assert np.isnan(out.outputs[ks.index(k)]).all()
    assert stats["workers_killed"] == 2 and stats["failed"] == 6
    assert again.errors == [None, None]


def test_serial_backend_enforces_soft_timeouts(rec):
    th = np.array([[2.0, 100.0], [-3.0, 100.0], [-1.0, 100.0]])
    with CallableModel(
        flaky, parameters=PARAMS, inputs={"u": "P"}, outputs=["y"], timeout=0.5, backend="serial"
    ) as m:
        out = m.simulate(th, rec)
    assert out.errors[0] is None
    assert out.errors[1] == "evaluation timed out after 0.5 s"
    assert out.errors[2].startswith("ValueError: negative gain")


def test_lambdas_and_closures_reach_the_workers(rec):
    gain = 3.0
    with CallableModel(
        lambda t, u, p: {"y": gain * p["K"] * u["u"]},
        parameters={"K": (1.0, 0.0, 2.0)},
        inputs={"u": "P"},
        outputs=["y"],
        workers=2,
    ) as m:
        out = m.simulate(np.array([[0.5], [2.0]]), rec)
    np.testing.assert_array_equal(out.outputs[:, :, 0], [1.5 * rec["P"], 6.0 * rec["P"]])


def test_a_model_that_cannot_start_fails_every_set_with_its_message(tmp_path, rec):
    script = tmp_path / "m.py"
    script.write_text("K = 1.0\ny = K * u\n")
    with ScriptModel(script, parameters={"K": (1, 0, 2)}, inputs={"u": "P"}, outputs=["y"]) as m:
        script.write_text("K = 1.0\ny = = K * u\n")  # broken after it was checked
        out = m.simulate(np.array([[1.0], [2.0]]), rec)
        assert m.simulate(np.array([[1.0]]), rec).errors == out.errors[:1]  # no restart loop
        script.write_text("K = 1.0\ny = K * u\n")  # repaired: close() lets it start again
        m.close()
        fixed = m.simulate(np.array([[2.0]]), rec)
        assert fixed.errors == [None]
        np.testing.assert_array_equal(fixed.outputs[0, :, 0], 2.0 * rec["P"])
    assert all("could not be set up" in e and "m.py' line 2" in e for e in out.errors), out.errors
    assert np.isnan(out.outputs).all()


@pytest.fixture(scope="module")
def ray_instance():
    ray = pytest.importorskip("ray")
    started = not ray.is_initialized()
    if started:
        ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    yield ray
    if started:
        ray.shutdown()


def test_ray_backend_gives_identical_results_and_reports_failures(ray_instance, rec, theta):
    with _script(backend="process", workers=2) as local:
        ref = local.simulate(theta, rec)
    with _script(backend="ray", chunksize=4) as remote:
        out = remote.simulate(theta, rec)
        assert remote.stats["backend"] == "ray" and remote.stats["workers"] == 2
    np.testing.assert_array_equal(out.outputs, ref.outputs)
    assert out.errors == ref.errors
    th = np.array([[2.0, 100.0], [-1.0, 100.0], [-4.0, 100.0], [3.0, 100.0]])
    with CallableModel(
        f"{Path(__file__).resolve()}:flaky",
        parameters=PARAMS,
        inputs={"u": "P"},
        outputs=["y"],
        backend="ray",
        timeout=1.0,
        kill_grace=1.0,
    ) as m:
        bad = m.simulate(th, rec)
        assert m.stats["workers_killed"] == 1
    assert bad.errors[0] is None and bad.errors[3] is None
    assert bad.errors[1].startswith("ValueError: negative gain K=-1.0")
    assert bad.errors[2].startswith("evaluation timed out after 1 s (the worker did not respond")
