"""Pouring with the configured engine (``fidelity.pour_engine``), and keeping the packings.

This sits in the DEM's room because it is the lowest one that sees both pours
(:func:`pidpipe.liggghts.pour.pour` and :func:`pidpipe.dem.pour.pour`); the workflow's steps,
the studies and the command line pour through it.
"""

from __future__ import annotations

import json
from pathlib import Path

from pidpipe.cell.packing import Packing
from pidpipe.config.settings import POUR_ENGINES, PourSettings
from pidpipe.errors import ConfigError


def pour_with_engine(settings: PourSettings, fill_pct: float, replicate: int,
                     workdir: str | Path) -> Packing:
    """Pour one packing with ``settings.pouring.engine``; arguments as :func:`pidpipe.liggghts.pour.pour`.

    Raises
    ------
    ConfigError
        The engine is not one of :data:`~pidpipe.config.settings.POUR_ENGINES`.
    """
    engine = settings.pouring.engine
    if engine == "dem":
        from pidpipe.dem.pour import pour
    elif engine == "liggghts":
        from pidpipe.liggghts.pour import pour
    else:
        raise ConfigError(f"fidelity.pour_engine {engine!r} is not one of {', '.join(POUR_ENGINES)}")
    return pour(settings, fill_pct, replicate, workdir)


def pour_replicates_with_engine(settings: PourSettings, fill_pct: float, replicates,
                                workdirs) -> list[Packing]:
    """Several replicates of one fill, each the packing :func:`pour_with_engine` pours alone.

    The DEM pours them in one batched call (:func:`pidpipe.dem.pour.pour_replicates`, one
    process's start-up for all of them); LIGGGHTS pours one run after another (each run is a
    process of its own).

    Parameters
    ----------
    settings : PourSettings
    fill_pct : float
        Fill fraction, percent.
    replicates : sequence of int
        Replicate indices (seeds ``fidelity.seed`` + replicate).
    workdirs : sequence of path
        One engine folder per replicate (LIGGGHTS' files; unused by the DEM).

    Returns
    -------
    list of Packing
        In the order of ``replicates``.

    Raises
    ------
    ConfigError
        The engine is not one of :data:`~pidpipe.config.settings.POUR_ENGINES`.
    """
    replicates, workdirs = [int(k) for k in replicates], list(workdirs)
    if len(workdirs) != len(replicates):
        raise ValueError(f"{len(replicates)} replicates but {len(workdirs)} work folders")
    if settings.pouring.engine == "dem":
        from pidpipe.dem.pour import pour_replicates
        return pour_replicates(settings, fill_pct, replicates)
    return [pour_with_engine(settings, fill_pct, k, workdir)
            for k, workdir in zip(replicates, workdirs)]


def replicate_packings(settings: PourSettings, fill_pct: float, replicates: int, folder: str | Path,
                       workers: int = 1) -> tuple[list[Packing], dict[int, float]]:
    """The packings of replicates 0 .. replicates-1 of a fill, poured as the campaign pours them.

    Each is :func:`pour_with_engine` (seed = ``fidelity.seed`` + replicate), kept in ``folder``
    as ``r<fill>pct_rep<k>.json`` and reused on the next call when its seed, sphere count and
    pour engine still match the settings (:func:`pidpipe.cell.packing.reusable`).

    Parameters
    ----------
    settings : PourSettings
    fill_pct : float
    replicates : int
    folder : path
    workers : int
        Pours run at the same time (each is one serial process).

    Returns
    -------
    packings : list of Packing
    pour_cpu_s : dict
        CPU time (s) of each pour, by replicate, as measured when it was poured (kept in
        ``folder`` next to the packings): the pour's process and its children (LIGGGHTS), so
        either engine's; the first DEM pour of a worker includes loading the compiled kernel.
    """
    from concurrent.futures import ProcessPoolExecutor

    from pidpipe.cases import format_number
    from pidpipe.cell.packing import load_packing, reusable

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    paths = [folder / f"r{format_number(fill_pct)}pct_rep{k}.json" for k in range(replicates)]
    wanted = settings.fill.spheres(fill_pct)
    seed = settings.pouring.seed

    def usable(k: int) -> bool:
        return paths[k].is_file() and reusable(load_packing(paths[k]), seed + k, wanted,
                                               settings.pouring.engine)

    missing = [k for k in range(replicates) if not usable(k)]
    cpu_path = folder / f"r{format_number(fill_pct)}pct_pour_cpu_s.json"
    pour_cpu = ({int(k): v for k, v in json.loads(cpu_path.read_text()).items()}
                if cpu_path.is_file() else {})
    if missing:
        with ProcessPoolExecutor(max_workers=max(1, int(workers))) as pool:
            jobs = [(settings, fill_pct, k, str(paths[k])) for k in missing]
            for k, cpu in zip(missing, pool.map(_pour_one, jobs)):
                pour_cpu[k] = cpu
                cpu_path.write_text(json.dumps(pour_cpu))
    return [load_packing(path) for path in paths], {k: pour_cpu[k] for k in range(replicates)
                                                    if k in pour_cpu}


def _pour_one(job: tuple) -> float:
    """Pour one replicate into a scratch folder, save it; its CPU time (this process and its
    children), s."""
    import resource
    import shutil
    import tempfile

    from pidpipe.cell.packing import save_packing
    settings, fill_pct, replicate, path = job

    def cpu_s() -> float:
        own, children = (resource.getrusage(who) for who in
                         (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN))
        return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime

    before = cpu_s()
    scratch = tempfile.mkdtemp(prefix=f"pour_rep{replicate}_")
    try:
        save_packing(pour_with_engine(settings, fill_pct, replicate, scratch), path)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    return cpu_s() - before
