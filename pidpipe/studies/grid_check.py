"""The whole grid checked by both solvers: each LIGGGHTS case record against the compiled DEM's
record of the same case, on the same packings, with the same fidelity.

One row a case (:data:`GRID_COLUMNS`): both C_eq per cell with their standard errors, their
ratio, ``z_combined`` = (C_eq,dem - C_eq,liggghts) / sqrt(SEM_l^2 + SEM_d^2), whether they agree
within :data:`AGREEMENT_SEMS` combined SEM, each solver's status and flags, and what each cost
(CPU seconds). A case either solver flagged or failed is kept, marked, and counted apart.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from pidpipe.design.records import record_cpu_time_s

AGREEMENT_SEMS = 2.0
"""Two solvers agree on a case when their C_eq differ by at most this many combined SEM."""

#: Columns of results/validation/grid.csv, in order.
GRID_COLUMNS: tuple[str, ...] = (
    "case_id", "freq_hz", "accel_g", "fill_pct", "n_spheres", "cells_per_run", "regime",
    "ceq_cell_liggghts_ns_m", "ceq_cell_liggghts_sem_ns_m",
    "ceq_cell_dem_ns_m", "ceq_cell_dem_sem_ns_m",
    "ratio_dem_over_liggghts", "z_combined", "agree",
    "liggghts_status", "liggghts_flags", "dem_status", "dem_flags", "both_ok",
    "liggghts_measured_cycles", "dem_measured_cycles",
    "liggghts_transient_cycles", "dem_transient_cycles",
    "liggghts_cpu_time_s", "dem_cpu_time_s",
)


def _cpu_time(record: dict) -> float:
    """A record's CPU seconds (:func:`pidpipe.design.records.record_cpu_time_s`)."""
    return record_cpu_time_s(record)


def grid_row(liggghts: dict, dem: dict) -> dict:
    """One row of the grid check from the two solvers' records of a case.

    Parameters
    ----------
    liggghts, dem : dict
        Case records of :func:`pidpipe.liggghts.shake.run_case` and
        :func:`pidpipe.dem.case.run_dem_case` (``failed`` records give NaN values).

    Returns
    -------
    dict
        The :data:`GRID_COLUMNS` of the case.
    """
    nan = math.nan
    value_l, sem_l = float(liggghts.get("ceq_cell_ns_m", nan)), float(liggghts.get("ceq_cell_sem_ns_m", nan))
    value_d, sem_d = float(dem.get("ceq_cell_ns_m", nan)), float(dem.get("ceq_cell_sem_ns_m", nan))
    combined = math.hypot(sem_l, sem_d)
    z = (value_d - value_l) / combined if combined > 0 else nan
    status_l, status_d = liggghts.get("status", "missing"), dem.get("status", "missing")
    fid_l, fid_d = liggghts.get("fidelity", {}), dem.get("fidelity", {})
    return {
        "case_id": liggghts["case_id"],
        "freq_hz": float(liggghts["freq_hz"]),
        "accel_g": float(liggghts["accel_g"]),
        "fill_pct": float(liggghts["fill_pct"]),
        "n_spheres": int(liggghts["n_spheres"]),
        "cells_per_run": int(fid_l.get("cells_per_run", 1)),
        "regime": liggghts.get("regime", ""),
        "ceq_cell_liggghts_ns_m": value_l, "ceq_cell_liggghts_sem_ns_m": sem_l,
        "ceq_cell_dem_ns_m": value_d, "ceq_cell_dem_sem_ns_m": sem_d,
        "ratio_dem_over_liggghts": value_d / value_l if value_l else nan,
        "z_combined": z,
        "agree": bool(np.isfinite(z) and abs(z) <= AGREEMENT_SEMS),
        "liggghts_status": status_l, "liggghts_flags": ";".join(liggghts.get("flags", [])),
        "dem_status": status_d, "dem_flags": ";".join(dem.get("flags", [])),
        "both_ok": status_l == "ok" and status_d == "ok",
        "liggghts_measured_cycles": int(fid_l.get("measured_cycles", 0)),
        "dem_measured_cycles": int(fid_d.get("measured_cycles", 0)),
        "liggghts_transient_cycles": int(fid_l.get("transient_cycles", -1)),
        "dem_transient_cycles": int(fid_d.get("transient_cycles", -1)),
        "liggghts_cpu_time_s": _cpu_time(liggghts),
        "dem_cpu_time_s": _cpu_time(dem),
    }


def grid_table(pairs: list[tuple[dict, dict]]) -> pd.DataFrame:
    """The grid check of (LIGGGHTS record, DEM record) pairs, sorted by (f, G, r)."""
    table = pd.DataFrame([grid_row(l, d) for l, d in pairs], columns=list(GRID_COLUMNS))
    return table.sort_values(["freq_hz", "accel_g", "fill_pct", "case_id"]).reset_index(drop=True)


def grid_summary(table: pd.DataFrame) -> dict:
    """Counts of the grid check: cases, both ok, agreeing among those, and the CPU of each solver.

    Returns
    -------
    dict
        ``cases``, ``both_ok``, ``agree_both_ok`` (of the both-ok cases, how many agree within
        :data:`AGREEMENT_SEMS` combined SEM), ``agree_all``, ``disagreeing`` (case ids of
        both-ok cases that do not agree), ``liggghts_cpu_time_s``, ``dem_cpu_time_s``.
    """
    both = table[table["both_ok"]]
    return {
        "cases": int(len(table)),
        "both_ok": int(len(both)),
        "agree_both_ok": int(both["agree"].sum()),
        "agree_all": int(table["agree"].sum()),
        "disagreeing": both.loc[~both["agree"], "case_id"].tolist(),
        "liggghts_cpu_time_s": float(table["liggghts_cpu_time_s"].sum()),
        "dem_cpu_time_s": float(table["dem_cpu_time_s"].sum()),
    }
