"""The modal stage's step (``snakemake --cores 2 panel``, ``pidpipe panel``): read, run, write.

:func:`panel_step` reads the config's panel and the coupon surrogate, runs
:func:`pidpipe.panel.study.run_panel_study` and writes results/panel/: ``modes.csv``,
``layout.csv``, ``designs.csv``, ``response.csv`` (each design at each modal force, solved to
consistency) and ``panel.png`` / ``.pdf``. With ``results/surrogate_m_eff.json`` (a table with
m_eff) the modal mass takes the particles' effective mass from it
(:mod:`pidpipe.panel.mass`), else the bed's mass; designs.csv's ``modal_mass_source`` says which.
"""

from __future__ import annotations

import logging
from pathlib import Path

from pidpipe.files import write_atomic

logger = logging.getLogger("pidpipe.campaign")


def panel_study_from_config(config: dict, surrogate, m_eff_surrogate=None):
    """Run the modal stage of a validated config on a fitted surrogate (and, when given, the
    m_eff surrogate that puts the particles' effective mass in the modal mass)."""
    from pidpipe.config.panel import PanelSettings
    from pidpipe.panel.study import run_panel_study
    from pidpipe.steps.design import environment_objects, search_settings

    settings = PanelSettings.from_config(config)
    return run_panel_study(settings, surrogate, environment_objects(config["environments"]),
                           search_settings(config["optimisation"]),
                           int(config["geometry"]["coupon_n_cells"]),
                           m_eff_surrogate=m_eff_surrogate)


def panel_m_eff_surrogate(path, ceq_surrogate, loader=None):
    """The m_eff surrogate for the modal mass, or None with one line saying why.

    Parameters
    ----------
    path : path or None
        ``results/surrogate_m_eff.json``; None or a missing file: the modal mass takes the bed's
        mass times ``panel.effective_mass_fraction`` (logged).
    ceq_surrogate
        The C_eq surrogate the stage runs on: an m_eff surrogate fitted to another table is
        refused (:func:`pidpipe.panel.mass.check_m_eff_surrogate`).
    loader : callable, optional
        ``loader(path) -> surrogate``; default :func:`pidpipe.design.surrogate.load_surrogate`.
    """
    from pidpipe.panel.mass import check_m_eff_surrogate

    if path is None or not Path(path).is_file():
        logger.warning("panel: no m_eff surrogate%s: the modal mass takes the bed's mass x "
                       "panel.effective_mass_fraction", f" ({path})" if path else "")
        return None
    if loader is None:
        from pidpipe.design.surrogate import load_surrogate as loader
    m_eff = loader(path)
    check_m_eff_surrogate(m_eff, ceq_surrogate, str(path))
    logger.info("panel: the modal mass takes the particles' m_eff from %s", path)
    return m_eff


def write_panel_study(study, folder: str | Path) -> list[Path]:
    """Write the study's tables and figure into ``folder``; return the paths."""
    from pidpipe.figures.common import save_figure
    from pidpipe.figures.panel import plot_panel_layouts
    from pidpipe.panel.study import modes_frame

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    tables = {"modes.csv": modes_frame(study.modes), "layout.csv": study.layouts,
              "designs.csv": study.designs, "response.csv": study.responses}
    paths = []
    for name, frame in tables.items():
        path = folder / name
        write_atomic(path, lambda tmp, frame=frame: frame.to_csv(tmp, index=False))
        paths.append(path)
    settings = study.settings
    panels = []
    for entry in study.figure_layouts:
        mode, layout = entry["mode"], entry["layout"]
        xy = study.centres[layout.cells] * 1e3
        panels.append({"title": f"{entry['environment']}: mode ({mode.m}, {mode.n}) at "
                                f"{mode.freq_hz:.0f} Hz\noptimised band_mean layout, "
                                f"{layout.cells.size} filled cells",
                       "shape": lambda x, y, mode=mode: mode.shape(x * 1e-3, y * 1e-3),
                       "x_mm": xy[:, 0], "y_mm": xy[:, 1], "fill_pct": layout.fill_pct})
    figure = plot_panel_layouts(panels, settings.length_m * 1e3, settings.width_m * 1e3)
    paths += save_figure(figure, folder / "panel")
    return paths


