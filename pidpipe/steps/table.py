"""The table stage's step: collect the case records into the C_eq table (CSV).
"""

from __future__ import annotations

import logging
from pathlib import Path

import pandas as pd

from pidpipe.cases import CaseSpec
from pidpipe.design.fit_policy import classify_row, row_flags
from pidpipe.design.records import read_record, records_to_table
from pidpipe.files import write_atomic
from pidpipe.refine.table import GRID_SOURCE

logger = logging.getLogger("pidpipe.campaign")


def collect_table(record_paths: list[str], table_path: str, case_ids: list[str] | None = None,
                  full_cell_spheres: int | None = None) -> pd.DataFrame:
    """Aggregate case records into the C_eq table (CSV, written atomically): the columns of
    :data:`pidpipe.design.records.TABLE_COLUMNS` and ``source`` (``grid``).

    A row's ``fill_pct`` is the fill its cells hold when ``full_cell_spheres`` is given (the
    workflow always gives it; :func:`pidpipe.design.records.records_to_table`).

    Parameters
    ----------
    record_paths : list of path
        Case records; a path that does not exist gives a ``missing`` row.
    table_path : path
        The CSV to write.
    case_ids : list of str, optional
        The campaign's cases; one without a record path is ``missing`` too.
    full_cell_spheres : int, optional
        Spheres at 100 % fill (config ``fill``).

    Returns
    -------
    pandas.DataFrame
    """
    records = [read_record(p) for p in record_paths if Path(p).is_file()]
    expected = [CaseSpec.from_id(c) for c in case_ids or []]
    expected += [CaseSpec.from_id(Path(p).stem) for p in record_paths if not Path(p).is_file()]
    table = records_to_table(records, expected, full_cell_spheres)
    # where the rows came from, as the refinement loop's table says it (its rows add
    # "refine round N"; results/ceq_table_refined.csv)
    table["source"] = GRID_SOURCE
    write_atomic(table_path, lambda tmp: table.to_csv(tmp, index=False))
    counts = table["status"].value_counts().to_dict()
    logger.info("C_eq table %s: %d grid points (%s)", table_path, len(table),
                ", ".join(f"{v} {k}" for k, v in sorted(counts.items())))
    bad = table[table["status"] != "ok"]
    for _, row in bad.iterrows():
        dropped = classify_row(row["status"], row_flags(row["flags"]), row["ceq_coupon_ns_m"],
                               row["ceq_coupon_sem_ns_m"])
        fit = (f"no surrogate fits it ({dropped})" if dropped else
               "the gp surrogate fits it with its SEM, the interpolants leave it out")
        logger.warning("grid point f=%g Hz, G=%g g, r=%g %% (%s) is %s%s; %s",
                       row["freq_hz"], row["accel_g"], row["fill_pct"], row["case_id"],
                       row["status"], f": {row['message']}" if row["message"] else
                       (f" ({row['flags']})" if row["flags"] else ""), fit)
    if not bad.empty:
        logger.warning("to rerun a failed or flagged case, delete its record in results/cases/ "
                       "(and change what made it fail) and run snakemake again")
    return table
