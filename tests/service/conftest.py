"""Fixtures of the service tests: apps on a temporary data folder, a finished job to share."""

from __future__ import annotations

import sys
import warnings
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))

from _service_support import blade_csv, upload, wait_for_job

with warnings.catch_warnings():  # starlette 1.0 asks for httpx2; httpx is what we have
    warnings.filterwarnings("ignore", message="Using `httpx` with `starlette.testclient`")
    from fastapi.testclient import TestClient

from streamline_cam.service import ServiceConfig, create_app


@contextmanager
def _client(data_dir: Path, *, stream_loader=None, **config) -> Iterator[TestClient]:
    config.setdefault("workers", 1)
    config.setdefault("executor", "thread")
    app = create_app(ServiceConfig(data_dir=data_dir, **config), stream_loader=stream_loader)
    with TestClient(app) as client:
        yield client


@pytest.fixture
def service_client(tmp_path) -> Callable[..., object]:
    """``with service_client(data_dir=None, stream_loader=None, **config) as client:``.

    Thread workers (one), data in ``tmp_path / "data"`` unless given.
    """

    def make(data_dir: Path | None = None, **config):
        return _client(data_dir or tmp_path / "data", **config)

    return make


@pytest.fixture(scope="session")
def finished_job(tmp_path_factory) -> tuple[Path, str]:
    """A data folder holding one finished job of the small blade: ``(data_dir, job_id)``."""
    data_dir = tmp_path_factory.mktemp("finished") / "data"
    with _client(data_dir) as client:
        answer = upload(client, blade_csv(), filename="small blade.csv")
        assert answer.status_code == 202, answer.text
        status = wait_for_job(client, answer.json()["id"])
    assert status["state"] == "done", status
    return data_dir, status["id"]
