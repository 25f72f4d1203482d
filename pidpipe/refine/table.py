"""The refinement's C_eq table: append-only, each row saying where it came from and why.

The loop never rewrites a row. A row it adds carries

``source``
    ``"grid"`` (the campaign's pilots, before the loop), ``"refine round N"`` (a case the loop
    chose in round N) or ``"verify"`` (a verifying case);
``reason``
    why it was chosen (the score that chose it, or the design and point it verifies);
``refine_round``
    the round that added it (0 for the grid);
``action``
    ``"new"`` (a new case), ``"extend"`` (more cells or cycles on an existing case: the row
    supersedes the case's earlier row), ``"verify"`` (a verifying point's first run) or
    ``"reverify"`` (another run of a verifying point that failed, pooled with the first);
``planned_cpu_s``
    the engine CPU the cost model planned for it, s (0 for the grid: the loop's budget counts
    only what the loop spends).

A case is identified by its key (:func:`case_key`: f, G and r rounded). The table a round fits
(:func:`fit_table`) is the latest row of every key among the rows of earlier rounds, verifying
rows left out: they stay out of sample, so that a verification is never a comparison of the
surrogate with its own data. Because the rows of round N are decided from the rows of rounds
< N (and from round N's own first verifying runs, themselves decided so), a loop restarted from
the table it wrote decides round N again exactly as before and finds the rows it already has.
"""

from __future__ import annotations

import io

import numpy as np
import pandas as pd

from pidpipe.design.ceq_table import COORDINATE_COLUMNS, SEM_COLUMN, VALUE_COLUMN

#: Columns the loop adds to every row, besides the C_eq table's.
REFINE_COLUMNS: tuple[str, ...] = ("case_key", "source", "reason", "refine_round", "action",
                                   "planned_cpu_s")

#: ``source`` of the campaign's rows before the loop, and of verifying rows.
GRID_SOURCE, VERIFY_SOURCE = "grid", "verify"

#: Decimals of the key's coordinates (Hz, g, %).
KEY_DECIMALS = {"freq_hz": 3, "accel_g": 4, "fill_pct": 3}


def round_source(round_index: int) -> str:
    """``source`` of a case chosen in round N."""
    return f"refine round {int(round_index)}"


def case_key(freq_hz: float, accel_g: float, fill_pct: float) -> str:
    """The case's identity in the table: ``f<Hz>_G<g>_r<%>``, coordinates rounded."""
    f = round(float(freq_hz), KEY_DECIMALS["freq_hz"])
    g = round(float(accel_g), KEY_DECIMALS["accel_g"])
    r = round(float(fill_pct), KEY_DECIMALS["fill_pct"])
    return f"f{f:g}_G{g:g}_r{r:g}"


def start_table(grid: pd.DataFrame) -> pd.DataFrame:
    """The grid's C_eq table with the loop's columns (a table that has them is returned as is).

    Parameters
    ----------
    grid : pandas.DataFrame
        Rows of ``results/ceq_table.csv``: at least f, G, r, C_eq; SEM, status, flags optional.
    """
    table = grid.copy().reset_index(drop=True)
    if "refine_round" in table.columns:
        return table
    table["case_key"] = [case_key(*row) for row in table[list(COORDINATE_COLUMNS)].to_numpy()]
    if "status" not in table.columns:
        table["status"] = "ok"
    if SEM_COLUMN not in table.columns:
        table[SEM_COLUMN] = np.nan
    if "source" not in table.columns:
        table["source"] = GRID_SOURCE
    table["reason"] = table.get("reason", pd.Series("grid", index=table.index)).fillna("grid")
    table["refine_round"] = 0
    table["action"] = "new"
    table["planned_cpu_s"] = 0.0
    return table


def from_csv(source) -> pd.DataFrame:
    """A table the loop wrote, read from a path or a text stream (``status``, ``source``,
    ``reason``, ``action`` and ``case_key`` as text, ``refine_round`` as int)."""
    table = pd.read_csv(source, keep_default_na=True)
    for column in ("status", "source", "reason", "action", "case_key"):
        if column in table.columns:
            table[column] = table[column].fillna("").astype(str)
    table["refine_round"] = table["refine_round"].astype(int)
    return table


