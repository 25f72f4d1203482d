"""From the dissipated energy per cycle to the equivalent viscous damping C_eq.

For base motion of acceleration amplitude a = G g at angular frequency omega, the displacement
amplitude is W = a / omega^2, and a viscous damper c dissipates pi c omega W^2 per cycle, so
C_eq = E_d / (pi omega W^2) (SPEC.md). The per-cycle series is autocorrelated (the bed can
alternate between high and low cycles), so the standard error of the mean comes from means of
blocks of consecutive cycles, not from the raw cycle-to-cycle scatter.
"""

from __future__ import annotations

import math

import numpy as np

from pidpipe.contact import STANDARD_GRAVITY_M_S2


def displacement_amplitude_m(freq_hz: float, accel_g: float) -> float:
    """Base displacement amplitude W = G g / omega^2, m."""
    omega = 2.0 * math.pi * freq_hz
    return accel_g * STANDARD_GRAVITY_M_S2 / omega**2


def ceq_from_energy(energy_per_cycle_j: float, freq_hz: float, accel_g: float) -> float:
    """Equivalent viscous damping C_eq = E_d / (pi omega W^2), N s/m."""
    omega = 2.0 * math.pi * freq_hz
    amplitude = displacement_amplitude_m(freq_hz, accel_g)
    return energy_per_cycle_j / (math.pi * omega * amplitude**2)


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
        Cycles per block for the standard error.

    Returns
    -------
    dict
        ``ed_cycle_mean_j``, ``ed_cycle_sem_j``, ``ed_cycle_std_j`` (raw cycle-to-cycle scatter),
        ``ed_lag1_autocorrelation``, ``n_cycles``, ``ceq_cell_ns_m``, ``ceq_cell_sem_ns_m``,
        ``ceq_coupon_ns_m``, ``ceq_coupon_sem_ns_m``, ``displacement_amplitude_m``.
    """
    dissipated_j = np.asarray(dissipated_j, dtype=float)
    mean, sem = mean_and_sem(dissipated_j, block_cycles)
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
