"""``toolpath warm-up``: jobs of both kinds of blade, 3-axis and 5-axis (issue 27)."""

from streamline_cam.cli import main
from streamline_cam.warmup import WARM_JOBS
from toolpath import as_sections, read_sections
from toolpath.paper_examples import bundled_data_path


def test_the_warm_up_jobs_cover_open_and_closed_blades_3_and_5_axis():
    kinds = {}
    for _label, name, machine, axis_mode, _verify in WARM_JOBS:
        kinds[axis_mode] = (as_sections(read_sections(bundled_data_path(name))).closed, machine)
    # 3-axis on the open development blade, 5-axis (a spiral) round closed sections
    assert kinds == {"3": (False, "grbl-router"), "lead-tilt": (True, "trunnion-ac")}
    assert any(job[-1] for job in WARM_JOBS)  # the verifier is reached too


def test_warm_up_is_a_documented_command(capsys):
    try:
        main(["warm-up", "--help"])
    except SystemExit as stop:
        assert stop.code == 0
    assert "compile" in capsys.readouterr().out


def test_jobs_a_failed_worker_pool_did_not_finish_run_in_this_process(monkeypatch):
    from streamline_cam import warmup

    ran, said = [], []

    def pool_that_breaks(workers, folder, say, pending):
        say(warmup._warm_job(0, folder))  # the first job finished in a worker
        pending.discard(0)
        raise OSError("no /dev/shm")

    def job(index, folder):
        ran.append(index)
        return f"job {index} done"

    monkeypatch.setattr(warmup, "_in_processes", pool_that_breaks)
    monkeypatch.setattr(warmup, "_warm_job", job)
    warmup.warm_up(said.append, processes=2)
    assert ran == list(range(len(WARM_JOBS)))  # each job once: none lost, none repeated
    assert any("worker process failed (no /dev/shm)" in line for line in said)
