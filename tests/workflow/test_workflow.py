"""The Snakemake campaign end to end on the reduced config (.test/config.yaml), with LIGGGHTS.

One campaign runs once per module (about a minute on 2 cores) in a temporary working
directory; the tests read its outputs, then check resume (nothing to do; a deleted record
reruns only its case), the failure policy (an injected LIGGGHTS failure of one case), a bad
config and packings that do not fit.
"""

from __future__ import annotations

import json
import shutil
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pidpipe.config import budget_spheres, full_cell_spheres, load_config
from pidpipe.config.derived import poured_fill
from pidpipe.design.ceq_table import OPTIONAL_COLUMNS, REQUIRED_COLUMNS, read_ceq_table
from tests._snakemake import (
    LIGGGHTS,
    TEST_CONFIG,
    WORKFLOW_MARKS,
    planned_jobs,
    snakemake,
    write_config,
)

FIDELITY_COLUMNS = ("dt_s", "dt_rayleigh_fraction", "steps_per_cycle", "youngs_modulus_scale",
                    "transient_cycles", "measured_cycles", "sem_block_cycles", "seed")

pytestmark = WORKFLOW_MARKS

#: The case records (rule ``cases``: a deleted record is rerun though the table is up to date),
#: the C_eq table and the surrogate fitted to it; not the designs and figures after them.
SURROGATE_TARGETS = ("cases", "table", "results/surrogate.json")


@pytest.fixture(scope="module")
def campaign_dir(tmp_path_factory) -> Path:
    workdir = tmp_path_factory.mktemp("campaign")
    shutil.copy(TEST_CONFIG, workdir / "config.yaml")
    started = time.perf_counter()
    run = snakemake(workdir)
    elapsed = time.perf_counter() - started
    assert run.returncode == 0, run.stdout[-5000:]
    print(f"\nreduced campaign: {elapsed:.1f} s on 2 cores")
    return workdir


@pytest.fixture(scope="module")
def config() -> dict:
    return load_config(TEST_CONFIG)


def test_table_has_every_case_with_values_errors_and_fidelity(campaign_dir, config):
    table = read_ceq_table(campaign_dir / "results" / "ceq_table.csv")
    assert len(table) == 8
    assert set(REQUIRED_COLUMNS + OPTIONAL_COLUMNS) <= set(table.columns)
    grid = config["grid"]
    assert set(table["freq_hz"]) == set(grid["freq_hz"])
    assert set(table["accel_g"]) == set(grid["accel_g"])
    # each row sits at the fill its cells hold: 25 % and 50 % pour 5 and 11 of 21 spheres
    full = full_cell_spheres(config)
    assert set(table["fill_pct"]) == {poured_fill(r, full)[0] for r in grid["fill_pct"]}
    assert set(table["fill_pct"]) == {23.81, 52.381}
    ok = table[table["status"] == "ok"]
    assert len(ok) >= 5, table[["case_id", "status", "flags"]]
    for column in ("ceq_coupon_ns_m", "ceq_coupon_sem_ns_m", "ceq_cell_ns_m", "ed_cycle_mean_j"):
        values = ok[column].to_numpy(dtype=float)
        assert np.all(np.isfinite(values) & (values > 0)), column
    # an error bar smaller than the value: the runs measured something
    assert np.all(ok["ceq_coupon_sem_ns_m"] < ok["ceq_coupon_ns_m"])
    np.testing.assert_allclose(ok["ceq_coupon_ns_m"], 441 * ok["ceq_cell_ns_m"], rtol=1e-9)
    assert (table["measured_cycles"] == config["fidelity"]["measured_cycles"]).all()
    assert (table["transient_cycles"] == config["fidelity"]["transient_cycles"]).all()
    for column in FIDELITY_COLUMNS:
        assert table[column].notna().all(), column
    assert table["liggghts_version"].str.contains("3.8").all()
    assert (table["wall_time_s"] > 0).all()


def test_every_case_has_a_record_a_log_and_a_benchmark(campaign_dir):
    table = pd.read_csv(campaign_dir / "results" / "ceq_table.csv")
    for case_id in table["case_id"]:
        assert (campaign_dir / "results" / "cases" / f"{case_id}.json").is_file()
        assert "C_eq(coupon)" in (campaign_dir / "logs" / "simulate_case" / f"{case_id}.log").read_text()
        assert (campaign_dir / "results" / "benchmarks" / "simulate_case" / f"{case_id}.tsv").is_file()
    check = pd.read_csv(campaign_dir / "results" / "packings" / "check.tsv", sep="\t")
    assert list(check["verdict"]) == ["ok", "ok"]
    assert (check["pile_height_mm"] < check["lid_height_mm"]).all()


