"""The validation stage's steps: the whole grid checked by the compiled DEM against the
campaign's LIGGGHTS records (``snakemake validate``), and chosen cases run afresh in both
(``snakemake validate_chosen``).
"""

from __future__ import annotations

import logging
from dataclasses import replace
from pathlib import Path

from pidpipe.cases import CaseSpec
from pidpipe.config.settings import ShakeSettings
from pidpipe.errors import PidpipeError
from pidpipe.files import write_atomic
from pidpipe.measurement.case_record import CaseRecord

logger = logging.getLogger("pidpipe.campaign")


def validate_against_dem(config: dict, cases: list[dict], packing_paths: list[str],
                         table_path: str, plot_path: str, workdir: str) -> None:
    """Run chosen cases in LIGGGHTS and in the in-repo DEM; write the comparison table and plot.

    Parameters
    ----------
    config : dict
        The case stage's part of the config (:func:`pidpipe.config.stages.stage_config`).
    cases : list of dict
        ``{"freq_hz", "accel_g", "fill_pct"}`` each (``validation.cases``).
    packing_paths : list of path
        The replicate-0 packings of the cases' fills.
    table_path, plot_path : path
        The comparison CSV and PNG.
    workdir : path
        Scratch folder for both solvers.
    """
    import shutil

    from pidpipe.cell.packing import load_packing
    from pidpipe.studies.validation import run_validation

    specs = [CaseSpec(float(c["freq_hz"]), float(c["accel_g"]), float(c["fill_pct"])) for c in cases]
    packings = {Path(path).stem: load_packing(path) for path in packing_paths}
    table = run_validation(ShakeSettings.from_config(config), specs, packings, workdir)
    write_atomic(table_path, lambda tmp: table.to_csv(tmp, index=False))
    shutil.copyfile(Path(workdir) / "validation.png", plot_path)
    logger.info("validation: %d of %d cases agree within 2 combined standard errors",
                int(table["agree"].sum()), len(table))


def check_case_with_dem(config: dict, liggghts_record_path: str, packing_paths: list[str],
                        record_path: str, packing_pool: str | None = None) -> CaseRecord:
    """Shake a campaign case in the compiled DEM on the cells its LIGGGHTS record shook.

    A case measured to a target made several runs (``target.runs``): the DEM replays the runs
    that make the record (``used``), each on the same packings (by seed: the pilot's from
    ``packing_paths``, the others from the pool the campaign poured them into) for the same
    measured cycles, and combines them as the campaign does
    (:func:`pidpipe.measurement.adaptive.combine_runs`): a paired check, cell for cell. A case
    without a target is shaken as configured (its pilot).

    Parameters
    ----------
    config : dict
        The case stage's part of the config (:func:`pidpipe.config.stages.stage_config`),
        parsed here; its fidelity is the LIGGGHTS campaign's.
    liggghts_record_path : path
        The campaign's record of the case (``results/cases/<case>.json``).
    packing_paths : list of path
        The case's pilot packings, one per cell of its first run.
    record_path : path
        The DEM record to write (JSON, atomically).
    packing_pool : path, optional
        The folder of the packings poured for the cases' targets (``results/packings/pool``).

    Raises
    ------
    PidpipeError
        The campaign's record is not a LIGGGHTS record (a campaign run with ``engine: dem``
        has nothing to be checked against), or a packing it shook is missing or not the one it
        shook.
    """
    from pidpipe.cell.packing import load_packing, pour_engines
    from pidpipe.design.records import read_record

    liggghts = read_record(liggghts_record_path)
    if liggghts.solver != "liggghts":
        raise PidpipeError(f"{liggghts_record_path} was made by {liggghts.solver!r}, not "
                           "LIGGGHTS: `snakemake validate` checks a LIGGGHTS campaign (engine: "
                           "liggghts) with the DEM")
    settings = ShakeSettings.from_config(config)
    case = CaseSpec.from_id(liggghts.case_id)
    pilot = [load_packing(path) for path in packing_paths]
    poured_by = liggghts.fidelity.pour_engine
    if poured_by is not None and poured_by != pour_engines(pilot):
        raise PidpipeError(f"{liggghts_record_path} shook packings poured by {poured_by}, but "
                           f"{', '.join(str(p) for p in packing_paths)} were poured by "
                           f"{pour_engines(pilot)}: rerun the campaign first")
    runs = [run for run in (liggghts.target.runs if liggghts.target else []) if run.get("used")]
    if not runs:
        seeds = liggghts.fidelity.get("seeds")
        runs = [{"run": 0, "seeds": seeds if seeds is not None else [p.seed for p in pilot],
                 "measured_cycles": settings.sampling.measured_cycles}]
    by_seed = {packing.seed: packing for packing in pilot}
    plan = [(run, [_packing_of_seed(seed, by_seed, case, config, packing_pool,
                                    liggghts_record_path) for seed in run["seeds"]])
            for run in runs]
    record = replay_runs(settings, case, plan, Path(record_path).parent)
    record.write(record_path)
    logger.info("case %s: C_eq(cell) DEM %.4g +- %.2g, LIGGGHTS %.4g +- %.2g N*s/m over the same "
                "%d cells; DEM %s%s", case.case_id, record.ceq_cell_ns_m,
                record.ceq_cell_sem_ns_m, liggghts.ceq_cell_ns_m,
                liggghts.ceq_cell_sem_ns_m, len(record.cells or [1]),
                record.status, f" ({', '.join(record.flags)})" if record.flags else "")
    return record


