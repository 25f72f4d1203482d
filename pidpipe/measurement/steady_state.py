"""Is a case's per-cycle dissipation series in steady state? Detect the transient, test the rest.

Three tests on the series of one LIGGGHTS run (every cycle from the start of shaking):

1. **Transient detection (MSER).** The marginal standard error rule (White, 1997, for the
   initial bias of simulation output) chooses the number of leading cycles d to discard as the
   one minimising the squared standard error of the mean of what is left,
   ``sum((x_i - mean_d)^2) / (n - d)^2``, over d up to half the run. It is applied to block
   means (``block`` cycles each, as the SEM is), so d is a whole number of blocks. The case
   discards ``max(configured transient, d)`` cycles: the transient is detected, the configured
   count is a floor.
2. **Stationarity (halves).** Welch's t-test between the block means of the first and second
   halves of the measured cycles. A level shift or a trend (a bed that collapses, an
   arch that forms) gives a small p-value; ``not_stationary`` when p < :data:`TREND_P_LIMIT`.
   With 60 cases at most about one is flagged by chance.
3. **Stored-energy drift.** In steady state the spheres' mechanical energy is the same at the
   two ends of the measured window, so all the dissipated energy came from the walls.
   ``not_steady`` when more than :data:`STEADY_DRIFT_LIMIT` of it came from stored energy.

And the sign: ``negative_dissipation`` when the mean dissipation is below zero by more than
three standard errors (the balance is inconsistent), ``not_resolved`` when it is within two
standard errors of zero (no dissipation can be told from the balance's noise). The standard
error is the one the record reports (:func:`pidpipe.measurement.statistics.standard_error`, the larger of the
block-means and the AR(1) estimates), so a flag and the error bar beside it agree.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from pidpipe.measurement.statistics import block_means, standard_error

STEADY_DRIFT_LIMIT = 0.1
"""Largest share of the measured dissipation that may come from a net loss of stored energy
(compaction, a collapsing arch, the decay of the start-up) before a case counts as not steady."""

TREND_P_LIMIT = 0.01
"""p-value below which the two halves of the measured window differ (``not_stationary``)."""

NOT_RESOLVED_SEMS = 2.0
"""A mean dissipation within this many standard errors of zero is ``not_resolved``."""

NEGATIVE_SEMS = 3.0
"""A mean dissipation below zero by more than this many standard errors is ``negative_dissipation``."""


@dataclass(frozen=True)
class SteadyState:
    """The verdict on one run's per-cycle series.

    Attributes
    ----------
    transient_cycles : int
        Cycles discarded: max(configured, detected).
    detected_transient_cycles : int
        Cycles MSER would discard.
    drift_fraction : float
        (E_start - E_end) / measured dissipation (NaN if none was dissipated).
    halves_p_value : float
        Welch p-value between the measured window's halves (NaN if too few blocks).
    flags : list of str
        Failed checks (empty if steady and resolved).
    """

    transient_cycles: int
    detected_transient_cycles: int
    drift_fraction: float
    halves_p_value: float
    flags: list[str] = field(default_factory=list)

    def as_record(self) -> dict:
        """The verdict's fields for a case record (the cycles discarded go under ``fidelity``)."""
        return {"detected_transient_cycles": self.detected_transient_cycles,
                "energy_drift_fraction": self.drift_fraction,
                "halves_p_value": self.halves_p_value}


