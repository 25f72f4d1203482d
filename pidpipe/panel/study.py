"""The modal stage: the plate's modes, and every environment's designs on its modes.

For each environment, the modes whose bare frequency lies in its frequency band are designed
for; the band of antinode accelerations is the environment's G band. On each such mode and for
each design kind (peak, band_mean, worst_case) three layouts spend the same particle budget:

``source_uniform``
    the coupon design of that kind (:func:`pidpipe.design.designs.optimise_design` with the
    plate's budget and cell count: n_c cells, built at whole spheres,
    :func:`pidpipe.design.built_cells.whole_sphere_cells`), its cells spread evenly;
``source_antinode``
    the same n_c cells, placed where |phi| is largest (the fuller ones first);
``optimised``
    :func:`pidpipe.panel.layout.optimise_layout`.

Every layout's loss factor is evaluated on all its cells over the band (mean, worst, best), with
an interval from the C_eq model's uncertainty (:mod:`pidpipe.panel.uncertainty`), and solved to
consistency at each modal force (:mod:`pidpipe.panel.response`).
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from pidpipe.config.panel import PanelSettings
from pidpipe.panel.cells import cell_centres
from pidpipe.design.built_cells import whole_sphere_cells
from pidpipe.panel.layout import (antinode_layout, built_fills, make_regions, optimise_layout,
                                  uniform_layout)
from pidpipe.panel.loss import KINDS, AccelBand, Layout, ModalLoss, band_summary
from pidpipe.panel.mass import FULL_MASS, SurrogateEffectiveMass
from pidpipe.panel.plate import Mode, Sandwich, plate_modes
from pidpipe.panel.response import forced_response
from pidpipe.panel.uncertainty import UncertainCeq, interval

logger = logging.getLogger("pidpipe.campaign")

#: Columns of results/panel/modes.csv.
MODE_COLUMNS: tuple[str, ...] = ("mode_m", "mode_n", "freq_hz", "modal_mass_kg")
#: Said in designs.csv where the band's lowest antinode G reaches the C_eq model's lowest G.
FLOOR_NOTE = ("the band's lowest G at the antinode is at or below the C_eq model's lowest G: "
              "cells below it count as C_eq = 0 (the spheres rest on the floor)")
#: The layouts compared on every design, in table order.
LAYOUTS: tuple[str, ...] = ("source_uniform", "source_antinode", "optimised")


def sandwich_of(settings: PanelSettings) -> Sandwich:
    """The plate's section from its settings."""
    return Sandwich(settings.face_thickness_m, settings.face_density_kg_m3,
                    settings.face_youngs_modulus_pa, settings.face_poisson_ratio,
                    settings.core_height_m, settings.core_density_kg_m3,
                    settings.core_shear_modulus_xz_pa, settings.core_shear_modulus_yz_pa,
                    rotary_inertia=settings.rotary_inertia)


def modes_frame(modes: list[Mode]) -> pd.DataFrame:
    """results/panel/modes.csv: one row per mode (bare plate)."""
    return pd.DataFrame([{"mode_m": m.m, "mode_n": m.n, "freq_hz": m.freq_hz,
                          "modal_mass_kg": m.modal_mass_kg} for m in modes], columns=list(MODE_COLUMNS))


@dataclass
class PanelStudy:
    """What the stage found: tables and the figure's data."""

    settings: PanelSettings
    modes: list
    centres: np.ndarray
    designs: pd.DataFrame
    layouts: pd.DataFrame
    responses: pd.DataFrame
    uncertainty: str
    optimisation_s: float
    figure_layouts: list = field(default_factory=list)


