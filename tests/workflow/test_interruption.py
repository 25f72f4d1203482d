"""Interrupting the campaign, resuming it and reproducing it, with the real LIGGGHTS (issue 6).

A tiny campaign runs to its C_eq table (targets ``cases table``: one frequency gives no
surrogate to fit): 1000 Hz x (5, 10) g x (25, 50) % fill, 20 transient + 10 measured cycles,
i.e. four simulate_case jobs of about 3 s, two at a time on 2 cores. Its two packings are
poured once (``poured``); the reference campaign and every interrupted one start from a copy of
that folder. A second campaign (``fresh``) runs from nothing in its own folder.

Faults injected while the simulate_case jobs run, i.e. once Snakemake has finished at least one
case and at least one case's LIGGGHTS is still running (the tests poll results/cases, the
processes' working folders and Snakemake's output; no fixed sleep):

- Ctrl-C: SIGINT to Snakemake's process group; the jobs and their LIGGGHTS die at once.
- ``kill -INT`` of Snakemake alone: it stops and waits for the running jobs, whose records
  are then complete but never marked finished.
- ``kill`` (SIGTERM) of Snakemake alone: it lets the running jobs finish and records them.
- ``kill -9`` of Snakemake's process group: nothing cleans up.
- ``kill -9`` of one case's LIGGGHTS process, once (the retry succeeds) and twice (the case is
  recorded as failed and the campaign goes on).

What the pipeline guarantees, and these tests check: every file results/cases/*.json that an
interruption leaves is a complete record (temporary ``.part`` files are never taken for one);
the records of finished jobs are kept untouched (inode, mtime, bytes); a plain
``snakemake --cores 2 cases table`` runs exactly the cases that were not finished; and the resumed
campaign's C_eq table and records equal an uninterrupted campaign's bit for bit, timing aside.

Two things the next run needs to know, and how the pipeline handles them:

- A job that wrote its record but was stopped before Snakemake marked it finished leaves the
  record marked incomplete (always after ``kill -INT`` of Snakemake, and whenever a signal
  lands in that gap). Snakemake cannot tell such a record from a half-written output and, by
  default, refuses to start until it is given ``--rerun-incomplete``. ``profiles/default``
  (read by every ``snakemake`` run of this Snakefile) sets ``rerun-incomplete``, so a plain
  run redoes these cases: the cost is at most the jobs that were running.
- ``kill -9`` leaves Snakemake's lock behind, and the next run refuses to start until
  ``snakemake --unlock``. The lock records no process id, so no tool can tell it from the lock
  of a run that is still going; unlocking automatically would let two runs write the same
  files, so the pipeline leaves that step to the user.
"""

from __future__ import annotations

import base64
import csv
import json
import math
import os
import re
import shutil
import signal
import subprocess
import time
from pathlib import Path

import psutil  # a dependency of snakemake
import pytest

from pidpipe.design.records import read_record
from tests._snakemake import (
    WORKFLOW_MARKS,
    planned_jobs,
    sigint_as_from_a_terminal,
    snakemake,
    snakemake_command,
    write_config,
)

pytestmark = WORKFLOW_MARKS

GRID = {"freq_hz": [1000], "accel_g": [5, 10], "fill_pct": [25, 50]}
#: 20 + 80 cycles make a case last a few seconds (with 10 measured cycles, under one): the test
#: signals while a case runs, and a longer case leaves it a wider window.
FIDELITY = {"transient_cycles": 20, "transient_min_time_s": 0.0, "measured_cycles": 80}
CASES = frozenset(f"f1000Hz_G{accel}_r{fill}pct_rep0" for accel in (5, 10) for fill in (25, 50))
#: Table columns that must be among those compared: values, errors, flags, fidelity.
VALUE_COLUMNS = ("case_id", "status", "flags", "n_replicates", "ceq_coupon_ns_m",
                 "ceq_coupon_sem_ns_m", "ceq_cell_ns_m", "ceq_cell_sem_ns_m", "ed_cycle_mean_j",
                 "ed_cycle_sem_j", "n_cycles", "n_spheres", "dt_s", "dt_rayleigh_fraction",
                 "steps_per_cycle", "youngs_modulus_scale", "transient_cycles", "measured_cycles",
                 "sem_block_cycles", "rotation", "friction", "seed", "liggghts_version")
#: What every run builds: the case records (rule ``cases``, so that a deleted record is rerun
#: even though the table is up to date) and the C_eq table; one frequency gives no surrogate.
TARGETS = ("cases", "table")
POLL_S = 0.05
TIMEOUT_S = 180.0


# --------------------------------------------------------------------------------------------
# Helpers


