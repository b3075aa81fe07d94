"""``verify_program``: replay, sweep, compare with the design; one report.

Stages (each timed in the report):

1. **replay** (:mod:`verification.replay`): the program through the interpreter and the
   machine's forward kinematics, joints interpolated within blocks as the controller does;
2. **samples** (:mod:`verification.samples`): the design surface on a grid fine enough for
   the scallop asked for (or given, taken ahead: :func:`design_samples`; their timings
   then come from the caller, :meth:`VerificationReport.with_samples_taken_ahead`);
3. **pieces** (:mod:`verification.pieces`): the swept ball as capsules (flat and
   bull-nose cutters: swept cutter pieces measured by :mod:`verification.torus`), the
   shank at resampled instances;
4. **near** and **collision** searches (:mod:`verification.dexels`): the material left on
   every dexel, and the block that left it;
5. **refine**: the largest excesses and deepest gouges re-measured on three levels of finer
   grids around them (the top of a cusp is a kink a grid misses by ``spacing x slope``),
   then those that may be the extreme once more with the path around them replayed finely
   (:mod:`verification.fine_model`): the reported extremes do not depend on how the path
   is cut into moves;
6. the report (:mod:`verification.report`).

The design surface must be given in the workpiece frame the program was posted for (the
frame of :class:`toolpath.Toolpath` and of :func:`machines.forward`).
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import replace
from pathlib import Path
from typing import Any, Final

import numba
import numpy as np
from numpy.typing import NDArray

from gcode.check import machine_dialect
from gcode.dialects import Dialect, dialect_by_name
from gcode.machine_frame import machine_axis_names, program_values
from gcode.parser import parse_file
from gcode.post import DEFAULT_JOINT_TOLERANCE_MM
from gcode.program import Linear, Program, Rapid
from machines import Machine
from toolpath import MoveKind, Toolpath, surface_from_dict
from toolpath.joint_refine import refine_for_joint_interpolation
from toolpath.planning.cutters import Cutter, CutterKind
from toolpath.surface import ParametricSurface

from .dexels import SweepIndex, near_search_radius_mm
from .errors import VerificationError
from .extremes import Extreme, border, extremes
from .fine_model import FineModel
from .options import DexelMethod, VerifyOptions
from .pages import with_small_pages
from .pieces import Pieces, ball_pieces, cutter_pieces, shank_pieces
from .replay import ToolMotion, replay
from .report import (
    BlockGouge,
    DeviationMap,
    DeviationStats,
    JointDeviation,
    Location,
    VerificationReport,
)
from .samples import DesignSamples, sample_design
from .search import Dexels, grid_search
from .vectors import row_norms

__all__ = ["design_samples", "load_surface", "program_of_toolpath", "verify_file",
           "verify_program", "verify_toolpath"]

FloatArray = NDArray[np.float64]

_MAX_GOUGING_BLOCKS: Final[int] = 10


def _location(motion: ToolMotion, e: Extreme | None) -> Location | None:
    if e is None:
        return None
    known = e.move >= 0
    return Location(
        deviation_mm=e.dev, point_mm=(float(e.point[0]), float(e.point[1]), float(e.point[2])),
        t=e.t, s=e.s, block_index=int(motion.block_index[e.move]) if known else None,
        line=int(motion.line[e.move]) if known else None,
        rapid=bool(motion.rapid[e.move]) if known else None, shank=e.shank)


def _gouging_blocks(motion: ToolMotion, dev: FloatArray, move: NDArray[np.int64],
                    area: FloatArray, points: FloatArray, tol: float) -> tuple[BlockGouge, ...]:
    d = dev.ravel()
    g = np.flatnonzero(np.isfinite(d) & (d < -tol) & (move.ravel() >= 0))
    if g.shape[0] == 0:
        return ()
    mv = move.ravel()[g]
    order = np.lexsort((d[g], mv))
    g, mv = g[order], mv[order]
    first = np.flatnonzero(np.r_[True, mv[1:] != mv[:-1]])
    areas = np.add.reduceat(area.ravel()[g], first)
    deepest = g[first]  # sorted by deviation within each move: the first is the deepest
    # deepest first; of equally deep blocks the earlier first (the tie rule of
    # verification.dexels: ``first`` is in block order, a stable sort keeps it)
    rank = np.argsort(d[deepest], kind="stable")[:_MAX_GOUGING_BLOCKS]
    pts = points.reshape(-1, 3)
    return tuple(
        BlockGouge(block_index=int(motion.block_index[mv[first[r]]]),
                   line=int(motion.line[mv[first[r]]]), depth_mm=float(-d[deepest[r]]),
                   area_mm2=float(areas[r]),
                   point_mm=tuple(float(v) for v in pts[deepest[r]]),  # type: ignore[arg-type]
                   rapid=bool(motion.rapid[mv[first[r]]]))
        for r in rank)


def _joints(motion: ToolMotion, tol: float) -> JointDeviation:
    dev = motion.tip_deviation_mm
    i = int(np.argmax(dev))
    has = bool(dev[i] > 0.0)
    return JointDeviation(
        max_mm=float(dev[i]), block_index=int(motion.block_index[i]) if has else None,
        line=int(motion.line[i]) if has else None, rotary_deg=float(motion.rotary_deg[i]),
        blocks_over_tol=int((dev > tol).sum()), substeps=int(motion.substeps.sum()))


def _settings(surface: ParametricSurface, cutter: Cutter, opts: VerifyOptions
              ) -> tuple[float | None, dict[str, float]]:
    """The cutter's corner radius (None: a ball) and ``opts`` resolved for that cutter.

    Raises VerificationError for a surface that is not a ParametricSurface.
    """
    if not isinstance(surface, ParametricSurface):
        raise VerificationError(f"surface must be a ParametricSurface, got "
                                f"{type(surface).__name__}")
    corner = None if cutter.kind is CutterKind.BALL else cutter.corner_radius_mm
    return corner, opts.resolved(cutter.radius_mm, corner)


@with_small_pages
def design_samples(surface: ParametricSurface, cutter: Cutter, *,
                   options: VerifyOptions | None = None) -> DesignSamples:
    """The samples of ``surface`` that :func:`verify_program` measures on (same arguments).

    They depend on the surface, the cutter and the options alone, not on the program: a
    caller that knows those before the program is written may take the samples ahead (the
    job does, in a thread while it posts and checks the program) and hand them to
    :func:`verify_program` as ``samples``.

    Raises
    ------
    VerificationError
        For a surface that is not a ParametricSurface or has no extent.
    """
    opts = options if options is not None else VerifyOptions()
    _, cfg = _settings(surface, cutter, opts)
    return sample_design(surface, spacing_t_mm=cfg["spacing_t_mm"],
                         spacing_s_mm=cfg["spacing_s_mm"], max_samples=opts.max_samples)


@with_small_pages
def verify_program(program: Program, surface: ParametricSurface, machine: Machine,
                   cutter: Cutter, *, options: VerifyOptions | None = None,
                   offsets: dict[int, tuple[float, ...]] | None = None,
                   samples: DesignSamples | None = None) -> VerificationReport:
    """Replay a program on a machine and compare what it cuts with the design surface.

    Parameters
    ----------
    program : Program
        The program (parsed, or built with :mod:`gcode.program` / :func:`gcode.post`).
    surface : ParametricSurface
        The design surface in the workpiece frame, mm, normals out of the material.
    machine : Machine
        The machine that runs the program (kinematics, work origin).
    cutter : Cutter
        The cutter (:func:`toolpath.planning.cutters.parse_cutter`): ball, flat or
        bull-nose.
    options : VerifyOptions, optional
        Resolution, horizons, tolerances.
    offsets : dict, optional
        Work offsets G54-G59 (mm, degrees); the machine's work origin when None.
    samples : DesignSamples, optional
        :func:`design_samples` of this surface, cutter and options, taken beforehand
        (default: taken here, after the replay).

    Returns
    -------
    VerificationReport
        Largest gouge and excess with their blocks and lines, the distribution, the
        uncut area, joint-interpolation figures and the deviation map.

    Raises
    ------
    VerificationError
        For a program without motion or invalid options.
    """
    opts = options if options is not None else VerifyOptions()
    corner, cfg = _settings(surface, cutter, opts)
    radius = cutter.radius_mm
    clock = {"start": time.perf_counter()}
    timings: dict[str, float] = {}

    def lap(name: str) -> None:
        now = time.perf_counter()
        timings[name] = now - clock["start"]
        clock["start"] = now

    motion = replay(program, machine, chord_tol_mm=opts.replay_tol_mm, radius_mm=radius,
                    offsets=offsets)
    lap("replay")
    if samples is None:
        samples = design_samples(surface, cutter, options=opts)
    lap("samples")
    method = opts.method
    if method is DexelMethod.AUTO:
        method = DexelMethod.NORMAL
    ball, shank = _pieces(motion, cutter, cfg, opts)
    assert shank is not None
    horizon, depth = cfg["horizon_mm"], cfg["gouge_search_mm"]
    levels = opts.levels()
    shape = radius if corner is None else corner
    near_cell = float(near_search_radius_mm(shape, levels[0], depth, np.zeros(1),
                                            core_radius_mm=radius - shape)[0])
    pts = samples.points.reshape(-1, 3)
    # how far beyond the samples' box the searches reach: a near search around P + r n
    # within R + e + g, a collision search around P within R + e + L (its radius counts
    # the cores' height); a deeper search, or one past the box, widens its grid itself
    index = SweepIndex(ball, shank, radius, pts.min(axis=0), pts.max(axis=0),
                       base_cell_mm=(near_cell + ball.max_half_mm) / 2.0,
                       reach_limit_mm=radius + horizon + max(shape + depth, ball.max_height_mm),
                       max_pairs=opts.max_pairs, corner_radius_mm=corner)
    ball = index.ball  # its view of the pieces it holds (what was passed, now views of them)
    ev = Dexels(index, radius, levels, depth, method, corner_radius=corner,
                model_tol_mm=opts.replay_tol_mm + opts.merge_tol_mm)
    fine = None
    if opts.extremes_tol_mm is not None and (opts.merge_tol_mm > 0.0
                                             or opts.replay_tol_mm > opts.extremes_tol_mm):
        fine_opts = replace(opts, merge_tol_mm=0.0, replay_tol_mm=opts.extremes_tol_mm)
        fine = FineModel(motion, machine, ev,
                         lambda stretch: _pieces(stretch, cutter, cfg, fine_opts,
                                                 shank=False)[0],
                         model_tol_mm=opts.replay_tol_mm + opts.merge_tol_mm,
                         chord_tol_mm=opts.extremes_tol_mm,
                         pieces_per_rad=(0.0 if cutter.kind is CutterKind.BALL else
                                         _core(cutter)[1] / (2.0 * opts.extremes_tol_mm)))
    lap("pieces")
    stride = None
    if opts.collision:
        step = max(samples.spacing_t_mm, samples.spacing_s_mm)
        stride = max(1, round(cfg["collision_spacing_mm"] / step))
    away = faces_away(motion, samples.normals)
    # a sample facing away from every axis most likely holds nothing within the horizon:
    # a flat or bull-nose cutter's near search, whose levels' radii differ by a few % (the
    # core's radius dominates them), starts it at the widest level rather than failing
    # every narrower one (the same results: Dexels.search's guess_mm); on the 3-axis
    # blades half the samples. A ball's levels differ by more (0.55 to 1.3 mm at the
    # 6 mm ball's): its deepening is kept as it was
    guess = None if corner is None else np.where(away, np.inf, 0.0)
    res, dev = grid_search(ev, samples, stride, guess_mm=guess)
    dev_grid = dev.reshape(samples.shape)
    move_grid = res.move.reshape(samples.shape)
    lap("search")

    tol = opts.gouge_tol_mm
    cut = np.isfinite(dev_grid)
    # a ball's profile (a bull-nose's corner) rises by the horizon within this band
    band = max(math.sqrt(2.0 * shape * horizon), samples.spacing_t_mm, samples.spacing_s_mm)
    interior = cut & ~away & ~border(~cut | away, math.ceil(band / samples.spacing_t_mm),
                                     math.ceil(band / samples.spacing_s_mm))
    max_gouge, max_excess, max_scallop = extremes(
        ev, surface, samples, res, dev_grid,
        [(cut, False, -tol), (cut, True, -np.inf), (interior, True, -np.inf)],
        refine=opts.refine, collision=opts.collision, fine=fine)
    lap("refine")
    stats = DeviationStats.of(dev_grid, samples.area_mm2, tol)
    timings["total"] = float(sum(timings.values()))
    return VerificationReport(
        machine=machine.name, cutter=cutter.spec, method=method.value, blocks=len(program),
        motion_blocks=motion.n_moves, tool_instances=motion.n_instances,
        pieces=ball.size + shank.size, samples=samples.shape,
        spacing_mm=(samples.spacing_t_mm, samples.spacing_s_mm), horizon_mm=horizon,
        gouge_tol_mm=tol,
        requested_scallop_mm=float("nan") if opts.scallop_mm is None else opts.scallop_mm,
        max_gouge=_location(motion, max_gouge), max_excess=_location(motion, max_excess),
        max_scallop=_location(motion, max_scallop), unswept_moves=motion.first_swept,
        gouging_blocks=_gouging_blocks(motion, dev_grid, move_grid, samples.area_mm2,
                                       samples.points, tol),
        stats=stats, joints=_joints(motion, tol), pairs=res.pairs, timings_s=timings,
        faces_away_area_mm2=float(samples.area_mm2[away].sum()),
        unreachable_area_mm2=float(samples.area_mm2[away | np.isposinf(dev_grid)].sum()),
        design_area_mm2=float(samples.area_mm2.sum()),
        deviation_map=DeviationMap(samples.t, samples.s, samples.points, dev_grid,
                                   np.where(move_grid >= 0, motion.block_index[move_grid], -1)))


#: Cutting axes are told apart to this (components of the unit vector, about 3 deg) when a
#: program turns its axis: a design normal faces away when it stands more than this past
#: square to every one of them.
AXIS_BIN = 0.05
#: Largest spread of a program's axis components still taken as one fixed axis (3-axis,
#: 3+2): far below :data:`AXIS_BIN`, above the rounding of posted and replayed angles.
FIXED_AXIS_SPREAD = 1e-9
#: Floor of an axis bin's length before it is normalised (a bin rounded to the zero vector
#: stays zero rather than dividing by zero; any positive length far below a bin's works).
MIN_BIN_LENGTH = 1e-300
#: Packing of a bin's three rounded components (each within ``+-1 / AXIS_BIN = +-20``)
#: into one integer key, so that the bins are found by a 1-D ``np.unique``.
_BIN_OFFSET = 128
_BIN_BASE = 256


def faces_away(motion: ToolMotion, normals: FloatArray) -> NDArray[np.bool_]:
    """Where the design faces away from every tool axis the program cuts with.

    The cutter's surface faces down its axis and sideways only (a ball's lower half, the
    flutes), so it touches the design only where ``n . a >= 0``: where ``n . a < 0`` for
    the program's one fixed axis (3-axis, 3+2), or for every axis of a program that turns
    it (5-axis: the range its moves use, told apart to :data:`AXIS_BIN`, and the normal
    then past square to all of them by that much), no move cuts to the surface, and the
    material left there is what the cutter's side shaved off passing by, not a scallop
    between passes.

    A normal is reached as soon as one axis bin has ``n . a >= -AXIS_BIN``
    (:func:`_past_square_to_all`): the bin that faced the previous sample best is tried
    first and usually reaches its neighbour too, so a reached normal costs one product and
    only a facing-away one (or a turn of the normals) all of them, with no
    ``samples x bins`` table.
    """
    cutting = ~motion.rapid[motion.move_of_instance[1:]]
    axes = motion.axes[1:][cutting]
    if axes.shape[0] == 0:
        return np.zeros(normals.shape[:-1], dtype=bool)
    if np.abs(axes - axes[0]).max() <= FIXED_AXIS_SPREAD:
        return normals @ axes[0] < 0.0
    # one key per bin: rounded components lie within +-1 / AXIS_BIN, packed in 8 bits each
    bins = np.round(axes / AXIS_BIN).astype(np.int64) + _BIN_OFFSET
    key = np.unique((bins[:, 0] * _BIN_BASE + bins[:, 1]) * _BIN_BASE + bins[:, 2])
    kinds = np.column_stack((key // (_BIN_BASE * _BIN_BASE), key // _BIN_BASE % _BIN_BASE,
                             key % _BIN_BASE)).astype(float)
    kinds = (kinds - _BIN_OFFSET) * AXIS_BIN
    kinds /= np.maximum(row_norms(kinds), MIN_BIN_LENGTH)[:, None]
    flat = np.ascontiguousarray(normals.reshape(-1, 3), dtype=float)
    return _past_square_to_all(flat, np.ascontiguousarray(kinds), -AXIS_BIN).reshape(
        normals.shape[:-1])


@numba.njit(cache=True)
def _past_square_to_all(normals: FloatArray, axes: FloatArray, limit: float
                        ) -> NDArray[np.bool_]:
    """Per row of ``normals``: ``max_k n . a_k < limit``.

    The axis that faced the last normal scanned best is tried first; only when it falls
    short are all axes scanned (and the best kept for the next rows).
    """
    away = np.ones(normals.shape[0], dtype=np.bool_)
    last = 0
    for i in range(normals.shape[0]):
        nx, ny, nz = normals[i, 0], normals[i, 1], normals[i, 2]
        if nx * axes[last, 0] + ny * axes[last, 1] + nz * axes[last, 2] >= limit:
            away[i] = False
            continue
        best = -np.inf
        for k in range(axes.shape[0]):
            c = nx * axes[k, 0] + ny * axes[k, 1] + nz * axes[k, 2]
            if c > best:
                best, last = c, k
        away[i] = not best >= limit
    return away


def _core(cutter: Cutter) -> tuple[float, float]:
    """A flat or bull-nose piece's core height ``max(R - 2 r, 0)`` and reach, mm.

    The reach ``hypot(R - r, L) + r`` bounds how far a point of the piece's cutter stands
    from its core centre (:func:`_pieces`).
    """
    radius, corner = cutter.radius_mm, cutter.corner_radius_mm
    height = max(radius - 2.0 * corner, 0.0)
    return height, math.hypot(radius - corner, height) + corner


def _pieces(motion: ToolMotion, cutter: Cutter, cfg: dict[str, float], opts: VerifyOptions,
            *, shank: bool = True) -> tuple[Pieces, Pieces | None]:
    """The swept cutter's near pieces and its shank pieces (:mod:`verification.pieces`).

    A flat or bull-nose piece is the bottom ``max(R, 2 r)`` of the cutter (core height
    ``max(R - 2 r, 0)``): a gouge deeper than that is the collision search's, as a ball's
    deeper than ``2 R``. Its axis turns along it by at most what moves a cutter point by
    the replay tolerance, so the number of pieces grows with ``reach x rotation``.
    ``shank=False``: the near pieces only (None for the shank).
    """
    radius, flutes = cutter.radius_mm, cutter.flute_length_mm
    if cutter.kind is CutterKind.BALL:
        return (ball_pieces(motion, radius, cfg["max_piece_mm"], merge_tol_mm=opts.merge_tol_mm),
                shank_pieces(motion, radius, flutes, cfg["shank_spacing_mm"],
                             cfg["shank_piece_mm"]) if shank else None)
    corner = cutter.corner_radius_mm
    height, reach = _core(cutter)
    near = cutter_pieces(motion, corner, height, cfg["max_piece_mm"], reach_mm=reach,
                         rot_tol_mm=opts.replay_tol_mm, merge_tol_mm=opts.merge_tol_mm)
    if not shank:
        return near, None
    return near, shank_pieces(motion, corner, flutes - corner, cfg["shank_spacing_mm"],
                              cfg["shank_piece_mm"])


def load_surface(path: str | Path) -> ParametricSurface:
    """Read a design surface saved as JSON (a fitted surface, or an analytic test surface).

    Parameters
    ----------
    path : str or Path
        JSON written by ``to_dict()`` of a fitted (``toolpath fit surface -o``) or analytic
        surface.

    Returns
    -------
    ParametricSurface

    Raises
    ------
    VerificationError
        When the file is not JSON or not a saved surface.
    """
    try:
        data: Any = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise VerificationError(f"{path}: cannot read a surface: {exc}") from None
    kind = data.get("kind") if isinstance(data, dict) else None
    if isinstance(kind, str) and kind.startswith("analytic"):
        from toolpath.planning.analytic import analytic_surface_from_dict

        return analytic_surface_from_dict(data)
    return surface_from_dict(data)


def verify_file(path: str | Path, surface: ParametricSurface, machine: Machine,
                cutter: Cutter, *, dialect: Dialect | None = None,
                options: VerifyOptions | None = None,
                samples: DesignSamples | None = None) -> VerificationReport:
    """Parse a G-code file strictly and verify it (see :func:`verify_program`).

    Parameters
    ----------
    path : str or Path
        The G-code file.
    surface, machine, cutter, options, samples
        As for :func:`verify_program`.
    dialect : Dialect, optional
        What the controller accepts; the machine's dialect (restricted to its axes) when
        None.

    Returns
    -------
    VerificationReport
        Lines in it are lines of the file.
    """
    d = dialect if dialect is not None else dialect_by_name(machine.dialect)
    program = parse_file(path, machine_dialect(machine, d))
    return verify_program(program, surface, machine, cutter, options=options,
                          samples=samples)


def program_of_toolpath(toolpath: Toolpath, machine: Machine) -> Program:
    """The program a toolpath becomes on a machine, unrounded: one block per point.

    Joints come from the machine's inverse kinematics (:meth:`toolpath.Toolpath.to_machine`)
    and are written as program words (:func:`gcode.machine_frame.program_values`) without
    rounding them to any text resolution, rapids as G0 and every other move as G1 at its
    feed: what the controller would execute if the G-code were exact. The first block
    positions every axis.

    Parameters
    ----------
    toolpath : Toolpath
        Tool tips and axes in the workpiece frame.
    machine : Machine
        The machine.

    Returns
    -------
    Program
        Blocks in mm and degrees; no source lines (lines are block numbers + 1).
    """
    words = program_values(machine, toolpath.to_machine(machine).joints)
    names = machine_axis_names(machine)
    cols = ["xyzabc".index(a) for a in names]
    rows = words[:, cols].tolist()
    feeds = toolpath.feeds_mm_per_min.tolist()
    kinds = toolpath.kinds.tolist()
    blocks: list[Rapid | Linear] = [Rapid(**dict(zip(names, rows[0], strict=True)))]
    for row, kind, feed in zip(rows[1:], kinds[1:], feeds[1:], strict=True):
        axes = dict(zip(names, row, strict=True))
        blocks.append(Rapid(**axes) if kind == MoveKind.RAPID
                      else Linear(**axes, feed=feed if feed > 0.0 else 1.0))
    return Program(tuple(blocks), name=toolpath.metadata.get("name"))


def verify_toolpath(toolpath: Toolpath, surface: ParametricSurface, machine: Machine,
                    cutter: Cutter, *, options: VerifyOptions | None = None,
                    joint_tolerance_mm: float | None = DEFAULT_JOINT_TOLERANCE_MM
                    ) -> VerificationReport:
    """Verify a toolpath as the machine would run it, before any G-code rounding.

    The planning step's figures (scallop, chord error) are figures of its toolpath; this is
    the check that confirms them with the machine's joint interpolation between points
    (:func:`program_of_toolpath`, then :func:`verify_program`), after the post's split of
    5-axis moves (:func:`~toolpath.joint_refine.refine_for_joint_interpolation`, which
    :func:`gcode.post` runs by default): the planner checks its leads and links as
    straight tip moves and leaves them to that split, so without it a link that turns the
    tool axis bows off its chord, into the part (issue 28: 0.06 mm on a dev-blade zigzag
    link turning the axis 20 deg). Lines in the report are point numbers + 1 of the
    toolpath so split (block ``i`` arrives at point ``i``); the same as the planner's on
    a 3-axis machine, or with ``joint_tolerance_mm=None``.

    Parameters
    ----------
    toolpath : Toolpath
        The planner's output.
    surface, machine, cutter, options
        As for :func:`verify_program`.
    joint_tolerance_mm : float or None
        The post's joint tolerance, mm (its default,
        :data:`gcode.post.DEFAULT_JOINT_TOLERANCE_MM`); None: every point joined by one
        block interpolated in joint space (a post run with ``joint_tolerance_mm=None``).

    Returns
    -------
    VerificationReport
    """
    if joint_tolerance_mm is not None:
        toolpath = refine_for_joint_interpolation(toolpath, machine, joint_tolerance_mm)
    program = program_of_toolpath(toolpath, machine)
    return verify_program(program, surface, machine, cutter, options=options)
