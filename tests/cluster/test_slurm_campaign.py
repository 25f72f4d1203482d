"""The .test campaign through profiles/slurm on a real single-node SLURM, against a local run.

One module fixture runs two campaigns of .test/config.yaml from nothing to the C_eq table
(targets ``cases table``; the surrogate, optimum and figures would add a SLURM job of about a
minute here and test nothing more about the cluster), at the same time: a local one
(``--cores 2``, profiles/default) and one with ``--workflow-profile profiles/slurm`` on the
local SLURM (tests/cluster/local_slurm.py). While the SLURM campaign shakes its cases,
the SLURM job of one running case's LIGGGHTS is cancelled once with ``scancel``; the profile's
``retries: 1`` must resubmit it and the campaign must finish.

The status checks are made faster than the profile's (2 s instead of 40 s at first) so that the
test stays short; everything else is the profile as shipped.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import time
from pathlib import Path

import psutil
import pytest

from pidpipe.campaign import campaign_cases, read_record
from pidpipe.config import load_config
from tests._snakemake import SNAKEFILE, SNAKEMAKE, TEST_CONFIG, WORKFLOW_MARKS, snakemake_command
from tests.test_interruption import _running_liggghts, _table_values, _tail

PROFILE = Path(__file__).resolve().parents[2] / "profiles" / "slurm"
#: Faster status polling than the profile's, for the test only (s).
FAST_POLLING = ("--slurm-init-seconds-before-status-checks", "2",
                "--seconds-between-status-checks", "2")
TARGETS = ("cases", "table")
TIMEOUT_S = 900

pytestmark = [*WORKFLOW_MARKS, pytest.mark.slurm]


def slurm_command(workdir: Path, *args: str) -> list[str]:
    """The command line of a campaign in ``workdir`` through profiles/slurm (``args``: targets)."""
    return [str(SNAKEMAKE), *args, "--snakefile", str(SNAKEFILE), "--directory", str(workdir),
            "--workflow-profile", str(PROFILE), *FAST_POLLING]


def _start(command: list[str], workdir: Path, output: Path) -> subprocess.Popen:
    with open(output, "w") as handle:
        return subprocess.Popen(command, cwd=workdir, stdout=handle, stderr=subprocess.STDOUT,
                                start_new_session=True)


def _slurm_job_of(process: psutil.Process) -> str | None:
    """The SLURM job id in a process's environment (None once it has ended)."""
    try:
        return process.environ().get("SLURM_JOB_ID")
    except psutil.Error:
        return None


def _wait(process: subprocess.Popen, output: Path) -> None:
    try:
        process.wait(timeout=TIMEOUT_S)
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, 9)
        process.wait()
        pytest.fail(f"campaign did not end within {TIMEOUT_S} s:\n{_tail(output)}")


def submitted_jobs(output: str) -> list[tuple[str, str, Path]]:
    """(Snakemake job or group id, SLURM job id, SLURM log) of every submission, in order."""
    return [(job, slurm_id, Path(log)) for job, slurm_id, log in re.findall(
        r"Job (\S+) has been submitted with SLURM jobid (\d+) \(log: (\S+)\)\.", output)]


def cases_in_slurm_log(log: Path) -> set[str]:
    """The case records that the jobs of one SLURM job's log were to write."""
    return set(re.findall(r"output: results/cases/(\S+)\.json", log.read_text(errors="replace")))


