"""Disturbance events: on-periods read from the residual, modelled, and named.

The truth is made outside the package: a first-order response filtered by
``scipy.signal.lfilter`` for the reader, and the block of :mod:`_diag_plants`
(its own RK4) with water drawn off at random times for the whole diagnosis.
"""

from __future__ import annotations

import numpy as np
import pytest
from _diag_plants import TRUE, NodeModel, node_recordings
from scipy.signal import lfilter

from thermogym.errors import ConfigError
from thermogym.identification.diagnosis import diagnose
from thermogym.identification.diagnosis.events import find_events, input_steps
from thermogym.models.augmented import AugmentedModel

DT, TAU = 30.0, 3600.0


def _response(d: np.ndarray, gain: float = 40.0) -> np.ndarray:
    """A first-order plant's response to ``d`` (ZOH): the residual a disturbance leaves."""
    a = np.exp(-DT / TAU)
    return lfilter([0.0, gain * (1.0 - a)], [1.0, -a], d)


def test_events_are_read_at_their_samples_and_with_their_sign():
    d = np.zeros(1200)
    d[100:108] = -1.0
    d[500:510] = -1.0
    d[900:904] = 0.5
    r = _response(d) + 0.01 * np.random.default_rng(1).standard_normal(d.size)
    ev = find_events(r, DT, TAU)
    assert [(e.start, e.stop, e.sign) for e in ev] == [
        (100, 108, -1),
        (500, 510, -1),
        (900, 904, 1),
    ]


def test_a_sensor_spike_and_noise_alone_are_not_events():
    rng = np.random.default_rng(2)
    r = 0.02 * rng.standard_normal(2000)
    assert find_events(r, DT, TAU) == []
    r[700] += 1.0  # one bad reading: + then − through the inverse filter
    assert find_events(r, DT, TAU) == []


def test_a_quantised_reading_stepping_between_levels_is_not_events():
    # a 10-bit logger (0.32 K per count, like the TCLab's) on a slowly warming block: the
    # reading steps one count at a time, the model's prediction is smooth
    t = np.arange(3600.0)
    smooth = 25.0 + 10.0 * (1.0 - np.exp(-t / 900.0))
    noisy = smooth + 0.05 * np.random.default_rng(5).standard_normal(t.size)
    reading = 0.32 * np.round(noisy / 0.32)
    assert not find_events(reading - smooth, 1.0, 900.0, noise=0.32 / np.sqrt(12.0))


def test_runs_on_the_inputs_own_steps_are_not_events():
    # a heater whose gain the model has wrong: the residual's jumps start and end where the
    # heater switches, so they are the input's own effect, not a disturbance nobody logged
    u = np.zeros((1200, 1))
    u[200:400, 0] = 1.0
    u[700:800, 0] = 1.0
    r = _response(u[:, 0]) + 0.01 * np.random.default_rng(4).standard_normal(1200)
    steps = input_steps(u)
    assert np.flatnonzero(steps).tolist() == [200, 400, 700, 800]
    assert find_events(r, DT, TAU) != []  # without the inputs' steps they look like events
    assert find_events(r, DT, TAU, steps) == []


def test_runs_between_an_input_step_and_its_delayed_effect_are_not_events():
    # the input acts 10 samples after it was logged (a dead time, a skewed clock): each step
    # leaves a run as long as the delay that starts on the logged step
    u = np.zeros((1200, 1))
    u[200:500, 0] = 1.0
    u[800:1000, 0] = 1.0
    late = np.concatenate([np.zeros(10), u[:-10, 0]])
    r = _response(late - u[:, 0]) + 0.01 * np.random.default_rng(6).standard_normal(1200)
    assert find_events(r, DT, TAU) != []
    assert find_events(r, DT, TAU, input_steps(u)) == []


def test_a_residual_that_is_not_sparse_is_not_read_as_events():
    # a random walk switching every few samples: a course of time, not on-periods
    rng = np.random.default_rng(3)
    d = np.repeat(rng.choice([-1.0, 1.0], 600), 2)
    assert find_events(_response(d), DT, TAU) is None


