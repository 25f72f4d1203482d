"""The host-coupled compiled loop (pidpipe.dem.coupled): the bare host against the analytic
single-degree-of-freedom response, and the energy balance of host and spheres per cycle."""

from __future__ import annotations

import numpy as np
import pytest

from pidpipe.dem.host_drive import HostDrive, effective_mass_and_damping, run_host
from tests.dem.conftest import spec_scene

FREQ_HZ = 300.0
MASS_KG = 0.02
NATURAL_HZ = 280.0


def _host(zeta: float, force_n: float, scale: float) -> HostDrive:
    stiffness = MASS_KG * (2 * np.pi * NATURAL_HZ) ** 2
    return HostDrive(MASS_KG, stiffness, 2 * zeta * np.sqrt(stiffness * MASS_KG), force_n, scale)


def _analytic(host: HostDrive, mass_kg: float, freq_hz: float) -> complex:
    """X of x = Re(X e^{i Omega t}) for m x'' + c x' + k x = F cos(Omega t)."""
    omega = 2 * np.pi * freq_hz
    return host.force_n / (host.stiffness_n_m - mass_kg * omega**2 + 1j * host.damping_ns_m * omega)


def test_the_bare_host_from_rest_settles_on_the_analytic_response():
    # zeta = 0.05: the free transient decays as exp(-2 pi zeta N) = 3e-6 of it after 40 cycles
    host = _host(0.05, 0.1, 0.0)
    out = run_host(spec_scene(freq_hz=FREQ_HZ, accel_g=0.0), None, host, 40)
    expected = _analytic(host, MASS_KG, FREQ_HZ)
    assert np.abs(out["displacement"][-1] / expected - 1) < 1e-3
    assert abs(out["peak_displacement_m"][-1] / abs(expected) - 1) < 1e-3
    assert out["particle_dissipation_j"].tolist() == [0.0] * 40


def test_the_bare_host_started_on_its_steady_state_stays_on_it_every_cycle():
    host = _host(0.01, 0.1, 0.0)
    expected = _analytic(host, MASS_KG, FREQ_HZ)
    omega = 2 * np.pi * FREQ_HZ
    out = run_host(spec_scene(freq_hz=FREQ_HZ, accel_g=0.0), None, host, 6,
                   expected.real, (1j * omega * expected).real)
    assert np.max(np.abs(out["displacement"] / expected - 1)) < 1e-3
    # the force's work per cycle is the damper's, pi c Omega |X|^2
    assert np.allclose(out["force_work_j"], np.pi * host.damping_ns_m * omega * abs(expected)**2,
                       rtol=1e-3)


def test_spheres_that_do_not_act_on_the_host_leave_it_analytic(settled_11):
    host = _host(0.01, 0.1, 0.0)
    expected = _analytic(host, MASS_KG, FREQ_HZ)
    omega = 2 * np.pi * FREQ_HZ
    out = run_host(spec_scene(freq_hz=FREQ_HZ, accel_g=0.0), settled_11[None], host, 3,
                   expected.real, (1j * omega * expected).real)
    assert np.max(np.abs(out["displacement"] / expected - 1)) < 1e-3
    assert np.all(out["particle_dissipation_j"] == 0.0)      # scaled by S = 0


@pytest.mark.parametrize("force_n", [0.05, 0.2])
def test_the_energy_balance_closes_every_cycle(settled_11, force_n):
    """W_F = D_h + S D_p + Delta(E_h + S E_p) per cycle: the host's ledger is exact, the
    spheres' carries the kernel's O(dt^2) error of the elastic contact energy
    (pidpipe.dem.energy), so the residual is small at the campaign's dt and falls as dt^2."""
    packings = np.stack([settled_11, settled_11[::-1]])
    largest = []
    for fraction in (0.2, 0.1):
        scene = spec_scene(freq_hz=FREQ_HZ, accel_g=0.0, timestep_rayleigh_fraction=fraction)
        out = run_host(scene, packings, _host(0.01, force_n, 10.0), 12)
        residual = np.abs(out["balance_residual_j"])
        # pidpipe.dem.case.BALANCE_TOLERANCE allows 1 % of the work exchanged with the walls
        flows = (np.abs(out["force_work_j"]) + out["host_damping_j"]
                 + out["particle_dissipation_j"])
        assert np.all(residual <= 0.005 * flows)
        assert np.all(residual <= 0.005 * out["gross_wall_work_j"])
        assert np.all(out["particle_dissipation_j"] > 0)
        # the spheres take part: they dissipate a tenth of what the host's damping does, or more
        assert out["particle_dissipation_j"][2:].sum() > 0.1 * out["host_damping_j"][2:].sum()
        largest.append(residual.max() / out["gross_wall_work_j"].mean())
    assert largest[1] < largest[0] / 3          # second order in dt (measured: a factor 4)


def test_spheres_that_never_leave_the_floor_ride_as_mass(settled_11):
    """Below 1 g the bed moves with the floor: its force on the host is its mass times the
    host's acceleration (m_eff = the spheres' mass, to the bed's small compliance)."""
    scene = spec_scene(freq_hz=FREQ_HZ, accel_g=0.0)
    host = _host(0.01, 0.004, 20.0)
    spheres = 20.0 * settled_11.shape[0] * scene.mass_kg
    omega = 2 * np.pi * FREQ_HZ
    start = _analytic(host, MASS_KG + spheres, FREQ_HZ)       # no transient to bias R / X
    out = run_host(scene, settled_11[None], host, 6, start.real, (1j * omega * start).real)
    accel_g = np.abs(out["displacement"]) * omega**2 / 9.81
    assert np.all(accel_g[2:] < 0.7)
    m_eff, _ = effective_mass_and_damping(out["displacement"], out["reaction"], omega)
    assert np.all(np.abs(m_eff[2:] / spheres - 1) < 0.02)


def test_a_host_started_in_motion_carries_its_bed_and_the_balance_closes_from_the_start(settled_11):
    """Started on the spheres-as-mass steady state, the packing starts on the moving floor
    (shifted and moving with it), so the first cycle's balance closes like the others."""
    scene = spec_scene(freq_hz=FREQ_HZ, accel_g=0.0)
    host = _host(0.01, 0.1, 10.0)
    omega = 2 * np.pi * FREQ_HZ
    start = _analytic(host, MASS_KG + 20 * settled_11.shape[0] * scene.mass_kg, FREQ_HZ)
    out = run_host(scene, np.stack([settled_11, settled_11[::-1]]), host, 4, start.real,
                   (1j * omega * start).real)
    assert np.all(np.abs(out["balance_residual_j"]) <= 0.005 * out["gross_wall_work_j"])
    assert abs(abs(out["displacement"][0]) / abs(start) - 1) < 0.1
