"""Streamline surfaces ``∂X/∂t = T^{-1} D(t, s) T (X + c)`` (Section 4, Algorithm 4).

The solution (eq. 25, shifted by the translation ``c``) is

    ``X(t, s) = −c + T^{-1} [Z_0(s) ∘ exp(G(t, s))]``,  ``Z_0(s) = T (X_0(s) + c)``,

with ``X_0(s)`` the not-a-knot cubic through the first point of every section and ``G`` a
bicubic tensor spline per component (eq. 29) with ``G(0, s) = 0`` and
``G(1, s_j) = Y_nj`` (eqs. 27-28), fitted to ``Y_ij = log(Z_ij / Z_0j)``. The curves
``s = const`` are streamlines of the system: the cutting passes. So
``X(1, s_j) = X_nj`` exactly and ``X(0, s) = X_0(s)`` for every ``s``; between sections the
last edge ``X(1, s)`` is the interpolation of the ``Y_n`` in log space.

Derivatives, with ``W = Z_0 ∘ e^G`` (componentwise) and ``X^(·) = T^{-1} W^(·)``:
along ``t`` from the system itself, ``W_t = W G_t`` (``D = diag G_t``, eq. 22) and
``W_tt = W (G_tt + G_t²)``; across ``s`` by the chain rule,
``W_s = e^G (Z_0' + Z_0 G_s)``, ``W_ts = W_s G_t + W G_ts`` and
``W_ss = e^G (Z_0'' + 2 Z_0' G_s + Z_0 (G_ss + G_s²))``.

Closed sections: ``Y_n = 0``, so ``G`` is periodic in ``t`` (:mod:`toolpath.periodic`)
with ``G(0, s_j) = 0`` kept exactly, hence ``G(0, s) = 0`` for every ``s`` (the rows are
interpolated linearly in their coefficients): ``X(0, s) = X_0(s)`` and ``X`` is periodic in
``t``, position, tangent and curvature continuous across the seam ``t = 0 ≡ 1`` (a corner
only where the data have one at the seam).
"""

from __future__ import annotations

import dataclasses
import functools
import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.interpolate
from numpy.typing import NDArray

from .adaptive import DEFAULT_SWEEPS, check_given_knots, knot_options
from .bspline_surface import fit_bspline_surface
from .compiled import StreamlineKernel
from .cone_frame import ConeFrame, candidate_frames, paper_frame
from .errors import ConvergenceWarning, InvalidParameterError, LogRangeError
from .fitted_surface import FittedSurface, GridFit, column_errors, fit_grid
from .knots import DEFAULT_CORNER_ANGLE_DEG
from .sections import Sections, as_sections
from .splinefit import DEGREE, end_interpolating_lsq, n_coefficients
from .streamline_curve import (
    FRAME_METHODS,
    FRAME_TRIES,
    LogSpaceProblem,
    check_log_range,
    fit_in_frames,
)
from .tensor_spline import PiecewiseCubic

__all__ = ["StreamlineSurface", "fit_streamline_surface"]

#: Cone margins (radius factors of Algorithm 2) and origin distances tried for surfaces.
SURFACE_MARGINS = (3.0, 10.0, 100.0)
SURFACE_KAPPAS = (3.0, 10.0, 100.0)
#: Candidates (best at the data) whose error between sections is also measured.
FINALISTS = 4


def _section_points(knots_t, g_coef, x0, t, T, c) -> NDArray[np.float64]:
    z0 = T @ (x0 + c)
    g = scipy.interpolate.BSpline(knots_t, g_coef, DEGREE)(t)
    return (z0 * np.exp(g)) @ np.linalg.inv(T).T - c


