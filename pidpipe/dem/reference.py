"""The NumPy reference of the DEM: the readable, vectorised version the compiled kernel is
checked against (tests/dem/test_kernel.py), not an engine.

Same interface as :mod:`pidpipe.dem.run`'s :func:`~pidpipe.dem.run.start`,
:func:`~pidpipe.dem.run.advance` and :func:`~pidpipe.dem.run.run_cycles`, with the physics of
:mod:`pidpipe.dem.contacts` (forces and energy terms), :mod:`pidpipe.dem.integrator` (velocity
Verlet) and :mod:`pidpipe.dem.energy` (the energies at the cycle boundaries). It is 100-400
times slower than the kernel; nothing outside the tests runs it.
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

from pidpipe.dem.contacts import (
    DISSIPATION_TERMS,
    Workspace,
    accumulated_dissipation,
    reset_accumulators,
)
from pidpipe.dem.energy import centre_of_mass_height, ledger_energy
from pidpipe.dem.integrator import set_up, step
from pidpipe.dem.run import CONTACT_TYPES, cycle_ledgers, prepare
from pidpipe.dem.scene import Scene
from pidpipe.dem.state import State

SOLVER_NAME = "numpy-dem-reference"


def start(scene: Scene, positions_m, velocities_m_s=None, angular_velocities_rad_s=None,
          overlap_tolerance_m: float | None = None) -> tuple[Scene, State, Workspace]:
    """As :func:`pidpipe.dem.run.start`, with the NumPy workspace."""
    scene, state = prepare(scene, positions_m, velocities_m_s, angular_velocities_rad_s,
                           overlap_tolerance_m)
    ws = Workspace(scene, state)
    set_up(scene, state, ws)
    return scene, state, ws


def advance(scene: Scene, state: State, ws: Workspace, n_steps: int,
            observer: Callable[[State, Workspace], None] | None = None,
            walls: str = "viblin") -> None:
    """Take ``n_steps`` steps, calling ``observer(state, ws)`` after each one if given (``walls``:
    as :func:`pidpipe.dem.integrator.step`)."""
    for _ in range(int(n_steps)):
        step(scene, state, ws, walls)
        if observer is not None:
            observer(state, ws)


def run_cycles(scene: Scene, state: State, ws: Workspace, n_cycles: int,
               walls: str = "viblin") -> dict:
    """As :func:`pidpipe.dem.run.run_cycles` (the same keys and shapes); ``walls`` as
    :func:`pidpipe.dem.integrator.step` (``viblin``, the default: where LIGGGHTS' mesh is, as in the kernel)."""
    n_batch = state.n_batch
    work = np.zeros((n_batch, n_cycles))
    gross = np.zeros((n_batch, n_cycles))
    terms = np.zeros((len(DISSIPATION_TERMS), len(CONTACT_TYPES), n_batch, n_cycles))
    harmonics = np.zeros((2, n_batch, n_cycles))
    dt, omega = scene.timestep_s, scene.omega_rad_s
    reference = centre_of_mass_height(state)
    boundary = [ledger_energy(scene, state, ws, reference)]
    heights = [(reference, state.x[2].min(axis=1), state.x[2].max(axis=1))]
    for cycle in range(n_cycles):
        reset_accumulators(ws)
        for _ in range(scene.steps_per_cycle):
            step(scene, state, ws, walls)
            # the spheres' force on the walls at the walls' phase (pidpipe.measurement.harmonics)
            theta = omega * ((state.step + 0.5) * dt)
            harmonics[0, :, cycle] -= ws.wall_force_z * (math.cos(theta) * dt)
            harmonics[1, :, cycle] -= ws.wall_force_z * (math.sin(theta) * dt)
        work[:, cycle] = ws.wall_work_acc
        gross[:, cycle] = ws.gross_wall_work_acc
        terms[..., cycle] = accumulated_dissipation(ws, scene.timestep_s)
        boundary.append(ledger_energy(scene, state, ws, reference))
        heights.append((centre_of_mass_height(state), state.x[2].min(axis=1),
                        state.x[2].max(axis=1)))
    stack = {key: np.stack([b[key] for b in boundary], axis=1) for key in boundary[0]}
    com, lowest, highest = (np.stack(column, axis=1) for column in zip(*heights))
    return cycle_ledgers(work, gross, terms, stack, com, lowest, highest, *harmonics)
