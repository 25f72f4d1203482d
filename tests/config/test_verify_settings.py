"""The verify section: defaults, its typed settings, and a clear error for a bad value."""

import pytest

from pidpipe.config import validate_config
from pidpipe.config.settings import VerifySettings
from pidpipe.errors import ConfigError
from pidpipe.steps.params import verify_case_config, verify_params


def test_verify_defaults_to_liggghts_at_two_combined_uncertainties(config):
    settings = VerifySettings.from_config(config)
    assert settings == VerifySettings("liggghts", 2.0, 200, 13)
    assert VerifySettings.from_config(verify_params(config)) == settings


def test_the_verifying_cases_run_with_verify_engine_and_the_campaigns_fidelity(config):
    config["verify"]["engine"] = "dem"
    case = verify_case_config(config)
    assert case["engine"] == "dem"
    assert case["fidelity"]["target_relative_sem"] == config["fidelity"]["target_relative_sem"]
    config["verify"]["engine"] = "liggghts"
    assert "engine" not in verify_case_config(config)        # as the campaign's LIGGGHTS cases


@pytest.mark.parametrize("key, value", [("engine", "lammps"), ("flag_z", 0), ("surrogate_draws", -1)])
def test_a_bad_verify_value_is_refused_naming_the_key(config, key, value):
    config["verify"][key] = value
    with pytest.raises(ConfigError, match=key):
        validate_config(config)
