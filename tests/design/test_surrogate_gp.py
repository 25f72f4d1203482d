"""The Gaussian-process surrogate: calibration on tables of known truth and noise, holes,
flagged cases, save/load, refits and the generic value column.

The synthetic tables lie on the reference grid (5 f x 3 G x 4 r). Their truth is the analytic
``onset`` of test_surrogate (C_eq ~ f^1.1, a steep rise above 1 g, a fill optimum) scaled to the
order of the DEM's coupon values (1.2-410 N*s/m on the grid); their noise is of the order the
DEM campaign reports (tests/fixtures/ceq_table_dem_default.csv: 2-5 % at 5 and 10 g, 4-63 % at
1 g): SEMs of 5 % at 5 and 10 g and of 30 % at 1 g, where the cases are flagged
(``not_resolved`` or ``target_not_reached``) and the spline surrogates leave them out.
"""

import itertools
import json

import numpy as np
import pandas as pd
import pytest

from pidpipe.design.surrogate import (
    NOISE_AT_COLUMN,
    cross_validate,
    fit_surrogate,
    load_surrogate,
    loo_predictions,
    refit_values,
    save_surrogate,
)
from pidpipe.errors import TableError

F_HZ = (50.0, 100.0, 500.0, 750.0, 1000.0)
G_G = (1.0, 5.0, 10.0)
R_PCT = (25.0, 50.0, 75.0, 90.0)
VALUE, SEM = "ceq_coupon_ns_m", "ceq_coupon_sem_ns_m"


def truth(f, g, r):
    """C_eq of the coupon, N*s/m."""
    f, g, r = (np.asarray(a, dtype=float) for a in (f, g, r))
    return 80.0 * (f / 100.0) ** 1.1 * (1.0 - np.exp(-(g - 0.5) / 3.0)) * (r / 100.0) * np.exp(-r / 120.0)


def noisy_table(seed: int, f=F_HZ, g=G_G, r=R_PCT) -> pd.DataFrame:
    """The truth on the grid plus Gaussian noise of the stated SEMs; 1 g rows flagged."""
    table = pd.DataFrame(list(itertools.product(f, g, r)), columns=["freq_hz", "accel_g", "fill_pct"])
    exact = truth(table["freq_hz"], table["accel_g"], table["fill_pct"])
    low = table["accel_g"].to_numpy() == 1.0
    sem = np.where(low, 0.30, 0.05) * exact
    table[VALUE] = exact + sem * np.random.default_rng(seed).standard_normal(len(table))
    table[SEM] = sem
    table["status"] = np.where(low, "flagged", "ok")
    table["flags"] = np.where(low, np.where(table["fill_pct"] < 60, "not_resolved", "target_not_reached"), "")
    return table


def random_points(n, rng):
    """Off-grid points filling the reference domain: f log-uniform, G and r uniform."""
    return (np.exp(rng.uniform(np.log(50), np.log(1000), n)), rng.uniform(1, 10, n),
            rng.uniform(25, 90, n))


@pytest.fixture(scope="module")
def coverage():
    """Coverage of the truth by the GP's latent 68.3 % and 95 % intervals on 40 synthetic
    tables: {(where, level): one fraction per table}, where is ``grid`` (the 60 grid points),
    ``off 5-10 g`` and ``off 1-5 g`` (random off-grid points between the 5 and 10 g levels and
    between the 1 and 5 g levels). Each table's GP is fitted from scratch, hyperparameters
    included."""
    n_tables, n_off = 40, 90
    rng = np.random.default_rng(7)
    out = {}
    for seed in range(n_tables):
        table = noisy_table(seed)
        surrogate = fit_surrogate(table, method="gp")
        assert len(surrogate.training) == 60  # the flagged 1 g rows are fitted
        off = random_points(n_off, rng)
        high = off[1] >= 5.0
        where = {"grid": (table["freq_hz"], table["accel_g"], table["fill_pct"]),
                 "off 5-10 g": tuple(a[high] for a in off),
                 "off 1-5 g": tuple(a[~high] for a in off)}
        for name, points in where.items():
            exact = truth(*points)
            for level in (0.6827, 0.95):
                lower, upper = surrogate.predict_interval(*points, level=level)
                out.setdefault((name, level), []).append(
                    (np.sum((exact >= lower) & (exact <= upper)), exact.size))
    return out


