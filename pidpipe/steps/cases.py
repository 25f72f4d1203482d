"""The case stage's step: shake one case with the configured engine (LIGGGHTS or the compiled
DEM), retry an engine failure once, record a case that fails.

Failure policy (see also the Snakefile header): a case whose LIGGGHTS run fails
(:class:`~pidpipe.errors.EngineError` or :class:`~pidpipe.errors.ParseError`) is run once more;
if it fails again it does not stop the campaign: :func:`simulate_case` writes a record with
``status: failed`` and the message (which names the case, the LIGGGHTS screen file and the
rule's log), logs it and returns normally, so every other case still runs and the C_eq table is
still written. A missing LIGGGHTS binary or a packing that does not fit fails the step.
"""

from __future__ import annotations

import logging

from pidpipe.cases import CaseSpec
from pidpipe.config.settings import ShakeSettings
from pidpipe.errors import EngineError, ParseError, PidpipeError

logger = logging.getLogger("pidpipe.campaign")


#: LIGGGHTS runs of a case before it is recorded as failed: one unexplained MPI_ABORT in about
#: 40 runs did not reproduce (notes/liggghts-3.8.md), so one retry saves a campaign from holes.
ENGINE_ATTEMPTS = 2


def simulate_case(config: dict, case_id: str, packing_paths: list[str], record_path: str,
                  workdir: str, log_path: str) -> dict:
    """Run one case and write its record; a LIGGGHTS failure gives a ``failed`` record.

    A run that fails is tried again once (:data:`ENGINE_ATTEMPTS`); when every attempt fails
    the record has status ``failed`` and the last message.

    Parameters
    ----------
    config : dict
        The case stage's part of the config (:func:`pidpipe.config.stages.stage_config`),
        parsed here into :class:`~pidpipe.config.settings.ShakeSettings`.
    case_id : str
    packing_paths : list of path
        The packings to shake (JSON), one per cell of the run (:func:`case_packing_ids`).
    record_path : path
        The record to write (JSON, atomically).
    workdir : path
        The case's folder for the deck, the mesh and LIGGGHTS' files.
    log_path : path
        The rule's log, named in a failure's message.

    Returns
    -------
    dict
        The record written.

    Raises
    ------
    EngineError
        LIGGGHTS is not installed (no case could run: not a failure of this case).
    PackingError
        The packing does not fit or has not settled.
    """
    from pidpipe.cell.packing import load_packing
    from pidpipe.liggghts.shake import write_record
    from pidpipe.measurement.adaptive import run_to_target

    case = CaseSpec.from_id(case_id)
    settings = ShakeSettings.from_config(config)
    run_case = case_runner(settings)
    packings = [load_packing(path) for path in packing_paths]
    failures = []
    for attempt in range(1, ENGINE_ATTEMPTS + 1):
        try:
            record = run_to_target(settings, case, packings, workdir, run=run_case)
        except (EngineError, ParseError) as exc:
            failures.append(str(exc))
            logger.warning("case %s, attempt %d of %d: %s", case_id, attempt, ENGINE_ATTEMPTS, exc)
            continue
        record["engine_attempts"] = attempt
        logger.info("case %s (%s): status %s%s, C_eq(coupon) = %.6g +- %.2g N*s/m over %d "
                    "cycles, wall time %.1f s (attempt %d); files in %s", case_id,
                    record["solver"], record["status"],
                    f" ({', '.join(record['flags'])})" if record["flags"] else "",
                    record["ceq_coupon_ns_m"], record["ceq_coupon_sem_ns_m"], record["n_cycles"],
                    record["wall_time_s"], attempt, workdir)
        break
    else:
        message = (f"case {case_id} failed after {ENGINE_ATTEMPTS} attempt(s): {failures[-1]}; "
                   f"rule log: {log_path}")
        logger.error("%s", message)
        logger.error("the record %s is written with status failed so that the other cases and "
                     "the C_eq table go on; delete it to run the case again", record_path)
        record = failed_record(settings, case, packings[0].n_spheres,
                               [packing.seed for packing in packings], message)
        record["engine_attempts"] = ENGINE_ATTEMPTS
    write_record(record, record_path)
    return record


def case_runner(settings: ShakeSettings):
    """The function that shakes a case with the configured ``engine``.

    ``liggghts``: :func:`pidpipe.liggghts.shake.run_case` (LIGGGHTS must be installed);
    ``dem``: :func:`pidpipe.dem.case.run_dem_case` (numba must be installed). Both take
    ``(settings, case, packings, workdir)`` and return records with the same keys.

    Raises
    ------
    EngineError
        LIGGGHTS is not installed (engine liggghts).
    PidpipeError
        numba is not installed (engine dem); the message names the fix.
    """
    if settings.engine == "dem":
        try:
            from pidpipe.dem.case import run_dem_case
        except ImportError as exc:              # numba missing: the message names the fix
            raise PidpipeError(str(exc)) from None
        return run_dem_case
    from pidpipe.liggghts.process import find_liggghts
    from pidpipe.liggghts.shake import run_case
    find_liggghts()
    return run_case


def solver_name(settings: ShakeSettings) -> str:
    """The ``solver`` a record of the configured engine names."""
    if settings.engine == "dem":
        from pidpipe.dem.run import SOLVER_NAME
        return SOLVER_NAME
    return "liggghts"


def failed_record(settings: ShakeSettings, case: CaseSpec, n_spheres: int, seeds: list[int],
                  message: str) -> dict:
    """The record of a case whose run failed: its coordinates, the settings it ran with, no values.

    ``seeds`` are those of its packings, one per cell of the run.
    """
    from pidpipe.cell.scene import CellScene

    fidelity, sampling = settings.fidelity, settings.sampling
    seeds = [int(seed) for seed in seeds]
    nan = float("nan")
    return {
        "solver": solver_name(settings), "case_id": case.case_id, "freq_hz": case.freq_hz,
        "accel_g": case.accel_g, "fill_pct": case.fill_pct, "replicate": case.replicate,
        "n_spheres": n_spheres, "status": "failed", "flags": [], "message": message,
        "ceq_coupon_ns_m": nan, "ceq_coupon_sem_ns_m": nan, "ceq_cell_ns_m": nan,
        "ceq_cell_sem_ns_m": nan, "ed_cycle_mean_j": nan, "ed_cycle_sem_j": nan, "n_cycles": 0,
        "fidelity": {
            **CellScene.of(settings).timestep(case.freq_hz).as_record(),
            "timestep_rayleigh_fraction_config": fidelity.timestep_rayleigh_fraction,
            "youngs_modulus_scale": fidelity.youngs_modulus_scale,
            "transient_cycles": sampling.transient_cycles_at(case.freq_hz),
            "measured_cycles": sampling.measured_cycles,
            "sem_block_cycles": sampling.sem_block_cycles,
            "rotation": fidelity.rotation, "friction": fidelity.friction,
            "cells_per_run": len(seeds),
            "seed": seeds[0],
            "seeds": seeds,
            "engine": settings.engine,
        },
        "engine": {"name": settings.engine, "solver": solver_name(settings)},
        "wall_time_s": nan,
    }
