"""The cell walls: eight planes moving rigidly with the base, as LIGGGHTS' ``viblin`` moves them.

``fix move/mesh ... viblin axis 0 0 1 order 1 amplitude W phase 0 period T`` places the mesh,
at the start of every step, at z_w(t) = W (cos(omega t) - 1) with velocity
v_w(t) = -W omega sin(omega t), t being the time at the end of the step (LIGGGHTS moves the mesh
in ``initial_integrate``, after the clock has advanced). The wall does not rotate, so a wall
contact's normal is the plane's inward normal throughout.

The velocity v_w(t_n) is what the contact forces of step n see (LIGGGHTS' mesh velocity). The
wall's displacement over step n is z_w(t_n) - z_w(t_{n-1}), and its mean velocity over the
step, :func:`wall_step_velocity`, is v_w at the middle of the step (times
sin(omega dt/2)/(omega dt/2)): using v_w(t_n) instead for the work of the walls is half a
step late, an error of (dt/2) * integral(F a_w dt) per cycle.
"""

from __future__ import annotations

import math

import numpy as np

from pidpipe.cell.geometry import HexCell


def wall_motion(time_s: float, amplitude_m: np.ndarray, omega_rad_s: float
                ) -> tuple[np.ndarray, np.ndarray]:
    """Wall displacement and velocity along z at time t.

    Parameters
    ----------
    time_s : float
        Time since the motion started, s.
    amplitude_m : ndarray, shape (n_batch,)
        Displacement amplitude W of each cell, m.
    omega_rad_s : float
        Angular frequency, rad/s.

    Returns
    -------
    z_m, v_m_s : ndarray, shape (n_batch,)
        z_w = W (cos(omega t) - 1) in m and v_w = -W omega sin(omega t) in m/s.
    """
    phase = omega_rad_s * time_s
    return (amplitude_m * (math.cos(phase) - 1.0),
            amplitude_m * (-omega_rad_s * math.sin(phase)))


def wall_step_velocity(step: int, timestep_s: float, amplitude_m: np.ndarray,
                       omega_rad_s: float) -> np.ndarray:
    """Mean wall velocity over step n, (z_w(t_n) - z_w(t_{n-1})) / dt, along z.

    Written as -2 W sin(omega t_{n-1/2}) sin(omega dt/2) / dt, which is exact and keeps its
    precision when the displacement of one step is tiny against W.

    Parameters
    ----------
    step : int
        The step n that ends at t_n = n dt.
    timestep_s : float
        dt, s.
    amplitude_m : ndarray, shape (n_batch,)
        Displacement amplitude W of each cell, m.
    omega_rad_s : float
        Angular frequency, rad/s.

    Returns
    -------
    ndarray, shape (n_batch,)
        The wall's displacement over the step divided by dt, m/s.
    """
    mid_phase = omega_rad_s * (step - 0.5) * timestep_s
    half_step_phase = 0.5 * omega_rad_s * timestep_s
    return amplitude_m * (-2.0 * math.sin(mid_phase) * math.sin(half_step_phase) / timestep_s)


def wall_planes(cell: HexCell) -> tuple[np.ndarray, np.ndarray]:
    """Inward unit normals (8, 3) and offsets (8,) in m of the cell at rest (z_w = 0).

    The distance of a point x from plane k when the cell is displaced by z_w along z is
    ``normals[k] @ x + offsets[k] - normals[k, 2] * z_w``.
    """
    normals, offsets = cell.planes()
    return np.ascontiguousarray(normals, dtype=float), np.ascontiguousarray(offsets, dtype=float)
