"""The patch deck: golden file, and nothing but validated numbers and names reaches it.

Set PIDPIPE_UPDATE_GOLDEN=1 to rewrite the golden file after an intended template change.
"""

import os
from pathlib import Path

import numpy as np
import pytest

from pidpipe.cell.packing import Packing
from pidpipe.cell.patch import ring_centres
from pidpipe.cell.scene import CellScene
from pidpipe.config import load_config
from pidpipe.config.settings import ShakeSettings
from pidpipe.errors import ConfigError
from pidpipe.liggghts.patch_run import render_patch_deck

GOLDEN = Path(__file__).parents[1] / "golden" / "patch.lmp"


def _packing(dx):
    positions = [[0.0004 + dx, 0.0003, -0.01125], [-0.0005, 0.0002, -0.0088]]
    return Packing(positions_m=positions, radius_m=1.25e-3, n_spheres=2, seed=1, pile_height_m=0.006,
                   lid_height_m=0.0254, max_speed_m_s=0.0, settle_time_s=0.1, fill_pct=10.0)


def _render(tmp_path, label="patch_test"):
    config = load_config()
    centres = ring_centres(CellScene.from_config(config).cell, 1)[:2]
    return render_patch_deck(ShakeSettings.from_config(config), 500, 5, [_packing(0.0), _packing(1e-4)], centres, tmp_path, label)


def test_patch_deck_golden(tmp_path):
    plan = _render(tmp_path)
    text = plan["deck"].read_text()
    if os.environ.get("PIDPIPE_UPDATE_GOLDEN"):
        GOLDEN.write_text(text)
    assert text == GOLDEN.read_text(), "patch.lmp changed; if intended, rerun with PIDPIPE_UPDATE_GOLDEN=1"
    assert plan["cell_index"].tolist() == [0, 0, 1, 1]
    assert (tmp_path / "patch.stl").is_file()


def test_spheres_are_created_in_their_cells(tmp_path):
    text = _render(tmp_path)["deck"].read_text()
    created = np.array([[float(v) for v in line.split()[3:6]] for line in text.splitlines()
                        if line.startswith("create_atoms")])
    centre_1 = ring_centres(CellScene.from_config(load_config()).cell, 1)[1]
    assert np.allclose(created[2], [0.0005 + centre_1[0], 0.0003 + centre_1[1], -0.01125])


def test_patch_deck_holds_no_shell_include_or_string_variable(tmp_path):
    for line in _render(tmp_path)["deck"].read_text().splitlines():
        command = line.split("#")[0].split()
        if command:
            assert command[0] not in {"shell", "include", "python", "jump", "label"}
            if command[0] == "variable":
                assert command[2] in {"equal", "atom"}


@pytest.mark.parametrize("label", ["x\nshell touch pwned", "a b"])
def test_bad_label_is_refused(tmp_path, label):
    with pytest.raises(ConfigError, match="not allowed"):
        _render(tmp_path, label)
