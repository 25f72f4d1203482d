"""The coupled sweep's reduction of one run (pidpipe.loop.coupled_sweep.run_point)."""

from __future__ import annotations

import numpy as np

from pidpipe.cell.scene import CellScene
from pidpipe.config import load_config
from pidpipe.dem.host_drive import HostDrive
from pidpipe.loop.coupled_sweep import SweepPoint, run_point
from pidpipe.loop.sdof import complex_amplitude
from tests.dem.conftest import DATA

MASS = 0.022
STIFFNESS = MASS * (2 * np.pi * 275.0) ** 2
DAMPING = 2 * 0.01 * np.sqrt(STIFFNESS * MASS)


def _point(force_n: float, scale: float, freq_hz: float = 240.0) -> tuple[SweepPoint, complex]:
    spheres = 4 * scale * 11 * 9.65e-6
    start = complex_amplitude(force_n, MASS + spheres, STIFFNESS, DAMPING, 2 * np.pi * freq_hz)
    return SweepPoint(freq_hz, HostDrive(MASS, STIFFNESS, DAMPING, force_n, scale), start, 4, 8,
                      2), start


def test_a_point_reads_the_host_and_the_spheres_as_mass_and_dashpot():
    packing = np.loadtxt(DATA / "settled_11.csv", delimiter=",")
    packings = np.stack([packing, packing[::-1], packing, packing[::-1]])
    point, start = _point(0.002, 5.0)          # well below 1 g: the bed rides on the floor
    row = run_point(CellScene.from_config(load_config()), packings, point)
    spheres = 20 * 11 * 1180 * 4 / 3 * np.pi * 1.25e-3**3
    assert row["accel_g"] < 0.6 and row["steady"]
    assert abs(row["m_eff_kg"] / spheres - 1) < 0.05
    # the host with the measured mass and dashpot is the measured host (linear response; off
    # resonance, where |X| is not 25 times as sensitive to m_eff as near it)
    linear = complex_amplitude(0.002, MASS + row["m_eff_kg"], STIFFNESS,
                               DAMPING + row["c_eff_ns_m"], 2 * np.pi * 240.0)
    assert abs(abs(linear) / row["amplitude_m"] - 1) < 1e-3
    # loss factor by energy and by the first harmonic agree: (c_h + c_eff) Omega / k
    assert abs(row["loss_factor"] / ((DAMPING + row["c_eff_ns_m"]) * 2 * np.pi * 240.0
                                     / STIFFNESS) - 1) < 0.02
    assert row["balance_residual_fraction"] < 0.005
    # the cells' scatter is measured (a reversed packing is another packing once it moves)
    assert 0 <= row["amplitude_sem_packings_m"] < 0.01 * row["amplitude_m"]
    assert row["amplitude_sem_m"] >= row["amplitude_sem_cycles_m"]