def _check_coverage(counts, level):
    """Mean coverage within 3 times its scatter of the nominal level. Points of one table share
    one fit, so their misses are correlated: the scatter of the mean coverage is taken from the
    spread between tables, and never below the binomial scatter of the pooled points."""
    hits, sizes = np.array(counts, dtype=float).T
    fractions = hits / sizes
    mean = hits.sum() / sizes.sum()
    scatter = max(fractions.std(ddof=1) / np.sqrt(fractions.size),
                  np.sqrt(level * (1 - level) / sizes.sum()))
    assert 3.0 * scatter < 0.08  # the test can tell 68 % from 60 % or 76 %
    assert abs(mean - level) <= 3.0 * scatter, (level, mean, scatter)


@pytest.mark.slow
@pytest.mark.parametrize("where", ["grid", "off 5-10 g"])
@pytest.mark.parametrize("level", [0.6827, 0.95])
def test_intervals_cover_the_truth_at_their_nominal_rates(coverage, where, level):
    _check_coverage(coverage[(where, level)], level)


@pytest.mark.slow
def test_the_95_pct_intervals_between_1_and_5_g_cover_the_truth_at_their_nominal_rate(coverage):
    # Measured: 94.0 +- 1.4 %. With the cases observed as transformed values (before the
    # linearised observations) 86.8 +- 2.6 %: the 30 % SEMs at 1 g, taken as Gaussian in ln C,
    # were understated, and the intervals between 1 and 5 g came out too narrow.
    _check_coverage(coverage[("off 1-5 g", 0.95)], 0.95)


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason=(
    "between the 1 and 5 g levels the truth's onset bends and the grid has no level to show it; "
    "measured on these tables: 60.9 +- 3.5 % of the truth inside the 68.3 % intervals (47.9 +- "
    "3.8 % with the cases observed as transformed values), against 67.6 % between 5 and 10 g: "
    "consistent with the nominal rate within 3 scatters, but the scatter between tables is too "
    "large for this check to tell 68 % from 60 %"))
def test_the_68_pct_intervals_between_1_and_5_g_cover_the_truth_at_their_nominal_rate(coverage):
    _check_coverage(coverage[("off 1-5 g", 0.6827)], 0.6827)


def test_a_hole_is_bridged_with_a_larger_uncertainty_than_its_neighbours():
    table = noisy_table(3)
    hole = (500.0, 5.0, 50.0)
    at_hole = ((table["freq_hz"] == hole[0]) & (table["accel_g"] == hole[1])
               & (table["fill_pct"] == hole[2])).to_numpy()
    table.loc[at_hole, ["status", VALUE, SEM]] = ["failed", np.nan, np.nan]
    with pytest.raises(TableError, match="leave 1 grid point"):
        fit_surrogate(table, method="gp")
    surrogate = fit_surrogate(table, method="gp", allow_holes=True)
    assert surrogate.holes == [hole]
    # its neighbours along f and r, measured with the same 5 % SEM (the ones along G have 30 %
    # at 1 g); relative uncertainties, as C_eq differs by 10x between them
    neighbours = np.array([(100.0, 5.0, 50.0), (750.0, 5.0, 50.0), (500.0, 5.0, 25.0),
                           (500.0, 5.0, 75.0)])
    value, u = surrogate.predict_with_uncertainty(*hole)
    _, u_neighbours = surrogate.predict_with_uncertainty(*neighbours.T)
    # measured: 2.43 % at the hole, 2.11-2.53 % (mean 2.37 %) at the neighbours; the neighbours
    # nearer an edge of the domain have more than the interior ones, so the mean is compared.
    # (With the cases observed as transformed values, before the linearised observations, the
    # fit's length scales were shorter and the hole stood out more: 3.5 % against 2.8-3.4 %.)
    assert u / value > np.mean(u_neighbours / surrogate.predict(*neighbours.T))
    # the same point measured: 2.2 % (the hole widens it 1.10 times; 1.17, 1.10 and 1.13 with
    # seeds 4-6; 1.23 and 1.18 with seeds 3 and 4 before the linearised observations)
    full = fit_surrogate(noisy_table(3), method="gp")
    assert u > 1.05 * full.predict_with_uncertainty(*hole)[1]
    assert abs(value - truth(*hole)) < 3.0 * u