def test_surrogate_and_its_cross_validation(campaign_dir):
    from pidpipe.design.surrogate import load_surrogate

    surrogate = load_surrogate(campaign_dir / "results" / "surrogate.json")
    assert surrogate.method == "rbf_thin_plate"
    assert surrogate.domain == {"freq_hz": (500.0, 1000.0), "accel_g": (5.0, 10.0),
                                "fill_pct": (23.81, 52.381)}
    table = read_ceq_table(campaign_dir / "results" / "ceq_table.csv")
    ok = table[table["status"] == "ok"]
    predicted = surrogate.predict(ok["freq_hz"], ok["accel_g"], ok["fill_pct"])
    np.testing.assert_allclose(predicted, ok["ceq_coupon_ns_m"], rtol=1e-6)  # interpolates
    cv = pd.read_csv(campaign_dir / "results" / "surrogate_cv.csv")
    point = cv[(cv["method"] == "rbf_thin_plate") & (cv["scheme"] == "point")]
    assert len(point) == 2  # log and linear targets
    assert (point["n_predictions"] == len(ok)).all()
    assert np.all(np.isfinite(point["rms_rel_error"])) and (point["rms_rel_error"] >= 0).all()


def test_the_m_eff_surrogate_and_its_maps(campaign_dir):
    """Every case measures m_eff; the campaign fits its GP (linear target) and maps it."""
    from pidpipe.design.surrogate import load_surrogate

    table = read_ceq_table(campaign_dir / "results" / "ceq_table.csv")
    measured = table[table["status"].isin(["ok", "flagged"])]
    for column in ("m_eff_cell_kg", "m_eff_cell_sem_kg", "m_eff_ratio", "bed_mass_kg",
                   "ceq_force_cell_ns_m", "ceq_force_cell_sem_ns_m"):
        assert np.all(np.isfinite(measured[column].to_numpy(dtype=float))), column
    np.testing.assert_allclose(measured["m_eff_ratio"],
                               measured["m_eff_cell_kg"] / measured["bed_mass_kg"], rtol=1e-9)
    surrogate = load_surrogate(campaign_dir / "results" / "surrogate_m_eff.json")
    assert (surrogate.method, surrogate.target, surrogate.value_column) == (
        "gp", "linear", "m_eff_cell_kg")
    _, sd = surrogate.predict_with_uncertainty(750.0, 7.5, 37.5)
    assert np.isfinite(sd) and sd > 0
    for name in ("m_eff_freq_fill", "m_eff_freq_accel"):
        for suffix in (".png", ".pdf"):
            assert (campaign_dir / "results" / "figures" / f"{name}{suffix}").stat().st_size > 0
    assert "m_eff surrogate gp" in (campaign_dir / "logs" / "fit_m_eff_surrogate.log").read_text()


