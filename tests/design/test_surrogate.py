"""Surrogates of C_eq: accuracy on analytic tables, cross-validation, refusals, save/load.

The analytic table ``onset`` mimics what the DEM gives: C_eq grows like f^1.1, rises steeply
from near zero above 1 g and saturates (1 - exp(-(G - 0.5)/3)), and has a fill optimum. It is
sampled on the reference grid (5 f x 3 G x 4 r).
"""

import itertools
import json

import numpy as np
import pandas as pd
import pytest

from pidpipe.design.surrogate import (
    DEFAULT_METHOD,
    DEFAULT_TARGET,
    SPLINE_METHODS,
    TARGETS,
    cross_validate,
    fit_surrogate,
    load_surrogate,
    save_surrogate,
    select_surrogate,
)
from pidpipe.errors import DomainError, TableError

F_HZ = (50.0, 100.0, 500.0, 750.0, 1000.0)
G_G = (1.0, 5.0, 10.0)
R_PCT = (25.0, 50.0, 75.0, 90.0)


def onset(f, g, r):
    """Analytic C_eq of the coupon, N*s/m."""
    return 2.0 * (f / 100.0) ** 1.1 * (1.0 - np.exp(-(g - 0.5) / 3.0)) * (r / 100.0) * np.exp(-r / 120.0)


def power_law(f, g, r):
    """ln C linear in (ln f, ln G, r): every method must reproduce it exactly (log target)."""
    return 0.03 * f**1.2 * g**-0.4 * np.exp(0.01 * r)


def grid_table(function, f=F_HZ, g=G_G, r=R_PCT) -> pd.DataFrame:
    table = pd.DataFrame(list(itertools.product(f, g, r)), columns=["freq_hz", "accel_g", "fill_pct"])
    table["ceq_coupon_ns_m"] = function(table["freq_hz"], table["accel_g"], table["fill_pct"])
    return table


def random_points(n=1500, seed=1):
    """Off-grid points filling the reference domain: f log-uniform, G and r uniform."""
    rng = np.random.default_rng(seed)
    return (np.exp(rng.uniform(np.log(50), np.log(1000), n)), rng.uniform(1, 10, n),
            rng.uniform(25, 90, n))


def relative_errors(surrogate, function):
    f, g, r = random_points()
    truth = function(f, g, r)
    return np.abs(surrogate.predict(f, g, r) - truth) / truth


@pytest.mark.parametrize("method", SPLINE_METHODS)
def test_power_law_is_reproduced_exactly(method):
    # ln C is linear in u = (ln f, ln G, r): multilinear, spline and thin-plate-with-linear-tail
    # interpolants reproduce linear functions exactly; the 1e-12 offset changes ln C by <1e-9.
    surrogate = fit_surrogate(grid_table(power_law), method=method, log_offset_fraction=1e-12)
    assert relative_errors(surrogate, power_law).max() < 1e-6


@pytest.mark.parametrize("method, target", list(itertools.product(SPLINE_METHODS, TARGETS)))
def test_every_surrogate_interpolates_the_table(method, target):
    table = grid_table(onset)
    surrogate = fit_surrogate(table, method=method, target=target)
    predicted = surrogate.predict(table["freq_hz"], table["accel_g"], table["fill_pct"])
    np.testing.assert_allclose(predicted, table["ceq_coupon_ns_m"], rtol=1e-8)


def _multilinear_bound(surrogate, function, f, g, r):
    """Error bound of multilinear interpolation of y = ln(C + c0) in u = (ln f, ln G, r) at the
    query points: |e| <= sum_i h_i^2 / 8 * max_cell |d2y/du_i2| over the query's grid cell.
    The maximum is sampled on 9^3 points per cell and given a 20 % margin."""
    c0 = surrogate.offset_ns_m
    levels = [np.log(F_HZ), np.log(G_G), np.asarray(R_PCT)]
    to_phys = [np.exp, np.exp, lambda v: v]
    u = [np.log(f), np.log(g), r]
    cell = [np.clip(np.searchsorted(lv, ui) - 1, 0, lv.size - 2) for lv, ui in zip(levels, u)]
    bound = np.zeros(f.size)
    for index in set(zip(*cell)):
        lo = [lv[i] for lv, i in zip(levels, index)]
        hi = [lv[i + 1] for lv, i in zip(levels, index)]
        axes = [np.linspace(a, b, 9) for a, b in zip(lo, hi)]
        uu = np.meshgrid(*axes, indexing="ij")
        total = 0.0
        for k in range(3):
            step = 1e-3 * (hi[k] - lo[k])
            shifted = []
            for delta in (-step, 0.0, step):
                parts = [uu[j] + (delta if j == k else 0.0) for j in range(3)]
                phys = [to_phys[j](parts[j]) for j in range(3)]
                shifted.append(np.log(function(*phys) + c0))
            second = (shifted[0] - 2 * shifted[1] + shifted[2]) / step**2
            total += (hi[k] - lo[k]) ** 2 / 8.0 * np.abs(second).max()
        mask = (cell[0] == index[0]) & (cell[1] == index[1]) & (cell[2] == index[2])
        bound[mask] = 1.2 * total
    return bound


