"""The honeycomb cells' centres on the plate: a hexagonal lattice of whole cells.

A cell is a regular hexagon with flat-to-flat size d (``geometry.cell_inscribed_diameter_m``) and
circumradius R = d / sqrt(3), its vertices at (+-R, 0) as in the cell's DEM frame. Such hexagons
tile the plane in columns 1.5 R apart along x, cells d apart along y within a column, every
other column shifted by d / 2. Every cell lying wholly on the a x b plate is kept, so the count
is close to the plate's area over a cell's, a b / (sqrt(3)/2 d^2).
"""

from __future__ import annotations

import math

import numpy as np


def cell_area_m2(inscribed_diameter_m: float) -> float:
    """Area of one hexagonal cell, sqrt(3)/2 d^2, m^2."""
    return math.sqrt(3.0) / 2.0 * inscribed_diameter_m**2


def cell_centres(length_m: float, width_m: float, inscribed_diameter_m: float) -> np.ndarray:
    """Centres of the whole cells on the plate [0, a] x [0, b].

    Returns
    -------
    numpy.ndarray, shape (n_cells, 2)
        (x, y) in m, column by column (x rising), y rising within a column.
    """
    d = inscribed_diameter_m
    r = d / math.sqrt(3.0)
    xs = np.arange(r, length_m - r + 1e-12, 1.5 * r)
    columns = []
    for index, x in enumerate(xs):
        y0 = d / 2.0 + (d / 2.0 if index % 2 else 0.0)
        ys = np.arange(y0, width_m - d / 2.0 + 1e-12, d)
        columns.append(np.column_stack([np.full(ys.size, x), ys]))
    return np.vstack(columns) if columns else np.empty((0, 2))
