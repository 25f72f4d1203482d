"""The m_eff / bed mass maps and their uncertainty panels."""

import numpy as np
import pytest

from pidpipe.design.surrogate import fit_surrogate
from pidpipe.figures.maps import (M_EFF_RATIO_LABEL, bed_mass_of_fill, m_eff_ratio_grid,
                                  plot_m_eff_freq_accel, plot_m_eff_freq_fill)
from tests.steps.test_m_eff_surrogate import bed_mass, lifting_ratio, m_eff_table


@pytest.fixture(scope="module")
def surrogate():
    return fit_surrogate(m_eff_table(), method="gp", target="linear",
                         value_column="m_eff_cell_kg", sem_column="m_eff_cell_sem_kg")


def test_bed_mass_is_the_tables_on_its_fills_and_linear_between():
    mass = bed_mass_of_fill([25.0, 25.0, 50.0, 90.0, 50.0], [1.0, 1.2, 2.0, np.nan, 2.0])
    np.testing.assert_allclose(mass([25.0, 50.0, 37.5]), [1.1, 2.0, 1.55])
    with pytest.raises(ValueError, match="bed_mass_kg"):
        bed_mass_of_fill([25.0], [np.nan])


def test_the_ratio_and_its_uncertainty_are_the_gps_over_the_bed_mass(surrogate):
    table = m_eff_table()
    mass = bed_mass_of_fill(table["fill_pct"], table["bed_mass_kg"])
    f, g, r = np.array([60.0, 800.0]), np.array([0.5, 10.0]), np.array([25.0, 90.0])
    ratio, sd = m_eff_ratio_grid(surrogate, mass, f, g, r)
    value, std = surrogate.predict_with_uncertainty(f, g, r)
    np.testing.assert_allclose(ratio, value / bed_mass(r))
    np.testing.assert_allclose(sd, std / bed_mass(r))
    # resting at 0.5 g, airborne at 10 g (the table's truth within a few of its 2 % noise)
    np.testing.assert_allclose(ratio, lifting_ratio(g), atol=0.08)


def test_maps_have_a_ratio_and_an_uncertainty_row_with_units(surrogate, tmp_path):
    table = m_eff_table()
    mass = bed_mass_of_fill(table["fill_pct"], table["bed_mass_kg"])
    figure = plot_m_eff_freq_fill(surrogate, mass, accel_levels_g=(0.5, 2.0, 20.0),
                                  stem=tmp_path / "fill")
    axes = figure.axes
    maps, panels = axes[:3], axes[3:6]
    assert [a.get_xlabel() for a in panels] == ["frequency f (Hz)"] * 3
    assert maps[0].get_ylabel() == "fill fraction r (%)"
    assert "predictive std" in panels[0].get_title()
    assert "outside the surrogate domain" in maps[2].get_title()     # 20 g: not extrapolated
    labels = [a.get_ylabel() for a in axes[6:]]
    assert M_EFF_RATIO_LABEL in labels and any("% of the bed" in label for label in labels)
    assert (tmp_path / "fill.png").is_file() and (tmp_path / "fill.pdf").is_file()
    figure = plot_m_eff_freq_accel(surrogate, mass)
    assert figure.axes[0].get_ylabel() == "base acceleration G (g)"
