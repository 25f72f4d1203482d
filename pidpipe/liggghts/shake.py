"""One case end to end: shake a settled packing in LIGGGHTS, close the energy balance, report C_eq.

The case's record (:class:`pidpipe.measurement.case_record.CaseRecord`, written as JSON
atomically) holds the result with its uncertainty, the whole per-cycle series, the checks that
were made, and every fidelity setting that produced it.
"""

from __future__ import annotations

import math
import platform
import time
from pathlib import Path
from typing import Sequence

import numpy as np

from pidpipe.cases import CaseSpec
from pidpipe.cell.layout import place_packings, side_by_side, write_cells_mesh
from pidpipe.cell.packing import Packing, check_packing, pour_engines
from pidpipe.cell.patch import patch_box
from pidpipe.cell.scene import CellScene
from pidpipe.config.inspection import MovieSettings
from pidpipe.config.settings import ShakeSettings
from pidpipe.liggghts.contact_energy import boundary_elastic_energy
from pidpipe.liggghts.decks import common_values, render
from pidpipe.liggghts.inspection import inspection_record
from pidpipe.liggghts.motion import ENERGY_FILE as MOTION_ENERGY_FILE
from pidpipe.liggghts.motion import WINDOW_FILE as MOTION_WINDOW_FILE
from pidpipe.liggghts.motion import motion_deck_values
from pidpipe.liggghts.movie import DUMP_FILE as MOVIE_DUMP_FILE
from pidpipe.liggghts.movie import movie_deck_values
from pidpipe.liggghts.parsing import CycleSeries, read_cos_sums, read_shake_cycles
from pidpipe.liggghts.process import run_deck
from pidpipe.measurement.case_record import CaseRecord
from pidpipe.measurement.cells import summarise_cells
from pidpipe.measurement.harmonics import harmonics_record, sine_sums_from_wall_work
from pidpipe.measurement.run_record import fidelity_record
from pidpipe.measurement.steady_state import assess_steady_state
from pidpipe.physics.contact import STANDARD_GRAVITY_M_S2, sphere_mass
from pidpipe.physics.equivalent_damping import displacement_amplitude_m
from pidpipe.physics.timestep import HERTZ_FRACTION_LIMIT, TIMESTEP_CHECKS_PER_CYCLE

