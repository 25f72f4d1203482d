"""The verify stage's steps (``snakemake --cores 2 verify``): plan the designs' verifying cases,
check their packings, compare the cases with the surrogate (:mod:`pidpipe.loop.verify`).

The cases themselves are shaken by :func:`pidpipe.steps.cases.simulate_case` (run to the
campaign's target, engine ``verify.engine``) on packings poured by
:func:`pidpipe.steps.packings.pour_packing`.
"""

from __future__ import annotations

import json
import logging
from pathlib import Path

import pandas as pd

from pidpipe.config.settings import Fill, VerifySettings
from pidpipe.errors import PidpipeError
from pidpipe.files import write_atomic

logger = logging.getLogger("pidpipe.campaign")


def plan_verify(optimum_path: str, fill: dict, points_path: str) -> None:
    """Write the verifying cases of every band_mean and peak design (CSV, atomically).

    Parameters
    ----------
    optimum_path : path
        The optimisation's results (``results/optimum.json``).
    fill : dict
        The config's ``fill`` section (spheres per full cell).
    points_path : path
        ``results/verify/points.csv``: :data:`pidpipe.loop.verify.POINT_COLUMNS`.
    """
    from pidpipe.loop.verify import plan_points, unique_case_ids

    designs = json.loads(Path(optimum_path).read_text(encoding="utf-8"))
    points = plan_points(designs, Fill.from_config({"fill": fill}).full_cell_spheres)
    write_atomic(points_path, lambda tmp: points.to_csv(tmp, index=False))
    cases = unique_case_ids(points)
    logger.info("verify: %d design point(s), %d distinct case(s) (shared points run once): %s",
                len(points), len(cases), ", ".join(cases))


def read_points(points_path: str) -> pd.DataFrame:
    """The plan written by :func:`plan_verify` (case ids kept as text)."""
    return pd.read_csv(points_path, dtype={"case_id": str, "environment": str, "design": str,
                                           "point": str})


def verify_case_ids(points_path: str) -> list[str]:
    """The distinct case ids of a plan, each once (the workflow's list of verifying cases)."""
    from pidpipe.loop.verify import unique_case_ids

    return unique_case_ids(read_points(points_path))


def check_verify_packing(packing_path: str, report_path: str) -> None:
    """Check one verifying case's packing as the campaign's are checked
    (:func:`pidpipe.steps.packings.check_packings`); write its one-row report (TSV).

    Raises
    ------
    PackingError
        The packing does not fit or has not settled.
    """
    from pidpipe.steps.packings import check_packings

    check_packings([packing_path], [], report_path)


def configured_fidelity(config: dict) -> tuple[dict, float | None]:
    """What a verifying case's record must show (:func:`pidpipe.loop.verify.stale_records`):
    its ``fidelity`` values, and the target relative SEM.

    Parameters
    ----------
    config : dict
        The verifying cases' case-stage config (``steps.params.verify_case_config``).
    """
    from pidpipe.config.settings import ShakeSettings

    settings = ShakeSettings.from_config(config)
    fidelity, sampling = settings.fidelity, settings.sampling
    return ({"engine": settings.engine,
             "timestep_rayleigh_fraction_config": fidelity.timestep_rayleigh_fraction,
             "youngs_modulus_scale": fidelity.youngs_modulus_scale,
             "measured_cycles": sampling.measured_cycles, "rotation": fidelity.rotation,
             "friction": fidelity.friction, "cells_per_run": sampling.cells_per_run},
            sampling.target_relative_sem)


