"""Issue 27: a flat or bull-nose cutter's fine refinement, its starts a group at a time.

Where the fine model's searches are lazy (:mod:`verification.fine_lazy`, which keeps the
fine pieces of the segments it needed up to a budget), the refinement takes its starts
through every fine level a group at a time (:func:`verification.extremes._start_groups`)
rather than each level for all the starts: a level of every start asked for the segments
round all of them, more than the budget holds, and each batch replayed what the level
before had dropped. The figures must be those of all the starts at once.
"""

import numpy as np
import pytest
from verify_programs import five_axis_cap

import verification.extremes as extremes
import verification.fine_lazy as fine_lazy
from machines import load_machine
from toolpath.planning.analytic import SpherePatch
from toolpath.planning.cutters import parse_cutter
from verification import VerifyOptions, verify_program
from verification.fine_model import FineModel


def _figures(report):
    """The refined extremes: value, parameters, block, shank."""
    return [None if e is None else (e.deviation_mm, e.t, e.s, e.block_index, e.shank)
            for e in (report.max_gouge, report.max_excess, report.max_scallop)]


@pytest.mark.parametrize("spec", ["flat:6", "bull:6:1"])
def test_starts_refined_a_group_at_a_time_give_the_figures_of_all_at_once(monkeypatch, spec):
    machine, cutter = load_machine("trunnion-ac"), parse_cutter(spec)
    # 5-axis passes 0.5 mm apart over a sphere, the axis leaning 10 deg along them and
    # turning with the normal; cut 3 um too deep, so there are gouges and cusps to refine
    radius_mm = 20.0
    program = five_axis_cap(machine, cutter, radius_mm - 0.003,
                            colatitudes_deg=np.arange(20.0, 30.0, np.degrees(0.5 / radius_mm)),
                            longitude_deg=(-12.0, 12.0), points=30, lead_deg=10.0)
    sphere = SpherePatch(radius_mm=radius_mm, colatitude_deg=(21.0, 29.0),
                         longitude_deg=(-8.0, 8.0))
    options = VerifyOptions(spacing_mm=0.1, refine=6)
    groups = []
    split = extremes._start_groups

    def spy(lazy, n):
        groups.append((n, []))
        for rows in split(lazy, n):
            groups[-1][1].append(rows)
            yield rows

    refine, drop = extremes._refine, fine_lazy.LazyFineSweeps._drop
    reports, starts, drops = {}, {}, []

    def counted_drop(self):
        drops.append(self)
        drop(self)

    for name in ("all at once", "a group at a time"):
        found = starts[name] = {}

        def each_start(ev, surface, samples, ti, si, conv, *, found=found, **kw):
            # every fine start's value, keyed by where it starts and its levels
            out = refine(ev, surface, samples, ti, si, conv, **kw)
            if kw.get("contacts") is not None:
                for k in range(ti.shape[0]):
                    found[(len(kw["scales"]), ti[k], si[k])] = (
                        out.dev[k], out.t[k], out.s[k], out.move[k], out.shank[k])
            return out

        with monkeypatch.context() as m:
            # lazy whatever the model's size; levels of 2 starts per batch, 12 segments kept
            m.setattr(FineModel, "builds_lazily", lambda self, rows: self.can_build_lazily)
            m.setattr(fine_lazy, "FINE_BATCH", 2 * 81)
            m.setattr(fine_lazy, "KEPT_PIECES", 20_000)
            m.setattr(extremes, "_refine", each_start)
            m.setattr(fine_lazy.LazyFineSweeps, "_drop", counted_drop)
            m.setattr(extremes, "_start_groups",
                      spy if name == "a group at a time" else lambda lazy, n: iter([np.arange(n)]))
            reports[name] = verify_program(program, sphere, machine, cutter, options=options)
    once, grouped = (_figures(reports[k]) for k in ("all at once", "a group at a time"))
    assert once[0] is not None and once[2] is not None  # a gouge and a scallop refined
    assert grouped == once
    # each start's own value the same, at its own levels (2 refinements x 12 starts x 2;
    # fewer keys where a coarse end is its grid start)
    assert len(starts["all at once"]) > 24
    assert starts["a group at a time"] == starts["all at once"]
    assert drops  # the budget held less than the segments asked for
    # every refinement in groups of coarse ends and their grid starts, each start once
    assert groups and all(len(g) > 1 for _, g in groups)
    for n, g in groups:
        assert np.array_equal(np.sort(np.concatenate(g)), np.arange(n))
        assert all(np.array_equal(rows[len(rows) // 2:], rows[:len(rows) // 2] + n // 2)
                   for rows in g)
