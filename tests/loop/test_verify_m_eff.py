"""verify with a GP surrogate (its own predictive uncertainty) and with the m_eff surrogate."""

import numpy as np
import pandas as pd
import pytest

from pidpipe.design.surrogate import fit_surrogate
from pidpipe.loop.verify import (VERIFY_COLUMNS, compare, m_eff_off_lines, m_eff_predictions,
                                 plan_points, surrogate_uncertainty, unique_case_ids)
from tests.loop.test_verify import design, grid_table, record

BED_KG = 9 * 9.65e-6          # 9 acrylic spheres


def m_eff_table(seed=0):
    """m_eff of one cell on the C_eq grid: a bed half airborne, falling with G; 3 % SEM."""
    rows = grid_table()
    mass = BED_KG * rows.fill_pct / 42.857 * (7.5 / rows.accel_g) * 0.3
    rows["m_eff_cell_sem_kg"] = 0.03 * BED_KG
    rows["m_eff_cell_kg"] = mass + rows["m_eff_cell_sem_kg"] * np.random.default_rng(
        seed).standard_normal(len(rows))
    return rows


def test_a_gp_surrogate_gives_its_own_predictive_uncertainty_with_the_scatter():
    table = grid_table(noise=0.05, seed=2)
    gp = fit_surrogate(table, method="gp")
    points = plan_points([design("A", "peak", 44.0)], 21)
    u = surrogate_uncertainty(gp, points, draws=20, seed=1)
    value, sd = gp.predict_with_uncertainty(points["freq_hz"], points["accel_g"],
                                            points["fill_pct"], include_scatter=True)
    np.testing.assert_allclose(u["ceq_coupon_surrogate_ns_m"], value)
    np.testing.assert_allclose(u["surrogate_u_ns_m"], sd)
    assert (u["surrogate_u_method"] == "gp_predictive").all()
    assert u["surrogate_noise_sd_ns_m"].isna().all() and u["surrogate_interp_sd_ns_m"].isna().all()
    _, without = gp.predict_with_uncertainty(points["freq_hz"], points["accel_g"], points["fill_pct"])
    assert np.all(u["surrogate_u_ns_m"] >= without - 1e-12)
    # the interpolants keep the bootstrap and leave-one-out construction
    rbf = surrogate_uncertainty(fit_surrogate(table), points, draws=20, seed=1)
    assert (rbf["surrogate_u_method"] == "bootstrap_and_loo").all()
    np.testing.assert_allclose(rbf["surrogate_u_ns_m"]**2, rbf["surrogate_noise_sd_ns_m"]**2
                               + rbf["surrogate_interp_sd_ns_m"]**2)


def test_the_dem_m_eff_is_compared_with_the_m_eff_surrogate():
    ceq = fit_surrogate(grid_table())
    m_eff = fit_surrogate(m_eff_table(), method="gp", target="linear",
                          value_column="m_eff_cell_kg", sem_column="m_eff_cell_sem_kg")
    points = plan_points([design("A", "peak", 44.0)], 21)
    predictions = pd.concat([surrogate_uncertainty(ceq, points, draws=0, seed=1),
                             m_eff_predictions(m_eff, points)], axis=1)
    value, sd = m_eff.predict_with_uncertainty(points["freq_hz"], points["accel_g"],
                                               points["fill_pct"], include_scatter=True)
    np.testing.assert_allclose(predictions["m_eff_surrogate_kg"], value)
    np.testing.assert_allclose(predictions["m_eff_surrogate_u_kg"], sd)
    assert np.all(sd > 0)
    ids = unique_case_ids(points)
    truth = dict(zip(points["case_id"], value))
    sem = 0.02 * BED_KG
    records = {c: record(c, 50.0, 1.0).with_(harmonics={"m_eff_cell_kg": truth[c],
                                                        "m_eff_cell_sem_kg": sem})
               for c in ids}
    off = ids[1]
    records[off] = records[off].with_(harmonics={"m_eff_cell_kg": truth[off] + 0.5 * BED_KG,
                                                 "m_eff_cell_sem_kg": sem})
    records[ids[2]] = record(ids[2], 50.0, 1.0)            # a record without harmonics
    table = compare(points, records, predictions, flag_z=2.0)
    assert list(table.columns) == list(VERIFY_COLUMNS)
    row = table.set_index("case_id").loc[off]
    assert row["z_m_eff"] == pytest.approx(0.5 * BED_KG / np.hypot(sem, row["m_eff_surrogate_u_kg"]))
    assert row["m_eff_off"] and "m_eff surrogate off by" in row["note"]
    fine = table[~table["case_id"].isin([off, ids[2]])]
    assert fine["z_m_eff"].abs().max() < 1e-9 and not fine["m_eff_off"].any()
    no_harmonics = table.set_index("case_id").loc[ids[2]]
    assert np.isnan(no_harmonics["m_eff_dem_kg"]) and np.isnan(no_harmonics["z_m_eff"])
    assert not no_harmonics["m_eff_off"]
    assert len(m_eff_off_lines(table)) == 1


def test_without_an_m_eff_surrogate_the_m_eff_columns_are_nan():
    ceq = fit_surrogate(grid_table())
    points = plan_points([design("A", "peak", 44.0)], 21)
    predictions = surrogate_uncertainty(ceq, points, draws=0, seed=1)
    records = {c: record(c, 50.0, 1.0) for c in unique_case_ids(points)}
    for given in (predictions, pd.concat([predictions, m_eff_predictions(None, points)], axis=1)):
        table = compare(points, records, given, flag_z=2.0)
        assert table[["m_eff_surrogate_kg", "m_eff_surrogate_u_kg", "z_m_eff"]].isna().all().all()
        assert not table["m_eff_off"].any()
