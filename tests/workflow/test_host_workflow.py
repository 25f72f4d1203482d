"""`snakemake --cores 2 host` on the reduced config: an external C_eq table (no shaking runs),
its surrogate and designs, two poured packings, and a short coupled sweep (few frequencies, few
cycles: exercises the stage, not numbers anyone reports)."""

from __future__ import annotations

import json

import matplotlib.image
import numpy as np
import pandas as pd

from tests._snakemake import WORKFLOW_MARKS, planned_jobs, snakemake, write_config

pytestmark = WORKFLOW_MARKS

HOST = {"cells": 2, "force_n": [0.05], "freq_points": 3, "freq_span_fraction": 0.1,
        "transient_cycles": 2, "measured_cycles": 4, "surrogate_draws": 3}


def _table(path) -> None:
    rows = [{"freq_hz": f, "accel_g": g, "fill_pct": r, "status": "ok",
             "ceq_coupon_ns_m": 2.0 * r / 25 * min(g, 3.0) / 3.0 * (f / 500) ** 0.5,
             "ceq_coupon_sem_ns_m": 0.1}
            for f in (500, 1000) for g in (1, 2, 5, 10) for r in (25, 50)]
    pd.DataFrame(rows).to_csv(path, index=False)


def _config(workdir) -> None:
    _table(workdir / "published.csv")
    write_config(workdir, optimisation={"external_ceq_table": "published.csv", "starts": 4,
                                        "band_quadrature_points": 3, "band_grid_points": 3,
                                        "bootstrap": {"draws": 0}},
                 fidelity={"settle_time_s": 0.05}, host=HOST)


def test_the_host_check_is_not_part_of_all(tmp_path):
    _config(tmp_path)
    jobs = planned_jobs(snakemake(tmp_path, "--dry-run").stdout)
    assert "optimise_environments" in jobs and "check_host" not in jobs


def test_the_host_target_compares_both_models(tmp_path):
    _config(tmp_path)
    run = snakemake(tmp_path, "host")
    assert run.returncode == 0, run.stdout[-5000:]
    results = tmp_path / "results"
    assert not (results / "cases").exists()
    curves = pd.read_csv(results / "host" / "curves.csv")
    assert sorted(curves["model"].unique()) == ["coupled", "equivalent", "equivalent_bare_mass"]
    assert len(curves) == 3 * 3
    coupled = curves[curves["model"] == "coupled"]
    assert np.all(np.isfinite(coupled["amplitude_m"]) & (coupled["amplitude_m"] > 0))
    assert np.all(np.isfinite(coupled["amplitude_unc_m"]))
    assert np.all(coupled["balance_residual_fraction"] < 0.01)
    # the dashpot models' uncertainty comes from the redrawn surrogates
    equivalent = curves[curves["model"] == "equivalent"]
    assert np.all(equivalent["amplitude_unc_m"] > 0)
    summary = pd.read_csv(results / "host" / "summary.csv")
    assert list(summary["model"]) == ["coupled", "equivalent", "equivalent_bare_mass"]
    assert summary.loc[1:, "amplitude_rel_diff"].notna().all()
    meta = json.loads((results / "host" / "host.json").read_text())
    assert meta["engine"]["solver"] == "numba-dem" and meta["load"]["cells_integrated"] == 2
    assert meta["host"]["natural_freq_hz"] == 750.0          # the band centre of 600-900 Hz
    image = matplotlib.image.imread(results / "host" / "host.png")
    assert image.shape[0] > 300 and image[..., :3].std() > 0.05
    log = (tmp_path / "logs" / "check_host.log").read_text()
    assert "vs coupled" in log
