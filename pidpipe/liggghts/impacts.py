"""Single impacts in LIGGGHTS: the contact law checked against the configured restitution.

A sphere thrown at the floor of the fixed cell, or two spheres thrown at each other, with
gravity off; the normal coefficient of restitution is the ratio of the normal relative speeds
after and before the impact.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pidpipe.cell.geometry import write_cell_stl
from pidpipe.cell.scene import CellScene
from pidpipe.liggghts.decks import common_values, render, simulation_box
from pidpipe.liggghts.parsing import read_dump_atoms
from pidpipe.liggghts.process import run_deck


def run_impact(scene: CellScene, positions_m: np.ndarray, velocities_m_s: np.ndarray, duration_s: float,
               workdir: str | Path, label: str = "impact") -> np.ndarray:
    """Run spheres with prescribed start velocities in the fixed, closed cell, gravity off.

    Parameters
    ----------
    scene : CellScene
        The cell, materials and fidelity (timestep fraction, stiffness, friction).
    positions_m, velocities_m_s : ndarray, shape (n, 3)
        Start centres (m) and velocities (m/s).
    duration_s : float
        Simulated time, s.

    Returns
    -------
    ndarray, shape (n, 6)
        Final centres (m) and velocities (m/s) of the spheres, by id.
    """
    workdir = Path(workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    cell, radius = scene.cell, scene.radius_m
    dt = scene.fidelity.timestep_rayleigh_fraction * scene.rayleigh_time_s
    steps = max(1, int(np.ceil(duration_s / dt)))
    write_cell_stl(workdir / "cell.stl", cell)
    values = common_values(scene, positions_m, dt, "cell.stl", label, "impact",
                           simulation_box(cell, cell.lid_z_m, 0.0, radius), thermo_every=steps)
    values.update(velocities_m_s=np.asarray(velocities_m_s, dtype=float).reshape(-1, 3).tolist(),
                  gravity_on=False, total_steps=steps, dump_every=steps, output_file="final.dump")
    deck = workdir / "impact.lmp"
    deck.write_text(render("impact.lmp.j2", values), encoding="utf-8")
    (workdir / "final.dump").unlink(missing_ok=True)
    run_deck(deck, label)
    return read_dump_atoms(workdir / "final.dump")[:, 1:7]


def wall_restitution(scene: CellScene, speed_m_s: float, workdir: str | Path,
                     xy_m: tuple[float, float] = (0.4e-3, 0.3e-3)) -> float:
    """Measured restitution of a sphere thrown straight down at the floor at ``speed_m_s``."""
    cell, radius = scene.cell, scene.radius_m
    gap = 0.1 * radius
    start = np.array([[xy_m[0], xy_m[1], cell.floor_z_m + radius + gap]])
    duration = 2.0 * gap / speed_m_s + 20.0 * scene.rayleigh_time_s
    final = run_impact(scene, start, [[0.0, 0.0, -speed_m_s]], duration, workdir, "wall_impact")
    return float(final[0, 5] / speed_m_s)


def pair_restitution(scene: CellScene, speed_m_s: float, workdir: str | Path) -> float:
    """Measured restitution of two spheres thrown head-on at each other, each at ``speed_m_s``."""
    radius = scene.radius_m
    gap = 0.1 * radius
    half = radius + 0.5 * gap
    start = np.array([[0.2e-3, 0.1e-3, -half], [0.2e-3, 0.1e-3, half]])
    duration = gap / (2.0 * speed_m_s) + 20.0 * scene.rayleigh_time_s
    final = run_impact(scene, start, [[0, 0, speed_m_s], [0, 0, -speed_m_s]], duration, workdir,
                       "pair_impact")
    return float((final[1, 5] - final[0, 5]) / (2.0 * speed_m_s))
