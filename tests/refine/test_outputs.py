"""rounds.csv (written, and updated by a resumed loop) and the convergence figure."""

import numpy as np
import pandas as pd
import pytest

from pidpipe.figures.refine import plot_refine
from pidpipe.refine.intervals import Z95, DesignInterval
from pidpipe.refine.loop import RoundRecord
from pidpipe.refine.outputs import ROUND_COLUMNS, read_table, rounds_frame, write_rounds, write_table
from pidpipe.refine.table import start_table


def _record(round_index, value, std, z=float("nan"), open_lines=()):
    intervals = [DesignInterval("low", kind, 45.0, 490, 441, np.nan, np.nan, value, std, "point")
                 for kind in ("peak", "band_mean")]
    return RoundRecord(round_index, intervals, {"low/peak": z}, list(open_lines), cases_added=2,
                       engine_cpu_s=20.0, cumulative_cpu_s=20.0 * round_index)


def test_rounds_csv_has_a_row_per_round_and_design_with_its_interval(tmp_path):
    path = write_rounds([_record(1, 80.0, 8.0, open_lines=["low/peak: wide"]),
                         _record(2, 78.0, 2.0, z=1.3)], tmp_path / "refine" / "rounds.csv")
    table = pd.read_csv(path)
    assert list(table.columns) == list(ROUND_COLUMNS)
    assert len(table) == 4
    row = table[(table["round"] == 2) & (table["design"] == "peak")].iloc[0]
    assert row["total_ceq_lo_ns_m"] == pytest.approx(78.0 - Z95 * 2.0)
    assert row["half_width_fraction"] == pytest.approx(Z95 * 2.0 / 78.0)
    assert row["verify_worst_abs_z"] == pytest.approx(1.3)
    first = table[(table["round"] == 1) & (table["design"] == "peak")].iloc[0]
    assert first["open"] == "low/peak: wide"
    assert np.isnan(table[(table["round"] == 1) & (table["design"] == "band_mean")]["verify_worst_abs_z"]).all()


def test_a_resumed_loop_replaces_its_rounds_and_keeps_the_earlier_ones(tmp_path):
    path = tmp_path / "rounds.csv"
    write_rounds([_record(1, 80.0, 8.0), _record(2, 79.0, 4.0)], path)
    write_rounds([_record(2, 78.0, 2.0), _record(3, 77.0, 1.0)], path)
    table = pd.read_csv(path)
    assert table["round"].tolist() == [1, 1, 2, 2, 3, 3]
    assert table.loc[table["round"] == 2, "total_ceq_ns_m"].tolist() == [78.0, 78.0]


def test_the_table_reads_back_as_written(tmp_path):
    grid = pd.DataFrame({"freq_hz": [100.0, 500.0], "accel_g": [1.0, 5.0], "fill_pct": [25.0, 50.0],
                         "ceq_coupon_ns_m": [1.5, 2.25], "ceq_coupon_sem_ns_m": [0.1, np.nan]})
    table = start_table(grid)
    back = read_table(write_table(table, tmp_path / "t.csv"))
    pd.testing.assert_frame_equal(back[table.columns], table, check_dtype=False)


def test_the_convergence_figure_is_drawn_per_environment_and_design(tmp_path):
    frame = rounds_frame([_record(1, 80.0, 8.0), _record(2, 78.0, 2.0, z=1.3)])
    paths = plot_refine(frame, tmp_path / "refine_convergence", interval_fraction=0.1)
    assert [p.suffix for p in paths] == [".png", ".pdf"]
    assert all(p.stat().st_size > 1000 for p in paths)
    assert not list(tmp_path.glob(".*part"))
