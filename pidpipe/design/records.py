"""From case records to the C_eq table: one row per grid point, replicates combined, status and flags kept.
"""

from __future__ import annotations

import math
import os
from typing import Iterable

import numpy as np
import pandas as pd

from pidpipe.cases import CaseSpec, regime
from pidpipe.config.derived import cell_fill_pct, poured_fill
from pidpipe.design.ceq_table import COORDINATE_COLUMNS, signal_quality
from pidpipe.design.packing_noise import LOADS_COLUMN, cell_loads, combine_loads, format_loads
from pidpipe.measurement.case_record import CaseRecord

#: Statuses a table row can have, from the most to the least usable.
_STATUS_ORDER = ("ok", "flagged", "failed", "missing")

#: (value, its SEM): record attributes (and table columns) averaged over replicates.
_MEAN_WITH_SEM = (
    ("ceq_coupon_ns_m", "ceq_coupon_sem_ns_m"),
    ("ceq_cell_ns_m", "ceq_cell_sem_ns_m"),
    ("ed_cycle_mean_j", "ed_cycle_sem_j"),
)

#: (value, its SEM): keys of the record's ``harmonics`` (and table columns) averaged over the
#: replicates that carry harmonics (:mod:`pidpipe.measurement.harmonics`): the mean cell's
#: effective mass (kg), its ratio to the cell's bed mass, and the force-based C_eq (N*s/m).
_HARMONICS_WITH_SEM = (
    ("m_eff_cell_kg", "m_eff_cell_sem_kg"),
    ("m_eff_ratio", "m_eff_ratio_sem"),
    ("ceq_force_cell_ns_m", "ceq_force_cell_sem_ns_m"),
)

#: table column -> key of the record's ``fidelity``, for settings the same for every replicate.
_FIDELITY_COLUMNS = {
    "dt_s": "timestep_s",
    "dt_rayleigh_fraction": "rayleigh_fraction",
    "steps_per_cycle": "steps_per_cycle",
    "youngs_modulus_scale": "youngs_modulus_scale",
    "transient_cycles": "transient_cycles",
    "measured_cycles": "measured_cycles",
    "sem_block_cycles": "sem_block_cycles",
    "rotation": "rotation",
    "friction": "friction",
    "seed": "seed",
    "pour_engine": "pour_engine",
    "cells_per_run": "cells_per_run",
}

#: Columns of the campaign's C_eq table, in order (see :mod:`pidpipe.design.ceq_table`).
TABLE_COLUMNS: tuple[str, ...] = (
    "case_id", "freq_hz", "accel_g", "fill_pct", "status", "flags", "regime", "regime_cells", "signal",
    "n_replicates", "ceq_coupon_ns_m", "ceq_coupon_sem_ns_m", "ceq_relative_sem",
    "ceq_cell_ns_m", "ceq_cell_sem_ns_m",
    "ed_cycle_mean_j", "ed_cycle_sem_j", "n_cycles",
    "m_eff_cell_kg", "m_eff_cell_sem_kg", "m_eff_ratio", "m_eff_ratio_sem", "bed_mass_kg",
    "ceq_force_cell_ns_m", "ceq_force_cell_sem_ns_m",
    "n_spheres", "dt_s", "dt_rayleigh_fraction", "steps_per_cycle", "youngs_modulus_scale",
    "transient_cycles", "measured_cycles", "sem_block_cycles", "rotation", "friction", "seed",
    "pour_engine", "cells_per_run", "solver", "solver_version", "liggghts_version", "wall_time_s",
    "solver_wall_time_s", "liggghts_wall_time_s", "message", LOADS_COLUMN,
)


def combine_replicates(values, sems) -> tuple[float, float]:
    """Mean of replicate estimates and its standard error.

    With k estimates x_i of standard errors s_i (each from one run's cycle-to-cycle scatter),
    the mean's error propagated from the runs is sqrt(sum s_i^2) / k. It misses the scatter
    between packings, which the spread of the x_i measures, std(x, ddof=1) / sqrt(k), but
    that estimate is itself poor for few replicates. The larger of the two is returned.

    Parameters
    ----------
    values, sems : array_like, shape (k,)

    Returns
    -------
    (float, float)
        mean and standard error; (nan, nan) for k = 0; (x_1, s_1) for k = 1.
    """
    values, sems = np.asarray(values, dtype=float), np.asarray(sems, dtype=float)
    k = values.size
    if k == 0:
        return math.nan, math.nan
    mean = float(values.mean())
    propagated = float(np.sqrt(np.sum(sems**2)) / k)
    if k == 1:
        return mean, propagated
    between = float(values.std(ddof=1) / math.sqrt(k))
    return mean, max(propagated, between)


