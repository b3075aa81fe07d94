"""A machine definition: kinematic type, axes, pivot geometry, dialect and connection.

Frames (see :mod:`machines.kinematics` for the formulas):

* **Machine frame**: right-handed, axes parallel to the linear axes X, Y, Z, origin at
  machine zero. All geometry below is given in it, in mm.
* **Workpiece frame**: fixed to the part (carried by the rotary table). Its axes are
  parallel to the machine frame when every rotary axis is at 0, and its origin is then at
  :attr:`Machine.work_origin` (like a G54 offset).
* **Linear joints** X, Y, Z are the machine coordinates of the spindle gauge point; for a
  tilting head, of the gauge point the head would have at tilt 0 (its pivot minus
  :attr:`Machine.head_pivot_length` along machine Z). With every rotary at 0 the linear
  joints are therefore ``work_origin + tip + tool_length * Z``.

Definitions ship as TOML in ``machines/data/`` and load by name or path.

Examples
--------
>>> m = load_machine("trunnion-ac")
>>> m.letters, m.kinematics.value, m.dialect
('XYZAC', 'table-table-ac', 'linuxcnc')
>>> m.axis("A").min
-120.0
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from dataclasses import dataclass, field
from enum import StrEnum
from pathlib import Path
from typing import Any

from machines.axes import Axis, AxisKind, Wrap
from machines.catalog import list_machines, shipped_definitions
from machines.errors import (
    MachineDefinitionError,
    MachineError,
    UnknownAxisError,
    UnknownMachineError,
)

__all__ = [
    "FORMAT_VERSION",
    "KinematicType",
    "Machine",
    "list_machines",
    "load_machine",
    "machine_from_mapping",
]

FORMAT_VERSION = 1
"""Version of the TOML machine-definition format this module reads."""

Vec3 = tuple[float, float, float]


class KinematicType(StrEnum):
    """Kinematic structure of a machine.

    ``table-table-ac``: A tilts the table about X and carries the C rotary table (trunnion).
    ``table-table-bc``: as above with B tilting about Y. ``head-table-bc``: B tilts the
    spindle head about Y, C turns the table. ``head-table-ac``: as above with an A head.
    """

    XYZ = "xyz"
    TABLE_TABLE_AC = "table-table-ac"
    TABLE_TABLE_BC = "table-table-bc"
    HEAD_TABLE_AC = "head-table-ac"
    HEAD_TABLE_BC = "head-table-bc"

    @property
    def letters(self) -> str:
        """Axis letters the structure needs, in canonical order (``"XYZ"``, ``"XYZAC"``...)."""
        return "XYZ" if self is KinematicType.XYZ else "XYZ" + self.value[-2:].upper()

    @property
    def tilt_letter(self) -> str | None:
        """Letter of the tilting axis (``"A"`` or ``"B"``), None for 3-axis."""
        return None if self is KinematicType.XYZ else self.value[-2].upper()

    @property
    def is_five_axis(self) -> bool:
        """True for every structure with a tilt and a C axis."""
        return self is not KinematicType.XYZ

    @property
    def tilting_head(self) -> bool:
        """True when the tilt axis moves the spindle head rather than the table."""
        return self.value.startswith("head-")


@dataclass(frozen=True, slots=True)
class Machine:
    """An immutable machine definition.

    Parameters
    ----------
    name : str
        Identifier, e.g. ``"trunnion-ac"``.
    kinematics : KinematicType
        Kinematic structure.
    axes : tuple of Axis
        The axes in the machine's column order (joint arrays use this order); their letters
        must be exactly ``kinematics.letters`` in some order.
    dialect : str
        Name of the G-code dialect it speaks, e.g. ``"grbl"``, ``"linuxcnc"``, ``"fanuc"``.
    connection : str
        Default connection, plain text such as ``"socket://127.0.0.1:0"`` or ``"sim:pty"``.
    tool_length : float
        Gauge line to tool tip, mm (>= 0). 0 means the work offset absorbs it (touch-off).
    work_origin : tuple of 3 float
        Workpiece origin in machine coordinates with every rotary at 0, mm.
    rotary_centre : tuple of 3 float
        mm, machine coordinates. Table-table: a point on the tilting-table axis (the
        rotary centre point). Head-table: a point on the C axis. Unused for 3-axis.
    c_offset : tuple of 3 float
        Table-table only: vector from `rotary_centre` to a point on the C axis at tilt 0,
        mm (the offset between the tilt and C axes). Must be zero otherwise.
    head_pivot_length : float
        Head-table only: distance from the head's tilt pivot to the spindle gauge line
        along the spindle, mm (>= 0). Must be zero otherwise.
    preferred_tilt_sign : int
        +1 or -1: the tilt-axis branch taken at the start of a path when both branches fit
        the travel equally (e.g. -1 for a trunnion with A in [-120, 30] deg).
    description : str
        Free text.
    source : str or None
        File the definition was read from (not compared).

    Raises
    ------
    MachineError
        When the axes do not match the kinematic type or the geometry is inconsistent.
    """

    name: str
    kinematics: KinematicType
    axes: tuple[Axis, ...]
    dialect: str
    connection: str = ""
    tool_length: float = 0.0  # mm
    work_origin: Vec3 = (0.0, 0.0, 0.0)  # mm, machine coordinates at zero rotary
    rotary_centre: Vec3 = (0.0, 0.0, 0.0)  # mm, machine coordinates
    c_offset: Vec3 = (0.0, 0.0, 0.0)  # mm, tilt axis point -> C axis point
    head_pivot_length: float = 0.0  # mm, tilt pivot -> gauge line
    preferred_tilt_sign: int = 1
    description: str = ""
    source: str | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        kin = KinematicType(self.kinematics)
        object.__setattr__(self, "kinematics", kin)
        axes = tuple(self.axes)
        object.__setattr__(self, "axes", axes)
        if not self.name or not isinstance(self.name, str):
            raise MachineError(f"machine name must be a non-empty string, got {self.name!r}")
        letters = "".join(a.letter for a in axes)
        if sorted(letters) != sorted(kin.letters) or len(set(letters)) != len(letters):
            raise MachineError(
                f"machine {self.name!r}: kinematics {kin.value!r} needs axes "
                f"{kin.letters!r} (any order), got {letters!r}"
            )
        for vec_name in ("work_origin", "rotary_centre", "c_offset"):
            vec = tuple(float(v) for v in getattr(self, vec_name))
            if len(vec) != 3 or not all(math.isfinite(v) for v in vec):
                raise MachineError(f"machine {self.name!r}: {vec_name} must be 3 finite mm")
            object.__setattr__(self, vec_name, vec)
        for num_name in ("tool_length", "head_pivot_length"):
            value = float(getattr(self, num_name))
            if not (math.isfinite(value) and value >= 0.0):
                raise MachineError(f"machine {self.name!r}: {num_name} must be >= 0 mm")
            object.__setattr__(self, num_name, value)
        if self.preferred_tilt_sign not in (1, -1):
            raise MachineError(
                f"machine {self.name!r}: preferred_tilt_sign must be +1 or -1, "
                f"got {self.preferred_tilt_sign!r}"
            )
        is_table = kin in (KinematicType.TABLE_TABLE_AC, KinematicType.TABLE_TABLE_BC)
        if not is_table and any(self.c_offset):
            raise MachineError(f"machine {self.name!r}: c_offset applies only to table-table")
        if not kin.tilting_head and self.head_pivot_length:
            raise MachineError(
                f"machine {self.name!r}: head_pivot_length applies only to head-table"
            )
        if not self.dialect or not isinstance(self.dialect, str):
            raise MachineError(f"machine {self.name!r}: dialect must be a non-empty string")

    @property
    def letters(self) -> str:
        """Axis letters in column order, e.g. ``"XYZAC"``."""
        return "".join(a.letter for a in self.axes)

    @property
    def n_axes(self) -> int:
        """Number of axes (columns of a joint array)."""
        return len(self.axes)

    def index(self, letter: str) -> int:
        """Column of the axis `letter` in joint arrays.

        Parameters
        ----------
        letter : str
            Axis letter (case-insensitive).

        Returns
        -------
        int
            0-based column.

        Raises
        ------
        UnknownAxisError
            If the machine has no such axis.
        """
        pos = self.letters.find(str(letter).upper()) if len(str(letter)) == 1 else -1
        if pos < 0:
            raise UnknownAxisError(
                f"machine {self.name!r} has no axis {letter!r}; its axes are {self.letters!r}"
            )
        return pos

    def axis(self, letter: str) -> Axis:
        """Return the axis with this letter.

        Parameters
        ----------
        letter : str
            Axis letter (case-insensitive).

        Returns
        -------
        Axis
            The axis.

        Raises
        ------
        UnknownAxisError
            If the machine has no such axis.
        """
        return self.axes[self.index(letter)]

    def with_tool_length(self, tool_length: float) -> Machine:
        """Return a copy with another tool length.

        Parameters
        ----------
        tool_length : float
            Gauge line to tool tip, mm.

        Returns
        -------
        Machine
            The copy.
        """
        return dataclasses.replace(self, tool_length=float(tool_length))


# --------------------------------------------------------------------------------------
# Loading
# --------------------------------------------------------------------------------------

_TOP_KEYS = {
    "format",
    "name",
    "description",
    "kinematics",
    "dialect",
    "connection",
    "tool_length",
    "preferred_tilt",
    "geometry",
    "axes",
}
_AXIS_KEYS = {"letter", "kind", "min", "max", "max_rate", "max_accel", "wrap"}
_TABLE_GEOMETRY = {"work_origin", "rotary_centre", "c_offset"}
_HEAD_GEOMETRY = {"work_origin", "rotary_centre", "head_pivot_length"}
_GEOMETRY_KEYS = {
    KinematicType.XYZ: {"work_origin"},
    KinematicType.TABLE_TABLE_AC: _TABLE_GEOMETRY,
    KinematicType.TABLE_TABLE_BC: _TABLE_GEOMETRY,
    KinematicType.HEAD_TABLE_AC: _HEAD_GEOMETRY,
    KinematicType.HEAD_TABLE_BC: _HEAD_GEOMETRY,
}


class _Reader:
    """Typed access to a parsed TOML table with errors naming the file and dotted key."""

    def __init__(self, source: str) -> None:
        self.source = source

    def fail(self, message: str, key: str | None) -> MachineDefinitionError:
        return MachineDefinitionError(message, path=self.source, key=key)

    def check_keys(self, table: dict[str, Any], allowed: set[str], prefix: str) -> None:
        for key in table:
            if key not in allowed:
                raise self.fail(
                    f"unknown key (allowed: {', '.join(sorted(allowed))})", prefix + key
                )

    def get(self, table: dict[str, Any], key: str, prefix: str = "") -> Any:
        if key not in table:
            raise self.fail("missing required key", prefix + key)
        return table[key]

    def string(self, table: dict[str, Any], key: str, prefix: str = "", **kw: Any) -> str:
        value = table.get(key, kw["default"]) if "default" in kw else self.get(table, key, prefix)
        if not isinstance(value, str):
            raise self.fail(f"expected a string, got {value!r}", prefix + key)
        return value

    def number(self, table: dict[str, Any], key: str, prefix: str = "", **kw: Any) -> float:
        value = table.get(key, kw["default"]) if "default" in kw else self.get(table, key, prefix)
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.fail(f"expected a number, got {value!r}", prefix + key)
        return float(value)

    def vec3(self, table: dict[str, Any], key: str, prefix: str = "") -> Vec3:
        value = self.get(table, key, prefix)
        if (
            not isinstance(value, list)
            or len(value) != 3
            or any(isinstance(v, bool) or not isinstance(v, int | float) for v in value)
        ):
            raise self.fail(f"expected 3 numbers [x, y, z] in mm, got {value!r}", prefix + key)
        return (float(value[0]), float(value[1]), float(value[2]))

    def choice(self, value: str, key: str, allowed: list[str]) -> str:
        if value not in allowed:
            raise self.fail(f"{value!r} is not one of {', '.join(map(repr, allowed))}", key)
        return value


def _axis_from_table(r: _Reader, table: Any, i: int) -> Axis:
    prefix = f"axes[{i}]."
    if not isinstance(table, dict):
        raise r.fail(f"expected a table, got {table!r}", f"axes[{i}]")
    r.check_keys(table, _AXIS_KEYS, prefix)
    letter = r.string(table, "letter", prefix)
    kind = r.choice(r.string(table, "kind", prefix), prefix + "kind", [k.value for k in AxisKind])
    if kind == AxisKind.LINEAR:
        wrap = r.choice(r.string(table, "wrap", prefix, default="none"), prefix + "wrap", ["none"])
    else:
        wrap = r.choice(
            r.string(table, "wrap", prefix),
            prefix + "wrap",
            [w.value for w in Wrap if w is not Wrap.NONE],
        )
    unbounded = wrap in (Wrap.CONTINUOUS, Wrap.SHORTEST)
    for key in ("min", "max"):
        if unbounded and key in table:
            raise r.fail(f"a {wrap} axis has no travel limit; remove {key!r}", prefix + key)
    lo = -math.inf if unbounded else r.number(table, "min", prefix)
    hi = math.inf if unbounded else r.number(table, "max", prefix)
    rate = r.number(table, "max_rate", prefix)
    accel = r.number(table, "max_accel", prefix)
    try:
        return Axis(letter, AxisKind(kind), lo, hi, rate, accel, Wrap(wrap))
    except MachineError as exc:
        raise r.fail(str(exc), f"axes[{i}]") from None


def machine_from_mapping(data: dict[str, Any], *, source: str = "<mapping>") -> Machine:
    """Build a :class:`Machine` from a parsed definition (the TOML schema as a dict).

    Parameters
    ----------
    data : dict
        The parsed TOML document (see ``machines/data/*.toml`` for the schema).
    source : str, optional
        Where it came from, used in error messages.

    Returns
    -------
    Machine
        The machine.

    Raises
    ------
    MachineDefinitionError
        For a missing, unknown or mistyped key, or an inconsistent definition; the message
        names `source` and the dotted key.
    """
    r = _Reader(source)
    r.check_keys(data, _TOP_KEYS, "")
    version = data.get("format")
    if version is None:
        raise r.fail("missing required key", "format")
    if version != FORMAT_VERSION:
        raise r.fail(
            f"unsupported format {version!r}; this reader knows {FORMAT_VERSION}",
            "format",
        )
    name = r.string(data, "name")
    kin = KinematicType(
        r.choice(r.string(data, "kinematics"), "kinematics", [k.value for k in KinematicType])
    )
    dialect = r.string(data, "dialect")
    connection = r.string(data, "connection", default="")
    description = r.string(data, "description", default="")
    tool_length = r.number(data, "tool_length", default=0.0)
    tilt = r.choice(
        r.string(data, "preferred_tilt", default="positive"),
        "preferred_tilt",
        ["positive", "negative"],
    )
    if kin is KinematicType.XYZ and "preferred_tilt" in data:
        raise r.fail("a 3-axis machine has no tilt axis", "preferred_tilt")

    allowed = _GEOMETRY_KEYS[kin]
    geometry = data.get("geometry", {} if kin is KinematicType.XYZ else None)
    if geometry is None:
        raise r.fail(f"missing required table for {kin.value!r}", "geometry")
    if not isinstance(geometry, dict):
        raise r.fail(f"expected a table, got {geometry!r}", "geometry")
    r.check_keys(geometry, allowed, "geometry.")
    geo: dict[str, Any] = {}
    for key in sorted(allowed):
        optional = kin is KinematicType.XYZ and key == "work_origin"
        if optional and key not in geometry:
            continue
        if key == "head_pivot_length":
            geo[key] = r.number(geometry, key, "geometry.")
        else:
            geo[key] = r.vec3(geometry, key, "geometry.")

    raw_axes = r.get(data, "axes")
    if not isinstance(raw_axes, list) or not raw_axes:
        raise r.fail("expected a non-empty array of [[axes]] tables", "axes")
    axes = tuple(_axis_from_table(r, t, i) for i, t in enumerate(raw_axes))
    try:
        return Machine(
            name=name,
            kinematics=kin,
            axes=axes,
            dialect=dialect,
            connection=connection,
            tool_length=tool_length,
            preferred_tilt_sign=-1 if tilt == "negative" else 1,
            description=description,
            source=source,
            **geo,
        )
    except MachineError as exc:
        key = "axes" if "needs axes" in str(exc) else None
        raise r.fail(str(exc), key) from None


def _read_toml(text: str, source: str) -> Machine:
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise MachineDefinitionError(f"not valid TOML: {exc}", path=source) from None
    return machine_from_mapping(data, source=source)


def load_machine(name_or_path: str | Path) -> Machine:
    """Load a machine definition by shipped name or by file path.

    Parameters
    ----------
    name_or_path : str or pathlib.Path
        A name from :func:`list_machines` (e.g. ``"trunnion-ac"``), or the path of a TOML
        definition. A :class:`~pathlib.Path`, or a string containing a path separator or
        ending in ``.toml``, is always treated as a path.

    Returns
    -------
    Machine
        The machine, with :attr:`Machine.source` set to the file it came from.

    Raises
    ------
    UnknownMachineError
        If no shipped definition has that name and it is not a file.
    MachineDefinitionError
        If the file is malformed; the message names the file and the key.
    """
    text_name = str(name_or_path)
    looks_like_path = (
        isinstance(name_or_path, Path)
        or "/" in text_name
        or "\\" in text_name
        or text_name.endswith(".toml")
    )
    if not looks_like_path:
        resource = shipped_definitions().joinpath(f"{text_name}.toml")
        if resource.is_file():
            return _read_toml(resource.read_text(encoding="utf-8"), str(resource))
    path = Path(name_or_path)
    if path.is_file():
        try:
            text = path.read_text(encoding="utf-8")
        except UnicodeDecodeError as exc:
            raise MachineDefinitionError(f"not a TOML text file: byte {exc.start} is not "
                                         "UTF-8", path=str(path)) from None
        return _read_toml(text, str(path))
    raise UnknownMachineError(text_name, list_machines())
