"""What a plan request assumes, and how a cutter is written (standard library only).

The defaults and the cutter-spec grammar that ``toolpath plan --help`` and ``verify
--help`` show, here so the help loads no numpy; the planner's modules import them from
here (:mod:`.resolution`, :mod:`.options`, :mod:`.cutters`).
"""

from __future__ import annotations

from typing import Final

__all__ = ["CUTTER_SPEC_HELP", "DEFAULT_FEED_MM_PER_MIN", "GOUGE_TOL_MM"]

GOUGE_TOL_MM: Final[float] = 1e-3
"""Penetration counted as a gouge, mm: the 1 um grid the G-code writes coordinates to
(rounding to it moves the cutter by up to about that: a shallower cut is not one a program
can avoid), far above the 1e-12 mm round-off of exact contacts, and a tenth of a finishing
chord tolerance (chords dip into convex surfaces by up to that by design)."""

DEFAULT_FEED_MM_PER_MIN: Final[float] = 1500.0
"""A finishing feed for a 6 mm carbide ball in steel or titanium at ~10 000 rpm
(0.05 mm/tooth, 3 flutes); the machine's rate limits slow it where needed."""

CUTTER_SPEC_HELP: Final[str] = (
    "KIND:DIAMETER[:CORNER_RADIUS][:flute=LENGTH], all in mm, the number after the kind "
    "being the DIAMETER (industry convention): ball:6 is a 6 mm ball-nose (radius 3 mm), "
    "flat:10 a 10 mm flat end mill, bull:10:2 a 10 mm bull-nose with a 2 mm corner radius; "
    "kinds: ball, flat, bull")