def test_flagged_1g_cases_are_fitted_where_the_splines_bridge_a_hole():
    # The splines fit status-ok rows only: with one 1 g case left ok they bridge 1 g from 5 g.
    table = noisy_table(5)
    keep_ok = ((table["accel_g"] == 1.0) & (table["freq_hz"] == 50.0) & (table["fill_pct"] == 25.0))
    table.loc[keep_ok, ["status", "flags"]] = ["ok", ""]
    gp = fit_surrogate(table, method="gp")
    rbf = fit_surrogate(table, method="rbf_thin_plate", allow_holes=True)
    assert len(gp.training) == 60 and len(rbf.training) == 41
    f, r = np.meshgrid(np.linspace(450, 500, 6), np.linspace(25, 90, 6))
    g = np.ones_like(f)
    exact = truth(f, g, r)
    value, u = gp.predict_with_uncertainty(f, g, r)
    gp_error = np.abs(value - exact)
    rbf_error = np.abs(rbf.predict(f, g, r) - exact)
    assert np.all(gp_error < 3.0 * u)
    # measured: 3.7 against 16.3 N*s/m RMS, the GP within 2.3 u; the RBF is high everywhere
    # (bridged from 5 g)
    assert np.sqrt(np.mean(gp_error**2)) < 0.4 * np.sqrt(np.mean(rbf_error**2))
    assert np.all(rbf.predict(f, g, r) > exact)


def test_save_and_load_rebuild_the_same_gp_without_optimising(tmp_path):
    surrogate = fit_surrogate(noisy_table(1), method="gp")
    path = tmp_path / "surrogate.json"
    save_surrogate(surrogate, path)
    document = json.loads(path.read_text())
    assert len(document["options"]["kernel_theta"]) == 5  # amplitude, 3 length scales, white
    assert "Matern" in document["gp_kernel"]
    assert NOISE_AT_COLUMN in document["training"]
    loaded = load_surrogate(path)
    assert loaded._model.regressor.optimizer is None
    np.testing.assert_array_equal(loaded._model.theta, surrogate._model.theta)
    f, g, r = random_points(200, np.random.default_rng(2))
    for a, b in zip(loaded.predict_with_uncertainty(f, g, r), surrogate.predict_with_uncertainty(f, g, r)):
        np.testing.assert_allclose(a, b, rtol=1e-10)
    document["check_uncertainty_ns_m"][3] *= 1.1
    path.write_text(json.dumps(document))
    with pytest.raises(TableError, match="differs from the saved one"):
        load_surrogate(path)


def test_refit_on_new_values_keeps_the_kernel_and_the_noise():
    surrogate = fit_surrogate(noisy_table(2), method="gp")
    values = truth(surrogate.training["freq_hz"], surrogate.training["accel_g"],
                   surrogate.training["fill_pct"])
    again = refit_values(surrogate, values)
    np.testing.assert_array_equal(again._model.theta, surrogate._model.theta)
    np.testing.assert_array_equal(again._model.noise, surrogate._model.noise)
    point = (300.0, 3.0, 60.0)
    assert again.predict(*point) != surrogate.predict(*point)
    # the uncertainty depends on where the points are and on their noise, not on the values
    assert (again.predict_with_uncertainty(*point)[1] / again.predict(*point)
            == pytest.approx(surrogate.predict_with_uncertainty(*point)[1] / surrogate.predict(*point), rel=0.2))


def test_any_value_column_with_its_sem_column_can_be_fitted(tmp_path):
    table = noisy_table(4)
    table["m_eff_cell_kg"] = 1e-6 * table[VALUE] + 2e-4
    table["m_eff_cell_sem_kg"] = 1e-6 * table[SEM]
    surrogate = fit_surrogate(table, method="gp", value_column="m_eff_cell_kg",
                              sem_column="m_eff_cell_sem_kg")
    point = (300.0, 7.0, 60.0)
    value, u = surrogate.predict_with_uncertainty(*point)
    assert abs(value - (1e-6 * truth(*point) + 2e-4)) < 3 * u
    assert 0 < u < 1e-5
    path = tmp_path / "m_eff.json"
    save_surrogate(surrogate, path)
    loaded = load_surrogate(path)
    assert loaded.value_column == "m_eff_cell_kg" and loaded.predict(*point) == pytest.approx(value, rel=1e-10)


