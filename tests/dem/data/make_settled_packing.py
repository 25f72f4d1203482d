"""Regenerate the settled packings used by the DEM tests (run from the repo root).

Spheres start in a loose two-per-layer column and settle for 60 ms under gravity in the still
cell with strong damping (e = 0.3); the final centres are written as CSV (m, cell frame).
Usage: python tests/dem/data/make_settled_packing.py 11
"""

import sys
from pathlib import Path

import numpy as np

from pidpipe.cell.geometry import HexCell
from pidpipe.dem import Material, advance, make_scene, start


def column(n: int, radius: float, floor_z: float, gap: float = 2.3e-3) -> np.ndarray:
    """Two spheres per layer, layers turned by 60 degrees, centres in m."""
    k = np.arange(n)
    angle = np.deg2rad(60.0 * (k // 2)) + np.pi * (k % 2)
    offset = 1.01 * radius
    return np.column_stack([offset * np.cos(angle), offset * np.sin(angle),
                            floor_z + 1.01 * radius + (k // 2) * gap])


def settle(n: int, seconds: float = 0.06) -> np.ndarray:
    cell = HexCell(4.76e-3, 25.4e-3)
    acrylic = Material(2.84e9, 0.402, 1180.0, 1.25e-3)
    aluminium = Material(70e9, 0.33)
    scene = make_scene(cell, acrylic, aluminium, pp_friction=0.096, pp_restitution=0.3,
                       pw_friction=0.14, pw_restitution=0.3, freq_hz=500.0, accel_g=0.0)
    rng = np.random.default_rng(n)
    positions = column(n, scene.radius_m, cell.floor_z_m)
    positions[:, :2] += rng.uniform(-2e-5, 2e-5, size=(n, 2))
    scene, state, ws = start(scene, positions)
    advance(scene, state, ws, int(seconds / scene.timestep_s))
    return np.moveaxis(state.x[:, 0], 0, 1)


if __name__ == "__main__":
    count = int(sys.argv[1])
    out = Path(__file__).with_name(f"settled_{count}.csv")
    np.savetxt(out, settle(count), delimiter=",", header="x_m,y_m,z_m", fmt="%.12e")
    print(out)
