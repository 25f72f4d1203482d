"""Velocity-Verlet time stepping as LIGGGHTS' ``fix nve/sphere`` (or ``fix nve`` without rotation).

One step, in LIGGGHTS' order:

1. initial_integrate: v += dt/2 F/m; x += dt v; omega += dt/2 T/I
2. the clock advances; the walls move by v_w(t + dt) dt, as LIGGGHTS' ``fix move/mesh viblin``
   moves its mesh in initial_integrate (:func:`pidpipe.dem.walls.viblin_wall_motion`)
3. forces at the new positions with the half-step velocities (pair, walls, gravity); the
   energy terms of the step use the wall's actual displacement over it (v_w dt; with
   ``walls="exact"``, :func:`pidpipe.dem.walls.wall_step_velocity`)
4. final_integrate: v += dt/2 F/m; omega += dt/2 T/I

The walls are where LIGGGHTS' mesh is, as in the compiled kernel (``walls="viblin"``, the
default); ``walls="exact"`` puts them at z_w(t + dt) = W (cos(omega (t + dt)) - 1) with the
contacts seeing v_w(t + dt), the DEM's walls before 2026-12-01, kept to measure what that cost
(``benchmarks/experiments/bench_solver_difference.py``).
"""

from __future__ import annotations

import numpy as np

from pidpipe.dem.contacts import Workspace, clear_step_terms, compute_forces
from pidpipe.dem.scene import Scene
from pidpipe.dem.state import State
from pidpipe.dem.walls import WALL_MOTIONS, viblin_wall_motion, wall_motion, wall_step_velocity


def set_up(scene: Scene, state: State, ws: Workspace) -> None:
    """Evaluate the forces of the initial state (LIGGGHTS' set-up: no history update)."""
    ws.amplitude_m, ws.omega_rad_s = scene.amplitude_m, scene.omega_rad_s
    z, vz = viblin_wall_motion(state.step, scene.timestep_s, ws.amplitude_m, ws.omega_rad_s)
    compute_forces(scene, state, ws, z, vz, update_history=False)
    clear_step_terms(ws)


def step(scene: Scene, state: State, ws: Workspace, walls: str = "viblin") -> None:
    """Advance the batch by one timestep; the step's energy terms are left in ``ws``.

    ``walls`` is one of :data:`pidpipe.dem.walls.WALL_MOTIONS`: ``viblin`` (where LIGGGHTS'
    mesh is; its move over the step is v_w dt; every DEM run) or ``exact`` (z_w(t + dt)).
    """
    if walls not in WALL_MOTIONS:
        raise ValueError(f"walls must be one of {', '.join(WALL_MOTIONS)}, got {walls!r}")
    dt = scene.timestep_s
    kick = ws.kick
    half_over_m = 0.5 * dt / scene.mass_kg
    v, x = state.v, state.x
    kick_force(state.force, half_over_m, v, kick)
    kick_force(v, dt, x, kick)
    if scene.rotation:
        kick_force(state.torque, 0.5 * dt / scene.inertia_kg_m2, state.omega, kick)
    state.step += 1
    if walls == "viblin":
        z, vz = viblin_wall_motion(state.step, dt, ws.amplitude_m, ws.omega_rad_s)
        v_step = vz
    else:
        z, vz = wall_motion(state.step * dt, ws.amplitude_m, ws.omega_rad_s)
        v_step = wall_step_velocity(state.step, dt, ws.amplitude_m, ws.omega_rad_s)
    compute_forces(scene, state, ws, z, vz, wall_step_v_m_s=v_step, update_history=True)
    kick_force(state.force, half_over_m, v, kick)
    if scene.rotation:
        kick_force(state.torque, 0.5 * dt / scene.inertia_kg_m2, state.omega, kick)


def kick_force(rate, factor: float, target, scratch) -> None:
    """``target += factor * rate`` without temporaries (arrays of shape (3, n_batch, n))."""
    np.multiply(rate, factor, out=scratch)
    target += scratch