def test_splines_have_no_uncertainty_and_gp_needs_sems():
    table = noisy_table(0)
    with pytest.raises(TableError, match="no uncertainty of its own"):
        fit_surrogate(table, method="rbf_thin_plate", allow_holes=True).predict_with_uncertainty(300, 5, 50)
    with pytest.raises(TableError, match="has no column ceq_coupon_sem_ns_m; for a table without SEMs"):
        fit_surrogate(table.drop(columns=[SEM]), method="gp")
    with pytest.raises(ValueError, match="level"):
        fit_surrogate(table, method="gp").predict_interval(300, 5, 50, level=1.5)


def test_leave_one_out_of_the_gp_reports_z_scores_and_coverage():
    table = noisy_table(6, f=(50.0, 500.0, 1000.0), g=(1.0, 5.0, 10.0), r=(25.0, 90.0))
    points = loo_predictions(table, "gp")
    assert len(points) == 18 and set(points["status"]) == {"ok", "flagged"}
    assert np.all(np.isfinite(points["z"])) and np.all(points["u"] > 0)
    cv = cross_validate(table, methods=("rbf_thin_plate", "gp"), schemes=("point",), rows="policy")
    gp = cv.set_index("method").loc["gp"]
    assert gp["n_predictions"] == 18 and 0.0 <= gp["coverage_68"] <= gp["coverage_95"] <= 1.0
    assert 0.3 < gp["z_std"] < 3.0 and gp["rms_error_per_sem"] > 0
    rbf = cv[cv["method"] == "rbf_thin_plate"]
    assert list(rbf["target"]) == ["log", "linear"] and rbf["z_std"].isna().all()


@pytest.mark.slow
def test_leave_one_out_z_scores_on_the_dem_campaign_table_are_calibrated():
    # The default campaign's DEM table (tests/fixtures/README.md), every case the fit policy keeps
    # held out in turn. For 60 z-scores of a calibrated model the mean scatters by 1/sqrt(60) =
    # 0.13 and the standard deviation by 1/sqrt(2 * 59) = 0.09: the bounds are 3 of those.
    # Measured: z mean -0.04, std 0.95 (0.02 and 0.87 with the cases observed as transformed
    # values, before the linearised observations); RMS error 2.30 case SEMs against 5.13 for the RBF
    # fitted to the same rows and 116 for the RBF fitted to the ok rows only.
    from pathlib import Path

    from pidpipe.design.ceq_table import read_ceq_table

    table = read_ceq_table(Path(__file__).parents[1] / "fixtures" / "ceq_table_dem_default.csv")
    gp = loo_predictions(table, "gp")
    assert len(gp) == 60 and (gp["status"] == "flagged").sum() == 17
    assert abs(gp["z"].mean()) < 3 / np.sqrt(60)
    assert abs(gp["z"].std(ddof=1) - 1.0) < 3 / np.sqrt(2 * 59)

    def rms_per_sem(points):
        return np.sqrt(np.mean(((points["predicted"] - points["value"]) / points["sem"]) ** 2))

    rbf_policy = loo_predictions(table, "rbf_thin_plate", rows="policy")
    rbf_ok = loo_predictions(table, "rbf_thin_plate", rows="policy", fit_rows="ok")
    assert rms_per_sem(gp) < 0.6 * rms_per_sem(rbf_policy) < 0.6 * rms_per_sem(rbf_ok)


def test_uncertainty_interval_and_scatter_agree():
    surrogate = fit_surrogate(noisy_table(8), method="gp")
    f, g, r = random_points(50, np.random.default_rng(3))
    value, u = surrogate.predict_with_uncertainty(f, g, r)
    lower, upper = surrogate.predict_interval(f, g, r, level=0.6827, clip=False)
    np.testing.assert_allclose(u, 0.5 * (upper - lower), rtol=1e-3)  # 0.6827 vs erf(1/sqrt 2)
    np.testing.assert_allclose(value, surrogate.predict(f, g, r))
    assert np.all((lower < value) & (value < upper))  # the median of a log-normal interval
    _, u_scatter = surrogate.predict_with_uncertainty(f, g, r, include_scatter=True)
    assert np.all(u_scatter >= u)
    wide = surrogate.predict_interval(f, g, r, level=0.95)
    assert np.all((wide[0] <= np.maximum(lower, 0.0)) & (wide[1] >= upper))
    value, u = surrogate.predict_with_uncertainty(300.0, 5.0, 50.0)
    assert value.shape == () and u.shape == ()


