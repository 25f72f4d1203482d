"""Elastic energy held in the contacts at the cycle boundaries, from the shake deck's contact dumps.

At a cycle boundary part of the spheres' energy sits in the contacts: compressed Hertz springs
and stretched tangential springs. The balance E_d = W_wall - Delta E must count it in E, or
every cycle whose two ends hold different contact energy is wrong by the difference (it cancels
in a long mean, not cycle by cycle). Per contact (:mod:`pidpipe.physics.contact`):

- normal: ``8/15 E* sqrt(R*) delta^{5/2}``, the work of LIGGGHTS' Hertz force ``k_n delta``;
- tangential: ``1/2 k_t |xi|^2`` with ``k_t = 8 G* sqrt(R* delta)`` and xi the displacement
  stored by ``tangential history`` (already capped by Coulomb's law inside LIGGGHTS).

E*, G* and R* are those LIGGGHTS computes for the two atom types of the deck: particle-particle
(R* = r/2) and particle-wall (the wall's material, a flat wall: R* = r).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pidpipe.cell.scene import CellScene
from pidpipe.errors import ParseError
from pidpipe.liggghts.decks import material_values
from pidpipe.liggghts.parsing import CONTACT_COLUMNS, read_local_frames
from pidpipe.physics.contact import (
    effective_radius,
    effective_shear_modulus,
    effective_youngs_modulus,
    hertz_normal_energy,
    tangential_spring_energy,
)

_SHEAR = slice(CONTACT_COLUMNS.index("shear_x"), CONTACT_COLUMNS.index("shear_z") + 1)
_OVERLAP = CONTACT_COLUMNS.index("overlap")


@dataclass(frozen=True)
class ContactElasticity:
    """The elastic constants of one kind of contact.

    Attributes
    ----------
    youngs_eff_pa : float
        Effective Young's modulus E*, Pa.
    shear_eff_pa : float
        Effective shear modulus G* (LIGGGHTS' definition), Pa.
    radius_eff_m : float
        Effective radius R*, m.
    """

    youngs_eff_pa: float
    shear_eff_pa: float
    radius_eff_m: float


def contact_elasticities(scene: CellScene) -> dict[str, ContactElasticity]:
    """E*, G* and R* of particle-particle and particle-wall contacts, as the deck gives them to LIGGGHTS.

    Taken from :func:`pidpipe.liggghts.decks.material_values`, so the fidelity's Young's modulus scale
    is included exactly as in the deck.

    Returns
    -------
    dict
        ``{"particle_particle": ContactElasticity, "particle_wall": ContactElasticity}``.
    """
    values = material_values(scene)
    youngs, poisson = values["youngs_pa"], values["poisson"]
    radius = 0.5 * values["diameter_m"]
    particle = (youngs["particle"], poisson["particle"])
    wall = (youngs["wall"], poisson["wall"])
    return {
        "particle_particle": ContactElasticity(effective_youngs_modulus(*particle, *particle),
                                               effective_shear_modulus(*particle, *particle),
                                               effective_radius(radius, radius)),
        "particle_wall": ContactElasticity(effective_youngs_modulus(*particle, *wall),
                                           effective_shear_modulus(*particle, *wall),
                                           effective_radius(radius, None)),
    }


def contact_elastic_energies(contacts: np.ndarray, elasticity: ContactElasticity) -> np.ndarray:
    """Elastic energy held in each contact of one kind, J.

    Parameters
    ----------
    contacts : ndarray, shape (n_contacts, len(CONTACT_COLUMNS))
        One frame of a contact dump.
    elasticity : ContactElasticity
        The constants of this kind of contact.

    Returns
    -------
    ndarray, shape (n_contacts,)
        The normal plus the tangential spring energy of each contact, J (a contact reported
        with overlap <= 0 holds none).
    """
    contacts = np.asarray(contacts, dtype=float).reshape(-1, len(CONTACT_COLUMNS))
    overlap = contacts[:, _OVERLAP]
    normal = hertz_normal_energy(elasticity.youngs_eff_pa, elasticity.radius_eff_m, overlap)
    tangential = tangential_spring_energy(elasticity.shear_eff_pa, elasticity.radius_eff_m, overlap,
                                          contacts[:, _SHEAR])
    return normal + tangential


#: Column of the atom id that places a contact in a cell: particle-particle contacts join two
#: spheres of one cell (id_a), particle-wall contacts name the atom third (id_c).
_ATOM_COLUMN = {"particle_particle": CONTACT_COLUMNS.index("id_a"),
                "particle_wall": CONTACT_COLUMNS.index("id_c")}


def boundary_elastic_energy(pair_path: str | Path, wall_path: str | Path, scene: CellScene,
                            expected_steps: np.ndarray, cell_of_atom: np.ndarray) -> np.ndarray:
    """Elastic energy in each cell's contacts at each cycle boundary, from the two contact dumps.

    Parameters
    ----------
    pair_path, wall_path : path
        The particle-particle and particle-wall ``dump local`` files of the shake deck.
    scene : CellScene
        The scene the deck was rendered from.
    expected_steps : ndarray of int, shape (n_boundaries,)
        The steps of the cycle boundaries, from step 0 (those of the energy file).
    cell_of_atom : ndarray of int, shape (n_atoms,)
        The cell of each atom, indexed by atom id - 1
        (:meth:`pidpipe.cell.layout.CellLayout.cell_of_atom`; zeros for one cell).

    Returns
    -------
    ndarray, shape (n_boundaries, n_cells)
        Elastic energy held in each cell's contacts at each boundary, J.

    Raises
    ------
    ParseError
        If a dump is missing, damaged, or its frames are not at the expected steps, or a
        contact names an atom that is not in ``cell_of_atom``.
    """
    expected_steps = np.asarray(expected_steps, dtype=np.int64)
    cell_of_atom = np.asarray(cell_of_atom, dtype=np.int64)
    elasticity = contact_elasticities(scene)
    n_cells = int(cell_of_atom.max()) + 1
    energy = np.zeros((expected_steps.size, n_cells))
    for path, kind in ((pair_path, "particle_particle"), (wall_path, "particle_wall")):
        steps, frames = read_local_frames(path, len(CONTACT_COLUMNS))
        if not np.array_equal(steps, expected_steps):
            raise ParseError(f"{path} has frames at {len(steps)} steps ({steps[0]} .. {steps[-1]}), "
                             f"expected the {expected_steps.size} cycle boundaries "
                             f"({expected_steps[0]} .. {expected_steps[-1]}) (truncated run?)")
        for row, frame in enumerate(frames):
            atom_ids = frame[:, _ATOM_COLUMN[kind]].astype(np.int64)
            if atom_ids.size and (atom_ids.min() < 1 or atom_ids.max() > len(cell_of_atom)):
                raise ParseError(f"{path}: a contact at step {steps[row]} names atom "
                                 f"{atom_ids.max()}, but the run has {len(cell_of_atom)} atoms")
            energy[row] += np.bincount(cell_of_atom[atom_ids - 1], minlength=n_cells,
                                       weights=contact_elastic_energies(frame, elasticity[kind]))
    return energy
