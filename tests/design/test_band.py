"""The three designs on an analytic C_eq whose peak, band-mean and worst-case optima differ.

C_eq = 1e-3 r f (1 + 0.1 G) q(r, f), q = 1 - ((r - r0(f)) / 60)^2, r0(f) = 40 + 0.6 (f - 250) %.
With the budget spent, n_c = 100 n_b / (s r), so the objective is proportional to
f (1 + 0.1 G) q(r, f):

- peak: q = 1 at r = r0(f), so the best point is f = 300 Hz, G = 6 g, r = r0(300) = 70 %;
- band_mean: the f-mean of f q is maximal at r* = int f r0 df / int f df = 55.4545... %
  (2-point Gauss-Legendre already integrates this cubic in f exactly);
- worst_case: G = 5 g is the worst G; f q is concave in f, so the worst f is an end of the
  band, and the best worst case equalises the ends: 250 q(r, 250) = 300 q(r, 300).
"""

import numpy as np
import pytest
from scipy.optimize import brentq

from pidpipe.design.band import BandRule, evaluate_band, optimise_band_design
from pidpipe.design.designs import (
    REGIME_WARNING,
    Search,
    format_designs,
    optimise_designs,
    results_frame,
)
from pidpipe.design.optimisation import Budget, Environment
from pidpipe.errors import ConfigError

DOMAIN = {"freq_hz": (50.0, 1000.0), "accel_g": (1.0, 10.0), "fill_pct": (25.0, 90.0)}
ENV = Environment("250-300 Hz, 5-6 g", (250.0, 300.0), (5.0, 6.0))
BUDGET = Budget(n_spheres=230, full_cell_spheres=22, n_cells_coupon=441)


def r0(f):
    return 40.0 + 0.6 * (np.asarray(f, dtype=float) - 250.0)


class Shifting:
    """The analytic C_eq of the module docstring, N*s/m."""

    domain = DOMAIN

    def predict(self, freq_hz, accel_g, fill_pct):
        f, g, r = (np.asarray(v, dtype=float) for v in (freq_hz, accel_g, fill_pct))
        for name, value in zip(DOMAIN, (f, g, r)):
            assert np.all((value >= DOMAIN[name][0]) & (value <= DOMAIN[name][1])), name
        return 1e-3 * r * f * (1 + 0.1 * g) * (1 - ((r - r0(f)) / 60.0) ** 2)


BAND_MEAN_FILL = 0.6 * ((300**3 - 250**3) / 3) / ((300**2 - 250**2) / 2) - 110.0
WORST_CASE_FILL = brentq(lambda r: 250 * (1 - ((r - 40) / 60) ** 2) - 300 * (1 - ((r - 70) / 60) ** 2),
                         40.0, 70.0)


def total(model, f, g, r, budget=BUDGET):
    """(C/N) n_c with n_c spending the budget at fill r."""
    n_cells = budget.n_spheres / budget.spheres_per_cell(r)
    return model.predict(f, g, r) / budget.n_cells_coupon * n_cells


@pytest.fixture(scope="module")
def designs():
    return {res.kind: res for res in optimise_designs(Shifting(), [ENV], BUDGET, Search(starts=12, seed=4))}


def test_the_three_optima_are_where_the_analysis_puts_them(designs):
    model = Shifting()
    assert BAND_MEAN_FILL == pytest.approx(55.4545, abs=1e-4) and 44 < WORST_CASE_FILL < 46
    peak, mean, worst = designs["peak"].optimum, designs["band_mean"].optimum, designs["worst_case"].optimum
    assert (peak.freq_hz, peak.accel_g) == (pytest.approx(300.0), pytest.approx(6.0))
    assert peak.fill_pct == pytest.approx(70.0, abs=0.05)
    assert mean.fill_pct == pytest.approx(BAND_MEAN_FILL, abs=0.05)
    assert worst.fill_pct == pytest.approx(WORST_CASE_FILL, abs=0.05)
    # objectives: the band mean by a dense trapezoid rule, the worst case at its equal ends
    f = np.linspace(250, 300, 2001)
    g = np.linspace(5, 6, 3)
    ff, gg = np.meshgrid(f, g)
    dense_mean = np.trapezoid(np.trapezoid(total(model, ff, gg, BAND_MEAN_FILL), f, axis=1), g) / 50.0
    assert mean.total_ceq_ns_m == pytest.approx(dense_mean, rel=1e-6)
    assert worst.total_ceq_ns_m == pytest.approx(total(model, 250.0, 5.0, WORST_CASE_FILL), rel=1e-6)
    assert worst.total_ceq_ns_m == pytest.approx(total(model, 300.0, 5.0, WORST_CASE_FILL), rel=1e-6)
    assert peak.total_ceq_ns_m == pytest.approx(total(model, 300.0, 6.0, 70.0), rel=1e-6)
    for res in designs.values():
        assert res.n_converged >= 10 and len(res.local_optima) == 1


