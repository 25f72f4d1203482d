"""Multi-start SLSQP under the particle budget, on analytic C_eq models whose optimum is known.

With the budget spent exactly, n_c = 100 n_b / (s r), so the objective (C/N) n_c equals
100 n_b / (N s) * C(f, G, r) / r: the best fill maximises C/r, and when C grows with f and G
the best f and G are the tops of the environment's bands.
"""

import itertools
import json

import numpy as np
import pandas as pd
import pytest

from pidpipe.design.designs import (
    history_frame,
    results_frame,
    write_history_csv,
    write_results_csv,
    write_results_json,
)
from pidpipe.design.optimisation import (
    Budget,
    BudgetError,
    Environment,
    optimise_environment,
    optimise_environments,
)
from pidpipe.design.surrogate import fit_surrogate
from pidpipe.errors import ConfigError, DomainError

DOMAIN = {"freq_hz": (50.0, 1000.0), "accel_g": (1.0, 10.0), "fill_pct": (25.0, 90.0)}
ENV = Environment("250-300 Hz, 5-6 g", (250.0, 300.0), (5.0, 6.0))
BUDGET = Budget(n_spheres=230, full_cell_spheres=22, n_cells_coupon=441)


class Analytic:
    """C_eq = 0.01 f (1 + 0.1 G) r * shape(r), N*s/m; C/r = 0.01 f (1 + 0.1 G) shape(r)."""

    domain = DOMAIN

    def __init__(self, shape):
        self.shape = shape

    def predict(self, freq_hz, accel_g, fill_pct):
        for name, value in zip(("freq_hz", "accel_g", "fill_pct"), (freq_hz, accel_g, fill_pct)):
            lo, hi = self.domain[name]
            assert np.all((np.asarray(value) >= lo) & (np.asarray(value) <= hi)), (name, value)
        r = np.asarray(fill_pct, dtype=float)
        return 0.01 * freq_hz * (1 + 0.1 * accel_g) * r * self.shape(r)


def single_peak(r):
    """C/r peaks at r = 50 %."""
    return (r / 50.0) * np.exp(1.0 - r / 50.0)


def two_peaks(r):
    """C/r has its global peak at r = 35 % and a lower local one at r = 75 %."""
    return np.exp(-((r - 35.0) ** 2) / 200.0) + 0.6 * np.exp(-((r - 75.0) ** 2) / 200.0)


def best_total(model, fill, budget=BUDGET, f=300.0, g=6.0):
    n_cells = 100.0 * budget.n_spheres / (budget.full_cell_spheres * fill)
    return model.predict(f, g, fill) / budget.n_cells_coupon * n_cells


def test_known_optimum_is_found_from_most_starts():
    model = Analytic(single_peak)
    result = optimise_environment(model, ENV, BUDGET, starts=24, seed=3)
    opt = result.optimum
    assert opt.fill_pct == pytest.approx(50.0, abs=0.05)
    assert opt.freq_hz == pytest.approx(300.0) and opt.accel_g == pytest.approx(6.0)
    assert opt.total_ceq_ns_m == pytest.approx(best_total(model, 50.0), rel=1e-6)
    assert opt.n_starts >= 0.8 * 24
    assert result.n_converged >= 0.8 * 24


def test_whole_cell_design_respects_budget_and_bounds():
    model = Analytic(single_peak)
    result = optimise_environment(model, ENV, BUDGET, starts=12, seed=3)
    d = result.design
    assert isinstance(d.n_cells, int) and 1 <= d.n_cells <= BUDGET.n_cells_coupon
    assert d.n_cells in (20, 21)  # continuous optimum 20.9
    assert d.spheres_per_cell == pytest.approx(BUDGET.n_spheres / d.n_cells)
    assert d.spheres_per_cell * d.n_cells == pytest.approx(BUDGET.n_spheres)
    assert d.whole_spheres_per_cell * d.n_cells + d.spheres_left_over == BUDGET.n_spheres
    assert 0 <= d.spheres_left_over < d.n_cells
    assert abs(d.budget_residual_spheres) < 1e-9
    assert DOMAIN["fill_pct"][0] <= d.fill_pct <= DOMAIN["fill_pct"][1]
    assert ENV.freq_hz[0] <= d.freq_hz <= ENV.freq_hz[1] and ENV.accel_g[0] <= d.accel_g <= ENV.accel_g[1]
    assert d.total_ceq_ns_m == pytest.approx(d.ceq_per_cell_ns_m * d.n_cells)
    assert d.total_ceq_ns_m <= result.optimum.total_ceq_ns_m * (1 + 1e-9)
    assert d.total_ceq_ns_m == pytest.approx(result.optimum.total_ceq_ns_m, rel=1e-3)
    for run in result.starts:
        if run.converged:
            assert abs(run.budget_residual_spheres) <= 1e-6 * BUDGET.n_spheres


