"""The ``fidelity`` block every case record carries, whichever engine made it (or failed to)."""

from __future__ import annotations

from typing import Sequence

from pidpipe.config.settings import ShakeSettings
from pidpipe.physics.timestep import TimestepPlan


def fidelity_record(settings: ShakeSettings, plan: TimestepPlan, transient_cycles: int,
                    seeds: Sequence[int], engine: str, configured_transient: int | None = None,
                    pile_height_m: float | None = None, pour_engine: str | None = None) -> dict:
    """The settings a run was made with, as its record's ``fidelity``.

    Parameters
    ----------
    settings : ShakeSettings
    plan : TimestepPlan
        The run's timestep.
    transient_cycles : int
        Cycles discarded before the measured window (the configured floor or the detected one).
    seeds : sequence of int
        The seeds of the run's packings, one per cell.
    engine : str
        ``liggghts`` or ``dem``.
    configured_transient, pile_height_m : optional
        The configured transient (cycles) and the first packing's pile height (m), for a run
        that was made; left out of a failed case's record.
    pour_engine : str, optional
        The engine that poured the run's packings (:func:`pidpipe.cell.packing.pour_engines`).
    """
    fidelity, sampling = settings.fidelity, settings.sampling
    seeds = [int(seed) for seed in seeds]
    record = {
        **plan.as_record(),
        "timestep_rayleigh_fraction_config": fidelity.timestep_rayleigh_fraction,
        "youngs_modulus_scale": fidelity.youngs_modulus_scale,
        "transient_cycles": transient_cycles,
    }
    if configured_transient is not None:
        record["transient_cycles_configured"] = configured_transient
    record.update(measured_cycles=sampling.measured_cycles,
                  sem_block_cycles=sampling.sem_block_cycles, rotation=fidelity.rotation,
                  friction=fidelity.friction, cells_per_run=len(seeds), seed=seeds[0], seeds=seeds)
    if pile_height_m is not None:
        record["pile_height_m"] = pile_height_m
    if pour_engine is not None:
        record["pour_engine"] = pour_engine
    record["engine"] = engine
    return record
