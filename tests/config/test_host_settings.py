"""The host section of the config: defaults, nulls resolved, bad values named."""

from __future__ import annotations

import math

import pytest

from pidpipe.config import load_config, panel_mass_kg, validate_config
from pidpipe.config.settings import HostSettings
from pidpipe.errors import ConfigError


def test_the_defaults_resolve_to_the_panel_and_the_band_centre():
    config = load_config()
    host = HostSettings.from_config(config)
    assert host.mass_kg == pytest.approx(panel_mass_kg(config))
    assert host.natural_freq_hz == 275.0                     # 250-300 Hz
    assert math.sqrt(host.stiffness_n_m / host.mass_kg) / (2 * math.pi) == pytest.approx(275.0)
    assert host.damping_ns_m / (2 * math.sqrt(host.stiffness_n_m * host.mass_kg)) == pytest.approx(0.01)
    freqs = host.frequencies_hz()
    assert len(freqs) == host.freq_points and freqs[0] == pytest.approx(0.85 * 275.0)
    assert freqs[-1] == pytest.approx(1.15 * 275.0)


def test_given_values_are_kept():
    config = load_config()
    config["host"].update(mass_kg=0.5, natural_freq_hz=480.0, environment=1, design="peak")
    host = HostSettings.from_config(validate_config(config))
    assert (host.mass_kg, host.natural_freq_hz, host.design) == (0.5, 480.0, "peak")
    assert host.environment.name == "450-500 Hz, 1-2 g"


@pytest.mark.parametrize("key, value", [("damping_ratio", -0.1), ("force_n", []),
                                        ("freq_points", 2), ("design", "best"), ("cells", 0)])
def test_a_bad_value_is_refused_naming_its_key(key, value):
    config = load_config()
    config["host"][key] = value
    with pytest.raises(ConfigError, match=f"host.{key}"):
        validate_config(config)


def test_an_environment_index_past_the_list_is_named():
    config = load_config()
    config["host"]["environment"] = 3
    with pytest.raises(ConfigError, match=r"host.environment = 3 .* 3 environment\(s\)"):
        HostSettings.from_config(validate_config(config))
