"""Elastic energy held in the contacts: the formulas against their force laws, and the constants.

The force laws here are the NumPy DEM's (pidpipe.dem.scene, built independently from the
config and checked against LIGGGHTS in tests/liggghts/test_contact_law.py): a_n delta^{3/2}
normal, a_t sqrt(delta) |xi| tangential. The stored energy must be their work, integrated
numerically.
"""

import numpy as np
import pytest
from scipy.integrate import quad

from pidpipe.cell.scene import CellScene
from pidpipe.dem.from_scene import dem_scene
from pidpipe.liggghts.contact_energy import (
    contact_elastic_energies,
    contact_elasticities,
)
from pidpipe.liggghts.parsing import CONTACT_COLUMNS
from pidpipe.physics.contact import (
    hertz_normal_energy,
    hertz_normal_force,
    tangential_spring_energy,
)

OVERLAPS_M = (1e-10, 3e-8, 1e-6)   # a resting sphere's floor contact to a hard impact


@pytest.fixture
def laws(config):
    scene = dem_scene(CellScene.from_config(config), 500.0, 5.0)
    return {"particle_particle": scene.pp, "particle_wall": scene.pw}


@pytest.mark.parametrize("kind", ["particle_particle", "particle_wall"])
@pytest.mark.parametrize("overlap", OVERLAPS_M)
def test_hertz_energy_is_the_work_of_the_hertz_force(config, laws, kind, overlap):
    law = laws[kind]
    work, _ = quad(lambda d: law.a_n * d**1.5, 0.0, overlap, epsabs=0.0, epsrel=1e-12)
    elasticity = contact_elasticities(CellScene.from_config(config))[kind]
    energy = hertz_normal_energy(elasticity.youngs_eff_pa, elasticity.radius_eff_m, overlap)
    assert energy == pytest.approx(work, rel=1e-9)
    force = hertz_normal_force(elasticity.youngs_eff_pa, elasticity.radius_eff_m, overlap)
    assert force == pytest.approx(law.a_n * overlap**1.5, rel=1e-12)


@pytest.mark.parametrize("kind", ["particle_particle", "particle_wall"])
def test_tangential_energy_is_the_work_of_the_spring_at_the_present_overlap(config, laws, kind):
    overlap = 3e-8
    xi = np.array([2e-9, -1e-9, 0.5e-9])
    stiffness = laws[kind].a_t * np.sqrt(overlap)
    length = float(np.linalg.norm(xi))
    work, _ = quad(lambda s: stiffness * s, 0.0, length, epsabs=0.0, epsrel=1e-12)
    elasticity = contact_elasticities(CellScene.from_config(config))[kind]
    energy = tangential_spring_energy(elasticity.shear_eff_pa, elasticity.radius_eff_m, overlap, xi)
    assert energy == pytest.approx(work, rel=1e-9)


def test_no_energy_without_overlap(config):
    elasticity = contact_elasticities(CellScene.from_config(config))["particle_wall"]
    assert hertz_normal_energy(elasticity.youngs_eff_pa, elasticity.radius_eff_m, -1e-9) == 0.0
    assert tangential_spring_energy(elasticity.shear_eff_pa, elasticity.radius_eff_m, 0.0,
                                    [1e-9, 0.0, 0.0]) == 0.0


def test_constants_follow_the_deck(config):
    # the Young's modulus scale of the fidelity reaches the deck, so it must reach the energy
    base = contact_elasticities(CellScene.from_config(config))
    config["fidelity"]["youngs_modulus_scale"] = 0.1
    soft = contact_elasticities(CellScene.from_config(config))
    radius = config["materials"][config["particle_material"]]["radius_m"]
    for kind in base:
        assert soft[kind].youngs_eff_pa == pytest.approx(0.1 * base[kind].youngs_eff_pa, rel=1e-12)
        assert soft[kind].shear_eff_pa == pytest.approx(0.1 * base[kind].shear_eff_pa, rel=1e-12)
    assert base["particle_particle"].radius_eff_m == pytest.approx(radius / 2)
    assert base["particle_wall"].radius_eff_m == radius


def test_a_frame_sums_normal_and_tangential_energy_of_every_contact(config):
    elasticity = contact_elasticities(CellScene.from_config(config))["particle_particle"]
    e_star, g_star, r_star = elasticity.youngs_eff_pa, elasticity.shear_eff_pa, elasticity.radius_eff_m
    rows = np.array([[1, 2, 0, 1e-9, 0.0, 0.0, 4e-8],
                     [2, 3, 0, 0.0, 0.0, 0.0, 1e-8],
                     [3, 4, 0, 5e-10, 5e-10, 0.0, -2e-12]])    # touching, no overlap: nothing
    assert rows.shape[1] == len(CONTACT_COLUMNS)
    expected = (8 / 15 * e_star * r_star**0.5 * (4e-8**2.5 + 1e-8**2.5)
                + 0.5 * 8 * g_star * (r_star * 4e-8) ** 0.5 * 1e-18)
    assert np.sum(contact_elastic_energies(rows, elasticity)) == pytest.approx(expected, rel=1e-12)
    assert np.sum(contact_elastic_energies(np.empty((0, len(CONTACT_COLUMNS))), elasticity)) == 0.0
