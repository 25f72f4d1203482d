"""The case stage's step: shake one case, retry a LIGGGHTS failure once, record a case that fails.

Failure policy (see also the Snakefile header): a case whose LIGGGHTS run fails
(:class:`~pidpipe.errors.EngineError` or :class:`~pidpipe.errors.ParseError`) is run once more;
if it fails again it does not stop the campaign: :func:`simulate_case` writes a record with
``status: failed`` and the message (which names the case, the LIGGGHTS screen file and the
rule's log), logs it and returns normally, so every other case still runs and the C_eq table is
still written. A missing LIGGGHTS binary or a packing that does not fit fails the step.
"""

from __future__ import annotations

import functools
import logging

from pidpipe.cases import CaseSpec
from pidpipe.config.inspection import MovieSettings
from pidpipe.errors import EngineError, ParseError

logger = logging.getLogger("pidpipe.campaign")


#: LIGGGHTS runs of a case before it is recorded as failed: one unexplained MPI_ABORT in about
#: 40 runs did not reproduce (notes/liggghts-3.8.md), so one retry saves a campaign from holes.
ENGINE_ATTEMPTS = 2


def simulate_case(config: dict, case_id: str, packing_paths: list[str], record_path: str,
                  workdir: str, log_path: str, movie: dict | None = None) -> dict:
    """Run one case and write its record; a LIGGGHTS failure gives a ``failed`` record.

    A run that fails is tried again once (:data:`ENGINE_ATTEMPTS`); when every attempt fails
    the record has status ``failed`` and the last message.

    Parameters
    ----------
    config : dict
        The case stage's config (:func:`stage_config`).
    case_id : str
    packing_paths : list of path
        The packings to shake (JSON), one per cell of the run (:func:`case_packing_ids`).
    record_path : path
        The record to write (JSON, atomically).
    workdir : path
        The case's folder for the deck, the mesh and LIGGGHTS' files.
    log_path : path
        The rule's log, named in a failure's message.
    movie : dict, optional
        ``frames_per_cycle``, ``cycles`` and ``directory``: also write the run's ParaView movie
        there (``inspection.movie_cases``); empty or None: no movie.

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
    from pidpipe.liggghts.process import find_liggghts
    from pidpipe.liggghts.shake import run_case, write_record
    from pidpipe.measurement.adaptive import run_to_target

    case = CaseSpec.from_id(case_id)
    find_liggghts()
    packings = [load_packing(path) for path in packing_paths]
    shake = run_case
    if movie:
        shake = functools.partial(run_case, movie=MovieSettings(int(movie["frames_per_cycle"]),
                                                               int(movie["cycles"])),
                                  movie_dir=movie["directory"])
    failures = []
    for attempt in range(1, ENGINE_ATTEMPTS + 1):
        try:
            record = run_to_target(config, case, packings, workdir, run=shake)
        except (EngineError, ParseError) as exc:
            failures.append(str(exc))
            logger.warning("case %s, attempt %d of %d: %s", case_id, attempt, ENGINE_ATTEMPTS, exc)
            continue
        record["engine_attempts"] = attempt
        logger.info("case %s: status %s%s, C_eq(coupon) = %.6g +- %.2g N*s/m over %d cycles, "
                    "wall time %.1f s (attempt %d); LIGGGHTS files in %s", case_id, record["status"],
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
        record = failed_record(config, case, packings[0].n_spheres,
                               [packing.seed for packing in packings], message)
        record["engine_attempts"] = ENGINE_ATTEMPTS
    write_record(record, record_path)
    return record


def failed_record(config: dict, case: CaseSpec, n_spheres: int, seeds: list[int],
                  message: str) -> dict:
    """The record of a case whose run failed: its coordinates, the settings it ran with, no values.

    ``seeds`` are those of its packings, one per cell of the run.
    """
    from pidpipe.measurement.timestep import plan_timestep, transient_cycles_for

    fidelity = config["fidelity"]
    seeds = [int(seed) for seed in seeds]
    nan = float("nan")
    return {
        "solver": "liggghts", "case_id": case.case_id, "freq_hz": case.freq_hz,
        "accel_g": case.accel_g, "fill_pct": case.fill_pct, "replicate": case.replicate,
        "n_spheres": n_spheres, "status": "failed", "flags": [], "message": message,
        "ceq_coupon_ns_m": nan, "ceq_coupon_sem_ns_m": nan, "ceq_cell_ns_m": nan,
        "ceq_cell_sem_ns_m": nan, "ed_cycle_mean_j": nan, "ed_cycle_sem_j": nan, "n_cycles": 0,
        "fidelity": {
            **plan_timestep(config, case.freq_hz).as_record(),
            "timestep_rayleigh_fraction_config": fidelity["timestep_rayleigh_fraction"],
            "youngs_modulus_scale": fidelity["youngs_modulus_scale"],
            "transient_cycles": transient_cycles_for(config, case.freq_hz),
            "measured_cycles": int(fidelity["measured_cycles"]),
            "sem_block_cycles": int(fidelity["sem_block_cycles"]),
            "rotation": bool(fidelity["rotation"]), "friction": bool(fidelity["friction"]),
            "cells_per_run": len(seeds),
            "seed": seeds[0],
            "seeds": seeds,
        },
        "engine": {},
        "wall_time_s": nan,
    }
