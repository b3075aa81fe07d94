"""Command-line placement of a saved surface, shared by ``toolpath plan`` and ``verify``.

``--rotate 'y:-90,z:30' [--translate x,y,z] [--on-table --base-height MM]`` places the
surface in the machine's workpiece frame (:mod:`toolpath.planning.setup`); ``verify`` must
be given the same options as ``plan`` so both see the surface where it was cut.
"""

from __future__ import annotations

import argparse
import math
from typing import TYPE_CHECKING

from toolpath.errors import InvalidParameterError

if TYPE_CHECKING:
    from toolpath.surface import ParametricSurface

__all__ = ["add_placement_arguments", "parse_vector", "placed_surface"]


def parse_vector(text: str, name: str) -> tuple[float, float, float]:
    """Three finite numbers ``x,y,z`` from ``text``, or an error naming ``name``."""
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        values = ()
    if len(values) != 3 or not all(map(math.isfinite, values)):
        raise InvalidParameterError(f"{name} must be three numbers x,y,z, got {text!r}")
    return values  # type: ignore[return-value]


def add_placement_arguments(parser: argparse.ArgumentParser) -> None:
    """``--rotate``, ``--translate``, ``--on-table``, ``--base-height``."""
    parser.add_argument("--rotate", default="",
                        help="place the surface: rotations about fixed axes, e.g. 'y:-90,z:30'")
    parser.add_argument("--translate", default=None, help="then shift by x,y,z mm")
    parser.add_argument("--on-table", action="store_true",
                        help="after --rotate, centre on the table axis, lowest point at "
                             "--base-height above z=0")
    parser.add_argument("--base-height", type=float, default=20.0,
                        help="with --on-table, mm above the table (20)")


def placed_surface(surface: ParametricSurface, args: argparse.Namespace) -> ParametricSurface:
    """The surface in the workpiece frame as the placement arguments say."""
    import numpy as np

    from toolpath.planning.setup import PlacedSurface, centred_on_table, rotation_from_spec

    rotation = rotation_from_spec(args.rotate)
    shift = (np.asarray(parse_vector(args.translate, "--translate")) if args.translate
             else np.zeros(3))
    if args.on_table:
        base = centred_on_table(surface, rotation, base_height_mm=args.base_height)
        return PlacedSurface(surface, rotation, base.translation + shift)
    if args.rotate or args.translate:
        return PlacedSurface(surface, rotation, shift)
    return surface
