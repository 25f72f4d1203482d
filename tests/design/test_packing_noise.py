"""Errors shared through packings: the loads, their covariance, and a GP that does not average
away an offset its cases share.

The synthetic campaigns shake every case of a fill on the same 7 packings, as the grid's pilots
and the loop's new cases do. Each packing damps by its own factor (1 + b_p), b_p ~ N(0, 0.1^2),
the same in every case, and each cell adds cycle noise of 2 %; the truth is
:func:`campaign_truth`.
"""

import itertools

import numpy as np
import pandas as pd
import pytest

from pidpipe.design.bootstrap import resampled_values
from pidpipe.design.gaussian_process import fit_gaussian_process
from pidpipe.design.packing_noise import (
    LOADS_COLUMN,
    SharedPackings,
    cell_loads,
    combine_loads,
    format_loads,
    load_matrices,
    noise_covariance,
    Correlation,
    overlap,
    pair_correlations,
    parse_loads,
)
from pidpipe.design.surrogate import fit_surrogate
from tests.design.test_surrogate_gp import SEM, VALUE

CELLS = 7
PACKING_SPREAD, CYCLE_NOISE = 0.10, 0.02


def test_loads_give_the_between_cells_variance_and_the_cells_correlation():
    """Two rows on the same packings: sum u^2 is var / k, and the pooled correlation is the
    correlation of their cells."""
    rng = np.random.default_rng(3)
    x = rng.normal(10.0, 1.0, (2, CELLS))
    x[1] += 0.5 * x[0]
    weights, u = load_matrices([50.0, 50.0], [cell_loads(row, range(CELLS)) for row in x])
    np.testing.assert_allclose(np.sum(u**2, axis=1), np.var(x, axis=1, ddof=1) / CELLS, rtol=1e-12)
    i, j, r = pair_correlations(weights, u)
    assert (list(i), list(j)) == ([0], [1]) and r[0] == pytest.approx(np.corrcoef(x)[0, 1], rel=1e-12)
    np.testing.assert_allclose(overlap(weights), np.ones((2, 2)))


def test_rows_of_other_fills_share_nothing():
    loads = {0: (0.5, 1.0), 1: (0.5, -1.0)}
    weights, u = load_matrices([25.0, 50.0], [loads, loads])
    assert u.shape == (2, 4)
    assert overlap(weights)[0, 1] == 0.0
    table = pd.DataFrame({"freq_hz": [100.0, 100.0], "accel_g": [5.0, 5.0], "fill_pct": [25.0, 50.0],
                          LOADS_COLUMN: [format_loads(loads)] * 2})
    assert SharedPackings.of(table) is None


def test_the_covariance_is_one_offset_per_packing_set_and_keeps_each_rows_own_noise():
    """Rows on the same packings at one condition share one offset: the shared part has rank one,
    so no combination of the rows removes it; the diagonal is the larger of SEM^2 and v; apart,
    the correlation scales the covariance."""
    weights = np.full((3, 4), 0.25)
    u = np.array([[0.3, -0.3, 0.1, -0.1], [0.4, -0.4, 0.0, 0.0], [0.1, 0.2, -0.3, 0.0]])
    noise = np.array([1.0, 0.01, 0.2])
    v = np.sum(u**2, axis=1)
    covariance = noise_covariance(weights, u, noise, np.ones((3, 3)))
    np.testing.assert_allclose(np.diag(covariance), np.maximum(noise, v))
    shared = covariance - np.diag(np.diag(covariance)) + np.diag(v)
    assert np.linalg.matrix_rank(shared, tol=1e-12) == 1
    apart = noise_covariance(weights, u, noise, np.full((3, 3), 0.5) + 0.5 * np.eye(3))
    assert apart[0, 1] == pytest.approx(0.5 * np.sqrt(v[0] * v[1]))
    assert np.linalg.eigvalsh(apart).min() >= -1e-12


def test_the_correlation_falls_with_distance_as_fitted():
    """Pairs whose correlation falls from 1 to 0.1 over 0.4 (ln units) give that floor and length."""
    truth = Correlation(0.1, 0.4, 1)
    distance = np.linspace(0.0, 3.0, 200)
    fitted = Correlation.fit(distance, truth(distance))
    assert fitted.floor == pytest.approx(0.1, abs=0.02)
    assert fitted.length == pytest.approx(0.4, rel=0.15)
    assert fitted.pairs == 200
    assert Correlation.fit(np.array([]), np.array([])).pairs == 0


def test_loads_round_trip_as_text_and_combine_by_weight():
    loads = {3: (0.25, 0.125), 1: (0.25, -2.5e-7)}
    assert parse_loads(format_loads(loads)) == loads
    assert parse_loads(float("nan")) == {} and parse_loads("") == {}
    assert combine_loads([{1: (1.0, 1.0)}, {1: (0.5, 3.0), 2: (0.5, 2.0)}], [0.25, 0.75]) == {
        1: (0.625, 2.5), 2: (0.375, 1.5)}
    with pytest.raises(ValueError, match="seed:weight:load"):
        parse_loads("1:0.5")


def test_fewer_than_two_cells_have_no_loads():
    assert cell_loads([1.0], [0]) == {}
    assert cell_loads([1.0, float("nan")], [0, 1]) == {}