def mser_truncation(series: np.ndarray, block: int) -> int:
    """Leading cycles to discard by the MSER rule on block means (a multiple of ``block``).

    Parameters
    ----------
    series : ndarray, shape (n,)
        Per-cycle values from the start of the run (J).
    block : int
        Cycles per block.

    Returns
    -------
    int
        d * block with d in [0, n_blocks // 2] minimising the MSER statistic; 0 for fewer than
        two blocks.
    """
    means = block_means(series, block)
    count = means.size
    if count < 2:
        return 0
    statistic = [float(np.sum((means[d:] - means[d:].mean()) ** 2)) / (count - d) ** 2
                 for d in range(count // 2 + 1)]
    return int(np.argmin(statistic)) * block


def halves_p_value(measured: np.ndarray, block: int) -> float:
    """Welch's t-test p-value between the block means of the two halves of a series.

    Returns NaN with fewer than two blocks in a half, or 1.0 if both halves are constant and equal.
    """
    means = block_means(measured, block)
    half = means.size // 2
    if half < 2:
        return float("nan")
    first, second = means[:half], means[half:2 * half]
    if np.ptp(first) == 0.0 and np.ptp(second) == 0.0:
        return 1.0 if first[0] == second[0] else 0.0
    return welch_p_value(first, second)


def welch_p_value(first: np.ndarray, second: np.ndarray) -> float:
    """Two-sided p-value of Welch's t-test between two 1-D samples (float64).

    The arithmetic of ``scipy.stats.ttest_ind(first, second, equal_var=False)`` (scipy 1.17:
    variances as the mean squared deviation times n / (n - 1), a NaN degrees of freedom taken
    as 1, p = 2 stdtr(df, -|t|)), to the last bit (tests/measurement/test_steady_state.py), with
    only ``scipy.special``: ``scipy.stats`` costs a DEM case job some 0.6 s of CPU to import,
    more than its kernel run at 1000 Hz (benchmarks/bench_job_startup.py).
    """
    from scipy.special import stdtr

    a, b = np.asarray(first, dtype=float), np.asarray(second, dtype=float)
    n1, n2 = a.shape[0], b.shape[0]
    with np.errstate(divide="ignore", invalid="ignore"):
        v1 = _sample_variance(a)
        v2 = _sample_variance(b)
        vn1, vn2 = v1 / n1, v2 / n2
        df = (vn1 + vn2) ** 2 / (vn1 ** 2 / (n1 - 1) + vn2 ** 2 / (n2 - 1))
        df = np.where(np.isnan(df), 1.0, df)
        t = np.divide(np.mean(a) - np.mean(b), np.sqrt(vn1 + vn2))
    return float(2 * stdtr(df, -np.abs(t)))


def _sample_variance(x: np.ndarray) -> np.ndarray:
    """Variance with n - 1 in the denominator, as scipy.stats' ``_var(x, ddof=1)`` computes it."""
    n = np.asarray(x.shape[0], dtype=x.dtype)
    return np.mean((x - np.mean(x, keepdims=True)) ** 2) * (n / (n - 1))


def drift_fraction(energy_j: np.ndarray, dissipated_j: np.ndarray, transient_cycles: int) -> float:
    """Share of the measured dissipation that came from stored energy (NaN if none dissipated).

    ``energy_j`` holds the energy at every cycle boundary, from the start (n + 1 values for n
    cycles); the measured window runs from boundary ``transient_cycles`` to the last.
    """
    total = float(np.sum(dissipated_j[transient_cycles:]))
    if total <= 0.0:
        return float("nan")
    return float(energy_j[transient_cycles] - energy_j[-1]) / total


def assess_steady_state(dissipated_j: np.ndarray, energy_j: np.ndarray, configured_transient: int,
                        block: int) -> SteadyState:
    """Detect the transient of a run's per-cycle series and test the measured rest.

    Parameters
    ----------
    dissipated_j : ndarray, shape (n,)
        Dissipated energy of every cycle from the start of shaking, J.
    energy_j : ndarray, shape (n + 1,)
        The spheres' mechanical energy at every cycle boundary, J.
    configured_transient : int
        The configured transient (a floor on the cycles discarded).
    block : int
        Cycles per block (``fidelity.sem_block_cycles``).

    Returns
    -------
    SteadyState
    """
    dissipated_j = np.asarray(dissipated_j, dtype=float)
    detected = mser_truncation(dissipated_j, block)
    transient = max(int(configured_transient), detected)
    measured = dissipated_j[transient:]
    flags = []
    drift = drift_fraction(np.asarray(energy_j, dtype=float), dissipated_j, transient)
    if math.isfinite(drift) and abs(drift) > STEADY_DRIFT_LIMIT:
        flags.append("not_steady")
    p_value = halves_p_value(measured, block)
    if math.isfinite(p_value) and p_value < TREND_P_LIMIT:
        flags.append("not_stationary")
    flags += sign_flags(*standard_error(measured, block))
    return SteadyState(transient, detected, drift, p_value, flags)


SIGN_FLAGS = ("negative_dissipation", "not_resolved")
"""The flags :func:`sign_flags` decides."""


def sign_flags(mean: float, sem: float) -> list[str]:
    """``negative_dissipation`` (below zero by more than :data:`NEGATIVE_SEMS` standard errors),
    ``not_resolved`` (within :data:`NOT_RESOLVED_SEMS` of zero, or no finite SEM), or none.

    Parameters
    ----------
    mean, sem : float
        A mean dissipation (or C_eq) and its standard error, same unit.
    """
    if not math.isfinite(sem) or mean + NEGATIVE_SEMS * sem < 0.0:
        return ["negative_dissipation" if math.isfinite(sem) else "not_resolved"]
    if mean <= NOT_RESOLVED_SEMS * sem:
        return ["not_resolved"]
    return []
