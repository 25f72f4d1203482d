"""What a run's sampled bed motion adds to its case record, whatever engine sampled it.

Both engines sample the motion in windows (:class:`~pidpipe.measurement.motion.BedMotion`:
LIGGGHTS from its deck's files, :mod:`pidpipe.liggghts.motion`; the compiled DEM inside its
kernel, :func:`pidpipe.dem.run.run_cycles_sampled`); :func:`motion_record` turns it into the
record's ``regime`` and ``motion`` block, so the two engines' records read alike.
"""

from __future__ import annotations

from pidpipe.measurement.motion import BedMotion
from pidpipe.measurement.phase import phase_profile
from pidpipe.measurement.regime import motion_regime


def motion_record(motion: BedMotion, first_cycle: int, steps_per_cycle: int,
                  windows_per_cycle: int, rest_height_m) -> dict:
    """The record's ``regime`` and ``motion`` from a run's bed motion.

    Parameters
    ----------
    motion : BedMotion
    first_cycle : int
        The first measured cycle (after the transient the case discards).
    steps_per_cycle : int
    windows_per_cycle : int
        The sampling's windows per cycle (the phase bins of the profile, at most the windows
        that fit in a cycle).
    rest_height_m : array_like, shape (n_cells,)
        Each cell's bed height at rest (highest minus lowest centre), m.

    Returns
    -------
    dict
        ``regime`` (decided from the motion, :func:`pidpipe.measurement.regime.motion_regime`)
        and ``motion``: the windows' length, the phase profile of the mean cell
        (:func:`pidpipe.measurement.phase.phase_profile`), each cell's regime and features.
    """
    bins = min(int(windows_per_cycle), int(steps_per_cycle) // motion.window_steps)
    regime = motion_regime(motion, first_cycle, bins, rest_height_m)
    return {"regime": regime["regime"],
            "motion": {"window_steps": motion.window_steps, "phase_bins": bins,
                       "profile": phase_profile(motion, first_cycle, bins),
                       "cell_regimes": regime["cell_regimes"],
                       "cell_features": regime["cell_features"]}}
