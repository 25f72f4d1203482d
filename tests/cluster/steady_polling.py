"""Snakemake whose SLURM executor checks its jobs at a steady interval: the cluster tests' command.

Run as ``python tests/cluster/steady_polling.py <snakemake arguments>``: the same Snakemake as
the ``snakemake`` command, with one change to snakemake-executor-plugin-slurm. After every status
check that finds no job ended, the plugin waits 10 s longer before the next one (up to 180 s;
reset once a job has ended). A real campaign's jobs last minutes and the back-off spares the
scheduler; the tests' jobs last seconds, so the back-off, not the jobs, set their pace: a group
job of two cases was seen finished 36 s after its submission (checks at 2, 14 and 36 s), and
17 s after it with steady checks. Here every check is followed by
``--seconds-between-status-checks`` (the tests give 2 s). Job submission, cancellation and the
job states are the plugin's, unchanged.
"""

from __future__ import annotations

import sys

import snakemake_executor_plugin_slurm as slurm
from snakemake.cli import main

_check_active_jobs = slurm.Executor.check_active_jobs


async def _check_active_jobs_steadily(self, active_jobs):
    async for job in _check_active_jobs(self, active_jobs):
        yield job
    # None: the next sleep is remote_execution_settings.seconds_between_status_checks
    self.next_seconds_between_status_checks = None


slurm.Executor.check_active_jobs = _check_active_jobs_steadily

if __name__ == "__main__":
    sys.exit(main())