def test_optimum_lies_in_the_environment_and_spends_the_budget(campaign_dir, config):
    optimum = pd.read_csv(campaign_dir / "results" / "optimum.csv")
    assert len(config["environments"]) == 1
    assert list(optimum["design"]) == ["peak", "band_mean", "worst_case"]
    env = config["environments"][0]
    peak = optimum.iloc[0]
    assert env["freq_hz"][0] - 1e-9 <= peak["freq_hz"] <= env["freq_hz"][1] + 1e-9
    assert env["accel_g"][0] - 1e-9 <= peak["accel_g"] <= env["accel_g"][1] + 1e-9
    n_b, full = budget_spheres(config), full_cell_spheres(config)
    draws = config["optimisation"]["bootstrap"]["draws"]
    for _, row in optimum.iterrows():
        assert row["environment"] == env["name"]
        assert 23.81 - 1e-6 <= row["fill_pct"] <= 52.381 + 1e-6     # the cells' fills
        assert row["n_budget_spheres"] == n_b and row["full_cell_spheres"] == full
        n_cells = int(row["n_cells"])
        assert n_cells == row["n_cells"] and 1 <= n_cells <= config["geometry"]["coupon_n_cells"]
        # (9/25-style) budget: spheres per cell x filled cells = n_b, to rounding
        assert row["spheres_per_cell"] * n_cells == pytest.approx(n_b, rel=1e-9)
        assert row["whole_spheres_per_cell"] * n_cells + row["spheres_left_over"] == n_b
        assert row["fill_pct"] == pytest.approx(100.0 * row["spheres_per_cell"] / full, rel=1e-9)
        assert row["total_ceq_ns_m"] == pytest.approx(row["ceq_per_cell_ns_m"] * n_cells, rel=1e-9)
        assert row["total_ceq_ns_m"] > 0 and row["n_converged"] >= 1
        assert (row["band_worst_total_ceq_ns_m"] <= row["band_mean_total_ceq_ns_m"]
                <= row["band_best_total_ceq_ns_m"])
        # the bootstrap: every case's SEM redrawn, draws re-optimised, intervals around the design
        assert row["bootstrap_draws"] == draws and row["bootstrap_used"] >= 0.9 * draws
        for name in ("fill_pct", "n_cells", "total_ceq_ns_m"):
            assert row[f"{name}_lo"] <= row[f"{name}_hi"]
        assert row["total_ceq_ns_m_lo"] < row["total_ceq_ns_m_hi"]
    history = pd.read_csv(campaign_dir / "results" / "optimum_history.csv")
    assert set(history["design"]) == {"peak", "band_mean", "worst_case"}
    for _, starts in history.groupby("design"):
        assert set(starts["start"]) >= set(range(config["optimisation"]["starts"]))
    assert (campaign_dir / "results" / "optimum.json").stat().st_size > 0
    boot = pd.read_csv(campaign_dir / "results" / "optimum_bootstrap.csv")
    assert len(boot) == 3 * draws


def test_figures_are_written_as_png_and_pdf(campaign_dir):
    for stem in ("ceq_freq_fill", "ceq_freq_accel", "convergence", "optimum_spread"):
        png = campaign_dir / "results" / "figures" / f"{stem}.png"
        pdf = campaign_dir / "results" / "figures" / f"{stem}.pdf"
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000
        assert pdf.read_bytes()[:5] == b"%PDF-" and pdf.stat().st_size > 5_000


def test_validate_checks_every_case_with_the_dem_on_the_campaigns_packings(campaign_dir):
    """`snakemake validate` reuses the LIGGGHTS records (no LIGGGHTS job runs) and shakes every
    case in the compiled DEM; grid.csv has one row a case with both C_eq and z_combined."""
    dry = planned_jobs(snakemake(campaign_dir, "validate", "--dry-run").stdout)
    assert dry == {"validate_case": 8, "collect_grid_check": 1, "validate": 1}
    run = snakemake(campaign_dir, "validate")
    assert run.returncode == 0, run.stdout[-3000:]
    grid = pd.read_csv(campaign_dir / "results" / "validation" / "grid.csv")
    table = pd.read_csv(campaign_dir / "results" / "ceq_table.csv")
    assert sorted(grid["case_id"]) == sorted(table["case_id"])
    for column in ("ceq_cell_liggghts_ns_m", "ceq_cell_dem_ns_m", "ceq_cell_dem_sem_ns_m",
                   "z_combined"):
        assert np.isfinite(grid[column]).all(), column
    np.testing.assert_allclose(grid.sort_values("case_id")["ceq_cell_liggghts_ns_m"],
                               table.sort_values("case_id")["ceq_cell_ns_m"], rtol=1e-12)
    both = grid[grid["both_ok"]]
    assert len(both) >= 5 and both["agree"].mean() >= 0.75, grid[["case_id", "z_combined"]]
    assert grid["dem_cpu_time_s"].sum() < grid["liggghts_cpu_time_s"].sum()
    assert (campaign_dir / "results" / "validation" / "grid.png").stat().st_size > 10_000
    record = json.loads(next((campaign_dir / "results" / "validation" / "dem").glob("*.json"))
                        .read_text())
    assert record["solver"] == "numba-dem"


