"""Lazy package exports (PEP 562): a package's public names, imported on first use.

``import toolpath`` or ``import gcode`` then costs only the modules a caller touches, so
``toolpath --help`` and ``toolpath check`` do not load scipy, numba or the planner, and a
command that plans loads them once, when it first reads a planner name.
"""

from __future__ import annotations

import importlib
import importlib.util
import sys
import types
from collections.abc import Callable, Mapping
from typing import Any


class _Package(types.ModuleType):
    """A package whose exported names keep their meaning when a submodule loads.

    The import system binds a loaded submodule as an attribute of its package; where the
    package exports a name spelled like its own submodule (``gcode.post``, the function in
    ``gcode/post.py``; ``verification.replay``), the export is bound instead, as an eager
    ``from .post import post`` in the package left it.
    """

    def __setattr__(self, name: str, value: Any) -> None:
        exports = self.__dict__.get("_lazy_exports", {})
        if (isinstance(value, types.ModuleType) and name in exports
                and value.__name__ == importlib.util.resolve_name(exports[name], self.__name__)):
            value = getattr(value, name)
        super().__setattr__(name, value)


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
    module = sys.modules[package]
    module.__class__ = _Package
    eager["_lazy_exports"] = exports  # type: ignore[index]

    def __getattr__(name: str) -> Any:
        if name not in exports:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(exports[name], package), name)
        eager[name] = value  # type: ignore[index]
        return value

    def __dir__() -> list[str]:
        return sorted(set(eager) | set(exports))

    return __getattr__, __dir__
