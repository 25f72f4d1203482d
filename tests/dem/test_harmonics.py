"""The compiled kernel's first-harmonic sums of the spheres' force on the walls: the sums of the
per-step force, a rigid rider's mass, and the force-based C_eq against the dissipation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pidpipe.cases import CaseSpec
from pidpipe.cell.packing import Packing
from pidpipe.config.settings import ShakeSettings
from pidpipe.dem import reference
from pidpipe.dem.case import run_dem_case
from pidpipe.dem.run import advance, run_cycles, start
from pidpipe.measurement.harmonics import effective_mass_kg, force_ceq_ns_m, harmonic_sums
from tests.conftest import short_config
from tests.dem.conftest import spec_scene


def test_kernel_sums_are_the_sums_of_the_per_step_force(settled_11):
    """Two cycles with impacts (1000 Hz, 10 g): the sums the kernel accumulates equal
    :func:`harmonic_sums` of the walls' force taken after every step (same trajectory)."""
    scene = spec_scene(freq_hz=1000.0, accel_g=10.0)
    cycles = 2
    sums = run_cycles(*start(scene, settled_11), cycles)
    forces = []
    scene, state, ws = start(scene, settled_11)
    advance(scene, state, ws, cycles * scene.steps_per_cycle,
            observer=lambda s, w: forces.append(-w.wall_force_z.copy()))
    cos_sums, sin_sums = harmonic_sums(np.array(forces).T, scene.steps_per_cycle,
                                       scene.timestep_s, scene.omega_rad_s)
    scale = np.abs(cos_sums).max()
    assert scale > 0
    np.testing.assert_allclose(sums["harmonic_cos_n_s"], cos_sums, rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(sums["harmonic_sin_n_s"], sin_sums, rtol=0, atol=1e-12 * scale)


def test_kernel_sums_equal_the_references(settled_11):
    """The NumPy reference sums the same force the same way (one cycle, two accelerations)."""
    scene = spec_scene(freq_hz=1000.0, accel_g=[10.0, 5.0])
    scene, ref_state, ref_ws = reference.start(scene, settled_11)
    mine = run_cycles(*start(scene, settled_11), 1)
    theirs = reference.run_cycles(scene, ref_state, ref_ws, 1)
    for key in ("harmonic_cos_n_s", "harmonic_sin_n_s"):
        scale = np.abs(theirs[key]).max()
        np.testing.assert_allclose(mine[key], theirs[key], rtol=0, atol=1e-11 * scale, err_msg=key)


def test_a_rigid_rider_has_the_mass_of_its_bed(settled_11):
    """11 settled spheres at 0.3 g, 100 Hz never leave the floor: the bed rides the wall, and
    m_eff is its mass (measured 1.0017: the packing's contacts are springs, so the bed is a
    little more than rigid below their resonance); nothing is in phase with the velocity
    beyond the contacts' own damping."""
    scene = spec_scene(freq_hz=100.0, accel_g=0.3)
    scene, state, ws = start(scene, settled_11)
    sums = run_cycles(scene, state, ws, 4)
    amplitude = float(np.atleast_1d(scene.amplitude_m)[0])
    mass = effective_mass_kg(sums["harmonic_cos_n_s"][0, 1:], amplitude, scene.omega_rad_s)
    bed = state.n_spheres * scene.mass_kg
    np.testing.assert_allclose(mass / bed, 1.0, rtol=0.01)
    damping = force_ceq_ns_m(sums["harmonic_sin_n_s"][0, 1:], amplitude)
    assert np.all(np.abs(damping) < 0.01 * bed * scene.omega_rad_s)


def _packing(positions: np.ndarray) -> Packing:
    radius = 1.25e-3
    return Packing(positions_m=positions.tolist(), radius_m=radius, n_spheres=len(positions),
                   seed=0, pile_height_m=float(positions[:, 2].max() + radius + 12.7e-3),
                   lid_height_m=25.4e-3, max_speed_m_s=0.0, settle_time_s=0.15, fill_pct=50.0,
                   pour_engine="dem")


@pytest.mark.parametrize("case", [CaseSpec(500, 5, 50), CaseSpec(1000, 10, 50)])
def test_force_and_energy_c_eq_agree_in_a_case_record(settled_11, case):
    """The record's force-based C_eq (from S_s) agrees with its C_eq from the contacts'
    dissipation within their combined standard error (40 measured cycles)."""
    settings = ShakeSettings.from_config(short_config(transient=3, measured=40))
    record = run_dem_case(settings, case, _packing(settled_11))
    harmonics = record.harmonics
    assert harmonics["ceq_energy_cell_ns_m"] == record.ceq_cell_ns_m
    combined = math.hypot(harmonics["ceq_force_cell_sem_ns_m"], record.ceq_cell_sem_ns_m)
    assert abs(harmonics["ceq_force_cell_ns_m"] - record.ceq_cell_ns_m) < combined
    assert abs(harmonics["ledger_z"]) < 1 and "ledger_force_energy" not in record.flags
    # airborne most of the cycle at 5-10 g: far from the resting bed's 1 (measured -0.01 at
    # 1000 Hz, 10 g: the impacts can even push in phase with the wall's acceleration)
    assert abs(harmonics["m_eff_ratio"]) < 0.5
    assert harmonics["m_eff_ratio"] == pytest.approx(harmonics["m_eff_cell_kg"]
                                                     / harmonics["bed_mass_kg"])
