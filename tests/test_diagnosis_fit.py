"""The diagnosis' fitting layer: the shared solver, initial states, per-recording parameters."""

from __future__ import annotations

import numpy as np
import pytest
from _diag_plants import TRUE, NodeModel, node_recordings

from thermogym.identification.diagnosis.experiments import prepare_experiments
from thermogym.identification.diagnosis.fit import FitProblem, fit_model, sobol_starts
from thermogym.identification.diagnosis.scoring import ar_filter, delta_ic, whitened_chi2
from thermogym.identification.optimizers.local import box_least_squares
from thermogym.models.augmented import AugmentedModel


def test_box_least_squares_solves_a_bounded_problem_and_stops_at_the_bound():
    t = np.linspace(0.0, 1.0, 50)
    y = 0.3 + 2.0 * np.exp(-3.0 * t)

    def fun(s):  # s in the unit box: a = s0, b = 4 s1, c = 10 s2
        return s[0] + 4 * s[1] * np.exp(-10 * s[2] * t) - y

    def jac(s):
        e = np.exp(-10 * s[2] * t)
        return np.column_stack([np.ones_like(t), 4 * e, -40 * s[1] * t * e])

    res = box_least_squares(fun, jac, np.array([0.5, 0.5, 0.5]), max_nfev=200)
    assert res.success and res.s == pytest.approx([0.3, 0.5, 0.3], abs=1e-6)
    # the constant's best value is negative: held at the bound 0, the others compensate
    res = box_least_squares(lambda s: fun(s) + 0.5, jac, np.array([0.5, 0.5, 0.5]))
    assert res.s[0] == 0.0 and res.cost > 0


def test_identification_solver_option_normal_is_the_same_solver():
    from thermogym.identification.optimizers.local import _SOLVERS, LEAST_SQUARES_OPTIONS

    assert "normal" in _SOLVERS and LEAST_SQUARES_OPTIONS["solver"] == "trf"


def test_initial_state_is_estimated_from_a_log_that_starts_mid_operation():
    # the block's log starts 30 min into operation; the model's own start (steady at the
    # first input) is wrong, the estimated one is right: true parameters fit to the noise
    tr, _ = node_recordings(2, n_val=0, white=0.01, coloured=1e-6)
    m = NodeModel()
    exps = prepare_experiments(m, tr, ["T"])
    th = m.theta(dict(TRUE))[0]
    rms = {}
    for x0 in ("rest", "estimate"):
        pb = FitProblem(m, (), th, np.zeros(0), np.zeros(0), exps, np.ones(1), x0)
        r = pb.residuals(np.zeros((1, 0)))[0]
        rms[x0] = float(np.sqrt(np.mean(r**2)))
    assert rms["estimate"] < 0.02 < 0.5 < rms["rest"]


def test_per_recording_parameters_are_fitted_in_each_recording():
    # a disturbance course that differs per recording: shared nothing, one block each
    tr, _ = node_recordings(3, n_val=0, white=0.02, coloured=1e-6)
    base = NodeModel()
    m = AugmentedModel(
        base, None,
        [{"effect": "unmeasured_disturbance", "signal": "T_a", "form": "steps",
          "span": 2 * 3600.0 + 10, "segments": 2}],
    )  # fmt: skip
    exps = prepare_experiments(m, tr, ["T"])
    truth = [(1.5, -1.0), (-0.5, 2.0)]
    for e, (a, b) in zip(exps, truth, strict=True):
        th = m.theta({**TRUE, "dist_k0_T_a": a, "dist_k1_T_a": b})
        pb = FitProblem(m, (), th[0], np.zeros(0), np.zeros(0), [e], np.ones(1), "estimate")
        e.y[:, 0] = pb.simulate(np.zeros((1, 0)), 0)[0, :, 0]
    free = ("dist_k0_T_a", "dist_k1_T_a")
    th0 = m.theta(dict(TRUE))[0]
    pb = FitProblem(m, free, th0, np.full(2, -5.0), np.full(2, 5.0), exps, np.ones(1))
    assert pb.n_global == 0 and pb.n_local == 2 and pb.n_free == 4
    out = fit_model(pb, max_nfev=60)
    got = [(d["dist_k0_T_a"], d["dist_k1_T_a"]) for d in out.local]
    assert np.allclose(got, truth, atol=1e-3)


def test_sobol_starts_fill_the_bounds_deterministically():
    a = sobol_starts(np.array([1.0, -1.0]), np.array([1000.0, 1.0]), 8)
    b = sobol_starts(np.array([1.0, -1.0]), np.array([1000.0, 1.0]), 8)
    np.testing.assert_array_equal(a, b)
    assert a.shape == (8, 2) and a[:, 0].min() < 10 and a[:, 0].max() > 100  # log-spread


