"""Plans and what their measure stage measures them with, rebuilt from public names.

The measurement is given what ``plan_finishing``'s measure stage gives it: the plan's
toolpath (planned here with ``measure=False``) and its chord measurement on the surface
samples the gouge stage lays out (``gouge_sample_mm`` apart). And the standing dev blade
the 5-axis measure tests plan on, its bull-nose seeds round the leading edge, and a cusp
search that reads known cusps.

The standing blade's jobs are planned once a session (:func:`standing_blade_job`,
:func:`bull_leading_edge`, :func:`bull_leading_edge_estimates`): several test files
measure the same plan, and their tests read it, never write it.
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass

import numpy as np

from machines import Machine, load_machine
from toolpath import fit_streamline_surface
from toolpath.paper_examples import bundled_data_path
from toolpath.path import Toolpath
from toolpath.planning import Cutter, FinishingOptions, parse_cutter, plan_finishing
from toolpath.planning.chord_measure import ChordMeasurement, measure_chord
from toolpath.planning.cusp_estimates import torus_cusp_estimates
from toolpath.planning.cusp_search import SearchSeeds
from toolpath.planning.cut_volume import CutVolume, cusp_horizon_mm
from toolpath.planning.gouge import SurfaceSamples, sample_surface
from toolpath.planning.measure import SeedCusps, measure_scallop, seed_cusps
from toolpath.planning.setup import centred_on_table, rotation_from_spec
from toolpath.surface import ParametricSurface


@dataclass(frozen=True)
class Measured:
    """A plan's toolpath and what its measure stage measures it with."""

    path: Toolpath
    surface: ParametricSurface
    cutter: Cutter
    request_mm: float
    samples: SurfaceSamples
    chord: ChordMeasurement
    machine: Machine | None

    def scallop(self, **options):
        return measure_scallop(self.path, self.surface, self.cutter, self.request_mm,
                               self.chord, machine=self.machine, **options)

    def seeds(self, **options) -> SeedCusps:
        return seed_cusps(self.path, self.surface, self.cutter, self.request_mm, self.chord,
                          machine=self.machine, **options)

    def volume(self) -> CutVolume:
        """The material removed, to the horizon the measurement uses."""
        return CutVolume(self.path, self.cutter, cusp_horizon_mm(self.request_mm),
                         self.request_mm, self.machine)


def planned(surface, spec, *, machine=None, **options) -> Measured:
    """Plan without the measurement; measure the chord as ``plan_finishing`` does."""
    path, _ = plan_finishing(surface, spec, machine=machine, measure=False, **options)
    cutter = parse_cutter(spec)
    sample_mm = FinishingOptions(**options).resolved(cutter).gouge_sample_mm
    samples = sample_surface(surface, sample_mm)
    chord = measure_chord(path, surface, cutter, samples, machine=machine)
    return Measured(path, surface, cutter, options["scallop_mm"], samples, chord, machine)


@functools.cache
def standing_dev_blade() -> ParametricSurface:
    """The bundled dev blade's every other section (a shorter fit), standing on the table.

    (Fitted once a session: a surface is read, never written.)
    """
    rows = np.loadtxt(bundled_data_path("dev_blade_15x142.csv"), delimiter=",", skiprows=1)
    blade = fit_streamline_surface(rows[:, 1:].reshape(15, 142, 3)[::2], tol=0.01,
                                   closed=False)
    return centred_on_table(blade, rotation_from_spec("y:-90"))


@functools.cache
def standing_blade_job(spec: str, scallop_mm: float, chord_tol_mm: float,
                       machine: str | None = "trunnion-ac") -> Measured:
    """The user's kind of 5-axis job on the standing blade (lead-tilt, lead 10 degrees,
    ``machine`` by name, None: none), planned once a session for each cutter and request
    (~15 s each under load; several test files measure the same plan)."""
    return _read_only(planned(standing_dev_blade(), spec, scallop_mm=scallop_mm,
                              chord_tol_mm=chord_tol_mm, axis_mode="lead-tilt", lead_deg=10.0,
                              machine=None if machine is None else load_machine(machine)))


def _read_only(measured: Measured) -> Measured:
    """``measured`` with the arrays of its toolpath, samples and chord measurement made
    read-only: a test (or the code it tests) writing into a plan shared by the session
    fails there instead of changing what later tests read."""
    for part in (measured.path, measured.samples, measured.chord):
        for field in dataclasses.fields(part):
            value = getattr(part, field.name)
            if isinstance(value, np.ndarray):
                value.flags.writeable = False
    return measured


@functools.cache
def bull_leading_edge(t_from: float, t_to: float):
    """The user's kind of bull-nose job (bull:8:1, lead 10, trunnion-ac) on the standing
    blade, and its seeds with ``t_from <= t < t_to`` (round the leading edge): the plan, its
    cut volume, those seeds and the others of :meth:`SearchSeeds.of`.

    Once a session for each band: the band's tests (ranks, lazy tightening) read them.
    """
    measured = standing_blade_job("bull:8:1", 0.01, 0.02)
    volume = measured.volume()
    seeds, others = SearchSeeds.of(measured.surface, measured.chord)
    band = np.flatnonzero((seeds.t >= t_from) & (seeds.t < t_to))
    seeds = SearchSeeds(*(column[band] for column in seeds))
    for column in seeds:
        column.flags.writeable = False
    return measured, volume, seeds, others


@functools.cache
def bull_leading_edge_estimates(t_from: float, t_to: float) -> np.ndarray:
    """:func:`bull_leading_edge`'s seeds' flat and bull-nose estimates (every one tight:
    :func:`~toolpath.planning.cusp_estimates.torus_cusp_estimates`), once a session;
    read-only (a search that tightened them in place would fail, not change them)."""
    measured, volume, seeds, _ = bull_leading_edge(t_from, t_to)
    guess = torus_cusp_estimates(volume, measured.surface, seeds)
    guess.flags.writeable = False
    return guess


class KnownCusps:
    """A cusp search whose ray casts read known cusps (the full method's answer), and
    which records which seeds were cast."""

    def __init__(self, cusps_mm):
        self.cusps_mm = np.asarray(cusps_mm, dtype=float)
        self.cast = np.zeros(len(self.cusps_mm), dtype=bool)
        self.height = np.full(len(self.cusps_mm), np.nan)

    def run(self, rows):
        todo = rows & ~self.cast
        self.cast[todo] = True
        self.height[todo] = self.cusps_mm[todo]