def panel_step(config: dict, surrogate_path: str, folder: str,
               m_eff_surrogate_path: str | None = None) -> None:
    """The rule's step: load the surrogates, run the modal stage, write results/panel/.

    ``m_eff_surrogate_path``: ``results/surrogate_m_eff.json`` (:func:`panel_m_eff_surrogate`);
    None (a table without m_eff): the bed's mass.
    """
    from pidpipe.design.surrogate import load_surrogate

    surrogate = load_surrogate(surrogate_path)
    study = panel_study_from_config(config, surrogate,
                                    panel_m_eff_surrogate(m_eff_surrogate_path, surrogate))
    for path in write_panel_study(study, folder):
        logger.info("wrote %s", path)
    logger.info("layout optimisation: %.1f CPU-s over every environment and mode", study.optimisation_s)


def layout_of(layouts, environment: str, design: str, name: str):
    """One layout of results/panel/layout.csv: the lowest mode's of the environment's band.

    Returns
    -------
    mode : tuple of int
        (m, n).
    layout : pidpipe.panel.loss.Layout
    """
    import numpy as np

    from pidpipe.errors import ConfigError
    from pidpipe.panel.loss import Layout

    rows = layouts[(layouts.environment == environment) & (layouts.design == design)
                   & (layouts.layout == name)] if not layouts.empty else layouts
    if rows.empty:
        raise ConfigError(f"results/panel/layout.csv has no {name} {design} layout for environment "
                          f"{environment!r} (config key panel.check; rerun `snakemake panel`)")
    first = rows.iloc[0]
    mode = (int(first.mode_m), int(first.mode_n))
    rows = rows[(rows.mode_m == mode[0]) & (rows.mode_n == mode[1])]
    return mode, Layout(name, rows.cell.to_numpy(dtype=int), rows.fill_pct.to_numpy(dtype=float))


