"""A job's process keeps freed arrays for reuse, its idle threads asleep (issue 27)."""

import os
import platform

import pytest

from streamline_cam.job_process import prepare_job_process
from verification.pages import madvise_switch


def test_numpy_asks_for_no_huge_pages_and_openmp_waits_passively():
    prepare_job_process()
    switch = madvise_switch()
    assert switch is not None and switch(False) is False  # returns the setting it replaced
    assert os.environ["OMP_WAIT_POLICY"]  # PASSIVE unless the environment chose


@pytest.mark.skipif(platform.libc_ver()[0] != "glibc", reason="mallopt is glibc's")
def test_glibc_takes_the_malloc_settings():
    assert prepare_job_process() is True
