"""The workflow's parameters from the config (pidpipe.steps.params): the DEM jobs' priority."""

import copy

import pytest

from pidpipe.cases import CaseSpec
from pidpipe.config import load_config
from pidpipe.config.settings import ShakeSettings
from pidpipe.config.pilots import grid_case_config
from pidpipe.steps.params import (
    CHASE_WEIGHT_AT_1G,
    dem_batch_case_ids,
    dem_batch_priority,
)
from pidpipe.studies.fidelity import planned_steps


def pilot_steps(config, case_ids):
    total = 0.0
    for case in map(CaseSpec.from_id, case_ids):
        settings = ShakeSettings.from_config(grid_case_config(config, case.freq_hz, case.accel_g))
        total += planned_steps(settings, case)
    return total / 1e6


def test_a_dem_job_at_1_g_counts_its_pilots_thrice_when_chased_and_starts_before_its_5_g_one():
    # a campaign with a uniform target (the default campaign's loop runs pilots only)
    config = copy.deepcopy(load_config())
    config["fidelity"]["target_relative_sem"] = 0.05
    at_1g, at_5g = (dem_batch_case_ids(config, "1000", g, "0") for g in ("1", "5"))
    assert dem_batch_priority(config, at_1g) == pytest.approx(CHASE_WEIGHT_AT_1G * pilot_steps(config, at_1g))
    assert dem_batch_priority(config, at_5g) == pytest.approx(pilot_steps(config, at_5g))
    assert dem_batch_priority(config, at_1g) > dem_batch_priority(config, at_5g)
    # the 1000 Hz / 1 g job now ranks above the 500 Hz / 5 g one, whose pilots take more steps
    at_500 = dem_batch_case_ids(config, "500", "5", "0")
    assert pilot_steps(config, at_1g) < pilot_steps(config, at_500) < dem_batch_priority(config, at_1g)


def test_without_a_target_every_dem_job_counts_its_pilots_alone():
    config = copy.deepcopy(load_config())
    config["fidelity"]["target_relative_sem"] = None
    at_1g = dem_batch_case_ids(config, "1000", "1", "0")
    assert dem_batch_priority(config, at_1g) == pytest.approx(pilot_steps(config, at_1g))


def test_a_dem_job_whose_point_no_band_reads_counts_its_short_pilots():
    config = copy.deepcopy(load_config())
    at_1g = dem_batch_case_ids(config, "1000", "1", "0")      # 1000 Hz, 1 g: no band between
    short = dem_batch_priority(config, at_1g)
    config["refine"]["far_pilot_measured_cycles"] = None
    full = dem_batch_priority(config, at_1g)
    # 30 transient + 12 measured cycles against 30 + 40, at the same steps per cycle
    assert short / full == pytest.approx(42 / 70)
