"""The host-coupled check's steps (``snakemake --cores 2 host``): the check itself and its figure.

:func:`check_host` reads the design and the surrogates (C_eq, and m_eff for model (c) when
``surrogate_m_eff.json`` lies next to ``surrogate.json``), pours the k representative packings at
the design's fill (LIGGGHTS, as the campaign pours; kept in ``folder`` and reused), runs
:func:`pidpipe.loop.host.host_check` and writes the curves, the summary and the run's
parameters; :func:`plot_host_figure` draws the curves.
"""

from __future__ import annotations

import json
import logging
from pathlib import Path

import numpy as np
import pandas as pd

from pidpipe.config.settings import HostSettings, PourSettings
from pidpipe.errors import ConfigError
from pidpipe.files import write_atomic
from pidpipe.steps.params import host_params  # noqa: F401  (the host rule's params)

logger = logging.getLogger("pidpipe.campaign")


def chosen_design(results: list, settings: HostSettings):
    """The optimisation result of the host's environment and design kind."""
    for result in results:
        if result.environment.name == settings.environment.name and result.kind == settings.design:
            return result
    raise ConfigError(f"config key host.design = {settings.design!r}: results/optimum.json has no "
                      f"{settings.design} design for environment {settings.environment.name!r}; "
                      "rerun `snakemake optimum` with this config")


def prepare_host(config: dict, surrogate_path: str, designs_path: str, folder: str,
                 workers: int = 1):
    """Everything the check runs on: the settings, the design's load, the surrogate and its
    draws, and the k representative packings (poured into ``folder``, or reused).

    Returns
    -------
    settings : HostSettings
    load : pidpipe.loop.host.HostLoad
    surrogate : pidpipe.design.surrogate.Surrogate
    draws : iterable of Surrogate
        Refitted to the redrawn C_eq table (empty without SEMs or with ``surrogate_draws`` 0).
    packings : ndarray, shape (k, n, 3)
        Sphere centres of the k cells, m.
    extra : dict
        ``packings`` (seeds, pile heights, pour CPU) and ``design`` for the run's record.
    """
    from pidpipe.cell.packing import check_packing
    from pidpipe.design.bootstrap import has_sem, resampled_surrogates
    from pidpipe.design.optimisation_files import read_results_json
    from pidpipe.design.surrogate import load_surrogate
    from pidpipe.dem.pouring import replicate_packings
    from pidpipe.loop.host import HostLoad
    from pidpipe.physics.contact import sphere_mass

    settings = HostSettings.from_config(config)
    result = chosen_design(read_results_json(designs_path), settings)
    design = result.design
    pour = PourSettings.from_config(config)
    n_spheres = pour.fill.spheres(design.fill_pct)
    if n_spheres < 1:
        raise ConfigError(f"the {settings.design} design of {settings.environment.name!r} fills "
                          f"{design.fill_pct:.3g} %, less than one sphere per cell")
    packings, pour_cpu = replicate_packings(pour, design.fill_pct, settings.cells, folder, workers)
    for index, packing in enumerate(packings):
        check_packing(packing, f"host cell {index}")
    particle = pour.materials.particle
    load = HostLoad(n_cells=int(design.n_cells), spheres_per_cell=n_spheres,
                    fill_pct=100.0 * n_spheres / pour.fill.full_cell_spheres,
                    sphere_mass_kg=sphere_mass(particle.radius_m, particle.density_kg_m3),
                    coupon_n_cells=settings.coupon_n_cells)
    surrogate = load_surrogate(surrogate_path)
    draws = []
    if settings.surrogate_draws and has_sem(surrogate):
        draws = resampled_surrogates(surrogate, settings.surrogate_draws, settings.seed)
    elif settings.surrogate_draws:
        logger.warning("host: the C_eq table has no SEMs: the dashpot model has no uncertainty")
    logger.info("host: %s design of %s: %d cells x %d spheres (fill %.4g %%, design %.4g %%; "
                "%d spheres against the budget's %d)", settings.design, settings.environment.name,
                load.n_cells, n_spheres, load.fill_pct, design.fill_pct, load.n_cells * n_spheres,
                result.budget.n_spheres)
    extra = {"packings": {"seeds": [p.seed for p in packings],
                          "pile_height_m": [p.pile_height_m for p in packings],
                          "pour_cpu_s": pour_cpu},
             "design": {"kind": settings.design, "budget_spheres": result.budget.n_spheres,
                        **vars(design)}}
    return settings, load, surrogate, draws, np.stack([p.centres() for p in packings]), extra


