"""The timestep of a run: a fraction of the particles' Rayleigh time, a whole number of steps a cycle.

The timestep is the configured fraction of the particles' Rayleigh time, shortened so that a
cycle of the base motion is a whole number of steps (cycle boundaries then fall on steps).
Softening scales every Young's modulus, which lengthens the Rayleigh time and so the timestep.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

HERTZ_FRACTION_LIMIT = 0.1
"""Largest dt / Hertz contact time at the fastest impact (LIGGGHTS' conservative estimate in
``fix check/timestep/gran``): at least 10 steps per collision."""

TIMESTEP_CHECKS_PER_CYCLE = 20
"""How often per cycle LIGGGHTS checks the timestep against the fastest sphere."""


@dataclass(frozen=True)
class TimestepPlan:
    """Timestep of one case.

    Attributes
    ----------
    timestep_s : float
        dt = period / steps_per_cycle, s.
    steps_per_cycle : int
    rayleigh_time_s : float
        Rayleigh time of the (softened) particles, s.
    rayleigh_fraction : float
        dt / Rayleigh time actually used (<= the configured fraction).
    """

    timestep_s: float
    steps_per_cycle: int
    rayleigh_time_s: float
    rayleigh_fraction: float

    def as_record(self) -> dict:
        return asdict(self)


def plan_timestep(rayleigh_time_s: float, rayleigh_fraction: float, freq_hz: float) -> TimestepPlan:
    """Timestep for excitation at ``freq_hz``: at most ``rayleigh_fraction`` Rayleigh times.

    Parameters
    ----------
    rayleigh_time_s : float
        Rayleigh time of the (softened) particles, s.
    rayleigh_fraction : float
        Largest dt / Rayleigh time.
    freq_hz : float
        Excitation frequency, Hz; a cycle is a whole number of steps.
    """
    target = rayleigh_fraction * rayleigh_time_s
    period = 1.0 / freq_hz
    steps = max(1, math.ceil(period / target - 1e-9))
    dt = period / steps
    return TimestepPlan(dt, steps, rayleigh_time_s, dt / rayleigh_time_s)
