"""The verification verdict: what the verifier measured against what the job asked for.

One implementation for the command line (``toolpath run --verify`` exits 1 when the
program exceeds the request) and the service (the job's ``verdict`` and ``summary``).
The deepest gouge is held to the chord tolerance (chords cut into a convex surface by up
to that much by design; the plan keeps room for the G-code's rounding), the largest
scallop between passes to the scallop asked for.
"""

from __future__ import annotations

from typing import Any

__all__ = ["plan_excess", "report_verdict", "verdict_summary", "verify_excess",
           "verify_verdict"]


def verify_verdict(report: dict[str, Any]) -> dict[str, Any] | None:
    """Pass or fail of a job's verified program against its request; None unverified.

    ``report`` is the pipeline's (``plan`` and ``verify`` sections). Returns ``ok``, the
    figures held to each limit (``gouge_mm`` to ``chord_tol_mm``, ``scallop_mm`` to
    ``scallop_request_mm``) and ``exceeds``: one line per limit exceeded, naming the
    command-line flag that sets it and the G-code line where the verifier found it.
    """
    verify, plan = report.get("verify"), report.get("plan") or {}
    if not verify:
        return None
    over = []
    gouge = float(verify.get("max_gouge_mm") or 0.0)
    chord = float(plan["chord_tol_mm"])
    if gouge > chord:
        where = verify.get("max_gouge") or {}
        over.append(f"deepest gouge {gouge:.4f} mm exceeds the chord tolerance {chord:g} mm "
                    "(--chord-tol)" + (f" at line {where['line']}" if where.get("line") else ""))
    scallop = float(verify.get("max_scallop_mm") or 0.0)
    asked = float(plan["scallop_request_mm"])
    if scallop > asked:
        where = verify.get("max_scallop") or {}
        over.append(f"scallop {scallop:.4f} mm exceeds the {asked:g} mm asked (--scallop)"
                    + (f" at line {where['line']}" if where.get("line") else ""))
    return {"ok": not over, "gouge_mm": gouge, "chord_tol_mm": chord, "scallop_mm": scallop,
            "scallop_request_mm": asked, "exceeds": over}


def report_verdict(report: dict[str, Any] | None) -> dict[str, Any] | None:
    """The verdict a job's report carries (:func:`verify_verdict`, set by ``run_job``)."""
    return ((report or {}).get("verify") or {}).get("verdict")


def verify_excess(report: dict[str, Any]) -> str | None:
    """What the verifier measured beyond the request, in one line; None when nothing was."""
    verdict = report_verdict(report) or verify_verdict(report)
    if verdict is None or verdict["ok"]:
        return None
    return "; ".join(verdict["exceeds"])


def verdict_summary(verdict: dict[str, Any]) -> str:
    """The verdict in one line: the figures within the request, or what exceeds it."""
    if not verdict["ok"]:
        return "the program exceeds the request: " + "; ".join(verdict["exceeds"])
    return (f"verified: deepest gouge {verdict['gouge_mm']:.4f} mm within the chord tolerance "
            f"{verdict['chord_tol_mm']:g} mm, scallop {verdict['scallop_mm']:.4f} mm within the "
            f"{verdict['scallop_request_mm']:g} mm asked")


def plan_excess(report: dict[str, Any]) -> str | None:
    """What the plan's own measurement found beyond the request, in one line; None if nothing.

    For a job not verified: the plan's scallop away from uncut areas (where a re-plan can
    lower it; the largest where there is no such figure) against the user's scallop, its
    chord error against the chord tolerance, as ``toolpath plan`` judges its exit code.
    A job may keep a plan over the request: re-planned tighter, the nearest was kept, or
    the excess was too large to re-plan (the propeller with flat:6 in 5 axes, scallop
    0.01 mm: 0.0152 mm at its leading edge).
    """
    plan, request = report.get("plan") or {}, report.get("request") or {}
    over = []
    scallop = plan.get("scallop_interior_mm")
    scallop = plan.get("max_scallop_mm") if scallop is None else scallop
    above = plan.get("scallop_horizon_mm") if plan.get("scallop_above_horizon") else None
    asked = request.get("scallop_mm", plan.get("scallop_request_mm"))
    if scallop is None and above is not None and asked is not None:
        over.append(f"scallop above {above:g} mm (the measure's horizon) exceeds the "
                    f"{asked:g} mm asked (--scallop)")
    elif scallop is not None and asked is not None and scallop > asked:
        at = plan.get("scallop_at")
        over.append(f"scallop {scallop:.4f} mm exceeds the {asked:g} mm asked (--scallop)"
                    + (f" at t={at[0]:.4f}, s={at[1]:.4f}" if at else ""))
    chord = plan.get("max_chord_error_mm")
    tol = request.get("chord_tol_mm", plan.get("chord_tol_mm"))
    if chord is not None and tol is not None and chord > tol:
        over.append(f"chord error {chord:.4f} mm exceeds the chord tolerance {tol:g} mm "
                    "(--chord-tol)")
    if over and plan.get("replan_stopped"):
        over.append(plan["replan_stopped"])
    return "; ".join(over) or None
