"""The C_eq table: one row per DEM case (or per published data point), and its validation.

Every table, including external published data, has the four columns of
:data:`REQUIRED_COLUMNS`: the base-excitation frequency ``freq_hz`` (Hz), the base acceleration
amplitude ``accel_g`` (in g = 9.81 m/s^2), the fill fraction ``fill_pct`` (%) and the coupon's
equivalent viscous damping ``ceq_coupon_ns_m`` (N*s/m). The campaign writes more columns
(:data:`OPTIONAL_COLUMNS`); columns that are neither are kept and not checked.

A ``status`` column says whether a case can be used: only ``"ok"`` rows enter a surrogate fit.
``"flagged"``, ``"failed"`` and ``"missing"`` rows are kept in the table (their coordinates say
where the grid has a hole) but :func:`split_usable` sets them aside, and the surrogate reports
them. A table without a ``status`` column is taken as all ``"ok"``.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from pidpipe.design.packing_noise import LOADS_COLUMN
from pidpipe.errors import TableError

#: Coordinates of a table row, in the order (f [Hz], G [g], r [%]) used throughout.
COORDINATE_COLUMNS: tuple[str, ...] = ("freq_hz", "accel_g", "fill_pct")

#: The fitted quantity: the coupon's equivalent viscous damping, N*s/m.
VALUE_COLUMN = "ceq_coupon_ns_m"

#: Its standard error, N*s/m (optional).
SEM_COLUMN = "ceq_coupon_sem_ns_m"

#: The mean cell's effective mass, kg (the spheres' force in phase with the wall's acceleration,
#: :mod:`pidpipe.measurement.harmonics`), and its standard error: what the m_eff surrogate fits.
#: It may be about zero or slightly negative (a bed in free flight), so it has no range check.
M_EFF_COLUMN = "m_eff_cell_kg"
M_EFF_SEM_COLUMN = "m_eff_cell_sem_kg"

#: Low-signal warning: a C_eq whose standard error exceeds this fraction of it is marked
#: ``uncertain`` in the table's ``signal`` column and drawn as such in the figures.
UNCERTAIN_RELATIVE_SEM = 0.3

#: Columns every table must have.
REQUIRED_COLUMNS: tuple[str, ...] = COORDINATE_COLUMNS + (VALUE_COLUMN,)

#: Numeric columns that the campaign writes (may be NaN, for instance in failed rows).
OPTIONAL_NUMERIC_COLUMNS: tuple[str, ...] = (
    "n_spheres",
    "ceq_cell_ns_m",
    "ceq_cell_sem_ns_m",
    "ceq_coupon_sem_ns_m",
    "ceq_relative_sem",
    "ed_cycle_mean_j",
    "ed_cycle_sem_j",
    "n_cycles",
    "dt_s",
    "dt_rayleigh_fraction",
    "youngs_modulus_scale",
    "transient_cycles",
    "measured_cycles",
    "seed",
    "cells_per_run",
    "wall_time_s",
    M_EFF_COLUMN,
    M_EFF_SEM_COLUMN,
    "m_eff_ratio",
    "m_eff_ratio_sem",
    "bed_mass_kg",
    "ceq_force_cell_ns_m",
    "ceq_force_cell_sem_ns_m",
)

#: Text columns that the campaign writes.
OPTIONAL_TEXT_COLUMNS: tuple[str, ...] = ("case_id", "status", "flags", "regime", "regime_cells",
                                          "signal", "solver", "solver_version", "liggghts_version",
                                          "pour_engine", LOADS_COLUMN)

#: Every column the campaign writes, required first.
OPTIONAL_COLUMNS: tuple[str, ...] = OPTIONAL_TEXT_COLUMNS + OPTIONAL_NUMERIC_COLUMNS

#: Allowed values of ``status``; only ``"ok"`` rows are fitted.
STATUS_VALUES: tuple[str, ...] = ("ok", "flagged", "failed", "missing")

#: How many offending row numbers an error message lists before it says "and N more".
_MAX_ROWS_LISTED = 10


def _rows_text(rows: np.ndarray | list[int]) -> str:
    """Row numbers as a short text, counting data rows from 1 (the header is not a row)."""
    rows = [int(i) + 1 for i in rows]
    shown = ", ".join(str(i) for i in rows[:_MAX_ROWS_LISTED])
    more = len(rows) - _MAX_ROWS_LISTED
    return shown + (f" and {more} more" if more > 0 else "")


def read_ceq_table(path: str | Path) -> pd.DataFrame:
    """Read a C_eq table from CSV and validate it.

    Parameters
    ----------
    path : str or Path
        CSV file with a header line. Rows are numbered from 1 after the header in messages.

    Returns
    -------
    pandas.DataFrame
        The table, with required and known numeric columns as float64 and ``status`` (when
        present) as lower-case text. Shape (n_rows, n_columns).

    Raises
    ------
    TableError
        The file is missing or unreadable, or :func:`validate_ceq_table` refuses its content.
    """
    path = Path(path)
    if not path.is_file():
        raise TableError(f"C_eq table {path}: no such file")
    try:
        table = pd.read_csv(path, skipinitialspace=True)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise TableError(f"C_eq table {path}: cannot be read as CSV ({exc})") from exc
    return validate_ceq_table(table, source=str(path))


def validate_ceq_table(table: pd.DataFrame, source: str = "<table>") -> pd.DataFrame:
    """Check a C_eq table and return a cleaned copy.

    Checks, in order: the required columns are present; ``status`` values are known; the
    required and known numeric columns hold numbers (empty cells become NaN); in the rows
    that will be used (``status == "ok"``, or every row without a status column) the required
    columns are finite; coordinates are positive, the fill is at most 100 %, and C_eq is not
    negative (dissipated energy cannot be).

    Parameters
    ----------
    table : pandas.DataFrame
        The raw table.
    source : str
        The file name (or another label) that error messages name.

    Returns
    -------
    pandas.DataFrame
        A copy with numeric columns as float64 and ``status`` stripped and lower-cased.

    Raises
    ------
    TableError
        Naming the source, the column and the offending rows (numbered from 1).
    """
    table = table.copy()
    table.columns = [str(c).strip() for c in table.columns]
    missing = [c for c in REQUIRED_COLUMNS if c not in table.columns]
    if missing:
        raise TableError(
            f"C_eq table {source}: missing required column(s) {', '.join(missing)} "
            f"(required: {', '.join(REQUIRED_COLUMNS)}; found: {', '.join(table.columns)})"
        )
    if table.empty:
        raise TableError(f"C_eq table {source}: has no rows")
    if "status" in table.columns:
        table["status"] = _clean_status(table["status"], source)
    for column in REQUIRED_COLUMNS + OPTIONAL_NUMERIC_COLUMNS:
        if column in table.columns:
            table[column] = _to_float(table[column], column, source)
    used = usable_mask(table)
    _check_finite(table, used, source)
    _check_ranges(table, used, source)
    return table


def _clean_status(status: pd.Series, source: str) -> pd.Series:
    """Strip and lower-case ``status``; refuse empty or unknown values."""
    text = status.astype("string").str.strip().str.lower()
    bad = np.flatnonzero((text.isna() | ~text.isin(STATUS_VALUES)).to_numpy())
    if bad.size:
        values = sorted({str(status.iloc[i]) for i in bad})
        raise TableError(
            f"C_eq table {source}: column status has value(s) {', '.join(values)} in row(s) "
            f"{_rows_text(bad)}; allowed: {', '.join(STATUS_VALUES)}"
        )
    return text.astype(object)


def _to_float(values: pd.Series, column: str, source: str) -> pd.Series:
    """Convert a column to float64; empty cells become NaN, text is refused."""
    if pd.api.types.is_numeric_dtype(values):
        # already numbers (a table validated before, refitted in a fold or a fantasy): no text
        # to look for, so the string scan below is skipped
        return values.astype("float64")
    numbers = pd.to_numeric(values, errors="coerce").astype("float64")
    text = values.astype("string").str.strip()
    not_numbers = numbers.isna() & text.notna() & (text != "") & (text.str.lower() != "nan")
    bad = np.flatnonzero(not_numbers.to_numpy())
    if bad.size:
        examples = ", ".join(repr(str(values.iloc[i])) for i in bad[:3])
        raise TableError(
            f"C_eq table {source}: column {column} is not numeric in row(s) {_rows_text(bad)} "
            f"(e.g. {examples})"
        )
    return numbers


def usable_mask(table: pd.DataFrame) -> np.ndarray:
    """Which rows a fit may use.

    Parameters
    ----------
    table : pandas.DataFrame
        A C_eq table.

    Returns
    -------
    numpy.ndarray of bool, shape (n_rows,)
        True where ``status == "ok"``; all True when there is no ``status`` column.
    """
    if "status" not in table.columns:
        return np.ones(len(table), dtype=bool)
    return (table["status"] == "ok").to_numpy(dtype=bool)


def _check_finite(table: pd.DataFrame, used: np.ndarray, source: str) -> None:
    """Refuse NaN or infinite required values in the rows that will be used."""
    for column in REQUIRED_COLUMNS:
        values = table[column].to_numpy(dtype=float)
        bad = np.flatnonzero(used & ~np.isfinite(values))
        if bad.size:
            where = "status ok " if "status" in table.columns else ""
            raise TableError(
                f"C_eq table {source}: column {column} is missing or not finite in {where}"
                f"row(s) {_rows_text(bad)}; give a value or set status to failed/missing"
            )


def _check_ranges(table: pd.DataFrame, used: np.ndarray, source: str) -> None:
    """Refuse non-physical coordinates and negative damping in the rows that will be used."""
    checks = (
        ("freq_hz", lambda v: v > 0, "must be > 0 Hz"),
        ("accel_g", lambda v: v > 0, "must be > 0 g"),
        ("fill_pct", lambda v: (v > 0) & (v <= 100), "must be in (0, 100] %"),
        (VALUE_COLUMN, lambda v: v >= 0, "must be >= 0 N*s/m (dissipation is not negative)"),
    )
    for column, valid, rule in checks:
        values = table[column].to_numpy(dtype=float)
        bad = np.flatnonzero(used & ~valid(values))
        if bad.size:
            shown = ", ".join(f"{values[i]:g}" for i in bad[:3])
            raise TableError(
                f"C_eq table {source}: column {column} {rule}; got {shown} in row(s) "
                f"{_rows_text(bad)}"
            )


def split_usable(table: pd.DataFrame) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Split a validated table into the rows a fit uses and the rows it must leave out.

    Parameters
    ----------
    table : pandas.DataFrame
        A table returned by :func:`read_ceq_table` or :func:`validate_ceq_table`.

    Returns
    -------
    used : pandas.DataFrame
        ``status == "ok"`` rows (all rows without a status column), original index kept.
    excluded : pandas.DataFrame
        The other rows, original index kept, so that their cases can be reported.
    """
    mask = usable_mask(table)
    return table.loc[mask], table.loc[~mask]


def signal_quality(value: float, sem: float) -> tuple[float, str]:
    """Relative standard error of a C_eq and its label: ``resolved``, ``uncertain`` (SEM above
    :data:`UNCERTAIN_RELATIVE_SEM` of the value, or a value not above zero) or ``none`` (NaN)."""
    if not (math.isfinite(value) and math.isfinite(sem)):
        return math.nan, "none"
    if value <= 0.0:
        return math.inf, "uncertain"
    relative = sem / value
    return relative, ("uncertain" if relative > UNCERTAIN_RELATIVE_SEM else "resolved")