def compare_designs(points_path: str, record_paths: list[str], surrogate_path: str,
                    verify: dict, case_config: dict, table_path: str, plot_path: str,
                    m_eff_surrogate_path: str | None = None) -> None:
    """Compare every verifying case with the surrogates (C_eq, and m_eff when there is one);
    write results/verify.csv and its figure.

    Parameters
    ----------
    points_path : path
        The plan (:func:`plan_verify`).
    record_paths : list of path
        The record of every distinct case of the plan (``results/verify/cases/<case>.json``).
    surrogate_path : path
        The campaign's surrogate (``results/surrogate.json``).
    verify : dict
        ``{"verify": {...}}``: :meth:`pidpipe.config.settings.VerifySettings.as_params`.
    case_config : dict
        The verifying cases' case-stage config: every record must have been made with it.
    table_path, plot_path : path
        The table (CSV, atomically) and the parity figure (``.png``; a ``.pdf`` next to it).
    m_eff_surrogate_path : path, optional
        The campaign's m_eff surrogate (``results/surrogate_m_eff.json``); None (an external C_eq
        table): the m_eff columns are NaN.

    Raises
    ------
    PidpipeError
        A record was made with other settings than the configured ones (left from before a
        change, in the run whose checkpoint replanned the cases): the message names them and
        the fix, running verify again.
    """
    from pidpipe.design.records import read_record
    from pidpipe.design.surrogate import load_surrogate
    from pidpipe.figures.verify import plot_verify
    from pidpipe.loop.verify import (calibration_line, compare, m_eff_off_lines,
                                     m_eff_predictions, off_lines, stale_records,
                                     surrogate_uncertainty, worst_z_line)

    settings = VerifySettings.from_config(verify)
    points = read_points(points_path)
    records = {record.case_id: record for record in map(read_record, record_paths)}
    stale = stale_records(records, *configured_fidelity(case_config))
    if stale:
        raise PidpipeError(f"{len(stale)} setting(s) of verifying case records differ from the "
                           "config (records from before a change; Snakemake reruns them in the "
                           "next run, as it does not check cases it planned after a checkpoint "
                           "in the same run): run `snakemake --cores 2 verify` again; "
                           + "; ".join(stale))
    surrogate = load_surrogate(surrogate_path)
    predictions = surrogate_uncertainty(surrogate, points, settings.surrogate_draws,
                                        settings.surrogate_seed)
    m_eff_surrogate = load_surrogate(m_eff_surrogate_path) if m_eff_surrogate_path else None
    predictions = pd.concat([predictions, m_eff_predictions(m_eff_surrogate, points)], axis=1)
    table = compare(points, records, predictions, settings.flag_z)
    write_atomic(table_path, lambda tmp: table.to_csv(tmp, index=False))
    plot_verify(table, Path(plot_path).with_suffix(""), flag_z=settings.flag_z)
    off = off_lines(table)
    engines = ", ".join(sorted(set(table["engine"].astype(str))))
    logger.info("verify (%s): %d design point(s), %d distinct case(s), %.0f s CPU; the surrogate "
                "(%s, uncertainty %s) is off by more than %g combined standard uncertainties "
                "at %d of them", engines, len(table), table["case_id"].nunique(),
                table.drop_duplicates("case_id")["dem_cpu_time_s"].sum(), surrogate.method,
                table["surrogate_u_method"].iloc[0] if len(table) else "-", settings.flag_z,
                len(off))
    logger.info("verify: worst |z| per environment: %s", worst_z_line(table))
    logger.info("verify: %s", calibration_line(table, settings.flag_z))
    for line in off:
        logger.warning("surrogate off: %s", line)
    if m_eff_surrogate is None:
        logger.info("verify: no m_eff surrogate (an external C_eq table): m_eff not compared")
    else:
        m_eff_off = m_eff_off_lines(table)
        logger.info("verify: the m_eff surrogate is off by more than %g combined standard "
                    "uncertainties at %d of %d design point(s) with an m_eff", settings.flag_z,
                    len(m_eff_off), int(table["z_m_eff"].notna().sum()))
        for line in m_eff_off:
            logger.warning("m_eff off: %s", line)
    not_ok = table[table["dem_status"] != "ok"].drop_duplicates("case_id")
    for _, row in not_ok.iterrows():
        logger.warning("verifying case %s: DEM status %s%s", row["case_id"], row["dem_status"],
                       f" ({row['dem_flags']})" if row["dem_flags"] else "")
