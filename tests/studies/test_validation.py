"""The comparison of the two solvers' records (the solvers themselves are tested elsewhere)."""

from __future__ import annotations

import math

import pytest

from pidpipe.measurement.case_record import CaseRecord
from pidpipe.studies.validation import (
    TABLE_COLUMNS,
    compare_records,
    plot_comparison,
    write_table,
)


def _record(ed, sem, **extra):
    """A simulate_cell record (the DEM's side)."""
    per_joule = 1.0 / (math.pi * 2 * math.pi * 500.0 * (5 * 9.81 / (2 * math.pi * 500.0) ** 2) ** 2)
    return {"ed_cycle_mean_j": ed, "ed_cycle_sem_j": sem, "ceq_cell_ns_m": ed * per_joule,
            "ceq_cell_sem_ns_m": sem * per_joule, "freq_hz": 500.0, "accel_g": 5.0,
            "fill_pct": 50.0, "n_spheres": 11, "case_id": "f500Hz_G5_r50pct_rep0", **extra}


def _case_record(ed, sem, **extra):
    """The same values as a LIGGGHTS case record."""
    return CaseRecord(solver="liggghts", status="ok", **_record(ed, sem, **extra))


def test_agreement_is_judged_against_the_combined_uncertainty():
    row = compare_records(_case_record(1.0e-8, 0.3e-9), _record(1.1e-8, 0.4e-9))
    assert row["difference_over_combined_sem"] == pytest.approx(0.1e-8 / 0.5e-9)   # 2.0
    assert row["agree"]                                   # exactly at 2 sigma
    assert not compare_records(_case_record(1.0e-8, 0.3e-9), _record(1.11e-8, 0.4e-9))["agree"]
    assert row["ratio_dem_over_liggghts"] == pytest.approx(1.1)
    assert row["ratio_sem"] == pytest.approx(1.1 * math.hypot(0.03, 0.4 / 11))


def test_table_and_plot_are_written(tmp_path):
    rows = [compare_records(_case_record(1.0e-8, 0.3e-9), _record(1.05e-8, 0.4e-9))]
    table = write_table(rows, tmp_path / "validation.csv").read_text().splitlines()
    assert table[0].split(",") == list(TABLE_COLUMNS) and len(table) == 2
    assert plot_comparison(rows, tmp_path / "validation.png").stat().st_size > 1000


def test_each_solvers_discarded_transient_and_flags_are_reported():
    liggghts = _case_record(1.0e-8, 0.3e-9, fidelity={"transient_cycles": 10}, flags=["not_resolved"])
    dem = _record(1.05e-8, 0.4e-9, fidelity={"transient_cycles": 5}, flags=[])
    row = compare_records(liggghts, dem)
    assert (row["liggghts_transient_cycles"], row["dem_transient_cycles"]) == (10, 5)
    assert (row["liggghts_flags"], row["dem_flags"]) == ("not_resolved", "")
