"""``Toolpath``: the planner's output and the post's input, an immutable value of arrays.

Point ``i`` is a cutter location: the **tool tip** (the lowest point of the cutter on its
axis: a ball's bottom, a flat or bull-nose cutter's face centre) in the workpiece frame, mm,
with the unit **tool axis** from the tip towards the spindle. ``kinds[i]`` and
``feeds_mm_per_min[i]`` describe the move that *arrives* at point ``i`` (point 0 is where the
tool starts, reached by a rapid). Rapids carry feed ``0`` (the machine's rapid rate applies).
"""

from __future__ import annotations

import zipfile
import zlib
from dataclasses import dataclass, field, replace
from enum import IntEnum
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from machines import Machine
from machines.kinematics import AXIS_NORM_TOL, InverseSolution, solve_inverse
from machines.limits import min_segment_times

from .errors import DataFileError, InvalidParameterError

__all__ = ["TOOLPATH_FORMAT_VERSION", "MoveKind", "SolvedJoints", "Toolpath"]

#: Bumped whenever the ``.npz`` layout changes incompatibly; ``load`` refuses other
#: versions. Arrays added since (``joints_checked_for``) are optional: older files read.
TOOLPATH_FORMAT_VERSION = 1
#: The metadata key under which files written before :attr:`Toolpath.joints_checked_for`
#: kept a fingerprint of the machine; dropped on reading.
LEGACY_JOINT_CHECKED_KEY = "joint_checked_for"


class MoveKind(IntEnum):
    """What the move arriving at a point does."""

    RAPID = 0  #: positioning above the part, at the machine's rapid rate
    PLUNGE = 1  #: feeding down from clearance towards the part
    LEAD_IN = 2  #: approach arc or line onto the surface
    CUT = 3  #: cutting along a pass
    LEAD_OUT = 4  #: departing arc or line off the surface
    LINK = 5  #: feed move between passes without retracting (zig-zag, spiral step)
    RETRACT = 6  #: feeding up to clearance


@dataclass(frozen=True, eq=False)
class SolvedJoints:
    """A toolpath's joints on one machine, solved once and handed on with the path.

    The planner's machine stage solves the inverse kinematics of its path
    (:func:`machines.kinematics.solve_inverse`); the joint measurement, the rotary rates
    and the post read them here instead of solving the same points again. A
    :class:`Toolpath` keeps them only while its points are the very points solved
    (``positions_mm`` and ``tool_axes`` equal, value for value): a path made with other
    points (shifted, split) drops them, and its joints are solved anew.

    Attributes
    ----------
    machine_key : str
        :func:`toolpath.joint_refine.machine_key` of the machine they were solved for.
    positions_mm, tool_axes : ndarray, shape (n, 3)
        The tool tips (mm, workpiece frame) and unit tool axes solved.
    solution : InverseSolution
        ``solve_inverse(machine, positions_mm, tool_axes)`` (joints in mm and unwrapped
        deg, machine axis order; the in-cone mask and achieved-axis error).
    """

    machine_key: str
    positions_mm: NDArray[np.float64]
    tool_axes: NDArray[np.float64]
    solution: InverseSolution

    def __post_init__(self) -> None:
        # shared by every reader and every copy of the path: nobody may change them
        for array in (self.solution.joints, self.solution.in_cone,
                      self.solution.axis_error_deg):
            array.setflags(write=False)

    def solved_for(self, positions_mm: NDArray[np.float64], tool_axes: NDArray[np.float64]
                   ) -> bool:
        """Whether these are the joints of exactly these points (same values, same order)."""
        return (_same(self.positions_mm, positions_mm) and _same(self.tool_axes, tool_axes)
                and len(self.solution.joints) == len(positions_mm))


