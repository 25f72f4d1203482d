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
(the measured window's two halves differ in mean |X| by less than 3 combined standard errors
or by less than 1 %).
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
#: standard errors, and by more than STEADY_RELATIVE of |X|, flag the point not steady.
STEADY_SIGMAS = 3.0
#: A drift of the amplitude below this fraction is immaterial to a comparison of models at the
#: 10 % level (the cycle-to-cycle SEM of |X| is often 1e-4 of it, so 3 SEM alone flags drifts of
#: a few 1e-4).
STEADY_RELATIVE = 0.01


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
        ``m_eff_kg``/``_sem_kg``, ``c_eff_ns_m``/``_sem_ns_m``, ``loss_factor``/``_sem`` (each
        SEM the cycles' and the packings' (:func:`packing_spread`) in quadrature),
        ``amplitude_sem_cycles_m``, ``amplitude_sem_packings_m``,
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
    spread = packing_spread(out, point, measured)
    relative = spread["amplitude_m"] / spread["amplitude_ref_m"]
    packing_sems = {"amplitude_sem_m": row["amplitude_m"] * relative,
                    "accel_sem_g": row["accel_g"] * relative, "m_eff_sem_kg": spread["m_eff_kg"],
                    "c_eff_sem_ns_m": spread["c_eff_ns_m"], "loss_factor_sem": spread["loss_factor"]}
    row["amplitude_sem_cycles_m"] = row["amplitude_sem_m"]
    row["amplitude_sem_packings_m"] = packing_sems["amplitude_sem_m"]
    for name, packing in packing_sems.items():
        row[name] = float(np.hypot(np.nan_to_num(row[name]), packing))
    half = amplitude.size // 2
    first, second = (mean_and_sem(part, block) for part in (amplitude[:half], amplitude[half:]))
    combined = np.hypot(first[1], second[1])
    row["halves_sigma"] = float(abs(first[0] - second[0]) / combined) if combined > 0 else 0.0
    drift = abs(first[0] - second[0]) / row["amplitude_m"]
    row["steady"] = bool(row["halves_sigma"] <= STEADY_SIGMAS or drift <= STEADY_RELATIVE)
    row["balance_residual_fraction"] = float(np.max(np.abs(out["balance_residual_j"]) / flows))
    row.update(timestep_s=out["timestep_s"], steps_per_cycle=out["steps_per_cycle"],
               cpu_s=out["cpu_s"])
    return row


def packing_spread(out: dict, point: SweepPoint, measured: slice) -> dict:
    """The standard errors that the k cells' packing-to-packing scatter puts on the point.

    The cells ride on one host, so they are not separate runs; but each cell's own first-harmonic
    wall force, as if all n_c cells were like it (R_b = -n_c F_w,b), gives its own m_eff,b and
    c_eff,b, and its own dissipation its own loss factor. The host's linear response to cell b's
    (m_eff,b, c_eff,b), X_b = F_0 / (k_h - (m_h + m_eff,b) Omega^2 + i Omega (c_h + c_eff,b)),
    carries the scatter to the amplitude. Each standard error is the cells' standard deviation
    over sqrt(k) (NaN-free zero for one cell: no scatter can be measured).

    Returns
    -------
    dict
        ``amplitude_m`` (SEM of |X| from the cells' |X_b|), ``amplitude_ref_m`` (|X| of the
        cells' mean m_eff and c_eff, the linear response the SEM is relative to),
        ``m_eff_kg``, ``c_eff_ns_m``, ``loss_factor``.
    """
    host = point.host
    omega = 2.0 * np.pi * point.freq_hz
    k = out["cell_wall_force"].shape[0]
    displacement = out["displacement"][measured]
    n_cells = host.cell_scale * k
    ratio = (-n_cells * out["cell_wall_force"][:, measured] / displacement).mean(axis=1)
    m_eff, c_eff = ratio.real / omega**2, -ratio.imag / omega
    from pidpipe.loop.sdof import complex_amplitude

    linear = np.abs(complex_amplitude(host.force_n, host.mass_kg + m_eff, host.stiffness_n_m,
                                      host.damping_ns_m + c_eff, omega))
    reference = float(np.abs(complex_amplitude(host.force_n, host.mass_kg + m_eff.mean(),
                                               host.stiffness_n_m,
                                               host.damping_ns_m + c_eff.mean(), omega)))
    strain = np.pi * host.stiffness_n_m * np.abs(displacement) ** 2
    eta = ((out["host_damping_j"][measured] + n_cells * out["cell_dissipation_j"][:, measured])
           / strain).mean(axis=1)

    def sem(values):
        return float(np.std(values, ddof=1) / np.sqrt(k)) if k > 1 else 0.0

    return {"amplitude_m": sem(linear), "amplitude_ref_m": reference, "m_eff_kg": sem(m_eff),
            "c_eff_ns_m": sem(c_eff), "loss_factor": sem(eta)}


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
