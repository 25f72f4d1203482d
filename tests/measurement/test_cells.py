"""The mean cell's standard error (pidpipe.measurement.cells.mean_of_cells) on synthetic cells whose
true error is known: packings with their own offsets, each shaken for n autocorrelated cycles."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pidpipe.measurement.cells import mean_of_cells, summarise_cells
from pidpipe.measurement.statistics import standard_error, summarise_cycles

REPLICAS = 400


def ar1(rng, rho: float, n: int, shape: tuple) -> np.ndarray:
    """Stationary AR(1) series of unit marginal variance, shape ``shape + (n,)``."""
    out = np.empty(shape + (n,))
    out[..., 0] = rng.standard_normal(shape)
    scale = math.sqrt(1.0 - rho ** 2)
    for t in range(1, n):
        out[..., t] = rho * out[..., t - 1] + scale * rng.standard_normal(shape)
    return out


def ar1_mean_variance(rho: float, n: int) -> float:
    """Exact variance of the mean of n values of a unit-variance AR(1) series."""
    lags = np.arange(1, n)
    return (n + 2.0 * np.sum((n - lags) * rho ** lags)) / n ** 2


def reported_and_true(rho: float, packing_std: float, k: int, n: int, seed: int):
    """REPLICAS synthetic cases of k cells x n cycles: the reported SEMs, the true SEM, and the
    errors of the reported means."""
    rng = np.random.default_rng(seed)
    truth = math.sqrt((packing_std ** 2 + ar1_mean_variance(rho, n)) / k)
    sems, errors = [], []
    cases = 10.0 + packing_std * rng.standard_normal((REPLICAS, k, 1)) + ar1(rng, rho, n, (REPLICAS, k))
    for series in cases:
        means, cell_sems = zip(*(standard_error(s, 2) for s in series))
        estimate = mean_of_cells(np.array(means), np.array(cell_sems))
        sems.append(estimate.sem)
        errors.append(estimate.mean - 10.0)
    return np.array(sems), truth, np.array(errors)


@pytest.mark.parametrize("rho", [-0.6, 0.0, 0.5, 0.9])
@pytest.mark.parametrize("packing_std_over_cycle", [0.0, 1.0, 3.0])
@pytest.mark.parametrize("k", [4, 7, 28])
def test_the_sem_is_not_below_the_truth_by_more_than_its_scatter(rho, packing_std_over_cycle, k):
    n = 40
    packing_std = packing_std_over_cycle * math.sqrt(ar1_mean_variance(rho, n))
    sems, truth, errors = reported_and_true(rho, packing_std, k, n, seed=int(1000 * (rho + 1)) + k)
    ratio = sems / truth
    scatter = ratio.std()
    # the typical report is not low by more than the estimator's own scatter ...
    assert np.median(ratio) >= 1.0 - scatter, (np.median(ratio), scatter)
    # ... its variance is not biased low (s^2 / k is unbiased, and the estimate is never below it)
    assert np.mean(ratio ** 2) >= 1.0 - 3.0 * np.std(ratio ** 2) / math.sqrt(REPLICAS)
    # ... and the reported means scatter as the truth says
    assert np.std(errors) == pytest.approx(truth, rel=4.0 / math.sqrt(2 * REPLICAS))


def test_it_tracks_the_truth_where_the_old_larger_of_two_rule_did_as_well():
    # packings spread 3x the cycle noise of a cell: the spread is the error, and it is reported
    sems, truth, _ = reported_and_true(0.0, 3.0 * math.sqrt(1 / 40), 7, 40, seed=5)
    assert np.median(sems / truth) == pytest.approx(1.0, abs=0.1)
    # identical packings (no spread): the cycle noise, known from 7 x 40 cycles, is the floor
    sems, truth, _ = reported_and_true(0.0, 0.0, 7, 40, seed=6)
    assert np.quantile(sems / truth, 0.1) > 0.9


def test_cells_of_unequal_length_are_combined_with_their_own_cycle_noise():
    rng = np.random.default_rng(1)
    cells = [1e-8 + 1e-9 * rng.standard_normal(n) for n in (40, 40, 160, 160)]
    summary = summarise_cells(cells, 500.0, 5.0, 441, 2)
    own = [summarise_cycles(c, 500.0, 5.0, 441, 2) for c in cells]
    values = np.array([c["ceq_cell_ns_m"] for c in own])
    sems = np.array([c["ceq_cell_sem_ns_m"] for c in own])
    assert summary["ceq_cell_ns_m"] == pytest.approx(values.mean())
    assert summary["ceq_cell_cycle_sem_ns_m"] == pytest.approx(math.sqrt(np.mean(sems ** 2) / 4))
    assert summary["ceq_cell_sem_ns_m"] == pytest.approx(
        math.sqrt(max(values.var(ddof=1), np.mean(sems ** 2)) / 4))
    assert [c["n_cycles"] for c in summary["cells"]] == [40, 40, 160, 160]
    assert summary["cycle_noise_ns_m_sqrt_cycle"] == pytest.approx(
        math.sqrt(np.mean([n * s ** 2 for n, s in zip((40, 40, 160, 160), sems)])))


def test_one_cell_is_its_own_estimate():
    estimate = mean_of_cells(np.array([2.0]), np.array([0.1]))
    assert (estimate.mean, estimate.sem, estimate.cycle_sem) == (2.0, 0.1, 0.1)
    assert math.isnan(estimate.spread_sem) and math.isnan(estimate.packing_std)
    with pytest.raises(ValueError, match="one SEM per cell"):
        mean_of_cells(np.array([1.0, 2.0]), np.array([0.1]))
