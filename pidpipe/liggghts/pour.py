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

from pathlib import Path

import numpy as np

from pidpipe.cell.geometry import write_cell_stl
from pidpipe.cell.packing import MAX_FURTHER_SETTLING, SETTLED_SPEED_M_S, Packing
from pidpipe.cell.pour_protocol import (  # noqa: F401  (the protocol's constants, named here too)
    TAP_ACCEL_G,
    TAP_CYCLES,
    TAP_FREQ_HZ,
    plan_pour,
    settled_packing,
)
from pidpipe.config.settings import PourSettings
from pidpipe.errors import EngineError
from pidpipe.liggghts.decks import common_values, render, simulation_box
from pidpipe.liggghts.parsing import read_dump_atoms
from pidpipe.liggghts.process import run_deck

ENGINE_NAME = "liggghts"
"""The value of ``fidelity.pour_engine`` that selects this pour, recorded in its packings."""


def pour(settings: PourSettings, fill_pct: float, replicate: int, workdir: str | Path) -> Packing:
    """Pour the spheres of a fill level into the cell with LIGGGHTS and return the settled packing.

    The protocol is :mod:`pidpipe.cell.pour_protocol`'s (:func:`~pidpipe.cell.pour_protocol.plan_pour`).

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
    plan = plan_pour(settings, fill_pct, replicate)
    scene, cell, radius = plan.scene, plan.scene.cell, plan.scene.radius_m
    write_cell_stl(workdir / "pour_cell.stl", cell, top_z_m=plan.top_z_m, closed=False)
    steps = plan.settle_steps
    values = common_values(scene, plan.start_m, plan.timestep.timestep_s, "pour_cell.stl",
                           plan.label, "pack",
                           simulation_box(cell, plan.top_z_m, 2.0 * plan.tap_amplitude_m, radius),
                           thermo_every=max(1, steps // 10))
    values.update(settle_steps=steps, output_file="settled.dump", further_settling=[],
                  tap_amplitude_m=plan.tap_amplitude_m, tap_period_s=1.0 / TAP_FREQ_HZ,
                  tap_steps=plan.tap_steps)
    deck = workdir / "pour.lmp"
    deck.write_text(render("pack.lmp.j2", values), encoding="utf-8")
    output = workdir / "settled.dump"
    output.unlink(missing_ok=True)
    run_deck(deck, plan.label)
    atoms = read_dump_atoms(output)
    chunks = 1
    if MAX_FURTHER_SETTLING > 0 and _max_speed(atoms) > SETTLED_SPEED_M_S:
        atoms, chunks = _settle_further(deck, values, steps, atoms, plan.label)
    return settled_packing(plan, atoms[:, 1:4], atoms[:, 4:7], chunks, ENGINE_NAME)


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
