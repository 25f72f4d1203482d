"""The fidelity settings of a run: timestep, stiffness softening, cycles.

The timestep is the configured fraction of the particles' Rayleigh time, shortened so that a
cycle of the base motion is a whole number of steps (cycle boundaries then fall on steps).
Softening scales every Young's modulus, which lengthens the Rayleigh time and so the timestep.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

from pidpipe.config import particle_properties
from pidpipe.physics.contact import rayleigh_time

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


def particle_rayleigh_time(config: dict) -> float:
    """Rayleigh time of the configured particles with the configured softening, s."""
    particle = particle_properties(config)
    scale = config["fidelity"]["youngs_modulus_scale"]
    return rayleigh_time(particle["radius_m"], particle["density_kg_m3"],
                         particle["youngs_modulus_pa"] * scale, particle["poisson_ratio"])


def transient_cycles_for(config: dict, freq_hz: float) -> int:
    """Cycles discarded before measuring at ``freq_hz``: the configured count, or more to last
    at least ``fidelity.transient_min_time_s``."""
    fidelity = config["fidelity"]
    by_time = math.ceil(fidelity["transient_min_time_s"] * freq_hz - 1e-9)
    return max(int(fidelity["transient_cycles"]), by_time)


def plan_timestep(config: dict, freq_hz: float) -> TimestepPlan:
    """Timestep for excitation at ``freq_hz`` (Hz) under the config's fidelity settings."""
    t_rayleigh = particle_rayleigh_time(config)
    target = config["fidelity"]["timestep_rayleigh_fraction"] * t_rayleigh
    period = 1.0 / freq_hz
    steps = max(1, math.ceil(period / target - 1e-9))
    dt = period / steps
    return TimestepPlan(dt, steps, t_rayleigh, dt / t_rayleigh)
