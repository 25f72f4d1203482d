"""Energies of the spheres and the contacts, for the per-cycle energy balance.

The balance over a cycle (steps a+1 .. b) is

    W_wall = Delta(K^ + P + U) + D,

with W_wall the work of the moving walls on the spheres, P = m g (z - z_0) (z_0 the centre of
mass at the start, as the LIGGGHTS path measures it), U the elastic energy stored in the
contacts (Hertz 8/15 E* sqrt(R*) delta^{5/2} normal, 1/2 k_t |s|^2 tangential, from
:mod:`pidpipe.physics.contact`, the functions the LIGGGHTS path's ledger uses) and D the dissipated
energy. Velocity Verlet moves a sphere over step n by dt v_{n-1/2} under the mean force
(F_{n-1} + F_n)/2, and then

    1/2 m v_b^2 - 1/2 m v_a^2 = sum_n (F_{n-1} + F_n)/2 . dt v_{n-1/2}
                                + dt^2 (|F_b|^2 - |F_a|^2) / (8 m)

exactly (F the total force with gravity; the same for rotation with T and I). So the kinetic
energy in the balance is K^ = 1/2 m v^2 - dt^2 |F|^2 / (8 m) - dt^2 |T|^2 / (8 I), the wall
work and the contact terms are accumulated with the same step-mean forces
(:mod:`pidpipe.dem.contacts`; the walls' work over the displacement they actually made in each
step), and the two ledgers differ only by the O(dt^2) error of the elastic contact energies; plain kinetic energy would leave an error of order dt^2 F^2/m at
each cycle boundary, which an impact in progress makes visible.
"""

from __future__ import annotations

import numpy as np

from pidpipe.dem.contacts import Workspace
from pidpipe.dem.scene import ContactLaw, Scene
from pidpipe.dem.state import State
from pidpipe.physics import contact


def kinetic_energy(scene: Scene, state: State) -> tuple[np.ndarray, np.ndarray]:
    """Translational and rotational kinetic energy of each cell; shapes (n_batch,), J."""
    trans = 0.5 * scene.mass_kg * np.einsum("cbn,cbn->b", state.v, state.v)
    rot = 0.5 * scene.inertia_kg_m2 * np.einsum("cbn,cbn->b", state.omega, state.omega)
    return trans, rot


def centre_of_mass_height(state: State) -> np.ndarray:
    """Mean z of the spheres of each cell (lab frame); shape (n_batch,), m."""
    return state.x[2].mean(axis=1)


def potential_energy(scene: Scene, state: State,
                     reference_height_m: np.ndarray | float = 0.0) -> np.ndarray:
    """Gravitational energy of each cell, m g sum(z - z_ref); shape (n_batch,), J.

    Parameters
    ----------
    scene : Scene
    state : State
    reference_height_m : float or ndarray, shape (n_batch,)
        Height z_ref (lab frame) at which a sphere's potential energy is zero, m.
    """
    reference = np.broadcast_to(np.asarray(reference_height_m, dtype=float), (state.n_batch,))
    heights = state.x[2].sum(axis=1) - state.n_spheres * reference
    return scene.mass_kg * scene.gravity_m_s2 * heights


def contact_type_energy(law: ContactLaw, overlap_m: np.ndarray,
                        displacement_m: np.ndarray) -> np.ndarray:
    """Elastic energy held in contacts of one type, per cell; shape (n_batch,), J.

    Parameters
    ----------
    law : ContactLaw
        The contact type's law (its E*, G* and R*).
    overlap_m : ndarray, shape (n_batch, n, k)
        Overlaps delta (0 where not in contact), m.
    displacement_m : ndarray, shape (3, n_batch, n, k)
        Tangential history xi, m.

    Returns
    -------
    ndarray, shape (n_batch,)
        Hertz normal energy (:func:`pidpipe.physics.contact.hertz_normal_energy`) plus tangential
        spring energy (:func:`pidpipe.physics.contact.tangential_spring_energy`) summed over the
        contacts, J.
    """
    normal = contact.hertz_normal_energy(law.youngs_eff_pa, law.radius_eff_m, overlap_m)
    tangential = contact.tangential_spring_energy(law.shear_eff_pa, law.radius_eff_m, overlap_m,
                                                  np.moveaxis(displacement_m, 0, -1))
    return (normal + tangential).sum(axis=(1, 2))


def elastic_energy(scene: Scene, state: State, ws: Workspace) -> np.ndarray:
    """Elastic energy stored in all contacts at the last force evaluation; (n_batch,), J.

    Normal 8/15 E* sqrt(R*) delta^{5/2} and tangential 1/2 k_t |xi|^2 per contact
    (:func:`contact_type_energy`). Sphere pairs appear twice in the dense arrays and count half.
    """
    n = ws.n
    pairs = contact_type_energy(scene.pp, ws.delta[..., :n], state.shear[..., :n])
    walls = contact_type_energy(scene.pw, ws.delta[..., n:], state.shear[..., n:])
    return 0.5 * pairs + walls


def total_energy(scene: Scene, state: State, ws: Workspace) -> np.ndarray:
    """Plain mechanical energy K + P + U of each cell (P from z = 0); shape (n_batch,), J."""
    trans, rot = kinetic_energy(scene, state)
    return trans + rot + potential_energy(scene, state) + elastic_energy(scene, state, ws)


def ledger_energy(scene: Scene, state: State, ws: Workspace,
                  reference_height_m: np.ndarray | float = 0.0) -> dict[str, np.ndarray]:
    """Energies at a cycle boundary, each of shape (n_batch,), J.

    Parameters
    ----------
    scene : Scene
    state : State
    ws : Workspace
    reference_height_m : float or ndarray, shape (n_batch,)
        Zero of the potential energy (:func:`potential_energy`), m.

    Returns
    -------
    dict
        ``kinetic_translational``, ``kinetic_rotational``, ``potential``, ``elastic`` (plain
        values) and ``ledger`` = K^ + P + U, the total whose change closes the
        balance (see the module docstring).
    """
    dt = scene.timestep_s
    trans, rot = kinetic_energy(scene, state)
    pot = potential_energy(scene, state, reference_height_m)
    elastic = elastic_energy(scene, state, ws)
    shift = -dt**2 / (8.0 * scene.mass_kg) * np.einsum("cbn,cbn->b", state.force, state.force)
    if scene.rotation:
        shift -= dt**2 / (8.0 * scene.inertia_kg_m2) * np.einsum("cbn,cbn->b", state.torque,
                                                                 state.torque)
    return dict(kinetic_translational=trans, kinetic_rotational=rot, potential=pot,
                elastic=elastic, ledger=trans + rot + shift + pot + elastic)
