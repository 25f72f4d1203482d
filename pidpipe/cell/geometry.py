"""The hexagonal honeycomb cell: its bounding planes, its STL wall mesh, the coupon.

Local frame at the cell centre, z across the panel (SPEC.md): the face sheets are the planes
z = -h/2 (floor) and z = +h/2 (lid); the six side walls are at distance a = d/2 (the apothem,
half the inscribed-circle diameter d) from the axis, with outward normals at 30, 90, ..., 330
degrees, so that the vertices lie at (+-R, 0) with circumradius R = d / sqrt(3).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np


@dataclass(frozen=True)
class HexCell:
    """A regular hexagonal cell.

    Parameters
    ----------
    inscribed_diameter_m : float
        Diameter of the circle inscribed in the hexagon (the honeycomb's cell size), m.
    height_m : float
        Core height (distance between the face sheets), m.
    """

    inscribed_diameter_m: float
    height_m: float

    def __post_init__(self) -> None:
        for name in ("inscribed_diameter_m", "height_m"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"HexCell.{name} must be a positive finite number, got {value!r}")

    @property
    def apothem_m(self) -> float:
        """Distance from the axis to each side wall, m."""
        return 0.5 * self.inscribed_diameter_m

    @property
    def circumradius_m(self) -> float:
        """Distance from the axis to each vertex, m (R = d / sqrt(3))."""
        return self.inscribed_diameter_m / math.sqrt(3.0)

    @property
    def floor_z_m(self) -> float:
        """z of the floor face sheet, m."""
        return -0.5 * self.height_m

    @property
    def lid_z_m(self) -> float:
        """z of the lid face sheet, m."""
        return 0.5 * self.height_m

    @property
    def area_m2(self) -> float:
        """Cross-section area of the hexagon, m^2 (2 sqrt(3) a^2)."""
        return 2.0 * math.sqrt(3.0) * self.apothem_m**2

    @property
    def volume_m3(self) -> float:
        """Volume of the closed cell, m^3."""
        return self.area_m2 * self.height_m

    def vertices_xy(self) -> np.ndarray:
        """The six hexagon vertices, counter-clockwise from (R, 0); shape (6, 2), m."""
        angles = np.deg2rad(np.arange(6) * 60.0)
        return self.circumradius_m * np.column_stack([np.cos(angles), np.sin(angles)])

    def side_normals(self) -> np.ndarray:
        """Outward unit normals of the six side walls in the xy plane; shape (6, 2)."""
        angles = np.deg2rad(30.0 + np.arange(6) * 60.0)
        return np.column_stack([np.cos(angles), np.sin(angles)])

    def planes(self) -> tuple[np.ndarray, np.ndarray]:
        """All eight bounding planes as inward unit normals n and offsets c.

        A point x lies inside the cell when ``n @ x + c >= 0`` for every plane, and
        ``n @ x + c`` is then its distance to that plane.

        Returns
        -------
        normals : ndarray, shape (8, 3)
            Inward unit normals: six side walls, then the floor (+z) and the lid (-z).
        offsets : ndarray, shape (8,)
            Plane offsets, m.
        """
        side = self.side_normals()
        normals = np.zeros((8, 3))
        normals[:6, :2] = -side
        normals[6] = (0.0, 0.0, 1.0)
        normals[7] = (0.0, 0.0, -1.0)
        offsets = np.full(8, self.apothem_m)
        offsets[6] = -self.floor_z_m
        offsets[7] = self.lid_z_m
        return normals, offsets

    def contains_spheres(self, centres_m: np.ndarray, radius_m: float, tol_m: float = 0.0) -> np.ndarray:
        """Whether each sphere lies wholly inside the cell (within ``tol_m``); shape (n,)."""
        normals, offsets = self.planes()
        distances = np.asarray(centres_m, dtype=float) @ normals.T + offsets
        return np.all(distances >= radius_m - tol_m, axis=1)


def cell_wall_triangles(cell: HexCell, top_z_m: float | None = None,
                        closed: bool = True, subdivisions: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Triangulate the cell walls with inward-facing normals.

    Parameters
    ----------
    cell : HexCell
        The cell.
    top_z_m : float, optional
        z of the top of the side walls, m; defaults to the lid. A taller value gives the open
        pouring cell used for packing.
    closed : bool
        Whether to add the lid at ``top_z_m``.
    subdivisions : int
        Points per hexagon side (1: the corners only, the mesh every run uses). With n > 1 each
        side is cut into n equal pieces: each side wall becomes n strips (2n triangles) and the
        floor and lid 6n - 2 triangles each, the same surfaces with more shared edges between
        coplanar triangles and still no vertex inside a face (every vertex lies on the
        hexagon's edges). Only for measuring what the edges of a flat face do
        (``benchmarks/experiments/bench_solver_difference.py``).

    Returns
    -------
    points : ndarray, shape (12 * subdivisions, 3)
        Vertex coordinates, m: the bottom ring, then the top ring.
    triangles : ndarray, shape (n_triangles, 3)
        Vertex indices, wound so that the right-hand normal points into the cell.
    """
    n = int(subdivisions)
    if n < 1 or n != subdivisions:
        raise ValueError(f"subdivisions must be a whole number >= 1, got {subdivisions!r}")
    top = cell.lid_z_m if top_z_m is None else float(top_z_m)
    bottom = cell.floor_z_m
    corners = cell.vertices_xy()
    fraction = np.arange(n) / n
    ring = np.vstack([corners[k] + fraction[:, None] * (corners[(k + 1) % 6] - corners[k])
                      for k in range(6)])                                # (6n, 2), counter-clockwise
    m = len(ring)
    points = np.vstack([
        np.column_stack([ring, np.full(m, bottom)]),   # 0..m-1   bottom ring
        np.column_stack([ring, np.full(m, top)]),      # m..2m-1  top ring
    ])
    triangles = []
    for j in range(m):
        b0, b1, t0, t1 = j, (j + 1) % m, m + j, m + (j + 1) % m
        # side wall strip j: the ring runs counter-clockwise, so (b0, t0, b1) faces inward
        triangles += [(b0, t0, b1), (b1, t0, t1)]
    # Faces: a fan from corner 0, so that no mesh vertex lies inside a face (LIGGGHTS'
    # contact with a vertex shared by many coplanar triangles loses energy: measured e = 0.60
    # for a configured 0.70 on a centre vertex, against 0.69-0.70 on a face or an edge). The
    # points on the two sides that meet at corner 0 are in line with it: they are fanned from
    # the first point past corner 1 and the last before corner 5 instead.
    floor = [(i, i + 1, n + 1) for i in range(n)]                       # side 0, apex past corner 1
    floor += [(0, k, k + 1) for k in range(n + 1, 5 * n - 1)]           # the fan from corner 0
    floor += [((i + 1) % m, 5 * n - 1, i) for i in range(5 * n, m)]     # side 5, apex before corner 5
    for a, b, c in floor:
        triangles.append((a, b, c))                     # floor, normal +z
        if closed:
            triangles.append((m + a, m + c, m + b))     # lid, normal -z
    return points, np.asarray(triangles, dtype=np.int64)


def triangle_normals(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Unit right-hand normals of the triangles; shape (n_triangles, 3)."""
    a, b, c = (points[triangles[:, k]] for k in range(3))
    normals = np.cross(b - a, c - a)
    return normals / np.linalg.norm(normals, axis=1, keepdims=True)


def cells_wall_triangles(cell: HexCell, top_z_m: float | None = None, closed: bool = True,
                         offsets_xy_m: np.ndarray | None = None,
                         subdivisions: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """The walls of one cell, or of several separate cells, as one triangle mesh.

    Parameters
    ----------
    top_z_m, closed, subdivisions
        As :func:`cell_wall_triangles`.
    offsets_xy_m : ndarray, shape (n_cells, 2), optional
        Where each cell's axis is, m (default: one cell at the origin).

    Returns
    -------
    points : ndarray, shape (12 * subdivisions * n_cells, 3)
        Vertex coordinates, m, cell by cell.
    triangles : ndarray, shape (n_triangles, 3)
        Vertex indices, wound so that the right-hand normal points into the cells.
    """
    points, triangles = cell_wall_triangles(cell, top_z_m=top_z_m, closed=closed,
                                            subdivisions=subdivisions)
    if offsets_xy_m is not None:
        offsets = np.asarray(offsets_xy_m, dtype=float).reshape(-1, 2)
        n_points = len(points)
        triangles = np.vstack([triangles + k * n_points for k in range(len(offsets))])
        points = np.vstack([points + [x, y, 0.0] for x, y in offsets])
    return points, triangles


def write_cell_stl(path: str | Path, cell: HexCell, top_z_m: float | None = None,
                   closed: bool = True, offsets_xy_m: np.ndarray | None = None,
                   subdivisions: int = 1) -> Path:
    """Write the cell walls as an ASCII STL file (coordinates in m) with meshio.

    The file is written to a temporary name and renamed, so a reader never sees half a mesh.

    Parameters
    ----------
    top_z_m, closed, subdivisions
        As :func:`cell_wall_triangles`.
    offsets_xy_m : ndarray, shape (n_cells, 2), optional
        For several separate cells in one mesh: where each cell's axis is, m (default: one
        cell at the origin). The cells must not overlap.
    """
    import meshio

    path = Path(path)
    points, triangles = cells_wall_triangles(cell, top_z_m=top_z_m, closed=closed,
                                             offsets_xy_m=offsets_xy_m, subdivisions=subdivisions)
    tmp = path.with_name(path.name + ".part")
    meshio.write(tmp, meshio.Mesh(points, [("triangle", triangles)]), file_format="stl",
                 binary=False)
    tmp.replace(path)
    return path


def coupon_cell_count(width_m: float, length_m: float, inscribed_diameter_m: float) -> int:
    """Number of cells of a rectangular coupon, counted as the source study does.

    The source counts ``floor(W/d) * floor(L/d)`` cells (100 mm x 100 mm with d = 4.76 mm
    gives 21 x 21 = 441). A true hexagonal lattice (rows of pitch d spaced d*sqrt(3)/2 apart)
    would hold about 15 % more whole cells (504); the config carries N explicitly so that
    either convention can be used.
    """
    return math.floor(width_m / inscribed_diameter_m) * math.floor(length_m / inscribed_diameter_m)
