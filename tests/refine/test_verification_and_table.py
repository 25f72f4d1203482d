"""Verifying runs pooled and compared out of sample; the table a round fits."""

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from pidpipe.errors import DomainError
from pidpipe.refine.table import case_key, fit_table, start_table, verify_rows
from pidpipe.measurement.agreement import normal_score
from pidpipe.refine.verification import compare, pooled
from tests._surrogates import FakeSurrogate, constant


def _rows(*rows, cells=None):
    table = pd.DataFrame([{"case_key": k, "ceq_coupon_ns_m": v, "ceq_coupon_sem_ns_m": s}
                          for k, v, s in rows])
    if cells is not None:
        table["cells"] = cells
    return table


def test_verifying_runs_of_a_point_are_pooled_as_replicates_with_their_cells_dof():
    # two runs that agree within their SEMs: equal weights, the propagated SEM
    table = pooled(_rows(("a", 10.0, 1.0), ("a", 11.0, 2.0), ("b", 5.0, 0.5), cells=[7, 7, 5]))
    a, b = (table.set_index("case_key").loc[k] for k in ("a", "b"))
    assert a["dem_ns_m"] == pytest.approx(10.5)
    assert a["dem_sem_ns_m"] == pytest.approx(np.sqrt(1.0 + 4.0) / 2)
    assert (a["dem_dof"], a["runs"]) == (12.0, 2)
    assert (b["dem_ns_m"], b["dem_sem_ns_m"], b["dem_dof"]) == (5.0, 0.5, 4.0)
    # runs that disagree beyond their SEMs: the spread between them sets the SEM, and the run
    # with the smallest SEM does not pull the mean to itself
    apart = pooled(_rows(("a", 10.0, 1.0), ("a", 16.0, 3.0), cells=[7, 7])).iloc[0]
    assert apart["dem_ns_m"] == pytest.approx(13.0)
    assert apart["dem_sem_ns_m"] == pytest.approx(np.std([10.0, 16.0], ddof=1) / np.sqrt(2))


def test_a_run_without_a_cell_count_leaves_the_dof_infinite_and_z_normal():
    assert pooled(_rows(("a", 10.0, 1.0)))["dem_dof"].iloc[0] == np.inf
    assert pooled(_rows(("a", 10.0, 1.0), cells=[1]))["dem_dof"].iloc[0] == np.inf
    assert normal_score(2.5, 1.0, np.inf, 0.5) == pytest.approx(2.5)


def test_z_is_the_normal_score_of_t_by_its_welch_satterthwaite_dof():
    # the DEM's SEM alone (a surrogate without spread): nu is the runs' dof, and z has t's tail
    for t, dof in ((2.0, 6.0), (-3.0, 12.0), (1.0, 42.0)):
        z = normal_score(t, 1.0, dof, 0.0)
        assert stats.norm.sf(abs(z)) == pytest.approx(stats.t.sf(abs(t), dof), rel=1e-9)
        assert np.sign(z) == np.sign(t) and abs(z) < abs(t)
    # the surrogate's part adds dof: SEM 1 with 6 dof and sigma_s 1 give nu = 4 * 6
    assert normal_score(2.0, 1.0, 6.0, 1.0) == pytest.approx(
        stats.norm.isf(stats.t.sf(2.0, 24.0)))
    # judged as normal, |t| > 2 fails a 7-cell run about twice as often as flag_z = 2 means
    assert 2 * stats.t.sf(2.0, 6) / (2 * stats.norm.sf(2.0)) == pytest.approx(2.0, abs=0.05)


class Refusing(FakeSurrogate):
    """Refuses fills below 25 %."""

    def predict_with_uncertainty(self, f, g, r):
        if np.any(np.asarray(r) < 25.0):
            raise DomainError("fill below the domain")
        return super().predict_with_uncertainty(f, g, r)


def test_z_combines_the_dem_sem_and_the_surrogate_std_and_a_refused_point_fails():
    points = pd.DataFrame([
        {"design": "e/peak", "point": "centre", "freq_hz": 100.0, "accel_g": 2.0, "fill_pct": 50.0,
         "case_key": "in"},
        {"design": "e/peak", "point": "f_lo_G_lo", "freq_hz": 100.0, "accel_g": 2.0,
         "fill_pct": 23.8, "case_key": "out"},
        {"design": "e/peak", "point": "f_hi_G_hi", "freq_hz": 100.0, "accel_g": 2.0,
         "fill_pct": 50.0, "case_key": "not_run"},
    ])
    result = compare(points, _rows(("in", 13.0, 3.0), ("out", 10.0, 1.0)),
                     Refusing(constant(9.0), constant(4.0)), flag_z=2.0)
    z = result.set_index("case_key")["z"]
    assert z["in"] == pytest.approx((13.0 - 9.0) / 5.0)    # no cell count: z is t
    assert np.isnan(z["out"]) and np.isnan(z["not_run"])
    assert result["passes"].tolist() == [True, False, False]


