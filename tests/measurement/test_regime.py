"""The regime classifier and the phase profile on synthetic bed motions whose regime is known."""

import math

import numpy as np
import pytest

from pidpipe.measurement.motion import BedMotion
from pidpipe.measurement.phase import phase_profile
from pidpipe.measurement.regime import (
    BOUNCING_BED,
    FLUIDISED,
    IRREGULAR,
    LID_IMPACTS,
    NO_LIFT_OFF,
    PERIOD_DOUBLING,
    case_regime,
    motion_regime,
)

WINDOWS = 20
CYCLES = 24
WEIGHT = 1.0e-3
RADIUS = 1.25e-3
REST = 8.0e-3


def synthetic(floor_per_cycle, lid_per_cycle=None, height_m=REST) -> BedMotion:
    """A one-cell motion whose floor force (bed weights) in cycle k is ``floor_per_cycle(k)``,
    an array of WINDOWS values; 20 windows of 10 steps make a cycle of 200 steps."""
    floor = np.concatenate([floor_per_cycle(k) for k in range(CYCLES)]) * WEIGHT
    lid = (np.zeros_like(floor) if lid_per_cycle is None
           else np.concatenate([lid_per_cycle(k) for k in range(CYCLES)]) * WEIGHT)
    n = floor.size
    column = lambda values: np.asarray(values, dtype=float).reshape(n, 1)
    return BedMotion(window_steps=10, timestep_s=5e-6, period_s=200 * 5e-6, amplitude_m=1e-5,
                     power_w=column(np.zeros(n)), floor_force_n=column(floor),
                     lid_force_n=column(lid), centre_m=column(np.full(n, 4e-3)),
                     bottom_m=column(np.full(n, RADIUS)), top_m=column(np.full(n, RADIUS + height_m)),
                     energy_j=np.zeros((n + 1, 1)), weight_n=np.array([WEIGHT]), radius_m=RADIUS)


def flight(start, end, landing=5.0):
    """One cycle's floor force: airborne in windows [start, end), a landing of `landing` weights."""
    force = np.ones(WINDOWS)
    force[start:end] = 0.0
    if end < WINDOWS:
        force[end] = landing
    return force


def regime_of(motion):
    return motion_regime(motion, first_cycle=2, bins=WINDOWS, rest_height_m=[REST])


def test_a_bed_that_follows_the_floor_does_not_lift_off():
    # G = 1: the floor is unloaded for one window at the top of the cycle only
    result = regime_of(synthetic(lambda k: 1.0 - np.cos(2 * math.pi * (np.arange(WINDOWS) + 0.5) / WINDOWS)))
    assert result["regime"] == NO_LIFT_OFF
    assert result["cell_features"][0]["lift_off_cycles"] == 0.0


def test_one_landing_a_cycle_at_one_phase_is_a_bouncing_bed():
    rng = np.random.default_rng(1)
    result = regime_of(synthetic(lambda k: flight(2, 11 + int(rng.integers(0, 2)))))
    assert result["regime"] == BOUNCING_BED
    features = result["cell_features"][0]
    assert features["landings_per_cycle"] == 1.0 and features["landing_scatter"] <= 0.05
    assert features["flight"] == pytest.approx(0.475, abs=0.03)


def test_alternating_long_and_short_flights_are_period_doubling():
    # a flight over a whole cycle and part of the next, then a short one: lands every other cycle
    result = regime_of(synthetic(lambda k: np.zeros(WINDOWS) if k % 2 else flight(0, 8)))
    assert result["regime"] == PERIOD_DOUBLING
    features = result["cell_features"][0]
    assert features["d2"] < 0.5 * features["d1"]


def test_touching_the_lid_in_many_cycles_is_lid_impacts():
    lid = lambda k: np.where(np.arange(WINDOWS) == 7, 3.0, 0.0) if k % 3 == 0 else np.zeros(WINDOWS)
    result = regime_of(synthetic(lambda k: flight(2, 12), lid))
    assert result["regime"] == LID_IMPACTS
    assert result["cell_features"][0]["lid_cycles"] == pytest.approx(1 / 3, abs=0.05)
    assert result["cell_features"][0]["lid_peak"] == 3.0


def test_the_lid_peak_is_the_strongest_impact_of_any_cycle_and_zero_without_one():
    # impacts of 2, 4, 6 weights in turn, at a phase that moves: the phase-mean peak is far lower
    lid = lambda k: np.where(np.arange(WINDOWS) == 4 + k % 8, 2.0 * (1 + k % 3), 0.0)
    motion = synthetic(lambda k: flight(2, 12), lid)
    assert regime_of(motion)["cell_features"][0]["lid_peak"] == 6.0
    profile = phase_profile(motion, first_cycle=2, bins=WINDOWS)
    assert max(profile["lid_force_n"]["mean"]) / profile["bed_weight_n"] < 1.5
    assert regime_of(synthetic(lambda k: flight(2, 12)))["cell_features"][0]["lid_peak"] == 0.0


def test_a_bed_expanded_by_more_than_a_diameter_is_fluidised():
    result = regime_of(synthetic(lambda k: flight(2, 12), height_m=REST + 3.0 * 2 * RADIUS))
    assert result["regime"] == FLUIDISED
    assert result["cell_features"][0]["expansion_diameters"] == pytest.approx(3.0)


def test_landings_at_random_phases_are_irregular():
    rng = np.random.default_rng(3)
    result = regime_of(synthetic(lambda k: flight(0, int(rng.integers(3, 19)))))
    assert result["regime"] == IRREGULAR


def test_the_case_takes_the_regime_of_most_cells_and_ties_go_to_the_earlier_regime():
    assert case_regime([BOUNCING_BED, IRREGULAR, BOUNCING_BED]) == BOUNCING_BED
    assert case_regime([IRREGULAR, PERIOD_DOUBLING]) == PERIOD_DOUBLING
    assert case_regime([NO_LIFT_OFF]) == NO_LIFT_OFF


def test_phase_profile_averages_the_measured_cycles_with_their_spread():
    # the landing alternates between 5 and 7 bed weights: mean 6, sample std sqrt(2) (22 cycles)
    motion = synthetic(lambda k: flight(2, 12, landing=5.0 if k % 2 else 7.0))
    profile = phase_profile(motion, first_cycle=2, bins=WINDOWS)
    assert profile["n_cycles"] == CYCLES - 2
    floor = np.array(profile["floor_force_n"]["mean"]) / WEIGHT
    assert floor[12] == pytest.approx(6.0)
    assert np.array(profile["floor_force_n"]["std"])[12] / WEIGHT == pytest.approx(
        np.std([5.0, 7.0] * 11, ddof=1))
    assert floor[5] == 0.0 and floor[15] == pytest.approx(1.0)
    wall = np.array(profile["wall_z_m"]["mean"])
    assert wall[0] == pytest.approx(1e-5 * (math.cos(math.pi / WINDOWS) - 1.0))
    assert wall.min() == pytest.approx(-2e-5, rel=0.01)
