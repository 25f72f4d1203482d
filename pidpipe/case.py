"""One case end to end: shake a settled packing in LIGGGHTS, close the energy balance, report C_eq.

The record a case writes (JSON, atomically) holds the result with its uncertainty, the whole
per-cycle series, the checks that were made, and every fidelity setting that produced it.
"""

from __future__ import annotations

import json
import math
import os
import platform
import time
from pathlib import Path

import numpy as np

from pidpipe.cases import CaseSpec, regime
from pidpipe.config import particle_properties
from pidpipe.contact_energy import boundary_elastic_energy
from pidpipe.damping import displacement_amplitude_m, summarise_cycles
from pidpipe.decks import common_values, render, simulation_box
from pidpipe.engine import run_deck
from pidpipe.fidelity import (HERTZ_FRACTION_LIMIT, TIMESTEP_CHECKS_PER_CYCLE, plan_timestep,
                              transient_cycles_for)
from pidpipe.packing import Packing, cell_from_config, check_packing
from pidpipe.parsing import CycleSeries, read_cycles
from pidpipe.geometry import write_cell_stl
from pidpipe.steady_state import assess_steady_state

POWER_FILE = "power.txt"
ENERGY_FILE = "energy.txt"
PAIR_CONTACT_FILE = "pair_contacts.dump"
WALL_CONTACT_FILE = "wall_contacts.dump"
RECORD_VERSION = 3
"""3: energy_j includes the elastic energy held in the contacts (mechanical_j and elastic_j
keep the parts), and the potential energy is measured from the packing's starting centre of mass."""


