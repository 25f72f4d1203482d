"""Which cases check the designs, how shared points collapse, and how DEM and surrogate compare."""

import copy
import itertools

import numpy as np
import pandas as pd
import pytest

from pidpipe.cases import CaseSpec
from pidpipe.measurement.case_record import CaseRecord
from pidpipe.design.surrogate import fit_surrogate
from pidpipe.errors import PidpipeError
from pidpipe.loop.verify import (
    POINT_NAMES,
    VERIFY_COLUMNS,
    VERIFY_REPLICATE,
    band_points,
    compare,
    is_off,
    off_lines,
    plan_points,
    poured_fill,
    stale_records,
    surrogate_uncertainty,
    unique_case_ids,
    t_combined,
)


def design(env, kind, fill_pct, freq=(600.0, 900.0), accel=(6.0, 9.0), n_cells=22):
    """One result as results/optimum.json holds it (the fields the plan reads)."""
    return {"environment": {"name": env, "freq_hz": list(freq), "accel_g": list(accel)},
            "kind": kind, "bounds": {"freq_hz": list(freq), "accel_g": list(accel),
                                     "fill_pct": [25.0, 50.0], "n_cells": [1.0, 441.0]},
            "design": {"fill_pct": fill_pct, "n_cells": n_cells, "freq_hz": None, "accel_g": None}}


def test_a_band_has_four_corners_and_its_arithmetic_centre():
    points = band_points((250.0, 300.0), (5.0, 6.0))
    assert [p[0] for p in points] == list(POINT_NAMES)
    assert {(f, g) for _, f, g in points[:4]} == {(250, 5), (250, 6), (300, 5), (300, 6)}
    assert points[4][1:] == (275.0, 5.5)


def test_the_dem_pours_the_nearest_whole_sphere_count_and_its_fill_gives_it_back():
    # 21 spheres fill a cell: 49.567 % is 10.41 spheres -> 10 spheres = 47.619 %
    fill, n = poured_fill(49.56709956709956, 21)
    assert (fill, n) == (47.619, 10)
    assert CaseSpec(500, 5, fill).case_id == "f500Hz_G5_r47.619pct_rep0"
    assert poured_fill(50.0, 36) == (50.0, 18)                 # a grid fill stays itself
    with pytest.raises(PidpipeError, match="no whole sphere"):
        poured_fill(1.0, 21)


def test_band_mean_and_peak_of_every_environment_give_five_points_each_and_worst_case_none():
    designs = [design("A", kind, 49.567) for kind in ("peak", "band_mean", "worst_case")]
    designs += [design("B", kind, 30.0, freq=(250, 300), accel=(5, 6))
                for kind in ("peak", "band_mean", "worst_case")]
    points = plan_points(designs, 21)
    assert len(points) == 2 * 2 * 5
    assert list(points["environment"].unique()) == ["A", "B"]
    assert list(points["design"].iloc[:10]) == ["band_mean"] * 5 + ["peak"] * 5
    assert set(points["design"]) == {"band_mean", "peak"}
    b = points[points["environment"] == "B"]
    assert set(b["fill_pct"]) == {28.571} and set(b["n_spheres"]) == {6}
    assert set(b["freq_hz"]) == {250.0, 275.0, 300.0}


def test_a_verifying_case_shakes_packings_no_campaign_case_or_loop_run_shakes():
    """On the campaign's packings a verifying case would share their offset with the fitted cases
    of its fill (every case of a fill shakes them), and z could not see it."""
    from pidpipe.steps.cases import extra_packing_index
    from pidpipe.steps.refine_engine import EXTEND_REPLICATES_FROM, VERIFY_REPLICATES_FROM

    points = plan_points([design("A", "peak", 49.567)], 21)
    cells = 24                                          # the schema's largest cells_per_run
    for case_id in unique_case_ids(points):
        case = CaseSpec.from_id(case_id)
        assert case.replicate == VERIFY_REPLICATE
        mine = {int(p.rsplit("_rep", 1)[1]) for p in case.packing_ids(cells)}
        campaign = {int(p.rsplit("_rep", 1)[1]) for q in range(100)      # replicates 0-99
                    for p in CaseSpec(case.freq_hz, case.accel_g, case.fill_pct, q).packing_ids(cells)}
        assert not mine & campaign
        # the cells a target adds come from the pool's packings of its own replicate, apart from
        # the loop's extensions and verifying runs
        assert VERIFY_REPLICATE < EXTEND_REPLICATES_FROM + 1 <= VERIFY_REPLICATES_FROM
        assert extra_packing_index(VERIFY_REPLICATE, 999) < extra_packing_index(
            EXTEND_REPLICATES_FROM + 1, 0)