def test_tensor_linear_error_within_the_interpolation_bound():
    surrogate = fit_surrogate(grid_table(onset), method="tensor_linear", target="log")
    f, g, r = random_points()
    y_true = np.log(onset(f, g, r) + surrogate.offset_ns_m)
    y_pred = np.log(surrogate.predict(f, g, r) + surrogate.offset_ns_m)
    bound = _multilinear_bound(surrogate, onset, f, g, r)
    error = np.abs(y_pred - y_true)
    assert np.all(error <= bound)
    # The bound is not vacuous: somewhere the error reaches 73 % of it (measured), and its
    # largest value, in the 1-5 g cells, is 1.0 in ln C; the median is 0.2.
    assert np.max(error / bound) > 0.4
    assert np.median(bound) < 0.3


@pytest.mark.parametrize("method, rms_bound, max_bound", [
    # Measured on this table: tensor_spline 2.0 % rms / 6.3 % max, rbf_thin_plate 4.7 % / 14.6 %.
    # The error is dominated by the G interval 1-5 g, where the onset bends and the grid has
    # only 3 levels; the bounds leave a factor ~1.6 for changes of SciPy's internals while still
    # failing if a coordinate or target transform goes wrong (linear G: rbf 19 % rms).
    ("tensor_spline", 0.035, 0.10),
    ("rbf_thin_plate", 0.075, 0.22),
])
def test_off_grid_error_on_the_analytic_table_is_small(method, rms_bound, max_bound):
    errors = relative_errors(fit_surrogate(grid_table(onset), method=method, target="log"), onset)
    assert np.sqrt(np.mean(errors**2)) < rms_bound
    assert errors.max() < max_bound


def test_zero_damping_at_low_g_is_fitted_without_negative_or_infinite_values():
    table = grid_table(onset)
    table.loc[table["accel_g"] == 1.0, "ceq_coupon_ns_m"] = 0.0  # spheres do not lift off
    surrogate = fit_surrogate(table, method="rbf_thin_plate", target="log")
    f, g, r = random_points(300)
    values = surrogate.predict(f, g, r)
    assert np.all(np.isfinite(values)) and np.all(values >= 0.0)
    assert surrogate.predict(100.0, 1.0, 50.0) == pytest.approx(0.0, abs=1e-9)


def test_cross_validation_reports_every_candidate_with_sensible_numbers():
    cv = cross_validate(grid_table(onset))
    plane = cv[cv["scheme"] == "plane"]
    # gp is left out: this table has no SEMs
    assert set(zip(plane["method"], plane["target"])) == set(itertools.product(SPLINE_METHODS,
                                                                               ("log", "linear")))
    # interior levels: f 100/500/750 (12 points each), G 5 (20), r 50/75 (15 each)
    assert (plane["n_folds"] == 6).all() and (plane["n_predictions"] == 86).all()
    point = cv[cv["scheme"] == "point"]
    assert set(point["method"]) == {"rbf_thin_plate"} and (point["n_predictions"] == 60).all()
    assert (cv["rms_rel_error"] > 0).all() and (cv["rms_rel_error"] <= cv["max_rel_error"]).all()
    best_point = point[point["target"] == "log"].iloc[0]
    assert best_point["rms_rel_error"] < 0.04  # measured 1.9 %
    # on this table the log target beats the linear one for every method
    for method in SPLINE_METHODS:
        rows = plane[plane["method"] == method].set_index("target")
        assert rows.loc["log", "rms_rel_error"] < rows.loc["linear", "rms_rel_error"]
    assert select_surrogate(cv) == ("rbf_thin_plate", "log")


def test_ci_grid_has_no_plane_folds_and_falls_back_to_the_default():
    table = grid_table(onset, f=(100.0, 500.0), g=(1.0, 5.0), r=(25.0, 50.0))
    cv = cross_validate(table, methods=("tensor_linear", "rbf_thin_plate"))
    assert set(cv["scheme"]) == {"point"}
    assert select_surrogate(cv) == (DEFAULT_METHOD, DEFAULT_TARGET)
    assert fit_surrogate(table, method="tensor_spline").predict(300.0, 3.0, 40.0) > 0


def test_predict_refuses_queries_outside_the_domain():
    surrogate = fit_surrogate(grid_table(onset))
    with pytest.raises(DomainError, match=r"fill_pct = 95 % is outside the surrogate's domain \[25, 90\] %"):
        surrogate.predict(100.0, 5.0, 95.0)
    with pytest.raises(DomainError, match=r"freq_hz = 20 Hz .* \[50, 1000\] Hz"):
        surrogate.predict([100.0, 20.0], 5.0, 50.0)
    with pytest.raises(DomainError, match="accel_g must be finite"):
        surrogate.predict(100.0, np.nan, 50.0)
    with pytest.raises(DomainError, match="do not broadcast"):
        surrogate.predict([100.0, 200.0], [2.0, 3.0, 4.0], 50.0)
    assert isinstance(surrogate.predict(100.0, 5.0, 50.0), float)
    assert surrogate.predict(np.full((2, 3), 100.0), 5.0, 50.0).shape == (2, 3)


