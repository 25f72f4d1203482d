"""The host-coupled check of one design: both models swept at every force level, and compared.

The host (:class:`pidpipe.config.settings.HostSettings`): mass m_h, stiffness k_h = m_h (2 pi f_n)^2,
structural damping c_h, forced by F_0 cos(Omega t) at ``freq_points`` frequencies around f_n. It
carries the design's n_c filled cells of n spheres each (fill r = 100 n / full-cell spheres),
total sphere mass m_p = n_c n m_sphere.

- ``coupled`` (a): the compiled DEM of k representative cells (each its own packing) on the host,
  their wall force scaled by S = n_c / k (:mod:`.coupled_sweep`).
- ``equivalent`` (b): the same host with the surrogate's C_eq(f, Gamma, r) x n_c / N as a linear
  dashpot, solved to consistency in Gamma (:mod:`.equivalent`), moving mass m_h + m_p: the spheres
  are part of the structure's mass in a structural model that smears them in (as the particle
  budget counts them), and a dashpot cannot add or remove mass.
- ``equivalent_bare_mass`` (b'): the same dashpot on m_h alone: the limit of spheres that are
  airborne all the time. Where the coupled peak lies between the two, the spheres' effective
  mass (measured by the coupled run as m_eff, the in-phase part of their force) is what shifts it.
- ``equivalent_mass`` (c): the host carrying the damper element
  (:class:`pidpipe.design.damper.Damper`): the cells' effective mass n_c m_eff(f, Gamma, r) from
  the m_eff surrogate as added mass (moving mass m_h + n_c m_eff, not m_h + m_p) and
  C_eq(f, Gamma, r) n_c / N as dashpot, both solved to consistency in Gamma
  (:func:`pidpipe.loop.equivalent.solve_mass_point`). Omitted, with the reason logged, when no
  m_eff surrogate is given (tables without the m_eff column).

Uncertainties: the coupled host's are standard errors over its measured cycles and over its k
cells' packings (:func:`pidpipe.loop.coupled_sweep.packing_spread`) in quadrature; the dashpot
model's are the standard deviation over surrogates refitted to the C_eq table redrawn within its
SEMs (none when the table has no SEMs or ``surrogate_draws`` is 0). Model (c)'s are the standard
deviation over ``surrogate_draws`` solutions with m_eff and C_eq redrawn within the surrogates'
predictive standard uncertainties: draw j reads m_eff + z_m,j sd(m_eff) and
max(C_eq + z_c,j sd(C_eq), 0), with z_m,j and z_c,j independent standard normal numbers that are
the same at every f and Gamma of the draw (the surrogate's error is taken as fully correlated
over the small part of its domain one sweep reads, which keeps each draw a smooth function of
Gamma that can be solved to consistency, and gives the peak its largest spread). A C_eq surrogate
without a predictive uncertainty contributes, instead, the refitted surrogates of (b) (draw j
uses refit j, or none if there are none); an m_eff surrogate without one contributes nothing; and
each omission is logged.
"""

from __future__ import annotations

import logging
from dataclasses import asdict, dataclass
from typing import Iterable

import numpy as np
import pandas as pd

from pidpipe.cell.scene import CellScene
from pidpipe.config.settings import HostSettings
from pidpipe.dem.host_drive import HostDrive
from pidpipe.loop.compare import peak_with_uncertainty, redraw, relative_difference
from pidpipe.loop.coupled_sweep import SweepPoint, run_sweep
from pidpipe.loop.equivalent import damper_model, solve_mass_point, solve_point, surrogate_damping
from pidpipe.loop.sdof import loss_factor
from pidpipe.physics.contact import STANDARD_GRAVITY_M_S2

logger = logging.getLogger("pidpipe.loop")

MODELS: tuple[str, ...] = ("coupled", "equivalent", "equivalent_bare_mass", "equivalent_mass")
"""The curves, in the order of the tables."""
PEAK_DRAWS = 200
"""Redraws of the coupled curve within its standard errors, for its peak's uncertainty."""
#: The draws' spread arrays hold, in this order along axis 0, per draw and frequency:
SPREAD_KEYS: tuple[str, ...] = ("amplitude_m", "accel_g", "ceq_ns_m", "loss_factor", "m_eff_kg")


