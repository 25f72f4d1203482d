"""The DEM check of a mode: the mode as a host carrying representative cells, coupled two ways.

The mode (:class:`pidpipe.panel.plate.Mode`) is a single-degree-of-freedom host: its coordinate q
is the antinode's displacement (m), its mass the bare plate's modal mass M_plate, its stiffness
omega_0^2 M_plate and its structural damping c_s = 2 zeta sqrt(k M_plate) (the panel's
``damping_ratio``), forced by the modal force F_0 cos(Omega t). The layout's filled cells are
grouped by |phi| (:func:`layout_groups`: G groups of nearly equal counts, the largest |phi|
first); group g of n_g cells sits at phi_g = sqrt(<phi^2>_g) (so that sum_g n_g phi_g^2 is the
layout's sum phi_i^2: the modal mass of resting beds and of a constant C_eq is kept), and
k_g DEM cells, each its own packing, stand for it. The cells' walls move as phi_g q; their
spheres act on the mode with -sum_g (n_g / k_g) phi_g (F_w,g - W_0,g)
(:func:`pidpipe.dem.host_drive.run_host_groups`), so the particles' mass and dissipation enter
through the DEM alone (two-way coupling).

The compiled DEM cells hold one number of spheres: every group is run at the layout's most
common count n (:func:`check_fill`), and the panel model is evaluated on the same cells at the
fill of n spheres (the *represented* layout; its fill clipped to the C_eq model's domain).

Both are swept in frequency the way a structure is, by continuation
(:mod:`pidpipe.panel.branches`): up (the reported sweep) and down, the first frequency from rest,
every other one from the state reached at the one before -- the coupled host from the previous
run's last-cycle amplitude (:func:`coupled_continuation`; its spheres from their settled packings),
the panel model from the previous consistent amplitude. Where C_eq falls with G the panel model's
response folds (up to three consistent amplitudes), and a sweep stays on its branch until the
branch ends, then jumps, as the coupled host would; so each panel curve is compared with the
coupled curve of its own sweep. At every frequency the coupled host runs ``transient_cycles``
and ``measured_cycles``, reduced as the host check reduces its points
(:mod:`pidpipe.loop.coupled_sweep`): |q| and its standard error over blocks of cycles, the
antinode's G, the loss factor eta = (D_h + sum S D_p) / (pi k |q|^2) and its particle part, the
spheres' force as m_eff and c_eff, steadiness and the energy balance. The panel model
(:func:`pidpipe.panel.response.response_curve`) is swept at the same frequencies: ``panel`` with
the stage's modal mass (the m_eff surrogate's when given, else the bed's mass) and
``panel_full_mass`` with the beds' whole mass, and, with the m_eff surrogate, ``panel_mass_at_g``
with its mass read at each amplitude's G (not at the band's middle); ``panel_largest``, beside
the reported sweep, takes the largest consistent amplitude at every frequency (the rule before
continuation). Each curve's peak (:mod:`pidpipe.loop.compare`) gives the comparison: peak
frequency, amplitude and loss factor. The panel model's dashpot is also read in each coupled
state (its f and G: ``panel_ceq_ns_m``, ``panel_particle_loss_factor``), which compares the C_eq
model with the DEM state for state, whatever branch either is on.
"""

from __future__ import annotations

import math
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass

import numpy as np
import pandas as pd

from pidpipe.loop.compare import peak_with_uncertainty, redraw, relative_difference
from pidpipe.panel.branches import sweep_order
from pidpipe.panel.loss import Layout, ModalLoss
from pidpipe.panel.mass import SurrogateEffectiveMass
from pidpipe.panel.response import response_curve
from pidpipe.physics.contact import STANDARD_GRAVITY_M_S2

#: The curves, in table order (``panel_mass_at_g`` only with the m_eff surrogate;
#: ``panel_largest`` and, with the C_eq model's std, ``panel_ceq_*_sd`` only beside the reported
#: sweep).
MODELS: tuple[str, ...] = ("coupled", "panel", "panel_full_mass", "panel_mass_at_g", "panel_largest",
                           "panel_ceq_minus_sd", "panel_ceq_plus_sd")
#: The sweeps the check runs by default, the reported one first.
SWEEPS: tuple[str, ...] = ("up", "down")
#: Redraws of the coupled curve within its standard errors, for its peak's uncertainty.
PEAK_DRAWS = 200