def test_report_collects_figures_and_tables(campaign_dir):
    run = snakemake(campaign_dir, "--report", "report.html")
    assert run.returncode == 0, run.stdout[-3000:]
    assert "ERROR" not in run.stdout, run.stdout[-3000:]
    html = (campaign_dir / "report.html").read_text(errors="replace")
    for name in ("ceq_freq_fill.png", "convergence.png", "ceq_table.csv", "optimum.csv"):
        assert name in html


def test_regimes_gallery_and_movie_of_the_chosen_cases(campaign_dir, config):
    """Every row's regime comes from its cells' motion; the chosen cases have their phase
    figure (in the report) and their movie."""
    from pidpipe.cell.vtk_series import read_pvd
    from pidpipe.measurement.regime import REGIMES

    table = pd.read_csv(campaign_dir / "results" / "ceq_table.csv")
    done = table[table["status"].isin(["ok", "flagged"])]
    assert done["regime"].isin(REGIMES).all(), done[["case_id", "regime"]]
    assert done["regime_cells"].str.contains(":").all()
    html = (campaign_dir / "report.html").read_text(errors="replace")
    for case_id in config["inspection"]["phase_figure_cases"]:
        png = campaign_dir / "results" / "figures" / "phase" / f"{case_id}.png"
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000
        assert f"{case_id}.png" in html
    for case_id in config["inspection"]["movie_cases"]:
        entries = read_pvd(campaign_dir / "results" / "movies" / case_id / "movie.pvd")
        frames = config["inspection"]["movie_frames_per_cycle"] * config["inspection"]["movie_cycles"]
        assert len(entries) == 2 * frames and all(path.is_file() for _, _, path in entries)


def test_second_run_has_nothing_to_do(campaign_dir):
    run = snakemake(campaign_dir, "--dry-run")
    assert run.returncode == 0, run.stdout[-3000:]
    assert "Nothing to be done" in run.stdout


def test_deleted_record_reruns_only_its_case_and_a_failed_case_is_marked(campaign_dir, tmp_path):
    failing = "f1000Hz_G10_r50pct_rep0"
    record = campaign_dir / "results" / "cases" / f"{failing}.json"
    record.unlink()
    dry = snakemake(campaign_dir, "--dry-run")
    jobs = planned_jobs(dry.stdout)
    assert jobs["simulate_case"] == 1, dry.stdout[-3000:]
    assert "pour_packing" not in jobs and "check_packings" not in jobs
    assert f"results/cases/{failing}.json" in dry.stdout
    assert sum("output: results/cases/" in line for line in dry.stdout.splitlines()) == 1

    # That case's LIGGGHTS fails: the others stay, the table marks it, the surrogate refuses
    # the hole instead of interpolating over it.
    fake = tmp_path / "liggghts"
    fake.write_text(f'#!/bin/sh\ncase "$PWD" in *{failing}*) '
                    'echo "ERROR: injected failure"; exit 1;; esac\n'
                    f'exec {LIGGGHTS} "$@"\n')
    fake.chmod(0o755)
    # (targets: the table and the surrogate that reads it; the designs and figures after them
    # would only wait for the surrogate)
    run = snakemake(campaign_dir, "--keep-going", *SURROGATE_TARGETS,
                    env={"PIDPIPE_LIGGGHTS": str(fake)})
    assert run.returncode != 0
    assert f"case {failing} failed" in run.stdout
    assert f"logs/simulate_case/{failing}.log" in run.stdout
    assert "Traceback" not in run.stdout
    table = read_ceq_table(campaign_dir / "results" / "ceq_table.csv")
    row = table.set_index("case_id").loc[failing]
    assert row["status"] == "failed" and np.isnan(row["ceq_coupon_ns_m"])
    assert "injected failure" in row["message"] and "screen.txt" in row["message"]
    assert (table["status"] == "ok").sum() >= 5
    assert "grid point(s) empty" in run.stdout and "f=1000 Hz, G=10 g, r=52.381 %" in run.stdout

    # Retry: delete the failed record, run again with the real LIGGGHTS.
    record.unlink()
    run = snakemake(campaign_dir, *SURROGATE_TARGETS)
    assert run.returncode == 0, run.stdout[-5000:]
    table = read_ceq_table(campaign_dir / "results" / "ceq_table.csv")
    assert table.set_index("case_id").loc[failing, "status"] != "failed"


