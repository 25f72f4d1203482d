"""The shake deck's first-harmonic sums in the real LIGGGHTS: a rigid rider's mass, the
force-based C_eq against the energy balance, the same numbers as the DEM's on a resting bed,
and the harmonics files read back."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from pidpipe.cases import CaseSpec
from pidpipe.config.settings import ShakeSettings
from pidpipe.dem.case import run_dem_case
from pidpipe.errors import ParseError
from pidpipe.liggghts.parsing import read_cos_sums
from pidpipe.liggghts.shake import run_case
from pidpipe.measurement.harmonics import sine_sums_from_wall_work
from pidpipe.physics.equivalent_damping import displacement_amplitude_m
from tests.conftest import short_config

RIDER = CaseSpec(100, 0.3, 50)


@pytest.mark.engine
def test_a_rigid_rider_has_the_mass_of_its_bed_in_both_engines(tmp_path, half_fill_packing):
    """The 50 % packing at 0.3 g, 100 Hz rides the wall: m_eff is the bed's mass within 1 %
    (measured 1.0055; 1.0011 at 50 Hz: the packing's contact springs, whose share falls with
    the frequency squared), and LIGGGHTS' mesh force and the DEM's walls give the same m_eff
    (the same packing: measured to 2e-6)."""
    settings = ShakeSettings.from_config(short_config(transient=3, measured=5))
    liggghts = run_case(settings, RIDER, half_fill_packing, tmp_path).harmonics
    dem = run_dem_case(settings, RIDER, half_fill_packing).harmonics
    assert liggghts["bed_mass_kg"] == pytest.approx(dem["bed_mass_kg"], rel=1e-12)
    assert liggghts["m_eff_ratio"] == pytest.approx(1.0, abs=0.01)
    assert dem["m_eff_ratio"] == pytest.approx(1.0, abs=0.01)
    assert liggghts["m_eff_cell_kg"] == pytest.approx(dem["m_eff_cell_kg"], rel=1e-4)
    # the part in phase with the velocity is the contacts' damping alone, as in the DEM
    assert liggghts["ceq_force_cell_ns_m"] == pytest.approx(dem["ceq_force_cell_ns_m"], rel=1e-3)


@pytest.mark.engine
def test_force_and_energy_c_eq_agree(tmp_path, half_fill_packing):
    """500 Hz, 5 g, 50 %, 40 measured cycles: the force-based C_eq (from S_s) and the energy
    balance's agree within their combined standard error."""
    settings = ShakeSettings.from_config(short_config(transient=3, measured=40))
    record = run_case(settings, CaseSpec(500, 5, 50), half_fill_packing, tmp_path)
    harmonics = record.harmonics
    combined = math.hypot(harmonics["ceq_force_cell_sem_ns_m"], record.ceq_cell_sem_ns_m)
    assert abs(harmonics["ceq_force_cell_ns_m"] - record.ceq_cell_ns_m) < combined
    assert abs(harmonics["ledger_z"]) < 1 and "ledger_force_energy" not in record.flags
    assert abs(harmonics["m_eff_ratio"]) < 0.5              # airborne most of the cycle
    # S_c is the cycle mean the deck wrote times the period; S_s the wall work over W omega
    # cos(omega dt / 2)
    written = np.loadtxt(tmp_path / "harmonics.txt", comments="#")
    np.testing.assert_allclose(harmonics["cos_sums_n_s"][0], written[:, 1] / 500.0, rtol=1e-15)
    amplitude, omega = record.displacement_amplitude_m, 2 * math.pi * 500.0
    np.testing.assert_allclose(np.array(harmonics["sin_sums_n_s"][0]) * amplitude * omega,
                               record.cycles["wall_work_j"], rtol=1e-5)


def _write(path, rows):
    path.write_text("# Time-averaged data\n# TimeStep v_a\n"
                    + "".join(" ".join(str(v) for v in row) + "\n" for row in rows))


def test_harmonics_files_are_read_for_one_cell_and_for_several(tmp_path):
    _write(tmp_path / "h.txt", [[10, 1.0], [20, 3.0]])
    _write(tmp_path / "c.txt", [[0, 0, 0], [10, 0.25, 0.75], [20, 1.0, 2.0]])
    np.testing.assert_array_equal(read_cos_sums(tmp_path / "h.txt", tmp_path / "no.txt", 0.5, 2, 1),
                                  [[0.5, 1.5]])
    np.testing.assert_array_equal(read_cos_sums(tmp_path / "no.txt", tmp_path / "c.txt", 0.5, 2, 2),
                                  [[0.125, 0.5], [0.375, 1.0]])
    with pytest.raises(ParseError, match="expected 3"):
        read_cos_sums(tmp_path / "h.txt", tmp_path / "no.txt", 0.5, 3, 1)
    with pytest.raises(ParseError, match="missing"):
        read_cos_sums(tmp_path / "h.txt", tmp_path / "no.txt", 0.5, 2, 2)


FIXTURE = Path(__file__).parents[1] / "fixtures" / "shake_500Hz_5g_harmonics"


def test_real_harmonics_files_are_read():
    """Real output: six cycles of S_c; the first of two cells side by side (from its spheres'
    forces) is the same packing shaken alone (from the mesh's force), to the 6 digits written."""
    period = 1.0 / 500.0
    one = read_cos_sums(FIXTURE / "harmonics.txt", FIXTURE / "absent.txt", period, 6, 1)
    two = read_cos_sums(FIXTURE / "absent.txt", FIXTURE / "two_cells_cell_harmonics.txt", period, 6, 2)
    assert one.shape == (1, 6) and two.shape == (2, 6)
    np.testing.assert_allclose(two[0], one[0], rtol=1e-5)
    assert not np.allclose(two[1], one[0], rtol=1e-2)
    # and S_s, from each one's wall power (the mesh's; the cell's)
    amplitude, omega = displacement_amplitude_m(500.0, 5.0), 2 * math.pi * 500.0
    timestep = period / 2223
    mesh = np.loadtxt(FIXTURE / "power.txt")[:, 1] * period
    cell = np.loadtxt(FIXTURE / "two_cells_cell_power.txt")[1:, 1] * period
    np.testing.assert_allclose(sine_sums_from_wall_work(cell, amplitude, omega, timestep),
                               sine_sums_from_wall_work(mesh, amplitude, omega, timestep), rtol=1e-5)
