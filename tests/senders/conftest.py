"""Fixtures for the sender tests: simulators on real links (pty, TCP, Modbus) on 127.0.0.1."""

from __future__ import annotations

import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))

from _senders_support import MACHINE, WORK_OFFSET


@contextmanager
def _sim(**kw) -> Iterator[object]:
    from simulator import run_simulator

    kw.setdefault("work_offsets", {1: WORK_OFFSET})
    kw.setdefault("speed", "instant")
    with run_simulator(MACHINE, **kw) as sim:
        yield sim


@pytest.fixture
def simulator_factory():
    """``with simulator_factory(serial="pty", faults=[...]) as sim:``."""
    return _sim