def _copy(source: Path, target: Path) -> Path:
    """A copy of a campaign folder, Snakemake's metadata and file times included."""
    shutil.copytree(source, target, symlinks=True)
    return target


def _records(workdir: Path) -> dict[str, Path]:
    """Case id -> record file, for every results/cases/*.json."""
    return {path.stem: path for path in (workdir / "results" / "cases").glob("*.json")}


def _marked_incomplete(workdir: Path) -> set[str]:
    """The outputs that Snakemake's bookkeeping holds incomplete: one file each in
    .snakemake/incomplete, named by the output's path in URL-safe base64 (a long name split
    into '@'-prefixed folders). A job's marker goes when Snakemake post-processes it."""
    root = workdir / ".snakemake" / "incomplete"
    if not root.is_dir():
        return set()
    return {base64.urlsafe_b64decode("".join(part.lstrip("@") for part in
                                             path.relative_to(root).parts)).decode()
            for path in root.rglob("*") if path.is_file() and path.name != "migration_underway"}


def _completed_cases(workdir: Path) -> set[str]:
    """The cases whose job Snakemake has post-processed: a record, and no incomplete marker.

    Snakemake post-processes a finished job (its marker removed) before it prints "Finished
    jobid" (snakemake.scheduling.job_scheduler, _finish_jobs), so a signal between the two
    leaves a case completed that its output never calls finished; the resume rightly skips it.
    """
    incomplete = _marked_incomplete(workdir)
    return {case_id for case_id in _records(workdir)
            if not any(key.endswith(f"results/cases/{case_id}.json") for key in incomplete)}


def _processes_in(folder: Path) -> list[psutil.Process]:
    """Live processes whose working directory is ``folder`` or below it (zombies have none).

    Only the working directory is read for every process (about 2 ms for 100 processes),
    so that polling costs little CPU.
    """
    inside = f"{folder}{os.sep}"
    return [process for process in psutil.process_iter(["cwd"])
            if (cwd := process.info["cwd"]) and (cwd == str(folder) or cwd.startswith(inside))]


def _name(process: psutil.Process) -> str:
    """A process's name, or "" once it has ended."""
    try:
        return process.name()
    except psutil.Error:  # it has ended
        return ""


def _running_liggghts(workdir: Path) -> dict[str, psutil.Process]:
    """Case id -> its LIGGGHTS process, for every case whose LIGGGHTS is running."""
    cases = workdir / "results" / "work" / "cases"
    return {Path(p.info["cwd"]).name: p for p in _processes_in(cases) if _name(p) == "liggghts"}


def _case_jobs(output: str) -> dict[str, str]:
    """Job id -> case id of every simulate_case job that a Snakemake run started."""
    field = r"(?:[ \t]+\w+: .*\n)*?"  # any other fields of the job, in any order
    jobs = re.findall(rf"rule simulate_case:\n{field}[ \t]+output: results/cases/(\S+)\.json\n"
                      rf"{field}[ \t]+jobid: (\d+)\n", output)
    return {jobid: case_id for case_id, jobid in jobs}


def _finished_cases(output: str) -> set[str]:
    """The cases whose simulate_case job a Snakemake run marked finished."""
    jobs = _case_jobs(output)
    return {jobs[j] for j in re.findall(r"Finished jobid: (\d+) \(Rule: simulate_case\)", output)}


def _snapshot(paths: dict[str, Path]) -> dict[str, tuple[int, int, bytes]]:
    """Case id -> (inode, mtime in ns, content) of each file."""
    return {name: (path.stat().st_ino, path.stat().st_mtime_ns, path.read_bytes())
            for name, path in paths.items()}


def _is_timing(key: str) -> bool:
    """Whether a table column or record key is a measured time (wall, CPU, loop), which differs
    between runs of the same case."""
    return key.endswith("_time_s")


