"""The spheres' force on the cell at the first harmonic of the base motion: effective mass and a
force-based C_eq.

The energy per cycle (:mod:`pidpipe.measurement.statistics`) sees only the part of the spheres'
force in phase with the wall's velocity. Both engines also sum, every step of every cycle, the z
force F_n that a cell's spheres put on its walls (floor, lid and side walls together; N, up
positive; the negative of the walls' force on the spheres) against the wall's phase:

    S_c = dt sum_n F_n cos(theta_n),    S_s = dt sum_n F_n sin(theta_n),
    theta_n = omega (t_n + dt / 2),  t_n = n dt,

n over the N = T / dt steps of the cycle, N.s (the compiled DEM sums both in its time loop; the
LIGGGHTS deck sums S_c and has S_s in its wall power, :func:`sine_sums_from_wall_work`). The walls
move as z_w = W (cos(omega t) - 1) (LIGGGHTS' ``viblin``, and the DEM's walls where LIGGGHTS puts
its mesh): after step n they stand at dt sum_{k <= n} v_w(t_k) = z_w(t_n + dt / 2) - z_w(dt / 2),
so theta_n is the wall's phase when F_n is evaluated. Over a whole cycle the discrete sums of
cos(theta_n), sin(theta_n) and their cross product vanish and those of cos^2 and sin^2 are N / 2,
exactly: a force A cos(theta_n) + B sin(theta_n) + F_0 returns S_c = A T / 2 and S_s = B T / 2,
and the weight (the constant F_0) has no first harmonic.

With a_w = -W omega^2 cos(theta) and v_w = -W omega sin(theta),

- the effective mass m_eff = S_c / (pi W omega), kg: the force in phase with minus the wall's
  acceleration. A rigid mass m riding the wall pushes on it with F = -m a_w - m g, so
  m_eff = m (times sin(omega dt / 2) / (omega dt / 2), the discrete wall's acceleration:
  1 - 1.6e-6 at 1000 steps a cycle); a bed in free flight, 0.
- the force-based C_eq = S_s / (pi W), N.s/m: the force in phase with the wall's velocity. A
  dashpot c on the wall pushes on it with F = -c v_w, so C_eq = c.

The walls' work on the spheres over the cycle is W omega S_s (the decks' and the kernel's wall
work, to a factor cos(omega dt / 2) and terms at the cycle's two ends), so the force-based C_eq
equals the energy-based one, E_d / (pi omega W^2), wherever the spheres' energy returns to itself
over the measured cycles: the ledger check (:func:`ledger_check`) compares the two estimates. In
the DEM S_s is summed apart from the wall work and E_d is the contacts' own dissipation, term by
term; in LIGGGHTS S_s is the wall work (:func:`sine_sums_from_wall_work`) and E_d the balance's,
so there the check is one of the bed's energy drift over the window. A difference is such a
drift or a broken ledger.

Standard errors are the ones C_eq carries: each cell's series through
:func:`pidpipe.measurement.statistics.standard_error` (blocks of cycles, AR(1)), the cells
through :func:`pidpipe.measurement.cells.mean_of_cells` (packing spread and cycle noise).
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from pidpipe.measurement.cells import MeanOfCells, mean_of_cells
from pidpipe.measurement.statistics import standard_error
from pidpipe.physics.equivalent_damping import displacement_amplitude_m

LEDGER_LIMIT_SEM = 3.0
"""Largest |force-based - energy-based C_eq| in units of their combined standard error before
the case is flagged ``ledger_force_energy``."""
LEDGER_FLAG = "ledger_force_energy"


def step_phases(first_step: int, n_steps: int, timestep_s: float,
                omega_rad_s: float) -> np.ndarray:
    """The wall's phase theta_n = omega (n + 1/2) dt at steps first_step + 1 .. first_step + n_steps.

    Returns
    -------
    ndarray, shape (n_steps,)
        rad.
    """
    steps = np.arange(first_step + 1, first_step + n_steps + 1, dtype=float)
    return omega_rad_s * ((steps + 0.5) * timestep_s)


def harmonic_sums(force_n: np.ndarray, steps_per_cycle: int, timestep_s: float,
                  omega_rad_s: float, first_step: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """S_c and S_s of every whole cycle of a per-step force (the engines' sums, from a series).

    Parameters
    ----------
    force_n : ndarray, shape (..., n_steps)
        The spheres' z force on the walls at steps first_step + 1 .. first_step + n_steps, N.
    steps_per_cycle : int
        Steps per cycle of the base motion.
    timestep_s, omega_rad_s : float
        Timestep (s) and angular frequency of the base motion (rad/s).
    first_step : int
        The step before the first force; a cycle ends at every multiple of steps_per_cycle after it.

    Returns
    -------
    cos_sums, sin_sums : ndarray, shape (..., n_steps // steps_per_cycle)
        dt sum F_n cos(theta_n) and dt sum F_n sin(theta_n) over each cycle, N.s (a trailing
        partial cycle is left out).
    """
    force = np.asarray(force_n, dtype=float)
    n_cycles = force.shape[-1] // steps_per_cycle
    force = force[..., :n_cycles * steps_per_cycle]
    theta = step_phases(first_step, force.shape[-1], timestep_s, omega_rad_s)
    shape = force.shape[:-1] + (n_cycles, steps_per_cycle)
    cos_sums = (force * np.cos(theta)).reshape(shape).sum(axis=-1) * timestep_s
    sin_sums = (force * np.sin(theta)).reshape(shape).sum(axis=-1) * timestep_s
    return cos_sums, sin_sums


def sine_sums_from_wall_work(wall_work_j: np.ndarray, amplitude_m: float, omega_rad_s: float,
                             timestep_s: float) -> np.ndarray:
    """S_s from the wall work per cycle of the LIGGGHTS shake deck, which is the same step sum.

    The deck's wall power at step n is F_n W omega (sin(omega t_n) + sin(omega t_n+1)) / 2
    (:mod:`pidpipe.liggghts.parsing`), and (sin a + sin b) / 2 = cos((b - a) / 2) sin((a + b) / 2),
    so its work over a cycle is W omega cos(omega dt / 2) S_s exactly: the deck sums the sine
    once, as the wall power, and not again.

    Parameters
    ----------
    wall_work_j : ndarray
        The walls' work on a cell's spheres in each cycle, J.
    amplitude_m, omega_rad_s, timestep_s : float
        W (m), omega (rad/s) and dt (s) of the run.

    Returns
    -------
    ndarray, same shape
        N s.
    """
    _check_motion(amplitude_m, omega_rad_s)
    factor = amplitude_m * omega_rad_s * math.cos(0.5 * omega_rad_s * timestep_s)
    return np.asarray(wall_work_j, dtype=float) / factor


def effective_mass_kg(cos_sums_n_s: np.ndarray, amplitude_m: float,
                      omega_rad_s: float) -> np.ndarray:
    """m_eff = S_c / (pi W omega), kg, cycle by cycle (same shape as ``cos_sums_n_s``).

    Parameters
    ----------
    cos_sums_n_s : ndarray
        S_c of each cycle, N.s.
    amplitude_m, omega_rad_s : float
        The wall's displacement amplitude W (m, > 0) and angular frequency (rad/s).
    """
    _check_motion(amplitude_m, omega_rad_s)
    return np.asarray(cos_sums_n_s, dtype=float) / (math.pi * amplitude_m * omega_rad_s)


def force_ceq_ns_m(sin_sums_n_s: np.ndarray, amplitude_m: float) -> np.ndarray:
    """The force-based C_eq = S_s / (pi W), N.s/m, cycle by cycle (same shape as ``sin_sums_n_s``).

    Parameters
    ----------
    sin_sums_n_s : ndarray
        S_s of each cycle, N.s.
    amplitude_m : float
        The wall's displacement amplitude W, m (> 0).
    """
    _check_motion(amplitude_m, 1.0)
    return np.asarray(sin_sums_n_s, dtype=float) / (math.pi * amplitude_m)


def mean_cell(per_cycle, first_cycle: int | Sequence[int],
              block_cycles: int) -> tuple[MeanOfCells, list]:
    """The mean cell of a quantity measured cycle by cycle in k cells, with C_eq's standard error.

    Parameters
    ----------
    per_cycle : ndarray, shape (k, n_cycles) or (n_cycles,); or k sequences
        Each cell's value in every cycle, transient included (cells of several runs may have
        series of different lengths).
    first_cycle : int, or sequence of k int
        The first measured cycle (the case's transient), or each cell's.
    block_cycles : int
        Cycles per block (:func:`pidpipe.measurement.statistics.standard_error`).

    Returns
    -------
    MeanOfCells
        The mean over cells and its two-level standard error
        (:func:`pidpipe.measurement.cells.mean_of_cells`).
    cells : list of (float, float)
        Each cell's mean over its measured cycles and its standard error.
    """
    values = cell_series(per_cycle)
    firsts = _first_cycles(first_cycle, len(values))
    cells = [standard_error(series[first:], block_cycles) for series, first in zip(values, firsts)]
    return mean_of_cells(np.array([c[0] for c in cells]), np.array([c[1] for c in cells])), cells


def ledger_check(force_ns_m: float, force_sem_ns_m: float, energy_ns_m: float,
                 energy_sem_ns_m: float, limit_sem: float = LEDGER_LIMIT_SEM) -> tuple[float, bool]:
    """Whether the force-based and the energy-based C_eq agree within ``limit_sem`` combined SEMs.

    Returns
    -------
    z : float
        (force - energy) / sqrt(sem_force^2 + sem_energy^2); NaN if that is not finite and
        positive (one cycle, or two exactly equal estimates: then 0).
    agree : bool
        |z| <= limit_sem, or the two are equal; True when z cannot be computed.
    """
    difference = force_ns_m - energy_ns_m
    combined = math.hypot(force_sem_ns_m, energy_sem_ns_m)
    if difference == 0.0:
        return 0.0, True
    if not (math.isfinite(combined) and combined > 0.0):
        return float("nan"), True
    z = difference / combined
    return z, abs(z) <= limit_sem


def cell_series(per_cycle) -> list[np.ndarray]:
    """Each cell's series: the rows of a (k, n) array, a (n,) array as one cell, or k sequences."""
    if isinstance(per_cycle, np.ndarray) or not len(per_cycle) or np.ndim(per_cycle[0]) == 0:
        return list(np.atleast_2d(np.asarray(per_cycle, dtype=float)))
    return [np.asarray(series, dtype=float).reshape(-1) for series in per_cycle]


def _first_cycles(first_cycle: int | Sequence[int], n_cells: int) -> list[int]:
    firsts = [int(first_cycle)] * n_cells if np.ndim(first_cycle) == 0 else [int(f) for f in first_cycle]
    if len(firsts) != n_cells:
        raise ValueError(f"{len(firsts)} first cycles for {n_cells} cells")
    return firsts


def harmonics_record(cos_sums_n_s, sin_sums_n_s, first_cycle: int | Sequence[int],
                     freq_hz: float, accel_g: float, bed_mass_kg: float, block_cycles: int,
                     ceq_energy_ns_m: float, ceq_energy_sem_ns_m: float,
                     energy_j: np.ndarray | None = None) -> dict:
    """The ``harmonics`` block of a case record, from the engines' per-cycle sums.

    Parameters
    ----------
    cos_sums_n_s, sin_sums_n_s : ndarray, shape (k, n_cycles), or k sequences
        Each cell's S_c and S_s in every cycle of its run, transient included, N.s.
    first_cycle : int, or sequence of k int
        The first measured cycle (the case's transient), or each cell's (cells of several runs).
    freq_hz, accel_g : float
        The base motion (W = G g / omega^2).
    bed_mass_kg : float
        The spheres' mass of the mean cell, kg.
    block_cycles : int
        Cycles per block of the standard errors.
    ceq_energy_ns_m, ceq_energy_sem_ns_m : float
        The case's energy-based C_eq of the mean cell and its standard error (``ceq_cell_ns_m``,
        ``ceq_cell_sem_ns_m``), N.s/m.
    energy_j : ndarray, shape (n_cycles + 1,), optional
        The k cells' energy at the cycle boundaries (J), for the reason of a ledger flag: the
        change of the bed's energy over the measured cycles, as a fraction of the energy
        dissipated in them.

    Returns
    -------
    dict
        ``m_eff_cell_kg``, ``m_eff_cell_sem_kg``, ``m_eff_ratio`` (over ``bed_mass_kg``),
        ``m_eff_ratio_sem``, ``bed_mass_kg``, ``ceq_force_cell_ns_m``,
        ``ceq_force_cell_sem_ns_m``, ``ceq_energy_cell_ns_m`` and its SEM (as given),
        ``ledger_z`` (force minus energy over their combined SEM), ``ledger_relative_difference``
        (over the energy-based C_eq), ``flags`` ([``ledger_force_energy``] beyond
        :data:`LEDGER_LIMIT_SEM`, else []), ``ledger_reason`` (None when they agree),
        ``cells`` (each cell's m_eff and force-based C_eq with SEMs; empty for one cell), and
        the per-cycle sums ``cos_sums_n_s``, ``sin_sums_n_s`` (k lists of n_cycles).
    """
    cos_sums, sin_sums = cell_series(cos_sums_n_s), cell_series(sin_sums_n_s)
    if [c.shape for c in cos_sums] != [s.shape for s in sin_sums]:
        raise ValueError("S_c and S_s differ in shape")
    n_cells = len(cos_sums)
    omega = 2.0 * math.pi * freq_hz
    amplitude = displacement_amplitude_m(freq_hz, accel_g)
    mass, mass_cells = mean_cell([effective_mass_kg(c, amplitude, omega) for c in cos_sums],
                                 first_cycle, block_cycles)
    ceq, ceq_cells = mean_cell([force_ceq_ns_m(c, amplitude) for c in sin_sums], first_cycle,
                               block_cycles)
    z, agree = ledger_check(ceq.mean, ceq.sem, ceq_energy_ns_m, ceq_energy_sem_ns_m)
    reason = None
    if not agree:
        reason = (f"force-based C_eq {ceq.mean:.5g} +- {ceq.sem:.2g} N.s/m against the "
                  f"energy-based {ceq_energy_ns_m:.5g} +- {ceq_energy_sem_ns_m:.2g}: {z:+.1f} "
                  "combined SEM")
        drift = (None if np.ndim(first_cycle) else energy_drift_of_dissipation(
            energy_j, int(first_cycle), ceq_energy_ns_m, freq_hz, accel_g, n_cells))
        if drift is not None:
            reason += (f"; the bed's energy changed by {drift:+.3g} of the energy dissipated "
                       "over the measured cycles")
    return {
        "m_eff_cell_kg": mass.mean,
        "m_eff_cell_sem_kg": mass.sem,
        "m_eff_ratio": mass.mean / bed_mass_kg,
        "m_eff_ratio_sem": mass.sem / bed_mass_kg,
        "bed_mass_kg": float(bed_mass_kg),
        "ceq_force_cell_ns_m": ceq.mean,
        "ceq_force_cell_sem_ns_m": ceq.sem,
        "ceq_energy_cell_ns_m": float(ceq_energy_ns_m),
        "ceq_energy_cell_sem_ns_m": float(ceq_energy_sem_ns_m),
        "ledger_z": z,
        "ledger_relative_difference": ((ceq.mean - ceq_energy_ns_m) / ceq_energy_ns_m
                                       if ceq_energy_ns_m else float("nan")),
        "flags": [] if agree else [LEDGER_FLAG],
        "ledger_reason": reason,
        "cells": [] if n_cells == 1 else [
            {"m_eff_cell_kg": m[0], "m_eff_cell_sem_kg": m[1],
             "ceq_force_cell_ns_m": c[0], "ceq_force_cell_sem_ns_m": c[1]}
            for m, c in zip(mass_cells, ceq_cells)],
        "cos_sums_n_s": [c.tolist() for c in cos_sums],
        "sin_sums_n_s": [c.tolist() for c in sin_sums],
    }


def combine_harmonics(records: Sequence[dict], ceq_energy_ns_m: float,
                      ceq_energy_sem_ns_m: float) -> dict:
    """The ``harmonics`` of a case measured in several runs, over all their cells.

    Parameters
    ----------
    records : sequence of CaseRecord
        Run records of one case (each with ``harmonics``, ``freq_hz``, ``accel_g`` and
        ``fidelity``: its transient and block cycles), their cells distinct packings.
    ceq_energy_ns_m, ceq_energy_sem_ns_m : float
        The combined energy-based C_eq of the mean cell and its SEM, N.s/m
        (:func:`pidpipe.measurement.adaptive.combine_runs`).

    Returns
    -------
    dict
        :func:`harmonics_record` of every run's cells, each cell measured after its own run's
        transient (no energy drift in a ledger flag's reason: the runs' energies are apart).
    """
    cos_sums, sin_sums, firsts = [], [], []
    for record in records:
        harmonics = record.harmonics
        cos_sums += harmonics["cos_sums_n_s"]
        sin_sums += harmonics["sin_sums_n_s"]
        firsts += [int(record.fidelity.transient_cycles)] * len(harmonics["cos_sums_n_s"])
    last = records[-1]
    return harmonics_record(cos_sums, sin_sums, firsts, last.freq_hz, last.accel_g,
                            float(np.mean([r.harmonics["bed_mass_kg"] for r in records])),
                            int(last.fidelity.sem_block_cycles), ceq_energy_ns_m,
                            ceq_energy_sem_ns_m)


def energy_drift_of_dissipation(energy_j: np.ndarray | None, first_cycle: int,
                                ceq_energy_ns_m: float, freq_hz: float, accel_g: float,
                                n_cells: int) -> float | None:
    """The k cells' energy change over the measured cycles over the energy they dissipated in
    them (None without ``energy_j`` or dissipation)."""
    if energy_j is None:
        return None
    energy = np.asarray(energy_j, dtype=float)
    n_measured = energy.size - 1 - first_cycle
    omega = 2.0 * math.pi * freq_hz
    amplitude = displacement_amplitude_m(freq_hz, accel_g)
    dissipated = ceq_energy_ns_m * math.pi * omega * amplitude**2 * n_measured * n_cells
    if n_measured < 1 or not dissipated:
        return None
    return float((energy[-1] - energy[first_cycle]) / dissipated)


def _check_motion(amplitude_m: float, omega_rad_s: float) -> None:
    if not (amplitude_m > 0.0 and omega_rad_s > 0.0):
        raise ValueError(f"the first harmonic needs a moving wall: W = {amplitude_m} m, "
                         f"omega = {omega_rad_s} rad/s")
