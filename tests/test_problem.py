"""Identification problem: signal pairs (eq 4), parameters, ratios, experiments, batches."""

from __future__ import annotations

import numpy as np
import pytest

from thermogym.errors import ConfigError, ParameterError, RecordingError, UnknownNameError
from thermogym.identification.metrics import rmse
from thermogym.identification.problem import FreeParameter, Problem, RatioParameter, SignalPair
from thermogym.identification.simmodel import SimBatch, ThermogymModel
from thermogym.models.axt211 import AXT211
from thermogym.models.strut import StrutModel
from thermogym.recording import Recording
from thermogym.rigs import run_experiment


class Lag:
    """Toy SimModel: y' = (K u − y)/tau (exact ZOH) and z = 2 y; fails for K > fail_above."""

    name = "lag"
    batched = True
    param_names = ("K", "tau", "c")
    nominal = np.array([1.0, 50.0, 0.0])
    lower = np.array([0.1, 5.0, -1.0])
    upper = np.array([10.0, 500.0, 1.0])
    input_names = ("u",)
    output_names = ("y", "z")

    def __init__(self, fail_above: float = np.inf) -> None:
        self.fail_above = fail_above
        self.calls = 0

    def simulate(self, theta, experiment):
        self.calls += 1
        th = np.atleast_2d(theta)
        u = np.asarray(experiment["u"])
        dt = np.diff(experiment.time, prepend=experiment.time[0])
        B, T = th.shape[0], u.size
        y = np.zeros((B, T))
        for k in range(1, T):
            a = np.exp(-dt[k] / th[:, 1])
            y[:, k] = a * y[:, k - 1] + (1 - a) * th[:, 0] * u[k - 1]
        y = y + th[:, 2:3]
        out = np.stack([y, 2 * y], axis=2)
        errors = [
            f"K = {k:g} exceeds {self.fail_above:g}" if k > self.fail_above else None
            for k in th[:, 0]
        ]
        out[np.array([e is not None for e in errors])] = np.nan
        return SimBatch(out, errors)

    def close(self):
        pass


def lag_data(K=2.0, tau=40.0, c=0.0, n=200, seed=0, noise=0.0, eid="e"):
    rng = np.random.default_rng(seed)
    t = np.arange(n, dtype=float)
    u = (np.sin(t / 15.0) > 0).astype(float)
    rec = Recording(t, {"u": u}, experiment_id=eid)
    out = Lag().simulate(np.array([[K, tau, c]]), rec).outputs[0]
    return rec.with_columns(
        y=out[:, 0] + noise * rng.standard_normal(n), z=out[:, 1] + noise * rng.standard_normal(n)
    )


def test_defaults_pairs_and_free_parameters():
    pb = Problem(Lag(), lag_data())
    assert [p.label for p in pb.pairs] == ["y", "z"]
    assert pb.names == ("K", "tau", "c")
    np.testing.assert_array_equal(pb.start, Lag.nominal)


def test_criterion_is_eq4_pooled_over_experiments():
    recs = [lag_data(seed=1, noise=0.3, eid="a"), lag_data(seed=2, noise=0.3, n=150, eid="b")]
    recs[1] = recs[1].with_columns(y=np.where(np.arange(150) % 7 == 0, np.nan, recs[1]["y"]))
    pb = Problem(Lag(), recs, pairs=[("y", "y", 2.0), SignalPair("z", weight=0.5)])
    z = np.array([1.7, 35.0, 0.1])
    ev = pb.evaluate(z)
    sims = [Lag().simulate(z[None], r).outputs[0] for r in recs]
    # independent: RMSE of the concatenated series, NaN samples ignored (000 eqs 2, 4)
    r_y = rmse(np.concatenate([r["y"] for r in recs]), np.concatenate([s[:, 0] for s in sims]))
    r_z = rmse(np.concatenate([r["z"] for r in recs]), np.concatenate([s[:, 1] for s in sims]))
    assert ev.criterion[0] == pytest.approx(2.0 * r_y + 0.5 * r_z, rel=1e-12)
    assert ev.mse[0] == pytest.approx(2.0 * r_y**2 + 0.5 * r_z**2, rel=1e-12)
    res = pb.evaluate(z, residuals=True).residuals[0]
    assert res @ res == pytest.approx(ev.mse[0], rel=1e-12)  # Σ r² = Σ w_j MSE_j


def test_batch_evaluation_equals_one_by_one_and_chunking():
    rec = lag_data(noise=0.2)
    Z = np.column_stack([np.linspace(0.5, 3, 7), np.linspace(20, 80, 7), np.zeros(7)])
    pb = Problem(Lag(), rec)
    batch = pb.evaluate(Z)
    single = np.array([pb.evaluate(z).criterion[0] for z in Z])
    np.testing.assert_allclose(batch.criterion, single, rtol=1e-13)
    tiny = Problem(Lag(), rec, max_batch_mb=1e-4)  # forces chunks of one set
    np.testing.assert_allclose(tiny.evaluate(Z).criterion, batch.criterion, rtol=1e-13)
    assert tiny.counters.calls > pb.counters.calls / 2


def test_failing_sets_carry_their_message_and_the_rest_is_evaluated():
    model = Lag(fail_above=2.5)
    pb = Problem(model, [lag_data(eid="one"), lag_data(eid="two")])
    Z = np.array([[1.0, 50.0, 0.0], [3.0, 50.0, 0.0], [2.0, 40.0, 0.0]])
    ev = pb.evaluate(Z)
    assert ev.ok.tolist() == [True, False, True]
    assert ev.errors[1] == "experiment 'one': K = 3 exceeds 2.5"
    assert np.isinf(ev.criterion[1]) and np.isfinite(ev.criterion[[0, 2]]).all()
    assert ev.criterion[2] == pytest.approx(0.0, abs=1e-12)
    # a failed set is not simulated on the following experiments
    assert pb.counters.simulations == 3 + 2