@dataclass(frozen=True, eq=False, kw_only=True)
class StreamlineSurface(FittedSurface):
    """``X(t, s) = −c + T^{-1} [Z_0(s) ∘ exp(G(t, s))]`` (eq. 25, shifted).

    A section's row is ``G``'s ``t``-coefficients ``(n_t * 3)`` then ``X_0(s_j)`` (3).

    Attributes
    ----------
    T : ndarray, shape (3, 3)
        The constant matrix diagonalizing the system.
    c : ndarray, shape (3,)
        Translation (mm) putting the data in ``T``'s positive cone.
    frame_label : str
        How ``(T, c)`` was chosen.
    """

    T: NDArray[np.float64]
    c: NDArray[np.float64]
    frame_label: str = ""

    @classmethod
    def _row_points(cls, knots_t, row, t, extra) -> NDArray[np.float64]:
        return _section_points(knots_t, row[:-3].reshape(-1, 3), row[-3:], t, extra["T"],
                               extra["c"])

    @property
    def G(self):
        """``G(t, s)`` as a :class:`toolpath.tensor_spline.TensorSpline` (eq. 29)."""
        return self.tensor

    def X0(self, s: Any, ds: int = 0) -> NDArray[np.float64]:
        """The boundary curve ``X_0(s)`` through the first points (or its derivative)."""
        s = np.asarray(s, float)
        return self._x0_curve(s, ds).reshape((*s.shape, 3))

    @functools.cached_property
    def _x0_curve(self) -> PiecewiseCubic:
        return PiecewiseCubic(self.knots_s, np.ascontiguousarray(self.row_coef[:, -3:]))

    def D(self, t: Any, s: Any) -> NDArray[np.float64]:
        """``D(t, s) = diag(∂G/∂t)`` (eq. 22), shape ``broadcast(t, s).shape + (3, 3)``."""
        t, s = np.broadcast_arrays(np.asarray(t, float), np.asarray(s, float))
        g_t = self.tensor.partial(t.ravel(), s.ravel(), 1, 0).reshape((*t.shape, 3))
        return g_t[..., :, None] * np.eye(3)

    def _partials(self, t, s, dt, ds) -> NDArray[np.float64]:
        return self.partials_many(t, s, ((dt, ds),))[dt, ds]

    def kernel(self) -> StreamlineKernel:
        """Eq. 25 and its partials, compiled (:mod:`toolpath.compiled`)."""
        return self._compiled

    @functools.cached_property
    def _compiled(self) -> StreamlineKernel:
        breaks_t, breaks_s, g_poly = self.tensor.patches
        x0_breaks, x0_poly = self._x0_curve.pieces
        T = np.ascontiguousarray(self.T, dtype=float)
        return StreamlineKernel(
            breaks_t, breaks_s, g_poly, x0_breaks, np.ascontiguousarray(x0_poly), T,
            np.ascontiguousarray(np.linalg.inv(T)), np.ascontiguousarray(self.c, dtype=float),
            np.eye(3), np.zeros(3), bool(self.closed_t))

    def to_dict(self) -> dict[str, Any]:
        """JSON-serializable description; :meth:`from_dict` restores it exactly."""
        return {"kind": "streamline_surface", **self._common_dict(), "T": self.T.tolist(),
                "c": self.c.tolist(), "frame_label": self.frame_label}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> StreamlineSurface:
        """Rebuild from :meth:`to_dict` output."""
        return cls(T=np.asarray(data["T"], float), c=np.asarray(data["c"], float),
                   frame_label=str(data.get("frame_label", "")), **cls._common_fields(data))


