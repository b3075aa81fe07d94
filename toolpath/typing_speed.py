"""numba's type inference without three costs that decide nothing (issue 27, cold start).

Compiling the planner's kernels on an empty cache is half numba's own Python (typing the
kernels and the library functions they call), and three of its habits repeat work whose
answer is known; :func:`speed_up_typing` (run when numba is imported, see
:mod:`toolpath.kernel_cache`) removes them without changing any type, so the compiled code
and what it computes are the same:

* **each failed typing attempt's message was coloured by colorama** (an ``init`` and a
  ``deinit`` of the terminal per message, about 28,000 of them for a 5-axis plan's kernels,
  some 0.5 CPU s); messages are only shown when a compile fails. numba's colour scheme of
  this process is one that returns messages as they are (:func:`plain_error_messages`),
  unless the user set numba's switch (:data:`NO_HIGHLIGHT`): error messages lose only their
  escape codes, and the environment that child processes inherit is left as it was;
* **every scalar operator was first typed as a numpy ufunc** (``a + b`` on two floats
  searched numpy's loops of ``add``, about 11,000 searches), and the answer then thrown
  away because no argument is an array: numba's array-operator rule now declines at once
  when no argument is an array (:func:`_arrays_only`), as it did after the search;
* **each look-up of an overload's compiled implementation hashed and compared the
  compile's flags** by building a dict of all ~40 options through their properties
  (about 120,000 times); :func:`_quick_values` builds the same dict from the class's
  defaults updated with the options set.
"""

from __future__ import annotations

import functools
import os
import sys
from collections.abc import Callable, Mapping
from typing import Any, Final

__all__ = ["NO_HIGHLIGHT", "plain_error_messages", "speed_up_typing"]

#: numba's switch (an environment variable, read when ``numba.core.errors`` loads; numba
#: 0.68 keeps no setting for it in ``numba.config``): error messages without colour.
NO_HIGHLIGHT: Final = "NUMBA_DISABLE_ERROR_MESSAGE_HIGHLIGHTING"


def plain_error_messages(environ: Mapping[str, str] = os.environ) -> bool:
    """Uncoloured numba error messages in this process, unless the user chose; numba loaded.

    numba makes its colour scheme as it loads, from the switch it read (several of its
    modules keep the scheme as ``_termcolor``); the scheme set here in its place returns
    each message as it is. Setting the switch itself would pass it on to every child
    process. Returns whether the scheme was set: not when ``environ`` holds the switch (the
    user's choice, which numba follows), nor with a numba whose internals are not 0.68's.
    """
    if NO_HIGHLIGHT in environ:
        return False
    try:
        from numba.core import errors
    except ImportError:
        return False
    base = getattr(errors, "_DummyColorScheme", None)
    if not isinstance(base, type) or not hasattr(errors, "_termcolor_inst"):
        return False
    made = errors._termcolor_inst
    if getattr(made, "_streamline_cam", False):
        return True
    plain = _plain_scheme(base)()
    errors._termcolor_inst = plain
    for name, module in list(sys.modules.items()):
        if made is not None and name.startswith("numba.") \
                and getattr(module, "_termcolor", None) is made:
            module._termcolor = plain
    return True


def _plain_scheme(base: type) -> type:
    """A subclass of numba's colour scheme ``base`` that returns each message as it is."""
    def as_it_is(self: Any, msg: str) -> str:
        return msg

    methods: dict[str, Any] = {name: as_it_is for name in (
        "code", "errmsg", "filename", "indicate", "highlight", "reset")}
    return type("PlainScheme", (base,), {**methods, "_streamline_cam": True})


def speed_up_typing() -> None:
    """Patch numba's messages, operator rule and flag values (module's text); numba loaded.

    A numba without the internals patched here (0.68's) is left as it is: modules or names
    missing, or quick flag values that differ from numba's own on a default and a changed
    set of compile flags (:func:`_same_values`); patching twice is a no-op.
    """
    plain_error_messages()
    try:
        from numba.core import targetconfig
        from numba.core.compiler import Flags
        from numba.core.typing import npydecl
    except ImportError:
        return
    rule = getattr(npydecl, "NumpyRulesArrayOperator", None)
    if callable(getattr(rule, "generic", None)) and not getattr(rule, "_streamline_cam", False):
        rule.generic = _arrays_only(rule.generic)
        rule._streamline_cam = True
    config = getattr(targetconfig, "TargetConfig", None)
    if callable(getattr(config, "values", None)) and hasattr(config, "options") \
            and not getattr(config.values, "_streamline_cam", False):
        quick = _quick_values(config.values)
        if _same_values(Flags, config.values, quick):
            config.values = quick


def _same_values(flags_class: type, values: Callable[[Any], dict],
                 quick: Callable[[Any], dict]) -> bool:
    """Whether ``quick`` gives numba's ``values`` (keys, order, values) on two sets of flags.

    The default flags and flags with two options changed; any error reads as "not the same"
    (numba's internals are not those :func:`_quick_values` reads).
    """
    try:
        changed = flags_class()
        changed.nrt = True
        changed.error_model = "numpy"
        return all(list(quick(flags).items()) == list(values(flags).items())
                   for flags in (flags_class(), changed))
    except Exception:  # (any difference of internals: leave numba as it is)
        return False


def _arrays_only(generic: Callable[..., Any]) -> Callable[..., Any]:
    """The array-operator rule of numba, declining (None) at once when no argument is an array.

    The rule returned None in that case anyway, after typing the operator as a ufunc:
    the types it gives, and those other rules give, are unchanged.
    """
    from numba.core import types

    def is_array(kind: Any) -> bool:
        kind = kind.type if isinstance(kind, types.Optional) else kind
        return isinstance(kind, types.ArrayCompatible)

    @functools.wraps(generic)
    def rule(self: Any, args: Any, kws: Any) -> Any:
        if not any(map(is_array, args)) and not any(map(is_array, (kws or {}).values())):
            return None
        return generic(self, args, kws)

    return rule


def _quick_values(values: Callable[[Any], dict]) -> Callable[[Any], dict]:
    """``TargetConfig.values``: each option's value, from the class's defaults and the set.

    The same dict, in the same order, as numba's (one property call per option); a config
    holding an option its class does not declare (none does) goes the old way.
    """
    defaults: dict[type, dict[str, Any]] = {}

    def quick(self: Any) -> dict:
        cls = type(self)
        known = defaults.get(cls)
        if known is None:
            known = defaults[cls] = {name: option.default
                                     for name, option in cls.options.items()}
        own = self._values
        if not own.keys() <= known.keys():
            return values(self)
        merged = dict(known)
        merged.update(own)
        return merged

    quick._streamline_cam = True  # type: ignore[attr-defined]
    return quick
