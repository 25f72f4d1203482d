"""Time limits of case jobs on a cluster (pidpipe.steps.resources)."""

from __future__ import annotations

import math

import pytest

from pidpipe.cases import CaseSpec
from pidpipe.cell.scene import CellScene
from pidpipe.config.settings import ShakeSettings
from pidpipe.steps import resources as cr

CASE = CaseSpec(500.0, 5.0, 50.0)


def test_planned_steps_are_cycles_times_steps_per_cycle(config):
    config["fidelity"].update(transient_cycles=5, transient_min_time_s=0.0, measured_cycles=40)
    spc = CellScene.from_config(config).timestep(500.0).steps_per_cycle
    assert cr.case_planned_steps(ShakeSettings.from_config(config), CASE) == 45 * spc
    # A lower frequency has longer cycles, so more steps for the same cycles.
    assert cr.case_planned_steps(ShakeSettings.from_config(config), CaseSpec(50.0, 5.0, 50.0)) > 9 * 45 * spc


def test_a_target_sem_adds_the_case_cpu_cap_to_the_pilot(config):
    config["fidelity"].update(transient_cycles=5, transient_min_time_s=0.0, measured_cycles=40,
                              target_relative_sem=None)
    without = cr.case_wall_time_s(ShakeSettings.from_config(config), CASE)
    config["fidelity"].update(target_relative_sem=0.05, max_case_cpu_s=300.0)
    settings = ShakeSettings.from_config(config)
    assert cr.case_planned_steps(settings, CASE) == 45 * CellScene.from_config(config).timestep(500.0).steps_per_cycle
    assert cr.case_wall_time_s(settings, CASE) == pytest.approx(without + 300.0)


def test_runtime_is_the_estimate_with_margin_in_whole_minutes_and_grows_with_attempt(config):
    config["fidelity"].update(cells_per_run=7, target_relative_sem=None)
    seconds = cr.case_wall_time_s(ShakeSettings.from_config(config), CASE)
    steps = cr.case_planned_steps(ShakeSettings.from_config(config), CASE)
    assert seconds == pytest.approx(cr.SETUP_S + steps * (cr.US_PER_STEP_FIRST_CELL
                                                          + 6 * cr.US_PER_STEP_EXTRA_CELL) * 1e-6)
    first = cr.case_runtime_min(ShakeSettings.from_config(config), CASE)
    assert first == math.ceil(seconds * cr.MARGIN / 60)
    assert cr.case_runtime_min(ShakeSettings.from_config(config), CASE, attempt=2) == math.ceil(seconds * cr.MARGIN * 2 / 60)
    assert cr.case_runtime_min(ShakeSettings.from_config(config), CASE, attempt=2) >= 2 * first - 1


def test_runtime_is_at_least_a_minute_and_attempt_must_be_positive(config):
    config["fidelity"].update(transient_cycles=1, transient_min_time_s=0.0, measured_cycles=2,
                              cells_per_run=1, target_relative_sem=None)
    assert cr.case_runtime_min(ShakeSettings.from_config(config), CaseSpec(1000.0, 5.0, 25.0)) == 1
    with pytest.raises(ValueError, match="attempt"):
        cr.case_runtime_min(ShakeSettings.from_config(config), CASE, attempt=0)


def test_a_refinement_run_gets_its_planned_cpu_with_margin_and_longer_on_a_retry():
    from pidpipe.steps.resources import MARGIN, SETUP_S, refine_run_runtime_min

    assert refine_run_runtime_min(0.0) == 1
    planned = 600.0
    first = refine_run_runtime_min(planned)
    assert first == math.ceil((SETUP_S + planned) * MARGIN / 60.0)
    assert refine_run_runtime_min(planned, attempt=2) > first
    with pytest.raises(ValueError):
        refine_run_runtime_min(float("nan"))


def test_a_refine_step_that_runs_the_cases_has_time_for_the_whole_budget():
    from pidpipe.steps.resources import (MARGIN, ROUND_FIT_MIN, SETUP_S,
                                         refine_step_runtime_min)

    deciding = refine_step_runtime_min(3000.0, 20, 1, runs_cases=False)
    assert deciding == math.ceil(SETUP_S * MARGIN / 60.0 + ROUND_FIT_MIN)
    running = refine_step_runtime_min(3000.0, 20, 2, runs_cases=True)
    assert running == math.ceil((SETUP_S + 1500.0) * MARGIN / 60.0 + 20 * ROUND_FIT_MIN)
    assert refine_step_runtime_min(3000.0, 20, 4, runs_cases=True) < running
    assert refine_step_runtime_min(3000.0, 20, 2, runs_cases=True, attempt=2) > running
    with pytest.raises(ValueError):
        refine_step_runtime_min(3000.0, 20, 0, runs_cases=True)
