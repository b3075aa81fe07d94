"""``toolpath warm-up``: its coarse blade is the kind of surface jobs get (issue 27)."""

from streamline_cam.cli import main
from streamline_cam.warmup import POINT_STEP, SECTION_STEP, _coarse_blade
from toolpath import as_sections, read_sections
from toolpath.paper_examples import bundled_data_path


def test_the_coarse_blade_keeps_the_sections_kind_hub_to_tip(tmp_path):
    full = as_sections(read_sections(bundled_data_path("dev_blade_15x142.csv")))
    coarse = as_sections(read_sections(_coarse_blade(tmp_path)))
    assert coarse.closed == full.closed  # open: the blunt trailing edge stays unsampled
    m, n = full.points.shape[:2]
    assert coarse.points.shape[0] == len(range(0, m - 1, SECTION_STEP)) + 1 >= 5
    assert abs(coarse.points.shape[1] - n / POINT_STEP) <= 1
    # hub and tip sections are the bundled blade's own
    assert abs(coarse.points[0, 0, 2] - full.points[0, 0, 2]) < 1e-9
    assert abs(coarse.points[-1, 0, 2] - full.points[-1, 0, 2]) < 1e-9


def test_warm_up_is_a_documented_command(capsys):
    try:
        main(["warm-up", "--help"])
    except SystemExit as stop:
        assert stop.code == 0
    assert "compile" in capsys.readouterr().out
