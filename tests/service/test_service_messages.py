"""Library messages reach a job's client with the JSON fields, not command-line flags."""

from streamline_cam.service.runner import as_job_fields


def test_flags_in_messages_become_job_fields():
    text = ("the ball:6 cutter would cut 0.0589 mm into the surface; use --on-gouge lift "
            "(lifts the cutter clear), or --gouge-tol above 0.0589 mm; increase --clearance "
            "or --approach, or --on-limit report; move the part (--translate)")
    assert as_job_fields(text) == (
        "the ball:6 cutter would cut 0.0589 mm into the surface; use "
        'planning_options.on_gouge="lift" (lifts the cutter clear), or '
        "planning_options.gouge_tol_mm above 0.0589 mm; increase planning_options.clearance_mm "
        'or planning_options.approach_mm, or planning_options.on_limit="report"; move the '
        "part (--translate)")
