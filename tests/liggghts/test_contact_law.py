"""The contact law in LIGGGHTS rebounds with the configured restitution (within 2 %)."""

import pytest

from pidpipe.cell.scene import CellScene
from pidpipe.config import load_config, pair_properties
from pidpipe.liggghts.impacts import pair_restitution, wall_restitution

pytestmark = pytest.mark.engine


@pytest.mark.parametrize("speed", [0.05, 0.5])
def test_sphere_wall_restitution(tmp_path, speed):
    cfg = load_config()
    wanted = pair_properties(cfg, cfg["particle_material"], cfg["wall_material"])["restitution"]
    assert wall_restitution(CellScene.from_config(cfg), speed, tmp_path) == pytest.approx(wanted, rel=0.02)


@pytest.mark.parametrize("speed", [0.05, 0.5])
def test_sphere_sphere_restitution(tmp_path, speed):
    cfg = load_config()
    wanted = pair_properties(cfg, cfg["particle_material"], cfg["particle_material"])["restitution"]
    assert pair_restitution(CellScene.from_config(cfg), speed, tmp_path) == pytest.approx(wanted, rel=0.02)


def test_restitution_follows_the_config(tmp_path):
    cfg = load_config()
    for pair in cfg["pairs"]:
        if set(pair["materials"]) == {"acrylic", "aluminium"}:
            pair["restitution"] = 0.4
    assert wall_restitution(CellScene.from_config(cfg), 0.5, tmp_path) == pytest.approx(0.4, rel=0.02)


def test_restitution_error_shrinks_with_the_timestep(tmp_path):
    cfg = load_config()
    errors = []
    for fraction in (0.2, 0.05):
        cfg["fidelity"]["timestep_rayleigh_fraction"] = fraction
        errors.append(abs(wall_restitution(CellScene.from_config(cfg), 0.5, tmp_path) - 0.7))
    assert errors[1] < errors[0]
