"""C_eq of a case measured on several cells with their own packings: the mean cell and its standard errors.
"""

from __future__ import annotations

import math

import numpy as np

from pidpipe.measurement.statistics import summarise_cycles
from pidpipe.physics.equivalent_damping import ceq_from_energy


def summarise_cells(cells_dissipated_j: list[np.ndarray], freq_hz: float, accel_g: float,
                    n_cells_coupon: int, block_cycles: int) -> dict:
    """C_eq of the mean cell of a run of k cells, with a standard error that includes the
    scatter between their packings.

    Parameters
    ----------
    cells_dissipated_j : list of ndarray, each of shape (n_cycles,)
        Each cell's dissipated energy per measured cycle, J.
    freq_hz, accel_g, n_cells_coupon, block_cycles
        As :func:`pidpipe.measurement.statistics.summarise_cycles`.

    Returns
    -------
    dict
        :func:`pidpipe.measurement.statistics.summarise_cycles` of the mean cell's series (the k cells' E_d
        averaged cycle by cycle), whose standard errors become the larger of two estimates:
        the mean series' cycle-to-cycle one (``ceq_cell_cycle_sem_ns_m``), and the spread of
        the k cells' own C_eq, std / sqrt(k) (``ceq_cell_between_cells_sem_ns_m``, NaN for one
        cell), which also holds the packing-to-packing scatter. As for replicates in separate
        runs (:func:`pidpipe.design.records.combine_replicates`), the larger is kept because the
        spread of a few cells is itself a poor estimate. With one cell this is
        ``summarise_cycles`` of that cell, with ``cells`` empty. ``cells`` lists each cell's
        own ``ceq_cell_ns_m`` and ``ceq_cell_sem_ns_m`` (N s/m) and ``ed_cycle_mean_j`` (J).
    """
    n_cells = len(cells_dissipated_j)
    mean_cell = np.mean(cells_dissipated_j, axis=0) if n_cells > 1 else cells_dissipated_j[0]
    summary = summarise_cycles(mean_cell, freq_hz, accel_g, n_cells_coupon, block_cycles)
    cycle_sem = summary["ceq_cell_sem_ns_m"]
    summary.update(ceq_cell_cycle_sem_ns_m=cycle_sem, ceq_cell_between_cells_sem_ns_m=float("nan"),
                   cells=[])
    if n_cells == 1:
        return summary
    own = [summarise_cycles(series, freq_hz, accel_g, n_cells_coupon, block_cycles)
           for series in cells_dissipated_j]
    values = np.array([cell["ceq_cell_ns_m"] for cell in own])
    between = float(values.std(ddof=1) / np.sqrt(n_cells))
    summary["ceq_cell_between_cells_sem_ns_m"] = between
    summary["cells"] = [{key: cell[key] for key in ("ceq_cell_ns_m", "ceq_cell_sem_ns_m",
                                                    "ed_cycle_mean_j")} for cell in own]
    if between > cycle_sem or not np.isfinite(cycle_sem):
        summary.update(ceq_cell_sem_ns_m=between, ceq_coupon_sem_ns_m=between * n_cells_coupon,
                       ed_cycle_sem_j=between / ceq_from_energy(1.0, freq_hz, accel_g))
    return summary


def per_cell_ceq(cell_ceq: list[float], total: dict) -> dict:
    """C_eq per cell of a scene of several cells, with two standard errors.

    Parameters
    ----------
    cell_ceq : list of float, length n_cells
        Each cell's C_eq over the measured cycles, N s/m.
    total : dict
        :func:`pidpipe.measurement.statistics.summarise_cycles` of the scene's total E_d per measured cycle
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
