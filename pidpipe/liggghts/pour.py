"""Pouring seeded packings in LIGGGHTS: deposition, tapping and settling in a tall open cell.

Spheres are placed without overlap at random (from the seed) in a tall, open prism of the
cell's hexagon, poured under gravity with LIGGGHTS until they settle, and their settled centres
kept. Pouring into the tall cell and then closing the lid is how a real cell is filled; it is
also the only way to tell whether the spheres fit (:func:`pidpipe.cell.packing.check_packing`).

A pour whose fastest sphere is still above :data:`~pidpipe.cell.packing.SETTLED_SPEED_M_S` after
the configured settle time is not refused at once: the same LIGGGHTS run is repeated and goes
on settling, in chunks of the settle time, up to :data:`MAX_FURTHER_SETTLING` chunks, and the
packing is the state after the first chunk at which it has settled; ``Packing.settle_time_s``
says how long it settled.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from pidpipe.cell.geometry import write_cell_stl
from pidpipe.cell.packing import (
    MAX_FURTHER_SETTLING,
    SETTLED_SPEED_M_S,
    Packing,
    random_start,
)
from pidpipe.cell.scene import CellScene
from pidpipe.config.settings import PourSettings
from pidpipe.errors import EngineError
from pidpipe.liggghts.decks import common_values, render, simulation_box
from pidpipe.liggghts.parsing import read_dump_atoms
from pidpipe.liggghts.process import run_deck
from pidpipe.physics.equivalent_damping import displacement_amplitude_m

TAP_FREQ_HZ = 100.0
"""Frequency of the tapping that compacts a fresh pour, Hz."""

TAP_ACCEL_G = 10.0
"""Acceleration amplitude of the tapping, in g (the top of the reference grid)."""

TAP_CYCLES = 20
"""Cycles of tapping. Without it a deposited pile collapses during measured cycles: measured
at 500 Hz, 5 g, 11 spheres, the potential energy fell by 8 cycles' worth of dissipation
between cycles 35 and 42."""


def pour(settings: PourSettings, fill_pct: float, replicate: int, workdir: str | Path) -> Packing:
    """Pour the spheres of a fill level into the cell with LIGGGHTS and return the settled packing.

    Parameters
    ----------
    settings : PourSettings
        The cell, materials, fidelity, fill definition and pouring settings.
    fill_pct : float
        Fill fraction, percent.
    replicate : int
        Replicate index; the packing seed is ``fidelity.seed + replicate``.
    workdir : path
        Folder for the deck, mesh and output (created; its old contents are overwritten).
    """
    workdir = Path(workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    scene = CellScene.of(settings)
    cell, radius = scene.cell, scene.radius_m
    n_spheres = settings.fill.spheres(fill_pct)
    seed = settings.pouring.seed + int(replicate)
    start = random_start(cell, n_spheres, radius, seed)
    top_z = max(cell.lid_z_m, float(start[:, 2].max()) + 4.0 * radius)
    write_cell_stl(workdir / "pour_cell.stl", cell, top_z_m=top_z, closed=False)
    # One timestep for settling and tapping: a whole number of steps per tapping cycle.
    plan = scene.timestep(TAP_FREQ_HZ)
    target_dt = settings.fidelity.timestep_rayleigh_fraction * plan.rayleigh_time_s
    steps = max(1, math.ceil(settings.pouring.settle_time_s / target_dt))
    label = f"pour_r{fill_pct:g}pct_rep{replicate}"
    amplitude = displacement_amplitude_m(TAP_FREQ_HZ, TAP_ACCEL_G)
    values = common_values(scene, start, plan.timestep_s, "pour_cell.stl", label, "pack",
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


def replicate_packings(settings: PourSettings, fill_pct: float, replicates: int, folder: str | Path,
                       workers: int = 1) -> tuple[list[Packing], dict[int, float]]:
    """The packings of replicates 0 .. replicates-1 of a fill, poured as the campaign pours them.

    Each is :func:`pidpipe.liggghts.pour.pour` (seed = ``fidelity.seed`` + replicate), kept in
    ``folder`` as ``r<fill>pct_rep<k>.json`` and reused on the next call when its seed and
    sphere count still match the settings.

    Parameters
    ----------
    settings : PourSettings
    fill_pct : float
    replicates : int
    folder : path
    workers : int
        LIGGGHTS pours run at the same time (each is one serial process).

    Returns
    -------
    packings : list of Packing
    pour_cpu_s : dict
        CPU time (s) of each pour, by replicate, as measured when it was poured (kept in
        ``folder`` next to the packings).
    """
    from concurrent.futures import ProcessPoolExecutor

    from pidpipe.cases import format_number
    from pidpipe.cell.packing import load_packing

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    paths = [folder / f"r{format_number(fill_pct)}pct_rep{k}.json" for k in range(replicates)]
    wanted = settings.fill.spheres(fill_pct)
    seed = settings.pouring.seed

    def usable(k: int) -> bool:
        if not paths[k].is_file():
            return False
        packing = load_packing(paths[k])
        return packing.seed == seed + k and packing.n_spheres == wanted

    missing = [k for k in range(replicates) if not usable(k)]
    cpu_path = folder / f"r{format_number(fill_pct)}pct_pour_cpu_s.json"
    pour_cpu = ({int(k): v for k, v in json.loads(cpu_path.read_text()).items()}
                if cpu_path.is_file() else {})
    if missing:
        with ProcessPoolExecutor(max_workers=max(1, int(workers))) as pool:
            jobs = [(settings, fill_pct, k, str(paths[k])) for k in missing]
            for k, cpu in zip(missing, pool.map(_pour_one, jobs)):
                pour_cpu[k] = cpu
                cpu_path.write_text(json.dumps(pour_cpu))
    return [load_packing(path) for path in paths], {k: pour_cpu[k] for k in range(replicates)
                                                    if k in pour_cpu}


def _pour_one(job: tuple) -> float:
    """Pour one replicate into a scratch folder, save it; the LIGGGHTS CPU time, s."""
    import resource
    import shutil
    import tempfile

    from pidpipe.cell.packing import save_packing
    settings, fill_pct, replicate, path = job
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    scratch = tempfile.mkdtemp(prefix=f"pour_rep{replicate}_")
    try:
        save_packing(pour(settings, fill_pct, replicate, scratch), path)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