POWER_FILE = "power.txt"
CELL_POWER_FILE = "cell_power.txt"
HARMONICS_FILE = "harmonics.txt"
CELL_HARMONICS_FILE = "cell_harmonics.txt"
ENERGY_FILE = "energy.txt"
PAIR_CONTACT_FILE = "pair_contacts.dump"
WALL_CONTACT_FILE = "wall_contacts.dump"
MESH_FILE = "cell.stl"
LEDGER_TOLERANCE = 1e-4
"""Largest mismatch, per cycle, between the mesh's wall work and the sum of the cells', as a
fraction of the gross work exchanged (both are written with 6 digits)."""
def render_shake_deck(settings: ShakeSettings, case: CaseSpec,
                      packings: Packing | Sequence[Packing], workdir: Path,
                      movie: MovieSettings | None = None, mesh_subdivisions: int = 1) -> dict:
    """Write the cells' wall mesh and the shake deck of a case; return the run's plan.

    Parameters
    ----------
    settings : ShakeSettings
        The cell, materials, fidelity and sampling of the case.
    case : CaseSpec
    packings : Packing or sequence of Packing
        One packing per cell; several cells are laid out side by side
        (:mod:`pidpipe.cell.layout`).
    workdir : Path
    movie : MovieSettings, optional
        Dump a movie (:mod:`pidpipe.liggghts.movie`); off if None. The bed's motion within the
        cycle is sampled as ``settings.motion`` says (:mod:`pidpipe.liggghts.motion`; off if
        None). With both off the deck is the plain shake deck.
    mesh_subdivisions : int
        Pieces each hexagon side of the wall mesh is cut into (1: the mesh every run uses; more
        only to measure what the edges of a flat face do,
        :func:`pidpipe.cell.geometry.cell_wall_triangles`).

    Returns
    -------
    dict
        ``deck``, ``period_s``, ``steps_per_cycle``, ``cycles``, ``timestep`` (a TimestepPlan),
        ``amplitude_m``, ``layout`` (a CellLayout), ``scene`` (the CellScene), ``cells``,
        ``motion`` and ``movie`` (the deck's values of each, or None).
    """
    packings = as_packing_list(packings)
    scene = CellScene.of(settings)
    cell = scene.cell
    plan = scene.timestep(case.freq_hz)
    period = 1.0 / case.freq_hz
    omega = 2.0 * math.pi * case.freq_hz
    amplitude = displacement_amplitude_m(case.freq_hz, case.accel_g)
    cycles = settings.sampling.transient_cycles_at(case.freq_hz) + settings.sampling.measured_cycles
    radius = scene.radius_m
    layout = side_by_side(cell, [p.n_spheres for p in packings], radius)
    write_cells_mesh(workdir / MESH_FILE, cell, layout, subdivisions=mesh_subdivisions)
    centres = [p.centres() for p in packings]
    values = common_values(scene, place_packings(layout, centres), plan.timestep_s, MESH_FILE,
                           case.case_id, "shake",
                           patch_box(cell, layout.offsets_m, cell.lid_z_m, 2.0 * amplitude, radius),
                           thermo_every=plan.steps_per_cycle * max(1, cycles // 10))
    # Equal spheres: a cell's centre of mass is the mean centre. Potential energy is measured
    # from its starting height so that the 6 digits fix ave/time writes resolve its changes.
    mass_kg = sphere_mass(scene.particle.radius_m, scene.particle.density_kg_m3)
    cells = [{"group": f"cell{index}", "first_atom_id": first, "last_atom_id": last,
              "potential_reference_z_m": float(np.mean(c[:, 2])),
              "weight_n": len(c) * mass_kg * STANDARD_GRAVITY_M_S2}
             for index, (first, last, c) in enumerate(zip(layout.first_atom_ids,
                                                          layout.last_atom_ids, centres))]
    # One cell's wall power is the mesh's; several need their own (summed from the spheres').
    values.update(amplitude_m=amplitude, period_s=period, omega_rad_s=omega, cells=cells,
                  cell_powers=cells if len(cells) > 1 else [], cell_power_file=CELL_POWER_FILE,
                  velocity_amplitude_m_s=amplitude * omega,
                  steps_per_cycle=plan.steps_per_cycle, total_steps=plan.steps_per_cycle * cycles,
                  power_file=POWER_FILE, energy_file=ENERGY_FILE,
                  harmonics_file=HARMONICS_FILE, cell_harmonics_file=CELL_HARMONICS_FILE,
                  mesh_harmonics=len(cells) == 1,
                  pair_contact_file=PAIR_CONTACT_FILE, wall_contact_file=WALL_CONTACT_FILE,
                  timestep_check_every=max(1, plan.steps_per_cycle // TIMESTEP_CHECKS_PER_CYCLE),
                  rayleigh_fraction_limit=settings.fidelity.timestep_rayleigh_fraction * (1.0 + 1e-6),
                  hertz_fraction_limit=HERTZ_FRACTION_LIMIT)
    motion = settings.motion
    values.update(
        motion=None if motion is None else motion_deck_values(
            motion, plan.steps_per_cycle, cell, radius),
        movie=None if movie is None else movie_deck_values(
            movie, plan.steps_per_cycle, cycles, workdir),
        store_wall_force=motion is not None,
        sphere_power=len(cells) > 1 or motion is not None)
    deck = workdir / "shake.lmp"
    deck.write_text(render("shake.lmp.j2", values), encoding="utf-8")
    return {"deck": deck, "period_s": period, "cycles": cycles, "timestep": plan,
            "steps_per_cycle": plan.steps_per_cycle, "amplitude_m": amplitude, "layout": layout,
            "scene": scene, "cells": cells, "motion": values["motion"], "movie": values["movie"]}



def as_packing_list(packings: Packing | Sequence[Packing]) -> list[Packing]:
    """One packing, or several (one per cell), as a non-empty list."""
    listed = [packings] if isinstance(packings, Packing) else list(packings)
    if not listed:
        raise ValueError("a case needs at least one packing")
    return listed


def checked_packing_list(packings: Packing | Sequence[Packing], case_id: str) -> list[Packing]:
    """:func:`as_packing_list`, each packing checked to fit and to have settled
    (:func:`pidpipe.cell.packing.check_packing`, naming the cell when there are several)."""
    listed = as_packing_list(packings)
    for index, packing in enumerate(listed):
        check_packing(packing, case_id if len(listed) == 1 else f"{case_id} cell {index}")
    return listed


def containment_flags(scene: CellScene, series: CycleSeries, amplitude_m: float) -> list[str]:
    """Flags for spheres found outside the moving cell at any cycle end (escaped or tunnelled)."""
    cell, radius = scene.cell, scene.radius_m
    flags = []
    if np.any(series.lowest_z_m < cell.floor_z_m - 2.0 * amplitude_m + 0.5 * radius):
        flags.append("sphere_below_floor")
    if np.any(series.highest_z_m > cell.lid_z_m - 0.5 * radius):
        flags.append("sphere_above_lid")
    return flags


def timestep_flags(warnings: tuple[str, ...]) -> list[str]:
    """``timestep_check`` if LIGGGHTS warned that the timestep is too large for the run."""
    return ["timestep_check"] if warnings else []


def run_case(settings: ShakeSettings, case: CaseSpec, packings: Packing | Sequence[Packing],
             workdir: str | Path, movie: MovieSettings | None = None,
             movie_dir: str | Path | None = None, mesh_subdivisions: int = 1) -> CaseRecord:
    """Shake one case in LIGGGHTS and return its record.

    Parameters
    ----------
    settings : ShakeSettings
        The cell, materials, fidelity and sampling of the case.
    case : CaseSpec
    packings : Packing or sequence of Packing
        The settled packing of the case's fill and replicate; or one per cell, for k cells side
        by side in one run (:mod:`pidpipe.replicate_cells`), whose mean cell the record reports.
    workdir : path
        The case's own folder (deck, meshes, LIGGGHTS output and screen).
    movie : MovieSettings, optional
        Also write a ParaView movie of the run's last cycles into ``movie_dir``
        (default ``workdir/movie``); off if None.
    movie_dir : path, optional
    mesh_subdivisions : int
        As :func:`render_shake_deck` (1, the default, in every campaign run).

    Returns
    -------
    CaseRecord
        The case record (write it with :meth:`CaseRecord.write`).
    """
    started = time.perf_counter()
    workdir = Path(workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    packings = checked_packing_list(packings, case.case_id)
    for stale in (POWER_FILE, CELL_POWER_FILE, ENERGY_FILE, PAIR_CONTACT_FILE, WALL_CONTACT_FILE, MOTION_WINDOW_FILE,
                  MOTION_ENERGY_FILE, MOVIE_DUMP_FILE, HARMONICS_FILE, CELL_HARMONICS_FILE):
        (workdir / stale).unlink(missing_ok=True)
    plan = render_shake_deck(settings, case, packings, workdir, movie=movie,
                             mesh_subdivisions=mesh_subdivisions)
    engine = run_deck(plan["deck"], case.case_id)
    cells, series, ledger_mismatch = read_cell_series(plan["scene"], plan, workdir)
    sampling = settings.sampling
    configured_transient = sampling.transient_cycles_at(case.freq_hz)
    steady = assess_steady_state(series.dissipated_j, series.energy_j, configured_transient,
                                 sampling.sem_block_cycles)
    transient = steady.transient_cycles
    summary = summarise_cells([cell.dissipated_j[transient:] for cell in cells], case.freq_hz,
                              case.accel_g, settings.coupon_n_cells, sampling.sem_block_cycles)
    for cell_summary, cell, packing in zip(summary["cells"], cells, packings):
        cell_summary.update(seed=packing.seed, n_spheres=packing.n_spheres,
                            pile_height_m=packing.pile_height_m,
                            dissipated_j=cell.dissipated_j.tolist())
    inspection = inspection_record(plan, workdir, case.accel_g, packings, transient,
                                   plan["scene"].cell, settings.motion, movie, movie_dir)
    harmonics = run_harmonics(plan, workdir, case, transient, sampling.sem_block_cycles, summary,
                              cells, series)
    flags = (containment_flags(plan["scene"], series, plan["amplitude_m"])
             + timestep_flags(engine.timestep_warnings) + steady.flags
             + (["ledger_mismatch"] if ledger_mismatch > LEDGER_TOLERANCE else [])
             + harmonics["flags"])
    return CaseRecord.of_run(
        "liggghts", case, packings[0].n_spheres, flags,
        **summary,
        **steady.as_record(),
        **inspection,
        wall_work_cycle_mean_j=float(series.wall_work_j[transient:].mean()) / len(cells),
        ledger_mismatch_of_gross_work=ledger_mismatch,
        cycles=series.as_record(),
        fidelity=fidelity_record(settings, plan["timestep"], transient,
                                 [packing.seed for packing in packings], "liggghts",
                                 configured_transient, packings[0].pile_height_m,
                                 pour_engines(packings)),
        engine={
            "name": "liggghts",
            "solver": "liggghts",
            "version": engine.version,
            "wall_time_s": engine.wall_time_s,
            "cpu_time_s": engine.cpu_time_s,
            "liggghts_version": engine.version,
            "liggghts_wall_time_s": engine.wall_time_s,
            "liggghts_cpu_time_s": engine.cpu_time_s,
            "liggghts_loop_time_s": engine.loop_time_s,
            "steps": engine.steps,
            "host": platform.node(),
        },
        wall_time_s=time.perf_counter() - started,
        harmonics=harmonics,
    )


def read_cell_series(scene: CellScene, plan: dict,
                     workdir: Path) -> tuple[list[CycleSeries], CycleSeries, float]:
    """Each cell's per-cycle balance, elastic energy included, from a shake run's output.

    Returns
    -------
    cells : list of CycleSeries
    mesh : CycleSeries
        All cells together, the wall work from the mesh's force
        (:func:`pidpipe.liggghts.parsing.read_shake_cycles`).
    ledger_mismatch : float
        The largest difference, over the cycles, between the mesh's wall work and the sum of
        the cells', as a fraction of the mean gross work exchanged: within the 6 digits of the
        output when the cells' ledgers are complete (no force between cells).
    """
    layout = plan["layout"]
    boundaries = plan["steps_per_cycle"] * np.arange(plan["cycles"] + 1)
    cell_of_atom = layout.cell_of_atom()
    elastic = boundary_elastic_energy(workdir / PAIR_CONTACT_FILE, workdir / WALL_CONTACT_FILE,
                                      scene, boundaries, cell_of_atom=cell_of_atom)
    cells, mesh = read_shake_cycles(workdir / POWER_FILE, workdir / ENERGY_FILE, plan["period_s"],
                                    plan["cycles"], layout.n_cells, elastic_j=elastic,
                                    cell_power_path=workdir / CELL_POWER_FILE)
    cells_work = np.sum([cell.wall_work_j for cell in cells], axis=0)
    gross = mesh.gross_work_j.mean()
    return cells, mesh, float(np.max(np.abs(cells_work - mesh.wall_work_j)) / gross) if gross > 0 else 0.0


def run_harmonics(plan: dict, workdir: Path, case: CaseSpec, transient: int, block_cycles: int,
                  summary: dict, cells: list[CycleSeries], series: CycleSeries) -> dict:
    """The record's ``harmonics`` (:func:`pidpipe.measurement.harmonics.harmonics_record`): each
    cell's S_c from the harmonics files, its S_s from its wall work
    (:func:`pidpipe.measurement.harmonics.sine_sums_from_wall_work`), against the mean cell's
    energy-based C_eq (``summary``); ``series``, all cells' energies, for a flag's reason."""
    cos_sums = read_cos_sums(workdir / HARMONICS_FILE, workdir / CELL_HARMONICS_FILE,
                             plan["period_s"], plan["cycles"], len(cells))
    omega = 2.0 * math.pi * case.freq_hz
    sin_sums = np.array([sine_sums_from_wall_work(cell.wall_work_j, plan["amplitude_m"], omega,
                                                  plan["timestep"].timestep_s) for cell in cells])
    bed_mass = float(np.mean([cell["weight_n"] for cell in plan["cells"]])) / STANDARD_GRAVITY_M_S2
    return harmonics_record(cos_sums, sin_sums, transient, case.freq_hz, case.accel_g, bed_mass,
                            block_cycles, summary["ceq_cell_ns_m"], summary["ceq_cell_sem_ns_m"],
                            series.energy_j)

