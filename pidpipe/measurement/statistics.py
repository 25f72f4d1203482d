"""Per-cycle statistics: the mean dissipation per cycle, its autocorrelation-aware standard error, C_eq.

The per-cycle series is autocorrelated, both ways: the bed can alternate between high and low
cycles (negative lag-1 correlation, handled by means of blocks of consecutive cycles), or drift
slowly through long runs of similar cycles (positive correlation, handled by the AR(1)
correction of the standard error). The reported standard error is the larger of the two
estimates (:func:`standard_error`).
"""

from __future__ import annotations

import math

import numpy as np

from pidpipe.physics.equivalent_damping import ceq_from_energy, displacement_amplitude_m


def block_means(series: np.ndarray, block: int) -> np.ndarray:
    """Means of consecutive, non-overlapping blocks of ``block`` values (a trailing partial block is dropped).

    Parameters
    ----------
    series : ndarray, shape (n,)
    block : int
        Values per block, >= 1.

    Returns
    -------
    ndarray, shape (n // block,)
    """
    series = np.asarray(series, dtype=float)
    count = series.size // block
    return series[: count * block].reshape(count, block).mean(axis=1)


def mean_and_sem(series: np.ndarray, block: int = 1) -> tuple[float, float]:
    """Mean and standard error from means of consecutive blocks of ``block`` values.

    A trailing partial block is left out of both, so that the mean and its error describe the
    same cycles.

    Returns
    -------
    mean : float
        Mean of the values in whole blocks.
    sem : float
        Standard error of the mean; NaN if fewer than two blocks.
    """
    series = np.asarray(series, dtype=float)
    blocks = block_means(series, block)
    mean = float(series[: blocks.size * block].mean()) if blocks.size else float("nan")
    if blocks.size < 2:
        return mean, float("nan")
    return mean, float(blocks.std(ddof=1) / math.sqrt(blocks.size))


def lag1_autocorrelation(series: np.ndarray) -> float:
    """Lag-1 autocorrelation of a series (negative for alternating high/low cycles)."""
    series = np.asarray(series, dtype=float)
    if series.size < 3:
        return float("nan")
    centred = series - series.mean()
    denominator = float(centred @ centred)
    if denominator == 0.0:
        return 0.0
    return float(centred[:-1] @ centred[1:] / denominator)


RHO_CAP = 0.99
"""Largest lag-1 autocorrelation the AR(1) correction uses (the SEM stays finite)."""


def ar1_standard_error(series: np.ndarray) -> float:
    """Standard error of the mean of a positively autocorrelated series, AR(1) model.

    sem = s / sqrt(n) * sqrt((1 + rho) / (1 - rho)), with rho the lag-1 autocorrelation,
    corrected for its small-sample bias (Kendall: E[r] ~ rho - (1 + 3 rho) / n), taken as 0
    when negative (alternation is the block means' business) and capped at :data:`RHO_CAP`.
    NaN for n < 3. On synthetic AR(1) series of 40 cycles this recovers 0.77 of the true
    standard error at rho = 0.9 and 0.95 at rho = 0.5 (the uncorrected estimate: 0.58, 0.88).
    """
    series = np.asarray(series, dtype=float)
    rho = lag1_autocorrelation(series)
    if not math.isfinite(rho):
        return float("nan")
    rho = max(rho, 0.0)
    rho = min(rho + (1.0 + 3.0 * rho) / series.size, RHO_CAP)
    return float(series.std(ddof=1) / math.sqrt(series.size) * math.sqrt((1.0 + rho) / (1.0 - rho)))


def standard_error(series: np.ndarray, block: int) -> tuple[float, float]:
    """Mean and its standard error: the larger of the block-means and the AR(1) estimates.

    Both are computed on the cycles of whole blocks (a trailing partial block is left out).

    Returns
    -------
    mean, sem : float
    """
    series = np.asarray(series, dtype=float)
    mean, block_sem = mean_and_sem(series, block)
    whole = series[: (series.size // block) * block]
    ar1_sem = ar1_standard_error(whole)
    if math.isnan(block_sem) or math.isnan(ar1_sem):
        return mean, block_sem
    return mean, max(block_sem, ar1_sem)


def summarise_cycles(dissipated_j: np.ndarray, freq_hz: float, accel_g: float, n_cells: int,
                     block_cycles: int = 2) -> dict:
    """Summarise the measured cycles of one cell.

    Parameters
    ----------
    dissipated_j : ndarray, shape (n_cycles,)
        Energy dissipated in each measured cycle by one cell's spheres, J.
    freq_hz, accel_g : float
        Excitation frequency (Hz) and acceleration amplitude (in g).
    n_cells : int
        Cells in the coupon, N (the coupon's C_eq is N times the cell's).
    block_cycles : int
        Cycles per block for the standard error (:func:`standard_error`).

    Returns
    -------
    dict
        ``ed_cycle_mean_j``, ``ed_cycle_sem_j``, ``ed_cycle_std_j`` (raw cycle-to-cycle scatter),
        ``ed_lag1_autocorrelation``, ``n_cycles``, ``ceq_cell_ns_m``, ``ceq_cell_sem_ns_m``,
        ``ceq_coupon_ns_m``, ``ceq_coupon_sem_ns_m``, ``displacement_amplitude_m``.
    """
    dissipated_j = np.asarray(dissipated_j, dtype=float)
    mean, sem = standard_error(dissipated_j, block_cycles)
    per_joule = ceq_from_energy(1.0, freq_hz, accel_g)
    return {
        "n_cycles": int(dissipated_j.size),
        "ed_cycle_mean_j": mean,
        "ed_cycle_sem_j": sem,
        "ed_cycle_std_j": float(dissipated_j.std(ddof=1)) if dissipated_j.size > 1 else float("nan"),
        "ed_lag1_autocorrelation": lag1_autocorrelation(dissipated_j),
        "displacement_amplitude_m": displacement_amplitude_m(freq_hz, accel_g),
        "ceq_cell_ns_m": mean * per_joule,
        "ceq_cell_sem_ns_m": sem * per_joule,
        "ceq_coupon_ns_m": mean * per_joule * n_cells,
        "ceq_coupon_sem_ns_m": sem * per_joule * n_cells,
    }
