import math

import meshio
import numpy as np
import pytest

from pidpipe.cell.geometry import (
    HexCell,
    cell_wall_triangles,
    coupon_cell_count,
    triangle_normals,
    write_cell_stl,
)

CELL = HexCell(4.76e-3, 25.4e-3)


def _edges(triangles):
    edges = {}
    for tri in triangles:
        for a, b in ((tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0])):
            edges.setdefault(tuple(sorted((a, b))), []).append((a, b))
    return edges


def test_mesh_is_closed_and_consistently_oriented():
    _, triangles = cell_wall_triangles(CELL)
    for key, uses in _edges(triangles).items():
        assert len(uses) == 2, f"edge {key} is used by {len(uses)} triangles"
        assert uses[0] != uses[1], f"edge {key} is traversed the same way twice"


def test_normals_face_inward():
    points, triangles = cell_wall_triangles(CELL)
    normals = triangle_normals(points, triangles)
    centroids = points[triangles].mean(axis=1)
    # the cell is convex and contains the origin: inward normals point towards it
    assert np.all(np.einsum("ij,ij->i", normals, -centroids) > 0)


def test_enclosed_volume_and_inscribed_diameter():
    points, triangles = cell_wall_triangles(CELL)
    a, b, c = (points[triangles[:, k]] for k in range(3))
    # divergence theorem with inward normals: the signed volume comes out negative
    volume = -np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0
    assert volume == pytest.approx(CELL.volume_m3, rel=1e-12)
    assert CELL.volume_m3 == pytest.approx(math.sqrt(3) / 2 * 4.76e-3**2 * 25.4e-3, rel=1e-12)
    normals, offsets = CELL.planes()
    assert np.allclose(offsets[:6] * 2, 4.76e-3)
    assert np.allclose(np.linalg.norm(normals, axis=1), 1.0)
    assert CELL.circumradius_m == pytest.approx(4.76e-3 / math.sqrt(3))


def test_no_vertex_inside_a_face():
    points, _ = cell_wall_triangles(CELL)
    radial = np.linalg.norm(points[:, :2], axis=1)
    assert np.allclose(radial, CELL.circumradius_m)


def test_stl_round_trip(tmp_path):
    path = write_cell_stl(tmp_path / "cell.stl", CELL)
    mesh = meshio.read(path)
    assert mesh.cells_dict["triangle"].shape == (20, 3)
    assert not (tmp_path / "cell.stl.part").exists()


def test_open_pouring_cell_has_no_lid():
    points, triangles = cell_wall_triangles(CELL, top_z_m=0.05, closed=False)
    assert len(triangles) == 16
    assert points[:, 2].max() == pytest.approx(0.05)


def test_contains_spheres():
    inside = CELL.contains_spheres(np.array([[0, 0, 0], [0, 2.0e-3, 0], [0, 0, 12.0e-3]]), 1.25e-3)
    assert inside.tolist() == [True, False, False]


def test_coupon_cell_count_matches_source():
    assert coupon_cell_count(0.1, 0.1, 4.76e-3) == 441


@pytest.mark.parametrize("bad", [0.0, -1.0, float("nan"), "5"])
def test_bad_cell_dimensions_rejected(bad):
    with pytest.raises(ValueError, match="positive finite"):
        HexCell(bad, 25.4e-3)


@pytest.mark.parametrize("n", [2, 4])
def test_subdivided_walls_are_the_same_closed_surface_without_a_vertex_inside_a_face(n):
    points, triangles = cell_wall_triangles(CELL, subdivisions=n)
    assert len(points) == 12 * n
    assert len(triangles) == 12 * n + 2 * (6 * n - 2)
    for key, uses in _edges(triangles).items():
        assert len(uses) == 2, f"edge {key} is used by {len(uses)} triangles"
        assert uses[0] != uses[1], f"edge {key} is traversed the same way twice"
    normals = triangle_normals(points, triangles)
    centroids = points[triangles].mean(axis=1)
    assert np.all(np.einsum("ij,ij->i", normals, -centroids) > 0)
    a, b, c = (points[triangles[:, k]] for k in range(3))
    assert np.all(np.linalg.norm(np.cross(b - a, c - a), axis=1) > 1e-3 * CELL.area_m2)
    volume = -np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0
    assert volume == pytest.approx(CELL.volume_m3, rel=1e-12)
    # every vertex lies on the hexagon's boundary: on (at least) one side wall's plane
    normals8, offsets8 = CELL.planes()
    distance = points @ normals8[:6].T + offsets8[:6]
    assert np.all(np.min(np.abs(distance), axis=1) < 1e-12)


def test_one_subdivision_is_the_campaigns_mesh_and_a_bad_count_is_refused():
    default = cell_wall_triangles(CELL)
    explicit = cell_wall_triangles(CELL, subdivisions=1)
    assert np.array_equal(default[0], explicit[0]) and np.array_equal(default[1], explicit[1])
    for bad in (0, 1.5):
        with pytest.raises(ValueError, match="subdivisions"):
            cell_wall_triangles(CELL, subdivisions=bad)
