"""Seeded, settled packings of the spheres of a case inside the closed cell.

Spheres are placed without overlap at random (from the seed) in a tall, open prism of the
cell's hexagon, poured under gravity with LIGGGHTS until they settle, and their settled centres
kept. Pouring into the tall cell and then closing the lid is how a real cell is filled; it is
also the only way to tell whether the spheres fit: when the settled pile rises above the lid
the case is refused (:class:`~pidpipe.errors.PackingError`) before any shaking run, with the
sphere count and the pile height it needs. The same seed gives the same packing.

A pour whose fastest sphere is still above :data:`SETTLED_SPEED_M_S` after the configured
settle time is not refused at once: the same LIGGGHTS run is repeated and goes on settling, in
chunks of the settle time, up to :data:`MAX_FURTHER_SETTLING` chunks, and the packing is the
state after the first chunk at which it has settled; ``Packing.settle_time_s`` says how long it
settled. Only a pour still moving after the last chunk is refused by :func:`check_packing`.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from pidpipe.config import particle_properties, spheres_for_fill
from pidpipe.damping import displacement_amplitude_m
from pidpipe.decks import common_values, render, simulation_box
from pidpipe.engine import run_deck
from pidpipe.errors import EngineError, PackingError, ParseError
from pidpipe.fidelity import plan_timestep
from pidpipe.geometry import HexCell, write_cell_stl

DEPOSITION_GAP_FRACTION = 0.02
"""Gap left above each deposited sphere, as a fraction of the radius (so nothing overlaps)."""
TAP_FREQ_HZ = 100.0
"""Frequency of the tapping that compacts a fresh pour, Hz."""
TAP_ACCEL_G = 10.0
"""Acceleration amplitude of the tapping, in g (the top of the reference grid)."""
TAP_CYCLES = 20
"""Cycles of tapping. Without it a deposited pile collapses during measured cycles: measured
at 500 Hz, 5 g, 11 spheres, the potential energy fell by 8 cycles' worth of dissipation
between cycles 35 and 42."""
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

    @property
    def fits(self) -> bool:
        """Whether the settled pile stays below the lid."""
        return self.pile_height_m <= self.lid_height_m

    def centres(self) -> np.ndarray:
        """Sphere centres, shape (n_spheres, 3), m."""
        return np.asarray(self.positions_m, dtype=float).reshape(-1, 3)


def cell_from_config(config: dict) -> HexCell:
    """The configured honeycomb cell."""
    geo = config["geometry"]
    return HexCell(geo["cell_inscribed_diameter_m"], geo["core_height_m"])


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


def pour(config: dict, fill_pct: float, replicate: int, workdir: str | Path) -> Packing:
    """Pour the spheres of a fill level into the cell with LIGGGHTS and return the settled packing.

    Parameters
    ----------
    config : dict
        Validated config.
    fill_pct : float
        Fill fraction, percent.
    replicate : int
        Replicate index; the packing seed is ``fidelity.seed + replicate``.
    workdir : path
        Folder for the deck, mesh and output (created; its old contents are overwritten).
    """
    workdir = Path(workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    cell = cell_from_config(config)
    radius = particle_properties(config)["radius_m"]
    n_spheres = spheres_for_fill(config, fill_pct)
    seed = int(config["fidelity"]["seed"]) + int(replicate)
    start = random_start(cell, n_spheres, radius, seed)
    top_z = max(cell.lid_z_m, float(start[:, 2].max()) + 4.0 * radius)
    write_cell_stl(workdir / "pour_cell.stl", cell, top_z_m=top_z, closed=False)
    # One timestep for settling and tapping: a whole number of steps per tapping cycle.
    plan = plan_timestep(config, TAP_FREQ_HZ)
    target_dt = config["fidelity"]["timestep_rayleigh_fraction"] * plan.rayleigh_time_s
    steps = max(1, math.ceil(float(config["fidelity"]["settle_time_s"]) / target_dt))
    label = f"pour_r{fill_pct:g}pct_rep{replicate}"
    amplitude = displacement_amplitude_m(TAP_FREQ_HZ, TAP_ACCEL_G)
    values = common_values(config, start, plan.timestep_s, "pour_cell.stl", label, "pack",
                           simulation_box(cell, top_z, 2.0 * amplitude, radius),
                           thermo_every=max(1, steps // 10))
    values.update(settle_steps=steps, output_file="settled.dump", further_settling=[], tap_amplitude_m=amplitude,
                  tap_period_s=1.0 / TAP_FREQ_HZ, tap_steps=TAP_CYCLES * plan.steps_per_cycle)
    deck = workdir / "pour.lmp"
    deck.write_text(render("pack.lmp.j2", values), encoding="utf-8")
    output = workdir / "settled.dump"
    output.unlink(missing_ok=True)
    run_deck(deck, label)
    atoms = read_dump_atoms(output)
    chunks = 1
    if MAX_FURTHER_SETTLING > 0 and _max_speed(atoms) > SETTLED_SPEED_M_S:
        atoms, chunks = _settle_further(deck, values, steps, atoms, label)
    centres, velocities = atoms[:, 1:4], atoms[:, 4:7]
    pile = float(centres[:, 2].max() + radius - cell.floor_z_m)
    return Packing(positions_m=centres.tolist(), radius_m=radius, n_spheres=n_spheres, seed=seed,
                   pile_height_m=pile, lid_height_m=cell.height_m,
                   max_speed_m_s=float(np.linalg.norm(velocities, axis=1).max()),
                   settle_time_s=chunks * steps * plan.timestep_s, fill_pct=float(fill_pct))


def _max_speed(atoms: np.ndarray) -> float:
    """Largest sphere speed of a dump frame (columns id x y z vx vy vz), m/s."""
    return float(np.linalg.norm(atoms[:, 4:7], axis=1).max())


def _settle_further(deck: Path, values: dict, steps: int, first: np.ndarray,
                    label: str) -> tuple[np.ndarray, int]:
    """Run a pour that had not settled again, going on settling; its first settled state.

    The deck is the pour's own with :data:`MAX_FURTHER_SETTLING` chunks of ``steps`` appended
    to the same run, the state dumped after each. LIGGGHTS is deterministic (one process), so
    the run repeats the pour exactly up to the end of the configured settle time (checked: its
    first dump must equal the pour's) and then continues from the full state, velocities,
    spins and contact history included, as one longer pour would.

    Returns
    -------
    atoms : ndarray
        The dump frame after the first chunk at which no sphere is faster than
        :data:`SETTLED_SPEED_M_S`, or after the last chunk if none is.
    chunks : int
        Settle periods the returned state settled for, the configured one included (2 ..
        1 + MAX_FURTHER_SETTLING).
    """
    folder = deck.parent
    further = [{"steps": steps, "output_file": f"settled_more{k}.dump"}
               for k in range(1, MAX_FURTHER_SETTLING + 1)]
    for path in [values["output_file"]] + [chunk["output_file"] for chunk in further]:
        (folder / path).unlink(missing_ok=True)
    deck.write_text(render("pack.lmp.j2", {**values, "further_settling": further}), encoding="utf-8")
    run_deck(deck, label)
    again = read_dump_atoms(folder / values["output_file"])
    if not np.array_equal(again, first):
        raise EngineError(
            f"{label}: LIGGGHTS did not repeat its own pour (the settled state differs between "
            f"two runs of the same deck), so the pour cannot be continued reproducibly; see "
            f"{folder / 'screen.txt'}")
    for chunks, chunk in enumerate(further, start=2):
        atoms = read_dump_atoms(folder / chunk["output_file"])
        if _max_speed(atoms) <= SETTLED_SPEED_M_S:
            break
    return atoms, chunks


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


def read_dump_atoms(path: str | Path) -> np.ndarray:
    """The last frame of a LIGGGHTS ``dump custom`` file, sorted by id; shape (n_atoms, n_columns)."""
    path = Path(path)
    if not path.is_file():
        raise ParseError(f"LIGGGHTS output {path} is missing")
    lines = path.read_text(encoding="utf-8").splitlines()
    starts = [i for i, line in enumerate(lines) if line.startswith("ITEM: ATOMS")]
    if not starts:
        raise ParseError(f"{path} holds no ITEM: ATOMS frame")
    first = starts[-1]
    rows = [line.split() for line in lines[first + 1:] if line.strip()]
    try:
        table = np.array(rows, dtype=float)
    except ValueError:
        raise ParseError(f"{path} has a malformed atom row") from None
    if table.ndim != 2 or not np.all(np.isfinite(table)):
        raise ParseError(f"{path} holds non-finite or ragged atom data")
    return table[np.argsort(table[:, 0])]


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
