"""Single contacts against theory: impacts (restitution, Hertz duration) and Coulomb sliding.

Measured values (acrylic on aluminium, acrylic on acrylic, SPEC.md properties, 0.1 m/s):
restitution 0.6994 (wall) and 0.6992 (pair) for e = 0.70; elastic contact duration within
1 % of Hertz's 2.868 (m*^2 / (R* E*^2 v))^(1/5) at dt = t_R / 50.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from pidpipe.dem import advance, start
from pidpipe.physics import contact
from tests.dem.conftest import CELL, spec_scene

SPEED = 0.1                  # impact speed, m/s
FLOOR_COLUMN = 6             # the floor is plane 6 of HexCell.planes(); columns n + k


def _fine(scene, fraction=0.02):
    """The scene with dt = fraction x t_R (a test of the model, not of the timestep)."""
    return dataclasses.replace(scene, timestep_s=fraction * scene.rayleigh_time_s)


def _impact(scene, positions, velocities, column, n_steps):
    """Run an impact; return (final velocities (3, n), steps in contact)."""
    scene, state, ws = start(scene, positions, velocities_m_s=velocities)
    counted = [0]

    def count(_state, workspace):
        counted[0] += bool(workspace.contact[0, 0, column])

    advance(scene, state, ws, n_steps, count)
    return state.v[:, 0], counted[0]


def _wall_impact(scene):
    z0 = CELL.floor_z_m + scene.radius_m + 1e-6
    steps = int(round(3 * scene.rayleigh_time_s * 25 / scene.timestep_s)) + 50
    return _impact(scene, [[0.0, 0.0, z0]], [[0.0, 0.0, -SPEED]], 1 + FLOOR_COLUMN, steps)


def _pair_impact(scene):
    gap = scene.radius_m + 1e-6
    steps = int(round(3 * scene.rayleigh_time_s * 25 / scene.timestep_s)) + 50
    return _impact(scene, [[0.0, 0.0, -gap], [0.0, 0.0, gap]],
                   [[0.0, 0.0, SPEED / 2], [0.0, 0.0, -SPEED / 2]], 1, steps)


@pytest.mark.parametrize("restitution", [0.70, 0.85])
def test_sphere_wall_rebound_has_the_configured_restitution(restitution):
    scene = spec_scene(pw_restitution=restitution, accel_g=0.0, gravity_m_s2=0.0)
    velocity, _ = _wall_impact(scene)
    assert velocity[2] / SPEED == pytest.approx(restitution, rel=0.01)
    assert np.allclose(velocity[:2], 0.0)


@pytest.mark.parametrize("restitution", [0.70, 0.85])
def test_sphere_sphere_rebound_has_the_configured_restitution(restitution):
    scene = spec_scene(pp_restitution=restitution, accel_g=0.0, gravity_m_s2=0.0)
    velocity, _ = _pair_impact(scene)
    separation_speed = velocity[2, 1] - velocity[2, 0]
    assert separation_speed / SPEED == pytest.approx(restitution, rel=0.01)
    assert velocity[2].sum() == pytest.approx(0.0, abs=1e-12)         # momentum


def test_elastic_sphere_wall_contact_lasts_as_long_as_hertz_says():
    scene = _fine(spec_scene(pw_restitution=1.0, accel_g=0.0, gravity_m_s2=0.0))
    velocity, steps = _wall_impact(scene)
    law = scene.pw
    expected = contact.hertz_contact_duration(law.mass_eff_kg, law.radius_eff_m,
                                              law.youngs_eff_pa, SPEED)
    assert steps * scene.timestep_s == pytest.approx(expected, rel=0.02)
    assert velocity[2] == pytest.approx(SPEED, rel=1e-3)


def test_elastic_sphere_sphere_contact_lasts_as_long_as_hertz_says():
    scene = _fine(spec_scene(pp_restitution=1.0, accel_g=0.0, gravity_m_s2=0.0))
    _, steps = _pair_impact(scene)
    law = scene.pp
    expected = contact.hertz_contact_duration(law.mass_eff_kg, law.radius_eff_m,
                                              law.youngs_eff_pa, SPEED)
    assert steps * scene.timestep_s == pytest.approx(expected, rel=0.02)


def _sliding_start(scene):
    """A sphere resting on the floor at its static overlap, moving along +y."""
    static_overlap = (scene.mass_kg * scene.gravity_m_s2 / scene.pw.a_n) ** (2 / 3)
    z0 = CELL.floor_z_m + scene.radius_m - static_overlap
    return [[0.0, -0.9e-3, z0]]


def test_sliding_without_rotation_stops_after_the_coulomb_distance():
    """No rotation: a = -mu g until rest, so the sphere slides v0^2 / (2 mu g)."""
    v0, mu = 0.01, 0.14
    scene = spec_scene(accel_g=0.0, rotation=False, pw_friction=mu)
    start_pos = _sliding_start(scene)
    stop_time = v0 / (mu * scene.gravity_m_s2)
    scene, state, ws = start(scene, start_pos, velocities_m_s=[[0.0, v0, 0.0]])
    advance(scene, state, ws, int(1.15 * stop_time / scene.timestep_s))
    travelled = state.x[1, 0, 0] - start_pos[0][1]
    assert travelled == pytest.approx(v0**2 / (2 * mu * scene.gravity_m_s2), rel=0.01)
    assert abs(state.v[1, 0, 0]) < 1e-3 * v0


def test_sliding_with_rotation_ends_rolling_at_five_sevenths():
    """Rotation on, no spin at first: friction slows the sphere and spins it up until
    v = R omega, at t = 2 v0 / (7 mu g) with v = 5/7 v0; then it rolls without slip."""
    v0, mu = 0.01, 0.14
    scene = spec_scene(accel_g=0.0, rotation=True, pw_friction=mu)
    start_pos = _sliding_start(scene)
    scene, state, ws = start(scene, start_pos, velocities_m_s=[[0.0, v0, 0.0]])
    slide_time = 2 * v0 / (7 * mu * scene.gravity_m_s2)
    sliding_steps = [0]

    def count(_state, workspace):
        sliding_steps[0] += bool(workspace.slide[0, 0, 1 + FLOOR_COLUMN])

    advance(scene, state, ws, int(1.5 * slide_time / scene.timestep_s), count)
    speed = state.v[1, 0, 0]
    assert speed == pytest.approx(5 / 7 * v0, rel=0.01)
    assert -state.omega[0, 0, 0] * scene.radius_m == pytest.approx(speed, rel=0.01)  # no slip
    assert sliding_steps[0] * scene.timestep_s == pytest.approx(slide_time, rel=0.02)
