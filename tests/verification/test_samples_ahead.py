"""Issue 27: the job's verification takes its design samples ahead.

The design samples depend on the surface, the cutter and the options alone
(:func:`verification.verify.design_samples`): the job takes them in a thread while it posts
and checks the program (:func:`streamline_cam.pipeline.sample_ahead`), and the verification
given them reports what it reports when it takes them itself.
"""

import threading

import numba
import numpy as np
import pytest
from verify_programs import zigzag_raster

from gcode import GRBL, emit_text, parse
from streamline_cam.pipeline import sample_ahead
from toolpath.planning.analytic import PlaneSurface
from toolpath.row_threads import MIN_ROWS_PER_THREAD, run_in_threads
from verification import VerificationError, VerifyOptions, design_samples, verify_program
from verification.samples import sample_design


def _plane_raster():
    levels = np.arange(0, 8) * 0.6
    program = parse(emit_text(zigzag_raster(levels, -5.0, 25.0), GRBL), GRBL)
    plane = PlaneSurface((0.0, 0.0, 0.0), (20.0, 0.0, 0.0), (0.0, float(levels[-1]), 0.0))
    return program, plane


def test_verification_on_samples_taken_ahead_reports_the_same(router, ball6):
    program, plane = _plane_raster()
    options = VerifyOptions(scallop_mm=0.03)
    own = verify_program(program, plane, router, ball6, options=options).to_dict()
    samples = design_samples(plane, ball6, options=options)
    ahead = verify_program(program, plane, router, ball6, options=options,
                           samples=samples).to_dict()
    for report in (own, ahead):
        report.pop("timings_s")
    assert ahead == own
    assert tuple(ahead["samples"]) == samples.shape


def test_verification_measures_on_the_samples_it_is_given(router, ball6):
    program, plane = _plane_raster()
    coarse = sample_design(plane, spacing_t_mm=0.5, spacing_s_mm=0.25, max_samples=10_000)
    report = verify_program(program, plane, router, ball6, samples=coarse)
    assert report.samples == coarse.shape == (41, 18)


def test_samples_taken_in_a_thread_are_the_verifications_own(ball6):
    _, plane = _plane_raster()
    taken = sample_ahead(plane, "ball:6", 0.03)()
    own = design_samples(plane, ball6, options=VerifyOptions(scallop_mm=0.03))
    assert taken.shape == own.shape
    np.testing.assert_array_equal(taken.points, own.points)
    np.testing.assert_array_equal(taken.area_mm2, own.area_mm2)


def test_a_sampling_error_is_raised_where_the_samples_are_asked_for():
    samples = sample_ahead("not a surface", "ball:6", 0.03)  # started: no error yet
    with pytest.raises(VerificationError, match="ParametricSurface"):
        samples()


@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2,
                    reason="needs a kernel-thread budget above one to lower")
def test_sampling_ahead_keeps_the_callers_kernel_thread_budget():
    # numba.set_num_threads holds per thread: a batch task limited to one thread must
    # not take its samples on every core
    from streamline_cam.pipeline import in_thread

    before = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        assert in_thread(numba.get_num_threads, "budget")() == 1
    finally:
        numba.set_num_threads(before)


def test_a_failure_in_the_thread_is_raised_by_the_getter():
    from streamline_cam.pipeline import in_thread

    def fail():
        raise VerificationError("no extent")

    getter = in_thread(fail, "fails")
    with pytest.raises(VerificationError, match="no extent"):
        getter()


@numba.njit(nogil=True)
def _note_thread(thread, lo, hi):
    """Each row: the ident of the thread that evaluated it."""
    with numba.objmode(ident="uint64"):
        ident = threading.get_ident()
    for i in range(lo, hi):
        thread[i] = ident


class _ThreadNotingPlane(PlaneSurface):
    """A plane whose every evaluation of many points also notes the threads it ran in."""

    def partials_many(self, t, s, orders):
        thread = np.zeros(np.size(t), dtype=np.uint64)
        run_in_threads(_note_thread, thread.size, thread)
        self.threads.update(thread.tolist())
        return super().partials_many(t, s, orders)


@pytest.mark.filterwarnings("ignore:.*Code running in object mode")
def test_samples_taken_ahead_run_off_the_callers_thread_and_time_themselves():
    # taken while the job posts and checks: not in the caller's thread, and their own
    # time is known when they are handed over (the verify's report gives it)
    _, plane = _plane_raster()
    noting = _ThreadNotingPlane(plane.origin, plane.u, plane.v)
    noting.threads = set()
    pending = sample_ahead(noting, "ball:6", 0.03)
    samples = pending()
    assert samples.size >= 2 * MIN_ROWS_PER_THREAD
    assert noting.threads and threading.get_ident() not in noting.threads
    assert pending.seconds > 0.0


def test_samples_taken_ahead_report_their_own_time_and_the_wait(router, ball6):
    program, plane = _plane_raster()
    options = VerifyOptions(scallop_mm=0.03)
    report = verify_program(program, plane, router, ball6, options=options,
                            samples=design_samples(plane, ball6, options=options))
    ahead = report.with_samples_taken_ahead(0.25, 0.05)
    assert list(ahead.timings_s) == ["replay", "samples", "samples_wait", "pieces", "search",
                                     "refine", "total"]
    assert ahead.timings_s["samples"] == 0.25 and ahead.timings_s["samples_wait"] == 0.05
    own = sum(v for k, v in ahead.timings_s.items() if k not in ("samples", "total"))
    assert ahead.timings_s["total"] == pytest.approx(own)  # the wait, not the samples
    assert ahead.to_dict()["timings_s"] == ahead.timings_s  # (in the JSON as well)
    assert ahead.max_scallop == report.max_scallop


def test_a_verified_job_reports_the_time_its_samples_took_ahead(tmp_path):
    from pathlib import Path

    from streamline_cam.pipeline import JobRequest, run_job
    from toolpath.paper_examples import bundled_data_path

    request = JobRequest(Path(bundled_data_path("dev_blade_15x142.csv")), scallop_mm=0.05,
                         chord_tol_mm=0.02)
    timings = run_job(request, tmp_path, verify=True).report["verify"]["timings_s"]
    assert timings["samples"] > 0.0 and timings["samples_wait"] >= 0.0
    assert timings["total"] == pytest.approx(
        sum(v for k, v in timings.items() if k not in ("samples", "total")))
