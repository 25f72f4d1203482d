"""LIGGGHTS inside an ``srun`` job step, as every job of the SLURM executor plugin runs it.

Open MPI takes a process whose environment holds a SLURM step id for one rank of an
srun-launched job and looks for SLURM's PMI server; with SLURM's default ``MpiDefault=none``
there is none and LIGGGHTS aborts in MPI_Init. pidpipe.liggghts.process runs LIGGGHTS without the step's
id (``liggghts_environment``); this runs a tiny deck through ``pidpipe.liggghts.process.run_deck`` in a
real job step.
"""

from __future__ import annotations

import sys

import pytest

from pidpipe.liggghts.process import SLURM_STEP_VARIABLES, liggghts_environment

TINY_DECK = """\
atom_style granular
atom_modify map array sort 0 0.0
boundary f f f
newton off
communicate single vel yes
units si
region box block 0 1 0 1 0 1 units box
create_box 1 box
neighbor 0.1 bin
timestep 1e-5
run 10
"""

RUN = ("from pidpipe.liggghts.process import run_deck; "
       "print('steps', run_deck(__import__('sys').argv[1], 'tiny deck').steps)")


def test_liggghts_environment_drops_only_the_step_id():
    environ = {"SLURM_JOB_ID": "7", "SLURM_STEP_ID": "0", "SLURM_STEPID": "0", "PATH": "/bin"}
    assert liggghts_environment(environ) == {"SLURM_JOB_ID": "7", "PATH": "/bin"}
    assert set(SLURM_STEP_VARIABLES) == {"SLURM_STEP_ID", "SLURM_STEPID"}


@pytest.mark.engine
@pytest.mark.slurm
def test_run_deck_works_inside_an_srun_job_step(slurm_cluster, tmp_path):
    deck = tmp_path / "deck.in"
    deck.write_text(TINY_DECK)
    run = slurm_cluster.command("srun", "--ntasks=1", sys.executable, "-c", RUN, str(deck),
                                timeout=120)
    assert run.returncode == 0, run.stdout + (tmp_path / "screen.txt").read_text(errors="replace")
    assert "steps 10" in run.stdout
