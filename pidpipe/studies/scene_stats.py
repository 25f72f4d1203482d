"""Statistics of the scene study: same-packing agreement between scenes, packing-to-packing scatter, run-to-run noise.
"""

from __future__ import annotations

import math

import numpy as np

from pidpipe.measurement.cells import per_cell_ceq
from pidpipe.measurement.statistics import summarise_cycles


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
