"""The packing stage's steps: pour one packing (or several of one fill), then check every packing before any case is shaken.
"""

from __future__ import annotations

import logging
from pathlib import Path

from pidpipe.cases import CaseSpec
from pidpipe.config.settings import PourSettings
from pidpipe.errors import PackingError
from pidpipe.files import write_atomic

logger = logging.getLogger("pidpipe.campaign")


def pour_packing(config: dict, fill_pct: float, replicate: int, packing_path: str,
                 workdir: str) -> None:
    """Pour and settle the packing of one fill level and replicate with ``fidelity.pour_engine``; save it (JSON).

    A packing that does not fit is saved as well: :func:`check_packings` refuses it, with every
    other one that does not fit, in one message.
    """
    pour_packings(config, fill_pct, [replicate], [packing_path], [workdir])


def pour_packings(config: dict, fill_pct: float, replicates: list[int], packing_paths: list[str],
                  workdirs: list[str]) -> None:
    """Pour several replicates of one fill level in this process and save each (JSON), each the
    packing :func:`pour_packing` saves alone (the DEM pours them as one batch:
    :func:`pidpipe.dem.pouring.pour_replicates_with_engine`).

    Parameters
    ----------
    config : dict
        The packing stage's part of the config.
    fill_pct : float
        Fill fraction, percent.
    replicates : list of int
        Replicate (packing) indices.
    packing_paths, workdirs : list of path
        The file of each packing and its engine folder (LIGGGHTS' files), in the same order.
    """
    from pidpipe.cell.packing import save_packing
    from pidpipe.dem.pouring import pour_replicates_with_engine

    replicates = [int(k) for k in replicates]
    if len(packing_paths) != len(replicates):
        raise ValueError(f"{len(replicates)} replicates but {len(packing_paths)} packing files")
    packings = pour_replicates_with_engine(PourSettings.from_config(config), float(fill_pct),
                                           replicates, workdirs)
    for replicate, packing, path, workdir in zip(replicates, packings, packing_paths, workdirs):
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        save_packing(packing, path)
        logger.info("packing r=%g %% replicate %d, poured by %s: %d spheres, seed %d, pile %.2f mm "
                    "(lid %.2f mm), fastest sphere %.2g m/s; engine files (LIGGGHTS) in %s",
                    packing.fill_pct, replicate, packing.pour_engine, packing.n_spheres,
                    packing.seed, packing.pile_height_m * 1e3, packing.lid_height_m * 1e3,
                    packing.max_speed_m_s, workdir)


def check_packings(packing_paths: list[str], case_ids: list[str], report_path: str,
                   cells_per_run: int = 1) -> None:
    """Check every packing before any case is shaken; refuse all misfits in one message.

    Parameters
    ----------
    packing_paths : list of path
        The packings (JSON), one per fill level and replicate.
    case_ids : list of str
        The campaign's cases; the message lists those that use a refused packing.
    report_path : path
        A tab-separated summary of every packing, written when all pass.
    cells_per_run : int
        Cells (packings) per case (``fidelity.cells_per_run``).

    Raises
    ------
    PackingError
        One message naming every refused packing, why, and its cases.
    """
    from pidpipe.cell.packing import check_packing, load_packing

    cases_of: dict[str, list[str]] = {}
    for case_id in case_ids:
        for packing_id in CaseSpec.from_id(case_id).packing_ids(cells_per_run):
            cases_of.setdefault(packing_id, []).append(case_id)
    rows, problems = [], []
    for path in packing_paths:
        packing = load_packing(path)
        packing_id = Path(path).stem
        try:
            check_packing(packing, packing_id)
            verdict = "ok"
        except PackingError as exc:
            verdict = "refused"
            cases = cases_of.get(packing_id, [])
            problems.append(f"{exc} [{len(cases)} case(s): {', '.join(cases)}]" if cases else str(exc))
        rows.append({"packing_id": packing_id, "fill_pct": packing.fill_pct,
                     "n_spheres": packing.n_spheres, "seed": packing.seed,
                     "pour_engine": packing.pour_engine,
                     "pile_height_mm": round(packing.pile_height_m * 1e3, 3),
                     "lid_height_mm": round(packing.lid_height_m * 1e3, 3),
                     "max_speed_m_s": packing.max_speed_m_s,
                     "settle_time_s": packing.settle_time_s, "verdict": verdict})
        logger.info("%s: %d spheres, pile %.2f mm, lid %.2f mm: %s", packing_id, packing.n_spheres,
                    packing.pile_height_m * 1e3, packing.lid_height_m * 1e3, verdict)
    if problems:
        raise PackingError(f"{len(problems)} of {len(packing_paths)} packing(s) refused, so no case "
                           "is run:\n  " + "\n  ".join(problems))
    import pandas as pd     # here, not at the top: a pour job does not need it

    write_atomic(report_path, lambda tmp: pd.DataFrame(rows).to_csv(tmp, sep="\t", index=False))
