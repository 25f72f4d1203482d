"""Shake a patch of cells in one LIGGGHTS run and report E_d and C_eq per cell and in total.

The campaign shakes a few cells and multiplies the mean cell's C_eq by the coupon's N cells.
This module runs the same case on a patch of cells (rings of 7, 19, ... cells, or the whole
coupon), each cell holding its own packing, so that the claim can be measured (the scene study,
:mod:`pidpipe.studies.scene`).

Two ledgers are kept. The whole patch's balance is the one of the single-cell case (mesh force
times wall velocity, minus the change of the spheres' energy; :func:`pidpipe.liggghts.parsing.read_cycles`).
Per cell, the wall work comes from the cell's momentum (:func:`pidpipe.liggghts.parsing.cell_cycles`);
the sum over cells must match the mesh ledger, which the record reports.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from pidpipe.cell.packing import Packing, check_packing
from pidpipe.cell.patch import (
    patch_box,
    place_in_cells,
    spheres_in_own_cells,
    write_patch_stl,
)
from pidpipe.cell.scene import CellScene
from pidpipe.config.settings import ShakeSettings
from pidpipe.liggghts.decks import common_values, render
from pidpipe.liggghts.parsing import (
    SPHERE_COLUMNS,
    CycleSeries,
    cell_cycles,
    read_cycles,
    read_dump_frames,
)
from pidpipe.liggghts.process import run_deck
from pidpipe.measurement.cells import per_cell_ceq
from pidpipe.measurement.statistics import summarise_cycles
from pidpipe.physics.contact import STANDARD_GRAVITY_M_S2
from pidpipe.physics.equivalent_damping import displacement_amplitude_m

POWER_FILE = "power.txt"

ENERGY_FILE = "energy.txt"

SPHERE_FILE = "spheres.dump"

MESH_FILE = "patch.stl"

CONTAINMENT_TOL_RADII = 0.02
"""A sphere counts as inside its cell if it pokes through no wall by more than this many radii
(contact overlaps are micrometres; a sphere in the wrong cell is off by more than a radius)."""


def render_patch_deck(settings: ShakeSettings, freq_hz: float, accel_g: float, packings: list[Packing],
                      centres_m: np.ndarray, workdir: Path, label: str,
                      flip_normals: bool = False) -> dict:
    """Write the patch mesh and deck; return the run's plan.

    Parameters
    ----------
    settings : ShakeSettings
        The cell, materials, fidelity and sampling (measured cycles, SEM blocks).
    freq_hz, accel_g : float
        Excitation frequency (Hz) and acceleration amplitude (g).
    packings : list of Packing
        One settled packing per cell, in the cell frame.
    centres_m : ndarray, shape (n_cells, 2)
        Cell centres, m (:mod:`pidpipe.cell.patch`).
    workdir : Path
    label : str
        Names the run in the deck and in error messages (letters, digits, _ and .).
    flip_normals : bool
        Write every wall triangle reversed (:func:`pidpipe.cell.patch.write_patch_stl`).

    Returns
    -------
    dict
        ``deck``, ``period_s``, ``cycles``, ``transient_cycles``, ``timestep`` (TimestepPlan),
        ``amplitude_m``, ``cell_index`` (ndarray of the cell of each sphere, in atom-id order).
    """
    scene = CellScene.of(settings)
    cell, radius = scene.cell, scene.radius_m
    plan = scene.timestep(freq_hz)
    omega = 2.0 * math.pi * freq_hz
    amplitude = displacement_amplitude_m(freq_hz, accel_g)
    transient = settings.sampling.transient_cycles_at(freq_hz)
    cycles = transient + settings.sampling.measured_cycles
    positions, cell_index = place_in_cells([p.centres() for p in packings], centres_m)
    write_patch_stl(workdir / MESH_FILE, cell, centres_m, flip_normals=flip_normals)
    values = common_values(scene, positions, plan.timestep_s, MESH_FILE, label, "patch",
                           patch_box(cell, centres_m, cell.lid_z_m, 2.0 * amplitude, radius),
                           thermo_every=plan.steps_per_cycle * max(1, cycles // 10))
    values.update(amplitude_m=amplitude, period_s=1.0 / freq_hz, omega_rad_s=omega,
                  floor_z_m=cell.floor_z_m, velocity_amplitude_m_s=amplitude * omega,
                  acceleration_amplitude_m_s2=amplitude * omega**2,
                  steps_per_cycle=plan.steps_per_cycle, total_steps=plan.steps_per_cycle * cycles,
                  power_file=POWER_FILE, energy_file=ENERGY_FILE, sphere_file=SPHERE_FILE)
    deck = workdir / "patch.lmp"
    deck.write_text(render("patch.lmp.j2", values), encoding="utf-8")
    return {"deck": deck, "period_s": 1.0 / freq_hz, "cycles": cycles, "transient_cycles": transient,
            "timestep": plan, "amplitude_m": amplitude, "cell_index": cell_index}


def run_patch(settings: ShakeSettings, freq_hz: float, accel_g: float, packings: list[Packing],
              centres_m: np.ndarray, workdir: str | Path, label: str,
              flip_normals: bool = False) -> dict:
    """Shake a patch of cells in one LIGGGHTS run; per-cell and whole-patch E_d and C_eq.

    Parameters
    ----------
    settings, freq_hz, accel_g, packings, centres_m, label, flip_normals
        As :func:`render_patch_deck`.
    workdir : path
        The run's own folder.

    Returns
    -------
    dict
        ``cells``: one summary per cell (:func:`pidpipe.measurement.statistics.summarise_cycles` with N = 1,
        plus ``seed``, ``n_spheres``, ``energy_drift_fraction``, ``flags``);
        ``total``: the whole patch's summary from the mesh ledger (C_eq of the patch, N = 1);
        ``per_cell``: C_eq per cell with two standard errors (see :func:`per_cell_ceq`);
        ``ledger_mismatch``: sum of per-cell wall work minus the mesh ledger's, per measured
        cycle, as a fraction of the mean gross work exchanged and of the mean E_d;
        ``contained``: whether every sphere was inside its own cell at every cycle end;
        ``total_dissipated_j`` (mesh ledger) and ``cell_dissipated_j`` (per cell): E_d of each
        measured cycle, J;
        ``engine``: LIGGGHTS' CPU, wall and loop time and steps; ``cell_cycles``: cells x
        cycles run; plus the case and fidelity.
    """
    started = time.perf_counter()
    workdir = Path(workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    if len(packings) != len(centres_m):
        raise ValueError(f"{len(packings)} packings for {len(centres_m)} cells")
    for index, packing in enumerate(packings):
        check_packing(packing, f"{label} cell {index}")
    for stale in (POWER_FILE, ENERGY_FILE, SPHERE_FILE):
        (workdir / stale).unlink(missing_ok=True)
    plan = render_patch_deck(settings, freq_hz, accel_g, packings, centres_m, workdir, label,
                             flip_normals)
    engine = run_deck(plan["deck"], label)
    scene = CellScene.of(settings)
    cell, radius = scene.cell, scene.radius_m
    total = read_cycles(workdir / POWER_FILE, workdir / ENERGY_FILE, plan["period_s"], plan["cycles"])
    steps, frames = read_dump_frames(workdir / SPHERE_FILE, len(SPHERE_COLUMNS))
    per_cell = cell_cycles(steps, frames, plan["cell_index"], plan["period_s"], plan["cycles"],
                           STANDARD_GRAVITY_M_S2, cell.floor_z_m)
    contained = [spheres_in_own_cells(cell, centres_m, frame[:, 1:4], plan["cell_index"], radius,
                                      CONTAINMENT_TOL_RADII * radius) for frame in frames]
    transient = plan["transient_cycles"]
    block = settings.sampling.sem_block_cycles
    cells = [{"cell": index, "seed": packing.seed, "n_spheres": packing.n_spheres,
              **summarise_cycles(series.dissipated_j[transient:], freq_hz, accel_g, 1, block),
              "energy_drift_fraction": energy_drift(series, transient)}
             for index, (series, packing) in enumerate(zip(per_cell, packings))]
    whole = summarise_cycles(total.dissipated_j[transient:], freq_hz, accel_g, 1, block)
    summed_work = np.sum([s.wall_work_j for s in per_cell], axis=0)
    mismatch = (summed_work - total.wall_work_j)[transient:]
    return {
        "label": label, "freq_hz": freq_hz, "accel_g": accel_g,
        "fill_pct": packings[0].fill_pct, "n_cells": len(packings),
        "n_spheres": int(sum(p.n_spheres for p in packings)),
        "cells": cells,
        "total": {**whole, "energy_drift_fraction": energy_drift(total, transient)},
        "per_cell": per_cell_ceq([c["ceq_cell_ns_m"] for c in cells], whole),
        "ledger_mismatch": {
            "of_gross_work": float(mismatch.mean() / total.gross_work_j[transient:].mean()),
            "of_dissipation": float(mismatch.mean() / total.dissipated_j[transient:].mean()),
            "largest_cycle_of_gross_work": float(np.abs(mismatch).max()
                                                 / total.gross_work_j[transient:].mean()),
        },
        "contained": bool(np.all(contained)),
        "total_dissipated_j": total.dissipated_j[transient:].tolist(),
        "cell_dissipated_j": [series.dissipated_j[transient:].tolist() for series in per_cell],
        "transient_cycles": transient, "measured_cycles": plan["cycles"] - transient,
        "timestep": plan["timestep"].as_record(),
        "cell_cycles": len(packings) * plan["cycles"],
        "engine": {"cpu_time_s": engine.cpu_time_s, "wall_time_s": engine.wall_time_s,
                   "loop_time_s": engine.loop_time_s, "steps": engine.steps,
                   "liggghts_version": engine.version},
        "wall_time_s": time.perf_counter() - started,
    }


def energy_drift(series: CycleSeries, transient_cycles: int) -> float:
    """(E at the start - E at the end of the measured cycles) / their total E_d (NaN if <= 0).

    The share of the measured dissipation that came from stored energy rather than from the
    walls: near 0 in steady state (as the single-cell case's drift check).
    """
    total = float(series.dissipated_j[transient_cycles:].sum())
    if total <= 0.0:
        return float("nan")
    return float(series.energy_j[transient_cycles] - series.energy_j[-1]) / total