@dataclass(frozen=True)
class LayoutGroups:
    """A layout's filled cells in groups by |phi| (:func:`layout_groups`).

    Attributes
    ----------
    weights : ndarray, shape (G,)
        phi_g = sqrt(<phi^2>_g), the rms |phi| of the group's cells.
    cells : ndarray of int, shape (G,)
        n_g, the group's filled cells.
    phi_min, phi_max : ndarray, shape (G,)
        The group's range of |phi|.
    """

    weights: np.ndarray
    cells: np.ndarray
    phi_min: np.ndarray
    phi_max: np.ndarray


def layout_groups(phi_cells, groups: int) -> LayoutGroups:
    """The filled cells (their mode shape values ``phi_cells``, shape (k,)) in ``groups`` groups
    of nearly equal counts by falling |phi| (fewer when there are fewer cells)."""
    a = np.sort(np.abs(np.asarray(phi_cells, dtype=float)))[::-1]
    if a.size == 0:
        raise ValueError("the layout fills no cell: nothing to check")
    chunks = [c for c in np.array_split(a, min(int(groups), a.size)) if c.size]
    return LayoutGroups(weights=np.array([math.sqrt(float(np.mean(c**2))) for c in chunks]),
                        cells=np.array([c.size for c in chunks]),
                        phi_min=np.array([c.min() for c in chunks]),
                        phi_max=np.array([c.max() for c in chunks]))


def check_fill(layout: Layout, spheres_of, full_cell_spheres: float, domain: dict) -> tuple[int, float]:
    """The DEM cells' sphere count and the fill (%) the panel model reads them at.

    ``spheres_of(fill_pct) -> int`` is the campaign's rule (``fill.definition``); n is the
    commonest count over the layout's cells, its fill 100 n / full_cell_spheres clipped to the
    C_eq model's fill domain.
    """
    counts = np.array([int(spheres_of(float(r))) for r in layout.fill_pct])
    values, times = np.unique(counts, return_counts=True)
    n = int(values[np.argmax(times)])
    lo, hi = domain["fill_pct"]
    return n, float(np.clip(100.0 * n / full_cell_spheres, lo, hi))


@dataclass(frozen=True)
class CheckRun:
    """What the coupled sweep runs: the host, the groups and the run's length."""

    mass_kg: float
    stiffness_n_m: float
    damping_ns_m: float
    force_n: float
    group_of: tuple
    weights: tuple
    cells: tuple
    transient_cycles: int
    measured_cycles: int
    block_cycles: int


def sweep_frequencies(loss: ModalLoss, full_mass: ModalLoss, layout: Layout, points: int,
                      span_fraction: float) -> np.ndarray:
    """``points`` frequencies (Hz) from the fully loaded mode's frequency x (1 - span) to the
    bare mode's x (1 + span), where a peak between the beds' whole mass and none lies."""
    low = min(full_mass.frequency_hz(layout), loss.frequency_hz(layout)) * (1.0 - span_fraction)
    high = loss.mode.freq_hz * (1.0 + span_fraction)
    return np.linspace(low, high, int(points))


