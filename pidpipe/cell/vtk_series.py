"""A time series of spheres and the moving cell as VTK files that ParaView opens directly.

:func:`write_vtk_series` takes plain arrays (any engine's frames) and writes, into one folder,
one ``.vtu`` file per frame for the spheres (vertex cells with point data ``velocity_m_s``,
``spin_rad_s``, ``radius_m``, ``id`` and ``cell``) and one per frame for the cell walls (the
wall mesh moved by the frame's wall displacement), via meshio, and a ``movie.pvd`` collection
that lists them with their times (``part`` 0 the spheres, 1 the walls). In ParaView: open
``movie.pvd``, then a Glyph filter (sphere, scale by ``radius_m``, scale factor 2) on the spheres.

The folder is written under a temporary name and renamed when complete: a reader never sees
half a series.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

PVD_FILE = "movie.pvd"


def write_vtk_series(directory: str | Path, times_s, positions_m, velocities_m_s, spins_rad_s,
                     radii_m, ids, cell_of_sphere, wall_points_m, wall_triangles,
                     wall_z_m) -> Path:
    """Write the spheres and the moving walls, frame by frame, as a ParaView time series.

    Parameters
    ----------
    directory : path
        The folder to write (replaced if it exists).
    times_s : array_like, shape (n_frames,)
        Time of each frame, s.
    positions_m, velocities_m_s, spins_rad_s : array_like, shape (n_frames, n_spheres, 3)
        Sphere centres (m), velocities (m/s) and angular velocities (rad/s).
    radii_m : array_like, shape (n_spheres,)
        Sphere radii, m.
    ids, cell_of_sphere : array_like of int, shape (n_spheres,)
        Each sphere's id and the cell it is in.
    wall_points_m : array_like, shape (n_points, 3)
        The wall mesh's vertices at rest, m.
    wall_triangles : array_like of int, shape (n_triangles, 3)
    wall_z_m : array_like, shape (n_frames,)
        The walls' displacement along z at each frame, m (the mesh moves rigidly).

    Returns
    -------
    Path
        The ``.pvd`` file.
    """
    import meshio

    times = np.asarray(times_s, dtype=float).reshape(-1)
    positions = np.asarray(positions_m, dtype=float)
    velocities = np.asarray(velocities_m_s, dtype=float)
    spins = np.asarray(spins_rad_s, dtype=float)
    n_frames = times.size
    if positions.ndim != 3 or positions.shape[0] != n_frames or positions.shape[2] != 3:
        raise ValueError(f"positions must have shape ({n_frames}, n_spheres, 3), got {positions.shape}")
    if velocities.shape != positions.shape or spins.shape != positions.shape:
        raise ValueError("positions, velocities and spins must have the same shape")
    n_spheres = positions.shape[1]
    radii = np.broadcast_to(np.asarray(radii_m, dtype=float), (n_spheres,))
    ids = np.asarray(ids, dtype=np.int64).reshape(n_spheres)
    cells = np.asarray(cell_of_sphere, dtype=np.int64).reshape(n_spheres)
    wall_points = np.asarray(wall_points_m, dtype=float).reshape(-1, 3)
    wall_triangles = np.asarray(wall_triangles, dtype=np.int64).reshape(-1, 3)
    wall_z = np.asarray(wall_z_m, dtype=float).reshape(n_frames)
    vertices = [("vertex", np.arange(n_spheres, dtype=np.int64).reshape(-1, 1))]

    directory = Path(directory)
    tmp = directory.with_name(f".{directory.name}.{os.getpid()}.part")
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir(parents=True)
    try:
        entries = []
        for frame, time in enumerate(times):
            spheres = f"spheres_{frame:05d}.vtu"
            walls = f"walls_{frame:05d}.vtu"
            meshio.write(tmp / spheres, meshio.Mesh(
                positions[frame], vertices,
                point_data={"velocity_m_s": velocities[frame], "spin_rad_s": spins[frame],
                            "radius_m": radii, "id": ids, "cell": cells}), binary=True)
            meshio.write(tmp / walls, meshio.Mesh(wall_points + [0.0, 0.0, wall_z[frame]],
                                                  [("triangle", wall_triangles)]), binary=True)
            entries += [(float(time), 0, spheres), (float(time), 1, walls)]
        lines = ['<?xml version="1.0"?>',
                 '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">',
                 "  <Collection>"]
        lines += [f'    <DataSet timestep="{time!r}" group="" part="{part}" file={quoteattr(name)}/>'
                  for time, part, name in entries]
        lines += ["  </Collection>", "</VTKFile>", ""]
        (tmp / PVD_FILE).write_text("\n".join(lines), encoding="utf-8")
        if directory.exists():
            shutil.rmtree(directory)
        tmp.rename(directory)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return directory / PVD_FILE


def read_pvd(path: str | Path) -> list[tuple[float, int, Path]]:
    """The (time, part, file) entries of a ``.pvd`` collection, in file order."""
    import xml.etree.ElementTree as ElementTree

    path = Path(path)
    root = ElementTree.parse(path).getroot()
    return [(float(entry.get("timestep")), int(entry.get("part", 0)), path.parent / entry.get("file"))
            for entry in root.iter("DataSet")]
