"""Lazy package exports (PEP 562): a package's public names, imported on first use.

``import toolpath`` or ``import gcode`` then costs only the modules a caller touches, so
``toolpath --help`` and ``toolpath check`` do not load scipy, numba or the planner, and a
command that plans loads them once, when it first reads a planner name.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from typing import Any


def lazy_exports(package: str, exports: Mapping[str, str],
                 eager: Mapping[str, Any]) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """The ``__getattr__`` and ``__dir__`` of a package whose names load on first use.

    Parameters
    ----------
    package
        The package's ``__name__``.
    exports
        Exported name -> the module defining it (relative to ``package``, e.g. ``".path"``).
    eager
        The package's namespace (its ``globals()``): a loaded name is stored there, so the
        next read is a plain attribute.
    """
    def __getattr__(name: str) -> Any:
        if name not in exports:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(exports[name], package), name)
        eager[name] = value  # type: ignore[index]
        return value

    def __dir__() -> list[str]:
        return sorted(set(eager) | set(exports))

    return __getattr__, __dir__
