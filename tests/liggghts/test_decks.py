"""Deck templates: golden files, and nothing but validated numbers reaches a deck.

Set PIDPIPE_UPDATE_GOLDEN=1 to rewrite the golden files after an intended template change.
"""

import os
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from pidpipe.cases import CaseSpec
from pidpipe.cell.packing import Packing
from pidpipe.cell.scene import CellScene
from pidpipe.config import load_config
from pidpipe.config.settings import ShakeSettings
from pidpipe.errors import ConfigError
from pidpipe.liggghts.decks import common_values, render
from pidpipe.liggghts.shake import render_shake_deck


def _plain(config: dict) -> ShakeSettings:
    """The shake settings of ``config`` without the motion sampling: the plain deck."""
    return replace(ShakeSettings.from_config(config), motion=None)

GOLDEN = Path(__file__).parents[1] / "golden"
POSITIONS = [[0.0004, 0.0003, -0.01125], [-0.0005, 0.0002, -0.0088]]


def _packing():
    return Packing(positions_m=POSITIONS, radius_m=1.25e-3, n_spheres=2, seed=1, pile_height_m=0.006,
                   lid_height_m=0.0254, max_speed_m_s=0.0, settle_time_s=0.1, fill_pct=10.0)


def _compare(name, text):
    path = GOLDEN / name
    if os.environ.get("PIDPIPE_UPDATE_GOLDEN"):
        path.write_text(text)
    assert text == path.read_text(), f"{name} changed; if intended, rerun with PIDPIPE_UPDATE_GOLDEN=1"


def test_shake_deck_golden(tmp_path):
    plan = render_shake_deck(_plain(load_config()), CaseSpec(500, 5, 10), _packing(), tmp_path)
    _compare("shake.lmp", plan["deck"].read_text())


def test_shake_deck_of_two_cells_golden(tmp_path):
    """Two cells side by side in one mesh: a group and a ledger each, the second cell's spheres
    moved to its place and numbered after the first's."""
    second = Packing(positions_m=[[0.0001, -0.0002, -0.0112]], radius_m=1.25e-3, n_spheres=1,
                     seed=2, pile_height_m=0.003, lid_height_m=0.0254, max_speed_m_s=0.0,
                     settle_time_s=0.1, fill_pct=10.0)
    plan = render_shake_deck(_plain(load_config()), CaseSpec(500, 5, 10), [_packing(), second], tmp_path)
    text = plan["deck"].read_text()
    assert "group           cell1 id 3:3" in text
    assert "fix             cycle_power all ave/time 1 2223 2223 v_power v_abs_power file" in text
    # each cell's power: one per-sphere pass a step, summed per cell only at the cycle ends
    assert "fix             sphere_cycle_power all ave/atom 1 2223 2223 v_sphere_power" in text
    assert " c_cycle_power_cell0[1] c_cycle_power_cell1[1] file cell_power.txt" in text
    # and each cell's first-harmonic sum in the same pass (pidpipe.measurement.harmonics),
    # not the mesh's
    assert ("ave/atom 1 2223 2223 v_sphere_power v_sphere_force_cos\n" in text
            and " c_cycle_power_cell0[2] c_cycle_power_cell1[2] file cell_harmonics.txt" in text)
    assert "cycle_harmonics" not in text
    assert "equal (fcm(" not in text
    assert text.count("mesh/surface/stress") == 1
    _compare("shake_two_cells.lmp", text)


def test_shake_deck_writes_the_subdivided_mesh_only_when_asked(tmp_path):
    """mesh_subdivisions (benchmarks/experiments/bench_solver_difference.py) changes the wall mesh and
    nothing else; the default is the campaign's mesh of 20 triangles per cell."""
    import meshio

    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    default = render_shake_deck(_plain(load_config()), CaseSpec(500, 5, 10), _packing(), tmp_path / "a")
    finer = render_shake_deck(_plain(load_config()), CaseSpec(500, 5, 10), _packing(), tmp_path / "b",
                              mesh_subdivisions=4)
    assert default["deck"].read_text() == finer["deck"].read_text()
    assert meshio.read(tmp_path / "a" / "cell.stl").cells_dict["triangle"].shape == (20, 3)
    assert meshio.read(tmp_path / "b" / "cell.stl").cells_dict["triangle"].shape == (92, 3)