def test_a_point_two_designs_share_is_one_case():
    designs = [design("A", "peak", 49.567), design("A", "band_mean", 49.0),   # both 10 spheres
               design("B", "band_mean", 40.0, freq=(900, 1000), accel=(9, 10))]
    points = plan_points(designs, 21)
    cases = unique_case_ids(points)
    # A's two designs pour the same 10 spheres at the same five points; B's corner (900, 9)
    # is a point of A's band too, but at B's own fill (8 spheres), so a different case
    assert len(points) == 15 and len(cases) == 10
    assert len(set(points["case_id"][points["environment"] == "A"])) == 5
    assert cases == list(dict.fromkeys(points["case_id"]))


def test_results_without_band_mean_or_peak_have_nothing_to_verify():
    with pytest.raises(PidpipeError, match="nothing to verify"):
        plan_points([design("A", "worst_case", 40.0)], 21)


def test_t_is_the_difference_over_the_combined_standard_uncertainty():
    t = t_combined([10.0, 10.0, 5.0], [3.0, 0.0, 0.0], [6.0, 10.0, 5.0], [4.0, 1.0, 0.0])
    assert t[0] == pytest.approx(4.0 / 5.0)
    assert t[1] == 0.0
    assert np.isnan(t[2])                                        # nothing to divide by
    assert list(is_off([2.5, -2.01, 1.99, np.nan], 2.0)) == [True, True, False, False]


def grid_table(noise=0.0, seed=0):
    """A smooth C_eq on a 3 x 3 x 3 grid, with a relative SEM of 5 %."""
    rows = pd.DataFrame(list(itertools.product((500.0, 750.0, 1000.0), (5.0, 7.5, 10.0),
                                               (25.0, 37.5, 50.0))),
                        columns=["freq_hz", "accel_g", "fill_pct"])
    value = 0.1 * rows.freq_hz * np.sqrt(rows.accel_g) * rows.fill_pct / 50
    rows["ceq_coupon_ns_m"] = value * (1 + noise * np.random.default_rng(seed).standard_normal(len(rows)))
    rows["ceq_coupon_sem_ns_m"] = 0.05 * value
    rows["status"] = "ok"
    return rows


def test_the_surrogates_uncertainty_holds_the_tables_noise_and_the_interpolation_error():
    surrogate = fit_surrogate(grid_table())
    points = plan_points([design("A", "peak", 44.0, freq=(600, 900), accel=(6, 9))], 21)
    u = surrogate_uncertainty(surrogate, points, draws=40, seed=1)
    assert len(u) == 5
    assert np.all(u["surrogate_noise_sd_ns_m"] > 0) and np.all(u["surrogate_interp_sd_ns_m"] > 0)
    np.testing.assert_allclose(u["surrogate_u_ns_m"]**2, u["surrogate_noise_sd_ns_m"]**2
                               + u["surrogate_interp_sd_ns_m"]**2)
    # redrawing values with a 5 % SEM moves an interpolated value by about that much, not 10 x
    rel = u["surrogate_noise_sd_ns_m"] / u["ceq_coupon_surrogate_ns_m"]
    assert np.all((rel > 0.005) & (rel < 0.1))
    no_draws = surrogate_uncertainty(surrogate, points, draws=0, seed=1)
    assert no_draws["surrogate_noise_sd_ns_m"].isna().all()
    np.testing.assert_allclose(no_draws["surrogate_u_ns_m"], no_draws["surrogate_interp_sd_ns_m"])
    assert no_draws["note"].str.contains("without its noise part").all()