def test_too_few_levels_says_how_many_it_has_and_needs():
    table = grid_table(onset, g=(5.0,))
    with pytest.raises(TableError, match=r"accel_g has 1 distinct value\(s\) \(5\) .* needs at least 2"):
        fit_surrogate(table, method="tensor_linear")


def test_bad_values_in_used_rows_and_unknown_options_are_refused():
    table = grid_table(onset)
    table.loc[3, "ceq_coupon_ns_m"] = np.nan
    with pytest.raises(TableError, match=r"ceq_coupon_ns_m is missing or not finite in row\(s\) 4"):
        fit_surrogate(table)
    with pytest.raises(TableError, match="method 'kriging' is unknown"):
        fit_surrogate(grid_table(onset), method="kriging")
    with pytest.raises(TableError, match="repeat the same"):
        fit_surrogate(pd.concat([grid_table(onset), grid_table(onset).iloc[:1]]))


def failed_table() -> pd.DataFrame:
    table = grid_table(onset)
    table["status"] = "ok"
    table.loc[[7, 30], "status"] = ["failed", "flagged"]
    table.loc[7, "ceq_coupon_ns_m"] = np.nan
    return table


@pytest.mark.parametrize("method", SPLINE_METHODS)
def test_holes_left_by_non_ok_rows_are_refused_by_default(method):
    with pytest.raises(TableError, match=r"leave 2 grid point\(s\) empty .*1 failed.*f=50 Hz, G=5 g, r=90 %"):
        fit_surrogate(failed_table(), method=method)


def test_tensor_methods_cannot_bridge_holes_even_when_allowed():
    with pytest.raises(TableError, match="needs a complete grid"):
        fit_surrogate(failed_table(), method="tensor_spline", allow_holes=True)


def test_rbf_bridges_holes_only_when_asked_and_reports_them():
    surrogate = fit_surrogate(failed_table(), method="rbf_thin_plate", allow_holes=True)
    assert len(surrogate.training) == 58
    assert sorted(surrogate.holes) == [(50.0, 5.0, 90.0), (500.0, 5.0, 75.0)]
    assert sorted(row["status"] for row in surrogate.excluded) == ["failed", "flagged"]
    assert "bridges 2 hole(s)" in surrogate.describe()
    truth = onset(500.0, 5.0, 75.0)
    assert surrogate.predict(500.0, 5.0, 75.0) == pytest.approx(truth, rel=0.1)


def test_save_and_load_round_trip(tmp_path):
    surrogate = fit_surrogate(failed_table(), method="rbf_thin_plate", allow_holes=True)
    path = tmp_path / "surrogate.json"
    save_surrogate(surrogate, path)
    loaded = load_surrogate(path)
    f, g, r = random_points(200)
    np.testing.assert_allclose(loaded.predict(f, g, r), surrogate.predict(f, g, r), rtol=1e-12)
    assert loaded.method == surrogate.method and loaded.domain == surrogate.domain
    assert loaded.holes == surrogate.holes and loaded.excluded == surrogate.excluded


def test_load_refuses_foreign_or_inconsistent_files(tmp_path):
    path = tmp_path / "surrogate.json"
    save_surrogate(fit_surrogate(grid_table(onset), method="tensor_linear"), path)
    document = json.loads(path.read_text())
    document["check_values_ns_m"][0] *= 1.5
    path.write_text(json.dumps(document))
    with pytest.raises(TableError, match="differs from the saved one"):
        load_surrogate(path)
    path.write_text(json.dumps({"format": "something-else"}))
    with pytest.raises(TableError, match="not a pidpipe-surrogate"):
        load_surrogate(path)


def test_cross_validation_in_worker_processes_gives_the_same_table():
    table = grid_table(onset, f=(100.0, 500.0, 1000.0), g=(1.0, 5.0, 10.0), r=(25.0, 50.0, 90.0))
    table["ceq_coupon_sem_ns_m"] = 0.03 * table["ceq_coupon_ns_m"] + 1e-3
    methods = ("gp", "tensor_linear")
    here = cross_validate(table, methods=methods)
    assert "gp" in set(here["method"]) and set(here["scheme"]) == {"point", "plane"}
    pd.testing.assert_frame_equal(cross_validate(table, methods=methods, workers=2), here)


def test_a_log_line_lists_a_few_points_and_counts_the_rest():
    from pidpipe.design.surrogate import LISTED_POINTS, listed_points

    points = [(50.0, float(g), 25.0) for g in range(1, 1196)]
    line = listed_points(points)
    assert line.startswith("(50.0, 1.0, 25.0), (50.0, 2.0, 25.0)")
    assert line.count("(") == LISTED_POINTS
    assert line.endswith(f" and {1195 - LISTED_POINTS} more")
    assert listed_points(points[:2]) == "(50.0, 1.0, 25.0), (50.0, 2.0, 25.0)"
