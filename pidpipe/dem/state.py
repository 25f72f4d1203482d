"""The dynamic state of a batch of cells: sphere kinematics, forces and contact history.

Arrays are component-first so that dot and cross products are sums over the first axis:

- ``x``, ``v``, ``omega``, ``force``, ``torque``: shape (3, n_batch, n_spheres)
- contact arrays have a column per possible partner, ``n_cols = n_spheres + 8``: the other
  spheres (columns ``0 .. n-1``, the diagonal never in contact) then the eight cell walls.
  ``shear`` (3, n_batch, n_spheres, n_cols) is LIGGGHTS' tangential history (the accumulated
  tangential displacement, m); ``tangential_energy`` (n_batch, n_spheres, n_cols) the elastic
  energy 1/2 k_t |shear|^2 stored in it at the last force evaluation, J.

A sphere-sphere contact appears twice (i, j) and (j, i) with opposite vectors; both copies are
updated identically, so the dense layout needs no scatter.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

N_WALLS = 8


@dataclass
class State:
    """Positions, velocities, forces and contact history at one step.

    Attributes
    ----------
    x : ndarray, shape (3, n_batch, n)
        Sphere centres in the lab frame (cell frame at rest), m.
    v : ndarray, shape (3, n_batch, n)
        Velocities, m/s (full-step values between steps).
    omega : ndarray, shape (3, n_batch, n)
        Angular velocities, rad/s.
    force, torque : ndarray, shape (3, n_batch, n)
        Total force (contacts and gravity), N, and contact torque, N m, at the current positions.
    shear : ndarray, shape (3, n_batch, n, n + 8)
        Tangential history per contact, m.
    tangential_energy : ndarray, shape (n_batch, n, n + 8)
        Elastic energy stored in the tangential springs, J.
    step : int
        Steps taken since the base motion started (t = step * dt).
    """

    x: np.ndarray
    v: np.ndarray
    omega: np.ndarray
    force: np.ndarray
    torque: np.ndarray
    shear: np.ndarray
    tangential_energy: np.ndarray
    step: int = 0

    @property
    def n_batch(self) -> int:
        """Number of cells in the batch."""
        return self.x.shape[1]

    @property
    def n_spheres(self) -> int:
        """Spheres per cell."""
        return self.x.shape[2]

    def copy(self) -> "State":
        """A deep copy."""
        return State(*(getattr(self, name).copy() for name in
                       ("x", "v", "omega", "force", "torque", "shear", "tangential_energy")),
                     step=self.step)


def _batched(array, name: str, n_batch: int | None = None) -> np.ndarray:
    """Coerce (n, 3) or (n_batch, n, 3) to a component-first (3, n_batch, n) float array."""
    arr = np.asarray(array, dtype=float)
    if arr.ndim == 2:
        arr = arr[None]
    if arr.ndim != 3 or arr.shape[2] != 3:
        raise ValueError(f"{name} must have shape (n, 3) or (n_batch, n, 3), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite")
    if n_batch is not None and arr.shape[0] == 1 and n_batch > 1:
        arr = np.broadcast_to(arr, (n_batch,) + arr.shape[1:])
    return np.ascontiguousarray(np.moveaxis(arr, 2, 0))


def initial_state(positions_m, velocities_m_s=None, angular_velocities_rad_s=None,
                  n_batch: int | None = None) -> State:
    """A state at rest (or with the given velocities), forces not yet evaluated.

    Parameters
    ----------
    positions_m : array_like, shape (n, 3) or (n_batch, n, 3)
        Sphere centres in the cell frame, m. One packing is repeated ``n_batch`` times.
    velocities_m_s, angular_velocities_rad_s : array_like, optional
        Same shapes, m/s and rad/s; default zero.
    n_batch : int, optional
        Batch size when a single packing is given.
    """
    x = _batched(positions_m, "positions_m", n_batch)
    zeros = np.zeros_like(x)
    v = zeros.copy() if velocities_m_s is None else _batched(velocities_m_s, "velocities_m_s",
                                                             x.shape[1])
    w = zeros.copy() if angular_velocities_rad_s is None else _batched(
        angular_velocities_rad_s, "angular_velocities_rad_s", x.shape[1])
    if v.shape != x.shape or w.shape != x.shape:
        raise ValueError("velocities must have the same shape as positions")
    _, n_batch_, n = x.shape
    n_cols = n + N_WALLS
    return State(x=x, v=v, omega=w, force=zeros.copy(), torque=zeros.copy(),
                 shear=np.zeros((3, n_batch_, n, n_cols)),
                 tangential_energy=np.zeros((n_batch_, n, n_cols)))