def replay_runs(settings: ShakeSettings, case: CaseSpec, plan: list[tuple[dict, list]],
                workdir: str | Path) -> CaseRecord:
    """The DEM's record of a case made of the given runs, combined as the campaign combines them.

    Parameters
    ----------
    settings : ShakeSettings
    case : CaseSpec
    plan : list of (run, packings)
        Each run's entry (``measured_cycles``) and its packings, one per cell.
    workdir : path
        Unused by the DEM (it writes no files).

    Returns
    -------
    CaseRecord
        The combined record; ``target`` = {``replay_of`` the runs replayed (run index, seeds,
        measured cycles, CPU s), ``cells``, ``measured_cycles``, ``cpu_time_s``}.
    """
    import time

    from pidpipe.dem.case import run_dem_case
    from pidpipe.measurement.adaptive import combine_runs

    records, replayed = [], []
    started = time.perf_counter()
    for run, packings in plan:
        staged = replace(settings, sampling=replace(settings.sampling,
                                                    measured_cycles=int(run["measured_cycles"]),
                                                    target_relative_sem=None))
        record = run_dem_case(staged, case, packings, workdir)
        records.append(record)
        replayed.append({"run": int(run.get("run", len(replayed))),
                         "seeds": [int(p.seed) for p in packings],
                         "measured_cycles": int(run["measured_cycles"]),
                         "cpu_time_s": record.engine_cpu_s})
    combined = combine_runs(records, case.freq_hz, case.accel_g, settings.coupon_n_cells)
    return combined.with_(target={
        "replay_of": replayed, "cells": sum(len(packings) for _, packings in plan),
        "measured_cycles": max(int(run["measured_cycles"]) for run, _ in plan),
        "cpu_time_s": sum(entry["cpu_time_s"] for entry in replayed),
        "wall_time_s": time.perf_counter() - started})


def _packing_of_seed(seed: int, pilot: dict, case: CaseSpec, config: dict,
                     packing_pool: str | None, source: str):
    """The packing of ``seed``: one of the pilot's, or the pool's of the case's fill."""
    from pidpipe.cell.packing import load_packing
    from pidpipe.config.settings import PourSettings
    from pidpipe.steps.cases import pool_packing_path

    if seed in pilot:
        return pilot[seed]
    index = int(seed) - PourSettings.from_config(config).pouring.seed
    path = pool_packing_path(packing_pool or ".", case.fill_pct, index)
    name = path.name
    if not packing_pool or not path.is_file():
        raise PidpipeError(f"{source} shook a packing of seed {seed} ({name}), which is not in "
                           f"the packing pool {packing_pool}: rerun the campaign first")
    packing = load_packing(path)
    if packing.seed != seed:
        raise PidpipeError(f"{path} has seed {packing.seed}, but {source} shook seed {seed}: "
                           "rerun the campaign first")
    return packing


def collect_grid_check(liggghts_paths: list[str], dem_paths: list[str], table_path: str,
                       plot_path: str) -> None:
    """Write the grid check (CSV, atomically) and its parity figure (PNG and PDF).

    Parameters
    ----------
    liggghts_paths, dem_paths : list of path
        The two solvers' records of every case, in the same order.
    table_path : path
        ``results/validation/grid.csv``: :data:`pidpipe.studies.grid_check.GRID_COLUMNS`.
    plot_path : path
        The parity figure (``.png``; a ``.pdf`` is written next to it).
    """
    from pidpipe.design.records import read_record
    from pidpipe.figures.parity import plot_parity
    from pidpipe.studies.grid_check import AGREEMENT_SEMS, grid_summary, grid_table

    pairs = [(read_record(lig), read_record(dem)) for lig, dem in zip(liggghts_paths, dem_paths)]
    table = grid_table(pairs)
    write_atomic(table_path, lambda tmp: table.to_csv(tmp, index=False))
    plot_parity(table, Path(plot_path).with_suffix(""), coverage=AGREEMENT_SEMS)
    summary = grid_summary(table)
    logger.info("grid check: %d cases, %d ok in both solvers, of which %d agree within %g "
                "combined SEM (%d of all cases); CPU: LIGGGHTS %.0f s, DEM %.0f s",
                summary["cases"], summary["both_ok"], summary["agree_both_ok"], AGREEMENT_SEMS,
                summary["agree_all"], summary["liggghts_cpu_time_s"], summary["dem_cpu_time_s"])
    if summary["disagreeing"]:
        logger.warning("cases ok in both solvers that differ by more than %g combined SEM: %s",
                       AGREEMENT_SEMS, ", ".join(summary["disagreeing"]))
    logger.info("paired cell by cell (same packings, the packing spread cancels): %d of the %d "
                "cases ok in both agree within %g SEM of the difference", summary["paired_agree_both_ok"],
                summary["both_ok"], AGREEMENT_SEMS)
    if summary["paired_disagreeing"]:
        logger.warning("cases ok in both solvers whose cells differ by more than %g SEM of the "
                       "paired difference: %s", AGREEMENT_SEMS, ", ".join(summary["paired_disagreeing"]))
