"""The sequential allocation (pidpipe.measurement.allocation) on synthetic noise and cost models."""

from __future__ import annotations

import math

import pytest

from pidpipe.measurement.allocation import (
    PLAN_MARGIN,
    Components,
    Limits,
    plan_next_step,
    runs_cpu_s,
)
from pidpipe.measurement.cost_model import CostModel

# A LIGGGHTS-like model: 1 s start-up, steps x (10 + 6 k) us; 1000 steps per cycle, 30 transient.
MODEL = CostModel("liggghts", 1.0, 10e-6, 6e-6, 0.0, 5.0, 0.0)
TRANSIENT = 30
LIMITS = Limits(max_cells=48, max_cycles=400, max_cpu_s=1e4, cells_per_run=24)


def run_cost(k: int, n: int) -> float:
    return MODEL.run_cpu_s(k, 11, 1000 * (TRANSIENT + n))


def components(relative_packing_std: float, relative_cell_sem_40: float) -> Components:
    """C_eq 1; a packing's own spread, and a cell's SEM over 40 cycles, relative to C_eq."""
    return Components(1.0, relative_packing_std ** 2, 40 * relative_cell_sem_40 ** 2)


def test_packing_spread_dominating_adds_cells_not_cycles():
    # 7 cells x 40 cycles: packings spread 20 %, a cell's cycle SEM 2 %: SEM 7.6 %
    noise = components(0.20, 0.02)
    step = plan_next_step(noise, 7, 40, 10.0, 0.05, LIMITS, run_cost, pour_cpu_s=5.0)
    assert step.kind == "more_cells" and step.cycles == 40
    # the fewest cells that reach the target with the margin: (0.2^2 + 0.02^2) K^-1 <= 0.05^2 / 1.2
    assert 7 + step.new_cells == math.ceil((0.2 ** 2 + 0.02 ** 2) * PLAN_MARGIN / 0.05 ** 2)
    assert step.reaches_target and step.predicted_sem <= 0.05
    assert step.cpu_s == pytest.approx(runs_cpu_s(step.new_cells, 40, run_cost, 24) + 5.0 * step.new_cells)


def test_cycle_noise_dominating_adds_cycles_when_new_packings_cost_more():
    # no packing spread, a cell's cycle SEM 25 % over 40 cycles: SEM 9.4 % with 7 cells
    noise = components(0.0, 0.25)
    step = plan_next_step(noise, 7, 40, 10.0, 0.05, LIMITS, run_cost, pour_cpu_s=5.0)
    assert step.kind == "more_cycles" and step.new_cells == 0 and step.run_cells == 7
    assert step.cycles == math.ceil(40 * 0.25 ** 2 * PLAN_MARGIN / (7 * 0.05 ** 2))
    assert step.reaches_target


def test_with_free_packings_more_cells_beat_rerunning_the_cycles():
    # the same noise, but new packings cost nothing (already poured for another case) and the
    # transient is long: fresh cells are cheaper than paying the transient and 40 cycles again
    noise = components(0.0, 0.25)
    step = plan_next_step(noise, 7, 40, 10.0, 0.05, LIMITS, run_cost, pour_cpu_s=0.0)
    assert step.kind in ("more_cells", "both") and step.new_cells > 0
    cycles_only = plan_next_step(noise, 7, 40, 10.0, 0.05,
                                 Limits(7, 400, 1e4, 24), run_cost, pour_cpu_s=0.0)
    assert cycles_only.kind == "more_cycles" and cycles_only.cpu_s > step.cpu_s


def test_both_components_large_gives_both():
    noise = components(0.15, 0.40)
    step = plan_next_step(noise, 7, 40, 10.0, 0.05, Limits(24, 400, 1e4, 24), run_cost, 5.0)
    assert step.kind == "both" and step.new_cells > 0 and step.cycles > 40
    assert step.run_cells == 7 + step.new_cells and step.reaches_target


def test_a_met_target_plans_nothing():
    assert plan_next_step(components(0.02, 0.02), 7, 40, 10.0, 0.05, LIMITS, run_cost, 5.0) is None


