"""A settled packing of spheres in the closed cell: its data, its checks, and its JSON file.

The packing is poured by LIGGGHTS (:mod:`pidpipe.liggghts.pour`) or the compiled DEM
(:mod:`pidpipe.dem.pour`), by the same protocol (:mod:`pidpipe.cell.pour_protocol`). When the settled pile rises
above the lid the case is refused (:class:`~pidpipe.errors.PackingError`) before any shaking
run, with the sphere count and the pile height it needs; a pour still moving after its
settling is refused too (:func:`check_packing`). The same seed gives the same packing.
"""

from __future__ import annotations

import json
import os
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from pidpipe.cell.geometry import HexCell
from pidpipe.errors import PackingError, ParseError

DEPOSITION_GAP_FRACTION = 0.02
"""Gap left above each deposited sphere, as a fraction of the radius (so nothing overlaps)."""

SETTLED_SPEED_M_S = 5e-3
"""A packing counts as settled when no sphere moves faster than this at the end, m/s."""

MAX_FURTHER_SETTLING = 4
"""Chunks of ``fidelity.settle_time_s`` that a pour not settled after the configured settle time
goes on settling, at most. Of 441 pours of the default config at 50 % fill (seeds
fidelity.seed + 0 .. 440) two had not settled after 0.15 s (fastest sphere 5.5 and 7.7 mm/s);
one further chunk settled both (below 0.1 mm/s)."""


@dataclass(frozen=True)
class Packing:
    """A settled packing of one cell.

    Attributes
    ----------
    positions_m : list of [x, y, z]
        Sphere centres in the cell frame, m (floor at z = -h/2).
    radius_m : float
    n_spheres : int
    seed : int
    pile_height_m : float
        Top of the highest sphere above the floor, m.
    lid_height_m : float
        Core height h, m.
    max_speed_m_s : float
        Largest sphere speed when the pour ended, m/s.
    settle_time_s : float
        How long the pile settled after tapping, s: ``fidelity.settle_time_s`` (rounded to whole
        steps), or a whole multiple of it when the pour needed further settling.
    fill_pct : float
    pour_engine : str
        The engine that poured it, ``liggghts`` or ``dem`` (``fidelity.pour_engine``); files
        written before the DEM could pour have no such key and were poured by LIGGGHTS.
    """

    positions_m: list
    radius_m: float
    n_spheres: int
    seed: int
    pile_height_m: float
    lid_height_m: float
    max_speed_m_s: float
    settle_time_s: float
    fill_pct: float
    pour_engine: str = "liggghts"

    @property
    def fits(self) -> bool:
        """Whether the settled pile stays below the lid."""
        return self.pile_height_m <= self.lid_height_m

    def centres(self) -> np.ndarray:
        """Sphere centres, shape (n_spheres, 3), m."""
        return np.asarray(self.positions_m, dtype=float).reshape(-1, 3)


def random_start(cell: HexCell, n_spheres: int, radius_m: float, seed: int) -> np.ndarray:
    """Non-overlapping start positions by random sequential deposition, from a seed.

    Each sphere in turn gets a random (x, y) inside the hexagon (shrunk by its radius) and is
    lowered along z until it meets the floor or a sphere already placed, then lifted by a small
    gap. The result is a loose pile close to a settled one, so the pour settles quickly.

    Parameters
    ----------
    cell : HexCell
    n_spheres : int
    radius_m : float
    seed : int

    Returns
    -------
    ndarray, shape (n_spheres, 3)
        Centres in the cell frame, m.
    """
    rng = np.random.default_rng(seed)
    normals, offsets = cell.planes()
    side_n, side_c = normals[:6, :2], offsets[:6]
    gap = DEPOSITION_GAP_FRACTION * radius_m
    reach = cell.circumradius_m
    placed = np.empty((0, 3))
    while len(placed) < n_spheres:
        xy = rng.uniform(-reach, reach, size=2)
        if np.any(side_n @ xy + side_c < radius_m + gap):
            continue
        z = cell.floor_z_m + radius_m + gap
        if placed.size:
            horizontal = np.linalg.norm(placed[:, :2] - xy, axis=1)
            below = horizontal < 2.0 * radius_m + gap
            if np.any(below):
                rise = np.sqrt((2.0 * radius_m + gap) ** 2 - horizontal[below] ** 2)
                z = max(z, float(np.max(placed[below, 2] + rise)))
        placed = np.vstack([placed, [xy[0], xy[1], z]])
    return placed


def reusable(packing: Packing, seed: int, n_spheres: int, pour_engine: str) -> bool:
    """Whether a packing kept from an earlier pour is the one the settings would pour now.

    The same seed, sphere count and pour engine: the two engines integrate the same protocol
    differently, so a packing poured by the other engine is poured again, not reused.
    """
    return (packing.seed == seed and packing.n_spheres == n_spheres
            and packing.pour_engine == pour_engine)


def pour_engines(packings) -> str:
    """The engine(s) that poured some packings, for a record: ``liggghts``, ``dem`` or, should
    a run mix them, both joined by ``+``."""
    return "+".join(sorted({packing.pour_engine for packing in packings}))


def check_packing(packing: Packing, case_label: str) -> None:
    """Refuse a packing that does not fit below the lid or has not settled.

    A packing from :func:`pour` that has not settled has already settled for the configured
    settle time and :data:`MAX_FURTHER_SETTLING` more periods of it.
    """
    if not packing.fits:
        raise PackingError(
            f"case {case_label}: {packing.n_spheres} spheres do not fit in the cell: poured, they "
            f"settle into a pile {packing.pile_height_m * 1e3:.1f} mm high, and the lid is at "
            f"{packing.lid_height_m * 1e3:.1f} mm. Lower the fill, or use fill.definition "
            "poured_capacity (config.yaml)")
    if packing.max_speed_m_s > SETTLED_SPEED_M_S:
        raise PackingError(
            f"case {case_label}: the poured spheres had not settled after {packing.settle_time_s:.3g} s "
            f"of settling, fidelity.settle_time_s and up to {MAX_FURTHER_SETTLING} more periods of "
            f"it (fastest sphere {packing.max_speed_m_s:.3g} m/s > {SETTLED_SPEED_M_S} m/s); raise "
            "fidelity.settle_time_s")


def save_packing(packing: Packing, path: str | Path) -> Path:
    """Write a packing as JSON, atomically (temporary file, then rename)."""
    path = Path(path)
    tmp = path.with_name(path.name + ".part")
    tmp.write_text(json.dumps(asdict(packing), indent=1), encoding="utf-8")
    os.replace(tmp, path)
    return path


def load_packing(path: str | Path) -> Packing:
    """Read a packing written by :func:`save_packing`."""
    try:
        data = json.loads(Path(path).read_text(encoding="utf-8"))
        return Packing(**data)
    except (OSError, ValueError, TypeError) as exc:
        raise ParseError(f"packing file {path} cannot be read: {exc}") from None
