"""The validation stage's steps: the whole grid checked by the compiled DEM against the
campaign's LIGGGHTS records (``snakemake validate``), and chosen cases run afresh in both
(``snakemake validate_chosen``).
"""

from __future__ import annotations

import logging
from pathlib import Path

from pidpipe.cases import CaseSpec
from pidpipe.config.settings import ShakeSettings
from pidpipe.errors import PidpipeError
from pidpipe.files import write_atomic

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
                        record_path: str) -> dict:
    """Shake a campaign case in the compiled DEM on the packings its LIGGGHTS record shook.

    Parameters
    ----------
    config : dict
        The case stage's part of the config (:func:`pidpipe.config.stages.stage_config`),
        parsed here; its fidelity (adaptive cycles, cells per run) is the LIGGGHTS campaign's.
    liggghts_record_path : path
        The campaign's record of the case (``results/cases/<case>.json``).
    packing_paths : list of path
        The case's packings, one per cell.
    record_path : path
        The DEM record to write (JSON, atomically).

    Raises
    ------
    PidpipeError
        The campaign's record is not a LIGGGHTS record (a campaign run with ``engine: dem``
        has nothing to be checked against), or the packings are not the ones it shook.
    """
    from pidpipe.cell.packing import load_packing, pour_engines
    from pidpipe.dem.case import run_dem_case
    from pidpipe.design.records import read_record
    from pidpipe.liggghts.shake import write_record
    from pidpipe.measurement.adaptive import run_to_target

    liggghts = read_record(liggghts_record_path)
    if liggghts.get("solver") != "liggghts":
        raise PidpipeError(f"{liggghts_record_path} was made by {liggghts.get('solver')!r}, not "
                           "LIGGGHTS: `snakemake validate` checks a LIGGGHTS campaign (engine: "
                           "liggghts) with the DEM")
    packings = [load_packing(path) for path in packing_paths]
    seeds = liggghts.get("fidelity", {}).get("seeds")
    poured_by = liggghts.get("fidelity", {}).get("pour_engine")
    if (seeds is not None and seeds != [p.seed for p in packings]) or (
            poured_by is not None and poured_by != pour_engines(packings)):
        raise PidpipeError(f"{liggghts_record_path} shook packings of seeds {seeds} poured by "
                           f"{poured_by or 'liggghts'}, not {[p.seed for p in packings]} poured by "
                           f"{pour_engines(packings)}: rerun the campaign first")
    case = CaseSpec.from_id(liggghts["case_id"])
    record = run_to_target(ShakeSettings.from_config(config), case, packings,
                           Path(record_path).parent, run=run_dem_case)
    write_record(record, record_path)
    logger.info("case %s: C_eq(cell) DEM %.4g +- %.2g, LIGGGHTS %.4g +- %.2g N*s/m; DEM %s%s",
                case.case_id, record["ceq_cell_ns_m"], record["ceq_cell_sem_ns_m"],
                liggghts.get("ceq_cell_ns_m", float("nan")),
                liggghts.get("ceq_cell_sem_ns_m", float("nan")), record["status"],
                f" ({', '.join(record['flags'])})" if record["flags"] else "")
    return record


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

    pairs = [(read_record(l), read_record(d)) for l, d in zip(liggghts_paths, dem_paths)]
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