def test_caps_stop_the_plan_short_of_the_target():
    noise = components(0.30, 0.02)
    # cells capped at 14: the best is all 14 cells, and it does not reach 5 %
    step = plan_next_step(noise, 7, 40, 10.0, 0.05, Limits(14, 400, 1e4, 24), run_cost, 5.0)
    assert 7 + step.new_cells == 14 and not step.reaches_target
    assert step.predicted_sem == pytest.approx(noise.sem(14, step.cycles))
    # at the cells cap with only packing spread, more cycles cannot help: nothing to do
    assert plan_next_step(components(0.30, 0.0001), 14, 40, 10.0, 0.05,
                          Limits(14, 400, 1e4, 24), run_cost, 5.0) is None
    # a CPU cap: the step is the largest the budget pays for
    budget = Limits(48, 400, 40.0, 24)
    step = plan_next_step(noise, 7, 40, 10.0, 0.05, budget, run_cost, 5.0)
    assert step is not None and step.cpu_s <= 30.0 and not step.reaches_target
    assert plan_next_step(noise, 7, 40, 40.0, 0.05, budget, run_cost, 5.0) is None


def test_more_cells_than_a_run_holds_are_split_over_runs():
    assert runs_cpu_s(30, 40, run_cost, 24) == pytest.approx(2 * run_cost(15, 40))
    assert runs_cpu_s(24, 40, run_cost, 24) == pytest.approx(run_cost(24, 40))


def continue_cost(n_new: int) -> float:
    """Taking the 7 cells of one 40-cycle run on to ``n_new`` cycles: the cycles added alone."""
    return MODEL.run_cpu_s(7, 11, 1000 * (n_new - 40))


def test_more_cycles_on_an_engine_that_continues_cost_only_the_cycles_added():
    noise = components(0.0, 0.2)                     # cycle noise only: more cycles
    replay = plan_next_step(noise, 7, 40, 10.0, 0.05, LIMITS, run_cost, 5.0)
    continued = plan_next_step(noise, 7, 40, 10.0, 0.05, LIMITS, run_cost, 5.0, continue_cost)
    assert replay.kind == continued.kind == "more_cycles" and continued.cycles == replay.cycles
    assert (replay.run_cells, replay.continued_cells) == (7, 0)
    assert (continued.run_cells, continued.continued_cells) == (0, 7)
    assert replay.cpu_s == pytest.approx(run_cost(7, replay.cycles))
    assert continued.cpu_s == pytest.approx(continue_cost(continued.cycles))
    # the transient and the 40 cycles already run are not paid again
    assert replay.cpu_s - continued.cpu_s == pytest.approx(run_cost(7, 40) - MODEL.overhead_s)


def test_both_continues_the_old_runs_only_where_that_is_cheaper():
    """With a per-step cost that does not grow with the cells (10 us here), one run of all the
    cells can cost less than the old run continued beside a run of the new cells: the cheaper
    is planned."""
    continued = plan_next_step(components(0.12, 0.15), 7, 40, 10.0, 0.05, LIMITS, run_cost, 5.0,
                               continue_cost)
    assert continued.kind == "both" and continued.continued_cells == 7
    assert continued.run_cells == continued.new_cells == 2
    assert continued.cpu_s == pytest.approx(continue_cost(continued.cycles)
                                            + run_cost(2, continued.cycles) + 2 * 5.0)
    assert continued.cpu_s < run_cost(9, continued.cycles) + 2 * 5.0
    fresh = plan_next_step(components(0.10, 0.30), 7, 40, 10.0, 0.05, LIMITS, run_cost, 5.0,
                           continue_cost)
    assert fresh.kind == "both" and fresh.continued_cells == 0
    assert fresh.run_cells == 7 + fresh.new_cells
    assert fresh.cpu_s == pytest.approx(run_cost(fresh.run_cells, fresh.cycles) + fresh.new_cells * 5.0)
    assert fresh.cpu_s < (continue_cost(fresh.cycles) + run_cost(fresh.new_cells, fresh.cycles)
                          + fresh.new_cells * 5.0)


def test_lost_cycles_are_taken_off_the_measured_cycles():
    # a run of N measured cycles keeps N - L: SEM and the cycles asked for both count them
    plain = components(0.05, 0.10)
    losing = Components(plain.value, plain.packing_var, plain.cycle_noise_var, lost_cycles=30.0)
    assert losing.sem(7, 70) == pytest.approx(plain.sem(7, 40), rel=1e-15)
    assert losing.cycles_for(7, 0.03) == pytest.approx(plain.cycles_for(7, 0.03) + 30.0, rel=1e-15)
    assert losing.cycles_for(7, 0.01) == math.inf == plain.cycles_for(7, 0.01)
    step = plan_next_step(losing, 7, 70, 10.0, 0.03, LIMITS, run_cost, pour_cpu_s=1e3)
    assert step.kind == "more_cycles" and step.reaches_target
    assert step.predicted_sem == pytest.approx(losing.sem(7, step.cycles), rel=1e-15)
    assert losing.sem(7, step.cycles) <= 0.03 / math.sqrt(PLAN_MARGIN) * (1 + 1e-12)
