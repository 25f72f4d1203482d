"""Wall motion: the DEM's z_w = W (cos wt - 1), starting at rest, and where LIGGGHTS' viblin puts its mesh."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pidpipe.dem import reference
from pidpipe.dem.walls import viblin_wall_motion, wall_motion, wall_step_velocity
from tests.dem.conftest import spec_scene


def test_the_base_motion_starts_at_rest_and_returns_after_a_period():
    amplitude = np.array([2e-6])
    omega = 2 * math.pi * 100.0
    z0, v0 = wall_motion(0.0, amplitude, omega)
    assert z0[0] == 0.0 and v0[0] == 0.0
    z_half, _ = wall_motion(0.005, amplitude, omega)
    assert z_half[0] == pytest.approx(-2 * 2e-6)
    z_end, v_end = wall_motion(0.01, amplitude, omega)
    assert z_end[0] == pytest.approx(0.0, abs=1e-18) and v_end[0] == pytest.approx(0.0, abs=1e-15)


def test_wall_velocity_is_the_derivative_of_its_position():
    amplitude, omega, t, h = np.array([3e-6]), 2 * math.pi * 750.0, 3.1e-4, 1e-9
    (zp,), _ = wall_motion(t + h, amplitude, omega)
    (zm,), _ = wall_motion(t - h, amplitude, omega)
    _, (v,) = wall_motion(t, amplitude, omega)
    assert (zp - zm) / (2 * h) == pytest.approx(v, rel=1e-6)


def test_step_velocity_is_the_walls_move_over_the_step_divided_by_dt():
    amplitude, omega, dt = np.array([2.5e-5]), 2 * math.pi * 100.0, 9e-7
    for step in (1, 2777, 5557, 11113):
        (z_now,), _ = wall_motion(step * dt, amplitude, omega)
        (z_before,), _ = wall_motion((step - 1) * dt, amplitude, omega)
        (mean_v,) = wall_step_velocity(step, dt, amplitude, omega)
        assert mean_v * dt == pytest.approx(z_now - z_before, rel=1e-6)
        # the end-of-step velocity the forces see runs half a step ahead of the mean, by
        # a_w dt / 2 (to within 0.1 % of the largest such lag, W omega^2 dt / 2)
        _, (v_end,) = wall_motion(step * dt, amplitude, omega)
        accel = -amplitude[0] * omega**2 * math.cos(omega * step * dt)
        largest_lag = amplitude[0] * omega**2 * dt / 2
        assert v_end - mean_v == pytest.approx(0.5 * accel * dt, rel=0, abs=1e-3 * largest_lag)


def test_viblin_walls_are_where_liggghts_moves_its_mesh():
    """LIGGGHTS' viblin moves the mesh by v_w(t_n) dt in step n: the closed form is that sum,
    half a step ahead of z_w(t_n), and its move over a step is v_w(t_n) dt."""
    amplitude, omega, steps = np.array([2.5e-7]), 2 * math.pi * 1000.0, 1112
    dt = 1e-3 / steps
    z_sum = 0.0
    for step in range(steps + 1):
        (z,), (v,) = viblin_wall_motion(step, dt, amplitude, omega)
        _, (v_exact,) = wall_motion(step * dt, amplitude, omega)
        assert v == pytest.approx(v_exact, rel=1e-13)
        if step:
            z_sum += v * dt
        assert z == pytest.approx(z_sum, rel=0, abs=1e-9 * amplitude[0])
        (z_ahead,), _ = wall_motion((step + 0.5) * dt, amplitude, omega)
        assert z - z_ahead == pytest.approx(0.0, abs=amplitude[0] * (omega * dt) ** 2 / 4)
    assert z == pytest.approx(0.0, abs=1e-9 * amplitude[0])


def test_an_unknown_wall_motion_is_refused():
    scene, state, ws = reference.start(spec_scene(), np.array([[0.0, 0.0, -0.0114]]))
    with pytest.raises(ValueError, match="walls must be one of exact, viblin"):
        reference.advance(scene, state, ws, 1, walls="sine")
