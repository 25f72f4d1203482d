"""What looking inside a finished shake run adds to its record: regime and phase profile, movie.

One call from :func:`pidpipe.liggghts.shake.run_case`, so that the shake stage itself only passes
the run's plan along (:mod:`pidpipe.liggghts.motion`, :mod:`pidpipe.liggghts.movie`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np

from pidpipe.cases import regime
from pidpipe.cell.geometry import HexCell
from pidpipe.cell.packing import Packing
from pidpipe.config.inspection import MotionSampling, MovieSettings
from pidpipe.liggghts.motion import motion_record
from pidpipe.liggghts.movie import write_case_movie


def inspection_record(plan: dict, workdir: str | Path, accel_g: float, packings: Sequence[Packing],
                      first_cycle: int, cell: HexCell, motion: MotionSampling | None,
                      movie: MovieSettings | None, movie_dir: str | Path | None) -> dict:
    """The record's ``regime``, and its ``motion`` and ``movie`` when they were asked for.

    Parameters
    ----------
    plan : dict
        The run's plan (:func:`pidpipe.liggghts.shake.render_shake_deck`).
    workdir : path
        The run's folder.
    accel_g : float
        The case's acceleration (the regime without motion sampling comes from it alone).
    packings : sequence of Packing
        The run's packings, one per cell (their heights at rest).
    first_cycle : int
        The first measured cycle.
    cell : HexCell
    motion : MotionSampling or None
    movie : MovieSettings or None
    movie_dir : path or None
        Where the movie goes (default ``workdir/movie``).
    """
    workdir = Path(workdir)
    record: dict = {"regime": regime(accel_g)}
    if motion is not None:
        record = motion_record(plan, workdir, first_cycle, [c["weight_n"] for c in plan["cells"]],
                               [float(np.ptp(p.centres()[:, 2])) for p in packings],
                               packings[0].radius_m, motion.windows_per_cycle)
    if movie is not None:
        write_case_movie(workdir, Path(movie_dir) if movie_dir is not None else workdir / "movie",
                         cell, plan["layout"], plan["timestep"].timestep_s, plan["period_s"],
                         plan["amplitude_m"], plan["movie"]["n_frames"])
        record["movie"] = {"frames": plan["movie"]["n_frames"], "cycles": movie.cycles,
                           "frames_per_cycle": movie.frames_per_cycle}
    return record
