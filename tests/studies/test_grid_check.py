"""The grid check's table and parity figure from pairs of records (no solver runs)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pidpipe.figures.parity import plot_parity
from pidpipe.measurement.case_record import CaseRecord
from pidpipe.studies.grid_check import GRID_COLUMNS, grid_row, grid_summary, grid_table


def _record(solver, value, sem, status="ok", flags=(), case_id="f500Hz_G5_r50pct_rep0",
            cpu=1.0):
    return CaseRecord(solver=solver, case_id=case_id, freq_hz=500.0, accel_g=5.0,
                      fill_pct=50.0, n_spheres=11, regime="impacting", status=status,
                      flags=list(flags), ceq_cell_ns_m=value, ceq_cell_sem_ns_m=sem,
                      fidelity={"cells_per_run": 7, "measured_cycles": 40, "transient_cycles": 15},
                      engine={"cpu_time_s": cpu})


def test_z_combined_is_the_difference_over_the_combined_sem():
    row = grid_row(_record("liggghts", 0.10, 0.003), _record("numba-dem", 0.11, 0.004, cpu=0.1))
    assert row["z_combined"] == pytest.approx(0.01 / 0.005)
    assert row["agree"] and row["both_ok"]
    assert row["ratio_dem_over_liggghts"] == pytest.approx(1.1)
    assert row["dem_cpu_time_s"] == 0.1 and row["cells_per_run"] == 7
    assert set(row) == set(GRID_COLUMNS)


def _with_cells(record, values, seeds):
    return record.with_(cells=[{"seed": s, "ceq_cell_ns_m": v} for s, v in zip(seeds, values)])


def test_the_paired_test_sees_a_systematic_difference_the_packing_spread_hides():
    # 8 packings spread by 20 %: each solver's SEM is dominated by that common spread, but the
    # DEM is 3 % lower on every cell (+- 0.5 % cycle noise): invisible to z_combined, not paired
    rng = np.random.default_rng(1)
    levels = 0.1 * (1 + 0.2 * rng.standard_normal(8))
    lig = levels * (1 + 0.005 * rng.standard_normal(8))
    dem = 0.97 * levels * (1 + 0.005 * rng.standard_normal(8))
    sem = lambda v: v.std(ddof=1) / math.sqrt(v.size)                     # noqa: E731
    seeds = list(range(100, 108))
    row = grid_row(_with_cells(_record("liggghts", lig.mean(), sem(lig)), lig, seeds),
                   _with_cells(_record("numba-dem", dem.mean(), sem(dem)), dem, seeds))
    assert row["agree"] and abs(row["z_combined"]) < 1
    assert row["paired_cells"] == 8
    assert row["paired_rel_diff"] == pytest.approx((dem - lig).mean() / lig.mean())
    assert row["paired_rel_diff"] == pytest.approx(-0.03, abs=0.01)
    assert not row["paired_agree"] and row["z_paired"] < -5
    # cells are matched by seed, not by position
    shuffled = _with_cells(_record("numba-dem", dem.mean(), sem(dem)), dem[::-1], seeds[::-1])
    assert grid_row(_with_cells(_record("liggghts", lig.mean(), sem(lig)), lig, seeds),
                    shuffled)["z_paired"] == pytest.approx(row["z_paired"])


def test_without_cells_in_both_there_is_no_paired_test():
    row = grid_row(_record("liggghts", 0.10, 0.003), _record("numba-dem", 0.11, 0.004))
    assert row["paired_cells"] == 0 and math.isnan(row["z_paired"]) and not row["paired_agree"]


def test_flags_and_failures_are_kept_and_counted_apart(tmp_path):
    pairs = [
        (_record("liggghts", 0.10, 0.003, case_id="a"), _record("numba-dem", 0.10, 0.003, case_id="a")),
        (_record("liggghts", 0.10, 0.001, case_id="b"), _record("numba-dem", 0.2, 0.001, case_id="b")),
        (_record("liggghts", 0.10, 0.05, "flagged", ["not_steady"], case_id="c"),
         _record("numba-dem", 0.3, 0.01, case_id="c")),
        (_record("liggghts", math.nan, math.nan, "failed", case_id="d"),
         _record("numba-dem", 0.3, 0.01, case_id="d")),
    ]
    table = grid_table(pairs)
    assert list(table.columns) == list(GRID_COLUMNS)
    flagged = table.set_index("case_id")
    assert flagged.loc["c", "liggghts_flags"] == "not_steady" and not flagged.loc["c", "both_ok"]
    assert not flagged.loc["d", "agree"] and math.isnan(flagged.loc["d", "z_combined"])
    summary = grid_summary(table)
    assert summary["cases"] == 4 and summary["both_ok"] == 2 and summary["agree_both_ok"] == 1
    assert summary["disagreeing"] == ["b"]
    paths = plot_parity(table, tmp_path / "grid")
    assert [p.suffix for p in paths] == [".png", ".pdf"] and all(p.stat().st_size for p in paths)