def render_shake_deck(config: dict, case: CaseSpec, packing: Packing, workdir: Path) -> dict:
    """Write the closed-cell mesh and the shake deck of a case; return the run's plan.

    Returns
    -------
    dict
        ``deck``, ``period_s``, ``steps_per_cycle``, ``cycles``, ``timestep`` (a TimestepPlan),
        ``amplitude_m``.
    """
    cell = cell_from_config(config)
    fidelity = config["fidelity"]
    plan = plan_timestep(config, case.freq_hz)
    period = 1.0 / case.freq_hz
    omega = 2.0 * math.pi * case.freq_hz
    amplitude = displacement_amplitude_m(case.freq_hz, case.accel_g)
    cycles = transient_cycles_for(config, case.freq_hz) + int(fidelity["measured_cycles"])
    write_cell_stl(workdir / "cell.stl", cell)
    radius = particle_properties(config)["radius_m"]
    values = common_values(config, packing.centres(), plan.timestep_s, "cell.stl", case.case_id,
                           "shake", simulation_box(cell, cell.lid_z_m, 2.0 * amplitude, radius),
                           thermo_every=plan.steps_per_cycle * max(1, cycles // 10))
    # Equal spheres: the centre of mass is the mean centre. Potential energy is measured from
    # its starting height so that the 6 digits fix ave/time writes resolve its changes.
    start_z = float(np.mean(packing.centres()[:, 2]))
    values.update(amplitude_m=amplitude, period_s=period, omega_rad_s=omega,
                  potential_reference_z_m=start_z, velocity_amplitude_m_s=amplitude * omega,
                  steps_per_cycle=plan.steps_per_cycle, total_steps=plan.steps_per_cycle * cycles,
                  power_file=POWER_FILE, energy_file=ENERGY_FILE,
                  pair_contact_file=PAIR_CONTACT_FILE, wall_contact_file=WALL_CONTACT_FILE,
                  timestep_check_every=max(1, plan.steps_per_cycle // TIMESTEP_CHECKS_PER_CYCLE),
                  rayleigh_fraction_limit=fidelity["timestep_rayleigh_fraction"] * (1.0 + 1e-6),
                  hertz_fraction_limit=HERTZ_FRACTION_LIMIT)
    deck = workdir / "shake.lmp"
    deck.write_text(render("shake.lmp.j2", values), encoding="utf-8")
    return {"deck": deck, "period_s": period, "cycles": cycles, "timestep": plan,
            "steps_per_cycle": plan.steps_per_cycle,
            "amplitude_m": amplitude}


def containment_flags(config: dict, series: CycleSeries, amplitude_m: float) -> list[str]:
    """Flags for spheres found outside the moving cell at any cycle end (escaped or tunnelled)."""
    cell = cell_from_config(config)
    radius = particle_properties(config)["radius_m"]
    flags = []
    if np.any(series.lowest_z_m < cell.floor_z_m - 2.0 * amplitude_m + 0.5 * radius):
        flags.append("sphere_below_floor")
    if np.any(series.highest_z_m > cell.lid_z_m - 0.5 * radius):
        flags.append("sphere_above_lid")
    return flags


def timestep_flags(warnings: tuple[str, ...]) -> list[str]:
    """``timestep_check`` if LIGGGHTS warned that the timestep is too large for the run."""
    return ["timestep_check"] if warnings else []


def run_case(config: dict, case: CaseSpec, packing: Packing, workdir: str | Path) -> dict:
    """Shake one case in LIGGGHTS and return its record.

    Parameters
    ----------
    config : dict
        Validated config.
    case : CaseSpec
    packing : Packing
        The settled packing of the case's fill and replicate.
    workdir : path
        The case's own folder (deck, mesh, LIGGGHTS output and screen).

    Returns
    -------
    dict
        The case record (see :func:`write_record`).
    """
    started = time.perf_counter()
    workdir = Path(workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    check_packing(packing, case.case_id)
    for stale in (POWER_FILE, ENERGY_FILE, PAIR_CONTACT_FILE, WALL_CONTACT_FILE):
        (workdir / stale).unlink(missing_ok=True)
    plan = render_shake_deck(config, case, packing, workdir)
    engine = run_deck(plan["deck"], case.case_id)
    boundaries = plan["steps_per_cycle"] * np.arange(plan["cycles"] + 1)
    elastic = boundary_elastic_energy(workdir / PAIR_CONTACT_FILE, workdir / WALL_CONTACT_FILE,
                                      config, boundaries)
    series = read_cycles(workdir / POWER_FILE, workdir / ENERGY_FILE, plan["period_s"],
                         plan["cycles"], elastic_j=elastic)
    fidelity = config["fidelity"]
    configured_transient = transient_cycles_for(config, case.freq_hz)
    steady = assess_steady_state(series.dissipated_j, series.energy_j, configured_transient,
                                 int(fidelity["sem_block_cycles"]))
    transient = steady.transient_cycles
    measured = series.dissipated_j[transient:]
    summary = summarise_cycles(measured, case.freq_hz, case.accel_g,
                               config["geometry"]["coupon_n_cells"], fidelity["sem_block_cycles"])
    flags = (containment_flags(config, series, plan["amplitude_m"])
             + timestep_flags(engine.timestep_warnings) + steady.flags)
    return {
        "record_version": RECORD_VERSION,
        "solver": "liggghts",
        "case_id": case.case_id,
        "freq_hz": case.freq_hz,
        "accel_g": case.accel_g,
        "fill_pct": case.fill_pct,
        "replicate": case.replicate,
        "n_spheres": packing.n_spheres,
        "status": "flagged" if flags else "ok",
        "flags": flags,
        **summary,
        **steady.as_record(),
        "regime": regime(case.accel_g),
        "wall_work_cycle_mean_j": float(series.wall_work_j[transient:].mean()),
        "cycles": series.as_record(),
        "fidelity": {
            **plan["timestep"].as_record(),
            "timestep_rayleigh_fraction_config": fidelity["timestep_rayleigh_fraction"],
            "youngs_modulus_scale": fidelity["youngs_modulus_scale"],
            "transient_cycles": transient,
            "transient_cycles_configured": configured_transient,
            "measured_cycles": int(fidelity["measured_cycles"]),
            "sem_block_cycles": int(fidelity["sem_block_cycles"]),
            "rotation": bool(fidelity["rotation"]),
            "friction": bool(fidelity["friction"]),
            "seed": packing.seed,
            "pile_height_m": packing.pile_height_m,
        },
        "engine": {
            "liggghts_version": engine.version,
            "liggghts_wall_time_s": engine.wall_time_s,
            "liggghts_cpu_time_s": engine.cpu_time_s,
            "liggghts_loop_time_s": engine.loop_time_s,
            "steps": engine.steps,
            "host": platform.node(),
        },
        "wall_time_s": time.perf_counter() - started,
    }


def write_record(record: dict, path: str | Path) -> Path:
    """Write a case record as JSON, atomically and flushed to disk: a reader never sees half a
    file, and an interrupted write leaves no temporary file behind."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.part")
    try:
        with open(tmp, "w", encoding="utf-8") as handle:
            handle.write(json.dumps(record, indent=1, allow_nan=True))
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return path
