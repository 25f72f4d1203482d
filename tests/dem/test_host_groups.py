"""Cells in groups along a mode shape on the host-coupled compiled loop (run_host_groups): one
group at weight 1 is the single host, weights 0 leave the bare host, a resting bed adds
sum n_g phi_g^2 of its mass, and the energy balance closes with the weights."""

from __future__ import annotations

import numpy as np

from pidpipe.dem.host_drive import CellGroups, effective_mass_and_damping, run_host, run_host_groups
from tests.dem.conftest import spec_scene
from tests.dem.test_coupled import FREQ_HZ, MASS_KG, _analytic, _host


def test_one_group_at_weight_one_is_the_single_host_operation_for_operation(settled_11):
    scene = spec_scene(freq_hz=FREQ_HZ, accel_g=0.0)
    packings = np.stack([settled_11, settled_11[::-1]])
    host = _host(0.01, 0.1, 10.0)
    start = (1e-6, 0.0)
    single = run_host(scene, packings, host, 2, *start)
    grouped = run_host_groups(scene, packings, CellGroups((0, 0), (1.0,), (20.0,)), host, 2, *start)
    for key in ("displacement", "reaction", "force_work_j", "host_damping_j", "wall_work_j",
                "gross_wall_work_j", "host_energy_j", "cell_wall_force"):
        assert np.array_equal(single[key], grouped[key]), key
    for key in ("particle_dissipation_j", "particle_energy_j", "balance_residual_j"):
        assert np.allclose(single[key], grouped[key], rtol=1e-12, atol=1e-18), key
    assert np.allclose(grouped["group_wall_force"][0], single["cell_wall_force"].mean(axis=0))


def test_cells_at_the_modes_nodes_leave_the_bare_host_and_its_structural_loss_factor(settled_11):
    scene = spec_scene(freq_hz=FREQ_HZ, accel_g=0.0)
    host = _host(0.01, 0.1, 0.0)
    expected = _analytic(host, MASS_KG, FREQ_HZ)
    omega = 2 * np.pi * FREQ_HZ
    groups = CellGroups((0, 1), (0.0, 0.0), (200.0, 300.0))
    out = run_host_groups(scene, np.stack([settled_11, settled_11[::-1]]), groups, host, 3,
                          expected.real, (1j * omega * expected).real)
    assert np.max(np.abs(out["displacement"] / expected - 1)) < 1e-3
    assert np.all(out["reaction"] == 0)
    eta = (out["host_damping_j"] + out["particle_dissipation_j"]) / (
        np.pi * host.stiffness_n_m * np.abs(out["displacement"]) ** 2)
    assert np.allclose(eta, host.damping_ns_m * omega / host.stiffness_n_m, rtol=2e-3)


def test_a_resting_bed_adds_its_mass_times_the_sum_of_n_phi_squared(settled_11):
    """Below 1 g at every cell the beds ride on their floors: the mode sees the mass
    sum_g n_g phi_g^2 m_bed (the projection the panel's modal mass makes)."""
    scene = spec_scene(freq_hz=FREQ_HZ, accel_g=0.0)
    host = _host(0.01, 0.004, 0.0)
    bed = settled_11.shape[0] * scene.mass_kg
    weights, cells = (1.0, 0.5), (10.0, 40.0)
    projected = bed * sum(n * w**2 for n, w in zip(cells, weights))     # 20 beds at weight 1
    omega = 2 * np.pi * FREQ_HZ
    start = _analytic(host, MASS_KG + projected, FREQ_HZ)
    out = run_host_groups(scene, np.stack([settled_11, settled_11[::-1]]),
                          CellGroups((0, 1), weights, cells), host, 4, start.real,
                          (1j * omega * start).real)
    assert np.all(np.abs(out["displacement"]) * omega**2 / 9.81 < 0.7)
    m_eff, _ = effective_mass_and_damping(out["displacement"], out["reaction"], omega)
    assert np.all(np.abs(m_eff[1:] / projected - 1) < 0.02)
    # the whole mass of the 50 beds would be 2.5 times more
    assert np.all(m_eff[1:] < 0.5 * bed * sum(cells))


def test_the_energy_balance_closes_every_cycle_with_weighted_groups(settled_11):
    scene = spec_scene(freq_hz=FREQ_HZ, accel_g=0.0)
    host = _host(0.01, 0.2, 0.0)
    out = run_host_groups(scene, np.stack([settled_11, settled_11[::-1]]),
                          CellGroups((0, 1), (1.0, 0.6), (10.0, 15.0)), host, 5)
    flows = np.abs(out["force_work_j"]) + out["host_damping_j"] + out["particle_dissipation_j"]
    assert np.all(np.abs(out["balance_residual_j"]) <= 0.005 * flows)
    assert np.all(np.abs(out["balance_residual_j"]) <= 0.005 * out["gross_wall_work_j"])
    # the spheres take part (they fly: Gamma at the antinode of several g)
    assert np.abs(out["displacement"][-1]) * (2 * np.pi * FREQ_HZ) ** 2 / 9.81 > 2.0
    assert out["particle_dissipation_j"][1:].sum() > 0.1 * out["host_damping_j"][1:].sum()