def coupled_point(scene, packings: np.ndarray, run: CheckRun, freq_hz: float,
                  start_amplitude: complex) -> dict:
    """One frequency of the coupled mode, reduced to its steady state (module docstring).

    Parameters
    ----------
    scene : pidpipe.cell.scene.CellScene
    packings : ndarray, shape (k, n, 3)
        The k DEM cells' settled packings, m (cell b in group ``run.group_of[b]``).
    run : CheckRun
    freq_hz : float
    start_amplitude : complex
        The modal coordinate's steady state to start from, m.

    Returns
    -------
    dict
        ``freq_hz``, ``amplitude_m``, ``accel_g``, ``loss_factor``, ``particle_loss_factor``,
        ``m_eff_kg``, ``c_eff_ns_m`` and their ``*_sem`` (blocks of cycles), ``steady``,
        ``balance_residual_fraction``, ``steps_per_cycle``, ``timestep_s``, ``cpu_s``, and
        ``end_amplitude`` (the last cycle's first-harmonic q, complex, m: where the next
        frequency of a sweep starts).
    """
    from pidpipe.dem.from_scene import dem_scene
    from pidpipe.dem.host_drive import CellGroups, HostDrive, effective_mass_and_damping, run_host_groups
    from pidpipe.loop.coupled_sweep import STEADY_RELATIVE, STEADY_SIGMAS
    from pidpipe.loop.sdof import steady_state
    from pidpipe.measurement.statistics import mean_and_sem

    omega = 2.0 * math.pi * freq_hz
    dem = dem_scene(scene, freq_hz, np.zeros(packings.shape[0]))
    host = HostDrive(run.mass_kg, run.stiffness_n_m, run.damping_ns_m, run.force_n, 0.0)
    groups = CellGroups(run.group_of, run.weights, run.cells)
    x0, u0 = steady_state(start_amplitude, omega)
    out = run_host_groups(dem, packings, groups, host, run.transient_cycles + run.measured_cycles,
                          x0, u0)
    measured = slice(run.transient_cycles, None)
    displacement = out["displacement"][measured]
    amplitude = np.abs(displacement)
    strain = math.pi * run.stiffness_n_m * amplitude**2
    particles = out["particle_dissipation_j"][measured]
    m_eff, c_eff = effective_mass_and_damping(displacement, out["reaction"][measured], omega)
    row = {"freq_hz": float(freq_hz), "force_n": run.force_n}
    for name, series in (("amplitude_m", amplitude),
                         ("accel_g", amplitude * omega**2 / STANDARD_GRAVITY_M_S2),
                         ("loss_factor", (out["host_damping_j"][measured] + particles) / strain),
                         ("particle_loss_factor", particles / strain),
                         ("m_eff_kg", m_eff), ("c_eff_ns_m", c_eff)):
        row[name], row[f"{name}_sem"] = mean_and_sem(series, run.block_cycles)
    half = amplitude.size // 2
    first, second = (mean_and_sem(part, run.block_cycles) for part in (amplitude[:half], amplitude[half:]))
    combined = math.hypot(first[1], second[1])
    sigmas = abs(first[0] - second[0]) / combined if combined > 0 else 0.0
    row["steady"] = bool(sigmas <= STEADY_SIGMAS or abs(first[0] - second[0]) <= STEADY_RELATIVE * row["amplitude_m"])
    flows = np.abs(out["force_work_j"]) + out["host_damping_j"] + out["particle_dissipation_j"]
    row["balance_residual_fraction"] = float(np.max(np.abs(out["balance_residual_j"]) / flows))
    row.update(steps_per_cycle=out["steps_per_cycle"], timestep_s=out["timestep_s"], cpu_s=out["cpu_s"],
               end_amplitude=complex(out["displacement"][-1]))
    return row


def coupled_continuation(scene, packings: np.ndarray, run: CheckRun, freqs_hz, sweep: str
                         ) -> list[dict]:
    """The coupled mode swept in frequency by continuation, one run after another.

    The frequencies are visited in ``sweep`` order (:func:`pidpipe.panel.branches.sweep_order`:
    ``up`` ascending, ``down`` descending); the first starts from rest (q = 0), every other one
    from the first-harmonic amplitude of the last cycle before it (``end_amplitude``), the
    host's displacement and velocity at that amplitude and the new frequency. The spheres start
    each run from their settled packings (the runs do not hand on the beds' state; the beds
    reach their steady motion within the transient cycles, the host's amplitude is what carries
    the branch).

    Returns
    -------
    list of dict
        :func:`coupled_point`'s rows in ascending frequency, each with ``sweep`` and
        ``start_amplitude_m`` (|q| it started from), without ``end_amplitude``.
    """
    freqs = np.asarray(freqs_hz, dtype=float)
    packings = np.ascontiguousarray(packings, dtype=float)
    rows: list[dict | None] = [None] * freqs.size
    start = 0j
    for index in sweep_order(freqs, sweep):
        row = coupled_point(scene, packings, run, float(freqs[index]), start)
        row.update(sweep=sweep, start_amplitude_m=abs(start))
        start = row.pop("end_amplitude")
        rows[index] = row
    return rows


def _run_sweep(job: tuple) -> list[dict]:
    return coupled_continuation(*job)


def coupled_sweeps(scene, packings: np.ndarray, run: CheckRun, freqs_hz, sweeps, workers: int = 1
                   ) -> dict[str, list[dict]]:
    """:func:`coupled_continuation` in each direction of ``sweeps``, ``workers`` sweeps at a time
    (a sweep's runs follow one another)."""
    jobs = [(scene, packings, run, np.asarray(freqs_hz, dtype=float), sweep) for sweep in sweeps]
    if workers <= 1 or len(jobs) <= 1:
        return {job[-1]: _run_sweep(job) for job in jobs}
    with ProcessPoolExecutor(max_workers=min(int(workers), len(jobs))) as pool:
        return dict(zip(sweeps, pool.map(_run_sweep, jobs)))


