"""A patch of honeycomb cells: where the cells are, their shared wall mesh, and packings in them.

The cells are the regular hexagons of :class:`~pidpipe.cell.geometry.HexCell` (vertices at (+-R, 0)
in each cell's frame), tiled edge to edge: neighbouring centres are one inscribed diameter d
apart, in the directions of the side normals (30, 90, ..., 330 degrees). Two layouts:

- rings around a centre cell: 1, 7, 19, 37, ... cells (1 + 3 n (n + 1) for n rings);
- a coupon of ``columns x rows`` cells in offset columns (columns 1.5 R apart, every other
  column shifted by d/2), e.g. 21 x 21 = 441 cells for the source's 100 mm x 100 mm coupon.

The mesh holds every wall once: a wall between two cells is one rectangle (two triangles) that
both cells' spheres touch, from either side, so every cell has exactly the geometry of the
single cell of :func:`~pidpipe.cell.geometry.cell_wall_triangles`, with no foil thickness. Floors
and lids are fanned from each cell's corner 0, as in the single cell, so no vertex lies inside
a face.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from pidpipe.cell.geometry import HexCell

_VERTEX_KEY_M = 1e-9
"""Vertices of neighbouring cells closer than this are the same lattice vertex, m."""


def ring_centres(cell: HexCell, rings: int) -> np.ndarray:
    """Centres of a patch of ``rings`` rings around a centre cell, ring by ring.

    Parameters
    ----------
    cell : HexCell
    rings : int
        0 gives the centre cell alone, 1 gives 7 cells, 2 gives 19, n gives 1 + 3 n (n + 1).

    Returns
    -------
    ndarray, shape (n_cells, 2)
        Cell centres (x, y), m; cell 0 at the origin, then ring 1, ring 2, ...
    """
    if isinstance(rings, bool) or not isinstance(rings, (int, np.integer)) or rings < 0:
        raise ValueError(f"rings must be a non-negative integer, got {rings!r}")
    centres = [np.zeros(2)]
    for ring in range(1, rings + 1):
        this_ring = [_axial_to_xy(cell, q, r) for q in range(-ring, ring + 1)
                     for r in range(-ring, ring + 1) if max(abs(q), abs(r), abs(q + r)) == ring]
        centres += sorted(this_ring, key=lambda xy: math.atan2(xy[1], xy[0]) % (2.0 * math.pi))
    return np.array(centres)


def _axial_to_xy(cell: HexCell, q: int, r: int) -> np.ndarray:
    """Centre of the cell at axial coordinates (q, r): q steps along 30 degrees, r along 90, m."""
    return np.array([1.5 * cell.circumradius_m * q, cell.inscribed_diameter_m * (r + 0.5 * q)])


def coupon_centres(cell: HexCell, columns: int, rows: int) -> np.ndarray:
    """Centres of a rectangular coupon in offset columns, column by column.

    Columns are 1.5 R apart in x; in each column the cells are d apart in y, and every odd
    column is shifted by d/2. Cell 0 is at the origin.

    Parameters
    ----------
    cell : HexCell
    columns, rows : int
        Cells across (x) and along (y); 21 x 21 = 441 for the source's coupon.

    Returns
    -------
    ndarray, shape (columns * rows, 2)
        Cell centres (x, y), m.
    """
    for name, value in (("columns", columns), ("rows", rows)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
            raise ValueError(f"{name} must be a positive integer, got {value!r}")
    d = cell.inscribed_diameter_m
    return np.array([(1.5 * cell.circumradius_m * i, d * (j + 0.5 * (i % 2)))
                     for i in range(columns) for j in range(rows)])


def patch_wall_triangles(cell: HexCell, centres_m: np.ndarray, top_z_m: float | None = None,
                         closed: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Triangulate the walls of a patch of cells, every shared wall once.

    Parameters
    ----------
    cell : HexCell
    centres_m : ndarray, shape (n_cells, 2)
        Cell centres, m (from :func:`ring_centres` or :func:`coupon_centres`).
    top_z_m : float, optional
        z of the top of the side walls, m; defaults to the lid (a taller value gives open
        pouring cells).
    closed : bool
        Whether to add each cell's lid at ``top_z_m``.

    Returns
    -------
    points : ndarray, shape (n_points, 3)
        Vertex coordinates, m.
    triangles : ndarray, shape (n_triangles, 3)
        Vertex indices. A wall faces the first cell that has it; floors face +z, lids -z.
    """
    centres = _centres(centres_m)
    top = cell.lid_z_m if top_z_m is None else float(top_z_m)
    bottom = cell.floor_z_m
    ring = cell.vertices_xy()
    keys: dict[tuple[int, int], int] = {}
    columns: list[np.ndarray] = []

    def vertex(xy: np.ndarray) -> int:
        key = (round(xy[0] / _VERTEX_KEY_M), round(xy[1] / _VERTEX_KEY_M))
        if key not in keys:
            keys[key] = len(columns)
            columns.append(xy)
        return keys[key]

    cell_vertices = np.array([[vertex(centre + corner) for corner in ring] for centre in centres])
    n_columns = len(columns)
    xy = np.array(columns)
    points = np.vstack([np.column_stack([xy, np.full(n_columns, bottom)]),
                        np.column_stack([xy, np.full(n_columns, top)])])
    triangles = []
    walls_done = set()
    for corners in cell_vertices:
        for k in range(6):
            b0, b1 = int(corners[k]), int(corners[(k + 1) % 6])
            if (min(b0, b1), max(b0, b1)) in walls_done:
                continue
            walls_done.add((min(b0, b1), max(b0, b1)))
            t0, t1 = b0 + n_columns, b1 + n_columns
            triangles += [(b0, t0, b1), (b1, t0, t1)]   # faces this cell (ring counter-clockwise)
        for k in range(1, 5):
            c0, ck, ck1 = int(corners[0]), int(corners[k]), int(corners[k + 1])
            triangles.append((c0, ck, ck1))                                   # floor, +z
            if closed:
                triangles.append((c0 + n_columns, ck1 + n_columns, ck + n_columns))  # lid, -z
    return points, np.asarray(triangles, dtype=np.int64)