# The default grid through lift-off: G in {0.5, 1, 2, 5, 10} g. With the truth above (onset at
# 0.5 g) the C_eq on the 0.5 g plane is exactly zero, and so is its noise (relative SEMs, as
# benchmarks/compare_surrogates.py draws them): the log target puts those 20 rows at ln(c0),
# several log units below the 1 g plane and flat in f and r, a cliff no DEM table has (the
# campaign's 0.5 g cases measure 0.0006-380 N*s/m with SEMs). With the onset at 0.25 g the
# truth is positive on every level.
G_LIFT_OFF = (0.5, 1.0, 2.0, 5.0, 10.0)
#: The DEM campaign's relative SEM per G level (tests/fixtures/ceq_table_dem_default_100.csv:
#: median 35 % at 0.5 g, 18-25 % at 1 g, about 4 % above).
RELATIVE_SEM = {0.5: 0.35, 1.0: 0.25}


def truth_with_onset(f, g, r, onset_g):
    """:func:`truth` with its onset (zero C_eq) at ``onset_g`` instead of 0.5 g."""
    return truth(f, np.asarray(g, dtype=float) - onset_g + 0.5, r)


def lift_off_table(seed: int, onset_g: float) -> pd.DataFrame:
    """The truth on the through-lift-off grid with the DEM campaign's relative SEMs per level;
    flagged as the measurement flags them (within 2 SEM of zero: not_resolved)."""
    table = pd.DataFrame(list(itertools.product(F_HZ, G_LIFT_OFF, R_PCT)),
                         columns=["freq_hz", "accel_g", "fill_pct"])
    exact = truth_with_onset(table["freq_hz"], table["accel_g"], table["fill_pct"], onset_g)
    sem = table["accel_g"].map(RELATIVE_SEM).fillna(0.04).to_numpy() * exact
    table[VALUE] = exact + sem * np.random.default_rng(seed).standard_normal(len(table))
    table[SEM] = sem
    unresolved = table[VALUE] <= 2.0 * sem
    table["status"] = np.where(unresolved, "flagged", "ok")
    table["flags"] = np.where(unresolved, "not_resolved", "")
    return table


def lift_off_coverage(onset_g: float, n_tables: int = 20, n_off: int = 150,
                      observations: str = "linearised") -> dict:
    """As the :func:`coverage` fixture on through-lift-off tables, off-grid points with G
    log-uniform: ``grid`` and ``off <lo>-<hi> g`` for every interval between G levels."""
    rng = np.random.default_rng(11)
    out = {}
    for seed in range(n_tables):
        table = lift_off_table(seed, onset_g)
        surrogate = fit_surrogate(table, method="gp", gp_observations=observations)
        assert len(surrogate.training) == 100
        f, r = np.exp(rng.uniform(np.log(50), np.log(1000), n_off)), rng.uniform(25, 90, n_off)
        g = np.exp(rng.uniform(np.log(0.5), np.log(10), n_off))
        where = {"grid": (table["freq_hz"], table["accel_g"], table["fill_pct"])}
        for lo, hi in zip(G_LIFT_OFF[:-1], G_LIFT_OFF[1:]):
            inside = (g >= lo) & (g < hi)
            where[f"off {lo:g}-{hi:g} g"] = (f[inside], g[inside], r[inside])
        for name, points in where.items():
            exact = truth_with_onset(*points, onset_g)
            for level in (0.6827, 0.95):
                lower, upper = surrogate.predict_interval(*points, level=level)
                out.setdefault((name, level), []).append(
                    (np.sum((exact >= lower) & (exact <= upper)), exact.size))
    return out


@pytest.fixture(scope="module")
def zero_plane_coverage():
    """The truth zero on the 0.5 g plane (onset 0.5 g)."""
    return lift_off_coverage(0.5)


@pytest.fixture(scope="module")
def positive_coverage():
    """The truth positive on every level (onset 0.25 g)."""
    return lift_off_coverage(0.25)


def _merged(coverage, names, level):
    """The per-table counts of several bands added together (one (hits, size) per table)."""
    return [tuple(np.sum([coverage[(name, level)][k] for name in names], axis=0))
            for k in range(len(coverage[(names[0], level)]))]


