"""numba's type inference, sped up (toolpath.typing_speed), types and reports as before.

Each test runs a fresh interpreter where that matters (numba reads its colour switch once,
when it loads).
"""

import operator
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import toolpath  # noqa: F401  (numba patched when it loads)
from toolpath.typing_speed import NO_HIGHLIGHT, plain_error_messages

ROOT = Path(__file__).resolve().parents[2]


_FAILED_COMPILE = textwrap.dedent("""
    import os, toolpath, numba, numpy as np

    @numba.njit
    def bad(a):
        return a.no_such_attribute

    try:
        bad(np.ones(2))
    except numba.core.errors.TypingError as exc:
        print("no_such_attribute" in str(exc), "\\x1b[" in str(exc),
              os.environ.get("NUMBA_DISABLE_ERROR_MESSAGE_HIGHLIGHTING"))
""")


def _failed_compile(**environ: str) -> list[str]:
    """In a child process: whether a failed compile's message names the attribute, holds
    escape codes, and what numba's colour switch in the environment is."""
    env = {"PATH": "/usr/bin:/bin", "PYTHONPATH": str(ROOT), **environ}
    done = subprocess.run([sys.executable, "-c", _FAILED_COMPILE], capture_output=True,
                          text=True, env=env, check=True)
    return done.stdout.split()


def test_a_failed_compile_explains_itself_without_escape_codes():
    names, coloured, _ = _failed_compile()
    assert names == "True" and coloured == "False"


def test_plain_messages_leave_the_environment_children_inherit_alone():
    assert _failed_compile()[2] == "None"  # the variable is not set for children


def test_the_users_own_colour_choice_is_kept():
    assert not plain_error_messages({NO_HIGHLIGHT: ""})
    assert _failed_compile(**{NO_HIGHLIGHT: ""})[:2] == ["True", "True"]  # numba's colours


def test_the_array_operator_rule_declines_operands_that_are_no_arrays():
    from numba.core import types
    from numba.core.registry import cpu_target
    from numba.core.typing.npydecl import NumpyRulesArrayOperator

    rule = type("Add", (NumpyRulesArrayOperator,), {"key": operator.add})(
        cpu_target.typing_context)
    # (strings: no numpy loop; the rule looked them up and failed before it declined)
    assert rule.generic((types.unicode_type, types.unicode_type), {}) is None
    assert rule.generic((types.float64, types.int64), {}) is None
    for array in (types.float64[:], types.Optional(types.float64[:])):
        result = rule.generic((array, types.float64), {}).return_type
        assert (result.dtype, result.ndim) == (types.float64, 1)


@pytest.mark.parametrize("options", [{}, {"release_gil": True, "boundscheck": False,
                                          "error_model": "numpy", "no_cpython_wrapper": True}])
def test_compile_flags_hold_the_values_their_options_give(options):
    from numba.core.compiler import Flags

    flags = Flags()
    for name, value in options.items():
        setattr(flags, name, value)
    by_option = {name: getattr(flags, name) for name in flags.options}
    assert list(flags.values().items()) == list(by_option.items())
    assert flags == Flags(flags) and hash(flags) == hash(Flags(flags))
    assert (flags == Flags()) == (not options)


def test_the_installed_numba_is_the_one_patched():
    # (the tests above hold on an unpatched numba too: here, that the patch is on)
    from numba.core import targetconfig
    from numba.core.typing.npydecl import NumpyRulesArrayOperator

    assert getattr(NumpyRulesArrayOperator, "_streamline_cam", False)
    assert NumpyRulesArrayOperator.generic.__name__ == "generic"
    assert getattr(targetconfig.TargetConfig.values, "_streamline_cam", False)


def test_quick_flag_values_that_differ_from_numbas_are_not_used():
    from numba.core.compiler import Flags

    from toolpath.typing_speed import _same_values

    def numbas(flags):
        return {name: getattr(flags, name) for name in flags.options}

    def stale(flags):  # (a numba whose getter no longer reads the options set)
        return {name: option.default for name, option in type(flags).options.items()}

    assert _same_values(Flags, numbas, numbas)
    assert not _same_values(Flags, numbas, stale)