def load_m_eff_surrogate(surrogate_path: str, m_eff_path: str | None = None, loader=None):
    """The m_eff surrogate for model (c), or None (the reason logged) when there is none.

    Parameters
    ----------
    surrogate_path : path
        The C_eq surrogate (``results/surrogate.json``).
    m_eff_path : path, optional
        The m_eff surrogate; default :data:`pidpipe.design.damper.M_EFF_FILE` next to
        ``surrogate_path``.
    loader : callable, optional
        ``loader(path) -> surrogate``; default :func:`pidpipe.design.surrogate.load_surrogate`.
    """
    from pidpipe.design.damper import M_EFF_FILE

    path = Path(m_eff_path) if m_eff_path else Path(surrogate_path).with_name(M_EFF_FILE)
    if not path.is_file():
        logger.warning("host: no m_eff surrogate (%s): model (c), the host with the spheres' "
                       "effective mass, is left out", path)
        return None
    if loader is None:
        from pidpipe.design.surrogate import load_surrogate as loader
    return loader(path)


def check_host(config: dict, surrogate_path: str, designs_path: str, curves_path: str,
               summary_path: str, meta_path: str, folder: str, workers: int = 1,
               m_eff_surrogate_path: str | None = None) -> None:
    """Run the host-coupled check of one design and write its tables.

    Parameters
    ----------
    config : dict
        :func:`host_params` of the validated config.
    surrogate_path, designs_path : path
        ``results/surrogate.json`` and ``results/optimum.json``.
    curves_path, summary_path, meta_path : path
        The curves (CSV), the per-level summary (CSV) and the parameters and costs (JSON).
    folder : path
        Where the host's packings are poured and kept.
    workers : int
        LIGGGHTS pours and coupled runs at a time.
    m_eff_surrogate_path : path, optional
        The m_eff surrogate for model (c) (:func:`load_m_eff_surrogate`; absent: (c) left out).
    """
    from pidpipe.cell.scene import CellScene
    from pidpipe.loop.host import host_check

    settings, load, surrogate, draws, packings, extra = prepare_host(
        config, surrogate_path, designs_path, folder, workers)
    m_eff = load_m_eff_surrogate(surrogate_path, m_eff_surrogate_path)
    curves, summary, meta = host_check(settings, CellScene.from_config(config), load, surrogate,
                                       draws, packings, workers, m_eff_surrogate=m_eff)
    meta.update(extra, fidelity=dict(config["fidelity"]), engine=_engine())
    for line in summary_lines(summary):
        logger.info("host: %s", line)
    write_atomic(curves_path, lambda tmp: curves.to_csv(tmp, index=False))
    write_atomic(summary_path, lambda tmp: summary.to_csv(tmp, index=False))
    write_atomic(meta_path, lambda tmp: tmp.write_text(json.dumps(meta, indent=2, default=float)))


def _engine() -> dict:
    import numba

    from pidpipe.dem.compiled import KERNEL_NAME

    return {"solver": KERNEL_NAME, "version": f"numba {numba.__version__}"}


def summary_lines(summary: pd.DataFrame) -> list[str]:
    """One line per force level and model: the peak, and for the surrogate models the verdict."""
    lines = []
    for row in summary.itertuples():
        text = (f"F0 {row.force_n:g} N {row.model}: peak {row.peak_amplitude_m * 1e6:.4g} "
                f"+- {row.peak_amplitude_m_sd * 1e6:.2g} um at {row.peak_freq_hz:.4g} "
                f"+- {row.peak_freq_hz_sd:.2g} Hz (Gamma {row.peak_accel_g:.3g} g), loss factor "
                f"{row.peak_loss_factor:.4g} +- {row.peak_loss_factor_sd:.2g}")
        if row.model != "coupled":
            text += (f"; vs coupled: amplitude {row.amplitude_rel_diff:+.1%} "
                     f"+- {row.amplitude_rel_diff_sd:.1%}, peak {row.peak_shift_hz:+.3g} "
                     f"+- {row.peak_shift_sd_hz:.2g} Hz, loss factor {row.loss_factor_rel_diff:+.1%} "
                     f"+- {row.loss_factor_rel_diff_sd:.1%}: {'holds' if row.holds else 'fails'}")
            sigmas = getattr(row, "peak_shift_sigmas", float("nan"))
            if np.isfinite(sigmas):
                text += f" (peak {sigmas:.2g} sd from the coupled one)"
        if row.peak_at_edge:
            text += " (peak at the sweep's edge)"
        lines.append(text)
    return lines


def plot_host_figure(curves_path: str, png: str) -> None:
    """The amplitude-frequency and loss-factor curves of both models (:mod:`pidpipe.figures.host`)."""
    from pidpipe.figures.common import save_figure
    from pidpipe.figures.host import plot_host

    figure = plot_host(pd.read_csv(curves_path))
    save_figure(figure, Path(png).with_suffix(""))