def test_bad_config_stops_before_any_job_with_the_key(tmp_path):
    write_config(tmp_path, grid={"freq_hz": [-500, 1000]})
    run = snakemake(tmp_path)
    assert run.returncode != 0
    assert "grid.freq_hz[0] = -500" in run.stdout and "must be > 0" in run.stdout
    assert "Traceback" not in run.stdout
    assert not (tmp_path / "results").exists() and not (tmp_path / "logs").exists()


def test_packings_that_do_not_fit_stop_the_run_before_any_case(tmp_path):
    # The source's 36 spheres per full cell: 75 % and 90 % (27 and 32 spheres) do not fit.
    write_config(tmp_path, fill={"definition": "source_36"}, grid={"fill_pct": [25]})
    run = snakemake(tmp_path, "packings")
    assert run.returncode == 0, run.stdout[-3000:]
    checked = (tmp_path / "results" / "packings" / "check.tsv").read_text()

    write_config(tmp_path, fill={"definition": "source_36"}, grid={"fill_pct": [25, 75, 90]})
    run = snakemake(tmp_path, "--keep-going")
    assert run.returncode != 0
    assert "2 of 3 packing(s) refused" in run.stdout, run.stdout[-3000:]
    for fill in (75, 90):
        for freq in (500, 1000):
            for accel in (5, 10):
                assert f"f{freq}Hz_G{accel}_r{fill}pct_rep0" in run.stdout
    assert "Traceback" not in run.stdout
    assert not (tmp_path / "results" / "cases").exists()
    # the last good check is kept, so cases already run are not rerun once the grid is fixed
    assert (tmp_path / "results" / "packings" / "check.tsv").read_text() == checked


def test_external_table_is_optimised_without_any_dem_run(tmp_path):
    rows = [{"freq_hz": f, "accel_g": g, "fill_pct": r, "ceq_coupon_ns_m": 0.05 * f * r / g}
            for f in (500, 1000) for g in (5, 10) for r in (25, 50)]
    pd.DataFrame(rows).to_csv(tmp_path / "published.csv", index=False)
    write_config(tmp_path, optimisation={"external_ceq_table": "published.csv"})
    run = snakemake(tmp_path)
    assert run.returncode == 0, run.stdout[-5000:]
    assert not (tmp_path / "results" / "cases").exists()
    assert not (tmp_path / "results" / "ceq_table.csv").exists()
    from pidpipe.design.surrogate import load_surrogate

    surrogate = load_surrogate(tmp_path / "results" / "surrogate.json")
    assert len(surrogate.training) == 8
    optimum = pd.read_csv(tmp_path / "results" / "optimum.csv")
    # C_eq grows with f and falls with G: the optimum sits at the top of the band in f, the
    # bottom in G
    assert optimum["freq_hz"].iloc[0] == pytest.approx(900.0, rel=1e-6)
    assert optimum["accel_g"].iloc[0] == pytest.approx(6.0, rel=1e-6)
    assert (tmp_path / "results" / "figures" / "convergence.png").is_file()


def test_several_cells_per_run_pour_their_own_packings_and_report_their_spread(tmp_path):
    """fidelity.cells_per_run = 2 with 2 replicates: 4 packings per fill, none shared; each
    record holds its 2 cells; the table averages the 2 runs and says how many cells each had."""
    write_config(tmp_path, grid={"freq_hz": [1000], "accel_g": [10], "fill_pct": [25],
                                 "replicates": 2}, environments=[],
                 fidelity={"cells_per_run": 2, "transient_cycles": 10, "measured_cycles": 6})
    run = snakemake(tmp_path, "table")
    assert run.returncode == 0, run.stdout[-3000:]
    checked = pd.read_csv(tmp_path / "results" / "packings" / "check.tsv", sep="\t")
    assert sorted(checked["packing_id"]) == [f"r25pct_rep{k}" for k in range(4)]
    seeds = []
    for replicate in (0, 1):
        record = json.loads((tmp_path / "results" / "cases" /
                             f"f1000Hz_G10_r25pct_rep{replicate}.json").read_text())
        assert len(record["cells"]) == 2 and record["fidelity"]["cells_per_run"] == 2
        seeds += record["fidelity"]["seeds"]
    assert len(set(seeds)) == 4
    table = pd.read_csv(tmp_path / "results" / "ceq_table.csv")
    assert len(table) == 1
    assert table.loc[0, "cells_per_run"] == 2 and table.loc[0, "n_replicates"] == 2
