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
