"""First-harmonic sums of the spheres' force: known forces give back their amplitude and phase,
a rigid rider its mass, a dashpot its coefficient; the ledger check flags a disagreement."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pidpipe.measurement.case_record import CaseRecord
from pidpipe.measurement.cells import mean_of_cells
from pidpipe.measurement.harmonics import (
    LEDGER_FLAG,
    combine_harmonics,
    effective_mass_kg,
    force_ceq_ns_m,
    harmonic_sums,
    harmonics_record,
    ledger_check,
    mean_cell,
    sine_sums_from_wall_work,
    step_phases,
)
from pidpipe.measurement.statistics import standard_error
from pidpipe.physics.equivalent_damping import displacement_amplitude_m

FREQ_HZ, STEPS = 500.0, 2223
OMEGA = 2.0 * math.pi * FREQ_HZ
DT = 1.0 / FREQ_HZ / STEPS


@pytest.mark.parametrize("first_step", [0, 3 * STEPS])
@pytest.mark.parametrize("amplitude, phase", [(2.5e-3, 0.3), (1e-6, -2.0), (7.0, 3.0)])
def test_sums_return_a_known_amplitude_and_phase(amplitude, phase, first_step):
    """F = A cos(theta - phi) + weight + a second harmonic: S_c = A cos(phi) T / 2 and
    S_s = A sin(phi) T / 2 in every cycle, to 1e-9; the weight and the second harmonic drop out."""
    n_cycles = 3
    theta = step_phases(first_step, n_cycles * STEPS, DT, OMEGA)
    force = amplitude * np.cos(theta - phase) - 1.0e-3 + 0.5 * amplitude * np.sin(2 * theta + 1.0)
    cos_sums, sin_sums = harmonic_sums(force, STEPS, DT, OMEGA, first_step)
    period = 1.0 / FREQ_HZ
    assert cos_sums.shape == sin_sums.shape == (n_cycles,)
    scale = amplitude * period / 2
    np.testing.assert_allclose(cos_sums, amplitude * math.cos(phase) * period / 2, rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(sin_sums, amplitude * math.sin(phase) * period / 2, rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(np.hypot(cos_sums, sin_sums), scale, rtol=1e-9)
    np.testing.assert_allclose(np.arctan2(sin_sums, cos_sums), math.remainder(phase, 2 * math.pi),
                               rtol=0, atol=1e-9)


def test_phases_are_the_walls_at_the_half_step():
    """The weights sit at omega (n + 1/2) dt for steps n = first + 1 ..."""
    np.testing.assert_allclose(step_phases(10, 3, 0.1, 2.0), 2.0 * 0.1 * np.array([11.5, 12.5, 13.5]))


def test_a_rigid_rider_gives_its_mass_and_a_dashpot_its_coefficient():
    """F on the walls = -m a_w - m g for a mass riding the wall; -c v_w for a dashpot."""
    accel_g, mass, damping = 5.0, 1.8e-4, 0.12
    amplitude = displacement_amplitude_m(FREQ_HZ, accel_g)
    theta = step_phases(0, 4 * STEPS, DT, OMEGA)
    wall_acceleration = -amplitude * OMEGA**2 * np.cos(theta)
    wall_velocity = -amplitude * OMEGA * np.sin(theta)
    rider = -mass * wall_acceleration - mass * 9.81
    cos_sums, sin_sums = harmonic_sums(rider, STEPS, DT, OMEGA)
    np.testing.assert_allclose(effective_mass_kg(cos_sums, amplitude, OMEGA), mass, rtol=1e-9)
    np.testing.assert_allclose(force_ceq_ns_m(sin_sums, amplitude), 0.0, atol=1e-9 * damping)
    cos_sums, sin_sums = harmonic_sums(-damping * wall_velocity, STEPS, DT, OMEGA)
    np.testing.assert_allclose(force_ceq_ns_m(sin_sums, amplitude), damping, rtol=1e-9)
    np.testing.assert_allclose(effective_mass_kg(cos_sums, amplitude, OMEGA), 0.0, atol=1e-9 * mass)


def test_the_wall_work_is_w_omega_times_the_sine_sum():
    """So the force-based C_eq is the wall work's C_eq: dt sum F_n v_w(n + 1/2) = -W omega S_s."""
    amplitude = displacement_amplitude_m(FREQ_HZ, 5.0)
    rng = np.random.default_rng(1)
    force = rng.normal(size=STEPS)
    theta = step_phases(0, STEPS, DT, OMEGA)
    work_on_spheres = -np.sum(force * (-amplitude * OMEGA * np.sin(theta))) * DT
    _, sin_sums = harmonic_sums(force, STEPS, DT, OMEGA)
    assert work_on_spheres == pytest.approx(amplitude * OMEGA * sin_sums[0], rel=1e-12)


def test_a_static_wall_has_no_harmonics():
    with pytest.raises(ValueError, match="moving wall"):
        effective_mass_kg(np.ones(2), 0.0, OMEGA)
    with pytest.raises(ValueError, match="moving wall"):
        force_ceq_ns_m(np.ones(2), -1.0)


def test_mean_cell_is_the_two_level_estimate_of_c_eq():
    rng = np.random.default_rng(7)
    series = rng.normal(1.0, 0.1, size=(3, 30)) + np.array([[0.0], [0.05], [-0.05]])
    estimate, cells = mean_cell(series, 4, 2)
    own = [standard_error(row[4:], 2) for row in series]
    assert cells == own
    assert estimate == mean_of_cells(np.array([c[0] for c in own]), np.array([c[1] for c in own]))
    single, _ = mean_cell(series[0], 4, 2)
    assert (single.mean, single.sem) == own[0]