def test_the_surrogate_is_read_at_the_cases_fill_and_a_fill_off_its_domain_is_held_and_said():
    surrogate = fit_surrogate(grid_table())
    points = plan_points([design("A", "band_mean", 44.0)], 21)    # 9 spheres = 42.857 %
    assert np.all(points["fill_pct"] == 42.857)
    u = surrogate_uncertainty(surrogate, points, draws=0, seed=1)
    np.testing.assert_allclose(u["ceq_coupon_surrogate_ns_m"],
                               surrogate.predict(points["freq_hz"], points["accel_g"], 42.857))
    # between 9 and 9.24 spheres the smooth C_eq differs by 2.7 %: reading at r_d would show it
    at_design = surrogate.predict(points["freq_hz"], points["accel_g"], 44.0)
    assert np.all(np.abs(u["ceq_coupon_surrogate_ns_m"] / at_design - 1) > 0.01)
    assert not u["note"].str.contains("edge").any()
    points = plan_points([design("A", "band_mean", 24.0)], 21)    # 5 spheres = 23.81 %
    u = surrogate_uncertainty(surrogate, points, draws=0, seed=1)
    assert u["note"].str.contains("edge 25 % (the case's fill is 23.81 %)", regex=False).all()


def record(case_id, value, sem, status="ok", flags=(), cells=1):
    case = CaseSpec.from_id(case_id)
    return CaseRecord(case_id=case_id, status=status, flags=list(flags), solver="numba-dem",
                      freq_hz=case.freq_hz, accel_g=case.accel_g, fill_pct=case.fill_pct,
                      ceq_coupon_ns_m=value, ceq_coupon_sem_ns_m=sem, n_cycles=10,
                      fidelity={"engine": "dem", "cells_per_run": cells, "transient_cycles": 30,
                                "steps_per_cycle": 2000},
                      engine={"name": "dem", "cpu_time_s": 1.5})


def test_compare_flags_a_surrogate_that_is_off_and_keeps_a_shared_case_in_each_design():
    surrogate = fit_surrogate(grid_table())
    designs = [design("A", "peak", 44.0), design("A", "band_mean", 44.5)]   # both 9 spheres
    points = plan_points(designs, 21)
    predictions = surrogate_uncertainty(surrogate, points, draws=20, seed=3)
    peak = points["design"] == "peak"            # the DEM gives what the surrogate says at peak's fill
    truth = dict(zip(points["case_id"][peak], predictions["ceq_coupon_surrogate_ns_m"][peak]))
    ids = unique_case_ids(points)
    records = {c: record(c, truth[c], 0.02 * truth[c]) for c in ids}
    off_case = ids[2]
    records[off_case] = record(off_case, 3.0 * truth[off_case], 0.02 * truth[off_case],
                               status="flagged", flags=["not_steady"])
    table = compare(points, records, predictions, flag_z=2.0)
    assert list(table.columns) == list(VERIFY_COLUMNS) and len(table) == 10
    assert table.loc[peak & (table["case_id"] != off_case), "z_combined"].abs().max() < 1e-9
    # both designs' rows read the surrogate at the case's 9 spheres: one case, one prediction
    band = table[~peak]
    np.testing.assert_allclose(band["ceq_coupon_surrogate_ns_m"].to_numpy(),
                               table.loc[peak, "ceq_coupon_surrogate_ns_m"].to_numpy(), rtol=1e-12)
    assert set(band["design_fill_pct"]) == {44.5} and set(band["fill_pct"]) == {42.857}
    np.testing.assert_allclose(band["z_combined"], band["difference_ns_m"]
                               / np.hypot(band["ceq_coupon_dem_sem_ns_m"], band["surrogate_u_ns_m"]))
    off = table[table["surrogate_off"]]
    assert set(off["case_id"]) == {off_case} and set(off["design"]) == {"peak", "band_mean"}
    off_peak = off[off["design"] == "peak"].iloc[0]
    expected = 2.0 * truth[off_case] / np.hypot(0.02 * truth[off_case], off_peak["surrogate_u_ns_m"])
    assert off_peak["z_combined"] == pytest.approx(expected)
    assert off["note"].str.contains("surrogate off by").all()
    assert off["note"].str.contains("DEM case flagged (not_steady)", regex=False).all()
    assert (table["engine"] == "dem").all() and (table["dem_cpu_time_s"] == 1.5).all()
    assert len(off_lines(table)) == 2