def missing_record(case: CaseSpec) -> CaseRecord:
    """Stand-in for a case that has no record (status ``missing``, never written)."""
    return CaseRecord(solver="", case_id=case.case_id, freq_hz=case.freq_hz, accel_g=case.accel_g,
                      fill_pct=case.fill_pct, replicate=case.replicate, status="missing",
                      message="no record")


def records_to_table(records: Iterable[CaseRecord],
                     expected: Iterable[CaseSpec] | None = None,
                     full_cell_spheres: int | None = None) -> pd.DataFrame:
    """The C_eq table: one row per grid point (f, G, r), replicates averaged.

    Parameters
    ----------
    records : iterable of CaseRecord
        Case records (:func:`pidpipe.liggghts.shake.run_case`, :func:`pidpipe.dem.case.run_dem_case`,
        :func:`pidpipe.steps.cases.failed_record`).
    expected : iterable of CaseSpec, optional
        The campaign's cases; one without a record gives a ``missing`` replicate.
    full_cell_spheres : int, optional
        Spheres at 100 %. Given, a row's ``fill_pct`` is the fill its cells hold
        (:func:`cell_fill`: 23.81 % for the 5 of 21 spheres a case named 25 % pours), so that
        every row, whatever fill it was named by, sits where its sphere count puts it; without
        it, the fill the case is named by.

    Returns
    -------
    pandas.DataFrame
        Columns :data:`TABLE_COLUMNS`, rows sorted by (f, G, r). A point's status is ``ok`` if
        any replicate is ok, and its values are then the mean over the ok replicates
        (:func:`combine_replicates`), the others being listed in ``flags``
        (``rep1:failed``). Without an ok replicate, the status is ``flagged`` if any is
        flagged (values over the flagged ones, kept for inspection, never fitted), else
        ``failed``, else ``missing`` (values NaN). ``case_id`` joins the replicates' ids
        with ``;`` (just the one id without replicates); ``n_replicates`` counts those averaged.
    """
    by_id: dict[str, CaseRecord] = {}
    for record in records:
        by_id[record.case_id] = record
    for case in expected or ():
        by_id.setdefault(case.case_id, missing_record(case))
    groups: dict[tuple[float, float, float], list[CaseRecord]] = {}
    for record in by_id.values():
        key = (float(record.freq_hz), float(record.accel_g), cell_fill(record, full_cell_spheres))
        groups.setdefault(key, []).append(record)
    rows = [_table_row(point, sorted(group, key=lambda r: int(r.replicate)))
            for point, group in sorted(groups.items())]
    table = pd.DataFrame(rows, columns=list(TABLE_COLUMNS))
    return table


def cell_fill(record: CaseRecord, full_cell_spheres: int | None) -> float:
    """The fill (%) a record's cells hold (:func:`pidpipe.config.derived.cell_fill_pct` of its
    sphere count, or of the count its named fill pours when it has none, e.g. a missing
    record); its named fill when ``full_cell_spheres`` is None."""
    if full_cell_spheres is None:
        return float(record.fill_pct)
    if record.n_spheres:
        return cell_fill_pct(int(record.n_spheres), full_cell_spheres)
    return poured_fill(float(record.fill_pct), full_cell_spheres)[0]


def _table_row(point: tuple[float, float, float], replicates: list[CaseRecord]) -> dict:
    """One grid point's row from its replicates' records."""
    status_of = [r.status for r in replicates]
    best = min(status_of, key=_STATUS_ORDER.index)
    used = [r for r, s in zip(replicates, status_of) if s == best and best in ("ok", "flagged")]
    flags: list[str] = []
    for record, status in zip(replicates, status_of):
        rep = f"rep{record.replicate}"
        prefix = f"{rep}:" if len(replicates) > 1 else ""
        flags.extend(f"{prefix}{flag}" for flag in record.flags)
        if status != best:
            flags.append(f"{rep}:{status}")
    row = dict(zip(COORDINATE_COLUMNS, point))
    row.update(case_id=";".join(r.case_id for r in replicates), status=best,
               flags=";".join(flags), n_replicates=len(used),
               message=" | ".join(r.message for r in replicates if r.message))
    for value_key, sem_key in _MEAN_WITH_SEM:
        row[value_key], row[sem_key] = combine_replicates(
            [_number(getattr(r, value_key)) for r in used], [_number(getattr(r, sem_key)) for r in used])
    row.update(harmonics_columns(used))
    row["n_cycles"] = int(sum(int(r.n_cycles or 0) for r in used))
    row["regime"], row["regime_cells"] = table_regime(point[1], used)
    row["ceq_relative_sem"], row["signal"] = signal_quality(row["ceq_coupon_ns_m"],
                                                            row["ceq_coupon_sem_ns_m"])
    timed = [r for r in replicates if r.measured]
    row["wall_time_s"] = float(sum(_number(r.wall_time_s) for r in timed)) if timed else math.nan
    row["liggghts_wall_time_s"] = (float(sum(_number(r.engine.get("liggghts_wall_time_s"))
                                             for r in timed)) if timed else math.nan)
    row["solver_wall_time_s"] = (float(sum(_number(r.engine.get("wall_time_s"))
                                           for r in timed)) if timed else math.nan)
    reference = (used or replicates)[0]
    row["n_spheres"] = reference.n_spheres
    for column, key in _FIDELITY_COLUMNS.items():
        row[column] = reference.fidelity.get(key)
    row[LOADS_COLUMN] = replicates_loads(used)
    row["solver"] = reference.solver if reference.status != "missing" else None
    row["solver_version"] = reference.engine.version
    row["liggghts_version"] = reference.engine.get("liggghts_version")
    return row


