"""C_eq of a case measured on several cells with their own packings: the mean cell and its standard error.

The error of the mean over cells has two parts, the spread between packings (which only more
cells reduce) and each cell's cycle noise (which more cycles reduce too); :func:`mean_of_cells`
estimates them as the two variance components of one random-effects model, and the sequential
allocation (:mod:`pidpipe.measurement.allocation`) plans with them.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from pidpipe.measurement.statistics import summarise_cycles
from pidpipe.physics.equivalent_damping import ceq_from_energy


@dataclasses.dataclass(frozen=True)
class MeanOfCells:
    """The mean over k cells and its standard error, from a two-level (random-effects) model.

    Cell i's measured mean is x_i = mu + b_i + e_i: b_i the packing's own offset (variance
    sigma_b^2, the spread between packings), e_i its cycle noise (variance v_i, the cell's own
    autocorrelation-aware squared SEM). The mean of the k cells has variance
    (k sigma_b^2 + sum v_i) / k^2, whatever the v_i; ``sem`` is its square root with sigma_b^2
    estimated by moments (:func:`mean_of_cells`).

    Attributes
    ----------
    mean : float
        Unweighted mean of the cells' values (the mean cell).
    sem : float
        Its standard error (same unit); NaN if it cannot be estimated.
    cycle_sem : float
        The part of ``sem`` from the cycle noise alone, sqrt(mean(v_i) / k).
    spread_sem : float
        std(x_i) / sqrt(k), the between-cells estimate (NaN for one cell).
    packing_std : float
        sigma_b, the estimated spread between packings beyond the cycle noise (0 when the cells
        scatter no more than their cycle noise; NaN for one cell).
    cells : int
    """

    mean: float
    sem: float
    cycle_sem: float
    spread_sem: float
    packing_std: float
    cells: int


def mean_of_cells(values: np.ndarray, sems: np.ndarray) -> MeanOfCells:
    """The mean over cells with one standard error holding both the packing spread and the cycle noise.

    sigma_b^2 = max(0, s^2 - mean(v_i)) (s^2 the sample variance of the values: its expectation
    is sigma_b^2 + mean(v_i) for any v_i), and sem^2 = (sigma_b^2 + mean(v_i)) / k. The
    resulting variance is never below the unbiased s^2 / k, so it is not biased low when the
    cycle SEMs are (strong autocorrelation in short series), and it keeps the cycle noise's
    floor when a few cells happen to agree closely (k - 1 degrees of freedom in s^2).

    Parameters
    ----------
    values : ndarray, shape (k,)
        Each cell's mean (e.g. C_eq, N s/m).
    sems : ndarray, shape (k,)
        Each cell's standard error from its own cycles (same unit); NaN entries make the cycle
        part NaN, and then ``sem`` is the spread alone.

    Returns
    -------
    MeanOfCells
        With one cell: its value and its SEM, spread NaN.
    """
    values = np.asarray(values, dtype=float)
    sems = np.asarray(sems, dtype=float)
    k = values.size
    if k == 0 or sems.shape != values.shape:
        raise ValueError(f"need one SEM per cell value, got {sems.shape} for {values.shape}")
    cycle_var = float(np.mean(sems ** 2))
    if k == 1:
        return MeanOfCells(float(values[0]), float(sems[0]), float(sems[0]), float("nan"),
                           float("nan"), 1)
    spread_var = float(values.var(ddof=1))
    if math.isfinite(cycle_var):
        packing_var = max(0.0, spread_var - cycle_var)
        total = packing_var + cycle_var
    else:
        packing_var, total = float("nan"), spread_var
    return MeanOfCells(float(values.mean()), math.sqrt(total / k), math.sqrt(cycle_var / k),
                       math.sqrt(spread_var / k), math.sqrt(packing_var), k)


def summarise_cells(cells_dissipated_j: list[np.ndarray], freq_hz: float, accel_g: float,
                    n_cells_coupon: int, block_cycles: int) -> dict:
    """C_eq of the mean cell of k cells, with one standard error that includes the scatter
    between their packings.

    Parameters
    ----------
    cells_dissipated_j : list of ndarray, each of shape (n_cycles_i,)
        Each cell's dissipated energy per measured cycle, J (cells of one run have equal
        lengths; cells from several runs need not).
    freq_hz, accel_g, n_cells_coupon, block_cycles
        As :func:`pidpipe.measurement.statistics.summarise_cycles`.

    Returns
    -------
    dict
        :func:`pidpipe.measurement.statistics.summarise_cycles` of the mean cell's series (the k
        cells' E_d averaged cycle by cycle, when their lengths agree; else the first cell's
        layout with the means replaced), whose C_eq is the mean over cells and whose standard
        errors are the two-level one of :func:`mean_of_cells` over the cells' own C_eq and
        SEMs. Also ``ceq_cell_cycle_sem_ns_m`` (the part from the cycle noise),
        ``ceq_cell_between_cells_sem_ns_m`` (std / sqrt(k), NaN for one cell),
        ``ceq_cell_packing_std_ns_m`` (the spread between packings beyond the cycle noise),
        ``cycle_noise_ns_m_sqrt_cycle`` (the cells' long-run cycle noise, sqrt(mean(n_i v_i)):
        a cell's SEM over n cycles is about this / sqrt(n)), and ``cells``, each cell's own
        ``ceq_cell_ns_m``, ``ceq_cell_sem_ns_m``, ``ed_cycle_mean_j`` and ``n_cycles`` (empty
        for one cell).
    """
    n_cells = len(cells_dissipated_j)
    lengths = {len(series) for series in cells_dissipated_j}
    own = [summarise_cycles(series, freq_hz, accel_g, n_cells_coupon, block_cycles)
           for series in cells_dissipated_j]
    if n_cells == 1:
        summary = dict(own[0])
    elif len(lengths) == 1:
        summary = summarise_cycles(np.mean(cells_dissipated_j, axis=0), freq_hz, accel_g,
                                   n_cells_coupon, block_cycles)
    else:
        summary = dict(own[0])
    estimate = mean_of_cells(np.array([cell["ceq_cell_ns_m"] for cell in own]),
                             np.array([cell["ceq_cell_sem_ns_m"] for cell in own]))
    per_joule = ceq_from_energy(1.0, freq_hz, accel_g)
    noise = math.sqrt(np.mean([cell["n_cycles"] * cell["ceq_cell_sem_ns_m"] ** 2 for cell in own]))
    summary.update(
        ceq_cell_ns_m=estimate.mean, ceq_cell_sem_ns_m=estimate.sem,
        ceq_coupon_ns_m=estimate.mean * n_cells_coupon,
        ceq_coupon_sem_ns_m=estimate.sem * n_cells_coupon,
        ed_cycle_mean_j=estimate.mean / per_joule, ed_cycle_sem_j=estimate.sem / per_joule,
        ceq_cell_cycle_sem_ns_m=estimate.cycle_sem,
        ceq_cell_between_cells_sem_ns_m=estimate.spread_sem,
        ceq_cell_packing_std_ns_m=estimate.packing_std,
        cycle_noise_ns_m_sqrt_cycle=noise,
        cells=[] if n_cells == 1 else [
            {key: cell[key] for key in ("ceq_cell_ns_m", "ceq_cell_sem_ns_m", "ed_cycle_mean_j",
                                        "n_cycles")} for cell in own])
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
