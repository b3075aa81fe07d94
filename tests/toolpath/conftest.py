import numpy as np
import pytest


@pytest.fixture
def rng():
    return np.random.default_rng(20261122)


@pytest.fixture(scope="session")
def closed_sections():
    """Twisted, tapering ellipses, first point repeated at the end."""
    m, n = 6, 60
    theta = np.linspace(0.0, 2 * np.pi, n)
    out = []
    for j, h in enumerate(np.linspace(0.0, 1.0, m)):
        a, b, twist = 30.0 - 6 * h, 8.0 - 2 * h, 0.3 * h
        x, y = a * np.cos(theta), b * np.sin(theta)
        c, s = np.cos(twist), np.sin(twist)
        out.append(np.c_[100 + c * x - s * y, 50 + s * x + c * y, np.full(n, 20.0 * j)])
    return np.stack(out)