def test_distinct_local_optima_are_reported_and_the_global_one_wins():
    model = Analytic(two_peaks)
    result = optimise_environment(model, ENV, BUDGET, starts=30, seed=11)
    fills = sorted(round(o.fill_pct) for o in result.local_optima)
    assert fills == [35, 75]
    assert result.optimum.fill_pct == pytest.approx(35.0, abs=0.1)
    assert result.local_optima[1].total_ceq_ns_m < result.optimum.total_ceq_ns_m
    assert sum(o.n_starts for o in result.local_optima) == result.n_converged
    for run in result.starts:  # history: from the start's objective to the end point's
        assert run.history_ns_m[0] == pytest.approx(best_total(model, run.start["fill_pct"],
                                                               f=run.start["freq_hz"], g=run.start["accel_g"]))
        assert run.history_ns_m[-1] == pytest.approx(run.objective_ns_m, rel=1e-6)
        # one entry per iteration SciPy calls back after; SciPy 1.17's SLSQP may count two
        # iterations in its last call (traced: iter 9 -> 11 with exit mode 0), so nit can be
        # one more than the callbacks
        assert run.n_iterations <= len(run.history_ns_m) <= run.n_iterations + 1


def test_cell_count_bound_is_respected_when_it_binds():
    # C/r falls with r, so the fewest spheres per cell win; a budget this large needs
    # n_c = N = 441 cells at r = 100 * 5000 / (22 * 441) = 51.5 %.
    model = Analytic(lambda r: np.exp(-r / 30.0))
    budget = Budget(n_spheres=5000, full_cell_spheres=22, n_cells_coupon=441)
    result = optimise_environment(model, ENV, budget, starts=10, seed=1)
    assert result.optimum.n_cells == pytest.approx(441.0, rel=1e-6)
    assert result.optimum.fill_pct == pytest.approx(100 * 5000 / (22 * 441), rel=1e-5)
    assert result.design.n_cells == 441


def test_same_seed_same_result():
    model = Analytic(two_peaks)
    a = optimise_environment(model, ENV, BUDGET, starts=8, seed=5)
    b = optimise_environment(model, ENV, BUDGET, starts=8, seed=5)
    assert [r.history_ns_m for r in a.starts] == [r.history_ns_m for r in b.starts]


def test_environment_outside_the_domain_is_refused_unless_clipped():
    model = Analytic(single_peak)
    wide = Environment("900-1200 Hz", (900.0, 1200.0), (5.0, 6.0))
    with pytest.raises(DomainError, match=r"freq_hz band \[900, 1200\] Hz leaves .* \[50, 1000\] Hz"):
        optimise_environment(model, wide, BUDGET, starts=4)
    result = optimise_environment(model, wide, BUDGET, starts=4, clip_environment=True)
    assert result.clipped and result.bounds["freq_hz"] == (900.0, 1000.0)
    assert result.design.freq_hz == pytest.approx(1000.0)
    far = Environment("2 kHz", (2000.0, 2500.0), (5.0, 6.0))
    with pytest.raises(DomainError, match="does not overlap"):
        optimise_environment(model, far, BUDGET, starts=4, clip_environment=True)


def test_infeasible_budgets_are_refused_with_the_reason():
    model = Analytic(single_peak)
    with pytest.raises(BudgetError, match=r"budget of 5 spheres is less than one cell at the lowest fill 25 %"):
        optimise_environment(model, ENV, Budget(5, 22, 441), starts=4)
    # the source's 15876 spheres with 36 per full cell need r = 100 % in all 441 cells
    with pytest.raises(BudgetError, match=r"cannot be spent: all 441 cells at the highest fill 90 %"):
        optimise_environment(model, ENV, Budget(15876, 36, 441), starts=4)


def test_invalid_inputs_are_refused():
    with pytest.raises(ConfigError, match="0 < low <= high"):
        Environment("bad", (300.0, 250.0), (5.0, 6.0))
    with pytest.raises(ConfigError, match="starts must be >= 1"):
        optimise_environment(Analytic(single_peak), ENV, BUDGET, starts=0)


