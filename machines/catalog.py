"""The shipped machine definitions by name (standard library only).

A command's ``--help`` lists the names without loading the machine model (numpy);
:func:`machines.machine.load_machine` reads the files from the same folder.
"""

from __future__ import annotations

from importlib import resources
from importlib.abc import Traversable

__all__ = ["list_machines", "shipped_definitions"]


def shipped_definitions() -> Traversable:
    """The folder of the shipped definitions, ``machines/data/<name>.toml``."""
    return resources.files("machines").joinpath("data")


def list_machines() -> list[str]:
    """Names of the shipped machine definitions, sorted.

    Returns
    -------
    list of str
        One name per ``machines/data/<name>.toml``.
    """
    return sorted(
        p.name[: -len(".toml")] for p in shipped_definitions().iterdir()
        if p.name.endswith(".toml")
    )
