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


def with_m_eff(table, m_surrogate, m_u, m_dem, m_sem, flag_z=2.0):
    """verify_table plus the m_eff columns (kg) and their z-scores as compare() writes them."""
    table = table.assign(m_eff_surrogate_kg=m_surrogate, m_eff_surrogate_u_kg=m_u,
                         m_eff_dem_kg=m_dem, m_eff_dem_sem_kg=m_sem)
    z = (table["m_eff_dem_kg"] - table["m_eff_surrogate_kg"]) / np.hypot(
        table["m_eff_dem_sem_kg"], table["m_eff_surrogate_u_kg"])
    return table.assign(z_m_eff=z, m_eff_off=z.abs() > flag_z)


def _bars(container):
    """(x half-widths, y half-widths) of an errorbar container's bars, one per point."""
    x_bars, y_bars = container.lines[2]
    half = [np.array([np.ptp(np.asarray(s)[:, k]) / 2 for s in bars.get_segments()])
            for bars, k in ((x_bars, 0), (y_bars, 1))]
    return half[0], half[1]


def test_the_m_eff_panel_draws_both_uncertainties_in_kg_and_the_threshold(tmp_path, monkeypatch):
    saved = _axes_of(monkeypatch)
    m_surrogate = np.array([2.0e-3, 1.0e-3, 2.0e-4, -5.0e-5, 5.0e-4])
    m_u = np.array([1.0e-4, 5.0e-5, 4.0e-5, 3.0e-5, 2.0e-5])
    m_sem = np.array([2.0e-5, 3.0e-5, 1.0e-5, 2.0e-5, 1.0e-5])
    m_dem = m_surrogate + np.array([0.5, -0.3, 0.2, 0.1, 4.0]) * np.hypot(m_sem, m_u)
    table = with_m_eff(verify_table([20, 30, 40, 50, 60], [False] * 5, ["band_mean"] * 5),
                       m_surrogate, m_u, m_dem, m_sem)
    plot_verify(table, tmp_path / "verify", flag_z=2.0)
    ceq_ax, ax = saved["figure"].axes
    assert "N·s/m" in ceq_ax.get_xlabel()
    assert "(kg)" in ax.get_xlabel() and "(kg)" in ax.get_ylabel() and "dem" in ax.get_ylabel()
    assert "m_\\mathrm{eff}" in ax.get_xlabel() and ax.get_xscale() == "linear"
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "band_mean (4)" in labels and "band_mean, off (|z| > 2) (1)" in labels
    within, off = ax.containers
    x_half, y_half = _bars(within)
    np.testing.assert_allclose(x_half, m_u[:4], rtol=1e-9)               # surrogate's u on x
    np.testing.assert_allclose(y_half, m_sem[:4], rtol=1e-9)             # DEM's SEM on y
    np.testing.assert_allclose(np.asarray(off.lines[0].get_ydata(), float), m_dem[4:], rtol=1e-12)
    assert off.lines[0].get_color() == "C3"
    lo, hi = ax.get_xlim()
    assert lo < m_surrogate.min() - m_u[3] and hi > m_surrogate.max() + m_u[0]   # negative shown
    texts = [t.get_text() for t in ax.texts]
    assert texts == ["worst |z| 4.00 (above the threshold 2)"]


def test_the_m_eff_panel_says_when_m_eff_was_not_compared(tmp_path, monkeypatch):
    saved = _axes_of(monkeypatch)
    table = verify_table([20, 30, 40], [False] * 3, ["peak"] * 3)
    nan = np.full(3, np.nan)
    for frame in (table, with_m_eff(table, nan, nan, nan, nan)):
        plot_verify(frame, tmp_path / "verify")
        ax = saved["figure"].axes[1]
        assert ax.containers == [] and "not compared" in ax.texts[0].get_text()


def test_the_ceq_panel_states_its_worst_z_within_the_threshold(tmp_path, monkeypatch):
    saved = _axes_of(monkeypatch)
    table = verify_table([20, 30, 40], [False] * 3, ["peak"] * 3)
    table["z_combined"] = [0.3, -1.25, 0.1]
    plot_verify(table, tmp_path / "verify", flag_z=3.0)
    assert [t.get_text() for t in saved["figure"].axes[0].texts] == [
        "worst |z| 1.25 (within the threshold 3)"]
