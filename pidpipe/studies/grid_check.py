"""The whole grid checked by both solvers: each LIGGGHTS case record against the compiled DEM's
record of the same case, on the same packings, with the same fidelity.

One row a case (:data:`GRID_COLUMNS`): both C_eq per cell with their standard errors, their
ratio, ``z_combined`` = (C_eq,dem - C_eq,liggghts) / sqrt(SEM_l^2 + SEM_d^2), whether they agree
within :data:`AGREEMENT_SEMS` combined SEM, each solver's status and flags, and what each cost
(CPU seconds). A case either solver flagged or failed is kept, marked, and counted apart.

Both solvers shake the same packings, so the spread between packings, which is most of each
case's SEM once it has several cells, is common to both and cancels in their difference: the
combined-SEM test is then blind to a systematic difference smaller than that spread. The
**paired** columns compare the solvers cell by cell (cells matched by packing seed):
``paired_rel_diff`` = mean over cells of (C_dem - C_liggghts) / mean C_liggghts, and
``z_paired`` = mean difference / its standard error over the cells (which carries the two
solvers' cycle noise only); ``paired_agree`` is |z_paired| <= :data:`AGREEMENT_SEMS`.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from pidpipe.measurement.case_record import CaseRecord

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
    "paired_cells", "paired_rel_diff", "paired_rel_diff_sem", "z_paired", "paired_agree",
)


def paired_difference(liggghts: CaseRecord, dem: CaseRecord) -> dict:
    """The cell-by-cell difference of two records of a case (cells matched by packing seed):
    :func:`paired_cell_difference` of their ``cells``."""
    return paired_cell_difference(liggghts.cells or (), dem.cells or ())


def paired_cell_difference(liggghts_cells, dem_cells) -> dict:
    """The cell-by-cell difference of two lists of cells of a case (matched by packing seed).

    Parameters
    ----------
    liggghts_cells, dem_cells : sequence of dict
        Each cell's ``seed`` and ``ceq_cell_ns_m`` (a record's ``cells``).

    Returns
    -------
    dict
        ``paired_cells`` (cells in both), ``paired_rel_diff`` and ``paired_rel_diff_sem`` (the
        mean difference C_dem - C_liggghts and its standard error over the cells, both over the
        mean LIGGGHTS C_eq of those cells), ``z_paired`` and ``paired_agree``; NaN (and False)
        with fewer than 2 cells in both.
    """
    def by_seed(cells) -> dict:
        return {int(cell["seed"]): float(cell["ceq_cell_ns_m"]) for cell in cells
                if "seed" in cell and math.isfinite(float(cell.get("ceq_cell_ns_m", math.nan)))}

    left, right = by_seed(liggghts_cells), by_seed(dem_cells)
    seeds = sorted(set(left) & set(right))
    nan = math.nan
    if len(seeds) < 2:
        return {"paired_cells": len(seeds), "paired_rel_diff": nan, "paired_rel_diff_sem": nan,
                "z_paired": nan, "paired_agree": False}
    lig = np.array([left[s] for s in seeds])
    diff = np.array([right[s] for s in seeds]) - lig
    scale = abs(lig.mean())
    sem = diff.std(ddof=1) / math.sqrt(diff.size)
    z = diff.mean() / sem if sem > 0 else nan
    return {"paired_cells": len(seeds), "paired_rel_diff": float(diff.mean() / scale),
            "paired_rel_diff_sem": float(sem / scale), "z_paired": float(z),
            "paired_agree": bool(np.isfinite(z) and abs(z) <= AGREEMENT_SEMS)}


def grid_row(liggghts: CaseRecord, dem: CaseRecord) -> dict:
    """One row of the grid check from the two solvers' records of a case.

    Parameters
    ----------
    liggghts, dem : CaseRecord
        Case records of :func:`pidpipe.liggghts.shake.run_case` and
        :func:`pidpipe.dem.case.run_dem_case` (``failed`` records give NaN values).

    Returns
    -------
    dict
        The :data:`GRID_COLUMNS` of the case.
    """
    nan = math.nan
    value_l, sem_l = float(liggghts.ceq_cell_ns_m), float(liggghts.ceq_cell_sem_ns_m)
    value_d, sem_d = float(dem.ceq_cell_ns_m), float(dem.ceq_cell_sem_ns_m)
    combined = math.hypot(sem_l, sem_d)
    z = (value_d - value_l) / combined if combined > 0 else nan
    status_l, status_d = liggghts.status, dem.status
    fid_l, fid_d = liggghts.fidelity, dem.fidelity
    return {
        "case_id": liggghts.case_id,
        "freq_hz": float(liggghts.freq_hz),
        "accel_g": float(liggghts.accel_g),
        "fill_pct": float(liggghts.fill_pct),
        "n_spheres": int(liggghts.n_spheres),
        "cells_per_run": fid_l.cells_per_run,
        "regime": liggghts.regime or "",
        "ceq_cell_liggghts_ns_m": value_l, "ceq_cell_liggghts_sem_ns_m": sem_l,
        "ceq_cell_dem_ns_m": value_d, "ceq_cell_dem_sem_ns_m": sem_d,
        "ratio_dem_over_liggghts": value_d / value_l if value_l else nan,
        "z_combined": z,
        "agree": bool(np.isfinite(z) and abs(z) <= AGREEMENT_SEMS),
        "liggghts_status": status_l, "liggghts_flags": ";".join(liggghts.flags),
        "dem_status": status_d, "dem_flags": ";".join(dem.flags),
        "both_ok": status_l == "ok" and status_d == "ok",
        "liggghts_measured_cycles": int(fid_l.get("measured_cycles", 0)),
        "dem_measured_cycles": int(fid_d.get("measured_cycles", 0)),
        "liggghts_transient_cycles": int(fid_l.get("transient_cycles", -1)),
        "dem_transient_cycles": int(fid_d.get("transient_cycles", -1)),
        "liggghts_cpu_time_s": liggghts.cpu_time_s,
        "dem_cpu_time_s": dem.cpu_time_s,
        **paired_difference(liggghts, dem),
    }


def grid_table(pairs: list[tuple[CaseRecord, CaseRecord]]) -> pd.DataFrame:
    """The grid check of (LIGGGHTS record, DEM record) pairs, sorted by (f, G, r)."""
    table = pd.DataFrame([grid_row(lig, dem) for lig, dem in pairs], columns=list(GRID_COLUMNS))
    return table.sort_values(["freq_hz", "accel_g", "fill_pct", "case_id"]).reset_index(drop=True)


def grid_summary(table: pd.DataFrame) -> dict:
    """Counts of the grid check: cases, both ok, agreeing among those, and the CPU of each solver.

    Returns
    -------
    dict
        ``cases``, ``both_ok``, ``agree_both_ok`` (of the both-ok cases, how many agree within
        :data:`AGREEMENT_SEMS` combined SEM), ``agree_all``, ``disagreeing`` (case ids of
        both-ok cases that do not agree), ``paired_agree_both_ok`` and ``paired_disagreeing``
        (the same by the paired test), ``liggghts_cpu_time_s``, ``dem_cpu_time_s``.
    """
    both = table[table["both_ok"]]
    return {
        "cases": int(len(table)),
        "both_ok": int(len(both)),
        "agree_both_ok": int(both["agree"].sum()),
        "agree_all": int(table["agree"].sum()),
        "paired_agree_both_ok": int(both["paired_agree"].sum()),
        "paired_disagreeing": both.loc[~both["paired_agree"], "case_id"].tolist(),
        "disagreeing": both.loc[~both["agree"], "case_id"].tolist(),
        "liggghts_cpu_time_s": float(table["liggghts_cpu_time_s"].sum()),
        "dem_cpu_time_s": float(table["dem_cpu_time_s"].sum()),
    }
