"""A job's process keeps freed arrays for reuse (streamline_cam.memory, issue 27)."""

import platform

import pytest
from numpy._core import multiarray

from streamline_cam.memory import keep_freed_memory


def test_numpy_asks_for_no_huge_pages_afterwards():
    keep_freed_memory()
    assert multiarray._set_madvise_hugepage(False) is False  # returns the setting it replaced


@pytest.mark.skipif(platform.libc_ver()[0] != "glibc", reason="mallopt is glibc's")
def test_glibc_takes_the_malloc_settings():
    assert keep_freed_memory() is True
