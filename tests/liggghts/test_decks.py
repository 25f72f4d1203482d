"""Deck templates: golden files, and nothing but validated numbers reaches a deck.

Set PIDPIPE_UPDATE_GOLDEN=1 to rewrite the golden files after an intended template change.
"""

import os
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
    plan = render_shake_deck(ShakeSettings.from_config(load_config()), CaseSpec(500, 5, 10), _packing(), tmp_path)
    _compare("shake.lmp", plan["deck"].read_text())


def test_shake_deck_of_two_cells_golden(tmp_path):
    """Two cells side by side in one mesh: a group and a ledger each, the second cell's spheres
    moved to its place and numbered after the first's."""
    second = Packing(positions_m=[[0.0001, -0.0002, -0.0112]], radius_m=1.25e-3, n_spheres=1,
                     seed=2, pile_height_m=0.003, lid_height_m=0.0254, max_speed_m_s=0.0,
                     settle_time_s=0.1, fill_pct=10.0)
    plan = render_shake_deck(ShakeSettings.from_config(load_config()), CaseSpec(500, 5, 10), [_packing(), second], tmp_path)
    text = plan["deck"].read_text()
    assert "group           cell1 id 3:3" in text
    assert "fix             cycle_power all ave/time 1 2223 2223 v_power v_abs_power v_power_cell0 v_power_cell1 file" in text
    assert text.count("mesh/surface/stress") == 1
    _compare("shake_two_cells.lmp", text)


def test_shake_deck_without_rotation_and_friction_golden(tmp_path):
    cfg = load_config()
    cfg["fidelity"].update(rotation=False, friction=False, youngs_modulus_scale=0.1)
    plan = render_shake_deck(ShakeSettings.from_config(cfg), CaseSpec(50, 1, 10), _packing(), tmp_path)
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
    plan = render_shake_deck(ShakeSettings.from_config(load_config()), CaseSpec(500, 5, 10), _packing(), tmp_path)
    for line in plan["deck"].read_text().splitlines():
        command = line.split("#")[0].split()
        if command:
            assert command[0] not in {"shell", "include", "python", "jump", "label"}
            if command[0] == "variable":
                assert command[2] == "equal"
