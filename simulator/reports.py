r"""GRBL 1.1 report texts: status report, ``$G``, ``$#``, ``$I``, banner and messages.

Formats follow grbl 1.1h ``report.c`` and ``doc/markdown/interface.md``: coordinates with
3 decimals, feed and spindle speed without decimals, fields separated by ``|``, every
line ended by ``\r\n``. ``WCO:`` is added every 10 reports when idle and every 30 when
busy, ``Ov:`` (with ``A:`` accessories) every 10 / 20, as grbl's refresh counters do.

Examples
--------
>>> format_coords((1.0, -0.0001, 2.5))
'1.000,0.000,2.500'
"""

from __future__ import annotations

from gcode.modal import ModalState, MotionMode
from gcode.program import DistanceMode, FeedMode, SpindleDirection, Units
from machines import MM_PER_INCH

__all__ = [
    "BANNER",
    "BUILD_DATE",
    "HELP",
    "VERSION",
    "StatusCounters",
    "accessories",
    "format_build_info",
    "format_coords",
    "format_gcode_state",
    "format_offsets",
    "format_status",
]

VERSION = "1.1h"
BUILD_DATE = "20190830"
#: The welcome line (grbl prints ``\r\n`` before it): a reset happened.
BANNER = f"Grbl {VERSION} ['$' for help]"
HELP = "[HLP:$$ $# $G $I $N $x=val $Nx=line $J=line $SLP $C $X $H ~ ! ? ctrl-x]"

_WCO_IDLE, _WCO_BUSY = 10, 30
_OVR_IDLE, _OVR_BUSY = 10, 20


def format_coords(values: tuple[float, ...] | list[float]) -> str:
    """Comma-separated values with 3 decimals and no ``-0.000``."""
    out = []
    for v in values:
        t = f"{v:.3f}"
        out.append("0.000" if t == "-0.000" else t)
    return ",".join(out)


class StatusCounters:
    """grbl's WCO and override refresh counters (which report carries ``WCO:``/``Ov:``)."""

    def __init__(self) -> None:
        self.wco = 0
        self.ovr = 0

    def reset(self) -> None:
        """After a reset the next report carries ``WCO:`` again."""
        self.wco = 0
        self.ovr = 0

    def next(self, busy: bool) -> tuple[bool, bool]:
        """Return (show WCO, show Ov) for the next report and count it."""
        show_wco = show_ovr = False
        if self.wco > 0:
            self.wco -= 1
        else:
            show_wco = True
            self.wco = (_WCO_BUSY if busy else _WCO_IDLE) - 1
        if self.ovr > 0:
            self.ovr -= 1
        elif not show_wco:
            show_ovr = True
            self.ovr = (_OVR_BUSY if busy else _OVR_IDLE) - 1
        return show_wco, show_ovr


def format_status(
    state: str,
    mpos: tuple[float, ...],
    wco: tuple[float, ...],
    *,
    machine_position: bool,
    buffer: tuple[int, int] | None,
    feed_mm_per_min: float,
    rpm: float,
    show_wco: bool,
    show_ovr: bool,
    accessories: str = "",
) -> str:
    """One status report, without the line end.

    Parameters
    ----------
    state : str
        ``Idle``, ``Run``, ``Hold:0``, ``Hold:1``, ``Alarm`` or ``Check``.
    mpos, wco : tuple of float
        Machine position and work offset (mm, deg).
    machine_position : bool
        ``$10`` bit 0: MPos (else WPos = MPos - WCO).
    buffer : (int, int) or None
        Free planner blocks and free RX bytes (``Bf:``), None to omit.
    feed_mm_per_min, rpm : float
        Current feed and spindle speed.
    show_wco, show_ovr : bool
        Add ``WCO:`` or ``Ov:`` (from :class:`StatusCounters`).
    accessories : str
        ``A:`` letters (S, C, F, M) shown with ``Ov:``.

    Returns
    -------
    str
        ``<Idle|MPos:0.000,0.000,0.000|Bf:15,128|FS:0,0|WCO:0.000,0.000,0.000>``.
    """
    if machine_position:
        parts = [state, "MPos:" + format_coords(mpos)]
    else:
        parts = [
            state,
            "WPos:" + format_coords(tuple(m - w for m, w in zip(mpos, wco, strict=True))),
        ]
    if buffer is not None:
        parts.append(f"Bf:{buffer[0]},{buffer[1]}")
    parts.append(f"FS:{feed_mm_per_min:.0f},{rpm:.0f}")
    if show_wco:
        parts.append("WCO:" + format_coords(wco))
    elif show_ovr:
        parts.append("Ov:100,100,100")
        if accessories:
            parts.append("A:" + accessories)
    return "<" + "|".join(parts) + ">"


def accessories(state: ModalState) -> str:
    """``A:`` letters of a modal state: S/C spindle CW/CCW, F flood, M mist."""
    out = ""
    if state.spindle is SpindleDirection.CW:
        out += "S"
    elif state.spindle is SpindleDirection.CCW:
        out += "C"
    if state.flood:
        out += "F"
    if state.mist:
        out += "M"
    return out


def format_gcode_state(state: ModalState) -> str:
    """``[GC:...]`` for ``$G`` (feed in the active units per minute, grbl style)."""
    motion = {MotionMode.RAPID: "G0", MotionMode.LINEAR: "G1", MotionMode.ARC_CW: "G2",
              MotionMode.ARC_CCW: "G3"}[state.motion]  # fmt: skip
    words = [
        motion,
        f"G{53 + state.wcs}",
        f"G{int(state.plane)}",
        "G20" if state.units is Units.INCH else "G21",
        "G91" if state.distance is DistanceMode.INCREMENTAL else "G90",
        "G93" if state.feed_mode is FeedMode.INVERSE_TIME else "G94",
        f"M{int(state.spindle)}",
    ]
    if state.mist or state.flood:
        if state.mist:
            words.append("M7")
        if state.flood:
            words.append("M8")
    else:
        words.append("M9")
    feed = state.feed or 0.0
    if state.units is Units.INCH and state.feed_mode is FeedMode.UNITS_PER_MINUTE:
        feed /= MM_PER_INCH
    words += [f"T{state.tool}", f"F{feed:.0f}", f"S{state.rpm:.0f}"]
    return "[GC:" + " ".join(words) + "]"


def format_offsets(offsets: dict[int, tuple[float, ...]], idx: tuple[int, ...]) -> list[str]:
    """``$#`` lines: G54-G59, G28, G30, G92, TLO, PRB (reported axes only)."""
    zero = format_coords([0.0] * len(idx))
    lines = [
        f"[G{53 + k}:" + format_coords([offsets[k][i] for i in idx]) + "]" for k in range(1, 7)
    ]
    lines += [f"[G28:{zero}]", f"[G30:{zero}]", f"[G92:{zero}]", "[TLO:0.000]", f"[PRB:{zero}:0]"]
    return lines


def format_build_info(planner_blocks: int, rx_bytes: int) -> list[str]:
    """``$I`` lines: version and options (``V`` variable spindle, planner, RX size)."""
    return [f"[VER:{VERSION}.{BUILD_DATE}:]", f"[OPT:V,{planner_blocks},{rx_bytes}]"]
