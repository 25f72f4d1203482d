"""Which grid pilots run short (pidpipe.config.pilots): the points no environment's band reads."""

from __future__ import annotations

import copy

import pytest

from pidpipe.config import load_config
from pidpipe.config.pilots import (
    band_points,
    bracketing_levels,
    grid_case_config,
    pilot_measured_cycles,
)
from pidpipe.config.stages import stage_config
from pidpipe.errors import ConfigError


@pytest.mark.parametrize("low, high, expected", [
    (250, 300, (100, 500)),            # between two levels
    (450, 500, (100, 500)),            # ends on a level
    (500, 500, (500,)),                # a band of one level
    (500, 750, (500, 750)),
    (60, 1000, (50, 100, 500, 750, 1000)),
    (20, 40, (50,)),                   # below the grid: its lowest level
    (2000, 3000, (1000,)),             # above the grid: its highest level
])
def test_a_band_is_bracketed_by_the_levels_around_it(low, high, expected):
    assert bracketing_levels([1000, 50, 500, 100, 750], low, high) == expected


def test_the_default_campaign_screens_the_points_no_band_lies_between():
    config = load_config()
    grid = config["grid"]
    short = {(f, g) for f in grid["freq_hz"] for g in grid["accel_g"]
             if pilot_measured_cycles(config, f, g) < config["fidelity"]["measured_cycles"]}
    # bands 250-300 Hz / 5-6 g, 450-500 Hz / 1-2 g, 750-800 Hz / 4-6 g
    assert short == {(50, 0.5), (50, 1), (50, 2), (50, 5), (50, 10), (100, 0.5), (500, 0.5),
                     (750, 0.5), (750, 1), (1000, 0.5), (1000, 1)}
    assert band_points(config) == {(f, g) for f in grid["freq_hz"] for g in grid["accel_g"]} - short
    assert {pilot_measured_cycles(config, f, g) for f, g in short} == {12}


@pytest.mark.parametrize("change", [
    {"refine": {"enabled": False}},                    # no loop: the pilots are the table
    {"fidelity": {"target_relative_sem": 0.05}},       # a uniform target chases every case
    {"refine": {"far_pilot_measured_cycles": None}},   # switched off
])
def test_every_pilot_is_full_unless_the_loop_screens(change):
    config = copy.deepcopy(load_config())
    for section, values in change.items():
        config[section].update(values)
    assert pilot_measured_cycles(config, 50, 10) == config["fidelity"]["measured_cycles"]


def test_a_short_pilot_is_never_longer_than_a_full_one():
    config = copy.deepcopy(load_config())
    config["fidelity"]["measured_cycles"] = 8
    assert pilot_measured_cycles(config, 50, 10) == 8


def test_only_the_measured_cycles_of_a_far_point_differ_from_the_stage_config():
    config = load_config()
    full, far = stage_config(config, "case"), grid_case_config(config, 50, 10)
    assert far["fidelity"].pop("measured_cycles") == 12
    full["fidelity"].pop("measured_cycles")
    assert far == full
    assert grid_case_config(config, 500, 2) == stage_config(config, "case")


@pytest.mark.parametrize("value, words", [
    (3, "two blocks of fidelity.sem_block_cycles (2)"),
    (1, "far_pilot_measured_cycles"),
    ("12", "far_pilot_measured_cycles"),
])
def test_a_bad_short_pilot_length_is_refused_in_one_line(value, words, tmp_path):
    import yaml

    from pidpipe.config import REPO_ROOT

    config = yaml.safe_load((REPO_ROOT / "config.yaml").read_text(encoding="utf-8"))
    config["refine"]["far_pilot_measured_cycles"] = value
    path = tmp_path / "config.yaml"
    path.write_text(yaml.safe_dump(config), encoding="utf-8")
    with pytest.raises(ConfigError) as error:
        load_config(path)
    assert words in str(error.value) and "\n" not in str(error.value)


def test_check_config_names_the_short_pilots(capsys):
    from pidpipe.cli import main
    from pidpipe.config import REPO_ROOT

    assert main(["--config", str(REPO_ROOT / "config.yaml"), "check-config"]) == 0
    line = next(l for l in capsys.readouterr().out.splitlines() if "pilots:" in l)
    assert line.strip().startswith("pilots: 7 cells x 40 measured cycles; 12 at the 11 (f, G)")
    assert "50 Hz/0.5 g" in line and "1000 Hz/1 g" in line and "500 Hz/2 g" not in line


def test_short_pilot_points_are_those_of_pilot_measured_cycles():
    from pidpipe.config.pilots import short_pilot_points

    config = load_config()
    assert len(short_pilot_points(config)) == 11
    config = copy.deepcopy(config)
    config["refine"]["enabled"] = False
    assert short_pilot_points(config) == []
