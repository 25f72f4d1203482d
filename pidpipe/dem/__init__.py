"""An independent NumPy DEM of one shaken honeycomb cell, to validate the LIGGGHTS results.

It integrates exactly the scene the LIGGGHTS decks describe (Hertz normal contact with
restitution damping, history tangential contact capped by Coulomb friction, the eight planes of
the cell moving as z_w = W (cos(omega t) - 1), gravity, velocity Verlet), vectorised over all
contacts and over a batch of independent cells, and keeps two independent ledgers of the
dissipated energy: term by term at the contacts, and the energy balance.

Modules: :mod:`.scene` (materials, contact laws, timestep), :mod:`.walls` (wall motion),
:mod:`.state` (the state arrays), :mod:`.contacts` (the force kernel and energy terms),
:mod:`.integrator` (velocity Verlet), :mod:`.energy` (energies and the balance),
:mod:`.run` (cycles and the case record), :mod:`.from_scene` (its scene from the shared
:class:`pidpipe.cell.scene.CellScene`).
"""

from pidpipe.dem.contacts import DISSIPATION_TERMS, Workspace, compute_forces
from pidpipe.dem.energy import (
                             elastic_energy,
                             kinetic_energy,
                             ledger_energy,
                             total_energy,
)
from pidpipe.dem.integrator import set_up, step
from pidpipe.dem.run import (
                             CONTACT_TYPES,
                             SOLVER_NAME,
                             advance,
                             run_cycles,
                             simulate_cell,
                             start,
)
from pidpipe.dem.scene import ContactLaw, Material, Scene, choose_timestep, make_scene
from pidpipe.dem.state import State, initial_state

__all__ = [
    "CONTACT_TYPES", "DISSIPATION_TERMS", "SOLVER_NAME", "ContactLaw", "Material", "Scene",
    "State", "Workspace", "advance", "choose_timestep", "compute_forces", "elastic_energy",
    "initial_state", "kinetic_energy", "ledger_energy", "make_scene", "run_cycles", "set_up",
    "simulate_cell", "start", "step", "total_energy",
]