@dataclass(frozen=True)
class HostLoad:
    """What the host carries: the design's filled cells.

    Attributes
    ----------
    n_cells : int
        n_c, filled cells.
    spheres_per_cell : int
        n, spheres in each (a whole number: the DEM's cells hold whole spheres).
    fill_pct : float
        The fill of n spheres, 100 n / full-cell spheres, %: where the surrogate is read.
    sphere_mass_kg : float
    coupon_n_cells : int
        N, the coupon's cells (the surrogate's C_eq is the coupon's).
    """

    n_cells: int
    spheres_per_cell: int
    fill_pct: float
    sphere_mass_kg: float
    coupon_n_cells: int

    @property
    def particle_mass_kg(self) -> float:
        """m_p = n_c n m_sphere, kg."""
        return self.n_cells * self.spheres_per_cell * self.sphere_mass_kg


def _curve_row(settings: HostSettings, freq: float, point, clipped: bool) -> dict:
    """One frequency of a model's curve from its consistent steady state."""
    omega = 2 * np.pi * freq
    return {"freq_hz": freq, "amplitude": point.amplitude, "amplitude_m": abs(point.amplitude),
            "accel_g": point.accel_g, "ceq_ns_m": point.ceq_ns_m,
            "loss_factor": float(loss_factor(settings.damping_ns_m + point.ceq_ns_m,
                                             settings.stiffness_n_m, omega)),
            "m_eff_kg": point.added_mass_kg, "n_solutions": point.n_solutions,
            "surrogate_clipped": clipped}


def equivalent_curve(settings: HostSettings, load: HostLoad, surrogate, force_n: float,
                     mass_kg: float) -> list[dict]:
    """The dashpot model's steady state at every frequency of the sweep, for one surrogate
    (``m_eff_kg``: the mass it carries beyond m_h)."""
    model, clipped = surrogate_damping(surrogate.predict, surrogate.domain, load.fill_pct,
                                       load.n_cells / load.coupon_n_cells)
    rows = []
    for freq in settings.frequencies_hz():
        point = solve_point(freq, force_n, mass_kg, settings.stiffness_n_m, settings.damping_ns_m,
                            model)
        rows.append(_curve_row(settings, freq, point, clipped(freq, point.accel_g)))
        rows[-1]["m_eff_kg"] = mass_kg - settings.mass_kg
    return rows


def _spread(curves: list[list[dict]], n_freq: int) -> np.ndarray:
    """The draws' curves as an array of :data:`SPREAD_KEYS`, shape (keys, draws, n_freq)."""
    spread = np.array([[[row[key] for row in curve] for curve in curves] for key in SPREAD_KEYS])
    return spread.reshape(len(SPREAD_KEYS), len(curves), n_freq)


def equivalent_curves(settings: HostSettings, load: HostLoad, surrogate, draws: list
                      ) -> dict[tuple[str, float], tuple[list[dict], np.ndarray]]:
    """Both dashpot variants at every force level: the central rows and, per draw,
    :data:`SPREAD_KEYS`, shape (5, draws, n_freq)."""
    masses = {"equivalent": settings.mass_kg + load.particle_mass_kg,
              "equivalent_bare_mass": settings.mass_kg}
    out = {}
    for model, mass in masses.items():
        for force in settings.force_n:
            central = equivalent_curve(settings, load, surrogate, force, mass)
            spread = _spread([equivalent_curve(settings, load, draw, force, mass)
                              for draw in draws], len(central))
            out[model, force] = central, spread
    return out


def mass_curve(settings: HostSettings, load: HostLoad, damper, force_n: float,
               mass_shift: float = 0.0, damping_shift: float = 0.0) -> list[dict]:
    """Model (c)'s steady state at every frequency of the sweep: the host m_h carrying the
    damper's n_c m_eff and n_c C_eq / N (:func:`pidpipe.loop.equivalent.damper_model`; the
    shifts redraw them within their standard uncertainties)."""
    model, clipped = damper_model(damper, load.fill_pct, load.n_cells, mass_shift, damping_shift)
    rows = []
    for freq in settings.frequencies_hz():
        point = solve_mass_point(freq, force_n, settings.mass_kg, settings.stiffness_n_m,
                                 settings.damping_ns_m, model)
        rows.append(_curve_row(settings, freq, point, clipped(freq, point.accel_g)))
    return rows


