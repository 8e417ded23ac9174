"""Optimisers of the coordinator: stop criteria, interruption, failures, batches, gradients."""

from __future__ import annotations

import time

import numpy as np
import pytest

from thermogym.errors import ConfigError, IdentificationError
from thermogym.identification.coordinator import METHODS, run_identification
from thermogym.identification.optimizers.base import StopCriteria
from thermogym.identification.optimizers.sensitivities import sensitivity_function
from thermogym.identification.problem import Problem
from thermogym.identification.simmodel import SimBatch, ThermogymModel
from thermogym.models.axt211 import AXT211
from thermogym.models.spindle import SpindleModel
from thermogym.recording import Recording
from thermogym.rigs import run_experiment

TRUTH = np.array([2.0, 40.0])


class Lag:
    """Toy SimModel y' = (K u − y)/tau; optional failures, delay and interrupt."""

    name = "lag"
    batched = True
    param_names = ("K", "tau")
    nominal = np.array([1.0, 100.0])
    lower = np.array([0.1, 5.0])
    upper = np.array([10.0, 500.0])
    input_names = ("u",)
    output_names = ("y",)

    def __init__(self, fail_above=np.inf, sleep=0.0, interrupt_at=None):
        self.fail_above, self.sleep, self.interrupt_at = fail_above, sleep, interrupt_at
        self.calls = 0
        self.batch_sizes: list[int] = []

    def simulate(self, theta, experiment):
        self.calls += 1
        if self.calls == self.interrupt_at:
            raise KeyboardInterrupt
        time.sleep(self.sleep)
        th = np.atleast_2d(theta)
        self.batch_sizes.append(th.shape[0])
        u = np.asarray(experiment["u"])
        y = np.zeros((th.shape[0], u.size))
        a = np.exp(-1.0 / th[:, 1])
        for k in range(1, u.size):
            y[:, k] = a * y[:, k - 1] + (1 - a) * th[:, 0] * u[k - 1]
        bad = th[:, 0] > self.fail_above
        y[bad] = np.nan
        errs = [
            f"solver crashed at K = {k:.3g}" if b else None
            for k, b in zip(th[:, 0], bad, strict=True)
        ]
        return SimBatch(y[:, :, None], errs)

    def close(self):
        pass


def data(n=300, noise=0.0, seed=0):
    t = np.arange(float(n))
    u = (np.sin(t / 20.0) > 0).astype(float)
    rec = Recording(t, {"u": u}, experiment_id="toy")
    y = Lag().simulate(TRUTH[None], rec).outputs[0, :, 0]
    return rec.with_columns(y=y + noise * np.random.default_rng(seed).standard_normal(n))


def problem(model=None, **kw):
    return Problem(model or Lag(), data(), **kw)


GLOBAL = ("montecarlo", "anneal", "evolution", "cmaes")


@pytest.mark.parametrize(
    ("method", "tol"),
    [("greybox", 1e-8), ("evolution", 2e-3), ("cmaes", 1e-4), ("anneal", 0.05)],
)
def test_methods_find_the_known_optimum(method, tol):
    res = run_identification(problem(), method, progress=False, seed=3)
    np.testing.assert_allclose(res.x, TRUTH, rtol=tol)


def test_monte_carlo_keeps_the_best_sample():
    res = run_identification(problem(), "montecarlo", n_samples=500, batch_size=100, progress=False)
    Z, cost, _ = res.samples
    assert Z.shape == (500, 2) and res.evaluations == 500
    assert res.criterion == pytest.approx(cost.min())
    np.testing.assert_array_equal(res.x, Z[np.argmin(cost)])
    assert res.stop_reason == "completed" and res.iterations == 5


@pytest.mark.parametrize("method", ["greybox", *GLOBAL])
def test_max_iter_ends_a_run(method):
    res = run_identification(problem(), method, max_iter=3, progress=False, uncertainty=False)
    assert res.stop_reason == "max_iter"
    assert res.iterations == 3


@pytest.mark.parametrize("method", GLOBAL)
def test_max_evals_ends_a_run(method):
    res = run_identification(problem(), method, max_evals=60, progress=False, uncertainty=False)
    assert res.stop_reason in ("max_evals", "completed")
    # the limit is checked after every batch: at most one population beyond it
    assert 60 <= res.evaluations <= 60 + 100


