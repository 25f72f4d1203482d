"""One cycle of the bed's motion, averaged over the measured cycles, with the spread between them.

The windows of a :class:`~pidpipe.measurement.motion.BedMotion` are put into ``bins`` equal phase
bins by the phase of their centre; each measured cycle gives one value per bin (the mean of its
windows there), for the mean cell of the run; the profile is the mean over the cycles and their
standard deviation (the spread, not an error of the mean).
"""

from __future__ import annotations

import numpy as np

from pidpipe.measurement.motion import BedMotion

#: Quantities of a phase profile: name -> (unit, description), in the figure's order.
PROFILE_QUANTITIES = {
    "wall_z_m": ("m", "wall position"),
    "centre_m": ("m", "bed centre of mass above the floor"),
    "floor_force_n": ("N", "force of the floor on the bed"),
    "lid_force_n": ("N", "force of the bed on the lid"),
    "dissipation_w": ("W", "dissipation rate"),
}


def cycle_bins(motion: BedMotion, first_cycle: int, bins: int) -> tuple[np.ndarray, np.ndarray, int]:
    """Which measured cycle and phase bin each window falls in.

    Parameters
    ----------
    motion : BedMotion
    first_cycle : int
        The first measured cycle (the transient before it is left out).
    bins : int
        Phase bins per cycle.

    Returns
    -------
    cycle : ndarray of int, shape (n_windows,)
        Measured cycle of each window from 0, -1 for a window of the transient or of the last,
        incomplete cycle.
    phase_bin : ndarray of int, shape (n_windows,)
    n_cycles : int
        Measured cycles.
    """
    cycle = motion.cycle - int(first_cycle)
    phase_bin = np.minimum((motion.phase * bins).astype(int), bins - 1)
    # A cycle counts if the windows reach within half a window of its end (a cycle need not
    # hold a whole number of windows, so the last window may end a few steps short).
    complete = int(np.floor((motion.n_windows + 0.5) * motion.window_s / motion.period_s))
    n_cycles = max(0, complete - int(first_cycle))
    cycle = np.where((cycle >= 0) & (cycle < n_cycles), cycle, -1)
    return cycle, phase_bin, n_cycles


def per_cycle(values: np.ndarray, cycle: np.ndarray, phase_bin: np.ndarray, n_cycles: int,
              bins: int) -> np.ndarray:
    """Mean of a window quantity over each (measured cycle, phase bin); NaN where a bin is empty.

    Parameters
    ----------
    values : ndarray, shape (n_windows,) or (n_windows, n_cells)

    Returns
    -------
    ndarray, shape (n_cycles, bins) or (n_cycles, bins, n_cells)
    """
    values = np.asarray(values, dtype=float)
    tail = values.shape[1:]
    total = np.zeros((n_cycles, bins) + tail)
    count = np.zeros((n_cycles, bins))
    keep = cycle >= 0
    np.add.at(total, (cycle[keep], phase_bin[keep]), values[keep])
    np.add.at(count, (cycle[keep], phase_bin[keep]), 1.0)
    count = count.reshape(count.shape + (1,) * len(tail))
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, total / np.maximum(count, 1.0), np.nan)


def phase_profile(motion: BedMotion, first_cycle: int, bins: int) -> dict:
    """The mean cell's cycle: each quantity of :data:`PROFILE_QUANTITIES` per phase bin.

    Parameters
    ----------
    motion : BedMotion
    first_cycle : int
        The first measured cycle.
    bins : int
        Phase bins (at most the windows per cycle, so that every bin gets a window each cycle).

    Returns
    -------
    dict
        ``phase`` (bin centres, fraction of the period, shape (bins,)), ``n_cycles``,
        ``period_s``, ``bed_weight_n`` (the mean cell's), and for each quantity
        ``<name>`` = {``mean``, ``std``} over the measured cycles (lists of length bins; the
        force, centre and dissipation are the mean cell's).
    """
    cycle, phase_bin, n_cycles = cycle_bins(motion, first_cycle, bins)
    series = {
        "wall_z_m": motion.wall_z_m,
        "centre_m": motion.centre_m.mean(axis=1),
        "floor_force_n": motion.floor_force_n.mean(axis=1),
        "lid_force_n": motion.lid_force_n.mean(axis=1),
        "dissipation_w": motion.dissipation_w.mean(axis=1),
    }
    profile = {"phase": ((np.arange(bins) + 0.5) / bins).tolist(), "n_cycles": n_cycles,
               "period_s": motion.period_s, "bed_weight_n": float(np.mean(motion.weight_n))}
    for name in PROFILE_QUANTITIES:
        table = per_cycle(series[name], cycle, phase_bin, n_cycles, bins)
        with np.errstate(invalid="ignore"):
            std = np.nanstd(table, axis=0, ddof=1) if n_cycles > 1 else np.full(bins, np.nan)
        profile[name] = {"mean": np.nanmean(table, axis=0).tolist() if n_cycles else [np.nan] * bins,
                         "std": std.tolist()}
    return profile