def _table():
    grid = pd.DataFrame({"freq_hz": [100.0, 200.0], "accel_g": [1.0, 1.0], "fill_pct": [50.0, 50.0],
                         "ceq_coupon_ns_m": [1.0, 2.0], "ceq_coupon_sem_ns_m": [0.1, 0.2]})
    table = start_table(grid)
    added = pd.DataFrame([
        {"freq_hz": 100.0, "accel_g": 1.0, "fill_pct": 50.0, "ceq_coupon_ns_m": 1.1,
         "ceq_coupon_sem_ns_m": 0.05, "status": "ok", "source": "refine round 1",
         "refine_round": 1, "action": "extend"},
        {"freq_hz": 300.0, "accel_g": 1.0, "fill_pct": 50.0, "ceq_coupon_ns_m": 3.0,
         "ceq_coupon_sem_ns_m": 0.3, "status": "ok", "source": "verify", "refine_round": 1,
         "action": "verify"},
        {"freq_hz": 300.0, "accel_g": 1.0, "fill_pct": 50.0, "ceq_coupon_ns_m": 3.1,
         "ceq_coupon_sem_ns_m": 0.3, "status": "ok", "source": "verify", "refine_round": 1,
         "action": "reverify"},
        {"freq_hz": 400.0, "accel_g": 1.0, "fill_pct": 50.0, "ceq_coupon_ns_m": 4.0,
         "ceq_coupon_sem_ns_m": 0.4, "status": "ok", "source": "refine round 2",
         "refine_round": 2, "action": "new"},
    ])
    added["case_key"] = [case_key(f, g, r) for f, g, r in
                         added[["freq_hz", "accel_g", "fill_pct"]].to_numpy()]
    return pd.concat([table, added], ignore_index=True)


def test_a_round_fits_the_latest_row_of_each_case_of_earlier_rounds_and_no_verifying_row():
    table = _table()
    assert fit_table(table, 1)["ceq_coupon_ns_m"].tolist() == [1.0, 2.0]
    assert fit_table(table, 2)["ceq_coupon_ns_m"].tolist() == [1.1, 2.0]      # extended
    assert fit_table(table, 3)["ceq_coupon_ns_m"].tolist() == [1.1, 2.0, 4.0]


def test_a_round_compares_its_own_first_verifying_runs_and_earlier_reruns():
    table = _table()
    assert verify_rows(table, 1)["action"].tolist() == ["verify"]
    assert verify_rows(table, 2)["action"].tolist() == ["verify", "reverify"]


def test_a_table_resumed_on_a_new_grid_keeps_the_loops_rows_after_the_new_grid():
    from pidpipe.refine.table import start_table, with_grid

    grid = pd.DataFrame({"freq_hz": [500.0, 1000.0], "accel_g": [5.0, 5.0],
                         "fill_pct": [25.0, 25.0], "ceq_coupon_ns_m": [10.0, 20.0],
                         "ceq_coupon_sem_ns_m": [1.0, 2.0], "status": ["ok", "ok"]})
    table = start_table(grid)
    added = table.iloc[[0]].assign(refine_round=1, source="refine round 1", action="extend",
                                   ceq_coupon_ns_m=11.0, ceq_coupon_sem_ns_m=0.5)
    table = pd.concat([table, added], ignore_index=True)
    assert with_grid(table, grid) is table
    rerun = grid.assign(ceq_coupon_ns_m=[12.0, 20.0])
    resumed = with_grid(table, rerun)
    assert resumed["ceq_coupon_ns_m"].tolist() == [12.0, 20.0, 11.0]
    assert resumed["refine_round"].tolist() == [0, 0, 1]


def test_the_table_a_round_decides_from_is_the_table_as_it_reads_back():
    from pidpipe.refine.table import as_stored, start_table

    grid = pd.DataFrame({"freq_hz": [500.0], "accel_g": [5.0], "fill_pct": [25.0],
                         "ceq_coupon_ns_m": [10.0], "ceq_coupon_sem_ns_m": [1.0],
                         "status": ["ok"], "flags": [None], "n_cycles": [40]})
    stored = as_stored(start_table(grid))
    assert stored["flags"].isna().all() and stored["n_cycles"].dtype.kind == "i"
    assert as_stored(stored).equals(stored)


def test_a_request_at_a_band_corner_computed_in_floating_point_is_the_corner():
    from pidpipe.cases import CaseSpec
    from pidpipe.refine.candidates import Request

    request = Request(800.0000000000001, 4.000000000000006, 28.571428571428573, "verify")
    assert (request.freq_hz, request.accel_g, request.fill_pct) == (800.0, 4.0, 28.571)
    case = CaseSpec(request.freq_hz, request.accel_g, request.fill_pct, 200)
    assert case.case_id == "f800Hz_G4_r28.571pct_rep200"


def test_a_seven_cell_run_passes_at_a_t_the_normal_would_fail():
    points = pd.DataFrame([{"design": "e/peak", "point": "centre", "freq_hz": 100.0,
                            "accel_g": 2.0, "fill_pct": 50.0, "case_key": "p"}])
    run = _rows(("p", 9.0 + 2.3 * 3.0, 3.0), cells=[7])
    row = compare(points, run, FakeSurrogate(constant(9.0), constant(0.0)), flag_z=2.0).iloc[0]
    assert row["t"] == pytest.approx(2.3) and row["dem_dof"] == 6.0
    assert row["z"] == pytest.approx(stats.norm.isf(stats.t.sf(2.3, 6.0)))
    assert row["z"] < 2.0 and bool(row["passes"])
    unknown = compare(points, _rows(("p", 9.0 + 2.3 * 3.0, 3.0)),
                      FakeSurrogate(constant(9.0), constant(0.0)), flag_z=2.0).iloc[0]
    assert unknown["z"] == pytest.approx(2.3) and not bool(unknown["passes"])


def test_the_t_a_run_passes_up_to_grows_as_its_cells_fall():
    """The figures docs/explanation/refine.md quotes: at flag_z = 2, one 7-cell run passes up
    to |t| = 2.52, seven of them (42 dof) up to 2.06."""
    for dof, limit in ((6.0, 2.52), (42.0, 2.06)):
        t = stats.t.isf(stats.norm.sf(2.0), dof)
        assert t == pytest.approx(limit, abs=0.005)
        assert normal_score(t, 1.0, dof, 0.0) == pytest.approx(2.0)
