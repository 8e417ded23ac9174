"""Long recordings are searched on a grid the nominal model's dynamics still resolve.

A day at 1 Hz holds 86,400 samples per output; the block of
``tests/_diag_plants.py`` (its own RK4 code, hidden effects, coloured noise)
responds in minutes. Truth here is the block's own time constant ``C/G``
(design values of :class:`NodeModel`), not anything the diagnosis computes.
"""

from __future__ import annotations

import math

import numpy as np
from _diag_plants import DESIGN, NodeModel, node_recordings

from thermogym.identification.diagnosis import diagnose
from thermogym.identification.diagnosis.experiments import (
    AUTO_SAMPLES,
    AUTO_SHARE,
    auto_period,
    half_response_time,
    prepare_experiments,
)

#: half-response of the design block: ln 2 of its time constant C/G [s]
T_HALF = math.log(2.0) * DESIGN["C"] / DESIGN["G"]


def _exps(hours: float, dt: float, n: int = 3, **kw):
    tr, va = node_recordings(5, hours=hours, dt=dt, n_train=n - 1, n_val=1, **kw)
    m = NodeModel()
    return m, prepare_experiments(m, [*tr, *va], ["T"])


def test_half_response_time_is_the_block_time_constant_ln2() -> None:
    m, exps = _exps(2.0, 5.0, n=2)
    t = half_response_time(m, m.nominal, exps[0], ["T"])
    assert abs(t - T_HALF) <= 2 * 5.0


def test_short_recordings_keep_their_period() -> None:
    m, exps = _exps(2.0, 5.0)  # 3 x 1440 samples
    assert sum(e.n for e in exps) <= AUTO_SAMPLES
    assert auto_period(m, m.nominal, exps, ["T"]) is None


def test_long_recordings_get_a_grid_within_a_twentieth_of_the_response() -> None:
    m, exps = _exps(8.0, 1.0)  # 3 x 28,800 samples: a day at 1 Hz
    step = auto_period(m, m.nominal, exps, ["T"])
    assert step is not None
    dt, t_half = step
    assert abs(t_half - T_HALF) <= 2.0
    assert dt == round(dt) and 2.0 <= dt <= AUTO_SHARE * T_HALF + 1e-9
    # the longest such multiple of the recordings' 1 s
    assert dt + 1.0 > AUTO_SHARE * t_half


def test_an_output_that_follows_its_input_at_once_keeps_the_period() -> None:
    """A model whose output answers within a sample gives no room to average."""
    m, exps = _exps(8.0, 1.0)
    th = m.nominal.copy()
    th[m.param_index("C")] = 1.0  # time constant 0.6 s
    assert auto_period(m, th, exps, ["T"]) is None


def test_a_day_at_1_hz_is_diagnosed_on_the_coarser_grid_and_says_so() -> None:
    tr, va = node_recordings(
        3, effects={"radiation": 0.2}, hours=3.0, dt=1.0, n_train=2, n_val=1, hold=(600.0, 3600.0)
    )
    rep = diagnose(NodeModel(), tr, va, max_effects=1)
    dt = rep.nominal_fit.settings["dt"]
    assert dt is not None and 2.0 <= dt <= AUTO_SHARE * T_HALF + 1e-9
    assert any(f"averaged onto a {dt:g} s grid" in n for n in rep.notes)
    assert rep.named_effects[0] == "nonlinear_heat_transfer"
    assert rep.best["validation_after"]["mean"] > rep.best["validation_before"]["mean"]


def test_the_recordings_own_period_keeps_the_full_rate() -> None:
    tr, va = node_recordings(4, hours=3.0, dt=1.0, n_train=2, n_val=1)
    rep = diagnose(NodeModel(), tr, va, dt=1.0, candidates=["sensor_offset"], max_effects=1)
    assert rep.nominal_fit.settings["dt"] == 1.0
    assert not any("averaged onto" in n for n in rep.notes)
    assert np.isfinite(rep.fit_before["validation"]["mean"])
