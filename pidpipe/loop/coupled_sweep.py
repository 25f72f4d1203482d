"""The host coupled to the compiled DEM, swept over forcing frequencies at each force level.

Every (force level, frequency) point is one run of :func:`pidpipe.dem.host_drive.run_host`:
``transient_cycles`` discarded, then ``measured_cycles`` whose per-cycle values give the steady
state and its standard error (blocks of ``sem_block_cycles``). The points are independent (each
starts from the settled packings), so they run in a process pool.

Per point: the host's first-harmonic amplitude |X| (m) and acceleration Gamma = |X| Omega^2 / g;
the spheres' force on the host as an effective mass and dashpot (R = -m_eff x'' - c_eff x' at
the first harmonic; a rigid rider has m_eff = its mass, c_eff = 0); the loss factor
eta = (D_h + S D_p) / (pi k_h |X|^2), the energy dissipated per cycle over 2 pi times the peak
strain energy, as for the dashpot model (:func:`pidpipe.loop.sdof.loss_factor`); the largest
per-cycle residual of the energy balance over the cycle's energy flows; and a steadiness check
(the measured window's two halves differ in mean |X| by less than 3 combined standard errors).
"""

from __future__ import annotations

from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass

import numpy as np

from pidpipe.cell.scene import CellScene
from pidpipe.dem.from_scene import dem_scene
from pidpipe.dem.host_drive import HostDrive, effective_mass_and_damping, run_host
from pidpipe.measurement.statistics import mean_and_sem
from pidpipe.physics.contact import STANDARD_GRAVITY_M_S2

#: Two halves of the measured window whose mean |X| differ by more than this many combined
#: standard errors flag the point ``not_steady``.
STEADY_SIGMAS = 3.0


@dataclass(frozen=True)
class SweepPoint:
    """One run of the sweep: the forcing, the start and the run's length."""

    freq_hz: float
    host: HostDrive
    start_amplitude: complex
    transient_cycles: int
    measured_cycles: int
    block_cycles: int


def run_point(scene: CellScene, packings: np.ndarray, point: SweepPoint) -> dict:
    """One forcing frequency of one force level, reduced to its steady state (module docstring).

    Parameters
    ----------
    scene : CellScene
        The cells, their materials and the fidelity (the timestep comes from it).
    packings : ndarray, shape (k, n, 3)
        The k representative cells' settled packings, m.
    point : SweepPoint

    Returns
    -------
    dict
        ``freq_hz``, ``force_n``, ``amplitude_m``/``_sem_m``, ``accel_g``/``_sem_g``,
        ``m_eff_kg``/``_sem_kg``, ``c_eff_ns_m``/``_sem_ns_m``, ``loss_factor``/``_sem``,
        ``steady``, ``halves_sigma``, ``balance_residual_fraction``, ``timestep_s``,
        ``steps_per_cycle``, ``cpu_s``.
    """
    from pidpipe.loop.sdof import steady_state

    omega = 2.0 * np.pi * point.freq_hz
    dem = dem_scene(scene, point.freq_hz, np.zeros(packings.shape[0]))
    x0, u0 = steady_state(point.start_amplitude, omega)
    out = run_host(dem, packings, point.host, point.transient_cycles + point.measured_cycles,
                   x0, u0)
    measured = slice(point.transient_cycles, None)
    displacement = out["displacement"][measured]
    amplitude = np.abs(displacement)
    m_eff, c_eff = effective_mass_and_damping(displacement, out["reaction"][measured], omega)
    dissipated = out["host_damping_j"][measured] + out["particle_dissipation_j"][measured]
    eta = dissipated / (np.pi * point.host.stiffness_n_m * amplitude**2)
    flows = (np.abs(out["force_work_j"]) + out["host_damping_j"] + out["particle_dissipation_j"])
    block = point.block_cycles
    row = {"freq_hz": point.freq_hz, "force_n": point.host.force_n}
    for name, sem_name, series in (
            ("amplitude_m", "amplitude_sem_m", amplitude),
            ("accel_g", "accel_sem_g", amplitude * omega**2 / STANDARD_GRAVITY_M_S2),
            ("m_eff_kg", "m_eff_sem_kg", m_eff), ("c_eff_ns_m", "c_eff_sem_ns_m", c_eff),
            ("loss_factor", "loss_factor_sem", eta)):
        row[name], row[sem_name] = mean_and_sem(series, block)
    half = amplitude.size // 2
    first, second = (mean_and_sem(part, block) for part in (amplitude[:half], amplitude[half:]))
    combined = np.hypot(first[1], second[1])
    row["halves_sigma"] = float(abs(first[0] - second[0]) / combined) if combined > 0 else 0.0
    row["steady"] = bool(row["halves_sigma"] <= STEADY_SIGMAS)
    row["balance_residual_fraction"] = float(np.max(np.abs(out["balance_residual_j"]) / flows))
    row.update(timestep_s=out["timestep_s"], steps_per_cycle=out["steps_per_cycle"],
               cpu_s=out["cpu_s"])
    return row


def _run_job(job: tuple) -> dict:
    return run_point(*job)


def run_sweep(scene: CellScene, packings: np.ndarray, points: list[SweepPoint],
              workers: int = 1) -> list[dict]:
    """:func:`run_point` for every point, ``workers`` at a time; rows in the order of ``points``."""
    jobs = [(scene, np.ascontiguousarray(packings, dtype=float), point) for point in points]
    if workers <= 1 or len(jobs) <= 1:
        return [_run_job(job) for job in jobs]
    with ProcessPoolExecutor(max_workers=int(workers)) as pool:
        return list(pool.map(_run_job, jobs))