def judged(cells, t, dem_sem=5.0, surrogate_u=1.0, target_cells=None):
    """compare() of one design's five points, every case's DEM value t combined standard
    uncertainties above the surrogate's (C_eq and m_eff alike), its record of ``cells`` cells
    (``target_cells``: a case measured to a target that ended with that many)."""
    points = plan_points([design("A", "peak", 44.0)], 21)
    n = len(points)
    predictions = pd.DataFrame({
        "surrogate_method": "gp", "ceq_coupon_surrogate_ns_m": np.full(n, 100.0),
        "surrogate_u_method": "gp_predictive", "surrogate_noise_sd_ns_m": np.nan,
        "surrogate_interp_sd_ns_m": np.nan, "surrogate_u_ns_m": np.full(n, surrogate_u),
        "note": "", "m_eff_surrogate_kg": np.full(n, 1e-4),
        "m_eff_surrogate_u_kg": np.full(n, 1e-6 * surrogate_u)})
    shift = t * np.hypot(dem_sem, surrogate_u)
    records = {}
    for case_id in unique_case_ids(points):
        made = record(case_id, 100.0 + shift, dem_sem, cells=cells).with_(
            harmonics={"m_eff_cell_kg": 1e-4 + 1e-6 * shift, "m_eff_cell_sem_kg": 1e-6 * dem_sem})
        if target_cells is not None:
            made = made.with_(target={"relative_sem": 0.05, "reached": False,
                                      "cells": target_cells})
        records[case_id] = made
    return compare(points, records, predictions, flag_z=2.0)


def test_a_point_is_judged_by_its_dem_sems_degrees_of_freedom():
    """A 7-cell pilot's SEM has 6 degrees of freedom: t = 2.3 passes at flag_z = 2 (its normal
    score is below 2), where 200 cells (199 dof) and the same t fail, as a normal z does."""
    from scipy import stats

    few = judged(cells=1, t=2.3, target_cells=7)                 # the pilot of 7, target unreached
    many = judged(cells=200, t=2.3)
    for table, dof in ((few, 6.0), (many, 199.0)):
        assert (table["n_cells_measured"] == dof + 1).all() and (table["dem_dof"] == dof).all()
        for t, z in (("t_combined", "z_combined"), ("t_m_eff", "z_m_eff")):
            np.testing.assert_allclose(table[t], 2.3)
            # Welch-Satterthwaite: SEM 5 with the dof, the surrogate's 1 taken as known
            nu = (5.0**2 + 1.0**2) ** 2 / (5.0**4 / dof)
            np.testing.assert_allclose(table[z], stats.norm.isf(stats.t.sf(2.3, nu)))
    assert not few["surrogate_off"].any() and not few["m_eff_off"].any()
    assert (few["z_combined"] < 1.95).all()
    assert many["surrogate_off"].all() and many["m_eff_off"].all()
    assert many["note"].str.contains("surrogate off by +2.3 combined standard uncertainties "
                                     "(|z| 2.28 > 2)", regex=False).all()
    assert off_lines(many)[0].endswith("t = +2.30 (199 dof), z = +2.28")


def test_z_is_t_where_the_dem_sems_degrees_of_freedom_are_unknown():
    """One cell (its SEM its cycles', of no known count), or no count at all: dof inf, z = t."""
    for cells in (1, 0):
        table = judged(cells=cells, t=2.3)
        assert np.isinf(table["dem_dof"]).all()
        np.testing.assert_array_equal(table["z_combined"], table["t_combined"])
        np.testing.assert_array_equal(table["z_m_eff"], table["t_m_eff"])
        assert table["surrogate_off"].all()


def test_a_7_cell_pilot_passes_up_to_t_2_52_at_flag_z_2():
    """The docs' figure: with the surrogate's uncertainty small beside the DEM's SEM, t has the
    pilot's 6 degrees of freedom, and the |t| that z = 2 allows is 2.52."""
    from scipy import stats

    limit = stats.t.isf(stats.norm.sf(2.0), 6.0)
    assert round(limit, 2) == 2.52
    # judged as normal, |t| > 2 would flag such a case about twice as often as flag_z = 2 means
    assert stats.t.sf(2.0, 6.0) / stats.norm.sf(2.0) == pytest.approx(2.0, abs=0.05)
    inside = judged(cells=7, t=limit - 0.01, surrogate_u=1e-6)
    outside = judged(cells=7, t=limit + 0.01, surrogate_u=1e-6)
    assert not inside["surrogate_off"].any() and outside["surrogate_off"].all()


def test_compare_refuses_a_missing_or_mismatched_record():
    surrogate = fit_surrogate(grid_table())
    points = plan_points([design("A", "peak", 44.0)], 21)
    predictions = surrogate_uncertainty(surrogate, points, draws=0, seed=3)
    ids = unique_case_ids(points)
    records = {c: record(c, 50.0, 1.0) for c in ids[1:]}
    with pytest.raises(PidpipeError, match=ids[0]):
        compare(points, records, predictions, 2.0)
    records[ids[0]] = record(ids[1], 50.0, 1.0)
    with pytest.raises(PidpipeError, match="is of case"):
        compare(points, records, predictions, 2.0)


