"""The bed's motion within the cycle, as any engine samples it: windows of a few steps each.

A shake run that samples the motion (:mod:`pidpipe.liggghts.motion` for LIGGGHTS) averages, over
consecutive windows of equal length, each cell's power from the walls, the force the floor
pushes the spheres up with, the force the spheres push the lid up with, and the height above the
floor of the cell's centre of mass and of its lowest and highest sphere centre; and it takes
each cell's energy (kinetic, rotational, potential) at the windows' ends. :class:`BedMotion`
holds that, whatever engine produced it; :mod:`pidpipe.measurement.phase` averages it over the
cycle and :mod:`pidpipe.measurement.regime` reads the regime from it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class BedMotion:
    """Window means of one run's bed motion, every cell of the run.

    Attributes
    ----------
    window_steps : int
        Steps per window.
    timestep_s : float
        Timestep, s.
    period_s : float
        Period of the base motion, s (a cycle need not hold a whole number of windows).
    amplitude_m : float
        Wall displacement amplitude W, m: the wall moves as z = W (cos(2 pi t / T) - 1).
    power_w : ndarray, shape (n_windows, n_cells)
        Mean power the walls put into each cell's spheres, W (the forces may be sampled every
        few steps rather than every step).
    floor_force_n : ndarray, shape (n_windows, n_cells)
        Mean upward force of the floor on each cell's spheres, N (the bed's weight at rest).
    lid_force_n : ndarray, shape (n_windows, n_cells)
        Mean upward force of each cell's spheres on its lid, N (0 unless they touch it).
    centre_m, bottom_m, top_m : ndarray, shape (n_windows, n_cells)
        Mean height above the floor of each cell's centre of mass, lowest and highest sphere
        centre over each window (or the mean of its two ends), m.
    energy_j : ndarray, shape (n_windows + 1, n_cells)
        Each cell's kinetic + rotational + potential energy at the windows' boundaries (the
        first at the start of the run), J.
    weight_n : ndarray, shape (n_cells,)
        Weight of each cell's spheres, N.
    radius_m : float
        Sphere radius, m.
    """

    window_steps: int
    timestep_s: float
    period_s: float
    amplitude_m: float
    power_w: np.ndarray
    floor_force_n: np.ndarray
    lid_force_n: np.ndarray
    centre_m: np.ndarray
    bottom_m: np.ndarray
    top_m: np.ndarray
    energy_j: np.ndarray
    weight_n: np.ndarray
    radius_m: float

    @property
    def n_windows(self) -> int:
        return int(self.power_w.shape[0])

    @property
    def n_cells(self) -> int:
        return int(self.power_w.shape[1])

    @property
    def window_s(self) -> float:
        """Length of a window, s."""
        return self.window_steps * self.timestep_s

    @property
    def centre_time_s(self) -> np.ndarray:
        """Time of each window's centre, s; shape (n_windows,)."""
        return (np.arange(self.n_windows) + 0.5) * self.window_s

    @property
    def phase(self) -> np.ndarray:
        """Phase of each window's centre within its cycle, in [0, 1); shape (n_windows,)."""
        return np.mod(self.centre_time_s / self.period_s, 1.0)

    @property
    def cycle(self) -> np.ndarray:
        """Cycle (from 0) that each window's centre lies in; shape (n_windows,)."""
        return np.floor(self.centre_time_s / self.period_s + 1e-12).astype(int)

    @property
    def wall_z_m(self) -> np.ndarray:
        """Wall position at each window's centre, m; shape (n_windows,)."""
        return self.amplitude_m * (np.cos(2.0 * math.pi * self.centre_time_s / self.period_s) - 1.0)

    @property
    def dissipation_w(self) -> np.ndarray:
        """Mean dissipation rate in each window, W: the walls' power minus the rate of change of
        the spheres' energy (the elastic energy held in contacts is not sampled, so a window in
        mid-impact shifts part of its dissipation into the next); shape (n_windows, n_cells)."""
        return self.power_w - np.diff(self.energy_j, axis=0) / self.window_s
