"""The C_eq table's regime comes from the cells' motion when the records hold it."""

import pandas as pd

from pidpipe.config import load_config
from pidpipe.design.records import records_to_table
from pidpipe.design.surrogate import fit_surrogate
from pidpipe.figures.maps import plot_ceq_freq_accel
from pidpipe.steps.params import inspected_cases, workflow_config
from tests.steps.test_steps import record


def _seen(cell_regimes, **kwargs):
    return record(**kwargs).with_(motion={"cell_regimes": list(cell_regimes)})


def test_regime_is_that_of_most_cells_over_the_replicates():
    rows = records_to_table([
        _seen(["bouncing_bed"] * 2 + ["irregular"], replicate=0),
        _seen(["irregular"] * 2 + ["bouncing_bed"], replicate=1),
        _seen(["period_doubling"], accel=10.0),
        record(accel=1.0),   # no motion sampled: decided from G
    ])
    both, doubling, one_g = (rows[rows.accel_g == g].iloc[0] for g in (5.0, 10.0, 1.0))
    assert both["regime"] == "bouncing_bed"          # 3 : 3, the tie goes to the earlier regime
    assert both["regime_cells"] == "bouncing_bed:3;irregular:3"
    assert (doubling["regime"], doubling["regime_cells"]) == ("period_doubling", "period_doubling:1")
    assert (one_g["regime"], one_g["regime_cells"]) == ("no_lift_off", "")


def test_maps_mark_each_point_with_its_regime():
    rows = []
    regimes = iter(["no_lift_off", "bouncing_bed", "period_doubling", "lid_impacts"] * 4)
    for f in (100.0, 1000.0):
        for g in (1.0, 10.0):
            for r in (25.0, 50.0):
                rows.append({"freq_hz": f, "accel_g": g, "fill_pct": r, "ceq_coupon_ns_m": f * g * r / 1e4,
                             "ceq_coupon_sem_ns_m": 0.01, "status": "ok", "regime": next(regimes)})
    surrogate = fit_surrogate(pd.DataFrame(rows), method="rbf_thin_plate")
    figure = plot_ceq_freq_accel(surrogate, fill_levels_pct=(25.0, 50.0))
    labels = {text.get_text() for legend in figure.legends for text in legend.get_texts()}
    assert {"DEM on the slice: no lift off", "DEM on the slice: lid impacts"} <= labels


def test_movie_and_figure_cases_outside_the_campaign_are_set_aside():
    config = load_config()
    config["inspection"]["movie_cases"] = ["f123Hz_G5_r50pct_rep0", "f500Hz_G5_r50pct_rep0"]
    assert inspected_cases(workflow_config(config), "movie_cases") == (
        ["f500Hz_G5_r50pct_rep0"], ["f123Hz_G5_r50pct_rep0"])
    config["inspection"]["phase_figure_cases"] = ["f500Hz_G5_r50pct_rep3"]    # one replicate only
    assert inspected_cases(config, "phase_figure_cases") == ([], ["f500Hz_G5_r50pct_rep3"])
