"""The config's sections as typed settings (pidpipe.config.sections, pidpipe.config.studies):
parsed once, each checking itself, and the rules' params built from them unchanged."""

from __future__ import annotations

import copy
import dataclasses

import pytest

from pidpipe.config import load_config, validate_config
from pidpipe.config.sections import (
    Bootstrap,
    Grid,
    Inspection,
    Optimisation,
    Settings,
    SurrogateSettings,
    Validation,
)
from pidpipe.config.settings import Budget, Environment
from pidpipe.config.stages import sorted_keys
from pidpipe.config.studies import FidelityStudySettings, SceneSettings
from pidpipe.errors import ConfigError
from pidpipe.steps import params

CONFIGS = ("config.yaml", ".test/config.yaml")


@pytest.fixture(params=CONFIGS)
def config(request):
    from pidpipe.config import REPO_ROOT

    return load_config(REPO_ROOT / request.param)


def test_the_whole_config_parses_once_into_its_sections(config):
    settings = Settings.from_config(config)
    assert settings.engine == config["engine"]
    assert settings.grid.fill_pct == tuple(config["grid"]["fill_pct"])
    assert settings.surrogate.method == config["surrogate"]["method"]
    assert settings.optimisation.bootstrap.draws == config["optimisation"]["bootstrap"]["draws"]
    assert [e.name for e in settings.environments] == [e["name"] for e in config["environments"]]
    assert settings.host.environment.name == config["environments"][0]["name"]
    with pytest.raises(dataclasses.FrozenInstanceError):
        settings.engine = "dem"


def test_rule_params_built_from_the_settings_are_the_plain_values_the_jobs_recorded(config):
    """A finished job reruns when its params change: the typed settings give back exactly the
    values the config's dicts gave (same numbers, types and key order)."""
    optimisation = {k: v for k, v in config["optimisation"].items() if k != "external_ceq_table"}
    assert repr(params.optimisation_params(config)) == repr(sorted_keys(optimisation))
    assert repr(params.environment_params(config)) == repr(sorted_keys(config["environments"]))
    assert repr(params.validation_params(config)) == repr(config["validation"]["cases"])
    bootstrap = config["optimisation"]["bootstrap"]
    assert params.map_uncertainty_params(config) == {
        "draws": min(bootstrap["draws"], params.MAP_DRAWS), "seed": bootstrap["seed"]}


def test_budget_and_environment_are_defined_once():
    from pidpipe.design import optimisation

    assert optimisation.Budget is Budget and optimisation.Environment is Environment
    budget = Budget.from_config(load_config())
    assert Budget(**budget.as_params()) == budget and budget.max_cells == 441


@pytest.mark.parametrize(("build", "key"), [
    (lambda: Grid((500,), (5,), (50,), replicates=0), "grid.replicates"),
    (lambda: Grid((500,), (5,), (150,)), "grid.fill_pct"),
    (lambda: Inspection(movie_cycles=0), "inspection.movie_cycles"),
    (lambda: Bootstrap(confidence=1.0), "optimisation.bootstrap"),
    (lambda: Optimisation(band_grid_points=1), "optimisation.band_grid_points"),
    (lambda: Optimisation(external_ceq_table=""), "optimisation.external_ceq_table"),
    (lambda: SurrogateSettings(method=""), "surrogate.method"),
    (lambda: Environment("e", (600, 500), (5, 6)), "environments"),
    (lambda: Budget(0, 21, 441), "budget"),
])
def test_each_section_refuses_a_bad_value_naming_its_key(build, key):
    with pytest.raises(ConfigError, match=f"config key {key}"):
        build()


def _with(section: str, value) -> dict:
    raw = copy.deepcopy(load_config())
    raw[section] = {**raw[section], **value}
    return raw


def test_the_fidelity_study_refuses_a_repeated_case_or_variant_and_an_unknown_baseline():
    config = load_config()
    study = config["fidelity_study"]
    twice = _with("fidelity_study", {"cases": study["cases"] + study["cases"][:1]})
    with pytest.raises(ConfigError, match=r"fidelity_study.cases\[10\].*listed twice"):
        FidelityStudySettings.from_config(validate_config(twice))
    named = _with("fidelity_study", {"variants": study["variants"] + [{"name": "reference"}]})
    with pytest.raises(ConfigError, match=r"fidelity_study.variants\[11\].name.*reserved"):
        FidelityStudySettings.from_config(validate_config(named))
    with pytest.raises(ConfigError, match="fidelity_study.baseline = 'nope'"):
        FidelityStudySettings.from_config(validate_config(_with("fidelity_study",
                                                                {"baseline": "nope"})))
    parsed = FidelityStudySettings.from_config(config)
    assert parsed.key_of("reference") == "fidelity_study.reference"
    assert parsed.key_of(study["variants"][2]["name"]) == "fidelity_study.variants[2].fidelity"


def test_the_scene_study_parses_its_section():
    scene = SceneSettings.from_config(load_config())
    assert scene.coupon_cells == 441 and scene.singles >= 19 and scene.cases
    with pytest.raises(ConfigError, match="config key scene"):
        SceneSettings(scene.cases, singles=5)


def test_validation_cases_keep_the_configs_numbers():
    config = load_config()
    assert Validation.from_config(config).as_params() == config["validation"]["cases"]