@dataclass(frozen=True)
class _GridLogProblem:
    """Every section seen in one cone frame: ``Y_ij = log(Z_ij / Z_0j)``, stacked."""

    sections: Sections
    frame: ConeFrame

    @functools.cached_property
    def z(self) -> NDArray[np.float64]:
        return self.frame.to_cone(self.sections.points.reshape(-1, 3)).reshape(
            self.sections.points.shape)

    @functools.cached_property
    def y_stacked(self) -> NDArray[np.float64]:
        z = self.z
        y = np.log(z / z[:, :1, :])  # (m, n, 3)
        return y.transpose(1, 0, 2).reshape(self.sections.n_columns, -1)

    def fit(self, knots, refine: bool, weights=None):
        grid = self.sections
        m, n = grid.n_sections, grid.n_columns
        coef = np.asarray(end_interpolating_lsq(grid.t, self.y_stacked, knots, weights).c)
        check_log_range(coef, self.y_stacked, knots)
        coef = coef.reshape(-1, m, 3)
        if refine:
            for j in range(m):
                coef[:, j] = LogSpaceProblem(grid.points[j], grid.t, self.frame)._refine(
                    knots, coef[:, j], weights)
        g = scipy.interpolate.BSpline(knots, coef.reshape(-1, m * 3), DEGREE)(grid.t)
        z0 = self.z[:, :1, :]
        fitted = (z0 * np.exp(g.reshape(n, m, 3).transpose(1, 0, 2))) @ np.linalg.inv(
            self.frame.T).T - self.frame.c
        rows = np.concatenate((coef.transpose(1, 0, 2).reshape(m, -1), grid.points[:, 0]),
                              axis=1)
        return rows, column_errors(fitted, grid.points)


def _ranked_frames(sections: Sections, knots) -> list[ConeFrame]:
    """The candidate frames, best first on ``knots`` (the baseline's), in and between sections.

    Candidates are wide cones (:data:`SURFACE_MARGINS`): a tight cone makes ``T``
    ill-conditioned and the exponential amplifies any error between the sections (cylinder
    patch, ``benchmarks/paper_tables.py``: 0.038 mm between sections for a 0.0003 mm fit at
    the data with the curve fitter's margins, 0.00004 mm with these). The
    :data:`FINALISTS` with the smallest max error at the data are then ranked by
    ``max(data error, leave-one-out error)``, and the other frames after them by their max
    error at the data; frames whose fit leaves the log range are left out.
    """
    ranked, failure = [], None
    for candidate in candidate_frames(sections.points.reshape(-1, 3), margins=SURFACE_MARGINS,
                                      kappas=SURFACE_KAPPAS):
        try:
            rows, errors = _GridLogProblem(sections, candidate).fit(knots, refine=False)
        except LogRangeError as exc:  # out of the log range (check_log_range): the next frame
            failure = exc
            continue
        ranked.append((float(errors.max()), len(ranked), candidate, rows, errors))
    if not ranked and failure is not None:
        raise LogRangeError("no cone frame gives a streamline fit on "
                            f"{n_coefficients(knots)} control points along t: {failure}")
    if not ranked:
        return [paper_frame(sections.points.reshape(-1, 3))]
    ranked.sort(key=lambda item: item[:2])
    finalists = []
    for k, (data_error, _, candidate, rows, errors) in enumerate(ranked[:FINALISTS]):
        fields = {"T": candidate.T, "c": candidate.c}
        loo = StreamlineSurface._leave_one_out(sections, GridFit(knots, rows, errors), fields)
        finalists.append((max(data_error, loo), k, candidate))
    finalists.sort(key=lambda item: item[:2])
    return [frame for *_, frame in finalists] + [item[2] for item in ranked[FINALISTS:]]