def mass_draws(damper, refits: list, draws: int, seed: int) -> list[tuple]:
    """Model (c)'s draws (module docstring): ``(damper, z_m, z_c)`` per draw.

    Parameters
    ----------
    damper : pidpipe.design.damper.Damper
    refits : list of Surrogate
        The C_eq surrogates refitted for (b), used when the C_eq surrogate has no predictive
        uncertainty.
    draws : int
        ``surrogate_draws``.
    seed : int
    """
    from pidpipe.design.damper import Damper, has_uncertainty

    z = np.random.default_rng(seed).standard_normal((max(draws, 0), 2))
    ceq_std = has_uncertainty(damper.ceq_surrogate)
    m_std = has_uncertainty(damper.m_eff_surrogate)
    if not ceq_std:
        logger.warning("host: the C_eq surrogate has no predictive uncertainty: model (c) %s",
                       "redraws C_eq by the refitted surrogates of (b)" if refits
                       else "has no uncertainty from C_eq")
    if not m_std:
        logger.warning("host: the m_eff surrogate has no predictive uncertainty: model (c) has "
                       "none from m_eff")
    out = []
    for j in range(draws):
        if ceq_std:
            out.append((damper, z[j, 0] if m_std else 0.0, z[j, 1]))
        elif refits:
            refit = Damper(refits[j % len(refits)], damper.m_eff_surrogate, damper.coupon_n_cells)
            out.append((refit, z[j, 0] if m_std else 0.0, 0.0))
        elif m_std:
            out.append((damper, z[j, 0], 0.0))
    return out


def mass_curves(settings: HostSettings, load: HostLoad, damper, draws: list[tuple]
                ) -> dict[tuple[str, float], tuple[list[dict], np.ndarray]]:
    """Model (c) at every force level: the central rows and, per draw (:func:`mass_draws`),
    :data:`SPREAD_KEYS`, shape (5, draws, n_freq)."""
    out = {}
    for force in settings.force_n:
        central = mass_curve(settings, load, damper, force)
        spread = _spread([mass_curve(settings, load, d, force, z_m, z_c)
                          for d, z_m, z_c in draws], len(central))
        out["equivalent_mass", force] = central, spread
    return out


def coupled_points(settings: HostSettings, load: HostLoad, cells: int,
                   equivalent: dict) -> list[SweepPoint]:
    """The coupled sweep's runs: every force level x frequency, started as ``settings.start`` says."""
    points = []
    for force in settings.force_n:
        host = HostDrive(settings.mass_kg, settings.stiffness_n_m, settings.damping_ns_m, force,
                         load.n_cells / cells)
        start_rows = equivalent["equivalent", force][0]
        for freq, row in zip(settings.frequencies_hz(), start_rows):
            start = row["amplitude"] if settings.start == "equivalent" else 0j
            points.append(SweepPoint(freq, host, start, settings.transient_cycles,
                                     settings.measured_cycles, settings.sem_block_cycles))
    return points


def _sd(values: np.ndarray) -> np.ndarray:
    """Standard deviation over draws (axis 0); NaN with fewer than two draws."""
    return (np.std(values, axis=0, ddof=1) if values.shape[0] >= 2
            else np.full(values.shape[1:], np.nan))


def curves_table(settings: HostSettings, load: HostLoad, coupled: list[dict],
                 equivalent: dict) -> pd.DataFrame:
    """One row per model, force level and frequency (columns: docs/explanation/validation.md, the host section)."""
    rows = []
    n_freq = settings.freq_points
    for level, force in enumerate(settings.force_n):
        for row in coupled[level * n_freq:(level + 1) * n_freq]:
            rows.append({"model": "coupled", "level": level, "force_n": force,
                         "freq_hz": row["freq_hz"],
                         "amplitude_m": row["amplitude_m"], "amplitude_unc_m": row["amplitude_sem_m"],
                         "amplitude_unc_cycles_m": row["amplitude_sem_cycles_m"],
                         "amplitude_unc_packings_m": row["amplitude_sem_packings_m"],
                         "accel_g": row["accel_g"], "accel_unc_g": row["accel_sem_g"],
                         "loss_factor": row["loss_factor"], "loss_factor_unc": row["loss_factor_sem"],
                         "ceq_ns_m": row["c_eff_ns_m"], "ceq_unc_ns_m": row["c_eff_sem_ns_m"],
                         "m_eff_kg": row["m_eff_kg"], "m_eff_unc_kg": row["m_eff_sem_kg"],
                         "n_solutions": 1, "surrogate_clipped": False, "steady": row["steady"],
                         "balance_residual_fraction": row["balance_residual_fraction"],
                         "cpu_s": row["cpu_s"]})
        for model in MODELS[1:]:
            if (model, force) not in equivalent:
                continue
            central, spread = equivalent[model, force]
            sd = _sd(np.moveaxis(spread, 1, 0))
            for i, row in enumerate(central):
                rows.append({"model": model, "level": level, "force_n": force,
                             "freq_hz": row["freq_hz"], "amplitude_m": row["amplitude_m"],
                             "amplitude_unc_m": sd[0, i], "amplitude_unc_cycles_m": np.nan,
                             "amplitude_unc_packings_m": np.nan, "accel_g": row["accel_g"],
                             "accel_unc_g": sd[1, i], "loss_factor": row["loss_factor"],
                             "loss_factor_unc": sd[3, i], "ceq_ns_m": row["ceq_ns_m"],
                             "ceq_unc_ns_m": sd[2, i], "m_eff_kg": row["m_eff_kg"],
                             "m_eff_unc_kg": sd[4, i] if model == "equivalent_mass" else 0.0,
                             "n_solutions": row["n_solutions"],
                             "surrogate_clipped": row["surrogate_clipped"], "steady": True,
                             "balance_residual_fraction": float("nan"), "cpu_s": float("nan")})
    order = {m: i for i, m in enumerate(MODELS)}
    table = pd.DataFrame(rows)
    return table.sort_values(["level", "model", "freq_hz"], key=lambda c: c.map(order)
                             if c.name == "model" else c, kind="stable").reset_index(drop=True)


