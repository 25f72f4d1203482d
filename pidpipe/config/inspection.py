"""Typed settings of the inspection of a case: its motion within the cycle, its movie, its figures.

The config's ``inspection`` section (``workflow/schemas/config.schema.yaml``) becomes
:class:`MotionSampling` (how finely every shake run samples the bed's motion, from which the
regime is read) and :class:`MovieSettings` (the VTK movie of chosen cases).
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class MotionSampling:
    """How finely a shake run samples the bed's motion.

    Attributes
    ----------
    windows_per_cycle : int
        Windows a cycle is split into (about: a window is a whole number of samples).
    sample_every_steps : int
        The window means of the forces and the power sample every this many steps (evaluating
        them every step tripled LIGGGHTS' cost of 7 cells: ``benchmarks/experiments/bench_inspection.py``).
    """

    windows_per_cycle: int
    sample_every_steps: int = 10

    def window_steps(self, steps_per_cycle: int) -> int:
        """Steps per window: ``steps_per_cycle // windows_per_cycle`` rounded down to whole
        samples, at least one sample."""
        every = int(self.sample_every_steps)
        return every * max(1, int(steps_per_cycle) // int(self.windows_per_cycle) // every)


@dataclass(frozen=True)
class MovieSettings:
    """What a movie shows.

    Attributes
    ----------
    frames_per_cycle : int
        Frames per cycle of the base motion (rounded to whole steps).
    cycles : int
        How many of the run's last cycles the movie covers.
    """

    frames_per_cycle: int
    cycles: int


def motion_sampling(config: dict) -> MotionSampling | None:
    """The motion sampling of a validated config; None when ``phase_windows_per_cycle`` is 0."""
    windows = int(config["inspection"]["phase_windows_per_cycle"])
    every = int(config["inspection"]["phase_sample_every_steps"])
    return MotionSampling(windows, every) if windows > 0 else None


def movie_settings(config: dict) -> MovieSettings:
    """The movie settings of a validated config (for the cases that make one)."""
    section = config["inspection"]
    return MovieSettings(int(section["movie_frames_per_cycle"]), int(section["movie_cycles"]))
