"""A round's choice: the variance one more measurement removes, and a deterministic order."""

import numpy as np
import pandas as pd
import pytest
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import RBF, ConstantKernel

from pidpipe.design.designs import optimise_designs
from pidpipe.design.packing_noise import LOADS_COLUMN, format_loads
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
    return choose(table if fitted is None else fitted, lambda t, start=None: model, model, results,
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


@pytest.mark.parametrize("dem_sem, fitted_case", [(8.0, True), (20.0, False)])
def test_a_failing_point_gets_a_fitted_case_only_while_it_can_move_z(round_inputs, dem_sem,
                                                                      fitted_case):
    """The surrogate's std is 5 everywhere: against a verifying SEM of 8 a fitted case there
    still shrinks z's denominator; against 20 it cannot, and the point is only verified again."""
    key = Request(275.0, 5.0, 45.0).key
    failing = pd.DataFrame([{"case_key": key, "design": "low/peak", "point": "centre", "z": 3.1,
                             "freq_hz": 275.0, "accel_g": 5.0, "fill_pct": 45.0, "runs": 2,
                             "dem_sem_ns_m": dem_sem, "surrogate_std_ns_m": 5.0}])
    chosen = _choose(round_inputs, failing=failing)
    assert [(q.key, q.action, q.run) for q in chosen.reverify] == [(key, "reverify", 2)]
    assert (key in {c.key for c in chosen.cases}) == fitted_case
    assert ("no fitted case" in chosen.reverify[0].reason) != fitted_case


def _with_shared_loads(fitted: pd.DataFrame, shared_fraction: float) -> pd.DataFrame:
    """Every row loaded on the same 7 packings of its fill, the same pattern in every row (the
    cells' deviations fully correlated), with v = shared_fraction * SEM^2."""
    pattern = np.array([3.0, -2.0, 1.0, 0.0, -1.0, 2.0, -3.0])
    pattern /= np.sqrt(np.sum(pattern**2))
    out = fitted.copy()
    out[LOADS_COLUMN] = [
        format_loads({k: (1 / 7, float(p * np.sqrt(shared_fraction) * sem)) for k, p in enumerate(pattern)})
        for sem in out["ceq_coupon_sem_ns_m"]]
    return out


def _gain(request) -> float:
    return float(request.reason.split("removes ")[1].split(" ")[0])


def test_a_new_case_on_packings_its_fill_shares_gains_only_what_they_do_not_share(round_inputs):
    """The first pick opens a new fill; its fantasy carries the loads a case on that fill's pilot
    packings is expected to have, so later new cases at that fill (or at a grid fill, whose rows
    share theirs) are credited only with the part of their noise the packings do not share,
    and the second pick goes to a fill of its own."""
    fitted = round_inputs[3]
    plain = _choose(round_inputs, cases=6)
    shared = _choose(round_inputs, fitted=_with_shared_loads(fitted, 0.8), cases=6)
    assert shared.cases[0] == plain.cases[0]            # no row at its fill yet: the same gain
    first_fill = shared.cases[0].fill_pct
    assert shared.cases[1].fill_pct not in set(fitted["fill_pct"]) | {first_fill}
    plain_later = max(_gain(c) for c in plain.cases[1:] if c.fill_pct == first_fill)
    shared_later = [_gain(c) for c in shared.cases[1:] if c.fill_pct == first_fill]
    assert shared_later and max(shared_later) < 0.5 * plain_later