def test_shake_deck_without_rotation_and_friction_golden(tmp_path):
    cfg = load_config()
    cfg["fidelity"].update(rotation=False, friction=False, youngs_modulus_scale=0.1)
    plan = render_shake_deck(_plain(cfg), CaseSpec(50, 1, 10), _packing(), tmp_path)
    text = plan["deck"].read_text()
    assert "fix             integrate all nve\n" in text
    assert "coefficientFriction peratomtypepair 2 0.0 0.0 0.0 0.0" in text
    _compare("shake_no_rotation_no_friction.lmp", text)


def _values(**overrides):
    values = common_values(CellScene.from_config(load_config()), np.array(POSITIONS), 1e-6, "cell.stl", "test", "pack",
                           {"xlo": -1, "xhi": 1, "ylo": -1, "yhi": 1, "zlo": -1, "zhi": 1}, 100)
    values.update(settle_steps=10, output_file="settled.dump", tap_amplitude_m=2.5e-4, tap_period_s=0.01, tap_steps=1000,
                  further_settling=[])
    values.update(overrides)
    return values


def test_pack_deck_golden():
    _compare("pack.lmp", render("pack.lmp.j2", _values()))


@pytest.mark.parametrize("field, value", [
    ("timestep_s", "1e-6\nshell rm -rf /"),
    ("timestep_s", "1e-6 include evil.in"),
    ("timestep_s", float("nan")),
    ("timestep_s", True),
    ("settle_steps", 10.5),
    ("settle_steps", "10\nvariable x string y"),
    ("output_file", "../../etc/passwd"),
    ("output_file", "out.dump\nshell touch pwned"),
    ("mesh_file", "cell.stl shell touch pwned"),
    ("case_label", "x\nshell touch pwned"),
])
def test_non_numbers_never_reach_a_deck(field, value):
    with pytest.raises(ConfigError, match="not allowed"):
        render("pack.lmp.j2", _values(**{field: value}))


def test_nested_value_is_checked_too():
    values = _values()
    values["restitution"] = dict(values["restitution"], pp="0.7\nshell touch pwned")
    with pytest.raises(ConfigError, match="only finite numbers"):
        render("pack.lmp.j2", values)


def test_missing_value_is_an_error():
    values = _values()
    del values["timestep_s"]
    with pytest.raises(ConfigError, match="needs a value"):
        render("pack.lmp.j2", values)


def test_no_deck_holds_a_shell_include_or_string_variable(tmp_path):
    plan = render_shake_deck(_plain(load_config()), CaseSpec(500, 5, 10), _packing(), tmp_path)
    for line in plan["deck"].read_text().splitlines():
        command = line.split("#")[0].split()
        if command:
            assert command[0] not in {"shell", "include", "python", "jump", "label"}
            if command[0] == "variable":
                assert command[2] == "equal"


def test_shake_deck_with_motion_sampling_and_movie_golden(tmp_path):
    """The motion and movie blocks (off in every other golden deck): the walls store their
    force, each cell gets its floor, lid, centre and energy columns, the movie reads its steps."""
    from pidpipe.config.inspection import MotionSampling, MovieSettings

    second = Packing(positions_m=[[0.0001, -0.0002, -0.0112]], radius_m=1.25e-3, n_spheres=1,
                     seed=2, pile_height_m=0.003, lid_height_m=0.0254, max_speed_m_s=0.0,
                     settle_time_s=0.1, fill_pct=10.0)
    settings = replace(_plain(load_config()), motion=MotionSampling(20))
    plan = render_shake_deck(settings, CaseSpec(500, 5, 10), [_packing(), second], tmp_path,
                             movie=MovieSettings(5, 2))
    text = plan["deck"].read_text()
    assert "meshes cell store_force yes\n" in text
    assert "ave/atom 10 11 110 v_sphere_power v_floor_fz v_lid_force" in text
    assert " c_window_cell1[1] c_window_cell1[2] c_window_cell1[3] file motion_windows.txt" in text
    assert " v_energy_cell1 v_centre_cell1 v_bottom_cell1 v_top_cell1 file motion_energy.txt" in text
    # 2223 steps a cycle, 20 windows: 111 steps, rounded down to samples every 10 steps
    assert plan["motion"]["window_steps"] == 110 and "ave/atom 10 11 110" in text
    steps = [int(s) for s in (tmp_path / "movie_steps.txt").read_text().split()]
    cycles = plan["cycles"]
    assert len(steps) == 10 + 1 and steps[0] == (cycles - 2) * 2223 and steps[-1] == cycles * 2223 + 1
    _compare("shake_inspection.lmp", text)
