"""Small memory pages while the verifier runs: its big arrays live for one step only.

numpy asks the kernel for transparent huge pages on every array of 4 MB or more
(``madvise(MADV_HUGEPAGE)``). Where the kernel's THP ``defrag`` setting is ``madvise`` (a
common default), the first touch of such an array may compact memory to find a free 2 MB
page, and zeroes the whole page. The verifier makes and drops arrays of a million rows at
every step (samples, dexels, pieces): on the issue-27 job (1057 x 946 samples, 182,660
lines) that kernel work was 0.8-1.5 s of about 4.5 s of CPU, 0.3-0.4 s with small pages
(``NUMPY_MADVISE_HUGEPAGE=0``), the user time the same.

:func:`small_pages` turns numpy's request off for the duration (the switch is
process-wide: nested and concurrent users share it, and the first one in keeps what the
last one out restores). Where numpy has no such switch it does nothing.
"""

from __future__ import annotations

import functools
import importlib
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any, TypeVar

__all__ = ["madvise_switch", "small_pages", "with_small_pages"]

F = TypeVar("F", bound=Callable[..., Any])

_LOCK = threading.Lock()
_STATE = {"users": 0, "restore": True}


def madvise_switch() -> Callable[[bool], bool] | None:
    """The switch ``_set_madvise_hugepage`` of numpy (sets, returns the previous), or None."""
    for name in ("numpy._core.multiarray", "numpy.core.multiarray"):
        try:
            module = importlib.import_module(name)
        except ImportError:
            continue
        switch = getattr(module, "_set_madvise_hugepage", None)
        if switch is not None:
            return switch  # type: ignore[no-any-return]
    return None


@contextmanager
def small_pages() -> Iterator[None]:
    """Arrays made within get small pages; the previous request is restored after."""
    switch = madvise_switch()
    if switch is None:
        yield
        return
    with _LOCK:
        if _STATE["users"] == 0:
            _STATE["restore"] = bool(switch(False))
        _STATE["users"] += 1
    try:
        yield
    finally:
        with _LOCK:
            _STATE["users"] -= 1
            if _STATE["users"] == 0:
                switch(_STATE["restore"])


def with_small_pages(fn: F) -> F:
    """``fn`` run within :func:`small_pages`."""
    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        with small_pages():
            return fn(*args, **kwargs)

    return wrapper  # type: ignore[return-value]