def test_the_events_form_adds_its_amplitude_while_an_event_is_on():
    spec = {
        "effect": "unmeasured_disturbance",
        "signal": "u",
        "form": "events",
        "events": 2,
        "signs": "-+",
        "span": 7200.0,
    }
    m = AugmentedModel(NodeModel(), None, [spec])
    assert set(m.local_params) == {"dist_evneg_u", "dist_evpos_u"}
    assert len(m.recorded_params) == 6
    vals = {
        **TRUE,
        "dist_evneg_u": -30.0,
        "dist_evpos_u": 10.0,
        "dist_on0_u": 600.0,
        "dist_off0_u": 900.0,
        "dist_sg0_u": -1.0,
        "dist_on1_u": 3000.0,
        "dist_off1_u": 3060.0,
        "dist_sg1_u": 1.0,
    }
    ((_, _, c),) = m.courses(m.theta(vals), 240, 30.0)
    want = np.zeros(240)
    want[20:30] = -30.0
    want[100:102] = 10.0
    assert np.array_equal(c[0], want)
    # a batch whose sets read different times (the general path) agrees set by set
    th2 = m.theta(vals)
    th2 = np.vstack([th2, th2])
    th2[1, m.param_index("dist_on0_u")] = 660.0
    ((_, _, cb),) = m.courses(th2, 240, 30.0)
    want2 = want.copy()
    want2[20:22] = 0.0
    assert np.array_equal(cb[0], want) and np.array_equal(cb[1], want2)
    # an empty slot (off <= on) adds nothing; all slots neutral: the model as it was
    ((_, _, c0),) = m.courses(m.theta(dict(TRUE)), 240, 30.0)
    assert not c0.any()
    with pytest.raises(ConfigError, match="signs"):
        AugmentedModel(NodeModel(), None, [{**spec, "signs": "x"}])


@pytest.fixture(scope="module")
def draw_off_report():
    tr, va = node_recordings(
        11, effects={"draws": (4.0, 12.0)}, n_train=2, n_val=2, white=0.02, coloured=0.02
    )
    return diagnose(NodeModel(), tr, va, time_limit=120.0)


def test_draw_offs_at_random_times_are_named_as_events_and_modelled(draw_off_report):
    rep = draw_off_report
    assert rep.mismatch_detected
    best = rep.best
    assert best["effect"] == "unmeasured_disturbance" and best["form"] == "events"
    assert "sharp changes" in best["evidence"]
    ev = [h for h in rep.hypotheses if h.get("form") == "events"]
    # the on/off times read from the recordings are counted (two per event)
    assert ev and all(h["n_read_from_data"] >= 2 * 4 and h["n_read_from_data"] % 2 == 0 for h in ev)
    assert best["validation_after"]["mean"] > best["validation_before"]["mean"] + 0.1
    # the report lists the on-periods read from every recording (2 min each, negative: heat
    # drawn off) with their fitted size
    rows = best["events"]
    assert len(rows) == 4 and all(r["events"] for r in rows)
    for r in rows:
        for e in r["events"]:
            assert 60.0 <= e["off_s"] - e["on_s"] <= 240.0 and e["amplitude"] < 0


def test_a_port_the_output_follows_within_a_sample_reads_the_residual_itself():
    # no lag to undo (half-response at the step's own sample): the residual is the pulse
    d = np.zeros(600)
    d[100:106] = 1.0
    r = d + 0.01 * np.random.default_rng(7).standard_normal(600)
    assert [(e.start, e.stop, e.sign) for e in find_events(r, DT, 0.0)] == [(100, 106, 1)]


def test_event_times_count_as_parameters_when_the_combination_is_chosen():
    from thermogym.identification.diagnosis.hypothesis import Hypothesis
    from thermogym.identification.diagnosis.select import choose_combination

    two = [np.zeros((5, 1))] * 2  # two held-out recordings
    # one size per recording, but 20 event times read from each: more freedom per recording
    # than a six-knot course that removes nearly as much
    events = Hypothesis(candidates=(), k_local=1, k_recorded_val=40, explained=0.90)
    course = Hypothesis(candidates=(), k_local=6, explained=0.89)
    events.sims_val = course.sims_val = two
    assert choose_combination([([events], -500.0), ([course], -400.0)]) == [course]
    events.k_recorded_val = 4  # two events per recording: 3 numbers, the simpler
    assert choose_combination([([events], -500.0), ([course], -400.0)]) == [events]