@dataclass
class ModeCheck:
    """The check's tables and record.

    Attributes
    ----------
    curves : DataFrame
        One row per model and frequency: ``model``, ``freq_hz``, ``amplitude_m``, ``accel_g``,
        ``loss_factor``, ``particle_loss_factor`` (with ``*_sem`` for the coupled host), ...
    summary : DataFrame
        One row per model: its peak and, for the panel models, the differences from the
        coupled peak.
    meta : dict
        The host, the groups, the fills, the force, the costs.
    """

    curves: pd.DataFrame
    summary: pd.DataFrame
    meta: dict


def check_mode(scene, loss: ModalLoss, full_mass: ModalLoss, predict, layout: Layout,
               groups: LayoutGroups, cells_per_group: int, packings: np.ndarray, fill_pct: float,
               force_n: float, damping_ratio: float, freqs_hz, transient_cycles: int,
               measured_cycles: int, block_cycles: int = 2, workers: int = 1,
               seed: int = 17, sweeps: tuple[str, ...] = SWEEPS,
               predict_with_uncertainty=None) -> ModeCheck:
    """The coupled mode against the panel model at one modal force (module docstring).

    Parameters
    ----------
    scene : pidpipe.cell.scene.CellScene
    loss, full_mass : ModalLoss
        The mode with the stage's effective mass, and with the beds' whole mass.
    predict : callable
        C_eq_coupon(f, G, r), N s/m.
    layout : Layout
        The layout checked (its cells; their fill is ``fill_pct`` in the panel model).
    groups : LayoutGroups
        The layout's cells by |phi|.
    cells_per_group : int
        k_g, DEM cells per group.
    packings : ndarray, shape (G k_g, n, 3)
        Settled packings, group by group, m.
    fill_pct : float
        The fill the panel model reads the DEM's n spheres at, %.
    force_n : float
        F_0, N.
    damping_ratio : float
        The mode's structural damping ratio zeta.
    freqs_hz : array_like
        The sweep.
    transient_cycles, measured_cycles, block_cycles : int
    workers : int
        Coupled sweeps at a time (a sweep's frequencies run one after another).
    seed : int
        Of the coupled peak's redraws.
    sweeps : tuple of str
        The directions swept, coupled and panel model alike (``up``, ``down``); the first is the
        reported one (its rows come first in the summary).
    predict_with_uncertainty : callable, optional
        (f, G, r) -> (mean, std) of C_eq_coupon, N s/m (a Gaussian process's): the reported
        sweep of ``panel`` is also run with every C_eq at mean - std and mean + std
        (``panel_ceq_minus_sd``, ``panel_ceq_plus_sd``; fully correlated, as the stage's
        intervals), the model's own spread.
    """
    represented = Layout(f"{layout.name} (DEM fill)", layout.cells, np.full(layout.cells.size, fill_pct))
    mode = loss.mode
    stiffness = mode.omega**2 * mode.modal_mass_kg
    structural = 2.0 * damping_ratio * math.sqrt(stiffness * mode.modal_mass_kg)
    freqs = np.asarray(freqs_hz, dtype=float)
    if not sweeps or any(sweep not in SWEEPS for sweep in sweeps):
        raise ValueError(f"sweeps = {tuple(sweeps)!r}: each one of {', '.join(SWEEPS)}")
    with_mass_at_g = isinstance(loss.effective_mass_kg, SurrogateEffectiveMass)
    model_rows = {}
    for sweep in sweeps:
        model_rows[sweep] = {
            "panel": response_curve(loss, predict, represented, force_n, damping_ratio, freqs,
                                    sweep=sweep),
            "panel_full_mass": response_curve(full_mass, predict, represented, force_n,
                                              damping_ratio, freqs, sweep=sweep)}
        if with_mass_at_g:
            model_rows[sweep]["panel_mass_at_g"] = response_curve(
                loss, predict, represented, force_n, damping_ratio, freqs, mass_follows_accel=True,
                sweep=sweep)
    # the former rule, the largest consistent amplitude at every frequency, beside the reported sweep
    model_rows[sweeps[0]]["panel_largest"] = response_curve(loss, predict, represented, force_n,
                                                            damping_ratio, freqs, sweep="largest")
    if predict_with_uncertainty is not None:
        for name, sign in (("panel_ceq_minus_sd", -1.0), ("panel_ceq_plus_sd", 1.0)):
            model_rows[sweeps[0]][name] = response_curve(
                loss, _shifted(predict_with_uncertainty, sign), represented, force_n, damping_ratio,
                freqs, sweep=sweeps[0])
    k = int(packings.shape[0])
    if k != groups.cells.size * cells_per_group:
        raise ValueError(f"{k} packings for {groups.cells.size} groups x {cells_per_group} cells")
    run = CheckRun(mass_kg=mode.modal_mass_kg, stiffness_n_m=stiffness, damping_ns_m=structural,
                   force_n=float(force_n),
                   group_of=tuple(int(g) for g in np.repeat(np.arange(groups.cells.size), cells_per_group)),
                   weights=tuple(float(w) for w in groups.weights),
                   cells=tuple(float(n) for n in groups.cells),
                   transient_cycles=int(transient_cycles), measured_cycles=int(measured_cycles),
                   block_cycles=int(block_cycles))
    coupled = coupled_sweeps(scene, packings, run, freqs, sweeps, workers)
    for row in (row for rows in coupled.values() for row in rows):
        # the panel model's dashpot in the coupled state (same f and G)
        c_p = float(loss.damping_ns_m(predict, represented, np.array([row["accel_g"]]),
                                      freq_hz=row["freq_hz"])[0])
        row["panel_ceq_ns_m"] = c_p
        row["panel_particle_loss_factor"] = c_p * 2.0 * math.pi * row["freq_hz"] / stiffness
        row["panel_m_eff_kg"] = float(loss.state_added_mass_kg(represented, row["accel_g"],
                                                               row["freq_hz"])[0])
    curves = _curves(coupled, model_rows)
    summary = _summary(curves, seed)
    meta = {"mode": {"m": mode.m, "n": mode.n, "freq_hz": mode.freq_hz,
                     "modal_mass_kg": mode.modal_mass_kg, "stiffness_n_m": stiffness,
                     "structural_damping_ns_m": structural, "damping_ratio": damping_ratio},
            "force_n": float(force_n), "frequencies_hz": freqs.tolist(),
            "layout": {"name": layout.name, "cells": int(layout.cells.size),
                       "design_fill_pct": sorted(set(float(r) for r in layout.fill_pct)),
                       "dem_fill_pct": fill_pct, "spheres_per_cell": int(packings.shape[1])},
            "groups": {"weights": groups.weights.tolist(), "cells": groups.cells.tolist(),
                       "phi_min": groups.phi_min.tolist(), "phi_max": groups.phi_max.tolist(),
                       "dem_cells_per_group": int(cells_per_group)},
            "modal_mass_kg": {"panel": loss.modal_mass_kg(represented),
                              "panel_full_mass": full_mass.modal_mass_kg(represented)},
            "sweeps": list(sweeps), "reported_sweep": sweeps[0],
            "coupled": {"transient_cycles": int(transient_cycles),
                        "measured_cycles": int(measured_cycles),
                        "start": "rest at the sweep's first frequency, then the previous one's state",
                        "steps_per_cycle": [row["steps_per_cycle"] for row in coupled[sweeps[0]]],
                        "cpu_s": float(sum(row["cpu_s"] for rows in coupled.values() for row in rows))}}
    return ModeCheck(curves=curves, summary=summary, meta=meta)


