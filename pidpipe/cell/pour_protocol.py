"""The pour's protocol, the same for both engines that pour (LIGGGHTS and the compiled DEM).

A pour starts from the seed's random sequential deposition (:func:`pidpipe.cell.packing.random_start`)
in a tall, open prism of the cell's hexagon, whose side walls reach 4 radii above the highest
start (or the lid, if higher); it settles under gravity for ``fidelity.settle_time_s``, is tapped
(the cell moved as z = W (cos(omega t) - 1), :data:`TAP_CYCLES` whole cycles at
:data:`TAP_FREQ_HZ` and :data:`TAP_ACCEL_G`, starting and ending at rest), and settles again for
``fidelity.settle_time_s``. A pour that has not settled then (fastest sphere above
:data:`~pidpipe.cell.packing.SETTLED_SPEED_M_S`) goes on settling in chunks of the settle time,
up to :data:`~pidpipe.cell.packing.MAX_FURTHER_SETTLING` of them. One timestep for all of it: the
case timestep rule at the tapping frequency, a whole number of steps per tapping cycle.

:func:`plan_pour` computes everything an engine needs for that; :func:`settled_packing` turns the
engine's final state into the :class:`~pidpipe.cell.packing.Packing` that both engines return.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pidpipe.cell.packing import Packing, random_start
from pidpipe.cell.scene import CellScene
from pidpipe.config.settings import POUR_ENGINES, PourSettings
from pidpipe.physics.equivalent_damping import displacement_amplitude_m
from pidpipe.physics.timestep import TimestepPlan

TAP_FREQ_HZ = 100.0
"""Frequency of the tapping that compacts a fresh pour, Hz."""

TAP_ACCEL_G = 10.0
"""Acceleration amplitude of the tapping, in g (the top of the reference grid)."""

TAP_CYCLES = 20
"""Cycles of tapping. Without it a deposited pile collapses during measured cycles: measured
at 500 Hz, 5 g, 11 spheres, the potential energy fell by 8 cycles' worth of dissipation
between cycles 35 and 42."""

OPEN_CELL_HEADROOM_RADII = 4.0
"""How far the open pouring cell's side walls reach above the highest start, in radii."""


@dataclass(frozen=True)
class PourPlan:
    """One pour, as both engines run it.

    Attributes
    ----------
    scene : CellScene
        The cell (the closed cell the packing is for), materials and fidelity.
    fill_pct : float
    n_spheres : int
    seed : int
        ``fidelity.seed`` + replicate.
    start_m : ndarray, shape (n_spheres, 3)
        Start centres in the cell frame (floor at z = -h/2), m.
    top_z_m : float
        Top of the open pouring cell's side walls, m (cell frame).
    timestep : TimestepPlan
        The timestep at :data:`TAP_FREQ_HZ` (``steps_per_cycle`` steps per tapping cycle).
    settle_steps : int
        Steps of one settling period, ceil(settle_time_s / (fraction x t_R)).
    tap_steps : int
        Steps of the tapping, :data:`TAP_CYCLES` x steps per cycle.
    tap_amplitude_m : float
        Displacement amplitude W of the tapping, m.
    label : str
        ``pour_r<fill>pct_rep<replicate>``.
    """

    scene: CellScene
    fill_pct: float
    n_spheres: int
    seed: int
    start_m: np.ndarray
    top_z_m: float
    timestep: TimestepPlan
    settle_steps: int
    tap_steps: int
    tap_amplitude_m: float
    label: str

    @property
    def settle_period_s(self) -> float:
        """One settling period as stepped, s (``fidelity.settle_time_s`` rounded up to whole steps)."""
        return self.settle_steps * self.timestep.timestep_s


def plan_pour(settings: PourSettings, fill_pct: float, replicate: int) -> PourPlan:
    """The pour of one fill level and replicate: start, open cell, timestep and step counts.

    Parameters
    ----------
    settings : PourSettings
    fill_pct : float
        Fill fraction, percent.
    replicate : int
        Replicate (packing) index; the seed is ``fidelity.seed + replicate``.
    """
    scene = CellScene.of(settings)
    cell, radius = scene.cell, scene.radius_m
    n_spheres = settings.fill.spheres(fill_pct)
    seed = settings.pouring.seed + int(replicate)
    start = random_start(cell, n_spheres, radius, seed)
    top_z = max(cell.lid_z_m, float(start[:, 2].max()) + OPEN_CELL_HEADROOM_RADII * radius)
    plan = scene.timestep(TAP_FREQ_HZ)
    target_dt = settings.fidelity.timestep_rayleigh_fraction * plan.rayleigh_time_s
    return PourPlan(
        scene=scene, fill_pct=float(fill_pct), n_spheres=n_spheres, seed=seed, start_m=start,
        top_z_m=top_z, timestep=plan,
        settle_steps=max(1, math.ceil(settings.pouring.settle_time_s / target_dt)),
        tap_steps=TAP_CYCLES * plan.steps_per_cycle,
        tap_amplitude_m=displacement_amplitude_m(TAP_FREQ_HZ, TAP_ACCEL_G),
        label=f"pour_r{fill_pct:g}pct_rep{replicate}")


def settled_packing(plan: PourPlan, centres_m: np.ndarray, velocities_m_s: np.ndarray,
                    chunks: int, engine: str) -> Packing:
    """The packing of a finished pour.

    Parameters
    ----------
    plan : PourPlan
    centres_m, velocities_m_s : ndarray, shape (n_spheres, 3)
        Final centres in the cell frame (m) and velocities (m/s).
    chunks : int
        Settling periods after the tapping (1 .. 1 + MAX_FURTHER_SETTLING).
    engine : str
        The engine that poured it (one of :data:`~pidpipe.config.settings.POUR_ENGINES`).
    """
    if engine not in POUR_ENGINES:
        raise ValueError(f"pour engine {engine!r} is not one of {', '.join(POUR_ENGINES)}")
    centres = np.asarray(centres_m, dtype=float).reshape(-1, 3)
    speeds = np.linalg.norm(np.asarray(velocities_m_s, dtype=float).reshape(-1, 3), axis=1)
    cell, radius = plan.scene.cell, plan.scene.radius_m
    return Packing(positions_m=centres.tolist(), radius_m=radius, n_spheres=plan.n_spheres,
                   seed=plan.seed, pile_height_m=float(centres[:, 2].max() + radius - cell.floor_z_m),
                   lid_height_m=cell.height_m, max_speed_m_s=float(speeds.max()),
                   settle_time_s=chunks * plan.settle_steps * plan.timestep.timestep_s, fill_pct=plan.fill_pct,
                   pour_engine=engine)
