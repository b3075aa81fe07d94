"""numpy's huge-page request is off while the verifier runs and restored after."""

import pytest

from verification.pages import madvise_switch, small_pages


def test_small_pages_nest_and_restore_the_request():
    switch = madvise_switch()
    if switch is None:
        pytest.skip("this numpy has no huge-page switch")
    previous = switch(True)
    try:
        with small_pages():
            with small_pages():
                pass
            assert switch(False) is False  # still off after the inner block
        assert switch(True) is True  # the request as it was before
    finally:
        switch(previous)
