"""A local Dask cluster (127.0.0.1, 2 worker processes, no dashboard) shared by the batch tests."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))


@pytest.fixture(scope="session")
def client():
    from streamline_cam.dask_engine import job_client

    with job_client(None, workers=2, dashboard=False) as client:
        yield client
