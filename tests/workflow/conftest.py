"""A campaign that several workflow test modules start from, run once per session."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests._snakemake import snakemake, write_config


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
