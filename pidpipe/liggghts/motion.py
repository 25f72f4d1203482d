"""Sampling the bed's motion within the cycle in the LIGGGHTS shake deck, and reading it back.

With motion sampling on, the shake deck (``templates/shake.lmp.j2``, its ``motion`` block) stores
the walls' force on every sphere (``store_force yes`` on ``fix walls``) and writes two ``fix
ave/time`` files over consecutive windows of :meth:`MotionSampling.window_steps` steps:

- :data:`WINDOW_FILE`, window means (sampled every :attr:`MotionSampling.sample_every_steps`
  steps), per cell: the walls' power into the cell's spheres; the floor's upward force on them
  (the walls' z force on the spheres whose centre is within :data:`CONTACT_BAND_RADII` radii of
  the floor, so touching it); the spheres' upward force on the lid (the same at the lid, sign
  reversed);
- :data:`ENERGY_FILE`, at every window end (and at step 0), per cell: the kinetic + rotational +
  potential energy, and the height above the floor of the centre of mass and of the lowest and
  highest sphere centre.

A side wall's friction on a sphere inside a band also counts, but a sphere in the band is within
1 % of a radius of touching the floor or the lid. The cost of the sampling is measured in
``benchmarks/experiments/bench_inspection.py``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pidpipe.cell.geometry import HexCell
from pidpipe.config.inspection import MotionSampling
from pidpipe.errors import ParseError
from pidpipe.liggghts.parsing import read_ave_time, without_step_zero
from pidpipe.measurement.inspection import motion_record as bed_motion_record
from pidpipe.measurement.motion import BedMotion

WINDOW_FILE = "motion_windows.txt"
ENERGY_FILE = "motion_energy.txt"
CONTACT_BAND_RADII = 1.01
"""A sphere whose centre is within this many radii of the floor (or lid) touches it, or is
within 1 % of a radius of it (the walls' computed position may lag the true one by a micrometre
at 50 Hz, 10 g: a band of exactly one radius would miss resting spheres)."""
WINDOW_COLUMNS = ("power_w", "floor_force_n", "lid_force_n")
"""The window file's columns for each cell, in the deck's order (after the step)."""
POINT_COLUMNS = ("energy_j", "centre_m", "bottom_m", "top_m")
"""The energy file's columns for each cell, in the deck's order (after the step)."""


def motion_deck_values(sampling: MotionSampling, steps_per_cycle: int, cell: HexCell,
                       radius_m: float) -> dict:
    """The ``motion`` values of the shake deck.

    Parameters
    ----------
    sampling : MotionSampling
    steps_per_cycle : int
    cell : HexCell
        The cell (its floor and lid heights at rest, m).
    radius_m : float
        Sphere radius, m.
    """
    band = CONTACT_BAND_RADII * radius_m
    window = sampling.window_steps(steps_per_cycle)
    return {
        "window_steps": window,
        "sample_every_steps": int(sampling.sample_every_steps),
        "samples_per_window": window // int(sampling.sample_every_steps),
        "floor_z_m": cell.floor_z_m,
        "band_m": band,
        "lid_band_offset_m": (cell.lid_z_m - cell.floor_z_m) - band,
        "window_file": WINDOW_FILE,
        "energy_file": ENERGY_FILE,
    }


def read_bed_motion(workdir: str | Path, window_steps: int, total_steps: int, timestep_s: float,
                    period_s: float, amplitude_m: float, weight_n, radius_m: float) -> BedMotion:
    """The bed's motion from a shake run's two motion files.

    Parameters
    ----------
    workdir : path
        The run's folder.
    window_steps, total_steps : int
        Steps per window and of the whole run.
    timestep_s, period_s, amplitude_m : float
        Timestep, period and wall amplitude of the run, s, s, m.
    weight_n : array_like, shape (n_cells,)
        Weight of each cell's spheres, N.
    radius_m : float

    Raises
    ------
    ParseError
        A file is missing, malformed or short of windows.
    """
    weight = np.asarray(weight_n, dtype=float).reshape(-1)
    n_cells = weight.size
    n_windows = int(total_steps) // int(window_steps)
    windows = without_step_zero(read_ave_time(Path(workdir) / WINDOW_FILE,
                                              1 + len(WINDOW_COLUMNS) * n_cells))
    points = read_ave_time(Path(workdir) / ENERGY_FILE, 1 + len(POINT_COLUMNS) * n_cells)
    if len(windows) != n_windows or len(points) != n_windows + 1:
        raise ParseError(f"{Path(workdir) / WINDOW_FILE}: {len(windows)} windows and "
                         f"{len(points)} window ends, expected {n_windows} and {n_windows + 1} "
                         "(did the run finish?)")
    if not (np.array_equal(windows[:, 0].astype(np.int64), window_steps * np.arange(1, n_windows + 1))
            and np.array_equal(points[:, 0].astype(np.int64), window_steps * np.arange(n_windows + 1))):
        raise ParseError(f"{Path(workdir) / WINDOW_FILE}: windows do not end every {window_steps} steps")
    means = windows[:, 1:].reshape(n_windows, n_cells, len(WINDOW_COLUMNS))
    ends = points[:, 1:].reshape(n_windows + 1, n_cells, len(POINT_COLUMNS))
    values = {name: means[:, :, k] for k, name in enumerate(WINDOW_COLUMNS)}
    # Heights: the mean of each window's two ends stands for the window's mean.
    values.update({name: 0.5 * (ends[1:, :, k] + ends[:-1, :, k])
                   for k, name in enumerate(POINT_COLUMNS) if name != "energy_j"})
    return BedMotion(window_steps=int(window_steps), timestep_s=float(timestep_s),
                     period_s=float(period_s), amplitude_m=float(amplitude_m),
                     energy_j=ends[:, :, 0], weight_n=weight, radius_m=float(radius_m), **values)


def motion_record(plan: dict, workdir: str | Path, first_cycle: int, weight_n, rest_height_m,
                  radius_m: float, windows_per_cycle: int) -> dict:
    """What a shake run that sampled the motion adds to its record.

    Parameters
    ----------
    plan : dict
        The run's plan (:func:`pidpipe.liggghts.shake.render_shake_deck`), ``motion`` not None.
    workdir : path
    first_cycle : int
        The first measured cycle (after the transient the case discards).
    weight_n, rest_height_m : array_like, shape (n_cells,)
        Each cell's bed weight (N) and height at rest (highest minus lowest centre, m).
    radius_m : float
    windows_per_cycle : int
        The sampling's windows per cycle (the phase bins of the profile).

    Returns
    -------
    dict
        ``regime`` and ``motion``, as :func:`pidpipe.measurement.inspection.motion_record`
        makes them for either engine.
    """
    window_steps = int(plan["motion"]["window_steps"])
    motion = read_bed_motion(workdir, window_steps, plan["steps_per_cycle"] * plan["cycles"],
                             plan["timestep"].timestep_s, plan["period_s"], plan["amplitude_m"],
                             weight_n, radius_m)
    return bed_motion_record(motion, first_cycle, plan["steps_per_cycle"], windows_per_cycle,
                             rest_height_m)