def replicates_loads(used: list[CaseRecord]) -> str:
    """The ``packing_loads`` text of a row averaging ``used`` with equal weights."""
    return format_loads(combine_loads([record_loads(r) for r in used],
                                      [1.0 / max(len(used), 1)] * len(used)))


def record_loads(record: CaseRecord) -> dict[int, tuple[float, float]]:
    """A record's loads on its packings (seed -> weight, load), the load in coupon C_eq units
    (N*s/m) (:func:`pidpipe.design.packing_noise.cell_loads`); empty for one cell."""
    cells = record.cells or ()
    seeds = record.fidelity.seeds
    cell_sem, coupon_sem = _number(record.ceq_cell_sem_ns_m), _number(record.ceq_coupon_sem_ns_m)
    if len(cells) < 2 or len(seeds) != len(cells) or not cell_sem > 0:
        return {}
    return cell_loads([_number(cell.get("ceq_cell_ns_m")) for cell in cells], seeds,
                      coupon_sem / cell_sem)


def harmonics_columns(used: list[CaseRecord]) -> dict:
    """The first-harmonic columns of a grid point from its averaged replicates.

    Parameters
    ----------
    used : list of CaseRecord
        The replicates whose values the row averages; those without ``harmonics`` are left out.

    Returns
    -------
    dict
        Every column of :data:`_HARMONICS_WITH_SEM` (value and SEM by
        :func:`combine_replicates`) and ``bed_mass_kg`` (the mean cell's spheres' mass, kg,
        averaged); NaN for all when no replicate carries harmonics. ``m_eff_ratio`` is each
        replicate's m_eff over its own bed mass, then averaged.
    """
    measured = [r.harmonics for r in used if r.harmonics]
    columns = {}
    for value_key, sem_key in _HARMONICS_WITH_SEM:
        columns[value_key], columns[sem_key] = combine_replicates(
            [_number(h.get(value_key)) for h in measured], [_number(h.get(sem_key)) for h in measured])
    columns["bed_mass_kg"] = (float(np.mean([_number(h.get("bed_mass_kg")) for h in measured]))
                              if measured else math.nan)
    return columns


def table_regime(accel_g: float, used: list[CaseRecord]) -> tuple[str, str]:
    """A grid point's regime and how its cells split, from its replicates' motion.

    With the motion sampled (records with ``motion``), the regime is the one most cells of the
    used replicates are in (:func:`pidpipe.measurement.regime.case_regime`) and ``regime_cells``
    counts them (``bouncing_bed:5;irregular:2``); otherwise the regime is decided from G alone
    (:func:`pidpipe.cases.regime`) and ``regime_cells`` is empty.
    """
    from pidpipe.measurement.regime import REGIMES, case_regime

    cells = [name for r in used for name in (r.motion or {}).get("cell_regimes", [])]
    if not cells:
        return regime(accel_g), ""
    counts = {name: cells.count(name) for name in REGIMES if name in cells}
    return case_regime(cells), ";".join(f"{name}:{count}" for name, count in counts.items())


def _number(value) -> float:
    return math.nan if value is None else float(value)


def read_record(path: str | os.PathLike) -> CaseRecord:
    """Read a case record (JSON): :meth:`CaseRecord.read`.

    Raises
    ------
    ParseError
        The file cannot be read or is not a case record.
    RecordVersionError
        The record is of another record version (the message says to delete it and rerun).
    """
    return CaseRecord.read(path)