def test_every_design_is_evaluated_over_its_band_and_each_wins_its_own_criterion(designs):
    band = {kind: res.band for kind, res in designs.items()}
    # each design's band values lie between its worst and best, and it wins what it maximises
    for b in band.values():
        assert b.worst_total_ceq_ns_m <= b.mean_total_ceq_ns_m <= b.best_total_ceq_ns_m
    rtol = 2e-3  # the whole-cell rounding moves each design a little off its continuous optimum
    assert band["band_mean"].mean_total_ceq_ns_m >= max(b.mean_total_ceq_ns_m for b in band.values()) * (1 - rtol)
    assert band["worst_case"].worst_total_ceq_ns_m >= max(b.worst_total_ceq_ns_m for b in band.values()) * (1 - rtol)
    assert band["peak"].best_total_ceq_ns_m >= max(b.best_total_ceq_ns_m for b in band.values()) * (1 - rtol)
    # the peak design is what today's optimiser reports, and it does much worse at the band's worst
    assert (band["peak"].best_freq_hz, band["peak"].best_accel_g) == (300.0, 6.0)
    assert band["peak"].worst_total_ceq_ns_m < 0.9 * band["worst_case"].worst_total_ceq_ns_m
    assert designs["peak"].design.total_ceq_ns_m == pytest.approx(band["peak"].best_total_ceq_ns_m, rel=1e-9)
    assert designs["band_mean"].design.total_ceq_ns_m == pytest.approx(band["band_mean"].mean_total_ceq_ns_m, rel=1e-9)
    assert designs["worst_case"].design.total_ceq_ns_m == pytest.approx(band["worst_case"].worst_total_ceq_ns_m, rel=1e-9)
    for res in designs.values():  # whole cells, budget spent
        d = res.design
        assert d.spheres_per_cell * d.n_cells == pytest.approx(BUDGET.n_spheres)
        assert abs(d.budget_residual_spheres) < 1e-9


def test_histories_run_from_start_to_end_point(designs):
    for res in designs.values():
        for run in res.starts:
            assert run.history_ns_m[-1] == pytest.approx(run.objective_ns_m, rel=1e-6)
            assert len(run.history_ns_m) == run.n_iterations + 1
            if run.converged:
                assert abs(run.budget_residual_spheres) <= 1e-6 * BUDGET.n_spheres


def test_table_has_a_row_per_design_and_the_regime_warning_where_the_band_reaches_1_g():
    low = Environment("250-300 Hz, 1-2 g", (250.0, 300.0), (1.0, 2.0))
    results = optimise_designs(Shifting(), [ENV, low], BUDGET, Search(starts=4, seed=1))
    table = results_frame(results)
    assert list(table["design"]) == ["peak", "band_mean", "worst_case"] * 2
    assert (table["regime_warning"][:3] == "").all() and (table["regime_warning"][3:] == REGIME_WARNING).all()
    assert table.loc[table["design"] != "peak", "freq_hz"].isna().all()
    text = format_designs(results)
    assert text.count("warning: band reaches G <= 1") == 1
    assert "band_mean" in text and "worst_case" in text and "at 300 Hz, 6 g" in text


def test_quadrature_is_exact_for_a_cubic_and_the_grid_has_the_corners():
    rule = BandRule(quadrature_points=2, grid_points=3)
    bounds = {"freq_hz": (250.0, 300.0), "accel_g": (5.0, 6.0)}

    class Cubic:
        domain = DOMAIN

        def predict(self, f, g, r):
            return np.asarray(f, float) ** 3 * np.asarray(g, float)

    summary = evaluate_band(Cubic(), bounds, Budget(10, 10, 1), 1, rule)
    exact = (300**4 - 250**4) / 4 / 50.0 * 5.5
    assert summary.mean_total_ceq_ns_m == pytest.approx(exact, rel=1e-12)
    assert (summary.worst_freq_hz, summary.worst_accel_g) == (250.0, 5.0)
    assert summary.best_total_ceq_ns_m == pytest.approx(300.0**3 * 6.0)
    with pytest.raises(ConfigError, match="quadrature_points >= 2"):
        BandRule(quadrature_points=1)
    with pytest.raises(ConfigError, match="unknown"):
        optimise_band_design(Shifting(), ENV, BUDGET, "average")


@pytest.mark.parametrize("kind", ["band_mean", "worst_case"])
def test_band_gradients_match_finite_differences_of_the_problem(kind):
    from pidpipe.design.band import _BandProblem
    from pidpipe.design.optimisation import environment_bounds
    from tests.design.test_optimisation import central_difference

    model = Shifting()
    bounds, _ = environment_bounds(model, ENV, BUDGET)
    problem = _BandProblem(model, bounds, BUDGET, kind, BandRule())
    problem.set_scale(0.8)
    z = np.array([0.35, 0.1])[:len(problem.variables)]
    x = problem.to_x(z)
    np.testing.assert_array_equal(problem.band_totals_at(z[None, :])[0],
                                  problem.band_totals(x[0], problem.n_cells(x[0])))
    reference = central_difference(problem.objective, z)
    np.testing.assert_allclose(problem.objective_gradient(z), reference,
                               rtol=1e-6, atol=1e-7 * np.abs(reference).max())
    for constraint in problem.constraints():
        reference = central_difference(constraint["fun"], z)
        np.testing.assert_allclose(constraint["jac"](z), reference,
                                   rtol=1e-6, atol=1e-7 * np.abs(reference).max())
    assert (len(problem.constraints()) == 1) == (kind == "worst_case")
