"""What does running the .test campaign's cases through SLURM cost against a local run (issue 16)?

Starts the single-node SLURM of the tests (tests/cluster/local_slurm.py), pours the packings
once, then shakes the 8 cases (target ``cases``) from a copy of that folder:

- locally, ``snakemake --cores 2`` (profiles/default);
- through ``--workflow-profile profiles/slurm``, one SLURM job per case
  (``--group-components cases=1``) and grouped as the profile ships (4 cases per job), each at
  the profile's status polling (first check after 40 s) and at fast polling (2 s).

For every SLURM job it reads SLURM's own times (``scontrol show job``: submit, start, end) and
the Snakemake benchmark times of the cases it ran, and prints per run: wall time of the stage,
SLURM jobs, mean queue wait, and the overhead inside a job (its run time minus the case jobs'
own times: srun, and Snakemake starting again inside the job for each case). The wall-time
ratios are measured in one run of this script, on a machine that other sessions share. Figures
go to ``benchmarks/records/bench_slurm.json`` (:mod:`harness`).

Run (as root; installs SLURM's Debian packages if missing):
    .venv/bin/python benchmarks/bench_slurm.py [--polling 40 2]
"""

from __future__ import annotations

import argparse
import re
import shutil
import subprocess
import sys
import tempfile
from datetime import datetime
from pathlib import Path

import pandas as pd
from harness import REPO, SNAKEMAKE, measured, record

sys.path.insert(0, str(REPO))
from tests.cluster import local_slurm  # noqa: E402


def snakemake(workdir: Path, *args: str) -> tuple[float, str]:
    """Run the repository's Snakefile in ``workdir``; (wall s, output). Fails loudly."""
    command = [SNAKEMAKE, "--snakefile", str(REPO / "Snakefile"), "--directory", str(workdir), *args]
    with measured() as timing:
        run = subprocess.run(command, cwd=workdir, text=True, stdout=subprocess.PIPE,
                             stderr=subprocess.STDOUT)
    if run.returncode != 0:
        sys.exit(f"{' '.join(command)} failed:\n{run.stdout[-5000:]}")
    return timing.wall_s, run.stdout


def case_job_times(workdir: Path) -> dict[str, float]:
    """Case id -> the simulate_case job's own time (Snakemake benchmark ``s``), s."""
    folder = workdir / "results" / "benchmarks" / "simulate_case"
    return {path.stem: float(pd.read_csv(path, sep="\t")["s"].iloc[0])
            for path in folder.glob("*.tsv")}


def slurm_jobs(cluster, output: str) -> list[dict]:
    """Every SLURM job a run submitted: queue wait, run time and the cases in its log."""
    jobs = []
    for slurm_id, log in re.findall(r"submitted with SLURM jobid (\d+) \(log: (\S+)\)", output):
        info = cluster.command("scontrol", "show", "job", "-o", slurm_id).stdout
        times = {key: datetime.fromisoformat(value) for key, value in
                 re.findall(r"(SubmitTime|StartTime|EndTime)=(\S+)", info)}
        cases = set(re.findall(r"output: results/cases/(\S+)\.json", Path(log).read_text()))
        jobs.append({"id": slurm_id, "cases": cases,
                     "queue_s": (times["StartTime"] - times["SubmitTime"]).total_seconds(),
                     "run_s": (times["EndTime"] - times["StartTime"]).total_seconds()})
    return jobs


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--polling", type=int, nargs="+", default=[40, 2],
                        help="slurm-init-seconds-before-status-checks values to measure")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as scratch:
        scratch = Path(scratch)
        cluster = local_slurm.start(scratch / "slurm")
        try:
            poured = scratch / "poured"
            poured.mkdir()
            shutil.copy(REPO / ".test" / "config.yaml", poured / "config.yaml")
            snakemake(poured, "--cores", "2", "packings")
            rows = []
            local = shutil.copytree(poured, scratch / "local", symlinks=True)
            wall, _ = snakemake(local, "--cores", "2", "cases")
            case_s = sum(case_job_times(local).values())
            rows.append(f"| local, --cores 2 | - | {wall:.1f} | 1.00 | - | - | - | {case_s:.1f} |")
            figures = {"local_wall_s": round(wall, 1), "local_case_job_time_s": round(case_s, 1)}
            local_wall = wall
            for polling in args.polling:
                for label, extra in (("one job per case", ["--group-components", "cases=1"]),
                                     ("4 cases per job (profile)", [])):
                    work = shutil.copytree(poured, scratch / f"slurm_{polling}_{len(extra)}",
                                           symlinks=True)
                    wall, output = snakemake(
                        work, "cases", "--workflow-profile", str(REPO / "profiles" / "slurm"),
                        "--slurm-init-seconds-before-status-checks", str(polling), *extra)
                    times = case_job_times(work)
                    jobs = slurm_jobs(cluster, output)
                    queue = sum(job["queue_s"] for job in jobs) / len(jobs)
                    inside = sum(job["run_s"] - sum(times[c] for c in job["cases"])
                                 for job in jobs) / len(times)
                    key = f"slurm_{'one_per_job' if extra else 'grouped'}_polling{polling}s"
                    figures.update({f"{key}_wall_s": round(wall, 1),
                                    f"{key}_wall_over_local": round(wall / local_wall, 2),
                                    f"{key}_jobs": len(jobs), f"{key}_mean_queue_s": round(queue, 1),
                                    f"{key}_overhead_per_case_s": round(inside, 1)})
                    rows.append(f"| SLURM, {label} | {polling} | {wall:.1f} | "
                                f"{wall / local_wall:.2f} | {len(jobs)} | {queue:.1f} | "
                                f"{inside:.1f} | {sum(times.values()):.1f} |")
        finally:
            cluster.stop()
    notes = ("Stage `cases` only (packings poured once before). One node, 2 CPUs, one CPU per SLURM "
             "job. Queue wait and run time from `scontrol show job` (1 s resolution); overhead "
             "inside jobs = SLURM run time minus the case jobs' own Snakemake benchmark times "
             "(srun and Snakemake starting again in the job for each case). Wall includes "
             "Snakemake noticing the end of a job: the plugin checks first after the polling "
             "value, then 10 s later each time no job has ended.")
    print("\n".join(["| run | first status check s | wall s | wall / local | SLURM jobs | mean queue wait s "
                     "| overhead inside jobs per case s | summed case job time s |",
                     "|---|---|---|---|---|---|---|---|", *rows, "", notes]))
    record("bench_slurm", figures, notes=notes)


if __name__ == "__main__":
    main()
