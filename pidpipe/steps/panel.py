"""The modal stage's step (``snakemake --cores 2 panel``, ``pidpipe panel``): read, run, write.

:func:`panel_step` reads the config's panel and the coupon surrogate, runs
:func:`pidpipe.panel.study.run_panel_study` and writes results/panel/: ``modes.csv``,
``layout.csv``, ``designs.csv``, ``response.csv`` (each design at each modal force, solved to
consistency) and ``panel.png`` / ``.pdf``.
"""

from __future__ import annotations

import logging
from pathlib import Path

from pidpipe.files import write_atomic

logger = logging.getLogger("pidpipe.campaign")


def panel_study_from_config(config: dict, surrogate):
    """Run the modal stage of a validated config on a fitted surrogate."""
    from pidpipe.config.panel import PanelSettings
    from pidpipe.panel.study import run_panel_study
    from pidpipe.steps.design import environment_objects, search_settings

    settings = PanelSettings.from_config(config)
    return run_panel_study(settings, surrogate, environment_objects(config["environments"]),
                           search_settings(config["optimisation"]),
                           int(config["geometry"]["coupon_n_cells"]))


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


def panel_step(config: dict, surrogate_path: str, folder: str) -> None:
    """The rule's step: load the surrogate, run the modal stage, write results/panel/."""
    from pidpipe.design.surrogate import load_surrogate

    study = panel_study_from_config(config, load_surrogate(surrogate_path))
    for path in write_panel_study(study, folder):
        logger.info("wrote %s", path)
    logger.info("layout optimisation: %.1f CPU-s over every environment and mode", study.optimisation_s)
