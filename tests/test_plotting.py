"""The shared time axis of the plots."""

from __future__ import annotations

import numpy as np

from thermogym.plotting import time_axis


def test_time_axis_picks_a_readable_unit():
    t, label = time_axis(np.arange(0.0, 300.0, 10.0))
    assert label == "time [s]" and t[-1] == 290.0
    t, label = time_axis(np.arange(0.0, 3600.0, 60.0))
    assert label == "time [min]" and t[-1] == 59.0
    t, label = time_axis(np.arange(0.0, 86400.0, 3600.0))
    assert label == "time [h]" and t[-1] == 23.0


def test_time_axis_relative_counts_from_the_first_sample():
    t, label = time_axis(np.arange(7200.0, 7800.0 + 1, 60.0), relative=True)
    assert label == "time [s]" and t[0] == 0.0 and t[-1] == 600.0
    t, _ = time_axis(np.arange(7200.0, 7800.0 + 1, 60.0))
    assert t[0] == 7200.0  # absolute by default
    assert time_axis(np.array([]), relative=True)[1] == "time [s]"