def mode_check_from_config(config: dict, surrogate, m_eff_surrogate, layouts, folder: str,
                           workers: int = 1):
    """The DEM check of a mode (config ``panel.check``; :mod:`pidpipe.panel.check`).

    Parameters
    ----------
    config : dict
        :func:`pidpipe.config.panel.panel_check_params` of the validated config.
    surrogate, m_eff_surrogate
        The C_eq surrogate and the m_eff one (or None: the bed's mass in the stage's model).
    layouts : DataFrame
        results/panel/layout.csv.
    folder : path
        Where the DEM cells' packings are poured and kept (reused).
    workers : int
        Pours and coupled runs at a time.

    Returns
    -------
    pidpipe.panel.check.ModeCheck
        Its ``meta`` also holds the environment, the force's origin, the modal mass's source and
        the stage's loss factor of the layout as designed at that force (``designed``).
    """
    import numpy as np

    from pidpipe.cell.packing import check_packing
    from pidpipe.cell.scene import CellScene
    from pidpipe.config.panel import PanelCheckSettings, PanelSettings
    from pidpipe.config.settings import PourSettings
    from pidpipe.dem.pouring import replicate_packings
    from pidpipe.panel.cells import cell_centres
    from pidpipe.panel.check import check_fill, check_mode, layout_groups, sweep_frequencies
    from pidpipe.panel.loss import Layout, ModalLoss
    from pidpipe.panel.plate import navier_mode
    from pidpipe.panel.response import design_force_n, forced_response
    from pidpipe.panel.study import effective_mass_model, sandwich_of
    from pidpipe.panel.uncertainty import UncertainCeq
    from pidpipe.steps.design import environment_objects

    settings, check = PanelSettings.from_config(config), PanelCheckSettings.from_config(config)
    env = environment_objects(config["environments"])[check.environment]
    (m, n), layout = layout_of(layouts, env.name, check.design, check.layout)
    mode = navier_mode(sandwich_of(settings), settings.length_m, settings.width_m, m, n)
    centres = cell_centres(settings.length_m, settings.width_m, settings.cell_inscribed_diameter_m)
    phi = mode.shape(centres[:, 0], centres[:, 1])
    model = UncertainCeq.from_surrogate(surrogate)
    mass, mass_source = effective_mass_model(settings, env, mode, None, m_eff_surrogate)
    common = (mode, phi, int(config["geometry"]["coupon_n_cells"]), settings.full_cell_spheres,
              settings.sphere_mass_kg, model.domain)
    loss = ModalLoss(*common, settings.effective_mass_fraction, mass)
    full = ModalLoss(*common, 1.0, None)
    pour = PourSettings.from_config(config)
    spheres, fill = check_fill(layout, pour.fill.spheres, settings.full_cell_spheres, model.domain)
    represented = Layout(layout.name, layout.cells, np.full(layout.cells.size, fill))
    groups = layout_groups(phi[layout.cells], check.groups)
    band_g = 0.5 * (env.accel_g[0] + env.accel_g[1])
    if check.force_n is None:
        force = design_force_n(loss, model.predict, represented, settings.damping_ratio, band_g)
        force_source = f"drives the panel model to {band_g:g} g at the antinode at resonance"
    else:
        force, force_source = check.force_n, "config key panel.check.force_n"
    k = groups.cells.size * check.cells_per_group
    logger.info("panel check: %s, mode (%d, %d) %.4g Hz, %s %s layout of %d cells in %d groups "
                "(|phi| %s) x %d DEM cells of %d spheres (fill %.4g %%); modal force %.4g N (%s); "
                "the panel model's modal mass takes the %s", env.name, m, n, mode.freq_hz,
                check.design, check.layout, layout.cells.size, groups.cells.size,
                ", ".join(f"{w:.3f}" for w in groups.weights), check.cells_per_group, spheres, fill,
                force, force_source, mass_source)
    packings, pour_cpu = replicate_packings(pour, 100.0 * spheres / pour.fill.full_cell_spheres, k,
                                            folder, workers)
    for index, packing in enumerate(packings):
        check_packing(packing, f"panel check cell {index}")
    freqs = sweep_frequencies(loss, full, represented, check.freq_points, check.freq_span_fraction)
    result = check_mode(CellScene.from_config(config), loss, full, model.predict, represented,
                        groups, check.cells_per_group, np.stack([p.centres() for p in packings]),
                        fill, force, settings.damping_ratio, freqs, check.transient_cycles,
                        check.measured_cycles, check.sem_block_cycles, workers, settings.seed,
                        predict_with_uncertainty=model.predict_with_uncertainty)
    designed = forced_response(loss, model.predict, layout, force, settings.damping_ratio)
    result.meta.update(
        environment=env.name, design=check.design, force_source=force_source,
        modal_mass_source=mass_source, packings={"pour_cpu_s": pour_cpu,
                                                 "seeds": [p.seed for p in packings]},
        designed={"freq_hz": designed.freq_hz, "accel_g": designed.accel_g,
                  "eta_particles": designed.eta_particles, "eta_total": designed.eta_total,
                  "n_solutions": designed.n_solutions, "clipped_cells": designed.clipped_cells})
    return result


def check_panel_mode(config: dict, surrogate_path: str, layout_path: str, curves_path: str,
                     summary_path: str, meta_path: str, folder: str, workers: int = 1,
                     m_eff_surrogate_path: str | None = None) -> None:
    """The rule's step (``snakemake --cores 2 panel_check``): load, check, log and write the
    curves (CSV), the summary (CSV) and the record (JSON)."""
    import json

    import pandas as pd

    from pidpipe.design.surrogate import load_surrogate
    from pidpipe.panel.check import summary_lines

    surrogate = load_surrogate(surrogate_path)
    m_eff = panel_m_eff_surrogate(m_eff_surrogate_path, surrogate)
    result = mode_check_from_config(config, surrogate, m_eff, pd.read_csv(layout_path), folder,
                                    workers)
    for line in summary_lines(result.summary):
        logger.info("panel check: %s", line)
    write_atomic(curves_path, lambda tmp: result.curves.to_csv(tmp, index=False))
    write_atomic(summary_path, lambda tmp: result.summary.to_csv(tmp, index=False))
    write_atomic(meta_path, lambda tmp: Path(tmp).write_text(json.dumps(result.meta, indent=2,
                                                                        default=float)))
