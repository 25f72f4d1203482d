"""An independent DEM of shaken honeycomb cells, compiled with Numba: a second engine next to
LIGGGHTS, and its check.

It integrates exactly the scene the LIGGGHTS decks describe (Hertz normal contact with
restitution damping, history tangential contact capped by Coulomb friction, the eight planes of
the cell moving as z_w = W (cos(omega t) - 1), gravity, velocity Verlet) for a batch of
independent cells, and keeps two independent ledgers of the dissipated energy: term by term at
the contacts, and the energy balance. The time loop is the compiled kernel
(:mod:`.kernel`, driven by :mod:`.compiled`); the vectorised NumPy modules below are its
readable reference (:mod:`.reference`), which the tests compare it with.

Modules: :mod:`.scene` (materials, contact laws, timestep), :mod:`.walls` (wall motion),
:mod:`.state` (the state arrays), :mod:`.kernel` and :mod:`.compiled` (the compiled loop),
:mod:`.run` (cycles and the case record, on the kernel), :mod:`.coupled` and :mod:`.host_drive`
(the cells riding on a vibrating host, fed back to it: the host-coupled check of
:mod:`pidpipe.loop`), :mod:`.from_scene` (its scene from the
shared :class:`pidpipe.cell.scene.CellScene`); the reference: :mod:`.contacts` (forces and energy
terms), :mod:`.integrator` (velocity Verlet), :mod:`.energy` (energies and the balance, used by both), :mod:`.reference`.
"""

from pidpipe.dem.compiled import KernelError, KernelWorkspace
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
    "CONTACT_TYPES", "DISSIPATION_TERMS", "SOLVER_NAME", "ContactLaw", "KernelError",
    "KernelWorkspace", "Material", "Scene",
    "State", "Workspace", "advance", "choose_timestep", "compute_forces", "elastic_energy",
    "initial_state", "kinetic_energy", "ledger_energy", "make_scene", "run_cycles", "set_up",
    "simulate_cell", "start", "step", "total_energy",
]
