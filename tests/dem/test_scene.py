"""Scene set-up: timestep rule, contact coefficients against pidpipe.physics.contact, softening."""

from __future__ import annotations

import math

import pytest

from pidpipe.dem import choose_timestep
from pidpipe.physics import contact
from tests.dem.conftest import ACRYLIC, spec_scene


def test_timestep_is_a_whole_fraction_of_the_cycle_and_below_the_target():
    dt, steps = choose_timestep(500.0, 4.5e-6, 0.2)
    assert steps * dt == pytest.approx(1.0 / 500.0, rel=1e-14)
    assert dt <= 0.2 * 4.5e-6
    assert (steps - 1) * 0.2 * 4.5e-6 < 1.0 / 500.0        # the largest such dt


def test_contact_coefficients_reproduce_the_liggghts_expressions():
    scene = spec_scene()
    law = scene.pw
    delta = 3e-7
    gamma = contact.normal_damping_gamma(0.7, law.youngs_eff_pa, law.radius_eff_m,
                                         law.mass_eff_kg, delta)
    assert law.g_n * delta**0.25 == pytest.approx(gamma, rel=1e-12)
    assert law.a_n * math.sqrt(delta) == pytest.approx(
        4 / 3 * law.youngs_eff_pa * math.sqrt(law.radius_eff_m * delta), rel=1e-12)
    assert law.a_t * math.sqrt(delta) == pytest.approx(
        8 * law.shear_eff_pa * math.sqrt(law.radius_eff_m * delta), rel=1e-12)
    assert law.radius_eff_m == ACRYLIC.radius_m                 # wall: R* = R, m* = m
    assert law.mass_eff_kg == pytest.approx(scene.mass_kg)
    assert scene.pp.radius_eff_m == pytest.approx(ACRYLIC.radius_m / 2)
    assert scene.pp.mass_eff_kg == pytest.approx(scene.mass_kg / 2)


def test_softening_scales_every_modulus_and_lengthens_the_timestep():
    stiff, soft = spec_scene(), spec_scene(youngs_modulus_scale=0.01)
    assert soft.pw.youngs_eff_pa == pytest.approx(0.01 * stiff.pw.youngs_eff_pa)
    assert soft.rayleigh_time_s == pytest.approx(10.0 * stiff.rayleigh_time_s)
    assert soft.timestep_s > 9.0 * stiff.timestep_s


def test_wall_amplitude_is_g_over_omega_squared():
    scene = spec_scene(accel_g=[1.0, 5.0])
    omega = 2 * math.pi * 500.0
    assert scene.amplitude_m.tolist() == pytest.approx([9.81 / omega**2, 5 * 9.81 / omega**2])
