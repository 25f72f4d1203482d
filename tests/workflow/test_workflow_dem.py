"""The reduced campaign (.test/config.yaml) with ``engine: dem``: every case shaken by the
compiled DEM on LIGGGHTS' pour, through the same table, surrogate and optimum; then poured by
the DEM too (``fidelity.pour_engine: dem``)."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from tests._snakemake import (
    WORKFLOW_MARKS,
    copy_campaign,
    planned_jobs,
    snakemake,
    write_config,
)

pytestmark = WORKFLOW_MARKS


@pytest.fixture(scope="module")
def dem_campaign(dem_grid_campaign, tmp_path_factory):
    """The DEM campaign run to its end (tests/workflow/conftest.py), copied: the last test
    changes it."""
    return copy_campaign(dem_grid_campaign, tmp_path_factory.mktemp("dem_campaign") / "campaign")


def test_every_case_is_shaken_by_the_compiled_dem(dem_campaign):
    table = pd.read_csv(dem_campaign / "results" / "ceq_table.csv")
    assert len(table) == 8
    assert (table["solver"] == "numba-dem").all()
    assert table["solver_version"].str.startswith("numba").all()
    assert table["liggghts_version"].isna().all()
    ok = table[table["status"] == "ok"]
    assert len(ok) >= 5, table[["case_id", "status", "flags"]]
    for column in ("ceq_coupon_ns_m", "ceq_cell_ns_m", "ed_cycle_mean_j", "solver_wall_time_s"):
        values = ok[column].to_numpy(dtype=float)
        assert np.all(np.isfinite(values) & (values > 0)), column
    assert np.all(ok["ceq_coupon_sem_ns_m"] < ok["ceq_coupon_ns_m"])
    for case_id in table["case_id"]:
        record = json.loads((dem_campaign / "results" / "cases" / f"{case_id}.json").read_text())
        assert record["fidelity"]["engine"] == "dem" and record["engine"]["name"] == "dem"
        log = (dem_campaign / "logs" / "simulate_case" / f"{case_id}.log").read_text()
        assert f"case {case_id} (numba-dem)" in log and "case f" not in log.replace(f"case {case_id}", "")


def test_the_rest_of_the_campaign_runs_on_the_dem_table(dem_campaign):
    for path in ("surrogate.json", "surrogate_cv.csv", "optimum.csv",
                 "figures/ceq_freq_fill.png", "figures/convergence.png"):
        assert (dem_campaign / "results" / path).is_file(), path


def test_switching_the_engine_reruns_every_case_but_no_pour(dem_campaign):
    write_config(dem_campaign, engine="liggghts")
    try:
        jobs = planned_jobs(snakemake(dem_campaign, "--dry-run").stdout)
    finally:
        write_config(dem_campaign, engine="dem")
    assert jobs.get("simulate_case") == 8
    assert "pour_packing" not in jobs


def test_pouring_in_the_dem_too_repours_every_packing_and_reruns_every_case(dem_poured_campaign):
    """The campaign above with fidelity.pour_engine dem, run to its table (tests/workflow/
    conftest.py): the packings, cases and table that this test checks; the designs after the
    table are checked on the first one (test_the_rest_of_the_campaign_runs_on_the_dem_table)."""
    workdir, jobs, run = (dem_poured_campaign[key] for key in ("workdir", "planned", "run"))
    # the DEM's cases of one frequency and acceleration share a job (simulate_dem_cases)
    # and the DEM pours the packings of one fill in one job (pour_dem_packings)
    assert jobs.get("pour_dem_packings") == 2 and jobs.get("simulate_dem_cases") == 4
    assert "pour_packing" not in jobs
    assert "simulate_case" not in jobs
    assert run.returncode == 0, run.stdout[-5000:]
    for fill in (25, 50):
        packing = json.loads((workdir / "results" / "packings" / f"r{fill}pct_rep0.json").read_text())
        assert packing["pour_engine"] == "dem"
    check = pd.read_csv(workdir / "results" / "packings" / "check.tsv", sep="\t")
    assert (check["pour_engine"] == "dem").all() and (check["verdict"] == "ok").all()
    table = pd.read_csv(workdir / "results" / "ceq_table.csv")
    assert len(table) == 8 and (table["pour_engine"] == "dem").all()
    assert (table["solver"] == "numba-dem").all() and (table["status"] == "ok").sum() >= 5
    assert "pour_dem_packings" not in planned_jobs(snakemake(workdir, "--dry-run").stdout)
