"""The designs' check figure: saved, labelled in N*s/m, flagged points drawn apart."""

import numpy as np
import pandas as pd
from matplotlib.image import imread

from pidpipe.figures.verify import plot_verify


def verify_table(values, off, designs):
    values = np.asarray(values, dtype=float)
    return pd.DataFrame({
        "case_id": [f"c{i}" for i in range(len(values))], "design": designs, "engine": "dem",
        "ceq_coupon_surrogate_ns_m": values, "surrogate_u_ns_m": 0.1 * values,
        "ceq_coupon_dem_ns_m": values * np.where(off, 2.0, 1.02),
        "ceq_coupon_dem_sem_ns_m": 0.05 * values, "surrogate_off": off,
    })


def _axes_of(monkeypatch):
    """Capture the figure plot_verify saves."""
    saved = {}
    import pidpipe.figures.verify as module
    real = module.save_figure

    def capture(figure, stem):
        saved["figure"] = figure
        return real(figure, stem)

    monkeypatch.setattr(module, "save_figure", capture)
    return saved


def test_the_parity_figure_is_saved_labelled_and_marks_the_flagged_cases(tmp_path, monkeypatch):
    saved = _axes_of(monkeypatch)
    table = verify_table([20, 30, 40, 50, 60], [False, False, True, False, False],
                         ["band_mean", "band_mean", "peak", "peak", "peak"])
    paths = plot_verify(table, tmp_path / "verify", flag_z=2.0)
    assert [p.suffix for p in paths] == [".png", ".pdf"] and all(p.stat().st_size > 0 for p in paths)
    assert imread(paths[0]).std() > 0.01                                  # not blank
    ax = saved["figure"].axes[0]
    assert "N·s/m" in ax.get_xlabel() and "N·s/m" in ax.get_ylabel() and "dem" in ax.get_ylabel()
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "peak, off (|z| > 2) (1)" in labels and "band_mean (2)" in labels
    assert ax.get_xscale() == "linear"                                    # a span of 3: linear


def test_values_over_decades_go_on_log_axes(tmp_path, monkeypatch):
    saved = _axes_of(monkeypatch)
    table = verify_table([0.5, 5.0, 50.0], [False, False, False], ["peak"] * 3)
    plot_verify(table, tmp_path / "verify")
    assert saved["figure"].axes[0].get_xscale() == "log"
