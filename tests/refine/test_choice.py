"""A round's choice: the variance one more measurement removes, and a deterministic order."""

import numpy as np
import pandas as pd
import pytest
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import RBF, ConstantKernel

from pidpipe.design.designs import optimise_designs
from pidpipe.refine.candidates import EXTEND_FACTOR, Request
from pidpipe.refine.choice import choose, variance_reduction
from pidpipe.refine.intervals import design_intervals
from pidpipe.refine.table import start_table
from tests._surrogates import FakeSurrogate, constant

from ._fakes import BUDGET, ENVIRONMENTS, SEARCH, FakeEngine, TrueModel


def _gp(x, noise):
    kernel = ConstantKernel(1.0) * RBF(0.3)
    return GaussianProcessRegressor(kernel, alpha=noise, optimizer=None).fit(
        x, np.sin(3 * x[:, 0]))


def test_an_extension_removes_what_the_gaussian_process_update_removes():
    x = np.linspace(0, 1, 6)[:, None]
    sem = np.full(6, 0.2)
    before = _gp(x, sem ** 2).predict(x[2:3], return_std=True)[1][0]
    extended = sem.copy()
    extended[2] /= np.sqrt(EXTEND_FACTOR)
    after = _gp(x, extended ** 2).predict(x[2:3], return_std=True)[1][0]
    expected = variance_reduction(np.array([before]), np.array([(EXTEND_FACTOR - 1) / sem[2] ** 2]))
    assert before ** 2 - after ** 2 == pytest.approx(expected[0], rel=1e-6)


def test_a_new_case_removes_what_the_gaussian_process_update_removes():
    x = np.linspace(0, 1, 6)[:, None]
    new = np.array([[0.37]])
    s_e = 0.15
    before = _gp(x, np.full(6, 0.04)).predict(new, return_std=True)[1][0]
    after = _gp(np.vstack([x, new]), np.append(np.full(6, 0.04), s_e ** 2)).predict(
        new, return_std=True)[1][0]
    expected = variance_reduction(np.array([before]), np.array([1 / s_e ** 2]))
    assert before ** 2 - after ** 2 == pytest.approx(expected[0], rel=1e-6)


@pytest.fixture(scope="module")
def round_inputs():
    """A flat surrogate with equal uncertainty everywhere: every candidate gains the same."""
    model = FakeSurrogate(constant(50.0), constant(5.0))
    results = optimise_designs(TrueModel(), ENVIRONMENTS[:1], BUDGET, SEARCH)
    intervals = design_intervals(model, results, SEARCH.rule)
    fitted = start_table(FakeEngine().grid())
    names = {f"{r.environment.name}/{r.kind}" for r in results}
    return model, results, intervals, fitted, names


def _choose(round_inputs, fitted=None, cases=3, cost=FakeEngine.cost, failing=None):
    model, results, intervals, table, names = round_inputs
    failing = pd.DataFrame(columns=["case_key", "design", "point", "z", "freq_hz", "accel_g",
                                    "fill_pct", "runs"]) if failing is None else failing
    return choose(table if fitted is None else fitted, lambda t: model, model, results,
                  intervals, names, failing, cost, cases, 0.10, int(BUDGET.full_cell_spheres))


def test_equal_gains_are_taken_in_key_order_and_the_same_inputs_choose_the_same(round_inputs):
    first = _choose(round_inputs)
    again = _choose(round_inputs)
    assert first == again
    assert len(first.cases) == 3 and all(c.action == "new" for c in first.cases)
    # a flat surrogate: each design served adds the same gain (n_c / N cancels against its
    # target), so the points serving the most designs come first, ties in key order
    order = [(-len(c.designs), c.key) for c in first.cases]
    assert order == sorted(order)
    assert len(first.cases[0].designs) >= 2
    shuffled = round_inputs[3].sample(frac=1.0, random_state=1)
    assert _choose(round_inputs, fitted=shuffled) == first


def test_a_case_dearer_than_its_gain_is_passed_over(round_inputs):
    def cost(request):
        return 1e6 if request.fill_pct == 45.0 else 10.0
    chosen = _choose(round_inputs, cost=cost)
    assert all(c.fill_pct != 45.0 for c in chosen.cases)


def test_a_failing_verify_point_is_run_again_and_gets_a_fitted_case_first(round_inputs):
    failing = pd.DataFrame([{"case_key": Request(275.0, 5.0, 45.0).key, "design": "low/peak",
                             "point": "centre", "z": 3.1, "freq_hz": 275.0, "accel_g": 5.0,
                             "fill_pct": 45.0, "runs": 1}])
    chosen = _choose(round_inputs, failing=failing)
    assert chosen.cases[0].key == failing["case_key"][0] and chosen.cases[0].action == "new"
    assert "verify |z| = 3.10" in chosen.cases[0].reason
    assert [(q.key, q.action, q.run) for q in chosen.reverify] == [(failing["case_key"][0], "reverify", 1)]
