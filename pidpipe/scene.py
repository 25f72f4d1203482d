"""Shake a patch of cells in one LIGGGHTS run and report E_d and C_eq per cell and in total.

The campaign shakes one cell and multiplies its C_eq by the coupon's N cells. This module runs
the same case on a patch of cells (rings of 7, 19, ... cells, or the whole coupon), each cell
holding its own packing, so that the claim can be measured: per-cell results of a patch
against the same packings shaken alone, and the scatter from packing to packing.

Two ledgers are kept. The whole patch's balance is the one of the single-cell case (mesh force
times wall velocity, minus the change of the spheres' energy; :func:`pidpipe.parsing.read_cycles`).
Per cell, the wall work comes from the cell's momentum (:func:`pidpipe.parsing.read_cell_cycles`);
the sum over cells must match the mesh ledger, which the record reports.
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

import numpy as np

from pidpipe.config import particle_properties
from pidpipe.damping import displacement_amplitude_m, summarise_cycles
from pidpipe.decks import common_values, render
from pidpipe.engine import run_deck
from pidpipe.fidelity import plan_timestep, transient_cycles_for
from pidpipe.packing import Packing, cell_from_config, check_packing
from pidpipe.contact import STANDARD_GRAVITY_M_S2
from pidpipe.parsing import SPHERE_COLUMNS, CycleSeries, cell_cycles, read_cycles, read_dump_frames
from pidpipe.patch import patch_box, place_in_cells, spheres_in_own_cells, write_patch_stl

POWER_FILE = "power.txt"
ENERGY_FILE = "energy.txt"
SPHERE_FILE = "spheres.dump"
MESH_FILE = "patch.stl"
CONTAINMENT_TOL_RADII = 0.02
"""A sphere counts as inside its cell if it pokes through no wall by more than this many radii
(contact overlaps are micrometres; a sphere in the wrong cell is off by more than a radius)."""


def render_patch_deck(config: dict, freq_hz: float, accel_g: float, packings: list[Packing],
                      centres_m: np.ndarray, workdir: Path, label: str,
                      flip_normals: bool = False) -> dict:
    """Write the patch mesh and deck; return the run's plan.

    Parameters
    ----------
    config : dict
        Validated config (fidelity, materials, cell).
    freq_hz, accel_g : float
        Excitation frequency (Hz) and acceleration amplitude (g).
    packings : list of Packing
        One settled packing per cell, in the cell frame.
    centres_m : ndarray, shape (n_cells, 2)
        Cell centres, m (:mod:`pidpipe.patch`).
    workdir : Path
    label : str
        Names the run in the deck and in error messages (letters, digits, _ and .).
    flip_normals : bool
        Write every wall triangle reversed (:func:`pidpipe.patch.write_patch_stl`).

    Returns
    -------
    dict
        ``deck``, ``period_s``, ``cycles``, ``transient_cycles``, ``timestep`` (TimestepPlan),
        ``amplitude_m``, ``cell_index`` (ndarray of the cell of each sphere, in atom-id order).
    """
    cell = cell_from_config(config)
    radius = particle_properties(config)["radius_m"]
    plan = plan_timestep(config, freq_hz)
    omega = 2.0 * math.pi * freq_hz
    amplitude = displacement_amplitude_m(freq_hz, accel_g)
    transient = transient_cycles_for(config, freq_hz)
    cycles = transient + int(config["fidelity"]["measured_cycles"])
    positions, cell_index = place_in_cells([p.centres() for p in packings], centres_m)
    write_patch_stl(workdir / MESH_FILE, cell, centres_m, flip_normals=flip_normals)
    values = common_values(config, positions, plan.timestep_s, MESH_FILE, label, "patch",
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


def run_patch(config: dict, freq_hz: float, accel_g: float, packings: list[Packing],
              centres_m: np.ndarray, workdir: str | Path, label: str,
              flip_normals: bool = False) -> dict:
    """Shake a patch of cells in one LIGGGHTS run; per-cell and whole-patch E_d and C_eq.

    Parameters
    ----------
    config, freq_hz, accel_g, packings, centres_m, label, flip_normals
        As :func:`render_patch_deck`.
    workdir : path
        The run's own folder.

    Returns
    -------
    dict
        ``cells``: one summary per cell (:func:`pidpipe.damping.summarise_cycles` with N = 1,
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
    plan = render_patch_deck(config, freq_hz, accel_g, packings, centres_m, workdir, label,
                             flip_normals)
    engine = run_deck(plan["deck"], label)
    cell = cell_from_config(config)
    total = read_cycles(workdir / POWER_FILE, workdir / ENERGY_FILE, plan["period_s"], plan["cycles"])
    steps, frames = read_dump_frames(workdir / SPHERE_FILE, len(SPHERE_COLUMNS))
    per_cell = cell_cycles(steps, frames, plan["cell_index"], plan["period_s"], plan["cycles"],
                           STANDARD_GRAVITY_M_S2, cell.floor_z_m)
    radius = particle_properties(config)["radius_m"]
    contained = [spheres_in_own_cells(cell, centres_m, frame[:, 1:4], plan["cell_index"], radius,
                                      CONTAINMENT_TOL_RADII * radius) for frame in frames]
    transient = plan["transient_cycles"]
    block = int(config["fidelity"]["sem_block_cycles"])
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


def per_cell_ceq(cell_ceq: list[float], total: dict) -> dict:
    """C_eq per cell of a scene of several cells, with two standard errors.

    Parameters
    ----------
    cell_ceq : list of float, length n_cells
        Each cell's C_eq over the measured cycles, N s/m.
    total : dict
        :func:`pidpipe.damping.summarise_cycles` of the scene's total E_d per measured cycle
        with N = 1 (for cells run separately: of their series summed cycle by cycle).

    Returns
    -------
    dict
        ``ceq_ns_m``: the mean over cells, N s/m; ``sem_time_ns_m``: the total's standard error
        over cycles / n_cells (the cycle-to-cycle noise of these very packings);
        ``std_cells_ns_m`` and ``sem_cells_ns_m`` = std / sqrt(n_cells) over cells (packing-to-
        packing scatter plus cycle noise: the error of this scene as an estimate of the mean
        cell of a coupon; NaN for one cell).
    """
    cell_ceq = np.asarray(cell_ceq, dtype=float)
    n_cells = cell_ceq.size
    spread = float(cell_ceq.std(ddof=1)) if n_cells > 1 else float("nan")
    return {"ceq_ns_m": float(cell_ceq.mean()),
            "sem_time_ns_m": total["ceq_cell_sem_ns_m"] / n_cells,
            "std_cells_ns_m": spread,
            "sem_cells_ns_m": spread / math.sqrt(n_cells)}


def energy_drift(series: CycleSeries, transient_cycles: int) -> float:
    """(E at the start - E at the end of the measured cycles) / their total E_d (NaN if <= 0).

    The share of the measured dissipation that came from stored energy rather than from the
    walls: near 0 in steady state (as the single-cell case's drift check).
    """
    total = float(series.dissipated_j[transient_cycles:].sum())
    if total <= 0.0:
        return float("nan")
    return float(series.energy_j[transient_cycles] - series.energy_j[-1]) / total


def replicate_packings(config: dict, fill_pct: float, replicates: int, folder: str | Path,
                       workers: int = 1) -> tuple[list[Packing], dict[int, float]]:
    """The packings of replicates 0 .. replicates-1 of a fill, poured as the campaign pours them.

    Each is :func:`pidpipe.packing.pour` (seed = ``fidelity.seed`` + replicate), kept in
    ``folder`` as ``r<fill>pct_rep<k>.json`` and reused on the next call when its seed and
    sphere count still match the config.

    Parameters
    ----------
    config : dict
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
    from pidpipe.config import spheres_for_fill
    from pidpipe.packing import load_packing

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    paths = [folder / f"r{format_number(fill_pct)}pct_rep{k}.json" for k in range(replicates)]
    wanted = spheres_for_fill(config, fill_pct)
    seed = int(config["fidelity"]["seed"])

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
            jobs = [(config, fill_pct, k, str(paths[k])) for k in missing]
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

    from pidpipe.packing import pour, save_packing

    config, fill_pct, replicate, path = job
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    scratch = tempfile.mkdtemp(prefix=f"pour_rep{replicate}_")
    try:
        save_packing(pour(config, fill_pct, replicate, scratch), path)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)


def separate_runs_scene(records: list[dict], block_cycles: int) -> dict:
    """The scene of k cells shaken in k separate runs, summarised as one patch run is.

    Parameters
    ----------
    records : list of dict
        :func:`run_patch` records of one cell each, same case and fidelity.
    block_cycles : int

    Returns
    -------
    dict
        ``per_cell`` (as in :func:`run_patch`, the time SEM from the k series summed cycle by
        cycle), ``cells`` (each run's cell), ``cpu_time_s`` and ``cell_cycles`` (sums).
    """
    first = records[0]
    cells = [dict(record["cells"][0], cell=k) for k, record in enumerate(records)]
    summed = np.sum([record["total_dissipated_j"] for record in records], axis=0)
    total = summarise_cycles(summed, first["freq_hz"], first["accel_g"], 1, block_cycles)
    return {"per_cell": per_cell_ceq([c["ceq_cell_ns_m"] for c in cells], total), "cells": cells,
            "cpu_time_s": float(sum(r["engine"]["cpu_time_s"] for r in records)),
            "cell_cycles": int(sum(r["cell_cycles"] for r in records))}


def same_packing_z(cells_a: list[dict], cells_b: list[dict]) -> np.ndarray:
    """Differences of C_eq between two scenes' cells with the same packings, in combined SEMs.

    Cell i of one scene is compared with cell i of the other (the same replicate packing);
    as many cells as the smaller scene holds.

    Returns
    -------
    ndarray, shape (n,)
        (C_a - C_b) / sqrt(SEM_a^2 + SEM_b^2); 0 where both are identical.
    """
    n = min(len(cells_a), len(cells_b))
    z = np.zeros(n)
    for i in range(n):
        a, b = cells_a[i], cells_b[i]
        if a["seed"] != b["seed"]:
            raise ValueError(f"cell {i}: packing seeds differ ({a['seed']} vs {b['seed']})")
        difference = a["ceq_cell_ns_m"] - b["ceq_cell_ns_m"]
        if difference != 0.0:
            z[i] = difference / math.hypot(a["ceq_cell_sem_ns_m"], b["ceq_cell_sem_ns_m"])
    return z


def packing_scatter(cells: list[dict], run_noise_ns_m: float | None = None) -> dict:
    """How much C_eq varies from packing to packing, beyond the noise of one run.

    Parameters
    ----------
    cells : list of dict
        Per-cell summaries (``ceq_cell_ns_m``, ``ceq_cell_sem_ns_m``).
    run_noise_ns_m : float, optional
        Standard deviation of one cell's C_eq between runs of the same packing, N s/m (from
        :func:`run_to_run_noise`); when not given, the cells' own SEMs stand for it.

    Returns
    -------
    dict
        ``std_cells_ns_m`` (observed standard deviation over cells), ``rms_sem_ns_m`` (root mean
        square of the cells' reported SEMs), ``run_noise_ns_m`` (what was subtracted) and
        ``std_packing_ns_m`` = sqrt(max(0, std^2 - noise^2)), all N s/m.
    """
    ceq = np.array([c["ceq_cell_ns_m"] for c in cells])
    sem = np.array([c["ceq_cell_sem_ns_m"] for c in cells])
    std = float(ceq.std(ddof=1))
    rms = float(np.sqrt(np.mean(sem**2)))
    noise = rms if run_noise_ns_m is None else float(run_noise_ns_m)
    return {"std_cells_ns_m": std, "rms_sem_ns_m": rms, "run_noise_ns_m": noise,
            "std_packing_ns_m": math.sqrt(max(0.0, std**2 - noise**2))}


def run_to_run_noise(pairs: list[tuple[list[dict], list[dict]]]) -> tuple[float, int]:
    """Standard deviation of a cell's C_eq between two runs of the same packing.

    Runs of the same packing differ in rounding only, and their trajectories diverge, so the
    difference of their C_eq is run noise alone: its variance is twice that of one run.

    Parameters
    ----------
    pairs : list of (cells_a, cells_b)
        Scenes with the same packings cell by cell (:func:`same_packing_z`'s arguments).

    Returns
    -------
    noise : float
        sqrt(mean(d^2) / 2) over every pair of cells whose C_eq differ, N s/m.
    n : int
        Pairs used.
    """
    differences = []
    for cells_a, cells_b in pairs:
        for a, b in zip(cells_a, cells_b):
            if a["seed"] != b["seed"]:
                raise ValueError(f"packing seeds differ ({a['seed']} vs {b['seed']})")
            if a["ceq_cell_ns_m"] != b["ceq_cell_ns_m"]:
                differences.append(a["ceq_cell_ns_m"] - b["ceq_cell_ns_m"])
    differences = np.asarray(differences)
    return float(np.sqrt(np.mean(differences**2) / 2.0)), int(differences.size)