def test_a_diagonal_covariance_fits_as_scikit_learn_does():
    """The correlated-noise regressor with a diagonal noise is scikit-learn's model."""
    rng = np.random.default_rng(1)
    x = rng.uniform(size=(40, 3))
    y = np.sin(3 * x[:, 0]) + x[:, 1] ** 2 + 0.05 * rng.standard_normal(40)
    noise = np.full(40, 0.05**2)
    diagonal, full = fit_gaussian_process(x, y, noise), fit_gaussian_process(x, y, np.diag(noise))
    np.testing.assert_allclose(full.theta, diagonal.theta, atol=1e-5)
    query = rng.uniform(size=(6, 3))
    for a, b in zip(full.predict(query), diagonal.predict(query)):
        np.testing.assert_allclose(a, b, rtol=1e-6)
    rebuilt = fit_gaussian_process(x, y, np.diag(noise), theta=full.theta)
    np.testing.assert_array_equal(rebuilt(query), full(query))


def campaign_truth(f, g, r):
    """A C_eq (N*s/m) the GP represents well: a power of f, a rise with G, exponential in r."""
    return 80.0 * (f / 100.0) ** 1.1 * (1.0 - np.exp(-(g - 0.5) / 3.0)) * np.exp(r / 100.0)


def shared_packing_table(seed: int, oracle: bool = False) -> pd.DataFrame:
    """A campaign of 5 f x 2 G x 4 r whose cases of a fill share 7 packings (module text).

    ``oracle``: each row's SEM and loads are the true ones (the packings' offset of 0.1 / sqrt(7)
    shared by every row of the fill, the cycle noise its own) instead of the cells' estimates."""
    rng = np.random.default_rng(seed)
    rows = []
    direction = np.eye(CELLS)[0]
    for r in (25.0, 50.0, 75.0, 90.0):
        offsets = rng.normal(0.0, PACKING_SPREAD, CELLS)
        for f, g in itertools.product((300.0, 400.0, 500.0, 600.0, 700.0), (5.0, 10.0)):
            exact = float(campaign_truth(f, g, r))
            cells = exact * (1.0 + offsets + rng.normal(0.0, CYCLE_NOISE, CELLS))
            sem = cells.std(ddof=1) / np.sqrt(CELLS)
            loads = cell_loads(cells, range(CELLS))
            if oracle:
                sem = exact * np.hypot(PACKING_SPREAD, CYCLE_NOISE) / np.sqrt(CELLS)
                loads = {k: (1.0 / CELLS, exact * PACKING_SPREAD / np.sqrt(CELLS) * direction[k])
                         for k in range(CELLS)}
            rows.append({"freq_hz": f, "accel_g": g, "fill_pct": r, VALUE: cells.mean(),
                         SEM: sem, "status": "ok", LOADS_COLUMN: format_loads(loads)})
    return pd.DataFrame(rows)


def interval_check(tables, point) -> tuple[float, float]:
    """Over the tables: the fraction of 95 % intervals at ``point`` that cover the truth, and
    the RMS of (prediction - truth) / predicted sd (1 for a calibrated model)."""
    exact = float(campaign_truth(*point))
    z = []
    for table in tables:
        value, sd = fit_surrogate(table, method="gp").predict_with_uncertainty(*point)
        z.append((float(value) - exact) / float(sd))
    z = np.array(z)
    return float(np.mean(np.abs(z) <= 1.96)), float(np.sqrt(np.mean(z**2)))


def test_the_gp_with_loads_does_not_average_away_a_fills_offset():
    """At a point among the cases of a fill, 30 campaigns: with independent SEMs the GP's
    interval is too narrow (RMS z about 2.8: it averages the fill's shared offset away); with
    the loads' covariance it is much closer (about 1.7; the offsets' spread estimated from 7
    packings per fill, and fills whose packings happen to agree are trusted more); with the
    true covariance it is calibrated (RMS z about 0.9, every interval covering)."""
    point = (450.0, 5.0, 50.0)
    campaigns = range(30)
    tables = [shared_packing_table(seed) for seed in campaigns]
    _, independent = interval_check([t.drop(columns=LOADS_COLUMN) for t in tables], point)
    _, estimated = interval_check(tables, point)
    covered, oracle = interval_check([shared_packing_table(seed, oracle=True) for seed in campaigns],
                                     point)
    print(f"RMS z: independent {independent:.2f}, loads {estimated:.2f}, true covariance "
          f"{oracle:.2f} (covering {covered:.0%})")
    assert independent > 2.3
    assert estimated < 0.75 * independent
    assert oracle < 1.2 and covered >= 0.9


def test_bootstrap_draws_rows_of_a_fill_together():
    """The bootstrap's draws of two rows on the same packings correlate as their loads say."""
    surrogate = fit_surrogate(shared_packing_table(0), method="gp")
    draws = resampled_values(surrogate, 4000, seed=1)
    training = surrogate.training
    same_fill = np.flatnonzero(training["fill_pct"].to_numpy() == 25.0)[:2]
    other_fill = np.flatnonzero(training["fill_pct"].to_numpy() == 50.0)[0]
    shared = SharedPackings.of(training)
    expected = shared.covariance(training[SEM].to_numpy() ** 2)[same_fill[0], same_fill[1]]
    measured = np.cov(draws[:, same_fill].T)[0, 1]
    assert measured == pytest.approx(expected, rel=0.1)
    assert abs(np.corrcoef(draws[:, [same_fill[0], other_fill]].T)[0, 1]) < 0.06
