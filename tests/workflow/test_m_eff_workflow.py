"""The m_eff surrogate in the workflow (dry runs: the DAG, no job runs)."""

from __future__ import annotations

import re
import sys

import pandas as pd
import pytest

from tests._snakemake import SNAKEMAKE, planned_jobs, snakemake, write_config

pytestmark = pytest.mark.skipif(not SNAKEMAKE.is_file(),
                                reason=f"snakemake is not installed next to {sys.executable}")


def test_the_campaign_fits_and_maps_the_m_eff_surrogate(tmp_path):
    write_config(tmp_path)
    run = snakemake(tmp_path, "--dry-run")
    assert run.returncode == 0, run.stdout[-3000:]
    jobs = planned_jobs(run.stdout)
    assert jobs["fit_m_eff_surrogate"] == 1 and jobs["plot_m_eff_surrogate"] == 1
    assert "output: results/surrogate_m_eff.json" in run.stdout
    assert re.search(r"output: results/figures/m_eff_freq_fill\.png", run.stdout)


def test_the_host_check_waits_for_the_m_eff_surrogate(tmp_path):
    write_config(tmp_path)
    run = snakemake(tmp_path, "host", "--dry-run")
    assert run.returncode == 0, run.stdout[-3000:]
    check = run.stdout.split("rule check_host:", 1)[1].split("\n\n", 1)[0]
    assert "results/surrogate_m_eff.json" in check.split("output:", 1)[0]


def test_an_external_table_has_no_m_eff_surrogate(tmp_path):
    rows = [{"freq_hz": f, "accel_g": g, "fill_pct": r, "status": "ok",
             "ceq_coupon_ns_m": 1.0 + g, "ceq_coupon_sem_ns_m": 0.1}
            for f in (500, 1000) for g in (5, 10) for r in (25, 50)]
    pd.DataFrame(rows).to_csv(tmp_path / "published.csv", index=False)
    write_config(tmp_path, optimisation={"external_ceq_table": "published.csv"})
    for target in ("all", "host"):
        run = snakemake(tmp_path, target, "--dry-run")
        assert run.returncode == 0, run.stdout[-3000:]
        jobs = planned_jobs(run.stdout)
        assert "fit_m_eff_surrogate" not in jobs and "plot_m_eff_surrogate" not in jobs