def test_end_to_end_with_a_fitted_surrogate_and_written_results(tmp_path):
    grid = pd.DataFrame(list(itertools.product((50.0, 100.0, 500.0, 750.0, 1000.0), (1.0, 5.0, 10.0),
                                               (25.0, 50.0, 75.0, 90.0))),
                        columns=["freq_hz", "accel_g", "fill_pct"])
    model = Analytic(single_peak)
    grid["ceq_coupon_ns_m"] = model.predict(grid["freq_hz"], grid["accel_g"], grid["fill_pct"])
    surrogate = fit_surrogate(grid)
    envs = [ENV, Environment("750-800 Hz, 4-6 g", (750.0, 800.0), (4.0, 6.0))]
    results = optimise_environments(surrogate, envs, BUDGET, starts=6, seed=2)
    # C/r is flat near its peak, so the surrogate moves the fill more than the value
    assert 40.0 <= results[0].optimum.fill_pct <= 60.0
    assert results[0].optimum.total_ceq_ns_m == pytest.approx(best_total(model, 50.0), rel=0.02)
    write_results_csv(results, tmp_path / "optimum.csv")
    write_history_csv(results, tmp_path / "history.csv")
    write_results_json(results, tmp_path / "optimum.json")
    table = pd.read_csv(tmp_path / "optimum.csv")
    assert list(table["environment"]) == [e.name for e in envs]
    assert (table["n_cells"] * table["spheres_per_cell"]).round(6).tolist() == [230.0, 230.0]
    history = pd.read_csv(tmp_path / "history.csv")
    assert len(history) == sum(len(r.history_ns_m) for res in results for r in res.starts)
    assert history_frame(results)["at_optimum"].any()
    document = json.loads((tmp_path / "optimum.json").read_text())
    assert document[1]["design"]["n_cells"] == results[1].design.n_cells
    assert len(document[0]["starts"]) == 6
    assert results_frame(results)["total_ceq_ns_m"].gt(0).all()


# The gradients SLSQP is given: one batched forward difference and an exact budget gradient


def central_difference(fun, z, h=1e-6):
    """A reference derivative of fun (scalar or vector valued) at an interior z: second order."""
    columns = []
    for j in range(z.size):
        step = np.zeros_like(z)
        step[j] = h
        columns.append((np.asarray(fun(z + step)) - np.asarray(fun(z - step))) / (2 * h))
    return np.stack(columns, axis=-1)


def test_forward_difference_steps_like_scipy_backwards_at_the_bound_and_skips_fixed_variables():
    from pidpipe.design.optimisation import FD_RELATIVE_STEP, forward_difference_jacobian

    def values(zs):
        zs = np.atleast_2d(zs)
        return np.column_stack([np.sin(3 * zs[:, 0]) * zs[:, 1], zs[:, 0] ** 2 + np.exp(zs[:, 2])])

    calls = []

    def counted(zs):
        calls.append(len(zs))
        return values(zs)

    z = np.array([0.3, 1.0, 0.0])                 # z_1 at its upper bound: a backward step
    jac = forward_difference_jacobian(counted, z, np.array([False, False, True]))
    assert calls == [3]                             # z and one step per free variable, one call
    h = FD_RELATIVE_STEP
    for j, step in ((0, h), (1, -h)):               # point by point, as SciPy steps
        moved = z.copy()
        moved[j] = z[j] + step
        expected = (values(moved)[0] - values(z)[0]) / (moved[j] - z[j])
        np.testing.assert_array_equal(jac[:, j], expected)
    assert np.all(jac[:, 2] == 0.0)                 # fixed: not stepped
    exact = np.array([[3 * np.cos(0.9) * 1.0, np.sin(0.9)], [0.6, 0.0]])
    np.testing.assert_allclose(jac[:, :2], exact, rtol=1e-6, atol=1e-7)


@pytest.mark.parametrize("z", [np.array([0.2, 0.7, 0.4, 0.5]), np.array([0.9, 0.1, 0.6, 0.3])])
def test_objective_and_budget_gradients_match_finite_differences_of_the_problem(z):
    from pidpipe.design.optimisation import _Problem, environment_bounds

    model = Analytic(two_peaks)
    bounds, _ = environment_bounds(model, ENV, BUDGET)
    problem = _Problem(model, bounds, BUDGET)
    problem.scale = 0.37
    assert problem.objectives(z[None, :])[0] == problem.objective(z)
    reference = central_difference(problem.objective, z)
    np.testing.assert_allclose(problem.objective_gradient(z), reference,
                               rtol=1e-6, atol=1e-7 * np.abs(reference).max())
    reference = central_difference(problem.constraint, z)
    np.testing.assert_allclose(problem.constraint_gradient(z), reference,
                               rtol=1e-8, atol=1e-10 * np.abs(reference).max())
