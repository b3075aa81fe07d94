import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))

from machines import load_machine
from toolpath.planning.cutters import parse_cutter


@pytest.fixture(scope="session")
def router():
    return load_machine("grbl-router")


@pytest.fixture(scope="session")
def ball6():
    return parse_cutter("ball:6")


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20240909)
