"""The DEM's scene from the one description both solvers share (:class:`pidpipe.cell.scene.CellScene`)."""

from __future__ import annotations

import dataclasses

from pidpipe.cell.scene import CellScene
from pidpipe.dem.scene import Scene, make_scene


def dem_scene(scene: CellScene, freq_hz: float, accel_g) -> Scene:
    """The DEM scene of a case: the shared scene's cell, materials, pairs and fidelity.

    Parameters
    ----------
    scene : CellScene
        The cell, its materials (unscaled: :func:`make_scene` applies the fidelity's Young's
        modulus scale) and the fidelity.
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
    materials, fidelity = scene.materials, scene.fidelity
    pp, pw = materials.particle_particle, materials.particle_wall
    plan = scene.timestep(freq_hz)
    dem = make_scene(
        scene.cell, materials.particle, materials.wall,
        pp_friction=pp.friction, pp_restitution=pp.restitution,
        pw_friction=pw.friction, pw_restitution=pw.restitution,
        freq_hz=freq_hz, accel_g=accel_g,
        timestep_rayleigh_fraction=fidelity.timestep_rayleigh_fraction,
        youngs_modulus_scale=fidelity.youngs_modulus_scale,
        rotation=fidelity.rotation, friction=fidelity.friction)
    # the LIGGGHTS path's own timestep rule, so that both solvers step identically
    return dataclasses.replace(dem, timestep_s=plan.timestep_s,
                               steps_per_cycle=plan.steps_per_cycle)
