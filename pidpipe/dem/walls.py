"""The cell walls: eight planes moving rigidly with the base, as LIGGGHTS' ``viblin`` moves them.

``fix move/mesh ... viblin axis 0 0 1 order 1 amplitude W phase 0 period T`` gives the mesh,
in step n, the velocity v_w(t_n) = -W omega sin(omega t_n), t_n being the time at the end of
the step (LIGGGHTS moves the mesh in ``initial_integrate``, after the clock has advanced). The
wall does not rotate, so a wall contact's normal is the plane's inward normal throughout.

Where the mesh is: LIGGGHTS 3.8 (``MeshMoverVibLin::initial_integrate``) moves it by
v_w(t_n) dt in step n, so after step n it is at dt * sum_{k<=n} v_w(t_k)
(:func:`viblin_wall_motion`): the exact motion half a step ahead, W (cos(omega t_{n+1/2}) - 1),
to within W (omega dt)^2 / 8. The DEM (the compiled kernel, and the NumPy reference by
default) puts its walls there too, and its contacts see v_w(t_n), which is then the walls' own
move over the step. Until 2026-12-01 the DEM placed them at z_w(t_n) = W (cos(omega t_n) - 1)
(:func:`wall_motion`, ``walls="exact"`` in :func:`pidpipe.dem.integrator.step`), half a step
behind LIGGGHTS' mesh while the contacts saw the same v_w(t_n): the wall moved by u_w dt
(:func:`wall_step_velocity`) in a step in which the contacts integrated v_w(t_n) dt. That
half step made the DEM dissipate 0.1-0.3 % less than LIGGGHTS at 1 g
(``benchmarks/experiments/bench_solver_difference.py``, docs/explanation/validation.md, "Why the DEM once dissipated less at 1 g").

With the exact walls, the wall's displacement over step n is z_w(t_n) - z_w(t_{n-1}), and its
mean velocity over the step, :func:`wall_step_velocity`, is v_w at the middle of the step
(times sin(omega dt/2)/(omega dt/2)): using v_w(t_n) instead for the work of the walls would be
half a step late, an error of (dt/2) * integral(F a_w dt) per cycle. With LIGGGHTS' walls the
move over step n is v_w(t_n) dt itself.
"""

from __future__ import annotations

import math

import numpy as np

from pidpipe.cell.geometry import HexCell

WALL_MOTIONS = ("exact", "viblin")
"""How the DEM's walls move: ``viblin``, where LIGGGHTS' mesh is (:func:`viblin_wall_motion`,
every DEM run), or ``exact``, z_w(t_n) (:func:`wall_motion`, the DEM's walls before 2026-12-01)."""


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


def viblin_wall_motion(step: int, timestep_s: float, amplitude_m: np.ndarray,
                       omega_rad_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Wall displacement and velocity along z after step n, as LIGGGHTS' viblin moves its mesh.

    The mesh moves by v_w(t_k) dt in every step k, so after step n it is at
    ``dt * sum_{k=1..n} v_w(t_k) = -W omega dt (cos(theta/2) - cos((n + 1/2) theta)) / (2 sin(theta/2))``
    with theta = omega dt (the sum in closed form), and its velocity is v_w(t_n).

    Parameters
    ----------
    step, timestep_s, amplitude_m, omega_rad_s
        As :func:`wall_step_velocity` (step 0 is the start, at rest).

    Returns
    -------
    z_m, v_m_s : ndarray, shape (n_batch,)
        The mesh's displacement (m) and velocity (m/s); its move over step n is v_m_s * dt.
    """
    # the compiled kernel's operations in its order (pidpipe.dem.kernel._viblin_unit_z), so that
    # the reference and the kernel round alike
    theta = omega_rad_s * timestep_s
    half = 0.5 * theta
    unit_z = -theta * (math.cos(half) - math.cos((step + 0.5) * theta)) / (2.0 * math.sin(half))
    return amplitude_m * unit_z, amplitude_m * (-omega_rad_s * math.sin(omega_rad_s * (step * timestep_s)))


def wall_planes(cell: HexCell) -> tuple[np.ndarray, np.ndarray]:
    """Inward unit normals (8, 3) and offsets (8,) in m of the cell at rest (z_w = 0).

    The distance of a point x from plane k when the cell is displaced by z_w along z is
    ``normals[k] @ x + offsets[k] - normals[k, 2] * z_w``.
    """
    normals, offsets = cell.planes()
    return np.ascontiguousarray(normals, dtype=float), np.ascontiguousarray(offsets, dtype=float)