def _table_values(path: Path) -> list[dict[str, str]]:
    """The rows of a C_eq table as text, without its timing columns.

    The table is written by pandas, whose floats are the shortest text that reads back to the
    same double, so equal text means bit-identical values.
    """
    with open(path, newline="", encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    assert rows and set(VALUE_COLUMNS) <= set(rows[0]), f"{path} lacks value columns"
    return [{k: v for k, v in row.items() if not _is_timing(k)} for row in rows]


#: Record keys left out when two campaigns' records are compared: how many LIGGGHTS runs a case
#: took. One run in about 40 aborts unexplained and is retried
#: (pidpipe.steps.cases.ENGINE_ATTEMPTS), in either campaign; what the case measured is the same.
RETRIES = ("engine_attempts",)


def _record_values(path: Path, ignore: tuple[str, ...] = ()) -> str:
    """A case record as canonical JSON text without its timings (and the keys in ``ignore``)."""

    def strip(value):
        if isinstance(value, dict):
            return {k: strip(v) for k, v in value.items() if not _is_timing(k) and k not in ignore}
        return value

    return json.dumps(strip(json.loads(path.read_text(encoding="utf-8"))), sort_keys=True)


def _tail(path: Path, chars: int = 4000) -> str:
    """The end of a Snakemake run's output file, for failure messages."""
    return path.read_text(encoding="utf-8", errors="replace")[-chars:] if path.is_file() else ""


def _wait_for(condition, what: str, process: subprocess.Popen | None = None,
              output: Path | None = None, timeout_s: float = TIMEOUT_S):
    """Poll ``condition()`` until it returns something true, and return that.

    Fails the test if ``process`` ends first or after ``timeout_s``.
    """
    deadline = time.monotonic() + timeout_s
    while True:
        value = condition()
        if value:
            return value
        if process is not None and process.poll() is not None:
            pytest.fail(f"snakemake ended (status {process.returncode}) before {what}:\n"
                        f"{_tail(output) if output else ''}")
        if time.monotonic() > deadline:
            pytest.fail(f"no {what} within {timeout_s} s")
        time.sleep(POLL_S)


def _assert_nothing_left_running(workdir: Path) -> None:
    """No process (Snakemake, a job, LIGGGHTS, its MPI daemon) still works in ``workdir``."""
    deadline = time.monotonic() + 15.0
    while (left := _processes_in(workdir)) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not left, [(p.pid, _name(p), p.info["cwd"]) for p in left]


def _stop(process: subprocess.Popen) -> None:
    """Make sure a Snakemake run started by a test is gone, with its process group."""
    if process.poll() is None:
        try:
            os.killpg(process.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        process.wait(timeout=30)


# --------------------------------------------------------------------------------------------
# Campaigns shared by the tests


@pytest.fixture(scope="module")
def poured(tmp_path_factory) -> Path:
    """A campaign folder whose packings are poured and checked, and no case is run."""
    workdir = tmp_path_factory.mktemp("poured")
    write_config(workdir, grid=GRID, fidelity=FIDELITY, environments=[])
    run = snakemake(workdir, "packings")
    assert run.returncode == 0, run.stdout[-5000:]
    return workdir


@pytest.fixture(scope="module")
def reference(poured, tmp_path_factory) -> Path:
    """The campaign run to its C_eq table without interruption."""
    workdir = _copy(poured, tmp_path_factory.mktemp("reference") / "campaign")
    run = snakemake(workdir, *TARGETS)
    assert run.returncode == 0, run.stdout[-5000:]
    assert planned_jobs(run.stdout)["simulate_case"] == len(CASES)
    assert set(_records(workdir)) == CASES
    return workdir


@pytest.fixture(scope="module")
def fresh(tmp_path_factory) -> Path:
    """The same config run from nothing in another folder: its own pours, its own cases."""
    workdir = tmp_path_factory.mktemp("fresh")
    write_config(workdir, grid=GRID, fidelity=FIDELITY, environments=[])
    run = snakemake(workdir, *TARGETS)
    assert run.returncode == 0, run.stdout[-5000:]
    return workdir


# --------------------------------------------------------------------------------------------
# Tests


def test_same_config_and_seeds_give_bit_identical_results(reference, fresh):
    """Two campaigns from nothing, in separate folders, give the same packings, records and table.

    Everything is compared bit for bit except the measured times (table columns and record
    keys ending in ``_time_s``: ``wall_time_s``, ``liggghts_wall_time_s``, LIGGGHTS' CPU and
    loop times). Those differ from run to run, so the two ceq_table.csv files are not
    byte-identical as a whole.
    """
    for packing in sorted((reference / "results" / "packings").glob("r*.json")):
        assert packing.read_bytes() == (fresh / "results" / "packings" / packing.name).read_bytes()
    assert set(_records(fresh)) == CASES
    for case_id, path in _records(reference).items():
        assert (_record_values(path, ignore=RETRIES)
                == _record_values(_records(fresh)[case_id], ignore=RETRIES)), case_id
    table = _table_values(reference / "results" / "ceq_table.csv")
    assert table == _table_values(fresh / "results" / "ceq_table.csv")
    assert len(table) == len(CASES) and all(row["status"] in ("ok", "flagged") for row in table)


@pytest.mark.parametrize(("sig", "target", "cores"), [
    pytest.param(signal.SIGINT, "group", 2, id="ctrl-c"),
    pytest.param(signal.SIGINT, "snakemake", 2, id="sigint-snakemake"),
    # Snakemake lets the running jobs finish: one core, so that a case is left to resume
    pytest.param(signal.SIGTERM, "snakemake", 1, id="sigterm-snakemake"),
    pytest.param(signal.SIGKILL, "group", 2, id="kill-9-group"),
])
def test_interrupted_campaign_resumes_with_only_the_unfinished_cases(poured, reference, tmp_path,
                                                                     sig, target, cores):
    """Interrupt the simulate_case jobs; check what is left; resume with a plain run.

    The signal comes once Snakemake has finished a case and another case's LIGGGHTS runs (on
    ``cores`` cores). The resume is a plain ``snakemake --cores 2 cases table``.
    """
    workdir = _copy(poured, tmp_path / "campaign")
    output = tmp_path / "interrupted.out"
    started = time.perf_counter()
    command = snakemake_command(workdir, *TARGETS, cores=cores)
    with open(output, "w", encoding="utf-8") as handle:
        process = subprocess.Popen(command, cwd=workdir, stdout=handle, stderr=subprocess.STDOUT,
                                   start_new_session=True, preexec_fn=sigint_as_from_a_terminal)
        try:
            def mid_campaign():
                text = output.read_text(encoding="utf-8")
                finished = _finished_cases(text)
                running = set(_running_liggghts(workdir)) - set(_records(workdir))
                unstarted = CASES - set(_case_jobs(text).values())
                if finished and running and (unstarted or cores > 1):
                    return finished, running
                return None

            finished_then, running_then = _wait_for(
                mid_campaign, "finished case while another one runs", process, output)
            signalled_at = time.perf_counter() - started
            if target == "group":
                os.killpg(process.pid, sig)
            else:
                process.send_signal(sig)
            process.wait(timeout=TIMEOUT_S)
        finally:
            _stop(process)
    stopped_at = time.perf_counter() - started
    _assert_nothing_left_running(workdir)

    # What the interruption left: complete records only, those of finished jobs among them.
    finished = _finished_cases(output.read_text(encoding="utf-8"))
    assert finished_then <= finished
    records = _records(workdir)
    assert finished <= set(records) <= CASES
    # what the resume must skip: the cases Snakemake completed, those its output called
    # finished and any it completed just before the signal cut its "Finished" line
    completed = _completed_cases(workdir)
    assert finished <= completed, (finished - completed, _tail(output))
    for case_id, path in records.items():
        record = read_record(path)  # a CaseRecord (a JSON object with case_id and status), or ParseError
        assert record.case_id == case_id
        # an interrupted case is never recorded as failed (which would keep it from rerunning)
        assert record.status in ("ok", "flagged"), record.message
        assert (_record_values(path, ignore=RETRIES)
                == _record_values(reference / "results" / "cases" / path.name, ignore=RETRIES))
    unfinished_records = set(records) - finished
    if target == "snakemake" and sig == signal.SIGTERM:
        assert running_then <= finished, "SIGTERM: Snakemake lets the running jobs finish"
    if target == "snakemake" and sig == signal.SIGINT:
        # the case this test is for: records written in full, never marked finished
        assert running_then <= unfinished_records, _tail(output)
    parts = sorted(p.name for p in (workdir / "results").rglob("*.part"))
    # A record whose write was cut short: the next run must neither read it nor skip its case.
    pending = sorted(CASES - finished)
    decoy = workdir / "results" / "cases" / f".{pending[0]}.json.999999.part"
    decoy.parent.mkdir(parents=True, exist_ok=True)
    decoy.write_bytes((reference / "results" / "cases" / f"{pending[0]}.json").read_bytes()[:1000])

    kept = {case_id: records[case_id] for case_id in finished}
    before = _snapshot(kept)
    if sig == signal.SIGKILL:
        refused = snakemake(workdir, *TARGETS)
        assert refused.returncode != 0 and "LockException" in refused.stdout, refused.stdout[-3000:]
        assert "--unlock" in refused.stdout
        assert _records(workdir) == records and _snapshot(kept) == before
        unlocked = snakemake(workdir, "--unlock")
        assert unlocked.returncode == 0, unlocked.stdout[-3000:]

    resume_started = time.perf_counter()
    resumed = snakemake(workdir, *TARGETS)
    resume_s = time.perf_counter() - resume_started
    assert resumed.returncode == 0, resumed.stdout[-5000:]
    redone = set(_case_jobs(resumed.stdout).values())
    assert redone == CASES - completed, resumed.stdout[-5000:]
    assert planned_jobs(resumed.stdout)["simulate_case"] == len(CASES) - len(completed)
    assert _snapshot(kept) == before  # the finished records were not rewritten
    assert set(_records(workdir)) == CASES and decoy.is_file()
    for case_id, path in _records(workdir).items():
        assert (_record_values(path, ignore=RETRIES)
                == _record_values(reference / "results" / "cases" / path.name, ignore=RETRIES))
    assert (_table_values(workdir / "results" / "ceq_table.csv")
            == _table_values(reference / "results" / "ceq_table.csv"))
    print(f"\n{sig.name} to {target}: signal at {signalled_at:.1f} s, stopped at "
          f"{stopped_at:.1f} s; "
          f"running then {sorted(running_then)}; {len(finished)} finished record(s) kept, "
          f"{len(unfinished_records)} complete but unfinished record(s) and "
          f"{len(CASES) - len(records)} missing one(s) redone; .part files left: {parts}; "
          f"resume ran {len(redone)} case(s) in {resume_s:.1f} s")


def test_killed_liggghts_is_retried_once_then_the_case_is_recorded_failed(reference, tmp_path):
    """kill -9 one case's LIGGGHTS once and another's at both attempts, mid-run.

    The first case succeeds at its second attempt with the reference's values; the second is
    recorded as ``failed`` (naming the signal, the screen file and the rule's log), the job
    and the run succeed, and the table keeps its row as failed with no values.
    """
    workdir = _copy(reference, tmp_path / "campaign")
    once, always = "f1000Hz_G5_r25pct_rep0", "f1000Hz_G10_r50pct_rep0"
    kills_wanted = {once: 1, always: 2}
    for case_id in kills_wanted:
        (workdir / "results" / "cases" / f"{case_id}.json").unlink()
    others = _records(workdir)
    before = _snapshot(others)

    output = tmp_path / "run.out"
    kills: dict[str, list[int]] = {case_id: [] for case_id in kills_wanted}
    with open(output, "w", encoding="utf-8") as handle:
        process = subprocess.Popen(snakemake_command(workdir, *TARGETS), cwd=workdir, stdout=handle,
                                   stderr=subprocess.STDOUT, start_new_session=True)
        try:
            deadline = time.monotonic() + TIMEOUT_S
            while process.poll() is None and time.monotonic() < deadline:
                for case_id, liggghts in _running_liggghts(workdir).items():
                    if (len(kills.get(case_id, ())) >= kills_wanted.get(case_id, 0)
                            or liggghts.pid in kills[case_id]):
                        continue
                    screen = Path(liggghts.info["cwd"]) / "screen.txt"
                    text = screen.read_text(errors="replace") if screen.is_file() else ""
                    if "Setting up run" in text:  # its time loop has started
                        liggghts.send_signal(signal.SIGKILL)
                        kills[case_id].append(liggghts.pid)
                time.sleep(POLL_S)
            process.wait(timeout=TIMEOUT_S)
        finally:
            _stop(process)
    _assert_nothing_left_running(workdir)
    text = output.read_text(encoding="utf-8")
    assert process.returncode == 0, text[-5000:]
    assert {c: len(pids) for c, pids in kills.items()} == kills_wanted, text[-5000:]
    assert planned_jobs(text)["simulate_case"] == 2
    assert _snapshot(others) == before

    reference_cases = reference / "results" / "cases"
    retried = read_record(workdir / "results" / "cases" / f"{once}.json")
    assert retried.engine_attempts == 2
    assert (_record_values(workdir / "results" / "cases" / f"{once}.json", ignore=RETRIES)
            == _record_values(reference_cases / f"{once}.json", ignore=RETRIES))
    log = (workdir / "logs" / "simulate_case" / f"{once}.log").read_text()
    assert "attempt 1 of 2" in log and "killed by signal SIGKILL" in log

    failed = read_record(workdir / "results" / "cases" / f"{always}.json")
    assert failed.status == "failed" and failed.engine_attempts == 2
    assert math.isnan(failed.ceq_coupon_ns_m)
    assert failed.n_spheres == read_record(reference_cases / f"{always}.json").n_spheres
    for part in (f"case {always} failed after 2 attempt(s)", "killed by signal SIGKILL",
                 "screen.txt", f"logs/simulate_case/{always}.log"):
        assert part in failed.message, failed.message

    table = {row["case_id"]: row for row in _table_values(workdir / "results" / "ceq_table.csv")}
    reference_table = {row["case_id"]: row
                       for row in _table_values(reference / "results" / "ceq_table.csv")}
    assert table[always]["status"] == "failed" and table[always]["ceq_coupon_ns_m"] == ""
    assert table[once] == reference_table[once]
    for case_id in others:
        assert table[case_id] == reference_table[case_id]