def test_free_fixed_and_ratio_mapping():
    m = AXT211()
    pb = Problem(
        m,
        run_experiment("axt211", "steps", voltages=[24.0], ambients=[25.0], seed=0),
        pairs=["T_P"],
        free={"C_P": (5.0, 50.0, 20.0)},
        ratios=[RatioParameter("r_cond", ("lambda_PG", "lambda_GU"), 0.5, 2.0)],
        fixed={"C_G": 55.0},
    )
    assert pb.names == ("C_P", "r_cond") and pb.kinds == ("free", "ratio")
    assert pb.start.tolist() == [20.0, 1.0]
    v = pb.values([30.0, 1.5])
    assert v["C_P"] == 30.0 and v["C_G"] == 55.0
    assert v["lambda_PG"] == pytest.approx(1.5 * 0.07) and v["lambda_GU"] == pytest.approx(
        1.5 * 0.11
    )
    assert v["T_P0"] == 60.0  # untouched: nominal
    D = pb.theta_jacobian
    assert D[m.param_index("lambda_GU"), 1] == pytest.approx(0.11)


def test_unit_coordinates_round_trip_linear_and_log():
    pb = Problem(
        Lag(),
        lag_data(),
        free=[FreeParameter("K", scale="log"), FreeParameter("tau", lower=10.0, upper=100.0)],
        fixed={"c": 0.0},
    )
    z = np.array([[0.1, 10.0], [10.0, 100.0], [1.0, 55.0]])
    u = pb.to_unit(z)
    np.testing.assert_allclose(u[:, 0], [0.0, 1.0, 0.5])  # log scale: 1 is the middle of 0.1..10
    np.testing.assert_allclose(u[:, 1], [0.0, 1.0, 0.5])
    np.testing.assert_allclose(pb.from_unit(u), z)
    # dz/du by finite differences
    h = 1e-7
    uz = pb.to_unit(z[2])
    fd = (pb.from_unit(uz + h) - pb.from_unit(uz)) / h
    np.testing.assert_allclose(pb.unit_jacobian(z[2]), fd, rtol=1e-5)


@pytest.mark.parametrize(
    ("kwargs", "err", "match"),
    [
        ({"free": ["nope"]}, ParameterError, "'nope' is not a parameter"),
        ({"free": ["K"], "fixed": {"K": 1.0}}, ParameterError, "both fixed"),
        ({"free": {"K": (1.0, 0.5)}}, ParameterError, "need lower < upper"),
        ({"free": {"K": (0.5, 5.0, 9.0)}}, ParameterError, "outside its bounds"),
        ({"free": {"K": (0.0, np.inf)}}, ParameterError, "finite bounds"),
        ({"free": [FreeParameter("c", scale="log")]}, ParameterError, "log scale"),
        ({"pairs": ["w"]}, UnknownNameError, "'w' .* not an output"),
        ({"pairs": [("y", "y", 0.0)]}, ParameterError, "weight 0"),
        ({"pairs": [("y", "y", -1.0)]}, ParameterError, ">= 0"),
        ({"objective": "sse"}, ConfigError, "objective"),
        ({"fixed": {"K": 1.0, "tau": 50.0, "c": 0.0}}, ParameterError, "nothing to identify"),
        (
            {"ratios": [RatioParameter("r", ("K",)), RatioParameter("s", ("K",))]},
            ParameterError,
            "one ratio only",
        ),
        ({"free": ["K"], "ratios": [RatioParameter("r", ("K",))]}, ParameterError, "target"),
    ],
)
def test_bad_set_ups_name_the_offender(kwargs, err, match):
    with pytest.raises(err, match=match):
        Problem(Lag(), lag_data(), **kwargs)


def test_missing_columns_and_empty_series_are_refused():
    rec = lag_data()
    with pytest.raises(RecordingError, match="no column 'y'"):
        Problem(Lag(), [rec, rec.drop("y")], pairs=["y"])
    with pytest.raises(RecordingError, match="no valid"):
        Problem(Lag(), rec.with_columns(y=np.full(rec.n_samples, np.nan)), pairs=["y"])
    with pytest.raises(RecordingError, match="no experiment"):
        Problem(Lag(), [])


def test_with_experiments_and_metrics_per_experiment():
    pb = Problem(Lag(), lag_data(eid="train"), pairs=["y"], free=["K", "tau"])
    other = lag_data(K=2.5, eid="val")
    m = pb.metrics([2.0, 40.0, 0.0][:2], [other])
    assert set(m) >= {"val", "criterion", "pair_rmse"}
    assert m["val"]["rmse"]["y"] == pytest.approx(m["pair_rmse"]["y"])
    assert pb.experiments[0].experiment_id == "train"  # the original is unchanged


def test_thermogym_model_is_wrapped_and_exact_jacobian_matches_finite_differences():
    recs = run_experiment("strut", "steps", feed_rates=[20.0], seed=0)
    pb = Problem(StrutModel(), recs, pairs=["T_nut", "T_drive"], fixed={"T_ref": 20.0})
    assert isinstance(pb.model, ThermogymModel)
    z = np.array([1.3, 0.8, 1.6, 1.1, 0.9])
    r1, J1, n1 = pb.jacobian(z, method="exact")
    r2, J2, n2 = pb.jacobian(z, method="fd", diff="central")
    np.testing.assert_allclose(r1, r2, atol=1e-10)
    np.testing.assert_allclose(J1, J2, rtol=1e-5, atol=1e-8 * np.abs(J1).max())
    assert n1 == 1 and n2 == 2 * 5 + 1  # the finite differences: ONE batch of 2P + 1 sets
