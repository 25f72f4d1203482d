import math

import numpy as np
import pytest

from pidpipe.measurement.statistics import (
    block_means,
    lag1_autocorrelation,
    mean_and_sem,
    summarise_cycles,
)
from pidpipe.physics.equivalent_damping import ceq_from_energy, displacement_amplitude_m


def test_ceq_of_a_viscous_damper():
    # a dashpot c under x = W sin(wt) dissipates pi c w W^2 per cycle
    c, f, g = 0.37, 250.0, 3.0
    w = 2 * math.pi * f
    amplitude = displacement_amplitude_m(f, g)
    assert amplitude == pytest.approx(3.0 * 9.81 / w**2)
    assert ceq_from_energy(math.pi * c * w * amplitude**2, f, g) == pytest.approx(c, rel=1e-12)


def test_block_sem_sees_alternation():
    # period doubling: high, low, high, low ... the raw scatter is large, the mean is steady
    series = np.tile([3.0, 1.0], 20)
    mean, sem = mean_and_sem(series, block=2)
    assert mean == 2.0 and sem == 0.0
    assert lag1_autocorrelation(series) < -0.9
    _, raw_sem = mean_and_sem(series, block=1)
    assert raw_sem > 0.1


def test_sem_of_white_noise_matches_theory():
    rng = np.random.default_rng(3)
    series = rng.normal(5.0, 2.0, size=(400, 100))
    sems = np.array([mean_and_sem(row, block=2)[1] for row in series])
    assert sems.mean() == pytest.approx(2.0 / 10.0, rel=0.05)


def test_summary_scales_to_the_coupon():
    summary = summarise_cycles(np.full(10, 1e-7), 500.0, 5.0, 441, 2)
    assert summary["ceq_coupon_ns_m"] == pytest.approx(441 * summary["ceq_cell_ns_m"])
    assert summary["n_cycles"] == 10 and summary["ed_cycle_sem_j"] == 0.0


def test_block_means_drop_partial_block():
    assert block_means(np.arange(7.0), 3).tolist() == [1.0, 4.0]
