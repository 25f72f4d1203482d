"""The .test campaign through profiles/slurm on a real single-node SLURM, against a local run.

One module fixture runs two campaigns of .test/config.yaml from nothing to the C_eq table
(targets ``cases table``; the surrogate, optimum and figures would add a SLURM job of about a
minute here and test nothing more about the cluster), at the same time: a local one
(``--cores 2``, profiles/default) and one with ``--workflow-profile profiles/slurm`` on the
local SLURM (tests/cluster/local_slurm.py). While the SLURM campaign runs:

1. the SLURM job of the first case whose LIGGGHTS runs is cancelled with ``scancel``; the
   profile's ``retries: 1`` must resubmit it (attempt 2) and the campaign must go on;
2. once Snakemake has finished a case job and another case's LIGGGHTS runs under SLURM,
   Snakemake is interrupted (SIGINT, as Ctrl-C on the login node): it must cancel its SLURM
   jobs, and the same command run again must redo exactly the cases it had not finished.

Three settings differ from the profile, for a short test: faster status checks (2 s instead of
10 s at first), kept at 2 s (tests/cluster/steady_polling.py: the plugin waits 10 s longer
after each check that sees no job end, which made the test about 25 s longer), and 2 cases per
job instead of 4 (so that a job finishes while others still run).
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import psutil
import pytest
import yaml

from pidpipe.config import load_config
from pidpipe.design.records import read_record
from pidpipe.steps.params import campaign_cases
from tests._snakemake import (
    SNAKEFILE,
    TEST_CONFIG,
    WORKFLOW_MARKS,
    sigint_as_from_a_terminal,
    snakemake_command,
)
from tests.workflow.test_interruption import (
    _case_jobs,
    _finished_cases,
    _name,
    _processes_in,
    _running_liggghts,
    _table_values,
    _tail,
)

PROFILE = Path(__file__).resolve().parents[2] / "profiles" / "slurm"
STEADY_POLLING = Path(__file__).resolve().with_name("steady_polling.py")
#: Faster status polling than the profile's, for the test only (s).
FAST_POLLING = ("--slurm-init-seconds-before-status-checks", "2",
                "--seconds-between-status-checks", "2")
CASES_PER_JOB = 2
TARGETS = ("cases", "table")
TIMEOUT_S = 900

pytestmark = [*WORKFLOW_MARKS, pytest.mark.slurm]


def slurm_command(workdir: Path, *args: str) -> list[str]:
    """The command line of a campaign in ``workdir`` through profiles/slurm (``args``: targets):
    Snakemake with steady status checks (tests/cluster/steady_polling.py)."""
    return [sys.executable, str(STEADY_POLLING), *args, "--snakefile", str(SNAKEFILE),
            "--directory", str(workdir), "--workflow-profile", str(PROFILE), *FAST_POLLING,
            "--group-components", f"cases={CASES_PER_JOB}"]


#: Measured cycles of this test's cases: the reduced campaign's 10 make a case last about a
#: second, too short for the test to see a resubmitted job's case running before it ends (the
#: campaign twice ended first in runs of the whole suite on an idle machine).
MEASURED_CYCLES = 40


def _write_slow_config(path: Path) -> None:
    """The reduced campaign's config with MEASURED_CYCLES per case."""
    config = yaml.safe_load(TEST_CONFIG.read_text(encoding="utf-8"))
    config["fidelity"]["measured_cycles"] = MEASURED_CYCLES
    path.write_text(yaml.safe_dump(config, sort_keys=False), encoding="utf-8")


def _start(command: list[str], workdir: Path, output: Path) -> subprocess.Popen:
    with open(output, "w") as handle:
        return subprocess.Popen(command, cwd=workdir, stdout=handle, stderr=subprocess.STDOUT,
                                start_new_session=True, preexec_fn=sigint_as_from_a_terminal)


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


def cases_finished_in_slurm_log(log: Path) -> set[str]:
    """The cases whose simulate_case job finished inside one SLURM job, from its log.

    Inside the job, Snakemake runs each job of the group in a Snakemake of its own, which opens
    with Snakemake's banner, lists its one job as a ``localrule`` and numbers it 0; the group's
    own lines are interleaved with theirs.
    """
    field = r"(?:[ \t]+\w+: .*\n)*?"
    finished = set()
    for run in re.split(r"^SNAKEMAKE\n=+$", log.read_text(errors="replace"), flags=re.MULTILINE):
        for job in re.finditer(rf"localrule simulate_case:\n{field}[ \t]+output: "
                               rf"results/cases/(\S+)\.json\n{field}[ \t]+jobid: (\d+)\n", run):
            if f"Finished jobid: {job[2]} (Rule: simulate_case)" in run[job.end():]:
                finished.add(job[1])
    return finished