def _pooled_and_scatter(counts, level):
    """Pooled coverage and its scatter (as :func:`_check_coverage` takes it)."""
    hits, sizes = np.array(counts, dtype=float).T
    fractions = hits / sizes
    scatter = max(fractions.std(ddof=1) / np.sqrt(fractions.size),
                  np.sqrt(level * (1 - level) / sizes.sum()))
    return hits.sum() / sizes.sum(), scatter


ABOVE_1_G = ("off 1-2 g", "off 2-5 g", "off 5-10 g")
BELOW_2_G = ("off 0.5-1 g", "off 1-2 g")


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason=(
    "a stationary kernel against a cliff: the zero-noise rows at ln(c0) on the 0.5 g plane set "
    "the fit's amplitude and G length scale, and the intervals between 1 and 10 g come out too "
    "wide (measured on these tables: 98.6 +- 1.0 % of the truth inside the 68.3 % intervals, "
    "99.9 +- 0.5 % inside the 95 % ones; docs/explanation/designs.md)"))
@pytest.mark.parametrize("level", [0.6827, 0.95])
def test_with_a_zero_plane_the_intervals_above_1_g_are_calibrated(zero_plane_coverage, level):
    _check_coverage(_merged(zero_plane_coverage, ABOVE_1_G, level), level)


@pytest.mark.slow
def test_with_a_zero_plane_the_pooled_coverage_hides_two_opposite_misses(zero_plane_coverage):
    # What a pooled off-grid figure hides: above 1 g the truth lies inside the 68.3 % intervals
    # far more often than nominal, between 0.5 and 1 g (where the truth's log falls without
    # bound toward the zero plane, and no level shows where) far less often. Measured: 98.6 +-
    # 1.0 % above 1 g, 25.1 +- 2.5 % between 0.5 and 1 g.
    above, above_scatter = _pooled_and_scatter(_merged(zero_plane_coverage, ABOVE_1_G, 0.6827),
                                               0.6827)
    below, below_scatter = _pooled_and_scatter(zero_plane_coverage[("off 0.5-1 g", 0.6827)],
                                               0.6827)
    assert above - 3.0 * above_scatter > 0.6827 > below + 3.0 * below_scatter


@pytest.mark.slow
@pytest.mark.parametrize("level", [0.6827, 0.95])
def test_with_a_positive_truth_the_intervals_are_near_their_nominal_rates(positive_coverage,
                                                                         level):
    # With the truth positive on every level the cliff is gone. Measured on these tables (68.3 %
    # / 95 % intervals): grid 66.4 / 94.4 %, 0.5-1 g 56.8 / 91.8 %, 1-2 g 55.6 / 87.6 %, 2-5 g
    # 58.9 / 90.2 %, 5-10 g 68.3 / 93.7 %, with scatters between tables of 4.6-5.5 points
    # (68.3 %) and 2.0-3.2 (95 %) off the grid: within 3 scatters of nominal, where the
    # transformed observations were not (0.5-2 g: 37.8 +- 4.5 % and 74.2 +- 4.3 %; the SEMs of
    # 25-35 % there, taken as Gaussian in ln C, were understated). Twenty tables cannot tell
    # 68 % from 60 % (the scatter between tables), so this checks 3 scatters only.
    for band in ("grid", "off 0.5-1 g", "off 1-2 g", "off 2-5 g", "off 5-10 g"):
        pooled, scatter = _pooled_and_scatter(positive_coverage[(band, level)], level)
        assert abs(pooled - level) <= 3.0 * scatter, (band, pooled, scatter)
    pooled, scatter = _pooled_and_scatter(positive_coverage[("grid", level)], level)
    assert 3.0 * scatter < 0.05                          # on the grid the check is sharp


#: Tables of the comparison of linearised and transformed observations.
COMPARED_TABLES = 10


@pytest.fixture(scope="module")
def transformed_positive_coverage():
    """The first :data:`COMPARED_TABLES` tables of :func:`positive_coverage`, fitted on
    transformed observations (the same tables and points: the same seeds)."""
    return lift_off_coverage(0.25, n_tables=COMPARED_TABLES, observations="transformed")


