"""The C_eq table contract: what is accepted, and that every bad table gets a clear error."""

import numpy as np
import pandas as pd
import pytest

from pidpipe.design.ceq_table import (
    OPTIONAL_COLUMNS,
    REQUIRED_COLUMNS,
    read_ceq_table,
    split_usable,
    validate_ceq_table,
)
from pidpipe.errors import TableError


def campaign_table() -> pd.DataFrame:
    """Four cases as the campaign writes them: every required and optional column."""
    table = pd.DataFrame({
        "case_id": ["a", "b", "c", "d"],
        "freq_hz": [50.0, 100.0, 50.0, 100.0],
        "accel_g": [1.0, 1.0, 5.0, 5.0],
        "fill_pct": [25.0, 25.0, 25.0, 25.0],
        "ceq_coupon_ns_m": [0.1, 0.2, 0.3, np.nan],
        "status": ["ok", "ok", "flagged", "failed"],
        "flags": ["", "", "sem>10%", "engine exit 1"],
    })
    for column in OPTIONAL_COLUMNS:
        if column not in table.columns:
            table[column] = 1.0 if column != "liggghts_version" else "3.8.0"
    return table


def write(tmp_path, table: pd.DataFrame, name: str = "ceq.csv"):
    path = tmp_path / name
    table.to_csv(path, index=False)
    return path


def test_campaign_table_is_read_with_numeric_columns(tmp_path):
    table = read_ceq_table(write(tmp_path, campaign_table()))
    assert len(table) == 4
    for column in REQUIRED_COLUMNS + ("n_spheres", "wall_time_s"):
        assert table[column].dtype == np.float64
    assert list(table["status"]) == ["ok", "ok", "flagged", "failed"]


def test_minimal_published_table_without_status_is_all_usable(tmp_path):
    table = pd.DataFrame({"freq_hz": [50, 100], "accel_g": [1, 1], "fill_pct": [25, 50],
                          "ceq_coupon_ns_m": [0.5, 1.5], "source": ["paper", "paper"]})
    used, excluded = split_usable(read_ceq_table(write(tmp_path, table)))
    assert len(used) == 2 and excluded.empty
    assert "source" in used.columns  # unknown columns are kept, not refused


def test_split_usable_keeps_only_ok_rows_and_reports_the_others(tmp_path):
    used, excluded = split_usable(read_ceq_table(write(tmp_path, campaign_table())))
    assert list(used["case_id"]) == ["a", "b"]
    assert list(excluded["case_id"]) == ["c", "d"]


def test_missing_required_column_names_file_and_column(tmp_path):
    path = write(tmp_path, campaign_table().drop(columns=["fill_pct"]), "nofill.csv")
    with pytest.raises(TableError, match=r"nofill\.csv.*missing required column\(s\) fill_pct"):
        read_ceq_table(path)


def test_non_numeric_value_names_column_and_row(tmp_path):
    table = campaign_table().astype({"accel_g": object})
    table.loc[2, "accel_g"] = "five"
    with pytest.raises(TableError, match=r"ceq\.csv: column accel_g is not numeric in row\(s\) 3"):
        read_ceq_table(write(tmp_path, table))


def test_nan_in_an_ok_row_is_refused_but_allowed_in_a_failed_row(tmp_path):
    table = campaign_table()
    read_ceq_table(write(tmp_path, table))  # row 4 is failed with NaN: fine
    table.loc[1, "ceq_coupon_ns_m"] = np.inf
    with pytest.raises(TableError, match=r"column ceq_coupon_ns_m is missing or not finite in status ok row\(s\) 2"):
        read_ceq_table(write(tmp_path, table))


def test_empty_cell_in_ok_row_is_refused(tmp_path):
    path = tmp_path / "holes.csv"
    path.write_text("freq_hz,accel_g,fill_pct,ceq_coupon_ns_m\n50,1,25,0.1\n100,,25,0.2\n")
    with pytest.raises(TableError, match=r"holes\.csv: column accel_g .* row\(s\) 2"):
        read_ceq_table(path)


def test_unknown_status_is_refused(tmp_path):
    table = campaign_table()
    table.loc[0, "status"] = "done"
    with pytest.raises(TableError, match=r"column status has value\(s\) done in row\(s\) 1"):
        read_ceq_table(write(tmp_path, table))


@pytest.mark.parametrize("column, value, rule", [
    ("ceq_coupon_ns_m", -0.5, "must be >= 0"),
    ("fill_pct", 120.0, r"must be in \(0, 100\]"),
    ("freq_hz", 0.0, "must be > 0 Hz"),
])
def test_non_physical_values_are_refused(tmp_path, column, value, rule):
    table = campaign_table()
    table.loc[1, column] = value
    with pytest.raises(TableError, match=rf"column {column} {rule}.* row\(s\) 2"):
        read_ceq_table(write(tmp_path, table))


def test_missing_file_and_empty_table(tmp_path):
    with pytest.raises(TableError, match="no such file"):
        read_ceq_table(tmp_path / "absent.csv")
    with pytest.raises(TableError, match="has no rows"):
        validate_ceq_table(pd.DataFrame(columns=list(REQUIRED_COLUMNS)))
