"""The stored cost models (pidpipe/measurement/cost_models.json) that the allocation plans with."""

from __future__ import annotations

import pytest

from pidpipe.errors import ConfigError
from pidpipe.measurement.cost_model import ENGINES, load_cost_model


FIT = {"liggghts": 0.2, "dem": 0.3}
"""How closely each model reproduces the runs it was fitted to (relative): LIGGGHTS' within 15 %
(README); the DEM's within 24 % (7 cells of 11 spheres at 1000 Hz, 0.42 s for 0.55 s measured:
the model has no frequency term, and the DEM's cost per step follows the contacts the motion
makes, more at 1000 Hz than at 500 Hz)."""


@pytest.mark.parametrize("engine", ENGINES)
def test_every_engine_has_a_dated_model_that_fits_its_measured_runs(engine):
    model = load_cost_model(engine)
    assert model is not None, f"no stored cost model for {engine}: run benchmarks/bench_cells.py --cost"
    assert model.engine == engine and model.machine and model.date and "bench_cells.py --cost" in model.command
    assert min(model.overhead_s, model.per_step_s, model.per_cell_step_s, model.per_sphere_step_s,
               model.per_pair_step_s, model.pour_overhead_s, model.pour_per_sphere_s) >= 0.0
    cells = {point["cells"] for point in model.points}
    assert {1, 7}.issubset(cells) and len({point["n_spheres"] for point in model.points}) >= 2
    for point in model.points:
        predicted = model.run_cpu_s(point["cells"], point["n_spheres"], point["steps"])
        assert predicted == pytest.approx(point["cpu_s"], rel=FIT[engine]), point


def test_the_dem_model_covers_the_campaign_cell_counts_and_is_cheaper_than_liggghts():
    dem, liggghts = load_cost_model("dem"), load_cost_model("liggghts")
    assert {1, 2, 4, 7, 14, 28} <= {point["cells"] for point in dem.points}
    assert dem.per_pair_step_s > 0.0 and liggghts.per_pair_step_s == 0.0
    steps = 1112 * 50                              # 50 cycles at 1000 Hz
    for cells, spheres in ((1, 11), (7, 11), (7, 19), (28, 19)):
        assert dem.run_cpu_s(cells, spheres, steps) < liggghts.run_cpu_s(cells, spheres, steps) / 3


def test_an_engine_without_a_slot_is_refused():
    with pytest.raises(ConfigError, match="no cost-model slot"):
        load_cost_model("gromacs")
