"""Machine definitions: shipped files, loading by name and path, and bad definitions."""

import shutil
from pathlib import Path

import pytest
from _machines_support import SHIPPED

import machines
from machines import (
    KinematicType,
    Machine,
    MachineDefinitionError,
    MachineError,
    UnknownAxisError,
    UnknownMachineError,
    Wrap,
    list_machines,
    load_machine,
)

DATA = Path(machines.__file__).parent / "data"


def test_shipped_machines_are_listed_and_named_after_their_file():
    names = list_machines()
    assert set(SHIPPED) <= set(names)
    for name in names:
        m = load_machine(name)
        assert m.name == name
        assert Path(m.source).name == f"{name}.toml"


def test_shipped_definitions():
    router = load_machine("grbl-router")
    assert (router.kinematics, router.dialect, router.letters) == (KinematicType.XYZ, "grbl", "XYZ")
    trunnion = load_machine("trunnion-ac")
    assert trunnion.kinematics is KinematicType.TABLE_TABLE_AC and trunnion.dialect == "linuxcnc"
    assert (trunnion.axis("A").min, trunnion.axis("A").max) == (-120.0, 30.0)
    assert trunnion.axis("c").wrap is Wrap.CONTINUOUS and trunnion.preferred_tilt_sign == -1
    head = load_machine("head-table-bc")
    assert head.kinematics is KinematicType.HEAD_TABLE_BC and head.letters == "XYZBC"
    assert head.head_pivot_length > 0 and head.tool_length > 0
    for m in (router, trunnion, head):
        assert m.connection and m.description
        for ax in m.axes:  # big enough for a ~250 mm blade
            assert ax.max_rate > 0 and ax.max_accel > 0
            if not ax.is_rotary:
                assert ax.span >= 120.0
            assert ax.unit == ("deg" if ax.is_rotary else "mm")


def test_load_by_path_equals_load_by_name(tmp_path):
    target = tmp_path / "copy.toml"
    shutil.copy(DATA / "trunnion-ac.toml", target)
    by_path = load_machine(target)
    assert by_path == load_machine("trunnion-ac")  # source is not compared
    assert by_path.source == str(target)
    assert load_machine(str(target)) == by_path


def test_unknown_machine_lists_the_shipped_ones():
    with pytest.raises(UnknownMachineError, match=r"'no-such-mill'.*trunnion-ac") as info:
        load_machine("no-such-mill")
    assert isinstance(info.value, LookupError) and isinstance(info.value, ValueError)
    with pytest.raises(UnknownMachineError):
        load_machine("missing/dir/mill.toml")


def test_axis_lookup():
    m = load_machine("head-table-bc")
    assert m.axis("B").letter == "B" and m.index("c") == 4
    with pytest.raises(UnknownAxisError, match=r"no axis 'A'.*'XYZBC'"):
        m.axis("A")


def test_machine_is_frozen_and_with_tool_length():
    m = load_machine("trunnion-ac")
    with pytest.raises(AttributeError):
        m.tool_length = 5.0  # type: ignore[misc]
    assert m.with_tool_length(42.0).tool_length == 42.0 and m.tool_length == 100.0


def _write_bad(tmp_path, old, new, name="bad.toml"):
    text = (DATA / "trunnion-ac.toml").read_text(encoding="utf-8")
    assert old in text, old
    path = tmp_path / name
    path.write_text(text.replace(old, new, 1), encoding="utf-8")
    return path


@pytest.mark.parametrize(
    ("old", "new", "key", "match"),
    [
        ('dialect = "linuxcnc"\n', "", "dialect", "missing required key"),
        ('kinematics = "table-table-ac"', 'kinematics = "robot-arm"', "kinematics", "robot-arm"),
        ("format = 1", "format = 7", "format", "unsupported format 7"),
        ("tool_length = 100.0", 'tool_length = "long"', "tool_length", "expected a number"),
        ("tool_length = 100.0", "tool_lenght = 100.0", "tool_lenght", "unknown key"),
        ("c_offset = [0.0, 0.05, -120.0]", "c_offset = [0.0, 0.05]", "geometry.c_offset", "3"),
        ("rotary_centre = [0.0, 0.0, -450.0]", "", "geometry.rotary_centre", "missing"),
        ("min = -120.0         # deg", "", "axes[3].min", "missing required key"),
        ("max_rate = 9000.0", "max_rate = -1.0", "axes[3]", "max_rate must be > 0"),
        ('wrap = "continuous"', 'wrap = "sometimes"', "axes[4].wrap", "sometimes"),
        ('letter = "C"', 'letter = "B"', "axes", "needs axes 'XYZAC'"),
        ('preferred_tilt = "negative"', 'preferred_tilt = "up"', "preferred_tilt", "'up'"),
    ],
)
def test_bad_definition_names_file_and_key(tmp_path, old, new, key, match):
    path = _write_bad(tmp_path, old, new)
    with pytest.raises(MachineDefinitionError, match=match) as info:
        load_machine(path)
    err = info.value
    assert err.key == key
    assert err.path == str(path)
    assert str(path) in str(err) and repr(key) in str(err)
    assert isinstance(err, MachineError) and isinstance(err, ValueError)


def test_invalid_toml_syntax_names_the_file(tmp_path):
    path = _write_bad(tmp_path, "[geometry]", "[geometry")
    with pytest.raises(MachineDefinitionError, match="not valid TOML") as info:
        load_machine(path)
    assert str(path) in str(info.value)


def test_from_mapping_and_direct_construction_errors():
    with pytest.raises(MachineDefinitionError, match="<mapping>: key 'format'"):
        machines.machine_from_mapping({"name": "x"})
    router = load_machine("grbl-router")
    with pytest.raises(MachineError, match="head_pivot_length applies only"):
        Machine(
            name="bad",
            kinematics=KinematicType.XYZ,
            axes=router.axes,
            dialect="grbl",
            head_pivot_length=10.0,
        )
    with pytest.raises(MachineError, match="needs axes 'XYZAC'"):
        Machine(name="bad", kinematics="table-table-ac", axes=router.axes, dialect="linuxcnc")
