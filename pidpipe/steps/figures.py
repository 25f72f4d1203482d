"""The figure stage's steps: the surrogate maps with their uncertainty, the optimisation's
convergence and the optimum's spread.
"""

from __future__ import annotations

import logging
from pathlib import Path

from pidpipe.design.optimisation_files import read_results_json

logger = logging.getLogger("pidpipe.campaign")


def plot_surrogate_maps(surrogate_path: str, freq_fill_png: str, freq_accel_png: str,
                        draws: int = 0, seed: int = 0) -> None:
    """The C_eq(f, r) and C_eq(f, G) maps of a saved surrogate over their uncertainty panels,
    each as PNG and PDF.

    Parameters
    ----------
    surrogate_path : path
    freq_fill_png, freq_accel_png : path
        The PNG files; the PDF goes next to each, with the same stem.
    draws, seed : int
        Bootstrap refits of the uncertainty panels (the optimum's: the same seed redraws the
        same tables); 0 draws, or a table without SEMs, leaves the panels empty and says why.
    """
    from pidpipe.design.bootstrap import has_sem, resampled_surrogates
    from pidpipe.design.surrogate import load_surrogate
    from pidpipe.figures.maps import plot_ceq_freq_accel, plot_ceq_freq_fill

    surrogate = load_surrogate(surrogate_path)
    refits, note = None, ""
    if draws < 2:
        note = "bootstrap off (optimisation.bootstrap.draws < 2)"
    elif not has_sem(surrogate):
        note = "the table has no SEM (ceq_coupon_sem_ns_m): no bootstrap"
    else:
        refits = list(resampled_surrogates(surrogate, draws, seed))
    if note:
        logger.warning("surrogate maps: %s", note)
    plot_ceq_freq_fill(surrogate, stem=Path(freq_fill_png).with_suffix(""), draws=refits, note=note)
    plot_ceq_freq_accel(surrogate, stem=Path(freq_accel_png).with_suffix(""), draws=refits, note=note)
    logger.info("surrogate maps: %s, %s (and PDF), uncertainty from %d refits", freq_fill_png,
                freq_accel_png, len(refits or []))


def plot_m_eff_maps(surrogate_path: str, table_path: str, freq_fill_png: str,
                    freq_accel_png: str) -> None:
    """The m_eff / bed mass maps, (f, r) and (f, G), of the saved m_eff surrogate over its
    predictive standard uncertainty, each as PNG and PDF.

    Parameters
    ----------
    surrogate_path : path
        ``results/surrogate_m_eff.json`` (:func:`pidpipe.steps.design.fit_m_eff_surrogate`).
    table_path : path
        The C_eq table it was fitted to: each fill's bed mass (``bed_mass_kg``).
    freq_fill_png, freq_accel_png : path
        The PNG files; the PDF goes next to each, with the same stem.
    """
    from pidpipe.design.ceq_table import read_ceq_table
    from pidpipe.design.surrogate import load_surrogate
    from pidpipe.figures.maps import bed_mass_of_fill, plot_m_eff_freq_accel, plot_m_eff_freq_fill

    surrogate = load_surrogate(surrogate_path)
    table = read_ceq_table(table_path)
    bed_mass = bed_mass_of_fill(table["fill_pct"], table["bed_mass_kg"])
    plot_m_eff_freq_fill(surrogate, bed_mass, stem=Path(freq_fill_png).with_suffix(""))
    plot_m_eff_freq_accel(surrogate, bed_mass, stem=Path(freq_accel_png).with_suffix(""))
    logger.info("m_eff maps: %s, %s (and PDF), %s", freq_fill_png, freq_accel_png,
                "uncertainty from the surrogate's predictive std" if surrogate.has_uncertainty
                else f"no uncertainty ({surrogate.method} has none)")


def plot_optimisation_convergence(results_json: str, png: str) -> None:
    """Objective against SLSQP iteration of every start, per environment, as PNG and PDF.

    Parameters
    ----------
    results_json : path
        Written by :func:`optimise_surrogate`.
    png : path
        The PNG file; the PDF goes next to it, with the same stem.
    """
    from pidpipe.figures.convergence import plot_convergence

    plot_convergence(read_results_json(results_json), stem=Path(png).with_suffix(""))
    logger.info("convergence figure: %s (and PDF)", png)


def plot_optimum_spread_figure(results_json: str, bootstrap_csv: str, png: str) -> None:
    """The bootstrap's designs and intervals per environment, as PNG and PDF.

    Parameters
    ----------
    results_json, bootstrap_csv : path
        Written by :func:`pidpipe.steps.design.optimise_surrogate`.
    png : path
        The PNG file; the PDF goes next to it, with the same stem.
    """
    import pandas as pd

    from pidpipe.figures.spread import plot_optimum_spread

    results = read_results_json(results_json)
    draws = pd.read_csv(bootstrap_csv) if Path(bootstrap_csv).stat().st_size > 1 else pd.DataFrame()
    note = "" if len(draws) else "no bootstrap (no SEMs in the table, or draws = 0)"
    plot_optimum_spread(results, draws, stem=Path(png).with_suffix(""), note=note)
    logger.info("optimum spread figure: %s (and PDF), %d draws", png, len(draws))


def plot_case_phase(record_path: str, png: str) -> None:
    """The phase-resolved figure of one case record (:mod:`pidpipe.figures.phase`), PNG and PDF.

    Parameters
    ----------
    record_path : path
        The case record (JSON) with its ``motion``.
    png : path
        The PNG file; the PDF goes next to it, with the same stem.
    """
    from pidpipe.design.records import read_record
    from pidpipe.figures.phase import plot_phase_profile

    plot_phase_profile(read_record(record_path), stem=Path(png).with_suffix(""))
    logger.info("phase-resolved figure: %s (and PDF)", png)