@pytest.mark.parametrize("method", ["greybox", *GLOBAL])
def test_time_limit_ends_a_run(method):
    pb = problem(Lag(sleep=0.1 if method == "greybox" else 0.02))
    opts = {"n_samples": 10**6, "batch_size": 10} if method == "montecarlo" else {}
    res = run_identification(
        pb,
        method,
        time_limit=0.3,
        max_iter=10_000,
        progress=False,
        uncertainty=False,
        identifiability=False,
        **opts,
    )
    assert res.stop_reason == "time_limit"
    assert res.elapsed_s < 5.0  # ended, not run to 10 000 iterations


@pytest.mark.parametrize("method", ["greybox", *GLOBAL])
def test_quality_limit_ends_a_run(method):
    pb = problem()
    target = 0.05  # RMSE of y, eq (4) with one pair
    res = run_identification(pb, method, target=target, max_iter=10_000, progress=False, seed=1)
    assert res.stop_reason == "target"
    assert res.criterion <= target


def test_stop_criteria_are_validated():
    with pytest.raises(ConfigError, match="max_iter"):
        StopCriteria(max_iter=0)
    with pytest.raises(ConfigError, match="time_limit"):
        StopCriteria(time_limit=-1.0)
    with pytest.raises(ConfigError, match="no option"):
        run_identification(problem(), "cmaes", n_samples=10)
    with pytest.raises(ConfigError, match="unknown method"):
        run_identification(problem(), "simplex")


@pytest.mark.parametrize("method", GLOBAL)
def test_interrupt_keeps_the_best_result(method):
    seen = []

    def cb(entry):
        seen.append(entry.best)
        if entry.iteration == 3:
            raise KeyboardInterrupt

    res = run_identification(problem(), method, callback=cb, progress=False, seed=0)
    assert res.stop_reason == "interrupted"
    assert res.iterations == 3
    assert res.criterion == pytest.approx(min(seen)) and np.isfinite(res.criterion)
    assert res.fit.parameters["K"] == res.x[0]


def test_interrupt_inside_a_simulation_keeps_the_best_result():
    model = Lag(interrupt_at=6)
    res = run_identification(
        Problem(model, data()),
        "evolution",
        progress=False,
        uncertainty=False,
        identifiability=False,
    )
    assert res.stop_reason == "interrupted" and np.isfinite(res.criterion)


def test_failing_sets_are_reported_and_the_search_goes_on():
    pb = problem(Lag(fail_above=5.0))
    res = run_identification(pb, "montecarlo", n_samples=400, batch_size=100, progress=False)
    assert res.failed > 50  # about half of the box fails
    assert all(
        f["message"].startswith("experiment 'toy': solver crashed at K = ") for f in res.failures
    )
    assert all(f["parameters"]["K"] > 5.0 for f in res.failures)
    assert res.x[0] < 5.0 and np.isfinite(res.criterion)
    assert sum(res.failure_messages.values()) == res.failed


def test_everything_failing_is_a_clear_error():
    pb = problem(Lag(fail_above=0.0))
    with pytest.raises(IdentificationError, match=r"none of the .* simulated.*solver crashed"):
        run_identification(pb, "cmaes", progress=False)
    with pytest.raises(IdentificationError, match="fails at the start"):
        run_identification(pb, "greybox", progress=False)


def test_populations_are_evaluated_as_one_batch():
    model = Lag()
    run_identification(
        Problem(model, data()),
        "evolution",
        max_iter=4,
        popsize=10,
        progress=False,
        uncertainty=False,
        identifiability=False,
    )
    assert model.batch_sizes[:5] == [20] * 5  # popsize × P members per simulate call
    model = Lag()
    run_identification(
        Problem(model, data()),
        "greybox",
        jac="fd",
        max_iter=3,
        progress=False,
        uncertainty=False,
        identifiability=False,
    )
    assert 2 in model.batch_sizes  # the P perturbed sets of a Jacobian in one call


def test_same_seed_same_result_other_seed_other_path():
    a = run_identification(problem(), "anneal", max_iter=20, seed=5, progress=False)
    b = run_identification(problem(), "anneal", max_iter=20, seed=5, progress=False)
    c = run_identification(problem(), "anneal", max_iter=20, seed=6, progress=False)
    np.testing.assert_array_equal(a.x, b.x)
    assert not np.array_equal(a.x, c.x)


