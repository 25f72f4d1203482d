"""The figure stage's steps: the surrogate maps and the optimisation's convergence figure.
"""

from __future__ import annotations

import logging
from pathlib import Path

from pidpipe.design.optimisation_files import read_results_json

logger = logging.getLogger("pidpipe.campaign")


def plot_surrogate_maps(surrogate_path: str, freq_fill_png: str, freq_accel_png: str) -> None:
    """The C_eq(f, r) and C_eq(f, G) maps of a saved surrogate, each as PNG and PDF.

    Parameters
    ----------
    surrogate_path : path
    freq_fill_png, freq_accel_png : path
        The PNG files; the PDF goes next to each, with the same stem.
    """
    from pidpipe.design.surrogate import load_surrogate
    from pidpipe.figures.maps import plot_ceq_freq_accel, plot_ceq_freq_fill

    surrogate = load_surrogate(surrogate_path)
    plot_ceq_freq_fill(surrogate, stem=Path(freq_fill_png).with_suffix(""))
    plot_ceq_freq_accel(surrogate, stem=Path(freq_accel_png).with_suffix(""))
    logger.info("surrogate maps: %s, %s (and PDF)", freq_fill_png, freq_accel_png)


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
