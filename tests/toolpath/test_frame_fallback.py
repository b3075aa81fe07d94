"""Issue 23: a streamline fit whose frame leaves the log range moves to the next frame.

Frames are ranked on the baseline's knots; the knots the fit settles on may still make
``G`` leave the data's log range in the first one. Curves and surfaces then fit in the
next frame (one implementation, :func:`toolpath.streamline_curve.fit_in_frames`).
"""

import numpy as np
import pytest

from toolpath import (
    fit_streamline_curve,
    fit_streamline_surface,
    streamline_curve,
    streamline_surface,
)
from toolpath.errors import LogRangeError


def _refusing_the_first(monkeypatch, module, problem_class, rank):
    """Rank the frames as ``rank`` does, and make every fit in the first one leave the log
    range. Returns the ranked frames (filled in when the fitter ranks them)."""
    ranked = []

    def ranked_frames(*args):
        ranked[:] = rank(*args)
        return list(ranked)

    fit = problem_class.fit

    def refusing(self, *args, **kwargs):
        if ranked and self.frame is ranked[0]:
            raise LogRangeError("G leaves the data's log range (test)")
        return fit(self, *args, **kwargs)

    monkeypatch.setattr(module, "_ranked_frames", ranked_frames)
    monkeypatch.setattr(problem_class, "fit", refusing)
    return ranked


def _curve_points():
    s = np.linspace(0.0, np.pi, 60)
    return np.c_[40.0 * np.cos(s), 15.0 * np.sin(s), 2.0 * s]


def _surface_sections():
    t, s = np.linspace(0, 1, 40), np.linspace(0, 1, 5)
    a = 0.3 + 0.8 * t[None, :]
    return np.stack([(60 + 5 * s[:, None]) * np.cos(a), (60 + 5 * s[:, None]) * np.sin(a),
                     20 * s[:, None] + 0 * a], -1)


@pytest.mark.parametrize(("module", "problem", "data", "fit", "tol"), [
    (streamline_curve, "LogSpaceProblem", _curve_points, fit_streamline_curve, 0.01),
    (streamline_surface, "_GridLogProblem", _surface_sections, fit_streamline_surface, 0.005),
], ids=["curve", "surface"])
def test_a_fit_moves_to_the_next_frame(monkeypatch, module, problem, data, fit, tol):
    ranked = _refusing_the_first(monkeypatch, module, getattr(module, problem),
                                 module._ranked_frames)
    fitted = fit(data(), tol=tol)
    assert len(ranked) >= 2
    assert fitted.frame_label == ranked[1].label and fitted.max_error <= tol


def test_every_frame_out_of_range_names_the_cause(monkeypatch):
    def refusing(self, *args, **kwargs):
        raise LogRangeError("G leaves the data's log range (test)")

    monkeypatch.setattr(streamline_curve.LogSpaceProblem, "fit", refusing)
    s = np.linspace(0.0, np.pi, 60)
    with pytest.raises(LogRangeError, match="log range"):
        fit_streamline_curve(np.c_[40.0 * np.cos(s), 15.0 * np.sin(s)], tol=0.01)