def _same(a: NDArray[Any], b: NDArray[Any]) -> bool:
    """Equal bit for bit (-0.0 and +0.0 differ: an axis's sign of zero picks C's branch)."""
    return a is b or (a.shape == b.shape and a.dtype == b.dtype
                      and np.ascontiguousarray(a).tobytes() == np.ascontiguousarray(b).tobytes())


def _frozen(array: ArrayLike, dtype: Any) -> NDArray[Any]:
    out = np.array(array, dtype=dtype, copy=True)
    out.setflags(write=False)
    return out


@dataclass(frozen=True, eq=False)
class Toolpath:
    """Cutter locations in order, with tool axes, move kinds and feeds.

    Attributes
    ----------
    positions_mm : ndarray, shape (n, 3)
        Tool-tip positions in the workpiece frame.
    tool_axes : ndarray, shape (n, 3)
        Unit tool axes (tip towards spindle).
    kinds : ndarray of uint8, shape (n,)
        :class:`MoveKind` of the move arriving at each point.
    feeds_mm_per_min : ndarray, shape (n,)
        Tool-tip feed of the move arriving at each point (0 for rapids).
    pass_index : ndarray of int32, shape (n,)
        The finishing pass a point belongs to, ``-1`` for linking and positioning moves.
    metadata : dict
        Free-form strings (cutter, surface, parameters) carried into the program header;
        nothing reads them to decide what to do.
    joints_checked_for : str or None
        The :func:`~toolpath.joint_refine.machine_key` of the 5-axis machine whose joint
        interpolation the planner checked the cutting moves under (the post then leaves
        them whole, :func:`~toolpath.joint_refine.refine_for_joint_interpolation`); None
        when they were not checked so.
    solved_joints : SolvedJoints or None
        The path's joints on a machine, solved once (:func:`toolpath.joint_refine.known_joints`
        reads them); dropped on construction unless solved for exactly these points, and
        not saved to a file.
    """

    positions_mm: NDArray[np.float64]
    tool_axes: NDArray[np.float64]
    kinds: NDArray[np.uint8]
    feeds_mm_per_min: NDArray[np.float64]
    pass_index: NDArray[np.int32]
    metadata: dict[str, str] = field(default_factory=dict)
    joints_checked_for: str | None = None
    solved_joints: SolvedJoints | None = None

    def __post_init__(self) -> None:
        pos = np.asarray(self.positions_mm, dtype=float)
        if pos.ndim != 2 or pos.shape[1] != 3:
            raise InvalidParameterError(f"positions_mm must have shape (n, 3), got {pos.shape}")
        n = len(pos)
        axes = np.asarray(self.tool_axes, dtype=float)
        if axes.shape == (3,):
            axes = np.broadcast_to(axes, (n, 3))
        checks = {
            "tool_axes": (axes, (n, 3)),
            "kinds": (np.asarray(self.kinds), (n,)),
            "feeds_mm_per_min": (np.asarray(self.feeds_mm_per_min, dtype=float), (n,)),
            "pass_index": (np.asarray(self.pass_index), (n,)),
        }
        for name, (value, shape) in checks.items():
            if value.shape != shape:
                raise InvalidParameterError(f"{name} must have shape {shape}, got {value.shape}")
        for name, value in (("positions_mm", pos), ("tool_axes", axes),
                            ("feeds_mm_per_min", checks["feeds_mm_per_min"][0])):
            if not np.isfinite(value).all():
                bad = ~np.isfinite(value).reshape(n, -1).all(axis=1)
                raise InvalidParameterError(
                    f"{name} has a non-finite value at point {int(np.argmax(bad))}")
        norms = np.sqrt(np.einsum("ij,ij->i", axes, axes))
        bad = np.abs(norms - 1.0) > AXIS_NORM_TOL
        if bad.any():
            i = int(np.argmax(bad))
            raise InvalidParameterError(
                f"tool_axes must be unit vectors; point {i} has length {norms[i]:.6g}")
        kinds = checks["kinds"][0]
        known = np.isin(kinds, [k.value for k in MoveKind])
        if not known.all():
            i = int(np.argmax(~known))
            raise InvalidParameterError(f"unknown move kind {kinds[i]!r} at point {i}")
        feeds = checks["feeds_mm_per_min"][0]
        needs_feed = (kinds != MoveKind.RAPID) & (feeds <= 0.0)
        if n and needs_feed[1:].any():
            i = 1 + int(np.argmax(needs_feed[1:]))
            raise InvalidParameterError(
                f"feed move {MoveKind(int(kinds[i])).name} at point {i} has no positive feed")
        object.__setattr__(self, "positions_mm", _frozen(pos, float))
        object.__setattr__(self, "tool_axes", _frozen(axes, float))
        object.__setattr__(self, "kinds", _frozen(kinds, np.uint8))
        object.__setattr__(self, "feeds_mm_per_min", _frozen(feeds, float))
        object.__setattr__(self, "pass_index", _frozen(checks["pass_index"][0], np.int32))
        object.__setattr__(self, "metadata", {str(k): str(v) for k, v in self.metadata.items()})
        if self.joints_checked_for is not None:
            object.__setattr__(self, "joints_checked_for", str(self.joints_checked_for))
        solved = self.solved_joints
        if solved is not None:  # kept for these very points only, holding this path's arrays
            object.__setattr__(self, "solved_joints", replace(
                solved, positions_mm=self.positions_mm, tool_axes=self.tool_axes)
                if solved.solved_for(self.positions_mm, self.tool_axes) else None)

    # ------------------------------------------------------------------ figures
    def __len__(self) -> int:
        return len(self.positions_mm)

    @cached_property
    def segment_lengths_mm(self) -> NDArray[np.float64]:
        """Tool-tip length of each move (``n - 1`` values; move ``i`` arrives at ``i + 1``)."""
        step = np.diff(self.positions_mm, axis=0)
        return _frozen(np.sqrt(np.einsum("ij,ij->i", step, step)), float)

    @property
    def length_mm(self) -> float:
        """Total tool-tip path length, rapids included."""
        return float(self.segment_lengths_mm.sum())

    @property
    def cutting_length_mm(self) -> float:
        """Tool-tip length of the feed moves (everything but rapids)."""
        return float(self.segment_lengths_mm[self.kinds[1:] != MoveKind.RAPID].sum())

    @property
    def bounds_mm(self) -> NDArray[np.float64]:
        """``[[xmin, ymin, zmin], [xmax, ymax, zmax]]`` of the tool tip."""
        if not len(self):
            return np.full((2, 3), np.nan)
        return np.stack([self.positions_mm.min(axis=0), self.positions_mm.max(axis=0)])

    @property
    def n_passes(self) -> int:
        """Number of distinct finishing passes."""
        return int(np.unique(self.pass_index[self.pass_index >= 0]).size)

    # ------------------------------------------------------------------ machine
    def to_machine(self, machine: Machine, *, start: ArrayLike | None = None) -> InverseSolution:
        """Joint values through the machine's inverse kinematics (machine axis order)."""
        return solve_inverse(machine, self.positions_mm, self.tool_axes, start=start)

    def segment_times_s(self, machine: Machine,
                        joints: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
        """Seconds per move: the programmed feed, slowed to the axes' rate limits.

        Rapids run at the slowest axis's maximum rate; feed moves take
        ``length / feed`` unless an axis (linear or rotary) would exceed its rate.
        Acceleration is ignored, so this is a lower bound on real machining time.
        """
        if joints is None:
            joints = self.to_machine(machine).joints
        limit_s = min_segment_times(machine, joints)
        feeds = self.feeds_mm_per_min[1:]
        with np.errstate(divide="ignore", invalid="ignore"):
            feed_s = np.where(feeds > 0.0, 60.0 * self.segment_lengths_mm / feeds, 0.0)
        return np.maximum(feed_s, limit_s)

    def estimated_time_s(self, machine: Machine) -> float:
        """Total of :meth:`segment_times_s` (seconds)."""
        return float(self.segment_times_s(machine).sum())

    # ------------------------------------------------------------------ files
    def save(self, path: str | Path) -> None:
        """Write a ``.npz`` file (version :data:`TOOLPATH_FORMAT_VERSION`).

        Stored, not deflated: a 175,000-point 5-axis path takes 10.7 MB instead of 8.0, in
        0.01 s instead of 0.26 s (doubles of measured geometry barely compress). :meth:`load`
        reads either.
        """
        keys = np.array(list(self.metadata), dtype=str)
        values = np.array(list(self.metadata.values()), dtype=str)
        with Path(path).open("wb") as handle:
            np.savez(
                handle, format_version=np.array(TOOLPATH_FORMAT_VERSION),
                positions_mm=self.positions_mm, tool_axes=self.tool_axes, kinds=self.kinds,
                feeds_mm_per_min=self.feeds_mm_per_min, pass_index=self.pass_index,
                metadata_keys=keys, metadata_values=values,
                joints_checked_for=np.array(self.joints_checked_for or ""))

    @classmethod
    def load(cls, path: str | Path) -> Toolpath:
        """Read a file written by :meth:`save`; refuses other format versions.

        Raises
        ------
        DataFileError
            Naming the file: missing, not a ``.npz`` archive, damaged, not a toolpath, or
            another format version (never numpy's own messages about pickles).
        """
        path = Path(path)
        try:
            with path.open("rb") as handle:  # a missing file or a folder: OSError
                zipped = zipfile.is_zipfile(handle)
            if not zipped:  # np.load would try it as a pickle
                raise DataFileError("not a toolpath file: not a .npz archive (write one with "
                                    "'toolpath plan -o PATH.npz')", path=str(path))
            with np.load(path, allow_pickle=False) as data:
                return cls._from_arrays(data, path)
        except OSError as exc:
            raise DataFileError(f"cannot read a toolpath: {exc.strerror or exc}",
                                path=str(path)) from None
        except (ValueError, TypeError, KeyError, EOFError, zipfile.BadZipFile,
                zlib.error) as exc:
            if isinstance(exc, DataFileError):
                raise
            raise DataFileError(f"not a toolpath file: a damaged or foreign .npz "
                                f"({exc or type(exc).__name__})", path=str(path)) from None

    @classmethod
    def _from_arrays(cls, data: Any, path: Path) -> Toolpath:
        missing = {"format_version", "positions_mm", "tool_axes", "kinds",
                   "feeds_mm_per_min", "pass_index"} - set(data.files)
        if missing:
            raise DataFileError(f"not a toolpath file: missing {sorted(missing)}",
                                path=str(path))
        version = int(data["format_version"])
        if version != TOOLPATH_FORMAT_VERSION:
            raise DataFileError(
                f"toolpath format version {version}; this program reads version "
                f"{TOOLPATH_FORMAT_VERSION}", path=str(path))
        metadata = dict(zip(data.get("metadata_keys", np.array([], dtype=str)).tolist(),
                            data.get("metadata_values", np.array([], dtype=str)).tolist(),
                            strict=True))
        # files written before the typed field kept a fingerprint of the machine's repr
        # (its definition file's path included) here: not trusted, the post splits
        metadata.pop(LEGACY_JOINT_CHECKED_KEY, None)
        checked = (str(data["joints_checked_for"]) if "joints_checked_for" in data.files
                   else "")
        try:
            return cls(data["positions_mm"], data["tool_axes"], data["kinds"],
                       data["feeds_mm_per_min"], data["pass_index"], metadata,
                       joints_checked_for=checked or None)
        except InvalidParameterError as exc:
            raise DataFileError(f"not a valid toolpath: {exc}", path=str(path)) from None