def cell_boundary(points: np.ndarray, triangles: np.ndarray, cell: HexCell,
                  centre_m: np.ndarray) -> np.ndarray:
    """The triangles of a patch mesh that bound one cell, wound to face into that cell.

    A triangle bounds the cell when all three of its vertices are corners of the cell (a
    neighbour's wall or floor shares at most two of them).

    Returns
    -------
    ndarray, shape (n, 3)
        Vertex indices into ``points``; 20 triangles for a closed cell.
    """
    corners = np.asarray(centre_m, dtype=float)[:2] + cell.vertices_xy()
    is_corner = np.min(np.linalg.norm(points[:, None, :2] - corners[None], axis=2), axis=1) < _VERTEX_KEY_M
    mine = triangles[np.all(is_corner[triangles], axis=1)]
    a, b, c = (points[mine[:, k]] for k in range(3))
    normal = np.cross(b - a, c - a)
    inward_point = np.array([*np.asarray(centre_m, dtype=float)[:2],
                             0.5 * (cell.floor_z_m + points[:, 2].max())])
    facing = np.einsum("ij,ij->i", normal, inward_point - (a + b + c) / 3.0) > 0
    return np.where(facing[:, None], mine, mine[:, ::-1])


def write_patch_stl(path: str | Path, cell: HexCell, centres_m: np.ndarray,
                    top_z_m: float | None = None, closed: bool = True,
                    flip_normals: bool = False) -> Path:
    """Write the patch's walls as an ASCII STL file (m) with meshio, atomically.

    ``flip_normals`` reverses every triangle (a check that LIGGGHTS' walls act from both
    sides, which a shared wall needs: it faces only one of its two cells).
    """
    import meshio

    path = Path(path)
    points, triangles = patch_wall_triangles(cell, centres_m, top_z_m=top_z_m, closed=closed)
    if flip_normals:
        triangles = triangles[:, ::-1]
    tmp = path.with_name(path.name + ".part")
    meshio.write(tmp, meshio.Mesh(points, [("triangle", triangles)]), file_format="stl",
                 binary=False)
    tmp.replace(path)
    return path


def place_in_cells(local_positions: list[np.ndarray], centres_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Translate each cell's packing (in its own cell frame) to its cell in the patch.

    Parameters
    ----------
    local_positions : list of ndarray, each shape (n_i, 3)
        Sphere centres of cell i in the cell frame, m.
    centres_m : ndarray, shape (n_cells, 2)

    Returns
    -------
    positions : ndarray, shape (sum n_i, 3)
        Sphere centres in the patch frame, m, cell by cell.
    cell_index : ndarray of int, shape (sum n_i,)
        The cell of each sphere.
    """
    centres = _centres(centres_m)
    if len(local_positions) != len(centres):
        raise ValueError(f"{len(local_positions)} packings for {len(centres)} cells")
    placed, owner = [], []
    for index, (local, centre) in enumerate(zip(local_positions, centres)):
        local = np.asarray(local, dtype=float).reshape(-1, 3)
        placed.append(local + np.array([centre[0], centre[1], 0.0]))
        owner.append(np.full(len(local), index, dtype=np.int64))
    return np.vstack(placed), np.concatenate(owner)


def spheres_in_own_cells(cell: HexCell, centres_m: np.ndarray, positions_m: np.ndarray,
                         cell_index: np.ndarray, radius_m: float, tol_m: float = 0.0) -> np.ndarray:
    """Whether each sphere lies wholly inside its own cell of the patch (within ``tol_m``).

    Parameters
    ----------
    positions_m : ndarray, shape (n, 3)
        Sphere centres in the patch frame, with the cells at rest (z of the floor as built), m.
    cell_index : ndarray of int, shape (n,)

    Returns
    -------
    ndarray of bool, shape (n,)
    """
    centres = _centres(centres_m)
    local = np.asarray(positions_m, dtype=float).copy()
    local[:, :2] -= centres[np.asarray(cell_index)]
    return cell.contains_spheres(local, radius_m, tol_m)


def patch_box(cell: HexCell, centres_m: np.ndarray, top_z_m: float, travel_m: float,
              radius_m: float) -> dict:
    """A fixed simulation box around the patch's whole travel, m (cf. decks.simulation_box)."""
    centres = _centres(centres_m)
    margin = cell.circumradius_m + 2.0 * radius_m
    return {"xlo": float(centres[:, 0].min() - margin), "xhi": float(centres[:, 0].max() + margin),
            "ylo": float(centres[:, 1].min() - margin), "yhi": float(centres[:, 1].max() + margin),
            "zlo": cell.floor_z_m - travel_m - 2.0 * radius_m, "zhi": top_z_m + 2.0 * radius_m}


def _centres(centres_m: np.ndarray) -> np.ndarray:
    centres = np.asarray(centres_m, dtype=float)
    if centres.ndim != 2 or centres.shape[1] != 2 or len(centres) == 0 or not np.all(np.isfinite(centres)):
        raise ValueError(f"cell centres must be a finite (n_cells, 2) array, got shape {centres.shape}")
    return centres
