"""k independent cells, each with its own packing, laid side by side in one wall mesh.

The scene study (:mod:`pidpipe.studies.scene`) measured that neighbouring cells do not interact
(a cell of a patch reproduces the same packing shaken alone, bit for bit) and that packings
differ by 5-7 % in C_eq beyond their cycle-to-cycle noise. A case can therefore estimate the
mean cell of a coupon from k cells with k different packings.

The k cells are laid out in a row along x, a gap of :data:`GAP_RADII` sphere radii apart, all
in one wall mesh: LIGGGHTS' cost per step grows with the number of meshes (a first layout with a
mesh per cell cost as much as k separate runs, measured once during development), while one mesh
shares it (``benchmarks/bench_cells.py``: 0.51-0.65 of k runs for k = 7). The walls' force on a
cell's spheres is their group's total force plus their weight (contacts between a cell's own
spheres cancel, and cells are apart), so each cell's wall power is that force times the wall
velocity; its energies come from its group too (``templates/shake.lmp.j2``). The spheres of cell
i are atoms ``first_atom_id .. last_atom_id`` (LIGGGHTS numbers atoms in creation order).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pidpipe.cell.geometry import HexCell, write_cell_stl

GAP_RADII = 2.0
"""Gap between neighbouring cells' walls, in sphere radii (any gap > 0 keeps them apart: a
sphere cannot leave its own closed cell)."""

MAX_CELLS = 24
"""Most cells in one run: each needs a LIGGGHTS group, and LIGGGHTS allows 32 groups."""


@dataclass(frozen=True)
class CellLayout:
    """Where the cells of one run are and which atoms are theirs.

    Attributes
    ----------
    offsets_m : ndarray, shape (n_cells, 2)
        x, y of each cell's centre, m.
    first_atom_ids, last_atom_ids : tuple of int
        The atom ids of each cell's spheres, inclusive (ids start at 1).
    """

    offsets_m: np.ndarray
    first_atom_ids: tuple[int, ...]
    last_atom_ids: tuple[int, ...]

    @property
    def n_cells(self) -> int:
        return len(self.first_atom_ids)

    def cell_of_atom(self) -> np.ndarray:
        """The cell index of every atom, indexed by atom id - 1; shape (n_atoms,)."""
        counts = np.asarray(self.last_atom_ids) - np.asarray(self.first_atom_ids) + 1
        return np.repeat(np.arange(self.n_cells), counts)


def side_by_side(cell: HexCell, spheres_per_cell: list[int], radius_m: float) -> CellLayout:
    """A row of cells along x, :data:`GAP_RADII` radii apart; the first at the origin.

    Parameters
    ----------
    cell : HexCell
    spheres_per_cell : list of int
        Spheres in each cell (at least one cell, at most :data:`MAX_CELLS`).
    radius_m : float
        Sphere radius, m.

    Raises
    ------
    ValueError
        No cell, too many cells, or a cell without spheres.
    """
    n_cells = len(spheres_per_cell)
    if not 1 <= n_cells <= MAX_CELLS:
        raise ValueError(f"{n_cells} cells in one run; 1 to {MAX_CELLS} are allowed")
    if min(spheres_per_cell) < 1:
        raise ValueError(f"every cell needs a sphere, got {spheres_per_cell}")
    pitch = 2.0 * cell.circumradius_m + GAP_RADII * radius_m
    offsets = np.column_stack([pitch * np.arange(n_cells), np.zeros(n_cells)])
    last = np.cumsum(spheres_per_cell)
    first = last - np.asarray(spheres_per_cell) + 1
    return CellLayout(offsets_m=offsets, first_atom_ids=tuple(int(i) for i in first),
                      last_atom_ids=tuple(int(i) for i in last))


def place_packings(layout: CellLayout, centres_per_cell: list[np.ndarray]) -> np.ndarray:
    """Every sphere centre of the run, cell by cell, moved to its cell; shape (n_atoms, 3), m."""
    return np.vstack([np.asarray(centres, dtype=float) + [x, y, 0.0]
                      for centres, (x, y) in zip(centres_per_cell, layout.offsets_m)])


def write_cells_mesh(path: str | Path, cell: HexCell, layout: CellLayout,
                     subdivisions: int = 1) -> Path:
    """Write the closed walls of every cell of the layout as one mesh (ASCII STL, m); each
    hexagon side cut into ``subdivisions`` pieces (:func:`pidpipe.cell.geometry.cell_wall_triangles`)."""
    return write_cell_stl(path, cell, offsets_xy_m=layout.offsets_m, subdivisions=subdivisions)