def _slurm_liggghts(workdir: Path) -> dict[str, str]:
    """Case id -> SLURM job id of every case whose LIGGGHTS runs in a SLURM job in ``workdir``."""
    jobs = {case_id: _slurm_job_of(process) for case_id, process in _running_liggghts(workdir).items()}
    return {case_id: job for case_id, job in jobs.items() if job is not None}


def _poll(condition, what: str, process: subprocess.Popen, output: Path, cluster):
    """``condition()`` once it is true; fails if ``process`` ends first or after TIMEOUT_S."""
    deadline = time.monotonic() + TIMEOUT_S
    while not (value := condition()):
        if process.poll() is not None:
            pytest.fail(f"the SLURM campaign ended before {what}:\n{_tail(output)}")
        if time.monotonic() > deadline:
            pytest.fail(f"no {what} within {TIMEOUT_S} s:\n{_tail(output)}\n{cluster.logs()}")
        time.sleep(0.2)
    return value


@pytest.fixture(scope="module")
def campaigns(slurm_cluster, tmp_path_factory) -> dict:
    local = tmp_path_factory.mktemp("local")
    cluster = tmp_path_factory.mktemp("on_slurm")
    for workdir in (local, cluster):
        _write_slow_config(workdir / "config.yaml")
    local_out, cluster_out = local / "snakemake.out", cluster / "interrupted.out"
    resumed_out = cluster / "resumed.out"
    started = time.monotonic()
    local_run = _start(snakemake_command(local, *TARGETS), local, local_out)
    cluster_run = _start(slurm_command(cluster, *TARGETS), cluster, cluster_out)
    try:
        running = _poll(lambda: _slurm_liggghts(cluster), "case's LIGGGHTS under SLURM",
                        cluster_run, cluster_out, slurm_cluster)
        cancelled_case, cancelled_job = sorted(running.items())[0]
        scancel = slurm_cluster.command("scancel", cancelled_job)
        assert scancel.returncode == 0, scancel.stdout

        def retry_job():
            submissions = submitted_jobs(cluster_out.read_text())
            group = next((job for job, slurm_id, _ in submissions if slurm_id == cancelled_job), None)
            again = [slurm_id for job, slurm_id, _ in submissions
                     if job == group and slurm_id != cancelled_job]
            return again[0] if again else None

        def mid_campaign():
            # a case job finished, and the resubmitted job is running a case
            finished = _finished_cases(cluster_out.read_text())
            retry = retry_job()
            running = {case for case, job in _slurm_liggghts(cluster).items() if job == retry}
            return (finished, retry) if finished and running else None

        finished_then, retry = _poll(mid_campaign, "finished case job while the resubmitted one runs",
                                     cluster_run, cluster_out, slurm_cluster)
        cluster_run.send_signal(signal.SIGINT)
        _wait(cluster_run, cluster_out)
        interrupted = cluster_out.read_text()
        records_then = {path.stem: path.read_bytes()
                        for path in (cluster / "results" / "cases").glob("*.json")}
        left = slurm_cluster.command("squeue", "--noheader", "--format=%i|%T")
        deadline = time.monotonic() + 60
        while left.stdout.strip() and time.monotonic() < deadline:
            time.sleep(1)
            left = slurm_cluster.command("squeue", "--noheader", "--format=%i|%T")
        deadline = time.monotonic() + 60
        while (leftover := _processes_in(cluster)) and time.monotonic() < deadline:
            time.sleep(1)
        leftover = [(process.pid, _name(process)) for process in leftover]
        resumed_run = _start(slurm_command(cluster, *TARGETS), cluster, resumed_out)
        _wait(resumed_run, resumed_out)
        _wait(local_run, local_out)
    finally:
        for run in (local_run, cluster_run):
            if run.poll() is None:
                os.killpg(run.pid, 9)
                run.wait()
    print(f"\nlocal and SLURM campaigns side by side, SLURM interrupted and resumed: "
          f"{time.monotonic() - started:.0f} s")
    assert local_run.returncode == 0, f"{local_out}:\n{_tail(local_out)}"
    assert resumed_run.returncode == 0, f"{resumed_out}:\n{_tail(resumed_out)}\n{slurm_cluster.logs()}"
    return {"local": local, "cluster": cluster, "interrupted": interrupted,
            "resumed": resumed_out.read_text(), "cancelled_job": cancelled_job,
            "cancelled_case": cancelled_case, "retry_job": retry, "finished_then": finished_then,
            "records_then": records_then, "left_in_queue": left.stdout.strip(),
            "left_running": leftover,
            "interrupted_status": cluster_run.returncode}


