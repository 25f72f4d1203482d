"""Energy: conservation without dissipation, and the two ledgers of E_d agreeing.

Measured: with e = 1 and mu = 0 (three spheres bouncing in the still cell under gravity,
1e5 steps at dt = 0.1 t_R) the mechanical energy above the resting state drifts by 3.8e-5 of
itself between impacts (1.6e-4 at dt = 0.2 t_R; within an impact the Verlet trajectory's own
O(dt^2) energy error reaches 1.6e-4). On the shaken cell (11 spheres, 500 Hz, 5 g) the
term-by-term dissipation and the energy balance agree to about 0.1 % per cycle.
"""

from __future__ import annotations

import numpy as np
import pytest

from pidpipe.dem import advance, run_cycles, start, total_energy
from tests.dem.conftest import CELL, spec_scene


def test_energy_is_conserved_without_damping_or_friction():
    scene = spec_scene(accel_g=0.0, pp_restitution=1.0, pw_restitution=1.0, pp_friction=0.0,
                       pw_friction=0.0, friction=False, rotation=False,
                       timestep_rayleigh_fraction=0.1)
    radius, floor = scene.radius_m, CELL.floor_z_m
    positions = [[0.3e-3, 0.0, floor + radius + 2e-3], [-0.5e-3, 0.2e-3, floor + radius + 5e-3],
                 [0.0, -0.4e-3, floor + radius + 8e-3]]
    velocities = [[0.05, 0.02, 0.0], [-0.03, 0.04, 0.0], [0.01, -0.05, 0.0]]
    scene, state, ws = start(scene, positions, velocities_m_s=velocities)
    at_rest = 3 * scene.mass_kg * scene.gravity_m_s2 * (floor + radius)
    e0 = total_energy(scene, state, ws)[0]
    drift, contacts_seen = [], [0]

    def sample(st, workspace):
        if st.step % 50 == 0:
            if workspace.contact.any():
                contacts_seen[0] += 1
            else:
                drift.append(total_energy(scene, st, workspace)[0] - e0)

    advance(scene, state, ws, 100_000, sample)
    relative = np.abs(np.array(drift)) / (e0 - at_rest)
    assert contacts_seen[0] > 0 and len(drift) > 1000        # it did bounce
    assert relative.max() < 1e-4


def test_term_by_term_dissipation_matches_the_energy_balance(settled_11):
    scene, state, ws = start(spec_scene(freq_hz=500.0, accel_g=5.0), settled_11)
    cycles = run_cycles(scene, state, ws, 4)
    terms = cycles["dissipated_terms_j"][0, 1:]
    balance = cycles["dissipated_balance_j"][0, 1:]
    assert np.all(balance > 0)
    assert terms.sum() == pytest.approx(balance.sum(), rel=0.005)
    assert terms == pytest.approx(balance, rel=0.005)
    # the split adds up, and normal damping and friction both matter in this case
    parts = sum(cycles[key][0, 1:] for key in cycles
                if key.endswith(("_pp_j", "_pw_j")))
    assert parts == pytest.approx(terms, rel=1e-12)
    assert cycles["normal_damping_pw_j"][0, 1:].sum() > 0.1 * terms.sum()
    assert cycles["friction_pp_j"][0, 1:].sum() > 0.05 * terms.sum()


def test_friction_off_leaves_only_normal_damping(settled_11):
    scene = spec_scene(freq_hz=1000.0, accel_g=10.0, friction=False, rotation=False)
    scene, state, ws = start(scene, settled_11)
    cycles = run_cycles(scene, state, ws, 2)
    for key in ("friction", "tangential_damping", "tangential_spring"):
        assert not cycles[f"{key}_pp_j"].any() and not cycles[f"{key}_pw_j"].any()
    assert cycles["dissipated_terms_j"][0, 1] == pytest.approx(
        cycles["dissipated_balance_j"][0, 1], rel=0.005)
