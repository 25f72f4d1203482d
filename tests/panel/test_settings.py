"""The panel's settings: defaults from geometry and Table 2, the budget, and one clear line per bad value."""

import copy

import pytest
import yaml

from pidpipe.config import DEFAULT_CONFIG_PATH, validate_config
from pidpipe.config.panel import PanelSettings
from pidpipe.errors import ConfigError


def raw():
    return yaml.safe_load(DEFAULT_CONFIG_PATH.read_text())


def settings_of(**panel):
    config = raw()
    config["panel"] = {**config["panel"], **panel}
    return PanelSettings.from_config(validate_config(config))


def test_defaults_are_table_2_and_the_budget_is_a_tenth_of_the_plate():
    s = settings_of()
    assert (s.face_thickness_m, s.face_density_kg_m3, s.face_youngs_modulus_pa, s.face_poisson_ratio) == \
        (0.25e-3, 2800.0, 72e9, 0.33)
    assert (s.core_height_m, s.core_density_kg_m3) == (25.4e-3, 32.1)
    assert (s.core_shear_modulus_xz_pa, s.core_shear_modulus_yz_pa) == (1.85e8, 0.89e8)
    assert s.boundary == "simply_supported"
    assert s.n_spheres * s.sphere_mass_kg == pytest.approx(0.1 * s.plate_mass_kg, rel=1e-3)


def test_the_old_n_cells_key_still_works_and_keeps_its_meaning():
    config = raw()
    config["panel"]["n_cells"] = 1764
    validated = validate_config(config)
    assert validated["panel"]["n_cells"] == 1764
    assert PanelSettings.from_config(validated).length_m == 1.05


def test_a_budget_in_spheres_is_taken_as_it_is():
    config = raw()
    config["budget"] = {"mode": "spheres", "spheres": 5000}
    assert PanelSettings.from_config(validate_config(config)).n_spheres == 5000


@pytest.mark.parametrize("key, value, words", [
    ("boundary", "clamped", "panel.boundary = 'clamped' is not allowed: it must be one of simply_supported"),
    ("length_m", -1.0, "panel.length_m = -1.0 is not allowed: it must be > 0"),
    ("width_m", 0.0, "panel.width_m = 0.0 is not allowed: it must be > 0"),
    ("face_poisson_ratio", 0.5, "panel.face_poisson_ratio = 0.5 is not allowed: it must be < 0.5"),
    ("core_shear_modulus_xz_pa", 0, "panel.core_shear_modulus_xz_pa = 0 is not allowed: it must be > 0"),
    ("modal_force_n", [], "panel.modal_force_n = [] is not allowed: it must have at least 1 item"),
    ("modal_force_n", [0.1, -1], "panel.modal_force_n[1] = -1 is not allowed: it must be > 0"),
    ("effective_mass_fraction", 1.5, "panel.effective_mass_fraction = 1.5 is not allowed: it must be <= 1"),
    ("regions", 0, "panel.regions = 0 is not allowed: it must be >= 1"),
    ("confidence", 1.0, "panel.confidence = 1.0 is not allowed: it must be < 1"),
    ("stiffness", 3, "'stiffness' under panel is not a known key"),
])
def test_a_bad_panel_setting_is_one_clear_line(key, value, words):
    config = raw()
    config["panel"][key] = value
    with pytest.raises(ConfigError) as error:
        validate_config(config)
    message = str(error.value)
    assert words in message and "\n" not in message


def test_a_plate_smaller_than_a_cell_is_one_clear_line():
    with pytest.raises(ConfigError) as error:
        settings_of(length_m=0.004, width_m=0.1)
    message = str(error.value)
    assert "must hold at least one honeycomb cell (5.5 mm x 4.76 mm)" in message and "\n" not in message


def test_a_budget_too_small_for_one_sphere_is_one_clear_line():
    config = raw()
    config["panel"].update(length_m=0.006, width_m=0.006)   # one cell, 80 mg: 10 % is 8 mg
    with pytest.raises(ConfigError) as error:
        PanelSettings.from_config(validate_config(config))
    assert "gives 0 spheres for the 0.006 m x 0.006 m plate" in str(error.value)
