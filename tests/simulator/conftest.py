import pytest

from machines import load_machine
from simulator import Controller, GrblProtocol


@pytest.fixture(scope="session")
def router():
    return load_machine("grbl-router")


@pytest.fixture(scope="session")
def trunnion():
    return load_machine("trunnion-ac")


@pytest.fixture
def proto(router):
    """A GRBL front end on a fresh grbl-router controller, instant mode."""
    return GrblProtocol(Controller(router), instant=True)


def lines_of(out: bytes) -> list[str]:
    return [s for s in out.decode().split("\r\n") if s]
