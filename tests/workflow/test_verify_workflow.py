"""`snakemake --cores 2 verify` on the reduced campaign (.test/config.yaml), with the compiled DEM
for the campaign and the verifying cases (the cheapest engine): the designs' points are planned,
poured, checked, shaken once each and compared with the surrogate."""

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


VERIFY = {"engine": "dem", "surrogate_draws": 20}


@pytest.fixture(scope="module")
def verified(dem_grid_campaign, tmp_path_factory):
    """`snakemake verify` on a copy of the finished DEM campaign (tests/workflow/conftest.py):
    the verify section changes none of the campaign's jobs, so only verify's own run."""
    workdir = copy_campaign(dem_grid_campaign, tmp_path_factory.mktemp("verify") / "campaign")
    write_config(workdir, engine="dem", verify=VERIFY)
    run = snakemake(workdir, "verify")
    assert run.returncode == 0, run.stdout[-5000:]
    for rule in ("pour_packing", "simulate_dem_cases", "collect_table", "optimise_environments"):
        assert f"rule {rule}:" not in run.stdout, rule
    return workdir, run.stdout


def test_verify_in_a_new_folder_runs_the_campaign_first(tmp_path):
    """From nothing, `snakemake verify` plans the campaign's pours, cases, table, surrogate and
    designs before its checkpoint (the fixture above starts from a finished campaign)."""
    write_config(tmp_path, engine="dem", verify=VERIFY)
    run = snakemake(tmp_path, "verify", "--dry-run")
    assert run.returncode == 0, run.stdout[-5000:]
    jobs = planned_jobs(run.stdout)
    assert jobs["pour_packing"] == 2 and jobs["simulate_dem_cases"] == 4, jobs
    for rule in ("check_packings", "collect_table", "fit_surrogate", "cross_validate_surrogate",
                 "optimise_environments", "plan_verify"):
        assert jobs.get(rule) == 1, (rule, jobs)


def test_every_band_mean_and_peak_design_is_checked_at_its_corners_and_centre(verified):
    workdir, _ = verified
    table = pd.read_csv(workdir / "results" / "verify.csv")
    optimum = json.loads((workdir / "results" / "optimum.json").read_text())
    checked = [d for d in optimum if d["kind"] in ("band_mean", "peak")]
    assert len(table) == 5 * len(checked)
    for result in checked:
        rows = table[table["design"] == result["kind"]]
        assert set(rows["freq_hz"]) == {*result["bounds"]["freq_hz"], np.mean(result["bounds"]["freq_hz"])}
        assert set(rows["accel_g"]) == {*result["bounds"]["accel_g"], np.mean(result["bounds"]["accel_g"])}
        # the DEM shakes the design's fill as whole spheres: within half a sphere of it
        full = result["budget"]["full_cell_spheres"]
        assert np.all(np.abs(rows["fill_pct"] - result["design"]["fill_pct"]) <= 50.0 / full)
    # each distinct case was shaken once, on packings checked as the campaign's
    records = sorted(p.stem for p in (workdir / "results" / "verify" / "cases").glob("*.json"))
    assert records == sorted(set(table["case_id"]))
    packings = sorted((workdir / "results" / "verify" / "packings").glob("*.json"))
    assert {p.stem.split("_rep")[0] for p in packings} == {f"r{fill:g}pct" for fill in table["fill_pct"]}
    for packing in packings:
        check = pd.read_csv(packing.with_suffix(".check.tsv"), sep="\t")
        assert list(check["verdict"]) == ["ok"]