def _job_states(cluster) -> dict[str, str]:
    """SLURM job id -> state of every job the local SLURM still knows (MinJobAge keeps them)."""
    run = cluster.command("squeue", "--states=all", "--noheader", "--format=%i|%T")
    assert run.returncode == 0, run.stdout
    return dict(line.split("|") for line in run.stdout.split())


def test_every_case_ran_as_a_slurm_job(campaigns, slurm_cluster):
    """Each case finished inside a SLURM job that Snakemake submitted, and the jobs hold several
    cases each (grouping)."""
    states = _job_states(slurm_cluster)
    ran = {}
    for run in ("interrupted", "resumed"):
        for _, slurm_id, log in submitted_jobs(campaigns[run]):
            assert log.is_relative_to(campaigns["cluster"] / ".snakemake" / "slurm_logs")
            assert slurm_id in states
            if states[slurm_id] == "COMPLETED":
                assert log.is_file(), f"no SLURM log {log}"
            if log.is_file():  # (a job cancelled while pending has none)
                for case_id in cases_finished_in_slurm_log(log):
                    ran.setdefault(case_id, []).append(slurm_id)
    expected = {case.case_id for case in campaign_cases(load_config(TEST_CONFIG))}
    assert set(ran) == expected
    per_job = {}
    for case_id, jobs in ran.items():
        for job in jobs:
            per_job.setdefault(job, set()).add(case_id)
    assert max(len(cases) for cases in per_job.values()) == CASES_PER_JOB, per_job
    for case_id in expected:
        assert (campaigns["cluster"] / "logs" / "simulate_case" / f"{case_id}.log").is_file()


def test_table_equals_the_local_run_bit_for_bit_apart_from_timings(campaigns):
    local = _table_values(campaigns["local"] / "results" / "ceq_table.csv")
    cluster = _table_values(campaigns["cluster"] / "results" / "ceq_table.csv")
    assert cluster == local


def test_a_cancelled_case_job_is_resubmitted_once_and_the_campaign_goes_on(campaigns,
                                                                          slurm_cluster):
    states = _job_states(slurm_cluster)
    submissions = submitted_jobs(campaigns["interrupted"])
    cancelled, retry = campaigns["cancelled_job"], campaigns["retry_job"]
    assert states[cancelled] == "CANCELLED"
    assert "Error in group cases" in campaigns["interrupted"]
    group = next(job for job, slurm_id, _ in submissions if slurm_id == cancelled)
    assert [slurm_id for job, slurm_id, _ in submissions if job == group] == [cancelled, retry]
    log = next(log for _, slurm_id, log in submissions if slurm_id == retry)
    assert campaigns["cancelled_case"] in cases_in_slurm_log(log)
    assert "--attempt 2" in log.read_text(errors="replace")
    # the other jobs went on: case jobs finished after the cancellation, in the same run
    assert campaigns["finished_then"]
    record = read_record(campaigns["cluster"] / "results" / "cases"
                         / f"{campaigns['cancelled_case']}.json")
    assert record.status in ("ok", "flagged"), record.status


def test_an_interrupted_campaign_cancels_its_jobs_and_resumes_with_only_the_missing_cases(
        campaigns):
    """After Ctrl-C no SLURM job is left; the resumed run redoes every case without a record and
    none that Snakemake had finished. A case that finished inside a job that the interruption
    cancelled keeps its record (its Snakemake inside the job had marked it finished)."""
    assert campaigns["interrupted_status"] != 0
    assert campaigns["left_in_queue"] == "", "SLURM jobs left after Snakemake was interrupted"
    assert campaigns["left_running"] == [], "processes left in the campaign's folder"
    finished = _finished_cases(campaigns["interrupted"])
    records_then = campaigns["records_then"]
    assert campaigns["finished_then"] <= finished <= set(records_then)
    expected = {case.case_id for case in campaign_cases(load_config(TEST_CONFIG))}
    redone = set(_case_jobs(campaigns["resumed"]).values())
    assert expected - set(records_then) <= redone <= expected - finished, (
        sorted(redone), sorted(finished), sorted(records_then))
    for case_id, content in records_then.items():
        if case_id not in redone:
            path = campaigns["cluster"] / "results" / "cases" / f"{case_id}.json"
            assert path.read_bytes() == content, f"{case_id}: kept record rewritten"
