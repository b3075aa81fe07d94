"""Report: JSON form, statistics, batching does not change results, doctests."""

import doctest
import importlib
import json
import math

import numpy as np
import pytest
from verify_programs import zigzag_raster

from toolpath.planning.analytic import PlaneSurface
from verification import DeviationStats, VerifyOptions, verify_program


def test_report_json_has_no_nan_and_round_trips(router, ball6):
    plane = PlaneSurface((0.0, 0.0, 0.0), (10.0, 0.0, 0.0), (0.0, 2.4, 0.0))
    report = verify_program(zigzag_raster([0.0, 0.8, 1.6, 2.4], -5.0, 15.0), plane, router,
                            ball6, options=VerifyOptions(spacing_mm=0.1))
    text = json.dumps(report.to_dict(), allow_nan=False)
    data = json.loads(text)
    assert data["max_gouge"] is None and data["requested_scallop_mm"] is None
    assert data["max_scallop_mm"] == pytest.approx(report.max_scallop_mm)
    assert "deviation_map" not in data and data["samples"] == list(report.samples)
    assert math.isclose(sum(data["stats"]["histogram_area_mm2"]),
                        data["stats"]["cut_area_mm2"], rel_tol=1e-9)


def test_batch_size_changes_nothing(router, ball6):
    plane = PlaneSurface((0.0, 0.0, 0.0), (10.0, 0.0, 0.0), (0.0, 2.4, 0.0))
    program = zigzag_raster([0.0, 0.8, 1.6, 2.4], -5.0, 15.0, shift={1: -0.02})
    a = verify_program(program, plane, router, ball6,
                       options=VerifyOptions(spacing_mm=0.1, max_pairs=1000))
    b = verify_program(program, plane, router, ball6, options=VerifyOptions(spacing_mm=0.1))
    np.testing.assert_array_equal(a.deviation_map.deviation_mm, b.deviation_map.deviation_mm)
    assert a.max_gouge == b.max_gouge


def test_stats_are_area_weighted_and_classify_samples():
    dev = np.array([[-0.01, 0.0, 0.01, np.inf, np.nan]])
    area = np.array([[1.0, 2.0, 1.0, 3.0, 4.0]])
    s = DeviationStats.of(dev, area, gouge_tol_mm=0.002)
    assert (s.area_mm2, s.cut_area_mm2, s.uncut_area_mm2, s.hidden_area_mm2) == (11, 4, 3, 4)
    assert s.gouge_area_mm2 == 1.0 and s.mean_mm == 0.0
    assert s.rms_mm == pytest.approx(math.sqrt(2e-4 / 4)) and s.percentiles_mm["p50"] == 0.0


@pytest.mark.parametrize("name", ["capsule", "grid", "samples", "replay", "pieces", "dexels",
                                  "search", "extremes", "options", "report", "verify",
                                  "__init__"])
def test_docstring_examples_run(name):
    module = importlib.import_module("verification" if name == "__init__"
                                     else f"verification.{name}")
    failed, _ = doctest.testmod(module)
    assert failed == 0
