"""The part of a validated config that each stage's results depend on (a rule's ``params``).

A rule passes its stage's part as a parameter, so that Snakemake reruns it when (and only when)
one of these values changes: an edit elsewhere in the config reruns nothing.
"""

from __future__ import annotations

#: ``fidelity`` keys of the pours: the case stage reads them too, to pour the further packings
#: that a case's target SEM asks for.
POURING_KEYS: tuple[str, ...] = ("settle_time_s", "seed", "pour_engine")

#: Config keys each stage depends on: top-level key -> list of sub-keys (None: all of it).
#: ``materials`` and ``pairs`` are cut down to the particle and wall materials.
_STAGE_KEYS: dict[str, dict[str, list[str] | None]] = {
    "packing": {
        "geometry": ["cell_inscribed_diameter_m", "core_height_m"],
        "fill": None,
        "fidelity": ["timestep_rayleigh_fraction", "youngs_modulus_scale", "settle_time_s", "seed",
                     "rotation", "friction"],
    },
    "case": {
        "geometry": ["cell_inscribed_diameter_m", "core_height_m", "coupon_n_cells"],
        # fill, settle_time_s and seed: a case pours the further packings its target needs
        "fill": None,
        "fidelity": ["timestep_rayleigh_fraction", "youngs_modulus_scale", "transient_cycles",
                     "transient_min_time_s", "measured_cycles", "sem_block_cycles", "rotation", "friction",
                     "target_relative_sem", "max_measured_cycles", "cells_per_run",
                     "max_cells_per_case", "max_case_cpu_s", "settle_time_s", "seed"],
        "inspection": ["phase_windows_per_cycle", "phase_sample_every_steps"],
    },
}


def sorted_keys(value):
    """A copy with dict keys sorted at every level, so that its repr is stable."""
    if isinstance(value, dict):
        return {k: sorted_keys(value[k]) for k in sorted(value)}
    if isinstance(value, (list, tuple)):
        return [sorted_keys(v) for v in value]
    return value


def stage_config(config: dict, stage: str) -> dict:
    """The part of a validated config that a stage's results depend on.

    A rule passes this as its parameter, so that Snakemake reruns it when (and only when) one
    of these values changes. The result is still a config (same layout) that the stage's
    functions accept; a key they read that is not listed here raises KeyError, so the list
    cannot silently fall behind the code.

    Parameters
    ----------
    config : dict
        Validated config.
    stage : {"packing", "case"}

    Returns
    -------
    dict
        Keys sorted at every level.
    """
    keys = _STAGE_KEYS[stage]
    particle, wall = config["particle_material"], config["wall_material"]
    used = {particle, wall}
    part = {
        "particle_material": particle,
        "wall_material": wall,
        "materials": {name: config["materials"][name] for name in used},
        "pairs": [p for p in config["pairs"] if set(p["materials"]) <= used],
    }
    for top, subkeys in keys.items():
        section = config[top]
        part[top] = dict(section) if subkeys is None else {k: section[k] for k in subkeys}
    if stage == "case":
        # the solver, named only when it is not LIGGGHTS: records of a LIGGGHTS campaign keep
        # the params they were made with, and a switch of engine reruns every case
        engine = config.get("engine", "liggghts")
        if engine != "liggghts":
            part["engine"] = engine
    # the pour engine, likewise: both stages pour (a case its further packings); a switch
    # re-pours every packing and reruns every case
    pour_engine = config["fidelity"].get("pour_engine", "liggghts")
    if pour_engine != "liggghts":
        part["fidelity"]["pour_engine"] = pour_engine
    return sorted_keys(part)
