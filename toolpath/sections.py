"""Blade sections: validation and the grid parameters of a surface fit (Algorithm 4, step 1).

A blade is ``m`` sections (profiles) stacked hub to tip, each ordered points (counts may
differ). The surface fit needs them on a grid, column ``i`` with one parameter ``t_i`` and
section ``j`` with one ``s_j``:

- ``t`` pairs like with like: the sections are matched first
  (:mod:`toolpath.section_matching`: leading and trailing edges found in the geometry, the
  section's own chord length between them mapped onto common edge parameters). Sections
  that already correspond (same counts, edges between the same points) keep one column per
  point, ``t_i`` the mean of the matched parameters of point ``i``; otherwise the columns
  are the union of all sections' matched parameters and each section is interpolated at
  the others' (``mask`` tells the data entries). Given ``params`` as an array, ``t`` is
  that array and the points correspond by index;
- ``s_j`` is the cumulative mean distance between corresponding points of consecutive
  sections, normalized to [0, 1] (chord length across the sections).

A **closed** section (a profile wrapped all around) is stored with its first point repeated
at the end, so ``t = 0`` and ``t = 1`` are the same point (the seam); matched closed
sections have their seam moved to the trailing edge. Whether sections are closed is read
from how each one ends by the seam rule of :mod:`toolpath.closure` (a repeated first
point, or a closing step like its neighbours that is not a blunt base).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .arrays import MIN_CURVE_POINTS, as_curve_points
from .closure import CLOSURE_GAP_MM, close_loop, read_seam
from .errors import ClosureWarning, InvalidParameterError, InvalidPointsError
from .parametrize import PARAM_METHODS, unit_curve_parameters
from .section_matching import match_sections

__all__ = ["CLOSURE_GAP_MM", "MIN_SECTIONS", "ODD_SEAM_SHARE", "Sections", "as_sections"]

#: A cubic across the sections needs four of them.
MIN_SECTIONS = 4


@dataclass(frozen=True, eq=False)
class Sections:
    """Validated sections on a grid.

    Attributes
    ----------
    points : ndarray, shape (m, n, 3)
        Points (mm), section ``j`` hub to tip, point ``i`` along the section; for closed
        sections the last column repeats the first.
    closed : bool
        Whether the sections are closed loops.
    t : ndarray, shape (n,)
        Parameter of each column along the sections, 0 to 1.
    s : ndarray, shape (m,)
        Parameter of each section across the blade, 0 to 1.
    mask : ndarray of bool, shape (m, n), optional
        True where ``points`` holds a data point; False where it was interpolated along its
        section (ragged or shifted sections, a closed seam moved). ``None``: all data.
    """

    points: NDArray[np.float64]
    closed: bool
    t: NDArray[np.float64]
    s: NDArray[np.float64]
    mask: NDArray[np.bool_] | None = None

    @property
    def data_mask(self) -> NDArray[np.bool_]:
        """``mask``, all True when every entry is data."""
        return np.ones(self.points.shape[:2], bool) if self.mask is None else self.mask

    def samples_per_column(self, per_data_interval: int) -> int:
        """Samples per grid column giving about ``per_data_interval`` per data interval.

        A union grid (ragged or shifted sections) has several columns per data interval of
        any one section; dense checks (fairness) need their density per data interval.
        """
        per_section = max(self.data_counts)
        return max(2, int(np.ceil(per_data_interval * per_section / self.n_columns)))

    @property
    def data_counts(self) -> list[int]:
        """Data points per section (a closed seam counted once)."""
        counts = self.data_mask.sum(axis=1)
        if self.closed and self.mask is None:
            counts = counts - 1
        return [int(c) for c in counts]

    @property
    def n_sections(self) -> int:
        """``m``."""
        return self.points.shape[0]

    @property
    def n_columns(self) -> int:
        """``n``, grid columns: points per section (with the repeated seam point when closed).

        Ragged sections: the union of the matched parameters.
        """
        return self.points.shape[1]

    @property
    def stacked(self) -> NDArray[np.float64]:
        """The columns as one curve in ``R^(3m)``: row ``i`` is point ``i`` of every section."""
        return self.points.transpose(1, 0, 2).reshape(self.n_columns, -1)


def _section(j: int, raw: Any) -> NDArray[np.float64]:
    try:
        return as_curve_points(raw)
    except InvalidPointsError as exc:
        raise InvalidPointsError(f"section {j}: {exc}", index=exc.index) from None


#: Sections whose seams read otherwise than the rest are fitted as the rest read when they
#: are fewer than this share of the blade (a micrometre or two of scatter turns a closing
#: step of 10-20 um by tens of degrees: one of the DCA rotor's 11 sections with 2 um read
#: as a blunt base); more (one of four) are refused, naming the first odd one.
ODD_SEAM_SHARE = 0.25


def _is_closed(points: list[NDArray[np.float64]], closed: bool | None) -> bool:
    """``closed`` if given, else every section's seam read by :func:`toolpath.closure.read_seam`.

    Sections read differently (some closed, some open) are fitted as most read where the
    others are fewer than :data:`ODD_SEAM_SHARE` of them, with a warning naming them and the
    flag that says otherwise; else refused, naming the first odd one and why: the caller
    says which with ``--closed``/``--open``.
    """
    if closed is not None:
        return bool(closed)
    seams = [read_seam(p) for p in points]
    verdicts = np.array([seam.closed for seam in seams])
    if verdicts.all() or not verdicts.any():
        return bool(verdicts.all())
    most = bool(2 * verdicts.sum() > verdicts.size)
    odd = np.flatnonzero(verdicts != most)
    word = {True: "closed", False: "open"}
    if odd.size < ODD_SEAM_SHARE * verdicts.size:
        j = int(odd[0])
        named = f"section {j}" if odd.size == 1 else "sections " + ", ".join(map(str, odd))
        warnings.warn(ClosureWarning(
            f"{named} read{'s' if odd.size == 1 else ''} {word[not most]} ({seams[j].reason})"
            f" but the other {verdicts.size - odd.size} of {verdicts.size} sections read "
            f"{word[most]}: fitted {word[most]}; give --{word[not most]} if the blade is "
            f"{word[not most]}"), stacklevel=3)
        return most
    j = int(np.argmax(verdicts != verdicts[0]))
    raise InvalidPointsError(
        f"section {j} reads {word[bool(verdicts[j])]} ({seams[j].reason}) but section 0 "
        f"reads {word[bool(verdicts[0])]} ({seams[0].reason}): say which with --closed or "
        "--open", index=j)


def _column_parameters(points: NDArray[np.float64], params: Any) -> NDArray[np.float64]:
    """``params`` given as one array for every section, mapped onto [0, 1]."""
    return unit_curve_parameters(points[0], params)


def _section_parameters(points: NDArray[np.float64], section_params: Any
                        ) -> NDArray[np.float64]:
    if section_params is not None:
        try:
            return unit_curve_parameters(points[:, 0], section_params)
        except InvalidParameterError as exc:
            raise InvalidParameterError(f"section_params: {exc}") from None
    gaps = np.linalg.norm(np.diff(points, axis=0), axis=2).mean(axis=1)  # (m-1,)
    s = np.concatenate(([0.0], np.cumsum(gaps)))
    return s / s[-1]


def _check_order(points: NDArray[np.float64]) -> None:
    """Sections must advance hub to tip: centroids strictly progress along the span."""
    centroids = points.mean(axis=1)
    span = centroids[-1] - centroids[0]
    length = float(np.linalg.norm(span))
    if length == 0.0:
        raise InvalidPointsError("the first and last sections coincide: no span to fit")
    along = (centroids - centroids[0]) @ (span / length)
    back = np.diff(along) <= 0.0
    if back.any():
        j = int(np.argmax(back)) + 1
        raise InvalidPointsError(
            f"section {j} is out of order: its centroid is not beyond section {j - 1}'s "
            "along the span (sections must be stacked hub to tip)", index=j)


def as_sections(sections: Any, *, closed: bool | None = None, params: Any = "chord",
                section_params: Any = None) -> Sections:
    """Validate blade sections and compute their grid parameters.

    Parameters
    ----------
    sections : array_like, shape (m, n, 3), a sequence of (n_j, 3) arrays, or Sections
        Sections hub to tip, points in order within each, every section the same way
        round (point counts may differ). A :class:`Sections` is returned as it is.
    closed : bool, optional
        Whether the sections are closed loops. ``None`` (default): read from how each
        section ends (:mod:`toolpath.closure`: a repeated first point, or a last point a
        step like its neighbours short of the first, not a blunt base). With ``True`` an
        unrepeated first point is appended to close the loop.
    params : {"chord", "centripetal", "uniform"} or array_like, shape (n,)
        Column parameters ``t``: each section's own parameters by that method between its
        matched edges (module docstring), or one array for all (mapped onto [0, 1]; the
        sections then correspond by index and need one point count).
    section_params : array_like, shape (m,), optional
        Section parameters ``s`` (mapped onto [0, 1]); default: chord length across.

    Returns
    -------
    Sections

    Raises
    ------
    InvalidPointsError
        Fewer than four sections, sections with different point counts under array
        ``params`` (the message names the first odd section), a non-finite value or a
        repeated point (naming the section and point), sections out of order or running
        the other way round.
    """
    if isinstance(sections, Sections):
        return sections
    try:
        raw = list(sections)
    except TypeError:
        raise InvalidPointsError(
            f"sections must be an (m, n, 3) array or a list of (n, 3) arrays, got "
            f"{type(sections).__name__}") from None
    if len(raw) < MIN_SECTIONS:
        raise InvalidPointsError(
            f"a surface needs at least {MIN_SECTIONS} sections, got {len(raw)}")
    checked = [_section(j, r) for j, r in enumerate(raw)]
    for j, p in enumerate(checked):
        if p.shape[1] != 3:
            raise InvalidPointsError(f"section {j} has {p.shape[1]}-D points; sections are 3-D")
    counts = [len(p) for p in checked]
    matching = isinstance(params, str)
    if matching and params not in PARAM_METHODS:
        raise InvalidParameterError(
            f"params must be one of {PARAM_METHODS} or an array, got {params!r}")
    if not matching and len(set(counts)) > 1:
        j = next(j for j, c in enumerate(counts) if c != counts[0])
        raise InvalidPointsError(
            f"section {j} has {counts[j]} points but section 0 has {counts[0]}: with "
            "params given as an array every section needs the same number of points, in "
            "corresponding order", index=j)
    is_closed = _is_closed(checked, closed)
    if is_closed:
        checked = [close_loop(p) for p in checked]
        if len(checked[0]) - 1 < MIN_CURVE_POINTS:
            raise InvalidPointsError(
                f"a closed section needs at least {MIN_CURVE_POINTS} distinct points")
    if matching:
        matched = match_sections(checked, is_closed, params)
        points, t = matched.points, matched.t
        mask = None if matched.mask.all() else matched.mask
    else:
        points, mask = np.stack(checked), None
        t = _column_parameters(points, params)
    _check_order(points)
    return Sections(points=points, closed=is_closed, t=t,
                    s=_section_parameters(points, section_params), mask=mask)
