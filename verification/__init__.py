"""Material-removal verification: what the emitted G-code will actually cut.

A program is replayed through the interpreter and the machine's forward kinematics, with
the joints interpolated between blocks as the controller does (a 5-axis block does not move
the tip on a straight line); the ball-nose cutter's sweep becomes capsule pieces; dexels
through samples of the design surface (along the normal, or along +Z as a height map on
3-axis machines) measure the material left, signed (negative = gouge), each traced to its
block and source line.

Modules
-------
options
    ``VerifyOptions`` (resolution, horizons, tolerances; every default with its reason),
    ``DexelMethod``.
replay
    ``replay(program, machine, ...)`` -> ``ToolMotion``: tool tips and axes sampled in
    joint space, per-block joint-interpolation deviation.
samples
    ``sample_design(surface, ...)`` -> ``DesignSamples``: grid of points, normals, areas,
    convexity.
capsule
    ``line_capsule_interval``: where a line enters and leaves a capsule (the kernel).
torus
    ``line_sweep_interval``: where a line enters and leaves a flat or bull-nose cutter
    swept along a segment (the kernel for those cutters).
sweep_search
    ``lowest_sweep_entries``: the compiled grid walk for flat and bull-nose pieces.
pieces
    ``ball_pieces``, ``cutter_pieces``, ``shank_pieces`` -> ``Pieces``: the swept cutter.
grid
    ``PieceGrid``: uniform-grid bucketing of the pieces, candidate pairs in batches.
dexels
    ``SweepIndex``: near and collision searches -> ``DexelResult``.
search
    ``Dexels``, ``grid_search``: the searches over the sample grid, deviations.
extremes
    ``extreme``, ``extremes``: the deepest gouge, largest excess and scallop, refined on
    finer grids (an extreme two asks share searched once).
report
    ``VerificationReport`` (JSON via ``to_dict``), ``Location``, ``BlockGouge``,
    ``DeviationStats``, ``JointDeviation``, ``DeviationMap``.
pages
    ``small_pages``: numpy's huge-page request off while a verification runs.
verify
    ``verify_program``, ``verify_file``, ``verify_toolpath`` (a planner's toolpath as the
    machine runs it, unrounded), ``program_of_toolpath``, ``load_surface``,
    ``design_samples`` (the samples a verification measures on, to take ahead).
plotting
    ``plot_deviation_map``: the PNG deviation map (the only matplotlib user).
errors
    ``VerificationError`` (a ``ToolpathError``), ``UnsupportedCutterError`` (kept for
    callers; every cutter kind of :mod:`toolpath.planning.cutters` is verified now).

Examples
--------
>>> from gcode import Linear, Program, Rapid
>>> from verification import VerifyOptions, verify_program
>>> from machines import load_machine
>>> from toolpath.planning.analytic import PlaneSurface
>>> from toolpath.planning.cutters import parse_cutter
>>> plane = PlaneSurface((0, 0, 0), (10, 0, 0), (0, 2, 0))
>>> zigzag = [(-4.0, 0.0), (14.0, 0.0), (14.0, 1.0), (-4.0, 1.0), (-4.0, 2.0), (14.0, 2.0)]
>>> program = Program((Rapid(x=-4.0, y=0.0, z=5.0),
...                    *(Linear(x=x, y=y, z=0.0, feed=600.0) for x, y in zigzag)))
>>> report = verify_program(program, plane, load_machine("grbl-router"),
...                         parse_cutter("ball:6"), options=VerifyOptions(spacing_mm=0.05))
>>> report.max_gouge is None, round(report.max_excess_mm, 3)  # 3 - sqrt(9 - 0.25)
(True, 0.042)
"""

from toolpath.lazy import lazy_exports

from .errors import UnsupportedCutterError, VerificationError

#: Exported names -> defining module, imported on first use: reading the options (the
#: ``verify`` command's defaults) does not load the verifier.
_EXPORTS = {
    "DexelMethod": ".options",
    "VerifyOptions": ".options",
    "stepover_for_scallop_mm": ".options",
    "ToolMotion": ".replay",
    "replay": ".replay",
    "BlockGouge": ".report",
    "DeviationMap": ".report",
    "DeviationStats": ".report",
    "JointDeviation": ".report",
    "Location": ".report",
    "VerificationReport": ".report",
    "DesignSamples": ".samples",
    "sample_design": ".samples",
    "design_samples": ".verify",
    "load_surface": ".verify",
    "program_of_toolpath": ".verify",
    "verify_file": ".verify",
    "verify_program": ".verify",
    "verify_toolpath": ".verify",
}

__all__ = [
    "BlockGouge",
    "DesignSamples",
    "DeviationMap",
    "DeviationStats",
    "DexelMethod",
    "JointDeviation",
    "Location",
    "ToolMotion",
    "UnsupportedCutterError",
    "VerificationError",
    "VerificationReport",
    "VerifyOptions",
    "design_samples",
    "load_surface",
    "program_of_toolpath",
    "replay",
    "sample_design",
    "stepover_for_scallop_mm",
    "verify_file",
    "verify_program",
    "verify_toolpath",
]

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())