def _shifted(predict_with_uncertainty, sign: float):
    """C_eq_coupon at mean + sign x std (not below 0), N s/m."""
    def predict(freq_hz, accel_g, fill_pct):
        mean, std = predict_with_uncertainty(freq_hz, accel_g, fill_pct)
        return np.maximum(np.asarray(mean) + sign * np.asarray(std), 0.0)
    return predict


def _curves(coupled: dict, model_rows: dict) -> pd.DataFrame:
    rows = []
    for sweep, curve in coupled.items():
        rows += [{"model": "coupled", **{k: v for k, v in row.items() if k != "force_n"},
                  "branch": sweep, "n_solutions": 1} for row in curve]
        for model, curve in model_rows[sweep].items():
            # branch: how the curve picks its amplitudes (the sweep, or "largest")
            rows += [{"model": model, **{k: v for k, v in row.items() if k != "amplitude"},
                      "branch": row["sweep"], "sweep": sweep, "steady": True} for row in curve]
    return pd.DataFrame(rows)


def _summary(curves: pd.DataFrame, seed: int) -> pd.DataFrame:
    """One row per sweep and model, the sweeps in the curves' order; each panel curve is
    compared with the coupled curve of its own sweep."""
    rows = []
    for sweep in dict.fromkeys(curves.sweep):
        reference = None
        for model in MODELS:
            curve = curves[(curves.model == model) & (curves.sweep == sweep)]
            if curve.empty:
                continue
            f = curve.freq_hz.to_numpy()
            draws = (None, None)
            if model == "coupled":
                draws = (redraw(curve.amplitude_m, curve.amplitude_m_sem, PEAK_DRAWS, seed),
                         redraw(curve.loss_factor, curve.loss_factor_sem, PEAK_DRAWS, seed + 1))
            peak = peak_with_uncertainty(f, curve.amplitude_m.to_numpy(), curve.loss_factor.to_numpy(),
                                         *draws)
            omega = 2.0 * math.pi * peak["peak_freq_hz"]
            row = {"sweep": sweep, "model": model, **peak,
                   "peak_accel_g": peak["peak_amplitude_m"] * omega**2 / STANDARD_GRAVITY_M_S2,
                   "peak_particle_loss_factor": float(np.interp(peak["peak_freq_hz"], f,
                                                                curve.particle_loss_factor)),
                   "all_steady": bool(curve.steady.all()),
                   "max_solutions": int(curve.n_solutions.max())}
            if model == "coupled":
                # the panel model's particle loss factor in the coupled peak's state (f and G)
                panel = float(np.interp(peak["peak_freq_hz"], f, curve.panel_particle_loss_factor))
                row.update(panel_particle_loss_factor=panel,
                           particle_loss_factor_rel_diff=panel / row["peak_particle_loss_factor"] - 1.0,
                           m_eff_at_peak_kg=float(np.interp(peak["peak_freq_hz"], f, curve.m_eff_kg)),
                           panel_m_eff_at_peak_kg=float(np.interp(peak["peak_freq_hz"], f,
                                                                  curve.panel_m_eff_kg)))
                reference = row
            elif reference is not None:
                amp = relative_difference(row["peak_amplitude_m"], row["peak_amplitude_m_sd"],
                                          reference["peak_amplitude_m"], reference["peak_amplitude_m_sd"])
                eta = relative_difference(row["peak_loss_factor"], row["peak_loss_factor_sd"],
                                          reference["peak_loss_factor"], reference["peak_loss_factor_sd"])
                row.update(amplitude_rel_diff=amp[0], amplitude_rel_diff_sd=amp[1],
                           loss_factor_rel_diff=eta[0], loss_factor_rel_diff_sd=eta[1],
                           peak_shift_hz=row["peak_freq_hz"] - reference["peak_freq_hz"])
            rows.append(row)
    return pd.DataFrame(rows)


