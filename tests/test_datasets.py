"""Shipped real data sets load as recordings with their provenance."""

from __future__ import annotations

import numpy as np
import pytest

from thermogym.datasets import dataset_names, info, load
from thermogym.errors import UnknownNameError


@pytest.mark.parametrize("name", dataset_names())
def test_every_dataset_loads_with_roles(name):
    rec = load(name)
    assert rec.n_samples > 100
    roles = set(rec.roles.values())
    assert "output" in roles and "input" in roles
    for col in rec.columns:
        assert np.isfinite(rec[col]).all()
    assert "LICENCE" in info(name).upper() or "LICENSE" in info(name).upper()


def test_known_shapes_from_the_readmes():
    assert load("hair_dryer").n_samples == 1000
    assert load("glass_furnace").n_samples == 1247
    assert load("building").dt == 600.0
    assert load("tclab_step")["Q1"].max() == 50.0


def test_unknown_dataset():
    with pytest.raises(UnknownNameError, match="data sets are"):
        load("sauna")