def fit_streamline_surface(
    sections: Any,
    *,
    tol: float | None = None,
    n_control_points: int | None = None,
    max_control_points: int | None = None,
    knots: Any = None,
    closed: bool | None = None,
    params: Any = "chord",
    section_params: Any = None,
    knot_method: str = "density",
    corner_angle_deg: float | None = DEFAULT_CORNER_ANGLE_DEG,
    sweeps: int = DEFAULT_SWEEPS,
    frame: str = "best",
    refine: bool = False,
    minimax: bool = True,
    fair: bool = True,
) -> StreamlineSurface:
    """Fit a streamline surface through blade sections (Algorithm 4).

    Parameters
    ----------
    sections : array_like, shape (m, n, 3), or a list of (n, 3) arrays
        Sections hub to tip, points in order within each (see :func:`toolpath.as_sections`).
    tol : float, optional
        Max distance (mm) at the data points; the fewest ``t``-control points of ``G``
        reaching it are searched. Exactly one of ``tol``, ``n_control_points``, ``knots``.
    n_control_points : int, optional
        Control points of ``G`` along ``t`` (across ``s`` there is one per section).
    max_control_points : int, optional
        Upper bound along ``t`` while searching for ``tol``.
    knots : array_like, optional
        The clamped cubic ``t``-knot vector to use exactly (e.g. the baseline's
        ``knots_t``, for a same-knots comparison).
    closed : bool, optional
        Closed sections, fitted periodic in ``t`` (default: read from how the sections end,
        :mod:`toolpath.closure`).
    params, section_params
        Grid parameters ``t`` and ``s`` (see :func:`toolpath.as_sections`).
    knot_method, corner_angle_deg, sweeps, minimax, fair
        As for :func:`toolpath.fit_streamline_curve`; ``"dominant"`` gives the paper's
        dominant columns; fairness is checked on every section and midway between.
    frame : {"best", "paper"}
        ``"best"``: among the candidate frames (translations ``c`` included), the one with
        the smallest max error on the knots the baseline needs; ``"paper"``: the paper's.
    refine : bool
        Minimize the true error ``Σ ||X(t_i, s_j) − X_ij||²`` per section (Gauss-Newton).

    Returns
    -------
    StreamlineSurface

    Examples
    --------
    >>> import numpy as np
    >>> t, s = np.linspace(0, 1, 40), np.linspace(0, 1, 6)
    >>> a = 0.3 + 0.5 * t[None, :]
    >>> pts = np.stack([60 * np.cos(a), 60 * np.sin(a), 20 * s[:, None] + 0 * a], -1)
    >>> surf = fit_streamline_surface(pts, tol=0.001)
    >>> surf.max_error <= 0.001
    True
    """
    if frame not in FRAME_METHODS:
        raise InvalidParameterError(f"frame must be one of {FRAME_METHODS}, got {frame!r}")
    options = knot_options(tol=tol, n_control_points=n_control_points,
                           max_control_points=max_control_points, knots=knots,
                           knot_method=knot_method, corner_angle_deg=corner_angle_deg,
                           sweeps=sweeps, minimax=minimax)
    grid = as_sections(sections, closed=closed, params=params,
                       section_params=section_params)
    if grid.closed and refine:
        raise InvalidParameterError("refine is available for open sections only, not closed ones")
    if frame == "paper":
        frames = [paper_frame(grid.points.reshape(-1, 3))]
    else:
        probe = options.knots
        if probe is not None:
            check_given_knots(grid.t, probe)  # before the frames are tried on them
        else:
            # the grid itself: its points re-read as sections would be validated again,
            # and a matched grid's nearby columns of one section refused as repeated points
            with warnings.catch_warnings():  # the fit itself says what its probe would
                warnings.simplefilter("ignore", ConvergenceWarning)
                probe = fit_bspline_surface(
                    grid, tol=tol, n_control_points=n_control_points,
                    max_control_points=max_control_points, knot_method=knot_method,
                    corner_angle_deg=corner_angle_deg, sweeps=sweeps, minimax=False,
                    fair=False).knots_t
        frames = _ranked_frames(grid, probe)[:FRAME_TRIES]
        if options.knots is None and options.method == "density":
            # the baseline's knots for the same request: start the search there
            options = dataclasses.replace(options, start_knots=probe)

    def fit_in(frame: ConeFrame) -> GridFit:
        problem = _GridLogProblem(grid, frame)
        fields = {"T": frame.T, "c": frame.c, "frame_label": frame.label}
        return fit_grid(grid, problem.y_stacked, lambda k, w: problem.fit(k, refine, w),
                        options, (lambda fit: StreamlineSurface._from_grid(grid, fit, **fields))
                        if fair else None)

    chosen, fitted = fit_in_frames(frames, fit_in)
    return StreamlineSurface._from_grid(grid, fitted, T=chosen.T, c=chosen.c,
                                        frame_label=chosen.label)