def run_panel_study(settings: PanelSettings, surrogate, environments: list, search,
                    n_cells_coupon: int, model: UncertainCeq | None = None,
                    effective_mass_kg=None, m_eff_surrogate=None) -> PanelStudy:
    """Modes, layouts and loss factors of every environment (module docstring).

    Parameters
    ----------
    settings : PanelSettings
    surrogate : pidpipe.design.surrogate.Surrogate
        The coupon surrogate (the source-style designs are optimised on it).
    environments : list of pidpipe.design.optimisation.Environment
    search : pidpipe.design.designs.Search
        The coupon designs' search.
    n_cells_coupon : int
        N of the coupon.
    model : UncertainCeq, optional
        The C_eq model with its uncertainty; default: the surrogate with
        ``settings.surrogate_draws`` bootstrap refits.
    effective_mass_kg : callable, optional
        ``effective_mass_kg(fill_pct, spheres, phi_abs)`` -> the particles' effective mass per
        cell, kg (arrays); default: ``settings.effective_mass_fraction`` of the bed's whole mass.
    m_eff_surrogate : optional
        One cell's m_eff(f, G, r) surrogate, kg (``results/surrogate_m_eff.json``): each mode's
        cells then add the m_eff read at the mode's frequency and at their G over the
        environment's band middle (:class:`pidpipe.panel.mass.SurrogateEffectiveMass`); it takes
        precedence over ``effective_mass_kg``. designs.csv says which mass was used
        (``modal_mass_source``).
    """
    from pidpipe.design.designs import optimise_design
    from pidpipe.design.optimisation import Budget

    model = model or UncertainCeq.from_surrogate(surrogate, settings.surrogate_draws, settings.seed)
    modes = plate_modes(sandwich_of(settings), settings.length_m, settings.width_m, settings.max_freq_hz)
    centres = cell_centres(settings.length_m, settings.width_m, settings.cell_inscribed_diameter_m)
    budget = Budget(n_spheres=settings.n_spheres, full_cell_spheres=settings.full_cell_spheres,
                    n_cells_coupon=n_cells_coupon, n_cells_panel=int(len(centres)))
    logger.info("panel %g m x %g m: %d cells, %d spheres (%.4g kg, %.3g of the plate's %.4g kg); "
                "%d modes below %g Hz; C_eq uncertainty: %s", settings.length_m, settings.width_m,
                len(centres), settings.n_spheres, settings.n_spheres * settings.sphere_mass_kg,
                settings.n_spheres * settings.sphere_mass_kg / settings.plate_mass_kg,
                settings.plate_mass_kg, len(modes), settings.max_freq_hz, model.kind)
    designs, layouts, responses, figure = [], [], [], []
    optimisation_s = 0.0
    for env in environments:
        in_band = [m for m in modes if env.freq_hz[0] <= m.freq_hz <= env.freq_hz[1]]
        if not in_band:
            logger.warning("environment %r: no mode of the plate lies in %g-%g Hz; no panel design",
                           env.name, *env.freq_hz)
            designs.append({"environment": env.name, "note": "no mode in the band"})
            continue
        band = AccelBand(env.accel_g[0], env.accel_g[1], search.rule.quadrature_points,
                         search.rule.grid_points)
        sources = {kind: optimise_design(surrogate, env, budget, kind, search).design for kind in KINDS}
        for mode in in_band:
            phi = mode.shape(centres[:, 0], centres[:, 1])
            mass, mass_source = effective_mass_model(settings, env, mode, effective_mass_kg, m_eff_surrogate)
            logger.info("environment %r, mode (%d, %d): the modal mass takes the %s", env.name,
                        mode.m, mode.n, mass_source)
            loss = ModalLoss(mode, phi, n_cells_coupon, settings.full_cell_spheres,
                             settings.sphere_mass_kg, model.domain, settings.effective_mass_fraction,
                             mass)
            regions = make_regions(phi, settings.regions)
            for kind in KINDS:
                source = sources[kind]
                start = time.process_time()
                best = optimise_layout(loss, model.predict, regions, band, kind, settings.n_spheres,
                                       starts=settings.starts, seed=settings.seed,
                                       antinode_fills=(source.fill_pct,))
                optimisation_s += time.process_time() - start
                built = built_fills(whole_sphere_cells(budget, source.n_cells,
                                                       model.domain["fill_pct"]))
                chosen = {"source_uniform": uniform_layout(len(centres), source.n_cells, built),
                          "source_antinode": antinode_layout(phi, source.n_cells, built),
                          "optimised": best.layout}
                for name in LAYOUTS:
                    layout = chosen[name]
                    row, cells, forced = _evaluate(env, mode, kind, loss, model, layout, band,
                                                   settings, best if name == "optimised" else None)
                    row["modal_mass_source"] = mass_source
                    designs.append(row)
                    layouts.append(_cells_frame(env, mode, kind, layout, loss, centres, band))
                    responses += forced
                    if name == "optimised" and kind == "band_mean" and mode is in_band[0]:
                        figure.append({"environment": env.name, "mode": mode, "layout": layout})
    return PanelStudy(settings=settings, modes=modes, centres=centres,
                      designs=pd.DataFrame(designs),
                      layouts=pd.concat(layouts, ignore_index=True) if layouts else pd.DataFrame(),
                      responses=pd.DataFrame(responses), uncertainty=model.kind,
                      optimisation_s=optimisation_s, figure_layouts=figure)


