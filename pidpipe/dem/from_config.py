"""The DEM's scene from a validated pidpipe config (the same inputs as the LIGGGHTS deck)."""

from __future__ import annotations

import dataclasses

from pidpipe.cell.packing import cell_from_config
from pidpipe.config import pair_properties, particle_properties, wall_properties
from pidpipe.dem.scene import Material, Scene, make_scene
from pidpipe.measurement.timestep import plan_timestep


def material(props: dict) -> Material:
    """A :class:`Material` from a config material entry (SI keys)."""
    return Material(youngs_modulus_pa=float(props["youngs_modulus_pa"]),
                    poisson_ratio=float(props["poisson_ratio"]),
                    density_kg_m3=float(props.get("density_kg_m3", 0.0)),
                    radius_m=float(props.get("radius_m", 0.0)))


def scene_from_config(config: dict, freq_hz: float, accel_g) -> Scene:
    """The one-cell scene of a case, with the config's materials, pairs and fidelity.

    Parameters
    ----------
    config : dict
        Validated config (:func:`pidpipe.config.load_config`).
    freq_hz : float
        Excitation frequency, Hz.
    accel_g : float or array_like, shape (n_batch,)
        Base acceleration amplitude(s), in g.

    Notes
    -----
    Positions are not part of the scene: pass the packing to :func:`pidpipe.dem.start` or
    :func:`pidpipe.dem.simulate_cell`. With ``fidelity.friction`` false the tangential force is
    left out entirely (the LIGGGHTS decks set mu = 0, which gives the same forces).
    """
    fidelity = config["fidelity"]
    plan = plan_timestep(config, freq_hz)
    particle_name, wall_name = config["particle_material"], config["wall_material"]
    pp = pair_properties(config, particle_name, particle_name)
    pw = pair_properties(config, particle_name, wall_name)
    scene = make_scene(
        cell_from_config(config), material(particle_properties(config)),
        material(wall_properties(config)),
        pp_friction=pp["friction"], pp_restitution=pp["restitution"],
        pw_friction=pw["friction"], pw_restitution=pw["restitution"],
        freq_hz=freq_hz, accel_g=accel_g,
        timestep_rayleigh_fraction=float(fidelity["timestep_rayleigh_fraction"]),
        youngs_modulus_scale=float(fidelity["youngs_modulus_scale"]),
        rotation=bool(fidelity["rotation"]), friction=bool(fidelity["friction"]))
    # the LIGGGHTS path's own timestep rule, so that both solvers step identically
    return dataclasses.replace(scene, timestep_s=plan.timestep_s,
                               steps_per_cycle=plan.steps_per_cycle)