def test_ledger_check():
    assert ledger_check(1.0, 0.1, 1.2, 0.1) == (pytest.approx(-0.2 / math.hypot(0.1, 0.1)), True)
    z, agree = ledger_check(1.0, 0.01, 1.2, 0.01)
    assert z == pytest.approx(-0.2 / math.hypot(0.01, 0.01)) and not agree
    assert ledger_check(1.0, 0.0, 1.0, 0.0) == (0.0, True)
    z, agree = ledger_check(1.0, float("nan"), 2.0, 0.1)
    assert math.isnan(z) and agree


def _record(offset_ns_m: float, energy_sem: float = 0.01) -> dict:
    """Two cells of a dashpot 0.1 N s/m and a mass 1e-4 kg, with cycle noise; the energy-based
    C_eq given as 0.1 + offset."""
    accel_g, n_cycles = 5.0, 40
    amplitude = displacement_amplitude_m(FREQ_HZ, accel_g)
    rng = np.random.default_rng(3)
    half_period = 0.5 / FREQ_HZ
    cos_sums = 1e-4 * amplitude * OMEGA**2 * half_period * (1 + 0.05 * rng.normal(size=(2, n_cycles)))
    sin_sums = 0.1 * amplitude * OMEGA * half_period * (1 + 0.05 * rng.normal(size=(2, n_cycles)))
    energy = np.linspace(0.0, 1e-9, n_cycles + 1)
    return harmonics_record(cos_sums, sin_sums, 5, FREQ_HZ, accel_g, 2e-4, 2, 0.1 + offset_ns_m,
                            energy_sem, energy_j=energy)


def test_record_of_two_cells():
    record = _record(0.0)
    assert record["m_eff_cell_kg"] == pytest.approx(1e-4, rel=0.03)
    assert record["m_eff_ratio"] == pytest.approx(0.5, rel=0.03)
    assert record["m_eff_ratio_sem"] == pytest.approx(record["m_eff_cell_sem_kg"] / 2e-4)
    assert 0 < record["m_eff_cell_sem_kg"] < 0.03 * 1e-4
    assert record["ceq_force_cell_ns_m"] == pytest.approx(0.1, rel=0.03)
    assert len(record["cells"]) == 2 and len(record["cos_sums_n_s"][0]) == 40
    assert record["flags"] == [] and record["ledger_reason"] is None


def test_record_flags_a_force_energy_disagreement_with_its_reason():
    record = _record(0.05, energy_sem=0.001)
    assert record["flags"] == [LEDGER_FLAG]
    assert record["ledger_z"] < -3
    assert "combined SEM" in record["ledger_reason"] and "energy changed by" in record["ledger_reason"]


def test_runs_combine_over_all_their_cells_each_after_its_own_transient():
    """Cells of two runs (the allocation's more cells): one estimate over the three cells, each
    measured after its own run's transient; the same as the cells given together."""
    rng = np.random.default_rng(11)
    amplitude = displacement_amplitude_m(FREQ_HZ, 5.0)
    first = (rng.normal(1e-9, 1e-10, size=(2, 30)), rng.normal(1e-8, 1e-9, size=(2, 30)))
    second = (rng.normal(1e-9, 1e-10, size=(1, 50)), rng.normal(1e-8, 1e-9, size=(1, 50)))
    records = []
    for (cos_sums, sin_sums), transient in ((first, 4), (second, 9)):
        harmonics = harmonics_record(cos_sums, sin_sums, transient, FREQ_HZ, 5.0, 2e-4, 2, 1.0, 0.1)
        records.append(CaseRecord(solver="numba-dem", case_id="f500Hz_G5_r50pct_rep0",
                                  freq_hz=FREQ_HZ, accel_g=5.0, fill_pct=50.0, status="ok",
                                  fidelity={"transient_cycles": transient, "sem_block_cycles": 2},
                                  harmonics=harmonics))
    combined = combine_harmonics(records, 2e-3, 1e-4)
    assert len(combined["cells"]) == 3 and len(combined["cos_sums_n_s"][2]) == 50
    together = harmonics_record([*first[0], *second[0]], [*first[1], *second[1]], [4, 4, 9],
                                FREQ_HZ, 5.0, 2e-4, 2, 2e-3, 1e-4)
    assert combined == together
    # each cell's mean over its whole blocks of 2 measured cycles (26, 26 and 40 of 41)
    masses = [effective_mass_kg(c[t:t + 2 * ((c.size - t) // 2)], amplitude, OMEGA).mean()
              for c, t in ((first[0][0], 4), (first[0][1], 4), (second[0][0], 9))]
    assert combined["m_eff_cell_kg"] == pytest.approx(np.mean(masses), rel=1e-12)


def test_the_decks_wall_work_gives_the_sine_sums():
    """LIGGGHTS' wall power uses (sin(omega t_n) + sin(omega t_n+1)) / 2: its work over a cycle
    divided by W omega cos(omega dt / 2) is S_s, to rounding."""
    amplitude = displacement_amplitude_m(FREQ_HZ, 5.0)
    force = np.random.default_rng(5).normal(size=2 * STEPS)
    steps = np.arange(1, 2 * STEPS + 1)
    velocity = -amplitude * OMEGA * 0.5 * (np.sin(OMEGA * steps * DT) + np.sin(OMEGA * (steps + 1) * DT))
    work = (-force * velocity * DT).reshape(2, STEPS).sum(axis=1)
    _, sin_sums = harmonic_sums(force, STEPS, DT, OMEGA)
    np.testing.assert_allclose(sine_sums_from_wall_work(work, amplitude, OMEGA, DT), sin_sums,
                               rtol=1e-10)
