"""The VTK movie writer: what ParaView would open, read back with meshio."""

import meshio
import numpy as np
import pytest

from pidpipe.cell.geometry import HexCell, cells_wall_triangles
from pidpipe.cell.vtk_series import read_pvd, write_vtk_series


def test_series_holds_every_frame_sphere_and_the_moving_walls(tmp_path):
    rng = np.random.default_rng(0)
    frames, spheres = 6, 4
    times = np.arange(frames) * 1e-4
    positions = rng.normal(size=(frames, spheres, 3)) * 1e-3
    velocities = rng.normal(size=(frames, spheres, 3))
    spins = rng.normal(size=(frames, spheres, 3)) * 100
    cell = HexCell(inscribed_diameter_m=4.76e-3, height_m=25.4e-3)
    points, triangles = cells_wall_triangles(cell, offsets_xy_m=[[0.0, 0.0], [0.01, 0.0]])
    wall_z = 1e-4 * (np.cos(2 * np.pi * times / 6e-4) - 1.0)
    pvd = write_vtk_series(tmp_path / "movie", times, positions, velocities, spins,
                           np.full(spheres, 1.25e-3), np.arange(1, spheres + 1), [0, 0, 1, 1],
                           points, triangles, wall_z)
    entries = read_pvd(pvd)
    assert [(t, part) for t, part, _ in entries] == [(t, p) for t in times for p in (0, 1)]
    for frame, (time, part, path) in enumerate(entries[::2]):
        mesh = meshio.read(path)
        assert len(mesh.points) == spheres
        np.testing.assert_allclose(mesh.points, positions[frame])
        np.testing.assert_allclose(mesh.point_data["velocity_m_s"], velocities[frame])
        np.testing.assert_allclose(mesh.point_data["spin_rad_s"], spins[frame])
        assert list(mesh.point_data["cell"]) == [0, 0, 1, 1]
    for frame, (time, part, path) in enumerate(entries[1::2]):
        walls = meshio.read(path)
        np.testing.assert_allclose(walls.points - points, np.tile([0.0, 0.0, wall_z[frame]], (len(points), 1)),
                                   atol=1e-15)
        assert walls.cells_dict["triangle"].shape == triangles.shape


def test_bad_shapes_are_refused_and_nothing_is_left_behind(tmp_path):
    with pytest.raises(ValueError, match="shape"):
        write_vtk_series(tmp_path / "movie", [0.0, 1.0], np.zeros((3, 2, 3)), np.zeros((3, 2, 3)),
                         np.zeros((3, 2, 3)), 1.0, [1, 2], [0, 0], np.zeros((3, 3)), [[0, 1, 2]], [0, 0])
    assert list(tmp_path.iterdir()) == []
