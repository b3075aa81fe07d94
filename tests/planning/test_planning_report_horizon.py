"""A scallop beyond the measure's horizon is reported as such, not as ``none``.

The measure reads ``inf`` where a cusp stands above its horizon (10 x the request, at least
0.05 mm) outside the coarse uncut-area grid; ``none`` there read as "no scallop", and the
JSON's ``null`` as "not measured".
"""

from __future__ import annotations

import dataclasses
import json
import math

from toolpath.planning import SpherePatch, plan_finishing
from toolpath.planning.cutters import parse_cutter


def _report():
    cap = SpherePatch(radius_mm=30.0, longitude_deg=(-10, 10), colatitude_deg=(30, 40))
    return plan_finishing(cap, parse_cutter("ball:6"), scallop_mm=0.02, chord_tol_mm=0.01)[1]


def test_scallop_above_the_horizon_says_so_in_text_and_json():
    measured = _report()
    assert math.isfinite(measured.max_scallop_mm)
    assert not measured.as_dict()["scallop_above_horizon"]
    above = dataclasses.replace(measured, max_scallop_mm=math.inf,
                                scallop_interior_mm=math.inf)
    text = "\n".join(above.lines())
    scallop_line = next(line for line in text.splitlines() if line.startswith("scallop"))
    assert "above 0.2 mm (the measure's horizon)" in scallop_line
    assert "none" not in scallop_line
    written = next(line for line in text.splitlines() if "as written" in line)
    assert "above the measure's horizon (0.2 mm)" in written and "none" not in written
    data = json.loads(json.dumps(above.as_dict(), allow_nan=False))
    assert data["max_scallop_mm"] is None and data["scallop_above_horizon"]
    assert data["scallop_horizon_mm"] == 0.2
    assert not above.within_request
