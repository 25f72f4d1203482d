"""The movie of a LIGGGHTS shake run: spheres and moving cell over the last cycles, for ParaView.

With a movie asked for, the shake deck (its ``movie`` block) dumps every sphere's id, position,
velocity, spin and radius at :attr:`MovieSettings.frames_per_cycle` frames per cycle over the
last :attr:`MovieSettings.cycles` cycles of the run (steps listed in :data:`STEPS_FILE`, read by a
file-style variable through ``dump_modify every``), and :func:`write_case_movie` turns the dump
into a VTK time series with the cell walls at each frame's wall position
(:func:`pidpipe.cell.vtk_series.write_vtk_series`). Off by default; the cost is measured in
``benchmarks/experiments/bench_inspection.py``.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from pidpipe.cell.geometry import HexCell, cells_wall_triangles
from pidpipe.cell.layout import CellLayout
from pidpipe.cell.vtk_series import write_vtk_series
from pidpipe.config.inspection import MovieSettings
from pidpipe.errors import ParseError
from pidpipe.liggghts.parsing import read_dump_frames

STEPS_FILE = "movie_steps.txt"
DUMP_FILE = "movie.dump"
DUMP_COLUMNS = ("id", "x", "y", "z", "vx", "vy", "vz", "omegax", "omegay", "omegaz", "radius")


def movie_steps(settings: MovieSettings, steps_per_cycle: int, total_cycles: int) -> np.ndarray:
    """The steps at which the movie's frames are taken, shape (n_frames,).

    Frame j of the last ``cycles`` cycles is at step round(j * steps_per_cycle /
    frames_per_cycle) after their start, j = 0 .. cycles * frames_per_cycle - 1 (repeated steps,
    when a cycle has fewer steps than frames, are dropped).
    """
    cycles = min(int(settings.cycles), int(total_cycles))
    start = (int(total_cycles) - cycles) * int(steps_per_cycle)
    frames = np.arange(cycles * int(settings.frames_per_cycle))
    steps = start + np.rint(frames * steps_per_cycle / settings.frames_per_cycle).astype(np.int64)
    steps = np.unique(steps)
    return steps[steps > 0]


def movie_deck_values(settings: MovieSettings, steps_per_cycle: int, total_cycles: int,
                      workdir: Path) -> dict:
    """Write the movie's step list into ``workdir`` and return the deck's ``movie`` values."""
    steps = movie_steps(settings, steps_per_cycle, total_cycles)
    # A file-style variable must list one step beyond the run (LIGGGHTS' dump_modify every).
    beyond = int(total_cycles) * int(steps_per_cycle) + 1
    (Path(workdir) / STEPS_FILE).write_text("".join(f"{int(s)}\n" for s in [*steps, beyond]),
                                            encoding="utf-8")
    return {"steps_file": STEPS_FILE, "dump_file": DUMP_FILE, "first_step": int(steps[0]),
            "n_frames": int(steps.size)}


def write_case_movie(workdir: str | Path, out_dir: str | Path, cell: HexCell, layout: CellLayout,
                     timestep_s: float, period_s: float, amplitude_m: float,
                     expected_frames: int) -> Path:
    """The VTK series of a finished shake run that dumped a movie.

    Parameters
    ----------
    workdir : path
        The run's folder (holds :data:`DUMP_FILE`).
    out_dir : path
        The folder to write (``movie.pvd`` and the ``.vtu`` frames).
    cell : HexCell
    layout : CellLayout
        Where the run's cells are (the walls of every cell are drawn).
    timestep_s, period_s, amplitude_m : float
        The run's timestep, period and wall amplitude W (the walls are at W (cos wt - 1)).
    expected_frames : int

    Raises
    ------
    ParseError
        The dump is missing, truncated or does not hold the expected frames.
    """
    steps, frames = read_dump_frames(Path(workdir) / DUMP_FILE, len(DUMP_COLUMNS))
    if len(steps) != expected_frames:
        raise ParseError(f"{Path(workdir) / DUMP_FILE} holds {len(steps)} frames, expected "
                         f"{expected_frames} (did the run finish?)")
    column = {name: k for k, name in enumerate(DUMP_COLUMNS)}
    times = steps * float(timestep_s)
    wall_z = float(amplitude_m) * (np.cos(2.0 * math.pi * times / float(period_s)) - 1.0)
    points, triangles = cells_wall_triangles(cell, offsets_xy_m=layout.offsets_m)
    return write_vtk_series(
        out_dir, times,
        frames[:, :, column["x"]:column["z"] + 1],
        frames[:, :, column["vx"]:column["vz"] + 1],
        frames[:, :, column["omegax"]:column["omegaz"] + 1],
        frames[0, :, column["radius"]], frames[0, :, column["id"]].astype(np.int64),
        layout.cell_of_atom(), points, triangles, wall_z)