def test_the_table_is_physically_sensible_and_z_follows_from_its_values(verified):
    workdir, _ = verified
    table = pd.read_csv(workdir / "results" / "verify.csv")
    assert (table["engine"] == "dem").all() and (table["solver"] == "numba-dem").all()
    for column in ("ceq_coupon_dem_ns_m", "ceq_coupon_dem_sem_ns_m", "ceq_coupon_surrogate_ns_m",
                   "surrogate_u_ns_m", "dem_cpu_time_s"):
        values = table[column].to_numpy(dtype=float)
        assert np.all(np.isfinite(values) & (values > 0)), column
    # resolved: the SEM is below the value
    assert np.all(table["ceq_coupon_dem_sem_ns_m"] < table["ceq_coupon_dem_ns_m"])
    combined = np.hypot(table["ceq_coupon_dem_sem_ns_m"], table["surrogate_u_ns_m"])
    np.testing.assert_allclose(table["z_combined"],
                               (table["ceq_coupon_dem_ns_m"] - table["ceq_coupon_surrogate_ns_m"])
                               / combined, rtol=1e-9)
    assert list(table["surrogate_off"]) == list(table["z_combined"].abs() > 2.0)
    # the verifying cases ran at the campaign's fidelity
    case = json.loads((workdir / "results" / "verify" / "cases" / f"{table['case_id'][0]}.json").read_text())
    campaign = json.loads(next((workdir / "results" / "cases").glob("*.json")).read_text())
    for key in ("measured_cycles", "transient_cycles_configured", "cells_per_run", "engine"):
        assert case["fidelity"][key] == campaign["fidelity"][key], key


def test_the_log_and_the_figure_say_what_was_found(verified):
    workdir, _ = verified
    log = (workdir / "logs" / "verify" / "verify.log").read_text()
    table = pd.read_csv(workdir / "results" / "verify.csv")
    assert f"{len(table)} design point(s), {table['case_id'].nunique()} distinct case(s)" in log
    assert log.count("surrogate off:") == int(table["surrogate_off"].sum())
    assert (workdir / "results" / "verify.png").stat().st_size > 10_000


def test_the_dem_m_eff_is_compared_with_the_m_eff_surrogate(verified):
    """Every verifying case's m_eff against the campaign's m_eff GP, z from the table's values;
    the C_eq interpolant (rbf_thin_plate in .test) keeps its bootstrap and LOO uncertainty."""
    workdir, _ = verified
    table = pd.read_csv(workdir / "results" / "verify.csv")
    assert (table["surrogate_u_method"] == "bootstrap_and_loo").all()
    for column in ("m_eff_dem_kg", "m_eff_dem_sem_kg", "m_eff_surrogate_kg", "z_m_eff"):
        assert np.all(np.isfinite(table[column].to_numpy(dtype=float))), column
    assert np.all(table["m_eff_surrogate_u_kg"] > 0) and np.all(table["m_eff_dem_sem_kg"] > 0)
    combined = np.hypot(table["m_eff_dem_sem_kg"], table["m_eff_surrogate_u_kg"])
    np.testing.assert_allclose(table["z_m_eff"],
                               (table["m_eff_dem_kg"] - table["m_eff_surrogate_kg"]) / combined,
                               rtol=1e-9)
    assert list(table["m_eff_off"]) == list(table["z_m_eff"].abs() > 2.0)
    log = (workdir / "logs" / "verify" / "verify.log").read_text()
    assert log.count("m_eff off:") == int(table["m_eff_off"].sum())


def test_a_new_plan_runs_only_its_new_cases_and_refreshes_the_table_in_the_same_run(verified):
    """Another band replans the cases (the checkpoint reruns): the new corners are shaken, the
    shared ones are not, and verify.csv follows in the same run."""
    workdir, _ = verified
    before = {p.name: p.stat().st_mtime_ns for p in (workdir / "results" / "verify" / "cases").glob("*.json")}
    write_config(workdir, engine="dem", verify=VERIFY,
                 environments=[{"name": "600-1000 Hz, 6-9 g", "freq_hz": [600, 1000], "accel_g": [6, 9]}])
    run = snakemake(workdir, "verify")
    assert run.returncode == 0, run.stdout[-5000:]
    assert "simulate_case " not in run.stdout                   # the campaign is not rerun
    table = pd.read_csv(workdir / "results" / "verify.csv")
    points = pd.read_csv(workdir / "results" / "verify" / "points.csv")
    assert list(table["case_id"]) == list(points["case_id"])
    assert set(table["environment"]) == {"600-1000 Hz, 6-9 g"} and 1000.0 in set(table["freq_hz"])
    after = {p.name: p.stat().st_mtime_ns for p in (workdir / "results" / "verify" / "cases").glob("*.json")}
    kept = [name for name in before if f"{name[:-5]}" in set(table["case_id"])]
    assert len(kept) >= 2                                        # the f = 600 Hz corners stay
    assert all(after[name] == before[name] for name in kept)   # shared cases not shaken again
