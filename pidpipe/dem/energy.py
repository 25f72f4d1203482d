"""Energies of the spheres and the contacts, for the per-cycle energy balance.

The balance over a cycle (steps a+1 .. b) is

    W_wall = Delta(K^ + P + U) + D,

with W_wall the work of the moving walls on the spheres, P = m g z, U the elastic energy stored
in the contacts (2/5 k_n delta^2 normal, 1/2 k_t |s|^2 tangential) and D the dissipated
energy. Velocity Verlet moves a sphere over step n by dt v_{n-1/2} under the mean force
(F_{n-1} + F_n)/2, and then

    1/2 m v_b^2 - 1/2 m v_a^2 = sum_n (F_{n-1} + F_n)/2 . dt v_{n-1/2}
                                + dt^2 (|F_b|^2 - |F_a|^2) / (8 m)

exactly (F the total force with gravity; the same for rotation with T and I). So the kinetic
energy in the balance is K^ = 1/2 m v^2 - dt^2 |F|^2 / (8 m) - dt^2 |T|^2 / (8 I), the wall
work and the contact terms are accumulated with the same step-mean forces
(:mod:`pidpipe.dem.contacts`), and the two ledgers differ only by the O(dt^2) error of the
elastic contact energies; plain kinetic energy would leave an error of order dt^2 F^2/m at
each cycle boundary, which an impact in progress makes visible.
"""

from __future__ import annotations

import numpy as np

from pidpipe.dem.contacts import Workspace
from pidpipe.dem.scene import Scene
from pidpipe.dem.state import State


def kinetic_energy(scene: Scene, state: State) -> tuple[np.ndarray, np.ndarray]:
    """Translational and rotational kinetic energy of each cell; shapes (n_batch,), J."""
    trans = 0.5 * scene.mass_kg * np.einsum("cbn,cbn->b", state.v, state.v)
    rot = 0.5 * scene.inertia_kg_m2 * np.einsum("cbn,cbn->b", state.omega, state.omega)
    return trans, rot


def potential_energy(scene: Scene, state: State) -> np.ndarray:
    """Gravitational energy m g sum(z) of each cell (z in the lab frame); shape (n_batch,), J."""
    return scene.mass_kg * scene.gravity_m_s2 * state.x[2].sum(axis=1)


def elastic_energy(state: State, ws: Workspace) -> np.ndarray:
    """Elastic energy stored in all contacts at the last force evaluation; (n_batch,), J.

    Normal: 2/5 k_n delta^2 (the potential of F = k_n delta = 4/3 E* sqrt(R*) delta^1.5);
    tangential: 1/2 k_t |s|^2. Sphere pairs appear twice in the dense arrays and count half.
    """
    n = ws.n
    per_contact = 0.4 * ws.kn * ws.delta**2 + state.tangential_energy
    return 0.5 * per_contact[..., :n].sum(axis=(1, 2)) + per_contact[..., n:].sum(axis=(1, 2))


def total_energy(scene: Scene, state: State, ws: Workspace) -> np.ndarray:
    """Plain mechanical energy K + P + U of each cell; shape (n_batch,), J."""
    trans, rot = kinetic_energy(scene, state)
    return trans + rot + potential_energy(scene, state) + elastic_energy(state, ws)


def ledger_energy(scene: Scene, state: State, ws: Workspace) -> dict[str, np.ndarray]:
    """Energies at a cycle boundary, each of shape (n_batch,), J.

    Returns
    -------
    dict
        ``kinetic_translational``, ``kinetic_rotational``, ``potential``, ``elastic`` (plain
        values) and ``ledger`` = K^ + P + U, the total whose change closes the
        balance (see the module docstring).
    """
    dt = scene.timestep_s
    trans, rot = kinetic_energy(scene, state)
    pot = potential_energy(scene, state)
    elastic = elastic_energy(state, ws)
    shift = -dt**2 / (8.0 * scene.mass_kg) * np.einsum("cbn,cbn->b", state.force, state.force)
    if scene.rotation:
        shift -= dt**2 / (8.0 * scene.inertia_kg_m2) * np.einsum("cbn,cbn->b", state.torque,
                                                                 state.torque)
    return dict(kinetic_translational=trans, kinetic_rotational=rot, potential=pot,
                elastic=elastic, ledger=trans + rot + shift + pot + elastic)
