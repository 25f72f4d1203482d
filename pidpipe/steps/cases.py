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

import functools
import logging
from pathlib import Path

from pidpipe.cases import CaseSpec
from pidpipe.config.inspection import MovieSettings
from pidpipe.config.settings import PourSettings, ShakeSettings
from pidpipe.errors import EngineError, ParseError, PidpipeError
from pidpipe.measurement.case_record import CaseRecord

logger = logging.getLogger("pidpipe.campaign")


#: LIGGGHTS runs of a case before it is recorded as failed: one unexplained MPI_ABORT in about
#: 40 runs did not reproduce (notes/liggghts-3.8.md), so one retry saves a campaign from holes.
ENGINE_ATTEMPTS = 2


#: Cells beyond the pilot's: cell j of replicate q shakes packing EXTRA_PACKINGS_FROM + 1000 q + j
#: of its fill (seed fidelity.seed + that index), shared by every case of that fill and replicate;
#: above any pilot packing (replicates <= 100, cells_per_run <= 24) and below the next replicate's.
EXTRA_PACKINGS_FROM = 10000
EXTRA_PACKINGS_PER_REPLICATE = 1000


def extra_packing_index(replicate: int, cell: int) -> int:
    """Packing index of cell ``cell`` (counted from 0 over the case's cells) of a replicate."""
    if not 0 <= cell < EXTRA_PACKINGS_PER_REPLICATE:
        raise ValueError(f"cell {cell} of a case: 0 to {EXTRA_PACKINGS_PER_REPLICATE - 1} are allowed")
    return EXTRA_PACKINGS_FROM + EXTRA_PACKINGS_PER_REPLICATE * int(replicate) + int(cell)


def pool_packing_path(folder: str | Path, fill_pct: float, index: int) -> Path:
    """The file of packing ``index`` of a fill in the pool ``folder``: ``r<fill>pct_rep<index>.json``."""
    from pidpipe.cases import format_number

    return Path(folder) / f"r{format_number(fill_pct)}pct_rep{int(index)}.json"