def summary_table(settings: HostSettings, curves: pd.DataFrame, equivalent: dict) -> pd.DataFrame:
    """Per force level and model: the peak (frequency, amplitude, acceleration, loss factor, the
    dashpot and mass there) with uncertainties, and the dashpot models' differences from the
    coupled host with the verdict (``holds``) of ``agreement_fraction``; ``peak_shift_sigmas`` is
    the peak shift over its standard deviation (the coupled peak's and the model's in
    quadrature; NaN when neither is known). Models absent from ``curves`` have no rows."""
    span_hz = 2.0 * settings.freq_span_fraction * settings.natural_freq_hz
    agree = settings.agreement_fraction
    rows = []
    for level, force in enumerate(settings.force_n):
        reference = None
        for model in MODELS:
            curve = curves[(curves.level == level) & (curves.model == model)]
            if curve.empty:
                continue
            f = curve.freq_hz.to_numpy()
            if model == "coupled":
                seed = settings.seed + level
                draws = (redraw(curve.amplitude_m, curve.amplitude_unc_m, PEAK_DRAWS, seed),
                         redraw(curve.loss_factor, curve.loss_factor_unc, PEAK_DRAWS, seed + 1))
            else:
                spread = equivalent[model, force][1]
                draws = (spread[0], spread[3])
            peak = peak_with_uncertainty(f, curve.amplitude_m.to_numpy(),
                                         curve.loss_factor.to_numpy(), *draws)
            omega = 2 * np.pi * peak["peak_freq_hz"]
            row = {"level": level, "force_n": force, "model": model, **peak,
                   "peak_accel_g": peak["peak_amplitude_m"] * omega**2 / STANDARD_GRAVITY_M_S2,
                   "ceq_at_peak_ns_m": float(np.interp(peak["peak_freq_hz"], f, curve.ceq_ns_m)),
                   "m_eff_at_peak_kg": float(np.interp(peak["peak_freq_hz"], f, curve.m_eff_kg)),
                   "all_steady": bool(curve.steady.all()),
                   "any_surrogate_clipped": bool(curve.surrogate_clipped.any()),
                   "max_solutions": int(curve.n_solutions.max())}
            if reference is None:
                reference = row
            else:
                amp, amp_sd = relative_difference(row["peak_amplitude_m"], row["peak_amplitude_m_sd"],
                                                  reference["peak_amplitude_m"],
                                                  reference["peak_amplitude_m_sd"])
                eta, eta_sd = relative_difference(row["peak_loss_factor"], row["peak_loss_factor_sd"],
                                                  reference["peak_loss_factor"],
                                                  reference["peak_loss_factor_sd"])
                shift = row["peak_freq_hz"] - reference["peak_freq_hz"]
                shift_sd = float(np.hypot(np.nan_to_num(row["peak_freq_hz_sd"]),
                                          np.nan_to_num(reference["peak_freq_hz_sd"])))
                row.update(amplitude_rel_diff=amp, amplitude_rel_diff_sd=amp_sd,
                           loss_factor_rel_diff=eta, loss_factor_rel_diff_sd=eta_sd,
                           peak_shift_hz=shift, peak_shift_sd_hz=shift_sd,
                           peak_shift_sigmas=(abs(shift) / shift_sd if shift_sd > 0
                                              else float("nan")),
                           holds=bool(abs(amp) <= agree and abs(eta) <= agree
                                      and abs(shift) <= agree * span_hz))
            rows.append(row)
    return pd.DataFrame(rows)


