"""Fixtures for the machines tests: a seeded RNG, shipped and synthetic machines."""

import numpy as np
import pytest
from _machines_support import ALL_MACHINES, get_machine


@pytest.fixture
def rng():
    return np.random.default_rng(20240604)


@pytest.fixture(params=ALL_MACHINES)
def any_machine(request):
    return get_machine(request.param)


@pytest.fixture(params=[n for n in ALL_MACHINES if "xyz" not in n and n != "grbl-router"])
def five_axis(request):
    return get_machine(request.param)