def effective_mass_model(settings: PanelSettings, env, mode: Mode, effective_mass_kg, m_eff_surrogate):
    """The cells' m_eff model on one mode and its description (``modal_mass_source``)."""
    if m_eff_surrogate is not None:
        mass = SurrogateEffectiveMass(m_eff_surrogate, mode.freq_hz, 0.5 * (env.accel_g[0] + env.accel_g[1]),
                                      settings.sphere_mass_kg)
        return mass, mass.describe()
    if effective_mass_kg is not None:
        return effective_mass_kg, "effective mass given by the caller"
    return None, f"{FULL_MASS} {settings.effective_mass_fraction:g}"


def _objective(summary: dict, kind: str) -> float:
    return summary[kind]


def _evaluate(env, mode: Mode, kind: str, loss: ModalLoss, model: UncertainCeq, layout: Layout,
              band: AccelBand, settings: PanelSettings, best) -> tuple[dict, pd.DataFrame, list]:
    """One layout's row of designs.csv and its rows of the forced responses."""
    summary = band_summary(loss, model.predict, layout, band)
    lo, hi = interval(model, lambda predict: _objective(band_summary(loss, predict, layout, band), kind),
                      settings.confidence)
    fills = layout.fill_pct
    row = {"environment": env.name, "mode_m": mode.m, "mode_n": mode.n,
           "freq_hz": mode.freq_hz, "loaded_freq_hz": loss.frequency_hz(layout),
           "design": kind, "layout": layout.name, "n_cells": int(layout.cells.size),
           "fill_pct_min": float(fills.min()) if fills.size else np.nan,
           "fill_pct_max": float(fills.max()) if fills.size else np.nan,
           "spheres": float(np.sum(loss.spheres(fills))),
           "added_mass_kg": loss.added_mass_kg(layout), "modal_mass_kg": loss.modal_mass_kg(layout),
           "eta": summary[kind], "eta_lo": lo, "eta_hi": hi,
           "eta_band_mean": summary["band_mean"], "eta_band_worst": summary["worst_case"],
           "eta_band_best": summary["peak"], "worst_accel_g": summary["worst_accel_g"],
           "best_accel_g": summary["peak_accel_g"], "uncertainty": model.kind,
           "note": FLOOR_NOTE if band.low * np.abs(loss.phi).max() <= model.domain["accel_g"][0] else ""}
    if best is not None:
        row["n_starts"], row["n_converged"] = best.n_starts, best.n_converged
    forced = []
    for force in settings.modal_force_n:
        response = forced_response(loss, model.predict, layout, force, settings.damping_ratio)
        forced.append({"environment": env.name, "mode_m": mode.m, "mode_n": mode.n, "design": kind,
                       "layout": layout.name, "force_n": force, "freq_hz": response.freq_hz,
                       "accel_g": response.accel_g, "bare_accel_g": response.bare_accel_g,
                       "eta_particles": response.eta_particles, "eta_total": response.eta_total,
                       "n_solutions": response.n_solutions, "clipped_cells": response.clipped_cells})
    return row, None, forced


def _cells_frame(env, mode: Mode, kind: str, layout: Layout, loss: ModalLoss, centres: np.ndarray,
                 band: AccelBand) -> pd.DataFrame:
    """results/panel/layout.csv rows: each filled cell's position, fill and G over the band."""
    phi = loss.phi[layout.cells]
    return pd.DataFrame({
        "environment": env.name, "mode_m": mode.m, "mode_n": mode.n, "design": kind,
        "layout": layout.name, "cell": layout.cells,
        "x_mm": 1e3 * centres[layout.cells, 0], "y_mm": 1e3 * centres[layout.cells, 1],
        "phi": phi, "fill_pct": layout.fill_pct, "spheres": loss.spheres(layout.fill_pct),
        "accel_g_band_lo": band.low * np.abs(phi), "accel_g_band_hi": band.high * np.abs(phi)})
