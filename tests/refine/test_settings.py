"""The refine section: defaults, typed settings, and one clear line for each bad setting."""

import pytest

from pidpipe.config import validate_config
from pidpipe.config.refine import RefineSettings
from pidpipe.errors import ConfigError


def test_refine_defaults_to_ten_percent_intervals(config):
    settings = RefineSettings.from_config(config)
    assert settings.interval_fraction == 0.10
    assert settings.cases_per_round >= 1 and settings.max_rounds >= 1 and settings.max_cpu_s > 0
    assert RefineSettings.from_config(settings.as_params()) == settings


@pytest.mark.parametrize("key, value, says", [
    ("interval_fraction", 0, "must be > 0"),
    ("interval_fraction", 1.0, "must be < 1"),
    ("max_cpu_s", -5, "must be > 0"),
    ("cases_per_round", 0, "must be >= 1"),
    ("cases_per_round", 2.5, "must be of type integer"),
    ("max_rounds", 0, "must be >= 1"),
    ("budget_s", 10, "'budget_s' under refine is not a known key"),
    ("enabled", "yes", "must be of type boolean"),
    ("run_cases", "cluster", "must be one of auto, in_step, as_jobs"),
])
def test_a_bad_refine_value_is_refused_in_one_line_naming_the_key(config, key, value, says):
    config["refine"][key] = value
    with pytest.raises(ConfigError) as error:
        validate_config(config)
    message = str(error.value)
    assert "refine" in message and key in message and says in message
    assert "\n" not in message


def test_the_settings_refuse_each_bad_value_on_its_own_line():
    with pytest.raises(ConfigError) as error:
        RefineSettings(interval_fraction=0.0, max_cpu_s=float("inf"), cases_per_round=0,
                       max_rounds=True, run_cases="slurm")
    lines = str(error.value).splitlines()
    assert [line.split(" = ")[0] for line in lines] == [
        "config key refine.interval_fraction", "config key refine.max_cpu_s",
        "config key refine.run_cases", "config key refine.cases_per_round",
        "config key refine.max_rounds"]


def test_good_settings_have_no_problems():
    assert RefineSettings(0.05, 100.0, 2, 3).problems() == []


@pytest.mark.parametrize("run_cases, engine, in_step", [
    ("auto", "dem", True), ("auto", "liggghts", False), ("in_step", "liggghts", True),
    ("as_jobs", "dem", False)])
def test_auto_runs_the_dems_cases_in_the_step_and_liggghts_cases_as_jobs(run_cases, engine,
                                                                         in_step):
    assert RefineSettings(run_cases=run_cases).runs_in_step(engine) is in_step
