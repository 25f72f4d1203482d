"""The first-harmonic columns of the C_eq table: effective mass and force-based C_eq per grid point."""

import math

import numpy as np
import pytest

from pidpipe.design.ceq_table import M_EFF_COLUMN, M_EFF_SEM_COLUMN, read_ceq_table
from pidpipe.design.records import TABLE_COLUMNS, combine_replicates, records_to_table
from pidpipe.measurement.harmonics import harmonics_record
from pidpipe.physics.equivalent_damping import displacement_amplitude_m
from tests.steps.test_steps import record

HARMONIC_COLUMNS = ("m_eff_cell_kg", "m_eff_cell_sem_kg", "m_eff_ratio", "m_eff_ratio_sem",
                    "bed_mass_kg", "ceq_force_cell_ns_m", "ceq_force_cell_sem_ns_m")


def harmonics(m_eff, m_sem, bed=2e-4, c=0.05, c_sem=0.005):
    return {"m_eff_cell_kg": m_eff, "m_eff_cell_sem_kg": m_sem, "m_eff_ratio": m_eff / bed,
            "m_eff_ratio_sem": m_sem / bed, "bed_mass_kg": bed, "ceq_force_cell_ns_m": c,
            "ceq_force_cell_sem_ns_m": c_sem, "flags": []}


def test_table_has_the_harmonic_columns():
    assert set(HARMONIC_COLUMNS) <= set(TABLE_COLUMNS)


def test_replicates_harmonics_are_combined_like_ceq():
    rows = records_to_table([
        record(replicate=0).with_(harmonics=harmonics(1.0e-4, 3e-6, bed=2.0e-4, c=0.04)),
        record(replicate=1).with_(harmonics=harmonics(1.2e-4, 4e-6, bed=2.4e-4, c=0.06)),
    ])
    row = rows.iloc[0]
    mean, sem = combine_replicates([1.0e-4, 1.2e-4], [3e-6, 4e-6])
    assert row["m_eff_cell_kg"] == pytest.approx(mean)
    assert row["m_eff_cell_sem_kg"] == pytest.approx(sem)
    # the scatter between the two packings (1e-5) is larger than the runs' (2.5e-6)
    assert sem == pytest.approx(np.std([1.0e-4, 1.2e-4], ddof=1) / math.sqrt(2))
    # each replicate over its own bed mass: 0.5 both
    assert row["m_eff_ratio"] == pytest.approx(0.5)
    assert row["bed_mass_kg"] == pytest.approx(2.2e-4)
    assert row["ceq_force_cell_ns_m"] == pytest.approx(0.05)
    assert row["ceq_force_cell_sem_ns_m"] == pytest.approx(np.std([0.04, 0.06], ddof=1) / math.sqrt(2))


def test_records_without_harmonics_give_nan_and_are_left_out_of_the_mean():
    rows = records_to_table([
        record(accel=5.0),                                                  # an old record
        record(accel=10.0, replicate=0).with_(harmonics=harmonics(1.0e-4, 3e-6)),
        record(accel=10.0, replicate=1),                                    # old, same point
    ])
    old, mixed = rows.iloc[0], rows.iloc[1]
    assert all(math.isnan(old[c]) for c in HARMONIC_COLUMNS)
    assert mixed["n_replicates"] == 2
    assert mixed["m_eff_cell_kg"] == pytest.approx(1.0e-4)
    assert mixed["m_eff_cell_sem_kg"] == pytest.approx(3e-6)


def test_failed_replicates_harmonics_are_not_averaged():
    rows = records_to_table([
        record(replicate=0).with_(harmonics=harmonics(1.0e-4, 3e-6)),
        record(replicate=1, status="failed", ceq=float("nan"), sem=float("nan")).with_(
            harmonics=harmonics(9.0, 1.0)),
    ])
    assert rows.iloc[0]["m_eff_cell_kg"] == pytest.approx(1.0e-4)


def test_rigid_rider_gives_a_ratio_of_one_in_the_table():
    """A bed riding the wall (force = -m a_w - m g every step) reads m_eff = m in the table."""
    freq, accel, mass = 100.0, 0.5, 2.0e-4
    omega, steps, cycles = 2 * math.pi * freq, 1000, 12
    dt = 1.0 / (freq * steps)
    w = displacement_amplitude_m(freq, accel)
    theta = omega * (np.arange(1, steps * cycles + 1) + 0.5) * dt
    # the discrete wall's acceleration (harmonics.py: m_eff = m sin(x) / x, x = omega dt / 2)
    force = mass * w * omega**2 * np.cos(theta) - mass * 9.81
    from pidpipe.measurement.harmonics import harmonic_sums
    cos_sums, sin_sums = harmonic_sums(force[None, :], steps, dt, omega)
    block = harmonics_record(cos_sums, sin_sums, 2, freq, accel, mass, 2, 0.0, 1e-9)
    row = records_to_table([record(accel=accel).with_(harmonics=block)]).iloc[0]
    assert row["m_eff_ratio"] == pytest.approx(1.0, abs=1e-5)
    assert row["m_eff_cell_kg"] == pytest.approx(mass, rel=1e-5)
    assert abs(row["ceq_force_cell_ns_m"]) < 1e-9


def test_table_with_harmonic_columns_reads_back_as_numbers(tmp_path):
    """An airborne bed's m_eff may be slightly negative: the validation accepts it; empty cells
    (old records) read as NaN."""
    rows = records_to_table([
        record(accel=5.0).with_(harmonics=harmonics(-2e-6, 3e-6)),
        record(accel=10.0),
    ])
    path = tmp_path / "ceq_table.csv"
    rows.to_csv(path, index=False)
    table = read_ceq_table(path)
    assert table[M_EFF_COLUMN].dtype == np.float64 and table[M_EFF_SEM_COLUMN].dtype == np.float64
    assert table[M_EFF_COLUMN].iloc[0] == pytest.approx(-2e-6)
    assert math.isnan(table[M_EFF_COLUMN].iloc[1])
    assert table["ceq_force_cell_sem_ns_m"].dtype == np.float64
