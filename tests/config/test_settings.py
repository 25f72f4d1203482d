"""Typed settings: parsed once from a validated config or from a stage's part of one."""

from __future__ import annotations

import dataclasses
import math

import pytest

from pidpipe.cell.scene import CellScene
from pidpipe.config import load_config, spheres_for_fill
from pidpipe.config.settings import (
    Budget,
    Environment,
    Fidelity,
    Fill,
    Materials,
    PourSettings,
    Pouring,
    Sampling,
    ShakeSettings,
)
from pidpipe.config.stages import stage_config
from pidpipe.errors import ConfigError
from pidpipe.physics.contact import rayleigh_time


def test_every_stage_parses_its_own_part_of_the_config():
    config = load_config()
    shake = ShakeSettings.from_config(stage_config(config, "case"))
    pour = PourSettings.from_config(stage_config(config, "packing"))
    assert shake == ShakeSettings.from_config(config)
    assert pour == PourSettings.from_config(config)
    assert shake.coupon_n_cells == 441 and shake.sampling.cells_per_run == 7
    assert pour.pouring.seed == 20261123 and pour.fill.full_cell_spheres == 21


def test_the_pour_engine_defaults_to_liggghts_and_reaches_both_pouring_stages_only_when_not():
    config = load_config()
    assert config["fidelity"]["pour_engine"] == "liggghts"
    assert PourSettings.from_config(config).pouring.engine == "liggghts"
    # a LIGGGHTS campaign's params stay as they were (nothing reruns)
    for stage in ("packing", "case"):
        assert "pour_engine" not in stage_config(config, stage)["fidelity"]
    config["fidelity"]["pour_engine"] = "dem"
    for stage in ("packing", "case"):        # the case stage pours the further packings
        part = stage_config(config, stage)
        assert part["fidelity"]["pour_engine"] == "dem"
        assert PourSettings.from_config(part).pouring.engine == "dem"


def test_a_pour_engine_that_does_not_exist_is_refused():
    with pytest.raises(ConfigError, match="fidelity.pour_engine"):
        Pouring(0.15, 1, "lammps")


def test_a_stage_part_without_a_key_the_stage_reads_fails_at_once():
    part = stage_config(load_config(), "packing")     # pours do not read the sampling keys
    with pytest.raises(KeyError, match="target_relative_sem"):
        Sampling.from_config(part)


def test_settings_are_frozen():
    fidelity = Fidelity.from_config(load_config())
    with pytest.raises(dataclasses.FrozenInstanceError):
        fidelity.friction = False


def test_materials_name_the_configured_pairs_and_fall_back_for_the_wall_pair():
    config = load_config()
    materials = Materials.from_config(config)
    assert materials.particle.name == "acrylic" and materials.particle.radius_m == 1.25e-3
    assert (materials.particle_particle.friction, materials.particle_particle.restitution) == (0.096, 0.70)
    assert (materials.particle_wall.friction, materials.particle_wall.restitution) == (0.14, 0.70)
    assert materials.wall_wall.restitution == 0.85
    config["pairs"] = [p for p in config["pairs"] if p["materials"] != ["aluminium", "aluminium"]]
    assert Materials.from_config(config).wall_wall == Materials.from_config(config).particle_wall


def test_fill_and_budget_agree_with_the_config_functions():
    config = load_config()
    fill = Fill.from_config(config)
    assert [fill.spheres(r) for r in (25, 50, 75, 90)] == [spheres_for_fill(config, r)
                                                           for r in (25, 50, 75, 90)] == [5, 11, 16, 19]
    assert Budget.from_config(config).as_params() == {"n_spheres": 229, "full_cell_spheres": 21,
                                                      "n_cells_coupon": 441, "n_cells_panel": 441}


def test_the_transient_lasts_the_configured_cycles_or_the_minimum_time():
    sampling = Sampling.from_config(load_config())     # 5 cycles, at least 0.03 s
    assert sampling.transient_cycles_at(50.0) == 5
    assert sampling.transient_cycles_at(1000.0) == 30


def test_environments_are_typed_bands():
    envs = Environment.list_from_config(load_config())
    assert envs[0] == Environment("250-300 Hz, 5-6 g", (250.0, 300.0), (5.0, 6.0))


def test_the_scene_softens_every_modulus_and_switches_friction_off_as_configured():
    config = load_config()
    config["fidelity"].update(youngs_modulus_scale=0.01, friction=False)
    scene = CellScene.from_config(config)
    assert scene.particle.youngs_modulus_pa == pytest.approx(2.84e7)
    assert scene.wall.youngs_modulus_pa == pytest.approx(7.0e8)
    assert scene.pair("pp").friction == 0.0 and scene.pair("pw").restitution == 0.70
    expected = rayleigh_time(1.25e-3, 1180.0, 2.84e7, 0.402)
    assert scene.rayleigh_time_s == pytest.approx(expected)


def test_the_timestep_is_a_whole_number_of_steps_per_cycle_within_the_fraction():
    scene = CellScene.from_config(load_config())
    plan = scene.timestep(750.0)
    assert plan.steps_per_cycle * plan.timestep_s == pytest.approx(1.0 / 750.0)
    assert plan.rayleigh_fraction <= 0.2 and plan.rayleigh_fraction > 0.2 * (1 - 1.0 / plan.steps_per_cycle)
    assert math.isclose(plan.rayleigh_time_s, scene.rayleigh_time_s)