def model_curves(settings: HostSettings, load: HostLoad, surrogate, draws: list,
                 m_eff_surrogate=None) -> tuple[dict, dict]:
    """The surrogate models' curves at every force level: (b) and (b'), and (c) when an m_eff
    surrogate is given.

    Returns
    -------
    curves : dict
        ``(model, force_n) -> (central rows, spread)`` (:func:`equivalent_curves`,
        :func:`mass_curves`).
    note : dict
        Model (c)'s record: ``included``, and ``reason`` (left out) or ``damper`` and ``draws``.
    """
    curves = equivalent_curves(settings, load, surrogate, draws)
    if m_eff_surrogate is None:
        reason = ("no m_eff surrogate (the C_eq table has no m_eff_cell_kg column): model (c), "
                  "the host with the spheres' effective mass, is left out")
        logger.warning("host: %s", reason)
        return curves, {"included": False, "reason": reason}
    from pidpipe.design.damper import Damper

    damper = Damper(surrogate, m_eff_surrogate, load.coupon_n_cells)
    redraws = mass_draws(damper, draws, settings.surrogate_draws, settings.seed + 1000)
    logger.info("host: model (c) with the %s; %d draws", damper.describe(), len(redraws))
    curves.update(mass_curves(settings, load, damper, redraws))
    return curves, {"included": True, "damper": damper.describe(), "draws": len(redraws)}


def host_check(settings: HostSettings, scene: CellScene, load: HostLoad, surrogate,
               surrogate_draws: Iterable, packings: np.ndarray, workers: int = 1,
               m_eff_surrogate=None) -> tuple[pd.DataFrame, pd.DataFrame, dict]:
    """All models at every force level and frequency, and their comparison.

    Parameters
    ----------
    settings : HostSettings
    scene : CellScene
        The cells, materials and fidelity of the DEM.
    load : HostLoad
    surrogate : pidpipe.design.surrogate.Surrogate
    surrogate_draws : iterable of Surrogate
        Refitted surrogates for the dashpot model's uncertainty (may be empty).
    packings : ndarray, shape (k, n, 3)
        The k representative cells' settled packings, m.
    workers : int
        Coupled runs at a time.
    m_eff_surrogate : optional
        Surrogate of one cell's m_eff, kg (:mod:`pidpipe.design.damper`'s interface); None:
        model (c) is left out (logged).

    Returns
    -------
    curves, summary : DataFrame
        :func:`curves_table`, :func:`summary_table`.
    meta : dict
        The host's parameters, the load, the coupled runs' fidelity and CPU time.
    """
    draws = list(surrogate_draws)
    cells = int(packings.shape[0])
    equivalent, mass_note = model_curves(settings, load, surrogate, draws, m_eff_surrogate)
    points = coupled_points(settings, load, cells, equivalent)
    logger.info("host: %d coupled runs of %d cells x %d cycles (k_h %.6g N/m, c_h %.6g N s/m, "
                "m_h %.6g kg, spheres %.6g kg)", len(points), cells,
                settings.transient_cycles + settings.measured_cycles, settings.stiffness_n_m,
                settings.damping_ns_m, settings.mass_kg, load.particle_mass_kg)
    coupled = run_sweep(scene, packings, points, workers)
    curves = curves_table(settings, load, coupled, equivalent)
    summary = summary_table(settings, curves, equivalent)
    meta = {"host": {"mass_kg": settings.mass_kg, "stiffness_n_m": settings.stiffness_n_m,
                     "damping_ns_m": settings.damping_ns_m,
                     "damping_ratio": settings.damping_ratio,
                     "natural_freq_hz": settings.natural_freq_hz,
                     "force_n": list(settings.force_n),
                     "frequencies_hz": settings.frequencies_hz()},
            "environment": asdict(settings.environment), "design": settings.design,
            "load": {**asdict(load), "particle_mass_kg": load.particle_mass_kg,
                     "cells_integrated": cells, "cell_scale": load.n_cells / cells},
            "coupled": {"transient_cycles": settings.transient_cycles,
                        "measured_cycles": settings.measured_cycles,
                        "sem_block_cycles": settings.sem_block_cycles, "start": settings.start,
                        "timestep_s": [row["timestep_s"] for row in coupled],
                        "steps_per_cycle": [row["steps_per_cycle"] for row in coupled],
                        "cpu_s": float(sum(row["cpu_s"] for row in coupled))},
            "surrogate": {"description": surrogate.describe(), "draws": len(draws)},
            "equivalent_mass": mass_note}
    return curves, summary, meta