def as_stored(table: pd.DataFrame) -> pd.DataFrame:
    """The table as it reads back from its CSV file (:func:`from_csv`).

    The loop decides every round from the table in this form, whether the table was read from
    its file or grown in memory: a loop resumed from its file then decides exactly as the loop
    that wrote it (the text of a missing flag, a column's type, would otherwise differ)."""
    return from_csv(io.StringIO(table.to_csv(index=False)))


def with_grid(table: pd.DataFrame, grid: pd.DataFrame) -> pd.DataFrame:
    """The loop's table on ``grid``: its grid rows (round 0) replaced by ``grid``'s when they
    differ (same rows, in order, and same C_eq and SEM), its own rows kept after them.

    The loop's rows stay measurements of their cases whatever grid they were chosen from; a
    loop resumed on a new grid decides its next round from both.
    """
    fresh = start_table(grid)
    mine = table[table["refine_round"] == 0]
    columns = ["case_key", VALUE_COLUMN, SEM_COLUMN]
    same = (len(mine) == len(fresh) and all(c in mine.columns for c in columns)
            and mine["case_key"].tolist() == fresh["case_key"].tolist()
            and np.allclose(mine[columns[1:]].to_numpy(dtype=float),
                            fresh[columns[1:]].to_numpy(dtype=float), rtol=1e-9, atol=0.0,
                            equal_nan=True))
    if same:
        return table
    return append_rows(fresh, table[table["refine_round"] > 0])


def append_rows(table: pd.DataFrame, rows: pd.DataFrame) -> pd.DataFrame:
    """The table with ``rows`` after it (columns united; the order of rows kept)."""
    if rows is None or rows.empty:
        return table
    return pd.concat([table, rows], ignore_index=True, sort=False)


def fit_table(table: pd.DataFrame, before_round: int) -> pd.DataFrame:
    """What round ``before_round`` fits: the latest row of each key among rows of earlier
    rounds, verifying rows left out; in the order of first appearance of each key."""
    earlier = table[(table["refine_round"] < before_round) & (table["source"] != VERIFY_SOURCE)]
    latest = earlier.drop_duplicates("case_key", keep="last")
    order = {key: i for i, key in enumerate(earlier.drop_duplicates("case_key")["case_key"])}
    return latest.iloc[np.argsort([order[k] for k in latest["case_key"]], kind="stable")]


def verify_rows(table: pd.DataFrame, round_index: int) -> pd.DataFrame:
    """Every verifying run round N compares: its own first runs of points (``verify``, rounds
    <= N) and the reruns of failing points chosen in earlier rounds (``reverify``, rounds < N)."""
    rounds, action = table["refine_round"], table["action"]
    return table[((action == "verify") & (rounds <= round_index))
                 | ((action == "reverify") & (rounds < round_index))]


def rows_of_round(table: pd.DataFrame, round_index: int, action: str) -> pd.DataFrame:
    """Rows the loop added in one round with one action (``new``, ``extend`` or ``verify``)."""
    return table[(table["refine_round"] == round_index) & (table["action"] == action)]


def spent_cpu_s(table: pd.DataFrame) -> float:
    """Planned engine CPU of every row the loop added, s."""
    return float(np.nansum(table["planned_cpu_s"].to_numpy(dtype=float)))


def last_round(table: pd.DataFrame) -> int:
    """The highest round that added a row (0: only the grid)."""
    return int(table["refine_round"].max()) if len(table) else 0


def values_and_sems(rows: pd.DataFrame) -> tuple[np.ndarray, np.ndarray]:
    """C_eq and SEM of the coupon (N*s/m), each shape (n_rows,)."""
    return rows[VALUE_COLUMN].to_numpy(dtype=float), rows[SEM_COLUMN].to_numpy(dtype=float)