def pool_packings(settings: PourSettings, fill_pct: float, indices: list[int],
                  folder: str | Path) -> list[CaseRecord]:
    """The packings ``indices`` of a fill, poured on demand into ``folder`` and kept there.

    A packing already in ``folder`` with the settings' seed, sphere count and pour engine is
    reused (:func:`pidpipe.cell.packing.reusable`); else it is poured with
    ``fidelity.pour_engine`` (seed ``fidelity.seed`` + index) and saved atomically. A lock file
    per packing lets concurrent cases of the same fill pour it once; the same seed gives the
    same packing, so which case pours it changes nothing.

    The packings whose locks are free are taken together, and those of them that are missing
    are poured in one call (:func:`pidpipe.dem.pouring.pour_replicates_with_engine`: the DEM
    pours them as one batch, each the packing it pours alone); a packing whose lock another
    case holds is waited for afterwards, then read (or poured, should that case have failed).

    Returns
    -------
    list of Packing
        In the order of ``indices``.
    """
    import fcntl
    from contextlib import ExitStack

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)

    def lock_file(index: int) -> Path:
        return folder / f".{pool_packing_path(folder, fill_pct, index).stem}.lock"

    found, mine, busy = {}, [], []
    with ExitStack() as held:
        for index in indices:
            lock = held.enter_context(open(lock_file(index), "w"))
            try:
                fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                busy.append(index)
            else:
                mine.append(index)
        found.update(_pool_pour(settings, fill_pct, mine, folder))
    for index in busy:
        with open(lock_file(index), "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            found.update(_pool_pour(settings, fill_pct, [index], folder))
    return [found[index] for index in indices]


def _pool_pour(settings: PourSettings, fill_pct: float, indices: list[int], folder: Path) -> dict:
    """Packings ``indices`` of the pool, their locks held: each read if reusable, the others
    poured in one call and saved; {index: Packing}."""
    from pidpipe.cell.packing import load_packing, reusable, save_packing
    from pidpipe.dem.pouring import pour_replicates_with_engine

    wanted, seed = settings.fill.spheres(fill_pct), settings.pouring.seed
    out = {}
    for index in indices:
        path = pool_packing_path(folder, fill_pct, index)
        packing = load_packing(path) if path.is_file() else None
        ok = packing is not None and reusable(packing, seed + index, wanted, settings.pouring.engine)
        out[index] = packing if ok else None
    missing = [index for index in indices if out[index] is None]
    if missing:
        names = [pool_packing_path(folder, fill_pct, index).stem for index in missing]
        poured = pour_replicates_with_engine(settings, fill_pct, missing,
                                             [folder / "work" / name for name in names])
        for index, name, packing in zip(missing, names, poured):
            save_packing(packing, pool_packing_path(folder, fill_pct, index))
            logger.info("poured packing %s for a case's target with %s: %d spheres, seed %d",
                        name, packing.pour_engine, packing.n_spheres, packing.seed)
            out[index] = packing
    return out


def simulate_case(config: dict, case_id: str, packing_paths: list[str], record_path: str,
                  workdir: str, log_path: str, packing_pool: str | None = None,
                  movie: dict | None = None) -> CaseRecord:
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
    packing_pool : path, optional
        Where the further packings of a case with a target are poured and shared
        (:func:`pool_packings`); None: the case keeps its pilot's cells.
    movie : dict, optional
        ``frames_per_cycle``, ``cycles`` and ``directory``: also write the run's ParaView movie
        there (``inspection.movie_cases``); empty or None: no movie.

    Returns
    -------
    CaseRecord
        The record written.

    Raises
    ------
    EngineError
        LIGGGHTS is not installed (no case could run: not a failure of this case).
    PackingError
        The packing does not fit or has not settled.
    """
    from pidpipe.cell.packing import load_packing

    case = CaseSpec.from_id(case_id)
    settings = ShakeSettings.from_config(config)
    case_runner(settings)           # a missing engine fails the step here, not as a failed case
    pour_settings = PourSettings.from_config(config) if packing_pool else None
    packings = [load_packing(path) for path in packing_paths]
    movie_settings = None
    if movie and settings.engine == "liggghts":
        movie_settings = MovieSettings(int(movie["frames_per_cycle"]), int(movie["cycles"]))
    elif movie:
        logger.warning("case %s: no movie: the movie is written from LIGGGHTS' dumps, and this "
                       "campaign's engine is %s", case_id, settings.engine)
    failures = []
    for attempt in range(1, ENGINE_ATTEMPTS + 1):
        try:
            record = measure_case(settings, case, packings, workdir, pour_settings, packing_pool,
                                  movie=movie_settings,
                                  movie_dir=movie["directory"] if movie_settings else None)
        except (EngineError, ParseError) as exc:
            failures.append(str(exc))
            logger.warning("case %s, attempt %d of %d: %s", case_id, attempt, ENGINE_ATTEMPTS, exc)
            continue
        record = record.with_(engine_attempts=attempt)
        logger.info("case %s (%s): status %s%s, C_eq(coupon) = %.6g +- %.2g N*s/m over %d "
                    "cycles, wall time %.1f s (attempt %d); files in %s", case_id,
                    record.solver, record.status,
                    f" ({', '.join(record.flags)})" if record.flags else "",
                    record.ceq_coupon_ns_m, record.ceq_coupon_sem_ns_m, record.n_cycles,
                    record.wall_time_s, attempt, workdir)
        break
    else:
        message = (f"case {case_id} failed after {ENGINE_ATTEMPTS} attempt(s): {failures[-1]}; "
                   f"rule log: {log_path}")
        logger.error("%s", message)
        logger.error("the record %s is written with status failed so that the other cases and "
                     "the C_eq table go on; delete it to run the case again", record_path)
        record = failed_record(settings, case, packings[0].n_spheres,
                               [packing.seed for packing in packings], message)
        record = record.with_(engine_attempts=ENGINE_ATTEMPTS)
    record.write(record_path)
    return record


def simulate_cases(config: dict, case_ids: list[str], packing_paths: list[list[str]],
                   record_paths: list[str], workdirs: list[str], log_paths: list[str],
                   packing_pool: str | None = None, movies: list[dict] | None = None) -> list[CaseRecord]:
    """Several cases one after another in this process, each exactly as :func:`simulate_case`.

    One process for several DEM cases pays the job's start-up once (Python, the imports, Numba
    loading the compiled kernel: some 1.2 s of CPU per job, more than a 1000 Hz case's kernel
    run; benchmarks/bench_job_startup.py). Each case gets its own record and log, the same
    record as a job of its own would write (the engine's CPU and wall times aside).

    Parameters
    ----------
    config, packing_pool :
        As :func:`simulate_case`, shared by the cases.
    case_ids, packing_paths, record_paths, workdirs, log_paths : list
        One entry per case, in the same order (``packing_paths[i]``: case i's packings); each
        case's messages go to its own log (and to the job's).
    movies : list of dict, optional
        Case i's movie settings (:func:`simulate_case`'s ``movie``); None: no movies.

    Returns
    -------
    list of CaseRecord
        The records written, in order.
    """
    sizes = {len(case_ids), len(packing_paths), len(record_paths), len(workdirs), len(log_paths)}
    if movies is not None:
        sizes.add(len(movies))
    if len(sizes) != 1:
        raise ValueError(f"simulate_cases: one entry per case in every list, got lengths {sorted(sizes)}")
    root = logging.getLogger("pidpipe")
    records = []
    for i, case_id in enumerate(case_ids):
        Path(log_paths[i]).parent.mkdir(parents=True, exist_ok=True)
        handler = logging.FileHandler(log_paths[i], mode="a", encoding="utf-8")
        handler.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(message)s"))
        root.addHandler(handler)
        try:
            records.append(simulate_case(config, case_id, list(packing_paths[i]), record_paths[i],
                                         workdirs[i], log_paths[i], packing_pool,
                                         movies[i] if movies is not None else None))
        finally:
            root.removeHandler(handler)
            handler.close()
    return records


def measure_case(settings: ShakeSettings, case: CaseSpec, packings: list, workdir: str | Path,
                 pour_settings: PourSettings | None = None, packing_pool: str | Path | None = None,
                 movie: MovieSettings | None = None, movie_dir: str | Path | None = None,
                 continue_runs: bool = True) -> CaseRecord:
    """One case measured to its target (:func:`pidpipe.measurement.adaptive.run_to_target`).

    Parameters
    ----------
    settings : ShakeSettings
        The case's settings (engine, ``sampling.target_relative_sem`` and its caps).
    case : CaseSpec
    packings : list of Packing
        The pilot's cells, one per cell of its run.
    workdir : path
        The case's folder (run 0 there, run i in ``run<i>``).
    pour_settings : PourSettings, optional
        How the further packings of a case with a target are poured, into ``packing_pool``
        (:func:`pool_packings`); None (or no pool): the case keeps its pilot's cells.
    movie, movie_dir : optional
        Also write each LIGGGHTS run's ParaView movie into ``movie_dir`` (engine liggghts only).
    continue_runs : bool
        More cycles continue the runs where the engine can (:func:`case_starter`); False: they
        make them again, longer, as on LIGGGHTS (to measure what continuing saves,
        ``benchmarks/experiments/bench_continuation.py``).

    Returns
    -------
    CaseRecord
        The case's combined record (every run that made it in ``target.runs``).
    """
    from pidpipe.cell.scene import CellScene
    from pidpipe.measurement.adaptive import run_to_target
    from pidpipe.measurement.cost_model import load_cost_model

    plan = CellScene.of(settings).timestep(case.freq_hz)
    shake = case_runner(settings)
    if movie is not None:
        shake = functools.partial(shake, movie=movie, movie_dir=movie_dir)
    new_packings = None
    if pour_settings is not None and packing_pool is not None:
        def new_packings(first: int, count: int) -> list[CaseRecord]:
            indices = [extra_packing_index(case.replicate, cell)
                       for cell in range(first, first + count)]
            return pool_packings(pour_settings, case.fill_pct, indices, packing_pool)
    return run_to_target(settings, case, packings, workdir, run=shake, new_packings=new_packings,
                         cost_model=load_cost_model(settings.engine),
                         pour_model=(load_cost_model(pour_settings.pouring.engine)
                                     if new_packings is not None else None),
                         steps_per_cycle=plan.steps_per_cycle,
                         transient_cycles=settings.sampling.transient_cycles_at(case.freq_hz),
                         start=case_starter(settings) if continue_runs else None)


def case_starter(settings: ShakeSettings):
    """For an engine whose runs can go on from where they ended, the function that starts one
    (``dem``: :func:`pidpipe.dem.case.start_dem_case`); None for ``liggghts``, whose longer
    runs replay the shorter ones from the pour."""
    if settings.engine == "dem":
        from pidpipe.dem.case import start_dem_case
        return start_dem_case
    return None


def case_runner(settings: ShakeSettings):
    """The function that shakes a case with the configured ``engine``.

    ``liggghts``: :func:`pidpipe.liggghts.shake.run_case` (LIGGGHTS must be installed);
    ``dem``: :func:`pidpipe.dem.case.run_dem_case` (numba must be installed). Both take
    ``(settings, case, packings, workdir)`` and return a
    :class:`~pidpipe.measurement.case_record.CaseRecord`.

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
                  message: str) -> CaseRecord:
    """The record of a case whose run failed: its coordinates, the settings it ran with, no values
    (C_eq, E_d and the wall time NaN, no cycles).

    ``seeds`` are those of its packings, one per cell of the run.
    """
    from pidpipe.cell.scene import CellScene
    from pidpipe.measurement.run_record import fidelity_record

    seeds = [int(seed) for seed in seeds]
    return CaseRecord(
        solver=solver_name(settings), case_id=case.case_id, freq_hz=case.freq_hz,
        accel_g=case.accel_g, fill_pct=case.fill_pct, replicate=case.replicate,
        n_spheres=n_spheres, status="failed", flags=(), message=message, n_cycles=0,
        fidelity=fidelity_record(settings, CellScene.of(settings).timestep(case.freq_hz),
                                 settings.sampling.transient_cycles_at(case.freq_hz), seeds,
                                 settings.engine),
        engine={"name": settings.engine, "solver": solver_name(settings)})
