"""The loop's files, written atomically: the table it grows and ``results/refine/rounds.csv``.

``rounds.csv`` has one row per round and design:

``round``; ``cases_added``, ``cases_extended``, ``verify_cases`` (rows the round added);
``engine_cpu_s`` and ``cumulative_cpu_s`` (planned engine CPU of the round, and of the loop up
to its end, s); ``environment``, ``design``; ``fill_pct``, ``n_cells``; ``total_ceq_ns_m``
with ``total_ceq_lo_ns_m`` and ``total_ceq_hi_ns_m`` (the surrogate's 95 % interval, N*s/m),
``half_width_fraction`` and ``interval_method``; ``verify_worst_abs_z`` (NaN when the design was
not verified in the round); ``open`` (the design's open item, empty when done).

A loop restarted from its table runs again from the table's last round: :func:`write_rounds`
replaces the rows of the rounds it is given and keeps the file's other rows.
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from pidpipe.files import write_atomic
from pidpipe.refine.loop import RoundRecord
from pidpipe.refine.table import from_csv

#: Columns of rounds.csv, in order.
ROUND_COLUMNS: tuple[str, ...] = (
    "round", "cases_added", "cases_extended", "verify_cases", "engine_cpu_s", "cumulative_cpu_s",
    "environment", "design", "fill_pct", "n_cells", "total_ceq_ns_m", "total_ceq_lo_ns_m",
    "total_ceq_hi_ns_m", "half_width_fraction", "interval_method", "verify_worst_abs_z", "open",
)


def rounds_frame(records: list[RoundRecord]) -> pd.DataFrame:
    """:data:`ROUND_COLUMNS`, one row per round and design, rounds in order."""
    rows = []
    for record in records:
        for interval in record.intervals:
            name = f"{interval.environment}/{interval.kind}"
            open_item = "; ".join(line for line in record.open if line.startswith(name + ":"))
            rows.append({
                "round": record.round, "cases_added": record.cases_added,
                "cases_extended": record.cases_extended, "verify_cases": record.verify_cases,
                "engine_cpu_s": record.engine_cpu_s, "cumulative_cpu_s": record.cumulative_cpu_s,
                "environment": interval.environment, "design": interval.kind,
                "fill_pct": interval.fill_pct, "n_cells": interval.n_cells,
                "total_ceq_ns_m": interval.total_ceq_ns_m, "total_ceq_lo_ns_m": interval.lo,
                "total_ceq_hi_ns_m": interval.hi,
                "half_width_fraction": interval.half_width_fraction,
                "interval_method": interval.method,
                "verify_worst_abs_z": record.worst_z.get(name, float("nan")),
                "open": open_item,
            })
    return pd.DataFrame(rows, columns=list(ROUND_COLUMNS))


def write_rounds(records: list[RoundRecord], path: str | Path) -> Path:
    """Write (or update) rounds.csv: the records' rounds replace the file's rows of those rounds."""
    path = Path(path)
    new = rounds_frame(records)
    if path.is_file():
        old = pd.read_csv(path)
        old = old[~old["round"].isin(new["round"])]
        new = pd.concat([old, new], ignore_index=True).sort_values("round", kind="stable")
    return write_atomic(path, lambda tmp: new.to_csv(tmp, index=False))


def write_table(table: pd.DataFrame, path: str | Path) -> Path:
    """Write the loop's C_eq table as CSV."""
    return write_atomic(path, lambda tmp: table.to_csv(tmp, index=False))


#: Columns of verify_points.csv, in order.
VERIFY_POINT_COLUMNS: tuple[str, ...] = (
    "design", "point", "freq_hz", "accel_g", "design_fill_pct", "fill_pct", "case_key", "runs",
    "dem_ns_m", "dem_sem_ns_m", "dem_dof", "surrogate_ns_m", "surrogate_std_ns_m", "t", "z",
    "passes",
)


def write_verify_points(comparison: pd.DataFrame, path: str | Path) -> Path:
    """Write the last round's verifying points as CSV: :data:`VERIFY_POINT_COLUMNS`, one row
    per design and point (:func:`pidpipe.refine.verification.compare`: the DEM's pooled runs
    with their SEM and its degrees of freedom, the surrogate's mean and std, N*s/m; t, and z
    its normal score; no rows when the last round verified nothing)."""
    frame = comparison.reindex(columns=list(VERIFY_POINT_COLUMNS))
    return write_atomic(path, lambda tmp: frame.to_csv(tmp, index=False))


#: Read a table the loop wrote (:func:`pidpipe.refine.table.from_csv`).
read_table = from_csv


def summary_record(outcome, rounds: pd.DataFrame | None = None) -> dict:
    """What stopped the loop, what is open, and each design's interval (for summary.json).

    ``rounds`` (rows of rounds.csv) gives the rounds run when the loop ran in several calls
    (resumed, or the workflow's steps); without it, the outcome's own rounds."""
    run = (sorted({int(n) for n in rounds["round"]}) if rounds is not None
           else [record.round for record in outcome.rounds])
    return {
        "stopped_by": outcome.stopped_by,
        "open": list(outcome.open),
        "rounds_run": run,
        "planned_cpu_s": float(outcome.table["planned_cpu_s"].sum()),
        "designs": [{"environment": i.environment, "design": i.kind, "fill_pct": i.fill_pct,
                     "n_cells": i.n_cells, "total_ceq_ns_m": i.total_ceq_ns_m,
                     "total_ceq_lo_ns_m": i.lo, "total_ceq_hi_ns_m": i.hi,
                     "half_width_fraction": i.half_width_fraction, "interval_method": i.method}
                    for i in outcome.intervals],
    }


def write_summary(outcome, path: str | Path, rounds: pd.DataFrame | None = None) -> Path:
    """Write :func:`summary_record` as JSON."""
    import json

    text = json.dumps(summary_record(outcome, rounds), indent=1)
    return write_atomic(path, lambda tmp: Path(tmp).write_text(text + "\n"))
