"""Each design's 95 % interval from the surrogate's predictive std."""

import numpy as np
import pytest

from pidpipe.config.settings import Budget
from pidpipe.design.built_cells import whole_sphere_cells
from pidpipe.design.designs import optimise_designs
from pidpipe.refine.intervals import Z95, design_interval
from tests._surrogates import FakeSurrogate

from ._fakes import BUDGET, ENVIRONMENTS, SEARCH, TrueModel, true_ceq


def _std(f, g, r):
    return 0.02 * true_ceq(f, g, r) * (1.0 + f / 1000.0)    # varies over the band


class JointSurrogate(FakeSurrogate):
    """The fake surrogate with independent points: a diagonal covariance."""

    def predict_joint(self, f, g, r):
        mean, std = self.predict_with_uncertainty(f, g, r)
        return mean, np.diag(std ** 2)


@pytest.fixture(scope="module")
def results():
    return optimise_designs(TrueModel(), ENVIRONMENTS[:1], BUDGET, SEARCH)


def test_the_peak_interval_is_the_std_at_the_design_point(results):
    peak = results[0]
    interval = design_interval(FakeSurrogate(true_ceq, _std), peak, SEARCH.rule)
    d = peak.design
    per_cell = d.n_cells / BUDGET.n_cells_coupon
    assert interval.total_ceq_ns_m == pytest.approx(d.total_ceq_ns_m)
    assert interval.std_ns_m == pytest.approx(per_cell * float(_std(d.freq_hz, d.accel_g, d.fill_pct)))
    assert interval.hi - interval.lo == pytest.approx(2 * Z95 * interval.std_ns_m)
    assert interval.method == "point"


def test_the_band_mean_bound_holds_the_joint_std_and_equals_the_weighted_std(results):
    band = results[1]
    bound = design_interval(FakeSurrogate(true_ceq, _std), band, SEARCH.rule)
    joint = design_interval(JointSurrogate(true_ceq, _std), band, SEARCH.rule)
    f, g, w = SEARCH.rule.quadrature(band.bounds)
    s = _std(f, g, np.full_like(f, band.design.fill_pct))
    per_cell = band.design.n_cells / BUDGET.n_cells_coupon
    assert bound.method == "correlated bound" and joint.method == "joint"
    assert bound.std_ns_m == pytest.approx(per_cell * np.sum(w * s))
    assert joint.std_ns_m == pytest.approx(per_cell * np.sqrt(np.sum(w ** 2 * s ** 2)))
    assert joint.std_ns_m < bound.std_ns_m
    assert bound.total_ceq_ns_m == pytest.approx(band.design.total_ceq_ns_m)


def test_the_worst_case_interval_is_the_std_at_the_band_minimum(results):
    worst = results[2]
    interval = design_interval(FakeSurrogate(true_ceq, _std), worst, SEARCH.rule)
    f, g = SEARCH.rule.grid(worst.bounds)
    r = np.full_like(f, worst.design.fill_pct)
    k = int(np.argmin(true_ceq(f, g, r)))
    per_cell = worst.design.n_cells / BUDGET.n_cells_coupon
    assert interval.std_ns_m == pytest.approx(per_cell * _std(f[k], g[k], r[k]))
    assert interval.total_ceq_ns_m == pytest.approx(worst.design.total_ceq_ns_m)


def test_an_interval_is_within_a_fraction_when_its_half_width_is(results):
    interval = design_interval(FakeSurrogate(true_ceq, _std), results[0], SEARCH.rule)
    fraction = interval.half_width_fraction
    assert interval.within(fraction * 1.0001) and not interval.within(fraction * 0.9999)
    assert Z95 * interval.target_std_ns_m(fraction) == pytest.approx(fraction * interval.total_ceq_ns_m)


def test_a_design_of_two_sphere_counts_sums_both_cells_and_their_joint_std():
    budget = Budget(n_spheres=4400, full_cell_spheres=20, n_cells_coupon=441, n_cells_panel=1000)
    for result in optimise_designs(TrueModel(), ENVIRONMENTS[:1], budget, SEARCH):
        cells = whole_sphere_cells(budget, result.design.n_cells, result.bounds["fill_pct"])
        assert len(cells) == 2, cells                   # 4400 spheres do not divide evenly
        (r_w, n_w), (r_up, n_up) = cells
        bound = design_interval(FakeSurrogate(true_ceq, _std), result, SEARCH.rule)
        joint = design_interval(JointSurrogate(true_ceq, _std), result, SEARCH.rule)
        assert bound.total_ceq_ns_m == pytest.approx(result.design.total_ceq_ns_m)
        assert bound.method == "correlated bound" and joint.method == "joint"
        if result.kind == "peak":
            f, g = result.design.freq_hz, result.design.accel_g
            a, b = n_w / 441 * _std(f, g, r_w), n_up / 441 * _std(f, g, r_up)
            assert bound.std_ns_m == pytest.approx(a + b)
            assert joint.std_ns_m == pytest.approx(np.hypot(a, b))
        assert joint.std_ns_m < bound.std_ns_m
