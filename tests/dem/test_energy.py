"""Energy: conservation without dissipation, and the two ledgers of E_d agreeing.

Measured: with e = 1 and mu = 0 (three spheres bouncing in the still cell under gravity,
1e5 steps at dt = 0.1 t_R) the mechanical energy above the resting state drifts by 3.8e-5 of
itself between impacts (1.6e-4 at dt = 0.2 t_R; within an impact the Verlet trajectory's own
O(dt^2) energy error reaches 1.6e-4). On the shaken cell (11 spheres, 500 Hz, 5 g) the
term-by-term dissipation and the energy balance agree to about 0.1 % per cycle.

The wall work counts the walls' actual displacement over each step. Counting v_w(t_n) dt
instead (half a step late) gave, with e = 1 and mu = 0 at 100 Hz / 1 g, E_d = +2.3e-11 J in
every cycle, the (dt/4) M a^2 T of a bed that moves with the cell; now |E_d| < 2.1e-13 J. With
friction at 100 Hz / 1 g the balance then exceeded the term-by-term ledger by 1.8e-11 J per cycle
(17 % of E_d for this packing); now they agree to 5e-5.
"""

from __future__ import annotations

import numpy as np
import pytest

from pidpipe.dem import advance, elastic_energy, run_cycles, start, total_energy
from pidpipe.physics import contact
from tests.dem.conftest import CELL, spec_scene


def _elastic_scene(**overrides):
    """The reference scene with e = 1 and no tangential force: nothing can dissipate."""
    return spec_scene(pp_restitution=1.0, pw_restitution=1.0, pp_friction=0.0,
                      pw_friction=0.0, friction=False, rotation=False, **overrides)


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


def test_every_elastic_cycle_closes_within_one_percent_of_the_work_exchanged(settled_11):
    """e = 1, mu = 0 at 500 Hz / 5 g: the spheres leave the floor and hit it and each other."""
    scene, state, ws = start(_elastic_scene(freq_hz=500.0, accel_g=5.0), settled_11)
    cycles = run_cycles(scene, state, ws, 6)
    exchanged = cycles["gross_work_j"][0]
    assert np.all(exchanged > 1e-9)                        # the walls do work every cycle
    assert np.all(np.abs(cycles["dissipated_balance_j"][0]) < 0.01 * exchanged.mean())
    assert not cycles["dissipated_terms_j"].any()


def test_elastic_bed_at_one_g_shows_no_half_step_bias(settled_11):
    """At 1 g the bed rides on the floor. The walls push it with F = M (g + a_w) and a wall
    work taken over v_w(t_n) dt instead of the actual move would add (dt/2) integral(F a_w dt)
    = (dt/4) M a^2 T per cycle; the balance must close far below that in every cycle."""
    scene, state, ws = start(_elastic_scene(freq_hz=100.0, accel_g=1.0), settled_11)
    cycles = run_cycles(scene, state, ws, 2)
    bed_mass = settled_11.shape[0] * scene.mass_kg
    accel = scene.accel_g[0] * contact.STANDARD_GRAVITY_M_S2
    half_step_bias = scene.timestep_s / 4 * bed_mass * accel**2 / scene.freq_hz
    dissipated = cycles["dissipated_balance_j"][0]
    assert np.all(np.abs(dissipated) < 0.01 * half_step_bias)
    assert np.all(np.abs(dissipated) < 0.01 * cycles["gross_work_j"][0].mean())


def test_both_ledgers_agree_cycle_by_cycle_at_one_g(settled_11):
    """100 Hz / 1 g with friction: micro-slip at the walls and between spheres is all that
    dissipates, and the spheres against the side walls move with them on friction."""
    scene, state, ws = start(spec_scene(freq_hz=100.0, accel_g=1.0), settled_11)
    cycles = run_cycles(scene, state, ws, 2)
    terms = cycles["dissipated_terms_j"][0]
    balance = cycles["dissipated_balance_j"][0]
    assert np.all(terms > 0)
    assert terms == pytest.approx(balance, rel=1e-3)
    assert cycles["friction_pw_j"][0].sum() > 0.05 * terms.sum()


def test_elastic_energy_is_the_sum_over_contacts_of_hertz_and_spring_energies(settled_11):
    """The bed resting at 1 g: sphere-sphere and sphere-wall contacts, friction on."""
    scene, state, ws = start(spec_scene(freq_hz=100.0, accel_g=1.0), settled_11)
    advance(scene, state, ws, 3000)                  # settled again after the first hop
    n, radius = state.n_spheres, scene.radius_m
    centres = state.x[:, 0].T
    expected = state.tangential_energy[0, :, n:].sum()
    for i in range(n):
        for j in range(i + 1, n):
            overlap = 2 * radius - np.linalg.norm(centres[i] - centres[j])
            expected += contact.hertz_normal_energy(scene.pp.youngs_eff_pa,
                                                    scene.pp.radius_eff_m, overlap)
            expected += state.tangential_energy[0, i, j]
    expected += contact.hertz_normal_energy(scene.pw.youngs_eff_pa, scene.pw.radius_eff_m,
                                            ws.delta[0, :, n:]).sum()
    assert ws.contact[0, :, :n].any() and ws.contact[0, :, n:].any()
    assert state.tangential_energy[0, :, :n].any() and state.tangential_energy[0, :, n:].any()
    assert elastic_energy(scene, state, ws)[0] == pytest.approx(expected, rel=1e-9)
