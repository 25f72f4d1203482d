"""Steady-state tests on per-cycle series (pidpipe.measurement.steady_state) and the standard error of a mean
of autocorrelated cycles (pidpipe.measurement.statistics.standard_error), on synthetic series whose answer is known."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from pidpipe.cases import REGIME_IMPACTING, REGIME_NO_LIFT_OFF, regime
from pidpipe.liggghts.process import timestep_warnings
from pidpipe.liggghts.shake import timestep_flags
from pidpipe.measurement.statistics import mean_and_sem, standard_error
from pidpipe.measurement.steady_state import (
    assess_steady_state,
    halves_p_value,
    mser_truncation,
    welch_p_value,
)

RNG_SEED = 20261123


def steady_energy(n_cycles: int) -> np.ndarray:
    """Stored energy at every cycle boundary of a run with no drift (J)."""
    return np.full(n_cycles + 1, 1.0)


def test_mser_finds_a_start_up_transient():
    rng = np.random.default_rng(RNG_SEED)
    series = np.concatenate([np.geomspace(50.0, 2.0, 12), 1.0 + 0.1 * rng.standard_normal(60)])
    detected = mser_truncation(series, block=2)
    assert 10 <= detected <= 14


def test_mser_on_a_stationary_series_costs_cycles_not_bias():
    # MSER's end effect: on pure noise it sometimes cuts deep (fewer cycles measured, a larger
    # SEM), but on average little, and what is left is an unbiased sample.
    rng = np.random.default_rng(RNG_SEED)
    cuts, means = [], []
    for _ in range(1000):
        series = 1.0 + 0.2 * rng.standard_normal(70)
        cut = mser_truncation(series, block=2)
        cuts.append(cut)
        means.append(series[cut:].mean())
    assert np.median(cuts) == 0
    assert np.mean(cuts) < 7  # 10 % of the run
    assert max(cuts) <= 35
    assert np.mean(means) == pytest.approx(1.0, abs=0.005)


def test_the_configured_transient_is_a_floor_and_a_longer_detected_one_is_used():
    rng = np.random.default_rng(RNG_SEED)
    series = np.concatenate([np.full(20, 5.0), 1.0 + 0.05 * rng.standard_normal(60)])
    verdict = assess_steady_state(series, steady_energy(series.size), configured_transient=4, block=2)
    assert verdict.detected_transient_cycles >= 20
    assert verdict.transient_cycles == verdict.detected_transient_cycles
    quiet = assess_steady_state(series, steady_energy(series.size), configured_transient=30, block=2)
    assert quiet.transient_cycles == 30


def test_a_late_level_shift_is_not_stationary():
    # 1000 Hz / 1 g / 25 % did this: a plateau, then a new level three quarters of the way in.
    # MSER may not cut past half the run, so the halves test must catch it.
    rng = np.random.default_rng(RNG_SEED)
    series = np.concatenate([1.13 + 0.01 * rng.standard_normal(52), 0.85 + 0.01 * rng.standard_normal(18)])
    verdict = assess_steady_state(series, steady_energy(series.size), configured_transient=30, block=2)
    assert verdict.halves_p_value < 1e-4
    assert "not_stationary" in verdict.flags


def test_an_early_level_shift_is_a_transient():
    rng = np.random.default_rng(RNG_SEED)
    series = np.concatenate([1.13 + 0.01 * rng.standard_normal(20), 0.85 + 0.01 * rng.standard_normal(50)])
    verdict = assess_steady_state(series, steady_energy(series.size), configured_transient=4, block=2)
    assert 20 <= verdict.transient_cycles <= 22
    assert verdict.flags == []


def test_the_halves_test_false_alarm_rate_is_near_its_level():
    rng = np.random.default_rng(RNG_SEED)
    alarms = sum(halves_p_value(1.0 + 0.3 * rng.standard_normal(40), block=2) < 0.01 for _ in range(2000))
    assert alarms / 2000 < 0.02


def test_the_welch_p_value_is_scipy_stats_to_the_last_bit():
    """welch_p_value replaces scipy.stats.ttest_ind (too costly to import in every case job):
    the records keep the same halves_p_value, so it must agree bit for bit."""
    from scipy import stats

    rng = np.random.default_rng(RNG_SEED)
    samples = []
    for _ in range(400):
        n1, n2 = rng.integers(2, 60, size=2)
        scale = 10.0 ** rng.uniform(-12, 3)
        samples.append((scale * (1 + rng.standard_normal(n1)),
                        scale * (1 + rng.uniform(-0.5, 0.5) + rng.standard_normal(n2))))
    samples += [(np.full(5, 2.0), np.array([1.0, 2.0, 3.0, 2.5])),       # one half constant
                (np.array([1.0, 1.0 + 1e-15, 1.0]), np.array([1.0, 1.0, 1.0 + 2e-15]))]
    for first, second in samples:
        with warnings.catch_warnings():     # scipy's warning on the nearly constant pair
            warnings.simplefilter("ignore", RuntimeWarning)
            expected = float(stats.ttest_ind(first, second, equal_var=False).pvalue)
        assert welch_p_value(first, second) == expected or (np.isnan(expected) and np.isnan(
            welch_p_value(first, second)))


def test_stored_energy_drift_flags_not_steady():
    series = np.full(40, 1.0)
    energy = np.linspace(30.0, 0.0, 41)  # the bed loses 30 J while 40 J are dissipated
    verdict = assess_steady_state(series, energy, configured_transient=0, block=2)
    assert verdict.drift_fraction == pytest.approx(0.75)
    assert "not_steady" in verdict.flags


def test_a_clean_steady_series_has_no_flags():
    rng = np.random.default_rng(RNG_SEED)
    series = 1.0 + 0.1 * rng.standard_normal(60)
    verdict = assess_steady_state(series, steady_energy(series.size), configured_transient=6, block=2)
    assert verdict.flags == []


def test_dissipation_within_its_noise_of_zero_is_not_resolved():
    rng = np.random.default_rng(RNG_SEED)
    series = 1e-9 * rng.standard_normal(40)
    verdict = assess_steady_state(series, steady_energy(series.size), configured_transient=0, block=2)
    assert "not_resolved" in verdict.flags


def test_clearly_negative_dissipation_is_an_inconsistent_balance():
    rng = np.random.default_rng(RNG_SEED)
    series = -1.0 + 0.05 * rng.standard_normal(40)
    verdict = assess_steady_state(series, steady_energy(series.size), configured_transient=0, block=2)
    assert "negative_dissipation" in verdict.flags


def ar1_series(rng, rho: float, n: int) -> np.ndarray:
    """An AR(1) series x_k = rho x_{k-1} + e_k (unit innovations), started in its stationary state."""
    x = np.empty(n)
    x[0] = rng.standard_normal() / np.sqrt(1.0 - rho**2)
    for k in range(1, n):
        x[k] = rho * x[k - 1] + rng.standard_normal()
    return x


@pytest.mark.parametrize("rho", [0.5, 0.9])
def test_standard_error_covers_slowly_correlated_cycles(rho):
    # A bed that drifts through long runs of similar cycles (1000 Hz / 1 g / 25 % had a lag-1
    # correlation of 0.93): 2-cycle block means underestimate the scatter of the mean; the
    # reported SEM must not.
    rng = np.random.default_rng(RNG_SEED)
    samples = [ar1_series(rng, rho, 40) for _ in range(3000)]
    true_sem = np.std([s.mean() for s in samples])
    block_sem = np.median([mean_and_sem(s, 2)[1] for s in samples])
    reported = np.median([standard_error(s, 2)[1] for s in samples])
    assert block_sem < 0.8 * true_sem
    assert 0.6 * true_sem < reported < 1.4 * true_sem


def test_standard_error_of_uncorrelated_cycles_is_the_usual_one():
    rng = np.random.default_rng(RNG_SEED)
    samples = [rng.standard_normal(40) for _ in range(3000)]
    true_sem = np.std([s.mean() for s in samples])
    reported = np.median([standard_error(s, 2)[1] for s in samples])
    assert 0.8 * true_sem < reported < 1.2 * true_sem


def test_regime_names_the_no_lift_off_side_of_one_g():
    assert regime(0.5) == REGIME_NO_LIFT_OFF
    assert regime(1.0) == REGIME_NO_LIFT_OFF
    assert regime(1.5) == REGIME_IMPACTING


def test_timestep_warnings_are_read_from_the_screen_and_flag_the_case():
    screen = "\n".join([
        "WARNING: Movement type wiggle requires only (10 + 2*$order) arguments, excess arguments will be ignored",
        "WARNING: time-step is 23.000000 % of hertz time",
        "WARNING: time-step is 23.000000 % of hertz time",
        "WARNING: time step too large or skin too small - particles may travel a distance of 0.1 per time-step, but half skin is 0.01",
    ])
    warnings = timestep_warnings(screen)
    assert len(warnings) == 2
    assert all("time" in w for w in warnings)
    assert timestep_flags(warnings) == ["timestep_check"]
    assert timestep_flags(timestep_warnings("WARNING: Movement type wiggle ...")) == []
