"""Bad input gives clear errors naming the parameter and the place."""

import pytest

from toolpath.errors import InvalidParameterError, ToolpathError
from toolpath.planning import (
    CylinderPatch,
    PlaneSurface,
    SpherePatch,
    UnreachableRegionError,
    analytic_surface_from_dict,
    plan_finishing,
)

PLATE = PlaneSurface(t_vector_mm=(20.0, 0.0, 0.0), s_vector_mm=(0.0, 6.0, 0.0))


@pytest.mark.parametrize("kwargs, words", [
    ({"scallop_mm": 0.0}, "scallop_mm must be a finite length > 0 mm, got 0.0"),
    ({"scallop_mm": -0.01}, "scallop_mm"),
    ({"scallop_mm": float("nan")}, "scallop_mm"),
    ({"chord_tol_mm": 0}, "chord_tol_mm must be a finite length > 0 mm, got 0"),
    ({"scallop_mm": 3.0}, "scallop_mm=3.0 mm is not smaller than the cutter radius 3 mm"),
    ({"chord_tol_mm": 5.0}, "chord_tol_mm=5.0 mm is not smaller than the cutter radius"),
    ({"linking": "spiral"}, "--linking spiral needs closed sections"),
    ({"linking": "snake"}, "linking must be one of"),
    ({"axis_mode": "4"}, "axis_mode must be one of"),
    ({"lead_deg": 10.0}, "need axis_mode='lead-tilt'"),
    ({"axis_mode": "lead-tilt", "lead_deg": 95.0}, "lead_deg must be a finite angle"),
    ({"on_gouge": "retilt"}, "on_gouge='retilt' needs axis_mode='lead-tilt'"),
    ({"feed_mm_per_min": -5}, "feed_mm_per_min"),
    ({"colour": "red"}, "unknown option(s) ['colour']"),
    ({"probe_t": 5}, "probe_t must be an integer >= 17 or None (from the plan), got 5"),
    ({"probe_t": 100.5}, "probe_t must be an integer >= 17"),
])
def test_bad_options(kwargs, words):
    args = {"scallop_mm": 0.01, "chord_tol_mm": 0.01, **kwargs}
    with pytest.raises(InvalidParameterError) as err:
        plan_finishing(PLATE, "ball:6", **args)
    assert words in str(err.value)


def test_bad_cutter_and_surface():
    with pytest.raises(InvalidParameterError, match="the number after the kind"):
        plan_finishing(PLATE, "endmill:6", scallop_mm=0.01, chord_tol_mm=0.01)
    with pytest.raises(InvalidParameterError, match="expected a ParametricSurface"):
        plan_finishing("blade.json", "ball:6", scallop_mm=0.01, chord_tol_mm=0.01)


def test_nothing_reachable_with_the_fixed_axis():
    underside = CylinderPatch(radius_mm=10.0, angle_deg=(120.0, 240.0))
    with pytest.raises(UnreachableRegionError, match="no part of the surface faces"):
        plan_finishing(underside, "ball:6", scallop_mm=0.01, chord_tol_mm=0.01)


def test_surface_json_of_another_version():
    data = SpherePatch().to_dict()
    assert analytic_surface_from_dict(data).params() == SpherePatch().params()
    data["format_version"] = 99
    with pytest.raises(ToolpathError, match="format_version 99"):
        analytic_surface_from_dict(data)
    with pytest.raises(ToolpathError, match="kind must be one of"):
        analytic_surface_from_dict({"kind": "nurbs"})
