"""How a job's process uses memory: freed arrays stay in the process for the next ones.

A job makes and drops hundreds of large temporaries (a 175,000-point 5-axis path: columns
of 1-15 MB each, in every stage). By default glibc returns each of them to the kernel when
it is freed (blocks over its mmap threshold are unmapped, and the top of the heap is trimmed),
and numpy asks for 2 MB huge pages for every array over 4 MB. The next temporary then
faults fresh pages in, and the kernel zeroes each one first; on a virtual machine that hands
freed memory back to its host, a zeroed huge page costs milliseconds. Measured on the issue's
5-axis job (``toolpath run ... --verify``, 2-core VM): 2-7 s of the run was kernel time,
~99 % of it zeroing huge pages (``perf``: ``clear_page_erms`` under
``do_huge_pmd_anonymous_page``), against 0.4 s with the settings below.

:func:`keep_freed_memory` sets, for this process only:

* glibc's mmap threshold to its largest value (32 MiB on 64-bit) and its trim threshold to
  :data:`TRIM_THRESHOLD_BYTES`: blocks under 32 MiB come from the heap and freed ones are
  reused there without new page faults; a block over 32 MiB is still returned on free, and
  so is a free heap top over the trim threshold, so the process never holds more than its
  peak plus that;
* numpy's huge-page advice off (``NUMPY_MADVISE_HUGEPAGE=0`` at runtime): the arrays are
  reused instead, so they fault once, in small pages.

Neither changes any result; on a C library without ``mallopt`` (musl, macOS, Windows) only
the numpy setting applies.
"""

from __future__ import annotations

import ctypes
from typing import Final

__all__ = ["MMAP_THRESHOLD_BYTES", "TRIM_THRESHOLD_BYTES", "keep_freed_memory"]

#: glibc's largest mmap threshold on 64-bit (``DEFAULT_MMAP_THRESHOLD_MAX``): bigger blocks
#: are always mapped on their own.
MMAP_THRESHOLD_BYTES: Final[int] = 32 * 1024 * 1024
#: Free memory at the top of the heap kept for reuse before glibc returns it.
TRIM_THRESHOLD_BYTES: Final[int] = 1024 * 1024 * 1024

# mallopt parameters (malloc.h)
_M_TRIM_THRESHOLD: Final[int] = -1
_M_MMAP_THRESHOLD: Final[int] = -3

_done = False


def _mallopt(param: int, value: int) -> bool:
    """The C library's ``mallopt(param, value)``; False where it has none or refuses."""
    try:
        mallopt = ctypes.CDLL(None).mallopt  # the C library the interpreter runs on
    except (OSError, AttributeError):
        return False
    mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    mallopt.restype = ctypes.c_int
    return bool(mallopt(param, value))


def keep_freed_memory() -> bool:
    """Keep freed arrays in the process for reuse (see the module's text); idempotent.

    Returns whether the C library took the malloc settings.
    """
    global _done
    if _done:
        return True
    from numpy._core import multiarray

    set_hugepage = getattr(multiarray, "_set_madvise_hugepage", None)
    if set_hugepage is not None:
        set_hugepage(False)
    _done = (_mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES)
             and _mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD_BYTES))
    return _done
