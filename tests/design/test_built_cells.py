"""A design's cells as built: whole spheres, each read at its own sphere count's fill."""

import numpy as np
import pytest

from pidpipe.config.settings import Budget, Environment
from pidpipe.design.built_cells import cells_total, whole_sphere_cells
from pidpipe.design.optimisation import optimise_environment


class Quadratic:
    """C_eq convex in fill: (r / 10)^2 N*s/m, flat in f and G."""

    domain = {"freq_hz": (100.0, 1000.0), "accel_g": (1.0, 10.0), "fill_pct": (4.762, 100.0)}

    def predict(self, f, g, r):
        f, g, r = np.broadcast_arrays(np.asarray(f, float), np.asarray(g, float), np.asarray(r, float))
        return (r / 10.0) ** 2 + 0.0 * f * g


def test_the_budget_fills_cells_with_whole_spheres_and_one_more_in_the_left_over_ones():
    budget = Budget(100, 21, 441)
    assert whole_sphere_cells(budget, 15) == [(28.571, 5), (33.333, 10)]     # 6 x 5 + 7 x 10
    assert whole_sphere_cells(budget, 20) == [(23.81, 20)]                  # 5 each, none left
    assert whole_sphere_cells(budget, 15, (30.0, 90.0)) == [(30.0, 5), (33.333, 10)]
    with pytest.raises(ValueError):
        whole_sphere_cells(budget, 0)


def test_the_built_total_is_the_mean_fill_reading_for_a_linear_c_and_above_it_for_a_convex_one():
    budget = Budget(100, 21, 441)
    cells = whole_sphere_cells(budget, 15)
    mean_fill = 100.0 * 100 / 15 / 21

    class Linear(Quadratic):
        def predict(self, f, g, r):
            return np.asarray(r, float) * 2.0 + 0.0 * np.asarray(f, float)

    linear = cells_total(Linear(), [500.0], [5.0], cells, 441)[0]
    assert linear == pytest.approx(15 / 441 * 2.0 * mean_fill, rel=1e-4)   # fills rounded to 1e-3 %
    convex = cells_total(Quadratic(), [500.0, 600.0], [5.0, 6.0], cells, 441)
    at_mean = 15 / 441 * (mean_fill / 10.0) ** 2
    expected = (5 * (28.571 / 10) ** 2 + 10 * (33.333 / 10) ** 2) / 441
    np.testing.assert_allclose(convex, expected)
    assert np.all(convex > at_mean)                                         # Jensen: between counts


def test_the_optimisers_whole_cell_design_reports_its_cells_as_built():
    budget = Budget(100, 21, 441)
    environment = Environment("E", (400.0, 600.0), (4.0, 6.0))
    result = optimise_environment(Quadratic(), environment, budget, starts=4, seed=1)
    design = result.design
    cells = whole_sphere_cells(budget, design.n_cells, result.bounds["fill_pct"])
    assert sum(count for _, count in cells) == design.n_cells
    expected = cells_total(Quadratic(), [design.freq_hz], [design.accel_g], cells, 441)[0]
    assert design.total_ceq_ns_m == pytest.approx(expected, rel=1e-12)
