"""The host check with model (c) on the real compiled DEM (pidpipe.loop.host.host_check): a short
sweep at a force that keeps the bed resting, with fake surrogates."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from pidpipe.cell.scene import CellScene
from pidpipe.config import load_config
from pidpipe.config.settings import HostSettings
from pidpipe.loop.host import MODELS, HostLoad, host_check
from tests._surrogates import FakeSurrogate, constant, lifting_bed
from tests.dem.conftest import DATA

LOAD = HostLoad(n_cells=20, spheres_per_cell=11, fill_pct=50.0,
                sphere_mass_kg=1180 * 4 / 3 * np.pi * 1.25e-3**3, coupon_n_cells=441)
BED_KG = LOAD.spheres_per_cell * LOAD.sphere_mass_kg


@pytest.fixture(scope="module")
def checked():
    config = load_config()
    settings = dataclasses.replace(HostSettings.from_config(config), force_n=(0.002,),
                                   freq_points=3, transient_cycles=3, measured_cycles=6,
                                   sem_block_cycles=2, surrogate_draws=4)
    packing = np.loadtxt(DATA / "settled_11.csv", delimiter=",")
    packings = np.stack([packing, packing[::-1]])
    ceq = FakeSurrogate(constant(1e-3), constant(1e-4))
    m_eff = FakeSurrogate(lifting_bed(BED_KG), constant(0.02 * BED_KG))
    return host_check(settings, CellScene.from_config(config), LOAD, ceq, [], packings,
                      m_eff_surrogate=m_eff)


def test_the_check_writes_all_four_models(checked):
    curves, summary, meta = checked
    assert list(dict.fromkeys(curves.model)) == list(MODELS)
    assert len(curves) == 4 * 3 and list(summary.model) == list(MODELS)
    assert meta["equivalent_mass"]["included"] and meta["equivalent_mass"]["draws"] == 4
    mass = curves[curves.model == "equivalent_mass"]
    assert np.all(mass.amplitude_unc_m > 0) and np.all(mass.m_eff_unc_kg > 0)


def test_a_resting_bed_is_the_damper_with_the_beds_mass(checked):
    """Below 1 g the spheres ride on the floor: the coupled DEM measures m_eff = the bed's mass
    (as model (c)'s fake reads it), and model (c)'s host is the coupled host."""
    curves, _, _ = checked
    coupled = curves[curves.model == "coupled"].reset_index(drop=True)
    mass = curves[curves.model == "equivalent_mass"].reset_index(drop=True)
    assert np.all(coupled.accel_g < 0.6)
    assert np.all(np.abs(coupled.m_eff_kg / (LOAD.n_cells * BED_KG) - 1) < 0.05)
    assert mass.m_eff_kg.to_numpy() == pytest.approx(LOAD.n_cells * BED_KG, rel=1e-3)
    bare = curves[curves.model == "equivalent_bare_mass"].reset_index(drop=True)
    assert np.all(np.abs(bare.amplitude_m / coupled.amplitude_m - 1) > 0.2)   # the check bites
    assert np.all(np.abs(mass.amplitude_m / coupled.amplitude_m - 1) < 0.05)
