"""No module exports a compiled kernel that Python cannot call.

Kernels that only other kernels call are compiled without their Python wrapper
(``no_cpython_wrapper``: less compile time, issue 27); called from Python such a kernel
does not raise, it crashes the interpreter. So none may stand in a module's ``__all__``.
"""

import importlib
import pkgutil

import numba.core.registry
import pytest

import toolpath
import verification


def _modules():
    for package in (toolpath, verification):
        for info in pkgutil.walk_packages(package.__path__, package.__name__ + "."):
            yield info.name


def _wrapperless(module) -> list[str]:
    names = []
    for name in getattr(module, "__all__", ()):
        kernel = getattr(module, name, None)
        if (isinstance(kernel, numba.core.registry.CPUDispatcher)
                and kernel.targetoptions.get("no_cpython_wrapper")):
            names.append(name)
    return names


def test_the_check_sees_a_wrapperless_kernel():
    from toolpath.planning import rate_limit

    assert rate_limit.angle_deg_at.targetoptions.get("no_cpython_wrapper")
    module = type("Module", (), {"__all__": ["angle_deg_at"],
                                 "angle_deg_at": rate_limit.angle_deg_at})
    assert _wrapperless(module) == ["angle_deg_at"]


@pytest.mark.parametrize("name", sorted(_modules()))
def test_no_exported_kernel_lacks_its_python_wrapper(name):
    module = importlib.import_module(name)
    assert _wrapperless(module) == [], f"{name} exports kernels Python cannot call"
