"""Wall motion: LIGGGHTS' viblin, z = W (cos wt - 1), starting at rest."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pidpipe.dem.walls import wall_motion


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