def test_a_record_made_with_other_settings_is_named():
    fidelity = {"engine": "dem", "timestep_rayleigh_fraction_config": 0.2, "youngs_modulus_scale": 1.0,
                "measured_cycles": 10, "rotation": True, "friction": True, "cells_per_run": 1}
    current = record("f600Hz_G6_r47.619pct_rep0", 50.0, 1.0)
    current.fidelity.update(fidelity)
    old = record("f900Hz_G6_r47.619pct_rep0", 50.0, 1.0)
    old.fidelity.update(fidelity, engine="liggghts")
    assert stale_records({"a": current}, fidelity, None) == []
    stale = stale_records({"a": current, "b": old}, fidelity, 0.05)
    assert stale == ["a: target_relative_sem None (configured 0.05)", "b: engine 'liggghts' (configured 'dem')",
                     "b: target_relative_sem None (configured 0.05)"]


def test_a_record_the_allocation_extended_is_current():
    """The allocation took the case from its pilot (1 cell x 10 cycles) to 20 cells x 400
    cycles: the record's fidelity shows the extended run, its target block the pilot. It was
    made with the configured settings, so it is not stale; a pilot of other settings is."""
    fidelity = {"engine": "dem", "timestep_rayleigh_fraction_config": 0.2, "youngs_modulus_scale": 1.0,
                "measured_cycles": 10, "rotation": True, "friction": True, "cells_per_run": 1}
    extended = record("f475Hz_G1.5_r23.81pct_rep0", 5.2, 2.0)
    extended.fidelity.update(fidelity, measured_cycles=400, cells_per_run=20)
    target = {"relative_sem": 0.05, "reached": False, "cells": 20, "measured_cycles": 400,
              "runs": [{"run": 0, "kind": "pilot", "cells": 1, "measured_cycles": 10},
                       {"run": 1, "kind": "new", "cells": 19, "measured_cycles": 400}]}
    extended = extended.with_(target=target)
    assert stale_records({"a": extended}, fidelity, 0.05) == []
    other_target = copy.deepcopy(target)
    other_target["runs"][0]["measured_cycles"] = 40
    other_pilot = extended.with_(target=other_target)
    assert stale_records({"a": other_pilot}, fidelity, 0.05) == ["a: measured_cycles 40 (configured 10)"]


def test_the_log_names_each_environments_worst_point():
    import pandas as pd

    from pidpipe.loop.verify import worst_z_line

    table = pd.DataFrame({
        "environment": ["A", "A", "A", "B", "C"],
        "design": ["peak", "peak", "band_mean", "peak", "peak"],
        "point": ["f_lo_G_lo", "centre", "centre", "centre", "centre"],
        "z_combined": [0.5, -3.78, 1.2, 0.41, np.nan],
    })
    assert worst_z_line(table) == ("A |z| 3.78 (peak, centre); B |z| 0.41 (peak, centre); C -")


def test_the_calibration_line_counts_each_case_once_and_says_how_rare_its_worst_z_is():
    import pandas as pd
    from scipy.stats import norm

    from pidpipe.loop.verify import calibration_line

    table = pd.DataFrame({"case_id": ["a", "a", "b", "c", "d"],
                          "z_combined": [3.0, 3.0, -1.0, 0.0, np.nan]})
    line = calibration_line(table, 2.0)
    rms = np.sqrt((9.0 + 1.0 + 0.0) / 3)                      # a counted once, d has no z
    p = 1 - (1 - 2 * norm.sf(3.0)) ** 3
    assert line == (f"3 case(s): RMS z {rms:.2f}; worst |z| 3.00, which the worst of 3 independent "
                    f"points of a calibrated surrogate exceeds with probability {p:.2g}; "
                    f"|z| > 2 at 1 (expected about {3 * 2 * norm.sf(2.0):.1f})")
    # the doc's figure: the worst of 30 calibrated points exceeds 2 three times in four
    assert 1 - (1 - 2 * norm.sf(2.0)) ** 30 == pytest.approx(0.75, abs=0.01)
    assert calibration_line(table.iloc[4:], 2.0) == "-"
