"""Patches of honeycomb cells: layouts, the shared-wall mesh, packings placed in their cells."""

import itertools

import meshio
import numpy as np
import pytest

from pidpipe.cell.geometry import HexCell, cell_wall_triangles, triangle_normals
from pidpipe.cell.patch import (
    cell_boundary,
    coupon_centres,
    patch_wall_triangles,
    place_in_cells,
    ring_centres,
    spheres_in_own_cells,
    write_patch_stl,
)

CELL = HexCell(4.76e-3, 25.4e-3)
D = CELL.inscribed_diameter_m


def _pair_distances(centres):
    diff = centres[:, None, :] - centres[None, :, :]
    dist = np.linalg.norm(diff, axis=2)
    return dist[np.triu_indices(len(centres), 1)]


@pytest.mark.parametrize("rings, cells", [(0, 1), (1, 7), (2, 19), (3, 37)])
def test_rings_hold_1_7_19_37_cells_edge_to_edge(rings, cells):
    centres = ring_centres(CELL, rings)
    assert centres.shape == (cells, 2)
    assert np.allclose(centres[0], 0.0)
    if cells > 1:
        distances = _pair_distances(centres)
        assert distances.min() == pytest.approx(D, rel=1e-12)   # no overlap, neighbours touch
        # every cell of the first ring touches the centre cell
        assert np.allclose(np.linalg.norm(centres[1:7], axis=1), D)


def test_coupon_is_21_by_21_cells_about_100_mm_square():
    centres = coupon_centres(CELL, 21, 21)
    assert centres.shape == (441, 2)
    assert _pair_distances(centres).min() == pytest.approx(D, rel=1e-12)
    span = centres.max(axis=0) - centres.min(axis=0) + [2 * CELL.circumradius_m, D]
    assert 0.085 < span[0] < 0.105 and 0.095 < span[1] < 0.105
    # an interior cell has six neighbours at distance d
    middle = centres[10 * 21 + 10]
    assert np.sum(np.isclose(np.linalg.norm(centres - middle, axis=1), D)) == 6


@pytest.mark.parametrize("centres", [ring_centres(CELL, 1), ring_centres(CELL, 2),
                                     coupon_centres(CELL, 4, 3)], ids=["7", "19", "4x3"])
def test_every_cell_is_closed_inward_and_has_the_single_cell_volume(centres):
    points, triangles = patch_wall_triangles(CELL, centres)
    for centre in centres:
        mine = cell_boundary(points, triangles, CELL, centre)
        assert len(mine) == 20
        uses = {}
        for tri in mine:
            for a, b in ((tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0])):
                uses.setdefault(tuple(sorted((a, b))), []).append((a, b))
        assert all(len(u) == 2 and u[0] != u[1] for u in uses.values())   # closed, oriented
        a, b, c = (points[mine[:, k]] - [*centre, 0.0] for k in range(3))
        volume = -np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0
        assert volume == pytest.approx(CELL.volume_m3, rel=1e-9)


def test_shared_walls_are_meshed_once():
    centres = ring_centres(CELL, 2)
    points, triangles = patch_wall_triangles(CELL, centres)
    keys = {tuple(sorted(map(tuple, np.round(points[t] / 1e-9).astype(np.int64)))) for t in triangles}
    assert len(keys) == len(triangles)                      # no triangle twice
    walls = {(min(a, b), max(a, b)) for t in triangles for a, b in itertools.combinations(t, 2)}
    vertical = [w for w in walls if np.allclose(points[w[0], :2], points[w[1], :2])]
    # 19 cells in rings: 72 distinct walls; each wall has one vertical edge at each end
    n_walls = (len(triangles) - 8 * len(centres)) // 2
    assert n_walls == 72 and len(vertical) == len({tuple(np.round(p / 1e-9)) for p in points[:, :2]})


def test_no_vertex_inside_a_face_and_cell_0_is_the_single_cell():
    centres = ring_centres(CELL, 1)
    points, triangles = patch_wall_triangles(CELL, centres)
    radial = np.min(np.linalg.norm(points[:, None, :2] - centres[None], axis=2), axis=1)
    assert np.allclose(radial, CELL.circumradius_m)          # every vertex is a cell corner
    single_points, single_triangles = cell_wall_triangles(CELL)
    patch_cell_0 = {tuple(map(tuple, points[t])) for t in triangles[:20]}
    assert patch_cell_0 == {tuple(map(tuple, single_points[t])) for t in single_triangles}


def test_open_patch_for_pouring_has_no_lids(tmp_path):
    centres = ring_centres(CELL, 1)
    points, triangles = patch_wall_triangles(CELL, centres, top_z_m=0.05, closed=False)
    assert points[:, 2].max() == pytest.approx(0.05)
    assert len(triangles) == 2 * 30 + 4 * 7
    path = write_patch_stl(tmp_path / "patch.stl", CELL, centres)
    assert meshio.read(path).cells_dict["triangle"].shape == (2 * 30 + 8 * 7, 3)
    assert not (tmp_path / "patch.stl.part").exists()


def test_packings_are_placed_in_their_own_cells():
    centres = ring_centres(CELL, 1)
    local = [np.array([[0.0, 0.0, -0.011], [0.5e-3, -0.5e-3, -0.0085]]) for _ in centres]
    positions, owner = place_in_cells(local, centres)
    assert positions.shape == (14, 3) and owner.tolist() == [k for k in range(7) for _ in range(2)]
    assert spheres_in_own_cells(CELL, centres, positions, owner, 1.25e-3).all()
    moved = positions.copy()
    moved[0, :2] = centres[1]                               # a sphere of cell 0 now sits in cell 1
    inside = spheres_in_own_cells(CELL, centres, moved, owner, 1.25e-3)
    assert inside.tolist() == [False] + [True] * 13
    with pytest.raises(ValueError, match="7 packings for 19 cells"):
        place_in_cells(local, ring_centres(CELL, 2))


@pytest.mark.parametrize("bad", [-1, 1.5, True])
def test_bad_ring_count_is_refused(bad):
    with pytest.raises(ValueError, match="rings"):
        ring_centres(CELL, bad)


def test_flipped_patch_mesh_reverses_every_triangle(tmp_path):
    centres = ring_centres(CELL, 1)
    straight = meshio.read(write_patch_stl(tmp_path / "a.stl", CELL, centres))
    flipped = meshio.read(write_patch_stl(tmp_path / "b.stl", CELL, centres, flip_normals=True))
    a = triangle_normals(straight.points, straight.cells_dict["triangle"])
    b = triangle_normals(flipped.points, flipped.cells_dict["triangle"])
    assert np.allclose(a, -b)
