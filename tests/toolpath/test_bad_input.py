import numpy as np
import pytest

from streamline_cam.cli import main
from toolpath import (
    DataFileError,
    InvalidParameterError,
    InvalidPointsError,
    ToolpathError,
    fit_bspline_curve,
    fit_linear_system,
    fit_streamline_curve,
    read_points,
)

GOOD = np.c_[np.linspace(0, 10, 20), np.sin(np.linspace(0, 3, 20)) * 5 + 20]
FITTERS = [lambda p, **k: fit_streamline_curve(p, tol=0.01, **k),
           lambda p, **k: fit_bspline_curve(p, tol=0.01, **k),
           lambda p, **k: fit_linear_system(p, **k)]


def _with(index, value):
    pts = GOOD.copy()
    pts[index] = value
    return pts


@pytest.mark.parametrize("fit", FITTERS)
@pytest.mark.parametrize("points,words,index", [
    (_with(7, [np.nan, 1.0]), "point 7 is not finite", 7),
    (_with(3, [np.inf, 1.0]), "point 3 is not finite", 3),
    (np.vstack([GOOD[:5], GOOD[4:]]), "points 4 and 5 are the same", 5),
    (np.ones((10, 2)), "zero length", 0),
    (GOOD[:2], "at least", None),
    (np.zeros((10, 4)), "shape (n, 2) or (n, 3)", None),
    (np.zeros(10), "shape (n, 2) or (n, 3)", None),
    ([["a", "b"]] * 5, "numeric", None),
])
def test_bad_points_are_named(fit, points, words, index):
    with pytest.raises(InvalidPointsError) as info:
        fit(points)
    assert words in str(info.value)
    assert info.value.index == index
    assert isinstance(info.value, ValueError) and isinstance(info.value, ToolpathError)


@pytest.mark.parametrize("kwargs,words", [
    ({"tol": 0.0}, "tol must be a finite length > 0"),
    ({"tol": -1.0}, "tol must be a finite length > 0"),
    ({"tol": float("nan")}, "tol must be a finite length > 0"),
    ({"tol": 0.01, "n_control_points": 8}, "exactly one of"),
    ({}, "exactly one of"),
    ({"n_control_points": 2}, "n_control_points must be an integer >= 4"),
    ({"tol": 0.01, "knot_method": "magic"}, "knot_method must be one of"),
    ({"knots": [0, 0, 0, 0, 0.5, 0.5, 0.5, 0.5, 1, 1, 1, 1]}, "repeats 4 times"),
    ({"knots": [0, 0, 0, 0, 0.51, 0.52, 1, 1, 1, 1]}, "holds no data point"),
    ({"tol": 1e-9, "max_control_points": 6}, "not reached with"),
])
@pytest.mark.parametrize("fit", [fit_streamline_curve, fit_bspline_curve])
def test_bad_options_are_named(fit, kwargs, words):
    with pytest.raises(ToolpathError) as info:
        fit(GOOD, **kwargs)
    assert words in str(info.value)


def test_unknown_models_and_params():
    with pytest.raises(InvalidParameterError, match="model must be one of"):
        fit_linear_system(GOOD, model="P3")
    with pytest.raises(InvalidParameterError, match="params must be one of"):
        fit_bspline_curve(GOOD, tol=0.1, params="arc")
    with pytest.raises(InvalidParameterError, match=r"params\[3\] = .* >= params\[4\]"):
        fit_linear_system(GOOD, params=[0, 1, 2, 3, 3, *range(5, 20)])
    with pytest.raises(InvalidParameterError, match="frame must be one of"):
        fit_streamline_curve(GOOD, tol=0.1, frame="other")


@pytest.mark.parametrize("text,line,words", [
    ("x,y\n1,2\n3,abc\n", 3, "'abc' is not a number"),
    ("x,y,z\n1,2,3\n4,5\n", 3, "expected 3 columns, found 2"),
    ("section,a,b\n0,1,2\n", 1, "must name columns x and y"),
    ("1 2\n3 4 5\n", 2, "expected 2 columns, found 3"),
    ("1\n2\n", 1, "expected 2 or 3 numbers per line, found 1"),
    ("x,y\n1,nan\n", 2, "not a finite number"),
    ("x,y\n", None, "header but no points"),
    ("# only a comment\n", None, "no points"),
])
def test_unreadable_files_name_the_line(tmp_path, text, line, words):
    path = tmp_path / "pts.csv"
    path.write_text(text)
    with pytest.raises(DataFileError) as info:
        read_points(path)
    assert words in str(info.value)
    assert info.value.line == line
    if line is not None:
        assert f"pts.csv:{line}:" in str(info.value)


def test_reads_header_csv_with_extra_columns_and_whitespace_files(tmp_path):
    (tmp_path / "a.csv").write_text("section,x,y,z\n0,1,2,3\n0,4,5,6\n")
    (tmp_path / "b.xyz").write_text("# xyz\n1 2 3\n\n4 5 6\n")
    np.testing.assert_array_equal(read_points(tmp_path / "a.csv"), [[1, 2, 3], [4, 5, 6]])
    np.testing.assert_array_equal(read_points(tmp_path / "b.xyz"), [[1, 2, 3], [4, 5, 6]])


def test_missing_file_is_a_data_file_error(tmp_path):
    with pytest.raises(DataFileError, match="cannot read the file"):
        read_points(tmp_path / "nope.csv")


@pytest.mark.parametrize("text,args,words", [
    ("x,y\n0,0\n1,1\n", [], "at least 4 points"),
    ("x,y\n0,0\n1,1\n1,1\n2,3\n5,5\n", [], "points 1 and 2 are the same"),
    ("x,y\n0,0\n1,zz\n", [], "pts.csv:3:"),
    ("x,y\n0,0\n1,1\n2,3\n5,5\n", ["--tol", "0"], "--tol must be"),
])
def test_cli_prints_one_line_and_exits_non_zero(tmp_path, capsys, text, args, words):
    path = tmp_path / "pts.csv"
    path.write_text(text)
    assert main(["fit", "curve", str(path), *args]) == 2
    err = capsys.readouterr().err
    assert words in err
    assert err.count("\n") == 1 and "Traceback" not in err
