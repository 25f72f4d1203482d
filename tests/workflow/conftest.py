"""Campaigns that several workflow test modules start from, each run once per session."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests._snakemake import copy_campaign, planned_jobs, snakemake, write_config


@pytest.fixture(scope="session")
def dem_grid_campaign(tmp_path_factory) -> Path:
    """The reduced campaign (.test/config.yaml) with ``engine: dem``, run to its end (all).

    Never changed: a module that runs more in it works on a copy
    (``tests._snakemake.copy_campaign``).
    """
    workdir = tmp_path_factory.mktemp("dem_grid_campaign")
    write_config(workdir, engine="dem")
    run = snakemake(workdir)
    assert run.returncode == 0, run.stdout[-5000:]
    return workdir


@pytest.fixture(scope="session")
def dem_poured_campaign(dem_grid_campaign, tmp_path_factory) -> dict:
    """:func:`dem_grid_campaign` switched to ``fidelity.pour_engine: dem`` and run to its table.

    Returns
    -------
    dict
        ``workdir`` (a copy of the DEM campaign, the config changed, then target ``table``
        run), ``planned`` (rule -> jobs that a dry run of every target planned before that
        run) and ``run`` (that run's CompletedProcess). test_workflow_dem.py checks them; the
        refinement campaign (test_refine_workflow.py) starts from a copy. Never changed.
    """
    workdir = copy_campaign(dem_grid_campaign,
                            tmp_path_factory.mktemp("dem_poured_campaign") / "campaign")
    write_config(workdir, engine="dem", fidelity={"pour_engine": "dem"})
    planned = planned_jobs(snakemake(workdir, "--dry-run").stdout)
    return {"workdir": workdir, "planned": planned, "run": snakemake(workdir, "table")}