def test_whitened_chi2_ignores_coloured_noise_and_sees_a_real_difference():
    from scipy.signal import lfilter

    rng = np.random.default_rng(0)
    n = 6000
    noise = lfilter([1.0], [1.0, -0.98], 0.05 * rng.standard_normal((n, 1)), axis=0)
    # a "hypothesis" that follows another realisation of the same slow noise: no better
    other = lfilter([1.0], [1.0, -0.98], 0.05 * rng.standard_normal((n, 1)), axis=0)
    chi_null, m = whitened_chi2([noise], [noise - 0.3 * other])
    # a real step-wise error of a third of the noise's spread
    err = 0.1 * ((np.arange(n) // 300) % 2)[:, None]
    chi_real, _ = whitened_chi2([noise + err], [noise])
    assert delta_ic(chi_null, 1, m) > 0 > delta_ic(chi_real, 1, m)
    a, _ = ar_filter([noise[:, 0]])
    assert a.size >= 1 and a[0] == pytest.approx(0.98, abs=0.02)


def _stub(model, k_local, change, noise=0.05, n=200):
    """A fitted-looking hypothesis whose held-out prediction differs from its parent's by a
    constant ``change`` (K); everything else passes."""
    from thermogym.identification.diagnosis.hypothesis import Hypothesis

    h = Hypothesis(candidates=())
    h.model, h.k_local = model, k_local
    h.sims_val = [np.full((n, 1), 20.0 + change)]
    h.wsse_val, h.delta_ic, h.explained = 1.0, -50.0, 0.3
    return h


@pytest.mark.parametrize(
    ("aug", "follows"),
    [
        ({"effect": "sensor_offset", "signal": "T"}, False),
        ({"effect": "sensor_lag", "signal": "T"}, True),
        (
            {"effect": "unmeasured_disturbance", "signal": "T_a", "form": "steps", "span": 3600.0},
            True,
        ),
    ],
)
def test_the_wander_bar_is_asked_only_of_what_can_follow_each_recording(aug, follows):
    # a shared constant cannot follow a held-out recording's sensor wander; a per-recording
    # course or a state started afresh in every recording can, and must change the held-out
    # prediction by KEEP_SNR white-noise sigma to be kept
    from thermogym.identification.diagnosis.select import (
        KEEP_SNR,
        Data,
        follows_recordings,
        passes,
    )

    base = NodeModel()
    aug_model = AugmentedModel(base, None, [aug])
    k_local = sum(p.group == "local" for p in aug_model.parameters)
    parent = _stub(base, 0, 0.0)
    parent.wsse_val, parent.explained = 2.0, 0.0
    data = Data(train=[], val=[], weights=np.ones(1), x0="estimate", noise=np.array([0.05]))
    data.min_snr = 0.5
    assert follows_recordings(_stub(aug_model, k_local, 0.0), parent) is follows
    # a change of 1.2 sigma: above the detection's materiality, below the wander bar
    h = _stub(aug_model, k_local, 1.2 * 0.05)
    assert passes(h, parent, 4, data) is (not follows)
    # and one of 0.3 sigma is below both bars; one above KEEP_SNR passes either way
    assert not passes(_stub(aug_model, k_local, 0.3 * 0.05), parent, 4, data)
    assert passes(_stub(aug_model, k_local, (KEEP_SNR + 0.5) * 0.05), parent, 4, data)


def test_a_simpler_combination_that_removes_nearly_all_the_error_is_reported():
    from thermogym.identification.diagnosis.hypothesis import Hypothesis
    from thermogym.identification.diagnosis.select import PREDICTIVE_SHARE, choose_combination

    def step(explained, k_local=0):
        h = Hypothesis(candidates=())
        h.explained, h.k_local = explained, k_local
        return h

    one = [step(0.925)]
    two = [step(0.60), step(0.926)]
    # the pair is better by the criterion, the single effect removes 99.9 % of what it removes
    assert choose_combination([(two, -1048.0), (one, -1024.0)]) is one
    # a single effect that removes clearly less than the pair does not displace it
    short = [step(0.926 * PREDICTIVE_SHARE * 0.99)]
    assert choose_combination([(two, -1048.0), (short, -900.0)]) is two
    # fewer effects but more per-recording courses is not simpler
    course = [step(0.925, k_local=6)]
    assert choose_combination([(two, -1048.0), (course, -1024.0)]) is two
    # fewer courses is preferred even with more effects
    pair_no_course = [step(0.5), step(0.92)]
    assert choose_combination([([step(0.926, k_local=6)], -1048.0), (pair_no_course, -1000.0)]) is (
        pair_no_course
    )


def test_a_jacobian_past_the_time_limit_stops_the_fit_without_a_covariance():
    import time

    from thermogym.identification.diagnosis.fit import STOPPED

    tr, _ = node_recordings(2, n_val=0, white=0.02, coloured=1e-6)
    m = NodeModel()
    exps = prepare_experiments(m, tr, ["T"])
    th = m.theta(dict(TRUE))[0]
    free = ("C",)
    i = m.param_index("C")
    pb = FitProblem(m, free, th, np.array([0.5 * th[i]]), np.array([2.0 * th[i]]), exps,
                    np.ones(1), "estimate")  # fmt: skip
    out = fit_model(pb, max_nfev=20, deadline=time.perf_counter() - 1.0)
    assert out.message == STOPPED and out.covariance is None
    assert np.isnan(out.stderr["C"])
    # without a limit the same fit converges and has its interval
    done = fit_model(pb, max_nfev=20)
    assert done.message != STOPPED and np.isfinite(done.stderr["C"])


def test_the_best_form_of_every_effect_that_helps_held_out_is_refitted():
    from thermogym.identification.diagnosis.hypothesis import Candidate, Hypothesis
    from thermogym.identification.diagnosis.select import refit_set

    def screened(effect, form, train, held):
        h = Hypothesis(candidates=(Candidate(effect, form, "y"),))
        h.delta_ic_train, h.delta_ic = train, held
        h.model = object()  # type: ignore[assignment]  # fitted without error
        return h

    # per-recording courses lead the training criterion by following each recording
    courses = [screened(f"course_{i}", "walk", -500.0 + i, -40.0 + i) for i in range(4)]
    latent = screened("phase_change", "latent heat", -27.0, -21.8)  # predicts held out
    latent_2 = screened("phase_change", "wider range", -20.0, -5.0)  # a worse form of it
    useless = screened("sensor_drift", "linear", -30.0, 7.2)  # worse held out
    top = refit_set([*courses, useless, latent_2, latent], n_full=2)
    assert top[:2] == courses[:2]  # the training criterion's best first
    assert latent in top and latent_2 not in top  # the effect's best held-out form only
    assert useless not in top
    # each effect that helps held out once (four course effects, the latent heat)
    assert len(top) == 4 + 1


def test_a_small_second_effect_beside_a_dominant_first_is_material():
    from thermogym.identification.diagnosis.hypothesis import Candidate, Hypothesis
    from thermogym.identification.diagnosis.select import (
        MIN_SHARE,
        MIN_SHARE_FLOOR,
        material_share,
    )

    def hyp(explained, n_effects):
        h = Hypothesis(candidates=tuple(Candidate(f"e{i}", "f", "y") for i in range(n_effects)))
        h.explained = explained
        return h

    # a dead zone carrying 95.1 % of the nominal error, a drift removing 98 % of the rest
    dead_zone = hyp(0.951, 1)
    assert material_share(hyp(0.999, 2), dead_zone)
    # the same gain as a first effect is not material (a re-calibrated model that explains
    # much leaves no licence to keep less)
    recalibrated = hyp(0.951, 0)
    assert not material_share(hyp(0.999, 1), recalibrated)
    # a second effect removing a small part of what the first leaves is not material
    assert not material_share(hyp(0.951 + 0.2 * 0.049, 2), dead_zone)
    # once two effects removed nearly all of it, half the rest is below the floor
    two = hyp(0.9992, 2)
    assert not material_share(hyp(0.9992 + 0.6 * 0.0008, 3), two)
    assert 0.6 * 0.0008 < MIN_SHARE_FLOOR < MIN_SHARE
    # a first effect of MIN_SHARE is material whatever came before
    assert material_share(hyp(MIN_SHARE, 1), hyp(0.0, 0))
    # a course re-estimated in every recording can follow what the first effect leaves: it
    # needs MIN_SHARE of the nominal error whatever came before
    course = hyp(0.999, 2)
    course.k_local = 6
    assert not material_share(course, dead_zone)


def test_a_screening_takes_the_parents_columns_computed_once_per_round(monkeypatch):
    # the parent's Jacobian columns at its optimum, computed once for a round, are the
    # columns every candidate's screening computed itself at its neutral start: a candidate
    # screened from there gives the same fit either way
    import thermogym.identification.diagnosis.run as run
    from thermogym.identification.diagnosis import diagnose
    from thermogym.identification.diagnosis.select import fit_hypothesis, parent_columns

    seen = {}

    def stop_at_selection(st):
        seen["st"] = st
        raise KeyboardInterrupt

    monkeypatch.setitem(run._STAGE_FUNCS, "selection", stop_at_selection)
    tr, va = node_recordings(5, effects={"radiation": 0.2}, hours=1.5, dt=10.0)
    with pytest.raises(KeyboardInterrupt):
        diagnose(NodeModel(), tr, va)
    st = seen["st"]
    cols = parent_columns(st.nominal, st.data)
    n_res = sum(e.n * len(e.outputs) for e in st.data.train)
    assert cols is not None and cols.shape == (n_res, len(st.nominal.free))
    plain = [c for c in st.candidates if not c.starts and c.effect != "unmeasured_disturbance"]
    assert len(plain) >= 3
    for c in plain[:4]:
        own = fit_hypothesis(st.spec, st.nominal, c, st.data, st.nominal, screen=True)
        shared = fit_hypothesis(
            st.spec, st.nominal, c, st.data, st.nominal, screen=True, parent_columns=cols
        )
        assert not own.error and not shared.error, c.label
        np.testing.assert_allclose(shared.theta, own.theta, rtol=1e-4, atol=1e-9, err_msg=c.label)
        assert shared.delta_ic == pytest.approx(own.delta_ic, rel=1e-4, abs=1e-3), c.label