def summary_lines(summary: pd.DataFrame) -> list[str]:
    """One line per sweep and model: its peak, and the panel models' differences from the coupled
    curve of the same sweep."""
    lines = []
    for row in summary.itertuples():
        text = f"{row.model:<16} {row.sweep + ' sweep':<10} peak {row.peak_freq_hz:7.2f}"
        if np.isfinite(row.peak_freq_hz_sd):
            text += f" +- {row.peak_freq_hz_sd:.2g}"
        text += f" Hz, |q| {row.peak_amplitude_m * 1e6:.4g}"
        if np.isfinite(row.peak_amplitude_m_sd):
            text += f" +- {row.peak_amplitude_m_sd * 1e6:.2g}"
        text += (f" um (G {row.peak_accel_g:.3g} g), loss factor {row.peak_loss_factor:.4g}"
                 + (f" +- {row.peak_loss_factor_sd:.2g}" if np.isfinite(row.peak_loss_factor_sd) else "")
                 + f" (particles {row.peak_particle_loss_factor:.4g})")
        if row.model == "coupled":
            text += (f"; m_eff {row.m_eff_at_peak_kg * 1e3:.4g} g; the panel model in this state "
                     f"(f, G): particles' loss factor {row.panel_particle_loss_factor:.4g} "
                     f"({row.particle_loss_factor_rel_diff:+.1%}), m_eff {row.panel_m_eff_at_peak_kg * 1e3:.4g} g")
        else:
            text += (f"; vs coupled: peak {row.peak_shift_hz:+.2f} Hz, amplitude "
                     f"{row.amplitude_rel_diff:+.1%}, loss factor {row.loss_factor_rel_diff:+.1%}")
            if row.max_solutions > 1:
                rule = ("the largest taken" if row.model == "panel_largest"
                        else f"the {row.sweep} sweep's branch followed")
                text += f" (up to {row.max_solutions} consistent amplitudes: {rule})"
        if row.peak_at_edge:
            text += " (peak at the sweep's edge)"
        lines.append(text)
    return lines