@pytest.mark.slow
@pytest.mark.parametrize("level", [0.6827, 0.95])
def test_linearised_observations_cover_the_truth_below_2_g_better_than_transformed(
        positive_coverage, transformed_positive_coverage, level):
    # The same ten positive-truth tables fitted both ways: between 0.5 and 2 g the transformed
    # observations' intervals miss the truth far more often (a draw near zero lands several log
    # units below, outside its stated noise). Measured: 56.5 against 37.4 % inside the 68.3 %
    # intervals (gain 19.2 +- 5.1 points), 92.1 against 78.0 % inside the 95 % ones (14.4 +- 3.9).
    # The linearised fits are positive_coverage's first ten (lift_off_coverage draws table k's
    # points after table k-1's, so its first ten tables do not depend on n_tables).
    linearised = _merged(positive_coverage, BELOW_2_G, level)[:COMPARED_TABLES]
    transformed = _merged(transformed_positive_coverage, BELOW_2_G, level)
    # paired by table (the same tables, the same points): the per-table differences' scatter
    (hits_l, sizes), (hits_t, _) = (np.array(c, dtype=float).T for c in (linearised, transformed))
    gain = (hits_l - hits_t) / sizes
    assert gain.mean() > 3.0 * gain.std(ddof=1) / np.sqrt(gain.size), gain
    assert hits_l.sum() / sizes.sum() < level + 0.05           # nearer nominal, not beyond it


def test_linearised_observations_are_saved_refitted_and_old_files_reload_as_they_were(tmp_path):
    table = noisy_table(9)
    surrogate = fit_surrogate(table, method="gp")
    assert surrogate.options["gp_observations"] == "linearised"
    f, g, r = random_points(50, np.random.default_rng(4))
    # a refit on the same values rebuilds the same observations, so the same predictions
    again = refit_values(surrogate, surrogate.training[VALUE].clip(lower=0.0).to_numpy())
    np.testing.assert_allclose(again.predict(f, g, r), surrogate.predict(f, g, r), rtol=1e-9)
    # a file from before the option (transformed observations, no key) reloads unchanged
    old = fit_surrogate(table, method="gp", gp_observations="transformed")
    path = tmp_path / "old.json"
    save_surrogate(old, path)
    document = json.loads(path.read_text())
    del document["options"]["gp_observations"]
    path.write_text(json.dumps(document))
    loaded = load_surrogate(path)
    np.testing.assert_allclose(loaded.predict(f, g, r), old.predict(f, g, r), rtol=1e-10)
    # the two observations differ where the 1 g cases' 30 % SEMs make ln C skewed
    assert not np.allclose(old.predict(f, g, r), surrogate.predict(f, g, r), rtol=1e-3)
    with pytest.raises(TableError, match="gp_observations"):
        fit_surrogate(table, method="gp", gp_observations="exact")


def test_each_fold_starts_from_the_whole_tables_kernel_without_restarts(monkeypatch):
    import pidpipe.design.gaussian_process as gp_module  # the surrogate imports it per fit

    table = noisy_table(6, f=(50.0, 500.0, 1000.0), g=(1.0, 5.0, 10.0), r=(25.0, 90.0))
    starts = []
    real = gp_module.fit_gaussian_process

    def recording(x, y, noise, theta=None, start=None):
        starts.append(None if start is None else np.array(start, dtype=float))
        return real(x, y, noise, theta=theta, start=start)

    monkeypatch.setattr(gp_module, "fit_gaussian_process", recording)
    restarted = loo_predictions(table, "gp", fold_start="restarts")
    # each of the 18 folds: a first fit with restarts, a second from the first's kernel
    assert len(starts) == 36 and all(s is None for s in starts[0::2])
    whole = fit_surrogate(table, "gp", rows="policy", allow_holes=True)
    starts.clear()
    warm = loo_predictions(table, "gp")
    # the whole table's two fits, then every fold's first fit starts from its kernel
    assert len(starts) == 2 + 36 and starts[0] is None
    for first in starts[2::2]:
        np.testing.assert_array_equal(first, whole.options["kernel_theta"])
    # the folds' predictions move by a small fraction of their own uncertainty
    shift = np.abs(warm["predicted"] - restarted["predicted"]) / restarted["u"]
    assert shift.max() < 0.25
    with pytest.raises(ValueError, match="fold_start must be one of"):
        loo_predictions(table, "gp", fold_start="never")