def test_progress_bar_shows_the_best_criterion(capsys):
    pb = problem(Lag(sleep=0.05))  # slower than tqdm's refresh interval
    run_identification(pb, "cmaes", max_iter=5, progress=True, uncertainty=False)
    err = capsys.readouterr().err
    assert "cmaes" in err and "best=" in err


def test_polish_refines_a_global_result():
    pb = problem()
    rough = run_identification(pb, "montecarlo", n_samples=200, progress=False)
    fine = run_identification(pb, "montecarlo", n_samples=200, polish=True, progress=False)
    assert fine.criterion < 1e-6 < rough.criterion
    assert "polished" in fine.stop_reason


def test_methods_registry_describes_its_options():
    assert set(METHODS) == {"greybox", "montecarlo", "anneal", "evolution", "cmaes"}
    assert METHODS["greybox"].local and not METHODS["cmaes"].local
    assert "n_samples" in METHODS["montecarlo"].options


# --------------------------------------------------------------- sensitivities
def _fd_check(sm, theta, rec, rtol):
    fn = sensitivity_function(sm)
    assert fn is not None
    Y, dY = fn(theta, rec)
    sim = sm.simulate(theta[None], rec).outputs[0]
    np.testing.assert_allclose(Y, sim, atol=1e-9)
    for i in range(theta.size):
        h = 1e-5 * max(abs(theta[i]), 1e-2)
        tp, tm = theta.copy(), theta.copy()
        tp[i] += h
        tm[i] -= h
        fd = (sm.simulate(tp[None], rec).outputs[0] - sm.simulate(tm[None], rec).outputs[0]) / (
            2 * h
        )
        scale = np.abs(fd).max() + 1e-12
        np.testing.assert_allclose(dY[:, :, i], fd, atol=rtol * scale)


def test_axt211_forward_sensitivities_equal_finite_differences():
    rec = run_experiment(
        "axt211", "steps", voltages=[24.0], ambients=[25.0], on_s=900, off_s=900, seed=0
    )[0]
    m = AXT211()
    sm = ThermogymModel(m)
    th = m.nominal.copy()
    th[m.param_index("c_backlash")] = 0.15
    _fd_check(sm, th, rec, 2e-5)


def test_network_forward_sensitivities_equal_finite_differences():
    rec = run_experiment("strut", "steps", feed_rates=[25.0], seed=0)[0]
    from thermogym.models.strut import StrutModel

    sm = ThermogymModel(StrutModel())
    _fd_check(sm, np.array([1.4, 0.7, 1.9, 1.1, 0.9, 19.0]), rec, 1e-6)


def test_sensitivities_exist_only_where_they_are_exact():
    assert sensitivity_function(ThermogymModel(AXT211(effects=["phase_change"]))) is None
    assert sensitivity_function(Lag()) is None
    assert sensitivity_function(ThermogymModel(SpindleModel())) is not None
    pb = problem()
    with pytest.raises(ConfigError, match="exact gradients are not available"):
        run_identification(pb, "greybox", jac="exact", progress=False)


def test_exact_gradient_needs_fewer_simulations_than_finite_differences():
    recs = run_experiment("axt211", "steps", voltages=[24.0, 29.0], ambients=[25.0], seed=1)
    free = {
        "C_P": (5.0, 50.0, 25.0),
        "lambda_PG": (0.01, 0.3, 0.05),
        "C_G": (10.0, 300.0, 60.0),
        "lambda_GU": (0.01, 0.3, 0.15),
    }
    out = {}
    for jac in ("fd", "exact"):
        pb = Problem(AXT211(), recs, pairs=["T_P", "T_G"], free=free, objective="mse")
        res = run_identification(
            pb, "greybox", jac=jac, progress=False, uncertainty=False, identifiability=False
        )
        out[jac] = res
        assert res.stop_reason.startswith("converged")
    np.testing.assert_allclose(out["fd"].x, out["exact"].x, rtol=1e-4)
    fd_runs = out["fd"].simulations
    exact_runs = out["exact"].simulations + out["exact"].sensitivity_runs
    assert exact_runs < fd_runs / 2  # 1 augmented run per Jacobian instead of P (+1)