@pytest.fixture(scope="module")
def campaigns(slurm_cluster, tmp_path_factory) -> dict:
    local = tmp_path_factory.mktemp("local")
    cluster = tmp_path_factory.mktemp("on_slurm")
    for workdir in (local, cluster):
        shutil.copy(TEST_CONFIG, workdir / "config.yaml")
    local_out, cluster_out = local / "snakemake.out", cluster / "snakemake.out"
    started = time.monotonic()
    local_run = _start(snakemake_command(local, *TARGETS), local, local_out)
    cluster_run = _start(slurm_command(cluster, *TARGETS), cluster, cluster_out)
    try:
        deadline = time.monotonic() + TIMEOUT_S
        cancelled = None
        while cancelled is None:
            if cluster_run.poll() is not None:
                pytest.fail(f"the SLURM campaign ended before any case ran:\n{_tail(cluster_out)}")
            if time.monotonic() > deadline:
                pytest.fail(f"no case's LIGGGHTS ran under SLURM within {TIMEOUT_S} s:\n"
                            f"{_tail(cluster_out)}\n{slurm_cluster.logs()}")
            for case_id, process in _running_liggghts(cluster).items():
                if (job := _slurm_job_of(process)) is not None:
                    cancelled = (job, case_id)
                    break
            time.sleep(0.2)
        scancel = slurm_cluster.command("scancel", cancelled[0])
        assert scancel.returncode == 0, scancel.stdout
        _wait(cluster_run, cluster_out)
        _wait(local_run, local_out)
    finally:
        for run in (local_run, cluster_run):
            if run.poll() is None:
                os.killpg(run.pid, 9)
                run.wait()
    print(f"\nlocal and SLURM campaigns side by side: {time.monotonic() - started:.0f} s")
    for run, out in ((local_run, local_out), (cluster_run, cluster_out)):
        assert run.returncode == 0, f"{out}:\n{_tail(out)}\n{slurm_cluster.logs()}"
    return {"local": local, "cluster": cluster, "output": cluster_out.read_text(),
            "cancelled_job": cancelled[0], "cancelled_case": cancelled[1]}


def _job_states(cluster) -> dict[str, str]:
    """SLURM job id -> state of every job the local SLURM still knows (MinJobAge keeps them)."""
    run = cluster.command("squeue", "--states=all", "--noheader", "--format=%i|%T")
    assert run.returncode == 0, run.stdout
    return dict(line.split("|") for line in run.stdout.split())


def test_every_case_ran_as_a_slurm_job(campaigns, slurm_cluster):
    """Each case is in the log of a SLURM job that Snakemake submitted and SLURM completed."""
    states = _job_states(slurm_cluster)
    ran = {}
    for _, slurm_id, log in submitted_jobs(campaigns["output"]):
        assert log.is_file(), f"no SLURM log {log}"
        assert log.is_relative_to(campaigns["cluster"] / ".snakemake" / "slurm_logs")
        if states.get(slurm_id) == "COMPLETED":
            for case_id in cases_in_slurm_log(log):
                ran.setdefault(case_id, []).append(slurm_id)
    expected = {case.case_id for case in campaign_cases(load_config(TEST_CONFIG))}
    assert set(ran) == expected
    assert all(len(jobs) == 1 for jobs in ran.values()), ran
    # Grouping: 8 cases in groups of 4 (profiles/slurm group-components) are 2 SLURM jobs.
    assert len({job for jobs in ran.values() for job in jobs}) == 2, ran


def test_table_equals_the_local_run_bit_for_bit_apart_from_timings(campaigns):
    local = _table_values(campaigns["local"] / "results" / "ceq_table.csv")
    cluster = _table_values(campaigns["cluster"] / "results" / "ceq_table.csv")
    assert cluster == local


def test_a_cancelled_case_job_is_retried_once_and_the_campaign_goes_on(campaigns, slurm_cluster):
    states = _job_states(slurm_cluster)
    submissions = submitted_jobs(campaigns["output"])
    cancelled = campaigns["cancelled_job"]
    assert states[cancelled] == "CANCELLED"
    group = next(job for job, slurm_id, _ in submissions if slurm_id == cancelled)
    resubmitted = [slurm_id for job, slurm_id, _ in submissions if job == group]
    assert resubmitted[0] == cancelled and len(resubmitted) == 2, submissions
    assert states[resubmitted[1]] == "COMPLETED"
    retried = next(log for _, slurm_id, log in submissions if slurm_id == resubmitted[1])
    assert campaigns["cancelled_case"] in cases_in_slurm_log(retried)
    assert "--attempt 2" in retried.read_text(errors="replace")
    record = read_record(campaigns["cluster"] / "results" / "cases"
                         / f"{campaigns['cancelled_case']}.json")
    assert record["status"] in ("ok", "flagged"), record["status"]
    assert "Error in group cases" in campaigns["output"]
